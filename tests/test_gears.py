"""Tests of gearopt.gears (BasicRack, Gear, GearPair) against formulas and geometric constructions
written out independently here (docs/theory.md section 3; ISO 21771 / ISO 53). Lengths in mm, angles in rad."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from scipy.optimize import brentq

from gearopt import BasicRack, Gear, GearPair
from gearopt.errors import GearoptError, GeometryError

DEG = math.pi / 180


def _inv(a: float) -> float:
    return math.tan(a) - a


# ------------------------------------------------------------------------------------------------
# independent reference computations
# ------------------------------------------------------------------------------------------------

def _ref_geometry(z, m_n, x, beta=0.0, alpha_n=20 * DEG, h_aP=1.0, k=0.0):
    """(r_p, r_b, r_a, alpha_t, m_t) of a gear from textbook relations."""
    m_t = m_n / math.cos(beta)
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    r_p = z * m_t / 2
    return r_p, r_p * math.cos(alpha_t), r_p + m_n * (h_aP + x + k), alpha_t, m_t


def _ref_alpha_w(z1, z2, x1, x2, alpha_n, alpha_t):
    """Working pressure angle from inv(alpha_w) = inv(alpha_t) + 2 tan(alpha_n) (x1+x2)/(z1+z2) by brentq."""
    rhs = _inv(alpha_t) + 2 * math.tan(alpha_n) * (x1 + x2) / (z1 + z2)
    return brentq(lambda a: _inv(a) - rhs, 1e-6, 80 * DEG, xtol=1e-15, rtol=1e-15)


def _ref_pair(z1, z2, x1, x2, m_n=2.0, beta=0.0, alpha_n=20 * DEG, a=None):
    """Reference centre distance, working angle and the contact ratio of docs/theory.md section 3.3."""
    r_p1, r_b1, r_a1, alpha_t, m_t = _ref_geometry(z1, m_n, x1, beta, alpha_n)
    r_p2, r_b2, r_a2, _, _ = _ref_geometry(z2, m_n, x2, beta, alpha_n)
    alpha_w = _ref_alpha_w(z1, z2, x1, x2, alpha_n, alpha_t)
    a_0 = (r_p1 + r_p2) * math.cos(alpha_t) / math.cos(alpha_w)
    E = a_0 if a is None else a
    alpha_w = math.acos((r_b1 + r_b2) / E)
    # docs/theory.md section 3.3, with transverse module and pressure angle for helical gears
    eps = (math.sqrt(r_a1**2 - r_b1**2) + math.sqrt(r_a2**2 - r_b2**2) - E * math.sin(alpha_w)) / (
        math.pi * m_t * math.cos(alpha_t))
    return dict(a_0=a_0, E=E, alpha_w=alpha_w, eps=eps, r_b1=r_b1, r_b2=r_b2, r_a1=r_a1, r_a2=r_a2,
                p_b=math.pi * m_t * math.cos(alpha_t))


def _path_of_contact_geometric(r_b1, r_b2, r_a1, r_a2, E):
    """Length of the path of contact: the part of the common internal tangent of the base circles
    (centres O1 = (0, 0), O2 = (E, 0)) that lies inside both tip circles, by line-circle intersection."""
    O1, O2 = np.zeros(2), np.array([E, 0.0])
    # tangency points: O1T1 and O2T2 antiparallel, perpendicular to T1T2 -> cos(phi) = (r_b1 + r_b2) / E
    phi = math.acos((r_b1 + r_b2) / E)
    u = np.array([math.cos(phi), math.sin(phi)])
    T1, T2 = O1 + r_b1 * u, O2 - r_b2 * u
    d = (T2 - T1) / np.linalg.norm(T2 - T1)
    L = np.linalg.norm(T2 - T1)

    def hits(centre, radius):
        # |T1 + t d - centre| = radius
        w = T1 - centre
        bq, cq = 2 * w @ d, w @ w - radius**2
        disc = math.sqrt(bq * bq - 4 * cq)
        return (-bq - disc) / 2, (-bq + disc) / 2

    t_start = hits(O2, r_a2)[0]  # gear tip circle, entering near T1
    t_end = hits(O1, r_a1)[1]    # pinion tip circle, leaving near T2
    assert 0 <= t_start < t_end <= L  # both ends on the line of action between the tangency points
    return t_end - t_start


PAIRS = [
    # z1, z2, x1, x2, m_n, beta_deg
    (20, 40, 0.0, 0.0, 2.0, 0.0),
    (18, 31, 0.3, -0.1, 3.0, 0.0),
    (25, 60, 0.2, 0.25, 1.5, 0.0),
    (21, 47, 0.0, 0.0, 2.5, 15.0),
    (19, 53, 0.35, 0.15, 4.0, 22.0),
]


def _make_pair(z1, z2, x1, x2, m_n, beta_deg, a=None, b=30.0):
    beta = beta_deg * DEG
    p = Gear(z=z1, m_n=m_n, x=x1, beta=beta, hand="right", b=b, name="pinion")
    g = Gear(z=z2, m_n=m_n, x=x2, beta=beta, hand="left", b=b, name="gear")
    return GearPair(p, g, a=a)


# ------------------------------------------------------------------------------------------------
# basic rack
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("profile, h_fP, rho_fP", [("A", 1.25, 0.38), ("B", 1.25, 0.30), ("C", 1.25, 0.25),
                                                  ("D", 1.40, 0.39)])
def test_iso53_presets(profile, h_fP, rho_fP):
    r = BasicRack.iso53(profile)
    assert r.alpha_n == pytest.approx(20 * DEG, rel=1e-15)
    assert r.h_aP == 1.0
    assert r.h_fP == h_fP
    assert r.rho_fP == rho_fP
    assert r.c_P == pytest.approx(h_fP - 1.0, abs=1e-15)
    assert r.name == f"ISO 53 {profile}"
    assert BasicRack.iso53(profile.lower()) == r
    assert BasicRack.iso53(profile, rho_fP=0.2).rho_fP == 0.2
    with pytest.raises(GeometryError, match="rack.preset"):
        BasicRack.iso53("E")


def test_default_rack_is_iso53_A_and_h_lim_is_one():
    r = BasicRack()
    assert (r.alpha_n, r.h_aP, r.h_fP, r.rho_fP) == (BasicRack.iso53("A").alpha_n, 1.0, 1.25, 0.38)
    assert r.h_lim == pytest.approx(1.0, abs=1e-4)  # 1.25 - 0.38 (1 - sin 20 deg) = 0.99997


def _tool_fillet_geometry(alpha, h_fP, rho):
    """Rack-cutter tooth (normal section, units of m_n): datum line at depth 0, the tooth centre line at
    x = 0, half width pi/4 at the datum, flanks narrowing by tan(alpha) per unit depth towards the tool
    tip at depth h_fP. Returns (depth of the flank/fillet tangency point, x of the fillet centre)."""
    # flank line: points (pi/4 - d tan(alpha), d); unit direction along increasing depth
    p0 = np.array([math.pi / 4, 0.0])
    t = np.array([-math.sin(alpha), math.cos(alpha)])
    n_in = np.array([-math.cos(alpha), -math.sin(alpha)])  # towards the tooth inside
    # fillet centre: distance rho from the tip line (depth h_fP - rho) and from the flank (inside)
    d_c = h_fP - rho
    # centre = p0 + s t + rho n_in with depth d_c
    s = (d_c - rho * n_in[1]) / t[1]
    centre = p0 + s * t + rho * n_in
    foot = p0 + s * t  # foot of the perpendicular from the centre on the flank
    return foot[1], centre[0]


@pytest.mark.parametrize("alpha_deg, h_fP, rho", [(20, 1.25, 0.38), (20, 1.4, 0.39), (14.5, 1.25, 0.3),
                                                 (25, 1.25, 0.2), (20, 1.25, 0.0)])
def test_h_lim_and_rho_max_against_tool_geometry(alpha_deg, h_fP, rho):
    rack = BasicRack(alpha_n=alpha_deg * DEG, h_fP=h_fP, rho_fP=rho)
    depth, _ = _tool_fillet_geometry(rack.alpha_n, h_fP, rho)
    assert rack.h_lim == pytest.approx(depth, rel=1e-14)
    # rho_max: the two tip fillets meet on the tooth centre line (fillet centre at x = 0)
    _, x_c = _tool_fillet_geometry(rack.alpha_n, h_fP, rack.rho_max)
    assert x_c == pytest.approx(0.0, abs=1e-14)
    BasicRack(alpha_n=rack.alpha_n, h_fP=h_fP, rho_fP=rack.rho_max)  # accepted at the limit
    with pytest.raises(GeometryError, match="rho_fP"):
        BasicRack(alpha_n=rack.alpha_n, h_fP=h_fP, rho_fP=rack.rho_max * 1.001)


# ------------------------------------------------------------------------------------------------
# gear: radii, thickness, undercut, pointed tip
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("z, m_n, x, beta_deg, k", [(20, 2.0, 0.0, 0.0, 0.0), (13, 3.0, 0.45, 0.0, -0.05),
                                                    (31, 1.25, -0.2, 18.0, 0.0), (24, 5.0, 0.3, 30.0, 0.1)])
def test_gear_radii_and_thickness(z, m_n, x, beta_deg, k):
    beta = beta_deg * DEG
    g = Gear(z=z, m_n=m_n, x=x, beta=beta, k=k, hand="left")
    r_p, r_b, r_a, alpha_t, m_t = _ref_geometry(z, m_n, x, beta, k=k)
    assert g.r_p == pytest.approx(r_p, rel=1e-15)
    assert g.r_b == pytest.approx(r_b, rel=1e-15)
    assert g.r_a == pytest.approx(r_a, rel=1e-15)
    assert g.r_f == pytest.approx(r_p - m_n * (1.25 - x), rel=1e-15)
    assert g.m_t == pytest.approx(m_t, rel=1e-15)
    assert g.alpha_t == pytest.approx(alpha_t, rel=1e-15)
    assert math.tan(g.beta_b) == pytest.approx(math.tan(beta) * r_b / r_p, rel=1e-14, abs=1e-300)
    assert g.p_bt == pytest.approx(2 * math.pi * r_b / z, rel=1e-14)
    # normal arc thickness of the rack-generated tooth on the reference cylinder: m_n (pi/2 + 2 x tan alpha_n);
    # the transverse one is that divided by cos(beta)
    s_n = m_n * (math.pi / 2 + 2 * x * math.tan(20 * DEG))
    assert g.s_t == pytest.approx(s_n / math.cos(beta), rel=1e-14)
    assert g.s_at(g.r_p) == pytest.approx(g.s_t, rel=1e-14)
    # at the base circle: s_b = s_t r_b / r_p + 2 r_b inv(alpha_t)
    assert g.s_at(g.r_b) == pytest.approx(g.s_t * r_b / r_p + 2 * r_b * _inv(alpha_t), rel=1e-13)
    with pytest.raises(GeometryError, match="r_b"):
        g.s_at(0.99 * g.r_b)
    assert g.is_spur == (beta_deg == 0)
    assert g.helix_sign == (0 if beta_deg == 0 else -1)


def test_from_diametral_pitch():
    g = Gear.from_diametral_pitch(24, 8.0)
    assert g.m_n == pytest.approx(25.4 / 8)
    with pytest.raises(GeometryError, match="P_n"):
        Gear.from_diametral_pitch(24, 0.0)


def _rack_h1(alpha_deg: float) -> BasicRack:
    """A rack with h_lim = 1 exactly (h_fP = 1.25, tip radius 0.25 / (1 - sin alpha), or a sharp tip
    with h_fP = 1 when that radius does not fit)."""
    a = alpha_deg * DEG
    rho = 0.25 / (1 - math.sin(a))
    probe = BasicRack(alpha_n=a, h_fP=1.25, rho_fP=0.0)
    if rho <= probe.rho_max:
        return BasicRack(alpha_n=a, h_fP=1.25, rho_fP=rho)
    return BasicRack(alpha_n=a, h_fP=1.0, rho_fP=0.0)


@pytest.mark.parametrize("alpha_deg, n_min", [(14.5, 31.9), (20, 17.1), (25, 11.2)])
def test_minimum_teeth_without_undercut(alpha_deg, n_min):
    rack = _rack_h1(alpha_deg)
    assert rack.h_lim == pytest.approx(1.0, rel=1e-14)
    a = alpha_deg * DEG
    z = int(math.floor(n_min))  # just below N_min
    g_ok = Gear(z=z + 1, m_n=2.0, rack=rack)
    assert g_ok.z_min_undercut == pytest.approx(2 / math.sin(a) ** 2, rel=1e-14)
    assert g_ok.z_min_undercut == pytest.approx(n_min, abs=0.05)
    assert not g_ok.undercut
    # below N_min without shift: undercut -> error unless allowed
    with pytest.raises(GeometryError) as exc:
        Gear(z=z, m_n=2.0, rack=rack, name="pinion")
    msg = str(exc.value)
    assert "pinion.x" in msg and "valid" in msg and "allow_undercut" in msg
    g_u = Gear(z=z, m_n=2.0, rack=rack, allow_undercut=True)
    assert g_u.undercut
    # x_min = h_lim - z sin^2(alpha) / 2, and with x = x_min the gear is accepted
    x_min = 1.0 - z * math.sin(a) ** 2 / 2
    assert g_u.x_min_undercut == pytest.approx(x_min, rel=1e-13)
    g_x = Gear(z=z, m_n=2.0, rack=rack, x=x_min)
    assert not g_x.undercut or g_x.x == pytest.approx(g_x.x_min_undercut, abs=1e-15)
    # at x_min the involute reaches exactly down to the base circle (tool flank end at the interference point)
    assert g_x.r_lim == pytest.approx(g_x.r_b, rel=1e-12)


def test_undercut_helical_condition_geometric():
    """Helical: the tool flank end must not pass the interference point in the transverse section,
    whose depth below the pitch line is r_p - r_b cos(alpha_t)."""
    rack = BasicRack.iso53("A")
    beta = 25 * DEG
    g = Gear(z=14, m_n=2.0, beta=beta, x=0.5, rack=rack)
    depth_T = g.r_p - g.r_b * math.cos(g.alpha_t)
    x_lim = rack.h_lim - depth_T / g.m_n
    assert g.x_min_undercut == pytest.approx(x_lim, rel=1e-13)
    assert g.z_min_undercut == pytest.approx(g.z * rack.h_lim / (depth_T / g.m_n), rel=1e-13)


@pytest.mark.parametrize("x", [-0.3, 0.0, 0.4, 1.3])
def test_r_lim_against_line_of_action_construction(x):
    """The flank end (h below the pitch line) generates the point where it crosses the line of action."""
    g = Gear(z=30, m_n=2.0, x=x, allow_undercut=True)
    h = (g.rack.h_lim - x) * g.m_n
    P = np.array([0.0, g.r_p])
    T = g.r_b * np.array([math.sin(g.alpha_t), math.cos(g.alpha_t)])
    u = (T - P) / np.linalg.norm(T - P)
    Q = P + (h / -u[1]) * u  # the point of the line of action h below the pitch line
    assert Q[1] == pytest.approx(g.r_p - h, abs=1e-12)
    assert g.r_lim == pytest.approx(np.linalg.norm(Q), rel=1e-14)


def test_pointed_tip_limit():
    g = Gear(z=12, m_n=2.0, x=0.3)
    r_p, r_b, _, alpha_t, m_t = _ref_geometry(12, 2.0, 0.0)

    def s_a(x):  # independent tip thickness
        r_a = r_p + 2.0 * (1 + x)
        s_p = m_t * (math.pi / 2 + 2 * x * math.tan(20 * DEG))
        alpha_a = math.acos(r_b / r_a)
        return 2 * r_a * (s_p / (2 * r_p) + _inv(alpha_t) - _inv(alpha_a))

    x_pointed = brentq(s_a, 0.0, 3.0, xtol=1e-14)
    assert g.x_max_pointed == pytest.approx(x_pointed, abs=1e-9)
    assert g.s_at(g.r_a) == pytest.approx(s_a(0.3), rel=1e-12)
    Gear(z=12, m_n=2.0, x=x_pointed - 1e-6)
    with pytest.raises(GeometryError, match=r"pointed"):
        Gear(z=12, m_n=2.0, x=x_pointed + 1e-6)


# ------------------------------------------------------------------------------------------------
# pair: centre distance, backlash, contact ratio
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("case", PAIRS)
def test_centre_distance_a0(case):
    z1, z2, x1, x2, m_n, beta_deg = case
    pair = _make_pair(*case)
    ref = _ref_pair(z1, z2, x1, x2, m_n, beta_deg * DEG)
    assert pair.a_0 == pytest.approx(ref["a_0"], rel=1e-13)
    assert pair.a_w == pair.a_0
    assert pair.alpha_wt == pytest.approx(ref["alpha_w"], rel=1e-12)
    if x1 + x2 == 0:
        assert pair.a_0 == pytest.approx((z1 + z2) * m_n / (2 * math.cos(beta_deg * DEG)), rel=1e-14)
    assert pair.ratio == z2 / z1


@pytest.mark.parametrize("case", PAIRS)
def test_backlash_zero_at_a0_and_grows_with_a(case):
    pair = _make_pair(*case)
    assert pair.backlash == pytest.approx(0.0, abs=1e-11 * pair.a_0)
    for da in (1e-5, 1e-3):
        wider = GearPair(pair.pinion, pair.gear, a=pair.a_0 + da)
        assert wider.backlash > 0
        # first order: j_t = 2 (a - a_0) tan(alpha_wt)
        assert wider.backlash == pytest.approx(2 * da * math.tan(pair.alpha_wt), rel=5 * da)
    wide = GearPair(pair.pinion, pair.gear, a=pair.a_0 + 0.5)
    assert wide.backlash > GearPair(pair.pinion, pair.gear, a=pair.a_0 + 0.25).backlash > 0


@pytest.mark.parametrize("case", PAIRS)
def test_contact_ratio_formula_and_geometry(case):
    z1, z2, x1, x2, m_n, beta_deg = case
    for extra in (0.0, 0.3 * m_n):
        ref0 = _ref_pair(z1, z2, x1, x2, m_n, beta_deg * DEG)
        a = None if extra == 0 else ref0["a_0"] + extra
        pair = _make_pair(*case, a=a)
        ref = _ref_pair(z1, z2, x1, x2, m_n, beta_deg * DEG, a=a)
        assert pair.eps_alpha == pytest.approx(ref["eps"], rel=1e-12)
        L = _path_of_contact_geometric(ref["r_b1"], ref["r_b2"], ref["r_a1"], ref["r_a2"], ref["E"])
        assert pair.eps_alpha == pytest.approx(L / ref["p_b"], rel=1e-12)
    # standard value for 20/40, x = 0, ISO 53 (textbook: 1.64)
    if case[:4] == (20, 40, 0.0, 0.0):
        assert _make_pair(*case).eps_alpha == pytest.approx(1.635, abs=0.005)


def test_overlap_and_total_contact_ratio():
    pair = _make_pair(21, 47, 0.0, 0.0, 2.5, 15.0, b=40.0)
    assert pair.eps_beta == pytest.approx(40.0 * math.sin(15 * DEG) / (math.pi * 2.5), rel=1e-14)
    assert pair.eps_gamma == pytest.approx(pair.eps_alpha + pair.eps_beta, rel=1e-15)
    spur = _make_pair(20, 40, 0.0, 0.0, 2.0, 0.0)
    assert spur.eps_beta == 0.0


def test_tip_clearance():
    pair = _make_pair(20, 40, 0.0, 0.0, 2.0, 0.0)
    assert pair.tip_clearance == pytest.approx((0.25 * 2.0, 0.25 * 2.0), rel=1e-12)


# ------------------------------------------------------------------------------------------------
# invalid input table
# ------------------------------------------------------------------------------------------------

P20 = dict(z=20, m_n=2.0, name="pinion")
G40 = dict(z=40, m_n=2.0, name="gear")
NAN = float("nan")


def _pair(p=None, g=None, **kw):
    return GearPair(Gear(**{**P20, **(p or {})}), Gear(**{**G40, **(g or {})}), **kw)


def _a0():
    return _pair().a_0


BAD = [
    # id, callable, regex that must appear (parameter name), regex for the valid range
    ("z<3", lambda: Gear(z=2, m_n=2.0, allow_undercut=True), r"gear\.z", r"z >= 3"),
    ("z non-int", lambda: Gear(z=20.5, m_n=2.0), r"gear\.z", r"integer.*z >= 3"),
    ("z float 20.0", lambda: Gear(z=20.0, m_n=2.0), r"gear\.z", r"integer"),
    ("z bool", lambda: Gear(z=True, m_n=2.0), r"gear\.z", r"integer"),
    ("m_n=0", lambda: Gear(z=20, m_n=0.0), r"gear\.m_n", r"m_n > 0"),
    ("m_n<0", lambda: Gear(z=20, m_n=-1.0), r"gear\.m_n", r"m_n > 0"),
    ("b<=0", lambda: Gear(z=20, m_n=2.0, b=0.0), r"gear\.b", r"b > 0"),
    ("alpha_n=0", lambda: BasicRack(alpha_n=0.0), r"rack\.alpha_n", r"0 < alpha_n < 45 deg"),
    ("alpha_n<0", lambda: BasicRack(alpha_n=-5 * DEG), r"rack\.alpha_n", r"0 < alpha_n < 45 deg"),
    ("alpha_n=45", lambda: BasicRack(alpha_n=45 * DEG, rho_fP=0.0), r"rack\.alpha_n", r"0 < alpha_n < 45 deg"),
    ("alpha_n=50", lambda: BasicRack(alpha_n=50 * DEG, rho_fP=0.0), r"rack\.alpha_n", r"0 < alpha_n < 45 deg"),
    ("h_fP<h_aP", lambda: BasicRack(h_aP=1.0, h_fP=0.9), r"rack\.h_fP", r"h_fP >= h_aP"),
    ("h_aP<=0", lambda: BasicRack(h_aP=0.0, h_fP=1.0), r"rack\.h_aP", r"h_aP > 0"),
    ("rho_fP too large", lambda: BasicRack(rho_fP=0.6), r"rack\.rho_fP", r"0 <= rho_fP <= 0\.47"),
    ("rho_fP<0", lambda: BasicRack(rho_fP=-0.1), r"rack\.rho_fP", r"0 <= rho_fP"),
    ("a_c<0", lambda: BasicRack(a_c=-1e-4), r"rack\.a_c", r"a_c >= 0"),
    ("rack NaN", lambda: BasicRack(h_fP=NAN), r"rack\.h_fP", r"finite"),
    ("alpha_n NaN", lambda: BasicRack(alpha_n=NAN), r"rack\.alpha_n", r"finite"),
    ("beta=45", lambda: Gear(z=20, m_n=2.0, beta=45 * DEG), r"gear\.beta", r"0 <= beta < 45 deg"),
    ("beta<0", lambda: Gear(z=20, m_n=2.0, beta=-10 * DEG), r"gear\.beta", r"0 <= beta < 45 deg"),
    ("bad hand", lambda: Gear(z=20, m_n=2.0, hand="up"), r"gear\.hand", r"'right' or 'left'"),
    ("pointed tip", lambda: Gear(z=20, m_n=2.0, x=2.0), r"gear\.x", r"x < [0-9.]+ .*pointed"),
    ("undercut", lambda: Gear(z=12, m_n=2.0, x=0.0), r"gear\.x", r"x >= 0\.29"),
    ("tip below root", lambda: Gear(z=20, m_n=2.0, k=-2.5), r"gear\.k", r"k > -2\.25"),
    ("a_pl<0", lambda: Gear(z=20, m_n=2.0, a_pl=-1e-5), r"gear\.a_pl", r"a_pl >= 0"),
    ("m_n NaN", lambda: Gear(z=20, m_n=NAN), r"gear\.m_n", r"finite"),
    ("x NaN", lambda: Gear(z=20, m_n=2.0, x=NAN), r"gear\.x", r"finite"),
    ("x inf", lambda: Gear(z=20, m_n=2.0, x=math.inf), r"gear\.x", r"finite"),
    ("z NaN", lambda: Gear(z=NAN, m_n=2.0), r"gear\.z", r"integer"),
    ("rack type", lambda: Gear(z=20, m_n=2.0, rack="ISO 53 A"), r"gear\.rack", r"BasicRack"),
    ("a below base circles", lambda: _pair(a=55.0), r"pair\.a", r"a > r_b1 \+ r_b2 = 56\.38"),
    ("a below a_0", lambda: _pair(a=_a0() - 0.01), r"pair\.a", r"a >= a_0 = 60 mm"),
    ("a NaN", lambda: _pair(a=NAN), r"pair\.a", r"finite"),
    ("modules differ", lambda: _pair(g=dict(m_n=2.5)), r"gear\.m_n", r"equal to pinion\.m_n = 2\.0"),
    ("alpha differ", lambda: _pair(g=dict(rack=BasicRack(alpha_n=25 * DEG, rho_fP=0.2))), r"gear\.rack\.alpha_n",
     r"equal to pinion\.rack\.alpha_n = 20 deg"),
    ("beta differ", lambda: _pair(p=dict(beta=10 * DEG), g=dict(beta=12 * DEG, hand="left")), r"gear\.beta",
     r"equal to pinion\.beta = 10 deg"),
    ("same hands", lambda: _pair(p=dict(beta=15 * DEG), g=dict(beta=15 * DEG)), r"gear\.hand",
     r"opposite to pinion\.hand = 'right'"),
    ("tip interference with root", lambda: _pair(p=dict(k=0.3)), r"pinion\.k", r"clears the mating root"),
    ("contact ratio < 1", lambda: _pair(p=dict(k=-0.6), g=dict(k=-0.6)), r"eps_gamma", r"eps_gamma >= 1"),
    ("pair of non-gears", lambda: GearPair("a", "b"), r"GearPair", r"two Gear"),
]


@pytest.mark.parametrize("make, name_re, valid_re", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_inputs_raise_geometry_error(make, name_re, valid_re):
    with pytest.raises(GeometryError) as exc:
        make()
    assert isinstance(exc.value, GearoptError) and isinstance(exc.value, ValueError)
    msg = str(exc.value)
    assert re.search(name_re, msg), msg
    assert re.search(valid_re, msg), msg


def test_undercut_allowed_with_flag_and_small_z():
    g = Gear(z=3, m_n=2.0, allow_undercut=True, k=-0.5)
    assert g.undercut


def test_hand_ignored_for_spur_pairs():
    _pair()  # both right-handed spur gears are fine


# ------------------------------------------------------------------------------------------------
# immutability
# ------------------------------------------------------------------------------------------------

def test_frozen_dataclasses():
    rack = BasicRack()
    g = Gear(z=20, m_n=2.0)
    pair = _pair()
    for obj, field in ((rack, "alpha_n"), (g, "z"), (g, "x"), (pair, "a"), (pair, "pinion")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(obj, field, 1)
    g2 = g.with_(x=0.2)
    assert g.x == 0.0 and g2.x == 0.2
    with pytest.raises(GeometryError):
        g.with_(z=2)


def test_mating_tip_past_interference_point_is_rejected():
    """A long gear tip (k > 0, deep ISO 53 D rack) on a pinion shifted only to x_min reaches past
    the tangency point of the line of action with the pinion base circle: tip interference."""
    rack = BasicRack.iso53("D")
    probe = Gear(z=14, m_n=2.0, rack=rack, allow_undercut=True, name="pinion")
    pin = probe.with_(x=probe.x_min_undercut, allow_undercut=False)
    ok = Gear(z=200, m_n=2.0, rack=rack, name="gear")
    GearPair(pin, ok)  # standard tip: fine
    long_tip = ok.with_(k=0.35)
    with pytest.raises(GeometryError, match=r"gear\.k .*interference point of the pinion base circle"):
        GearPair(pin, long_tip)
    # Independent check of the geometry behind the message: the tip's reach exceeds a sin(alpha_w).
    pr_a = GearPair(pin, ok).a_w
    aw = math.acos((pin.r_b + long_tip.r_b) / pr_a)
    assert math.sqrt(long_tip.r_a**2 - long_tip.r_b**2) > pr_a * math.sin(aw)
