"""Tooth surfaces generated as envelopes of tool families (Litvin ch. 10.3, docs/theory.md sections 4-5):
the machinery the tools of :mod:`gearopt.geometry.tools` generate with (``RackCutter.generate``,
``Hob.generate``, ``Shaper.generate``). The public entry points are in
:mod:`gearopt.geometry.generation` (:func:`~gearopt.geometry.generation.generate`, which re-exports
this module's names).

This module imports nothing of :mod:`gearopt.gears` or :mod:`gearopt.geometry.tools` (both build on it):
the gear and the tool are read by their attributes.

A tool surface ``r_c(q, z)`` (rack-cutter, the imaginary rack of a hob, or a shaper tooth) moves
relative to the gear with one generating parameter psi (the gear's rotation angle). The gear
tooth surface is the envelope of that family: ``r_g(q, z) = M_gc(psi) r_c(q, z)`` together with
the equation of meshing ``n . v^(cg) = 0``. For a rack the meshing equation is affine in psi and
for a shaper (planar) it is the intersection of the normal line with the tool's centrode, so psi
is eliminated in closed form and every surface is an explicit CasADi graph of its surface
coordinates and a parameter vector ``p`` (design parameters stay symbolic).

Frames (gear frame S_g, tool frame S_c; mm, rad)
-----------------------------------------------
* S_g: origin on the gear axis, z along the axis; at psi = 0 the tooth is centred on +y.
* Rack: the datum line of the normal section is at ``y = r_p + x m_n``; the rack translates by
  ``s = -r_p psi`` when the gear turns by +psi (counter-clockwise), rolling on the pitch circle.
* Surface coordinates: ``q`` along the tool profile (``u`` [mm] on the flank, from the datum line
  towards the tool tip; ``phi`` [rad] on the tip fillet, from the flank junction towards the tip
  bottom) and ``z`` [mm], the axial position (face from -b/2 to b/2).
* Normals returned are unit outward normals of the gear tooth.
* Sides: ``"right"`` is the flank on the +x side of the tooth at psi = 0 seen from +z (for a
  pinion driving counter-clockwise... the sign of contact is the TCA's business), ``"left"`` the
  mirror one.

Parameter vector ``p`` (see :data:`PARAMS`): ``x`` profile shift [-], ``a_c`` parabolic profile
coefficient [1/mm], ``u_0`` parabola apex [mm], ``a_pl`` plunging (longitudinal crowning)
coefficient [1/mm].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..errors import ArgumentError, ConvergenceError, GeometryError, OptionError, out_of_range, shorten
from .frames import rot_z
from .involute import inv, inv_inverse
from .modification import FlankModification, compose, extend
from .rack import BasicRack

if TYPE_CHECKING:  # typing only: gears builds on geometry (a Gear holds its tool)
    from ..gears import Gear
    from ..types import ArrayLike, Param
    from .tools import Shaper

#: Names of the entries of the surface parameter vector p, in order.
PARAMS = ("x", "a_c", "u_0", "a_pl")
SIDES = ("right", "left")
_FILLET_NEWTON = 5  # Newton steps for the fillet junction of a parabolic tool profile


def default_params(gear: Gear) -> np.ndarray:
    """Parameter vector ``p`` (:data:`PARAMS`) of ``gear`` as built; ``x`` is the generating shift
    ``gear.x_E`` (the tool position that includes the tooth thickness allowance)."""
    return np.array([gear.x_E, gear.rack.a_c, gear.rack.u_0, gear.a_pl], dtype=float)


def _cross(a, b):
    return ca.vertcat(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _unit(v):
    return v / ca.norm_2(v)


_rot_z = rot_z  # (kept importable under its old name)


# ---------------------------------------------------------------------------------------------
# Rack-cutter profile (normal section)
# ---------------------------------------------------------------------------------------------
def rack_profile_functions(rack: BasicRack, m_n: float) -> dict[str, ca.Function]:
    """Normal-section profile of the rack-cutter tooth that cuts the right flank of a gear tooth.

    Coordinates ``(xi, eta)`` [mm]: ``xi`` along the datum line (gear tooth centred on xi = 0),
    ``eta`` normal to it, positive away from the gear, datum line at eta = 0. The straight flank
    passes through ``xi = pi m_n / 4`` on the datum line at the profile angle alpha_n; the
    parabolic modification (profile crowning) adds ``a_c (u - u_0)^2`` along the tool normal.
    The tip fillet (radius rho_fP m_n) is tangent to the flank and to the tip line
    ``eta = -h_fP m_n``.

    Returns
    -------
    dict
        ``"flank"``: Function (u, p) -> (P (2,), n (2,)) and ``"fillet"``: Function (phi, p) ->
        (P, n), with ``n`` the unit outward normal of the tool (pointing into the gear tooth);
        ``"junction"``: Function (p) -> (u_f, phi_max), the flank parameter where the fillet starts
        and the fillet angle range.
    """
    a, m = rack.alpha_n, m_n
    h_f, rho = rack.h_fP * m, rack.rho_fP * m
    u = ca.SX.sym("u")
    p = ca.SX.sym("p", len(PARAMS))
    a_c, u_0 = p[1], p[2]
    t0 = ca.vertcat(ca.sin(a), -ca.cos(a))
    n0 = ca.vertcat(-ca.cos(a), -ca.sin(a))
    P = ca.vertcat(math.pi * m / 4, 0.0) + u * t0 + a_c * (u - u_0) ** 2 * n0
    t = ca.jacobian(P, u)
    n = _unit(ca.vertcat(t[1], -t[0]))  # tangent turned by -90 deg: the tool's outward normal
    flank = ca.Function("rack_flank", [u, p], [P, n], ["u", "p"], ["P", "n"])

    # Fillet junction u_f: circle of radius rho tangent to the profile at u_f and to the tip line.
    g = P[1] - rho * n[1] + h_f - rho
    G = ca.Function("g", [u, p], [g, ca.jacobian(g, u)])
    u_f = (h_f - rho * (1 - math.sin(a))) / math.cos(a)  # exact for the straight profile
    for _ in range(_FILLET_NEWTON):
        gv, dg = G(u_f, p)
        u_f = u_f - gv / dg
    P_f, n_f = flank(u_f, p)
    C = P_f - rho * n_f
    theta_f = ca.atan2(-n_f[0], -n_f[1])  # angle of n_f from the tip normal (0, -1)
    junction = ca.Function("rack_junction", [p], [u_f, theta_f, C], ["p"], ["u_f", "phi_max", "C"])

    phi = ca.SX.sym("phi")
    th = theta_f - phi
    n_fil = ca.vertcat(-ca.sin(th), -ca.cos(th))
    fillet = ca.Function("rack_fillet", [phi, p], [C + rho * n_fil, n_fil], ["phi", "p"], ["P", "n"])
    return {"flank": flank, "fillet": fillet, "junction": junction}


# ---------------------------------------------------------------------------------------------
# Generated tooth
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GeneratedTooth:
    """Tooth surfaces of one gear generated by a tool, as compiled CasADi Functions.

    Attributes
    ----------
    gear : Gear
        The gear data.
    method : str
        ``"rack"``, ``"hob"`` or ``"shaper"``.
    functions : dict[str, casadi.Function]
        ``"<side>_flank"`` and ``"<side>_fillet"`` for side in ``("right", "left")``:
        inputs ``(q, z, p)`` -> outputs ``(r (3,) [mm], n (3,) unit outward normal, psi [rad]
        generating parameter)`` (plus ``phi_h`` hob rotation for a hob); ``"<side>_<segment>_family"``:
        ``(q, z, psi, p)`` -> (r, n) of the tool surface point in the gear frame for any psi
        (for checks of the equation of meshing); ``"junction"``: ``(p)`` -> ``(u_f, phi_max, C)``
        (flank parameter where the fillet starts, fillet angle range, fillet centre of the tool).
    r_root : float
        Root radius cut by the tool [mm].
    modifications : tuple of FlankModification
        Flank modifications composed into the flank Functions (:meth:`with_modification`); every
        Function then takes the longer ``p`` (:attr:`param_names`).
    unmodified_functions : dict or None
        The generated tooth's own Functions (for :attr:`unmodified`); None without modifications.
    """

    gear: Gear
    method: str
    functions: dict = field(repr=False)
    r_root: float
    extras: dict = field(default_factory=dict)
    modifications: tuple = ()
    unmodified_functions: dict | None = field(default=None, repr=False)

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the entries of this member's surface parameter vector ``p``, in order:
        :data:`PARAMS` (the generation settings), then the symbolic parameters of any flank
        modification (``"<modification>.<theta>"``, see :meth:`with_modification`). Every consumer
        (TCA layout, synthesis, edge contact) addresses ``p`` by these."""
        return PARAMS + tuple(nm for m in self.modifications for nm in m.names)

    @property
    def p0(self) -> np.ndarray:
        """Parameter vector of the gear as built (the generation settings, then the modifications'
        theta defaults)."""
        return np.concatenate([default_params(self.gear)] + [m.defaults for m in self.modifications])

    @property
    def unmodified(self) -> "GeneratedTooth":
        """The generated tooth without its flank modifications (``self`` if it has none); its
        parameter vector is the first ``len(PARAMS)`` entries of ``p``."""
        if not self.modifications:
            return self
        return GeneratedTooth(gear=self.gear, method=self.method, functions=dict(self.unmodified_functions),
                              r_root=self.r_root, extras=self.extras)

    def with_modification(self, mod: FlankModification) -> "GeneratedTooth":
        """This tooth with a flank modification composed into its flank Functions (once).

        ``functions["<side>_flank"]`` of each side in ``mod.sides`` becomes ``(u, z, p) ->
        (r + delta n, n', psi[, phi_h])`` (names of inputs and outputs kept; ``n'`` the unit outward
        normal of the modified surface, from its AD tangents); ``p`` grows by ``mod``'s theta
        (:attr:`param_names` ends with ``"<mod.name>.<theta>"``, :attr:`p0` with their defaults).
        The fillet, the tool families and the junction stay as generated (they take the longer
        ``p`` and ignore theta): a deviation that does not vanish at the flank/fillet junction leaves
        a step of ``delta`` there. Modifications stack: each one acts on the surface it is given.

        Parameters
        ----------
        mod : gearopt.geometry.modification.FlankModification

        Returns
        -------
        GeneratedTooth
            A new tooth; ``self`` is unchanged. Pass it to ``TCA(pair, pinion=...)`` / ``gear=...``.

        Raises
        ------
        ArgumentError
            If ``mod`` is not a FlankModification or one of its parameter names is already used.
        GeometryError
            If the modified flank is not finite (or not regular) at the pitch point of the tooth.
        """
        if not isinstance(mod, FlankModification):
            raise ArgumentError(f"with_modification: mod = {type(mod).__name__} {shorten(repr(mod))}: expected a "
                                "gearopt.geometry.modification.FlankModification.")
        clash = sorted(set(mod.names) & set(self.param_names)) or (
            [mod.name] if any(m.name == mod.name for m in self.modifications) else [])
        if clash:
            raise ArgumentError(f"with_modification: modification name {mod.name!r} is already used on "
                                f"{self.gear.name} ({clash}); give each modification its own name.")
        n_p, k = len(self.param_names), len(mod.theta)
        funcs = {}
        for key, f in self.functions.items():
            if not isinstance(f, ca.Function):
                continue  # cached evaluators (flank limits) are rebuilt for the new surfaces
            side, _, seg = key.partition("_")
            if seg == "flank" and side in mod.sides:
                funcs[key] = compose(f, mod, n_p)
            else:
                funcs[key] = extend(f, k, f.n_in() - 1)  # p is the last input of every Function
        base = self.unmodified_functions if self.modifications else {
            kk: v for kk, v in self.functions.items() if isinstance(v, ca.Function)}
        tooth = GeneratedTooth(gear=self.gear, method=self.method, functions=funcs, r_root=self.r_root,
                               extras=self.extras, modifications=self.modifications + (mod,),
                               unmodified_functions=base)
        p0 = tooth.p0
        u_p = float(self.extras.get("q_pitch", 0.0))
        for side in mod.sides:
            r, n, _ = tooth.point(side, "flank", u_p, 0.0, p0)
            if not (np.all(np.isfinite(r)) and np.all(np.isfinite(n)) and abs(np.linalg.norm(n) - 1) < 1e-9):
                raise GeometryError(f"with_modification: modification {mod.name!r} gives a {side} flank of "
                                    f"{self.gear.name} without a finite point and unit normal at the pitch point "
                                    f"(r = {r.tolist()}, n = {n.tolist()}, theta = {mod.defaults.tolist()}).")
        return tooth

    def surface(self, side: str = "right", segment: str = "flank") -> ca.Function:
        """The compiled surface Function ``(q, z, p) -> (r, n, psi)`` of a side and segment."""
        if side not in SIDES:
            raise out_of_range("side", side, "'right' or 'left'", cls=OptionError)
        if segment not in ("flank", "fillet"):
            raise out_of_range("segment", segment, "'flank' or 'fillet'", cls=OptionError)
        return self.functions[f"{side}_{segment}"]

    def junction(self, p: Param = None) -> tuple[float, float]:
        """Flank parameter ``u_f`` [mm] where the fillet begins and fillet angle range [rad]."""
        u_f, phi_max = self.functions["junction"](self.p0 if p is None else p)[:2]
        return float(u_f), float(phi_max)

    def point(self, side: str, segment: str, q: float, z: float = 0.0, p: Param = None) -> tuple[np.ndarray, np.ndarray,
              float]:
        """Numeric position (3,), unit normal (3,) and psi of one surface point."""
        r, n, psi = self.surface(side, segment)(q, z, self.p0 if p is None else p)[:3]
        return np.asarray(r).ravel(), np.asarray(n).ravel(), float(psi)

    def normal_deviation(self, side: str, u: ArrayLike, z: ArrayLike, p: Param = None) -> np.ndarray:
        """Normal deviation of the modified flank from the generated one [mm] (+: material added)
        at flank coordinates ``u`` [mm] and sections ``z`` [mm] (arrays of one length): the sum of
        every :class:`~gearopt.geometry.modification.FlankModification` on that side, measured along
        the unmodified flank's outward normal. Zeros without modifications."""
        u, z = np.atleast_1d(np.asarray(u, float)), np.atleast_1d(np.asarray(z, float))
        if not self.modifications:
            return np.zeros(np.broadcast(u, z).size)
        p = self.p0 if p is None else np.asarray(p, float)
        n_base = len(PARAMS)
        u, z = np.broadcast_arrays(u, z)
        f_m = self.surface(side, "flank").map(u.size)
        f_0 = self.unmodified_functions[f"{side}_flank"].map(u.size)
        r_m = np.asarray(f_m(u[None, :], z[None, :], np.tile(p[:, None], (1, u.size)))[0])
        r_0, n_0 = (np.asarray(v) for v in f_0(u[None, :], z[None, :], np.tile(p[:n_base, None], (1, u.size)))[:2])
        return np.sum((r_m - r_0) * n_0, axis=0)

    def radius_function(self, side: str = "right") -> ca.Function:
        """Function (u, z, p) -> (transverse radius, d radius / du) on the flank (built once per side)."""
        key = f"{side}_flank_radius"
        if key not in self.functions:
            u, z = ca.SX.sym("u"), ca.SX.sym("z")
            p = ca.SX.sym("p", len(self.param_names))
            r = self.surface(side, "flank")(u, z, p)[0]
            rad = ca.sqrt(r[0] ** 2 + r[1] ** 2)
            # (kept in a tuple: with_modification rebuilds cached evaluators, it composes only Functions)
            self.functions[key] = (ca.Function("flank_radius", [u, z, p], [rad, ca.jacobian(rad, u)]),)
        return self.functions[key][0]

    def u_at_radius(self, radius: float, z: float = 0.0, side: str = "right", p: Param = None,
                    tol: float = 1e-12) -> float:
        """Flank parameter u [mm] of the point at transverse radius ``radius`` (Newton).

        Raises
        ------
        GeometryError
            If the radius is not reached on the generated flank (below the form radius of an
            undercut tooth or beyond the tool's reach).
        """
        p = self.p0 if p is None else p
        f = self.radius_function(side)
        u = float(self.extras.get("q_pitch", 0.0))
        for _ in range(60):
            rad, d = (float(v) for v in f(u, z, p))
            if d >= 0:  # the flank coordinate runs towards the root: radius must decrease
                raise GeometryError(f"{self.gear.name}: radius {radius:.6g} mm is not reached on the involute flank "
                                    f"(the flank radius stops growing at u = {u:.6g} mm: undercut or singular point).")
            step = (rad - radius) / d
            u -= step
            # converged: the step is below tol, or the radius is met to rounding (large gears, where
            # an absolute 1e-12 mm is below the resolution of a double at that radius)
            if abs(step) < tol or abs(rad - radius) <= 4 * np.finfo(float).eps * abs(radius):
                return u
        raise ConvergenceError(f"{self.gear.name}: no flank point at radius {radius:.6g} mm after 60 Newton steps.")

    # --- the true limit of the generated flank ----------------------------------------------
    def _limit_eval(self, side: str) -> tuple[ca.Function, ca.Function]:
        """Compiled (flank, fillet) evaluators for :meth:`flank_limit` (built once per side):
        flank ``(u, z, p) -> (x, y, (r_u x r_z) . n, d radius/du, dx/du, dy/du)``, fillet
        ``(phi, z, p) -> (x, y, dx/dphi, dy/dphi)``."""
        key = f"{side}_flank_limit_eval"
        if key not in self.functions:
            u, z = ca.SX.sym("u"), ca.SX.sym("z")
            p = ca.SX.sym("p", len(self.param_names))
            r, n = self.surface(side, "flank")(u, z, p)[:2]
            r_u = ca.jacobian(r, u)
            reg = ca.dot(_cross(r_u, ca.jacobian(r, z)), n)
            rad = ca.sqrt(r[0] ** 2 + r[1] ** 2)
            fl = ca.Function(f"{self.gear.name}_{side}_limit_flank", [u, z, p],
                             [r[0], r[1], reg, ca.jacobian(rad, u), r_u[0], r_u[1]])
            q = ca.SX.sym("phi")
            rf = self.surface(side, "fillet")(q, z, p)[0]
            fi = ca.Function(f"{self.gear.name}_{side}_limit_fillet", [q, z, p],
                             [rf[0], rf[1], ca.jacobian(rf[0], q), ca.jacobian(rf[1], q)])
            self.functions[key] = (fl, fi)
        return self.functions[key]

    def flank_limit(self, side: str = "right", z: float = 0.0, p: Param = None, samples: int = 400) -> "FlankLimit":
        """Where the real generated flank ends in the transverse section ``z`` [mm].

        Going down the flank from the tip (u increasing towards the root), the generated surface is
        a regular, single-sheeted part of the tooth until the first of

        * the tool's flank/fillet junction ``u_f`` (``kind = "junction"``, the usual form radius);
        * a fold: the first zero of the signed regularity ``(r_u x r_z) . n`` or of ``d radius/du``
          (the envelope's singular point, Litvin section 6.3: the involute cusp on the base circle of
          an undercut tooth, or higher up for a strongly profile-crowned tool, whose curvature moves
          the singular point above the base circle); past it the flank runs back on a reversed
          branch. When the reversed branch or the fillet that follows it cuts the valid branch
          (a swallowtail: the trochoid of an undercut tooth cutting its involute), the material
          below the crossing is cut away by the tool and the flank ends at the crossing
          (``kind = "intersection"``); otherwise at the fold (``kind = "fold"``).

        The zeros are brackets from samples (outside any AD graph) refined by Brent's method on the
        smooth conditions; the crossing by Newton on the two curves' equations.

        Returns
        -------
        FlankLimit

        Raises
        ------
        GeometryError
            If the flank folds at or above the tip circle (no active flank at all).
        """
        p = self.p0 if p is None else np.asarray(p, float).ravel()
        fl, fi = self._limit_eval(side)
        g = self.gear
        u_f, phi_max = self.junction(p)
        # Sample from well above the tip (the tool point that cuts the tip lies (h_aP + k) m_n above
        # the datum line) down to the junction.
        u_a = self.extras.get("q_above_tip",  # a shaper's flank coordinate is its roll angle
                              -(g.rack.h_aP + abs(g.k) + 1.0) * g.m_n / math.cos(g.rack.alpha_n) - abs(u_f))
        us = np.linspace(u_a, u_f, samples)
        P = np.tile(p[:, None], samples)
        x, y, reg, drad = (np.asarray(v).ravel() for v in fl.map(samples)(us, z, P)[:4])
        rad = np.hypot(x, y)

        def ev(uu, k):
            return float(fl(uu, z, p)[k])

        below_tip = np.flatnonzero((rad <= g.r_a) & np.isfinite(reg))
        if below_tip.size == 0:
            raise GeometryError(f"{g.name}: the generated flank does not reach below the tip circle r_a = {g.r_a:.6g} mm "
                                f"in section z = {z:.6g} mm.")
        i0 = int(below_tip[0])
        orient = math.copysign(1.0, reg[i0]) if reg[i0] != 0 else 1.0
        bad = (orient * reg <= 0) | (drad >= 0) | ~np.isfinite(reg)
        bad[:i0] = False
        j = np.flatnonzero(bad)
        if j.size == 0:
            r_j = math.hypot(ev(u_f, 0), ev(u_f, 1))
            return FlankLimit(u=u_f, radius=r_j, kind="junction", u_fold=math.nan, radius_fold=math.nan, u_junction=u_f,
                              z=z)
        j = int(j[0])
        if j <= i0:
            raise GeometryError(f"{g.name}: the generated flank folds at or above the tip circle (r_a = {g.r_a:.6g} mm) "
                                f"in section z = {z:.6g} mm: no active flank (profile crowning a_c = {p[1]:.6g} 1/mm "
                                "is far too large, or the tooth is undercut up to the tip).")
        lo, hi = us[j - 1], us[j]
        roots = []
        for k, sgn in ((2, orient), (3, -1.0)):  # orient * reg > 0 and -d radius/du > 0 on the valid branch
            a, b = sgn * ev(lo, k), sgn * ev(hi, k)
            if a > 0 >= b:
                from scipy.optimize import brentq  # only for a fold: scipy.optimize takes ~0.3 s to import

                roots.append(brentq(lambda t: sgn * ev(t, k), lo, hi, xtol=1e-14, rtol=1e-15, maxiter=200))
        u_fold = min(roots) if roots else hi
        r_fold = math.hypot(ev(u_fold, 0), ev(u_fold, 1))
        cut = self._crossing(fl, fi, z, p, us[i0], u_fold, u_f, phi_max,
                             lambda uu, zz, pp: self.surface(side, "flank")(uu, zz, pp)[1])
        if cut is not None:
            return FlankLimit(u=cut[0], radius=cut[1], kind="intersection", u_fold=u_fold, radius_fold=r_fold,
                              u_junction=u_f, z=z, kink=cut[2])
        return FlankLimit(u=u_fold, radius=r_fold, kind="fold", u_fold=u_fold, radius_fold=r_fold, u_junction=u_f, z=z)

    @staticmethod
    def _crossing(fl, fi, z, p, u_tip, u_fold, u_f, phi_max, fl_normal, n: int = 400):
        """First crossing (highest on the valid branch) of the valid flank branch [u_tip, u_fold]
        with the rest of the generated section (reversed flank branch [u_fold, u_f], then the fillet),
        as (u, radius), or None. Bracketed on polylines, refined by Newton on the two curves."""
        uv = np.linspace(u_tip, u_fold, n)
        A = np.array(fl.map(n)(uv, z, np.tile(p[:, None], n))[:2]).reshape(2, n).T
        ur = np.linspace(u_fold, u_f, n) if u_f > u_fold else np.array([u_fold])
        B1 = np.array(fl.map(ur.size)(ur, z, np.tile(p[:, None], ur.size))[:2]).reshape(2, ur.size).T
        ph = np.linspace(0.0, phi_max, n)
        B2 = np.array(fi.map(n)(ph, z, np.tile(p[:, None], n))[:2]).reshape(2, n).T
        B = np.vstack([B1, B2])
        params = [("flank", v) for v in ur] + [("fillet", v) for v in ph]
        skip = 3  # segments next to the fold itself (the two branches meet there tangentially)
        a0, d1 = A[:-1 - skip], np.diff(A, axis=0)[:-skip]
        b0, d2 = B[skip:-1], np.diff(B, axis=0)[skip:]
        if len(a0) == 0 or len(b0) == 0:
            return None
        den = d1[:, None, 0] * d2[None, :, 1] - d1[:, None, 1] * d2[None, :, 0]
        w = b0[None, :, :] - a0[:, None, :]
        with np.errstate(all="ignore"):
            s = (w[..., 0] * d2[None, :, 1] - w[..., 1] * d2[None, :, 0]) / den
            t = (w[..., 0] * d1[:, None, 1] - w[..., 1] * d1[:, None, 0]) / den
        hit = (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1) & np.isfinite(s)
        ia, ib = np.nonzero(hit)
        for k in np.argsort(ia):  # highest on the valid branch first
            i, jb = int(ia[k]), int(ib[k]) + skip
            ua = uv[i] + s[i, jb - skip] * (uv[i + 1] - uv[i])
            seg, q0 = params[jb]
            seg1, q1 = params[jb + 1]
            if seg1 != seg:  # the segment joins the reversed flank to the fillet: start at its end
                seg, q0, q1 = seg1, q1, q1
            qb = q0 + t[i, jb - skip] * (q1 - q0)
            other = fl if seg == "flank" else fi
            for _ in range(30):  # Newton on r_valid(ua) - r_other(qb) = 0 (transverse plane)
                xa, ya, _, _, xua, yua = (float(v) for v in fl(ua, z, p))
                if seg == "flank":
                    xb, yb, _, _, xqb, yqb = (float(v) for v in other(qb, z, p))
                else:
                    xb, yb, xqb, yqb = (float(v) for v in other(qb, z, p))
                F = np.array([xa - xb, ya - yb])
                J = np.array([[xua, -xqb], [yua, -yqb]])
                try:
                    d = np.linalg.solve(J, F)
                except np.linalg.LinAlgError:
                    break
                ua, qb = ua - d[0], qb - d[1]
                if np.abs(d).max() < 1e-13:
                    break
            if np.hypot(*F) < 1e-10 and u_tip <= ua < u_fold - 1e-9:
                xa, ya, _, _, xua, yua = (float(v) for v in fl(ua, z, p))
                # Turning angle of the boundary at the crossing: from the flank's direction (towards
                # the root) to the cutting curve's, continued towards the root (radius decreasing).
                d = np.array([xua, yua]) / math.hypot(xua, yua)
                e = np.array([xqb, yqb]) / math.hypot(xqb, yqb)
                if e @ np.array([xa, ya]) > 0:
                    e = -e
                kink = math.acos(max(-1.0, min(1.0, float(d @ e))))
                a_n = np.asarray(fl_normal(ua, z, p)).ravel()[:2]
                if e @ a_n > 0:  # turns away from the tooth: a concave corner, no contact edge
                    kink = -kink
                return float(ua), math.hypot(xa, ya), kink
        return None

    def max_unfolded_a_c(self, side: str = "right", z: float = 0.0, p: Param = None, rel_tol: float = 1e-6) -> float:
        """Largest profile-crowning coefficient a_c [1/mm] (other parameters as in ``p``) for which
        the flank in section ``z`` does not fold before the tool's flank/fillet junction; 0.0 if it
        folds even with the straight tool (an undercut tooth). Bisection on :meth:`flank_limit`."""
        p = (self.p0 if p is None else np.asarray(p, float).ravel()).copy()

        def folds(a_c):
            q = p.copy()
            q[1] = a_c
            try:
                return self.flank_limit(side, z, q).kind != "junction"
            except GeometryError:
                return True

        if folds(0.0):
            return 0.0
        lo, hi = 0.0, max(p[1], 1e-4)
        while not folds(hi):
            lo, hi = hi, 2 * hi
            if hi > 1e3:
                return math.inf
        while hi - lo > rel_tol * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if not folds(mid) else (lo, mid)
        return lo

    def transverse_profile(self, z: float = 0.0, n: int = 60, p: Param = None) -> dict[str, np.ndarray]:
        """Sampled transverse section of one tooth (both sides, fillets, tip arc) [mm].

        Returns
        -------
        dict
            ``"right_flank"``, ``"left_flank"``, ``"right_fillet"``, ``"left_fillet"`` as (k, 2)
            arrays from the form limit to the tip / from the flank junction to the root,
            ``"tip"`` (k, 2) arc.
        """
        p = self.p0 if p is None else p
        g = self.gear
        u_f, phi_max = self.junction(p)
        out = {}
        for side in SIDES:
            u_tip = self.u_at_radius(g.r_a, z, side, p)
            us = np.linspace(u_tip, u_f, n)
            fl = np.array(self.surface(side, "flank").map(n)(us, z, np.tile(p[:, None], n))[0]).T
            phis = np.linspace(0.0, phi_max, n)
            fi = np.array(self.surface(side, "fillet").map(n)(phis, z, np.tile(p[:, None], n))[0]).T
            out[f"{side}_flank"] = fl[:, :2]
            out[f"{side}_fillet"] = fi[:, :2]
        a0 = math.atan2(out["left_flank"][0, 1], out["left_flank"][0, 0])
        a1 = math.atan2(out["right_flank"][0, 1], out["right_flank"][0, 0])
        ang = np.linspace(a1, a0, 20)
        out["tip"] = g.r_a * np.c_[np.cos(ang), np.sin(ang)]
        return out


@dataclass(frozen=True)
class FlankLimit:
    """The end of the real generated flank in one transverse section (see
    :meth:`GeneratedTooth.flank_limit`).

    Attributes
    ----------
    u : float
        Flank parameter [mm] where the active flank ends (contacts need ``u <= u``).
    radius : float
        Transverse radius there [mm]: the form radius of that section.
    kind : {"junction", "fold", "intersection"}
        The tool's flank/fillet junction (regular flank), the fold (singular point) of the generated
        flank, or the crossing of the valid branch with the reversed branch / fillet below the fold.
    u_fold, radius_fold : float
        First fold along u and its radius [mm] (NaN if the flank does not fold before ``u_junction``).
    u_junction : float
        The tool's flank/fillet junction [mm].
    z : float
        The section [mm].
    kink : float
        For ``kind = "intersection"``: the angle [rad] by which the tooth outline turns at the
        crossing (towards the tooth: a convex edge, which can carry contact like a tip edge).
    """

    u: float
    radius: float
    kind: str
    u_fold: float
    radius_fold: float
    u_junction: float
    z: float = 0.0
    kink: float = math.nan

    @property
    def folded(self) -> bool:
        """True when the generated flank folds (singular point) before the tool's junction."""
        return self.kind != "junction"


def _helix_sigma(gear: Gear) -> float:
    return 0.0 if gear.is_spur else (1.0 if gear.hand == "right" else -1.0)


def rack_generated(gear: Gear, rack: BasicRack, method: str, N_h: int | None = None) -> GeneratedTooth:
    m_n, beta = gear.m_n, gear.beta
    cb, tb = math.cos(beta), math.tan(beta)
    r_p = gear.r_p
    sigma = _helix_sigma(gear)
    prof = rack_profile_functions(rack, m_n)
    q, z, psi_free = ca.SX.sym("q"), ca.SX.sym("z"), ca.SX.sym("psi")
    p = ca.SX.sym("p", len(PARAMS))
    x, a_pl = p[0], p[3]
    funcs: dict[str, ca.Function] = {"junction": prof["junction"]}
    for side, sx in (("right", 1.0), ("left", -1.0)):
        for seg, qname in (("flank", "u"), ("fillet", "phi")):
            P = prof[seg](q, p)[0]
            # Tool surface in S_c: normal-section profile swept along the helix, plunged by a_pl z^2.
            # A right-hand tooth moves towards -x along +z on the rack side (+y) of the gear.
            R = ca.vertcat(sx * P[0] / cb - sigma * z * tb, P[1] - a_pl * z**2, z)
            n_c = _unit(sx * _cross(ca.jacobian(R, q), ca.jacobian(R, z)))  # tool outward normal
            # Equation of meshing n . v^(cg) = 0 with v^(cg) = omega (y_f - r_p, -x_f, 0),
            # x_f = x_c - r_p psi, y_f = y_c + r_p + x m_n: affine in psi, solved exactly.
            psi = (n_c[1] * R[0] - n_c[0] * (R[1] + x * m_n)) / (n_c[1] * r_p)

            def in_gear(ps):
                r_f = ca.vertcat(R[0] - r_p * ps, R[1] + r_p + x * m_n, R[2])
                return _rot_z(-ps, r_f), -_rot_z(-ps, n_c)

            r_g, n_g = in_gear(psi)
            outs, onames = [r_g, n_g, psi], ["r", "n", "psi"]
            if N_h is not None:  # hob: phi_h / phi_g = N_g / N_h (Litvin eq. 10.3.4)
                outs.append(psi * gear.z / N_h)
                onames.append("phi_h")
            name = f"{gear.name}_{side}_{seg}"
            funcs[f"{side}_{seg}"] = ca.Function(name, [q, z, p], outs, [qname, "z", "p"], onames)
            r_fam, n_fam = in_gear(psi_free)
            funcs[f"{side}_{seg}_family"] = ca.Function(
                f"{name}_family", [q, z, psi_free, p], [r_fam, n_fam], [qname, "z", "psi", "p"], ["r", "n"])
    return GeneratedTooth(gear=gear, method=method, functions=funcs, r_root=gear.r_f)


def shaper_generated(gear: Gear, shaper: Shaper) -> GeneratedTooth:
    """Tooth surfaces of a spur or helical gear generated by a shaper (external cutting mesh).

    The shaper (:class:`~gearopt.geometry.tools.Shaper`) is an involute gear of the same normal
    module; for a helical gear it has the same helix angle and the opposite hand, and its cutting
    stroke is a screw motion along its own helix, which slides the tool surface along itself and so
    does not change the envelope (Litvin section 10.3). The shaper turns by
    ``psi_s = (N_2 / N_s) psi`` opposite to the gear about a parallel axis at the cutting centre
    distance ``a_cut`` (``inv alpha_wt0 = inv alpha_t + 2 tan alpha_n (x_s + x) / (N_s + N_2)``,
    transverse section). The relative motion is planar, so the equation of meshing
    ``n_s . v^(s2) = 0`` holds section by section: the common normal passes through the pitch point I,
    and the tool's normal line is intersected with the shaper's cutting pitch circle. In the section
    ``z`` the shaper's transverse profile is turned by its helix, ``sigma_s z tan(beta) / r_ps``;
    the generated section is then the mid section turned by ``sigma z tan(beta) / r_p`` (the gear's
    helix: ``r_ps / r_p = N_s / N_2``) and the surface is a helicoid. The involute flank equals the
    rack-generated involute helicoid; the fillet is the trochoid of the shaper's tip rounding (a
    circle of radius ``rho_fP m_n`` in the shaper's transverse section) and tends to the rack's as
    N_s grows (exactly so for spur gears, whose rack fillet is the same circle).

    The flank coordinate ``q`` is the shaper involute's roll angle [rad] (growing towards the
    shaper tip, i.e. the gear root), the fillet coordinate the angle on the tip rounding [rad].

    Parameters
    ----------
    gear : Gear
        Without crowning (``a_pl = 0``, ``rack.a_c = 0``).
    shaper : Shaper

    Raises
    ------
    GeometryError
        If the shaper cannot cut the gear (:meth:`~gearopt.geometry.tools.Shaper.check`).
    """
    if gear.a_pl != 0 or gear.rack.a_c != 0:
        raise GeometryError(f"{gear.name}: crowning (a_pl = {gear.a_pl}, a_c = {gear.rack.a_c}) is defined for rack/hob "
                            "generation; shaper generation needs a_pl = 0 and a_c = 0.",
                            param=f"{gear.name}.a_pl" if gear.a_pl else f"{gear.name}.rack.a_c",
                            value=gear.a_pl or gear.rack.a_c, valid="a_pl = 0 and a_c = 0")
    if shaper is not gear.tool:
        shaper.check(gear)  # gear.tool was checked when the Gear was built
    cut0 = shaper.cutting(gear)
    rack, m = gear.rack, gear.m_n
    al = cut0["alpha_t"]  # transverse pressure angle (alpha_n itself for a spur gear)
    N_s, N_2 = shaper.N_s, gear.z
    r_ps, r_bs, r_as, rho, s_ps = cut0["r_ps"], cut0["r_bs"], cut0["r_as"], cut0["rho"], cut0["s_ps"]
    m_t = gear.m_t
    sigma = _helix_sigma(gear)
    tb = math.tan(gear.beta)
    gam0 = -math.pi / 2 + math.pi / N_s  # direction of the shaper tooth right of the line of centres

    q, z, psi_free = ca.SX.sym("q"), ca.SX.sym("z"), ca.SX.sym("psi")
    p = ca.SX.sym("p", len(PARAMS))
    x = p[0]
    inv_w = inv(al) + 2 * math.tan(rack.alpha_n) * (shaper.x_s + x) / (N_s + N_2)
    a_cut = (m_t * (N_s + N_2) / 2) * math.cos(al) / ca.cos(inv_inverse(inv_w))  # cutting centre distance
    r_ws = a_cut * N_s / (N_s + N_2)  # shaper's cutting pitch radius

    def shaper_flank(phi_roll):  # shaper flank facing -x (decreasing polar angle), roll angle phi_roll
        rad = r_bs * ca.sqrt(1 + phi_roll**2)
        half = s_ps / (2 * r_ps) + inv(al) - (phi_roll - ca.atan(phi_roll))
        ang = gam0 - half
        return ca.vertcat(rad * ca.cos(ang), rad * ca.sin(ang))

    P_fl = shaper_flank(q)
    t_fl = ca.jacobian(P_fl, q)
    n_fl = _unit(ca.vertcat(t_fl[1], -t_fl[0]))
    flank_fn = ca.Function("shaper_flank", [q], [P_fl, n_fl])
    # Tip rounding tangent to the flank (centre on the flank normal, |C| = r_as - rho): closed form.
    phi_j = (rho + math.sqrt((r_as - rho) ** 2 - r_bs**2)) / r_bs
    P_j, n_j = (np.asarray(v).ravel() for v in flank_fn(phi_j))
    C = P_j - rho * n_j
    c_hat = C / np.linalg.norm(C)
    phi_max = math.atan2(n_j[0] * c_hat[1] - n_j[1] * c_hat[0], n_j @ c_hat)
    n_rd = ca.vertcat(ca.cos(q) * n_j[0] - ca.sin(q) * n_j[1], ca.sin(q) * n_j[0] + ca.cos(q) * n_j[1])
    P_rd = C + rho * n_rd
    funcs: dict[str, ca.Function] = {
        "junction": ca.Function("shaper_junction", [p], [phi_j, phi_max, ca.DM(C)], ["p"], ["u_f", "phi_max", "C"])}
    for seg, qname, P, n in (("flank", "u", P_fl, n_fl), ("fillet", "phi", P_rd, n_rd)):
        # Planar meshing in the shaper's section at its own orientation: I_s = P + t n on the circle
        # |I_s| = r_ws, nearest root (P . n > 0 on the tool).
        b = P[0] * n[0] + P[1] * n[1]
        c = r_ws**2 - (P[0] ** 2 + P[1] ** 2)
        t = c / (b + ca.sqrt(b * b + c))
        I_s = P + t * n
        psi_s0 = ca.atan2(I_s[1], I_s[0]) + math.pi / 2  # shaper rotation (clockwise positive), section z = 0

        for side, sx in (("right", 1.0), ("left", -1.0)):
            # The shaper tooth right of the line of centres cuts the gear tooth's right flank; the
            # left flank is the mirror image of the right flank of the gear of the opposite hand.
            k_s = -sx * sigma * tb / r_ps  # the shaper's helix (opposite hand): its section at z is
            #                                turned counter-clockwise by k_s z
            if sigma == 0:
                n3 = ca.vertcat(n, 0.0)
            else:
                # Normal of the shaper's helicoid S(q, z) = Rot(k_s z) P(q) + z e_z at z = 0 orientation:
                # the in-plane normal n plus the axial part that makes it orthogonal to dS/dz.
                n3 = _unit(ca.vertcat(n, -k_s * (P[0] * n[1] - P[1] * n[0])))

            def in_gear(ps, z_, side_x=sx, k_s=k_s, n3=n3):
                a = ps * N_2 / N_s - k_s * z_  # the section's shaper profile turned clockwise by a
                c_, s_ = ca.cos(a), ca.sin(a)
                Pf = ca.vertcat(c_ * P[0] + s_ * P[1], -s_ * P[0] + c_ * P[1] + a_cut, z_)  # R(-a) P + O_s
                nf = ca.vertcat(c_ * n3[0] + s_ * n3[1], -s_ * n3[0] + c_ * n3[1], n3[2])
                r_g, n_g = _rot_z(-ps, Pf), -_rot_z(-ps, nf)
                mirror = ca.vertcat(side_x, 1.0, 1.0)
                return r_g * mirror, n_g * mirror

            # psi where the section z is cut: the shaper turned on by its helix twist k_s z.
            psi = (psi_s0 + k_s * z) * N_s / N_2
            r_g, n_g = in_gear(psi, z)
            name = f"{gear.name}_{side}_{seg}"
            funcs[f"{side}_{seg}"] = ca.Function(name, [q, z, p], [r_g, n_g, sx * psi], [qname, "z", "p"],
                                                 ["r", "n", "psi"])
            r_fam, n_fam = in_gear(sx * psi_free, z)
            funcs[f"{side}_{seg}_family"] = ca.Function(
                f"{name}_family", [q, z, psi_free, p], [r_fam, n_fam], [qname, "z", "psi", "p"], ["r", "n"])
    a_cut0 = float(ca.Function("a", [p], [a_cut])(default_params(gear)))
    # Flank coordinate (shaper roll angle) of the point that cuts beyond the gear's tip, for
    # GeneratedTooth.flank_limit: half the roll angle of the one that cuts the tip (> 0 by Shaper.check).
    q_above_tip = 0.5 * max(cut0["L_tip"], 1e-3 * m) / r_bs
    return GeneratedTooth(gear=gear, method="shaper", functions=funcs, r_root=a_cut0 - r_as,
                          extras={"N_s": N_s, "x_s": shaper.x_s, "a_cut": a_cut0, "r_as": r_as, "q_pitch": math.tan(al),
                                  "q_above_tip": q_above_tip})
