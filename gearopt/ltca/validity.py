"""The range of validity of the loaded TCA's linear-elastic contact model: the pressure and approach
limits (:data:`P_MAX_VALID`, :data:`DELTA_MAX_VALID`), a lower bound of the peak pressure from the gear
data alone (:func:`pressure_lower_bound`), the check of a torque before any solve
(:func:`check_torque_range`) and of a solved result (:func:`check_validity`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..contact.hertz import contact_modulus, hertz_peak_pressure
from ..errors import OptionError
from ..gears import GearPair

if TYPE_CHECKING:
    from .compliance import Material
    from .loaded_result import LoadedResult

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
