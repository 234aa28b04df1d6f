"""Micro-geometry in shop terms: ISO 21771 flank modifications as CasADi graphs (docs/microgeometry.md).

A gear drawing states modifications in micrometres: profile crowning ``C_alpha``, lead crowning
``C_beta``, tip relief ``C_alpha_a`` from ``d_Ca``, profile and helix slopes ``f_H_alpha``,
``f_H_beta``... :class:`Microgeometry` holds them (mm inside; scenes give um) and
:func:`flank_modifications` turns them, for a member of a pair, into one
:class:`~gearopt.geometry.modification.FlankModification` whose theta are the amounts: every amount
is a symbolic parameter of the TCA (``"pinion.iso.C_beta"``), so an NLP can choose it and AD gives
the sensitivities.

Conventions (one place; docs/microgeometry.md restates them with their sources):

* Deviations are ISO transverse deviations ``delta_t``: in the transverse plane along the tangent to
  the base circle, the measuring direction of the profile and helix charts of ISO 1328-1; positive
  means material added (the measuring-chart convention). The flank's normal deviation is
  ``delta_n = cos(beta_b) delta_t`` (the normal of an involute helicoid makes ``beta_b`` with the
  transverse plane).
* Profile coordinate: the roll length ``L_y = sqrt(r_y^2 - r_b^2)`` [mm] of the point's transverse
  radius ``r_y`` (ISO 21771); the profile evaluation range ``[L_s, L_e]`` is the active profile in the
  pair (from the start of active profile ``d_Nf``, where the mate's tip or form circle ends contact,
  to the tip ``d_a``), or given as diameters. ``L_alpha = L_e - L_s``, ``t_a = (L_y - L_m) / L_alpha``
  with ``L_m`` the middle of the range.
* Face coordinate: the axial position ``z`` [mm], face I at ``z = -b/2``, face II at ``z = +b/2``;
  ``t_b = z / b``.
* The deviation at a point is the deviation at the point's own roll length and section (what a
  measuring machine reports there): the roll length of the modified point is used, not that of the
  unmodified foot point (a fixed point, below), and the section is the modified point's axial
  position (the hook's ``z``).

Terms (``delta_t`` [mm]; each amount a theta entry):

==============  =====================================================  ==============================
amount          deviation                                              meaning
==============  =====================================================  ==============================
``C_alpha``     ``-C_alpha (2 t_a)^2``                                 profile crowning: the sagitta
                                                                       of the profile over L_alpha
``f_H_alpha``   ``f_H_alpha t_a``                                      profile slope: rise of the
                                                                       mean profile over L_alpha,
                                                                       + = more material to the tip
``C_beta``      ``-C_beta ((z - z_Cb) / (b/2))^2``                     lead crowning, vertex at z_Cb
                                                                       (the sagitta over b is C_beta)
``f_H_beta``    ``f_H_beta t_b``                                       helix slope over b, + = more
                                                                       material towards face II
``S_alpha``     ``S_alpha t_a t_b``                                    bias (flank twist): f_H_alpha
                                                                       at face II minus at face I
``C_alpha_a``   ``-C_alpha_a R(L_y - L_Ca) / R(L_a - L_Ca)``           tip relief from d_Ca to the tip
``C_alpha_f``   ``-C_alpha_f R(L_Cf - L_y) / R(L_Cf - L_s)``           root relief from d_Cf down to
                                                                       the start of the active profile
``C_beta_I``    ``-C_beta_I R(-b/2 + b_I - z) / R(b_I)``               end relief at face I, length b_I
``C_beta_II``   ``-C_beta_II R(z - b/2 + b_II) / R(b_II)``             end relief at face II
==============  =====================================================  ==============================

Relief shapes ``R``: ``"linear"``: ``R = P(s)``, ``"parabolic"`` (arc): ``R = P(s)^2``, with ``P``
the smooth ramp of :func:`smooth_ramp`: zero below ``s = -l/2``, exactly ``s`` above ``s = +l/2``
and a C2 cubic-quartic blend between (``l``: ``transition`` [mm], default a tenth of the relief
length). So a relief's slope rises from 0 to its full value over the transition length centred on
the nominal start, the flank stays C2 (curvature continuous) and the TCA and the NLPs see a smooth
graph (no kink inside an AD graph); beyond the transition the relief is exactly linear or
parabolic, and its amount at the tip (face end) is exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..errors import ArgumentError, ConvergenceError, out_of_range, shorten
from .inspection import check_grid_on_flank, flank_deviation, profile_chart
from .modification import SIDES, FlankModification

if TYPE_CHECKING:
    from ..gears import Gear, GearPair
    from ..types import ArrayLike, Expr
    from .envelope import GeneratedTooth
    from .inspection import FlankGrid

#: amounts (theta entries, mm) that are always part of a member's ISO modification, in this order
GLOBAL_AMOUNTS = ("C_alpha", "f_H_alpha", "C_beta", "f_H_beta", "S_alpha")
#: relief amounts: present when their start (diameter, roll length or length) is given
RELIEF_AMOUNTS = ("C_alpha_a", "C_alpha_f", "C_beta_I", "C_beta_II")
SHAPES = ("linear", "parabolic")
AMOUNT_MAX_PER_M = 0.1  #: an amount beyond 0.1 m_n (tens of microns per mm of module) is not micro-geometry
FIXED_POINT_STEPS = 3  #: fixed-point steps for the roll length of the modified point (contraction |d delta/dL|)
EPS_L = 1e-2  #: [mm] smoothing of the roll length at the base circle (sqrt of a smooth positive part)


def _doc(unit, doc, scene="um"):
    return {"unit": unit, "doc": doc, "scene": scene}


@dataclass(frozen=True)
class Microgeometry:
    """ISO 21771 flank modifications of one member (every length in mm; scenes give amounts in um).

    Amounts are deviations in the transverse plane along the base tangent, positive = material
    added (module docstring); crowning and relief amounts are given positive (material removed).

    Parameters
    ----------
    C_alpha : float
        Profile crowning [mm]: sagitta of the profile over the profile evaluation range.
    f_H_alpha : float
        Profile slope deviation [mm] over the evaluation range, positive: more material towards the tip.
    C_beta : float
        Lead crowning [mm]: ``-C_beta ((z - z_Cb) / (b/2))^2``; the sagitta over the face width.
    z_Cb : float
        Axial position of the lead crowning's vertex [mm] (0: symmetric; an offset centre adds a
        helix slope ``8 C_beta z_Cb / b`` to the lead chart).
    f_H_beta : float
        Helix slope deviation [mm] over the face width, positive: more material towards face II (+z).
    S_alpha : float
        Bias (flank twist) [mm]: profile slope at face II minus profile slope at face I.
    C_alpha_a, d_Ca, L_Ca, tip_shape : float, float or None, float or None, str
        Tip relief [mm] at the tip circle, starting at the diameter ``d_Ca`` [mm] or the roll length
        ``L_Ca`` [mm] (one of them), ``"linear"`` or ``"parabolic"``.
    C_alpha_f, d_Cf, L_Cf, root_shape
        Root relief [mm] at the start of the profile evaluation range, starting (going down) at
        ``d_Cf`` or ``L_Cf``.
    C_beta_I, b_I, C_beta_II, b_II, end_shape
        End reliefs [mm] at face I (z = -b/2) and face II (z = +b/2), over the lengths ``b_I``,
        ``b_II`` [mm] from each face.
    transition : float or None
        Length [mm] (roll length for profile reliefs, axial for end reliefs) of the smooth start of
        every relief, centred on its nominal start; None: a tenth of each relief's length.
    d_alpha : tuple of 2 floats or None
        Profile evaluation range as diameters [mm] (start, end); None: the active profile in the
        pair (from d_Nf to d_a), or the form circle to d_a for a gear alone.
    sides : tuple of str
        Flanks that carry the modifications: ``("right", "left")`` (default), ``("right",)``,
        ``("left",)``.
    measured : tuple of FlankGrid
        Measured (or designed) deviation grids added on top: one per flank at most
        (:class:`gearopt.geometry.inspection.FlankGrid`: ISO transverse deviations over roll
        length or diameter x face position), interpolated by a cubic B-spline.
    """

    C_alpha: float = field(default=0.0, metadata=_doc("mm", "profile crowning (sagitta over the profile evaluation range)"))
    f_H_alpha: float = field(default=0.0, metadata=_doc("mm", "profile slope over the evaluation range (+: more material to the tip)"))
    C_beta: float = field(default=0.0, metadata=_doc("mm", "lead crowning (sagitta over the face width)"))
    z_Cb: float = field(default=0.0, metadata=_doc("mm", "axial position of the lead crowning's vertex", "mm"))
    f_H_beta: float = field(default=0.0, metadata=_doc("mm", "helix slope over the face width (+: more material to face II, +z)"))
    S_alpha: float = field(default=0.0, metadata=_doc("mm", "bias (flank twist): profile slope at face II minus at face I"))
    C_alpha_a: float = field(default=0.0, metadata=_doc("mm", "tip relief at the tip circle"))
    d_Ca: float | None = field(default=None, metadata=_doc("mm", "tip relief start diameter", "mm"))
    L_Ca: float | None = field(default=None, metadata=_doc("mm", "tip relief start roll length", "mm"))
    tip_shape: str = field(default="linear", metadata=_doc("-", "tip relief shape: linear or parabolic", None))
    C_alpha_f: float = field(default=0.0, metadata=_doc("mm", "root relief at the start of the evaluation range"))
    d_Cf: float | None = field(default=None, metadata=_doc("mm", "root relief start diameter", "mm"))
    L_Cf: float | None = field(default=None, metadata=_doc("mm", "root relief start roll length", "mm"))
    root_shape: str = field(default="linear", metadata=_doc("-", "root relief shape: linear or parabolic", None))
    C_beta_I: float = field(default=0.0, metadata=_doc("mm", "end relief at face I (z = -b/2)"))
    b_I: float | None = field(default=None, metadata=_doc("mm", "end relief length at face I", "mm"))
    C_beta_II: float = field(default=0.0, metadata=_doc("mm", "end relief at face II (z = +b/2)"))
    b_II: float | None = field(default=None, metadata=_doc("mm", "end relief length at face II", "mm"))
    end_shape: str = field(default="linear", metadata=_doc("-", "end relief shape: linear or parabolic", None))
    transition: float | None = field(default=None, metadata=_doc("mm", "smooth start of every relief (default: a tenth of its length)", "mm"))
    d_alpha: tuple | None = field(default=None, metadata=_doc("mm", "profile evaluation range (start, end diameters)", "mm"))
    sides: tuple = field(default=SIDES, metadata=_doc("-", "flanks modified", None))
    measured: tuple = field(default=(), metadata=_doc("-", "measured deviation grids (FlankGrid), one per flank", None))

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.metadata.get("unit") == "mm" and f.name != "d_alpha":
                if v is None:
                    continue
                if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v):
                    raise ArgumentError(f"modifications.{f.name} = {shorten(repr(v))}: expected a finite number [mm].",
                                        param=f"modifications.{f.name}", value=v, valid="a finite number [mm]",
                                        detail=": expected a finite number [mm].")
                object.__setattr__(self, f.name, float(v))
        for nm in ("tip_shape", "root_shape", "end_shape"):
            if getattr(self, nm) not in SHAPES:
                raise out_of_range(f"modifications.{nm}", getattr(self, nm), "'linear' or 'parabolic'", cls=ArgumentError)
        for nm in ("C_alpha", "C_beta", "C_alpha_a", "C_alpha_f", "C_beta_I", "C_beta_II"):
            if getattr(self, nm) < 0:
                raise out_of_range(f"modifications.{nm}", getattr(self, nm), f"{nm} >= 0 mm (an amount of material "
                                   "removed; a negative crowning or relief adds material: use the slopes or a "
                                   "measured grid for that)", cls=ArgumentError)
        for a, b in (("d_Ca", "L_Ca"), ("d_Cf", "L_Cf")):
            if getattr(self, a) is not None and getattr(self, b) is not None:
                raise ArgumentError(f"modifications.{a} and {b} are both given: give the relief start either as a "
                                    "diameter or as a roll length.", param=f"modifications.{b}", value=getattr(self, b),
                                    valid=f"only one of {a}, {b}")
        for amount, starts in (("C_alpha_a", ("d_Ca", "L_Ca")), ("C_alpha_f", ("d_Cf", "L_Cf")),
                               ("C_beta_I", ("b_I",)), ("C_beta_II", ("b_II",))):
            if getattr(self, amount) > 0 and all(getattr(self, s) is None for s in starts):
                raise ArgumentError(f"modifications.{amount} = {getattr(self, amount):g} mm needs its start: give "
                                    f"{' or '.join(starts)}.", param=f"modifications.{starts[0]}", value=None,
                                    valid="a start diameter / roll length / length [mm]")
        for nm in ("b_I", "b_II", "transition"):
            v = getattr(self, nm)
            if v is not None and not v > 0:
                raise out_of_range(f"modifications.{nm}", v, f"{nm} > 0 mm", cls=ArgumentError)
        if self.d_alpha is not None:
            try:
                d = tuple(float(x) for x in self.d_alpha)
            except (TypeError, ValueError):
                d = ()
            if len(d) != 2 or not all(math.isfinite(x) for x in d) or not 0 < d[0] < d[1]:
                raise out_of_range("modifications.d_alpha", self.d_alpha, "(d_start, d_end) [mm] with 0 < d_start < "
                                   "d_end", cls=ArgumentError)
            object.__setattr__(self, "d_alpha", d)
        if isinstance(self.sides, str) or not isinstance(self.sides, (tuple, list)) or not self.sides \
                or any(s not in SIDES for s in self.sides) or len(set(self.sides)) != len(self.sides):
            raise out_of_range("modifications.sides", self.sides, "('right', 'left'), ('right',) or ('left',)",
                               cls=ArgumentError)
        object.__setattr__(self, "sides", tuple(self.sides))
        meas = tuple(self.measured)
        seen = set()
        for k, g in enumerate(meas):
            if not all(hasattr(g, a) for a in ("side", "profile", "s", "z", "deviation")):
                raise ArgumentError(f"modifications.measured[{k}] = {type(g).__name__}: expected a FlankGrid "
                                    "(gearopt.geometry.inspection).", param=f"modifications.measured[{k}]",
                                    value=type(g).__name__, valid="a FlankGrid")
            if g.side in seen:
                raise ArgumentError(f"modifications.measured: two grids for the {g.side} flank; give one per flank.",
                                    param="modifications.measured", value=g.side, valid="one grid per flank")
            seen.add(g.side)
        object.__setattr__(self, "measured", meas)

    # -- what is there --------------------------------------------------------------------------
    @classmethod
    def amount_names(cls) -> tuple[str, ...]:
        """Every amount [mm] (the possible theta entries)."""
        return GLOBAL_AMOUNTS + RELIEF_AMOUNTS

    @classmethod
    def meta(cls, name: str) -> dict:
        """Unit (``"mm"``/``"-"``), meaning and scene unit of a field."""
        return dict(next(f for f in fields(cls) if f.name == name).metadata)

    @property
    def reliefs(self) -> tuple[str, ...]:
        """The relief amounts present (their start is given)."""
        out = []
        if self.d_Ca is not None or self.L_Ca is not None:
            out.append("C_alpha_a")
        if self.d_Cf is not None or self.L_Cf is not None:
            out.append("C_alpha_f")
        if self.b_I is not None:
            out.append("C_beta_I")
        if self.b_II is not None:
            out.append("C_beta_II")
        return tuple(out)

    @property
    def theta_names(self) -> tuple[str, ...]:
        """Names of the theta entries of the ISO modification (``GLOBAL_AMOUNTS`` then the reliefs
        present), each ``"iso.<name>"`` in the member's ``param_names``."""
        return GLOBAL_AMOUNTS + self.reliefs

    @property
    def is_zero(self) -> bool:
        """No modification at all (every amount 0, no relief start, no measured grid)."""
        return not self.reliefs and not self.measured and all(getattr(self, a) == 0 for a in GLOBAL_AMOUNTS)

    def amounts(self) -> dict:
        """The theta defaults by name [mm]."""
        return {a: getattr(self, a) for a in self.theta_names}

    def to_dict(self) -> dict:
        """JSON-able summary: amounts in um (``<amount>_um``), positions in mm (``<key>_mm``),
        shapes, sides and the measured grids' sources."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "measured":
                out["measured"] = [{"side": g.side, "source": getattr(g, "source", ""), "profile": g.profile,
                                    "points": [len(g.s), len(g.z)]} for g in v]
            elif f.name == "sides":
                out["sides"] = list(v)
            elif f.name == "d_alpha":
                out["d_alpha_mm"] = None if v is None else list(v)
            elif f.metadata.get("scene") == "um":
                out[f"{f.name}_um"] = v * 1000.0
            elif f.metadata.get("unit") == "mm":
                out[f"{f.name}_mm"] = v
            else:
                out[f.name] = v
        return out

    def check(self, gear: Gear) -> None:
        """The amounts and positions against a gear (raises ArgumentError naming the field)."""
        n = getattr(gear, "name", "gear")
        lim = AMOUNT_MAX_PER_M * gear.m_n
        for a in self.amount_names():
            v = getattr(self, a)
            if abs(v) > lim:
                raise out_of_range(f"{n}.modifications.{a}", f"{v * 1000:.6g} um", f"|{a}| <= 0.1 m_n = "
                                   f"{lim * 1000:.6g} um (micro-geometry is microns; check the unit: scenes give um)",
                                   cls=ArgumentError)
        r_b, r_a = gear.r_b, gear.r_a
        # the relief starts lie on the real flank: from the form circle (known without generating the
        # tooth for a straight tool without undercut; else the base circle here, the form circle in
        # check_relief_starts against the pair) to the tip
        r_lo = gear.r_lim if gear.rack.a_c == 0 and not gear.undercut and gear.r_lim > r_b else r_b
        lo_text = "d_Ff" if r_lo > r_b else "d_b"
        for nm, kind in (("d_Ca", "d"), ("L_Ca", "L"), ("d_Cf", "d"), ("L_Cf", "L")):
            v = getattr(self, nm)
            if v is None:
                continue
            if kind == "d" and not 2 * r_lo < v < 2 * r_a:
                raise out_of_range(f"{n}.modifications.{nm}", v, f"{lo_text} = {2 * r_lo:.6g} mm < {nm} < d_a = "
                                   f"{2 * r_a:.6g} mm (a diameter on the {n}'s flank, from its "
                                   f"{'form' if r_lo > r_b else 'base'} circle to its tip)", cls=ArgumentError)
            L_lo = math.sqrt(max(r_lo**2 - r_b**2, 0.0))
            if kind == "L" and not L_lo < v < math.sqrt(r_a**2 - r_b**2):
                raise out_of_range(f"{n}.modifications.{nm}", v, f"{L_lo:.6g} mm < {nm} < L_a = "
                                   f"{math.sqrt(r_a**2 - r_b**2):.6g} mm (a roll length on the {n}'s flank, from its "
                                   f"{'form' if r_lo > r_b else 'base'} circle to its tip)", cls=ArgumentError)
        for nm in ("b_I", "b_II"):
            v = getattr(self, nm)
            if v is not None and not v < gear.b:
                raise out_of_range(f"{n}.modifications.{nm}", v, f"0 < {nm} < b = {gear.b:.6g} mm", cls=ArgumentError)
        if abs(self.z_Cb) > gear.b / 2:
            raise out_of_range(f"{n}.modifications.z_Cb", self.z_Cb, f"|z_Cb| <= b/2 = {gear.b / 2:.6g} mm",
                               cls=ArgumentError)
        if self.measured:  # on the flank, plausible deviations (the file, row and column named)
            for grid in self.measured:
                check_grid_on_flank(grid, gear)
        if self.d_alpha is not None and not (2 * r_b < self.d_alpha[0] and self.d_alpha[1] <= 2 * r_a + 1e-9):
            raise out_of_range(f"{n}.modifications.d_alpha", list(self.d_alpha), f"d_b = {2 * r_b:.6g} mm < d_start < "
                               f"d_end <= d_a = {2 * r_a:.6g} mm", cls=ArgumentError)


# ---------------------------------------------------------------------------------------------
# Smooth building blocks (CasADi-generic)
# ---------------------------------------------------------------------------------------------
def smooth_ramp(s: Expr, l: float) -> Expr:
    """The smooth positive part ``P_l(s)`` [mm]: 0 for ``s <= -l/2``, ``s`` for ``s >= l/2`` and,
    with ``t = (s + l/2) / l``, ``l (t^3 - t^4 / 2)`` between: C2 (P' rises from 0 to 1 as the
    smoothstep ``3 t^2 - 2 t^3``), CasADi-generic in ``s`` (float, SX or MX); ``l`` > 0 a float."""
    t = (s + l / 2) / l
    mid = l * (t**3 - t**4 / 2)
    return ca.if_else(s <= -l / 2, 0 * s, ca.if_else(s >= l / 2, s, mid))


def _relief(s, length, l, shape):
    """Relief profile normalised to 1 at ``s = length``: ``P(s) / P(length)`` or its square."""
    P = smooth_ramp(s, l)
    P_end = float(smooth_ramp(length, l))
    return P / P_end if shape == "linear" else (P / P_end) ** 2


@dataclass(frozen=True)
class Frame:
    """What the terms need of a member (resolved from the gear and the pair) [mm, rad]."""

    r_b: float
    beta_b: float
    b: float
    L_s: float  #: roll length of the start of the profile evaluation range
    L_e: float  #: roll length of its end
    L_a: float  #: roll length at the tip
    sign_L: float  #: +1 if material added (outward normal) increases the roll length of the flank point

    @property
    def L_m(self) -> float:
        return (self.L_s + self.L_e) / 2

    @property
    def L_alpha(self) -> float:
        return self.L_e - self.L_s


def roll_length_of(r: Expr, r_b: float) -> Expr:
    """Roll length ``sqrt(r_x^2 + r_y^2 - r_b^2)`` [mm] of a point (3,) (CasADi-generic), smoothed below
    ``EPS_L`` (a smooth positive part) so the graph stays finite at and below the base circle."""
    q = r[0] ** 2 + r[1] ** 2 - r_b**2
    return ca.sqrt((q + ca.sqrt(q**2 + EPS_L**4)) / 2)


def transverse_deviation(mg: Microgeometry, fr: Frame, L: Expr, z: Expr, th: dict, side: str) -> Expr:
    """``delta_t(L, z)`` [mm] of the ISO terms (module docstring table), CasADi-generic; ``th`` the
    amounts by name (symbols or floats)."""
    t_a = (L - fr.L_m) / fr.L_alpha
    t_b = z / fr.b
    d = (-th["C_alpha"] * (2 * t_a) ** 2 + th["f_H_alpha"] * t_a
         - th["C_beta"] * ((z - mg.z_Cb) / (fr.b / 2)) ** 2 + th["f_H_beta"] * t_b + th["S_alpha"] * t_a * t_b)
    for name, (s, length) in _relief_coords(mg, fr, L, z).items():
        if name in th:
            shape = {"C_alpha_a": mg.tip_shape, "C_alpha_f": mg.root_shape}.get(name, mg.end_shape)
            l = mg.transition if mg.transition is not None else 0.1 * length
            d = d - th[name] * _relief(s, length, l, shape)
    return d


def _relief_coords(mg: Microgeometry, fr: Frame, L, z) -> dict:
    """Per relief present: (coordinate s measured into the relief from its start, relief length)."""
    out = {}
    if mg.d_Ca is not None or mg.L_Ca is not None:
        L_Ca = mg.L_Ca if mg.L_Ca is not None else math.sqrt((mg.d_Ca / 2) ** 2 - fr.r_b**2)
        out["C_alpha_a"] = (L - L_Ca, fr.L_a - L_Ca)
    if mg.d_Cf is not None or mg.L_Cf is not None:
        L_Cf = mg.L_Cf if mg.L_Cf is not None else math.sqrt((mg.d_Cf / 2) ** 2 - fr.r_b**2)
        out["C_alpha_f"] = (L_Cf - L, L_Cf - fr.L_s)
    if mg.b_I is not None:
        out["C_beta_I"] = (-fr.b / 2 + mg.b_I - z, mg.b_I)
    if mg.b_II is not None:
        out["C_beta_II"] = (z - fr.b / 2 + mg.b_II, mg.b_II)
    return out


# ---------------------------------------------------------------------------------------------
# Resolution against a member of a pair
# ---------------------------------------------------------------------------------------------
def active_profile(pair: GearPair, member: str) -> tuple[float, float]:
    """Radii [mm] of the start of the active profile (``d_Nf / 2``: where the mate's tip, or this
    flank's own form circle, ends the path of contact) and of its end (the tip, ``d_a / 2``) of a
    member of a pair (docs/theory.md section 3.3, as :attr:`GearPair.g_alpha`)."""
    if member not in ("pinion", "gear"):
        raise out_of_range("member", member, "'pinion' or 'gear'", cls=ArgumentError)
    g, mate = (pair.pinion, pair.gear) if member == "pinion" else (pair.gear, pair.pinion)
    ga = pair.a_w * math.sin(pair.alpha_wt)
    s = max(ga - math.sqrt(mate.r_a**2 - mate.r_b**2), math.sqrt(max(g.r_form**2 - g.r_b**2, 0.0)))
    return math.sqrt(g.r_b**2 + s**2), g.r_a


def frame(tooth: GeneratedTooth, side: str, pair: GearPair | None = None, member: str | None = None,
          mg: Microgeometry | None = None) -> Frame:
    """The :class:`Frame` of a flank: base circle, face, profile evaluation range (``mg.d_alpha``, else
    the active profile in ``pair``, else the form circle to the tip) and the direction in which
    material added moves the roll length (from the flank's point and normal at the pitch point)."""
    g = tooth.gear
    if mg is not None and mg.d_alpha is not None:
        r_s, r_e = mg.d_alpha[0] / 2, mg.d_alpha[1] / 2
    elif pair is not None:
        r_s, r_e = active_profile(pair, member or ("pinion" if pair.pinion is g else "gear"))
    else:
        r_s, r_e = g.r_form, g.r_a
    L = lambda r: math.sqrt(max(r**2 - g.r_b**2, 0.0))  # noqa: E731
    u_p = float(tooth.extras.get("q_pitch", 0.0))
    r, n, _ = tooth.unmodified.point(side, "flank", u_p, 0.0, tooth.p0[:len(tooth.unmodified.param_names)])
    sign_L = 1.0 if r[0] * n[0] + r[1] * n[1] > 0 else -1.0
    return Frame(r_b=g.r_b, beta_b=g.beta_b, b=g.b, L_s=L(r_s), L_e=L(r_e), L_a=L(g.r_a), sign_L=sign_L)


def check_relief_starts(mg: Microgeometry, gear: Gear, r_s: float, r_e: float, where: str) -> None:
    """Refuse a profile relief whose start lies outside the profile evaluation range ``r_s`` ...
    ``r_e`` [mm] (radii: the active profile of the pair, or ``d_alpha``): a tip relief (``d_Ca`` /
    ``L_Ca``) starting below it would relieve the whole evaluated profile, a root relief
    (``d_Cf`` / ``L_Cf``) starting above it likewise. ArgumentError naming ``where.<key>`` with the
    valid range in the key's own terms (diameter or roll length)."""
    L = lambda r: math.sqrt(max(r * r - gear.r_b**2, 0.0))  # noqa: E731
    for d_key, L_key, what in (("d_Ca", "L_Ca", "tip"), ("d_Cf", "L_Cf", "root")):
        d_v, L_v = getattr(mg, d_key), getattr(mg, L_key)
        if d_v is None and L_v is None:
            continue
        Lv = L_v if L_v is not None else L(d_v / 2)
        lo, hi = L(r_s), L(r_e)
        inside = lo - 1e-9 <= Lv < hi if what == "tip" else lo < Lv <= hi + 1e-9
        if inside:
            continue
        ops = ("<=", "<") if what == "tip" else ("<", "<=")
        if d_v is not None:
            valid = (f"{2 * r_s:.6g} mm {ops[0]} {d_key} {ops[1]} {2 * r_e:.6g} mm (the {gear.name}'s profile evaluation "
                     "range: its active profile d_Nf ... d_a, or d_alpha)")
            raise out_of_range(f"{where}.{d_key}", d_v, valid, cls=ArgumentError)
        valid = (f"{lo:.6g} mm {ops[0]} {L_key} {ops[1]} {hi:.6g} mm (roll lengths of the {gear.name}'s profile "
                 "evaluation range: its active profile d_Nf ... d_a, or d_alpha)")
        raise out_of_range(f"{where}.{L_key}", L_v, valid, cls=ArgumentError)
    if "C_alpha_a" in mg.reliefs and "C_alpha_f" in mg.reliefs:  # the root relief ends where the tip relief starts
        L_a = mg.L_Ca if mg.L_Ca is not None else L(mg.d_Ca / 2)
        L_f = mg.L_Cf if mg.L_Cf is not None else L(mg.d_Cf / 2)
        if not L_f < L_a:
            key = "d_Cf" if mg.d_Cf is not None else "L_Cf"
            tip = f"d_Ca = {mg.d_Ca:.6g} mm" if mg.d_Ca is not None else f"L_Ca = {mg.L_Ca:.6g} mm"
            raise out_of_range(f"{where}.{key}", getattr(mg, key), f"a root relief start below the tip relief's ({tip}): "
                               "the two reliefs must not overlap", cls=ArgumentError)


def _check_reliefs(mg: Microgeometry, fr: Frame, where: str) -> None:
    for name, (s_end, length) in _relief_coords(mg, fr, fr.L_a, 0.0).items():
        if name in ("C_beta_I", "C_beta_II"):
            continue
        if not length > 0:
            start = {"C_alpha_a": ("d_Ca", "L_Ca"), "C_alpha_f": ("d_Cf", "L_Cf")}[name]
            key = start[0] if getattr(mg, start[0]) is not None else start[1]
            valid = (f"a start below the tip (L < L_a = {fr.L_a:.6g} mm)" if name == "C_alpha_a"
                     else f"a start above the start of the evaluation range (L > L_s = {fr.L_s:.6g} mm)")
            raise out_of_range(f"{where}.{key}", getattr(mg, key), valid, cls=ArgumentError)
        l = mg.transition if mg.transition is not None else 0.1 * length
        if l > length:
            raise out_of_range(f"{where}.transition", mg.transition, f"transition <= the relief length "
                               f"{length:.6g} mm of {name}", cls=ArgumentError)
    for name in ("b_I", "b_II"):
        length = getattr(mg, name)
        if length is not None and mg.transition is not None and mg.transition > length:
            raise out_of_range(f"{where}.transition", mg.transition, f"transition <= {name} = {length:.6g} mm",
                               cls=ArgumentError)


def _with_actual_roll_length(f, fr: Frame, L_foot, z):
    """``delta_t`` at the roll length of the modified point: ``d = f(L_foot + s cos^2(beta_b) d, z)``
    (the point moves ``delta_n cos(beta_b) = delta_t cos^2(beta_b)`` along the base tangent, i.e.
    along its roll length), by FIXED_POINT_STEPS fixed-point steps (contraction |df/dL| cos^2 beta_b,
    a relief's slope ~1e-2: each step gains about two digits)."""
    k = fr.sign_L * math.cos(fr.beta_b) ** 2
    d = f(L_foot, z)
    for _ in range(FIXED_POINT_STEPS):
        d = f(L_foot + k * d, z)
    return d


def flank_modifications(mg: Microgeometry, tooth: GeneratedTooth, pair: GearPair | None = None,
                        member: str | None = None, force_iso: bool = False) -> tuple:
    """The :class:`FlankModification` s of a member's :class:`Microgeometry`: ``"iso"`` (the ISO terms,
    theta = :attr:`Microgeometry.theta_names` [mm]) on ``mg.sides`` unless every term is absent, and
    one ``"measured_<side>"`` per measured grid (no theta). ``tooth``: the member's generated tooth
    (unmodified); ``pair``/``member`` set the profile evaluation range (active profile);
    ``force_iso``: the ``"iso"`` modification even when every amount is 0 (its theta entries are
    then inputs of the graphs, e.g. deviations sampled by a Monte Carlo study).

    The normal deviation composed into the flank is ``cos(beta_b) delta_t`` with ``delta_t`` taken
    at the modified point's own roll length (:func:`_with_actual_roll_length`)."""
    gear = tooth.gear
    where = f"{gear.name}.modifications"
    mg.check(gear)
    mods = []
    names = mg.theta_names
    if force_iso or any(getattr(mg, a) != 0 for a in GLOBAL_AMOUNTS) or mg.reliefs:
        frames = {side: frame(tooth, side, pair, member, mg) for side in mg.sides}
        for fr in frames.values():
            check_relief_starts(mg, gear, math.hypot(fr.r_b, fr.L_s), math.hypot(fr.r_b, fr.L_e), where)
            _check_reliefs(mg, fr, where)

        def delta_for(side):
            fr = frames[side]

            def delta(u, z, r, th):
                thd = {nm: th[i] for i, nm in enumerate(names)}
                f = lambda L, zz: transverse_deviation(mg, fr, L, zz, thd, side)  # noqa: E731
                return math.cos(fr.beta_b) * _with_actual_roll_length(f, fr, roll_length_of(r, fr.r_b), z)
            return delta

        theta = tuple((nm, getattr(mg, nm), "mm") for nm in names)
        sides = mg.sides
        if len(sides) == 2 and frames["right"] == frames["left"]:
            mods.append(FlankModification("iso", theta, delta_for("right"), sides))
        else:
            for side in sides:
                mods.append(FlankModification("iso" if len(sides) == 1 else f"iso_{side}", theta, delta_for(side),
                                              (side,)))
    for grid in mg.measured:
        fr = frame(tooth, grid.side, pair, member, mg)
        mods.append(measured_modification(grid, fr, name=f"measured_{grid.side}"))
    return tuple(mods)


#: extra grid nodes on each side of a measured grid, on the edge's osculating parabola (value, slope
#: and curvature of the spline at the edge): at 1 and 2 edge spacings, then at 1/4 ... 4 of the grid's
#: length beyond its edge (held constant further out)
GHOST_STEPS = (1.0, 2.0)
GHOST_SPANS = (0.25, 0.5, 1.0, 2.0, 4.0)
SPLINE_DEGREE = 5  #: B-spline degree of a measured grid (quintic: the synthesis NLPs differentiate the flank up to 5 times)
RECEDE = 1e-3  #: [1/mm] beyond the extended grid the flank recedes by RECEDE * excess^2 (no contact out there)


#: In-process memo of :func:`_grid_spline` (key: the spline's name and nodes' bytes), newest last.
_SPLINES: dict[str, ca.Function] = {}
_SPLINES_KEPT = 16


def _grid_spline(name: str, Lx: np.ndarray, zx: np.ndarray, E2: np.ndarray) -> ca.Function:
    """``ca.interpolant(name, "bspline", [Lx, zx], E2, degree SPLINE_DEGREE)``, built once per grid:
    CasADi fits the coefficients by an iterative least-squares solve (about 3 s of CPU for a 135 x 35
    grid), so the Function is kept in this process and, serialised, on disk (``interpolant/`` in
    :func:`gearopt.compiled.cache_root`; the same Function bit for bit, its derivatives included).
    Grid coordinates in mm, values in mm."""
    import hashlib

    from ..compiled import cache_root, write_cache_file

    h = hashlib.sha256()
    for part in (ca.__version__, name, str(SPLINE_DEGREE)):
        h.update(part.encode() + b"\0")
    for a in (Lx, zx, E2):
        a = np.ascontiguousarray(a, dtype=float)
        h.update(str(a.shape).encode() + a.tobytes())
    key = h.hexdigest()
    f = _SPLINES.pop(key, None)
    if f is None:
        path = cache_root() / "interpolant" / f"{key[:40]}.casadi"
        try:
            f = ca.Function.deserialize(path.read_text())
        except (OSError, RuntimeError):
            f = None
        if f is None or f.name() != name:
            f = ca.interpolant(name, "bspline", [Lx.tolist(), zx.tolist()], E2.ravel(order="F").tolist(),
                               {"degree": [SPLINE_DEGREE, SPLINE_DEGREE]})
            write_cache_file(path, f.serialize().encode())
    _SPLINES[key] = f
    while len(_SPLINES) > _SPLINES_KEPT:
        _SPLINES.pop(next(iter(_SPLINES)))
    return f


def measured_modification(grid: FlankGrid, fr: Frame, name: str = "measured") -> FlankModification:
    """A measured grid (``FlankGrid``: ISO transverse deviations [mm] over roll length ``L_y`` or
    diameter ``d_y`` x axial position) as a FlankModification of its flank, composed like the ISO
    terms (``cos(beta_b) delta_t`` at the modified point's roll length):

    * the deviation ``d_ij`` measured at roll length ``L_i`` (the actual point's) is turned, outside
      any graph, into the deviation at the foot point's roll length ``L_i``: ``e_ij = d(L_i + k e_ij,
      z_j)`` (``k = s cos^2(beta_b)``, fixed point on the not-a-knot cubic spline of column j), so the
      flank needs one spline evaluation per point;
    * the grid gets extra nodes on each side on the osculating parabola of its edge (GHOST_STEPS,
      GHOST_SPANS: up to four grid lengths beyond each edge), so a relief or a crowning keeps growing
      past the last measured point as the designed one does (a flank held flat beyond its tip or
      face would offer the TCA a false tangency out there); beyond those the spline is held at the
      last ghost node and the flank recedes by ``RECEDE * excess^2`` (a rootfinder wandering far
      off the tooth finds no false contact there), and the
      tensor-product cubic B-spline of ``ca.interpolant(..., "bspline")`` through all nodes is
      evaluated with its coordinates held inside the extended grid."""
    from scipy.interpolate import make_interp_spline

    s = np.asarray(grid.s, dtype=float)
    L = s if grid.profile == "L_y" else np.sqrt(np.maximum((s / 2) ** 2 - fr.r_b**2, 0.0))
    if not np.all(np.diff(L) > 0):
        raise ArgumentError(f"measured grid {getattr(grid, 'source', '') or grid.side}: its profile positions are not "
                            "strictly increasing above the base circle (diameters below d_b?).",
                            param="measured.s", value=list(s[:4]), valid=f"diameters above d_b = {2 * fr.r_b:.6g} mm")
    z = np.asarray(grid.z, dtype=float)
    V = np.asarray(grid.deviation, dtype=float)
    k = fr.sign_L * math.cos(fr.beta_b) ** 2
    E = V.copy()
    for j in range(z.size):  # deviation at the foot point's roll length (module docstring)
        d = make_interp_spline(L, V[:, j], k=3)
        e = V[:, j].copy()
        for _ in range(8):
            e = d(L + k * e)
        E[:, j] = e

    def ghosts(x, Y, axis):
        """x extended on each side (GHOST_STEPS, GHOST_SPANS), Y along ``axis`` on the edge parabolas."""
        h0, h1, span = x[1] - x[0], x[-1] - x[-2], x[-1] - x[0]

        def offsets(h):
            # the steps and the spans beyond two steps, sorted; offsets within round-off of each other
            # are one node (a span equal to two steps in exact arithmetic, e.g. 9 nodes and a quarter
            # span, differs by an ulp and would give two nodes at one place after x[0] - off)
            off = np.sort(np.r_[np.array(GHOST_STEPS) * h, [t * span for t in GHOST_SPANS if t * span > 2 * h]])
            return off[np.r_[True, np.diff(off) > 1e-9 * span]]

        off0, off1 = offsets(h0), offsets(h1)
        lo = x[0] - off0[::-1]
        hi = x[-1] + off1
        sp = make_interp_spline(x, Y, k=3, axis=axis)
        at = lambda f, xe: np.take(f(np.array([xe])), 0, axis=axis)  # noqa: E731
        taylor = [[at(sp.derivative(m) if m else sp, xe) for m in range(3)] for xe in (x[0], x[-1])]
        (y0, d0, c0), (y1, d1, c1) = taylor
        lo_v = np.stack([y0 + d0 * (t - x[0]) + c0 * (t - x[0]) ** 2 / 2 for t in lo], axis=axis)
        hi_v = np.stack([y1 + d1 * (t - x[-1]) + c1 * (t - x[-1]) ** 2 / 2 for t in hi], axis=axis)
        return np.r_[lo, x, hi], np.concatenate([lo_v, Y, hi_v], axis=axis)

    Lx, E1 = ghosts(L, E, 0)
    zx, E2 = ghosts(z, E1, 1)
    f = _grid_spline(f"{name}_spline", Lx, zx, E2)

    def delta(u, zz, r, th):
        L = roll_length_of(r, fr.r_b)
        L_c = ca.fmin(ca.fmax(L, float(Lx[0])), float(Lx[-1]))
        z_c = ca.fmin(ca.fmax(zz, float(zx[0])), float(zx[-1]))
        far = RECEDE * ((L - L_c) ** 2 + (zz - z_c) ** 2)
        return math.cos(fr.beta_b) * (f(ca.vertcat(L_c, z_c)) - far)

    return FlankModification(name, (), delta, (grid.side,))


def modified_tooth(pair: GearPair, member: str, tooth: GeneratedTooth | None = None,
                   force_iso: bool = False) -> GeneratedTooth:
    """The member's generated tooth with its gear's :class:`Microgeometry` composed in (the tooth
    itself when the gear has none). ``tooth``: the generated tooth (default ``generate(gear)``, the tool's);
    ``force_iso``: compose the ISO terms (zero when the gear has none) so that their amounts
    ``iso.<name>`` are parameters of the tooth (see :func:`flank_modifications`)."""

    gear = getattr(pair, member)
    tooth = tooth if tooth is not None else gear.tool.generate(gear)
    mg = getattr(gear, "modifications", None)
    if mg is None and force_iso:
        mg = Microgeometry()
    if mg is None or (mg.is_zero and not force_iso):
        return tooth
    for mod in flank_modifications(mg, tooth, pair, member, force_iso):
        tooth = tooth.with_modification(mod)
    return tooth


# ---------------------------------------------------------------------------------------------
# Litvin's settings <-> ISO amounts
# ---------------------------------------------------------------------------------------------
def _profile_trace_of_settings(pair, member, a_c, u_0, side="right", n=41):
    """Roll lengths (n,) over the active profile (midpoints of n equal intervals) and the ISO
    transverse deviation [mm] (:func:`gearopt.geometry.inspection.flank_deviation`) of the flank cut by
    the member's tool with profile crowning (a_c, u_0) and no plunging, at mid face."""

    g = getattr(pair, member)
    tooth = g.tool.generate(g).unmodified
    r_s, r_e = active_profile(pair, member)
    L_s, L_e = math.sqrt(r_s**2 - g.r_b**2), math.sqrt(r_e**2 - g.r_b**2)
    L = L_s + (np.arange(n) + 0.5) / n * (L_e - L_s)  # interval midpoints: symmetric, inside the flank
    p = np.array(tooth.p0[:4], dtype=float)
    p[1], p[2], p[3] = a_c, u_0, 0.0
    return L, flank_deviation(tooth, side, np.sqrt(L**2 + g.r_b**2), 0.0, p)


def profile_fit(L: ArrayLike, dev: ArrayLike) -> tuple[float, float]:
    """(C_alpha, f_H_alpha) [mm] of a profile trace over its whole range
    (:func:`gearopt.geometry.inspection.profile_chart`)."""

    ch = profile_chart(L, dev)
    return ch["C_alpha"], ch["f_H_alpha"]


def iso_from_litvin(pair: GearPair, member: str = "pinion") -> dict:
    """A member's Litvin crowning settings in ISO shop terms [mm] over the active profile and face:
    ``C_beta = a_pl (b/2)^2 sin(alpha_t)`` (exact: the tool fed ``a_pl z^2`` deeper offsets the flank
    by ``a_pl z^2 sin(alpha_n)`` along the normal, ``a_pl z^2 sin(alpha_t)`` transverse) with
    ``f_H_beta = 0``; ``C_alpha``, ``f_H_alpha`` of the flank cut by the parabolic tool
    (``rack.a_c``, ``rack.u_0``), evaluated from the surface at mid face (:func:`profile_fit` of the
    deviation from the straight tool's flank at the midpoints of 41 equal intervals of the active
    profile's roll length)."""
    g = getattr(pair, member)
    out = {"C_beta": g.a_pl * (g.b / 2) ** 2 * math.sin(g.alpha_t), "f_H_beta": 0.0}
    if g.rack.a_c == 0:
        out.update(C_alpha=0.0, f_H_alpha=0.0)
    else:
        C, fH = profile_fit(*_profile_trace_of_settings(pair, member, g.rack.a_c, g.rack.u_0))
        out.update(C_alpha=C, f_H_alpha=fH)
    return {k: out[k] for k in ("C_alpha", "f_H_alpha", "C_beta", "f_H_beta")}


def litvin_from_iso(pair: GearPair, member: str = "pinion", C_alpha: float = 0.0, C_beta: float = 0.0,
                    f_H_alpha: float = 0.0, tol: float = 1e-9) -> dict:
    """Litvin's settings ``a_c`` [1/mm], ``u_0`` [mm] (parabolic tool) and ``a_pl`` [1/mm] (plunging)
    that give the ISO amounts ``C_alpha``, ``f_H_alpha``, ``C_beta`` [mm] (the inverse of
    :func:`iso_from_litvin`): ``a_pl`` in closed form; ``a_c``, ``u_0`` by Newton's method on the
    evaluated profile from the first-order transfer of the tool parabola (the tool point ``u`` cuts
    the roll length ``L`` with ``|dL/du| = cos(alpha_n) / sin(alpha_t)``, and a normal deviation is
    ``cos(beta_b)`` times the transverse one).

    Raises
    ------
    ArgumentError
        For a negative crowning.
    ConvergenceError
        If the profile amounts are not met to ``tol`` [mm] in 12 Newton steps.
    """

    g = getattr(pair, member)
    for nm, v in (("C_alpha", C_alpha), ("C_beta", C_beta)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise out_of_range(nm, v, f"{nm} >= 0 mm", cls=ArgumentError)
    a_pl = C_beta / ((g.b / 2) ** 2 * math.sin(g.alpha_t))
    if C_alpha == 0 and f_H_alpha == 0:
        return {"a_c": 0.0, "u_0": 0.0, "a_pl": a_pl}
    if C_alpha <= 0:
        raise out_of_range("C_alpha", C_alpha, "C_alpha > 0 mm with a profile slope (a parabolic tool slopes the "
                           "profile only by moving the parabola's vertex)", cls=ArgumentError)

    r_s, r_e = active_profile(pair, member)
    L_s, L_e = math.sqrt(r_s**2 - g.r_b**2), math.sqrt(r_e**2 - g.r_b**2)
    L_al, L_m = L_e - L_s, (L_s + L_e) / 2
    k = C_alpha / (L_al / 2) ** 2  # delta_t = -k (L - L0)^2
    q = math.sin(g.alpha_t) / math.cos(g.rack.alpha_n)
    a_c = k * math.cos(g.beta_b) / q**2
    L0 = L_m + f_H_alpha / (2 * k * L_al)
    tooth = g.tool.generate(g).unmodified
    p_ref = np.array(tooth.p0[:4], dtype=float)
    p_ref[1:] = 0.0
    u_0 = tooth.u_at_radius(math.hypot(g.r_b, L0), 0.0, "right", p_ref)
    x = np.array([a_c, u_0])
    target = np.array([C_alpha, f_H_alpha])
    F = lambda v: np.array(profile_fit(*_profile_trace_of_settings(pair, member, v[0], v[1]))) - target  # noqa: E731
    for _ in range(12):
        r = F(x)
        if np.abs(r).max() < tol:
            return {"a_c": float(x[0]), "u_0": float(x[1]), "a_pl": a_pl}
        h = np.array([1e-6 * max(abs(x[0]), 1e-6), 1e-4])
        J = np.column_stack([(F(x + np.eye(2)[i] * h[i]) - r) / h[i] for i in range(2)])
        x = x - np.linalg.solve(J, r)
    raise ConvergenceError(f"litvin_from_iso: no parabolic tool (a_c, u_0) gives C_alpha = {C_alpha * 1e3:.4g} um, "
                           f"f_H_alpha = {f_H_alpha * 1e3:.4g} um on {g.name} (residual {np.abs(F(x)).max():.2g} mm).")
