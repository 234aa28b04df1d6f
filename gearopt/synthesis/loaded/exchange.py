"""The optimum's loaded TE objective confirmed between the NLP's positions (docs/loaded_synthesis.md
section 4, "Confirmed"): the loaded TE extremes of a design located on a fine grid and refined
between its positions by golden-section search (loaded TCA, outside the NLP), the objective they give,
and the positions an exchange adds to the NLP's grid (:class:`Exchange`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`).

The NLP's peak-to-peak is the largest minus the smallest loaded TE over its own positions only; an
optimum of it may move the extremes between those positions. :meth:`Exchange.confirm` finds the
extremes of the design's loaded TE over the whole mesh cycle; :meth:`LoadedMicroOptimizer.solve` adds
their positions to the NLP's grid and solves again from the optimum until the two objectives agree
(a semi-infinite program solved by exchange of its sample points; the NLP itself stays smooth)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..crowning import SynthesisError
from .constants import CONFIRM_ATOL, GOLDEN_STEPS
from .results import LoadedCheck

INV_PHI = (math.sqrt(5.0) - 1.0) / 2.0  #: golden section ratio 0.618...


@dataclass(frozen=True)
class Confirmation:
    """The loaded TE objective of a design over the whole mesh cycle (:meth:`Exchange.confirm`).

    Attributes
    ----------
    objective : float
        [arcsec] The weighted loaded TE peak-to-peak with every extreme refined between the fine grid's
        positions (the NLP's objective, continuous in the position).
    grid_objective : float
        [arcsec] The same on the fine grid alone.
    te_pp : (T, C) array
        [arcsec] Refined loaded TE peak-to-peak per torque and case.
    extremes : (T, C, 2) array
        [rad] Pinion angles of the largest and the smallest loaded TE per torque and case.
    te_extremes : (T, C, 2) array
        [arcsec] The largest and the smallest loaded TE per torque and case.
    n_grid : int
        Positions per mesh cycle of the fine grid.
    check : LoadedCheck
        The default loaded TCA of the design on the fine grid (its pressures and edge loads).
    """

    objective: float
    grid_objective: float
    te_pp: np.ndarray = field(repr=False)
    extremes: np.ndarray = field(repr=False)
    te_extremes: np.ndarray = field(repr=False)
    n_grid: int = 0
    check: LoadedCheck | None = field(default=None, repr=False)

    def positions(self, te_range: np.ndarray | None = None, tol: float = 0.0) -> np.ndarray:
        """The distinct extreme positions [rad], sorted; with ``te_range`` ((T, C, 2) [arcsec], the largest
        and smallest loaded TE over the NLP's positions), only those of the extremes the range misses by
        more than ``tol`` (T, C) [arcsec]."""
        if te_range is None:
            return np.unique(self.extremes.ravel())
        miss = np.stack([self.te_extremes[..., 0] - te_range[..., 0], te_range[..., 1] - self.te_extremes[..., 1]],
                        axis=-1) > np.asarray(tol)[..., None]
        return np.unique(self.extremes[miss])

    def to_dict(self) -> dict:
        from ...report import arr
        return {"objective_arcsec": self.objective, "grid_objective_arcsec": self.grid_objective,
                "te_pp_arcsec": arr(self.te_pp), "extremes_deg": arr(np.degrees(self.extremes)),
                "grid_positions": self.n_grid}


class Exchange:
    """The loaded TE extremes of a design between the positions of a grid, and the agreement test."""

    def confirm(self, theta: npt.ArrayLike, n: int | None = None, refine: bool = True,
                check: LoadedCheck | None = None) -> Confirmation:
        """The loaded TE objective of the design ``theta`` [mm] over the whole mesh cycle.

        Default loaded TCA (:meth:`check`) of every torque and case on ``n`` positions per mesh cycle
        (default ``n_confirm``); each (torque, case)'s largest and smallest loaded TE are then refined by
        golden-section search (``GOLDEN_STEPS`` steps, one loaded TCA per case and step at every
        torque's two points) over the two grid intervals around the grid's extreme, the interval
        shrinking to ``0.618^GOLDEN_STEPS`` of its width. The refined extreme is the best point the
        search evaluated, the grid's own included, so the confirmed peak-to-peak is never below the
        grid's. Only the loaded TE peak-to-peak objective (not ``harmonics``) is confirmed.

        ``refine=False``: the grid's extremes only (no search; what the loop needs to find the grid's
        pressures before its last pass); ``check``: the design's loaded TCA on the grid of ``n``
        positions already computed (:meth:`check`), reused."""
        theta = np.asarray(theta, float)
        n = self.n_confirm if n is None else int(n)
        grid = self.ltca.mesh_cycle(n)
        chk = self.check(theta, grid) if check is None else check
        half = math.pi / self.pair.pinion.z
        h = 2.0 * half / n
        T, C = self.torques.size, len(self.cases)
        pp = np.zeros((T, C))
        ext = np.zeros((T, C, 2))
        val = np.zeros((T, C, 2))
        p1, p2 = self.params(theta)
        for c, (sw, mis) in enumerate(zip(chk.sweeps, self.cases)):
            te = np.stack([r.te_loaded_arcsec for r in sw.results])  # (T, n)
            # per torque, the largest (sign +1) and the smallest (-1) loaded TE: maximise sign * te
            sign = np.tile([1.0, -1.0], T)
            rows = np.repeat(np.arange(T), 2)
            k = np.array([int(np.nanargmax(s * te[t])) for t, s in zip(rows, sign)])
            best_x = grid[k].copy()
            best_f = sign * te[rows, k]
            a, b = grid[k] - h, grid[k] + h
            x1, x2 = b - INV_PHI * (b - a), a + INV_PHI * (b - a)
            if refine:
                f1 = self._te_at(x1, rows, sign, p1, p2, mis)
                f2 = self._te_at(x2, rows, sign, p1, p2, mis)
            else:  # the grid's extremes: no point evaluated beside them
                f1 = f2 = np.full_like(best_f, -np.inf)
            for _ in range(GOLDEN_STEPS if refine else 0):
                for x, f in ((x1, f1), (x2, f2)):
                    up = f > best_f
                    best_x, best_f = np.where(up, x, best_x), np.where(up, f, best_f)
                left = f1 >= f2  # the maximum lies in [a, x2]
                a, b = np.where(left, a, x1), np.where(left, x2, b)
                nx1, nx2 = b - INV_PHI * (b - a), a + INV_PHI * (b - a)
                new = np.where(left, nx1, nx2)
                fn = self._te_at(new, rows, sign, p1, p2, mis)
                x1, f1, x2, f2 = (np.where(left, nx1, x2), np.where(left, fn, f2),
                                  np.where(left, x1, nx2), np.where(left, f1, fn))
            for x, f in ((x1, f1), (x2, f2)):
                up = f > best_f
                best_x, best_f = np.where(up, x, best_x), np.where(up, f, best_f)
            hi, lo = best_f[0::2], -best_f[1::2]
            pp[:, c] = hi - lo
            val[:, c, 0], val[:, c, 1] = hi, lo
            ext[:, c, 0], ext[:, c, 1] = self._wrap(best_x[0::2]), self._wrap(best_x[1::2])
        obj = float(np.sum(self.weights * pp))
        return Confirmation(objective=obj, grid_objective=chk.objective, te_pp=pp, extremes=ext, te_extremes=val,
                            n_grid=n, check=chk)

    def _wrap(self, phi: np.ndarray) -> np.ndarray:
        """Pinion angles [rad] brought into the mesh cycle ``[-pi/z1, pi/z1)`` (the loaded TE is periodic
        with it)."""
        half = math.pi / self.pair.pinion.z
        return (np.asarray(phi, float) + half) % (2.0 * half) - half

    def _te_at(self, x, rows, sign, p1, p2, mis) -> np.ndarray:
        """``sign * loaded TE`` [arcsec] at the pinion angles ``x`` [rad], each at its torque ``rows``: one
        loaded TCA of the case at every torque over the distinct angles."""
        u, inv = np.unique(self._wrap(x), return_inverse=True)
        sw = self.ltca.solve(self.torques, phi1=u, p1=p1, p2=p2, mis=mis)
        te = np.stack([r.te_loaded_arcsec for r in sw.results])  # (T, len(u))
        f = sign * te[rows, inv]
        return np.where(np.isfinite(f), f, -np.inf)

    def _exchanged(self, conf: Confirmation, chk: LoadedCheck) -> np.ndarray:
        """The extremes' positions [rad] that join the NLP's grid: those of each (torque, case) of weight > 0
        whose loaded TE the NLP's positions (``chk``: the loaded TCA there) miss. (Only those missed by more
        than a quarter of ``confirm_tol`` of the peak-to-peak, one or two positions an exchange, took 4
        exchanges without agreeing on the tiny problem of tests/test_loaded_exchange.py, and 529 instead of
        429 IPOPT iterations on problems/microgeometry_te_target.toml.)"""
        T, C = self.torques.size, len(self.cases)
        rng = np.zeros((T, C, 2))
        for c, sw in enumerate(chk.sweeps):
            for t, r in enumerate(sw.results):
                rng[t, c] = np.nanmax(r.te_loaded_arcsec), np.nanmin(r.te_loaded_arcsec)
        tol = np.where(self.weights > 0, 0.0, np.inf)
        return conf.positions(rng, tol)

    def _agrees(self, promised: float, conf: Confirmation) -> bool:
        """Whether the NLP's objective ``promised`` [arcsec] and the confirmed one agree within
        ``confirm_tol`` of the confirmed (at least ``CONFIRM_ATOL``)."""
        return abs(conf.objective - promised) <= max(self.confirm_tol * abs(conf.objective), CONFIRM_ATOL)

    def _disagrees(self, promised: float, conf: Confirmation, exchanges: int):
        """``SynthesisError`` (param ``max_exchanges``) where the objectives still disagree after
        ``exchanges`` exchanges."""
        raise SynthesisError(
            f"loaded micro-geometry: the NLP's objective {promised:.4f} arcsec on its {self.phi1.size} positions per "
            f"cycle is not confirmed between them: the loaded TE extremes of the optimum (refined on "
            f"{conf.n_grid} positions) give {conf.objective:.4f} arcsec ({conf.objective - promised:+.4f}, more than "
            f"confirm_tol = {100 * self.confirm_tol:g} %) after {exchanges} exchange(s) of the extremes' positions; "
            "raise max_exchanges, confirm_tol or n_positions.", param="max_exchanges", value=exchanges)
