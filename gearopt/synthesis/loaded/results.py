"""Results of the loaded micro-geometry optimiser: :class:`LoadedCheck` (loaded TCA of one design over
the duty cycle), :class:`MicroDesign` (an optimum, verified) and :class:`ParetoFront`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .constants import RHO

if TYPE_CHECKING:
    from .exchange import Confirmation


@dataclass(frozen=True)
class LoadedCheck:
    """Loaded TCA of one design over the duty cycle (arrays (T, C): torques x cases).

    Attributes
    ----------
    te_pp : peak-to-peak loaded TE over the mesh cycle [arcsec].
    p_max : largest Hertz peak pressure of the flank slices [MPa].
    edge_share : largest share of the normal load on tip-edge or face-end slices at any position.
    edge_gap : smallest gap of a tip-edge or face-end slice under load [mm] (0: loaded).
    edge_load : largest share of the normal load on one tip-edge or face-end slice.
    objective : the weighted objective [arcsec]: sum of ``te_pp``, or of the weighted harmonics.
    sweeps : (C,) the :class:`~gearopt.ltca.engine.LoadedSweep` of each case.
    harmonics : (T, C, H) amplitudes of the loaded TE's first H mesh harmonics [arcsec] (least squares
        on the positions; the DFT on a uniform grid), when the objective is the harmonics.
    te0_rms : (C,) with an unloaded-TE target (``te_level``): the RMS misfit [arcsec] of each case's
        unloaded TE (one pair over one mesh cycle centred on it, the smallest separation of its
        slices) to the target parabola plus its best line (:meth:`LoadedMicroOptimizer.te0_misfit`).
    te0_term : the target's term of the objective [arcsec] (0 without a target); the trust-region
        loop's merit is ``objective + te0_term`` plus the penalties.
    """

    te_pp: np.ndarray
    p_max: np.ndarray
    edge_share: np.ndarray
    edge_gap: np.ndarray
    edge_load: np.ndarray
    objective: float
    sweeps: tuple = field(repr=False)
    harmonics: np.ndarray | None = None
    te0_rms: np.ndarray | None = None
    te0_term: float = 0.0


@dataclass(frozen=True)
class MicroDesign:
    """Result of :meth:`LoadedMicroOptimizer.solve`.

    Attributes
    ----------
    theta : dict name -> amount [mm] (the optimum); theta0 : the start design.
    predicted : dict of the NLP's own values at the optimum: ``te_pp`` (T, C) [arcsec], ``p_max``
        (T, C) [MPa], ``objective`` [arcsec], ``slack_p``, ``slack_e`` (T, C); with an unloaded-TE
        target ``te0_rms`` (C,) [arcsec], ``te0_term`` [arcsec] and ``te0`` (the NLP's unloaded TE per block).
    verified : :class:`LoadedCheck` of the optimum by loaded TCA at the NLP's positions (exact slices
        of the modified flanks and the QP contact solver, nothing of the NLP).
    error : dict: largest |predicted - verified| of ``te_pp`` [arcsec], ``p_max`` [MPa] and the
        ``objective`` [arcsec] (the linearisation and the smoothing together), and of ``te0_rms``
        [arcsec] with an unloaded-TE target.
    before, after : :class:`LoadedCheck` of the start design and of the optimum on the verification
        grid (``n_verify`` positions per mesh cycle, independent of the NLP's grid).
    rounds : list of dicts per trust-region round (design, model and true objective, radius, IPOPT
        iterations and status, times).
    iterations : IPOPT iterations in all; time : wall time [s]; status : IPOPT's last return status.
    stop : why the trust-region loop ended: ``"converged"`` (the NLP's step fell below ``THETA_TOL``
        or its predicted decrease below ``F_TOL``: a stationary design) or ``"trust radius"`` (the
        radius shrank below ``THETA_TOL`` with no better design found: not shown stationary).
    binding : the bounds and constraints active at the optimum.
    rho, phi1 : the penalty weight and the NLP's positions [rad] at the end (:meth:`LoadedMicroOptimizer.sensitivities`).
    confirmed : :class:`~gearopt.synthesis.loaded.exchange.Confirmation` of the optimum: its loaded TE
        objective with the extremes located on ``n_confirm`` positions per cycle and refined between them
        (None with ``harmonics``); :attr:`promised` (the NLP's objective) agrees with it within
        ``confirm_tol`` (``error["confirmed"]``: confirmed minus promised [arcsec]).
    exchanges : times the optimum's loaded TE extremes joined the NLP's positions.
    """

    theta: dict
    theta0: dict
    predicted: dict
    verified: LoadedCheck
    error: dict
    before: LoadedCheck
    after: LoadedCheck
    rounds: list
    iterations: int
    time: float
    status: str
    binding: tuple
    rho: float = RHO  #: the exact-penalty weight the loop ended with
    phi1: np.ndarray | None = field(default=None, repr=False)  #: the NLP's final positions [rad]
    stop: str = "converged"  #: why the trust-region loop ended ("converged" or "trust radius")
    confirmed: Confirmation | None = None  #: the objective between the NLP's positions (:class:`.exchange.Confirmation`)
    exchanges: int = 0  #: times the extremes' positions joined the NLP's grid

    @property
    def promised(self) -> float:
        """The NLP's objective at the optimum [arcsec] (the loaded TE over its own positions)."""
        return float(self.predicted["objective"])

    def theta_um(self) -> dict:
        """The optimum's amounts [um]."""
        return {k: v * 1e3 for k, v in self.theta.items()}

    def to_dict(self) -> dict:
        """JSON-able summary (amounts in um, TE in arcsec, pressures in MPa)."""
        from ...report import arr

        def chk(c: LoadedCheck) -> dict:
            out = {"te_pp_arcsec": arr(c.te_pp), "p_max_MPa": arr(c.p_max), "edge_share": arr(c.edge_share),
                   "edge_gap_um": arr(c.edge_gap * 1e3), "edge_load": arr(c.edge_load), "objective_arcsec": c.objective}
            if c.harmonics is not None:
                out["harmonics_arcsec"] = arr(c.harmonics)
            if c.te0_rms is not None:
                out["te0_rms_arcsec"] = arr(c.te0_rms)
                out["te0_term_arcsec"] = c.te0_term
            return out

        pred = {"te_pp_arcsec": arr(self.predicted["te_pp"]), "p_max_MPa": arr(self.predicted["p_max"]),
                "objective_arcsec": self.predicted["objective"]}
        if self.predicted.get("te0_rms") is not None:
            pred["te0_rms_arcsec"] = arr(self.predicted["te0_rms"])
            pred["te0_term_arcsec"] = self.predicted["te0_term"]

        return {"theta_um": self.theta_um(), "theta0_um": {k: v * 1e3 for k, v in self.theta0.items()},
                "predicted": pred,
                "verified": chk(self.verified), "error": dict(self.error), "before": chk(self.before),
                "after": chk(self.after), "rounds": self.rounds, "iterations": self.iterations,
                "time_s": self.time, "status": self.status, "stop": self.stop, "binding": list(self.binding),
                "confirmed": None if self.confirmed is None else self.confirmed.to_dict(),
                "exchanges": self.exchanges}


@dataclass(frozen=True)
class ParetoFront:
    """Result of :meth:`LoadedMicroOptimizer.pareto`: loaded TE against peak pressure by an
    epsilon-constraint sweep of the pressure limit.

    Attributes
    ----------
    anchor : :class:`MicroDesign` without a pressure limit (the lowest loaded TE of the design space).
    p_limits : (L,) the pressure limits asked for [MPa], decreasing.
    designs : (L,) the :class:`MicroDesign` at each limit, None where none meets it.
    messages : (L,) why a limit has no design (the :class:`SynthesisError`'s text), else "".
    notes : (L + 1,) the anchor's and each limit's note, else "": its design was solved again from a
        tighter limit's design, or is that design (:meth:`LoadedMicroOptimizer.pareto`).
    solved_under : (L + 1,) the pressure limit [MPa] whose NLP the anchor's and each limit's design solves
        (None: no limit): the point's own, or the tighter limit's whose design it keeps (None where the
        limit has no design); the design's sensitivities are those of that NLP.
    """

    anchor: MicroDesign
    p_limits: tuple
    designs: tuple
    messages: tuple
    notes: tuple = ()
    solved_under: tuple = ()

    def points(self) -> list[dict]:
        """The front's points, the anchor first: the limit [MPa] (None for the anchor), the verified
        weighted loaded TE [arcsec] and largest peak pressure over the duty cycle [MPa] (loaded TCA on
        the verification grid), the unloaded-TE target's term [arcsec] (0 without one), and the design
        [um]; limits without a design give ``feasible: False``; a point whose design was solved again
        from a tighter limit's, or is that design, has its ``note``."""
        out = []
        notes = tuple(self.notes) or ("",) * (len(self.p_limits) + 1)
        for lim, d, msg, note in zip((None,) + tuple(self.p_limits), (self.anchor,) + tuple(self.designs),
                                     ("",) + tuple(self.messages), notes):
            if d is None:
                out.append({"p_limit_MPa": lim, "feasible": False, "message": msg})
                continue
            out.append({"p_limit_MPa": lim, "feasible": True, "objective_arcsec": d.after.objective,
                        "te0_term_arcsec": d.after.te0_term,
                        "p_max_MPa": float(np.max(d.after.p_max)), "edge_load": float(np.max(d.after.edge_load)),
                        "theta_um": d.theta_um(), "rounds": len(d.rounds), "time_s": d.time,
                        **({"note": note} if note else {})})
        return out

    def to_dict(self) -> dict:
        return {"points": self.points()}
