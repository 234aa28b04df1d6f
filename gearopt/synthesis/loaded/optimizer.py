"""The loaded micro-geometry optimiser (docs/loaded_synthesis.md): :class:`LoadedMicroOptimizer`, its
parts joined (each concept in its own module of this package) and :meth:`~LoadedMicroOptimizer.solve`,
the trust-region loop on a grid of positions refined by the verification."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from ..crowning import SynthesisError
from .constants import MAX_REFINE, RHO
from .exchange import Exchange
from .linearise import Lineariser
from .mirror import MirrorReduction
from .nlp import NLPBuilder
from .pareto import ParetoSweep
from .problem import LoadedProblem
from .results import MicroDesign
from .sensitivity import Sensitivities
from .solution import NLPSolution
from .trust_region import TrustRegion
from .verify import Verification


class LoadedMicroOptimizer(LoadedProblem, MirrorReduction, Verification, Exchange, Lineariser, NLPBuilder,
                           NLPSolution, TrustRegion, ParetoSweep, Sensitivities):
    """Choose flank modifications that minimise the loaded TE over a duty cycle (the package docstring,
    :mod:`gearopt.synthesis.loaded`).

    Parameters
    ----------
    pair : GearPair
        The drive; each member's :class:`Microgeometry` (``Gear.modifications``) is the start
        design, and gives the relief starts (``d_Ca``, ``d_Cf``, ``b_I``...) of any free relief.
    free : dict
        ``{"pinion.C_alpha": (lo, hi), ...}``: the free amounts with their bounds [mm]. Names are
        ``<member>.<amount>`` with an amount of ``Microgeometry.amount_names()``; a relief amount
        needs its start in the member's modifications. Litvin's settings ``<member>.a_c`` (parabolic
        rack-cutter profile) and ``<member>.a_pl`` (plunging: lead crowning) may be free too, bounds
        in 1/mm (0 ... 0.05 and 0 ... 0.02); the start is the member's ``rack.a_c`` / ``a_pl``.
    torques : sequence of float
        Pinion torques of the duty cycle [N m], strictly increasing.
    cases : sequence of Misalignment, optional
        Misalignment cases (default: the aligned drive).
    weights : array (T, C), optional
        Weight of each (torque, case) in the objective (default: all 1).
    settings : gearopt.settings.LoadedMicroSettings, optional
        The options below (``p_limit`` ... ``te_weight``, but ``material`` and ``jit``) as one object;
        keyword arguments replace its fields. Their defaults and valid ranges are declared there only.
    p_limit : float, optional
        Peak Hertz pressure limit of the flank slices [MPa] at every torque and case (None: none).
    edge_margin : float or None
        Smallest gap [mm] of every tip-edge and face-end slice under load (default 5e-4 mm; None:
        edge loading allowed).
    n_positions : int
        Positions per mesh cycle in the NLP (default 32).
    n_verify : int
        Positions per mesh cycle of the before/after loaded TCA (default 64).
    n_slices, material, side
        As :class:`gearopt.ltca.engine.LTCA`.
    jit : bool or "auto"
        Solve the slices as compiled C (:mod:`gearopt.compiled`); "auto" (default): whenever a C
        compiler is present.
    harmonics : sequence of float, optional
        Weights of the loaded TE's first mesh harmonics: the objective is then
        ``sum_(t,c) w_tc sum_h harmonics[h] A_h`` with ``A_h`` [arcsec] the amplitude of harmonic h + 1
        (least squares on the NLP's positions) instead of the peak-to-peak. ``2 len + 1 <= n_positions``.
    te_level : float, optional
        The unloaded drive's predesigned parabolic TE level [rad] (Litvin's target of
        :class:`gearopt.synthesis.crowning.CrowningOptimizer`: the parabola's drop from its apex over
        half a mesh cycle, ``A = te_level / (pi/z1)^2``) as a second term of the objective:
        ``te_weight * sum_c W_c sqrt(rms_c^2 + eps^2)``, with ``rms_c`` [arcsec] the RMS misfit of case
        c's unloaded TE over the NLP's positions to ``c0 + c1 phi - A phi^2`` (c0, c1 free per case,
        so a misalignment's line is absorbed) and ``W_c`` the case's weight summed over the torques.
        0 < te_level < 600 arcsec (default None: no such term).
    te_weight : float
        Weight of that term (default 1: an arcsec of a case's RMS misfit counts as much as an arcsec
        of its loaded TE objective at every torque); 0 < te_weight <= 1000.

    Call :meth:`solve` (``progress``: a callable taking one line of text per trust-region round).
    """

    def solve(self, progress: Callable[[str], None] | None = None, start: npt.ArrayLike | None = None,
              grid: npt.ArrayLike | None = None) -> MicroDesign:
        """Optimise and verify (docs/loaded_synthesis.md); ``start``: the first design [mm] (default
        the pair's own, which stays the "before" design); ``grid``: the NLP's first positions [rad]
        (default ``n_positions`` over the mesh cycle).

        The trust-region loop (:meth:`_trust_region`) optimises on the NLP's grid of positions. The
        optimum is then checked by the exact loaded TCA on the verification grid (``n_verify``
        positions) and on the confirmation grid (``n_confirm``, :meth:`confirm`); where the first shows
        edge loading or either a pressure above the limit between the NLP's positions, those positions
        join the NLP's grid and the loop goes on from the optimum (at most ``MAX_REFINE`` times). Then,
        with ``exchange`` and the peak-to-peak objective, where the NLP's objective (the promised one)
        and the confirmed one (the loaded TE extremes over the whole cycle) differ by more than
        ``confirm_tol``, the extremes' positions join the NLP's grid and the loop goes on from the
        optimum (at most ``max_exchanges`` times, then ``SynthesisError``)."""
        t_start = time.perf_counter()
        theta = self.theta0.copy() if start is None else np.clip(np.asarray(start, float), self.lo, self.hi)
        rounds, iters = [], 0
        fine = self.ltca.mesh_cycle(self.n_verify)
        self.phi1 = self.ltca.mesh_cycle(self.n_positions) if grid is None else np.sort(np.asarray(grid, float))
        # mirror-image cases are solved once in the loop (their loaded TCA is the same); the results
        # below are the full duty cycle's, every case solved
        red = self._reduced()
        classes = self.mirror_classes() if red is not self else [[c] for c in range(len(self.cases))]
        of = np.zeros(len(self.cases), int)
        for i, k in enumerate(classes):
            of[k] = i
        rho, last = RHO, None
        refine = exchanges = 0
        conf = None
        while True:
            red.phi1 = self.phi1
            # (a refinement goes on from the optimum with the penalty weight the last pass needed, its
            # IPOPT from the last pass's multipliers)
            theta, cur, pred, it, status, rho, stop = red._trust_region(theta, rounds, progress, rho, prev=last)
            last = red.last_solve
            iters += it
            after = self.check(theta, fine)
            # the design on the confirmation grid: its loaded TE extremes between the positions (module
            # exchange), and its peak pressures there
            # (the extremes refined between the grid's positions only where no position joins the grid:
            # the pass's last; and only for the peak-to-peak objective, the one confirmed)
            conf = red.confirm(theta, refine=False)
            add = self._violated_positions(after, fine)
            if conf is not None:
                add = np.union1d(add, red._violated_positions(conf.check, self.ltca.mesh_cycle(conf.n_grid),
                                                              edges=False))
            add = self._new_positions(add)
            if not add.size and conf is not None and self.harmonics is None:
                conf = red.confirm(theta, check=conf.check)
            if add.size:
                if refine == MAX_REFINE:
                    raise SynthesisError(
                        f"loaded micro-geometry: the optimum on {self.phi1.size} positions per cycle still loads an "
                        f"edge or exceeds the pressure limit at {add.size} of the verification ({self.n_verify}) and "
                        f"confirmation ({self.n_confirm}) positions after {MAX_REFINE} refinements; raise n_positions.",
                        param="n_positions", value=self.phi1.size)
                refine += 1
                what = "load an edge or exceed the pressure limit"
            elif conf is not None and self.exchange and self.harmonics is None:
                # the NLP's objective confirmed between its positions: where the design's loaded TE extremes
                # over the mesh cycle give another peak-to-peak, their positions join the NLP's grid and the
                # loop goes on from the optimum
                if self._agrees(pred["objective"], conf):
                    break
                add = self._new_positions(red._exchanged(conf, cur.check))
                if exchanges == self.max_exchanges or not add.size:
                    self._disagrees(pred["objective"], conf, exchanges)
                exchanges += 1
                what = (f"are loaded TE extremes (objective {pred['objective']:.4f} arcsec on the NLP's positions, "
                        f"{conf.objective:.4f} between them)")
            else:
                break
            self.phi1 = np.sort(np.concatenate([self.phi1, add]))
            if progress:
                progress(f"loaded micro-geometry: {add.size} positions between the NLP's {what}; the NLP's grid "
                         f"grows to {self.phi1.size}")
        ver = cur.check  # the exact loaded TCA of the final design (LTCA.solve on its own slices)
        if red is not self:  # every case, and the NLP's prediction of each mirror image by its twin's
            # (the loop's own loaded TCA of the final design is that of one case per class: the others
            # are solved here)
            ver = self.check(theta, known={k[0]: sw for k, sw in zip(classes, ver.sweeps)})
            pred = {k: (v[:, of] if isinstance(v, np.ndarray) and v.ndim == 2 else v) for k, v in pred.items()}
            if "te0_rms" in pred:
                pred["te0_rms"] = pred["te0_rms"][of]
                pred["te0_term"] = self._te0_term(pred["te0_rms"])
        self._raise_if_verification_fails(ver, after)
        err = {"te_pp": float(np.max(np.abs(pred["te_pp"] - ver.te_pp))),
               "objective": abs(pred["objective"] - ver.objective)}
        if conf is not None and self.harmonics is None:
            err["confirmed"] = conf.objective - pred["objective"]
        if self.p_limit is not None:
            err["p_max"] = float(np.max(np.abs(pred["p_max"] - ver.p_max)))
        if self.te_level is not None:
            err["te0_rms"] = float(np.max(np.abs(pred["te0_rms"] - ver.te0_rms)))
        before = self.check(self.theta0, fine)
        return MicroDesign(theta=dict(zip(self.free, theta.tolist())), theta0=dict(zip(self.free, self.theta0.tolist())),
                           predicted=pred, verified=ver, error=err, before=before, after=after, rounds=rounds,
                           iterations=iters, time=time.perf_counter() - t_start, status=status, stop=stop,
                           binding=self._binding(theta, pred, ver), rho=rho, phi1=self.phi1.copy(),
                           confirmed=None if conf is None or self.harmonics is not None else conf,
                           exchanges=exchanges)

    def _new_positions(self, phi: np.ndarray) -> np.ndarray:
        """The pinion angles ``phi`` [rad] not already among the NLP's positions."""
        phi = np.asarray(phi, float)
        return phi[~np.any(np.isclose(phi[:, None], self.phi1[None, :], rtol=0.0, atol=1e-12), axis=1)]
