"""The published FZG test gears (C14, H501) at a = 91.5 mm, tooth thickness allowances (DIN 3967 /
ISO 21771) and backlash, checked against formulas written out here and against the generated
tooth surfaces. Lengths in mm, angles in rad."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from gearopt import Gear, GearPair, load_scene
from gearopt.errors import GeometryError, SceneError
from gearopt.geometry.generation import generate_by_rack

DEG = math.pi / 180
ROOT = Path(__file__).resolve().parents[1]


def _inv(a):
    return math.tan(a) - a


def _ref(z1, z2, m_n, beta, x1, x2, a, d_a1, d_a2, b, A1=0.0, A2=0.0, alpha_n=20 * DEG):
    """Textbook (ISO 21771) values written out independently: operating pressure angle, path of
    contact, contact ratios, zero-backlash centre distance and backlash."""
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(beta))
    d1, d2 = z1 * m_n / math.cos(beta), z2 * m_n / math.cos(beta)
    d_b1, d_b2 = d1 * math.cos(alpha_t), d2 * math.cos(alpha_t)
    alpha_wt = math.acos((d_b1 + d_b2) / (2 * a))
    g_alpha = 0.5 * (math.sqrt(d_a1**2 - d_b1**2) + math.sqrt(d_a2**2 - d_b2**2)) - a * math.sin(alpha_wt)
    p_bt = math.pi * m_n / math.cos(beta) * math.cos(alpha_t)
    inv_w0 = _inv(alpha_t) + 2 * math.tan(alpha_n) * (x1 + x2) / (z1 + z2)
    alpha_w0 = brentq(lambda t: _inv(t) - inv_w0, 1e-6, 1.2, xtol=1e-15)
    a_0 = (d1 + d2) / 2 * math.cos(alpha_t) / math.cos(alpha_w0)
    # backlash: working pitch minus the thicknesses on the working pitch circles (allowances included)
    d_w1 = 2 * a * z1 / (z1 + z2)
    p_w = math.pi * d_w1 / z1
    s_w = 0.0
    for z, x, A, d in ((z1, x1, A1, d1), (z2, x2, A2, d2)):
        s_t = m_n / math.cos(beta) * (math.pi / 2 + 2 * x * math.tan(alpha_n)) + A / math.cos(beta)
        d_w = 2 * a * z / (z1 + z2)
        s_w += d_w * (s_t / d + _inv(alpha_t) - _inv(alpha_wt))
    j_wt = p_w - s_w
    beta_b = math.asin(math.sin(beta) * math.cos(alpha_n))
    return dict(alpha_wt=alpha_wt, g_alpha=g_alpha, eps_alpha=g_alpha / p_bt, eps_beta=b * math.sin(beta) / (math.pi * m_n),
                a_0=a_0, j_wt=j_wt, j_bn=j_wt * math.cos(alpha_wt) * math.cos(beta_b))


C14 = dict(z1=16, z2=24, m_n=4.5, beta=0.0, x1=0.1817, x2=0.1715, a=91.5, d_a1=82.46, d_a2=118.36, b=14.0)
H501 = dict(z1=20, z2=30, m_n=3.5, beta=15 * DEG, x1=0.1809, x2=0.0891, a=91.5, d_a1=None, d_a2=None, b=23.0)


def _pair(c, A1=0.0, A2=0.0, A1i=None, A2i=None, a=None):
    def k(z, x, d_a):
        return 0.0 if d_a is None else (d_a / 2 - z * c["m_n"] / math.cos(c["beta"]) / 2) / c["m_n"] - 1.0 - x
    kw = dict(m_n=c["m_n"], beta=c["beta"], b=c["b"])
    p = Gear(z=c["z1"], x=c["x1"], k=k(c["z1"], c["x1"], c["d_a1"]), hand="right", name="pinion", A_sne=A1, A_sni=A1i, **kw)
    g = Gear(z=c["z2"], x=c["x2"], k=k(c["z2"], c["x2"], c["d_a2"]), hand="left", name="gear", A_sne=A2, A_sni=A2i, **kw)
    return GearPair(p, g, a=c["a"] if a is None else a)


def _ref_of(c, pair, A1=0.0, A2=0.0):
    d_a1 = c["d_a1"] or 2 * pair.pinion.r_a
    d_a2 = c["d_a2"] or 2 * pair.gear.r_a
    return _ref(c["z1"], c["z2"], c["m_n"], c["beta"], c["x1"], c["x2"], pair.a_w, d_a1, d_a2, c["b"], A1, A2)


@pytest.mark.parametrize("c", [C14, H501], ids=["C14", "H501"])
def test_fzg_pair_at_91_5_mm_is_accepted_with_its_geometry(c):
    pair = _pair(c)  # a_0 from the rounded shifts is 0.08 / 0.26 um above 91.5 mm
    ref = _ref_of(c, pair)
    assert pair.a_w == 91.5
    assert 0 < pair.a_0 - 91.5 < pair.a_0_tolerance
    assert pair.a_0 == pytest.approx(ref["a_0"], abs=1e-9)
    assert pair.a_minus_a_0 == pytest.approx(91.5 - ref["a_0"], abs=1e-9)
    assert pair.alpha_wt == pytest.approx(ref["alpha_wt"], abs=1e-13)
    assert pair.g_alpha == pytest.approx(ref["g_alpha"], abs=1e-10)
    assert pair.eps_alpha == pytest.approx(ref["eps_alpha"], abs=1e-12)
    assert pair.eps_beta == pytest.approx(ref["eps_beta"], abs=1e-12)
    # within the tolerance the teeth overlap by less than a um: the reported backlash says so
    assert pair.backlash == pytest.approx(ref["j_wt"], abs=1e-10)
    assert -1e-3 < pair.backlash < 0


def test_fzg_c14_published_values():
    """DIN ISO 14635-1 / FZG: operating pressure angle 22.44 deg, transverse contact ratio 1.44."""
    pair = _pair(C14)
    assert pair.alpha_wt / DEG == pytest.approx(22.44, abs=0.005)
    assert pair.eps_alpha == pytest.approx(1.44, abs=0.005)


def test_a0_tolerance_is_the_effect_of_shift_rounding():
    """The tolerance is 1e-4 in x1 + x2 times da_0/d(x1 + x2), here by central differences of the
    independent a_0; a further below a_0 still jams and is refused."""
    for c in (C14, H501):
        pair = _pair(c)
        h = 1e-5
        da = (_ref(**{**_args(c), "x1": c["x1"] + h})["a_0"] - _ref(**{**_args(c), "x1": c["x1"] - h})["a_0"]) / (2 * h)
        assert pair.a_0_tolerance == pytest.approx(1e-4 * da, rel=1e-6)
        with pytest.raises(GeometryError, match=r"pair\.a .*a >= a_0 = .*tolerance"):
            _pair(c, a=pair.a_0 - 1.5 * pair.a_0_tolerance)
        _pair(c, a=pair.a_0 - 0.9 * pair.a_0_tolerance)  # accepted


def _args(c):
    d = {k: c[k] for k in ("z1", "z2", "m_n", "beta", "x1", "x2", "a", "b")}
    return {**d, "d_a1": 1e3, "d_a2": 1e3}


@pytest.mark.parametrize("c", [C14, H501], ids=["C14", "H501"])
def test_thickness_allowances_backlash(c):
    A1, A2, A1i, A2i = -0.05, -0.07, -0.09, -0.12
    pair = _pair(c, A1, A2, A1i, A2i)
    ref = _ref_of(c, pair, A1, A2)
    ref_max = _ref_of(c, pair, A1i, A2i)
    assert pair.backlash == pytest.approx(ref["j_wt"], abs=1e-10)
    assert pair.backlash_max == pytest.approx(ref_max["j_wt"], abs=1e-10)
    assert pair.backlash_normal == pytest.approx((ref["j_bn"], ref_max["j_bn"]), abs=1e-10)
    # the allowances add backlash linearly: -(A1 + A2) / cos(beta) * cos(alpha_t) / cos(alpha_wt)
    nominal = _pair(c)
    gain = -(A1 + A2) / math.cos(c["beta"]) * math.cos(pair.alpha_t) / math.cos(pair.alpha_wt)
    assert pair.backlash - nominal.backlash == pytest.approx(gain, rel=1e-9)
    # the generating shift (ISO 21771): x_E = x + A_sne / (2 m_n tan alpha_n); the root follows the tool
    assert pair.pinion.x_E == pytest.approx(c["x1"] + A1 / (2 * c["m_n"] * math.tan(20 * DEG)), abs=1e-15)
    assert pair.pinion.r_f == pytest.approx(nominal.pinion.r_f + A1 / (2 * math.tan(20 * DEG)), abs=1e-12)
    assert pair.pinion.r_a == nominal.pinion.r_a  # the tip is turned, not generated


def _angular_thickness(prof, r):
    """Angle [rad] subtended by the generated transverse tooth at radius r (from the sampled flanks)."""
    out = []
    for side in ("right_flank", "left_flank"):
        xy = prof[side]
        rad = np.hypot(xy[:, 0], xy[:, 1])
        ang = np.arctan2(xy[:, 1], xy[:, 0])
        order = np.argsort(rad)
        out.append(np.interp(r, rad[order], np.unwrap(ang[order])))
    return abs(out[1] - out[0])


@pytest.mark.parametrize("c", [C14, H501], ids=["C14", "H501"])
def test_generated_teeth_carry_the_allowance_and_leave_the_backlash(c):
    """The surfaces cut by the rack at x_E: measured on the generated profiles, the working pitch
    minus both tooth thicknesses on the working pitch circles is the reported backlash."""
    A1, A2 = -0.06, -0.04
    pair = _pair(c, A1, A2)
    a = pair.a_w
    r_w1 = a * c["z1"] / (c["z1"] + c["z2"])
    r_w2 = a - r_w1
    th1 = _angular_thickness(generate_by_rack(pair.pinion).transverse_profile(0.0, 400), r_w1)
    th2 = _angular_thickness(generate_by_rack(pair.gear).transverse_profile(0.0, 400), r_w2)
    j = 2 * math.pi * r_w1 / c["z1"] - th1 * r_w1 - th2 * r_w2
    assert j == pytest.approx(pair.backlash, abs=2e-4)
    nominal = _pair(c)
    th1n = _angular_thickness(generate_by_rack(nominal.pinion).transverse_profile(0.0, 400), r_w1)
    assert (th1n - th1) * r_w1 == pytest.approx(-A1 / math.cos(c["beta"]) * r_w1 / pair.pinion.r_p, rel=1e-3)


def test_allowance_validation():
    with pytest.raises(GeometryError, match=r"pinion\.A_sni .*A_sni <= A_sne = -0\.05"):
        Gear(z=16, m_n=4.5, x=0.18, A_sne=-0.05, A_sni=-0.01, name="pinion")
    with pytest.raises(GeometryError, match=r"A_sne .*finite"):
        Gear(z=16, m_n=4.5, A_sne=math.nan)
    g = Gear(z=16, m_n=4.5, x=0.18, A_sne=-0.05)
    assert g.A_sni == -0.05


@pytest.mark.parametrize("name, c", [("fzg_c14", C14), ("fzg_h501", H501)])
def test_fzg_scenes(name, c):
    scene = load_scene(ROOT / "problems" / f"{name}.toml")
    pair = scene.pair
    assert pair.a_w == 91.5 and pair.pinion.z == c["z1"] and pair.gear.x == c["x2"]
    if c["d_a1"]:
        assert 2 * pair.pinion.r_a == pytest.approx(c["d_a1"], abs=1e-12)
        assert 2 * pair.gear.r_a == pytest.approx(c["d_a2"], abs=1e-12)
    A1, A2 = pair.pinion.A_sne, pair.gear.A_sne
    ref = _ref_of(c, pair, A1, A2)
    rep = json.loads(json.dumps(scene.build().run().to_dict()))["pair"]
    assert rep["alpha_wt_deg"] == pytest.approx(ref["alpha_wt"] / DEG, abs=1e-10)
    assert rep["g_alpha"] == pytest.approx(ref["g_alpha"], abs=1e-9)
    assert rep["eps_alpha"] == pytest.approx(ref["eps_alpha"], abs=1e-10)
    assert rep["eps_beta"] == pytest.approx(ref["eps_beta"], abs=1e-12)
    assert rep["backlash_circumferential"] == pytest.approx(ref["j_wt"], abs=1e-10)
    assert rep["backlash_normal"] == pytest.approx(ref["j_bn"], abs=1e-10)
    assert rep["a_minus_a_0_um"] == pytest.approx((91.5 - _ref_of(c, pair)["a_0"]) * 1000, abs=1e-6)


def test_scene_tip_diameter_and_k_are_exclusive(tmp_path):
    text = (ROOT / "problems" / "fzg_c14.toml").read_text().replace('d_a = "82.46 mm"', 'd_a = "82.46 mm"\nk = 0.0')
    f = tmp_path / "s.toml"
    f.write_text(text)
    with pytest.raises(SceneError, match=r"\[pinion\] k and d_a"):
        load_scene(f)
