"""Loaded tooth contact analysis (docs/ltca.md): load sharing, loaded TE, contact pressure and mesh
stiffness of a spur or helical drive with its modifications and misalignments.

At each pinion angle the slices of every tooth pair (:mod:`gearopt.ltca.slices`) carry point loads
``F_i >= 0`` along the contact normal; with the compliance matrix ``C`` (:mod:`gearopt.ltca.compliance`)
and the unloaded separations ``s`` the gaps are ``g = s + C F - lam delta`` and the contact conditions
``F >= 0, g >= 0, F g = 0, sum lam F = W`` (W = T / (r_b1 cos(beta_b)); ``lam_i`` each force's own
lever about the pinion axis over ``r_b1 cos(beta_b)``, 1 on an involute flank, less on a tip edge)
are the optimality conditions of the convex QP

    min_F  1/2 F^T C F + s^T F    s.t.  F >= 0,  sum lam F = W,

whose equality multiplier is the loaded approach ``delta`` [mm] (the pinion's rigid advance along the
flank contact normal). The primal-dual active-set method solves it at every position at once
(:func:`contact_active_set`; qpOASES, CasADi's conic plugin, where that does not settle); the Hertz
part of C depends on the load (Weber's logarithm), so the QP is re-solved with the Hertz approach
linearised at the last loads (a Newton step, tangent by AD) until the loads stop changing (the
nonlinear contact law holds at the solution). Each solution is checked against the contact
conditions (``kkt_error_mm``).

Loaded TE = unloaded TE - delta / (r_b2 cos(beta_b)) [rad] (the gear lags); at zero load
delta = 0 and the loaded TE is the unloaded TE of the slices, which at the point contact equals
the TCA's (the grid of each pair passes through its unloaded point contact).
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple
from collections.abc import Sequence

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..contact.hertz import C_PRIME_STEEL, contact_modulus, hertz_peak_pressure
from ..errors import ArgumentError, ConvergenceError, OptionError, check_number, out_of_range
from ..gears import GearPair
from ..meshing.misalignment import Misalignment
from ..meshing.tca import TCA
from ..settings import LTCASettings
from ..units import RAD_TO_ARCSEC
from .compliance import (Material, ToothCompliance, body_coupling_length, face_matrix_batch,
                         weber_contact, weber_tangent, weber_tangent_array)
from .neighbours import NeighbourTerm, cross_blocks
from .slices import SliceSet, SliceSolver

if TYPE_CHECKING:
    from ..fea.influence import InfluenceGrid
    from ..fea.mesh import MeshOptions

HERTZ_TOL = 1e-7  #: the Hertz fixed point stops when no slice load changes by more than this x W
HERTZ_MAX_ITER = 30
EDGE_RADIUS = 0.05  #: rounding of an unrelieved tip edge [m_n]: the Hertz radius of a tip-edge slice
EDGE_GUESS = 2.0  #: first QP round: tip edges within this many times the ISO-estimated approach
OUTER_MAX = 10  #: QP rounds that add tip-edge slices found closed after a solve
KKT_ADD_TOL = 1e-12  #: a left-out slice whose gap falls below the approach by more than this [mm] is added
QP_SOLVER = "qpoases"  #: CasADi conic plugin of the contact QP where the active-set method does not settle
#: the contact QP's solver as results.json names it (``options.qp_solver``)
QP_METHOD = "active-set (qpoases where it does not settle)"
F_MIN_SHARE = 1e-3  #: Weber's logarithm uses at least this share of the mean line load
#: Range of validity of the linear-elastic contact model (refused beyond it, :func:`check_validity`).
#: Peak Hertz pressure of the flank contact [MPa] for steel (E = 206000 MPa), scaled by E / 206000
#: for another modulus (the same contact strain p0 / E = 0.024): at p0 = 5000 MPa the largest
#: subsurface shear stress of a line contact, 0.30 p0 = 1500 MPa, is beyond the shear yield
#: strength of the hardest case-hardened gear steel (~1200 MPa at 60+ HRC), and the static
#: contact capacity of such steels (ISO 6336-2, sigma_Hlim 1500 MPa x Z_NT 1.6 = 2400 MPa) is
#: exceeded twice over: no gear survives it, and the elastic model no longer describes it.
P_MAX_VALID = 5000.0
E_STEEL = 206000.0  #: [MPa] the modulus P_MAX_VALID is stated for
#: Largest loaded approach (the deflection of the mesh along the contact normal) [m_n]: beyond
#: 0.1 m_n the teeth bend so far that the small-deflection compliance (and the unloaded contact
#: geometry it is applied to) no longer hold (normal loads give 0.005 ... 0.02 m_n).
DELTA_MAX_VALID = 0.1


def pressure_lower_bound(pair: GearPair, torque: float, material: Material) -> float:
    """A lower bound of the peak Hertz pressure [MPa] of the flank contact at pinion torque
    ``torque`` [N m], from the gear data alone (no solve): the normal load ``W = T / (r_b1 cos
    beta_b)`` spread over the longest contact length the mesh can have, ``b (floor(eps_alpha) + 1) /
    cos(beta_b)``, on the flattest flanks of the path of contact (normal equivalent radius
    ``g / 4 / cos(beta_b)``, g = a_w sin(alpha_wt) the distance between the base-circle tangency
    points; the sum of the transverse radii along the path is g): Hertz's line contact
    ``p0 = sqrt(w E* / (pi rho))``, ``E* = E / (2 (1 - nu^2))``. Some slice carries at least the mean
    line load on flanks no flatter than that, so the solved peak is not below it (up to loads taken
    by tip edges)."""
    g1 = pair.pinion
    cb = math.cos(g1.beta_b)
    W = torque * 1e3 / (g1.r_b * cb)
    length = min(g1.b, pair.gear.b) * (math.floor(pair.eps_alpha) + 1) / cb
    rho = pair.a_w * math.sin(pair.alpha_wt) / 4 / cb
    e_star = contact_modulus(material.E, material.nu)
    return float(hertz_peak_pressure(W / length, rho, e_star))


def check_torque_range(pair: GearPair, torque_max: float, material: Material | None = None, name: str = "torque") -> None:
    """Refuse, before any solve, a torque [N m] whose :func:`pressure_lower_bound` already exceeds
    the model's pressure limit (``P_MAX_VALID E / 206000``): :class:`OptionError` naming ``name``.
    The solved results are checked in full by :func:`check_validity`."""
    from .compliance import Material

    material = material or Material()
    p_lim = P_MAX_VALID * material.E / E_STEEL
    p = pressure_lower_bound(pair, float(torque_max), material)
    if p > p_lim:
        valid = (f"a torque whose peak contact pressure stays <= {p_lim:.4g} MPa (no gear steel survives more; "
                 f"{P_MAX_VALID:g} MPa x E / {E_STEEL:g} MPa: the linear-elastic contact model's range of validity)")
        detail = (f"is beyond the range of the linear-elastic contact model: at {torque_max:g} N m the contact pressure "
                  f"is at least {p:.4g} MPa (Hertz, the load over the longest contact line); valid: {valid}.")
        raise OptionError(f"{name} = {torque_max:g} {detail}", param=name, value=float(torque_max), valid=valid,
                          detail=detail)


def check_validity(result: LoadedResult, pair: GearPair, material: Material) -> None:
    """Refuse a loaded result outside the linear-elastic model's range of validity: a peak flank
    pressure above ``P_MAX_VALID E / 206000`` MPa, a loaded approach above ``DELTA_MAX_VALID m_n``,
    or a mesh stiffness that is not positive (an approach <= 0 under load).

    Raises
    ------
    OptionError
        Naming ``torque`` and its value [N m], the figure reached and the limit.
    """
    T = float(result.torque)
    m_n = pair.pinion.m_n
    p_lim = P_MAX_VALID * material.E / E_STEEL
    d_lim = DELTA_MAX_VALID * m_n
    p = float(np.nanmax(result.p0_flank)) if np.isfinite(result.p0_flank).any() else 0.0
    d = np.asarray(result.delta, float)
    why = None
    if p > p_lim:
        why = f"the peak contact pressure reaches {p:.4g} MPa"
    elif np.nanmax(d) > d_lim:
        why = f"the loaded approach reaches {float(np.nanmax(d)) * 1000:.4g} um = {float(np.nanmax(d)) / m_n:.3g} m_n"
    elif np.any(d <= 0):
        why = (f"the loaded approach is {float(np.nanmin(d)) * 1000:.4g} um at some position: the mesh stiffness "
               "would not be positive")
    if why is None:
        return
    valid = (f"a torque whose peak contact pressure stays <= {p_lim:.4g} MPa (no gear steel survives more; "
             f"{P_MAX_VALID:g} MPa x E / {E_STEEL:g} MPa) and whose loaded approach stays within 0 ... "
             f"{DELTA_MAX_VALID:g} m_n = {d_lim * 1000:.4g} um (the linear-elastic contact model's range of validity)")
    detail = f"is beyond the range of the linear-elastic contact model: at {T:g} N m {why}; valid: {valid}."
    raise OptionError(f"torque = {T:g} {detail}", param="torque", value=T, valid=valid, detail=detail)


@contextlib.contextmanager
def _quiet_stdout():
    """Silence writes to the process's stdout (file descriptor 1) from C code."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as dn:
            os.dup2(dn.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


#: Slices narrower than this share of the nominal slice width are left out of the line-load statistics
#: (``K_Hbeta``, ``line_load_max``): slivers left where a flank slice is trimmed at a tip crossing.
SLIVER = 0.25


@dataclass(frozen=True)
class LoadedResult:
    """Loaded TCA at one torque over the positions ``phi1`` (arrays (K, N, M): K tooth pairs, N
    positions, M slice nodes; see :class:`~gearopt.ltca.slices.SliceSet`).

    Attributes
    ----------
    torque : pinion torque [N m]; W : total normal load [N].
    phi1 : (N,) [rad]; pairs : tuple.
    te_unloaded, te_loaded : (N,) unloaded and loaded TE [rad].
    delta : (N,) loaded approach along the contact normal [mm].
    load : (K, N, M) slice loads [N]; line_load : (K, N, M) load per unit face width [N/mm].
    p0, b_H : (K, N, M) Hertz peak pressure [MPa] and half-width [mm] of each slice.
    pair_load : (K, N) normal load of each pair [N]; share : (K, N) its share of the pinion torque
        (``sum lever F`` of its slices over ``torque``; its share of W where every slice is a flank).
    stiffness : (N,) mesh stiffness W / delta [N/um] (secant, including the separations closed).
    kkt_error : (N,) largest violation of the contact conditions [mm].
    hertz_iterations : (N,) fixed-point iterations; solve_time [s].
    edge : (K, N, M) tip-edge slices (1 pinion tip, 2 gear tip, 0 flank; ``SliceSet.edge``).
    lever : (K, N, M) moment arm of each slice's force about the pinion axis [mm]
        (``SliceSet.lever1``: r_b1 cos(beta_b) on a flank, less on a tip edge); the pinion torque is
        ``sum(lever * load)`` at every position (:attr:`torque_balance_error`).
    """

    torque: float
    W: float
    phi1: np.ndarray
    pairs: tuple
    te_unloaded: np.ndarray
    te_loaded: np.ndarray
    delta: np.ndarray
    load: np.ndarray
    line_load: np.ndarray
    p0: np.ndarray
    b_H: np.ndarray
    pair_load: np.ndarray
    share: np.ndarray
    stiffness: np.ndarray
    kkt_error: np.ndarray
    hertz_iterations: np.ndarray
    solve_time: float
    face_width: float
    stats: dict = field(default_factory=dict)
    edge: np.ndarray | None = None
    lever: np.ndarray | None = None

    @property
    def te_loaded_arcsec(self) -> np.ndarray:
        return self.te_loaded * RAD_TO_ARCSEC

    @property
    def peak_to_peak_arcsec(self) -> float:
        """Peak-to-peak loaded TE [arcsec]."""
        t = self.te_loaded_arcsec
        return float(np.nanmax(t) - np.nanmin(t))

    @property
    def p0_flank(self) -> np.ndarray:
        """(K, N, M) Hertz peak pressure of the flank slices [MPa] (0 on tip-edge slices)."""
        return self.p0 if self.edge is None else np.where(self.edge > 0, 0.0, self.p0)

    @property
    def p_max(self) -> float:
        """Largest Hertz peak pressure of the flank contact over positions and slices [MPa] (tip-edge
        slices excluded: see :attr:`edge_share` and :attr:`p_max_edge`)."""
        return float(np.nanmax(self.p0_flank))

    @property
    def edge_share(self) -> np.ndarray:
        """(N,) share of the pinion torque carried by tip edges (edge loading of unrelieved tips)."""
        if self.edge is None:
            return np.zeros(self.phi1.size)
        lev = 1.0 if self.lever is None else self.lever / (self.torque * 1e3 / self.W)
        return np.sum(np.where(self.edge > 0, lev * self.load, 0.0), axis=(0, 2)) / self.W

    @property
    def torque_balance_error(self) -> np.ndarray:
        """(N,) ``sum(lever * load) / torque - 1``: the pinion's moment balance with each slice force on
        its own lever (``lever``); NaN without levers."""
        if self.lever is None:
            return np.full(self.phi1.size, np.nan)
        return np.nansum(self.lever * self.load, axis=(0, 2)) * 1e-3 / self.torque - 1.0

    @property
    def p_max_edge(self) -> float:
        """Largest Hertz pressure on a tip edge of rounding ``EDGE_RADIUS`` m_n [MPa] (0: none loaded)."""
        if self.edge is None:
            return 0.0
        return float(np.max(np.where((self.edge > 0) & (self.load > 0), self.p0, 0.0)))

    @property
    def c_gamma(self) -> float:
        """Mean mesh stiffness per unit face width [N/(mm um)]."""
        return float(np.nanmean(self.stiffness)) / self.face_width


class CompliancePart(NamedTuple):
    """One term of the analytical tooth compliance (:meth:`LTCA.structure`), coupled across the face
    over its own length (:func:`~gearopt.ltca.compliance.face_matrix_batch`)."""

    #: (K, N, M) compliance per unit face width of each slice node [mm^2/N] (inactive nodes: the
    #: mean of the active ones)
    compliance: np.ndarray
    #: coupling length of the term across the face [mm]
    coupling_length: float


@dataclass(frozen=True)
class HertzNodes:
    """The Hertz data of slice nodes (any common shape: (K, N, M) per pair, position and node, or
    (N, K M) per position, :meth:`ContactStructure.by_position`)."""

    length: np.ndarray  #: length of contact line of each node [mm] (1 where inactive)
    R: np.ndarray  #: reduced radius of curvature across the contact line [mm] (1 where inactive)
    h1: np.ndarray  #: depth of the pinion's centreline below the point along the load line [mm] (Weber)
    h2: np.ndarray  #: the same on the gear [mm]


@dataclass(frozen=True)
class ContactStructure:
    """The load-independent parts of the loaded contact problem of a :class:`~gearopt.ltca.slices.SliceSet`
    (:meth:`LTCA.structure`): arrays (K, N, M) per tooth pair, position and slice node unless stated.

    Attributes
    ----------
    Cs : (N, K M, K M) array
        Compliance matrix of the teeth and bodies (bending, shear, compression, foundation) of each
        position over the flattened nodes ``k M + m`` [mm/N] (without the Hertz term).
    parts : tuple of CompliancePart
        The analytical compliance's terms (the teeth; the pinion's body; the gear's body) whose face
        matrices, times ``cos^2(beta_b)``, sum to ``Cs`` (with FE influence coefficients ``Cs`` is
        FE's and the parts are the analytical model's).
    ct : array
        Sum of the parts' compliances per unit face width [mm^2/N].
    length : array
        Length of contact line of each node, its width over ``cos(beta_b)`` [mm] (1 where inactive).
    R : array
        Reduced radius of curvature across the contact line [mm] (1 where inactive).
    h1, h2 : array
        Depths of the pinion's and the gear's tooth centreline below the point along the load line
        [mm] (Weber's contact term; 1 where inactive).
    radius1, radius2 : array
        Radius of the node's point on the pinion and on the gear [mm] (NaN where unused).
    """

    Cs: np.ndarray
    parts: tuple[CompliancePart, ...]
    ct: np.ndarray
    length: np.ndarray
    R: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    radius1: np.ndarray
    radius2: np.ndarray

    @property
    def hertz(self) -> HertzNodes:
        """The Hertz data (K, N, M)."""
        return HertzNodes(length=self.length, R=self.R, h1=self.h1, h2=self.h2)

    def by_position(self) -> HertzNodes:
        """The Hertz data as (N, K M) arrays: one row per position over the flattened nodes
        ``k M + m`` (the order of ``Cs``)."""
        K, N, M = self.length.shape
        flat = lambda a: np.transpose(a, (1, 0, 2)).reshape(N, K * M)  # noqa: E731
        return HertzNodes(length=flat(self.length), R=flat(self.R), h1=flat(self.h1), h2=flat(self.h2))


class LTCA:
    """Loaded tooth contact analysis of a gear pair (build once, solve many torques).

    Parameters
    ----------
    pair : GearPair
    settings : gearopt.settings.LTCASettings, optional
        ``side``, ``n_slices``, ``coupling``, ``compliance``, ``curvature``, ``body_coupling``, ``body``,
        ``helical`` as one object; keyword arguments replace its fields. Their defaults and ranges are declared there only.
    side : {"right", "left"}
        Driving flank of the pinion.
    material : Material
        Elastic constants (both members).
    n_slices : int
        Slices across the face (grid spacing b / (n_slices - 1); the face ends are slices too).
    r_int : (float, float), optional
        Inner radii of the pinion and gear bodies [mm] (default: half the root radius, a solid
        gear on its shaft).
    coupling : float, optional
        Coupling length of the teeth's slices across the face [mm] (bending, shear, compression;
        default: half the tooth height of the pinion, (r_a - r_f) / 2).
    body_coupling : float, optional
        Coupling length of the gear bodies' term (Sainsot's foundation) across the face [mm], both
        members (default: each member's :func:`~gearopt.ltca.compliance.body_coupling_length`).
    tca : TCA, optional
        The unloaded TCA (default: point contact with the members' modifications).
    compliance : {"analytical", "fe"}
        Tooth compliance: the analytical thin-slice model, or influence coefficients of each member's
        CalculiX model (:func:`gearopt.fea.influence.influence_grid`, cached on disk; right flank),
        with the same Weber-Banaschek contact term.
    fe_mesh : MeshOptions, optional
        Member mesh of the FE influence coefficients (default: that of ``influence_grid``).
    body : {"full_gear_fit", "sainsot2004"}
        The gear body's term of the analytical compliance (:class:`~gearopt.ltca.compliance.ToothCompliance`):
        Sainsot's form refitted to FE full gears held at their bores (default), or Sainsot, Velex &
        Duverger's 2004 coefficients.
    helical : {"normal", "transverse"}
        A helical member's slice compliance along the normal (per unit face width): the teeth's
        (bending, shear, compression) ``cos(beta_b)`` times the transverse slice's and the body's once
        the transverse term (default; the FE full gears of docs/ltca.md section 7), or both
        ``cos^2(beta_b)`` times it (the projection of the transverse slice, the model before 2026-11-29).
    neighbours : {"auto", "full_gear", "none"}, optional
        The coupling of the pairs in mesh through the gear bodies: a load on one tooth moves the teeth
        ``d`` pitches away by :class:`~gearopt.ltca.neighbours.NeighbourTerm` (fitted to FE full gears held
        at their bores, docs/ltca.md section 7; analytical compliance only), or the pairs are not coupled
        ("none"); "auto" (default): "full_gear" with the analytical compliance, "none" with FE influence
        coefficients (their members' own models). :attr:`neighbours` is the one in use.
    curvature : {"surface", "involute"}
        The flanks' curvature across the contact line in the Hertz term: each modified surface's own
        at the slice's point (by AD; profile crowning, reliefs and their smooth starts raise it), or
        the unmodified involute's ``cos(beta_b) / rho_t`` (for comparison only: it misses the
        reliefs' starts; the loaded micro-geometry optimiser uses the surface's).
    """

    def __init__(self, pair: GearPair, settings: LTCASettings | None = None, *, material: Material | None = None,
                 r_int: float | None = None, tca: TCA | None = None, fe_mesh: MeshOptions | None = None,
                 **options: Any):
        # side, n_slices, coupling, compliance, curvature, body_coupling, body, helical: defaults and checks
        # of LTCASettings
        s = LTCASettings.of(settings, **options)
        side, n_slices, coupling, compliance = s.side, s.n_slices, s.coupling, s.compliance
        curvature, body_coupling = s.curvature, s.body_coupling
        self.settings = s
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {pair!r:.60}: expected a gearopt.gears.GearPair.", param="pair", value=pair,
                                valid="a gearopt.gears.GearPair")
        material = material or Material()
        if not isinstance(material, Material):
            raise ArgumentError(f"material = {material!r:.60}: expected a gearopt.ltca.Material (E, nu).",
                                param="material", value=material, valid="a Material")
        t0 = time.perf_counter()
        self.pair, self.material, self.n_slices = pair, material, int(n_slices)
        self.tca = tca or TCA(pair, side=side)
        self.side = self.tca.side
        self.slicer = SliceSolver(self.tca)
        g1, g2 = pair.pinion, pair.gear
        if r_int is None:
            r_int = (0.5 * g1.r_f, 0.5 * g2.r_f)
        self.r_int = tuple(float(check_number(f"{n}.r_int", v, "inner radius of the gear body [mm]"))
                           for n, v in zip(("pinion", "gear"), r_int))
        tk = dict(body=s.body, helical=s.helical)
        self.teeth = (ToothCompliance(self.tca.pinion.unmodified, material, self.r_int[0], member="pinion", **tk),
                      ToothCompliance(self.tca.gear.unmodified, material, self.r_int[1], member="gear", **tk))
        lam = 0.5 * (g1.r_a - g1.r_f) if coupling is None else coupling
        if not 0.0 <= lam <= 10 * g1.b:
            raise out_of_range("coupling", lam, f"0 <= coupling <= {10 * g1.b:g} mm (10 face widths)", cls=OptionError)
        self.coupling_length = float(lam)
        if body_coupling is None:
            self.body_coupling = tuple(body_coupling_length(t) for t in self.teeth)
        else:
            lb = body_coupling
            if not 0.0 <= lb <= 100 * g1.b:
                raise out_of_range("body_coupling", lb, f"0 <= body_coupling <= {100 * g1.b:g} mm (100 face widths)",
                                   cls=OptionError)
            self.body_coupling = (float(lb), float(lb))
        self.cos_bb = math.cos(g1.beta_b)
        self.compliance = compliance
        self.curvature = curvature
        # the pairs' coupling through the bodies (gearopt.ltca.neighbours): a term of the analytical compliance;
        # FE coefficients are their members' own models (3-tooth sectors), without it
        nb = s.neighbours
        if nb == "auto":
            nb = "full_gear" if compliance == "analytical" else "none"
        if nb == "full_gear" and compliance != "analytical":
            raise out_of_range("neighbours", nb, "'none' with compliance = 'fe' (the coupling through the bodies is a "
                               "term of the analytical compliance)", cls=OptionError)
        self.neighbours = nb
        self.neighbour_terms = (tuple(NeighbourTerm.of(tc, t.unmodified) for tc, t in
                                      zip(self.teeth, (self.tca.pinion, self.tca.gear))) if nb == "full_gear" else None)
        self._influence = None
        self._fe_mesh = fe_mesh
        if compliance == "fe" and self.side != "right":
            raise out_of_range("side", self.side, "'right' with compliance = 'fe' (the FE model loads the right "
                               "flank)", cls=OptionError)
        self._qp: dict = {}
        self.build_time = time.perf_counter() - t0

    @property
    def influence(self) -> tuple[InfluenceGrid, InfluenceGrid] | None:
        """The members' FE influence grids (pinion, gear) with ``compliance = "fe"``, else None.
        Computed (CalculiX, or the disk cache) on first use, i.e. by the first solve: building an
        LTCA validates its inputs and runs nothing (``gearopt check`` writes nothing)."""
        if self.compliance != "fe":
            return None
        if self._influence is None:
            from ..fea.influence import influence_grid

            self._influence = tuple(influence_grid(t.unmodified, self.material.E, self.material.nu,
                                                   mesh=self._fe_mesh, r_form=self.tca.form_radius(m))
                                    for m, t in ((1, self.tca.pinion), (2, self.tca.gear)))
        return self._influence

    @influence.setter
    def influence(self, grids: tuple[InfluenceGrid, InfluenceGrid] | None) -> None:
        """Replace the influence grids (pinion, gear) of an ``"fe"`` engine (e.g. without their
        local excess)."""
        self._influence = None if grids is None else tuple(grids)

    # ------------------------------------------------------------------------------------------
    def default_pairs(self) -> tuple[int, ...]:
        """Tooth pairs that can be in mesh over one mesh cycle around phi1 = 0."""
        m = int(math.floor((self.pair.eps_gamma + 1.0) / 2.0 + 0.3))
        return tuple(range(-m, m + 1))

    def mesh_cycle(self, n: int = 64) -> np.ndarray:
        """``n`` pinion angles over one mesh cycle, ``[-pi/z1, pi/z1)`` [rad]."""
        z1 = self.pair.pinion.z
        return np.linspace(-math.pi / z1, math.pi / z1, int(n), endpoint=False)

    def slices(self, phi1: npt.ArrayLike | None = None, p1: npt.ArrayLike | None = None,
               p2: npt.ArrayLike | None = None, mis: Misalignment | None = None, pairs: Sequence[int] | None = None,
               offsets: tuple[npt.ArrayLike, npt.ArrayLike] | None = None) -> SliceSet:
        """Unloaded slices (the separations) at ``phi1`` [rad] (default: one mesh cycle of 64);
        ``offsets``: pitch deviations of the pairs' teeth (:meth:`SliceSolver.solve`)."""
        phi1 = self.mesh_cycle() if phi1 is None else phi1
        pairs = self.default_pairs() if pairs is None else pairs
        return self.slicer.solve(phi1, p1, p2, mis, pairs, self.n_slices, offsets=offsets)

    @staticmethod
    def validate_torques(torque: float | Sequence[float]) -> np.ndarray:
        """The torque(s) [N m] as an array; :class:`OptionError` naming ``torque`` unless each is a
        finite number > 0 and a list strictly increases."""
        try:
            T = np.atleast_1d(np.asarray(torque, dtype=float))
        except (TypeError, ValueError):
            T = None
        if T is None or T.ndim != 1 or T.size == 0 or isinstance(torque, (str, bytes, bool)):
            raise out_of_range("torque", torque, "a pinion torque [N m] > 0 or a strictly increasing list of them",
                               cls=OptionError)
        for v in T:
            if not (np.isfinite(v) and v > 0):
                raise out_of_range("torque", float(v), "0 < torque < inf [N m] (pinion torque)", cls=OptionError)
        if T.size > 1 and np.any(np.diff(T) <= 0):
            raise out_of_range("torque", T.tolist(), "a strictly increasing list of pinion torques [N m]",
                               cls=OptionError)
        return T

    def structure(self, S: SliceSet) -> ContactStructure:
        """The load-independent parts of the contact problem of the slices ``S``: the tooth and body
        compliance matrices per position and the Hertz data per slice node
        (:class:`ContactStructure`)."""
        g1, g2 = self.pair.pinion, self.pair.gear
        K, N, M = S.z.shape
        cb = self.cos_bb

        def tooth_frame(r, n, zsec, gear):
            # rotate each section's tooth back onto +y (helix: the section z is turned by sigma z tan(beta) / r_p)
            ang = -gear.helix_sign * np.tan(gear.beta) / gear.r_p * zsec if not gear.is_spur else np.zeros_like(zsec)
            c, s = np.cos(ang), np.sin(ang)
            rot = lambda v: np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)  # noqa: E731
            return rot(r), rot(n)

        used = np.isfinite(S.z)
        z1 = np.where(used, S.z, 0.0)
        z2 = np.where(np.isfinite(S.z2), S.z2, z1)
        # each tooth is loaded along the slice force's line of action (at a tip edge the mating flank's
        # normal, not the edge member's own flank normal continued to its tip)
        xy1, n1 = tooth_frame(S.r1, S.n1 if S.nc1 is None else S.nc1, z1, g1)
        xy2, n2 = tooth_frame(S.r2, S.n2 if S.nc2 is None else S.nc2, z2, g2)
        c1 = self.teeth[0].per_width(xy1.reshape(-1, 2), n1.reshape(-1, 2))
        c2 = self.teeth[1].per_width(xy2.reshape(-1, 2), n2.reshape(-1, 2))
        act = S.active

        def filled(c):  # inactive or degenerate nodes: the mean of the active ones (they carry no load)
            c = c.reshape(K, N, M)
            ok = np.where(act & np.isfinite(c) & (c > 0), c, np.nan)
            return np.where(np.isfinite(ok), ok, np.nanmean(ok) if np.isfinite(ok).any() else 1e-4)

        ct = filled(c1.total + c2.total)
        # the tooth (bending, shear, compression of both teeth) and each member's body (Sainsot's term),
        # coupled across the face over their own lengths (compliance.face_matrix_batch)
        parts = [(filled(c1.total - c1.foundation + c2.total - c2.foundation), self.coupling_length),
                 (filled(c1.foundation), self.body_coupling[0]), (filled(c2.foundation), self.body_coupling[1])]
        rad1 = np.hypot(S.r1[..., 0], S.r1[..., 1])
        rad2 = np.hypot(S.r2[..., 0], S.r2[..., 1])
        # bending/shear/foundation matrix of each pair over the used nodes: cos^2(beta_b) D A^-1 D
        # (analytical), or both members' FE influence coefficients at the slices' points
        Cs = np.zeros((N, K * M, K * M))
        if self.influence is not None:
            G1, G2 = self.influence
            for k in range(K):
                for n in range(N):
                    u = np.flatnonzero(used[k, n])
                    idx = k * M + u
                    Cs[n][np.ix_(idx, idx)] = (G1.matrix(rad1[k, n, u], z1[k, n, u])
                                               + G2.matrix(rad2[k, n, u], z2[k, n, u]))
        else:
            # the face coupling on the tooth's own widths (the slices fixed to the tooth), not the contact's
            wt = S.width if S.width_tooth is None else S.width_tooth
            blocks = cb**2 * face_matrix_batch(S.z.reshape(K * N, M), wt.reshape(K * N, M),
                                               [(c.reshape(K * N, M), lam) for c, lam in parts]).reshape(K, N, M, M)
            Cv = Cs.reshape(N, K, M, K, M)
            for k in range(K):
                Cv[:, k, :, k, :] = blocks[k]
            if self.neighbour_terms is not None:
                # the pairs coupled through the bodies (docs/ltca.md section 2, gearopt.ltca.neighbours (N1))
                Cs = cross_blocks(Cs, S.pairs, (np.where(used, S.z, np.nan), np.where(used, z2, np.nan)), wt,
                                  self.neighbour_terms, self.body_coupling, cb)
        # Hertz data per node: reduced radius across the contact line, depths to the centrelines, line
        # length. The curvature of each flank is its own surface's at the point (SliceSet.kappa: profile
        # crowning, reliefs and every modification change it); the involute's cos(beta_b) / rho_t where
        # that is missing, a tip edge's rounding radius on an edge
        k1 = np.sqrt(np.maximum(rad1**2 - g1.r_b**2, 1e-12)) ** -1 * cb
        k2 = np.sqrt(np.maximum(rad2**2 - g2.r_b**2, 1e-12)) ** -1 * cb
        if S.kappa1 is not None and self.curvature == "surface":
            k1 = np.where(np.isfinite(S.kappa1), S.kappa1, k1)
            k2 = np.where(np.isfinite(S.kappa2), S.kappa2, k2)
        if S.edge is not None:
            k1 = np.where(S.edge == 1, 1.0 / (EDGE_RADIUS * g1.m_n), k1)
            k2 = np.where(S.edge == 2, 1.0 / (EDGE_RADIUS * g2.m_n), k2)
        R = 1.0 / np.maximum(k1 + k2, 1e-6)  # (a flat or concave-convex pair beyond: 1 m)
        h1 = c1.h.reshape(K, N, M)
        h2 = c2.h.reshape(K, N, M)
        if self.influence is not None:
            # FE coefficients: the local compression of each member's actual tooth section from FE, Weber's
            # bracket + kappa = ln(2 h e^kappa / b_H) (gearopt.fea.local, docs/ltca.md section 5), on the flank
            # slices; the depth measured in the plane across the contact line, where the local problem is
            # plane strain: the transverse depth h projects to h cos(beta_b) there
            flank = np.ones((K, N, M), bool) if S.edge is None else S.edge == 0
            G1, G2 = self.influence
            h1 = np.where(flank, h1 * cb * np.exp(G1.local_excess(rad1)), h1)
            h2 = np.where(flank, h2 * cb * np.exp(G2.local_excess(rad2)), h2)
        length = S.width / cb
        return ContactStructure(Cs=Cs, parts=tuple(CompliancePart(c, lam) for c, lam in parts),
                                R=np.where(act, R, 1.0), h1=np.where(act, h1, 1.0), h2=np.where(act, h2, 1.0),
                                length=np.where(act, length, 1.0), radius1=rad1, radius2=rad2, ct=ct)

    def _weber_tangent(self, n: int) -> ca.Function:
        key = ("weber", n)
        if key not in self._qp:
            self._qp[key] = weber_tangent(self.material).map(n)
        return self._qp[key]

    def _solver(self, n: int, N: int) -> ca.Function:
        key = (n, N)
        if key not in self._qp:
            # qpOASES: an exact active-set method (daqp leaves loads of ~1e-8 W on slices that are
            # out of contact when the separations dominate, i.e. at light loads)
            with _quiet_stdout():
                qp = ca.conic("ltca_qp", QP_SOLVER, {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(1, n)},
                              {"error_on_fail": False, "printLevel": "none"})
                self._qp[key] = (qp, qp.map(N))
        return self._qp[key][1]

    def solve(self, torque: float | Sequence[float], phi1: npt.ArrayLike | None = None, p1: npt.ArrayLike | None = None,
              p2: npt.ArrayLike | None = None, mis: Misalignment | None = None, pairs: Sequence[int] | None = None,
              slices: SliceSet | None = None, offsets: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
              structure: ContactStructure | None = None) -> LoadedSweep:
        """Loaded TCA at one or several pinion torques.

        Parameters
        ----------
        torque : float or sequence of float
            Pinion torque(s) [N m], each > 0 and finite; a list must be strictly increasing.
        phi1 : array_like, optional
            Pinion angles [rad] (default: one mesh cycle of 64 positions).
        p1, p2, mis, pairs
            As :meth:`TCA.sweep` (default pairs: every pair that can mesh in the cycle).
        slices : SliceSet, optional
            Precomputed unloaded slices (:meth:`slices`) of the same positions and design.
        offsets : (e1, e2), optional
            Angular position deviations of the pinion and gear teeth of each pair [rad] (pitch
            deviations, :meth:`SliceSolver.solve`).
        structure : ContactStructure, optional
            :meth:`structure` of ``slices``, computed already (the loaded micro-geometry optimiser's
            linearisation holds it); only with ``slices``.

        Returns
        -------
        LoadedSweep
        """
        T = self.validate_torques(torque)
        if structure is not None and (slices is None or not isinstance(structure, ContactStructure)):
            raise ArgumentError("structure: LTCA.structure of the slices given as slices= (a ContactStructure), "
                                "and only with slices.", param="structure", value=type(structure).__name__,
                                valid="a ContactStructure of slices=")
        t0 = time.perf_counter()
        S = slices if slices is not None else self.slices(phi1, p1, p2, mis, pairs, offsets)
        t_sep = time.perf_counter() - t0
        st = structure if structure is not None else self.structure(S)
        results = []
        for t in T:  # each torque's first contact set: the previous torque's (a warm start)
            results.append(self._solve_one(float(t), S, st, start=results[-1] if results else None))
        return LoadedSweep(slices=S, results=results, separation_time=t_sep, structure=st,
                           te_zero_rad=S.phi2_ref, ltca=self)

    def _fixed_point(self, A, s, hz: HertzNodes, Cs, W, f_min, F0=None, lam=None, block=None, P0=None):
        """The contact QP over the slices ``A`` (N, n) of each position (separations ``s``, Hertz data
        ``hz`` (N, n) and compliance ``Cs`` (N, n, n), :class:`ContactStructure`), with the Hertz fixed point:
        ``(F (N, n), done (N,), change (N,), iterations (N,))``. ``lam`` (N, n): each slice's lever
        about the pinion axis over ``r_b1 cos(beta_b)`` (the equilibrium ``sum lam F = W``; default 1).
        ``block``: the nodes per tooth pair (``Cs`` is block diagonal: pairs are not coupled); default
        one block. ``P0`` (N, n): without ``F0``, the active-set method's first contact set (default every
        slice of ``A``; the solution does not depend on it).

        Each Newton step's QP is solved by the primal-dual active-set method on all positions at once
        (:func:`contact_active_set`), started from the previous step's contact set; a position where
        that does not settle is solved again by qpOASES (:meth:`_fixed_point_qpoases`)."""
        N, n = A.shape
        M = n if block is None else int(block)
        K = n // M
        Cv = Cs.reshape(N, K, M, K, M)
        Cb = np.moveaxis(Cv[:, np.arange(K), :, np.arange(K), :], 0, 1)  # (N, K, M, M)
        if any(np.any(Cv[:, k, :, j, :]) for k in range(K) for j in range(K) if j != k):  # pairs coupled: one block
            nc = int(max(A.sum(axis=1).max(), 1))
            if nc < n:
                return self._fixed_point_compact(A, s, hz, Cs, W, f_min, nc, F0=F0, lam=lam, P0=P0)
            K, M = 1, n
            Cb = Cs.reshape(N, 1, n, n)
        valid = A
        lamv = np.where(valid, np.ones((N, n)) if lam is None else lam, 0.0)
        lv = np.where(valid, hz.length, 1.0)
        Rv, h1v, h2v = (np.where(valid, v, 1.0) for v in (hz.R, hz.h1, hz.h2))
        # start: the load spread over the active contact length, or the previous round's loads
        Fc = np.where(valid, W * lv / np.maximum((lv * valid).sum(axis=1, keepdims=True), 1e-12), 0.0)
        P = valid.copy() if P0 is None else valid & P0
        P = np.where(P.any(axis=1, keepdims=True), P, valid)
        if F0 is not None:
            Fc = np.where(valid, F0, 0.0)
            P = valid & (F0 > 0)
            P = np.where(P.any(axis=1, keepdims=True), P, valid)
        it = np.zeros(N, int)
        done = np.zeros(N, bool)
        change = np.zeros(N)
        bad = np.zeros(N, bool)
        shp = (N, K, M)
        for i in range(HERTZ_MAX_ITER):
            # Newton step of the Hertz law (Josephy-Newton: the QP with the approach linearised at the
            # last loads, delta_H(F) ~ c F_k + dc (F - F_k), dc = d(c f)/df by AD); its fixed point is the
            # contact law's, reached quadratically (the secant compliance c alone converges linearly)
            cH, dc = weber_tangent_array(Fc / lv, Rv, h1v, h2v, self.material, f_min)
            dc = np.maximum(dc, 0.5 * cH)  # keeps the QP convex far from the solution (a damped step)
            sk = s + np.where(valid, (cH - dc) / lv * Fc, 0.0)
            Fn, Pn, ok = contact_active_set(Cb, sk.reshape(shp), lamv.reshape(shp), valid.reshape(shp), W,
                                            P.reshape(shp), max_iter=ACTIVE_SET_MAX_ITER,
                                            diag=np.where(valid, dc / lv, 0.0).reshape(shp))
            Fn, P = Fn.reshape(N, n), Pn.reshape(N, n)
            bad |= ~ok
            Fn = np.where(valid, np.maximum(Fn, 0.0), 0.0)
            change = np.max(np.abs(Fn - Fc), axis=1) / W
            it = np.where(done, it, i + 1)
            done = change <= HERTZ_TOL
            Fc = Fn
            if (done | bad).all():
                break
        if bad.any():
            # the active-set iteration did not settle at some position: qpOASES there (the same QP)
            j = np.flatnonzero(bad)
            sub = HertzNodes(length=hz.length[j], R=hz.R[j], h1=hz.h1[j], h2=hz.h2[j])
            Fj, dj, cj, ij = self._fixed_point_qpoases(A[j], s[j], sub, Cs[j], W, f_min, F0=F0 if F0 is None else F0[j],
                                                       lam=None if lam is None else lam[j])
            Fc[j], done[j], change[j], it[j] = Fj, dj, cj, ij
        return Fc, done, change, it

    def _fixed_point_compact(self, A, s, hz: HertzNodes, Cs, W, f_min, nc, F0=None, lam=None, P0=None):
        """:meth:`_fixed_point` of coupled pairs (one dense block per position) on each position's valid
        nodes only, gathered into ``nc`` columns (padded with invalid nodes): the same QP, whose dense
        solves shrink from every node of every pair (most of them out of mesh) to the nodes that can carry
        load; arguments and returns as :meth:`_fixed_point`."""
        N, n = A.shape
        # each position's valid nodes first (stable: in their order), the rest as padding
        gi = np.argsort(~A, axis=1, kind="stable")[:, :nc]
        rows = np.arange(N)[:, None]
        Ac = A[rows, gi]
        take = lambda a: None if a is None else a[rows, gi]  # noqa: E731
        hzc = HertzNodes(length=take(hz.length), R=take(hz.R), h1=take(hz.h1), h2=take(hz.h2))
        Cc = Cs[rows[:, :, None], gi[:, :, None], gi[:, None, :]]
        Fc, done, change, it = self._fixed_point(Ac, take(s), hzc, Cc, W, f_min, F0=take(F0), lam=take(lam),
                                                 block=None, P0=take(P0))
        F = np.zeros((N, n))
        F[rows, gi] = np.where(Ac, Fc, 0.0)
        return F, done, change, it

    def _fixed_point_qpoases(self, A, s, hz: HertzNodes, Cs, W, f_min, F0=None, lam=None):
        """The contact QP over the slices ``A`` (N, n) of each position (separations ``s``, Hertz data
        ``hz`` (N, n) and compliance ``Cs`` (N, n, n), :class:`ContactStructure`), with the Hertz fixed point,
        each Newton step's QP solved by qpOASES (mapped over the positions); arguments and returns as
        :meth:`_fixed_point`."""
        N, n = A.shape
        nc = int(max(A.sum(axis=1).max(), 1))  # padded to the largest count
        gi = np.zeros((N, nc), int)
        valid = np.zeros((N, nc), bool)
        for j in range(N):
            a = np.flatnonzero(A[j])
            gi[j, :a.size], valid[j, :a.size] = a, True
        rows = np.arange(N)[:, None]
        take = lambda a: np.where(valid, a[rows, gi], 0.0)  # noqa: E731
        Cc = Cs[rows[:, :, None], gi[:, :, None], gi[:, None, :]]
        Cc = np.where(valid[:, :, None] & valid[:, None, :], Cc, 0.0)
        sc, lc, Rc, h1c, h2c = (take(v) for v in (s, hz.length, hz.R, hz.h1, hz.h2))
        lamc = np.where(valid, take(np.ones((N, n)) if lam is None else lam), 0.0)
        lc = np.where(valid, lc, 1.0)
        Rc, h1c, h2c = (np.where(valid, v, 1.0) for v in (Rc, h1c, h2c))
        eye = np.eye(nc)
        # start: the load spread over the active contact length, or the previous round's loads
        Fc = np.where(valid, W * lc / np.maximum((lc * valid).sum(axis=1, keepdims=True), 1e-12), 0.0)
        if F0 is not None:
            Fc = np.where(valid, F0[rows, gi], 0.0)
        qp = self._solver(nc, N)
        ubx = np.where(valid, np.inf, 0.0).T
        it = np.zeros(N, int)
        done = np.zeros(N, bool)
        change = np.zeros(N)
        wt = self._weber_tangent(N * nc)
        for i in range(HERTZ_MAX_ITER):
            # Newton step of the Hertz law (Josephy-Newton: the QP with the approach linearised at the
            # last loads, delta_H(F) ~ c F_k + dc (F - F_k), dc = d(c f)/df by AD); its fixed point is the
            # contact law's, reached quadratically (the secant compliance c alone converges linearly)
            cH, dc = (np.asarray(v).reshape(N, nc) for v in wt((Fc / lc).ravel()[None, :], Rc.ravel()[None, :],
                                                                 h1c.ravel()[None, :], h2c.ravel()[None, :], f_min))
            dc = np.maximum(dc, 0.5 * cH)  # keeps the QP convex far from the solution (a damped step)
            C = Cc + np.einsum("ni,ij->nij", np.where(valid, dc / lc, 1.0), eye)
            sk = sc + np.where(valid, (cH - dc) / lc * Fc, 0.0)
            # scaled: min 1/2 x^T (C / c_ref) x + (s_k / (W c_ref))^T x, x = F / W (same minimiser)
            cref = np.einsum("nii->n", C) / nc
            H = C / cref[:, None, None]
            with _quiet_stdout():  # qpOASES prints its banner on stdout whatever its printLevel
                r = qp(h=np.hstack(list(H)), g=(sk / (W * cref[:, None])).T, a=lamc.reshape(1, nc * N), lba=1.0,
                       uba=1.0, lbx=0.0, ubx=ubx)
            Fn = np.where(valid, np.maximum(W * np.asarray(r["x"]).T, 0.0), 0.0)
            change = np.max(np.abs(Fn - Fc), axis=1) / W
            it = np.where(done, it, i + 1)
            done = change <= HERTZ_TOL
            Fc = Fn
            if done.all():
                break
        F = np.zeros((N, n))
        jj, cc = np.nonzero(valid)
        F[jj, gi[jj, cc]] = Fc[jj, cc]
        return F, done, change, it

    def _solve_one(self, torque: float, S: SliceSet, st: ContactStructure,
                   start: LoadedResult | None = None) -> LoadedResult:
        t0 = time.perf_counter()
        g1, g2 = self.pair.pinion, self.pair.gear
        cb = self.cos_bb
        K, N, M = S.z.shape
        n = K * M
        W = torque * 1e3 / (g1.r_b * cb)  # normal load [N]
        act = S.active
        te0 = S.te_unloaded  # (N,)
        has = np.isfinite(te0)
        if not has.all():
            bad = S.phi1[~has]
            raise ConvergenceError(f"loaded TCA: no tooth pair in contact at {bad.size} of {N} positions (e.g. phi1 = "
                                   f"{bad[0]:.6g} rad): the positions must lie where the pair meshes.",
                                   param="phi1", value=float(bad[0]))
        lever = g2.r_b * cb
        # each slice's force acts along its own line of action (SliceSet.nc1): the gear turned back by
        # te0 - te closes the slice's gap by that angle times its lever about the gear axis, and the
        # pinion torque is the sum of the forces times their levers about the pinion axis,
        # sum lam_i F_i = W, lam_i = lever1_i / (r_b1 cos(beta_b)) (1 on an involute flank, less on a
        # tip edge); the equality's multiplier delta is the pinion's rigid advance times r_b1 cos(beta_b)
        lev2 = lever if S.lever2 is None else np.where(act & np.isfinite(S.lever2), S.lever2, lever)
        lam = (np.ones(S.z.shape) if S.lever1 is None
               else np.where(act & np.isfinite(S.lever1), S.lever1 / (g1.r_b * cb), 1.0))
        s = np.where(act, (te0[None, :, None] - S.te) * lev2, 0.0)  # (K, N, M) [mm]
        s = np.transpose(s, (1, 0, 2)).reshape(N, n)
        lam = np.transpose(lam, (1, 0, 2)).reshape(N, n)
        A = np.transpose(act, (1, 0, 2)).reshape(N, n)
        f_min = F_MIN_SHARE * W * cb / g1.b
        hz = st.by_position()
        length, R, h1, h2 = hz.length, hz.R, hz.h1, hz.h2
        # Working set: the flank slices and the tip-edge slices near contact; every other active
        # slice is checked after the solve (its gap s + C F must not fall below the approach) and
        # added if it would take load, then the QP is solved again. The result is the QP over all
        # active slices; the working set only keeps far-open tip edges out of the dense QP.
        A_all = A
        edge = (np.zeros(A.shape, bool) if S.edge is None
                else np.transpose(S.edge > 0, (1, 0, 2)).reshape(N, n))
        # first round: the tip edges within twice the approach that ISO 6336-1's c' = 14 N/(mm um)
        # (steel, scaled by E) suggests; the check below makes the result independent of this guess
        guess = EDGE_GUESS * W / (C_PRIME_STEEL * self.material.E / 210000.0 * g1.b)
        A = A_all & (~edge | (s <= guess))
        Cs = st.Cs
        F = None
        # the active-set method's first contact set: the slices loaded at the previous torque (the QP's
        # solution does not depend on it)
        P0 = None if start is None else np.transpose(start.load > 0, (1, 0, 2)).reshape(N, n)
        for _outer in range(OUTER_MAX):
            F, done, change, it = self._fixed_point(A, s, hz, Cs, W, f_min, F0=F, lam=lam, block=M, P0=P0)
            if not done.all():
                raise ConvergenceError(f"loaded TCA at {torque:g} N m: the Hertz fixed point did not settle in "
                                       f"{HERTZ_MAX_ITER} QP solves at {int((~done).sum())} positions (largest load "
                                       f"change {float(np.max(change)):.3g} W).", param="torque", value=torque)
            # s + C F [mm] with the final compliance: no load (no Hertz term) outside the working set
            cH, bH, p0 = weber_contact(F / length, R, h1, h2, self.material, f_min)
            d = s + np.einsum("nij,nj->ni", Cs, F) + np.where(A, cH / length * F, 0.0)
            loaded = A & (F > 1e-9 * W)
            delta = row_median(np.where(loaded, d / lam, np.nan))
            add = A_all & ~A & (d < np.where(np.isfinite(delta), delta, np.inf)[:, None] * lam - KKT_ADD_TOL)
            if not add.any():
                break
            A = A | add
        else:
            raise ConvergenceError(f"loaded TCA at {torque:g} N m: the set of loaded tip edges did not settle in "
                                   f"{OUTER_MAX} QP rounds.", param="torque", value=torque)
        # the contact conditions over every active slice (the gaps d above are those of the full QP)
        err_on = np.where(loaded, np.abs(d - delta[:, None] * lam), 0.0).max(axis=1)
        err_off = np.where(A_all & ~loaded, np.maximum(delta[:, None] * lam - d, 0.0), 0.0).max(axis=1)
        kkt = np.maximum(err_on, err_off)
        sum_err = np.abs((lam * F).sum(axis=1) - W) / W
        if not np.all(np.isfinite(delta)) or np.any(sum_err > 1e-6):
            raise ConvergenceError(f"loaded TCA at {torque:g} N m: the contact QP failed (load balance error "
                                   f"{float(np.nanmax(sum_err)):.3g} W).", param="torque", value=torque)
        back = lambda a: np.transpose(a.reshape(N, K, M), (1, 0, 2))  # noqa: E731
        Fk = back(F)
        te_l = te0 - delta / lever
        pair_load = Fk.sum(axis=2)
        lam_k = back(lam)
        width = np.where(S.width > 0, S.width, np.nan)
        p0_k, bH_k = (np.where(back(A_all), back(v), 0.0) for v in (p0, bH))
        if S.partner_of is not None and (S.partner_of >= 0).any():
            # a partner (a node past the flank boundary, SliceSet.active) carries its share of the contact
            # up to the crossing; the pressure there is the linear interpolation from its neighbour on the
            # flanks, p_i + t (p_o - p_i) at the crossing (t: SliceSet.partner_t), so the peak pressure is
            # continuous as the crossing runs to the neighbour (t -> 0) or onto the partner (t -> 1)
            kk, nn, mm = np.nonzero(S.partner_of >= 0)
            ii, t = S.partner_of[kk, nn, mm], S.partner_t[kk, nn, mm]
            for v in (p0_k, bH_k):
                v[kk, nn, mm] = v[kk, nn, ii] + t * (v[kk, nn, mm] - v[kk, nn, ii])
        result = LoadedResult(
            torque=torque, W=W, phi1=S.phi1, pairs=S.pairs, te_unloaded=te0, te_loaded=te_l, delta=delta,
            load=Fk, line_load=np.where(np.isfinite(S.z), Fk / width, np.nan),
            p0=p0_k, b_H=bH_k, pair_load=pair_load,
            share=(lam_k * Fk).sum(axis=2) / W, stiffness=W / delta / 1e3, kkt_error=kkt, hertz_iterations=it,
            solve_time=time.perf_counter() - t0, face_width=g1.b, stats={"qp_solver": QP_METHOD}, edge=S.edge,
            lever=lam_k * g1.r_b * cb)
        check_validity(result, self.pair, self.material)
        return result


def row_median(a: np.ndarray) -> np.ndarray:
    """Median of each row of ``a`` (N, n) over its finite entries (NaN: none), as ``np.median`` of
    those entries gives it (the mean of the two middle ones of an even count)."""
    a = np.sort(np.where(np.isfinite(a), a, np.inf), axis=1)
    c = np.isfinite(a).sum(axis=1)
    rows = np.arange(a.shape[0])
    lo, hi = a[rows, np.maximum((c - 1) // 2, 0)], a[rows, np.minimum(c // 2, a.shape[1] - 1)]
    with np.errstate(invalid="ignore"):
        return np.where(c > 0, np.where(c % 2 == 1, lo, (lo + hi) / 2), np.nan)


#: primal-dual active-set iterations of one contact QP (:func:`contact_active_set`) before qpOASES takes over
ACTIVE_SET_MAX_ITER = 40


def contact_active_set(C: np.ndarray, s: np.ndarray, lam: np.ndarray, valid: np.ndarray, W: float,
                       P0: np.ndarray | None = None, max_iter: int = ACTIVE_SET_MAX_ITER,
                       diag: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The contact QP ``min 1/2 F^T C F + s^T F  s.t.  F >= 0, sum lam F = W`` of many positions at
    once, by the primal-dual active-set method (Hintermüller, Ito & Kunisch 2002, for this
    complementarity problem the classical load-distribution iteration of loaded TCA).

    With a contact set P, the loads on P solve ``C_PP F_P - lam_P delta = -s_P`` and ``lam_P^T F_P = W``
    (``F = 0`` off P; ``delta`` the approach, the equality's multiplier); the gaps are
    ``g = s + C F - lam delta``. The next set keeps the nodes of P whose load is not negative (to
    1e-13 W) and adds those off P whose gap is negative (to 1e-13 of the approach); when the set
    repeats, ``F >= 0`` on P, ``g = 0`` on P and ``g >= 0`` off it: the QP's optimality conditions,
    so its unique minimiser (C positive definite).
    The compliance of different tooth pairs is not coupled, so each pair with nodes in P is solved
    alone (the others carry nothing) and the approach follows from the load balance.

    Parameters
    ----------
    C : (N, K, M, M) array
        Compliance blocks of the K tooth pairs at N positions [mm/N], symmetric positive definite on
        the valid nodes.
    s : (N, K, M) array
        Separations [mm].
    lam : (N, K, M) array
        The equality's coefficients (each slice's lever over ``r_b1 cos(beta_b)``, > 0 on valid nodes).
    valid : (N, K, M) bool array
        Nodes that may carry load (others carry none).
    W : float
        Total normal load [N] (> 0).
    P0 : (N, K, M) bool array, optional
        The contact set to start from (a warm start: the previous Newton step's; default every valid node).
    max_iter : int
        Iterations before a position is given up.
    diag : (N, K, M) array, optional
        Added to the diagonal of ``C`` [mm/N] (the Hertz term of a Newton step).

    Returns
    -------
    F : (N, K, M) array
        Loads [N] (NaN where not settled).
    P : (N, K, M) bool array
        The final contact sets.
    ok : (N,) bool array
        The iteration settled at the position.
    """
    N, K, M = s.shape
    P = valid.copy() if P0 is None else (P0 & valid)
    F = np.full(s.shape, np.nan)
    ok = np.zeros(N, bool)
    todo = np.flatnonzero(valid.any(axis=(1, 2)))
    eye = np.eye(M)
    # hysteresis of the set changes (a node at zero load within rounding neither leaves nor re-enters)
    f_tol = 1e-13 * W
    for _ in range(max_iter):
        if todo.size == 0:
            break
        Pt = P[todo]
        # only the pairs with contact nodes (the others carry nothing and add nothing to the gaps)
        tb, kb = np.nonzero(Pt.any(axis=2))
        nb = todo[tb]
        Pb, Cb = Pt[tb, kb], C[nb, kb]
        if diag is not None:
            Cb = Cb + diag[nb, kb][:, :, None] * eye
        Cm = np.where(Pb[:, :, None] & Pb[:, None, :], Cb, 0.0) + (~Pb)[:, :, None] * eye
        sb, lb = s[nb, kb], lam[nb, kb]
        xy = np.linalg.solve(Cm, np.stack([np.where(Pb, -sb, 0.0), np.where(Pb, lb, 0.0)], axis=-1))
        x, y = xy[..., 0], xy[..., 1]
        lx = np.bincount(tb, weights=np.sum(lb * x, axis=1), minlength=todo.size)
        ly = np.bincount(tb, weights=np.sum(lb * y, axis=1), minlength=todo.size)
        empty = ~Pt.any(axis=(1, 2))
        d = (W - lx) / np.where(empty, 1.0, ly)
        Fb = x + d[tb, None] * y
        Ft = np.zeros(Pt.shape)
        Ft[tb, kb] = Fb
        CF = np.zeros(Pt.shape)
        CF[tb, kb] = (Cb @ Fb[:, :, None])[:, :, 0]
        st, lt = s[todo], lam[todo]
        g = st + CF - d[:, None, None] * lt
        g_tol = 1e-13 * np.maximum(np.abs(d), np.max(np.abs(st), axis=(1, 2)))[:, None, None]
        Pn = valid[todo] & np.where(Pt, Ft > -f_tol, g < -g_tol)
        same = np.all(Pn == Pt, axis=(1, 2)) & ~empty
        F[todo[same]] = Ft[same]
        ok[todo[same]] = True
        P[todo] = Pn
        todo = todo[~same & ~empty]
    return F, P, ok


@dataclass
class LoadedSweep:
    """Loaded TCA over a list of torques (one :class:`LoadedResult` each) on one set of slices."""

    slices: SliceSet
    results: list
    separation_time: float
    structure: ContactStructure
    te_zero_rad: float
    ltca: LTCA

    @property
    def torques(self) -> np.ndarray:
        return np.array([r.torque for r in self.results])

    def te_vs_torque(self, z1: int) -> dict:
        """Peak-to-peak loaded TE and its first mesh harmonic against torque [arcsec]."""
        from ..report import te_harmonics

        pp = [r.peak_to_peak_arcsec for r in self.results]
        h1 = []
        for r in self.results:
            h = te_harmonics(r.phi1, r.te_loaded_arcsec, z1)
            h1.append(None if h is None else h[0])
        return {"torque_Nm": self.torques.tolist(), "peak_to_peak_arcsec": pp, "harmonic1_arcsec": h1}

    def to_dict(self, z1: int, nominal: float | None = None) -> dict:
        """The sweep as results.json holds it (every key, unit and meaning in docs/results.md):
        unloaded TE, one entry per torque (loaded TE, harmonics, load sharing, mesh stiffness,
        peak pressure, errors), the TE-vs-torque curve, and the slice maps (loads, pressure,
        contact bands on both flanks) at the ``nominal`` torque (default: the largest)."""
        from ..report import arr, te_harmonics

        S = self.slices
        res = self.results
        nom = res[-1] if nominal is None else min(res, key=lambda r: abs(r.torque - nominal))
        g1, g2 = self.ltca.pair.pinion, self.ltca.pair.gear
        per = []
        for r in res:
            env = r.te_loaded_arcsec
            ll = np.where(r.load > 0, r.line_load, np.nan)
            mean_ll = r.pair_load / np.maximum(np.nansum(np.where(np.isfinite(S.z), S.width, 0.0), axis=2), 1e-12)
            # K_Hbeta (ISO 6336-1, 3.4: peak over mean load per unit face width) of the flank contact that
            # carries the largest line load of the cycle: the factor of the most loaded point. (The largest
            # ratio over all pairs would be that of a pair just entering mesh with a few newtons near a
            # face end: a large ratio of a negligible load.) Tip-edge slices are not flank line loads.
            # Slivers (a flank slice trimmed at a tip crossing to less than a quarter of the nominal slice
            # width) carry a few newtons over microns: their load over width is no line load to quote.
            w_nom = float(np.nanmax(np.where(np.isfinite(S.z), S.width, np.nan)))
            whole = S.width >= SLIVER * w_nom
            on_flank = ((r.load > 0) if S.edge is None else (r.load > 0) & (S.edge == 0)) & whole
            ll_flank = np.where(on_flank & np.isfinite(r.line_load), r.line_load, 0.0)
            peak = np.max(ll_flank, axis=2)
            k_star, n_star = np.unravel_index(int(np.argmax(peak)), peak.shape)
            khb = (np.array([peak[k_star, n_star] / mean_ll[k_star, n_star]])
                   if peak[k_star, n_star] > 0 and r.pair_load[k_star, n_star] > 0 else np.array([np.nan]))
            kp, nphi, mm = np.unravel_index(int(np.nanargmax(r.p0_flank)), r.p0.shape)
            per.append({
                "torque_Nm": r.torque, "normal_load_N": r.W,
                "te_loaded_arcsec": arr(env), "peak_to_peak_arcsec": r.peak_to_peak_arcsec,
                "harmonics_arcsec": te_harmonics(r.phi1, env, z1),
                "pair_share": arr(r.share), "pair_load_N": arr(r.pair_load),
                "stiffness_N_per_um": arr(r.stiffness), "stiffness_mean_N_per_um": float(np.mean(r.stiffness)),
                "c_gamma_N_per_mm_um": r.c_gamma,
                "delta_mm": arr(r.delta),
                "p_max_MPa": r.p_max, "p_max_at": {"phi1": float(r.phi1[nphi]), "pair": int(S.pairs[kp]),
                                                   "z_mm": float(S.z[kp, nphi, mm]),
                                                   "radius_mm": float(self.structure.radius1[kp, nphi, mm])},
                "p_max_per_position_MPa": arr(np.max(r.p0_flank, axis=(0, 2))),
                "edge_share": arr(r.edge_share), "edge_share_max": float(np.max(r.edge_share)),
                "p_max_edge_MPa": r.p_max_edge,
                "line_load_max_N_per_mm": float(np.nanmax(np.where(whole, ll, np.nan)))
                if np.isfinite(np.where(whole, ll, np.nan)).any() else 0.0,
                "K_Hbeta": float(np.nanmax(khb)) if np.isfinite(khb).any() else None,
                "kkt_error_max_mm": float(np.max(r.kkt_error)), "hertz_iterations_max": int(np.max(r.hertz_iterations)),
                "solve_time_s": r.solve_time,
            })
        used = np.isfinite(S.z)
        loaded = used & (nom.load > 0)
        st = self.structure

        def flat(a):
            return arr(np.asarray(a)[loaded])

        pattern = {
            "torque_Nm": nom.torque,
            "pair": [int(S.pairs[k]) for k in np.nonzero(loaded)[0]],
            "phi1": [float(S.phi1[n]) for n in np.nonzero(loaded)[1]],
            "load_N": flat(nom.load), "line_load_N_per_mm": flat(nom.line_load), "p0_MPa": flat(nom.p0),
            "edge": flat(nom.edge if nom.edge is not None else np.zeros(S.z.shape)),
            "b_H_mm": flat(nom.b_H), "width_mm": flat(S.width),
            "pinion": {"axial": flat(S.z), "from": flat(S.z_lo), "to": flat(S.z_hi), "radius": flat(st.radius1),
                       "r_b": g1.r_b},
            "gear": {"axial": flat(S.z2), "from": flat(S.z_lo + S.z2 - S.z), "to": flat(S.z_hi + S.z2 - S.z),
                     "radius": flat(st.radius2), "r_b": g2.r_b},
        }
        n_pk = int(np.argmax(np.max(nom.p0_flank, axis=(0, 2))))  # the largest flank pressure
        face = {"phi1": float(S.phi1[n_pk]), "pairs": list(S.pairs),
                "axial": arr(S.z[:, n_pk, :]), "line_load_N_per_mm": arr(np.where(used[:, n_pk], nom.line_load[:, n_pk],
                                                                                   np.nan)),
                "p0_MPa": arr(np.where(used[:, n_pk], nom.p0[:, n_pk], np.nan)),
                "edge": arr(np.where(used[:, n_pk], nom.edge[:, n_pk], 0) if nom.edge is not None
                            else np.zeros(S.z[:, n_pk].shape))}
        return {
            "phi1": arr(S.phi1), "pairs": list(S.pairs), "te_zero_rad": self.te_zero_rad,
            "te_unloaded_arcsec": arr(S.te_unloaded * RAD_TO_ARCSEC),
            "unloaded_peak_to_peak_arcsec": float(np.ptp(S.te_unloaded) * RAD_TO_ARCSEC),
            "torques": per, "te_vs_torque": self.te_vs_torque(z1), "nominal_torque_Nm": nom.torque,
            "pattern": pattern, "face_load": face,
            "slices": {"n_slices": self.ltca.n_slices, "n_active": int(S.active.sum()), "stats": S.stats},
            "separation_time_s": self.separation_time,
        }
