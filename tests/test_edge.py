"""Tests of edge contact (gearopt.contact.edge, Litvin & Fuentes section 9.6, docs/theory.md sections 5, 7, 9).

Every expectation is derived here from gear geometry or solved with our own frames; the engine's
output is only compared with it. Conventions (gearopt.meshing.tca module docstring): S_f with the
pinion axis z_f and the gear centre O2 = (0, a + dE, axial); the pinion drives on its ``side`` flank
(sgn = +1 right, -1 left) and is turned by Rz(sgn (theta1 - phi1)); the gear by
O2 + Ry(crossing) Rx(intersecting) Rz(sgn phi2) Rz(pi + sgn theta2); theta_i = half the tooth angle
on the operating pitch circle. Pair k is pair 0 at phi1 - 2 pi k / z1 with its gear angle shifted by
2 pi k / z2, so the raw TE of any contact is ``phi2_0 - (z1/z2) (phi1 - 2 pi k / z1)``.

Derivations used below
----------------------
A. Continuity surface -> edge (test 1). The pair's TE is the largest gear advance over the points of
   the finite flank, a constrained maximum of the gap function. While the unconstrained maximum (the
   surface-to-surface contact point) lies on the flank it is the answer; beyond the crossing angle
   phi1* where it reaches the tip (r = r_a1) the maximum sits on the tip edge. At phi1* both problems
   have the same solution (so the edge system 9.6.1-9.6.2 is solved by the surface contact point), and
   by the envelope theorem the value is C1 there: equal TE and equal dTE/dphi1.

B. First-order TE of an unmodified helical pair under a crossing angle g (test 4). Plane of action:
   T1 = r_b1 (-sin a, cos a), direction d = (cos a, sin a), a = alpha_wt; a point of it is
   P = T1 + s d + z e_z with s = r_b1 (tan a + phi1) on the line of contact through z = 0. The helix
   turns the section at z: on the contact line s = s_c(phi1) - z t, t = tan beta_b (right-hand pinion,
   right flank). The pinion's outward normal is n1 = (cos b_b cos a, cos b_b sin a, sin b_b). The
   gear turned by g about y_f through O2 moves its flank point by delta = g e_y x (P - O2) =
   g (z, 0, -x); a gear rotation dphi2 moves it by r_b2 cos b_b dphi2 along n1. So the gear advance
   demanded by a point of the (conjugate) contact line is
       TE_loc(s, z) = -(n1 . delta) / (r_b2 cos b_b) = -(g / r_b2) [cos a z - t (s cos a - r_b1 sin a)],
   linear along the contact line (coefficient of z there: -(g/r_b2) cos a (1 + t^2)): the gear rests
   on an END of the contact line segment that lies inside the active rectangle s_lo <= s <= s_hi,
   |z| <= b/2 (s_lo: gear tip, s_hi: pinion tip): for g > 0 the end with the smallest z (face end
   z = -b/2, or the pinion tip edge where the line is clipped), for g < 0 the other end. Slopes:
       face end (z fixed, ds = r_b1 dphi1):   dTE/dphi1 = +g t cos a r_b1 / r_b2,
       tip edge (s fixed, dz = -r_b1 dphi1/t): dTE/dphi1 = -g cos a r_b1 / (r_b2 t),
   both linear in g. (Errors are second order: g^2 terms and the shift of the edge point off the
   aligned line of action.) 21/53, beta 18 deg: t = 0.30346, cos a = 0.93394, g = 3' ->
   face +9.799e-5, tip -1.0642e-3 rad/rad.

C. Mirror symmetry (test 5). TE_loc is linear in (s, z); the point reflection
   (s, z) -> (s_lo + s_hi - s, -z) maps the active rectangle and the family of contact lines onto
   themselves (phi1 -> 2 phi_m - phi1, phi_m: mid mesh) and TE_loc(P) -> 2 TE_loc(centre) - TE_loc(P).
   Hence to first order TE(phi1; -g) = TE(2 phi_m - phi1; +g) + const, the load goes from the face end
   z = -b/2 to z = +b/2, pinion tip <-> gear tip. Exact symmetries: turning the whole drive by pi
   about y_f (x -> -x, z -> -z) maps each symmetric gear onto itself, the right flank onto the left
   one, clockwise onto counter-clockwise, and conjugates Ry(g) to itself: TE_right(phi1; g) =
   TE_left(phi1; g) with face+ <-> face-. For spur gears the mirror z -> -z also gives
   TE(phi1; g) = TE(phi1; -g).

D. Crowning (test 6): the surface TE of each pair is a parabola plus the misalignment's line
   (docs/theory.md section 5.3); two neighbouring pairs' identical parabolas cross at apex + pi/z1. If the surface
   contact point there is beyond the tip the transfer cannot happen on the flanks and an edge takes
   over.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy.optimize import brentq, fsolve

from gearopt.contact.edge import EdgeContact
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment
from conftest import Rx, Ry, Rz  # noqa: E402  (the tests' own rotation matrices)

DEG = math.pi / 180
ARCMIN = DEG / 60
AS = 180 * 3600 / math.pi  # arcsec per rad
SGN = {"right": 1.0, "left": -1.0}
PAIRS = (-2, -1, 0, 1, 2)
K0 = PAIRS.index(0)


# ------------------------------------------------------------------------------------------------
# Drives
# ------------------------------------------------------------------------------------------------
def helical(a_c=0.0, a_pl=0.0) -> GearPair:
    """21/53, m_n 2.5 mm, beta 18 deg, b 30 mm (scenes edge_helical_*, edge_crowned_*)."""
    p = Gear(z=21, m_n=2.5, b=30, beta=18 * DEG, hand="right", a_pl=a_pl, rack=BasicRack(a_c=a_c), name="pinion")
    g = Gear(z=53, m_n=2.5, b=30, beta=18 * DEG, hand="left", name="gear")
    return GearPair(p, g)


def spur(a_c=0.0, a_pl=0.0) -> GearPair:
    """20/40, m 3 mm, b 20 mm (scene edge_spur_crossed)."""
    p = Gear(z=20, m_n=3.0, b=20, a_pl=a_pl, rack=BasicRack(a_c=a_c), name="pinion")
    return GearPair(p, Gear(z=40, m_n=3.0, b=20, name="gear"))


@functools.lru_cache(maxsize=None)
def edge(kind: str, a_c: float = 0.0, a_pl: float = 0.0, side: str = "right") -> EdgeContact:
    pair = helical(a_c, a_pl) if kind == "helical" else spur(a_c, a_pl)
    return EdgeContact(TCA(pair, side=side))


@functools.lru_cache(maxsize=None)
def sweep(kind, a_c=0.0, a_pl=0.0, side="right", crossing=0.0, intersecting=0.0, dE=0.0, span=1.5, n=121,
          centre=0.0):
    ec = edge(kind, a_c, a_pl, side)
    z1 = ec.tca.pair.pinion.z
    phi = centre + np.linspace(-span, span, n) * 2 * math.pi / z1
    mis = Misalignment(crossing=crossing, intersecting=intersecting, dE=dE)
    return ec.sweep(phi, mis=mis, pairs=PAIRS)


CROWNED = dict(kind="helical", a_c=0.0003, a_pl=0.0002)  # scene edge_crowned_tip
CROWNED_MIS = Misalignment(crossing=5 * ARCMIN)


# ------------------------------------------------------------------------------------------------
# Independent geometry and frames
# ------------------------------------------------------------------------------------------------
def inv(a):
    return math.tan(a) - a


def own(pair: GearPair) -> dict:
    """Gear-pair quantities from the textbook formulas (x = 0 here, a = a_0)."""
    out = {}
    for i, g in ((1, pair.pinion), (2, pair.gear)):
        al_t = math.atan(math.tan(g.rack.alpha_n) / math.cos(g.beta))
        m_t = g.m_n / math.cos(g.beta)
        r_p = m_t * g.z / 2
        out["alpha_t"] = al_t
        out[f"r_p{i}"], out[f"r_b{i}"] = r_p, r_p * math.cos(al_t)
        out[f"r_a{i}"] = r_p + g.m_n * (g.rack.h_aP + g.x)
        out[f"s_t{i}"] = m_t * (math.pi / 2 + 2 * g.x * math.tan(g.rack.alpha_n))
        out[f"b{i}"] = g.b
        # Start of the involute (end of the rack's straight flank, h_lim below the datum line).
        h = (g.rack.h_fP - g.rack.rho_fP * (1 - math.sin(g.rack.alpha_n)) - g.x) * g.m_n
        out[f"r_form{i}"] = math.hypot(r_p * math.cos(al_t), r_p * math.sin(al_t) - h / math.sin(al_t))
    E = out["r_p1"] + out["r_p2"]
    a = math.acos((out["r_b1"] + out["r_b2"]) / E)
    t = math.tan(pair.pinion.beta) * math.cos(out["alpha_t"])  # tan(beta_b)
    out.update(E=E, a=a, t=t, z1=pair.pinion.z, z2=pair.gear.z)
    # Active rectangle of the plane of action (s from T1): gear tip .. pinion tip.
    out["s_lo"] = E * math.sin(a) - math.sqrt(out["r_a2"] ** 2 - out["r_b2"] ** 2)
    out["s_hi"] = math.sqrt(out["r_a1"] ** 2 - out["r_b1"] ** 2)
    for i, z in ((1, pair.pinion.z), (2, pair.gear.z)):
        r_w = E * z / (pair.pinion.z + pair.gear.z) if i == 1 else E * pair.gear.z / (pair.pinion.z + pair.gear.z)
        a_r = math.acos(out[f"r_b{i}"] / r_w)
        s_w = 2 * r_w * (out[f"s_t{i}"] / (2 * out[f"r_p{i}"]) + inv(out["alpha_t"]) - inv(a_r))
        out[f"theta{i}"] = s_w / (2 * r_w)
    return out


class Frames:
    """Our own placement of both members in S_f (documented conventions, textbook thicknesses)."""

    def __init__(self, ec: EdgeContact, mis: Misalignment):
        self.ec, self.mis, self.g = ec, mis, own(ec.tca.pair)
        self.side = ec.tca.side
        self.sg = SGN[self.side]
        self.Rmis = Ry(mis.crossing) @ Rx(mis.intersecting)
        self.O2 = np.array([0.0, self.g["E"] + mis.dE, mis.axial])
        self.S = {1: ec.tca.pinion, 2: ec.tca.gear}

    def R1(self, phis):
        return Rz(self.sg * (self.g["theta1"] - phis))

    def R2(self, phi2):
        return self.Rmis @ Rz(self.sg * phi2) @ Rz(math.pi + self.sg * self.g["theta2"])

    def own_point(self, member, u, z):
        r, n, _ = self.S[member].point(self.side, "flank", u, z)
        return r, n

    def u_at(self, member, radius, z):
        return self.S[member].u_at_radius(radius, z, self.side)

    def phi2_through(self, rf1, r2):
        """Gear angle that brings the gear point r2 (own frame) onto rf1, and the mismatch [mm]."""
        v = Rz(math.pi + self.sg * self.g["theta2"]) @ r2
        w = self.Rmis.T @ (rf1 - self.O2)
        ang = math.atan2(w[1], w[0]) - math.atan2(v[1], v[0])
        phi2 = self.sg * math.remainder(ang, 2 * math.pi)
        mismatch = math.hypot(abs(w[2] - v[2]), math.hypot(w[0], w[1]) - math.hypot(v[0], v[1]))
        return phi2, mismatch


def reconstruct(fr: Frames, r, b, k, i):
    """The contact (b, k, i) of a sweep from its reported radii/z: points, normals, phi2, raw TE."""
    phis = r.phi1[i] - 2 * math.pi * r.pairs[k] / fr.g["z1"]
    u1 = fr.u_at(1, r.radius1[b, k, i], r.z1[b, k, i])
    u2 = fr.u_at(2, r.radius2[b, k, i], r.z2[b, k, i])
    r1, n1 = fr.own_point(1, u1, r.z1[b, k, i])
    r2, n2 = fr.own_point(2, u2, r.z2[b, k, i])
    R1 = fr.R1(phis)
    rf1 = R1 @ r1
    phi2, mismatch = fr.phi2_through(rf1, r2)
    R2 = fr.R2(phi2)
    te_raw = phi2 - fr.g["z1"] / fr.g["z2"] * phis
    return dict(u1=u1, u2=u2, z1=r.z1[b, k, i], z2=r.z2[b, k, i], phis=phis, R1=R1, R2=R2, rf1=rf1,
                rf2=fr.O2 + R2 @ r2, nf1=R1 @ n1, nf2=R2 @ n2, phi2=phi2, mismatch=mismatch, te_raw=te_raw)


def edge_tangent(fr: Frames, name: str, c: dict, h=1e-4):
    """Unit tangent of the boundary curve through the contact point, in S_f, by central differences
    along the curve (tip: the curve r = r_a parameterised by z; face end: z = +-b/2 by u)."""
    member = 1 if name.startswith("pinion") else 2
    z, u = (c["z1"], c["u1"]) if member == 1 else (c["z2"], c["u2"])
    R = c["R1"] if member == 1 else c["R2"]
    if name.endswith("tip"):
        ra = fr.g[f"r_a{member}"]
        pts = [fr.own_point(member, fr.u_at(member, ra, z + s * h), z + s * h)[0] for s in (1, -1)]
    else:
        pts = [fr.own_point(member, u + s * h, z)[0] for s in (1, -1)]
    t = R @ (pts[0] - pts[1]) / (2 * h)
    return t / np.linalg.norm(t)


def first_order_te(g: dict, gam: float, phi1, k: int):
    """Derivation B: first-order TE of pair k of an unmodified helical pair (up to a constant), and
    the z of the loaded end of the contact line (NaN where the pair is out of the active rectangle)."""
    rb1, rb2, a, t, b = g["r_b1"], g["r_b2"], g["a"], g["t"], g["b1"]
    sc = rb1 * math.tan(a) + rb1 * (np.asarray(phi1) - 2 * math.pi * k / g["z1"])
    zlo = np.maximum(-b / 2, (sc - g["s_hi"]) / t)
    zhi = np.minimum(b / 2, (sc - g["s_lo"]) / t)
    te_loc = lambda z: -(gam / rb2) * (math.cos(a) * z - t * ((sc - z * t) * math.cos(a) - rb1 * math.sin(a)))  # noqa: E731
    te = np.maximum(te_loc(zlo), te_loc(zhi))
    z_end = np.where(te_loc(zlo) >= te_loc(zhi), zlo, zhi)
    ok = zlo <= zhi
    return np.where(ok, te, np.nan), np.where(ok, z_end, np.nan)


def slopes(g, gam):
    """Derivation B: (face-end slope, tip-edge slope) [rad/rad]."""
    ratio = g["r_b1"] / g["r_b2"]
    return gam * g["t"] * math.cos(g["a"]) * ratio, -gam * math.cos(g["a"]) * ratio / g["t"]


def segment_slopes(r, name, k=K0):
    """Least-squares slopes of the valid runs of branch ``name`` of pair k (with the max residual)."""
    b = r.branches.index(name)
    v = r.valid[b, k]
    out = []
    idx = np.flatnonzero(v)
    for run in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
        if run.size >= 4:
            c = np.polyfit(r.phi1[run], r.te[b, k, run], 1)
            out.append((c[0], np.abs(np.polyval(c, r.phi1[run]) - r.te[b, k, run]).max()))
    return out


# ------------------------------------------------------------------------------------------------
# Surface contact solved exactly at a crossing of a flank boundary
# ------------------------------------------------------------------------------------------------
def surface_solve(ec: EdgeContact, mis, phi, w0):
    return ec.tca.solve_point(phi, w0, mis=mis)


def surface_radius(ec, w, member):
    tooth = ec.tca.pinion if member == 1 else ec.tca.gear
    u, z = (w[0], w[1]) if member == 1 else (w[2], w[3])
    r = tooth.point(ec.tca.side, "flank", u, z)[0]
    return math.hypot(r[0], r[1])


def boundary_crossing(ec, mis, r, member, ra):
    """phi1 where the surface contact of pair 0 reaches r_a of ``member`` (bracketed from the
    sweep's surface path, solved with brentq on exact surface solves), and the solution there."""
    rad = r.surface.radius1[K0] if member == 1 else r.surface.radius2[K0]
    conv = r.surface.converged[K0]
    f = np.where(conv, rad - ra, np.nan)
    sgn_change = np.flatnonzero(np.isfinite(f[:-1]) & np.isfinite(f[1:]) & (np.sign(f[:-1]) != np.sign(f[1:])))
    assert sgn_change.size == 1, "the surface path must cross the tip circle once"
    i = int(sgn_change[0])
    cache = {"w": np.array([r.surface.u1[K0, i], r.surface.z1[K0, i], r.surface.u2[K0, i], r.surface.z2[K0, i],
                            (r.surface.phi2[K0, i]) * ec.tca.scale2])}

    def g(phi):
        cache["w"] = surface_solve(ec, mis, phi, cache["w"])
        return surface_radius(ec, cache["w"], member) - ra

    phi_star = brentq(g, r.phi1[i], r.phi1[i + 1], xtol=1e-15, rtol=1e-15)
    w = surface_solve(ec, mis, phi_star, cache["w"])
    return phi_star, w, i


# ================================================================================================
# 1. Continuity of the surface branch and the pinion-tip edge branch (derivation A)
# ================================================================================================
@pytest.mark.slow
def test_surface_and_tip_edge_meet_continuously():
    ec = edge(**CROWNED)
    g = own(ec.tca.pair)
    r = sweep(**CROWNED, crossing=CROWNED_MIS.crossing)
    phi_s, w_s, i = boundary_crossing(ec, CROWNED_MIS, r, 1, g["r_a1"])
    # On the grid the surface branch is valid up to i and the tip branch takes over after.
    b_tip = r.branches.index("pinion_tip")
    assert r.valid[0, K0, i] and not r.valid[0, K0, i + 1]
    assert r.valid[b_tip, K0, i + 1] and not r.valid[b_tip, K0, i - 1]
    assert abs(surface_radius(ec, w_s, 1) - g["r_a1"]) < 1e-9
    # The edge system at phi1* is solved by the surface contact point.
    br = ec.branches["pinion_tip"]
    prm = ec.tca.prm([phi_s], mis=CROWNED_MIS)[:, 0]
    F = np.asarray(ec.residuals["pinion_tip"](w_s, prm)).ravel()
    assert np.abs(F).max() < 1e-9, F
    w_e = br.newton(w_s, prm)
    res, cone, reg, ok = br.check(w_e, prm)
    assert ok and res < 1e-10
    # Same contact point on both members (mm), same gear angle (r_p2 phi2 in mm).
    assert np.abs(w_e - w_s).max() < 1e-8, w_e - w_s
    # Equal slopes (C1): finite differences of both branches' solutions about phi1*.
    h = 2e-4
    te = {}
    for name, solve in (("surface", lambda p, w: surface_solve(ec, CROWNED_MIS, p, w)),
                        ("tip", lambda p, w: br.newton(w, ec.tca.prm([p], mis=CROWNED_MIS)[:, 0]))):
        te[name] = [solve(phi_s + s * h, w_s)[4] / ec.tca.scale2 - g["z1"] / g["z2"] * (phi_s + s * h)
                    for s in (-1, 1)]
    slope_s = (te["surface"][1] - te["surface"][0]) / (2 * h)
    slope_e = (te["tip"][1] - te["tip"][0]) / (2 * h)
    # central differences: error ~ h^2 TE'''/6 < 1e-9 here; slopes are ~ -4e-5 rad/rad
    assert abs(slope_s - slope_e) < 2e-3 * abs(slope_s) + 1e-9, (slope_s, slope_e)
    # The sweep (its combination and TE zero) agrees: put phi1* on the grid.
    phi = np.r_[np.linspace(phi_s - 0.05, phi_s, 11), np.linspace(phi_s, phi_s + 0.05, 11)[1:]]
    r2 = ec.sweep(phi, mis=CROWNED_MIS, pairs=PAIRS)
    j = 10
    assert r2.valid[0, K0, j] and r2.valid[b_tip, K0, j]
    assert abs(r2.te[0, K0, j] - r2.te[b_tip, K0, j]) < 1e-10
    for arr in (r2.z1, r2.radius1, r2.z2, r2.radius2):
        assert abs(arr[0, K0, j] - arr[b_tip, K0, j]) < 1e-7
    # ... and the grid TE of the tip branch leaves phi1* with the surface's slope (second order:
    # |TE''| h^2 / 2 with the tip branch's TE'' ~ 0.02 rad/rad^2 and h = 5 mrad -> 2.5e-7 rad).
    dphi = phi[j + 1] - phi[j]
    pred = r2.te[0, K0, j] + slope_s * dphi
    assert abs(r2.te[b_tip, K0, j + 1] - pred) < 0.02 * dphi**2 / 2 * 2


# ================================================================================================
# 2. The edge equations (9.6.1, 9.6.2) hold at the accepted edge points, recomputed independently
# ================================================================================================
CASES_EQ = {
    "crowned_tip": (CROWNED, CROWNED_MIS.crossing),
    "helical_+3": (dict(kind="helical"), 3 * ARCMIN),
    "helical_-3": (dict(kind="helical"), -3 * ARCMIN),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES_EQ))
def test_edge_equations_hold_independently(case):
    geo, gam = CASES_EQ[case]
    ec = edge(**geo)
    mis = Misalignment(crossing=gam)
    r = sweep(**geo, crossing=gam)
    fr = Frames(ec, mis)
    g = fr.g
    seen, ref = set(), []
    for b in range(1, len(r.branches)):
        name = r.branches[b]
        if "/" in name:
            continue  # edge on edge: tests/test_edge_grid.py
        member = 1 if name.startswith("pinion") else 2
        ks, iis = np.nonzero(r.valid[b])
        for k, i in list(zip(ks, iis))[::3]:
            seen.add(name)
            corner = "corner" in name  # a vertex: on both boundaries, no edge tangent (no eq. 9.6.2)
            # On the boundary (the engine's own radii/z of its solution).
            if name.endswith("tip") or corner:
                rad = r.radius1[b, k, i] if member == 1 else r.radius2[b, k, i]
                assert abs(rad - g[f"r_a{member}"]) < 1e-8, (name, rad)
            if not name.endswith("tip"):
                zz = r.z1[b, k, i] if member == 1 else r.z2[b, k, i]
                assert abs(zz - (1 if name.endswith("+") else -1) * g[f"b{member}"] / 2) < 1e-9, (name, zz)
            c = reconstruct(fr, r, b, k, i)
            # r_f1 = r_f2: the gear point can be turned onto the pinion point (own frames) ...
            assert c["mismatch"] < 1e-7, (name, c["mismatch"])
            assert np.linalg.norm(c["rf1"] - c["rf2"]) < 1e-7
            # ... and the edge tangent is orthogonal to the mating normal (eq. 9.6.2).
            if not corner:
                t = edge_tangent(fr, name, c)
                n_other = c["nf2"] if member == 1 else c["nf1"]
                assert abs(t @ n_other) < 2e-8, (name, t @ n_other)
            # the flanks face each other (the edge touches from outside, no crossing normals); at a
            # vertex the mating normal only has to lie in the vertex's normal cone
            assert c["nf1"] @ c["nf2"] < (0.0 if corner else -0.99)
            # the reported TE is phi2 - (z1/z2) phi1 with one zero for every branch and pair
            ref.append(c["te_raw"] - r.te[b, k, i])
    expected = {"crowned_tip": {"pinion_tip", "gear_tip"},
                "helical_+3": {"pinion_tip", "pinion_face-", "gear_face-"},
                "helical_-3": {"gear_tip", "pinion_face+", "gear_face+"}}[case]
    assert expected <= seen, seen
    assert np.ptp(ref) < 1e-9, np.ptp(ref)
    # Sensitivity of the tangency check: 0.5 mm along the edge the condition fails clearly.
    b = r.branches.index(sorted(expected)[0])
    k, i = next(zip(*np.nonzero(r.valid[b])))
    name = r.branches[b]
    c = reconstruct(fr, r, b, k, i)
    member = 1 if name.startswith("pinion") else 2
    cc = dict(c)
    if name.endswith("tip"):
        cc[f"z{member}"] = c[f"z{member}"] + 0.5
    else:
        cc[f"u{member}"] = c[f"u{member}"] + 0.5
    t_off = edge_tangent(fr, name, cc)
    assert abs(t_off @ (c["nf2"] if member == 1 else c["nf1"])) > 1e-6


# ================================================================================================
# 3. Aligned conjugate pairs: no edge contact, zero TE (also with a centre-distance change)
# ================================================================================================
@pytest.mark.parametrize("kind", ["spur", "helical"])
@pytest.mark.parametrize("dE", [0.0, 0.2])
def test_aligned_conjugate_pair_has_no_edge_contact(kind, dE):
    r = sweep(kind, dE=dE)
    assert not r.edge_contact()
    assert np.isfinite(r.te_envelope).all()
    assert np.abs(r.te_envelope).max() < 1e-9
    assert (r.active == 0).all()  # the surface (line contact) carries everywhere


# ================================================================================================
# 4. First-order TE slopes of an unmodified helical pair under a crossing angle (derivation B)
# ================================================================================================
@pytest.mark.slow
def test_helical_crossing_te_slopes_first_order():
    ec = edge("helical")
    g = own(ec.tca.pair)
    found = {}
    for gam_min in (3.0, 6.0):
        gam = gam_min * ARCMIN
        r = sweep("helical", crossing=gam)
        s_face, s_tip = slopes(g, gam)
        for name, pred in (("pinion_face-", s_face), ("gear_face-", s_face), ("pinion_tip", s_tip)):
            segs = segment_slopes(r, name)
            assert segs, name
            for s, dev in segs:
                # linear per segment: the fit residual is < 0.5 % of the TE change over a pitch
                assert dev < 5e-3 * abs(s) * 2 * math.pi / g["z1"], (name, dev)
                assert abs(s / pred - 1) < 0.01, (name, gam_min, s, pred)
                found[(name, gam_min)] = s
        # the transfers' slopes too (face-end -> face-end transfers between pairs)
        ff = [t for t in r.transfers if all("face" in t[e]["branch"] and "/" not in t[e]["branch"] for e in ("from", "to"))]
        assert ff
        for t in ff:
            assert abs(t["slope_before"] / s_face - 1) < 0.01 and abs(t["slope_after"] / s_face - 1) < 0.01
        # the per-pair TE follows the first-order model on the face-end segments (up to the constant)
        pred = np.array([first_order_te(g, gam, r.phi1, k)[0] for k in r.pairs])
        face = np.zeros_like(r.te_pair, bool)
        for b, name in enumerate(r.branches):
            if "face" in name and "/" not in name:
                face |= (r.branch == b)
        d = (r.te_pair - pred)[face]
        pp = np.nanmax(np.nanmax(pred, axis=0)) - np.nanmin(np.nanmax(pred, axis=0))
        assert np.ptp(d) < 0.01 * pp, (np.ptp(d) * AS, pp * AS)
    # linear in the misalignment: doubling the angle doubles the slopes
    for name in ("pinion_face-", "gear_face-", "pinion_tip"):
        assert abs(found[(name, 6.0)] / found[(name, 3.0)] - 2) < 0.01 * 2, name


# ================================================================================================
# 5. Symmetries (derivation C)
# ================================================================================================
def _swap(name):
    return name.replace("+", "#").replace("-", "+").replace("#", "-")


@pytest.mark.slow
@pytest.mark.parametrize("kind, a_c, a_pl, mis", [
    ("spur", 0.0, 0.0, dict(crossing=3 * ARCMIN)),
    ("spur", 0.0003, 0.0002, dict(crossing=5 * ARCMIN)),
    ("spur", 0.0003, 0.0002, dict(intersecting=5 * ARCMIN)),
    ("helical", 0.0, 0.0, dict(crossing=3 * ARCMIN)),
])
def test_left_and_right_flanks_give_the_same_te(kind, a_c, a_pl, mis):
    """Turning the drive by pi about y_f swaps the flanks and the face ends (crossing invariant;
    intersecting changes sign, and for spur gears the mirror z -> -z changes it back)."""
    rr = sweep(kind, a_c, a_pl, "right", **mis)
    rl = sweep(kind, a_c, a_pl, "left", **mis)
    assert np.isfinite(rr.te_envelope).all()
    assert np.nanmax(np.abs(rr.te_envelope - rl.te_envelope)) < 1e-12
    assert rr.peak_to_peak > (1e-7 if a_c else 1e-9)  # a non-trivial TE
    names_r = [rr.branches[a] for a in rr.active]
    names_l = [rl.branches[a] for a in rl.active]
    assert names_l == [_swap(n) for n in names_r]
    if kind == "spur" and "crossing" in mis:  # z -> -z: the crossing angle changes sign
        rm = sweep(kind, a_c, a_pl, "right", crossing=-mis["crossing"])
        assert np.nanmax(np.abs(rr.te_envelope - rm.te_envelope)) < 1e-12
        assert [rm.branches[a] for a in rm.active] == [_swap(n) for n in names_r]


def test_crossing_sign_mirrors_helical_te():
    ec = edge("helical")
    g = own(ec.tca.pair)
    gam = 3 * ARCMIN
    # mid mesh of pair 0: s_c = (s_lo + s_hi) / 2
    phi_m = ((g["s_lo"] + g["s_hi"]) / 2 - g["r_b1"] * math.tan(g["a"])) / g["r_b1"]
    rp = sweep("helical", crossing=gam, centre=phi_m)
    rm = sweep("helical", crossing=-gam, centre=phi_m)
    assert np.allclose(rp.phi1 + rp.phi1[::-1], 2 * phi_m)
    # The loaded face end switches from z = -b/2 (g > 0) to +b/2 (g < 0), the tip from pinion to gear.
    for r, sign, tip in ((rp, -1, "pinion_tip"), (rm, 1, "gear_tip")):
        names = {r.branches[a] for a in r.active}
        assert tip in names and ("pinion_tip" if tip == "gear_tip" else "gear_tip") not in names
        for b, name in enumerate(r.branches):
            if "face" in name and "/" not in name:
                on = r.active == b
                if on.any():
                    assert name.endswith("+" if sign > 0 else "-")
                    d = r.driving[on]
                    assert np.allclose(r.z1[b, d, np.flatnonzero(on)], sign * g["b1"] / 2, atol=0.02)
        # and the first-order model predicts the same end for pair 0 where a face end carries it
        zp = first_order_te(g, gam if r is rp else -gam, r.phi1, 0)[1]
        fb = [b for b, n in enumerate(r.branches) if "face" in n and "/" not in n]
        onf = np.isin(r.branch[K0], fb)
        assert onf.any() and np.allclose(zp[onf], sign * g["b1"] / 2)
    # TE(phi; -g) = TE(2 phi_m - phi; +g) + const, per pair 0 where both are valid (first order:
    # the face-end segments agree to < 1 % of the peak-to-peak; the tip segments carry the second-order
    # shift of the tip contact point, ~6 % here, see derivation B).
    a, bb = rm.te_pair[K0], rp.te_pair[K0][::-1]
    both = np.isfinite(a) & np.isfinite(bb)
    face_m = np.isin(rm.branch[K0], [b for b, n in enumerate(rm.branches) if "face" in n and "/" not in n])
    face_p = np.isin(rp.branch[K0][::-1], [b for b, n in enumerate(rp.branches) if "face" in n and "/" not in n])
    sel = both & face_m & face_p
    assert sel.sum() > 20
    d = a[sel] - bb[sel]
    pp = rp.peak_to_peak
    assert np.ptp(d) < 0.01 * pp, (np.ptp(d) * AS, pp * AS)
    # (where pair 0 is in the active rectangle to first order: outside it the pair's own TE is set by
    # corners and crossing edges, to second order, and never carries the load)
    inside = both & np.isfinite(first_order_te(g, -gam, rm.phi1, 0)[0])
    d_all = a[inside] - bb[inside] - np.median(d)
    assert np.abs(d_all).max() < 0.1 * pp
    assert abs(rm.peak_to_peak / pp - 1) < 0.1


# ================================================================================================
# 6. Edge contact avoided by enough profile crowning (derivation D)
# ================================================================================================
def _tip_share(r):
    """Length of phi1 per pinion pitch in which the pinion tip edge carries the load."""
    b = r.branches.index("pinion_tip")
    span = r.phi1[-1] - r.phi1[0]
    return np.sum(r.active == b) * (r.phi1[1] - r.phi1[0]) * (2 * math.pi / 21) / span


def _predicted_transfer(r, ra1):
    """Derivation D from the surface TCA alone: parabola + line fit of pair 0's surface TE, the
    crossing apex + pi/z1 with the next pair, and the surface contact radius there."""
    s = r.surface
    on = s.on_surface[K0]
    c = np.polyfit(r.phi1[on], s.te[K0][on], 2)
    fit_err = np.abs(np.polyval(c, r.phi1[on]) - s.te[K0][on]).max()
    phi_t = -c[1] / (2 * c[0]) + math.pi / 21
    return phi_t, float(np.interp(phi_t, r.phi1, s.radius1[K0])), fit_err, c


@pytest.mark.slow
def test_crowning_avoids_edge_contact():
    g = own(helical())
    shares = []
    for a_c in (0.0003, 0.0004, 0.0005, 0.0006):
        r = sweep("helical", a_c, 0.0002, crossing=5 * ARCMIN, span=1.0, n=241)
        shares.append(_tip_share(r))
        if a_c == 0.0003:
            assert r.edge_contact() and shares[-1] > 0
            phi_t, rad_t, fit_err, c = _predicted_transfer(r, g["r_a1"])
            assert fit_err < 0.03 * abs(c[0]) * (math.pi / 21) ** 2  # a parabola indeed
            assert rad_t > g["r_a1"] + 0.5  # the transfer point would lie beyond the tip
            # pair 0's tip edge carries the load after its surface contact has left the flank (B',
            # where the surface path crosses r_a1) and before that predicted transfer
            b = r.branches.index("pinion_tip")
            conv = r.surface.converged[K0] & (r.phi1 > 0)
            phi_b = np.interp(g["r_a1"], r.surface.radius1[K0][conv], r.phi1[conv])
            on = r.phi1[(r.active == b) & (r.driving == K0)]
            assert on.size >= 5
            assert phi_b <= on.min() <= phi_b + (r.phi1[1] - r.phi1[0]) and on.max() < phi_t
    assert all(x > y for x, y in zip(shares[:3], shares[1:]))  # shrinks monotonically
    assert shares[-1] == 0.0
    # The scene edge_crowned_avoided (a_c = 0.001): transfers stay on the flanks.
    r = sweep("helical", 0.001, 0.0002, crossing=5 * ARCMIN, span=1.0, n=241)
    assert not r.edge_contact() and (r.active == 0).all()
    phi_t, rad_t, fit_err, c = _predicted_transfer(r, g["r_a1"])
    assert rad_t < g["r_a1"] - 0.3
    assert r.transfers
    for t in r.transfers:
        assert t["from"]["branch"] == t["to"]["branch"] == "surface"
        i = int(np.searchsorted(r.phi1, t["phi1"]))
        for pair, j in ((t["from"]["pair"], i - 1), (t["to"]["pair"], i)):
            k = r.pairs.index(pair)
            assert r.radius1[0, k, j] <= g["r_a1"] and r.radius2[0, k, j] <= g["r_a2"]
            assert abs(r.z1[0, k, j]) <= g["b1"] / 2
        # at the predicted crossing of two neighbouring parabolas (mod one pitch)
        d = math.remainder(t["phi1"] - phi_t, 2 * math.pi / 21)
        assert abs(d) < 2 * (r.phi1[1] - r.phi1[0]), (t["phi1"], phi_t)


# ================================================================================================
# 7. Interval of surface contact (eq. 9.6.3)
# ================================================================================================
def test_surface_contact_interval():
    ec = edge(**CROWNED)
    g = own(ec.tca.pair)
    r = sweep(**CROWNED, crossing=CROWNED_MIS.crossing)
    surf = [iv for iv in r.intervals if iv["branch"] == "surface"]
    assert len(surf) == 1
    p0, p1 = surf[0]["phi1_start"], surf[0]["phi1_end"]
    # A': the surface contact reaches the gear tip, B': the pinion tip (exact solves)
    phi_a, _, ia = boundary_crossing(ec, CROWNED_MIS, r, 2, g["r_a2"])
    phi_b, _, ib = boundary_crossing(ec, CROWNED_MIS, r, 1, g["r_a1"])
    assert r.phi1[ia] < phi_a <= p0 == r.phi1[ia + 1]
    assert r.phi1[ib] == p1 <= phi_b < r.phi1[ib + 1]
    # surface contact exactly where the contact point lies on both active flanks (own bounds)
    on = (r.converged[0, K0] & (r.radius1[0, K0] <= g["r_a1"]) & (r.radius2[0, K0] <= g["r_a2"])
          & (r.radius1[0, K0] >= g["r_form1"]) & (r.radius2[0, K0] >= g["r_form2"])
          & (np.abs(r.z1[0, K0]) <= g["b1"] / 2) & (np.abs(r.z2[0, K0]) <= g["b2"] / 2))
    inside = (r.phi1 >= p0) & (r.phi1 <= p1)
    assert np.array_equal(on, inside)
    assert (r.branch[K0][inside] == 0).all()
    # the form radii do not bind here (the tips do: A' and B' above; the pinion's path starts
    # ~0.1 mm above its form radius, the gear's ~0.4 mm)
    assert r.radius1[0, K0][inside].min() > g["r_form1"] + 0.05
    assert r.radius2[0, K0][inside].min() > g["r_form2"] + 0.05
    # before A' the gear tip edge, after B' the pinion tip edge carries the pair
    names = [r.branches[b] if b >= 0 else None for b in r.branch[K0]]
    assert names[ia] == "gear_tip" and names[ib + 1] == "pinion_tip"
    # and the surface TE matches the surface TCA's TE where the interval holds
    assert np.allclose(r.te[0, K0][inside], r.surface.te[K0][inside], atol=1e-12)


# ================================================================================================
# 8. The corner of two edges (pinion tip and face end) is a contact too
# ================================================================================================
def test_corner_contact_between_face_end_and_tip():
    ec = edge("helical")
    gam = 3 * ARCMIN
    mis = Misalignment(crossing=gam)
    g = own(ec.tca.pair)
    # First order: the contact line of pair 0 passes the corner (s_hi, -b/2) at phi_c.
    phi_c = (g["s_hi"] - g["b1"] / 2 * g["t"] - g["r_b1"] * math.tan(g["a"])) / g["r_b1"]
    phi = phi_c + np.linspace(-0.03, 0.03, 25)
    r = ec.sweep(phi, mis=mis, pairs=PAIRS)
    fr = Frames(ec, mis)
    bf = r.branches.index("pinion_face-")
    jf = np.flatnonzero(r.valid[bf, K0])[-1]  # last face-end contact of pair 0 before the corner
    c = reconstruct(fr, r, bf, K0, jf)
    ref = c["te_raw"] - r.te[bf, K0, jf]
    # corner point of pinion tooth 0: r = r_a1 on the face end z = -b/2
    u_c = fr.u_at(1, g["r_a1"], -g["b1"] / 2)
    r1c = fr.own_point(1, u_c, -g["b1"] / 2)[0]
    x = np.array([c["u2"], c["z2"], c["phi2"]])
    worst = 0.0
    for j in range(jf + 1, len(phi)):
        bt = r.branches.index("pinion_tip")
        if r.valid[bt, K0, j]:
            break
        rf1 = fr.R1(phi[j]) @ r1c

        def F(y):
            r2 = fr.own_point(2, y[0], y[1])[0]
            return fr.O2 + fr.R2(y[2]) @ r2 - rf1

        x = fsolve(F, x, xtol=1e-13)
        assert np.linalg.norm(F(x)) < 1e-8
        te_corner = x[2] - g["z1"] / g["z2"] * phi[j] - ref
        # the corner touches the gear flank there, so the gear is at least that far ahead
        worst = max(worst, te_corner - np.nan_to_num(r.te_envelope[j], nan=-np.inf))
    assert worst < 1e-9, f"envelope below the corner contact by {worst * AS:.3f} arcsec"
