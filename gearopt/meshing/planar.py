r"""Tooth contact analysis of two planar involute profiles (Litvin & Fuentes, Problem 9.4.1).

Frames and profiles
-------------------
S1, S2 are rigidly connected to the driving gear 1 and the driven gear 2, S_f to the frame
(Fig. 9.4.2). O1 (axis of gear 1) is the origin of S_f; O2 lies on the y_f axis at distance E.

Profile 1 in S1 (eq. 9.4.23) and its unit normal n1 = t1 x k1 (eq. 9.4.28)::

    r1(theta1) = r_b1 (sin th1 - th1 cos th1,  cos th1 + th1 sin th1)
    n1(theta1) = (cos th1, -sin th1)                       (theta1 != 0: singular point)

Profile 2 in S2 (eq. 9.4.24) and n2 = k2 x t2 (eq. 9.4.29)::

    r2(theta2) = r_b2 (-sin th2 + th2 cos th2, -cos th2 - th2 sin th2)
    n2(theta2) = (cos th2, -sin th2)

Indeed dr1/dth1 = r_b1 th1 (sin th1, cos th1), so t1 x k1 = (t_y, -t_x) = (cos th1, -sin th1) for
th1 > 0; dr2/dth2 = -r_b2 th2 (sin th2, cos th2), so k2 x t2 = (-t_y, t_x) = (cos th2, -sin th2)
for th2 > 0. Both formulas are the book's: smooth in theta, the orientation being that of th > 0
(the real involute; th < 0 is the mirrored branch, not the tooth).

Coordinate transformation (eq. 9.4.30), homogeneous planar coordinates (x, y, 1)::

    M_f1(phi1) = [[cos phi1, -sin phi1, 0],        gear 1 turns counter-clockwise by phi1
                  [sin phi1,  cos phi1, 0],
                  [0,         0,        1]]
    M_f2(phi2) = [[ cos phi2, sin phi2, 0],        gear 2 turns clockwise by phi2 (opposite
                  [-sin phi2, cos phi2, E],        sense: external gearing), O2 = (0, E)
                  [0,         0,        1]]

and L_fi is the upper-left 2 x 2 block. Multiplying out (with a = th1 - phi1, b = th2 + phi2)::

    r_f^(1) = r_b1 (sin a - th1 cos a,  cos a + th1 sin a),        n_f^(1) = (cos a, -sin a)
    r_f^(2) = (r_b2 (-sin b + th2 cos b),  r_b2 (-cos b - th2 sin b) + E),  n_f^(2) = (cos b, -sin b)

so r_f^(1) = r_f^(2), n_f^(1) = n_f^(2) (eq. 9.4.31) are exactly the book's scalar equations
9.4.32-9.4.35; the tests check this term by term.

Equations solved
----------------
Unknowns ``x = (theta1, theta2, phi2)`` [rad] for a given phi1 [rad]; three equations::

    g0 = (x_f^(1) - x_f^(2)) / E                    eq. 9.4.32, scaled by E
    g1 = (y_f^(1) - y_f^(2)) / E                    eq. 9.4.33, scaled by E
    g2 = (n_f^(1) x n_f^(2)) . k_f = sin(a - b)     one independent normal condition (9.4.34-35)

Both normals are unit vectors, so one scalar equation suffices for collinearity, but it admits
a - b = pi: opposite normals. That false root is a real solution of g = 0 (the profiles touch with
their normals opposed, the "open belt" external tangent of the base circles, which exists whenever
E > |r_b1 - r_b2|); every solved point is therefore checked for n_f^(1) . n_f^(2) > 0 and flagged.

Closed form (used only to check the solver): a = b = alpha = arccos((r_b1 + r_b2) / E),
r_b1 th1 + r_b2 th2 = E sin alpha (eqs. 9.4.36-9.4.40), hence dphi1/dphi2 = r_b2/r_b1
(eq. 9.4.41), the line of action is straight with a_f . (-i_f) = cos alpha (eqs. 9.4.42-9.4.44),
and it crosses the y_f axis at y_I = E / (1 + m12) (eq. 9.4.46).

Sign convention of the gear ratio: phi2 is counted positive in the driven sense (gear 2 turns
clockwise in S_f while gear 1 turns counter-clockwise, see M_f2). Then ``m12 = dphi1/dphi2 > 0``;
in signed z-components of the angular velocities (omega1_z = dphi1/dt, omega2_z = -dphi2/dt)
this is ``m12 = -omega1_z / omega2_z = r_b2 / r_b1``.

Transmission error (docs/theory.md section 1): ``TE(phi1) = phi2(phi1) - phi1 / m12_nom - c``, with
``m12_nom = r_b2 / r_b1`` and ``c`` the mean over the solved positions, in rad (reported in arcsec).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError, ConvergenceError, GeometryError, OptionError, out_of_range, shorten  # noqa: F401 (GeometryError via out_of_range)
from ..units import DEG, RAD_TO_ARCSEC
from .curvature import Sym

__all__ = [
    "involute_1", "involute_2", "M_f1", "M_f2", "tangency_residual", "planar_functions", "PlanarTCA",
    "PlanarTCAResult", "solve_planar_tca", "check_geometry", "closed_form", "profile_points",
    "initial_guess", "FLAG_NAMES",
    "FLAG_NOT_CONVERGED", "FLAG_RESIDUAL", "FLAG_FALSE_ROOT", "FLAG_SINGULAR",
]

#: Per-point flags (bit mask); 0 means a valid contact point.
FLAG_NOT_CONVERGED = 1  #: Newton reported failure (max_iter, singular Jacobian)
FLAG_RESIDUAL = 2  #: scaled residual norm above the tolerance, or not finite
FLAG_FALSE_ROOT = 4  #: n_f^(1) . n_f^(2) <= 0: normals opposite (false root of the single normal equation)
FLAG_SINGULAR = 8  #: theta1 or theta2 <= theta_min: at/behind the singular point of an involute
FLAG_NAMES = {FLAG_NOT_CONVERGED: "not_converged", FLAG_RESIDUAL: "residual", FLAG_FALSE_ROOT: "false_root",
              FLAG_SINGULAR: "singular_point"}

#: Inputs of the compiled functions (all scalars): unknowns x = (theta1, theta2, phi2) [rad].
X_NAMES = ("theta1", "theta2", "phi2")


# --- pure CasADi-generic geometry (SX, MX, DM or float) -----------------------------------------

def involute_1(theta1: Sym | float, r_b1: Sym | float) -> tuple[Sym, Sym]:
    """Profile of gear 1 in S1 and its unit normal, eqs. 9.4.23 and 9.4.28.

    Parameters
    ----------
    theta1 : scalar (float or CasADi)
        Involute parameter (roll angle) [rad]; > 0 on the tooth, 0 is the singular point.
    r_b1 : scalar
        Base radius [mm].

    Returns
    -------
    r1 : (2,) CasADi column
        Point (x1, y1) [mm].
    n1 : (2,) CasADi column
        Unit normal ``t1 x k1 = (cos theta1, -sin theta1)``.
    """
    c, s = ca.cos(theta1), ca.sin(theta1)
    r1 = r_b1 * ca.vertcat(s - theta1 * c, c + theta1 * s)
    n1 = ca.vertcat(c, -s)
    return r1, n1


def involute_2(theta2: Sym | float, r_b2: Sym | float) -> tuple[Sym, Sym]:
    """Profile of gear 2 in S2 and its unit normal, eqs. 9.4.24 and 9.4.29.

    Parameters
    ----------
    theta2 : scalar
        Involute parameter [rad]; > 0 on the tooth.
    r_b2 : scalar
        Base radius [mm].

    Returns
    -------
    r2 : (2,) CasADi column
        Point (x2, y2) [mm].
    n2 : (2,) CasADi column
        Unit normal ``k2 x t2 = (cos theta2, -sin theta2)``.
    """
    c, s = ca.cos(theta2), ca.sin(theta2)
    r2 = r_b2 * ca.vertcat(-s + theta2 * c, -c - theta2 * s)
    n2 = ca.vertcat(c, -s)
    return r2, n2


def M_f1(phi1: Sym | float) -> Sym:
    """Homogeneous planar transformation S1 -> S_f (eq. 9.4.30): rotation by +phi1 [rad] about z_f."""
    c, s = ca.cos(phi1), ca.sin(phi1)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def M_f2(phi2: Sym | float, E: Sym | float) -> Sym:
    """Homogeneous planar transformation S2 -> S_f (eq. 9.4.30): rotation by -phi2 [rad] (gear 2
    turns opposite to gear 1), then translation by E [mm] along y_f (O2 = (0, E), Fig. 9.4.2)."""
    c, s = ca.cos(phi2), ca.sin(phi2)
    return ca.vertcat(ca.horzcat(c, s, 0), ca.horzcat(-s, c, E), ca.horzcat(0, 0, 1))


def _apply(M, r, n):
    """r_f = M r (homogeneous), n_f = L n with L the 2x2 rotation block (eq. 9.4.30)."""
    rf = ca.mtimes(M, ca.vertcat(r, 1))[:2]
    nf = ca.mtimes(M[:2, :2], n)
    return rf, nf


def contact_in_frame(x: Sym, phi1: Sym | float, r_b1: Sym | float, r_b2: Sym | float,
                     E: Sym | float) -> tuple[Sym, Sym, Sym, Sym]:
    """Both profiles in S_f: ``(r_f1, n_f1, r_f2, n_f2)`` for ``x = (theta1, theta2, phi2)`` [rad]."""
    r1, n1 = involute_1(x[0], r_b1)
    r2, n2 = involute_2(x[1], r_b2)
    rf1, nf1 = _apply(M_f1(phi1), r1, n1)
    rf2, nf2 = _apply(M_f2(x[2], E), r2, n2)
    return rf1, nf1, rf2, nf2


def tangency_residual(x: Sym, phi1: Sym | float, r_b1: Sym | float, r_b2: Sym | float, E: Sym | float) -> Sym:
    """Scaled tangency equations (eq. 9.4.31 -> 9.4.32, 9.4.33 and one normal condition).

    Parameters
    ----------
    x : (3,) CasADi column
        Unknowns ``(theta1, theta2, phi2)`` [rad].
    phi1 : scalar
        Rotation of gear 1 [rad].
    r_b1, r_b2, E : scalar
        Base radii and centre distance [mm].

    Returns
    -------
    g : (3,) CasADi column
        ``((x_f1 - x_f2)/E, (y_f1 - y_f2)/E, (n_f1 x n_f2) . k_f)``, dimensionless.
    """
    rf1, nf1, rf2, nf2 = contact_in_frame(x, phi1, r_b1, r_b2, E)
    d = (rf1 - rf2) / E
    cross_z = nf1[0] * nf2[1] - nf1[1] * nf2[0]
    return ca.vertcat(d, cross_z)


@lru_cache(maxsize=None)
def planar_functions() -> dict:
    """The compiled CasADi Functions of Problem 9.4.1 (built once per process).

    Returns
    -------
    dict of ca.Function
        ``"residual"``: ``(x[3], phi1, r_b1, r_b2, E) -> (g[3], r_f1[2], r_f2[2], n_f1[2], n_f2[2])``,
        the scaled residual and the contact data in S_f (mm, unit vectors).
        ``"jacobian"``: same inputs ``-> (J_x[3x3], J_phi1[3])``, exact AD Jacobians of ``g``.
        ``"tangent"``: same inputs ``-> dx_dphi1[3]``, the solution curve's tangent by the implicit
        function theorem ``-J_x^{-1} J_phi1`` (predictor of the continuation; its third component is
        ``dphi2/dphi1 = 1/m12``).
        ``"rootfinder"``: Newton on ``g = 0`` with the exact Jacobian:
        ``(x0[3], phi1, r_b1, r_b2, E) -> (x[3], r_f1, r_f2, n_f1, n_f2)``.
    """
    x = ca.SX.sym("x", 3)
    phi1, rb1, rb2, E = (ca.SX.sym(n) for n in ("phi1", "r_b1", "r_b2", "E"))
    ins, names = [x, phi1, rb1, rb2, E], ["x", "phi1", "r_b1", "r_b2", "E"]
    g = tangency_residual(x, phi1, rb1, rb2, E)
    rf1, nf1, rf2, nf2 = contact_in_frame(x, phi1, rb1, rb2, E)
    res = ca.Function("planar_tca_residual", ins, [g, rf1, rf2, nf1, nf2], names,
                      ["g", "r_f1", "r_f2", "n_f1", "n_f2"])
    Jx, Jp = ca.jacobian(g, x), ca.jacobian(g, phi1)
    jac = ca.Function("planar_tca_jacobian", ins, [Jx, Jp], names, ["J_x", "J_phi1"])
    tan = ca.Function("planar_tca_tangent", ins, [-ca.solve(Jx, Jp)], names, ["dx_dphi1"])
    rf = ca.rootfinder("planar_tca_newton", "newton", res,
                       {"abstol": 1e-15, "abstolStep": 1e-16, "max_iter": 50, "error_on_fail": False})
    return {"residual": res, "jacobian": jac, "tangent": tan, "rootfinder": rf}


@lru_cache(maxsize=64)
def _mapped_rootfinder(n: int) -> ca.Function:
    return planar_functions()["rootfinder"].map(n)


# --- input checks and closed form ---------------------------------------------------------------

def check_geometry(r_b1: float, r_b2: float, E: float) -> None:
    """Raise :class:`GeometryError` unless ``r_b1 > 0``, ``r_b2 > 0`` and ``E > r_b1 + r_b2`` [mm]."""
    for name, v in (("r_b1", r_b1), ("r_b2", r_b2)):
        if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v) and v > 0):
            raise out_of_range(name, v, f"{name} > 0 mm (finite base radius)")
    if not (isinstance(E, (int, float, np.floating, np.integer)) and math.isfinite(E)):
        raise out_of_range("E", E, f"E > r_b1 + r_b2 = {r_b1 + r_b2:g} mm (finite centre distance)")
    if E <= r_b1 + r_b2:
        raise out_of_range("E", E, f"E > r_b1 + r_b2 = {r_b1 + r_b2:g} mm",
                           "The line of action must cross between the base circles (cos alpha = (r_b1 + "
                           "r_b2)/E < 1).")


def closed_form(r_b1: float, r_b2: float, E: float) -> dict:
    """The book's closed-form results (eqs. 9.4.36-9.4.46), for checking the solver only.

    Returns
    -------
    dict
        ``alpha`` [rad] (a_f . (-i_f) = cos alpha), ``m12``, ``y_I`` [mm], ``phi1_range`` [rad]
        (theta1 > 0 and theta2 > 0: contact between the tangency points T1, T2), and
        ``phi2(phi1)`` callable [rad].
    """
    check_geometry(r_b1, r_b2, E)
    alpha = math.acos((r_b1 + r_b2) / E)
    m12 = r_b2 / r_b1
    L = E * math.sin(alpha)  # T1 T2

    def phi2(phi1):
        return (r_b1 * np.asarray(phi1) + (r_b1 + r_b2) * alpha - L) / r_b2

    return {"alpha": alpha, "m12": m12, "y_I": E / (1 + m12), "T1T2": L,
            "phi1_range": (-alpha, L / r_b1 - alpha), "phi2": phi2}


def initial_guess(phi1: npt.ArrayLike, r_b1: float, r_b2: float, E: float, alpha_guess: float = 20 * DEG) -> np.ndarray:
    """Starting point ``(3, n)`` for Newton from an assumed pressure angle ``alpha_guess`` [rad].

    Takes ``theta1 - phi1 = theta2 + phi2 = alpha_guess`` and ``r_b1 theta1 + r_b2 theta2 =
    E sin(alpha_guess)``; exact only when alpha_guess is the operating pressure angle.
    """
    phi1 = np.atleast_1d(np.asarray(phi1, float))
    th1 = alpha_guess + phi1
    th2 = (E * math.sin(alpha_guess) - r_b1 * th1) / r_b2
    return np.vstack([th1, th2, alpha_guess - th2])


# --- result -------------------------------------------------------------------------------------

def _ro(a):
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def _ro_int(a):
    a = np.array(a, dtype=int)
    a.setflags(write=False)
    return a


def _f(v):
    """float, or None when not finite (for JSON)."""
    v = float(v)
    return v if math.isfinite(v) else None


@dataclass(frozen=True)
class PlanarTCAResult:
    """Solved positions of Problem 9.4.1 and what follows from them.

    Every derived figure is computed from the solved points (valid ones only, ``flags == 0``), not
    from the closed form; ``errors`` compares them with the closed form.

    Attributes
    ----------
    r_b1, r_b2, E : float
        Base radii and centre distance [mm].
    phi1, phi2, theta1, theta2 : (n,) arrays
        Rotation angles (phi2 positive in the driven sense) and involute parameters [rad].
    r_f1, r_f2 : (n, 2) arrays
        Contact point in S_f as a point of profile 1 and of profile 2 [mm].
    n_f1, n_f2 : (n, 2) arrays
        Unit normals of the profiles in S_f at the contact point.
    residual : (n,) array
        Euclidean norm of the scaled residual (positions / E, normal cross product).
    n_dot : (n,) array
        ``n_f1 . n_f2`` (+1 at a true contact point, -1 at the false root).
    iterations : (n,) int array
        Newton iterations (-1 when not reported, i.e. with ``method="map"``).
    flags : (n,) int array
        Bit mask of :data:`FLAG_NAMES`; 0 = valid.
    method : str
        ``"continuation"`` or ``"map"``.
    solve_time_s : float
        Wall time of all Newton solves [s] (excluding the one-off graph build).
    m12 : float
        Gear ratio dphi1/dphi2 from a least-squares line through the solved (phi2, phi1).
    m12_fit_residual : float
        Largest deviation of phi1 from that line [rad].
    m12_local : (n,) array
        ``1 / (dphi2/dphi1)`` at each point from the AD tangent (implicit function theorem).
    te : (n,) array
        Transmission error ``phi2 - phi1 r_b1/r_b2 - mean`` [rad].
    loa_point, loa_direction : (2,) arrays
        Line of action fitted through the contact points (centroid [mm], unit vector a_f oriented
        along the motion of the contact point, i.e. increasing theta1, as eq. 9.4.43).
    loa_straightness : float
        Largest distance of a contact point from the fitted line [mm].
    cos_loa : float
        ``a_f . (-i_f)`` (eq. 9.4.44).
    y_I : float
        Where the line crosses the y_f axis [mm] (eq. 9.4.46).
    dist_O1, dist_O2 : float
        Distance of the line from O1 = (0, 0) and O2 = (0, E) [mm] (tangency to the base circles
        when equal to r_b1, r_b2).
    T1, T2 : (2,) arrays
        Feet of the perpendiculars from O1, O2 on the line (the tangency points) [mm].
    crosses_centre_line : bool
        O1 and O2 on opposite sides of the line (internal common tangent).
    errors : dict
        Derived minus closed-form values (see :meth:`to_dict`).
    """

    r_b1: float
    r_b2: float
    E: float
    phi1: np.ndarray
    phi2: np.ndarray
    theta1: np.ndarray
    theta2: np.ndarray
    r_f1: np.ndarray
    r_f2: np.ndarray
    n_f1: np.ndarray
    n_f2: np.ndarray
    residual: np.ndarray
    n_dot: np.ndarray
    iterations: np.ndarray
    flags: np.ndarray
    method: str
    solve_time_s: float
    m12: float = math.nan
    m12_fit_residual: float = math.nan
    m12_local: np.ndarray = field(default=None, repr=False)
    te: np.ndarray = field(default=None, repr=False)
    loa_point: np.ndarray = field(default=None, repr=False)
    loa_direction: np.ndarray = field(default=None, repr=False)
    loa_straightness: float = math.nan
    cos_loa: float = math.nan
    y_I: float = math.nan
    dist_O1: float = math.nan
    dist_O2: float = math.nan
    T1: np.ndarray = field(default=None, repr=False)
    T2: np.ndarray = field(default=None, repr=False)
    crosses_centre_line: bool = False
    errors: dict = field(default_factory=dict)

    @property
    def ok(self) -> np.ndarray:
        """Mask of valid points (``flags == 0``)."""
        return self.flags == 0

    @property
    def n(self) -> int:
        return int(self.phi1.size)

    @property
    def time_per_position_s(self) -> float:
        return self.solve_time_s / max(self.n, 1)

    def flag_names(self, i: int) -> list[str]:
        """Names of the flags raised at point ``i``."""
        return [name for bit, name in FLAG_NAMES.items() if int(self.flags[i]) & bit]

    def to_dict(self) -> dict:
        """JSON-able dict with a ``units`` mapping (mm, rad; TE also in arcsec)."""
        def lst(a):  # arrays -> lists, NaN (flagged points) -> None
            if a is None:
                return None
            a = np.asarray(a)
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                return np.where(np.isfinite(a), a, None).tolist()
            return a.tolist()

        units = {"length": "mm", "angle": "rad", "te": "rad", "te_arcsec": "arcsec", "ratio": "-",
                 "residual": "- (positions scaled by E)", "time": "s", "n_dot": "-",
                 "flags": "bit mask: " + ", ".join(f"{b} {n}" for b, n in FLAG_NAMES.items())}
        return {
            "units": units,
            "input": {"r_b1": self.r_b1, "r_b2": self.r_b2, "E": self.E, "method": self.method},
            "positions": {
                "phi1": lst(self.phi1), "phi2": lst(self.phi2), "theta1": lst(self.theta1),
                "theta2": lst(self.theta2), "r_f1": lst(self.r_f1), "r_f2": lst(self.r_f2),
                "n_f1": lst(self.n_f1), "n_f2": lst(self.n_f2), "residual": lst(self.residual),
                "n_dot": lst(self.n_dot), "iterations": lst(self.iterations), "flags": lst(self.flags),
                "te": lst(self.te), "te_arcsec": None if self.te is None else lst(np.asarray(self.te) * RAD_TO_ARCSEC),
                "m12_local": lst(self.m12_local),
            },
            "derived": {
                "m12": _f(self.m12), "m12_fit_residual": _f(self.m12_fit_residual),
                "m12_convention": "m12 = dphi1/dphi2 = -omega1_z/omega2_z, phi2 positive in the driven sense",
                "te_max_abs": _f(np.max(np.abs(self.te[self.ok]))) if self.te is not None and self.ok.any() else None,
                "te_max_abs_arcsec": (_f(np.max(np.abs(self.te[self.ok])) * RAD_TO_ARCSEC)
                                      if self.te is not None and self.ok.any() else None),
                "line_of_action": {
                    "point": lst(self.loa_point), "direction": lst(self.loa_direction),
                    "straightness": _f(self.loa_straightness), "cos_angle": _f(self.cos_loa),
                    "angle": _f(math.acos(max(-1.0, min(1.0, self.cos_loa)))) if math.isfinite(self.cos_loa) else None,
                    "y_I": _f(self.y_I), "dist_O1": _f(self.dist_O1), "dist_O2": _f(self.dist_O2),
                    "T1": lst(self.T1), "T2": lst(self.T2), "crosses_centre_line": bool(self.crosses_centre_line),
                    "tangent_to_base_circles": bool(self.tangent_to_base_circles()),
                },
            },
            "errors": {k: _f(v) for k, v in self.errors.items()},
            "timing": {"solve_s": self.solve_time_s, "per_position_s": self.time_per_position_s,
                       "n_positions": self.n, "n_valid": int(self.ok.sum()),
                       "newton_iterations_max": int(np.max(self.iterations)) if self.n else 0},
        }

    def tangent_to_base_circles(self, tol: float = 1e-9) -> bool:
        """Whether the fitted line of action touches both base circles (relative tolerance on E)."""
        if not math.isfinite(self.dist_O1):
            return False
        return (abs(self.dist_O1 - self.r_b1) <= tol * self.E and abs(self.dist_O2 - self.r_b2) <= tol * self.E
                and self.crosses_centre_line)


def _derive(raw: dict, r_b1: float, r_b2: float, E: float) -> dict:
    """Gear ratio, TE and line of action from the valid solved points."""
    ok = raw["flags"] == 0
    out: dict = {}
    n = int(raw["phi1"].size)
    out["te"] = np.full(n, np.nan)
    out["m12_local"] = np.full(n, np.nan)
    if ok.any():
        tan = planar_functions()["tangent"]
        for i in np.flatnonzero(ok):
            d = np.asarray(tan(raw["x"][:, i], raw["phi1"][i], r_b1, r_b2, E)).ravel()
            out["m12_local"][i] = 1.0 / d[2]
    if ok.sum() < 3:
        return out
    p1, p2 = raw["phi1"][ok], raw["phi2"][ok]
    # gear ratio: least-squares line phi1 = m12 phi2 + c through the solved points (centred data)
    c2, c1 = p2.mean(), p1.mean()
    m12 = float(np.dot(p2 - c2, p1 - c1) / np.dot(p2 - c2, p2 - c2))
    out["m12"] = m12
    out["m12_fit_residual"] = float(np.max(np.abs((p1 - c1) - m12 * (p2 - c2))))
    te = raw["phi2"] - raw["phi1"] * (r_b1 / r_b2)
    te = te - te[ok].mean()
    te[~ok] = np.nan
    out["te"] = te
    # line of action: total least squares through the contact points
    P = raw["r_f1"][ok]
    c = P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P - c)
    d = Vt[0]
    th = raw["theta1"][ok]
    if np.dot(d, P[np.argmax(th)] - P[np.argmin(th)]) < 0:  # a_f along increasing theta1 (eq. 9.4.43)
        d = -d
    nrm = np.array([-d[1], d[0]])
    out["loa_point"], out["loa_direction"] = c, d
    out["loa_straightness"] = float(np.max(np.abs((P - c) @ nrm)))
    out["cos_loa"] = float(-d[0])
    out["y_I"] = float(c[1] - c[0] * d[1] / d[0]) if d[0] != 0 else math.nan
    O1, O2 = np.array([0.0, 0.0]), np.array([0.0, E])
    s1, s2 = float((O1 - c) @ nrm), float((O2 - c) @ nrm)
    out["dist_O1"], out["dist_O2"] = abs(s1), abs(s2)
    out["crosses_centre_line"] = bool(s1 * s2 < 0)
    out["T1"] = c + ((O1 - c) @ d) * d
    out["T2"] = c + ((O2 - c) @ d) * d
    cf = closed_form(r_b1, r_b2, E)
    out["errors"] = {
        "m12_rel": m12 / cf["m12"] - 1.0,
        "m12_local_rel_max": float(np.max(np.abs(out["m12_local"][ok] / cf["m12"] - 1.0))),
        "cos_loa": out["cos_loa"] - math.cos(cf["alpha"]),
        "y_I": out["y_I"] - cf["y_I"],
        "y_I_rel": out["y_I"] / cf["y_I"] - 1.0,
        "tangency_O1": out["dist_O1"] - r_b1,
        "tangency_O2": out["dist_O2"] - r_b2,
        "straightness": out["loa_straightness"],
        "te_max_abs": float(np.max(np.abs(te[ok]))),
        "phi2_max_abs": float(np.max(np.abs(p2 - cf["phi2"](p1)))),
        "theta1_minus_phi1_max_abs": float(np.max(np.abs(raw["theta1"][ok] - p1 - cf["alpha"]))),
        "gap_max": float(np.max(np.linalg.norm(raw["r_f1"][ok] - raw["r_f2"][ok], axis=1))),
        "residual_max": float(np.max(raw["residual"][ok])),
    }
    return out


# --- solver -------------------------------------------------------------------------------------

class PlanarTCA:
    """TCA of Problem 9.4.1 for one geometry (compiled graph shared by all instances).

    Parameters
    ----------
    r_b1, r_b2 : float
        Base radii of the driving gear 1 and the driven gear 2 [mm], > 0.
    E : float
        Centre distance [mm], > r_b1 + r_b2 (any value, standard or not).
    tol : float
        Largest accepted scaled residual norm (default 1e-12).
    theta_min : float
        Smallest accepted involute parameter [rad] on either profile (singular point at 0).

    Raises
    ------
    GeometryError
        Naming the parameter and its valid range.
    """

    def __init__(self, r_b1: float, r_b2: float, E: float, tol: float = 1e-12, theta_min: float = 1e-6):
        check_geometry(r_b1, r_b2, E)
        self.r_b1, self.r_b2, self.E = float(r_b1), float(r_b2), float(E)
        self.tol, self.theta_min = float(tol), float(theta_min)
        self.functions = planar_functions()

    @property
    def p(self) -> tuple[float, float, float]:
        return self.r_b1, self.r_b2, self.E

    def residual(self, x: npt.ArrayLike, phi1: float) -> np.ndarray:
        """Scaled residual ``g(x; phi1)`` (3,) at ``x = (theta1, theta2, phi2)`` [rad]."""
        return np.asarray(self.functions["residual"](x, phi1, *self.p)[0]).ravel()

    def solve(self, phi1: npt.ArrayLike, x0: npt.ArrayLike | None = None, method: str = "continuation", alpha_guess: float = 20 * DEG,
              on_fail: str = "raise") -> PlanarTCAResult:
        """Solve the tangency equations for every ``phi1``.

        Parameters
        ----------
        phi1 : float or (n,) array
            Rotation of gear 1 [rad].
        x0 : (3,) or (3, n) array, optional
            Starting point(s) ``(theta1, theta2, phi2)`` [rad]. Default: :func:`initial_guess`
            with ``alpha_guess`` (for the first point only with ``"continuation"``).
        method : {"continuation", "map"}
            ``"continuation"``: positions in order, each started from the previous solution plus the
            AD tangent step (implicit function theorem); ``"map"``: all positions at once through
            ``Function.map`` of the rootfinder, each from its own guess.
        alpha_guess : float
            Pressure angle [rad] assumed by the default starting point.
        on_fail : {"raise", "flag"}
            ``"raise"``: :class:`ConvergenceError` if any point is flagged; ``"flag"``: return the
            result with ``flags`` set (derived figures then use the valid points only).

        Returns
        -------
        PlanarTCAResult
        """
        if method not in ("continuation", "map"):
            raise OptionError(f"method = {method!r}; valid: 'continuation' or 'map'", param="method", value=method,
                              valid="'continuation' or 'map'", detail="; valid: 'continuation' or 'map'")
        if on_fail not in ("raise", "flag"):
            raise OptionError(f"on_fail = {on_fail!r}; valid: 'raise' or 'flag'", param="on_fail", value=on_fail,
                              valid="'raise' or 'flag'", detail="; valid: 'raise' or 'flag'")
        try:
            phi1 = np.asarray(phi1, dtype=float)
        except (TypeError, ValueError):
            raise ArgumentError(f"phi1 = {type(phi1).__name__} {shorten(repr(phi1))}: expected angles of gear 1 "
                                "[rad] (numbers).",
                                param="phi1", value=phi1, valid="angles of gear 1 [rad] (numbers)") from None
        if phi1.ndim > 1:
            raise ArgumentError(f"phi1: expected a number or a 1-D array of angles [rad], got shape {phi1.shape}.",
                                param="phi1", valid="a number or a 1-D array of angles [rad]")
        phi1 = np.atleast_1d(phi1)
        if phi1.size == 0 or not np.all(np.isfinite(phi1)):
            raise ArgumentError("phi1 must be a non-empty array of finite angles [rad]"
                                + (f" (phi1[{int(np.flatnonzero(~np.isfinite(phi1))[0])}] is not finite)."
                                   if phi1.size else " (it is empty)."),
                                param="phi1", valid="a non-empty array of finite angles [rad]")
        n = phi1.size
        if x0 is None:
            guess = initial_guess(phi1, *self.p, alpha_guess=alpha_guess)
        else:
            try:
                guess = np.asarray(x0, dtype=float).reshape(3, -1)
            except (TypeError, ValueError):
                raise ArgumentError(f"x0: expected (theta1, theta2, phi2) [rad], shape (3,) or (3, {n}); got "
                                    f"{shorten(repr(x0))}.",
                                    param="x0", value=x0, valid=f"shape (3,) or (3, {n})") from None
            if guess.shape[1] not in (1, n):
                raise ArgumentError(f"x0: expected shape (3,) or (3, {n}), got {np.shape(x0)}.",
                                    param="x0", value=np.shape(x0), valid=f"shape (3,) or (3, {n})")
            if guess.shape[1] == 1:
                guess = np.repeat(guess, n, axis=1)
            if guess.shape[1] != n:
                raise ValueError(f"x0 must be (3,) or (3, {n}), got {np.shape(x0)}")
        rf = self.functions["rootfinder"]
        it = np.full(n, -1, dtype=int)
        conv = np.ones(n, dtype=bool)
        t0 = time.perf_counter()
        if method == "map":
            X = np.asarray(_mapped_rootfinder(n)(guess, phi1[None, :], self.r_b1, self.r_b2, self.E)[0])
            X = X.reshape(3, n)
        else:
            X = np.empty((3, n))
            tan = self.functions["tangent"]
            prev = None  # (x, phi1) of the last valid point
            for i in range(n):
                if prev is None or x0 is not None and np.ndim(x0) == 2:
                    start = guess[:, i]
                else:
                    xp, pp = prev
                    start = xp + np.asarray(tan(xp, pp, *self.p)).ravel() * (phi1[i] - pp)
                X[:, i] = np.asarray(rf(start, phi1[i], *self.p)[0]).ravel()
                st = rf.stats()
                it[i] = int(st.get("iter_count", -1))
                conv[i] = bool(st.get("success", False))
                if conv[i] and self._point_flags(X[:, i], phi1[i])[0] == 0:
                    prev = (X[:, i].copy(), phi1[i])
        solve_time = time.perf_counter() - t0
        raw = self._evaluate(X, phi1, conv)
        raw["iterations"] = it
        der = _derive(raw, *self.p)
        result = PlanarTCAResult(
            r_b1=self.r_b1, r_b2=self.r_b2, E=self.E, phi1=_ro(phi1), phi2=_ro(raw["phi2"]),
            theta1=_ro(raw["theta1"]), theta2=_ro(raw["theta2"]), r_f1=_ro(raw["r_f1"]), r_f2=_ro(raw["r_f2"]),
            n_f1=_ro(raw["n_f1"]), n_f2=_ro(raw["n_f2"]), residual=_ro(raw["residual"]), n_dot=_ro(raw["n_dot"]),
            iterations=_ro_int(it), flags=_ro_int(raw["flags"]), method=method, solve_time_s=solve_time,
            **{k: (_ro(v) if isinstance(v, np.ndarray) else v) for k, v in der.items()})
        if on_fail == "raise" and np.any(result.flags):
            bad = np.flatnonzero(result.flags)
            lines = [f"phi1 = {phi1[i]:.6g} rad: {', '.join(result.flag_names(i))} (residual "
                     f"{result.residual[i]:.2e}, n1.n2 = {result.n_dot[i]:+.6f}, theta1 = {result.theta1[i]:.6g}, "
                     f"theta2 = {result.theta2[i]:.6g})" for i in bad[:5]]
            more = f" (and {bad.size - 5} more)" if bad.size > 5 else ""
            raise ConvergenceError(
                f"planar TCA: {bad.size} of {n} positions rejected{more}:\n  " + "\n  ".join(lines)
                + "\nA valid contact point needs residual <= tol, n_f1 . n_f2 > 0 (same orientation, eqs. "
                  "9.4.28-9.4.29) and theta1, theta2 > theta_min (contact between the tangency points T1, T2); "
                  f"for r_b1 = {self.r_b1:g}, r_b2 = {self.r_b2:g}, E = {self.E:g} mm that is "
                  f"{_phi1_range_text(self.r_b1, self.r_b2, self.E)}. Use on_fail='flag' to inspect.")
        return result

    def _point_flags(self, x, phi1):
        g, rf1, rf2, nf1, nf2 = (np.asarray(v).ravel() for v in self.functions["residual"](x, phi1, *self.p))
        res = float(np.linalg.norm(g)) if np.all(np.isfinite(g)) else math.inf
        ndot = float(nf1 @ nf2)
        f = 0
        if not res <= self.tol:
            f |= FLAG_RESIDUAL
        if not ndot > 0:
            f |= FLAG_FALSE_ROOT
        if not (x[0] > self.theta_min and x[1] > self.theta_min):
            f |= FLAG_SINGULAR
        return f, res, ndot, rf1, rf2, nf1, nf2

    def _evaluate(self, X, phi1, conv) -> dict:
        n = phi1.size
        raw = {"x": X, "phi1": phi1, "theta1": X[0].copy(), "theta2": X[1].copy(), "phi2": X[2].copy(),
               "r_f1": np.empty((n, 2)), "r_f2": np.empty((n, 2)), "n_f1": np.empty((n, 2)),
               "n_f2": np.empty((n, 2)), "residual": np.empty(n), "n_dot": np.empty(n),
               "flags": np.zeros(n, dtype=int)}
        for i in range(n):
            f, res, ndot, rf1, rf2, nf1, nf2 = self._point_flags(X[:, i], phi1[i])
            if not conv[i]:
                f |= FLAG_NOT_CONVERGED
            raw["flags"][i] = f
            raw["residual"][i], raw["n_dot"][i] = res, ndot
            raw["r_f1"][i], raw["r_f2"][i], raw["n_f1"][i], raw["n_f2"][i] = rf1, rf2, nf1, nf2
        return raw


def _phi1_range_text(r_b1, r_b2, E) -> str:
    lo, hi = closed_form(r_b1, r_b2, E)["phi1_range"]
    return f"{lo:.6g} < phi1 < {hi:.6g} rad ({lo / DEG:.4g} .. {hi / DEG:.4g} deg)"


def solve_planar_tca(r_b1: float, r_b2: float, E: float, phi1: npt.ArrayLike, **kwargs: Any) -> PlanarTCAResult:
    """Shortcut: ``PlanarTCA(r_b1, r_b2, E).solve(phi1, **kwargs)`` (see :meth:`PlanarTCA.solve`)."""
    tol = kwargs.pop("tol", 1e-12)
    theta_min = kwargs.pop("theta_min", 1e-6)
    return PlanarTCA(r_b1, r_b2, E, tol=tol, theta_min=theta_min).solve(phi1, **kwargs)


def profile_points(member: int, theta: npt.ArrayLike, angle: float, r_b1: float, r_b2: float, E: float) -> np.ndarray:
    """Points of profile 1 or 2 in S_f for a rotation ``angle`` [rad] (phi1 or phi2), for plots.

    Evaluates the same CasADi expressions as the solver (eqs. 9.4.23/9.4.24 with eq. 9.4.30).

    Parameters
    ----------
    member : {1, 2}
    theta : (m,) array
        Involute parameters [rad].
    angle : float
        phi1 for member 1, phi2 for member 2 [rad].

    Returns
    -------
    (m, 2) array
        Points in S_f [mm].
    """
    th = np.atleast_1d(np.asarray(theta, dtype=float))
    if member == 1:
        M = np.asarray(M_f1(angle))
        r = np.hstack([np.asarray(involute_1(t, r_b1)[0]) for t in th])
    elif member == 2:
        M = np.asarray(M_f2(angle, E))
        r = np.hstack([np.asarray(involute_2(t, r_b2)[0]) for t in th])
    else:
        raise ValueError(f"member = {member!r}; valid: 1 or 2")
    return (M[:2, :2] @ r + M[:2, 2:3]).T
