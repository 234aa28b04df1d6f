"""Hertz's line contact, Weber & Banaschek's contact approach and ISO 6336-1's single-pair stiffness
c' of steel: the one implementation shared by the
loaded TCA (:mod:`gearopt.ltca.compliance`, :mod:`gearopt.ltca.engine`), the loaded micro-geometry
optimiser's NLP (:mod:`gearopt.synthesis.loaded.nlp`) and the FE references (:func:`gearopt.fea.references.hertz_line`).

Every function is elementwise and generic: NumPy arrays or floats give NumPy results, CasADi
expressions (SX, MX, DM) give CasADi expressions (the NLP differentiates them by AD). The
operations are written once, in the same order for both, so a caller's numbers do not change with
the kind of its arguments.

Units: loads per unit length of contact line ``f`` [N/mm], radii and depths [mm], moduli [MPa].

References
----------
Johnson, K. L., *Contact Mechanics*, Cambridge University Press, 1985, section 4.2 (eq. 4.43, 4.45:
half-width and peak pressure of two cylinders). Weber, C., Banaschek, K., *Formänderung und
Profilrücknahme bei gerad- und schrägverzahnten Rädern*, Schriftenreihe Antriebstechnik 11, Vieweg,
1953 (the approach of two cylinders measured to a depth ``h``); Cornell, R. W., *Compliance and
stress sensitivity of spur gear teeth*, J. Mech. Des. 103 (1981), eq. 11 (the same formula).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..errors import out_of_range

if TYPE_CHECKING:
    from ..types import Expr

#: ISO 6336-1's typical single-pair stiffness c' of steel spur gears [N/mm per mm of face] (14 N/(mm um)):
#: the FE model's contact stiffness and the loaded TCA's first guess scale it with E / 210 GPa.
C_PRIME_STEEL = 14.0e3

#: how :func:`weber_compliance` keeps the logarithm finite at a vanishing load ``f`` (below ``f_min``)
SMOOTHINGS = ("max", "hypot")


def _casadi(*args) -> bool:
    return any(isinstance(a, (ca.SX, ca.MX, ca.DM)) for a in args)


def _sqrt(x):
    return ca.sqrt(x) if _casadi(x) else np.sqrt(x)


def _log(x):
    return ca.log(x) if _casadi(x) else np.log(x)


def contact_modulus(E: float, nu: float) -> float:
    """Contact modulus of two bodies of the same material, ``E* = E / (2 (1 - nu^2))`` [MPa]
    (``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``, Johnson eq. 4.22)."""
    return E / (2 * (1 - nu**2))


def hertz_half_width(f: Expr, R_star: Expr, E_star: Expr) -> Expr:
    """Half-width of the Hertz contact band of two cylinders, ``b_H = sqrt(4 f R* / (pi E*))`` [mm]
    (Johnson eq. 4.43).

    Parameters
    ----------
    f : float, array or CasADi expression
        Load per unit length of contact line [N/mm], >= 0.
    R_star : float or array
        Reduced radius of curvature across the line, ``1/R* = 1/rho1 + 1/rho2`` [mm].
    E_star : float
        Contact modulus [MPa] (:func:`contact_modulus`).
    """
    return _sqrt(4.0 * f * R_star / (math.pi * E_star))


def hertz_peak_pressure(f: Expr, R_star: Expr, E_star: Expr) -> Expr:
    """Peak pressure of the Hertz line contact, ``p0 = sqrt(f E* / (pi R*))`` [MPa] (Johnson eq. 4.45);
    arguments as :func:`hertz_half_width`."""
    return _sqrt(f * E_star / (math.pi * R_star))


def weber_compliance(f: Expr, R_star: Expr, h1: Expr, h2: Expr, E: float, nu: float, E_star: float, f_min: Expr,
                     smoothing: str = "max") -> Expr:
    """Weber & Banaschek's contact approach of two cylinders per unit load, each body measured to the
    depth ``h`` (the tooth centreline), ``c = delta / f`` [mm^2/N]:

        ``c = 2 (1 - nu^2) / (pi E) (ln(2 h1 / b_H) + ln(2 h2 / b_H) - nu / (1 - nu))``

    with ``b_H`` the Hertz half-width (:func:`hertz_half_width`) at the load ``f_s``, which is ``f``
    kept away from zero: ``smoothing = "max"``: ``f_s = max(f, f_min)`` (the loaded TCA: the
    compliance is held at its value at ``f_min`` below it); ``"hypot"``: ``f_s = sqrt(f^2 + f_min^2)``
    (the optimiser's NLP: smooth in ``f``, for its exact derivatives).

    Parameters
    ----------
    f : float, array or CasADi expression
        Load per unit length of contact line [N/mm].
    R_star : float or array
        Reduced radius of curvature across the line [mm].
    h1, h2 : float or array
        Depths of the two bodies to their reference (the tooth centreline) [mm].
    E, nu : float
        Young's modulus [MPa] and Poisson's ratio of both bodies.
    E_star : float
        Contact modulus [MPa] (:func:`contact_modulus`).
    f_min : float, array or CasADi expression
        Smallest load of the logarithm [N/mm], > 0.
    smoothing : str
        One of :data:`SMOOTHINGS`.

    Returns
    -------
    Compliance per unit contact length [mm^2/N], the kind of ``f``.
    """
    if smoothing == "max":
        fs = ca.fmax(f, f_min) if _casadi(f, f_min) else np.maximum(f, f_min)
    elif smoothing == "hypot":
        fs = _sqrt(f**2 + f_min**2)
    else:
        raise out_of_range("smoothing", smoothing, f"one of {list(SMOOTHINGS)}")
    b = hertz_half_width(fs, R_star, E_star)
    return 2.0 * (1.0 - nu**2) / (math.pi * E) * (_log(2.0 * h1 / b) + _log(2.0 * h2 / b) - nu / (1.0 - nu))
