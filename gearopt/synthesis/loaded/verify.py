"""Verification of a design by loaded TCA (exact slices of the modified flanks, the QP contact
solver, nothing of the NLP): the duty cycle's loaded TE, pressure and edge loads, the unloaded-TE
target's misfit, the merit the trust-region loop compares, and the errors a failed design raises
(:class:`Verification`, a part of :class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import math
import re

import numpy as np
import numpy.typing as npt

from ...ltca.engine import LoadedSweep
from ...ltca.slices import SliceSet

from ...units import RAD_TO_ARCSEC
from ..crowning import SynthesisError
from .constants import EDGE_TOL, G_REF, MU, P_VERIFY_TOL, RHO, SLACK_TOL, TE0_EPS
from .edges import edge_mask, edge_weight, edge_where, loaded_gaps
from .problem import case_text
from .results import LoadedCheck


class Verification:
    """Loaded TCA of designs over the duty cycle, the unloaded-TE target's misfit, the merit and the
    checks of a final design."""

    # -- loaded TCA of one design (the verification) ----------------------------------------------
    def check(self, theta: npt.ArrayLike, phi1: npt.ArrayLike | None = None,
              known: dict[int, LoadedSweep] | None = None) -> LoadedCheck:
        """Independent loaded TCA of the design ``theta`` [mm] at every torque and case (exact slices of
        the modified flanks, :class:`~gearopt.ltca.engine.LTCA`'s QP contact solver) at the positions
        ``phi1`` [rad] (default: the NLP's); ``known``: {case index: its sweep of this design at these
        positions, already solved}."""
        p1, p2 = self.params(np.asarray(theta, float))
        phi1 = self.phi1 if phi1 is None else phi1
        known = known or {}
        return self._check_of([known[c] if c in known else self.ltca.solve(self.torques, phi1=phi1, p1=p1, p2=p2, mis=mis)
                               for c, mis in enumerate(self.cases)])

    def _check_of(self, sweeps) -> LoadedCheck:
        T, C = self.torques.size, len(self.cases)
        pp, pm, es, eg, el = (np.zeros((T, C)) for _ in range(5))
        H = 0 if self.harmonics is None else self.harmonics.size
        hm = np.zeros((T, C, H))
        for c, sw in enumerate(sweeps):
            S = sw.slices
            R = harmonic_rows(S.phi1, self.pair.pinion.z, H) if H else None
            ends = edge_mask(S, self.pair)
            w_edge = edge_weight(S, self.pair)  # (of the slices: the same at every torque)
            for t, r in enumerate(sw.results):
                pp[t, c] = r.peak_to_peak_arcsec
                if H:
                    ab = (R @ r.te_loaded_arcsec).reshape(H, 2)
                    hm[t, c] = np.hypot(ab[:, 0], ab[:, 1])
                pm[t, c] = r.p_max
                es[t, c] = float(np.max(np.sum(np.where(ends, r.load, 0.0), axis=(0, 2)) / r.W))
                el[t, c] = float(np.max(w_edge * r.load) / r.W)
                gap = loaded_gaps(sw, r)
                eg[t, c] = float(np.min(np.where(ends & S.active, gap, np.inf)))
        obj = float(np.sum(self.weights * pp)) if not H else float(np.sum(self.weights[..., None] * hm * self.harmonics))
        rms, term = None, 0.0
        if self.te_level is not None:
            rms = np.array([self.te0_misfit(sw.slices, c)[0] for c, sw in enumerate(sweeps)])
            term = self._te0_term(rms)
        return LoadedCheck(te_pp=pp, p_max=pm, edge_share=es, edge_gap=eg, edge_load=el, objective=obj,
                           sweeps=tuple(sweeps), harmonics=hm if H else None, te0_rms=rms, te0_term=term)

    # -- the unloaded-TE target ------------------------------------------------------------------
    def _te0_pairs(self, S) -> tuple[np.ndarray, np.ndarray]:
        """Per position of the slice set ``S``: the index into ``S.pairs`` of the pair whose own angle
        ``phi1 - 2 pi k / z1`` lies in [-pi/z1, pi/z1) (-1: that pair is not among ``S.pairs``), and that
        angle over pi/z1 (in [-1, 1)): Litvin's one pair over one mesh cycle centred on it."""
        half = math.pi / self.pair.pinion.z
        phi1 = np.asarray(S.phi1, float)
        k = np.floor((phi1 + half) / (2.0 * half) + 1e-9).astype(int)
        pairs = [int(v) for v in S.pairs]
        return np.array([pairs.index(v) if v in pairs else -1 for v in k], int), (phi1 - 2.0 * half * k) / half

    def te0_misfit(self, S: SliceSet, case: int = 0) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """The unloaded TE of the slice set ``S`` (exact slices of one case) against the target parabola.

        At every position the pair centred there (:meth:`_te0_pairs`) touches where its slices' TE is
        largest (their smallest separation); that TE [arcsec] is fitted by least squares with
        ``c0 + c1 psi - te_level psi^2`` (``psi``: the pair's angle over pi/z1, c0 and c1 free).

        Returns
        -------
        rms : float
            RMS misfit [arcsec].
        psi, te : (n,) arrays
            The positions' pair angles over pi/z1 and the unloaded TE [arcsec] (positions where the
            pair has no active slice left out).
        coef : (2,) c0, c1 [arcsec].
        """
        idx, psi = self._te0_pairs(S)
        te = np.full(psi.size, np.nan)
        for n, i in enumerate(idx):
            if i >= 0 and S.active[i, n].any():
                te[n] = np.max(S.te[i, n][S.active[i, n]]) * RAD_TO_ARCSEC
        ok = np.isfinite(te)
        self._te0_enough(int(ok.sum()), psi.size, case)
        psi, te = psi[ok], te[ok]
        rms, coef = parabola_fit(psi, te, self.te_level * RAD_TO_ARCSEC)
        return rms, psi, te, coef

    def _te0_enough(self, n: int, N: int, case: int):
        if n < 4:
            raise SynthesisError(
                f"loaded micro-geometry: the unloaded-TE target needs the pair centred on each position in contact, "
                f"but in case {case} ({case_text(self.cases[case])}) it touches at only {n} of the {N} positions "
                "of the mesh cycle; raise n_positions, or drop te_level.", param="te_level", value=n)

    def _te0_term(self, rms) -> float:
        Wc = self.weights.sum(axis=0)
        return float(self.te_weight * np.sum(Wc * np.sqrt(np.asarray(rms) ** 2 + TE0_EPS**2)))

    def _merit(self, chk: LoadedCheck, rho: float = RHO) -> float:
        """The NLP's objective for an exact loaded TCA: weighted TE peak-to-peak plus the penalised
        constraint violations (the slacks the NLP would need)."""
        pen = 0.0
        if self.p_limit is not None:
            pen += float(np.sum(self._mult * np.maximum(chk.p_max**2 / self.p_limit**2 - 1.0, 0.0)))
        if self.edge_margin is not None:
            pen += float(np.sum(self._mult * np.maximum(chk.edge_load - MU * G_REF / self.edge_margin, 0.0)))
        return chk.objective + chk.te0_term + rho * self._w_mean * pen

    def _violated_positions(self, chk: LoadedCheck, phi1, edges: bool = True) -> np.ndarray:
        """Positions of ``phi1`` where the exact loaded TCA ``chk`` loads an edge (a weighted slice load
        share above ``EDGE_TOL``; only with ``edges``) or exceeds the pressure limit, at any torque and case."""
        bad = np.zeros(phi1.size, bool)
        for sw in chk.sweeps:
            w = edge_weight(sw.slices, self.pair)
            for r in sw.results:
                if self.edge_margin is not None and edges:
                    bad |= np.max(w * r.load, axis=(0, 2)) / r.W > EDGE_TOL
                if self.p_limit is not None:
                    bad |= np.max(r.p0_flank, axis=(0, 2)) > self.p_limit * (1 + SLACK_TOL)
        return np.asarray(phi1)[bad]

    def _raise_if_infeasible(self, pred, chk: LoadedCheck | None = None, theta: np.ndarray | None = None):
        """``SynthesisError`` where the final design's NLP (``pred``, :meth:`_predicted`) still needs a
        pressure or edge slack: the loop (a local method, its penalty at its largest weight) found no
        design meeting the limit. For an edge the message names the edge (``chk``: the exact loaded
        TCA of the design) and says what keeps the loop from opening it: where the relief that would
        is free and inside its bounds (``theta`` [mm], the design) it is not the bounds, and where the
        peak flank pressure there is at ``p_limit`` the two limits trade against each other."""
        for kind, what, tol in (("slack_p", "p_max", SLACK_TOL), ("slack_e", "edge", EDGE_TOL)):
            s = pred[kind]
            if np.max(s) > tol:
                t, c = np.unravel_index(int(np.argmax(s)), s.shape)
                if what == "p_max":
                    val = pred["p_max"][t, c]
                    raise SynthesisError(
                        f"loaded micro-geometry: the pressure limit p_limit = {self.p_limit:g} MPa cannot be met "
                        f"within the bounds of {list(self.free)}: at {self.torques[t]:g} N m, case {c} "
                        f"({case_text(self.cases[c])}) the lowest peak pressure reached is {val:.1f} MPa. Raise p_limit, widen "
                        "the bounds or free more modifications.", param="p_limit", value=val)
                where, hint = "a tip edge or face end", "Free a relief or widen its bounds"
                if chk is not None:
                    where, hint = edge_where(chk.sweeps[c], t, self.pair)
                raise SynthesisError(
                    f"loaded micro-geometry: the optimiser found no design within the bounds of {list(self.free)} that keeps every tip edge "
                    f"and face end {self.edge_margin * 1e3:g} um open at {self.torques[t]:g} N m, case {c} "
                    f"({case_text(self.cases[c])}): {where} still carries {100 * s[t, c]:.3g} % of the "
                    f"normal load. {self._edge_remedy(hint, pred, chk, theta)}", param="edge_margin",
                    value=float(s[t, c]))

    def _edge_remedy(self, hint: str, pred: dict, chk: LoadedCheck | None, theta: np.ndarray | None) -> str:
        """What to change where an edge stays loaded (:meth:`_raise_if_infeasible`): ``hint`` (the relief
        that opens the edge, :func:`edge_where`) unless that relief is free and inside its bounds at
        ``theta``; and where the peak flank pressure of the design (``chk``, else ``pred``) is at
        ``p_limit`` (within ``10 SLACK_TOL`` of ``p_limit^2``), that the pressure limit is what the edge
        trades against."""
        free_inside = None
        m = re.search(r"\((C_\w+)\)", hint)
        name = f"pinion.{m.group(1)}" if m else None
        if theta is not None and name in self.free:
            i = self.free.index(name)
            if self.lo[i] + 1e-7 < theta[i] < self.hi[i] - 1e-7:
                free_inside = (f"The {name} that would open it is free and inside its bounds ({theta[i] * 1e3:.2f} um "
                               f"in {self.lo[i] * 1e3:g} ... {self.hi[i] * 1e3:g} um)")
        binding = None
        if self.p_limit is not None:
            pm = float(np.max(chk.p_max if chk is not None else pred["p_max"]))
            if pm**2 >= self.p_limit**2 * (1.0 - 10 * SLACK_TOL):
                binding = (f"the peak flank pressure of this design is {pm:.1f} MPa, at p_limit = {self.p_limit:g} MPa: "
                           "the pressure limit and the open edges trade against each other here, and the loop (a local "
                           "method) found no design meeting both")
        if free_inside and binding:
            return f"{free_inside}; {binding}. Raise p_limit or lower edge_margin."
        if binding:
            return f"{binding[0].upper()}{binding[1:]}. {hint}, raise p_limit or lower edge_margin."
        if free_inside:
            return f"{free_inside}. Free another modification, or lower edge_margin."
        return f"{hint}, or lower edge_margin."

    def _raise_if_verification_fails(self, *checks: LoadedCheck):
        """``SynthesisError`` where the default loaded TCA of the optimum (``checks``: on the NLP's grid and
        on the verification grid) puts the peak flank pressure more than ``P_VERIFY_TOL`` above
        ``p_limit``, or more than ``EDGE_TOL`` of the load on an edge slice, at any position, torque and
        case: a limit is never silently violated."""
        for chk in checks:
            for c, sw in enumerate(chk.sweeps):
                w = edge_weight(sw.slices, self.pair)
                for t, r in enumerate(sw.results):
                    at = f"{self.torques[t]:g} N m, case {c} ({case_text(self.cases[c])})"
                    if self.p_limit is not None:
                        p = np.max(r.p0_flank, axis=(0, 2))
                        n = int(np.argmax(p))
                        if p[n] > self.p_limit * (1.0 + P_VERIFY_TOL):
                            raise SynthesisError(
                                f"loaded micro-geometry: at the optimum the loaded TCA gives a peak flank pressure of "
                                f"{p[n]:.1f} MPa at {at}, phi1 = {np.degrees(sw.slices.phi1[n]):.4g} deg, above "
                                f"p_limit = {self.p_limit:g} MPa (+{100 * P_VERIFY_TOL:g} %); raise n_positions or "
                                "p_limit.", param="p_limit", value=float(p[n]))
                    if self.edge_margin is not None:
                        e = np.max(w * r.load, axis=(0, 2)) / r.W
                        n = int(np.argmax(e))
                        if e[n] > EDGE_TOL:
                            raise SynthesisError(
                                f"loaded micro-geometry: at the optimum the loaded TCA puts {100 * e[n]:.3g} % of the "
                                f"normal load on an edge slice at {at}, phi1 = {np.degrees(sw.slices.phi1[n]):.4g} deg "
                                f"(at most {100 * EDGE_TOL:g} %); raise n_positions or lower edge_margin.",
                                param="edge_margin", value=float(e[n]))

    def _binding(self, theta, pred, ver) -> tuple:
        out = []
        for n, t, a, b in zip(self.free, theta, self.lo, self.hi):
            if abs(t - a) <= 1e-7:
                out.append(f"{n} at its lower bound")
            elif abs(t - b) <= 1e-7:
                out.append(f"{n} at its upper bound")
        if self.p_limit is not None and np.max(pred["p_max"]) >= self.p_limit * (1 - 1e-4):
            out.append("p_max")
        if self.edge_margin is not None and np.min(ver.edge_gap) <= self.edge_margin * (1 + 1e-3):
            out.append("edge")
        return tuple(out)


def harmonic_rows(phi1: npt.ArrayLike, z1: int, H: int) -> np.ndarray:
    """(2H, N) least-squares map of a TE sampled at the pinion angles ``phi1`` [rad] (one mesh cycle or
    more) to the coefficients (a_1, b_1, ..., a_H, b_H) of ``te ~ c0 + sum_h a_h cos(h z1 phi1) + b_h
    sin(h z1 phi1)``; on a uniform grid over whole cycles this is the DFT."""
    phi1 = np.asarray(phi1, float)
    cols = [np.ones_like(phi1)]
    for h in range(1, H + 1):
        cols += [np.cos(h * z1 * phi1), np.sin(h * z1 * phi1)]
    return np.linalg.pinv(np.stack(cols, axis=1))[1:]


def parabola_fit(psi: npt.ArrayLike, te: npt.ArrayLike, level: float) -> tuple[float, np.ndarray]:
    """RMS misfit [arcsec] of ``te`` [arcsec] at ``psi`` to ``c0 + c1 psi - level psi^2`` (least squares
    in c0, c1) and (c0, c1)."""
    V = np.stack([np.ones_like(psi), psi], axis=1)
    rhs = te + level * psi**2
    coef = np.linalg.lstsq(V, rhs, rcond=None)[0]
    return float(np.sqrt(np.mean((rhs - V @ coef) ** 2))), coef
