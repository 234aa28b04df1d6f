"""Flank modifications (gearopt.geometry.modification, GeneratedTooth.with_modification).

Expectations are analytic, not the code's own output:

* Offset property of the involute helicoid. Its unit normal lies in the plane of action (tangent
  to the base cylinder) at the base helix angle beta_b to the transverse direction; the contact
  line is the generator of that plane at beta_b to the axis. An offset c along the normal moves the
  generator, within the plane of action, by c perpendicular to itself, i.e. by c / cos(beta_b)
  along the transverse line of action: the offset flank is the same helicoid turned by
  c / (r_b cos beta_b) about the axis. Offsetting the pinion's driving flank by c (material added)
  therefore advances the gear by exactly dphi2 = c / (r_b2 cos beta_b) at every position (spur:
  c / r_b2). Material added on the gear's contacting flank does the same: that flank faces the
  pushing pinion tooth, so the offset gear flank meets the pinion c / (r_b2 cos beta_b) of gear
  rotation earlier, i.e. the gear rests that much ahead (either offset takes up backlash). With
  r_b = z m_n cos(alpha_t) / (2 cos beta) and cos(alpha_t) cos(beta_b) = cos(alpha_n) cos(beta):
  r_b cos beta_b = z m_n cos(alpha_n) / 2, computed below from the gear data directly.
* In a transverse section of a spur gear the offset involute at a radius R lies c / r_b further
  towards its own side (polar angle), the same property seen on the tooth.
* The composed normal is checked against the cross product of central-difference tangents of the
  composed point, and the point against r + delta n with r, n of the unmodified tooth and delta
  written out here in numpy.
* AD sensitivities through the TCA equations (implicit function theorem) against central
  differences of two sweeps.
"""

from __future__ import annotations

import math
import re

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from gearopt.errors import ArgumentError, GeometryError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.geometry.generation import PARAMS, Hob, generate_by_hob, generate_by_rack
from gearopt.geometry.modification import FlankModification, constant_offset, polynomial, topography
from gearopt.meshing.tca import TCA, Misalignment

DEG = math.pi / 180


def rb_cos_beta_b(g: Gear) -> float:
    """r_b cos(beta_b) [mm] from the gear data (z m_n cos alpha_n / 2), see the module docstring."""
    return g.z * g.m_n * math.cos(g.rack.alpha_n) / 2


def spur_pair(**kw):
    return GearPair(Gear(z=20, m_n=2.0, x=0.2, b=20, name="pinion", **kw), Gear(z=40, m_n=2.0, x=0.1, b=20, name="gear"))


def helical_pair(a_pl=0.0):
    p = Gear(z=17, m_n=2.5, x=0.1, b=25, beta=15 * DEG, hand="right", a_pl=a_pl, name="pinion")
    return GearPair(p, Gear(z=43, m_n=2.5, x=0.0, b=25, beta=15 * DEG, hand="left", name="gear"))


PHI = np.linspace(-0.25, 0.25, 11)


# ------------------------------------------------------------------------------------------------
# The involute offset property through the whole TCA
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["spur", "helical"])
@pytest.mark.parametrize("side", ["right", "left"])
@pytest.mark.parametrize("member", ["pinion", "gear"])
def test_constant_offset_advances_gear_by_c_over_rb_cos_beta_b(kind, side, member):
    pair = spur_pair() if kind == "spur" else helical_pair()
    c = 0.012
    tooth = generate_by_rack(getattr(pair, member)).with_modification(constant_offset(c))
    base = TCA(pair, side=side, contact="line")
    mod = TCA(pair, side=side, contact="line", **{member: tooth})
    r0, r1 = base.sweep(PHI), mod.sweep(PHI)
    both = r0.converged & r1.converged
    assert both.sum() >= 15
    expect = c / rb_cos_beta_b(pair.gear)  # the gear's own base cylinder for either member (docstring)
    assert np.abs((r1.phi2 - r0.phi2)[both] - expect).max() < 1e-13
    # TE is referenced to phi2(0) of the same drive: a rigid advance leaves it unchanged
    assert np.nanmax(np.abs(r1.te - r0.te)) < 1e-13


def test_constant_offset_sensitivity_by_ad_is_analytic():
    """theta symbolic in the TCA graph: dphi2/dc = 1 / (r_b2 cos beta_b) by the implicit function theorem."""
    pair = helical_pair()
    tooth = generate_by_rack(pair.pinion).with_modification(constant_offset(0.0, name="off"))
    tca = TCA(pair, contact="line", pinion=tooth)
    i = 1 + tooth.param_names.index("off.c")  # prm = (phi1, p1, p2, mis, z_section)
    w, prm = ca.SX.sym("w", tca.residual.size1_in(0)), ca.SX.sym("prm", tca.residual.size1_in(1))
    F = tca.residual(w, prm)
    dwdp = ca.Function("dwdp", [w, prm], [-ca.solve(ca.jacobian(F, w), ca.jacobian(F, prm))])
    for phi1 in (-0.2, 0.0, 0.15):
        wsol = tca.solve_point(phi1)
        prm0 = tca.prm([phi1])[:, 0]
        d = float(np.asarray(dwdp(wsol, prm0))[-1, i]) / tca.scale2
        assert d == pytest.approx(1 / rb_cos_beta_b(pair.gear), rel=1e-10)


# ------------------------------------------------------------------------------------------------
# Composition: point and normal
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("side", ["right", "left"])
def test_lead_slope_composed_point_and_normal(side):
    pinion = Gear(z=19, m_n=3.0, x=0.15, b=30, beta=12 * DEG, hand="left", a_pl=0.002,
                  rack=BasicRack(a_c=0.004, u_0=0.5), name="pinion")
    c0, c_z, c_uu = 0.004, 2.0e-4, -1.5e-3
    mod = polynomial(c0=c0, c_z=c_z, c_uu=c_uu, u_ref=0.3, z_ref=1.0, name="lead")
    base = generate_by_rack(pinion)
    tooth = base.with_modification(mod)
    assert tooth.param_names == PARAMS + ("lead.c0", "lead.c_u", "lead.c_z", "lead.c_uu", "lead.c_zz")
    np.testing.assert_array_equal(tooth.p0[:len(PARAMS)], base.p0)
    np.testing.assert_array_equal(tooth.p0[len(PARAMS):], [c0, 0.0, c_z, c_uu, 0.0])
    def delta_of(u, z):
        return c0 + c_z * (z - 1.0) + c_uu * (u - 0.3) ** 2

    f = tooth.surface(side, "flank")
    assert f.name_in() == ["u", "z", "p"] and f.name_out() == ["r", "n", "psi"]
    h = 1e-5
    for u, z in ((-1.5, -12.0), (0.0, 0.0), (1.2, 9.0)):
        # foot point: the unmodified point (u, zeta) whose offset point lies in the section z;
        # delta is the deviation in that section z (where the modified point is)
        zeta = brentq(lambda t: base.point(side, "flank", u, t)[0][2] + delta_of(u, z) * base.point(side, "flank", u, t)[1][2]
                      - z, z - 1, z + 1, xtol=1e-15)
        rb, nb, psib = base.point(side, "flank", u, zeta)
        assert abs(zeta - z) > 1e-5  # the helical normal's axial component matters
        r, n, psi = tooth.point(side, "flank", u, z)
        np.testing.assert_allclose(r, rb + delta_of(u, z) * nb, rtol=0, atol=1e-13)
        assert r[2] == pytest.approx(z, abs=1e-14)
        assert psi == pytest.approx(psib, abs=1e-14)
        tu = (tooth.point(side, "flank", u + h, z)[0] - tooth.point(side, "flank", u - h, z)[0]) / (2 * h)
        tz = (tooth.point(side, "flank", u, z + h)[0] - tooth.point(side, "flank", u, z - h)[0]) / (2 * h)
        m = np.cross(tu, tz)
        m *= np.sign(m @ nb) / np.linalg.norm(m)
        np.testing.assert_allclose(n, m, rtol=0, atol=1e-8)
        assert abs(np.linalg.norm(n) - 1) < 1e-14
        # the normal turned by the slope: n . t_z = 0 where the unmodified one has n_b . t_z = -c_z ...
        assert abs(n @ tz) < 1e-8 and abs(n @ tu) < 1e-8
        assert abs(nb @ tz) > 1e-5  # (the modification really turns the normal)


def test_offset_in_transverse_section_and_tooth_methods():
    """u_at_radius, radius_function, flank_limit, transverse_profile, point take the longer p: the
    offset involute at radius R lies c / r_b further towards its side."""
    g = Gear(z=23, m_n=2.0, x=0.1, b=16, name="g")
    c = 0.02
    base = generate_by_rack(g)
    tooth = base.with_modification(constant_offset(c))
    r_b = g.z * g.m_n * math.cos(g.rack.alpha_n) / 2
    for side, sgn in (("right", -1.0), ("left", 1.0)):
        for R in (r_b + 0.8, g.r_p, g.r_a - 0.1):
            pm = tooth.point(side, "flank", tooth.u_at_radius(R, 0.0, side))[0]
            pb = base.point(side, "flank", base.u_at_radius(R, 0.0, side))[0]
            assert math.hypot(*pm[:2]) == pytest.approx(R, abs=1e-11)
            dang = math.atan2(pm[1], pm[0]) - math.atan2(pb[1], pb[0])
            assert dang == pytest.approx(sgn * c / r_b, abs=1e-12)
        lim = tooth.flank_limit(side)
        assert lim.kind == "junction" and lim.u == pytest.approx(base.flank_limit(side).u, abs=1e-12)
    prof = tooth.transverse_profile(n=20)
    assert np.hypot(*prof["right_flank"][0]) == pytest.approx(g.r_a, abs=1e-9)
    assert tooth.junction() == base.junction()


def test_hob_outputs_kept_and_fillet_unmodified():
    g = Gear(z=21, m_n=2.0, b=12, name="g")  # spur: the foot point is in the same section (n_z = 0)
    base = generate_by_hob(g, Hob())
    tooth = base.with_modification(constant_offset(0.01, sides=("left",)))
    assert tooth.surface("left", "flank").name_out() == ["r", "n", "psi", "phi_h"]
    u = 0.4
    for seg, q in (("fillet", 0.3), ("flank", u)):
        a = tooth.surface("right", seg)(q, 1.0, tooth.p0)
        b = base.surface("right", seg)(q, 1.0, base.p0)
        for x, y in zip(a, b):  # right side untouched, fillet untouched
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    a = [np.asarray(v).ravel() for v in tooth.surface("left", "flank")(u, 1.0, tooth.p0)]
    b = [np.asarray(v).ravel() for v in base.surface("left", "flank")(u, 1.0, base.p0)]
    np.testing.assert_allclose(a[0], b[0] + 0.01 * b[1], atol=1e-13)
    assert a[3] == b[3]  # phi_h of the generating point


def test_stacked_modifications_and_unmodified():
    g = Gear(z=21, m_n=2.0, b=12, name="g")
    base = generate_by_rack(g)
    t = base.with_modification(constant_offset(0.01, name="a")).with_modification(constant_offset(0.005, name="b"))
    assert t.param_names == PARAMS + ("a.c", "b.c")
    rb, nb, _ = base.point("right", "flank", 0.2)
    np.testing.assert_allclose(t.point("right", "flank", 0.2)[0], rb + 0.015 * nb, atol=1e-13)
    assert t.unmodified.param_names == PARAMS
    np.testing.assert_array_equal(t.unmodified.point("right", "flank", 0.2)[0], rb)


def test_topography_interpolates_grid_and_is_smooth():
    g = Gear(z=25, m_n=2.0, b=20, name="g")
    s = np.linspace(-2.5, 2.5, 7)
    zs = np.linspace(-10, 10, 6)
    S, Z = np.meshgrid(s, zs, indexing="ij")
    V = 1e-3 * (np.sin(S) + 0.1 * Z - 0.01 * S * Z)
    base = generate_by_rack(g)
    for parametric in (False, True):
        tooth = base.with_modification(topography(s, zs, V, parametric=parametric))
        assert len(tooth.param_names) == len(PARAMS) + (V.size if parametric else 0)
        for i, j in ((1, 2), (4, 0), (6, 5)):
            rb, nb, _ = base.point("right", "flank", s[i], zs[j])
            r = tooth.point("right", "flank", s[i], zs[j])[0]
            assert (r - rb) @ nb == pytest.approx(V[i, j], abs=1e-14)  # spline coefficients: a linear solve
    # parametric values: d r / d v_ij = n at that grid point (the spline interpolates), by AD
    tooth = base.with_modification(topography(s, zs, V, parametric=True, name="t"))
    p = ca.SX.sym("p", len(tooth.param_names))
    r = tooth.surface("right", "flank")(s[3], zs[2], p)[0]
    k = tooth.param_names.index("t.v3_2")
    d = np.asarray(ca.Function("d", [p], [ca.jacobian(r, p)])(tooth.p0))[:, k]
    np.testing.assert_allclose(d, base.point("right", "flank", s[3], zs[2])[1], atol=1e-12)
    # outside the grid the edge value is held (CasADi's B-spline alone would drop to 0 there)
    rb, nb, _ = base.point("right", "flank", s[-1] + 0.5, zs[0] - 1.0)
    assert (tooth.point("right", "flank", s[-1] + 0.5, zs[0] - 1.0)[0] - rb) @ nb == pytest.approx(V[-1, 0], abs=1e-14)


def test_topography_along_radius():
    g = Gear(z=25, m_n=2.0, b=20, name="g")
    base = generate_by_rack(g)
    radii = np.linspace(g.r_p - 3, g.r_a + 0.5, 6)
    zs = np.linspace(-10, 10, 4)
    V = np.outer(1e-3 * (radii - g.r_p) ** 2, np.ones(4))  # a parabola in radius, exact in the cubic spline
    tooth = base.with_modification(topography(radii, zs, V, along="radius"))
    for R in (g.r_p - 1.2, g.r_p + 1.3):
        u = base.u_at_radius(R, 3.0)
        rb, nb, _ = base.point("right", "flank", u, 3.0)
        r = tooth.point("right", "flank", u, 3.0)[0]
        assert (r - rb) @ nb == pytest.approx(1e-3 * (R - g.r_p) ** 2, abs=1e-14)


# ------------------------------------------------------------------------------------------------
# Zero modification, AD sensitivity through the TCA, FE pickup
# ------------------------------------------------------------------------------------------------
def test_zero_modification_gives_the_unmodified_results():
    pair = helical_pair(a_pl=0.003)
    tooth = generate_by_rack(pair.pinion).with_modification(polynomial(name="zero"))
    mis = Misalignment(crossing=2e-4)
    r0 = TCA(pair).sweep(PHI, mis=mis)
    r1 = TCA(pair, pinion=tooth).sweep(PHI, mis=mis)
    np.testing.assert_array_equal(r0.converged, r1.converged)
    ok = r0.converged
    assert ok.sum() > 15
    for k, tol in (("phi2", 1e-14), ("te", 1e-14), ("u1", 1e-11), ("z1", 1e-10), ("u2", 1e-11), ("z2", 1e-10)):
        assert np.abs(getattr(r1, k)[ok] - getattr(r0, k)[ok]).max() < tol, k
    np.testing.assert_allclose(r1.kappa1[ok], r0.kappa1[ok], rtol=1e-8, atol=1e-10)


@pytest.mark.slow
def test_dte_dtheta_by_ad_matches_finite_difference_of_sweeps():
    """A lead slope theta on a crowned pinion: d(TE)/d(theta) from the implicit function theorem on
    the TCA equations (AD) against a central difference of two sweeps."""
    pair = helical_pair(a_pl=0.003)
    tooth = generate_by_rack(pair.pinion).with_modification(polynomial(c_z=1e-4, c_uu=-2e-4, name="lead"))
    tca = TCA(pair, pinion=tooth)
    for name in ("lead.c_z", "lead.c_uu"):
        _check_ad_against_fd(tca, tooth, 1 + tooth.param_names.index(name), shape_changes=name == "lead.c_uu")


def _check_ad_against_fd(tca, tooth, i, shape_changes):
    w, prm = ca.SX.sym("w", 5), ca.SX.sym("prm", tca.residual.size1_in(1))
    F = tca.residual(w, prm)
    dwdp = ca.Function("dwdp", [w, prm], [-ca.solve(ca.jacobian(F, w), ca.jacobian(F, prm)[:, i])])
    phi = np.array([-0.2, -0.1, 0.0, 0.1, 0.2])
    res = tca.sweep(phi, pairs=(0,))

    def dphi2(k):
        wk = np.array([res.u1[0, k], res.z1[0, k], res.u2[0, k], res.z2[0, k], res.phi2[0, k] * tca.scale2])
        return float(np.asarray(dwdp(wk, tca.prm([phi[k]], p1=tooth.p0)[:, 0])).ravel()[4]) / tca.scale2

    ad = np.array([dphi2(k) for k in range(phi.size)])
    dte_ad = ad - ad[2]  # TE = phi2 - ratio phi1 - phi2(0): phi1 = 0 is column 2
    h = 2e-5
    p_hi, p_lo = tooth.p0.copy(), tooth.p0.copy()
    p_hi[i - 1] += h
    p_lo[i - 1] -= h
    hi, lo = tca.sweep(phi, p1=p_hi, pairs=(0,)), tca.sweep(phi, p1=p_lo, pairs=(0,))
    fd = (hi.phi2[0] - lo.phi2[0]) / (2 * h)
    dte_fd = (hi.te[0] - lo.te[0]) / (2 * h)
    assert np.all(np.isfinite(fd))
    np.testing.assert_allclose(ad, fd, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(dte_ad, dte_fd, rtol=1e-5, atol=1e-9)
    assert np.abs(ad).min() > 1e-4  # theta really moves the gear
    if shape_changes:  # a profile parabola changes the TE curve's shape
        assert np.abs(dte_ad).max() > 1e-3


def test_fe_mesher_uses_modified_flank():
    from gearopt.fea.mesh import MeshOptions, ToothMesher

    g = Gear(z=20, m_n=2.0, b=10, name="g")
    c = 0.01
    base = generate_by_rack(g)
    tooth = base.with_modification(constant_offset(c))
    mb, mm = ToothMesher(base, MeshOptions()), ToothMesher(tooth, MeshOptions())
    us = np.linspace(-1.0, 1.0, 5)
    rb = mb._eval("right", "flank", us, 2.0)
    nb = np.array([base.point("right", "flank", u, 2.0)[1] for u in us])
    np.testing.assert_allclose(mm._eval("right", "flank", us, 2.0), rb + c * nb, atol=1e-13)


# ------------------------------------------------------------------------------------------------
# Bad input
# ------------------------------------------------------------------------------------------------
def test_bad_modifications_are_refused_by_name():
    ok = lambda u, z, r, th: th[0] * z  # noqa: E731
    with pytest.raises(ArgumentError, match="delta.*CasADi"):
        FlankModification("m", (("c", 1.0, "mm"),), lambda u, z, r, th: math.sin(u) * th[0])
    with pytest.raises(ArgumentError, match="delta = str"):
        FlankModification("m", (("c", 1.0, "mm"),), "c * z")
    with pytest.raises(ArgumentError, match=r"delta returned shape \(2, 1\)"):
        FlankModification("m", (("c", 1.0, "mm"),), lambda u, z, r, th: ca.vertcat(u, z))
    with pytest.raises(ArgumentError, match="delta returned str"):
        FlankModification("m", (), lambda u, z, r, th: "0")
    with pytest.raises(ArgumentError, match="not its arguments"):
        k = ca.SX.sym("k")
        FlankModification("m", (), lambda u, z, r, th: k * u)
    with pytest.raises(ArgumentError, match="theta 'c' default = nan"):
        FlankModification("m", (("c", float("nan"), "mm"),), ok)
    with pytest.raises(ArgumentError, match="appears twice"):
        FlankModification("m", (("c", 1.0, "mm"), ("c", 2.0, "mm")), ok)
    with pytest.raises(ArgumentError, match=r"theta\[0\].*triple"):
        FlankModification("m", (("c", 1.0),), ok)
    with pytest.raises(ArgumentError, match="name = '2x'"):
        FlankModification("2x", (("c", 1.0, "mm"),), ok)
    with pytest.raises(ArgumentError, match="sides"):
        FlankModification("m", (("c", 1.0, "mm"),), ok, sides=("top",))
    with pytest.raises(ArgumentError, match="c = 'a'"):
        constant_offset("a")
    with pytest.raises(ArgumentError, match="c_z = inf"):
        polynomial(c_z=math.inf)
    with pytest.raises(ArgumentError, match=r"values has shape \(3, 4\)"):
        topography(np.arange(4.0), np.arange(4.0), np.zeros((3, 4)))
    with pytest.raises(ArgumentError, match="s_grid.*strictly increasing"):
        topography([0, 1, 1, 2], np.arange(4.0), np.zeros((4, 4)))
    with pytest.raises(ArgumentError, match="along = 'roll'"):
        topography(np.arange(4.0), np.arange(4.0), np.zeros((4, 4)), along="roll")


def test_bad_attachment_and_parameter_vectors():
    g = spur_pair().pinion
    base = generate_by_rack(g)
    with pytest.raises(ArgumentError, match="expected a gearopt.geometry.modification.FlankModification"):
        base.with_modification(lambda u, z, r, th: 0)
    t = base.with_modification(constant_offset(0.01, name="a"))
    with pytest.raises(ArgumentError, match="'a' is already used"):
        t.with_modification(polynomial(name="a"))
    with pytest.raises(GeometryError, match="pitch point"):
        base.with_modification(FlankModification("bad", (), lambda u, z, r, th: ca.log(u - 100)))
    tca = TCA(spur_pair(), contact="line", pinion=t)
    names = PARAMS + ("a.c",)
    with pytest.raises(ArgumentError, match=re.escape(f"p1: expected a vector of {len(names)} numbers {names}")):
        tca.sweep(PHI, p1=base.p0)
    p = t.p0.copy()
    p[len(PARAMS)] = np.nan  # the theta "a.c"
    with pytest.raises(ArgumentError, match=r"\['a.c'\] are not"):
        tca.sweep(PHI, p1=p)


@pytest.mark.slow
def test_edge_contact_of_offset_pinion_is_the_rotated_drive():
    """Misaligned uncrowned helical drive with edge contact: offsetting the pinion's driving flank by c
    (and its coast flank by -c) is turning the pinion by d1 = c / (r_b1 cos beta_b) (the tip cylinder and face ends are turned into
    themselves), so at phi1 the modified drive is the unmodified one at phi1 + d1:
    raw TE_mod(phi1) = raw TE(phi1 + d1) + (z1/z2) d1 (raw: phi2 - (z1/z2) phi1, zero not subtracted)."""
    from gearopt.contact.edge import EdgeContact

    p = Gear(z=21, m_n=2.5, b=30, beta=18 * DEG, hand="right", name="pinion")
    pair = GearPair(p, Gear(z=53, m_n=2.5, b=30, beta=18 * DEG, hand="left", name="gear"))
    c = 0.008
    d1 = c / rb_cos_beta_b(pair.pinion)
    mis = Misalignment(crossing=3 * DEG / 60)
    phi = np.linspace(-1.0, 1.0, 25) * 2 * math.pi / p.z
    # material c on the driving (right) flank and -c on the left: the tooth turned, not thickened (a
    # thickened tooth jams at zero backlash, see tests/test_edge_modifications.py)
    tooth = generate_by_rack(p).with_modification(constant_offset(c, sides=("right",)))
    tooth = tooth.with_modification(constant_offset(-c, name="coast", sides=("left",)))
    r1 = EdgeContact(TCA(pair, pinion=tooth)).sweep(phi, mis=mis, pairs=(-1, 0, 1))
    r0 = EdgeContact(TCA(pair)).sweep(phi + d1, mis=mis, pairs=(-1, 0, 1))
    raw1 = r1.te_envelope + r1.stats["te_zero_rad"]
    raw0 = r0.te_envelope + r0.stats["te_zero_rad"]
    np.testing.assert_array_equal(np.isfinite(raw1), np.isfinite(raw0))
    assert np.isfinite(raw1).sum() >= 20 and (r1.active > 0).any()  # edge contact carries the load somewhere
    # (which face end carries a contact where two tie within round-off may differ: compare TE only)
    ok = np.isfinite(raw1)
    np.testing.assert_allclose(raw1[ok], raw0[ok] + p.z / pair.gear.z * d1, rtol=0, atol=1e-12)
