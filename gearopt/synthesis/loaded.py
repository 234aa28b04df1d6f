"""Micro-geometry optimisation under load (docs/loaded_synthesis.md).

The design ``theta`` is a set of ISO 21771 amounts of either member (``"pinion.C_alpha"``,
``"pinion.C_alpha_a"``...; :class:`gearopt.geometry.microgeometry.Microgeometry`) and/or Litvin's
settings (``"pinion.a_c"``, ``"pinion.a_pl"``), each with manufacturing bounds. The duty cycle is a
list of pinion torques times a list of misalignment cases, each (torque, case) with a weight. The
objective is the weighted sum of the loaded TE's peak-to-peak [arcsec] over one mesh cycle (or of
its first mesh harmonics' weighted amplitudes); the constraints are a peak Hertz pressure limit on the
flank slices at every torque and case, and no edge loading: every tip-edge slice, every face-end
slice and every flank slice near a tip (graded weight, :func:`_edge_weight`) keeps its load share below
``mu / edge_margin`` (a gap of at least ``edge_margin`` on the smoothed manifold); the exact loaded TCA
of the optimum must show at most ``EDGE_TOL`` of the load on any of them.

One IPOPT NLP holds the whole duty cycle. Its unknowns are the design, every slice load ``x = F / W``
(share of the normal load), every slice gap ``y`` [um] and every position's approach, for every
(torque, case, position). The loaded-contact conditions of :mod:`gearopt.ltca.engine` are
constraints of the NLP:

    y = (a(theta) + W C x + delta_H(W x) - delta) / g_ref     (the gap of every slice)
    x + y - sqrt(x^2 + y^2 + 2 mu) = 0                         (Fischer-Burmeister, smoothed)
    sum x = 1                                                  (the load balance)

The smoothed Fischer-Burmeister function is zero exactly where ``x >= 0, y >= 0, x y = mu``. So the
complementarity ``F g = 0`` of the contact problem is relaxed to ``x y = mu``: an open slice at a gap
of 1 um carries ``mu`` of the load, and a loaded slice's gap is ``mu / x`` um. With the default
``mu = 1e-8`` that changes the loaded TE by less than 1e-3 arcsec; each optimum reports the
difference to the exact loaded TCA (below). Why one NLP and not a bilevel scheme: the contact
problem's active set changes with the design (slices open and close as relief grows), which makes
the loaded TE only piecewise smooth in theta for an outer solver; the smoothed NLP is smooth, IPOPT
sees every load and gap, and its exact Hessian is sparse (every nonlinearity acts on one slice).

The separations ``a`` [mm] of the slices are linear in the design: ``a(theta) = a_k + J_k (theta -
theta_k)`` with ``J_k`` the exact sensitivity of every slice's TE at ``theta_k`` (the implicit
function theorem on the slice equations, by AD). The slices' positions, compliance and Hertz
radii are those of ``theta_k``. A trust-region loop moves the design: every trial design's slices
are solved exactly and its loaded TCA (:class:`gearopt.ltca.engine.LTCA`, exact slices, the QP contact
solver) decides whether the step is taken. The optimum is verified by the same loaded TCA on the
NLP's positions and on a finer grid; positions of the finer grid that violate a constraint join the
NLP's grid. The result reports the NLP's values, the loaded TCA's, and their difference.

:meth:`LoadedMicroOptimizer.sensitivities` differentiates the optimum with respect to the torques and
a misalignment (the KKT system of its active set, read from IPOPT's central path, by CasADi); :meth:`LoadedMicroOptimizer.pareto`
sweeps the pressure limit (epsilon-constraint) for the front of loaded TE against peak pressure.

Optionally (``te_level``, ``te_weight``) Litvin's predesigned parabolic TE of the unloaded drive is a
second term of the objective: the RMS misfit of each case's unloaded TE (the pair centred on each
position, its smallest separation by the same smoothed complementarity at zero load) to the parabola
plus its least-squares line (docs/loaded_synthesis.md section 9).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..compiled import available
from ..errors import ArgumentError, OptionError, out_of_range
from ..gears import GearPair
from ..geometry.microgeometry import AMOUNT_MAX_PER_M, RELIEF_AMOUNTS, Microgeometry, modified_tooth
from ..ltca.compliance import Material, coupling_stiffness_batch
from ..ltca.engine import F_MIN_SHARE, LTCA, LoadedSweep
from ..meshing.misalignment import Misalignment
from ..meshing.tca import TCA
from ..units import RAD_TO_ARCSEC
from .crowning import SynthesisError

G_REF = 1e-3  #: [mm] unit of the gap unknowns y (1 um)
MU = 1e-8  #: smoothing of the complementarity: x y = MU (x: load share, y: gap in um)
RHO = 1000.0  #: first exact-penalty weight of the constraint slacks [arcsec per unit share of the load on an edge slice / per unit p^2/p_limit^2], times the mean weight
RHO_MAX = 1e5  #: the weight grows tenfold while a converged design, or the NLP's optimum well inside the trust region, leaves a slack, up to this
SLACK_TOL = 1e-3  #: a pressure slack above this is a violated limit (0.05 % of the pressure limit)
EDGE_TOL = 1e-4  #: an edge slack above this (share of the normal load on one edge slice, 0.01 %) is edge loading
MAX_ROUNDS = 30  #: trust-region rounds at most
MAX_REFINE = 3  #: times the NLP's grid may grow by the verification positions that violate a constraint
TR_START = 0.25  #: first trust radius, times the widest bound interval
F_TOL = 1e-4  #: ... or when the NLP predicts a decrease of the objective below this share of it
#: IPOPT from an earlier NLP's multipliers (:meth:`LoadedMicroOptimizer._solve_nlp`): a small first barrier
#: parameter and bound push, so the start point and multipliers are kept; a warm solve that fails or
#: takes longer than this falls back to the cold start
WARM_OPTS = {"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-4, "ipopt.warm_start_bound_push": 1e-9,
             "ipopt.warm_start_mult_bound_push": 1e-9, "ipopt.warm_start_slack_bound_push": 1e-9,
             "ipopt.max_iter": 300}
HARM_EPS = 1e-3  #: [arcsec] smoothing of a harmonic amplitude at zero, sqrt(a^2 + b^2 + eps^2)
TE0_EPS = 1e-3  #: [arcsec] smoothing of the unloaded TE's RMS misfit to its parabola at zero, sqrt(rms^2 + eps^2)
DEGENERATE_REL = 1e-6  #: an active constraint whose multiplier is below this times the largest is degenerate
THETA_TOL = 1e-4  #: [mm] the design has settled when no amount moves by more than this (0.1 um: below any grinding machine's resolution)
TIP_BAND = 0.02  #: [m_n] contact within this radial distance of a tip circle counts as tip (edge) contact
SETTINGS = {"a_c": 0.05, "a_pl": 0.02}  #: Litvin's settings a design may free, with their largest value [1/mm]
NONNEG = ("C_alpha", "C_beta", "C_alpha_a", "C_alpha_f", "C_beta_I", "C_beta_II")  #: amounts >= 0


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

    def theta_um(self) -> dict:
        """The optimum's amounts [um]."""
        return {k: v * 1e3 for k, v in self.theta.items()}

    def to_dict(self) -> dict:
        """JSON-able summary (amounts in um, TE in arcsec, pressures in MPa)."""
        from ..report import arr

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
                "time_s": self.time, "status": self.status, "stop": self.stop, "binding": list(self.binding)}


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
    """

    anchor: MicroDesign
    p_limits: tuple
    designs: tuple
    messages: tuple

    def points(self) -> list[dict]:
        """The front's points, the anchor first: the limit [MPa] (None for the anchor), the verified
        weighted loaded TE [arcsec] and largest peak pressure over the duty cycle [MPa] (loaded TCA on
        the verification grid), the unloaded-TE target's term [arcsec] (0 without one), and the design
        [um]; limits without a design give ``feasible: False``."""
        out = []
        for lim, d, msg in zip((None,) + tuple(self.p_limits), (self.anchor,) + tuple(self.designs),
                               ("",) + tuple(self.messages)):
            if d is None:
                out.append({"p_limit_MPa": lim, "feasible": False, "message": msg})
                continue
            out.append({"p_limit_MPa": lim, "feasible": True, "objective_arcsec": d.after.objective,
                        "te0_term_arcsec": d.after.te0_term,
                        "p_max_MPa": float(np.max(d.after.p_max)), "edge_load": float(np.max(d.after.edge_load)),
                        "theta_um": d.theta_um(), "rounds": len(d.rounds), "time_s": d.time})
        return out

    def to_dict(self) -> dict:
        return {"points": self.points()}


#: sign of each misalignment kind under the mirror z -> -z of a drive symmetric about its mid-face
#: (the centre distance is unchanged; the crossing and intersecting angles and the axial shift change
#: sign). Every field of Misalignment must be listed: a kind missing here disables the mirror reduction.
MIRROR_SIGN = {"dE": 1.0, "crossing": -1.0, "intersecting": -1.0, "axial": -1.0}


def mirror_image(mis: Misalignment) -> Misalignment:
    """The misalignment mirrored in z (each kind times its ``MIRROR_SIGN``); :class:`ArgumentError`
    naming the kind when one has no known mirror sign."""
    for k in Misalignment.names():
        if k not in MIRROR_SIGN:
            raise ArgumentError(f"misalignment kind {k!r}: its sign under the mirror z -> -z is not known "
                                "(gearopt.synthesis.loaded.MIRROR_SIGN).", param=k, value=k,
                                valid=f"one of {sorted(MIRROR_SIGN)}")
    return Misalignment(**{k: MIRROR_SIGN[k] * getattr(mis, k) for k in Misalignment.names()})


class LoadedMicroOptimizer:
    """Choose flank modifications that minimise the loaded TE over a duty cycle (module docstring).

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

    def __init__(self, pair: GearPair, free: dict, torques, cases=None, weights=None, p_limit: float | None = None,
                 edge_margin: float | None = 5e-4, n_positions: int = 32, n_verify: int = 64, n_slices: int = 15,
                 material: Material | None = None, side: str = "right", jit: bool | str = "auto", harmonics=None,
                 te_level: float | None = None, te_weight: float = 1.0):
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {pair!r:.60}: expected a gearopt.gears.GearPair.", param="pair", value=pair,
                                valid="a gearopt.gears.GearPair")
        self.pair = pair
        self.torques = LTCA.validate_torques(torques)
        cases = [Misalignment()] if cases is None else list(cases)
        if not cases or not all(isinstance(c, Misalignment) for c in cases):
            raise ArgumentError("cases: expected a non-empty list of gearopt Misalignment.", param="cases",
                                value=cases, valid="a list of Misalignment")
        self.cases = tuple(cases)
        T, C = self.torques.size, len(self.cases)
        w = np.ones((T, C)) if weights is None else np.asarray(weights, float)
        if w.shape != (T, C) or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.sum() > 0:
            raise ArgumentError(f"weights: expected a ({T}, {C}) array (torques x cases) of finite weights >= 0, "
                                "not all 0.", param="weights", value=np.shape(w), valid=f"shape ({T}, {C}), >= 0")
        self.weights = w
        if p_limit is not None and not (isinstance(p_limit, (int, float)) and math.isfinite(p_limit)
                                        and 100.0 <= p_limit <= 1e4):
            raise out_of_range("p_limit", p_limit, "100 <= p_limit <= 10000 MPa (peak Hertz pressure)",
                               cls=OptionError)
        self.p_limit = None if p_limit is None else float(p_limit)
        if edge_margin is not None and not (isinstance(edge_margin, (int, float)) and 0 < edge_margin <= 0.1):
            raise out_of_range("edge_margin", edge_margin, "0 < edge_margin <= 0.1 mm (or None)", cls=OptionError)
        self.edge_margin = None if edge_margin is None else float(edge_margin)
        if isinstance(n_positions, bool) or not isinstance(n_positions, (int, np.integer)) or not 8 <= n_positions <= 256:
            raise out_of_range("n_positions", n_positions, "an integer, 8 <= n_positions <= 256", cls=OptionError)
        if isinstance(n_verify, bool) or not isinstance(n_verify, (int, np.integer)) or not 8 <= n_verify <= 2000:
            raise out_of_range("n_verify", n_verify, "an integer, 8 <= n_verify <= 2000", cls=OptionError)
        self.n_verify = int(n_verify)
        self.harmonics = None
        if harmonics is not None:
            try:
                hw = np.asarray(harmonics, float).ravel()
            except (TypeError, ValueError):
                hw = np.array([np.nan])
            if not (1 <= hw.size <= 10 and np.all(np.isfinite(hw)) and np.all(hw >= 0) and hw.sum() > 0
                    and 2 * hw.size + 1 <= n_positions):
                raise out_of_range("harmonics", harmonics, "1 ... 10 weights >= 0, not all 0, one per mesh harmonic, "
                                   f"at most (n_positions - 1) / 2 = {(n_positions - 1) // 2} of them", cls=OptionError)
            self.harmonics = hw
        if te_level is not None and not (isinstance(te_level, (int, float)) and not isinstance(te_level, bool)
                                         and math.isfinite(te_level) and 0.0 < te_level < 600.0 / RAD_TO_ARCSEC):
            raise out_of_range("te_level", te_level if not isinstance(te_level, (int, float)) or isinstance(te_level, bool)
                               else f"{te_level * RAD_TO_ARCSEC:.6g} arcsec",
                               "0 < te_level < 600 arcsec (the unloaded parabolic TE level, in rad), or None",
                               cls=OptionError)
        self.te_level = None if te_level is None else float(te_level)
        if not (isinstance(te_weight, (int, float)) and not isinstance(te_weight, bool) and math.isfinite(te_weight)
                and 0.0 < te_weight <= 1e3):
            raise out_of_range("te_weight", te_weight, "0 < te_weight <= 1000 (weight of the unloaded-TE target)",
                               cls=OptionError)
        self.te_weight = float(te_weight)
        self.free, self.lo, self.hi = self._check_free(free)
        if not (isinstance(jit, (bool, np.bool_)) or (isinstance(jit, str) and jit == "auto")):
            raise out_of_range("jit", jit, "'auto', True or False (solve the slices as compiled C)", cls=OptionError)
        # the loop solves the slices of every case several hundred columns at a time, dozens of times:
        # compiled whenever a C compiler is present (8x faster than interpreted at 500 columns)
        jit = available() if jit == "auto" else bool(jit)
        self.tca = TCA(pair, side=side, pinion=modified_tooth(pair, "pinion", force_iso=True),
                       gear=modified_tooth(pair, "gear", force_iso=True), jit=jit)
        # the involute's curvature in the Hertz term: the pressure limit does not see the curvature of the
        # reliefs' smooth starts (docs/loaded_synthesis.md section 8)
        self.ltca = LTCA(pair, side=side, material=material, n_slices=n_slices, tca=self.tca, curvature="involute")
        self.material = self.ltca.material
        self.n_positions = int(n_positions)
        self.phi1 = self.ltca.mesh_cycle(self.n_positions)
        lay = self.tca.layout
        self._prm_index = [lay.index(f"{m}.{_entry(a)}") for m, a in (n.split(".", 1) for n in self.free)]
        self._prm_index += [lay.index(f"mis.{k}") for k in Misalignment.names()]  # then the misalignments
        self.p0 = (np.array(self.tca.pinion.p0, float), np.array(self.tca.gear.p0, float))
        self.theta0 = np.array([self.p0[0 if m == "pinion" else 1][lay.member_names[m].index(_entry(a))]
                                for m, a in (n.split(".", 1) for n in self.free)])
        bad = [(n, t) for n, t, a, b in zip(self.free, self.theta0, self.lo, self.hi) if not a <= t <= b]
        if bad:
            n, t = bad[0]
            i = self.free.index(n)
            k, u = (1.0, "1/mm") if n.split(".", 1)[1] in SETTINGS else (1e3, "um")
            raise out_of_range(f"free.{n}", f"{float(t) * k:g} {u}", f"the start design's {n} must lie within its bounds "
                               f"{self.lo[i] * k:g} ... {self.hi[i] * k:g} {u}", cls=OptionError)
        self._sens = {}
        self._has_settings = any(n.split(".", 1)[1] in SETTINGS for n in self.free)
        #: the penalty's weight scale (that of the full duty cycle; an unloaded-TE target adds its weight: its
        #: term weighs te_weight times the loaded objective's per case, and so may its multipliers)
        self._w_mean = float(np.mean(self.weights)) * (1.0 + (self.te_weight if self.te_level is not None else 0.0))
        self._mult = np.ones((T, C))  #: how many cases of the duty cycle each (torque, case) stands for

    def mirror_classes(self) -> list[list[int]] | None:
        """Cases that are mirror images of each other (docs/loaded_synthesis.md section 5): lists of
        case indices whose loaded TCA is the same for every design the optimiser may choose, or None
        when the drive is not mirror-symmetric about its mid-face. A spur pair whose flanks are
        symmetric in z (no helix slope, bias, off-centre lead crowning, unequal end reliefs or measured
        deviations; none of these free) meshes under a misalignment as under its mirror image
        (:func:`mirror_image`: ``(dE, crossing, intersecting, axial)`` as ``(dE, -crossing,
        -intersecting, -axial)``) mirrored in z. Every kind of ``Misalignment`` is read from its fields;
        one without a known mirror sign (``MIRROR_SIGN``) leaves every case on its own (None)."""
        asym = ("f_H_beta", "S_alpha", "z_Cb", "C_beta_I", "C_beta_II")
        if any(n.split(".", 1)[1] in asym for n in self.free):
            return None
        for g in (self.pair.pinion, self.pair.gear):
            if g.beta != 0.0:
                return None
            mg = g.modifications
            if mg is not None and (mg.f_H_beta or mg.S_alpha or mg.z_Cb or mg.measured or mg.C_beta_I != mg.C_beta_II
                                   or mg.b_I != mg.b_II):
                return None
        kinds = Misalignment.names()
        if any(k not in MIRROR_SIGN for k in kinds):
            return None  # a kind whose mirror image is not known: no case is taken for another's
        key = lambda m: tuple(round(float(getattr(m, k)), 15) for k in kinds)  # noqa: E731
        keys = [key(m) for m in self.cases]
        classes, seen = [], set()
        for c, m in enumerate(self.cases):
            if c in seen:
                continue
            mk = key(mirror_image(m))
            twin = [j for j in range(c + 1, len(keys)) if keys[j] == mk and j not in seen and keys[j] != keys[c]]
            cls = [c] + twin[:1]
            seen.update(cls)
            classes.append(cls)
        return classes if any(len(k) > 1 for k in classes) else None

    def shifted(self, offset: Misalignment) -> "LoadedMicroOptimizer":
        """A copy of this optimiser with ``offset`` added to every case (each kind of ``Misalignment``);
        the duty cycle :meth:`sensitivities` differentiates in (e.g. for finite differences of
        re-solved optima, ``benchmarks/loaded_sensitivity_fd.py``)."""
        if not isinstance(offset, Misalignment):
            raise ArgumentError(f"offset = {offset!r:.60}: expected a gearopt Misalignment.", param="offset",
                                value=offset, valid="a Misalignment")
        out = copy.copy(self)
        out.cases = tuple(Misalignment(**{k: getattr(c, k) + getattr(offset, k) for k in Misalignment.names()})
                          for c in self.cases)
        out.phi1 = self.phi1.copy()
        return out

    def _reduced(self):
        """The optimiser of one case per mirror class (:meth:`mirror_classes`), its weights the sums of
        the class's and its penalty counting each class as often as it has members (the same merit,
        objective and constraints as the full duty cycle at every symmetric design); self when no
        case has a mirror image."""
        classes = self.mirror_classes()
        if classes is None:
            return self
        red = copy.copy(self)
        red.cases = tuple(self.cases[k[0]] for k in classes)
        red.weights = np.stack([self.weights[:, k].sum(axis=1) for k in classes], axis=1)
        red._mult = np.tile(np.array([len(k) for k in classes], float), (self.torques.size, 1))
        red._w_mean = self._w_mean
        return red

    # ------------------------------------------------------------------------------------------
    def _check_free(self, free):
        if not isinstance(free, dict) or not free:
            raise ArgumentError("free: expected a dict {'pinion.C_alpha': (lo, hi), ...} of free amounts [mm].",
                                param="free", value=free, valid="a non-empty dict name -> (lo, hi) [mm]")
        names, lo, hi = [], [], []
        for name, b in free.items():
            member, _, amount = str(name).partition(".")
            gear = getattr(self.pair, member, None) if member in ("pinion", "gear") else None
            valid = [f"{m}.{a}" for m in ("pinion", "gear") for a in self._amounts(getattr(self.pair, m)) + tuple(SETTINGS)]
            if amount in SETTINGS and gear is not None:
                # Litvin's settings [1/mm]: parabolic rack-cutter profile a_c, plunging (lead crowning) a_pl
                try:
                    a, c = (float(v) for v in b)
                except (TypeError, ValueError):
                    raise out_of_range(f"free.{name}", b, "a pair (lo, hi) [1/mm]", cls=OptionError) from None
                if not (math.isfinite(a) and math.isfinite(c) and 0.0 <= a < c <= SETTINGS[amount]):
                    raise out_of_range(f"free.{name}", f"({a:g}, {c:g}) 1/mm",
                                       f"0 <= lo < hi <= {SETTINGS[amount]:g} 1/mm", cls=OptionError)
                names.append(f"{member}.{amount}")
                lo.append(a)
                hi.append(c)
                continue
            if gear is None or amount not in self._amounts(gear):
                hint = ""
                if gear is not None and amount in RELIEF_AMOUNTS:
                    hint = " (a relief needs its start, e.g. d_Ca, in the member's modifications)"
                raise out_of_range(f"free.{name}", name, f"one of {valid}{hint}", cls=OptionError)
            try:
                a, c = (float(v) for v in b)
            except (TypeError, ValueError):
                raise out_of_range(f"free.{name}", b, "a pair (lo, hi) of amounts [mm]", cls=OptionError) from None
            cap = AMOUNT_MAX_PER_M * gear.m_n
            low = 0.0 if amount in NONNEG else -cap
            if not (math.isfinite(a) and math.isfinite(c) and low <= a < c <= cap):
                raise out_of_range(f"free.{name}", f"({a * 1e3:g}, {c * 1e3:g}) um",
                                   f"{low * 1e3:g} um <= lo < hi <= {cap * 1e3:g} um", cls=OptionError)
            names.append(f"{member}.{amount}")
            lo.append(a)
            hi.append(c)
        return tuple(names), np.array(lo), np.array(hi)

    @staticmethod
    def _amounts(gear) -> tuple:
        mg = getattr(gear, "modifications", None) or Microgeometry()
        return mg.theta_names

    def params(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """Both members' parameter vectors with the design ``theta`` [mm] set."""
        p = {"pinion": self.p0[0].copy(), "gear": self.p0[1].copy()}
        for n, t in zip(self.free, np.asarray(theta, float)):
            m, a = n.split(".", 1)
            p[m][self.tca.layout.member_names[m].index(_entry(a))] = t
        return p["pinion"], p["gear"]

    # -- loaded TCA of one design (the verification) ----------------------------------------------
    def check(self, theta, phi1=None, known=None) -> LoadedCheck:
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
            R = _harmonic_rows(S.phi1, self.pair.pinion.z, H) if H else None
            ends = _edge_mask(S, self.pair)
            for t, r in enumerate(sw.results):
                pp[t, c] = r.peak_to_peak_arcsec
                if H:
                    ab = (R @ r.te_loaded_arcsec).reshape(H, 2)
                    hm[t, c] = np.hypot(ab[:, 0], ab[:, 1])
                pm[t, c] = r.p_max
                es[t, c] = float(np.max(np.sum(np.where(ends, r.load, 0.0), axis=(0, 2)) / r.W))
                el[t, c] = float(np.max(_edge_weight(S, self.pair) * r.load) / r.W)
                gap = _gaps(sw, r)
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

    def te0_misfit(self, S, case: int = 0) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
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
        rms, coef = _parabola_fit(psi, te, self.te_level * RAD_TO_ARCSEC)
        return rms, psi, te, coef

    def _te0_enough(self, n: int, N: int, case: int):
        if n < 4:
            raise SynthesisError(
                f"loaded micro-geometry: the unloaded-TE target needs the pair centred on each position in contact, "
                f"but in case {case} ({_case_text(self.cases[case])}) it touches at only {n} of the {N} positions "
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

    # -- linearisation --------------------------------------------------------------------------
    def _sensitivity(self, kind: int) -> ca.Function:
        """d(r_p2 phi2)/d(theta, misalignment) of a slice (kind 0: flank, 1/2: a tip edge), implicit
        function theorem; with the total derivatives of the slice point's radius on the pinion (``dr1``)
        and on the gear (``dr2``) [mm per unit], which move a flank slice in the tip band
        (:func:`_edge_weight`; zero on a tip edge, whose weight is 1)."""
        if kind not in self._sens:
            slicer = self.ltca.slicer
            G = slicer.G if kind == 0 else slicer.edge_branch[kind].G
            w = ca.SX.sym("w", 4)
            prm = ca.SX.sym("prm", self.tca.layout.size)
            F = G(w, prm)
            idx = self._prm_index
            dw = -ca.solve(ca.jacobian(F, w), ca.jacobian(F, prm)[:, idx])
            outs = [dw[3, :].T]
            if kind == 0:
                r1, _, r2 = slicer.geometry(w, prm)[:3]
                for r in (r1, r2):
                    rad = ca.sqrt(r[0] ** 2 + r[1] ** 2)
                    outs.append((ca.mtimes(ca.jacobian(rad, w), dw) + ca.jacobian(rad, prm)[:, idx]).T)
            else:
                outs += [ca.DM.zeros(len(idx)), ca.DM.zeros(len(idx))]
            self._sens[kind] = ca.Function(f"ltca_dphi2_{kind}", [w, prm], outs, ["w", "prm"], ["dw3", "dr1", "dr2"])
        return self._sens[kind]

    def linearise(self, theta) -> list:
        """Slices, compliance and the separations' sensitivities of the design ``theta`` [mm], per case:
        a list of dicts (``S``: SliceSet, ``st``: structure, ``a`` (K, N, M) separations [mm],
        ``J`` (K, N, M, P) [mm/mm], ``Jm`` (K, N, M, 4) per misalignment kind of
        ``Misalignment.names()`` [mm/rad or mm/mm], ``Jr`` (K, N, M, 2, P + 4) the slice point's radius
        on the pinion and on the gear per design amount and misalignment kind)."""
        p1, p2 = self.params(theta)
        lever = self.pair.gear.r_b * self.ltca.cos_bb
        z1 = self.pair.pinion.z
        out = []
        for mis in self.cases:
            S = self.ltca.slices(self.phi1, p1, p2, mis)
            st = self.ltca._structure(S)
            K, N, M = S.z.shape
            J = np.zeros((K, N, M, len(self._prm_index)))
            Jr = np.zeros((K, N, M, 2, len(self._prm_index)))
            phis = (S.phi1[None, :] - 2 * math.pi * np.array(S.pairs)[:, None] / z1)
            kinds = np.zeros((K, N, M), int) if S.edge is None else S.edge
            for kind in (0, 1, 2):
                sel = S.active & (kinds == kind)
                if not sel.any():
                    continue
                kk, nn, mm = np.nonzero(sel)
                prm = self.tca.prm(phis[kk, nn], p1, p2, mis)
                prm[self.tca.layout.index("z_section"), :] = S.z[kk, nn, mm]
                wv = S.w[kk, nn, mm].T
                f = self._sensitivity(kind).map(wv.shape[1])
                dw3, dr1, dr2 = (np.asarray(v).T for v in f(wv, prm))
                J[kk, nn, mm] = dw3 / self.pair.gear.r_p * (-lever)
                Jr[kk, nn, mm] = np.stack([dr1, dr2], axis=1)
            if S.partner_of is not None:
                # a partner slice's separation is interpolated to the crossing (SliceSet.partner_t), and
                # so is its sensitivity (the crossing's own motion with the design is left out)
                kk, nn, mm = np.nonzero(S.partner_of >= 0)
                ii, tt = S.partner_of[kk, nn, mm], S.partner_t[kk, nn, mm][:, None]
                J[kk, nn, mm] = J[kk, nn, ii] + tt * (J[kk, nn, mm] - J[kk, nn, ii])
            # each slice on its own levers (LTCA._solve_one, docs/ltca.md section 3): the gap is
            # (te0 - te) L2 + C F - lam delta, lam = L1 / (r_b1 cos(beta_b)); with the absolute separation
            # a = -te r_b2 cos(beta_b) and the block's approach d = delta - te0 r_b2 cos(beta_b)
            # (TE = -d / (r_b2 cos(beta_b))) it is a + da + C F - lam d, da = -(te - te0) (L2 - r_b2 cos(beta_b))
            # - te0 (lam - 1) r_b2 cos(beta_b): zero on an involute flank, on a tip edge held at its value
            # at the linearisation (J, the derivative of a, is the flank lever's)
            lam, lev2 = self._levers(S)
            te0 = S.te_unloaded[None, :, None]
            te0 = np.where(np.isfinite(te0), te0, 0.0)
            da = np.where(S.active, -(S.te - te0) * (lev2 - lever) - te0 * (lam - 1.0) * lever, 0.0)
            a = np.where(S.active, -S.te * lever, 0.0)
            P = len(self.free)
            out.append({"S": S, "st": st, "a": a, "J": J[..., :P], "Jm": J[..., P:], "Jr": Jr, "mis": mis,
                        "lam": lam, "da": da})
        return out

    def _levers(self, S) -> tuple[np.ndarray, np.ndarray]:
        """Per slice (K, N, M): ``lam`` = its lever about the pinion axis over ``r_b1 cos(beta_b)`` and its
        lever about the gear axis [mm] (``SliceSet.lever1/2``; the involute's where missing)."""
        cb = self.ltca.cos_bb
        lever = self.pair.gear.r_b * cb
        ok = S.active
        lam = (np.ones(S.z.shape) if S.lever1 is None
               else np.where(ok & np.isfinite(S.lever1), S.lever1 / (self.pair.pinion.r_b * cb), 1.0))
        lev2 = (np.full(S.z.shape, lever) if S.lever2 is None
                else np.where(ok & np.isfinite(S.lever2), S.lever2, lever))
        return lam, lev2

    # -- the NLP --------------------------------------------------------------------------------
    def _keep(self, lin, sweeps, radius: float) -> list:
        """Per case (T, K, N, M): the active slices the NLP holds at each torque. A slice is left out
        when it stays open for every design within ``radius`` of the linearisation: its separation,
        lowered by the most the design can change it there (``sum_j |J_ij| radius``, twice over), still
        exceeds 1.5 times the largest loaded approach of its case and torque plus the edge margin. The
        trust-region loop evaluates every trial design exactly, so a slice that would close anyway shows
        as a model miss there."""
        out = []
        margin = self.edge_margin or 0.0
        for L, sw in zip(lin, sweeps):
            S = L["S"]
            reach = (2.0 * radius * np.sum(np.abs(L["J"]), axis=-1) if np.isfinite(radius)
                     else np.full(S.z.shape, np.inf))  # no radius: every active slice stays
            keep = []
            for r in sw.results:
                s = (r.te_unloaded[None, :, None] - S.te) * self._levers(S)[1]
                bound = 1.5 * float(np.nanmax(r.delta)) + margin
                with np.errstate(invalid="ignore"):
                    keep.append(S.active & ~(s - reach > bound))
            out.append(np.array(keep))
        return out

    def _nlp(self, lin, theta_k, keep=None, radius: float = np.inf):
        """Build the duty-cycle NLP around the linearisation ``lin`` (module docstring).

        With the analytical compliance the deflections ``w`` [um] of every slice node are unknowns too,
        tied to the loads by the sparse stiffness form of the face coupling (``A (w / D) = cos^2(beta_b) D F``,
        A tridiagonal, docs/ltca.md section 2), so the NLP's Jacobian grows with the slice count and not
        its square; with FE influence coefficients the dense compliance blocks enter the gaps."""
        g1 = self.pair.pinion
        cb = self.ltca.cos_bb
        lever = self.pair.gear.r_b * cb
        mat = self.material
        T, C = self.torques.size, len(self.cases)
        P = len(self.free)
        Wt = self.torques * 1e3 / (g1.r_b * cb)
        sparse = self.ltca.compliance == "analytical"
        lam = self.ltca.coupling_length
        trip_C = ([], [], [])  # dense compliance (FE): gap rows x load columns [mm/N]
        trip_A = ([], [], [])  # stiffness rows x deflection columns
        trip_D = ([], [], [])  # stiffness rows x load-share columns
        w_of_x = []  # deflection unknown of each slice (sparse path)
        w_keys = []  # (torque, case, position, flat slice index) of each deflection unknown
        a0, Jx, Jmx, ln, Rx, h1x, h2x, edge, tix, blk, keys, tipe = [], [], [], [], [], [], [], [], [], [], [], []
        lamx = []  # each slice's lever about the pinion axis over r_b1 cos(beta_b)
        egx, near = [], []  # the edge weight's gradient (design, misalignment) and the rows it may reach
        blocks = []  # (t, c, n, first x, count)
        nx = nw = 0
        for c, L in enumerate(lin):
            S, st = L["S"], L["st"]
            K, N, M = S.z.shape
            acts = [np.transpose(S.active if keep is None else keep[c][t], (1, 0, 2)).reshape(N, K * M)
                    for t in range(T)]
            flat = lambda v: np.transpose(v, (1, 0, 2)).reshape(N, K * M)  # noqa: E731
            a_n, l_n, R_n, h1_n, h2_n = (flat(v) for v in (L["a"], st["length"], st["R"], st["h1"], st["h2"]))
            lam_n = flat(L["lam"])
            a_n = a_n + flat(L["da"])
            J_n = np.transpose(L["J"], (1, 0, 2, 3)).reshape(N, K * M, P)
            Jm_n = np.transpose(L["Jm"], (1, 0, 2, 3)).reshape(N, K * M, -1)
            e0, eg = _edge_weight_lin(S, self.pair, L["Jr"])
            e_n = flat(e0)
            eg_n = np.transpose(eg, (1, 0, 2, 3)).reshape(N, K * M, -1)
            # a flank slice joins the edge rows when the band can reach it within the radius
            span = np.minimum(2.0 * radius, self.hi - self.lo) if np.isfinite(radius) else self.hi - self.lo
            reach_n = np.sum(np.abs(eg_n[..., :P]) * span, axis=-1)
            tp_n = flat(np.zeros(S.z.shape, bool) if S.edge is None else S.edge > 0)
            if sparse:
                Acoup = coupling_stiffness_batch(S.z.reshape(K * N, M), S.width_tooth.reshape(K * N, M),
                                                 lam).reshape(K, N, M, M)
                Dn = np.sqrt(st["ct"])
            for t in range(T):
                act = acts[t]
                for n in range(N):
                    A = np.flatnonzero(act[n])
                    cnt = A.size
                    pos = {int(i): nx + j for j, i in enumerate(A)}
                    if sparse:
                        wi = np.full(cnt, -1)
                        for k in range(K):
                            U = np.flatnonzero(np.isfinite(S.z[k, n]))
                            if not any((k * M + m) in pos for m in U):
                                continue
                            Ak = Acoup[k, n][np.ix_(U, U)]
                            Dk = Dn[k, n, U]
                            rows = nw + np.arange(U.size)
                            w_keys.append(np.stack([np.full(U.size, t), np.full(U.size, c), np.full(U.size, n),
                                                    k * M + U], axis=1))
                            ii, jj = np.nonzero(Ak)
                            # row i: sum_j A_ij (D_i / D_j) w_j - cos^2(beta_b) D_i^2 W x_i / G_REF = 0
                            trip_A[0].append(rows[ii])
                            trip_A[1].append(rows[jj])
                            trip_A[2].append(Ak[ii, jj] * Dk[ii] / Dk[jj])
                            for j, m in enumerate(U):
                                q = pos.get(int(k * M + m))
                                if q is not None:
                                    trip_D[0].append([rows[j]])
                                    trip_D[1].append([q])
                                    trip_D[2].append([cb**2 * Dk[j] ** 2 * Wt[t] / G_REF])
                                    wi[q - nx] = rows[j]
                            nw += U.size
                        w_of_x.append(wi)
                    else:
                        Cb = st["Cs"][n][np.ix_(A, A)]
                        ii, jj = np.nonzero(Cb)
                        trip_C[0].append(ii + nx)
                        trip_C[1].append(jj + nx)
                        trip_C[2].append(Cb[ii, jj])
                    a0.append(a_n[n, A])
                    lamx.append(lam_n[n, A])
                    Jx.append(J_n[n, A])
                    Jmx.append(Jm_n[n, A])
                    ln.append(l_n[n, A])
                    Rx.append(R_n[n, A])
                    h1x.append(h1_n[n, A])
                    h2x.append(h2_n[n, A])
                    edge.append(e_n[n, A])
                    egx.append(eg_n[n, A])
                    near.append(e_n[n, A] + reach_n[n, A] > 0)
                    tipe.append(tp_n[n, A])
                    tix.append(np.full(cnt, t))
                    blk.append(np.full(cnt, len(blocks)))
                    keys.append(np.stack([np.full(cnt, t), np.full(cnt, c), np.full(cnt, n), A], axis=1))
                    blocks.append((t, c, n, nx, cnt))
                    nx += cnt
        a0, Jx, Jmx, ln, Rx, h1x, h2x, lamx = (np.concatenate(v) for v in (a0, Jx, Jmx, ln, Rx, h1x, h2x, lamx))
        ew, tix, blk, keys, tipe, egx, near = (np.concatenate(v) for v in (edge, tix, blk, keys, tipe, egx, near))
        edge = near  # rows of the edge-loading constraint; the pressure limit holds on every non-tip-edge slice
        nB = len(blocks)

        def triplet(tr, n_rows, n_cols):
            cat = lambda v: np.concatenate(v).astype(int).tolist() if v else []  # noqa: E731
            return ca.DM.triplet(cat(tr[0]), cat(tr[1]), ca.DM(np.concatenate(tr[2]) if tr[2] else np.zeros(0)),
                                 n_rows, n_cols)

        Ex_t = ca.DM.triplet(list(range(nx)), tix.tolist(), ca.DM.ones(nx), nx, T)  # x -> torque
        Ex_b = ca.DM.triplet(list(range(nx)), blk.tolist(), ca.DM.ones(nx), nx, nB)  # x -> block
        ct = np.array([b[0] * C + b[1] for b in blocks])
        Eb_ct = ca.DM.triplet(list(range(nB)), ct.tolist(), ca.DM.ones(nB), nB, T * C)
        # unknowns (scaled): design [um], loads x [share], gaps y [um], approach d [um], TE bounds, slacks,
        # and (analytical compliance) the deflections w [um] of every slice node
        th = ca.MX.sym("theta_um", P)
        x = ca.MX.sym("x", nx)
        y = ca.MX.sym("y", nx)
        d = ca.MX.sym("d", nB)
        u = ca.MX.sym("te_hi", T * C)
        v = ca.MX.sym("te_lo", T * C)
        sp = ca.MX.sym("slack_p", T * C)
        se = ca.MX.sym("slack_e", T * C)
        w = ca.MX.sym("w", nw)
        plim = ca.MX.sym("p_limit")
        marg = ca.MX.sym("edge_margin_um")
        mu = ca.MX.sym("mu")
        rho = ca.MX.sym("rho")
        # parameters of the sensitivities (:meth:`sensitivities`): each torque's scale (1: the duty
        # cycle's) and a misalignment added to every case (Misalignment.names() order, rad / mm)
        tq = ca.MX.sym("torque_scale", T)
        dm = ca.MX.sym("mis_offset", Jmx.shape[1])
        W = ca.mtimes(Ex_t, ca.DM(Wt) * tq)
        F = x * W
        f = F / ln
        fmin = F_MIN_SHARE * W * cb / g1.b
        fl = ca.sqrt(f**2 + fmin**2)
        bH = ca.sqrt(4.0 * fl * Rx / (math.pi * mat.E_star))
        nu = mat.nu
        cH = 2.0 * (1.0 - nu**2) / (math.pi * mat.E) * (ca.log(2.0 * h1x / bH) + ca.log(2.0 * h2x / bH)
                                                        - nu / (1.0 - nu))
        dth = th * 1e-3 - ca.DM(theta_k)
        gap = ((ca.DM(a0) + ca.mtimes(ca.DM(Jx), dth) + ca.mtimes(ca.DM(Jmx), dm) + cH * f) / G_REF
               - ca.DM(lamx) * ca.mtimes(Ex_b, d))
        g_list = []
        if sparse:
            wi = np.concatenate(w_of_x)
            gap = gap + w[wi.tolist()]
            w_t = np.concatenate(w_keys)[:, 0]
            E_wt = ca.DM.triplet(list(range(nw)), w_t.tolist(), ca.DM.ones(nw), nw, T)  # w row -> torque
            g_list.append(ca.mtimes(triplet(trip_A, nw, nw), w) - ca.mtimes(triplet(trip_D, nw, nx), x)
                          * ca.mtimes(E_wt, tq))
        else:
            gap = gap + ca.mtimes(triplet(trip_C, nx, nx), F) / G_REF
        fb = x + y - ca.sqrt(x**2 + y**2 + 2 * mu)  # zero where x >= 0, y >= 0, x y = mu
        te = -d * G_REF / lever * RAD_TO_ARCSEC  # (nB) loaded TE [arcsec] (up to each case's constant)
        g_list += [y - gap, fb, ca.mtimes(Ex_b.T, ca.DM(lamx) * x) - 1.0, ca.mtimes(Eb_ct, u) - te,
                   te - ca.mtimes(Eb_ct, v)]
        n_eq = (nw if sparse else 0) + 2 * nx + nB
        lbg = [np.zeros(n_eq), np.zeros(2 * nB)]
        ubg = [np.zeros(n_eq), np.full(2 * nB, np.inf)]
        ct_x = ct[blk]
        flank = np.flatnonzero(~tipe)
        ends = np.flatnonzero(edge)
        if self.p_limit is not None and flank.size:
            # p0^2 = f E* / (pi R*) <= p_limit^2, per flank slice, relative
            k = mat.E_star / (math.pi * Rx[flank] * ln[flank])
            E_f = ca.DM.triplet(list(range(flank.size)), ct_x[flank].tolist(), ca.DM.ones(flank.size), flank.size,
                                T * C)
            g_list.append(x[flank.tolist()] * W[flank.tolist()] * ca.DM(k) / plim**2 - 1.0 - ca.mtimes(E_f, sp))
            lbg.append(np.full(flank.size, -np.inf))
            ubg.append(np.zeros(flank.size))
        if self.edge_margin is not None and ends.size:
            E_e = ca.DM.triplet(list(range(ends.size)), ct_x[ends].tolist(), ca.DM.ones(ends.size), ends.size, T * C)
            # a gap of at least the margin is, with x y = mu, a load share of at most mu / margin: the
            # constraint is stated in the load (the smoothed complementarity pins the gap of a loaded slice
            # to first order, so a gap bound would leave no direction that opens it)
            # the weight of a flank slice in the tip band moves with its point (linearised; negative:
            # below the band, where the row holds for any load)
            w_e = ca.DM(ew[ends]) + ca.mtimes(ca.DM(egx[ends, :P]), dth) + ca.mtimes(ca.DM(egx[ends, P:]), dm)
            g_list.append(w_e * x[ends.tolist()] - mu / marg - ca.mtimes(E_e, se))
            lbg.append(np.full(ends.size, -np.inf))
            ubg.append(np.zeros(ends.size))
        te0 = self._te0_blocks(lin, radius, lever) if self.te_level is not None else None
        n0 = nB0 = 0
        te0_vars = []
        if te0 is not None:
            # the unloaded TE (zero load: no compliance, no Hertz flattening) of the pair centred on each
            # position, by the same smoothed complementarity: its approach d0 is the smallest separation
            # of the pair's slices to O(MU) (a sampled min would not be smooth); appended at the end of the
            # unknowns and rows, so the loaded NLP's indices stay as they are
            n0, nB0 = te0["a"].size, len(te0["blocks"])
            x0s, y0s, d0s = (ca.MX.sym(k, n) for k, n in (("x0", n0), ("y0", n0), ("d0", nB0)))
            te0_vars = [x0s, y0s, d0s]
            E0 = ca.DM.triplet(list(range(n0)), te0["blk"].tolist(), ca.DM.ones(n0), n0, nB0)
            gap0 = ((ca.DM(te0["a"]) + ca.mtimes(ca.DM(te0["J"]), dth) + ca.mtimes(ca.DM(te0["Jm"]), dm)) / G_REF
                    - ca.mtimes(E0, d0s))
            g_list += [y0s - gap0, x0s + y0s - ca.sqrt(x0s**2 + y0s**2 + 2 * mu), ca.mtimes(E0.T, x0s) - 1.0]
            lbg.append(np.zeros(2 * n0 + nB0))
            ubg.append(np.zeros(2 * n0 + nB0))
            # misfit of each block's unloaded TE [arcsec] to the case's parabola c0 + c1 psi - level psi^2
            # (Litvin's predesigned function, as synthesis/crowning.py), c0 and c1 by least squares: the
            # residual is the projection of te0 + level psi^2 off the span of (1, psi), one matrix per
            # case (no fit unknowns: free c0, c1 in the NLP let IPOPT diverge along the null direction
            # they share with the approaches); its RMS per case smoothed at 0
            te_b = -d0s * G_REF / lever * RAD_TO_ARCSEC + self.te_level * RAD_TO_ARCSEC * ca.DM(te0["psi"]) ** 2
            rows, cols, vals = [], [], []
            for c in range(C):
                k = np.flatnonzero(te0["case"] == c)
                V = np.stack([np.ones(k.size), te0["psi"][k]], axis=1)
                Pc = (np.eye(k.size) - V @ np.linalg.pinv(V)) / math.sqrt(k.size)  # residual / sqrt(n)
                ii, jj = np.meshgrid(k, k, indexing="ij")
                rows.append(ii.ravel())
                cols.append(jj.ravel())
                vals.append(Pc.ravel())
            res = ca.mtimes(_sparse_dm(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), nB0, nB0), te_b)
            Ec = ca.DM.triplet(list(range(nB0)), te0["case"].tolist(), ca.DM.ones(nB0), nB0, C)
            ms = ca.mtimes(Ec.T, res**2)
            te0_obj = self.te_weight * ca.dot(ca.DM(self.weights.sum(axis=0)), ca.sqrt(ms + TE0_EPS**2))
        wv = ca.DM(self.weights.ravel())  # (T, C) row-major: index t * C + c
        hmap = self._harmonic_map(blocks, nB)
        if hmap is None:
            fit = ca.dot(wv, u - v)
        else:  # weighted amplitudes of the first mesh harmonics (smooth: sqrt(a^2 + b^2 + eps^2))
            ab = ca.mtimes(hmap, te)
            H = self.harmonics.size
            a2 = ab[0::2] ** 2 + ab[1::2] ** 2
            amp_w = ca.DM(np.repeat(self.weights.ravel(), H) * np.tile(self.harmonics, T * C))
            fit = ca.dot(amp_w, ca.sqrt(a2 + HARM_EPS**2))
        mult = ca.DM(self._mult.ravel())  # (T C): cases standing for their mirror images count twice
        obj = fit + rho * self._w_mean * ca.dot(mult, sp + se)
        if te0 is not None:
            obj = obj + te0_obj
        z = ca.vertcat(th, x, y, d, u, v, sp, se, w, *te0_vars)
        nlp = {"x": z, "p": ca.vertcat(plim, marg, mu, rho, tq, dm), "f": obj, "g": ca.vertcat(*g_list)}
        # the start is the exact loaded TCA of the linearisation's design, close to the optimum: IPOPT's
        # adaptive barrier from mu = 0.01 (the target case 647 -> 529 iterations, 10 % faster, than the
        # monotone barrier from 0.01; docs/loaded_synthesis.md section 5). (Without IPOPT's gradient
        # scaling some rounds took 2-6x fewer iterations, but the smallest design derivatives of the
        # sensitivities lost their accuracy.)
        opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-9,
                "ipopt.max_iter": 1000, "ipopt.mu_strategy": "adaptive", "ipopt.mu_init": 1e-2, "error_on_fail": False,
                **getattr(self, "_extra_opts", {})}
        sizes = dict(P=P, nx=nx, nB=nB, TC=T * C, nw=nw, n0=n0, nB0=nB0)
        rows = dict(flank=flank if self.p_limit is not None else flank[:0],
                    ends=ends if self.edge_margin is not None else ends[:0])
        return _NLP(problem=nlp, opts=opts, phi1=self.phi1.copy(), rows=rows, gap=ca.Function("gap", [z, tq, dm], [gap]), lbg=np.concatenate(lbg),
                    ubg=np.concatenate(ubg), sizes=sizes, blocks=blocks, ct=ct, edge=tipe, ew=np.clip(ew, 0.0, 1.0),
                    lever=lever, Wt=Wt,
                    ln=ln, Rx=Rx, keys=keys, hmap=hmap, w_keys=np.concatenate(w_keys) if w_keys else np.zeros((0, 4), int),
                    te0=te0, te0_term=ca.Function("te0_term", [z], [te0_obj if te0 is not None else ca.MX(0.0)],
                                                  ["z"], ["te0_term"]))

    def _te0_blocks(self, lin, radius: float, lever: float) -> dict:
        """The unloaded-TE target's slices in the NLP: per case and position, the active slices of the
        pair centred there (:meth:`_te0_pairs`) that may become its contact within ``radius`` of the
        linearisation (separation lowered by ``2 radius sum_j |J_ij|`` not above the smallest
        separation raised by its own; every active slice without a radius). Arrays ``a`` [mm], ``J``,
        ``Jm`` of the slices; ``blk`` (block of each slice), ``blocks`` (c, n, first, count), ``case``,
        ``psi`` (pair angle over pi/z1) per block, ``keys`` (T, c, n, flat slice) per slice."""
        T = self.torques.size
        out = {k: [] for k in ("a", "J", "Jm", "blk", "case", "psi", "keys")}
        blocks, first = [], 0
        for c, L in enumerate(lin):
            S = L["S"]
            K, N, M = S.z.shape
            idx, psi = self._te0_pairs(S)
            reach = 2.0 * radius * np.sum(np.abs(L["J"]), axis=-1) if np.isfinite(radius) else None
            used = 0
            for n in range(N):
                i = idx[n]
                if i < 0 or not S.active[i, n].any():
                    continue
                m = np.flatnonzero(S.active[i, n])
                if reach is not None:
                    s = (np.max(S.te[i, n, m]) - S.te[i, n, m]) * lever
                    r = reach[i, n, m]
                    m = m[s - r <= np.min(s + r)]
                out["a"].append(L["a"][i, n, m])
                out["J"].append(L["J"][i, n, m])
                out["Jm"].append(L["Jm"][i, n, m])
                out["blk"].append(np.full(m.size, len(blocks)))
                out["keys"].append(np.stack([np.full(m.size, T), np.full(m.size, c), np.full(m.size, n), i * M + m], 1))
                out["case"].append(c)
                out["psi"].append(psi[n])
                blocks.append((c, n, first, m.size))
                first += m.size
                used += 1
            self._te0_enough(used, N, c)
        res = {k: np.concatenate(v) for k, v in out.items() if k not in ("case", "psi")}
        res.update(case=np.array(out["case"], int), psi=np.array(out["psi"]), blocks=blocks)
        return res

    def _start(self, nlp, lin, theta_k, sw):
        """Initial point: the exact loaded TCA of the linearisation's design (its loads, deflections and
        approach), with the smoothed complementarity x y = MU made to hold."""
        P, nx, nB, TC, nw = (nlp["sizes"][k] for k in ("P", "nx", "nB", "TC", "nw"))
        x0 = np.zeros(nx)
        d0 = np.zeros(nB)
        w0 = np.zeros(nw)
        lever = nlp["lever"]
        CF = {}
        for b, (t, c, n, first, cnt) in enumerate(nlp["blocks"]):
            S = lin[c]["S"]
            K, N, M = S.z.shape
            r = sw[c].results[t]
            A = nlp["keys"][first:first + cnt, 3]
            Ff = np.transpose(r.load, (1, 0, 2)).reshape(N, K * M)[n]
            x0[first:first + cnt] = Ff[A] / r.W
            CF[(t, c, n)] = lin[c]["st"]["Cs"][n] @ Ff / G_REF
            # delta' = delta - te0 lever (absolute separations a = -te lever)
            d0[b] = (r.delta[n] - r.te_unloaded[n] * lever) / G_REF
        for j, (t, c, n, i) in enumerate(nlp["w_keys"]):
            w0[j] = CF[(t, c, n)][i]
        te = -d0 * G_REF / lever * RAD_TO_ARCSEC
        u0 = np.full(TC, -np.inf)
        v0 = np.full(TC, np.inf)
        np.maximum.at(u0, nlp["ct"], te)
        np.minimum.at(v0, nlp["ct"], te)
        z0 = np.concatenate([np.asarray(theta_k) * 1e3, x0, np.ones(nx), d0, u0, v0, np.zeros(2 * TC), w0,
                             self._te0_start(nlp["te0"], lever) if nlp["te0"] is not None else []])
        gap = np.asarray(nlp["gap"](z0, np.ones(self.torques.size), np.zeros(len(Misalignment.names())))).ravel()
        loaded = x0 > 1e3 * MU
        y0 = np.where(loaded, MU / np.maximum(x0, 1e-300), np.maximum(gap, 1e-3))
        x0 = np.where(loaded, x0, MU / y0)
        z0[P:P + nx] = x0
        z0[P + nx:P + 2 * nx] = y0
        # slacks that make the start feasible for the pressure and edge constraints
        ct_x = np.repeat(nlp["ct"], [b[4] for b in nlp["blocks"]])
        s_p = np.zeros(TC)
        s_e = np.zeros(TC)
        if self.p_limit is not None:
            W = nlp["Wt"][np.repeat([b[0] for b in nlp["blocks"]], [b[4] for b in nlp["blocks"]])]
            p2 = np.where(nlp["edge"], 0.0, x0 * W * self.material.E_star / (math.pi * nlp["Rx"] * nlp["ln"]))
            np.maximum.at(s_p, ct_x, p2 / self.p_limit**2 - 1.0)
        if self.edge_margin is not None:
            np.maximum.at(s_e, ct_x, nlp["ew"] * x0 - MU * G_REF / self.edge_margin)
        z0[P + 2 * nx + nB + 2 * TC:P + 2 * nx + nB + 4 * TC] = np.concatenate([s_p, s_e]) * 1.01 + 1e-6
        return z0

    def _te0_start(self, te0, lever) -> np.ndarray:
        """Start of the unloaded-TE target's unknowns at the linearisation's design: each block's
        smallest separation carries the load, every other slice x = MU / y."""
        aa = te0["a"] / G_REF
        n0, nB0 = aa.size, len(te0["blocks"])
        x0, y0, d0 = np.zeros(n0), np.zeros(n0), np.zeros(nB0)
        for b, (_, _, first, cnt) in enumerate(te0["blocks"]):
            s = slice(first, first + cnt)
            y = aa[s] - np.min(aa[s])
            j = int(np.argmin(aa[s]))
            x = MU / np.maximum(y, 1e-3)
            x[j] = 1.0 - (np.sum(x) - x[j])
            d0[b] = np.min(aa[s]) - MU / x[j]
            y = aa[s] - d0[b]
            x = np.where(np.arange(cnt) == j, x[j], MU / y)
            x0[s], y0[s] = x, y
        return np.concatenate([x0, y0, d0])

    def _bounds(self, nlp):
        P, nx, nB, TC, nw, n0, nB0 = (nlp["sizes"][k] for k in ("P", "nx", "nB", "TC", "nw", "n0", "nB0"))
        free = 2 * nx + nB + 2 * TC
        tail = nw + 2 * n0 + nB0  # deflections and the unloaded-TE target's unknowns: free
        lbx = np.concatenate([self.lo * 1e3, np.full(free, -np.inf), np.zeros(2 * TC), np.full(tail, -np.inf)])
        ubx = np.concatenate([self.hi * 1e3, np.full(free, np.inf), np.full(2 * TC + tail, np.inf)])
        return lbx, ubx

    def solve(self, progress=None, start=None, grid=None) -> MicroDesign:
        """Optimise and verify (docs/loaded_synthesis.md); ``start``: the first design [mm] (default
        the pair's own, which stays the "before" design); ``grid``: the NLP's first positions [rad]
        (default ``n_positions`` over the mesh cycle).

        The trust-region loop (:meth:`_trust_region`) optimises on the NLP's grid of positions. The
        optimum is then checked by the exact loaded TCA on the verification grid (``n_verify``
        positions); where that shows edge loading or a pressure above the limit between the NLP's
        positions, those positions join the NLP's grid and the loop goes on from the optimum (at most
        ``MAX_REFINE`` times)."""
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
        rho = RHO
        for refine in range(MAX_REFINE + 1):
            red.phi1 = self.phi1
            # (a refinement goes on from the optimum with the penalty weight the last pass needed)
            theta, cur, pred, it, status, rho, stop = red._trust_region(theta, rounds, progress, rho)
            iters += it
            after = self.check(theta, fine)
            add = self._violated_positions(after, fine)
            add = add[~np.any(np.isclose(add[:, None], self.phi1[None, :], rtol=0.0, atol=1e-12), axis=1)]
            if not add.size:
                break
            if refine == MAX_REFINE:
                raise SynthesisError(
                    f"loaded micro-geometry: the optimum on {self.phi1.size} positions per cycle still loads an edge "
                    f"or exceeds the pressure limit at {add.size} of the {self.n_verify} verification positions after "
                    f"{MAX_REFINE} refinements; raise n_positions.", param="n_positions", value=self.phi1.size)
            self.phi1 = np.sort(np.concatenate([self.phi1, add]))
            if progress:
                progress(f"loaded micro-geometry: {add.size} verification positions load an edge or exceed the pressure "
                         f"limit between the NLP's positions; the NLP's grid grows to {self.phi1.size}")
        ver = cur["check"]  # the exact loaded TCA of the final design (LTCA.solve on its own slices)
        if red is not self:  # every case, and the NLP's prediction of each mirror image by its twin's
            # (the loop's own loaded TCA of the final design is that of one case per class: the others
            # are solved here)
            ver = self.check(theta, known={k[0]: sw for k, sw in zip(classes, ver.sweeps)})
            pred = {k: (v[:, of] if isinstance(v, np.ndarray) and v.ndim == 2 else v) for k, v in pred.items()}
            if "te0_rms" in pred:
                pred["te0_rms"] = pred["te0_rms"][of]
                pred["te0_term"] = self._te0_term(pred["te0_rms"])
        err = {"te_pp": float(np.max(np.abs(pred["te_pp"] - ver.te_pp))),
               "objective": abs(pred["objective"] - ver.objective)}
        if self.p_limit is not None:
            err["p_max"] = float(np.max(np.abs(pred["p_max"] - ver.p_max)))
        if self.te_level is not None:
            err["te0_rms"] = float(np.max(np.abs(pred["te0_rms"] - ver.te0_rms)))
        before = self.check(self.theta0, fine)
        return MicroDesign(theta=dict(zip(self.free, theta.tolist())), theta0=dict(zip(self.free, self.theta0.tolist())),
                           predicted=pred, verified=ver, error=err, before=before, after=after, rounds=rounds,
                           iterations=iters, time=time.perf_counter() - t_start, status=status, stop=stop,
                           binding=self._binding(theta, pred, ver), rho=rho, phi1=self.phi1.copy())

    def pareto(self, p_limits, progress=None, anchor: MicroDesign | None = None) -> ParetoFront:
        """Loaded TE against peak pressure: the epsilon-constraint sweep of the pressure limit.

        The anchor is the optimum without a pressure limit; then each limit of ``p_limits`` [MPa]
        (taken in decreasing order) is solved from the previous optimum, with the edge-loading
        constraint and everything else of this optimiser. Every point is verified by loaded TCA on the
        verification grid (:meth:`solve`). A limit no design within the bounds meets (with the
        edge-loading constraint; solved from the previous optimum and again from the start design)
        ends the sweep: it and every lower limit get no design and the reason.
        Where a tighter limit's optimum has the lower loaded TE (the looser one stopped in a local
        optimum), the looser limit is solved again from it, so the front is monotone.

        Parameters
        ----------
        p_limits : sequence of float
            Peak Hertz pressure limits [MPa], each 100 ... 10000, distinct.
        progress : callable, optional
            Takes one line of text per trust-region round and per point.
        anchor : MicroDesign, optional
            The optimum without a pressure limit, if already solved (by this optimiser with
            ``p_limit=None``): not solved again.

        Returns
        -------
        ParetoFront
        """
        try:
            lims = sorted((float(v) for v in p_limits), reverse=True)
        except (TypeError, ValueError):
            raise out_of_range("p_limits", p_limits, "a list of pressure limits [MPa]", cls=OptionError) from None
        if not lims or len(set(lims)) != len(lims) or not all(math.isfinite(v) and 100.0 <= v <= 1e4 for v in lims):
            raise out_of_range("p_limits", p_limits, "a non-empty list of distinct limits, 100 ... 10000 MPa each",
                               cls=OptionError)

        def at(limit):
            o = copy.copy(self)  # shares the compiled slices, the LTCA and the sensitivities
            o.p_limit = limit
            return o

        say = progress or (lambda m: None)
        first = at(None)
        if anchor is None:
            anchor = first.solve(progress=progress)
            grid = first.phi1  # with the positions the verification added: the next points start there
        else:
            if self.p_limit is not None:
                raise ArgumentError("anchor: given for an optimiser with a pressure limit; the anchor is the "
                                    "optimum without one (p_limit=None).", param="anchor", value=self.p_limit,
                                    valid="an optimiser with p_limit=None")
            grid = self.phi1
        say(f"loaded micro-geometry Pareto: no pressure limit: {anchor.after.objective:.4g} arcsec at "
            f"{np.max(anchor.after.p_max):.1f} MPa")
        designs, msgs = [], []
        theta = np.array(list(anchor.theta.values()))
        for lim in lims:
            if designs and designs[-1] is None:
                designs.append(None)
                msgs.append(f"not solved: a higher limit ({lims[len(designs) - 2]:g} MPa) has no design")
                continue
            o = at(lim)
            d = None
            # from the previous optimum; where that finds no design, once more from the start design (a
            # local method: the sweep's path may end in a corner the start design is not in)
            for start in (theta, self.theta0):
                if d is not None or (start is self.theta0 and np.allclose(theta, self.theta0)):
                    continue
                try:
                    d = o.solve(progress=progress, start=start, grid=grid)
                except SynthesisError as e:
                    if getattr(e, "param", None) not in ("p_limit", "edge_margin"):
                        raise  # a solver failure, not an infeasible limit
                    err = e
                    o = at(lim)
            if d is None:
                designs.append(None)
                msgs.append(f"{err} (solved from the previous optimum and from the start design)")
                say(f"loaded micro-geometry Pareto: p_limit {lim:g} MPa: no design ({err})")
                continue
            designs.append(d)
            msgs.append("")
            theta, grid = np.array(list(d.theta.values())), o.phi1
            say(f"loaded micro-geometry Pareto: p_limit {lim:g} MPa: {d.after.objective:.4g} arcsec at "
                f"{np.max(d.after.p_max):.1f} MPa")
        # A design meeting a limit meets every looser one: where a tighter limit's optimum has the lower
        # loaded TE, the looser limit's (a local optimum) is solved again from it, tightest first, so
        # the front comes out monotone.
        solved = [(None, anchor)] + [(lim, d) for lim, d in zip(lims, designs) if d is not None]
        for i in range(len(solved) - 2, -1, -1):
            lim, d = solved[i]
            better = solved[i + 1][1]
            # (with an unloaded-TE target its term counts too: the objective the designs minimise)
            tot = lambda m: m.after.objective + m.after.te0_term  # noqa: E731
            if tot(better) < tot(d) - 1e-3 * max(tot(d), 1.0):
                o = at(lim)
                d2 = o.solve(progress=progress, start=np.array(list(better.theta.values())), grid=grid)
                if tot(d2) < tot(d):
                    solved[i] = (lim, d2)
                    what = "no pressure limit" if lim is None else f"p_limit {lim:g} MPa"
                    say(f"loaded micro-geometry Pareto: {what}: solved again from the tighter limit's optimum: "
                        f"{d.after.objective:.4g} -> {d2.after.objective:.4g} arcsec")
        anchor = solved[0][1]
        again = {lim: d for lim, d in solved[1:]}
        designs = [again.get(lim) if d is not None else None for lim, d in zip(lims, designs)]
        return ParetoFront(anchor=anchor, p_limits=tuple(lims), designs=tuple(designs), messages=tuple(msgs))

    def sensitivities(self, design: MicroDesign) -> dict:
        """Sensitivities of the optimum to the torques and to a misalignment added to every case
        (docs/loaded_synthesis.md section 6): :meth:`kkt_sensitivities` of the duty cycle, or where its
        cases are mirror images of each other (:meth:`mirror_classes`) of the problem with one case per
        class, with each mirror-odd kind's derivatives by symmetry.

        Mirror-image cases make the full problem's active-set KKT system singular: each active row of
        a case has its twin's, and the twins' rows differ only in their own loads. The problem of one
        case per class is the full one for every perturbation that keeps the twins mirror images: the
        torques and the mirror-even kinds (``MIRROR_SIGN`` +1: the centre distance), whose derivatives
        it gives. An offset of a mirror-odd kind (crossing, intersecting, axial) added to every case
        breaks the pairing, but the duty cycle offset by ``-d`` is the mirror image of that offset by
        ``d``, so the optimum (symmetric amounts only, :meth:`mirror_classes`) is an even function of
        ``d``: its central derivative, and the objective's, are zero. (A kink there, an active set that
        changes at ``d = 0``, would give one-sided derivatives of opposite signs; they are not
        computed: ``benchmarks/loaded_sensitivity_fd.py`` measures them by re-solved optima.)

        Returns
        -------
        dict
            As :meth:`kkt_sensitivities`, and ``mirror_odd``: the kinds whose derivatives are zero by
            the mirror symmetry (empty without mirror-image cases).
        """
        classes = self.mirror_classes()
        if classes is None:
            return {**self.kkt_sensitivities(design), "mirror_odd": []}
        out = self._reduced().kkt_sensitivities(design)
        kinds = Misalignment.names()
        odd = [j for j, k in enumerate(kinds) if MIRROR_SIGN[k] < 0]
        out["d_theta_d_mis"][:, odd] = 0.0
        out["d_objective_d_mis"][odd] = 0.0
        out["mirror_odd"] = [kinds[j] for j in odd]
        return out

    def kkt_sensitivities(self, design: MicroDesign) -> dict:
        """Sensitivities of the optimum to the torques and to a misalignment, by AD (docs/loaded_synthesis.md),
        of this optimiser's own cases (:meth:`sensitivities` handles mirror-image cases).

        The NLP is built around ``design`` (its final positions, every active slice) with the torque
        scales and a misalignment offset added to every case as parameters, and solved with the design
        free within its bounds. The derivatives are those of the exact NLP (the limit mu -> 0 of IPOPT's
        barrier) at its active set, by CasADi: which inequalities and bounds are active is read from
        the tangent of IPOPT's central path at the solution (each slack's d log s / d log mu: 1 active,
        0 inactive, scale-free; rows between 0.1 and 0.9 are degenerate and counted); then the KKT
        system of the equalities and the active rows, with the inactive multipliers zero, is solved
        as one sparse system for all parameters (the optimum's derivatives at a fixed active set,
        Fiacco). The optimal objective's derivatives are those of the Lagrangian in the parameters
        (the envelope theorem).

        Returns
        -------
        dict
            ``d_objective_d_torque`` (T,) [arcsec per N m] and ``d_theta_d_torque`` (P, T) [mm per N m]
            (one torque of the duty cycle changed at a time); ``d_objective_d_mis`` (4,) and
            ``d_theta_d_mis`` (P, 4), per kind of ``Misalignment.names()`` [per rad or per mm],
            the same offset added to every case; ``model_step`` [mm]: how far the NLP's optimum lies
            from ``design`` (a converged design: below ``THETA_TOL``) and ``at_design`` (it is within
            ten times that: else the loop stopped on its trust radius and the derivatives are those
            of the NLP's optimum, not of the design); ``objective`` [arcsec]: the
            NLP's optimum (with an unloaded-TE target, its term included, and so in the derivatives
            of the objective); ``active``: the inequalities and bounds active at it; ``degenerate``: the
            active ones whose multiplier vanishes (below ``DEGENERATE_REL`` times the largest), and those
            neither clearly active nor inactive (0: the derivatives are unique; else they hold on the
            side of the active set chosen, each such row counted active when its indicator is above
            1/2); ``min_multiplier``: the smallest active multiplier over the largest;
            ``nlp`` / ``z`` / ``p``: the NLP, its solution and parameters (for checks).

        Raises
        ------
        SynthesisError
            When the NLP at the optimum fails, or the active set's KKT system is singular (dependent
            active constraints: the derivatives are not unique).
        """
        import scipy.sparse as sp_

        theta = np.array([design.theta[n] for n in self.free])
        if design.phi1 is not None:
            self.phi1 = np.asarray(design.phi1, float)
        cur = self._around(theta, np.inf, design.rho)
        nlp = cur["nlp"]
        # IPOPT without its bound relaxation (by default every bound moves out by 1e-8, the scale of
        # the edge rows' own allowance MU / margin): the slacks below are then IPOPT's own, and so are
        # the complementarity products the perturbed KKT system is built from
        nlp["solver"] = ca.nlpsol("loaded_microgeometry_kkt", "ipopt", nlp["problem"],
                                  {**nlp["opts"], "ipopt.bound_relax_factor": 0.0})
        lbx, ubx = self._bounds(nlp)
        p = np.array(self._pvec(design.rho), float)
        r = nlp["solver"](x0=cur["z0"], lbx=lbx, ubx=ubx, lbg=nlp["lbg"], ubg=nlp["ubg"], p=p)
        st = nlp["solver"].stats()
        if not st["success"]:
            raise SynthesisError(f"loaded micro-geometry sensitivities: the NLP at the optimum failed "
                                 f"({st['return_status']}).", param="ipopt", value=st["return_status"])
        z, lam_g, lam_x = (np.asarray(r[k]).ravel() for k in ("x", "lam_g", "lam_x"))
        pr = nlp["problem"]
        zs, ps, g, f = pr["x"], pr["p"], pr["g"], pr["f"]
        lam = ca.MX.sym("lam", g.shape[0])
        L = f + ca.dot(lam, g)
        sel = slice(4, ps.shape[0])  # the torque scales and misalignment offsets
        gz = ca.gradient(L, zs)
        fun = ca.Function("loaded_kkt", [zs, ps, lam],
                          [ca.hessian(L, zs)[0], g, ca.jacobian(g, zs), ca.jacobian(g, ps)[:, sel],
                           ca.jacobian(gz, ps)[:, sel], ca.gradient(L, ps)[sel]])
        H, gv, Jg, Gp, _, _ = fun(z, p, lam_g)
        H, Jg, Gp = _csc(H), _csc(Jg), _csc(Gp)
        gv = np.asarray(gv).ravel()
        lbg, ubg = nlp["lbg"], nlp["ubg"]
        eq = lbg == ubg
        I_ = np.flatnonzero(~eq)
        E = np.flatnonzero(eq)
        # which inequalities and bounds are active in the limit mu -> 0 of IPOPT's barrier (the edge
        # rows' slacks are of the order of MU / margin = 2e-8, and at IPOPT's final barrier parameter
        # their barrier multipliers are 0.05: lam / s or lam^2 / mu would count a thousand open slices as
        # nearly active; the central path's tangent is scale-free)
        ind_g, ind_x = central_path_indicators(H, Jg, lbg, ubg, gv, lam_g, lbx, ubx, z, lam_x)
        ind_g = ind_g[I_]
        bx = np.isfinite(ind_x)
        act_g, act_x = ind_g > 0.5, bx & (ind_x > 0.5)
        # degenerate: an active row or bound whose multiplier vanishes (strict complementarity fails; the
        # optimum is then only directionally differentiable), i.e. below DEGENERATE_REL times the largest
        # active multiplier, or one the central path cannot tell active from inactive
        degenerate, min_mult = degenerate_constraints(ind_g, lam_g[I_], ind_x, lam_x)
        # the limit's multipliers (inactive ones zero) and the active set's KKT system: the derivatives
        # of the optimum at fixed active set (Fiacco), one sparse LU for all parameters
        lam_a = lam_g.copy()
        lam_a[I_[~act_g]] = 0.0
        H, _, _, _, Lzp, Lp = fun(z, p, lam_a)
        H, Lzp = _csc(H), _csc(Lzp)
        rows = np.concatenate([E, I_[act_g]])
        B = np.flatnonzero(act_x)
        A = sp_.vstack([Jg[rows], sp_.csc_matrix((np.ones(B.size), (np.arange(B.size), B)), shape=(B.size, z.size))])
        K = sp_.bmat([[H, A.T], [A, None]], format="csc")
        rhs = -sp_.vstack([Lzp, Gp[rows], sp_.csc_matrix((B.size, Lzp.shape[1]))]).toarray()
        sol = _lu(K, "the active set's KKT system").solve(rhs)
        P, T = len(self.free), self.torques.size
        dth = sol[:P] * 1e-3  # theta is in um in the NLP
        dfdp = np.asarray(Lp).ravel()
        step = float(np.max(np.abs(z[:P] * 1e-3 - theta)))
        return {"d_objective_d_torque": dfdp[:T] / self.torques, "d_theta_d_torque": dth[:, :T] / self.torques[None, :],
                "d_objective_d_mis": dfdp[T:], "d_theta_d_mis": dth[:, T:],
                "model_step": step, "at_design": step <= 10 * THETA_TOL, "objective": float(r["f"]),
                "active": int(act_g.sum() + act_x.sum()), "degenerate": degenerate,
                "min_multiplier": min_mult,
                "nlp": nlp, "z": z, "p": p, "bounds": (lbx, ubx), "z0": cur["z0"]}

    def _violated_positions(self, chk: LoadedCheck, phi1) -> np.ndarray:
        """Positions of ``phi1`` where the exact loaded TCA ``chk`` loads an edge (a weighted slice load
        share above ``EDGE_TOL``) or exceeds the pressure limit, at any torque and case."""
        bad = np.zeros(phi1.size, bool)
        for sw in chk.sweeps:
            w = _edge_weight(sw.slices, self.pair)
            for r in sw.results:
                if self.edge_margin is not None:
                    bad |= np.max(w * r.load, axis=(0, 2)) / r.W > EDGE_TOL
                if self.p_limit is not None:
                    bad |= np.max(r.p0_flank, axis=(0, 2)) > self.p_limit * (1 + SLACK_TOL)
        return np.asarray(phi1)[bad]

    def _trust_region(self, theta, rounds: list, progress=None, rho: float = RHO):
        """Optimise and verify (module docstring).

        A trust-region loop of linearisations: the NLP around the design ``theta_k`` is solved with
        every amount within ``radius`` of ``theta_k``; the new design's slices are solved exactly and
        its loaded TCA gives the true objective. The step is accepted when the true objective falls by
        at least a tenth of what the NLP predicted (the radius doubles when the prediction was good
        and the step reached it), else the radius shrinks to a quarter of the step. It stops when the
        NLP's step is below ``THETA_TOL`` (the linearised optimum is the design itself: a stationary
        point of the exact problem, whose first derivatives the linearisation shares). Where the
        NLP's optimum, well inside the radius or at a stationary design, still needs a slack, the
        penalty weight grows tenfold (up to ``RHO_MAX``) and the same NLP is solved again. Where the
        NLP's optima of two accepted steps in a row needed a slack (the second's not tenfold smaller
        than the first's), the weight grows tenfold after the second step, for the next round.
        ``rho``: the first weight (a refinement of the grid starts from the weight the last pass ended
        with)."""
        p = self._pvec(rho)
        radius = TR_START * float(np.max(self.hi - self.lo))
        iters, status, pred, prev, stop = 0, "", None, None, "trust radius"
        last_viol = 0.0  # the model's constraint violation (relative, > 1: violated) at the last accepted step
        cur = self._around(theta, 2 * radius, rho)
        for rnd in range(MAX_ROUNDS):
            nlp = cur["nlp"]
            lbx, ubx = self._bounds(nlp)
            P = len(self.free)
            lbx[:P] = np.maximum(self.lo, theta - radius) * 1e3
            ubx[:P] = np.minimum(self.hi, theta + radius) * 1e3
            t1 = time.perf_counter()
            # from the last NLP's multipliers unless the radius grew (its step reached the region's
            # bound and the next optimum may lie far: there the cold start took 2-3x fewer iterations)
            warm = prev if prev is not None and prev[3] >= radius else None
            r, st, it = self._solve_nlp(nlp, cur["z0"], lbx, ubx, p, warm)
            status = st["return_status"]
            iters += it
            zs = np.asarray(r["x"]).ravel()
            new = np.clip(zs[:P] * 1e-3, self.lo, self.hi)
            model = float(r["f"])
            info = {"theta_um": (new * 1e3).tolist(), "model_objective": model, "merit": cur["merit"],
                    "radius_um": radius * 1e3, "rho": float(p[3]), "status": status, "iterations": it,
                    "nlp_s": time.perf_counter() - t1, "linearise_s": cur["time"], "n_loads": nlp["sizes"]["nx"],
                    "n_positions": int(self.phi1.size)}
            rounds.append(info)
            if not st["success"]:
                raise SynthesisError(f"loaded micro-geometry NLP: IPOPT stopped with {status} in round {rnd} "
                                     f"(design {dict(zip(self.free, (new * 1e3).round(3)))} um).",
                                     param="ipopt", value=status)
            pred = self._predicted(nlp, zs)
            step = float(np.max(np.abs(new - theta)))
            prev = (nlp, r, np.array(p, float), radius)
            stationary = step <= THETA_TOL or cur["merit"] - model <= F_TOL * max(cur["merit"], 1.0)
            viol = max(np.max(pred["slack_p"]) / SLACK_TOL, np.max(pred["slack_e"]) / EDGE_TOL)  # > 1: violated
            violated = viol > 1.0
            if violated and rho < RHO_MAX and (stationary or step < 0.5 * radius):
                # a constraint still violated at a stationary point of the penalised objective, or at
                # the model's own optimum well inside the trust region: the penalty is too light (an
                # exact penalty needs a weight above the constraint's multiplier); heavier, and the
                # same model again
                rho *= 10.0
                p[3] = rho
                cur["merit"] = self._merit(cur["check"], rho)
                info["accepted"] = f"penalty x10 ({rho:g})"
                if progress:
                    progress(_round_text(rnd, info, self._has_settings))
                continue
            if stationary:
                info["accepted"] = "converged"
                stop = "converged"
                if progress:
                    progress(_round_text(rnd, info, self._has_settings))
                break
            trial = self._around(new, 2 * radius, rho)
            gain = cur["merit"] - trial["merit"]
            ratio = gain / max(cur["merit"] - model, 1e-12)
            info.update(true_merit=trial["merit"], ratio=ratio)
            if ratio >= 0.1:
                info["accepted"] = True
                if ratio > 0.75 and step >= 0.9 * radius:
                    radius *= 2.0
                theta, cur = new, trial
                if violated and last_viol > 1.0 and viol > 0.1 * last_viol and rho < RHO_MAX:
                    # the model's optimum needed a slack after the last accepted step too, and not
                    # tenfold less: the penalty is too light for this drive; heavier from the next
                    # round on (the test above would raise it there, after one more solve)
                    rho *= 10.0
                    p[3] = rho
                    cur["merit"] = self._merit(cur["check"], rho)
                    info["rho_next"] = rho
                last_viol = viol
            else:
                info["accepted"] = False
                radius = 0.25 * step
            if progress:
                progress(_round_text(rnd, info, self._has_settings))
            if radius <= THETA_TOL:
                if violated and rho < RHO_MAX:
                    # no better design nearby, but a constraint still violated: a heavier penalty, and
                    # the radius of the last accepted step again
                    rho *= 10.0
                    p[3] = rho
                    cur["merit"] = self._merit(cur["check"], rho)
                    radius = 16.0 * THETA_TOL
                    continue
                break
        else:
            raise SynthesisError(f"loaded micro-geometry: no stationary design after {MAX_ROUNDS} linearisations "
                                 f"(last step {step * 1e3:.3g} um, trust radius {radius * 1e3:.3g} um).",
                                 param="theta", value=step)
        # the NLP's own values at the final design (its linearisation there, the design fixed): what the
        # verification below is compared with
        nlp = cur["nlp"]
        lbx, ubx = self._bounds(nlp)
        lbx[:len(self.free)] = ubx[:len(self.free)] = theta * 1e3
        r, st, _ = self._solve_nlp(nlp, cur["z0"], lbx, ubx, p, prev)
        if not st["success"]:
            raise SynthesisError(f"loaded micro-geometry: the NLP at the final design failed "
                                 f"({st['return_status']}).", param="ipopt", value=st["return_status"])
        pred = self._predicted(nlp, np.asarray(r["x"]).ravel())
        self._raise_if_infeasible(pred, cur["check"])
        return theta, cur, pred, iters, status, rho, stop

    def _multipliers(self, prev, nlp):
        """The multipliers of an earlier NLP's solution ``prev = (nlp, solution)`` carried to ``nlp``,
        row by row: a row of a slice, a block or a torque-case keeps its multiplier where the earlier
        NLP had the same row (the same torque, case, position and slice), else 0. ``None`` when the
        two grids of positions differ."""
        pn, r = prev
        if not np.array_equal(pn["phi1"], nlp["phi1"]):
            return None
        lg, lx = (np.asarray(r[k]).ravel() for k in ("lam_g", "lam_x"))

        def code(k):  # (torque, case, position, slice) -> one key
            k = np.asarray(k, np.int64).reshape(-1, 4)
            return ((k[:, 0] * 1000 + k[:, 1]) * 100000 + k[:, 2]) * 1000000 + k[:, 3]

        def rows(n):  # the constraint rows' segments in order, each by its keys
            kx = code(n["keys"])
            kb = code([(b[0], b[1], b[2], 0) for b in n["blocks"]])
            out = [code(n["w_keys"]), kx, kx, kb, kb, kb, kx[n["rows"]["flank"]], kx[n["rows"]["ends"]]]
            if n["te0"] is not None:  # the unloaded-TE target's rows (torque index T: zero load)
                k0 = code(n["te0"]["keys"])
                out += [k0, k0, code([(self.torques.size, c, m, 0) for c, m, _, _ in n["te0"]["blocks"]])]
            return out

        def carry(kp, vp, kn):
            out = np.zeros(kn.size)
            if kp.size and kn.size:
                o = np.argsort(kp)
                j = np.minimum(np.searchsorted(kp[o], kn), kp.size - 1)
                hit = kp[o][j] == kn
                out[hit] = vp[o[j[hit]]]
            return out

        old, new, parts, i = rows(pn), rows(nlp), [], 0
        for kp, kn in zip(old, new):
            parts.append(carry(kp, lg[i:i + kp.size], kn))
            i += kp.size
        sz, szp = nlp["sizes"], pn["sizes"]
        lam_x = np.zeros(nlp["problem"]["x"].shape[0])
        P, TC = sz["P"], sz["TC"]
        # (the design's bounds: none, the new design is the centre of its trust region)
        s0 = P + 2 * sz["nx"] + sz["nB"] + 2 * TC  # the slacks' bounds
        s0p = P + 2 * szp["nx"] + szp["nB"] + 2 * TC
        lam_x[s0:s0 + 2 * TC] = lx[s0p:s0p + 2 * TC]
        return lam_x, np.concatenate(parts)

    def _solve_nlp(self, nlp, z0, lbx, ubx, p, prev=None):
        """Solve ``nlp`` from ``z0``. With ``prev`` (an earlier NLP of the same positions and its
        solution), first from its multipliers (:meth:`_multipliers`) and a small barrier parameter
        (``WARM_OPTS``): near the earlier optimum a few tens of iterations instead of hundreds; where
        that fails, from the cold start. Returns the solution, IPOPT's stats and the iterations of both."""
        args = dict(x0=z0, lbx=lbx, ubx=ubx, lbg=nlp["lbg"], ubg=nlp["ubg"], p=p)
        its = 0
        lam = None if prev is None or not np.array_equal(prev[2], p) else self._multipliers(prev[:2], nlp)
        if lam is not None:
            if "warm" not in nlp:
                nlp["warm"] = ca.nlpsol("loaded_microgeometry_warm", "ipopt", nlp["problem"], {**nlp["opts"], **WARM_OPTS})
            r = nlp["warm"](lam_x0=lam[0], lam_g0=lam[1], **args)
            st = nlp["warm"].stats()
            its += int(st["iter_count"])
            if st["success"]:
                return r, st, its
        r = nlp["solver"](**args)
        st = nlp["solver"].stats()
        return r, st, its + int(st["iter_count"])

    def _harmonic_map(self, blocks, nB):
        """Sparse (T C 2H, nB) map of the blocks' loaded TE to the cosine and sine coefficients of the
        first H mesh harmonics of each (torque, case) (:func:`_harmonic_rows`); None for the
        peak-to-peak objective."""
        if self.harmonics is None:
            return None
        H = self.harmonics.size
        C = len(self.cases)
        R = _harmonic_rows(self.phi1, self.pair.pinion.z, H)
        rows, cols, vals = [], [], []
        for b, (t, c, n, _, _) in enumerate(blocks):
            base = (t * C + c) * 2 * H
            rows.extend(range(base, base + 2 * H))
            cols.extend([b] * (2 * H))
            vals.extend(R[:, n])
        return _sparse_dm(rows, cols, vals, self.torques.size * C * 2 * H, nB)

    def _pvec(self, rho: float) -> list:
        """The NLP's parameters: pressure limit, edge margin [um], smoothing, penalty weight, the torque
        scales (1) and the misalignment offsets (0)."""
        return ([self.p_limit or 1.0, (self.edge_margin or 0.0) / G_REF, MU, rho] + [1.0] * self.torques.size
                + [0.0] * len(Misalignment.names()))

    def _around(self, theta, radius: float = np.inf, rho: float = RHO) -> dict:
        """Linearisation, NLP and start point at ``theta``, with the exact loaded TCA there; the NLP
        leaves out the slices that stay open within ``radius`` [mm] of ``theta`` (:meth:`_keep`)."""
        t0 = time.perf_counter()
        lin = self.linearise(theta)
        sweeps = [self.ltca.solve(self.torques, slices=L["S"]) for L in lin]
        nlp = self._nlp(lin, theta, self._keep(lin, sweeps, radius), radius)
        z0 = self._start(nlp, lin, theta, sweeps)
        chk = self._check_of(sweeps)
        return {"nlp": nlp, "z0": z0, "check": chk, "merit": self._merit(chk, rho), "time": time.perf_counter() - t0}

    def _predicted(self, nlp, z):
        P, nx, nB, TC = (nlp["sizes"][k] for k in ("P", "nx", "nB", "TC"))
        x = z[P:P + nx]
        d = z[P + 2 * nx:P + 2 * nx + nB]
        te = -d * G_REF / nlp["lever"] * RAD_TO_ARCSEC
        hi = np.full(TC, -np.inf)
        lo = np.full(TC, np.inf)
        np.maximum.at(hi, nlp["ct"], te)
        np.minimum.at(lo, nlp["ct"], te)
        T, C = self.torques.size, len(self.cases)
        pp = (hi - lo).reshape(T, C)
        # flank pressure of the NLP's loads
        W = nlp["Wt"][np.repeat([b[0] for b in nlp["blocks"]], [b[4] for b in nlp["blocks"]])]
        f = np.maximum(x, 0.0) * W / nlp["ln"]
        p0 = np.where(nlp["edge"], 0.0, np.sqrt(f * self.material.E_star / (math.pi * nlp["Rx"])))
        pm = np.full(TC, 0.0)
        blk_ct = np.repeat(nlp["ct"], [b[4] for b in nlp["blocks"]])
        np.maximum.at(pm, blk_ct, p0)
        slack = z[P + 2 * nx + nB + 2 * TC:P + 2 * nx + nB + 4 * TC]
        obj = float(np.sum(self.weights * pp))
        if nlp["hmap"] is not None:
            H = self.harmonics.size
            ab = np.asarray(ca.mtimes(nlp["hmap"], ca.DM(te))).ravel().reshape(T, C, H, 2)
            obj = float(np.sum(self.weights[..., None] * np.hypot(ab[..., 0], ab[..., 1]) * self.harmonics))
        out = {"te_pp": pp, "p_max": pm.reshape(T, C), "objective": obj,
               "slack_p": slack[:TC].reshape(T, C), "slack_e": slack[TC:].reshape(T, C)}
        if nlp["te0"] is not None:  # the NLP's unloaded TE, its misfit by least squares (as in the NLP)
            sz, t0 = nlp["sizes"], nlp["te0"]
            off = P + 2 * nx + nB + 4 * TC + sz["nw"] + 2 * sz["n0"]
            te = -z[off:off + sz["nB0"]] * G_REF / nlp["lever"] * RAD_TO_ARCSEC
            rms = np.array([_parabola_fit(t0["psi"][t0["case"] == c], te[t0["case"] == c],
                                          self.te_level * RAD_TO_ARCSEC)[0] for c in range(C)])
            out.update(te0_rms=rms, te0_term=self._te0_term(rms), te0=te)
        return out

    def _raise_if_infeasible(self, pred, chk: LoadedCheck | None = None):
        for kind, what, tol in (("slack_p", "p_max", SLACK_TOL), ("slack_e", "edge", EDGE_TOL)):
            s = pred[kind]
            if np.max(s) > tol:
                t, c = np.unravel_index(int(np.argmax(s)), s.shape)
                if what == "p_max":
                    val = pred["p_max"][t, c]
                    raise SynthesisError(
                        f"loaded micro-geometry: the pressure limit p_limit = {self.p_limit:g} MPa cannot be met "
                        f"within the bounds of {list(self.free)}: at {self.torques[t]:g} N m, case {c} "
                        f"({_case_text(self.cases[c])}) the lowest peak pressure reached is {val:.1f} MPa. Raise p_limit, widen "
                        "the bounds or free more modifications.", param="p_limit", value=val)
                where, hint = "a tip edge or face end", "Free a relief or widen its bounds"
                if chk is not None:
                    where, hint = _edge_where(chk.sweeps[c], t, self.pair)
                raise SynthesisError(
                    f"loaded micro-geometry: the optimiser found no design within the bounds of {list(self.free)} that keeps every tip edge "
                    f"and face end {self.edge_margin * 1e3:g} um open at {self.torques[t]:g} N m, case {c} "
                    f"({_case_text(self.cases[c])}): {where} still carries {100 * s[t, c]:.3g} % of the "
                    f"normal load. {hint}, or lower edge_margin.", param="edge_margin",
                    value=float(s[t, c]))

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


def _entry(amount: str) -> str:
    """The member parameter of a free name: ``iso.<amount>`` for an ISO amount, the setting itself."""
    return amount if amount in SETTINGS else f"iso.{amount}"


def _sparse_dm(rows, cols, vals, n_rows, n_cols) -> ca.DM:
    return ca.DM.triplet(list(rows), list(cols), ca.DM(np.asarray(vals, float)), n_rows, n_cols)


def _harmonic_rows(phi1, z1: int, H: int) -> np.ndarray:
    """(2H, N) least-squares map of a TE sampled at the pinion angles ``phi1`` [rad] (one mesh cycle or
    more) to the coefficients (a_1, b_1, ..., a_H, b_H) of ``te ~ c0 + sum_h a_h cos(h z1 phi1) + b_h
    sin(h z1 phi1)``; on a uniform grid over whole cycles this is the DFT."""
    phi1 = np.asarray(phi1, float)
    cols = [np.ones_like(phi1)]
    for h in range(1, H + 1):
        cols += [np.cos(h * z1 * phi1), np.sin(h * z1 * phi1)]
    return np.linalg.pinv(np.stack(cols, axis=1))[1:]


def _parabola_fit(psi, te, level: float) -> tuple[float, np.ndarray]:
    """RMS misfit [arcsec] of ``te`` [arcsec] at ``psi`` to ``c0 + c1 psi - level psi^2`` (least squares
    in c0, c1) and (c0, c1)."""
    V = np.stack([np.ones_like(psi), psi], axis=1)
    rhs = te + level * psi**2
    coef = np.linalg.lstsq(V, rhs, rcond=None)[0]
    return float(np.sqrt(np.mean((rhs - V @ coef) ** 2))), coef


def _case_text(mis: Misalignment) -> str:
    """``"aligned"`` or the misalignment's non-zero kinds in the scene's units (``"crossing 2'"``)."""
    given = [f"{k} {Misalignment.display(k, getattr(mis, k))}" for k in Misalignment.names() if getattr(mis, k)]
    return ", ".join(given) or "aligned"


class _NLP(dict):
    """One linearisation's NLP (its parts by name); its cold-start IPOPT solver, ``"solver"``, is built
    on first use (a round solved warm, or a trial never solved, needs none)."""

    def __missing__(self, key):
        if key != "solver":
            raise KeyError(key)
        self[key] = ca.nlpsol("loaded_microgeometry", "ipopt", self["problem"], self["opts"])
        return self[key]


def degenerate_constraints(ind_g, lam_g, ind_x, lam_x) -> tuple[int, float | None]:
    """Degenerate inequalities and bounds at a solution: those active (central-path indicator above
    1/2, :func:`central_path_indicators`) whose multiplier vanishes (strict complementarity fails: the
    optimum is then only directionally differentiable), i.e. at most ``DEGENERATE_REL`` times the
    largest active multiplier, and those the indicator cannot tell active from inactive (between 0.1
    and 0.9). ``ind_g``, ``lam_g``: the inequality rows' indicators and multipliers; ``ind_x``,
    ``lam_x``: the variables' (indicator NaN: no finite bound). Returns ``(count, smallest active
    multiplier over the largest)`` (None without an active one)."""
    ind_g, lam_g, ind_x, lam_x = (np.asarray(v, float).ravel() for v in (ind_g, lam_g, ind_x, lam_x))
    bx = np.isfinite(ind_x)
    act_g, act_x = ind_g > 0.5, bx & (np.where(bx, ind_x, 0.0) > 0.5)
    mult = np.concatenate([np.abs(lam_g[act_g]), np.abs(lam_x[act_x])])
    big = float(mult.max()) if mult.size else 0.0
    tol = DEGENERATE_REL * big
    deg_g = (act_g & (np.abs(lam_g) <= tol)) | (np.abs(ind_g - 0.5) < 0.4)
    deg_x = (act_x & (np.abs(lam_x) <= tol)) | (bx & (np.abs(np.where(bx, ind_x, 0.0) - 0.5) < 0.4))
    return int(deg_g.sum() + deg_x.sum()), (float(mult.min()) / big if big > 0 else None)


def central_path_indicators(H, Jg, lbg, ubg, g, lam_g, lbx, ubx, x, lam_x):
    """How each inequality and bound of an interior-point solution behaves as the barrier vanishes.

    At IPOPT's solution ``x`` (multipliers ``lam_g``, ``lam_x`` in CasADi's signs: positive at an
    upper bound) of ``min f(x)`` s.t. ``lbg <= g(x) <= ubg``, ``lbx <= x <= ubx``, the tangent of the
    central path (every complementarity product lam s scaled together with the barrier parameter
    mu; the perturbed KKT system with ``H`` the Hessian of the Lagrangian and ``Jg`` the constraint
    Jacobian, sparse) gives each slack's d log s / d log mu: about 1 for an active constraint (its
    slack vanishes like mu), 0 for an inactive one (its multiplier does), 1/2 for a degenerate one
    (active with a zero multiplier: both vanish like sqrt(mu)). Scale-free, unlike lam / s.

    Parameters
    ----------
    H : (n, n) array or sparse matrix
        Hessian of the Lagrangian ``f + lam_g' g`` in ``x`` at the solution.
    Jg : (m, n) array or sparse matrix
        Jacobian of ``g`` at the solution.
    lbg, ubg, g, lam_g : (m,) arrays
        Constraint bounds (equal for an equality row), values and multipliers.
    lbx, ubx, x, lam_x : (n,) arrays
        Variable bounds (+-inf where none), the solution and the bounds' multipliers. The solve
        should run without IPOPT's bound relaxation (``bound_relax_factor`` 0), so that every slack
        is the solution's own.

    Returns
    -------
    ind_g : (m,) array
        Indicator of every constraint row (NaN for equality rows).
    ind_x : (n,) array
        Indicator of every variable's bound (NaN for a variable without finite bounds).
    """
    import scipy.sparse as sp_

    lbg, ubg, g, lam_g = (np.asarray(v, float).ravel() for v in (lbg, ubg, g, lam_g))
    lbx, ubx, x, lam_x = (np.asarray(v, float).ravel() for v in (lbx, ubx, x, lam_x))
    H, Jg = sp_.csc_matrix(H), sp_.csr_matrix(Jg)
    eq = lbg == ubg
    I_, E = np.flatnonzero(~eq), np.flatnonzero(eq)
    s_g = np.abs(np.where(lam_g[I_] > 0, ubg[I_] - g[I_], g[I_] - lbg[I_]))
    s_x = np.abs(np.where(lam_x > 0, ubx - x, x - lbx))
    bx = np.isfinite(s_x)
    tiny = 1e-300
    sig_g = np.abs(lam_g[I_]) / np.maximum(s_g, tiny)
    sig_x = np.where(bx, np.abs(lam_x) / np.where(bx, np.maximum(s_x, tiny), 1.0), 0.0)
    JI = Jg[I_]
    K = sp_.bmat([[H + JI.T @ sp_.diags(sig_g) @ JI + sp_.diags(sig_x), Jg[E].T], [Jg[E], None]], format="csc")
    # d(lam_i s_i) = lam_i s_i d(log mu): the stationarity's right-hand side is -(J^T lam + lam_x)
    dx = _lu(K, "IPOPT's perturbed KKT system").solve(
        np.concatenate([-(JI.T @ lam_g[I_]) - np.where(bx, lam_x, 0.0), np.zeros(E.size)]))[:x.size]
    ind_g = np.full(lbg.size, np.nan)
    ind_g[I_] = -np.sign(lam_g[I_]) * (JI @ dx) / np.maximum(s_g, tiny)
    ind_x = np.where(bx, -np.sign(lam_x) * dx / np.where(bx, np.maximum(s_x, tiny), 1.0), np.nan)
    return ind_g, ind_x


def _csc(m):
    import scipy.sparse as sp_

    m = ca.DM(m)
    i, j = m.sparsity().get_triplet()
    return sp_.csc_matrix((np.array(m.nonzeros()), (i, j)), shape=m.shape)


def _lu(K, what: str):
    import scipy.sparse.linalg as spla

    try:
        return spla.splu(K)
    except RuntimeError as exc:  # singular: the active constraints' gradients are dependent (no LICQ)
        raise SynthesisError(f"loaded micro-geometry sensitivities: {what} is singular ({exc}); the active "
                             "constraints' gradients are linearly dependent at this optimum, so its "
                             "derivatives are not unique.", param="sensitivities", value=what) from exc


def _round_text(rnd: int, info: dict, settings: bool = False) -> str:
    th = ", ".join(f"{v:.2f}" for v in info["theta_um"]) + ("] um (settings: 1e-3/mm" if settings else "")
    true = f", true {info['true_merit']:.4g}" if "true_merit" in info else ""
    return (f"loaded micro-geometry round {rnd}: design [{th}] um, model {info['model_objective']:.4g}{true} "
            f"(from {info['merit']:.4g}), radius {info['radius_um']:.3g} um, {info['iterations']} IPOPT iterations, "
            f"{'accepted' if info.get('accepted') is True else info.get('accepted')}"
            + (f", penalty x10 ({info['rho_next']:g}) from the next round" if "rho_next" in info else ""))


def _edge_weight(S, pair) -> np.ndarray:
    """(K, N, M) weight of each slice in the edge-loading constraint: 1 on the tip-edge slices and the
    face ends z = +-b/2; on flank slices it grows linearly from 0 to 1 over the last ``TIP_BAND`` m_n
    (radial) below either member's tip circle (a contact there reaches the tip corner). Graded, so that
    the constraint does not jump when the design moves a loaded slice towards the tip, or when a slice
    turns from flank contact just below the tip into tip-edge contact."""
    e = np.zeros(S.z.shape, bool) if S.edge is None else S.edge > 0
    g1, g2 = pair.pinion, pair.gear
    with np.errstate(invalid="ignore"):
        ends = np.abs(np.abs(S.z) - g1.b / 2) < 1e-9
        w1 = (np.hypot(S.r1[..., 0], S.r1[..., 1]) - (g1.r_a - TIP_BAND * g1.m_n)) / (TIP_BAND * g1.m_n)
        w2 = (np.hypot(S.r2[..., 0], S.r2[..., 1]) - (g2.r_a - TIP_BAND * g2.m_n)) / (TIP_BAND * g2.m_n)
        w = np.clip(np.fmax(np.nan_to_num(w1, nan=0.0), np.nan_to_num(w2, nan=0.0)), 0.0, 1.0)
    return np.where(e | ends, 1.0, w)


def _edge_weight_lin(S, pair, Jr) -> tuple[np.ndarray, np.ndarray]:
    """The edge weight of :func:`_edge_weight` linearised in the design and misalignment: ``(w0, g)``,
    (K, N, M) and (K, N, M, Q). On a flank slice, ``w0`` is the unclipped band coordinate
    ``(r - (r_a - TIP_BAND m_n)) / (TIP_BAND m_n)`` of the member whose tip is nearer and ``g`` its
    gradient from the point's radial sensitivities ``Jr`` (K, N, M, 2, Q) [mm per unit]: a crowned
    contact point moves along the profile some ten microns per micron of crowning, so a weight held
    at the linearisation misses the load a step brings into the band. Tip edges and face ends: 1 and 0."""
    g1, g2 = pair.pinion, pair.gear
    band1, band2 = TIP_BAND * g1.m_n, TIP_BAND * g2.m_n
    with np.errstate(invalid="ignore"):
        w1 = np.nan_to_num((np.hypot(S.r1[..., 0], S.r1[..., 1]) - (g1.r_a - band1)) / band1, nan=-np.inf)
        w2 = np.nan_to_num((np.hypot(S.r2[..., 0], S.r2[..., 1]) - (g2.r_a - band2)) / band2, nan=-np.inf)
    pin = w1 >= w2
    w0 = np.where(pin, w1, w2)
    g = np.where(pin[..., None], Jr[..., 0, :] / band1, Jr[..., 1, :] / band2)
    with np.errstate(invalid="ignore"):
        ends = np.abs(np.abs(S.z) - g1.b / 2) < 1e-9
    fixed = _edge_weight(S, pair) >= 1.0
    fixed |= (np.zeros(S.z.shape, bool) if S.edge is None else S.edge > 0) | ends
    lost = ~np.isfinite(w0) | ~S.active
    w0 = np.where(fixed, 1.0, np.where(lost, 0.0, w0))
    g = np.where((fixed | lost)[..., None], 0.0, np.nan_to_num(g))
    return w0, g


def _edge_where(sw: LoadedSweep, t: int, pair) -> tuple[str, str]:
    """Which edge carries the most weighted load at torque ``t`` of a loaded sweep, in words, and the
    modification that would open it: ``(where, hint)``."""
    S, r = sw.slices, sw.results[t]
    w = _edge_weight(S, pair) * r.load
    k, n, m = np.unravel_index(int(np.argmax(np.nan_to_num(w))), w.shape)
    at = f" (pair {S.pairs[k]}, phi1 = {math.degrees(S.phi1[n]):.3g} deg, z = {S.z[k, n, m]:.3g} mm)"
    kind = 0 if S.edge is None else int(S.edge[k, n, m])
    if kind == 1:
        return "the pinion's tip edge" + at, "Free or widen the pinion's tip relief (C_alpha_a)"
    if kind == 2:
        return "the gear's tip edge" + at, "Free or widen the pinion's root relief (C_alpha_f) or the gear's tip relief"
    if abs(abs(S.z[k, n, m]) - pair.pinion.b / 2) < 1e-9:
        return "a face end" + at, "Free or widen the lead crowning (C_beta) or an end relief (C_beta_I/II)"
    return "a flank slice at a tip" + at, "Free or widen a tip or root relief"


def _edge_mask(S, pair) -> np.ndarray:
    """(K, N, M) slices that count in the edge loading (weight > 0, :func:`_edge_weight`)."""
    return _edge_weight(S, pair) > 0


def _gaps(sw: LoadedSweep, r) -> np.ndarray:
    """(K, N, M) gaps g = s + C F - delta [mm] of a loaded result (every active slice, exact compliance)."""
    from ..ltca.compliance import weber_contact

    S = sw.slices
    st = sw.structure
    K, N, M = S.z.shape
    lever = sw.ltca.pair.gear.r_b * sw.ltca.cos_bb
    g1 = sw.ltca.pair.pinion
    # each slice on its own levers (LTCA._solve_one): the gap closes by delta times lever1 / (r_b1 cos(beta_b))
    lev2 = lever if S.lever2 is None else np.where(S.active & np.isfinite(S.lever2), S.lever2, lever)
    lam = 1.0 if r.lever is None else r.lever / (g1.r_b * sw.ltca.cos_bb)
    s = np.where(S.active, (r.te_unloaded[None, :, None] - S.te) * lev2, 0.0)
    F = np.transpose(r.load, (1, 0, 2)).reshape(N, K * M)
    CF = np.einsum("nij,nj->ni", st["Cs"], F)
    CF = np.transpose(CF.reshape(N, K, M), (1, 0, 2))
    f_min = F_MIN_SHARE * r.W * sw.ltca.cos_bb / g1.b
    cH = weber_contact(r.load / st["length"], st["R"], st["h1"], st["h2"], sw.ltca.material, f_min)[0]
    return s + CF + cH * r.load / st["length"] - r.delta[None, :, None] * lam
