"""ISO 21771 micro-geometry (gearopt.geometry.microgeometry): every term against its definition.

Expectations are independent of the code under test:

* The deviation of a modified flank is measured here as a measuring machine does it, with the
  tooth's own points only: at a transverse radius R in a section z, the modified and the unmodified
  flank are found by root finding on their point Functions (scipy brentq), and
  ``delta_t = s r_b (theta_mod - theta_ref)`` with ``theta = atan2(x, y)`` (s = +1 on the right
  flank, -1 on the left; r_b Delta theta is the distance between the two involutes along the base
  tangent). It is compared with the ISO formulas transcribed below in numpy (``iso_numpy``) at the
  point's roll length ``L = sqrt(R^2 - r_b^2)``.
* Lead crowning C_beta equals Litvin's plunging a_pl = C_beta / ((b/2)^2 sin alpha_t): a tool fed
  a_pl z^2 deeper cuts the same involute offset by a_pl z^2 sin(alpha_n) along the normal, i.e.
  a_pl z^2 sin(alpha_t) transverse (sin alpha_n = sin alpha_t cos beta_b); so the TCA of the two
  drives must agree to solver precision, spur and helical, aligned and misaligned.
* Tip relief: the conjugate spur drive has TE = 0 everywhere; a pinion tip relief lowers the TE of a
  pair once its contact passes the relief start, so the path of contact ends there (the next pair
  takes over): the last contact point of a pair at TE = 0 lies within the transition around d_Ca.
* AD derivatives of the flank points with respect to every amount against central differences;
  TE sensitivities through the TCA against differences of sweeps.
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq

from gearopt.errors import ArgumentError, GeometryError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.geometry.generation import PARAMS, generate
from gearopt.geometry.microgeometry import (Microgeometry, active_profile, modified_tooth, smooth_ramp)
from gearopt.meshing.tca import TCA, Misalignment
from gearopt.units import ARCMIN, RAD_TO_ARCSEC

DEG = math.pi / 180


def pair_of(kind="spur", mg=None, mg_gear=None, a_pl=0.0, hand="right"):
    if kind == "spur":
        p = Gear(z=20, m_n=3.0, x=0.1, b=20, a_pl=a_pl, name="pinion", modifications=mg)
        g = Gear(z=40, m_n=3.0, b=20, name="gear", modifications=mg_gear)
    else:
        other = "left" if hand == "right" else "right"
        p = Gear(z=21, m_n=2.5, x=0.2, b=30, beta=18 * DEG, hand=hand, a_pl=a_pl, name="pinion", modifications=mg)
        g = Gear(z=53, m_n=2.5, b=30, beta=18 * DEG, hand=other, name="gear", modifications=mg_gear)
    return GearPair(p, g)


# ------------------------------------------------------------------------------------------------
# Independent measurement and transcription of the ISO terms
# ------------------------------------------------------------------------------------------------
def polar_angle_at(tooth, side, R, z, p=None):
    """atan2(x, y) of the flank point at transverse radius R in section z (brentq on the flank)."""
    p = tooth.p0 if p is None else p
    f = lambda u: math.hypot(*tooth.point(side, "flank", u, z, p)[0][:2]) - R  # noqa: E731
    us = np.linspace(-2.5 * tooth.gear.m_n, 2.5 * tooth.gear.m_n, 101)
    # the scan for a bracket: the same point Function evaluated at every u in one mapped call
    r = np.asarray(tooth.surface(side, "flank").map(us.size)(us[None, :], z, np.tile(np.asarray(p, float)[:, None],
                                                                                     (1, us.size)))[0])
    v = np.hypot(r[0], r[1]) - R
    k = np.nonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0]
    assert k.size >= 1, "the radius is on the flank"  # the first crossing from the tip down: the real
    # flank (the Function continues past the base-circle fold into the reversed branch)
    u = brentq(f, us[k[0]], us[k[0] + 1], xtol=1e-15, rtol=1e-15)
    r = tooth.point(side, "flank", u, z, p)[0]
    assert abs(r[2] - z) < 1e-12  # the section is the axial position
    return math.atan2(r[0], r[1])


def measured(tooth, base, side, R, z, base_angle=None):
    """ISO transverse deviation of ``tooth`` from ``base`` (the unmodified tooth) at (R, z) [mm];
    ``base_angle``: the base's polar angle there when already measured."""
    s = 1.0 if side == "right" else -1.0
    if base_angle is None:
        base_angle = polar_angle_at(base, side, R, z, base.p0)
    return s * tooth.gear.r_b * (polar_angle_at(tooth, side, R, z) - base_angle)


@functools.lru_cache(maxsize=None)
def _unmodified(kind):
    """The unmodified pinion's generated tooth of the drive ``kind``, and its measured polar angles
    ``{(side, R, z): angle}`` (filled by the tests of every modification case of the drive)."""
    return generate(pair_of(kind).pinion), {}


def ramp(s, l):
    t = (s + l / 2) / l
    return 0.0 if s <= -l / 2 else (s if s >= l / 2 else l * (t**3 - t**4 / 2))


def iso_numpy(mg: Microgeometry, gear, L_s, L_e, L, z):
    """The ISO terms of the module docstring, transcribed independently (numpy floats)."""
    rb, b = gear.r_b, gear.b
    L_m, L_al = (L_s + L_e) / 2, L_e - L_s
    ta, tb = (L - L_m) / L_al, z / b
    d = -mg.C_alpha * (2 * ta) ** 2 + mg.f_H_alpha * ta - mg.C_beta * ((z - mg.z_Cb) / (b / 2)) ** 2 \
        + mg.f_H_beta * tb + mg.S_alpha * ta * tb
    L_a = math.sqrt(gear.r_a**2 - rb**2)

    def relief(amount, s, length, shape):
        l = mg.transition if mg.transition is not None else 0.1 * length
        v = ramp(s, l) / ramp(length, l)
        return amount * (v if shape == "linear" else v * v)

    if mg.d_Ca is not None or mg.L_Ca is not None:
        L_Ca = mg.L_Ca if mg.L_Ca is not None else math.sqrt((mg.d_Ca / 2) ** 2 - rb**2)
        d -= relief(mg.C_alpha_a, L - L_Ca, L_a - L_Ca, mg.tip_shape)
    if mg.d_Cf is not None or mg.L_Cf is not None:
        L_Cf = mg.L_Cf if mg.L_Cf is not None else math.sqrt((mg.d_Cf / 2) ** 2 - rb**2)
        d -= relief(mg.C_alpha_f, L_Cf - L, L_Cf - L_s, mg.root_shape)
    if mg.b_I is not None:
        d -= relief(mg.C_beta_I, -b / 2 + mg.b_I - z, mg.b_I, mg.end_shape)
    if mg.b_II is not None:
        d -= relief(mg.C_beta_II, z - b / 2 + mg.b_II, mg.b_II, mg.end_shape)
    return d


CASES = {
    "crowning+slopes": dict(C_alpha=0.006, f_H_alpha=-0.004, C_beta=0.012, z_Cb=2.0, f_H_beta=0.005, S_alpha=0.003),
    "tip+root linear": dict(C_alpha_a=0.015, C_alpha_f=0.010, transition=0.3),
    "tip+root parabolic": dict(C_alpha_a=0.012, C_alpha_f=0.008, tip_shape="parabolic", root_shape="parabolic"),
    "end reliefs": dict(C_beta_I=0.010, b_I=4.0, C_beta_II=0.020, b_II=6.0, end_shape="parabolic"),
}


def _with_starts(kind, spec):
    spec = dict(spec)
    g = pair_of(kind).pinion
    if "C_alpha_a" in spec:
        spec["d_Ca"] = 2 * (g.r_a - 0.35 * g.m_n)
    if "C_alpha_f" in spec:
        spec["d_Cf"] = 2 * (g.r_p - 0.3 * g.m_n)
    return Microgeometry(**spec)


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("kind", ["spur", "helical"])
def test_deviation_on_a_grid_equals_the_iso_definition(kind, case):
    mg = _with_starts(kind, CASES[case])
    pair = pair_of(kind, mg)
    # the unmodified tooth is the same for every case of a drive: generated and measured once per drive
    base, angles = _unmodified(kind)
    tooth = modified_tooth(pair, "pinion", tooth=base)
    g = pair.pinion
    r_s, r_e = active_profile(pair, "pinion")
    L_s, L_e = math.sqrt(r_s**2 - g.r_b**2), math.sqrt(r_e**2 - g.r_b**2)
    worst, biggest = 0.0, 0.0
    for side in ("right", "left"):
        for R in np.linspace(r_s + 0.01, g.r_a - 1e-3, 9):
            for z in np.linspace(-g.b / 2, g.b / 2, 7):
                key = (side, float(R), float(z))
                if key not in angles:
                    angles[key] = polar_angle_at(base, side, R, z, base.p0)
                got = measured(tooth, base, side, R, z, angles[key])
                want = iso_numpy(mg, g, L_s, L_e, math.sqrt(R**2 - g.r_b**2), z)
                worst, biggest = max(worst, abs(got - want)), max(biggest, abs(want))
    assert biggest > 3e-3  # the terms are really there
    assert worst < 2e-9, worst  # [mm]: 2e-6 um


def test_sides_and_gear_member():
    mg = Microgeometry(C_beta=0.01, sides=("left",))
    pair = pair_of("helical", mg_gear=mg)
    tooth, base = modified_tooth(pair, "gear"), generate(pair.gear)
    assert tooth.param_names == PARAMS + tuple(f"iso.{a}" for a in ("C_alpha", "f_H_alpha", "C_beta", "f_H_beta",
                                                                     "S_alpha"))
    z = pair.gear.b / 2
    R = pair.gear.r_p
    assert measured(tooth, base, "left", R, z) == pytest.approx(-0.01, abs=1e-9)
    assert abs(measured(tooth, base, "right", R, z)) < 1e-12
    assert modified_tooth(pair, "pinion") is not None and not modified_tooth(pair, "pinion").modifications


# ------------------------------------------------------------------------------------------------
# Lead crowning = plunging, through the whole TCA
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["spur", "helical"])
def test_lead_crowning_is_the_equivalent_plunging(kind):
    C_beta = 0.012
    g = pair_of(kind).pinion
    a_pl = C_beta / ((g.b / 2) ** 2 * math.sin(g.alpha_t))
    iso, lit = TCA(pair_of(kind, Microgeometry(C_beta=C_beta))), TCA(pair_of(kind, a_pl=a_pl))
    phi = np.linspace(-2 * math.pi / g.z, 2 * math.pi / g.z, 31)
    for mis in (Misalignment(), Misalignment(crossing=3 * ARCMIN), Misalignment(intersecting=-2 * ARCMIN)):
        a, b = iso.sweep(phi, mis=mis), lit.sweep(phi, mis=mis)
        np.testing.assert_array_equal(a.converged, b.converged)
        ok = a.converged
        assert ok.sum() > 40
        assert np.abs(a.te[ok] - b.te[ok]).max() * RAD_TO_ARCSEC < 1e-8
        for k in ("radius1", "z1", "radius2", "z2"):
            assert np.abs(getattr(a, k)[ok] - getattr(b, k)[ok]).max() < 1e-8, k
        if mis.crossing and kind == "helical":  # (a spur drive's crossing shifts the bearing, TE ~ 0)
            assert np.nanmax(np.abs(a.te)) * RAD_TO_ARCSEC > 1.0  # the parabola absorbs a real misalignment
        if mis.crossing or mis.intersecting:
            assert np.nanmax(np.abs(a.z1)) > 0.5  # the bearing contact moved along the face


# ------------------------------------------------------------------------------------------------
# Tip relief: the path of contact ends at its start; the TCA crosses the smooth kink
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("shape", ["linear", "parabolic"])
def test_tip_relief_ends_the_path_of_contact_at_its_start_diameter(shape):
    base = pair_of("spur").pinion
    d_Ca, C, l = 2 * (base.r_a - 0.25 * base.m_n), 0.015, 0.2
    mg = Microgeometry(C_alpha_a=C, d_Ca=d_Ca, tip_shape=shape, transition=l)
    pair = pair_of("spur", mg)
    tca = TCA(pair, contact="line")
    phi = np.linspace(-0.05, 0.35, 801)  # pair 0 from the pitch point to beyond the pinion tip
    res = tca.sweep(phi, pairs=(0,))
    assert res.converged.all()  # no lost contact across the relief start
    te = res.te[0] * RAD_TO_ARCSEC
    L = np.sqrt(res.radius1[0] ** 2 - base.r_b**2)
    L_Ca = math.sqrt((d_Ca / 2) ** 2 - base.r_b**2)
    assert np.all(np.diff(L) > 0)  # the contact runs monotonically up the pinion flank: no false root
    at_zero = np.abs(te) < 1e-6
    # conjugate (TE = 0) up to the transition around the start, relieved (TE < 0) beyond it
    assert L[at_zero].max() <= L_Ca - l / 2 + 1e-9 + (L[1] - L[0])
    assert L[~at_zero].min() >= L_Ca - l / 2 - 1e-9
    assert np.all(te[L > L_Ca + l / 2] < -0.01)
    # the relieved pair's TE falls smoothly: no jump in TE or its slope (C2 relief start)
    d1 = np.diff(te) / np.diff(phi)
    assert np.abs(np.diff(d1)).max() < 0.05 * np.abs(d1).max()
    # the driving pair in the envelope switches where the relief starts (the next pair has TE = 0)
    env = tca.sweep(phi, pairs=(0, 1))
    drive0 = env.driving == 0
    assert np.all(L[(env.te[0] * RAD_TO_ARCSEC > -1e-6) | (L < L_Ca - l)][:5] < L_Ca)
    assert L[drive0 & (env.te[0] * RAD_TO_ARCSEC < -1e-3)].size == 0  # a relieved pair never drives


def test_smooth_ramp_is_c2_and_exact_outside_the_transition():
    s = ca.SX.sym("s")
    l = 0.4
    P = smooth_ramp(s, l)
    f = ca.Function("P", [s], [P, ca.jacobian(P, s), ca.jacobian(ca.jacobian(P, s), s)])
    for x in (-0.2 - 1e-9, -0.2 + 1e-9, 0.2 - 1e-9, 0.2 + 1e-9):
        v, d1, d2 = (float(a) for a in f(x))
        assert abs(v - max(x, 0.0)) < 1e-8 if abs(x) > 0.1 else True
    for x in (-0.2, 0.2):  # value, slope and curvature continuous across both joints
        lo, hi = [np.array([float(a) for a in f(x + e)]) for e in (-1e-10, 1e-10)]
        np.testing.assert_allclose(lo, hi, atol=1e-8)
    for x in (-1.0, -0.25, 0.25, 1.0, 7.0):
        assert float(f(x)[0]) == max(x, 0.0)
    assert float(f(0.0)[1]) == pytest.approx(0.5)


# ------------------------------------------------------------------------------------------------
# AD against finite differences, every amount
# ------------------------------------------------------------------------------------------------
ALL = dict(C_alpha=0.006, f_H_alpha=-0.004, C_beta=0.012, f_H_beta=0.005, S_alpha=0.003, C_alpha_a=0.015,
           C_alpha_f=0.010, C_beta_I=0.010, b_I=4.0, C_beta_II=0.02, b_II=6.0)


@pytest.mark.parametrize("kind", ["spur", "helical"])
def test_flank_derivatives_in_every_amount_by_ad_match_finite_differences(kind):
    mg = _with_starts(kind, ALL)
    pair = pair_of(kind, mg)
    tooth = modified_tooth(pair, "pinion")
    names = tooth.param_names
    assert set(Microgeometry.amount_names()) == {n.split(".")[1] for n in names if n.startswith("iso.")}
    u, z, p = ca.SX.sym("u"), ca.SX.sym("z"), ca.SX.sym("p", len(names))
    for side in ("right", "left"):
        r = tooth.surface(side)(u, z, p)[0]
        J = ca.Function("J", [u, z, p], [ca.jacobian(r, p)])
        # points in the tip relief, root relief, both end reliefs, and the relief-start transitions
        for uu, zz in ((-0.8 * pair.pinion.m_n, -13.5), (-0.7 * pair.pinion.m_n, 12.5), (0.8, 0.0), (0.2, 9.0),
                       (-0.62 * pair.pinion.m_n, -5.0)):
            ad = np.asarray(J(uu, zz, tooth.p0))
            for k, nm in enumerate(names):
                if not nm.startswith("iso."):
                    continue
                h = 1e-4  # (amounts are 1e-2 mm; a smaller step drowns in the round-off of r ~ 30 mm)
                hi, lo = tooth.p0.copy(), tooth.p0.copy()
                hi[k] += h
                lo[k] -= h
                fd = (tooth.point(side, "flank", uu, zz, hi)[0] - tooth.point(side, "flank", uu, zz, lo)[0]) / (2 * h)
                np.testing.assert_allclose(ad[:, k], fd, rtol=1e-6, atol=1e-10, err_msg=f"{side} {nm} at {uu, zz}")


@pytest.mark.slow
def test_te_sensitivities_to_amounts_by_ad_match_sweeps():
    """d(TE)/d(amount) through the TCA equations (implicit function theorem) against central
    differences of two sweeps, for a profile and a relief amount of a crowned helical pinion."""
    mg = _with_starts("helical", dict(C_beta=0.012, C_alpha=0.004, C_alpha_a=0.01))
    pair = pair_of("helical", mg)
    tca = TCA(pair)
    tooth = tca.pinion
    lay = tca.layout
    w, prm = ca.SX.sym("w", 5), ca.SX.sym("prm", lay.size if hasattr(lay, "size") else tca.residual.size1_in(1))
    F = tca.residual(w, prm)
    phi = np.array([-0.25, -0.1, 0.0, 0.1, 0.25])
    res = tca.sweep(phi, pairs=(0,))
    assert res.converged.all()
    for name in ("pinion.iso.C_alpha", "pinion.iso.C_alpha_a", "pinion.iso.S_alpha"):
        i = lay.index(name)
        dwdp = ca.Function("dwdp", [w, prm], [-ca.solve(ca.jacobian(F, w), ca.jacobian(F, prm)[:, i])])
        ad = np.array([float(np.asarray(dwdp(
            np.array([res.u1[0, k], res.z1[0, k], res.u2[0, k], res.z2[0, k], res.phi2[0, k] * tca.scale2]),
            tca.prm([phi[k]], p1=tooth.p0)[:, 0])).ravel()[4]) / tca.scale2 for k in range(phi.size)])
        j = tooth.param_names.index(name.split(".", 1)[1])
        h = 1e-6
        hi, lo = tooth.p0.copy(), tooth.p0.copy()
        hi[j] += h
        lo[j] -= h
        fd = (tca.sweep(phi, p1=hi, pairs=(0,)).phi2[0] - tca.sweep(phi, p1=lo, pairs=(0,)).phi2[0]) / (2 * h)
        np.testing.assert_allclose(ad, fd, rtol=1e-5, atol=1e-8, err_msg=name)
        assert np.abs(ad).max() > 1e-5, name  # the amount moves the gear where the contact feels it


# ------------------------------------------------------------------------------------------------
# Bad input
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, param", [
    (dict(C_beta=-0.01), "modifications.C_beta"),
    (dict(C_alpha_a=0.01), "modifications.d_Ca"),
    (dict(C_alpha_a=0.01, d_Ca=60.0, L_Ca=10.0), "modifications.L_Ca"),
    (dict(tip_shape="circular"), "modifications.tip_shape"),
    (dict(C_alpha=float("nan")), "modifications.C_alpha"),
    (dict(b_I=-1.0), "modifications.b_I"),
    (dict(sides="right"), "modifications.sides"),
    (dict(d_alpha=(60.0, 50.0)), "modifications.d_alpha"),
])
def test_bad_microgeometry_is_refused_naming_the_field(kw, param):
    with pytest.raises(ArgumentError) as e:
        Microgeometry(**kw)
    assert e.value.param == param


@pytest.mark.parametrize("kw, param", [
    (dict(C_beta=0.5), "pinion.modifications.C_beta"),  # 500 um on m_n = 3 mm: a unit slip
    (dict(C_alpha_a=0.01, d_Ca=80.0), "pinion.modifications.d_Ca"),  # above the tip
    (dict(C_alpha_a=0.01, d_Ca=50.0), "pinion.modifications.d_Ca"),  # below the base circle
    (dict(C_beta_I=0.01, b_I=25.0), "pinion.modifications.b_I"),
    (dict(z_Cb=11.0), "pinion.modifications.z_Cb"),
])
def test_microgeometry_against_the_gear_names_the_field(kw, param):
    with pytest.raises(GeometryError) as e:
        Gear(z=20, m_n=3.0, b=20, name="pinion", modifications=Microgeometry(**kw))
    assert e.value.param == param


def test_relief_start_outside_the_evaluated_profile_is_refused():
    g = pair_of("spur").pinion
    mg = Microgeometry(C_alpha_f=0.01, d_Cf=2 * (g.r_b + 0.05))  # below the start of the active profile
    with pytest.raises(GeometryError) as e:
        TCA(pair_of("spur", mg), contact="line")
    assert e.value.param == "pinion.modifications.d_Cf"


# ------------------------------------------------------------------------------------------------
# Litvin's settings <-> ISO amounts
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["spur", "helical"])
def test_iso_from_litvin_and_back(kind):
    from gearopt.geometry.microgeometry import iso_from_litvin, litvin_from_iso

    base = pair_of(kind)
    g = base.pinion
    a_c, a_pl = 0.002, 0.0003
    pair = GearPair(g.with_(a_pl=a_pl, rack=BasicRack(a_c=a_c)), base.gear)
    iso = iso_from_litvin(pair)
    # lead: exact (the plunged tool's offset, module docstring)
    assert iso["C_beta"] == pytest.approx(a_pl * (g.b / 2) ** 2 * math.sin(g.alpha_t), rel=1e-14)
    assert iso["f_H_beta"] == 0.0
    # profile: the first-order transfer of the tool parabola (|dL/du| = cos alpha_n / sin alpha_t,
    # normal = cos(beta_b) transverse) gives the sagitta within a few per cent
    r_s, r_e = active_profile(pair, "pinion")
    L_al = math.sqrt(r_e**2 - g.r_b**2) - math.sqrt(r_s**2 - g.r_b**2)
    q = math.sin(g.alpha_t) / math.cos(g.rack.alpha_n)
    first_order = a_c * q**2 * (L_al / 2) ** 2 / math.cos(g.beta_b)
    assert iso["C_alpha"] == pytest.approx(first_order, rel=0.05)
    assert abs(iso["f_H_alpha"]) < iso["C_alpha"]
    back = litvin_from_iso(pair, C_alpha=iso["C_alpha"], C_beta=iso["C_beta"], f_H_alpha=iso["f_H_alpha"])
    assert back["a_pl"] == pytest.approx(a_pl, rel=1e-13)
    assert back["a_c"] == pytest.approx(a_c, rel=1e-6)
    assert back["u_0"] == pytest.approx(g.rack.u_0, abs=1e-6)
    none = iso_from_litvin(base)
    assert none == {"C_alpha": 0.0, "f_H_alpha": 0.0, "C_beta": 0.0, "f_H_beta": 0.0}


@pytest.mark.slow
def test_an_ipopt_nlp_chooses_an_amount_through_the_tca():
    """The amounts are symbolic TCA inputs: IPOPT, with the contact points of K positions as
    unknowns tied by the TCA equations, chooses the pinion's lead crowning C_beta so that the TE under
    a crossing of the axes matches that of the drive plunged by a_pl; the answer must be the
    equivalent C_beta = a_pl (b/2)^2 sin(alpha_t) (module docstring)."""
    base = pair_of("helical")
    g = base.pinion
    a_pl = 4e-4
    want = a_pl * (g.b / 2) ** 2 * math.sin(g.alpha_t)
    mis = Misalignment(crossing=3 * ARCMIN)
    phis = np.linspace(-0.12, 0.12, 7)
    ref = TCA(pair_of("helical", a_pl=a_pl)).sweep(phis, mis=mis, pairs=(0,))
    assert ref.converged.all()
    te_ref = ref.phi2[0] - ref.phi2[0][3]
    tca = TCA(pair_of("helical", Microgeometry(C_beta=0.5 * want)))
    lay = tca.layout
    guess = tca.sweep(phis, mis=mis, pairs=(0,))
    x = ca.MX.sym("x")  # C_beta / want
    p1 = ca.MX(tca.pinion.p0)
    p1[lay.p_index("pinion", "iso.C_beta")] = x * want
    K = phis.size
    W = ca.MX.sym("W", 5, K)
    PRM = lay.build({"phi1": ca.DM(phis).T, "pinion": ca.repmat(p1, 1, K), "gear": ca.repmat(ca.DM(tca.gear.p0), 1, K),
                     "mis": ca.repmat(ca.DM(mis.vector()), 1, K), "z_section": ca.DM.zeros(1, K)})
    g_eq = ca.vec(tca.residual.map(K)(w=W, prm=PRM)["F"])
    phi2 = W[4, :] / tca.scale2
    f = ca.sumsqr((phi2 - phi2[3] - ca.DM(te_ref).T) * RAD_TO_ARCSEC)
    W0 = np.vstack([guess.u1[0], guess.z1[0], guess.u2[0], guess.z2[0], guess.phi2[0] * tca.scale2])
    solver = ca.nlpsol("s", "ipopt", {"x": ca.vertcat(x, ca.vec(W)), "f": f, "g": g_eq},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-12})
    sol = solver(x0=np.r_[0.5, W0.T.ravel()], lbg=0, ubg=0)
    assert solver.stats()["success"]
    assert float(sol["x"][0]) * want == pytest.approx(want, rel=1e-6)


@pytest.mark.slow
def test_profile_crowning_te_equals_an_independent_2d_computation():
    """The unloaded TE of a spur pinion with ISO profile crowning C_alpha (its deviation at the
    modified point's own roll length, the evaluation range the pair's active profile), against an
    independent exact computation in the transverse plane: the involutes of the gear's base circle are
    parallel curves, r_b2 (theta - inv alpha) apart along the base tangents, so the gear angle at
    which the modified pinion profile touches is the largest of that coordinate over the profile
    (scipy, no gearopt geometry). The TE agrees within 1e-3 arcsec (its curvature over a mesh cycle
    within 1e-4), and both
    fall short of the first-order value C_alpha (p_b / L_alpha)^2 / r_b2 by a second-order amount
    that grows with C_alpha (1.35 % at 5.85 um)."""
    from scipy.optimize import minimize_scalar

    m, z1, z2 = 3.0, 20, 40
    al = math.radians(20.0)
    rb1, rb2, a = m * z1 / 2 * math.cos(al), m * z2 / 2 * math.cos(al), m * (z1 + z2) / 2
    inv = lambda x: math.tan(x) - x  # noqa: E731

    def u2(t, phi, C, Ls, L_alpha):
        # pinion involute (roll angle t) moved into the tooth by the deviation at its own roll length
        s = rb1 * t
        Lm = Ls + L_alpha / 2
        d = C * (2 * (s - Lm) / L_alpha) ** 2
        for _ in range(4):
            d = C * (2 * (s - d - Lm) / L_alpha) ** 2
        q = rb1 * np.array([math.cos(t) + t * math.sin(t), math.sin(t) - t * math.cos(t)]) - d * np.array(
            [math.sin(t), -math.cos(t)])
        x = (math.cos(phi) * q[0] - math.sin(phi) * q[1] - a, math.sin(phi) * q[0] + math.cos(phi) * q[1])
        return rb2 * (math.atan2(-x[1], -x[0]) - inv(math.acos(min(1.0, rb2 / math.hypot(*x)))))

    def touch(phi, C, Ls, L_alpha):  # the largest gear-side coordinate over the pinion profile, and where
        ts = np.linspace(0.05, 0.8, 300)
        i = int(np.argmax([u2(t, phi, C, Ls, L_alpha) for t in ts]))
        r = minimize_scalar(lambda t: -u2(t, phi, C, Ls, L_alpha), bounds=(ts[max(i - 2, 0)], ts[min(i + 2, ts.size - 1)]),
                            method="bounded", options={"xatol": 1e-13})
        return -r.fun, r.x

    for C in (0.005847, 0.002):
        pair = GearPair(Gear(z=z1, m_n=m, b=20.0, modifications=Microgeometry(C_alpha=C)), Gear(z=z2, m_n=m, b=20.0))
        tca = TCA(pair, pinion=modified_tooth(pair, "pinion", force_iso=True),
                  gear=modified_tooth(pair, "gear", force_iso=True), contact="line")
        phi = np.linspace(-math.pi / z1, math.pi / z1, 33)
        res = tca.sweep(phi, pairs=(0,))
        assert res.converged.all()
        k_tca = np.polyfit(phi, np.asarray(res.te[0]), 2)[0]
        r_s, r_e = active_profile(pair, "pinion")
        Ls, L_alpha = math.sqrt(r_s**2 - rb1**2), math.sqrt(r_e**2 - rb1**2) - math.sqrt(r_s**2 - rb1**2)
        # the same window of the path of contact: the TCA's contact roll length at phi1 = 0
        s0 = math.sqrt(float(res.radius1[0][phi.size // 2]) ** 2 - rb1**2)
        c0 = brentq(lambda f: touch(f, 0.0, Ls, L_alpha)[1] * rb1 - s0, -0.1, 0.1, xtol=1e-14)
        ph = c0 - phi  # (here the roll length falls as phi grows)
        te = np.array([touch(f, C, Ls, L_alpha)[0] - touch(f, 0.0, Ls, L_alpha)[0] for f in ph]) / rb2
        k_ind = np.polyfit(phi, te, 2)[0]
        assert k_tca == pytest.approx(k_ind, rel=1e-4)
        diff = np.asarray(res.te[0]) - te  # the same TE up to a constant and a line (the zero of phi)
        diff -= np.polyval(np.polyfit(phi, diff, 1), phi)
        assert np.max(np.abs(diff)) * RAD_TO_ARCSEC < 1e-3
        first = -C * 4 * rb1**2 / (L_alpha**2 * rb2)
        assert 0.95 < k_tca / first < 1.0 - 5e-4  # short of first order by a second-order amount
