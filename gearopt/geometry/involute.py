"""Involute curves and the involute function (Litvin & Fuentes, ch. 10.2).

Every function is CasADi-generic: it uses only ``ca.*`` operations and :func:`select`, so the same
code takes Python floats, ``ca.DM``, ``ca.SX`` and ``ca.MX`` and returns the same kind of object
(NumPy arrays are not a supported input). The expression graphs have a fixed structure (no
data-dependent loops), so they can be differentiated and embedded in NLPs.

Units: lengths in mm, angles in rad (the results are in the units of the inputs for lengths).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..errors import ArgumentError

if TYPE_CHECKING:
    from ..types import Expr

#: Number of Newton steps that polish the initial guess in :func:`inv_inverse`. Three steps reach
#: machine precision (<= 2 ulp) over 0 < alpha < 85 deg: the worst initial error is ~5e-4 (relative,
#: near 68 deg), after one step ~8e-7, after two ~2e-12, after three < 2e-16
#: (measured against a 50-digit root solve; see tests/test_involute.py).
NEWTON_STEPS = 3

#: Below this ``|alpha|`` [rad] :func:`inv` uses a series free of the cancellation in ``tan a - a``.
_INV_SERIES_MAX = 0.9
#: Coefficients of ``sin a - a cos a = sum_k (-1)^(k+1) 2k a^(2k+1) / (2k+1)!``, k = 1..9
#: (truncation error < 2e-16 relative for |a| < 1).
_SIN_ACOS = tuple((-1) ** (k + 1) * 2 * k / math.factorial(2 * k + 1) for k in range(1, 10))
#: Switch of the initial guess of :func:`inv_inverse` from Cheng's series to the asymptotic one
#: (theta = 1.6 is alpha ~ 70 deg, where both have a relative error ~5e-4; both lie above the root,
#: so Newton on the convex function tan(a) - a - theta converges monotonically).
_THETA_SWITCH = 1.6
#: Below this ``|theta|`` (alpha < 8e-68 rad) the leading terms of Cheng's series are returned instead
#: of Newton steps, whose ``tan(alpha)^2`` would underflow; it also makes theta = 0 give alpha = 0.
_THETA_TINY = 1e-200


#: Largest |theta| :func:`inv_inverse` accepts as a number (alpha within 1e-15 rad of pi/2).
THETA_MAX = 1e15


def _check_numeric(fn: str, name: str, value, below: float | None = None) -> None:
    """For plain numbers and arrays (not CasADi expressions): ArgumentError unless every entry is a
    finite real number with ``|value| < below``."""
    if isinstance(value, (ca.SX, ca.MX, ca.DM)):
        return
    try:
        if isinstance(value, (str, bytes)) or np.asarray(value).dtype.kind in "USbO":
            raise TypeError
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(f"{fn}: {name} = {type(value).__name__} {str(value)[:60]!r}: expected a number [rad] "
                            "(or an array of numbers, or a CasADi expression).",
                            param=name, value=value, valid="a number [rad]") from None
    if not np.all(np.isfinite(arr)):
        raise ArgumentError(f"{fn}: {name} must be finite [rad]; got {str(value)[:60]}.",
                            param=name, value=value, valid="finite [rad]")
    if below is not None and np.any(np.abs(arr) > below):
        raise ArgumentError(f"{fn}: {name} = {str(value)[:60]} is out of range; valid: |{name}| <= {below:.6g} rad "
                            + ("(pi/2: the involute function is defined below it)." if below < 2 else
                               "(beyond it alpha rounds to pi/2 in double precision)."),
                            param=name, value=value, valid=f"|{name}| <= {below:.6g} rad")


def select(cond: Expr, a: Expr, b: Expr) -> Expr:
    """``a`` where ``cond`` else ``b``.

    Python choice for a plain ``bool`` condition (float inputs), ``np.where`` for NumPy boolean
    arrays, ``ca.if_else`` for CasADi expressions (``ca.DM``, ``ca.SX``, ``ca.MX``). Both branches
    are built, so both must be finite (or at least harmless) wherever they are evaluated.
    """
    if isinstance(cond, (bool, np.bool_)):
        return a if cond else b
    if isinstance(cond, np.ndarray):
        return np.where(cond, a, b)
    return ca.if_else(cond, a, b)


def inv(alpha: Expr) -> Expr:
    """Involute function ``inv(alpha) = tan(alpha) - alpha`` (Litvin eq. 10.2.9).

    For ``|alpha| < 0.9`` it is computed as ``(sin a - a cos a) / cos a`` with the Taylor series of
    the numerator (odd powers a^3 ... a^19), which avoids the cancellation of ``tan a - a`` for
    small angles; the result is accurate to a few ulp for every ``alpha`` (relative error).

    Parameters
    ----------
    alpha : float or casadi.DM / SX / MX
        Pressure angle [rad], ``|alpha| < pi/2``. The function is odd.

    Returns
    -------
    same type as ``alpha``
        ``inv(alpha)`` [rad] (the polar angle of the involute point, eq. 10.2.8).
    """
    _check_numeric("inv", "alpha", alpha, math.pi / 2)
    return _inv(alpha)


def _inv(alpha):
    """:func:`inv` without the argument check (for internal graphs and Newton iterates)."""
    series = _sin_minus_x_cos_series(alpha) / ca.cos(alpha)
    return select(ca.fabs(alpha) < _INV_SERIES_MAX, series, ca.tan(alpha) - alpha)


def _sin_minus_x_cos_series(x):
    """``sin x - x cos x`` by its Taylor series (k = 1..9), relative error < 2e-16 for ``|x| < 1``."""
    x2 = x * x
    p = 0.0
    for c in reversed(_SIN_ACOS):
        p = p * x2 + c
    return x * x2 * p


def _cbrt(x):
    """Real cube root, odd in ``x`` [same unit^(1/3)]."""
    return ca.sign(x) * ca.fabs(x) ** (1.0 / 3.0)


def inv_inverse_cheng(theta: Expr) -> Expr:
    """Cheng's series for the inverse of the involute function (Litvin eq. 10.2.10).

    ``alpha = (3 theta)^(1/3) - (2/5) theta + (9/175) 3^(2/3) theta^(5/3)
    - (2/175) 3^(1/3) theta^(7/3)`` (odd extension for ``theta < 0``).

    Its truncation error grows with ``theta``: about 2e-8 rad at 20 deg, 1.4e-5 rad at 45 deg,
    5e-4 rad at 65-70 deg and worse beyond (the series is quoted as valid for ``theta < 1.8``,
    alpha < 72 deg). Use :func:`inv_inverse` for machine precision.

    Parameters
    ----------
    theta : float or casadi.DM / SX / MX
        Involute function value ``inv(alpha)`` [rad].

    Returns
    -------
    same type as ``theta``
        Approximate pressure angle [rad].
    """
    c = _cbrt(3.0 * theta)  # (3 theta)^(1/3)
    c2 = c * c
    # c^5 / 3 = 3^(2/3) theta^(5/3);  c^7 / 9 = 3^(1/3) theta^(7/3)
    return c - 0.4 * theta + c * c2 * c2 * ((9.0 / 175.0) / 3.0 - (2.0 / 175.0) / 9.0 * c2)


def _inv_inverse_asymptotic(theta):
    """Large-theta guess: ``alpha = pi/2 - eps``, ``eps = y + 2 y^3 / 3 + 13 y^5 / 15``,
    ``y = 1 / (theta + pi/2)`` (from ``cot eps + eps = theta + pi/2``); theta > 0 [rad]."""
    y = 1.0 / (theta + math.pi / 2)
    y2 = y * y
    return math.pi / 2 - y * (1.0 + y2 * (2.0 / 3.0 + y2 * (13.0 / 15.0)))


def inv_inverse(theta: Expr, steps: int = NEWTON_STEPS) -> Expr:
    """Pressure angle ``alpha`` with ``inv(alpha) = theta``, to machine precision.

    Initial guess: Cheng's series (eq. 10.2.10) for ``theta < 1.6`` (alpha < ~70 deg), an asymptotic
    series at ``alpha -> pi/2`` above; then ``steps`` Newton steps on ``tan(alpha) - alpha - theta = 0``
    (a fixed count, so the graph is smooth and has a fixed size). For ``|theta| < 1e-200`` the leading
    terms of Cheng's series are already exact and are returned (so ``theta = 0`` gives ``alpha = 0``).
    The function is odd in ``theta``.

    Parameters
    ----------
    theta : float or casadi.DM / SX / MX
        Involute function value [rad]; machine precision is reached for ``0 <= theta <= inv(85 deg)``
        (= 9.95) and the result stays accurate well beyond.
    steps : int
        Number of Newton steps (default :data:`NEWTON_STEPS`).

    Returns
    -------
    same type as ``theta``
        Pressure angle [rad], ``|alpha| < pi/2``. Its derivative is ``1 / tan(alpha)^2``.
    """
    # |theta| > 1e15: pi/2 - alpha < 1e-15 is below the spacing of doubles at pi/2 (2.2e-16), so alpha
    # rounds to pi/2 and the Newton steps diverge
    _check_numeric("inv_inverse", "theta", theta, THETA_MAX)
    sgn = ca.sign(theta)
    t_abs = ca.fabs(theta)
    tiny = t_abs < _THETA_TINY
    t = select(tiny, _THETA_TINY, t_abs)  # keeps the Newton branch finite (no 0/0 at theta = 0)
    alpha = select(t < _THETA_SWITCH, inv_inverse_cheng(t), _inv_inverse_asymptotic(t))
    for _ in range(steps):
        ta = ca.tan(alpha)
        alpha = alpha - (_inv(alpha) - t) / (ta * ta)
    # tiny theta: alpha = (3 theta)^(1/3) - (2/5) theta to machine precision (next term ~ theta^(5/3));
    # one Newton step on c^3 = 3 theta removes the rounding of pow(., 1/3), which grows with |log theta|
    # (fmax only guards 0/0 at theta = 0: 3 c^2 > 1e-215 for any positive double).
    x3 = 3.0 * t_abs
    c = x3 ** (1.0 / 3.0)
    c = c - (c * c * c - x3) / ca.fmax(3.0 * c * c, 1e-300)
    return sgn * select(tiny, c - 0.4 * t_abs, alpha)


def involute_point(r_b: float, phi: Expr) -> tuple:
    """Point of the involute of the base circle ``r_b`` at roll angle ``phi`` (Litvin eq. 10.2.5).

    ``x = r_b (sin phi - phi cos phi)``, ``y = r_b (cos phi + phi sin phi)``; the involute starts at
    ``(0, r_b)`` for ``phi = 0`` (the singular point). ``x`` is computed without cancellation for
    small ``phi`` (series for ``|phi| < 0.9``), so it keeps full relative accuracy there. The point lies at radius
    ``r_b sqrt(1 + phi^2)`` and polar angle ``inv(alpha)`` from the y axis towards +x, with
    ``phi = tan(alpha)`` (eqs. 10.2.6-10.2.9).

    Parameters
    ----------
    r_b : float or casadi expression
        Base radius [mm].
    phi : float or casadi expression
        Roll angle [rad].

    Returns
    -------
    (x, y) : tuple
        Coordinates [mm].
    """
    s, c = ca.sin(phi), ca.cos(phi)
    # sin phi - phi cos phi ~ phi^3 / 3 cancels near the base circle: series there
    sxc = select(ca.fabs(phi) < _INV_SERIES_MAX, _sin_minus_x_cos_series(phi), s - phi * c)
    return r_b * sxc, r_b * (c + phi * s)


def involute_tangent(r_b: float, phi: Expr) -> tuple:
    """Tangent ``d(x, y)/d phi = r_b phi (sin phi, cos phi)`` of :func:`involute_point`.

    Parameters
    ----------
    r_b : float or casadi expression
        Base radius [mm].
    phi : float or casadi expression
        Roll angle [rad].

    Returns
    -------
    (dx, dy) : tuple
        Tangent vector [mm/rad]; it vanishes at ``phi = 0`` (the singular point).
    """
    return r_b * phi * ca.sin(phi), r_b * phi * ca.cos(phi)


def involute_normal(phi: Expr) -> tuple:
    """Unit normal ``(cos phi, -sin phi)`` of the involute (Litvin eq. 9.4.28), defined for every phi.

    It is the unit tangent rotated by -90 deg for ``phi > 0`` (for ``phi < 0`` the tangent reverses
    while this normal does not: it is continuous through the cusp); it points away from the tooth
    whose flank the branch of eq. 10.2.5 bounds on its left, i.e. along the generating line.

    Parameters
    ----------
    phi : float or casadi expression
        Roll angle [rad].

    Returns
    -------
    (nx, ny) : tuple
        Unit normal [-].
    """
    return ca.cos(phi), -ca.sin(phi)


def extended_involute_point(r_b: float, h: float, phi: Expr, extended: bool = True) -> tuple:
    """Extended (``extended=True``) or shortened involute (Litvin eq. 10.2.11).

    ``x = (r_b -+ h) sin phi - r_b phi cos phi``, ``y = (r_b -+ h) cos phi + r_b phi sin phi``;
    ``h = 0`` is the involute, ``h = r_b`` (extended) the Archimedes spiral ``r = r_b |phi|``.

    Parameters
    ----------
    r_b : float or casadi expression
        Base radius [mm].
    h : float or casadi expression
        Offset of the tracing point from the generating line [mm] (towards the centre for the
        extended involute).
    phi : float or casadi expression
        Roll angle [rad].
    extended : bool
        ``True``: extended involute (``r_b - h``); ``False``: shortened (``r_b + h``).

    Returns
    -------
    (x, y) : tuple
        Coordinates [mm].
    """
    rr = r_b - h if extended else r_b + h
    s, c = ca.sin(phi), ca.cos(phi)
    return rr * s - r_b * phi * c, rr * c + r_b * phi * s


def pressure_angle_at(r_b: float, r: Expr) -> Expr:
    """Pressure angle of the involute at radius ``r``: ``cos alpha = r_b / r`` (eq. 10.2.7).

    Computed as ``atan2(sqrt((r - r_b)(r + r_b)), r_b)``, which is accurate near the base circle
    (where ``acos`` loses half the digits) and gives exactly 0 at ``r = r_b``.

    Parameters
    ----------
    r_b : float or casadi expression
        Base radius [mm], > 0.
    r : float or casadi expression
        Radius [mm], ``r >= r_b`` (NaN below the base circle).

    Returns
    -------
    same type
        Pressure angle [rad] in ``[0, pi/2)``.
    """
    return ca.atan2(ca.sqrt((r - r_b) * (r + r_b)), r_b)


def roll_angle_at(r_b: float, r: Expr) -> Expr:
    """Roll angle ``phi = sqrt(r^2 - r_b^2) / r_b = tan(alpha)`` of the involute point at radius ``r``.

    Parameters
    ----------
    r_b : float or casadi expression
        Base radius [mm], > 0.
    r : float or casadi expression
        Radius [mm], ``r >= r_b`` (NaN below the base circle).

    Returns
    -------
    same type
        Roll angle [rad], >= 0.
    """
    return ca.sqrt((r - r_b) * (r + r_b)) / r_b


def tooth_thickness(r: Expr, r_p: float, s_p: float, alpha_p: float) -> Expr:
    """Arc tooth thickness at radius ``r`` (in the plane of ``alpha_p``, the transverse section).

    ``s(r) = 2 r [ s_p / (2 r_p) + inv(alpha_p) - inv(alpha_r) ]`` with ``cos alpha_r = r_b / r``
    and ``r_b = r_p cos alpha_p``. At ``r = r_b``: ``s_b = s_p r_b / r_p + 2 r_b inv(alpha_p)``.

    Parameters
    ----------
    r : float or casadi expression
        Radius [mm], ``r >= r_b`` (NaN below the base circle).
    r_p : float or casadi expression
        Reference (pitch) radius [mm].
    s_p : float or casadi expression
        Arc tooth thickness on the reference circle [mm].
    alpha_p : float or casadi expression
        Pressure angle on the reference circle [rad].

    Returns
    -------
    same type
        Arc tooth thickness at ``r`` [mm] (<= 0 beyond the radius where the tooth is pointed).
    """
    r_b = r_p * ca.cos(alpha_p)
    return 2.0 * r * (s_p / (2.0 * r_p) + inv(alpha_p) - inv(pressure_angle_at(r_b, r)))
