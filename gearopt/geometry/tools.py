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

Tools are objects: :class:`Tool` declares what a generator needs of a tool, and each kind is one
subclass, registered by its ``kind`` (:data:`TOOLS`) when the class is defined:

* ``generate(gear)``: the gear's tooth surfaces (:class:`~gearopt.geometry.envelope.GeneratedTooth`),
  called by :func:`gearopt.geometry.generation.generate`;
* ``check(gear)``: the tool against the gear, run when the ``Gear`` is built;
* ``root_radius(gear)``, ``form_radius(gear)``, ``x_min_undercut(gear)``: the closed forms behind
  ``Gear.r_f``, ``Gear.r_lim`` and ``Gear.x_min_undercut`` (the rack-cutter's by default);
* ``flank_limit(gear)``, ``a_c_max_unfolded(gear)``: from the generated surfaces (``Gear.flank_limit``,
  ``Gear.r_form``, ``Gear.folded``, ``Gear.a_c_max_unfolded``);
* ``rack_settings``: whether the tool has the rack-cutter's crowning settings ``a_c``, ``a_pl``;
* ``scene_keys``: the keys of the scene's ``tool = {kind = ...}`` table (:class:`SceneKey`), from
  which :mod:`gearopt.io.scene` builds the table's fields and :meth:`Tool.from_scene` the tool.

Adding a tool is one subclass (docs/extending.md, "Adding a tool").

This module imports nothing of :mod:`gearopt.gears` (which imports it): the gear is read by its
attributes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

from ..errors import ArgumentError, GeometryError, out_of_range
from .envelope import FlankLimit, GeneratedTooth, rack_generated, shaper_generated
from .involute import inv, inv_inverse

if TYPE_CHECKING:  # typing only: gears imports this module
    from ..gears import Gear

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


class SceneKey(NamedTuple):
    """One key of a scene's ``tool = {kind = ...}`` table (:attr:`Tool.scene_keys`).

    Attributes
    ----------
    key : str
        The scene key (``"z"``).
    attr : str
        The tool's dataclass field it sets (``"N_h"``).
    kind : str
        The scene value type (``"int"``, ``"float"``, ``"str"``, ``"length"`` [mm], ``"angle"`` [deg in
        the scene, rad in the field]; see :class:`gearopt.io.schema.Field`).
    default : Any
        The scene default (the field's default, in scene units).
    doc : str
        One line for ``gearopt studies common`` and the docs.
    bounds : dict or None
        Keyword arguments of :class:`gearopt.io.schema.Bounds` (scene units), e.g. ``{"lo": 1, "hi": 8}``.
    choices : tuple or None
        The allowed values of a ``"str"`` key.
    """

    key: str
    attr: str
    kind: str
    default: Any
    doc: str
    bounds: dict | None = None
    choices: tuple | None = None


#: The tool classes by kind (every subclass of :class:`Tool` with a ``kind`` registers itself).
TOOLS: dict[str, type[Tool]] = {}


@lru_cache(maxsize=256)
def _flank_limit(gear: Gear) -> FlankLimit:
    return gear.tool.generate(gear).flank_limit("right", 0.0)


@lru_cache(maxsize=256)
def _a_c_max_unfolded(gear: Gear) -> float:
    return gear.tool.generate(gear).max_unfolded_a_c("right", 0.0)


class Tool:
    """A cutting tool: what the generators and the gear data ask of it (see the module docstring).

    A subclass is a frozen dataclass with a class attribute ``kind`` (the scene's ``tool = {kind =
    ...}``) and implements :meth:`generate`; the closed forms default to the rack-cutter's
    (a tool whose straight flank ends at the basic rack's ``h_lim``, Litvin section 10.3).
    Defining the subclass registers it in :data:`TOOLS`.
    """

    kind: ClassVar[str] = ""
    #: True when the tool has the rack-cutter's settings: profile crowning ``rack.a_c`` and plunging ``a_pl``.
    rack_settings: ClassVar[bool] = True
    #: Keys of the scene's ``tool = {kind = ...}`` table.
    scene_keys: ClassVar[tuple[SceneKey, ...]] = ()

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        kind = cls.__dict__.get("kind")
        if kind:
            old = TOOLS.get(kind)
            if old is not None and (old.__module__, old.__qualname__) != (cls.__module__, cls.__qualname__):
                taken = ", ".join(TOOLS)
                raise ArgumentError(f"{cls.__qualname__}.kind = {kind!r} is the kind of {old.__module__}."
                                    f"{old.__qualname__}; a tool kind names one class (taken: {taken}).",
                                    param=f"{cls.__qualname__}.kind", value=kind, valid=f"not one of {taken}")
            TOOLS[kind] = cls  # (a class defined again under the same name replaces itself)

    @classmethod
    def from_scene(cls, values: dict) -> Tool:
        """The tool from a parsed ``tool`` table (scene key -> value, ``kind`` ignored)."""
        return cls(**{k.attr: values[k.key] for k in cls.scene_keys if k.key in values})

    @classmethod
    def scene_key_of(cls, attr: str) -> str:
        """The scene key that sets the field ``attr`` (the field's name when no key does)."""
        return next((k.key for k in cls.scene_keys if k.attr == attr), attr)

    def check(self, gear: Gear) -> None:
        """Refuse a tool that cannot cut ``gear`` (GeometryError naming ``<gear>.tool...``); nothing
        by default."""

    def generate(self, gear: Gear) -> GeneratedTooth:
        """The tooth surfaces of ``gear`` cut by this tool (:mod:`gearopt.geometry.envelope`)."""
        raise NotImplementedError(f"{type(self).__name__}.generate")

    def root_radius(self, gear: Gear) -> float:
        """Root radius [mm] (``Gear.r_f``): cut by the tool tip line at the generating shift ``x_E``,
        ``r_p + m_n (x_E - h_fP)``."""
        return gear.r_p + gear.m_n * (gear.x_E - gear.rack.h_fP)

    def form_radius(self, gear: Gear) -> float:
        """Radius [mm] generated by the end of the tool's straight flank (``Gear.r_lim``; the form
        radius when there is no undercut)."""
        # The flank end, h below the rolling (pitch) line (h < 0: above it), generates the gear point
        # where it crosses the line of action, h / sin(alpha_t) from the pitch point towards the
        # interference point T (r_p sin(alpha_t) from the pitch point); the same formula holds for h < 0.
        # With undercut (h > r_p sin^2 alpha_t) the point lies beyond T: the value is then not the form radius.
        h = (gear.rack.h_lim - gear.x_E) * gear.m_n
        return math.hypot(gear.r_b, gear.r_p * math.sin(gear.alpha_t) - h / math.sin(gear.alpha_t))

    def x_min_undercut(self, gear: Gear) -> float:
        """Smallest generating shift without undercut (``Gear.x_min_undercut``):
        ``h_lim - z sin^2(alpha_t) / (2 cos beta)``."""
        return gear.rack.h_lim - gear.z * math.sin(gear.alpha_t) ** 2 / (2 * math.cos(gear.beta))

    def flank_limit(self, gear: Gear) -> FlankLimit:
        """Where the real generated flank ends in the mid section (right flank), from the generated
        surfaces (:meth:`~gearopt.geometry.envelope.GeneratedTooth.flank_limit`; cached per gear)."""
        return _flank_limit(gear)

    def a_c_max_unfolded(self, gear: Gear) -> float:
        """Largest ``rack.a_c`` [1/mm] for which the generated flank does not fold (0.0 if it folds
        with the straight tool); GeometryError for a tool without rack settings."""
        if not self.rack_settings:
            raise GeometryError(f"{gear.name}.a_c_max_unfolded: profile crowning a_c is a rack-cutter/hob setting; "
                                f"this gear is cut by a {type(self).__name__.lower()} (tool kind '{self.kind}').")
        return _a_c_max_unfolded(gear)


@dataclass(frozen=True)
class RackCutter(Tool):
    """The rack-cutter of the gear's basic rack (``Gear.rack``, normal section; Litvin Fig. 10.3.4).

    It has no data of its own: profile, tip fillet and profile crowning ``a_c`` are the
    :class:`~gearopt.gears.BasicRack`'s. The default tool of a :class:`~gearopt.gears.Gear`.
    """

    kind: ClassVar[str] = "rack"

    def check(self, gear: Gear) -> None:
        """Nothing to check against the gear."""

    def generate(self, gear: Gear) -> GeneratedTooth:
        """The rack-generated tooth (:func:`gearopt.geometry.generation.generate_by_rack`)."""
        return rack_generated(gear, gear.rack, "rack")


@dataclass(frozen=True)
class Hob(Tool):
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
    scene_keys: ClassVar[tuple[SceneKey, ...]] = (
        SceneKey("z", "N_h", "int", 1, "hob threads (starts)", {"lo": 1, "hi": 8}),
        SceneKey("d_p0", "d_p0", "length", 60.0, "hob reference diameter; lead angle asin(z m_n / d_p0) from 0.1 to "
                 "30 deg", {"lo": 0, "lo_open": True}),
        SceneKey("hand", "hand", "str", "right", "hand of the hob thread", choices=("right", "left")),
    )

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

    def swivel_angle(self, gear: Gear) -> float:
        """Setting angle between hob and gear axes [rad]: ``beta -+ lambda`` (same/opposite hands),
        measured from the plane normal to the gear axis."""
        lam = self.lead_angle(gear.m_n)
        same = gear.is_spur or gear.hand == self.hand
        sign = -1.0 if same else 1.0
        return (gear.beta if not gear.is_spur else 0.0) + sign * lam

    def check(self, gear: Gear) -> None:
        """The lead angle must be in range for the gear's module (raises ``<gear>.tool.d_p0``)."""
        self.lead_angle(gear.m_n, f"{gear.name}.tool.d_p0")

    def generate(self, gear: Gear) -> GeneratedTooth:
        """Tooth surfaces generated by this hob: its normal section acts as the rack-cutter, and the
        hob turns ``phi_h = (N_g / N_h) psi`` while the gear turns by psi (Litvin eq. 10.3.4); the
        surface Functions carry the extra output ``phi_h`` [rad]."""
        tooth = rack_generated(gear, gear.rack, "hob", N_h=self.N_h)
        return GeneratedTooth(gear=gear, method="hob", functions=tooth.functions, r_root=tooth.r_root,
                              extras={"N_h": self.N_h, "lead_angle": self.lead_angle(gear.m_n),
                                      "swivel_angle": self.swivel_angle(gear)})


@dataclass(frozen=True)
class Shaper(Tool):
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
    rack_settings: ClassVar[bool] = False
    scene_keys: ClassVar[tuple[SceneKey, ...]] = (
        SceneKey("z", "N_s", "int", 25, "shaper teeth (enough to reach the gear's tip: the smallest count is stated "
                 "otherwise); a helical shaper has the gear's helix angle, opposite hand", {"lo": 8, "hi": 400}),
        SceneKey("x", "x_s", "float", 0.0, "shaper profile shift coefficient", {"lo": -1, "hi": 2}),
    )

    def __post_init__(self):
        if not _is_int(self.N_s) or self.N_s < SHAPER_N_MIN:
            raise out_of_range("shaper.N_s", self.N_s, f"an integer >= {SHAPER_N_MIN} (teeth)")
        if not _is_finite(self.x_s):
            raise out_of_range("shaper.x_s", self.x_s, "a finite profile shift")

    # --- cutting geometry (transverse section; Litvin section 10.3, ISO 21771) -------------------
    def cutting(self, gear: Gear, x: float | None = None, N_s: int | None = None, x_s: float | None = None) -> dict:
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

    def root_radius(self, gear: Gear) -> float:
        """Root radius [mm] of ``gear`` cut by this shaper: ``a_cut - r_as`` (the rack-cutter's when the
        shaper has no cutting mesh with the gear)."""
        r = self.cutting(gear)["r_root"]
        return r if math.isfinite(r) else super().root_radius(gear)

    def generate(self, gear: Gear) -> GeneratedTooth:
        """Tooth surfaces cut by this shaper (:func:`gearopt.geometry.generation.generate_by_shaper`)."""
        return shaper_generated(gear, self)

    def form_radius(self, gear: Gear) -> float:
        """Radius [mm] of the gear point cut by the shaper's flank/rounding junction (the form radius
        when the gear is not undercut): on the line of action, ``line - L_form`` from the gear's
        base-circle tangency point."""
        c = self.cutting(gear)
        r_b = gear.r_p * math.cos(c["alpha_t"])
        return math.hypot(r_b, c["line"] - c["L_form"])

    def x_min_undercut(self, gear: Gear) -> float:
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

    def _fits(self, gear: Gear, N_s: int) -> bool:
        c = self.cutting(gear, N_s=N_s)
        return c["r_c"] > c["r_bs"] and c["L_tip"] > 0

    def check(self, gear: Gear) -> None:
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


#: The built-in tool kinds, as written in a scene's ``tool = {kind = ...}`` (:data:`TOOLS` also has any
#: kind defined later).
TOOL_KINDS = tuple(TOOLS)


def check_tool(gear: Gear) -> None:
    """Validate ``gear.tool`` (type, then against the gear); GeometryError naming ``<gear>.tool``."""
    tool = gear.tool
    if not isinstance(tool, Tool):
        valid = "a RackCutter, Hob or Shaper (gearopt.geometry.tools)"
        raise GeometryError(f"{gear.name}.tool = {type(tool).__name__} {tool!r:.80}: expected {valid}.",
                            param=f"{gear.name}.tool", value=tool, valid=valid)
    tool.check(gear)


def require_rack_settings(gear: Gear, what: str) -> None:
    """Refuse a shaper-cut ``gear`` where ``what`` sets its rack-cutter settings (profile crowning
    ``a_c``, plunging ``a_pl``): crowning synthesis needs a rack-cutter or hob.

    Raises
    ------
    GeometryError
        Naming ``<gear>.tool``.
    """
    if not gear.tool.rack_settings:
        kinds = " or ".join(f"'{k}'" for k, cls in TOOLS.items() if cls.rack_settings)
        raise out_of_range(f"{gear.name}.tool", f"kind '{gear.tool.kind}'", f"kind {kinds}: {what} sets the "
                           "rack-cutter's profile crowning a_c and plunging a_pl, which a shaper does not have")
