"""Gear data: the basic rack (the tool that defines a gear; :mod:`gearopt.geometry.rack`, re-exported
here), a gear, a gear pair.

Frozen dataclasses with ISO 21771 symbols, validated on construction. A gear holds its cutting tool
(:mod:`gearopt.geometry.tools`) and asks it for what depends on the tool: the closed-form root and
form radii and undercut limit, and what needs the generated surfaces (form radius of a folded or
undercut flank, flank limit); nothing here builds surfaces. Lengths in mm, angles in rad
(use :func:`gearopt.units.deg` at the edges), rack coefficients in units of the normal module m_n.
Derived quantities are properties; nothing is mutated after construction.

Glossary (ISO 21771 / ISO 53)
-----------------------------
z        number of teeth
m_n      normal module [mm];  m_t = m_n / cos(beta) transverse module
alpha_n  normal pressure angle of the basic rack [rad]; alpha_t transverse
beta     helix angle on the reference cylinder [rad]; hand 'right' or 'left'
x        profile shift coefficient (rack displaced by x m_n away from the gear centre)
k        tip alteration coefficient (d_a = d + 2 m_n (h_aP + x + k))
h_aP     addendum of the basic rack [m_n] (= cutting-tool dedendum)
h_fP     dedendum of the basic rack [m_n] (= cutting-tool addendum, cutting depth)
rho_fP   root fillet radius of the basic rack [m_n] (= tool tip radius)
c_P      bottom clearance h_fP - h_aP [m_n]
b        face width [mm]
r_p      reference (pitch) radius m_t z / 2;  r_b = r_p cos(alpha_t) base radius
r_a, r_f tip and root radii; r_F form radius (where the fillet meets the involute)
a        centre distance [mm]; alpha_wt working transverse pressure angle
A_sne, A_sni  upper / lower tooth thickness allowance [mm], normal section, on the reference
         circle (DIN 3967, ISO 21771); negative = thinner than the nominal tooth of shift x
x_E      generating profile shift coefficient x + A_sn / (2 m_n tan alpha_n) (ISO 21771): the tool
         position that cuts the thinned tooth
j_wt, j_bn  circumferential backlash on the working pitch circle, normal backlash [mm]
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np

from .errors import ArgumentError, GeometryError, out_of_range, shorten
from .geometry.involute import inv, inv_inverse, tooth_thickness
from .geometry.microgeometry import Microgeometry
from .geometry.rack import BasicRack, finite_number
from .geometry.envelope import FlankLimit
from .geometry.tools import RackCutter, Tool, check_tool
from .units import DEG, INCH

_HANDS = ("right", "left")
#: Most teeth gearopt accepts on one member.
Z_MAX = 100_000
#: Widest face, in reference diameters of the member.
B_MAX_PER_D = 10.0
#: Narrowest face, in normal modules (a face below a tenth of the module is a disc edge, not a tooth).
B_MIN_PER_M = 0.1
#: Largest tooth thickness allowance |A_sne|, |A_sni|, as a share of the reference tooth thickness
#: pi m_n / 2 (DIN 3967 allowances are tens to hundreds of microns: a few percent of it).
ALLOWANCE_SHARE = 0.5
#: Range of the normal module [mm] gearopt accepts (ISO 54 modules are 0.05 to 100 mm).
M_N_RANGE = (0.01, 1000.0)
#: Largest share of the reference tooth thickness crowning may remove from each flank.
CROWNING_SHARE = 0.25


@dataclass(frozen=True)
class Gear:
    """An external spur or helical involute gear, defined by the rack-cutter that generates it.

    Parameters
    ----------
    z : int
        Number of teeth, ``z >= 3``.
    m_n : float
        Normal module [mm], > 0. (Use :meth:`from_diametral_pitch` for P in 1/in.)
    x : float
        Profile shift coefficient [-].
    b : float
        Face width [mm], > 0.
    beta : float
        Helix angle [rad], ``0 <= beta < 45 deg`` (0 = spur).
    hand : {"right", "left"}
        Hand of helix (ignored for spur gears).
    rack : BasicRack
        The generating rack-cutter (normal section).
    k : float
        Tip alteration coefficient [-]; tip radius ``r_a = r_p + m_n (h_aP + x + k)``.
    a_pl : float
        Longitudinal crowning by plunging of the tool [1/mm]: in the section at axial position
        ``l`` the tool is fed ``a_pl l^2`` deeper (Litvin section 4). 0 = no crowning.
    allow_undercut : bool
        Accept a gear whose rack-cutter undercuts the involute (otherwise an error).
    name : str
        Label used in reports and plots.
    A_sne : float
        Upper tooth thickness allowance [mm] (DIN 3967 / ISO 21771): normal tooth thickness on the
        reference circle minus the nominal one of shift ``x``; negative = thinner (backlash). The
        generated tooth (flanks, root, TCA, FE) is the one of the upper allowance (maximum
        material), cut with the tool at the generating shift ``x_E`` (:attr:`x_E`).
    A_sni : float or None
        Lower tooth thickness allowance [mm], ``A_sni <= A_sne``; ``None``: equal to ``A_sne``.
        Only the largest backlash (:attr:`GearPair.backlash_max`) uses it.
    tool : Tool (RackCutter, Hob, Shaper, ...)
        The tool that cuts the teeth (:mod:`gearopt.geometry.tools`); default the rack-cutter of
        ``rack``. Every surface of the gear (TCA, edge contact, synthesis, FE) and :attr:`r_f`,
        :attr:`r_form`, :attr:`undercut` follow it (:func:`gearopt.geometry.generation.generate`).
    modifications : Microgeometry or None
        Flank modifications in ISO 21771 shop terms (:class:`gearopt.geometry.microgeometry.Microgeometry`:
        crowning, slopes, reliefs, measured grids; mm), composed into the flanks the TCA, edge
        contact, synthesis and FE models use (:func:`gearopt.geometry.microgeometry.modified_tooth`);
        the generation (tool, ``a_pl``, ``rack.a_c``) is not changed by them. None: unmodified.

    Raises
    ------
    GeometryError
        Naming the parameter, its value and valid range. Besides the ranges above:
        ``0.01 <= m_n <= 1000`` mm, ``z <= 100000``, ``b`` at most ten reference diameters, a root
        circle above the axis and a tip that is not pointed, and crowning that removes at most
        ``pi m_n / 8`` from each flank (``a_pl (b/2)^2 sin(alpha_n)`` at the face ends,
        ``a_c (u - u_0)^2`` over the tool's straight flank).
    """

    z: int
    m_n: float
    x: float = 0.0
    b: float = 20.0
    beta: float = 0.0
    hand: str = "right"
    rack: BasicRack = field(default_factory=BasicRack)
    k: float = 0.0
    a_pl: float = 0.0
    allow_undercut: bool = False
    name: str = "gear"
    A_sne: float = 0.0
    A_sni: float | None = None
    tool: Tool = field(default_factory=RackCutter)
    modifications: Microgeometry | None = None

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise ArgumentError(f"name = {shorten(repr(self.name))}: expected a str (e.g. 'pinion' or 'gear').",
                                param="name", value=self.name, valid="a str",
                                detail=": expected a str (e.g. 'pinion' or 'gear').")
        n = self.name
        for f in ("allow_undercut",):
            if not isinstance(getattr(self, f), (bool, np.bool_)):
                raise ArgumentError(f"{n}.{f} = {shorten(repr(getattr(self, f)))}: expected True or False.",
                                    param=f"{n}.{f}", value=getattr(self, f), valid="True or False",
                                    detail=": expected True or False.")
        finite_number(f"{n}.A_sne", self.A_sne)
        if self.A_sni is None:
            object.__setattr__(self, "A_sni", float(self.A_sne))
        elif finite_number(f"{n}.A_sni", self.A_sni) > self.A_sne:
            raise out_of_range(f"{n}.A_sni", self.A_sni, f"A_sni <= A_sne = {self.A_sne:.6g} mm (lower thickness "
                               "allowance below the upper one)")
        if isinstance(self.z, (numbers.Integral, np.integer)) and not isinstance(self.z, (bool, np.bool_)):
            object.__setattr__(self, "z", int(self.z))
        if isinstance(self.z, bool) or not isinstance(self.z, int):
            raise GeometryError(f"{n}.z = {self.z!r} must be an integer number of teeth (z >= 3).", param=f"{n}.z",
                                value=self.z, valid="an integer number of teeth (z >= 3)",
                                detail="must be an integer number of teeth (z >= 3).")
        if self.z < 3:
            raise out_of_range(f"{n}.z", self.z, "z >= 3 teeth")
        if self.z > Z_MAX:
            raise out_of_range(f"{n}.z", self.z, f"3 <= z <= {Z_MAX} teeth (beyond, a tooth is too small against "
                               "the gear radius for double precision; the largest gears have about 1000 teeth)")
        for f in ("m_n", "x", "b", "beta", "k", "a_pl"):
            finite_number(f"{n}.{f}", getattr(self, f))
        if self.m_n <= 0:
            raise out_of_range(f"{n}.m_n", self.m_n, "m_n > 0 mm")
        if not M_N_RANGE[0] <= self.m_n <= M_N_RANGE[1]:
            raise out_of_range(f"{n}.m_n", self.m_n, f"{M_N_RANGE[0]:g} <= m_n <= {M_N_RANGE[1]:g} mm (the solvers' "
                               "absolute tolerances, 1e-10 mm, and the contact's elastic approach, microns, assume "
                               "gears of ordinary size; ISO 54 modules span 0.05 to 100 mm)")
        if self.b <= 0:
            raise out_of_range(f"{n}.b", self.b, "b > 0 mm")
        if self.b < B_MIN_PER_M * self.m_n:
            raise out_of_range(f"{n}.b", self.b, f"b >= {B_MIN_PER_M:g} m_n = {B_MIN_PER_M * self.m_n:.6g} mm for "
                               f"m_n = {self.m_n:g} mm (a face narrower than a tenth of the module is not a tooth; "
                               "check the units of b)")
        a_max = ALLOWANCE_SHARE * math.pi * self.m_n / 2
        for f in ("A_sne", "A_sni"):
            if abs(getattr(self, f)) > a_max:
                raise out_of_range(f"{n}.{f}", getattr(self, f), f"|{f}| <= {a_max:.4g} mm for m_n = {self.m_n:g} "
                                   f"mm: a thickness allowance may change the reference tooth thickness pi m_n / 2 "
                                   f"by at most {ALLOWANCE_SHARE:.0%} (DIN 3967 allowances are tens to hundreds of "
                                   "microns)")
        d = self.m_n * self.z / math.cos(self.beta) if abs(self.beta) < 1.5 else self.m_n * self.z
        if self.b > B_MAX_PER_D * d:
            raise out_of_range(f"{n}.b", self.b, f"0 < b <= {B_MAX_PER_D:g} d = {B_MAX_PER_D * d:.6g} mm (d = m_n z / "
                               f"cos beta = {d:.6g} mm; a face wider than ten reference diameters is a shaft, not a "
                               "gear)")
        if not 0 <= self.beta < 45 * DEG:
            raise out_of_range(f"{n}.beta", f"{self.beta / DEG:.6g} deg", "0 <= beta < 45 deg")
        if self.hand not in _HANDS:
            raise out_of_range(f"{n}.hand", self.hand, "'right' or 'left'")
        if self.a_pl < 0:
            raise out_of_range(f"{n}.a_pl", self.a_pl, "a_pl >= 0 [1/mm] (0 = no longitudinal crowning)")
        if not isinstance(self.rack, BasicRack):
            raise GeometryError(f"{n}.rack must be a BasicRack, got {type(self.rack).__name__}.", param=f"{n}.rack",
                                value=self.rack, valid="a BasicRack")
        if not isinstance(self.tool, Tool):
            check_tool(self)  # names the type expected
        x_root = self.rack.h_fP - self.r_p / self.m_n  # r_f = 0
        if self.x <= x_root:
            raise out_of_range(f"{n}.x", self.x, f"x > {x_root:.4g} for z = {self.z} (root circle r_f = r_p + m_n (x - "
                               "h_fP) above the axis)")
        if not math.isfinite(self.k * self.m_n):
            raise out_of_range(f"{n}.k", self.k, "a finite tip radius r_a = r_p + m_n (h_aP + x + k)")
        if self.k > 0 and abs(self.x) < self.z and self.r_a >= self.r_b and not self.s_at(self.r_a) > 0:
            # a lengthened tip (k > 0) that is pointed: the tip alteration is what is wrong, not the shift
            raise self._k_error(None, self._k_max_pointed(), "(beyond it the tip is pointed)",
                                "Shorten the tip (lower k or the tip diameter d_a).")
        if not (math.isfinite(self.r_a) and math.isfinite(self.r_f) and self.x < self.z) and self.x > 0:
            # x >= z: the tip radius exceeds twice the reference radius; long before that the tip is pointed
            raise out_of_range(f"{n}.x", self.x, f"x < {self.x_max_pointed:.4f} for z = {self.z}, k = {self.k} "
                               "(beyond it the tip is pointed)", "Lower x or shorten the tip (k < 0).")
        if self.r_a <= self.r_f:
            raise self._k_error(-(self.rack.h_aP + self.rack.h_fP), None, "(tip above root)")
        check_tool(self)  # the tool against this gear (hob lead angle, shaper reach)
        if self.modifications is not None:
            if not isinstance(self.modifications, Microgeometry):
                raise ArgumentError(f"{n}.modifications = {type(self.modifications).__name__}: expected a "
                                    "gearopt.geometry.microgeometry.Microgeometry (or None).",
                                    param=f"{n}.modifications", value=type(self.modifications).__name__,
                                    valid="a Microgeometry or None")
            self.modifications.check(self)
        if not self.allow_undercut and self.x_E < self.x_min_undercut - 1e-12:
            raise out_of_range(
                f"{n}.x", self.x, f"x >= {self.x_min_undercut + self.x - self.x_E:.4f} for z = {self.z} (no undercut; z >= {self.z_min_undercut:.2f} "
                "teeth without shift)", "Raise x, or set allow_undercut = true to accept an undercut gear."
                + (f" Note rack.alpha_n = {self.rack.alpha_n / DEG:.6g} deg, far below the usual 14.5-30 deg (a value "
                   "meant in rad?)." if self.rack.alpha_n < 10 * DEG else ""))
        s_a = self.s_at(self.r_a)
        if not s_a > 0:  # NaN too
            raise out_of_range(f"{n}.x", self.x, f"x < {self.x_max_pointed:.4f} for z = {self.z}, k = {self.k} "
                               f"(the tip is pointed: s_a = {s_a:.4g} mm)", "Lower x or shorten the tip (k < 0).")

        self._check_crowning()

    def _k_error(self, lo: float | None, hi: float | None, why: str, hint: str = "") -> GeometryError:
        """An out-of-range error on the tip alteration ``k`` with the valid range ``lo < k < hi``;
        ``err.k_bounds = (lo, hi)`` lets a scene restate it for a tip diameter ``d_a``."""
        rng = f"k > {lo:.4g}" if hi is None else (f"k < {hi:.4f} for x = {self.x:g}, z = {self.z}" if lo is None
                                                  else f"{lo:.4g} < k < {hi:.4f}")
        err = out_of_range(f"{self.name}.k", self.k, f"{rng} {why}", hint)
        err.k_bounds = (lo, hi)
        return err

    def _k_max_pointed(self) -> float:
        """Tip alteration at which the tip becomes pointed (s_a = 0), by bisection."""
        def s_a(k):
            r_a = self.r_p + self.m_n * (self.rack.h_aP + self.x + k)
            return math.inf if r_a <= self.r_b else float(self.s_at(r_a))
        lo, hi = -(self.rack.h_aP + self.rack.h_fP), max(self.k, 1.0)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if s_a(mid) > 0 else (lo, mid)
        return lo

    def _check_crowning(self):
        """Crowning must be a modification, not a different tooth: at the face ends (plunging
        ``a_pl``) and at the ends of the tool's straight flank (parabolic profile ``a_c``) it may
        remove at most a quarter of the reference tooth thickness, ``pi m_n / 8``, from each flank
        (normal to it). Real crowning is tens of microns: that bound is some 30x above it."""
        n, rack = self.name, self.rack
        limit = CROWNING_SHARE * math.pi * self.m_n / 2  # per flank [mm]
        sin_a = math.sin(rack.alpha_n)
        # plunging by a_pl l^2 (radial feed) moves the flank by a_pl l^2 sin(alpha_n) along its normal
        half = self.b / 2
        depth = self.a_pl * half * half * sin_a
        if depth > limit:
            a_max = limit / (half * half * sin_a)
            raise out_of_range(f"{n}.a_pl", self.a_pl, f"a_pl <= {a_max:.4g} 1/mm for b = {self.b:g} mm, m_n = "
                               f"{self.m_n:g} mm: the plunge at the face ends may remove at most pi m_n / 8 = "
                               f"{limit:.4g} mm from each flank (here a_pl (b/2)^2 sin(alpha_n) = {depth:.4g} mm)",
                               "Real longitudinal crowning is of the order of 1e-4 to 1e-3 1/mm.")
        c = math.cos(rack.alpha_n)
        ends = (-rack.h_aP * self.m_n / c, rack.h_lim * self.m_n / c)  # the tool's straight flank [mm]
        depth_u = (rack.h_aP + rack.h_fP) * self.m_n / c  # whole depth along the tool flank
        if abs(rack.u_0) > depth_u:
            raise out_of_range(f"{n}.rack.u_0", rack.u_0, f"|u_0| <= {depth_u:.4g} mm for m_n = {self.m_n:g} mm: the "
                               "apex of the profile parabola lies on the tool flank, within one whole depth (h_aP + "
                               "h_fP) m_n / cos(alpha_n) of the datum line")
        reach = max(abs(u - rack.u_0) for u in ends)
        dev = rack.a_c * reach * reach
        if dev > limit:
            a_max = limit / reach ** 2
            raise out_of_range(f"{n}.rack.a_c", rack.a_c, f"a_c <= {a_max:.4g} 1/mm for m_n = {self.m_n:g} mm, u_0 = "
                               f"{rack.u_0:g} mm: the parabolic profile may depart from the straight one by at most pi "
                               f"m_n / 8 = {limit:.4g} mm over the tool's straight flank (here a_c (u - u_0)^2 = "
                               f"{dev:.4g} mm at |u - u_0| = {reach:.4g} mm)",
                               "Real profile crowning is of the order of 1e-3 1/mm for m_n = 3 mm.")

    @classmethod
    def from_diametral_pitch(cls, z: int, P_n: float, **kw: Any) -> "Gear":
        """Build from the normal diametral pitch ``P_n`` [1/in] (``m_n = 25.4 / P_n`` mm)."""
        P_n = finite_number("P_n", P_n)
        if P_n <= 0:
            raise out_of_range("P_n", P_n, "P_n > 0 [1/in]")
        return cls(z=z, m_n=INCH / P_n, **kw)

    def with_(self, **changes: Any) -> "Gear":
        """A copy with fields changed (validated again)."""
        return replace(self, **changes)

    # --- derived quantities -------------------------------------------------------------------
    @property
    def is_spur(self) -> bool:
        return self.beta == 0.0

    @property
    def helix_sign(self) -> int:
        """+1 for a right-hand helix, -1 for left hand (0 for spur)."""
        return 0 if self.is_spur else (1 if self.hand == "right" else -1)

    @property
    def x_E(self) -> float:
        """Generating profile shift coefficient [-] of the upper thickness allowance:
        ``x + A_sne / (2 m_n tan alpha_n)`` (ISO 21771; the tool sits ``x_E m_n`` off the reference
        circle). Equal to ``x`` without allowance."""
        return self.x + self.A_sne / (2 * self.m_n * math.tan(self.rack.alpha_n))

    @property
    def x_Ei(self) -> float:
        """Generating profile shift coefficient [-] of the lower thickness allowance ``A_sni``."""
        return self.x + self.A_sni / (2 * self.m_n * math.tan(self.rack.alpha_n))

    @property
    def m_t(self) -> float:
        """Transverse module [mm]."""
        return self.m_n / math.cos(self.beta)

    @property
    def alpha_t(self) -> float:
        """Transverse pressure angle [rad]: ``tan alpha_t = tan alpha_n / cos beta``."""
        return math.atan(math.tan(self.rack.alpha_n) / math.cos(self.beta))

    @property
    def beta_b(self) -> float:
        """Base helix angle [rad]."""
        return math.atan(math.tan(self.beta) * math.cos(self.alpha_t))

    @property
    def r_p(self) -> float:
        """Reference (pitch) radius ``m_t z / 2`` [mm] (Litvin eq. 10.3.1)."""
        return self.m_t * self.z / 2

    @property
    def r_b(self) -> float:
        """Base radius ``r_p cos alpha_t`` [mm] (Litvin eq. 10.3.2)."""
        return self.r_p * math.cos(self.alpha_t)

    @property
    def r_a(self) -> float:
        """Tip radius [mm]."""
        return self.r_p + self.m_n * (self.rack.h_aP + self.x + self.k)

    @property
    def r_f(self) -> float:
        """Root radius [mm] (cut by the tool tip line, tool at the generating shift ``x_E``; a shaper:
        ``a_cut - r_as``, its tip circle at the cutting centre distance): :meth:`Tool.root_radius
        <gearopt.geometry.tools.Tool.root_radius>`."""
        return self.tool.root_radius(self)

    @property
    def p_n(self) -> float:
        """Normal pitch ``pi m_n`` [mm]."""
        return math.pi * self.m_n

    @property
    def p_bt(self) -> float:
        """Transverse base pitch ``pi m_t cos alpha_t`` [mm]."""
        return math.pi * self.m_t * math.cos(self.alpha_t)

    @property
    def s_t(self) -> float:
        """Transverse arc tooth thickness on the reference circle [mm] of the generated tooth (upper
        allowance): ``m_t (pi/2 + 2 x_E tan alpha_n) = m_t (pi/2 + 2 x tan alpha_n) + A_sne / cos beta``."""
        return self.m_t * (math.pi / 2 + 2 * self.x_E * math.tan(self.rack.alpha_n))

    def s_at(self, r: float) -> float:
        """Transverse arc tooth thickness at radius ``r >= r_b`` [mm]."""
        if r < self.r_b:
            raise out_of_range(f"{self.name}: radius", r, f"r >= r_b = {self.r_b:.6g} mm")
        return float(tooth_thickness(r, self.r_p, self.s_t, self.alpha_t))

    @property
    def r_lim(self) -> float:
        """Radius [mm] generated by the end of the tool's straight flank (the involute's lower
        limit, the form radius ``r_F`` when there is no undercut). A shaper: the point cut by its
        flank/tip-rounding junction (:meth:`gearopt.geometry.tools.Shaper.form_radius`): :meth:`Tool.form_radius
        <gearopt.geometry.tools.Tool.form_radius>`."""
        return self.tool.form_radius(self)

    @property
    def undercut(self) -> bool:
        """True when the tool's straight flank reaches below the interference point
        (the generating line's tangency point with the base circle). A profile-crowned tool
        (``rack.a_c > 0``) can fold the flank without this: see :attr:`folded`."""
        return self.x_E < self.x_min_undercut

    @property
    def flank_limit(self) -> FlankLimit:
        """Where the real generated flank ends in the mid section (cut by :attr:`tool`, right flank):
        a :class:`gearopt.geometry.generation.FlankLimit` (the tool's flank/fillet junction, or
        below a fold of the flank its crossing with the reversed branch / the fillet), found by the
        tool on its generated surfaces (:meth:`gearopt.geometry.tools.Tool.flank_limit`)."""
        return self.tool.flank_limit(self)

    @property
    def r_form(self) -> float:
        """Form radius [mm]: the lowest radius of the real generated flank (mid section). Equals
        :attr:`r_lim` for a straight tool without undercut; for an undercut tooth the crossing of
        the involute with the trochoid fillet; for a folded profile-crowned flank the crossing
        below the fold."""
        if self.rack.a_c == 0 and not self.undercut:
            return self.r_lim  # the straight tool's flank end generates it; the flank cannot fold
        return self.flank_limit.radius

    @property
    def folded(self) -> bool:
        """True when the generated flank folds (its radius has a turning point, the surface a
        singular point) before the tool's flank/fillet junction: undercut by a straight tool, or
        by the curvature of a profile-crowned tool (large ``rack.a_c``)."""
        if self.rack.a_c == 0:
            return self.undercut
        return self.flank_limit.folded

    @property
    def a_c_max_unfolded(self) -> float:
        """Largest profile-crowning coefficient ``rack.a_c`` [1/mm] (all else as built) for which the
        flank does not fold; 0.0 if it folds even with the straight tool (undercut). Rack-cutter and
        hob only (a shaper has no profile crowning: GeometryError);
        :meth:`gearopt.geometry.tools.Tool.a_c_max_unfolded`."""
        return self.tool.a_c_max_unfolded(self)

    @property
    def x_min_undercut(self) -> float:
        """Smallest (generating) profile shift without undercut: ``h_lim - z sin^2(alpha_t) / (2 cos beta)``;
        compared with :attr:`x_E`. A shaper: where its flank/rounding junction cuts the gear at the
        interference point (:meth:`gearopt.geometry.tools.Shaper.x_min_undercut`)."""
        return self.tool.x_min_undercut(self)

    @property
    def z_min_undercut(self) -> float:
        """Smallest (real) number of teeth without undercut at x = 0: ``2 h_lim cos beta / sin^2 alpha_t``."""
        s2 = math.sin(self.alpha_t) ** 2
        return 2 * self.rack.h_lim * math.cos(self.beta) / s2 if s2 > 0 else math.inf

    @property
    def x_max_pointed(self) -> float:
        """Profile shift at which the tip becomes pointed (s_a = 0), by bisection (with the allowance
        ``A_sne`` on the thickness)."""
        dx = self.x_E - self.x

        def s_a(x):
            r_a = self.r_p + self.m_n * (self.rack.h_aP + x + self.k)
            if r_a <= self.r_b:  # no involute at the tip: not pointed
                return math.inf
            s_p = self.m_t * (math.pi / 2 + 2 * (x + dx) * math.tan(self.rack.alpha_n))
            return float(tooth_thickness(r_a, self.r_p, s_p, self.alpha_t))
        lo, hi = -5.0, 5.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if s_a(mid) > 0 else (lo, mid)
        return lo


@dataclass(frozen=True)
class GearPair:
    """An external gear pair: pinion (driving, member 1) and gear (driven, member 2).

    Parameters
    ----------
    pinion, gear : Gear
        Same m_n, rack alpha_n and beta; opposite hands for helical gears.
    a : float or None
        Centre distance [mm]. ``None`` (default): the zero-backlash distance ``a_0`` from
        ``x1 + x2`` through ``inv alpha_wt = inv alpha_t + 2 tan alpha_n (x1 + x2) / (z1 + z2)``.
        A larger ``a`` opens backlash; a smaller one jams the teeth (an error), except within
        :attr:`a_0_tolerance` of the zero-backlash distance of the generated teeth (the effect of
        shift coefficients rounded to 4 decimals). The operating geometry (alpha_wt, backlash,
        contact ratio, TCA) always uses the given ``a``; ``a - a_0`` is :attr:`a_minus_a_0`.
    """

    #: Rounding of published profile shift coefficients (4 decimals: x1 + x2 is known to +-1e-4).
    X_ROUNDING = 1e-4

    pinion: Gear
    gear: Gear
    a: float | None = None

    def __post_init__(self):
        p, g = self.pinion, self.gear
        if not isinstance(p, Gear) or not isinstance(g, Gear):
            raise GeometryError("GearPair needs two Gear objects (pinion, gear).")
        if abs(p.m_n - g.m_n) > 1e-12 * p.m_n:
            raise out_of_range("gear.m_n", g.m_n, f"equal to pinion.m_n = {p.m_n} mm (meshing gears share the module)")
        if abs(p.rack.alpha_n - g.rack.alpha_n) > 1e-12:
            raise out_of_range("gear.rack.alpha_n", f"{g.rack.alpha_n / DEG:.6g} deg",
                               f"equal to pinion.rack.alpha_n = {p.rack.alpha_n / DEG:.6g} deg")
        if abs(p.beta - g.beta) > 1e-12:
            raise out_of_range("gear.beta", f"{g.beta / DEG:.6g} deg", f"equal to pinion.beta = {p.beta / DEG:.6g} deg")
        if not p.is_spur and p.hand == g.hand:
            raise out_of_range("gear.hand", g.hand, f"opposite to pinion.hand = {p.hand!r} (external helical pair)")
        if self.a is not None:
            a = finite_number("pair.a", self.a)
            r_bsum = p.r_b + g.r_b
            if a <= r_bsum:
                raise out_of_range("pair.a", a, f"a > r_b1 + r_b2 = {r_bsum:.6g} mm (base circles)")
            a_jam, tol = self.a_0_generated, self.a_0_tolerance
            if a < a_jam - tol:
                gen = "" if p.A_sne == g.A_sne == 0 else (f" with the upper thickness allowances (generating shifts "
                                                           f"x_E1 + x_E2 = {p.x_E + g.x_E:.6g})")
                raise out_of_range("pair.a", a, f"a >= a_0 = {a_jam:.6g} mm, the zero-backlash distance for "
                                   f"x1 + x2 = {p.x + g.x:.6g}{gen}, less the tolerance {tol * 1000:.3g} um for "
                                   "shifts rounded to 4 decimals", "Increase a, reduce x1 + x2 or thin the teeth "
                                   "(negative A_sne).")
        c1, c2 = self.tip_clearance
        for who, c, r_a in (("pinion", c1, p.r_a), ("gear", c2, g.r_a)):
            if c < 0:
                raise out_of_range(f"{who}.k", (p if who == "pinion" else g).k,
                                   f"tip radius r_a = {r_a:.6g} mm that clears the mating root (clearance {c:.4g} mm < 0)",
                                   "Shorten the tip (negative k) or increase a.")
        aw = self.alpha_wt
        for who, me, mate in (("gear", p, g), ("pinion", g, p)):
            # The mating tip must meet the line of action before the tangency point T on this base circle.
            g_len = self.a_w * math.sin(aw) - math.sqrt(mate.r_a**2 - mate.r_b**2)
            if g_len < 0 and not me.allow_undercut:
                r_max = math.sqrt((self.a_w * math.sin(aw)) ** 2 + mate.r_b**2)
                raise out_of_range(f"{who}.k", mate.k, f"tip radius r_a <= {r_max:.6g} mm (the {who} tip, r_a = "
                                   f"{mate.r_a:.6g} mm, reaches past the interference point of the {me.name} "
                                   "base circle)", f"Shorten the {who} tip (negative k), shift the {me.name} (larger x) "
                                   "or use more pinion teeth.")
        if self.a is not None and self.eps_gamma < 1.0:
            a_max = self._a_max()
            raise out_of_range("pair.a", self.a, f"a_0 = {self.a_0:.6g} <= a <= {a_max:.6g} mm for m_n = {p.m_n:g} mm, "
                               f"z = {p.z}/{g.z}: beyond it the contact ratio eps_gamma = {self.eps_gamma:.4g} is below 1 "
                               "(the teeth do not reach each other long enough to mesh continuously)",
                               "Check the units of a and m_n.")
        if self.eps_alpha < 1.0 and self.eps_gamma < 1.0:
            self._blame_short_tips()
            raise GeometryError(f"contact ratio eps_gamma = {self.eps_gamma:.4f} < 1: the pair does not mesh continuously "
                                "(valid: eps_gamma >= 1). Increase the addenda ([rack] h_aP, [pinion]/[gear] k), reduce x or a, or use "
                                "helical gears.",
                                value=self.eps_gamma, valid="eps_gamma >= 1")

    def _blame_short_tips(self) -> None:
        """Contact ratio below 1 at a_0: if a member's tip is shortened (k < 0), name that k and the
        least k that gives eps_gamma = 1 (closed form: the tip's reach along the line of action)."""
        p, g = self.pinion, self.gear
        ga = self.a_w * math.sin(self.alpha_wt)
        members = [(who, me, mate) for who, me, mate in (("pinion", p, g), ("gear", g, p)) if me.k < 0]
        if not members:
            return
        who, me, mate = min(members, key=lambda t: t[1].k)
        need = p.p_bt * (1.0 - self.eps_beta) + ga - min(math.sqrt(mate.r_a**2 - mate.r_b**2), ga)
        if need <= 0 or need > ga:
            return
        r_a = math.hypot(me.r_b, need)
        k_min = (r_a - me.r_p) / me.m_n - me.rack.h_aP - me.x
        raise out_of_range(f"{who}.k", me.k, f"k >= {k_min:.4f} (tip radius r_a >= {r_a:.6g} mm, so that eps_gamma >= 1): with k = {me.k:g} the "
                           f"contact ratio eps_gamma = {self.eps_gamma:.4f} is below 1 (the pair does not mesh "
                           "continuously)")

    def _a_max(self) -> float:
        """Largest centre distance [mm] with eps_gamma >= 1 (bisection; a_0 if none)."""
        lo, hi = self.a_0, self.pinion.r_a + self.gear.r_a
        if self.eps_alpha_at(lo) + self.eps_beta < 1.0:
            return lo
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.eps_alpha_at(mid) + self.eps_beta >= 1.0 else (lo, mid)
        return lo

    def check_operating(self, dE: float, name: str = "dE") -> None:
        """Refuse a centre distance change ``dE`` [mm] (a misalignment) that jams or separates the teeth.

        The operating centre distance ``a_w + dE`` obeys the same rules as ``[pair] a``: not below
        the zero-backlash distance ``a_0`` (the teeth would interfere), tips clear of the mating
        roots, and a total contact ratio of at least 1.

        Raises
        ------
        GeometryError
            Naming ``name``, its value and the valid range of dE [mm].
        """
        dE = finite_number(name, dE)
        if dE == 0.0:
            return
        p, g = self.pinion, self.gear
        a = self.a_w + dE
        c_min = min(a - p.r_a - g.r_f, a - g.r_a - p.r_f)
        a_jam = self.a_0_generated - self.a_0_tolerance  # the rule of [pair] a
        lo = max(a_jam, self.a_w - min(self.tip_clearance)) - self.a_w
        if a < a_jam or c_min < 0:
            raise out_of_range(name, dE, f"dE >= {lo:.6g} mm: the operating centre distance a + dE = {a:.6g} mm must be "
                               f">= a_0 = {self.a_0_generated:.6g} mm, the zero-backlash distance of the generated teeth "
                               "(the same rule as for [pair] a), with the tips clear of the mating roots; closer, the "
                               "teeth interfere")
        if self.eps_alpha_at(a) + self.eps_beta < 1.0:
            hi = self._a_max() - self.a_w
            raise out_of_range(name, dE, f"{lo:.6g} <= dE <= {hi:.6g} mm: at a + dE = {a:.6g} mm the contact ratio "
                               "drops below 1 (the teeth separate)")

    def eps_alpha_at(self, a: float) -> float:
        """Transverse contact ratio at the centre distance ``a`` [mm] (docs/theory.md section 3.3)."""
        p, g = self.pinion, self.gear
        ga = a * math.sqrt(max(0.0, 1.0 - ((p.r_b + g.r_b) / a) ** 2))  # a sin(alpha_wt)
        path = min(math.sqrt(p.r_a**2 - p.r_b**2), ga) + min(math.sqrt(g.r_a**2 - g.r_b**2), ga) - ga
        return path / p.p_bt

    # --- derived quantities -------------------------------------------------------------------
    @property
    def ratio(self) -> float:
        """Gear ratio ``m12 = z2 / z1`` (= omega1 / omega2)."""
        return self.gear.z / self.pinion.z

    @property
    def alpha_t(self) -> float:
        return self.pinion.alpha_t

    @cached_property  # (frozen: computed once)
    def a_0(self) -> float:
        """Zero-backlash centre distance [mm] for x1 + x2 (docs/theory.md section 3.2)."""
        p, g = self.pinion, self.gear
        inv_w = inv(p.alpha_t) + 2 * math.tan(p.rack.alpha_n) * (p.x + g.x) / (p.z + g.z)
        alpha_w = float(inv_inverse(inv_w))
        return (p.r_p + g.r_p) * math.cos(p.alpha_t) / math.cos(alpha_w)

    @staticmethod
    def _a_of_shift(p: Gear, g: Gear, x_sum: float) -> float:
        inv_w = inv(p.alpha_t) + 2 * math.tan(p.rack.alpha_n) * x_sum / (p.z + g.z)
        alpha_w = float(inv_inverse(inv_w))
        return (p.r_p + g.r_p) * math.cos(p.alpha_t) / math.cos(alpha_w)

    @cached_property  # (frozen: computed once)
    def a_0_generated(self) -> float:
        """Zero-backlash centre distance [mm] of the generated teeth (upper thickness allowances,
        generating shifts ``x_E1 + x_E2``); equals :attr:`a_0` without allowances."""
        return self._a_of_shift(self.pinion, self.gear, self.pinion.x_E + self.gear.x_E)

    @cached_property  # (frozen: computed once)
    def a_0_tolerance(self) -> float:
        """How far [mm] ``a`` may lie below the zero-backlash distance: the change of ``a_0`` caused
        by :attr:`X_ROUNDING` in ``x1 + x2``, ``X_ROUNDING * da_0/d(x1 + x2)`` with
        ``da_0/d(x1 + x2) = 2 a_0 tan(alpha_n) / ((z1 + z2) tan(alpha_wt0))`` (differentiating
        ``inv alpha_wt``; ``d inv(a)/da = tan^2 a``). About 0.1 um per mm of module."""
        p, g = self.pinion, self.gear
        a0 = self.a_0_generated
        alpha_w0 = math.acos((p.r_b + g.r_b) / a0)
        return self.X_ROUNDING * 2 * a0 * math.tan(p.rack.alpha_n) / ((p.z + g.z) * math.tan(alpha_w0))

    @property
    def a_minus_a_0(self) -> float:
        """Operating centre distance minus the zero-backlash distance of the nominal shifts [mm]."""
        return self.a_w - self.a_0

    @property
    def a_w(self) -> float:
        """Operating centre distance [mm]: ``a`` if given, else ``a_0``."""
        return self.a if self.a is not None else self.a_0

    @property
    def alpha_wt(self) -> float:
        """Working transverse pressure angle [rad]: ``cos alpha_wt = (r_b1 + r_b2) / a``."""
        return math.acos((self.pinion.r_b + self.gear.r_b) / self.a_w)

    @property
    def r_w1(self) -> float:
        """Operating pitch radius of the pinion [mm]: ``a_w z1 / (z1 + z2)`` (the pitch point I
        divides the centre distance in the ratio of the tooth numbers)."""
        return self.a_w * self.pinion.z / (self.pinion.z + self.gear.z)

    @property
    def r_w2(self) -> float:
        """Operating pitch radius of the gear [mm]: ``a_w z2 / (z1 + z2)``."""
        return self.a_w * self.gear.z / (self.pinion.z + self.gear.z)

    def _backlash(self, s_t1: float, s_t2: float) -> float:
        p, g = self.pinion, self.gear
        r_w1 = self.r_w1
        r_w2 = self.a_w - r_w1
        s1 = float(tooth_thickness(r_w1, p.r_p, s_t1, p.alpha_t))
        s2 = float(tooth_thickness(r_w2, g.r_p, s_t2, g.alpha_t))
        return 2 * math.pi * r_w2 / g.z - s2 - s1

    @property
    def backlash(self) -> float:
        """Smallest circumferential backlash ``j_wt`` on the working pitch circles [mm], of the
        generated teeth (upper thickness allowances ``A_sne``): working pitch minus both tooth
        thicknesses there (0 at a = a_0 without allowances; slightly negative when ``a`` lies below
        ``a_0`` within :attr:`a_0_tolerance`)."""
        return self._backlash(self.pinion.s_t, self.gear.s_t)

    @property
    def backlash_max(self) -> float:
        """Largest circumferential backlash ``j_wt`` [mm], with the lower allowances ``A_sni``."""
        p, g = self.pinion, self.gear
        dx1, dx2 = p.x_Ei - p.x_E, g.x_Ei - g.x_E
        tan_a = math.tan(p.rack.alpha_n)
        return self._backlash(p.s_t + 2 * dx1 * tan_a * p.m_t, g.s_t + 2 * dx2 * tan_a * g.m_t)

    @property
    def backlash_normal(self) -> tuple[float, float]:
        """Normal backlash ``j_bn = j_wt cos(alpha_wt) cos(beta_b)`` [mm] (ISO 21771), smallest and
        largest: the gap between the coast flanks along their common normal."""
        f = math.cos(self.alpha_wt) * math.cos(self.pinion.beta_b)
        return self.backlash * f, self.backlash_max * f

    @property
    def g_alpha(self) -> float:
        """Length of the path of contact [mm] on the transverse line of action (docs/theory.md section 3.3):
        ``sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2) - a sin(alpha_wt)`` when the tips limit it;
        each end is cut where the mating flank ends (its form circle :attr:`Gear.r_form`: the
        involute/trochoid crossing of an undercut tooth, the crossing below the fold of a folded one)."""
        p, g = self.pinion, self.gear
        # Positions along the line of action from the pinion's tangency point T1 (length ga = T1 T2).
        # Contact runs from where the gear tip or the pinion's form circle (whichever is later)
        # to where the pinion tip or the gear's form circle ends it.
        ga = self.a_w * math.sin(self.alpha_wt)
        s_start = max(ga - math.sqrt(g.r_a**2 - g.r_b**2), math.sqrt(max(p.r_form**2 - p.r_b**2, 0.0)))
        s_end = min(math.sqrt(p.r_a**2 - p.r_b**2), ga - math.sqrt(max(g.r_form**2 - g.r_b**2, 0.0)))
        return s_end - s_start

    @cached_property  # (frozen: computed once)
    def tip_clearance(self) -> tuple[float, float]:
        """Radial clearance [mm] between each tip and the mating root: (pinion tip, gear tip)."""
        return self.a_w - self.pinion.r_a - self.gear.r_f, self.a_w - self.gear.r_a - self.pinion.r_f

    @property
    def eps_alpha(self) -> float:
        """Transverse contact ratio (docs/theory.md section 3.3): the path of contact :attr:`g_alpha`, between
        the tips and the form circles (:attr:`Gear.r_form`), over the transverse base pitch."""
        return self.g_alpha / self.pinion.p_bt

    @property
    def eps_beta(self) -> float:
        """Overlap ratio ``b sin(beta) / (pi m_n)`` with the narrower face width."""
        return min(self.pinion.b, self.gear.b) * math.sin(self.pinion.beta) / self.pinion.p_n

    @property
    def eps_gamma(self) -> float:
        """Total contact ratio ``eps_alpha + eps_beta``."""
        return self.eps_alpha + self.eps_beta

