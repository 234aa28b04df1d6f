"""The cutting tool of a gear (Litvin section 10.3): rack-cutter, hob or shaper.

A :class:`gearopt.gears.Gear` carries its tool (``Gear.tool``); :func:`gearopt.geometry.generation.generate`
builds the tooth surfaces with it, and every study and engine (TCA, edge contact, synthesis, FE,
the form and root radii of :mod:`gearopt.gears`) goes through that one dispatch. The tools are
frozen dataclasses validated on construction; the checks that need the gear (a hob's lead angle
for the module, a shaper's reach for the gear's tip) are in ``check(gear)``, which ``Gear`` runs.

Units: lengths in mm, angles in rad (degrees only at the scene edge), coefficients in units of the
normal module m_n.

* :class:`RackCutter`: the gear's own basic rack (``Gear.rack``) as a rack-cutter; no data of its
  own. The default tool.
* :class:`Hob`: a hob whose normal section is that rack (Litvin Fig. 10.3.5); it cuts the same
  flanks and fillets as the rack (the feed along the axis is continuous), and adds the hob rotation.
* :class:`Shaper`: a gear-shaped cutter (Litvin Fig. 10.3.6): an involute gear with ``N_s`` teeth,
  the gear's normal module and, for a helical gear, the same helix angle of the opposite hand (an
  external shaper cutting an external gear). Its teeth are conjugate to the gear's basic rack:
  addendum ``(h_fP + x_s) m_n`` over its reference circle and a tip rounding of radius
  ``rho_fP m_n``, circular in the shaper's transverse section.

This module imports nothing of :mod:`gearopt.gears` (which imports it): the gear is read by its
attributes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from ..errors import GeometryError, out_of_range
from .involute import inv, inv_inverse

#: Tool kinds, as written in a scene's ``tool = {kind = ...}``.
TOOL_KINDS = ("rack", "hob", "shaper")
_HANDS = ("right", "left")

#: Smallest hob lead angle [rad] gearopt accepts (real hobs have about 1 to 6 deg).
HOB_LEAD_MIN = 0.1 * math.pi / 180
#: Largest hob lead angle [rad] (multi-start roughing hobs reach about 10 deg; beyond 30 deg a
#: "hob" is a worm gear, not a generating tool).
HOB_LEAD_MAX = 30.0 * math.pi / 180
#: Fewest shaper teeth accepted on any gear (the gear may need more: :meth:`Shaper.check`).
SHAPER_N_MIN = 8


def _is_int(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, int)


def _is_finite(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)


@dataclass(frozen=True)
class RackCutter:
    """The rack-cutter of the gear's basic rack (``Gear.rack``, normal section; Litvin Fig. 10.3.4).

    It has no data of its own: profile, tip fillet and profile crowning ``a_c`` are the
    :class:`~gearopt.gears.BasicRack`'s. The default tool of a :class:`~gearopt.gears.Gear`.
    """

    kind: ClassVar[str] = "rack"

    def check(self, gear) -> None:
        """Nothing to check against the gear."""


@dataclass(frozen=True)
class Hob:
    """A hob whose normal section is the rack-cutter (Litvin section 10.3, Fig. 10.3.5).

    Parameters
    ----------
    N_h : int
        Number of threads (starts), >= 1 (usually 1).
    d_p0 : float
        Hob reference diameter [mm], > 0; with the module it sets the lead angle
        ``sin lambda = N_h m_n / d_p0``, which must lie in [:data:`HOB_LEAD_MIN`, :data:`HOB_LEAD_MAX`].
    hand : {"right", "left"}
        Hand of the hob thread.
    """

    N_h: int = 1
    d_p0: float = 60.0
    hand: str = "right"
    kind: ClassVar[str] = "hob"

    def __post_init__(self):
        if not _is_int(self.N_h) or self.N_h < 1:
            raise out_of_range("hob.N_h", self.N_h, "an integer >= 1 (threads)")
        if not (_is_finite(self.d_p0) and self.d_p0 > 0):
            raise out_of_range("hob.d_p0", self.d_p0, "d_p0 > 0 mm")
        if self.hand not in _HANDS:
            raise out_of_range("hob.hand", self.hand, "'right' or 'left'")

    def d_p0_range(self, m_n: float) -> tuple[float, float]:
        """Hob reference diameters [mm] that give a lead angle in [HOB_LEAD_MIN, HOB_LEAD_MAX]."""
        return self.N_h * m_n / math.sin(HOB_LEAD_MAX), self.N_h * m_n / math.sin(HOB_LEAD_MIN)

    def lead_angle(self, m_n: float, name: str = "hob.d_p0") -> float:
        """Thread lead angle on the reference cylinder [rad]: ``sin lambda = N_h m_n / d_p0``.

        Raises
        ------
        GeometryError
            If it falls outside [:data:`HOB_LEAD_MIN`, :data:`HOB_LEAD_MAX`] (named ``name``).
        """
        lo, hi = self.d_p0_range(m_n)
        if not lo <= self.d_p0 <= hi:
            raise out_of_range(name, self.d_p0, f"{lo:.6g} <= d_p0 <= {hi:.6g} mm for m_n = {m_n:g} mm, "
                               f"N_h = {self.N_h}: a lead angle from {math.degrees(HOB_LEAD_MIN):g} to "
                               f"{math.degrees(HOB_LEAD_MAX):g} deg (real hobs: about 1 to 6 deg; here "
                               + (f"asin(N_h m_n / d_p0) = {math.degrees(math.asin(self.N_h * m_n / self.d_p0)):.4g} deg)"
                                  if self.N_h * m_n < self.d_p0 else "N_h m_n >= d_p0: no lead angle at all)"))
        return math.asin(self.N_h * m_n / self.d_p0)

    def swivel_angle(self, gear) -> float:
        """Setting angle between hob and gear axes [rad]: ``beta -+ lambda`` (same/opposite hands),
        measured from the plane normal to the gear axis."""
        lam = self.lead_angle(gear.m_n)
        same = gear.is_spur or gear.hand == self.hand
        sign = -1.0 if same else 1.0
        return (gear.beta if not gear.is_spur else 0.0) + sign * lam

    def check(self, gear) -> None:
        """The lead angle must be in range for the gear's module (raises ``<gear>.tool.d_p0``)."""
        self.lead_angle(gear.m_n, f"{gear.name}.tool.d_p0")


@dataclass(frozen=True)
class Shaper:
    """A gear-shaped cutter with N_s teeth (Litvin section 10.3, Fig. 10.3.6).

    An involute gear of the cut gear's normal module; for a helical gear, of the same helix angle
    and the opposite hand (external cutting mesh). Its teeth are conjugate to the gear's basic rack:
    tip radius ``r_as = r_ps + (h_fP + x_s) m_n`` (it cuts the gear's dedendum) with a tip rounding
    of radius ``rho_fP m_n`` (circular in the shaper's transverse section). Crowning (``a_c``,
    ``a_pl``) is a rack/hob setting and is refused.

    Parameters
    ----------
    N_s : int
        Number of shaper teeth, >= :data:`SHAPER_N_MIN`; the gear may need more
        (:meth:`check`: the shaper's involute must reach the gear's tip).
    x_s : float
        Profile shift coefficient of the shaper [-].
    """

    N_s: int = 25
    x_s: float = 0.0
    kind: ClassVar[str] = "shaper"

    def __post_init__(self):
        if not _is_int(self.N_s) or self.N_s < SHAPER_N_MIN:
            raise out_of_range("shaper.N_s", self.N_s, f"an integer >= {SHAPER_N_MIN} (teeth)")
        if not _is_finite(self.x_s):
            raise out_of_range("shaper.x_s", self.x_s, "a finite profile shift")

    # --- cutting geometry (transverse section; Litvin section 10.3, ISO 21771) -------------------
    def cutting(self, gear, x: float | None = None, N_s: int | None = None, x_s: float | None = None) -> dict:
        """Transverse cutting geometry of this shaper on ``gear`` (at generating shift ``x``,
        default ``gear.x_E``) [mm, rad]: shaper reference, base and tip radii ``r_ps, r_bs, r_as``,
        tip rounding ``rho`` and its centre radius ``r_c``, reference thickness ``s_ps``, cutting
        pressure angle ``alpha_w`` (``inv alpha_w = inv alpha_t + 2 tan alpha_n (x_s + x)/(N_s + z)``),
        cutting centre distance ``a_cut``, gear root radius ``r_root = a_cut - r_as``, and ``L_tip``,
        ``L_form``: distances along the line of action from the shaper's base-circle tangency point
        to the point that cuts the gear's tip, and to the shaper's flank/rounding junction."""
        N_s = self.N_s if N_s is None else N_s
        x_s = self.x_s if x_s is None else x_s
        x = gear.x_E if x is None else x
        rack = gear.rack
        al = rack.alpha_n if gear.is_spur else gear.alpha_t
        m_t, m_n = gear.m_t, gear.m_n
        r_ps = m_t * N_s / 2
        r_bs = r_ps * math.cos(al)
        r_as = r_ps + m_n * (rack.h_fP + x_s)
        rho = rack.rho_fP * m_n
        inv_w = inv(al) + 2 * math.tan(rack.alpha_n) * (x_s + x) / (N_s + gear.z)
        out = {"r_ps": r_ps, "r_bs": r_bs, "r_as": r_as, "rho": rho, "r_c": r_as - rho,
               "s_ps": m_t * (math.pi / 2 + 2 * x_s * math.tan(rack.alpha_n)), "alpha_t": al}
        if not inv_w > 0:  # the centre distance would be below r_b + r_bs: no cutting mesh
            return {**out, "alpha_w": math.nan, "a_cut": math.nan, "r_root": math.nan, "L_tip": -math.inf,
                    "L_form": math.inf, "reach": -math.inf}
        alpha_w = float(inv_inverse(inv_w))
        a_cut = (r_ps + gear.r_p) * math.cos(al) / math.cos(alpha_w)
        line = a_cut * math.sin(alpha_w)  # T_s T_g, the line of action between the base circles
        r_b = gear.r_p * math.cos(al)
        L_tip = line - math.sqrt(max(gear.r_a**2 - r_b**2, 0.0))
        c = max(out["r_c"] ** 2 - r_bs**2, 0.0)
        L_form = rho + math.sqrt(c)  # r_bs * roll angle of the junction (centre on the flank normal)
        return {**out, "alpha_w": alpha_w, "a_cut": a_cut, "r_root": a_cut - r_as, "line": line,
                "L_tip": L_tip, "L_form": L_form}

    def root_radius(self, gear) -> float:
        """Root radius [mm] of ``gear`` cut by this shaper: ``a_cut - r_as``."""
        return self.cutting(gear)["r_root"]

    def form_radius(self, gear) -> float:
        """Radius [mm] of the gear point cut by the shaper's flank/rounding junction (the form radius
        when the gear is not undercut): on the line of action, ``line - L_form`` from the gear's
        base-circle tangency point."""
        c = self.cutting(gear)
        r_b = gear.r_p * math.cos(c["alpha_t"])
        return math.hypot(r_b, c["line"] - c["L_form"])

    def x_min_undercut(self, gear) -> float:
        """Smallest generating shift x_E without undercut by this shaper: the junction's point on the
        line of action stays between the two base-circle tangency points (bisection; the line grows
        with x)."""
        def margin(x):
            c = self.cutting(gear, x=x)
            return c["line"] - c["L_form"] if math.isfinite(c["a_cut"]) else -math.inf

        lo, hi = gear.x_E - 1.0, gear.x_E + 1.0
        for _ in range(60):
            if margin(lo) < 0:
                break
            lo -= 2 * (hi - lo)
        else:
            return -math.inf
        for _ in range(60):
            if margin(hi) >= 0:
                break
            hi += 2 * (hi - lo)
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if margin(mid) < 0 else (lo, mid)
        return hi

    def _fits(self, gear, N_s: int) -> bool:
        c = self.cutting(gear, N_s=N_s)
        return c["r_c"] > c["r_bs"] and c["L_tip"] > 0

    def check(self, gear) -> None:
        """Refuse a shaper that cannot cut ``gear``.

        * crowning: ``a_pl`` and the rack's ``a_c`` must be 0 (rack/hob settings);
        * the tip rounding's centre must lie outside the shaper's base circle, and the shaper's
          involute must reach the gear's tip (the point that cuts the tip lies beyond the shaper's
          base circle on the line of action); otherwise more teeth are needed (the smallest count
          is stated);
        * the shaper tooth must not be pointed at its tip circle.

        Raises
        ------
        GeometryError
            Naming ``<gear>.a_pl``, ``<gear>.rack.a_c``, ``<gear>.tool.N_s`` or ``<gear>.tool.x_s``.
        """
        n = gear.name
        if gear.a_pl != 0:
            raise out_of_range(f"{n}.a_pl", gear.a_pl, "a_pl = 0 for a shaper-cut gear (tool kind 'shaper'): "
                               "longitudinal crowning by plunging is a rack-cutter/hob setting")
        if gear.rack.a_c != 0:
            raise out_of_range(f"{n}.rack.a_c", gear.rack.a_c, "a_c = 0 for a shaper-cut gear (tool kind "
                               "'shaper'): profile crowning is a rack-cutter/hob setting")
        if not self._fits(gear, self.N_s):
            n_min = next((k for k in range(self.N_s + 1, 100001) if self._fits(gear, k)), None)
            c = self.cutting(gear)
            why = ("its tip rounding's centre falls inside its base circle" if not c["r_c"] > c["r_bs"] else
                   f"its involute does not reach the gear's tip circle r_a = {gear.r_a:.6g} mm (the tip would be "
                   "cut by the shaper's root region)")
            rng = f">= {n_min} shaper teeth" if n_min else "more shaper teeth"
            raise out_of_range(f"{n}.tool.N_s", self.N_s, f"{rng} for this gear (z = {gear.z}, x = {gear.x:g}, "
                               f"m_n = {gear.m_n:g} mm, shaper x_s = {self.x_s:g}): with {self.N_s} teeth {why}")
        c = self.cutting(gear)
        if c["r_as"] > c["r_bs"]:
            s_as = _thickness(c["r_as"], c["r_ps"], c["s_ps"], c["alpha_t"])
            if not s_as > 0:
                hi = _x_s_max_pointed(self, gear)
                raise out_of_range(f"{n}.tool.x_s", self.x_s, f"a shaper profile shift < {hi:.4f} for {self.N_s} "
                                   f"shaper teeth (beyond, the shaper tooth is pointed at its tip: here s_a = "
                                   f"{s_as:.4g} mm)")


def _thickness(r: float, r_p: float, s_p: float, alpha: float) -> float:
    """Transverse arc thickness at radius r of an involute tooth of thickness s_p on r_p."""
    a_r = math.acos(r_p * math.cos(alpha) / r)
    return 2 * r * (s_p / (2 * r_p) + inv(alpha) - inv(a_r))


def _x_s_max_pointed(shaper: Shaper, gear) -> float:
    lo, hi = -2.0, shaper.x_s
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        c = shaper.cutting(gear, x_s=mid)
        ok = c["r_as"] <= c["r_bs"] or _thickness(c["r_as"], c["r_ps"], c["s_ps"], c["alpha_t"]) > 0
        lo, hi = (mid, hi) if ok else (lo, mid)
    return lo


#: The tool classes by kind.
TOOLS = {"rack": RackCutter, "hob": Hob, "shaper": Shaper}


def check_tool(gear) -> None:
    """Validate ``gear.tool`` (type, then against the gear); GeometryError naming ``<gear>.tool``."""
    tool = gear.tool
    if not isinstance(tool, (RackCutter, Hob, Shaper)):
        valid = "a RackCutter, Hob or Shaper (gearopt.geometry.tools)"
        raise GeometryError(f"{gear.name}.tool = {type(tool).__name__} {tool!r:.80}: expected {valid}.",
                            param=f"{gear.name}.tool", value=tool, valid=valid)
    tool.check(gear)


def require_rack_settings(gear, what: str) -> None:
    """Refuse a shaper-cut ``gear`` where ``what`` sets its rack-cutter settings (profile crowning
    ``a_c``, plunging ``a_pl``): crowning synthesis needs a rack-cutter or hob.

    Raises
    ------
    GeometryError
        Naming ``<gear>.tool``.
    """
    if isinstance(gear.tool, Shaper):
        raise out_of_range(f"{gear.name}.tool", f"kind '{gear.tool.kind}'", f"kind 'rack' or 'hob': {what} sets the "
                           "rack-cutter's profile crowning a_c and plunging a_pl, which a shaper does not have")
