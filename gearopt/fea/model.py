"""Finite element model of a gear drive at one position of the meshing cycle (Litvin section 9.5),
solved with CalculiX, and the analytic references it is checked against (Hertz, ISO 6336-3).

:class:`GearFEModel` takes a :class:`~gearopt.gears.GearPair` and a pinion angle ``phi1`` (the TCA
convention of :mod:`gearopt.meshing.tca`): the TCA gives the gear angle ``phi2`` with the flanks in
contact and the contact points of each tooth pair; ``teeth`` teeth of each member (mates of each
other) are meshed (:mod:`gearopt.fea.mesh`) and placed in the fixed frame S_f exactly as the TCA
places the surfaces:

    pinion: r_f = Rz(-phi1 + theta1) r_1          gear: r_f = (0, a, 0) + Rz(phi2) Rz(pi + theta2) r_2

A misalignment of the gear (``mis``: centre distance change, crossing and intersecting angles, axial
displacement) places the gear as the TCA does (:meth:`~gearopt.meshing.misalignment.Misalignment.gear_to_fixed`:
the axis turned by ``intersecting`` about x_f, then by ``crossing`` about y_f, the centre moved to
``(0, a + dE, axial)``); the gear is held at its rim in that position, so the pinion's rotation about
its own axis stays the one free degree of freedom.

Pinion tooth k (turned by ``k 2 pi / z1`` in its frame) meshes with gear tooth ``-k``.

Boundary conditions: the gear rim (bottom arc and both sector sides) is fixed; the pinion rim nodes
form a rigid body tied to a reference node on the pinion axis whose rotation about z is the only
free DOF. Step 1 prescribes a rotation in the driving direction that closes the contact (the estimated
loaded approach, :meth:`GearFEModel.approach_estimate`); step 2 releases it (``*BOUNDARY, OP=NEW``) and
applies the torque as a moment on the rotation node (docs/theory.md section 12.3, rule 1); step 3 repeats
the load with the contact faces paired again at the loaded state (docs/fea.md "Solver cost"). Contact:
element-face surfaces on the driving flanks, the gear master and the pinion slave, surface-to-surface
penalty contact with a LINEAR pressure-overclosure slope of ``penalty`` x E (50 E by default, docs/theory.md
section 12.3, rule 2), no ADJUST (rule 3), no friction.

Elements are 8-node hexahedra C3D8 (full integration). C3D8I (incompatible modes) was measured to
cost ~3.4x the equations for no gain in this contact/root-stress problem (docs/theory.md section 12.2), so it is not
offered by default (``element_type`` may still name it).

The torque is in N*mm internally (the scene takes N*m).
"""

from __future__ import annotations

import functools
import math
import os
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, ClassVar

import casadi as ca
import numpy as np

from ..errors import (ArgumentError, ConvergenceError, GearoptError, GeometryError, check_number,  # noqa: F401
                      option_error, out_of_range)
from ..gears import GearPair
from ..geometry.frames import rot_z_points
from ..geometry.generation import GeneratedTooth
from ..contact.hertz import C_PRIME_STEEL, contact_modulus, hertz_half_width, hertz_peak_pressure
from ..meshing.misalignment import Misalignment
from ..meshing.tca import TCA
from .calculix import CalculixError, Deck, last_block, read_contact_statistics, read_dat, read_frd_block, run_ccx
from .mesh import (GAUSS_C3D8, MemberMesh, ToothMesher, build_member, face_of, graded_params,
                   hex_volume_sign, shape)
from ..settings import FEOptions  # noqa: F401 - the option set of the model, declared in gearopt.settings
from .vtu import write_vtu

if TYPE_CHECKING:
    from pathlib import Path
    from .calculix import CcxRun

# c' = C_PRIME_STEEL (ISO 6336-1 single-pair stiffness of steel spur gears, ~14 N/(mm um)), scaled with E below.
#: A loaded approach along the line of action more than this many times the ISO estimate F / (c' b)
#: is not an elastic deflection (the docs/fea.md model measures ~0.75x: 19 N/(mm um) with its rims).
DEFLECTION_FACTOR = 20.0
#: A peak contact pressure in the section through the contact more than this many times its Hertz
#: estimate (line contact, or the ellipse of a point contact) means the load sits on a few nodes
#: (penetration, a bad mesh); CI meshes measure 0.9-1.1x (docs/fea.md).
PRESSURE_FACTOR = 3.0


def check_elements(nodes: np.ndarray, elements: np.ndarray) -> None:
    """Raise :class:`CalculixError` if any hexahedron of the deck is inverted (non-positive Jacobian
    at its centre; ``elements`` 1-based C3D8 connectivity (n, 8), ``nodes`` (m, 3) [mm])."""
    det = hex_volume_sign(np.asarray(nodes, float), np.asarray(elements, int) - 1)
    bad = np.flatnonzero(~(det > 0))
    if bad.size:
        raise CalculixError(f"{bad.size} inverted element(s) in the FE mesh (non-positive Jacobian at the centre; "
                            f"first: element {int(bad[0]) + 1}): ccx would return garbage. Coarsen the mesh along the "
                            "flank/fillet (n_flank, n_fillet) or check the tooth geometry; nothing was run.")


def check_physics(*, phi1: float, rotation: float, r_b1: float, F_n: float, b: float, E: float, p_max: float,
                  p0: float) -> None:
    """Physical sanity of one FE position; :class:`CalculixError` naming the first failed rule.

    Parameters
    ----------
    rotation : float
        Pinion rotation under load [rad] (from the rigid-rim rotation node).
    r_b1, b : float
        Pinion base radius and loaded face width [mm].
    F_n, E : float
        Normal load [N] and Young's modulus [MPa].
    p_max, p0 : float
        Peak FE contact pressure in the section through the contact and its Hertz estimate (line
        contact, or the ellipse of a point contact) [MPa].
    """
    at = f"FE result at phi1 = {phi1:.6g} rad"
    if not (math.isfinite(rotation) and math.isfinite(p_max)):
        raise CalculixError(f"{at}: non-finite pinion rotation ({rotation}) or contact pressure ({p_max}) in the ccx "
                            "output: the solution diverged; the result is not valid.")
    c_prime = C_PRIME_STEEL * E / 210e3
    est = F_n / (c_prime * b)  # approach along the line of action [mm]
    approach = abs(rotation) * r_b1
    if approach > DEFLECTION_FACTOR * est:
        raise CalculixError(f"{at}: the loaded approach along the line of action, |rotation| r_b1 = {approach:.4g} mm "
                            f"(loaded TE {rotation * 206264.806:.4g} arcsec of the pinion), is more than "
                            f"{DEFLECTION_FACTOR:g} x the ISO 6336-1 estimate F / (c' b) = {est:.4g} mm (c' = "
                            f"{c_prime / 1e3:.3g} N/(mm um) for E = {E:g} MPa): not an elastic deflection (the teeth "
                            "passed through each other or the model is not restrained); the result is not valid.")
    if p_max > PRESSURE_FACTOR * p0:
        raise CalculixError(f"{at}: peak contact pressure {p_max:.4g} MPa is more than {PRESSURE_FACTOR:g} x the Hertz "
                            f"estimate p0 = {p0:.4g} MPa: the load sits on a few nodes (penetration or a bad contact "
                            "mesh); the result is not valid. Refine the contact (n_hertz) or raise the penalty.")

MESH_STIFFNESS = C_PRIME_STEEL  #: single-pair mesh stiffness estimate c' [N/mm per mm of face] (ISO 6336-1 order)


# ---------------------------------------------------------------------------------------------
# analytic references
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HertzLine:
    """Hertz line contact of two cylinders, equal materials (:func:`hertz_line`)."""

    kind: ClassVar[str] = "line"  #: the contact's kind as results.json names it (``hertz_kind``)
    p0: float  #: peak pressure [MPa]
    b: float  #: half-width of the contact band [mm]
    R_star: float  #: reduced radius ``1 / (1 / rho1 + 1 / rho2)`` [mm]
    E_star: float  #: contact modulus ``E / (2 (1 - nu^2))`` [MPa]
    vm_max: float  #: largest von Mises stress, 0.557 p0 at depth 0.70 b (nu 0.3) [MPa]
    rho1: float  #: radius of curvature of the first body across the line [mm]
    rho2: float  #: the same of the second body [mm]

    @property
    def a(self) -> None:
        """No major semi-axis: the contact spans the line (:attr:`HertzPoint.a` of a point contact)."""
        return None


@dataclass(frozen=True)
class HertzPoint:
    """Hertz point contact (an ellipse), equal materials (:func:`hertz_point`)."""

    kind: ClassVar[str] = "ellipse"  #: the contact's kind as results.json names it (``hertz_kind``)
    p0: float  #: peak pressure [MPa]
    a: float  #: major semi-axis of the contact ellipse [mm]
    b: float  #: minor semi-axis [mm]
    k: float  #: axis ratio a / b >= 1
    R_star: float  #: ``1 / (l_min + l_max)`` [mm]


#: the Hertz reference of a tooth pair of :class:`GearFEModel` (``GearFEModel.hertz``)
Hertz = HertzLine | HertzPoint


def hertz_line(force_per_length: float, rho1: float, rho2: float, E: float, nu: float) -> HertzLine:
    """Hertz line contact of two cylinders of radii rho1, rho2 [mm], equal materials, under the load
    per unit length ``force_per_length`` [N/mm]; ``E`` [MPa], ``nu``.

    :class:`HertzLine`: p0 [MPa] (max pressure), b [mm] (half-width), R* [mm], E* [MPa] with
    ``1/R* = 1/rho1 + 1/rho2``, ``E* = E / (2 (1 - nu^2))``, ``p0 = sqrt(F' E* / (pi R*))``,
    ``b = sqrt(4 F' R* / (pi E*))``; also the max von Mises stress 0.557 p0 at depth 0.70 b (nu 0.3)."""
    Rs = 1.0 / (1.0 / rho1 + 1.0 / rho2)
    Es = contact_modulus(E, nu)
    p0 = float(hertz_peak_pressure(force_per_length, Rs, Es))
    b = float(hertz_half_width(force_per_length, Rs, Es))
    return HertzLine(p0=p0, b=b, R_star=Rs, E_star=Es, vm_max=0.557 * p0, rho1=rho1, rho2=rho2)


def hertz_point(force: float, lam: tuple[float, float], E: float, nu: float) -> HertzPoint:
    """Hertz point contact (equal materials) of a normal load ``force`` [N] between surfaces whose
    relative curvature matrix has the eigenvalues ``lam = (l_min, l_max)`` [1/mm] (sum of both
    surfaces' curvature matrices; the TCA's contact-ellipse data).

    The axis ratio k = a/b >= 1 solves ``(l_max - l_min)/(l_max + l_min) = ((k^2 + 1) E(e) - 2 K(e))
    / ((k^2 - 1) E(e))`` with ``e^2 = 1 - 1/k^2`` (K, E complete elliptic integrals); then
    ``a = (6 k^2 E(e) F R / (pi E'))^(1/3)``, ``b = a / k``, ``R = 1/(l_min + l_max)``,
    ``E' = E / (1 - nu^2)``, ``p0 = 3 F / (2 pi a b)`` (Harris, Rolling Bearing Analysis, ch. 6;
    Johnson, Contact Mechanics, 4.2).

    :class:`HertzPoint`: p0 [MPa], a, b [mm] (semi-axes, major first), k, R* [mm]."""
    from scipy.optimize import brentq
    from scipy.special import ellipe, ellipk

    l1, l2 = sorted(float(v) for v in lam)
    if not (l1 > 0 and l2 > 0):
        raise GeometryError(f"hertz_point: relative curvatures {l1:.4g}, {l2:.4g} 1/mm must be > 0 (convex contact).",
                            param="lam", value=[l1, l2], valid="both > 0")
    Fr = (l2 - l1) / (l2 + l1)

    def f(k):
        m = 1.0 - 1.0 / k**2
        return ((k**2 + 1) * ellipe(m) - 2 * ellipk(m)) / ((k**2 - 1) * ellipe(m)) - Fr

    k = 1.0 if Fr < 1e-12 else brentq(f, 1.0 + 1e-9, 1e8, xtol=1e-12)
    Ee = float(ellipe(1.0 - 1.0 / k**2))
    R = 1.0 / (l1 + l2)
    Ep = E / (1 - nu**2)
    a = (6 * k**2 * Ee * force * R / (math.pi * Ep)) ** (1 / 3)
    b = a / k
    return HertzPoint(p0=3 * force / (2 * math.pi * a * b), a=a, b=b, k=k, R_star=R)


def penalty_layer_factor(lam: float, n: int = 300) -> float:
    """Peak pressure of a Hertz line contact with a linear penalty layer between the bodies, over Hertz's.

    The contact model's LINEAR pressure-overclosure (``p = K g``, K = penalty x E) is a compliant layer
    in series with the bodies; it widens the contact and lowers its peak by a factor that depends on
    ``lam = E* / (K b)`` only (E* = E / (2 (1 - nu^2)), b the contact half-width). Two elastic
    half-spaces in plane strain, gap ``x^2 / (2 R)``: the surface displacement of a pressure p(s) is
    ``-(2 / (pi E*)) int p(s) ln|x - s| ds`` (Johnson, Contact Mechanics, ch. 2); with p piecewise
    constant on ``n`` cells the conditions ``p >= 0``, ``p / K + u + x^2 / (2 R) - delta >= 0``,
    complementary, at Hertz's load are solved by an active set (``delta`` an unknown). The same
    discretisation without the layer gives the reference, so the factor is 1 at ``lam = 0``.

    Parameters
    ----------
    lam : float
        ``E* / (K b)`` [-], >= 0 (50 E and b = 0.16 mm: 0.067).
    n : int
        Cells over the contact (the span grows with the layer's widening).

    Returns
    -------
    float
        Peak pressure with the layer over the peak without it [-], in (0, 1].
    """
    lam = float(lam)
    if not (math.isfinite(lam) and lam >= 0):
        raise ArgumentError(f"penalty_layer_factor: lam = {lam!r} must be finite and >= 0.", param="lam", value=lam,
                            valid=">= 0")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 20 <= n <= 4000:
        raise ArgumentError(f"penalty_layer_factor: n = {n!r} must be an integer, 20 <= n <= 4000 (cells).", param="n",
                            value=n, valid="an integer in [20, 4000]")
    return _layered_line_contact(lam, int(n))[0] / _layered_line_contact(0.0, int(n))[0]


@functools.lru_cache(maxsize=16)
def _layered_line_contact(lay, n):
    """(peak pressure, contact half-width) in Hertz units (b = 1, R = 1/2, E* = 1, p0 = 1) with the layer
    ``lay`` = E* / (K b) (penalty_layer_factor)."""
    span = 1.5 + 2.0 * lay ** (1 / 3)  # b = 1, R = 1/2, E* = 1: the contact grows as lam^(1/3) when soft
    for _ in range(8):
        x = np.linspace(-span, span, n + 1)
        h, xc = x[1] - x[0], 0.5 * (x[1:] + x[:-1])
        F = xc[:, None] - x[None, :]
        F = F * np.log(np.abs(F) + 1e-300) - F  # antiderivative of ln|t|
        A = -(2 / math.pi) * (F[:, :-1] - F[:, 1:]) + lay * np.eye(n)
        g = xc ** 2  # x^2 / (2 R)
        act = np.abs(xc) <= 1.0
        for _ in range(4 * n):
            ia = np.flatnonzero(act)
            M = np.zeros((ia.size + 1, ia.size + 1))
            M[:-1, :-1], M[:-1, -1], M[-1, :-1] = A[np.ix_(ia, ia)], -1.0, h
            sol = np.linalg.solve(M, np.r_[-g[ia], math.pi / 2])  # load pi b p0 / 2 with p0 = 1
            p = np.zeros(n)
            p[ia] = sol[:-1]
            drop, add = act & (p < 0), ~act & (A @ p + g - sol[-1] < 0)
            if not (drop.any() or add.any()):
                break
            act = (act & ~drop) | add
        else:
            raise ConvergenceError("penalty_layer_factor: the active set did not settle.")
        if not (act[0] or act[-1]):
            ia = np.flatnonzero(act)
            return float(p.max()), float(0.5 * (x[ia[-1] + 1] - x[ia[0]]))
        span *= 1.5
    raise ConvergenceError("penalty_layer_factor: the contact outgrew the span.")


def penalty_layer_estimate(p_mid: float, hertz: Hertz, options: "FEOptions") -> dict:
    """What the penalty layer does to a section's peak pressure ``p_mid`` [MPa] (:func:`penalty_layer_factor`).

    ``hertz`` is the model's Hertz reference of that pair (its ``p0`` [MPa], ``b`` [mm]); the half-width of the
    FE's own peak is ``b p_mid / p0`` (b grows as p0 at a fixed curvature, line and ellipse alike).
    Returns ``penalty_lambda`` = E* / (K b) [-], ``penalty_layer_factor`` [-] and ``p_max_mid_penalty_free``
    = p_mid / factor [MPa] (all None without pressure).
    """
    hz, o = hertz, options
    if not (math.isfinite(p_mid) and p_mid > 0):
        return {"penalty_lambda": None, "penalty_layer_factor": None, "p_max_mid_penalty_free": None}
    lam = o.E / (2 * (1 - o.nu ** 2)) / (o.penalty * o.E * hz.b * p_mid / hz.p0)
    f = penalty_layer_factor(lam)
    return {"penalty_lambda": lam, "penalty_layer_factor": f, "p_max_mid_penalty_free": p_mid / f}


def root_stress_estimate(tooth: GeneratedTooth, contact_radius: float, F_n: float, b: float) -> dict:
    """Tooth-root stress estimates for a normal load F_n [N] on the (right) flank at ``contact_radius``.

    ISO 6336-3 method B geometry, evaluated on the generated fillet itself: the critical section
    joins the points where the fillet tangent makes 30 deg with the tooth centreline (chord s_Fn),
    the load line meets the centreline at h_Fe above the section, at alpha_Fen from its normal.
    Nominal (Lewis-type) bending stress ``sigma_b = 6 F_n cos(alpha_Fen) h_Fe / (b s_Fn^2)`` and ISO's
    ``sigma_F0 = sigma_b Y_S`` with ``Y_S = (1.2 + 0.13 L) q_s^(1 / (1.21 + 2.3 / L))``,
    ``L = s_Fn / h_Fe``, ``q_s = s_Fn / (2 rho_F)`` (rho_F: fillet radius of curvature at the 30 deg
    point). ISO applies it with the load at the outer point of single contact; here the load sits at
    the analysed position. Spur gears only."""
    g = tooth.gear
    if not g.is_spur:
        raise GeometryError("root_stress_estimate: spur gears only (transverse = normal section).")
    u_f, phi_max = tooth.junction()
    n = 2000
    ph = np.linspace(0.0, phi_max, n)
    f = tooth.surface("right", "fillet").map(n)
    P = np.asarray(f(ph, 0.0, np.tile(tooth.p0[:, None], n))[0]).T[:, :2]
    t = np.gradient(P, ph, axis=0)
    ang = np.degrees(np.arctan2(np.abs(t[:, 0]), np.abs(t[:, 1])))  # tangent angle from the centreline (y)
    i = int(np.argmin(np.abs(ang - 30.0)))
    dd = np.gradient(t, ph, axis=0)
    curv = np.abs(t[:, 0] * dd[:, 1] - t[:, 1] * dd[:, 0]) / np.linalg.norm(t, axis=1) ** 3
    x_F, y_F = P[i]
    s_Fn = 2 * x_F
    rho_F = 1.0 / curv[i]
    u_c = tooth.u_at_radius(contact_radius)
    r, nrm, _ = tooth.point("right", "flank", u_c)
    # load on the tooth: along -n through r; where it meets x = 0
    d = -nrm[:2]
    y_L = r[1] + d[1] * (-r[0] / d[0])
    h_Fe = y_L - y_F
    cos_a = abs(d[0]) / np.linalg.norm(d)
    sigma_b = 6 * F_n * cos_a * h_Fe / (b * s_Fn**2)
    L = s_Fn / h_Fe
    q_s = s_Fn / (2 * rho_F)
    Y_S = (1.2 + 0.13 * L) * q_s ** (1.0 / (1.21 + 2.3 / L))
    return {"s_Fn": s_Fn, "h_Fe": h_Fe, "rho_F": rho_F, "alpha_Fen_deg": math.degrees(math.acos(cos_a)),
            "radius_30deg": float(math.hypot(x_F, y_F)), "sigma_lewis": sigma_b, "Y_S": Y_S,
            "sigma_iso": sigma_b * Y_S}


# ---------------------------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------------------------
_rotz = rot_z_points  # points (n, 3) about z (gearopt.geometry.frames)


def _principal_vm(S):
    """Max principal and von Mises stress of rows (sxx, syy, szz, sxy, sxz, syz)."""
    T = np.empty((len(S), 3, 3))
    T[:, 0, 0], T[:, 1, 1], T[:, 2, 2] = S[:, 0], S[:, 1], S[:, 2]
    T[:, 0, 1] = T[:, 1, 0] = S[:, 3]
    T[:, 0, 2] = T[:, 2, 0] = S[:, 4]
    T[:, 1, 2] = T[:, 2, 1] = S[:, 5]
    ev = np.linalg.eigvalsh(T)
    vm = np.sqrt(0.5 * ((S[:, 0] - S[:, 1]) ** 2 + (S[:, 1] - S[:, 2]) ** 2 + (S[:, 2] - S[:, 0]) ** 2)
                 + 3 * (S[:, 3] ** 2 + S[:, 4] ** 2 + S[:, 5] ** 2))
    return ev[:, 2], vm


def _face_layers(b: float, n_face: int, z_c: float, h: float, window: float, growth: float) -> np.ndarray:
    """Face layers [mm] graded towards ``z_c`` (size ``h`` within ``window``, growing by ``growth``
    per mm beyond, at most the uniform size ``b / n_face``), one layer on ``z_c``."""
    z_c = float(np.clip(z_c, -b / 2, b / 2))
    lo = graded_params(np.array([0.0, z_c + b / 2]), max(1, round(n_face * (z_c + b / 2) / b)), z_c + b / 2, h,
                        window, growth) - b / 2 if z_c > -b / 2 + 1e-9 else np.array([-b / 2])
    hi = graded_params(np.array([0.0, b / 2 - z_c]), max(1, round(n_face * (b / 2 - z_c) / b)), 0.0, h,
                        window, growth) + z_c if z_c < b / 2 - 1e-9 else np.array([b / 2])
    out = np.concatenate([lo[:-1], [z_c], hi[1:]]) if lo.size > 1 and hi.size > 1 else np.concatenate([lo, hi])
    return np.unique(np.round(out, 12))


def _with_breaks(z, breaks, keep=None) -> np.ndarray:
    """Face layers ``z`` [mm] (increasing, ends included) with a layer on every ``breaks`` value: the
    nearest interior layer moves there when it is within 0.3 of its element's length (no sliver),
    unless it is ``keep`` (the ellipse centre's layer); otherwise a layer is inserted."""
    z = np.array(z, float)
    for e in sorted(breaks):
        if np.min(np.abs(z - e)) < 1e-9:
            continue
        j = int(np.searchsorted(z, e))
        lo, hi = z[j - 1], z[j]
        near = j - 1 if e - lo <= hi - e else j
        movable = 0 < near < len(z) - 1 and (keep is None or abs(z[near] - keep) > 1e-9)
        if movable and abs(z[near] - e) < 0.3 * (hi - lo):
            z[near] = e
        else:
            z = np.insert(z, j, e)
    return z


def model_tca(pair: GearPair, mis: Misalignment | None = None) -> TCA:
    """The TCA that places the FE model's members: right flank driving, line contact for unmodified,
    aligned (or only dE/axially displaced) members, point contact for a crowned pinion or gear or an
    angular misalignment."""
    crowned = any(g.a_pl != 0 or g.rack.a_c != 0 for g in (pair.pinion, pair.gear))
    angular = mis is not None and any(getattr(mis, k) != 0 for k in Misalignment.names("angle"))
    return TCA(pair, side="right", contact="point" if crowned or angular else "line")


class GearFEModel:
    """FE model of ``pair`` at the pinion angle ``phi1`` [rad] (see the module docstring).

    Parameters
    ----------
    pair : GearPair
    phi1 : float
        Pinion angle (TCA convention: 0 = tooth 0's driving flank at the pitch point).
    options : FEOptions
    tca : TCA, optional
        A compiled TCA of the pair (right flank driving); built if omitted (line contact for
        unmodified, aligned members, point contact for a crowned pinion or a misaligned drive).
    mis : Misalignment, optional
        Misalignment of the gear (mm, rad); default aligned. Checked as the TCA checks it (a centre
        distance that jams or separates the teeth, faces that do not overlap: an error naming the key).
    """

    def __init__(self, pair: GearPair, phi1: float, options: FEOptions | None = None, tca: TCA | None = None,
                 mis: Misalignment | None = None) -> None:
        t0 = time.perf_counter()
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {type(pair).__name__}: expected a gearopt.gears.GearPair.",
                                param="pair", value=pair, valid="a gearopt.gears.GearPair")
        if options is not None and not isinstance(options, FEOptions):
            raise ArgumentError(f"options = {type(options).__name__}: expected an FEOptions.",
                                param="options", value=options, valid="an FEOptions")
        if mis is not None and not isinstance(mis, Misalignment):
            raise ArgumentError(f"mis = {type(mis).__name__}: expected a gearopt.meshing.misalignment.Misalignment.",
                                param="mis", value=mis, valid="a Misalignment")
        self.pair, self.phi1 = pair, check_number("phi1", phi1, "a finite pinion angle [rad]")
        self.opt = options or FEOptions()
        self.mis = mis or Misalignment()
        self.mis.check(pair, "mis")
        misaligned = bool(np.any(self.mis.vector() != 0))
        if tca is None:
            tca = model_tca(pair, self.mis)
        if tca.side != "right":
            raise option_error("tca.side", tca.side, "'right' (the FE model drives on the pinion's right flank)")
        self.tca = tca
        o = self.opt
        g1, g2 = pair.pinion, pair.gear
        n = o.teeth
        self.tooth_ids = list(range(-(n // 2), n - n // 2))
        res = tca.sweep(np.array([self.phi1]), pairs=self.tooth_ids, mis=self.mis if misaligned else None)
        on = res.on_surface[:, 0]
        if not on.any():
            why = "choose phi1 within the meshing cycle"
            if misaligned:
                why += (f", or a smaller misalignment ({self.mis.label()}): under it the contact may leave the "
                        "flanks (edge contact at a face end or a tip, which the FE model does not place); crowning "
                        "the pinion keeps the contact on the flanks")
            raise GeometryError(f"FE model at phi1 = {self.phi1:.6g} rad: no tooth pair of the {n} modelled is in "
                                f"contact on the active flanks (TCA); {why}.", param="phi1", value=self.phi1)
        self.phi2 = float(np.nanmax(np.where(on, res.phi2[:, 0], np.nan)))
        gap = (self.phi2 - res.phi2[:, 0]) * pair.gear.r_b  # separation of each pair along the line of action
        # pairs that the load can close: within twice the estimated loaded approach (ISO 6336-1 c'), at
        # least 5 um; their contact zones are graded (a coarse faceted flank would keep them open)
        reach = max(5e-3, 2.0 * o.torque / g1.r_b / (MESH_STIFFNESS * min(g1.b, g2.b)))
        self.loaded = [k for k, o_, gp in zip(self.tooth_ids, on, gap) if o_ and gp < reach]
        if not (g1.is_spur and g2.is_spur):  # inclined contact lines: a pair may touch off the middle section
            self.loaded = sorted(self.loaded + self._helical_reach(reach))
        self.contact = {k: {"u1": float(res.u1[i, 0]), "u2": float(res.u2[i, 0]), "z1": float(res.z1[i, 0]),
                            "z2": float(res.z2[i, 0]),
                            "radius1": float(res.radius1[i, 0]), "radius2": float(res.radius2[i, 0]),
                            "gap": float(gap[i]), "on_surface": bool(on[i])}
                        for i, k in enumerate(self.tooth_ids)}
        self.tca_result = res
        # Hertz reference for the full load on one pair (also sets the contact grading)
        F_n = o.torque / g1.r_b
        self.F_n = F_n
        b_eff = min(g1.b, g2.b)
        self.hertz: dict[int, Hertz] = {}
        cb = math.cos(g1.beta_b)
        point = tca.contact_type == "point"
        for i, k in enumerate(self.tooth_ids):
            if k not in self.loaded or not on[i]:  # the Hertz references: pairs touching in the middle section
                continue
            c = self.contact[k]
            if point and np.isfinite(res.ellipse_a[i, 0]) and np.isfinite(res.ellipse_b[i, 0]):
                # point contact: the Hertz ellipse of the whole normal load on this pair
                lam = (2 * res.delta / res.ellipse_a[i, 0] ** 2, 2 * res.delta / res.ellipse_b[i, 0] ** 2)
                self.hertz[k] = hertz_point(F_n / cb, lam, o.E, o.nu)
                continue
            # line contact in the normal section: load per contact-line length F_bt / b, radii rho_t / cos(beta_b)
            rho1 = math.sqrt(max(c["radius1"] ** 2 - g1.r_b**2, 1e-12)) / cb
            rho2 = math.sqrt(max(c["radius2"] ** 2 - g2.r_b**2, 1e-12)) / cb
            self.hertz[k] = hertz_line(F_n / b_eff, rho1, rho2, o.E, o.nu)
        b_H = min(h.b for h in self.hertz.values())
        mo = o.mesh
        if o.n_hertz > 0 and mo.h_contact == 0:
            mo = replace(mo, h_contact=b_H / o.n_hertz, window=mo.window or 1.5 * b_H)
        # point contact: face layers graded towards the ellipse centre (n_ellipse elements per major semi-axis)
        z_layers = None
        ell = [(self.contact[k]["z1"], self.contact[k]["z2"], h.a) for k, h in self.hertz.items()
               if isinstance(h, HertzPoint)] if o.n_ellipse > 0 else []
        if ell:
            z_c1, z_c2, a_e = min(ell, key=lambda t: abs(t[0]))  # the ellipse centre in each member's frame
            z_layers = {m: _face_layers(g.b, mo.n_face, z_c, a_e / o.n_ellipse, a_e, mo.growth) for m, g, z_c in
                        (("pinion", g1, z_c1), ("gear", g2, z_c2))}
        self.mesh_options = mo
        self.b_H = b_H
        # meshes (member frames), then placement in S_f
        self.pin_tooth = tca.pinion
        self.gear_tooth = tca.gear
        z_layers = dict(z_layers or {})
        # the mate's face ends inside a member's face (unequal face widths, an axial displacement) are
        # layers of that member: the contact ends there, and a layer across it would smear the end of
        # the pattern and its edge pressure over an element (gear frame: z - axial)
        ax = self.mis.axial
        for name, g, ends, keep in (("pinion", g1, (ax - g2.b / 2, ax + g2.b / 2), z_c1 if ell else None),
                                    ("gear", g2, (-g1.b / 2 - ax, g1.b / 2 - ax), z_c2 if ell else None)):
            inner = [e for e in ends if abs(e) < g.b / 2 - 1e-6]
            if inner:
                base = z_layers.get(name)
                z_layers[name] = _with_breaks(np.linspace(-g.b / 2, g.b / 2, mo.n_face + 1) if base is None else base,
                                              inner, keep)
        m1 = ToothMesher(self.pin_tooth, mo, z_layers=z_layers.get("pinion"))
        m2 = ToothMesher(self.gear_tooth, mo, z_layers=z_layers.get("gear"))
        cu1 = {k: self.contact[k]["u1"] for k in self.loaded}
        cu2 = {-k: self.contact[k]["u2"] for k in self.loaded}
        if not (g1.is_spur and g2.is_spur):
            # helical: the contact line is inclined across the face; grade each face layer at its own
            # contact point (the conjugate contact of the aligned, unmodified drive in that section)
            for k in self.loaded:
                lay = self._layer_contact(m1, m2, k)
                if lay is not None:
                    cu1[k], cu2[-k] = lay
        # a pair the load can close but with no contact point to grade at (none in the middle section nor
        # in two face layers): uniform rows on its flanks
        cu1 = {k: v for k, v in cu1.items() if np.all(np.isfinite(v))}
        cu2 = {k: v for k, v in cu2.items() if np.all(np.isfinite(v))}
        first1 = self._first_layer(g1, [self.contact[k]["radius1"] for k in self.loaded], mo)
        first2 = self._first_layer(g2, [self.contact[k]["radius2"] for k in self.loaded], mo)
        self.pinion_mesh = build_member(m1, self.tooth_ids, cu1, "pinion", first1)
        self.gear_mesh = build_member(m2, sorted(-k for k in self.tooth_ids), cu2, "gear", first2)
        self.nodes_pinion = _rotz(self.pinion_mesh.nodes, -self.phi1 + tca.theta1)
        self.nodes_gear = self.place_gear(self.gear_mesh.nodes)
        self.build_time = time.perf_counter() - t0

    def place_gear(self, X: np.ndarray) -> np.ndarray:
        """Points ``X`` (n, 3) of the gear's own frame [mm] placed in the fixed frame S_f at the model's
        gear angle, as the TCA places the gear surface: ``Rz(phi2) Rz(pi + theta2)``, then the
        misalignment (:meth:`Misalignment.gear_to_fixed`)."""
        Xa = _rotz(_rotz(np.asarray(X, float).reshape(-1, 3), math.pi + self.tca.theta2), self.phi2)
        m = self.mis.as_dict()
        R = np.column_stack([np.asarray(Misalignment.gear_to_fixed(m, ca.DM(e), 0.0, False), float).ravel()
                             for e in np.eye(3)])
        return Xa @ R.T + np.array([0.0, self.pair.a_w + self.mis.dE, self.mis.axial])

    def _section_contacts(self, k: int, zs):
        """The line contact of pair k of the aligned, unmodified teeth in the pinion sections ``zs``
        [mm]: (u1, u2, z2, phi2, radius1, radius2) arrays (phi2 with the pair's shift, as the TCA's),
        or None if a section has none."""
        tca, pair = self.tca, self.pair
        if getattr(self, "_lt", None) is None:
            self._lt = TCA(pair, side="right", pinion=tca.pinion.unmodified, gear=tca.gear.unmodified, contact="line")
        lt = self._lt
        lay = tca.layout
        flat1, flat2 = np.zeros(len(tca.pinion.unmodified.param_names)), np.zeros(len(tca.gear.unmodified.param_names))
        flat1[lay.p_index("pinion", "x")] = tca.pinion.p0[lay.p_index("pinion", "x")]
        flat2[lay.p_index("gear", "x")] = tca.gear.p0[lay.p_index("gear", "x")]
        phi = self.phi1 - 2 * math.pi * k / pair.pinion.z
        S1, S2 = tca.pinion.unmodified.surface("right", "flank"), tca.gear.unmodified.surface("right", "flank")
        rows = []
        w = None
        for z in zs:
            try:
                w = lt.solve_point(phi, w, flat1, flat2, None, float(z))
            except GearoptError:
                rows.append((np.nan,) * 6)  # no contact in this section (e.g. below a base circle)
                w = None
                continue
            r1 = np.asarray(S1(w[0], float(z), flat1)[0]).ravel()
            r2 = np.asarray(S2(w[1], w[2], flat2)[0]).ravel()
            rows.append((w[0], w[1], w[2], w[3] / lt.scale2 + 2 * math.pi * k / pair.gear.z, np.hypot(r1[0], r1[1]),
                         np.hypot(r2[0], r2[1])))
        out = tuple(np.array(c, float) for c in zip(*rows))
        return out if np.isfinite(out[0]).any() else None

    def _layer_contact(self, m1: ToothMesher, m2: ToothMesher, k: int):
        """Contact parameters (u1 per pinion layer, u2 per gear layer) of pair k: the line contact of
        the aligned, unmodified teeth in each pinion section (None if a section has none)."""
        sol = self._section_contacts(k, m1.z)
        if sol is None:
            return None
        u1, u2, z2 = sol[:3]
        ok = np.isfinite(u1) & np.isfinite(u2) & np.isfinite(z2)
        if ok.sum() < 2:
            return None
        # sections without a contact (the line runs below a base circle there): the nearest section's
        order = np.argsort(z2[ok])
        return np.interp(m1.z, m1.z[ok], u1[ok]), np.interp(m2.z, z2[ok][order], u2[ok][order])

    def _helical_reach(self, reach: float) -> list:
        """Helical pairs not touching in the middle section whose contact line lies on both active
        flanks in some section within ``reach`` [mm] of closing (they carry load)."""
        pair, tca = self.pair, self.tca
        g1, g2 = pair.pinion, pair.gear
        zs = np.linspace(-g1.b / 2, g1.b / 2, 9)
        f1, f2 = tca.form_radius(1), tca.form_radius(2)
        out = []
        for k in self.tooth_ids:
            if k in self.loaded:
                continue
            sol = self._section_contacts(k, zs)
            if sol is None:
                continue
            _, _, z2, phi2, rad1, rad2 = sol
            with np.errstate(invalid="ignore"):
                on = (rad1 >= f1) & (rad1 <= g1.r_a) & (rad2 >= f2) & (rad2 <= g2.r_a) & (np.abs(z2) <= g2.b / 2)
            on &= np.isfinite(phi2)
            if on.any() and float(np.min((self.phi2 - phi2[on]) * g2.r_b)) < reach:
                out.append(k)
        return out

    @staticmethod
    def _first_layer(g, radii, mo) -> float:
        if mo.h_contact <= 0 or not radii:
            return 0.0
        half = min(g.s_at(min(max(r, g.r_b), g.r_a)) / 2 for r in radii if math.isfinite(r))
        return mo.h_contact / half

    # ------------------------------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return len(self.pinion_mesh.elements) + len(self.gear_mesh.elements)

    @property
    def n_nodes(self) -> int:
        return len(self.pinion_mesh.nodes) + len(self.gear_mesh.nodes)

    def _flank_faces(self, mesh: MemberMesh, k: int, eoff: int, noff: int):
        """(element id, face) of the right flank of tooth k (1-based ids)."""
        t = next(t for t in mesh.teeth if t["k"] == k)
        r0, r1 = t["section"].segments["flank"]
        out = []
        nodes = t["nodes"]
        for L in range(nodes.shape[0] - 1):
            for R in range(r0, r1):
                e = int(t["elements"][L, R, -1])
                quad = {int(nodes[L, R, -1]), int(nodes[L, R + 1, -1]), int(nodes[L + 1, R, -1]),
                        int(nodes[L + 1, R + 1, -1])}
                out.append((e + 1 + eoff, face_of(mesh.elements[e], quad)))
        return out

    def _fillet_elements(self, mesh: MemberMesh, eoff: int, cols: int = 2):
        ids = []
        for t in mesh.teeth:
            a, b = t["section"].segments["fillet"][0], t["section"].segments["root"][1]
            ids.append(t["elements"][:, a:b, -cols:].ravel())
        return np.concatenate(ids) + 1 + eoff

    def approach_estimate(self) -> float:
        """Estimated loaded approach of the members along the line of action [mm], the step-1 rotation's
        measure (``close_fraction`` of it, docs/fea.md "Solver cost").

        The loaded pairs as springs of the ISO 6336-1 single-pair stiffness ``c' b`` in parallel (c'
        :data:`MESH_STIFFNESS` scaled with E, b the common face width), each taking load once the approach
        exceeds its unloaded separation ``g_k`` (the TCA's, ``contact[k]["gap"]``):
        ``sum_k c' b max(0, delta - g_k) = F_n``. The FE models are stiffer or softer than ISO's c': the
        converged approach is 0.92 (one pair) and 1.12-1.15 (two pairs) of the estimate on
        problems/fea_crowned.toml, 0.72 and 0.85 on problems/fea_spur.toml. It sets ccx's iterations; the
        results depend on it little (step 3 pairs the faces again at the loaded state): 0.8 instead of 1.0
        of it moves the rotation by 4e-7 to 2.5e-5 and the peak pressure mid face by 5e-6 to 1.2e-3
        (relative; docs/fea.md "Solver cost").
        """
        g1, g2 = self.pair.pinion, self.pair.gear
        cb = MESH_STIFFNESS * self.opt.E / 210e3 * min(g1.b, g2.b)
        gaps = sorted(g for g in (self.contact[k]["gap"] for k in self.loaded) if math.isfinite(g) and g >= 0)
        gaps = gaps or [0.0]
        for n in range(len(gaps), 1, -1):  # the pairs that close: the n smallest separations
            delta = (self.F_n / cb + sum(gaps[:n])) / n
            if delta >= gaps[n - 1]:
                return delta
        return self.F_n / cb + gaps[0]

    def deck(self) -> Deck:
        o = self.opt
        n1 = len(self.nodes_pinion)
        e1 = len(self.pinion_mesh.elements)
        nodes = np.vstack([self.nodes_pinion, self.nodes_gear])
        elems = np.vstack([self.pinion_mesh.elements + 1, self.gear_mesh.elements + 1 + n1])
        ref, rot = len(nodes) + 1, len(nodes) + 2
        pm, gm = self.pinion_mesh, self.gear_mesh
        nsets = {"PRIM": np.unique(np.r_[pm.rim_bottom, pm.rim_sides]) + 1,
                 "GFIX": np.unique(np.r_[gm.rim_bottom, gm.rim_sides]) + 1 + n1}
        surfaces, pairs = {}, []
        for k in self.tooth_ids:
            surfaces[f"SP{k + 10}"] = self._flank_faces(pm, k, 0, 0)
            surfaces[f"SG{k + 10}"] = self._flank_faces(gm, -k, e1, n1)
            pairs.append((f"SP{k + 10}", f"SG{k + 10}"))
        self._pfil = self._fillet_elements(pm, 0)
        self._gfil = self._fillet_elements(gm, e1)
        elsets = {"PFIL": self._pfil, "GFIL": self._gfil}
        g1 = self.pair.pinion
        close = -o.close_fraction * self.approach_estimate() / g1.r_b  # clockwise: the pinion's driving direction
        check_elements(nodes, elems)
        return Deck(nodes=nodes, elements=elems, nsets=nsets, elsets=elsets, surfaces=surfaces, contact_pairs=pairs,
                    ref_node=ref, rot_node=rot, rigid_nset="PRIM", fixed_nset="GFIX", E=o.E, nu=o.nu,
                    penalty=o.penalty * o.E, close_rotation=close, moment=-o.torque, print_elsets=["PFIL", "GFIL"],
                    element_type=o.element_type)

    def run(self) -> "FEResult":
        """Write the deck, run ccx, read and check the results (:class:`CalculixError` when the
        reaction misses T / r_b1 by more than 1 % or no contact pressure is positive)."""
        deck = self.deck()
        run = run_ccx(deck, threads=self.opt.threads, timeout=self.opt.timeout, keep_dir=self.opt.keep_dir)
        return FEResult.from_run(self, deck, run)


@dataclass
class FEResult:
    """Results of one FE position (JSON-able via :meth:`to_dict`)."""

    phi1: float
    phi2: float
    data: dict

    @classmethod
    def from_run(cls, model: GearFEModel, deck: Deck, run: CcxRun) -> "FEResult":
        blocks = read_dat(run.dat)
        o = model.opt
        g1, g2 = model.pair.pinion, model.pair.gear
        nodes = deck.nodes
        rf = last_block(blocks, "total force", "GFIX") or last_block(blocks, "forces", "GFIX")
        if rf is None or not rf.rows:
            raise CalculixError("ccx output has no reaction forces of the fixed gear rim (GFIX): the run did not "
                                "reach the load step.")
        R = np.array(rf.rows[-1][-3:], float)
        F_n = model.F_n
        if not np.all(np.isfinite(R)):
            raise CalculixError(f"ccx reports a non-finite reaction force {R.tolist()} at phi1 = {model.phi1:.6g} rad: "
                                "the solution diverged; the result is not valid.")
        rel = abs(np.linalg.norm(R[:2]) - F_n) / F_n
        rot = last_block(blocks, "displacements", "NROT")
        rotation = float(rot.rows[-1][-1]) if rot and rot.rows else float("nan")
        cs = last_block(blocks, "contact stress")
        if cs is None or not cs.rows:
            raise CalculixError(f"ccx reports no contact stress at phi1 = {model.phi1:.6g} rad: the flanks did not "
                                "come into contact (open gap); nothing to report.")
        C = np.array([r for r in cs.rows if len(r) >= 4], float)
        press = C[:, -3]
        if not np.any(press > 0):
            raise CalculixError(f"no positive contact pressure at phi1 = {model.phi1:.6g} rad (max {press.max():.4g} "
                                "MPa): the contact is open; the result is not valid.")
        if rel > 0.01:
            raise CalculixError(f"gear reaction |R| = {np.linalg.norm(R[:2]):.6g} N differs from T / r_b1 = {F_n:.6g} N "
                                f"by {100 * rel:.3g} % (> 1 %): the load did not pass through the contact; the result "
                                "is not valid (see docs/theory.md section 12.3, rule 1).")
        elems = deck.elements
        profiles, p_mid_max = cls._contact_profiles(model, run.frd)
        # stresses at integration points of the fillet elements
        roots = {}
        for member, es, tooth, place in (("pinion", "PFIL", model.pin_tooth, (0.0, model.phi1)),
                                         ("gear", "GFIL", model.gear_tooth, None)):
            blk = last_block(blocks, "stresses", es)
            if blk is None or not blk.rows:
                raise CalculixError(f"ccx output has no stresses for the {member} fillet elements ({es}).")
            S = np.array(blk.rows, float)
            if not np.all(np.isfinite(S)):
                raise CalculixError(f"ccx reports non-finite stresses in the {member} fillet elements ({es}) at phi1 = "
                                    f"{model.phi1:.6g} rad: the solution diverged; the result is not valid.")
            e = S[:, 0].astype(int) - 1
            ip = S[:, 1].astype(int) - 1
            N = np.array([shape(*GAUSS_C3D8[i]) for i in ip])
            X = np.einsum("ni,nij->nj", N, nodes[elems[e] - 1])
            s1, vm = _principal_vm(S[:, 2:8])
            if member == "pinion":
                rad = np.hypot(X[:, 0], X[:, 1])
            else:
                rad = np.hypot(X[:, 0], X[:, 1] - model.pair.a_w)
            mid = np.abs(X[:, 2]) <= 0.25 * min(g1.b, g2.b)
            i_mid = int(np.argmax(np.where(mid, s1, -np.inf)))
            roots[member] = {"max_principal": float(s1.max()), "max_principal_mid": float(s1[i_mid]),
                             "radius_at_max_mid": float(rad[i_mid]), "z_at_max_mid": float(X[i_mid, 2]),
                             "max_von_mises": float(vm.max()), "n_points": int(len(s1))}
        # the pair nearest the pitch point: its Hertz reference and the FE pressure at mid face
        k0 = min(model.hertz, key=lambda k: abs(model.contact[k]["radius1"] - g1.r_p))
        hz = model.hertz[k0]
        p_max_mid = p_mid_max.get(k0, float("nan"))
        # ISO / Lewis estimates of the root stress for the whole load on the loaded pair (single contact)
        est = {}
        for member, tooth, radius in (("pinion", model.pin_tooth, model.contact[k0]["radius1"]),
                                      ("gear", model.gear_tooth, model.contact[k0]["radius2"])):
            try:
                est[member] = root_stress_estimate(tooth, radius, F_n, min(g1.b, g2.b))
            except GeometryError as e:  # helical: no estimate
                est[member] = {"error": str(e)}
        # the pressure in the section through the contact against its Hertz reference (the overall peak
        # also holds the stress singularities where a contact line meets a tip edge or a face end)
        check_physics(phi1=model.phi1, rotation=rotation, r_b1=g1.r_b, F_n=F_n, b=min(g1.b, g2.b), E=o.E,
                      p_max=p_max_mid if math.isfinite(p_max_mid) else float(press.max()), p0=hz.p0)
        # normal contact force of each tooth pair (load sharing), from the contact statistics per pair
        stats = read_contact_statistics(run.dat)
        fn = {k: -float(stats.get(f"SP{k + 10}", {}).get("normal_force", 0.0)) for k in model.tooth_ids}
        pair_force = {str(k): (v if math.isfinite(v) and v > 0 else 0.0) for k, v in fn.items()}
        tot = sum(pair_force.values())
        # the contact pattern across the face, its level set by the pair's contact force
        pattern = cls._line_loads(model, run.frd)
        for k, pat in pattern.items():
            f = pair_force.get(k, 0.0)
            pat["nodal_over_force"] = pat["force"] / f if f > 0 else None
            if f > 0 and pat["force"] > 0:
                pat["q"] = [q * f / pat["force"] for q in pat["q"]]
            pat["force"] = f
        te_arcsec = rotation * (g1.z / g2.z) * 206264.806  # gear lag equivalent of the pinion's extra rotation
        data = {
            "phi1": model.phi1, "phi2": model.phi2, "loaded_pairs": model.loaded,
            "single_pair_contact": len(model.loaded) == 1,
            "contact_points": {str(k): {n: (x if not isinstance(x, float) or math.isfinite(x) else None)
                                        for n, x in v.items()} for k, v in model.contact.items()},
            "n_elements": model.n_elements, "n_nodes": model.n_nodes, "element_type": o.element_type,
            "reaction": {"gear_rim_force": R.tolist(), "magnitude": float(np.linalg.norm(R[:2])),
                         "T_over_rb1": F_n, "rel_error": float(rel)},
            "pair_force_N": pair_force, "pair_share": {k: (v / tot if tot > 0 else None) for k, v in pair_force.items()},
            "pinion_rotation_rad": rotation,
            "loaded_te_arcsec": float(te_arcsec),
            "contact": {"p_max": float(press.max()), "p_max_mid": p_max_mid,
                        "hertz_p0": hz.p0, "hertz_b": hz.b, "R_star": hz.R_star, "hertz_kind": hz.kind,
                        "hertz_a": hz.a if hz.a is not None and math.isfinite(hz.a) else None,
                        "ratio_mid_to_hertz": p_max_mid / hz.p0, "hertz_pair": k0,
                        **penalty_layer_estimate(p_max_mid, hz, o),
                        "profiles": profiles, "pattern": pattern,
                        "n_points": int(len(press)), "n_positive": int((press > 0).sum())},
            "root": roots, "root_estimate": est,
            "timing": {"build_s": model.build_time, "ccx_s": run.seconds},
        }
        for member in ("pinion", "gear"):
            e_ = est[member]
            if "sigma_iso" in e_:
                data["root"][member]["ratio_to_iso"] = roots[member]["max_principal_mid"] / e_["sigma_iso"]
                data["root"][member]["ratio_to_lewis"] = roots[member]["max_principal_mid"] / e_["sigma_lewis"]
        data = _jsonable(data)
        out = cls(phi1=model.phi1, phi2=model.phi2, data=data)
        out.deck, out.frd = deck, run.frd  # for write_vtu (not part of the results dictionary)
        return out

    def write_vtu(self, path: str | os.PathLike) -> Path:
        """The mesh with displacements, stresses and contact pressure as ``.vtu`` (ParaView),
        :func:`gearopt.fea.vtu.write_vtu`."""
        return write_vtu(self.deck, self.frd, path)

    @staticmethod
    def _contact_profiles(model, frd: str):
        """Nodal contact pressure (CPRESS of the .frd) along the pinion's driving flank of each tooth in
        the middle section z = 0: ``{tooth: {"s", "radius", "p"}}`` with ``s`` the arc length [mm]
        along the profile from the TCA contact point (positive towards the tip), and the maximum per tooth."""
        blk = read_frd_block(frd, "CONTACT")
        if blk is None:
            raise CalculixError("ccx wrote no nodal contact output (CONTACT block of the .frd).")
        out, pmax = {}, {}
        pm = model.pinion_mesh
        for t in pm.teeth:
            k = t["k"]
            r0, r1 = t["section"].segments["flank"]
            c = model.contact.get(k)
            zl = pm.nodes[t["nodes"][:, r0, -1]][:, 2]  # the face layers
            z_ref = c["z1"] if (c is not None and k in model.loaded) else 0.0
            layer = int(np.argmin(np.abs(zl - z_ref)))  # the section through the contact (mid face: line contact)
            ids = t["nodes"][layer, r0:r1 + 1, -1]
            X = pm.nodes[ids]
            p = np.array([blk.get(int(i) + 1, [0, 0, 0, 0])[3] for i in ids])
            arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(X, axis=0), axis=1))])
            u_rows = t["u_rows"] if np.ndim(t["u_rows"]) == 1 else t["u_rows"][layer]
            ok = k in model.loaded and np.all(np.diff(u_rows) > 0)
            s0 = float(np.interp(c["u1"], u_rows, arc)) if ok else 0.0
            out[str(k)] = {"s": (s0 - arc).tolist(), "radius": np.hypot(X[:, 0], X[:, 1]).tolist(), "p": p.tolist()}
            pmax[k] = float(p.max())
        return out, pmax

    @staticmethod
    def _line_loads(model, frd: str) -> dict:
        """The contact pattern of each loaded pair across the face, from the nodal contact pressure on
        the whole driving flank of its pinion tooth: ``{tooth: {"z", "q", "force", "z_centroid",
        "p_max", "z_at_p_max"}}``. The pressure is integrated over each flank quadrilateral of the mesh
        (its area times the mean of its four nodal pressures); ``q`` [N/mm] is the normal load per mm of
        face between two face layers (``z_layers``) at their mid ``z`` [mm] (pinion frame = S_f z), ``force`` [N]
        their sum and ``z_centroid`` [mm] the force-weighted centre of the pattern. (The nodal
        pressures of ccx integrate to more than the pair's contact force, 10 % on the default mesh of a
        spur pair: :meth:`from_run` scales ``q`` to the contact force and reports the ratio.)"""
        blk = read_frd_block(frd, "CONTACT")
        pm = model.pinion_mesh
        out = {}
        for t in pm.teeth:
            k = t["k"]
            if k not in model.loaded:
                continue
            r0, r1 = t["section"].segments["flank"]
            ids = t["nodes"][:, r0:r1 + 1, -1]  # (layers, rows)
            X = pm.nodes[ids]
            p = np.array([[blk.get(int(i) + 1, [0, 0, 0, 0])[3] for i in row] for row in ids])
            # quadrilateral (L, R): corners (L, R), (L, R+1), (L+1, R+1), (L+1, R); area from its diagonals
            d1 = X[1:, 1:] - X[:-1, :-1]
            d2 = X[1:, :-1] - X[:-1, 1:]
            area = 0.5 * np.linalg.norm(np.cross(d1, d2), axis=-1)
            pq = 0.25 * (p[:-1, :-1] + p[:-1, 1:] + p[1:, :-1] + p[1:, 1:])
            F = area * pq
            zq = 0.25 * (X[:-1, :-1, 2] + X[:-1, 1:, 2] + X[1:, :-1, 2] + X[1:, 1:, 2])
            zl = X[:, :, 2].mean(axis=1)
            tot = float(F.sum())
            i, j = np.unravel_index(int(np.argmax(p)), p.shape)
            out[str(k)] = {"z": (0.5 * (zl[1:] + zl[:-1])).tolist(), "z_layers": zl.tolist(),
                           "q": (F.sum(axis=1) / np.diff(zl)).tolist(),
                           "force": tot, "z_centroid": float((F * zq).sum() / tot) if tot > 0 else None,
                           "p_max": float(p.max()), "z_at_p_max": float(X[i, j, 2])}
        return out

    def to_dict(self) -> dict:
        return self.data


def _jsonable(v):
    """Plain Python floats/ints/lists (NumPy scalars converted, non-finite floats as None)."""
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v
