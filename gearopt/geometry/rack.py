"""The basic rack (ISO 53, Litvin Fig. 10.3.4): the normal-section profile of the rack-cutter that
defines a gear. Data of the tool, below :mod:`gearopt.gears` (which re-exports :class:`BasicRack`)
and the generation machinery that cuts with it. Lengths in mm, angles in rad, coefficients in
units of the normal module m_n.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from ..errors import ArgumentError, GeometryError, out_of_range
from ..units import DEG

_ISO53 = {
    # profile: (h_aP, h_fP, rho_fP)   alpha_n = 20 deg for all (ISO 53:1998)
    "A": (1.0, 1.25, 0.38),
    "B": (1.0, 1.25, 0.30),
    "C": (1.0, 1.25, 0.25),
    "D": (1.0, 1.40, 0.39),
}


def finite_number(name: str, value: float) -> float:
    """``value`` as a float; GeometryError naming ``name`` unless it is a finite number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise GeometryError(f"{name} = {value!r} must be a finite number.", param=name, value=value,
                            valid="a finite number", detail="must be a finite number.")
    return float(value)


@dataclass(frozen=True)
class BasicRack:
    """Basic rack profile / rack-cutter that defines a gear (ISO 53, Litvin Fig. 10.3.4).

    The rack-cutter is the negative of the basic rack: its addendum cuts the gear's dedendum.
    Coefficients are in units of the normal module ``m_n`` of the gear it cuts.

    Parameters
    ----------
    alpha_n : float
        Profile (pressure) angle [rad], ``0 < alpha_n < 45 deg``.
    h_aP : float
        Addendum of the basic rack [m_n] (> 0); the gear's addendum for ``x = 0``.
    h_fP : float
        Dedendum of the basic rack [m_n] (>= h_aP); the tool's cutting depth below the datum line.
    rho_fP : float
        Root fillet radius of the basic rack [m_n] (tool tip radius), ``0 <= rho_fP <= rho_max``
        where ``rho_max`` leaves a tool tip land of zero width.
    a_c : float
        Parabolic profile coefficient [1/mm] of the rack-cutter (profile crowning, Litvin
        section 4): the tool profile deviates by ``a_c (u - u_0)^2`` from the straight line, ``u``
        measured along the profile [mm]. 0 is the straight (conjugate) rack.
    u_0 : float
        Position of the parabola apex along the profile [mm], from the datum line, positive towards
        the tool tip (the gear root). Usually at the mean contact point.
    name : str
        Label (``"ISO 53 A"`` for presets).
    """

    alpha_n: float = 20 * DEG
    h_aP: float = 1.0
    h_fP: float = 1.25
    rho_fP: float = 0.38
    a_c: float = 0.0
    u_0: float = 0.0
    name: str = "custom"

    def __post_init__(self):
        for f in ("alpha_n", "h_aP", "h_fP", "rho_fP", "a_c", "u_0"):
            finite_number(f"rack.{f}", getattr(self, f))
        if not 0.0 < self.alpha_n < 45 * DEG:
            raise out_of_range("rack.alpha_n", f"{self.alpha_n / DEG:.6g} deg", "0 < alpha_n < 45 deg")
        if self.h_aP <= 0:
            raise out_of_range("rack.h_aP", self.h_aP, "h_aP > 0 (in modules)")
        if self.h_fP < self.h_aP:
            raise out_of_range("rack.h_fP", self.h_fP, f"h_fP >= h_aP = {self.h_aP} (clearance c_P >= 0, in modules)")
        land = math.pi / 4 - self.h_fP * math.tan(self.alpha_n)  # half tip land of the straight tool [m_n]
        if land < 0:
            raise out_of_range("rack.h_fP", self.h_fP, f"h_fP <= {math.pi / 4 / math.tan(self.alpha_n):.4f} for "
                               f"alpha_n = {math.degrees(self.alpha_n):.4g} deg (the tool tooth would be pointed)")
        if self.rho_fP < 0 or self.rho_fP > self.rho_max:
            raise out_of_range("rack.rho_fP", self.rho_fP, f"0 <= rho_fP <= {self.rho_max:.4f} (in modules; larger "
                               "fillets do not fit on the tool tip)")
        if self.a_c < 0:
            raise out_of_range("rack.a_c", self.a_c, "a_c >= 0 [1/mm] (0 = straight profile)")

    @classmethod
    def iso53(cls, profile: str = "A", **changes: Any) -> "BasicRack":
        """ISO 53 basic rack profile A, B, C or D (alpha_n = 20 deg); ``changes`` override fields."""
        key = str(profile).upper().replace("ISO53", "").replace("ISO 53", "").strip(" -")
        if key not in _ISO53:
            raise out_of_range("rack.preset", profile, "one of 'A', 'B', 'C', 'D' (ISO 53)")
        h_aP, h_fP, rho = _ISO53[key]
        unknown = sorted(set(changes) - {f.name for f in fields(cls)})
        if unknown:
            valid = ', '.join(f.name for f in fields(cls))
            raise ArgumentError(f"BasicRack.iso53: unknown field(s) {', '.join(unknown)}; valid: {valid}.",
                                param=f"rack.{unknown[0]}", valid=valid)
        return cls(**{"alpha_n": 20 * DEG, "h_aP": h_aP, "h_fP": h_fP, "rho_fP": rho, "name": f"ISO 53 {key}", **changes})

    @property
    def c_P(self) -> float:
        """Bottom clearance coefficient ``h_fP - h_aP`` [m_n]."""
        return self.h_fP - self.h_aP

    @property
    def rho_max(self) -> float:
        """Largest tip radius [m_n] that fits the tool tooth (tip land of zero width)."""
        a = self.alpha_n
        half_land = math.pi / 4 - self.h_fP * math.tan(a)  # half tip width of the straight tool [m_n]
        return max(half_land, 0.0) * math.cos(a) / (1 - math.sin(a))

    @property
    def h_lim(self) -> float:
        """Height [m_n] below the datum line where the tool's straight flank meets its tip fillet.

        This bounds the part of the tool that generates involute; it sets the undercut limit
        (ISO 53 A: ``1.25 - 0.38 (1 - sin 20 deg) = 1.0``).
        """
        return self.h_fP - self.rho_fP * (1 - math.sin(self.alpha_n))
