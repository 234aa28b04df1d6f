"""Tests of the 3-D tooth contact analysis (gearopt.meshing.tca) against independent analysis.

Every expectation is derived here from gear geometry (Litvin & Fuentes ch. 9-10, docs/theory.md sections
1, 5, 7, 8), never read back from the engine. Conventions used (the engine's docstring, S_f):
pinion axis z_f, gear centre O2 = (0, a + dE, axial); the pinion drives on its ``side`` flank
(sgn = +1 right, -1 left) and turns by -sgn phi1 about z_f; phi1 = 0 puts the driving flank on the
operating pitch point I = (0, r_w1); TE = phi2 - (z1/z2) phi1 - phi2(0).

Reference results derived below
-------------------------------
* Conjugate involutes (Problem 9.4.1 generalised to a centre distance E = a + dE): the common
  normal is the internal tangent of both base circles, ``-x' sin a' + y cos a' = r_b1`` with
  ``x' = sgn x`` and ``cos a' = (r_b1 + r_b2) / E``; the tangency point on the pinion base circle is
  T1 = r_b1 (-sin a', cos a'), and the contact point lies at the distance
  ``s = x' cos a' + y sin a'`` from T1. At phi1 = 0 the pinion involute through I (design distance
  a, pressure angle a_w) starts on its base circle ``inv a_w`` behind I; unwinding to T1 gives
  ``s = r_b1 (a' + inv a_w + phi1)`` (the base circle rolls on the line of action), so
  ``r1^2 = r_b1^2 + s^2``. The same for the gear, with ``s + s2 = E sin a'``, gives
  ``phi2 = (r_b1/r_b2) phi1 + (1 + r_b1/r_b2)(inv a_w - inv a')``: TE = 0 for every dE.
  A helical section at axial position z is turned by the helix: ``s -> s - sigma sgn z tan b_b``.
* Parabolic rack (docs/theory.md section 5.1): the tool flank is displaced by ``a_c u^2`` along its normal
  (into the pinion tooth). The tool point at distance u from the pitch line along its straight flank
  generates the pinion point that lies ``d = u cot(alpha)`` from I along the line of action, and at
  the standard centre distance the pair's line of action is the generating one, so the pinion
  flank is relieved by ``a_c tan^2(alpha) s^2`` at the contact position ``s = r_b1 phi1``: the gear
  lags by that over its base radius, ``TE ~ -a_c tan^2(alpha) r_b1^2 / r_b2 phi1^2``. (Note the
  ``tan^2 alpha``: the naive ``a_c s^2 / r_b2`` is 7.5 times too large at 20 deg; checked.) The next
  order: the contact point slides by t along the profile to minimise relief + gap of the two
  involutes ``K t^2/2`` (K = 1/rho1 + 1/rho2 = (1/r_b1 + 1/r_b2)/tan a_w at I), and s changes by
  ``t r_b1/rho1 = t cot a_w``: minimising ``k (s + t cot a)^2 + K t^2 / 2`` divides the level by
  ``1 + 2 a_c / K``. The apex moves to ``phi1 = -u_0 cot(alpha) / r_b1`` (u_0 > 0: towards the
  pinion root, which meshes first).
* Longitudinal crowning by plunging (tool fed a_pl z^2 deeper): the flank is relieved by
  ``a_pl z^2 sin(alpha_n)`` along its normal, a normal curvature ``2 a_pl sin(alpha_n)`` along the
  face. For an aligned spur pair the contact stays at z = 0 (symmetry) and the TE is that of the
  profile-crowned pinion; the ellipse's major semi-axis is ``sqrt(2 delta / (2 a_pl sin alpha_n))``.
  A crossing angle g (gear turned about y_f) moves the gear flank by ``g (z n_x - x n_z)`` along
  the contact normal; for spur (n_z = 0, n_x = cos a_w) the gap ``a_pl sin(a) z^2 + g cos(a) z``
  is least at ``z = -g / (2 a_pl tan a_w)``; an intersecting angle (about x_f) moves it by
  ``-g z sin(a)``: ``z = +g / (2 a_pl)``.
* Misalignment of a point-contact pair to first order (envelope theorem: the contact point is the
  minimum of the gap, so the first-order change of the minimum is the gap change at the unperturbed
  point): ``d TE = -(n1 . delta) / (n1 . (sgn e_z x (r - O2)))`` with the gear displacement
  ``delta = g e_y x (r - O2)`` (crossing). For a helical pair n_z != 0 and this is a linear
  function of phi1 added to the parabola (docs/theory.md section 5.3).
* Contact ellipse (Litvin ch. 9 closed form), curvatures convex-positive with outward normals
  (so Litvin's kS1 - kS2 becomes kS1 + kS2 and -2 g1 g2 cos 2s becomes +2 g1 g2 cos 2s):
  ``A, B = [kS1 + kS2 -+ sqrt(g1^2 + 2 g1 g2 cos 2 sigma + g2^2)] / 4``, semi-axes
  ``sqrt(delta / A)``, ``sqrt(delta / B)``; principal curvatures from the fundamental forms of the
  surface Functions, here; involute profile curvature ``1 / sqrt(r^2 - r_b^2)``.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from gearopt.errors import ConvergenceError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment
from conftest import Rx, Ry, Rz  # noqa: E402  (the tests' own rotation matrices)

DEG = math.pi / 180
ARCMIN = DEG / 60
SGN = {"right": 1.0, "left": -1.0}


# ------------------------------------------------------------------------------------------------
# Independent helpers
# ------------------------------------------------------------------------------------------------
def inv(a: float) -> float:
    return math.tan(a) - a


def thickness(g: Gear, r: float) -> float:
    """Transverse arc thickness at radius r (Litvin eq. 10.2.9)."""
    a_r = math.acos(g.r_b / r)
    return 2 * r * (g.s_t / (2 * g.r_p) + inv(g.alpha_t) - inv(a_r))


def frames(pair: GearPair, side: str, phi1: float, phi2: float, mis: Misalignment):
    """Rotations pinion->S_f, gear->S_f and the gear centre, from the documented conventions."""
    sg = SGN[side]
    z1, z2 = pair.pinion.z, pair.gear.z
    rw1 = pair.a_w * z1 / (z1 + z2)
    rw2 = pair.a_w - rw1
    th1 = thickness(pair.pinion, rw1) / (2 * rw1)
    th2 = thickness(pair.gear, rw2) / (2 * rw2)
    R1 = Rz(sg * (th1 - phi1))
    R2 = Ry(mis.crossing) @ Rx(mis.intersecting) @ Rz(sg * phi2) @ Rz(math.pi + sg * th2)
    return R1, R2, np.array([0.0, pair.a_w + mis.dE, mis.axial])


def surface_geometry(S: ca.Function, u: float, z: float, p):
    """Point, unit normal and convex-positive principal curvatures/directions (3-D, local frame)
    of a surface Function (u, z, p) -> (r, n, ...) from its first and second fundamental forms."""
    U, Z = ca.SX.sym("u"), ca.SX.sym("z")
    q = ca.vertcat(U, Z)
    r, n = S(U, Z, p)[:2]
    J = ca.jacobian(r, q)
    f = ca.Function("f", [U, Z], [r, n, J, ca.jacobian(J[:, 0], q), ca.jacobian(J[:, 1], q)])
    r, n, J, H0, H1 = (np.asarray(v) for v in f(u, z))
    n = n.ravel()
    first = J.T @ J
    second = np.array([[H0[:, 0] @ n, H0[:, 1] @ n], [H1[:, 0] @ n, H1[:, 1] @ n]])
    lam, V = np.linalg.eig(-np.linalg.solve(first, second))  # outward n: convex -> positive
    lam, V = lam.real, V.real
    o = np.argsort(lam)[::-1]
    D = J @ V[:, o]
    return r.ravel(), n, lam[o], (D / np.linalg.norm(D, axis=0)).T, J


def newton(tca: TCA, w, prm, iters=60):
    """Plain Newton on the engine's residual (no checks): finds whatever root is nearby."""
    w = np.asarray(w, float).copy()
    for _ in range(iters):
        F = np.asarray(tca.residual(w, prm)).ravel()
        dw = np.linalg.solve(np.asarray(tca.jacobian(w, prm)), -F)
        w += dw
        if np.linalg.norm(dw) < 1e-13:
            break
    return w, float(np.linalg.norm(np.asarray(tca.residual(w, prm)).ravel()))


def quad_fit(phi, te):
    c = np.polyfit(phi, te, 2)
    return c, np.abs(np.polyval(c, phi) - te).max()


def parabola_coefficient(pair: GearPair, a_c: float) -> float:
    """Derived TE coefficient (TE ~ coef phi1^2) of a pinion cut by a parabolic rack, standard
    centre distance (module docstring)."""
    p, g = pair.pinion, pair.gear
    al = p.rack.alpha_n
    K = (1 / p.r_b + 1 / g.r_b) / math.tan(pair.alpha_wt)
    return -a_c * math.tan(al) ** 2 * p.r_b**2 / g.r_b / (1 + 2 * a_c / K)


def spur(z1=20, z2=40, a_c=0.0, u_0=0.0, a_pl=0.0, **kw):
    p = Gear(z=z1, m_n=2.0, b=20, rack=BasicRack(a_c=a_c, u_0=u_0), a_pl=a_pl, name="pinion", **kw)
    return GearPair(p, Gear(z=z2, m_n=2.0, b=20, name="gear"))


def helical(a_c=0.0, a_pl=0.0, x1=0.0, x2=0.0, a=None, hand="right"):
    other = {"right": "left", "left": "right"}[hand]
    p = Gear(z=17, m_n=2.5, x=x1, b=25, beta=15 * DEG, hand=hand, rack=BasicRack(a_c=a_c), a_pl=a_pl,
             name="pinion")
    g = Gear(z=43, m_n=2.5, x=x2, b=25, beta=15 * DEG, hand=other, name="gear")
    return GearPair(p, g, a=a)


# ------------------------------------------------------------------------------------------------
# 1. Conjugate involutes: TE = 0, line of action, roll relation, for any centre distance
# ------------------------------------------------------------------------------------------------
def _pairs_conjugate():
    sp = GearPair(Gear(z=20, m_n=2.0, x=0.2, b=20, name="pinion"), Gear(z=40, m_n=2.0, x=0.1, b=20, name="gear"))
    he = helical(x1=0.3, x2=-0.1)
    return {"spur": sp, "spur_a": GearPair(sp.pinion, sp.gear, a=sp.a_0 + 0.7), "helical": he,
            "helical_a": GearPair(he.pinion, he.gear, a=he.a_0 + 0.5),
            "helical_lh": helical(x1=0.3, x2=-0.1, hand="left")}


CONJ = _pairs_conjugate()


@pytest.mark.parametrize("name", list(CONJ))
@pytest.mark.parametrize("side", ["right", "left"])
def test_conjugate_involutes_zero_te_line_of_action(name, side):
    pair = CONJ[name]
    p, g = pair.pinion, pair.gear
    tca = TCA(pair, side=side, contact="line")
    phi = np.linspace(-0.3, 0.3, 13)
    rb1, rb2 = p.r_b, g.r_b
    a_w = math.acos((rb1 + rb2) / pair.a_w)  # design (operating) pressure angle at a
    for dE, zs in ((0.0, 0.0), (0.4, 0.0), (0.15, 0.0), (0.3, 4.0)):  # dE < 0 jams the teeth (refused)
        r = tca.sweep(phi, mis=Misalignment(dE=dE), pairs=(0,), z_section=zs)
        assert r.converged.all() and r.on_surface[0, 6]
        E = pair.a_w + dE
        ap = math.acos((rb1 + rb2) / E)
        # TE identically zero: conjugate involutes tolerate centre-distance changes
        assert np.abs(r.te).max() < 1e-12
        x, y = SGN[side] * r.rf[0, :, 0], r.rf[0, :, 1]
        # on the internal common tangent of the base circles (the line of action)
        np.testing.assert_allclose(-x * math.sin(ap) + y * math.cos(ap), rb1, atol=1e-9)
        np.testing.assert_allclose(r.rf[0, :, 2], zs, atol=1e-9)
        # roll relation: distance from T1 along the line of action
        helix = p.helix_sign * SGN[side] * zs * math.tan(p.beta_b)
        s_pred = rb1 * (ap + inv(a_w) + phi) - helix
        np.testing.assert_allclose(x * math.cos(ap) + y * math.sin(ap), s_pred, atol=1e-9)
        np.testing.assert_allclose(r.radius1[0], np.hypot(rb1, s_pred), atol=1e-9)
        # the gear meets it in the same transverse section, at the predicted angle
        np.testing.assert_allclose(r.z2[0], zs, atol=1e-9)
        phi2 = rb1 / rb2 * phi + (1 + rb1 / rb2) * (inv(a_w) - inv(ap))
        np.testing.assert_allclose(r.phi2[0], phi2, atol=1e-12)
        np.testing.assert_allclose(r.normal_dot[0], -1.0, atol=1e-12)


def test_conjugate_pitch_point_given_centre_distance():
    """GearPair(a=...): at phi1 = 0 the contact is the operating pitch point (0, a z1/(z1+z2))."""
    for pair in (CONJ["spur_a"], CONJ["helical_a"]):
        r = TCA(pair, contact="line").sweep(np.array([-0.1, 0.0, 0.1]), pairs=(0,))
        r_w1 = pair.a_w * pair.pinion.z / (pair.pinion.z + pair.gear.z)
        np.testing.assert_allclose(r.rf[0, 1], [0.0, r_w1, 0.0], atol=1e-9)
        np.testing.assert_allclose(r.phi2[0], r.phi1 * pair.pinion.z / pair.gear.z, atol=1e-12)


# ------------------------------------------------------------------------------------------------
# 2. Parabolic rack: parabolic TE
# ------------------------------------------------------------------------------------------------
def test_parabolic_rack_te_is_predicted_parabola():
    z1 = 20
    phi = np.linspace(-math.pi / z1, math.pi / z1, 21)
    levels, acs = [], (0.002, 0.005, 0.01)
    for a_c in acs:
        pair = spur(a_c=a_c)
        r = TCA(pair, contact="line").sweep(phi, pairs=(0,))
        assert r.converged.all()
        te = r.te[0]
        c, res = quad_fit(phi, te)
        level = -0.5 * (te[0] + te[-1])  # mean level at +-pi/z1
        assert level > 0 and np.all(te <= 1e-15)  # thinner pinion away from the apex: gear lags
        assert res < 0.02 * level  # a parabola
        assert abs(-c[1] / (2 * c[0])) < 0.05 * math.pi / z1  # apex at the pitch point
        coef = parabola_coefficient(pair, a_c)
        assert c[0] == pytest.approx(coef, rel=0.005)
        assert level == pytest.approx(-coef * (math.pi / z1) ** 2, rel=0.005)
        # the naive estimate without the tan^2(alpha) mapping is far off (7.5x)
        assert abs(c[0]) < 0.2 * a_c * pair.pinion.r_b**2 / pair.gear.r_b
        levels.append(level)
    levels = np.array(levels)
    assert np.all(np.diff(levels) > 0)  # grows monotonically with a_c
    per = levels / np.array(acs)
    assert per.max() / per.min() < 1.12  # roughly linear (the 1/(1 + 2 a_c/K) correction only)


def test_parabolic_rack_apex_follows_u0():
    u_0 = 0.8
    pair = spur(a_c=0.005, u_0=u_0)
    phi = np.linspace(-0.3, 0.1, 21)
    r = TCA(pair, contact="line").sweep(phi, pairs=(0,))
    c, _ = quad_fit(phi, r.te[0])
    apex = -c[1] / (2 * c[0])
    expected = -u_0 / math.tan(pair.pinion.rack.alpha_n) / pair.pinion.r_b
    assert apex == pytest.approx(expected, abs=0.005)
    assert c[0] == pytest.approx(parabola_coefficient(pair, 0.005), rel=0.02)


# ------------------------------------------------------------------------------------------------
# 3. Double crowning: point contact
# ------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_double_crowned_spur_aligned_path_te_and_ellipse():
    z1 = 20
    phi = np.linspace(-math.pi / z1, math.pi / z1, 21)
    base = spur(a_c=0.005)
    line = TCA(base, contact="line").sweep(phi, pairs=(0,))
    al = base.pinion.rack.alpha_n
    majors = []
    for a_pl in (0.008, 0.002, 0.0005):
        pair = GearPair(base.pinion.with_(a_pl=a_pl), base.gear)
        r = TCA(pair).sweep(phi, pairs=(0,))
        assert r.converged.all() and r.on_surface.all()
        np.testing.assert_allclose(r.z1, 0.0, atol=1e-9)  # mid face by symmetry
        np.testing.assert_allclose(r.z2, 0.0, atol=1e-9)
        # longitudinal crowning leaves the TE of an aligned spur pair unchanged
        np.testing.assert_allclose(r.te, line.te, atol=1e-12)
        np.testing.assert_allclose(r.rf, line.rf, atol=1e-9)
        # major axis along the face (gear z axis), semi-axis from the face curvature 2 a_pl sin(alpha)
        major = r.ellipse_dir2[0, :, 0, :]
        assert np.all(np.abs(major[:, 2]) > 1 - 1e-9)
        # the face curvature is the tool's along z, 2 a_pl n_y, with the parabolic tool's normal
        # at the generating point u1: n ~ (t_y, -t_x), t = t0 + 2 a_c u n0 (sin(alpha) at u = 0)
        u = r.u1[0]
        n_y = (math.sin(al) - 2 * 0.005 * u * math.cos(al)) / np.sqrt(1 + (2 * 0.005 * u) ** 2)
        np.testing.assert_allclose(r.ellipse_a[0], np.sqrt(r.delta / (a_pl * n_y)), rtol=1e-9)
        assert r.ellipse_a[0, 10] == pytest.approx(math.sqrt(r.delta / (a_pl * math.sin(al))), rel=1e-9)
        assert np.all(r.ellipse_b[0] < r.ellipse_a[0])
        majors.append(r.ellipse_a[0, 10])
    assert majors[0] < majors[1] < majors[2]  # grows when a_pl decreases


@pytest.mark.parametrize("a_pl", [0.002, 0.008])
def test_double_crowned_spur_misaligned_path_moves_off_mid_face(a_pl):
    z1, g = 20, 3 * ARCMIN
    phi = np.linspace(-math.pi / z1, math.pi / z1, 11)
    pair = spur(a_c=0.005, a_pl=a_pl)
    tca = TCA(pair)
    tan_a = math.tan(pair.alpha_wt)
    r0 = tca.sweep(phi, pairs=(0,))
    for kind, z_pred in (("crossing", -g / (2 * a_pl * tan_a)), ("intersecting", g / (2 * a_pl))):
        rp = tca.sweep(phi, pairs=(0,), mis=Misalignment(**{kind: g}))
        rm = tca.sweep(phi, pairs=(0,), mis=Misalignment(**{kind: -g}))
        assert rp.converged.all() and rm.converged.all()
        np.testing.assert_allclose(rp.z1, -rm.z1, atol=1e-9)  # +angle / -angle: mirrored paths
        assert rp.z1[0, 5] == pytest.approx(z_pred, rel=0.02)
        assert np.all(np.sign(rp.z1) == np.sign(z_pred)) and np.all(np.abs(rp.z1) > 0.5 * abs(z_pred))
        # spur: the first-order TE change g n1 . (e x (r - O2)) vanishes at the aligned path
        # (z = 0, n_z = 0), so the TE stays the aligned parabola (second order only)
        np.testing.assert_allclose(rp.te, r0.te, atol=0.005 * np.abs(r0.te).max())
        np.testing.assert_allclose(rm.te, r0.te, atol=0.005 * np.abs(r0.te).max())


def test_helical_crossing_adds_linear_te():
    pair = helical(a_c=0.004, a_pl=0.003)
    tca = TCA(pair)
    z1 = pair.pinion.z
    phi = np.linspace(-math.pi / z1, math.pi / z1, 21)
    r0 = tca.sweep(phi, pairs=(0,))
    c0, _ = quad_fit(phi, r0.te[0])
    # first-order prediction at the aligned contact points (envelope theorem)
    pred_unit = np.empty(phi.size)
    for i in range(phi.size):
        R1, R2, O2 = frames(pair, "right", phi[i], r0.phi2[0, i], Misalignment())
        _, n1, *_ = surface_geometry(tca.pinion.surface("right"), r0.u1[0, i], r0.z1[0, i], tca.pinion.p0)
        nf, rel = R1 @ n1, r0.rf[0, i] - O2
        lever = nf @ np.cross([0, 0, 1.0], rel)
        pred_unit[i] = -(nf @ np.cross([0, 1.0, 0], rel)) / lever
    pred_unit -= np.interp(0.0, phi, pred_unit)
    slopes = {}
    for g in (2 * ARCMIN, -2 * ARCMIN, 4 * ARCMIN):
        r = tca.sweep(phi, pairs=(0,), mis=Misalignment(crossing=g))
        assert r.converged.all()
        c, _ = quad_fit(phi, r.te[0])
        assert c[0] == pytest.approx(c0[0], rel=0.01)  # same parabola shape
        dte = r.te[0] - r0.te[0]
        lin = np.polyfit(phi, dte, 1)
        assert np.abs(np.polyval(lin, phi) - dte).max() < 0.05 * np.ptp(dte)  # a linear function
        assert np.abs(dte - g * pred_unit).max() < 0.05 * np.abs(g * pred_unit).max()
        assert abs(lin[0]) * math.pi / z1 > 0.02 * abs(c0[0]) * (math.pi / z1) ** 2  # not negligible
        slopes[g] = lin[0]
    assert slopes[-2 * ARCMIN] == pytest.approx(-slopes[2 * ARCMIN], rel=0.1)
    assert slopes[4 * ARCMIN] == pytest.approx(2 * slopes[2 * ARCMIN], rel=0.1)


# ------------------------------------------------------------------------------------------------
# 4. Curvatures and contact ellipse vs the closed form
# ------------------------------------------------------------------------------------------------
def _closed_form_check(tca: TCA, r, i, mis, side):
    pair = tca.pair
    R1, R2, O2 = frames(pair, side, r.phi1[i], r.phi2[0, i], mis)
    r1, n1, k1, d1, _ = surface_geometry(tca.pinion.surface(side), r.u1[0, i], r.z1[0, i], tca.pinion.p0)
    r2, n2, k2, d2, _ = surface_geometry(tca.gear.surface(side), r.u2[0, i], r.z2[0, i], tca.gear.p0)
    # my frames reproduce the contact point and opposite normals
    np.testing.assert_allclose(R1 @ r1, r.rf[0, i], atol=1e-9)
    np.testing.assert_allclose(R2 @ r2 + O2, r.rf[0, i], atol=1e-9)
    assert (R1 @ n1) @ (R2 @ n2) == pytest.approx(-1.0, abs=1e-12)
    np.testing.assert_allclose(np.sort(k1), r.kappa1[0, i], rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(np.sort(k2), r.kappa2[0, i], rtol=1e-7, atol=1e-12)
    nf = R1 @ n1
    e1, e1p = R1 @ d1[0], np.cross(nf, R1 @ d1[0])
    D2 = R2 @ d2[0]
    sig = math.atan2(D2 @ e1p, D2 @ e1)  # angle from e_I(1) to e_I(2)
    kS1, kS2, g1, g2 = k1.sum(), k2.sum(), k1[0] - k1[1], k2[0] - k2[1]
    root = math.sqrt(g1**2 + 2 * g1 * g2 * math.cos(2 * sig) + g2**2)
    A, B = (kS1 + kS2 - root) / 4, (kS1 + kS2 + root) / 4
    assert r.ellipse_a[0, i] == pytest.approx(math.sqrt(r.delta / A), rel=1e-7)
    assert r.ellipse_b[0, i] == pytest.approx(math.sqrt(r.delta / B), rel=1e-7)
    # minor axis at 2 psi = arg(g1 + g2 e^{2 i sigma}) from e_I(1); major axis across it
    psi = np.angle(g1 + g2 * np.exp(2j * sig)) / 2
    minor = math.cos(psi) * e1 + math.sin(psi) * e1p
    major = np.cross(nf, minor)
    assert abs(major @ (R2 @ r.ellipse_dir2[0, i, 0])) == pytest.approx(1.0, abs=1e-9)
    assert abs(minor @ (R2 @ r.ellipse_dir2[0, i, 1])) == pytest.approx(1.0, abs=1e-9)
    return r1, r2, k1, k2, sig


@pytest.mark.parametrize("side", ["right", "left"])
def test_contact_ellipse_closed_form_helical_misaligned(side):
    pair = helical(a_c=0.004, a_pl=0.003)
    tca = TCA(pair, side=side)
    mis = Misalignment(crossing=4 * ARCMIN, intersecting=-2 * ARCMIN, dE=0.05)
    r = tca.sweep(np.array([-0.12, 0.0, 0.09]), pairs=(0,), mis=mis)
    assert r.converged.all()
    sigmas = [_closed_form_check(tca, r, i, mis, side)[-1] for i in range(3)]
    assert min(abs(s) for s in sigmas) > 1e-3  # principal directions really differ (sigma != 0)


def test_contact_ellipse_spur_involute_profile_curvature():
    pair = spur(a_pl=0.002)  # involute profile, crowned along the face only
    tca = TCA(pair)
    phi = np.array([-0.12, 0.0, 0.1])
    r = tca.sweep(phi, pairs=(0,))
    al = pair.pinion.rack.alpha_n
    for i in range(phi.size):
        r1, r2, k1, k2, sig = _closed_form_check(tca, r, i, Misalignment(), "right")
        rad1, rad2 = math.hypot(*r1[:2]), math.hypot(*r2[:2])
        assert k1[0] == pytest.approx(1 / math.sqrt(rad1**2 - pair.pinion.r_b**2), rel=1e-9)
        assert k2[0] == pytest.approx(1 / math.sqrt(rad2**2 - pair.gear.r_b**2), rel=1e-9)
        assert k1[1] == pytest.approx(2 * pair.pinion.a_pl * math.sin(al), rel=1e-3)
        assert abs(k2[1]) < 1e-9 and abs(math.sin(sig)) < 1e-9  # aligned principal directions


# ------------------------------------------------------------------------------------------------
# 5. AD derivatives
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("contact", ["point", "line"])
def test_jacobian_matches_finite_differences(contact):
    # (line contact: conjugate surfaces; a profile-crowned helical pinion is in point contact)
    pair = helical(a_c=0.004, a_pl=0.003) if contact == "point" else helical(x1=0.2)
    tca = TCA(pair, contact=contact)
    mis = Misalignment(crossing=3 * ARCMIN, dE=0.1) if contact == "point" else Misalignment(dE=0.1, axial=0.2)
    r = tca.sweep(np.array([0.07]), pairs=(0,), mis=mis, z_section=1.5)
    full = np.array([r.u1[0, 0], r.z1[0, 0], r.u2[0, 0], r.z2[0, 0], r.phi2[0, 0] * pair.gear.r_p])
    w = full if contact == "point" else full[[0, 2, 3, 4]]
    w = w + 0.05  # off the root too
    prm = tca.prm([0.07], mis=mis, z_section=1.5)[:, 0]
    J = np.asarray(tca.jacobian(w, prm))
    h = 1e-6
    Jfd = np.column_stack([(np.asarray(tca.residual(w + h * e, prm)) - np.asarray(tca.residual(w - h * e, prm))).ravel()
                           / (2 * h) for e in np.eye(w.size)])
    np.testing.assert_allclose(J, Jfd, atol=1e-7 * np.abs(J).max())


@pytest.mark.slow
def test_te_sensitivities_implicit_function_vs_sweeps():
    pair = helical(a_c=0.004, a_pl=0.003)
    tca = TCA(pair)
    phi = np.array([-0.15, 0.0, 0.12])
    r = tca.sweep(phi, pairs=(0,))
    W, P = ca.SX.sym("w", 5), ca.SX.sym("p", tca.layout.size)
    F = tca.residual(w=W, prm=P)["F"]
    dwdp = ca.Function("dwdp", [W, P], [-ca.solve(ca.jacobian(F, W), ca.jacobian(F, P))])
    sens = []
    for i in range(phi.size):
        w = np.array([r.u1[0, i], r.z1[0, i], r.u2[0, i], r.z2[0, i], r.phi2[0, i] * pair.gear.r_p])
        prm = tca.prm([phi[i]])[:, 0]
        sens.append(np.asarray(dwdp(w, prm))[4] / pair.gear.r_p)  # d phi2 / d prm
    sens = np.array(sens)
    k0 = 1  # phi1 = 0: TE = phi2 - ratio phi1 - phi2(0)
    for name, h in (("pinion.a_c", 1e-5), ("mis.crossing", 1e-6)):
        idx = tca.layout.index(name)
        dte = sens[:, idx] - sens[k0, idx]
        fd = []
        for sgn in (1, -1):
            if name == "pinion.a_c":
                p1 = tca.pinion.p0.copy()
                p1[tca.layout.p_index("pinion", "a_c")] += sgn * h
                fd.append(tca.sweep(phi, p1=p1, pairs=(0,)).te[0])
            else:
                fd.append(tca.sweep(phi, mis=Misalignment(crossing=sgn * h), pairs=(0,)).te[0])
        fd = (fd[0] - fd[1]) / (2 * h)
        assert np.abs(dte).max() > 1e-4
        np.testing.assert_allclose(dte, fd, rtol=1e-5, atol=1e-6 * np.abs(dte).max())
    # and the a_c sensitivity is the derived parabola coefficient's (spur, standard distance)
    sp = spur(a_c=0.005, a_pl=0.002)
    ts = TCA(sp)
    rs = ts.sweep(np.array([-0.1, 0.0, 0.1]), pairs=(0,))
    d = []
    for i in range(3):
        w = np.array([rs.u1[0, i], rs.z1[0, i], rs.u2[0, i], rs.z2[0, i], rs.phi2[0, i] * sp.gear.r_p])
        W, P = ca.SX.sym("w", 5), ca.SX.sym("p", ts.layout.size)
        F = ts.residual(w=W, prm=P)["F"]
        f = ca.Function("s", [W, P], [-ca.solve(ca.jacobian(F, W), ca.jacobian(F, P))])
        d.append(np.asarray(f(w, ts.prm([rs.phi1[i]])[:, 0]))[4, ts.layout.index("pinion.a_c")] / sp.gear.r_p)
    # d/da_c of -a_c k/(1 + 2 a_c/K) phi^2 at a_c: coef'(a_c) = coef/a_c/(1 + 2 a_c/K)
    K = (1 / sp.pinion.r_b + 1 / sp.gear.r_b) / math.tan(sp.alpha_wt)
    expected = parabola_coefficient(sp, 0.005) / 0.005 / (1 + 2 * 0.005 / K) * 0.1**2
    # (the even part, free of the small cubic asymmetry of the TE)
    assert 0.5 * (d[0] + d[2]) - d[1] == pytest.approx(expected, rel=0.01)


# ------------------------------------------------------------------------------------------------
# 6. False roots
# ------------------------------------------------------------------------------------------------
def test_false_root_same_normals_is_refused():
    """A raw root of the TCA equations whose outward normals agree (n1 . n2 = +1) exists, and
    solve_point refuses it whether started on it or near it."""
    pair = spur()
    tca = TCA(pair, contact="line")
    prm = tca.prm([0.0])[:, 0]
    w, res = newton(tca, [-10.5, 12.7, 0.0, -27.0], prm)
    assert res < 1e-10
    # independent check that it is a root with equal normals
    phi2 = w[3] / pair.gear.r_p
    R1, R2, O2 = frames(pair, "right", 0.0, phi2, Misalignment())
    r1, n1, *_ = surface_geometry(tca.pinion.surface("right"), w[0], 0.0, tca.pinion.p0)
    r2, n2, *_ = surface_geometry(tca.gear.surface("right"), w[1], w[2], tca.gear.p0)
    np.testing.assert_allclose(R1 @ r1, R2 @ r2 + O2, atol=1e-9)
    assert (R1 @ n1) @ (R2 @ n2) == pytest.approx(1.0, abs=1e-9)
    for w0 in (w, w + np.array([0.3, -0.3, 0.0, 0.5])):
        with pytest.raises(ConvergenceError, match="false root"):
            tca.solve_point(0.0, w0=w0)
    # the proper root at the same position is found from the default first guess
    good = tca.solve_point(0.0)
    assert float(tca.contact(w=good, prm=prm)["n1n2"]) == pytest.approx(-1.0, abs=1e-12)


def test_false_root_at_base_circle_cusp_is_refused():
    """At the involute's singular point (base circle) dr2/du2 = 0, so n1 . dr2/du2 = 0 holds for
    any normal: the equations have roots where the surfaces cross without touching. A true
    contact point has n1 . n2 = -1 exactly; solve_point must refuse anything else."""
    p = Gear(z=10, m_n=2.0, b=20, allow_undercut=True, a_pl=0.002, name="pinion")
    g = Gear(z=30, m_n=2.0, b=20, name="gear")
    pair = GearPair(p, g)
    tca = TCA(pair)
    phi1 = -0.1587
    prm = tca.prm([phi1])[:, 0]
    w, res = newton(tca, [3.85, 0.0, 3.73, 0.0, 0.04], prm)
    assert res < 1e-10
    u_star = g.r_p * math.sin(g.rack.alpha_n) ** 2 / math.cos(g.rack.alpha_n)  # gear's cusp
    assert w[2] == pytest.approx(u_star, abs=1e-6)
    _, _, _, _, J2 = surface_geometry(tca.gear.surface("right"), w[2], w[3], tca.gear.p0)
    assert np.linalg.norm(J2[:, 0]) < 1e-9  # singular point of the gear flank
    n1n2 = float(tca.contact(w=w, prm=prm)["n1n2"])
    assert -0.9 < n1n2 < -0.5  # not a contact, yet below the guard's threshold
    with pytest.raises(ConvergenceError):
        tca.solve_point(phi1, w0=w)


def test_sweep_never_returns_false_roots_undercut_pinion():
    """Few-teeth undercut pinion over a wide range (into the interference zone): every position the
    sweep accepts is a true contact point (opposite normals to machine precision)."""
    p = Gear(z=10, m_n=2.0, b=20, allow_undercut=True, a_pl=0.002, name="pinion")
    pair = GearPair(p, Gear(z=30, m_n=2.0, b=20, name="gear"))
    tca = TCA(pair)
    r = tca.sweep(np.linspace(-0.9, 0.5, 57), pairs=(-1, 0, 1))
    ok = r.converged
    assert ok.sum() >= 90  # the rest lies past the cusp (reversed involute branch): rejected
    np.testing.assert_allclose(r.normal_dot[ok], -1.0, atol=1e-9)
    assert np.all(r.residual[ok] <= tca.tol)
    assert np.all(~r.converged[np.isnan(r.te)])


def test_sweep_rejects_raw_false_roots():
    """Far from the anchor the mapped Newton sometimes lands on raw roots with agreeing normals
    (n1 . n2 = +1); the sweep must flag them (converged False, TE NaN), never report them. (Which
    positions meet such roots depends on the solver path, hence a small grid of sweeps; the
    precondition asserts that the guard really fired at least once.)"""
    tca = TCA(spur(a_c=0.005, a_pl=0.002))
    fired = 0
    for span in (3.0, 3.5, 4.0):
        for n in (61, 101):
            r = tca.sweep(np.linspace(-span, span, n), pairs=(-2, -1, 0, 1, 2))
            raw_false = (r.residual <= tca.tol) & (r.normal_dot > 0.99)  # a root, normals equal
            fired += int(raw_false.sum())
            assert not r.converged[raw_false].any()
            assert np.isnan(r.te[raw_false]).all() and not r.on_surface[raw_false].any()
            assert np.all(r.normal_dot[r.converged] < -0.5)
    assert fired > 0, "precondition: the sweep's Newton met a raw root with n1 . n2 = +1"


def test_sweep_accepts_only_true_contacts():
    """Double-crowned spur pair, +-1 rad, five pairs: every accepted position must be a true
    contact point, n1 . n2 = -1 (to rounding), not merely below -0.5."""
    pair = spur(a_c=0.005, a_pl=0.002)
    tca = TCA(pair)
    r = tca.sweep(np.linspace(-1.0, 1.0, 81), pairs=(-2, -1, 0, 1, 2))
    ok = r.converged
    np.testing.assert_allclose(r.normal_dot[ok], -1.0, atol=1e-9)


# ------------------------------------------------------------------------------------------------
# 7. Point contact on line-contact surfaces
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("pair", [spur(), spur(a_c=0.005), helical()], ids=["spur", "profile_crowned", "helical"])
def test_point_contact_on_unmodified_pair_points_to_line_mode(pair):
    tca = TCA(pair, contact="point")
    with pytest.raises(ConvergenceError, match="contact='line'"):
        tca.solve_point(0.0)
    with pytest.raises(ConvergenceError, match="contact='line'"):
        tca.sweep(np.linspace(-0.1, 0.1, 5))
    assert TCA(pair, contact="line").sweep(np.linspace(-0.1, 0.1, 5), pairs=(0,)).converged.all()


# ------------------------------------------------------------------------------------------------
# 8. Several tooth pairs: envelope and transfer
# ------------------------------------------------------------------------------------------------
def test_multi_pair_envelope_double_crowned_spur():
    z1 = 20
    pair = spur(a_c=0.002, a_pl=0.002)
    tca = TCA(pair)
    phi = np.linspace(-2 * math.pi / z1, 2 * math.pi / z1, 161)
    r = tca.sweep(phi, pairs=(-2, -1, 0, 1, 2))
    # every position has a contact; pair 0 is solved over the whole range (far pairs may run past
    # the involute cusp, where the sweep rejects the reversed branch)
    assert np.isfinite(r.te_envelope).all() and r.converged[2].all()
    # envelope = max over pairs in contact on the active flanks; driving = that pair
    te_on = np.where(r.on_surface, r.te, -np.inf)
    np.testing.assert_array_equal(r.te_envelope, te_on.max(axis=0))
    np.testing.assert_array_equal(r.driving, te_on.argmax(axis=0))
    # pair k is pair 0 shifted by one angular pitch
    r0 = tca.sweep(phi - 2 * math.pi / z1, pairs=(0,))
    np.testing.assert_allclose(r.te[3], r0.te[0], atol=1e-12)
    # transfers at intersections of neighbouring TE curves, at +-pi/z1 for this symmetric case
    changes = np.nonzero(np.diff(r.driving))[0]
    assert len(changes) == 2
    for i in changes:
        a, b = r.driving[i], r.driving[i + 1]
        assert r.pairs[b] == r.pairs[a] + 1
        d0, d1 = r.te[a, i] - r.te[b, i], r.te[a, i + 1] - r.te[b, i + 1]
        assert d0 >= 0 >= d1  # the curves cross between i and i + 1
        x = phi[i] + (phi[i + 1] - phi[i]) * d0 / (d0 - d1)
        assert r.on_surface[a, i] and r.on_surface[b, i + 1]
        k = r.pairs[a]
        assert x == pytest.approx((2 * k + 1) * math.pi / z1, abs=0.01 * math.pi / z1)
    # peak-to-peak = level of the parabola at the transfer points
    one = r.te[2][(phi >= -math.pi / z1 - 1e-12) & (phi <= math.pi / z1 + 1e-12)]
    arms = sorted([-one[0], -one[-1]])
    level = -parabola_coefficient(pair, 0.002) * (math.pi / z1) ** 2
    assert arms[0] - 1e-3 * level <= r.peak_to_peak <= arms[1] + 1e-3 * level
    assert r.peak_to_peak == pytest.approx(level, rel=0.02)


def test_closed_form_2x2_eigen_against_lapack():
    """eigh2_sym (the sweep's compiled ellipse eigen-decomposition) against numpy.linalg.eigh on random
    symmetric matrices and the degenerate ones (isotropic, diagonal both ways, off-diagonal only)."""
    import casadi as ca

    from gearopt.meshing.tca import eigh2_sym
    K = ca.SX.sym("K", 2, 2)
    lam, vec = eigh2_sym(K)
    f = ca.Function("e", [K], [lam, vec])
    rng = np.random.default_rng(7)
    mats = [m + m.T for m in rng.normal(size=(200, 2, 2))]
    mats += [np.eye(2) * 0.3, np.diag([2.0, 1.0]), np.diag([1.0, 2.0]), np.array([[0.0, 1.0], [1.0, 0.0]]),
             np.array([[1.0, 1e-14], [1e-14, 1.0]])]
    for M in mats:
        lv, V = (np.asarray(v) for v in f(M))
        ref = np.linalg.eigvalsh(M)
        np.testing.assert_allclose(lv.ravel(), ref, rtol=0, atol=1e-14 * max(1.0, np.abs(ref).max()))
        assert lv[0, 0] <= lv[1, 0]
        np.testing.assert_allclose(V.T @ V, np.eye(2), atol=1e-15)
        np.testing.assert_allclose(M @ V, V * lv.ravel()[None, :], atol=1e-14 * max(1.0, np.abs(ref).max()))
