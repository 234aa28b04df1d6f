"""The tool on the gear (gearopt.geometry.tools, Gear.tool, generate) and helical shapers.

The expectations are independent of the code under test: the involute helicoid is written out here
in closed form (polar angle of the transverse involute plus the helix twist, normal from the
analytic partial derivatives), the cutting centre distance of a shaper from the textbook relation
``inv alpha_wt = inv alpha_t + 2 tan alpha_n (x_s + x) / (N_s + z)``, and the TCA of conjugate
involute helicoids has TE = 0.
"""

from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from gearopt.errors import GeometryError, SceneError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.geometry.generation import PARAMS, generate, generate_by_hob, generate_by_shaper
from gearopt.geometry.tools import Hob, RackCutter, Shaper
from gearopt.io.scene import load_scene
from gearopt.meshing.tca import TCA, Misalignment

DEG = math.pi / 180


def inv(a):
    return math.tan(a) - a


def inv_inverse(t):
    return brentq(lambda a: inv(a) - t, 1e-9, math.pi / 2 - 1e-9, xtol=1e-15, rtol=1e-15)


class Helicoid:
    """Closed-form involute helicoid of an external gear (ISO 21771 / Litvin section 10.2), written
    from the gear's data only: z, m_n, alpha_n, beta, hand, shift x. Gear frame: tooth centred on +y,
    a right-hand helix turns the section counter-clockwise with +z; the right flank is on +x."""

    def __init__(self, z, m_n, x, beta, hand, alpha_n=20 * DEG):
        self.m_t = m_n / math.cos(beta)
        self.r_p = self.m_t * z / 2
        self.alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
        self.r_b = self.r_p * math.cos(self.alpha_t)
        self.s_t = self.m_t * (math.pi / 2 + 2 * x * math.tan(alpha_n))
        self.k = (0.0 if beta == 0 else (1.0 if hand == "right" else -1.0)) * math.tan(beta) / self.r_p

    def point_normal(self, side, phi, zz):
        """Point and unit outward normal at roll angle ``phi`` (radius r_b sqrt(1 + phi^2)) and z."""
        s = 1.0 if side == "right" else -1.0
        rb = self.r_b
        rad = rb * math.hypot(1.0, phi)
        half = self.s_t / (2 * self.r_p) + inv(self.alpha_t) - (phi - math.atan(phi))
        gam = math.pi / 2 - s * half + self.k * zz
        P = np.array([rad * math.cos(gam), rad * math.sin(gam), zz])
        drad = rb * phi / math.hypot(1.0, phi)
        dgam = s * phi**2 / (1 + phi**2)  # d(-s half)/dphi
        r_phi = np.array([drad * math.cos(gam) - rad * math.sin(gam) * dgam,
                          drad * math.sin(gam) + rad * math.cos(gam) * dgam, 0.0])
        r_z = np.array([-rad * math.sin(gam) * self.k, rad * math.cos(gam) * self.k, 1.0])
        n = np.cross(r_phi, r_z)
        n /= np.linalg.norm(n)
        # outward: away from the tooth's middle, i.e. towards decreasing polar angle on the right flank
        if s * (n @ np.array([math.sin(gam), -math.cos(gam), 0.0])) < 0:
            n = -n
        return P, n


def cutting(z, m_n, x, beta, N_s, x_s, alpha_n=20 * DEG):
    """Independent transverse cutting geometry of a shaper (cutting centre distance, root radius)."""
    m_t = m_n / math.cos(beta)
    a_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    a_w = inv_inverse(inv(a_t) + 2 * math.tan(alpha_n) * (x_s + x) / (N_s + z))
    a_cut = m_t * (N_s + z) / 2 * math.cos(a_t) / math.cos(a_w)
    r_as = m_t * N_s / 2 + m_n * (1.25 + x_s)  # ISO 53 A: the shaper's addendum is h_fP = 1.25
    return a_cut, a_cut - r_as


def ev(f, *args):
    return [np.asarray(v, float).ravel() for v in f(*args)]


HELICAL_SHAPER_CASES = [  # (z, m_n, x, beta_deg, hand, N_s, x_s)
    (21, 3.0, 0.2, 15.0, "right", 25, 0.1),
    (21, 3.0, 0.2, 15.0, "left", 25, 0.1),
    (34, 2.0, -0.3, 30.0, "left", 40, 0.0),
    (17, 4.0, 0.45, 22.0, "right", 18, -0.2),
    (60, 1.5, 0.0, 8.0, "right", 33, 0.3),
]


def shaper_gear(z, m_n, x, beta_deg, hand, N_s, x_s, b=30.0):
    return Gear(z=z, m_n=m_n, x=x, b=b, beta=beta_deg * DEG, hand=hand, tool=Shaper(N_s=N_s, x_s=x_s))


# ------------------------------------------------------------------------------------------------
# Helical shaper: the flank is the involute helicoid; the fillet is the shaper's trochoid
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("case", HELICAL_SHAPER_CASES, ids=str)
def test_helical_shaper_flank_is_the_involute_helicoid(case):
    z, m_n, x, beta_deg, hand = case[:5]
    g = shaper_gear(*case)
    T = generate(g)
    assert T.method == "shaper"
    H = Helicoid(z, m_n, x, beta_deg * DEG, hand)
    r_tip = m_n / math.cos(beta_deg * DEG) * z / 2 + m_n * (1 + x)
    _, a_root = cutting(*[case[i] for i in (0, 1, 2)], beta_deg * DEG, *case[5:])
    n_pts = 0
    for side in ("right", "left"):
        F = T.surface(side, "flank")
        for zz in (-15.0, -4.0, 0.0, 6.5, 15.0):
            for q0 in np.linspace(float(T.extras["q_above_tip"]) * 1.9, T.junction()[0] * (1 - 1e-6), 9):
                r, n, psi = ev(F, q0, zz, T.p0)
                rad = math.hypot(r[0], r[1])
                if rad > r_tip:
                    continue
                phi = math.sqrt((rad / H.r_b) ** 2 - 1)
                P, N = H.point_normal(side, phi, zz)
                assert np.linalg.norm(r - P) < 1e-10 * H.r_p, (side, zz, q0, r - P)
                assert np.linalg.norm(n - N) < 1e-10, (side, zz, q0, n, N)
                n_pts += 1
    assert n_pts > 60


@pytest.mark.parametrize("case", HELICAL_SHAPER_CASES[:3], ids=str)
def test_helical_shaper_equation_of_meshing_on_the_family(case):
    """n . dr/dpsi = 0 on the shaper family at the returned psi (flank and fillet), not elsewhere; the
    family is a helicoid of the shaper's lead and of the opposite hand."""
    z, m_n, x, beta_deg, hand, N_s, x_s = case
    g = shaper_gear(*case)
    T = generate_by_shaper(g)
    q, zs, ps = ca.SX.sym("q"), ca.SX.sym("z"), ca.SX.sym("psi")
    p = ca.SX.sym("p", len(PARAMS))
    u_f, phi_max = T.junction()
    a_cut, _ = cutting(z, m_n, x, beta_deg * DEG, N_s, x_s)
    r_ps = m_n / math.cos(beta_deg * DEG) * N_s / 2
    sig = 1.0 if hand == "right" else -1.0
    for side, sx in (("right", 1.0), ("left", -1.0)):
        for seg, qs in (("flank", np.linspace(2 * T.extras["q_above_tip"], u_f, 5)),
                        ("fillet", np.linspace(0, phi_max, 5))):
            fam = T.functions[f"{side}_{seg}_family"]
            r_fam, n_fam = fam(q, zs, ps, p)
            f = ca.Function("f", [q, zs, ps, p], [r_fam, n_fam, ca.jacobian(r_fam, ps)])
            F = T.surface(side, seg)
            for zz in (-10.0, 0.0, 12.0):
                for qq in qs:
                    r, n, psi = ev(F, qq, zz, T.p0)
                    r1, n1, v = ev(f, qq, zz, psi[0], T.p0)
                    assert np.linalg.norm(r1 - r) < 1e-10 and np.linalg.norm(n1 - n) < 1e-12
                    assert abs(v @ n) < 1e-12 * np.linalg.norm(v), (side, seg, qq, zz, v @ n)
                    _, n2, v2 = ev(f, qq, zz, psi[0] + 0.05, T.p0)
                    assert abs(v2 @ n2) > 5e-3 * np.linalg.norm(v2)
            # The tool surface at psi = 0 seen from the shaper axis O_s = (0, a_cut): along z a point
            # of it turns about O_s by -sigma tan(beta) / r_ps per mm (the opposite hand: a right-hand
            # helix turns counter-clockwise with +z), on both sides (one shaper cuts both flanks).
            qq = qs[2]
            d = 1e-3
            ang = []
            for zz in (-d, d):
                r = ev(fam, qq, zz, 0.0, T.p0)[0]
                ang.append(math.atan2(r[1] - a_cut, r[0]))
            rate = (ang[1] - ang[0]) / (2 * d)
            assert rate == pytest.approx(-sig * math.tan(beta_deg * DEG) / r_ps, rel=1e-6)


@pytest.mark.parametrize("case", HELICAL_SHAPER_CASES, ids=str)
def test_helical_shaper_root_and_form_radius(case):
    z, m_n, x, beta_deg, hand, N_s, x_s = case
    g = shaper_gear(*case)
    T = generate(g)
    a_cut, r_root = cutting(z, m_n, x, beta_deg * DEG, N_s, x_s)
    assert T.r_root == pytest.approx(r_root, abs=1e-10)
    assert g.r_f == pytest.approx(r_root, abs=1e-10)
    # the fillet (trochoid of the tip rounding) reaches the root circle and stays outside it, in
    # every section
    _, phi_max = T.junction()
    for zz in (-12.0, 0.0, 9.0):
        for side in ("right", "left"):
            phis = np.linspace(0, phi_max, 400)
            pts = np.array([ev(T.surface(side, "fillet"), ph, zz, T.p0)[0] for ph in phis])
            rad = np.hypot(pts[:, 0], pts[:, 1])
            assert rad.min() > r_root - 1e-9
            assert rad.min() < r_root + 1e-6 * m_n
    # The form radius: the point cut by the shaper's flank/rounding junction, on the line of action
    # (closed form in Gear.r_form) equals the end of the generated flank found numerically.
    lim = T.flank_limit("right", 0.0)
    assert lim.kind == "junction"
    assert g.r_form == pytest.approx(lim.radius, abs=1e-9)
    r_b = Helicoid(z, m_n, x, beta_deg * DEG, hand).r_b
    assert r_b < g.r_form < g.r_p
    # standard shaper on a standard gear: a_cut = r_ps + r_p, the root is the rack's r_p - h_fP m_n
    g0 = shaper_gear(z, m_n, 0.0, beta_deg, hand, N_s, 0.0)
    assert g0.r_f == pytest.approx(m_n / math.cos(beta_deg * DEG) * z / 2 - 1.25 * m_n, abs=1e-10)
    assert g0.r_f == pytest.approx(g0.with_(tool=RackCutter()).r_f, abs=1e-10)


def test_shaper_fillet_differs_from_rack_and_form_radius_is_higher():
    """A small shaper cuts less deep into the flank than the rack (its tip circle curves away from
    the line of action and meets it nearer to the pitch point): a higher form radius, a shorter path
    of contact, and a different fillet."""
    kw = dict(z=18, m_n=3.0, x=0.1, b=20.0, beta=20 * DEG, hand="left")
    g_s, g_r = Gear(**kw, tool=Shaper(N_s=20)), Gear(**kw)
    assert g_s.r_form > g_r.r_form + 0.05
    mate = Gear(z=40, m_n=3.0, beta=20 * DEG, hand="right", b=20.0, x=-0.3)
    # the mate's tip reaches below the rack-cut form circle's path end: the shaper-cut pinion has less path
    assert GearPair(g_s, mate).eps_alpha < GearPair(g_r, mate).eps_alpha - 0.01
    Ts, Tr = generate(g_s), generate(g_r)
    ps = np.array([ev(Ts.surface("right", "fillet"), t, 0.0, Ts.p0)[0] for t in np.linspace(0, Ts.junction()[1], 50)])
    pr = np.array([ev(Tr.surface("right", "fillet"), t, 0.0, Tr.p0)[0] for t in np.linspace(0, Tr.junction()[1], 50)])
    gap = min(np.linalg.norm(pr - v, axis=1).min() for v in ps[10:40])
    assert gap > 0.005 * 3.0


# ------------------------------------------------------------------------------------------------
# One dispatch: the gear's tool everywhere
# ------------------------------------------------------------------------------------------------
def test_default_tool_is_the_rack_cutter_and_dispatch():
    g = Gear(z=20, m_n=3.0)
    assert isinstance(g.tool, RackCutter)
    assert generate(g).method == "rack"
    assert generate(g.with_(tool=Hob(N_h=2, d_p0=70.0))).extras["N_h"] == 2
    assert generate(g.with_(tool=Shaper(N_s=30))).extras["N_s"] == 30
    # generate_by_hob / _shaper without a tool argument take the gear's own
    assert generate_by_shaper(g.with_(tool=Shaper(N_s=31, x_s=0.2))).extras["x_s"] == 0.2
    assert generate_by_hob(g.with_(tool=Hob(N_h=3, d_p0=80.0))).extras["N_h"] == 3
    # the old import paths still work
    from gearopt.geometry import generation
    assert generation.Hob is Hob and generation.Shaper is Shaper


def test_tca_defaults_to_each_members_tool_and_conjugate_te_is_zero():
    """A helical pair whose pinion is shaper-cut: the same involute helicoid as rack-cut, so the
    conjugate drive has TE = 0, the same contact as the rack-cut pinion, under dE too."""
    kw = dict(m_n=2.5, beta=18 * DEG, b=30.0)
    pin_s = Gear(z=21, x=0.25, hand="right", name="pinion", tool=Shaper(N_s=24, x_s=0.1), **kw)
    gear = Gear(z=53, x=-0.1, hand="left", name="gear", **kw)
    pair_s = GearPair(pin_s, gear)
    pair_r = GearPair(pin_s.with_(tool=RackCutter()), gear)
    t_s, t_r = TCA(pair_s, contact="line"), TCA(pair_r, contact="line")
    assert t_s.pinion.method == "shaper" and t_s.gear.method == "rack"
    phi = np.linspace(-0.25, 0.25, 11)
    for dE, zs in ((0.0, 0.0), (0.2, 6.0)):
        rs = t_s.sweep(phi, mis=Misalignment(dE=dE), pairs=(0,), z_section=zs)
        rr = t_r.sweep(phi, mis=Misalignment(dE=dE), pairs=(0,), z_section=zs)
        assert rs.converged.all()
        assert np.abs(rs.te).max() < 1e-12
        np.testing.assert_allclose(rs.radius1, rr.radius1, atol=1e-9)
        np.testing.assert_allclose(rs.phi2, rr.phi2, atol=1e-12)
    # point contact against a crowned gear: the same TE as with the rack-cut pinion
    gear_c = gear.with_(a_pl=3e-4, rack=BasicRack(a_c=2e-3))
    ps, pr = TCA(GearPair(pin_s, gear_c)), TCA(GearPair(pin_s.with_(tool=RackCutter()), gear_c))
    mis = Misalignment(crossing=2 / 60 * DEG)
    a, b = ps.sweep(phi, mis=mis), pr.sweep(phi, mis=mis)
    ok = np.isfinite(a.te) & np.isfinite(b.te)
    assert ok.sum() > 10
    np.testing.assert_allclose(a.te[ok], b.te[ok], atol=1e-11)
    assert np.nanmax(np.abs(a.te)) > 1e-6  # a real parabolic TE, not a trivial zero


# ------------------------------------------------------------------------------------------------
# Scenes
# ------------------------------------------------------------------------------------------------
HELICAL = """
[scene]
name = "shaper_helical"
study = "{study}"

[pair]
m_n = "2.5 mm"
beta = "18 deg"
hand = "{hand}"

[pinion]
z = 21
x = 0.25
b = "30 mm"
{pinion}

[gear]
z = 53
x = -0.1
b = "30 mm"
{gear}

{extra}
"""


def write(tmp_path, study="geometry", hand="right", pinion='tool = {kind = "shaper", z = 60, x = 0.1}', gear="",
          extra=""):
    f = tmp_path / "scene.toml"
    f.write_text(HELICAL.format(study=study, hand=hand, pinion=pinion, gear=gear, extra=extra))
    return f


@pytest.mark.slow
@pytest.mark.parametrize("hand", ["right", "left"])
def test_scene_shaper_tool_round_trip_geometry(tmp_path, hand):
    sc = load_scene(write(tmp_path, hand=hand, gear='tool = {kind = "hob", z = 2, d_p0 = "75 mm", hand = "left"}'))
    assert sc.pair.pinion.tool == Shaper(N_s=60, x_s=0.1)
    assert sc.pair.gear.tool == Hob(N_h=2, d_p0=75.0, hand="left")
    rep = sc.build().run()
    m = rep.members["pinion"]
    _, r_root = cutting(21, 2.5, 0.25, 18 * DEG, 60, 0.1)
    assert m["generation"] == "shaper" and rep.members["gear"]["generation"] == "hob"
    assert m["r_f"] == pytest.approx(r_root, abs=1e-9)
    assert m["tool"]["N_s"] == 60
    assert m["r_f"] < m["r_form"] < m["r_active_start"] < m["d_a"] / 2
    assert rep.members["gear"]["tool"]["lead_angle"] == pytest.approx(math.asin(2 * 2.5 / 75.0), rel=1e-12)
    assert rep.pair["involute_interference"] is False
    files = rep.save_plots(tmp_path)
    assert "profiles.png" in files
    # a 24-tooth shaper leaves a higher form circle: the gear's tip now reaches below it
    rep24 = load_scene(write(tmp_path, hand=hand, pinion='tool = {kind = "shaper", z = 24, x = 0.1}')).build().run()
    assert rep24.members["pinion"]["r_form"] > m["r_form"] + 0.05
    assert rep24.pair["involute_interference"] is True


def test_scene_shaper_tool_round_trip_tca(tmp_path):
    f = write(tmp_path, study="tca", extra='[tca]\ncontact = "line"\npositions = 21\n')
    study = load_scene(f).build()
    assert study.tca.pinion.method == "shaper" and study.tca.pinion.extras["N_s"] == 60
    assert study.tca.gear.method == "rack"
    r = study.tca.sweep(np.linspace(-0.2, 0.2, 9), pairs=(0,))
    assert np.abs(r.te).max() < 1e-12
    rep = study.run()
    assert abs(rep.cases[0]["peak_to_peak_arcsec"]) < 1e-6


@pytest.mark.parametrize("pinion,needles", [
    ('tool = {kind = "grinder"}', [r"\[pinion\] tool.kind = \"grinder\" is not a tool kind", r"\"rack\", \"hob\", \"shaper\""]),
    ('tool = {z = 25}', [r"\[pinion\] tool.kind: missing", r"\"shaper\""]),
    ('tool = "shaper"', [r"\[pinion\] tool = \"shaper\": expected an inline table"]),
    ('tool = {kind = "hob", x = 0.1}', [r"\[pinion\] tool.x: not a key of a tool of kind = \"hob\"",
                                        r"x is a key of kind = \"shaper\"", r"Valid keys: kind, z, d_p0, hand"]),
    ('tool = {kind = "shaper", teeth = 25}', [r"\[pinion\] tool.teeth: not a key", r"Valid keys: kind, z, x"]),
    ('tool = {kind = "hob", d_p0 = "20 deg"}', [r"\[pinion\] tool.d_p0 = \"20 deg\"", r"length"]),
    ('tool = {kind = "shaper", z = 5}', [r"\[pinion\] tool.z = 5 is out of range; valid: 8 <= z <= 400"]),
    ('tool = {kind = "shaper", z = 25.5}', [r"\[pinion\] tool.z = 25.5: expected an integer"]),
    ('tool = {kind = "shaper", x = 3}', [r"\[pinion\] tool.x = 3 is out of range; valid: -1 <= x <= 2"]),
    ('tool = {kind = "hob", z = 1, d_p0 = "2 mm"}', [r"\[pinion\] tool.d_p0 = \"2 mm\" \(= 2.0\) is out of range",
                                                    r"5 <= d_p0 <= 1432.\d+ mm", r"lead angle"]),
    ('tool = {kind = "rack", z = 3}', [r"\[pinion\] tool.z: not a key of a tool of kind = \"rack\""]),
    ('a_pl = 0.0002\ntool = {kind = "shaper", z = 30}', [r"\[pinion\] a_pl = 0.0002 is out of range",
                                                        r"a_pl = 0 for a shaper-cut gear"]),
])
def test_scene_bad_tool_input(tmp_path, pinion, needles):
    with pytest.raises(SceneError) as e:
        load_scene(write(tmp_path, pinion=pinion))
    msg = str(e.value)
    for n in needles:
        assert re.search(n, msg), (n, msg)


def test_scene_shaper_with_too_few_teeth_states_the_smallest_count(tmp_path):
    # a long-addendum pinion: the shaper's involute must reach its tip circle
    pinion = 'x = 0.6\ntool = {kind = "shaper", z = 8, x = -0.5}'
    f = tmp_path / "s.toml"
    f.write_text(HELICAL.format(study="geometry", hand="right", pinion=pinion, gear="", extra="").replace("x = 0.25\n", ""))
    with pytest.raises(SceneError) as e:
        load_scene(f)
    msg = str(e.value)
    m = re.search(r"\[pinion\] tool.z = 8 is out of range; valid: >= (\d+) shaper teeth", msg)
    assert m, msg
    n_min = int(m.group(1))
    # independent check of that count: the shaper's base-circle tangency point must lie beyond the
    # point that cuts the pinion's tip, on the line of action
    beta, m_n, z = 18 * DEG, 2.5, 21
    m_t = m_n / math.cos(beta)
    a_t = math.atan(math.tan(20 * DEG) / math.cos(beta))
    r_b, r_a = m_t * z / 2 * math.cos(a_t), m_t * z / 2 + m_n * 1.6

    def reaches(N):
        a_cut, _ = cutting(z, m_n, 0.6, beta, N, -0.5)
        r_bs = m_t * N / 2 * math.cos(a_t)
        r_c = m_t * N / 2 + m_n * (1.25 - 0.5) - 0.38 * m_n
        return math.sqrt(a_cut**2 - (r_b + r_bs) ** 2) > math.sqrt(r_a**2 - r_b**2) and r_c > r_bs

    assert reaches(n_min) and not reaches(n_min - 1)
    f.write_text(f.read_text().replace("z = 8, x = -0.5", f"z = {n_min}, x = -0.5"))
    assert load_scene(f).pair.pinion.tool.N_s == n_min
    g = Gear(z=z, m_n=m_n, x=0.6, beta=beta, b=30.0, tool=Shaper(N_s=n_min, x_s=-0.5))
    assert generate(g).flank_limit("right", 0.0).radius < r_a


def test_geometry_tool_keys_moved_to_the_gears(tmp_path):
    f = write(tmp_path, pinion="", extra='[geometry]\ngeneration = "hob"\nN_h = 2\nd_p0 = "70 mm"\n')
    with pytest.raises(SceneError, match=r'\[geometry\] generation, N_h, d_p0: .*tool = \{kind = "hob", z = 2, '
                                         r'd_p0 = "70 mm"\} under \[pinion\] and under \[gear\]'):
        load_scene(f)


def test_python_api_bad_tools():
    with pytest.raises(GeometryError, match=r"pinion.tool = str"):
        Gear(z=20, m_n=3.0, name="pinion", tool="shaper")
    with pytest.raises(GeometryError, match=r"shaper.N_s = 5 is out of range"):
        Shaper(N_s=5)
    with pytest.raises(GeometryError, match=r"gear.tool.d_p0 = 5.0 is out of range"):
        Gear(z=20, m_n=3.0, tool=Hob(d_p0=5.0))
    with pytest.raises(GeometryError, match=r"gear.rack.a_c = 0.001 is out of range"):
        Gear(z=20, m_n=3.0, rack=BasicRack(a_c=1e-3), tool=Shaper())
    # crowning synthesis needs a rack/hob-cut pinion: the shaper-cut pinion refuses crowning
    with pytest.raises(GeometryError, match=r"a_pl = 0 for a shaper-cut gear"):
        Gear(z=20, m_n=3.0, tool=Shaper()).with_(a_pl=1e-4)
    from gearopt.synthesis.crowning import CrowningOptimizer, CrowningTarget
    from gearopt.synthesis.local import LocalTarget, local_synthesis

    pair = GearPair(Gear(z=20, m_n=3.0, name="pinion", tool=Shaper()), Gear(z=41, m_n=3.0, name="gear"))
    with pytest.raises(GeometryError, match=r"pinion.tool = .*shaper.* valid: kind 'rack' or 'hob'"):
        CrowningOptimizer(pair, CrowningTarget(te_level=3e-5), cases={"a": Misalignment()})
    with pytest.raises(GeometryError, match=r"pinion.tool = .*shaper.* valid: kind 'rack' or 'hob'"):
        local_synthesis(pair, LocalTarget(mprime21=-1e-3, major_axis=10.0))


def test_fe_model_meshes_the_shaper_cut_tooth():
    from gearopt.fea.model import GearFEModel

    p = Gear(z=20, m_n=3.0, x=0.2, b=20.0, name="pinion", tool=Shaper(N_s=30, x_s=0.3))
    g = Gear(z=41, m_n=3.0, b=20.0, name="gear")
    model = GearFEModel(GearPair(p, g), 0.0)
    assert model.pin_tooth.method == "shaper" and model.gear_tooth.method == "rack"
    _, r_root = cutting(20, 3.0, 0.2, 0.0, 30, 0.3)
    assert model.pinion_mesh.meta["r_f"] == pytest.approx(r_root, abs=1e-10)
    assert abs(r_root - (30.0 + 3.0 * (0.2 - 1.25))) > 0.01  # not the rack's root


def test_geometry_study_python_shorthand_and_studies_listing(capsys):
    from gearopt.cli import main
    from gearopt.studies.geometry import GeometryStudy

    pair = GearPair(Gear(z=20, m_n=3.0, name="pinion"), Gear(z=41, m_n=3.0, name="gear"))
    st = GeometryStudy(pair, generation="shaper", shaper=Shaper(N_s=30))
    assert st.generation == {"pinion": "shaper", "gear": "shaper"}
    assert GeometryStudy(pair).generation == {"pinion": "rack", "gear": "rack"}
    with pytest.raises(GeometryError, match="generation"):
        GeometryStudy(pair, generation="grinder")
    capsys.readouterr()
    assert main(["studies", "common"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"\[pinion\.tool\].*keys depend on kind", out)
    assert re.search(r'kind = "shaper":\n\s+z \(int, default 25\): 8 <= z <= 400', out)
    assert re.search(r"d_p0 \(length \[mm\], default 60.0\)", out)


@pytest.mark.parametrize("z,beta_deg,N_s,x_s", [(9, 10.0, 30, 0.0), (12, 0.0, 16, 0.2), (10, 25.0, 50, -0.1)])
def test_shaper_undercut_limit_matches_the_fold_of_the_generated_flank(z, beta_deg, N_s, x_s):
    """Gear.x_min_undercut of a shaper-cut gear (its flank/rounding junction cuts the gear at the
    interference point, closed form) is where the numerically generated flank starts to fold."""
    g = Gear(z=z, m_n=2.0, beta=beta_deg * DEG, allow_undercut=True, tool=Shaper(N_s=N_s, x_s=x_s))
    x_min = g.x_min_undercut
    assert x_min != pytest.approx(g.with_(tool=RackCutter()).x_min_undercut, abs=1e-3)
    above, below = g.with_(x=x_min + 2e-3), g.with_(x=x_min - 2e-3)
    assert not above.undercut and below.undercut
    assert generate(above).flank_limit("right", 0.0).kind == "junction"
    assert generate(below).flank_limit("right", 0.0).kind != "junction"
    with pytest.raises(GeometryError, match=rf"x >= {x_min:.4f}"):
        g.with_(x=x_min - 0.05, allow_undercut=False)
