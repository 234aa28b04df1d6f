"""The analytic references an FE position is checked against, and the checks themselves: Hertz's line
and point (ellipse) contact (:func:`hertz_line`, :func:`hertz_point`), the share of the peak pressure that
the penalty contact's compliant layer takes (:func:`penalty_layer_factor`, :func:`penalty_layer_estimate`),
ISO 6336-3's root stress on the generated fillet (:func:`root_stress_estimate`), and the sanity checks of
a deck and of a result (:func:`check_elements`, :func:`check_physics`)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..contact.hertz import C_PRIME_STEEL, contact_modulus, hertz_half_width, hertz_peak_pressure
from ..errors import ArgumentError, ConvergenceError, GeometryError
from ..geometry.generation import GeneratedTooth
from .calculix import CalculixError
from .mesh import hex_volume_sign

if TYPE_CHECKING:
    from ..settings import FEOptions

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


#: the Hertz reference of a tooth pair of :class:`~gearopt.fea.model.GearFEModel` (``GearFEModel.hertz``)
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
