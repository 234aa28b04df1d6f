"""Involute curves and the involute function (Litvin ch. 10.2).

All functions are CasADi-generic: they use only ``ca.*`` operations, so the same code takes
Python floats, NumPy arrays (element-wise), ``ca.SX`` or ``ca.MX``. Angles in rad, lengths in mm.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

#: Number of Newton steps that polish Cheng's series in :func:`inv_inverse` (machine precision
#: over 0 < alpha < 85 deg; see tests/test_involute.py).
NEWTON_STEPS = 4


def select(cond, a, b):
    """``a`` where ``cond`` else ``b``: Python choice for plain numbers, ``np.where`` for arrays,
    ``ca.if_else`` for symbolic expressions (both branches must be smooth where they are used)."""
    if isinstance(cond, (bool, np.bool_)):
        return a if cond else b
    if isinstance(cond, np.ndarray):
        return np.where(cond, a, b)
    return ca.if_else(cond, a, b)


def inv(alpha):
    """Involute function ``inv(alpha) = tan(alpha) - alpha`` (Litvin eq. 10.2.9).

    Parameters
    ----------
    alpha : float or casadi expression
        Pressure angle [rad], ``0 <= alpha < pi/2``.
    """
    # Series for small alpha avoids the cancellation of tan(alpha) - alpha.
    a2 = alpha * alpha
    series = alpha * a2 * (1.0 / 3 + a2 * (2.0 / 15 + a2 * (17.0 / 315 + a2 * (62.0 / 2835 + a2 * 1382.0 / 155925))))
    return select(alpha < 0.02, series, ca.tan(alpha) - alpha)


def inv_inverse_cheng(theta):
    """Cheng's series for the inverse of the involute function (Litvin eq. 10.2.10).

    Accurate to about 1e-4 rad at 45 deg and worse beyond; valid for ``theta < 1.8``.
    Use :func:`inv_inverse` for machine precision.
    """
    t = 3.0 * theta
    c = t ** (1.0 / 3)
    return c - 0.4 * theta + (9.0 / 175) * c**5 / 3.0 - (2.0 / 175) * c**7 / 9.0


def inv_inverse(theta, steps: int = NEWTON_STEPS):
    """Pressure angle alpha with ``inv(alpha) = theta``: Cheng's series polished by Newton.

    Parameters
    ----------
    theta : float or casadi expression
        Involute function value [rad], ``theta > 0``.
    steps : int
        Newton steps on ``tan(alpha) - alpha - theta = 0`` (a fixed count, so the graph is smooth).

    Returns
    -------
    alpha : same type as ``theta``
        Pressure angle [rad].
    """
    guess = select(theta < 1.0, inv_inverse_cheng(theta), ca.atan(theta + 1.3))
    alpha = guess
    for _ in range(steps):
        ta = ca.tan(alpha)
        alpha = alpha - (inv(alpha) - theta) / (ta * ta)
    return alpha


def involute_point(r_b, phi):
    """Point of the involute of the base circle ``r_b`` at roll angle ``phi`` (Litvin eq. 10.2.5).

    ``x = r_b (sin phi - phi cos phi)``, ``y = r_b (cos phi + phi sin phi)``; ``phi = 0`` is the
    point on the base circle (the singular point).

    Returns
    -------
    (x, y) : tuple
        Coordinates [mm].
    """
    s, c = ca.sin(phi), ca.cos(phi)
    return r_b * (s - phi * c), r_b * (c + phi * s)


def involute_tangent(r_b, phi):
    """Tangent ``d(x, y)/d phi = r_b phi (sin phi, cos phi)``; it vanishes at the singular point."""
    return r_b * phi * ca.sin(phi), r_b * phi * ca.cos(phi)


def involute_normal(phi):
    """Unit normal ``(cos phi, -sin phi)`` of the involute (Litvin eq. 9.4.28), defined for every phi.

    It is the unit tangent rotated by -90 deg for ``phi > 0``; it points away from the tooth whose
    flank the branch of eq. 10.2.5 bounds on its left, i.e. along the generating line.
    """
    return ca.cos(phi), -ca.sin(phi)


def extended_involute_point(r_b, h, phi, extended: bool = True):
    """Extended (``extended=True``) or shortened involute (Litvin eq. 10.2.11).

    ``x = (r_b -+ h) sin phi - r_b phi cos phi``, ``y = (r_b -+ h) cos phi + r_b phi sin phi``;
    ``h = 0`` is the involute, ``h = r_b`` (extended) the Archimedes spiral ``r = r_b |phi|``.
    """
    rr = r_b - h if extended else r_b + h
    s, c = ca.sin(phi), ca.cos(phi)
    return rr * s - r_b * phi * c, rr * c + r_b * phi * s


def pressure_angle_at(r_b, r):
    """Pressure angle of the involute at radius ``r``: ``alpha = acos(r_b / r)`` [rad] (eq. 10.2.7)."""
    return ca.acos(r_b / r)


def roll_angle_at(r_b, r):
    """Roll angle ``phi = sqrt(r^2 - r_b^2) / r_b`` of the involute point at radius ``r``."""
    return ca.sqrt(r * r - r_b * r_b) / r_b


def tooth_thickness(r, r_p, s_p, alpha_p):
    """Arc tooth thickness at radius ``r`` in the transverse section.

    ``s(r) = 2 r [ s_p / (2 r_p) + inv(alpha_p) - inv(alpha_r) ]`` with ``cos alpha_r = r_b / r``
    and ``r_b = r_p cos alpha_p``.

    Parameters
    ----------
    r : radius [mm] (``r >= r_b``)
    r_p : reference (pitch) radius [mm]
    s_p : transverse arc tooth thickness on the reference circle [mm]
    alpha_p : transverse pressure angle on the reference circle [rad]
    """
    r_b = r_p * ca.cos(alpha_p)
    return 2.0 * r * (s_p / (2.0 * r_p) + inv(alpha_p) - inv(pressure_angle_at(r_b, r)))
