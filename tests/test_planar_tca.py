"""Planar involute TCA (Litvin & Fuentes, Problem 9.4.1, eqs. 9.4.23-9.4.46).

Every figure is derived from the Newton-solved points and compared with the book's closed form.
"""

from __future__ import annotations

import json
import math
import re
import textwrap
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from gearopt.errors import ConvergenceError, GeometryError
from gearopt.meshing.planar import (FLAG_FALSE_ROOT, FLAG_SINGULAR, PlanarTCA, closed_form, involute_1,
                                    involute_2, planar_functions, solve_planar_tca)
from gearopt.units import DEG

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "problem_9_4_1.toml"

# (r_b1, r_b2, E) [mm]: standard 20/32 m4 pair, the scene's E, E barely above r_b1 + r_b2,
# E three times r_b1 + r_b2 (alpha = 70.5 deg), equal gears, gear 1 larger than gear 2.
CASES = [
    (37.58770483143634, 60.14032773029814, 104.0),
    (37.58770483143634, 60.14032773029814, 106.0),
    (20.0, 80.0, 100.05),
    (30.0, 45.0, 225.0),
    (50.0, 50.0, 130.0),
    (61.3, 24.7, 92.0),
]


def sweep(r_b1, r_b2, E, n=25, margin=0.05):
    lo, hi = closed_form(r_b1, r_b2, E)["phi1_range"]
    return np.linspace(lo + margin * (hi - lo), hi - margin * (hi - lo), n)


@pytest.mark.parametrize("method", ["continuation", "map"])
@pytest.mark.parametrize("r_b1,r_b2,E", CASES)
def test_solved_points_reproduce_book(r_b1, r_b2, E, method):
    res = solve_planar_tca(r_b1, r_b2, E, sweep(r_b1, r_b2, E), method=method)
    assert np.all(res.flags == 0)
    assert np.max(res.residual) < 1e-12
    assert np.all(res.n_dot > 0)
    m12 = r_b2 / r_b1
    # gear ratio (eq. 9.4.41), from the least-squares line through the solved (phi2, phi1) ...
    assert abs(res.m12 / m12 - 1) < 1e-12
    assert res.m12_fit_residual < 1e-12
    # ... and pointwise from the AD tangent (implicit function theorem)
    assert np.max(np.abs(res.m12_local / m12 - 1)) < 1e-12
    # line of action: orientation (eq. 9.4.44) and point I (eq. 9.4.46)
    assert abs(res.cos_loa - (r_b1 + r_b2) / E) < 1e-12
    assert abs(res.y_I - E / (1 + res.m12)) < 1e-12 * E
    assert abs(res.y_I - E / (1 + m12)) < 1e-12 * E
    # straight and tangent to both base circles, crossing the centre line between O1 and O2
    assert res.loa_straightness < 1e-12 * E
    assert abs(res.dist_O1 - r_b1) < 1e-12 * E and abs(res.dist_O2 - r_b2) < 1e-12 * E
    assert res.crosses_centre_line and res.tangent_to_base_circles(1e-12)
    assert 0 < res.y_I < E
    # transmission error identically zero
    assert np.max(np.abs(res.te)) < 1e-12
    # same point on both profiles; theta1 - phi1 = theta2 + phi2 = alpha (eq. 9.4.39)
    assert np.max(np.linalg.norm(res.r_f1 - res.r_f2, axis=1)) < 1e-12 * E
    alpha = math.acos((r_b1 + r_b2) / E)
    assert np.max(np.abs(res.theta1 - res.phi1 - alpha)) < 1e-12
    assert np.max(np.abs(res.theta2 + res.phi2 - alpha)) < 1e-12
    assert res.errors["phi2_max_abs"] < 1e-12
    assert res.solve_time_s > 0 and res.time_per_position_s < 0.05


def test_frames_reproduce_scalar_equations_9_4_32_to_35():
    """r_f^(1) - r_f^(2) and n_f^(1) - n_f^(2) built with M_f1, M_f2 (eq. 9.4.30) equal the book's
    scalar equations 9.4.32-9.4.35 term by term, for arbitrary (not solved) arguments."""
    f = planar_functions()["residual"]
    rng = np.random.default_rng(1)
    rb1, rb2, E = 37.0, 52.0, 101.0
    for _ in range(20):
        th1, th2, phi2, phi1 = rng.uniform(-1.5, 1.5, 4)
        out = f(x=[th1, th2, phi2], phi1=phi1, r_b1=rb1, r_b2=rb2, E=E)
        d = np.asarray(out["r_f1"] - out["r_f2"]).ravel()
        dn = np.asarray(out["n_f1"] - out["n_f2"]).ravel()
        a, b = th1 - phi1, th2 + phi2
        eq32 = rb1 * (math.sin(a) - th1 * math.cos(a)) - rb2 * (-math.sin(b) + th2 * math.cos(b))
        eq33 = rb1 * (math.cos(a) + th1 * math.sin(a)) - rb2 * (-math.cos(b) - th2 * math.sin(b)) - E
        eq34 = math.cos(a) - math.cos(b)
        eq35 = math.sin(a) - math.sin(b)
        assert d == pytest.approx([eq32, eq33], abs=1e-12)
        assert dn == pytest.approx([eq34, -eq35], abs=1e-14)
        g = np.asarray(out["g"]).ravel()
        assert g[:2] == pytest.approx(d / E, abs=1e-14)
        assert g[2] == pytest.approx(math.sin(a - b), abs=1e-14)


def test_normals_have_the_books_orientation():
    """n1 = t1 x k1 (eq. 9.4.28) and n2 = k2 x t2 (eq. 9.4.29), t the unit tangent, theta > 0."""
    th, rb = ca.SX.sym("th"), 40.0
    r1, n1 = involute_1(th, rb)
    r2, n2 = involute_2(th, rb)
    t1, t2 = ca.jacobian(r1, th), ca.jacobian(r2, th)
    t1, t2 = t1 / ca.norm_2(t1), t2 / ca.norm_2(t2)
    F = ca.Function("F", [th], [n1, ca.vertcat(t1[1], -t1[0]), n2, ca.vertcat(-t2[1], t2[0])])
    for v in (1e-3, 0.2, 0.7, 1.4):
        a, b, c, d = (np.asarray(o).ravel() for o in F(v))
        assert a == pytest.approx(b, abs=1e-12) and c == pytest.approx(d, abs=1e-12)


def test_ad_jacobian_matches_finite_differences():
    fns = planar_functions()
    res, jac = fns["residual"], fns["jacobian"]
    rng = np.random.default_rng(7)
    p = (37.6, 60.1, 106.0)
    h = 1e-6
    for _ in range(10):
        x = rng.uniform([0.05, 0.05, -0.5], [1.2, 1.2, 0.5])
        phi1 = rng.uniform(-0.3, 0.5)
        Jx, Jp = (np.asarray(m) for m in jac(x, phi1, *p))
        fd = np.empty((3, 3))
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            fd[:, k] = (np.asarray(res(x + e, phi1, *p)[0]) - np.asarray(res(x - e, phi1, *p)[0])).ravel() / (2 * h)
        fdp = (np.asarray(res(x, phi1 + h, *p)[0]) - np.asarray(res(x, phi1 - h, *p)[0])).ravel() / (2 * h)
        assert Jx == pytest.approx(fd, abs=1e-8)
        assert Jp.ravel() == pytest.approx(fdp, abs=1e-8)


def test_compiled_functions_have_named_io():
    fns = planar_functions()
    assert fns is planar_functions()  # compiled once
    assert fns["residual"].name() == "planar_tca_residual"
    assert fns["residual"].name_in() == ["x", "phi1", "r_b1", "r_b2", "E"]
    assert fns["residual"].name_out() == ["g", "r_f1", "r_f2", "n_f1", "n_f2"]
    assert fns["rootfinder"].name_in()[0] == "x0"
    assert fns["tangent"].name_out() == ["dx_dphi1"]


def _false_root_guess(r_b1, r_b2, E, phi1):
    """A point of the opposite-normal branch: theta2 + phi2 = theta1 - phi1 + pi, which solves
    r_f1 = r_f2 with cos(a) = (r_b1 - r_b2)/E, r_b1 theta1 - r_b2 theta2 = E sin(a)."""
    a = math.acos((r_b1 - r_b2) / E)
    th1 = a + phi1
    th2 = (r_b1 * th1 - E * math.sin(a)) / r_b2
    return np.array([th1, th2, a + math.pi - th2])


@pytest.mark.parametrize("method", ["continuation", "map"])
def test_false_root_is_flagged_and_raises(method):
    r_b1, r_b2, E = 37.6, 60.1, 106.0
    phi1 = 1.5  # theta1, theta2 > 0 on the false branch: only the orientation check can reject it
    x_false = _false_root_guess(r_b1, r_b2, E, phi1)
    assert x_false[0] > 0 and x_false[1] > 0
    tca = PlanarTCA(r_b1, r_b2, E)
    guess = x_false + np.array([0.04, -0.03, 0.02])  # near the opposite-normal branch
    res = tca.solve([phi1], x0=guess, method=method, on_fail="flag")
    # Newton did converge: the single normal equation n_f1 x n_f2 = 0 admits this root ...
    assert res.residual[0] < 1e-12
    # ... but the normals are opposite, and the point is flagged (only for that reason)
    assert res.n_dot[0] == pytest.approx(-1.0, abs=1e-12)
    assert res.flags[0] == FLAG_FALSE_ROOT
    assert res.flag_names(0) == ["false_root"]
    assert not res.ok.any()
    with pytest.raises(ConvergenceError, match="false_root"):
        tca.solve([phi1], x0=guess, method=method)


def test_false_root_in_a_sweep_is_not_used_by_the_derived_figures():
    r_b1, r_b2, E = 37.6, 60.1, 106.0
    phi1 = sweep(r_b1, r_b2, E, n=9)
    tca = PlanarTCA(r_b1, r_b2, E)
    x0 = np.vstack([tca.solve(phi1).theta1, tca.solve(phi1).theta2, tca.solve(phi1).phi2])
    x0[:, 4] = _false_root_guess(r_b1, r_b2, E, phi1[4]) + 0.01
    res = tca.solve(phi1, x0=x0, on_fail="flag")
    assert res.flags[4] & FLAG_FALSE_ROOT and np.all(np.delete(res.flags, 4) == 0)
    assert abs(res.m12 / (r_b2 / r_b1) - 1) < 1e-12 and res.tangent_to_base_circles(1e-12)
    with pytest.raises(ConvergenceError, match="1 of 9 positions rejected"):
        tca.solve(phi1, x0=x0)


def test_singular_point_and_out_of_range_positions_are_flagged():
    r_b1, r_b2, E = 37.6, 60.1, 106.0
    lo, hi = closed_form(r_b1, r_b2, E)["phi1_range"]
    tca = PlanarTCA(r_b1, r_b2, E)
    res = tca.solve([lo - 0.05, lo, 0.5 * (lo + hi), hi + 0.05], on_fail="flag")
    assert [bool(f & FLAG_SINGULAR) for f in res.flags] == [True, True, False, True]
    with pytest.raises(ConvergenceError, match="singular_point"):
        tca.solve([lo, 0.0])


@pytest.mark.parametrize("args,name,valid", [
    ((30.0, 40.0, 70.0), "E", "E > r_b1 + r_b2 = 70 mm"),
    ((30.0, 40.0, 60.0), "E", "E > r_b1 + r_b2 = 70 mm"),
    ((0.0, 40.0, 100.0), "r_b1", "r_b1 > 0 mm"),
    ((30.0, -4.0, 100.0), "r_b2", "r_b2 > 0 mm"),
    ((30.0, 40.0, float("nan")), "E", "E > r_b1 + r_b2"),
])
def test_bad_geometry_raises(args, name, valid):
    with pytest.raises(GeometryError, match=rf"^{name} = .* is out of range; valid: {re.escape(valid)}"):
        PlanarTCA(*args)


def test_result_to_dict_is_json_with_units():
    res = solve_planar_tca(30.0, 45.0, 225.0, sweep(30.0, 45.0, 225.0, n=5))
    d = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert d["units"]["length"] == "mm" and d["units"]["te_arcsec"] == "arcsec"
    assert d["derived"]["line_of_action"]["tangent_to_base_circles"] is True
    assert len(d["positions"]["phi2"]) == 5


@pytest.mark.slow
def test_scene_runs_through_cli(tmp_path):
    from gearopt.cli import main

    out = tmp_path / "out"
    assert main(["run", str(PROBLEM), "--out", str(out), "--quiet"]) == 0
    d = json.loads((out / "results.json").read_text())
    assert d["study"] == "planar_tca" and d["units"]["te_arcsec"] == "arcsec"
    E, rb1, rb2 = d["input"]["E"], d["input"]["r_b1"], d["input"]["r_b2"]
    assert E == 106.0  # not the standard 104 mm
    loa = d["derived"]["line_of_action"]
    assert abs(loa["cos_angle"] - (rb1 + rb2) / E) < 1e-12
    assert abs(loa["y_I"] - E / (1 + rb2 / rb1)) < 1e-12 * E
    assert abs(d["derived"]["m12"] - 1.6) < 1e-12
    assert d["derived"]["te_max_abs"] < 1e-12
    assert d["notes"] == []  # [planar_tca] agrees with the pair
    for png in ("line_of_action.png", "transmission_error.png"):
        assert (out / png).stat().st_size > 10_000


def _scene(tmp_path, body):
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent("""\
        [scene]
        name = "t"
        study = "planar_tca"
        [pair]
        m_n = 4
        [pinion]
        z = 20
        b = 30
        [gear]
        z = 32
        b = 28
        """) + textwrap.dedent(body))
    return p


@pytest.mark.slow
def test_scene_far_from_standard_and_defaults(tmp_path):
    from gearopt.cli import main

    out = tmp_path / "o"
    scene = _scene(tmp_path, """\
        [planar_tca]
        r_b1 = 25
        r_b2 = 70
        E = "190 mm"
        n = 7
        method = "map"
        """)
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    d = json.loads((out / "results.json").read_text())
    assert abs(d["derived"]["line_of_action"]["cos_angle"] - 0.5) < 1e-12
    assert abs(d["derived"]["line_of_action"]["y_I"] - 190 / (1 + 2.8)) < 1e-12 * 190
    assert any("differs from the pair" in n for n in d["notes"])
    # no [planar_tca] values: everything from the pair (r_b = m z cos 20 deg / 2, E = a_0 = 104 mm)
    out2 = tmp_path / "o2"
    assert main(["run", str(_scene(tmp_path, "")), "--out", str(out2), "--quiet"]) == 0
    d2 = json.loads((out2 / "results.json").read_text())
    assert d2["input"]["E"] == pytest.approx(104.0, abs=1e-9)
    assert d2["input"]["r_b1"] == pytest.approx(40 * math.cos(20 * DEG), abs=1e-12)


@pytest.mark.parametrize("body,text", [
    ("[planar_tca]\nE = 90\n", "[planar_tca] E = 90 is out of range; valid: E > r_b1 + r_b2"),
    ('[planar_tca]\nE = "3.5 in"\n', '[planar_tca] E = "3.5 in" is out of range; valid: E > r_b1 + r_b2 = 97.728 mm'),
    ("[planar_tca]\nphi1_min = -30\n", "[planar_tca] phi1_min = -30 deg is out of range; valid: -20 < phi1 <"),
    ("[planar_tca]\nr_b1 = 0\n", "[planar_tca] r_b1 = 0 is out of range"),
])
def test_bad_scene_values_name_key_and_range(tmp_path, capsys, body, text):
    from gearopt.cli import main

    assert main(["run", str(_scene(tmp_path, body)), "--out", str(tmp_path / "x"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert text in err
    assert not (tmp_path / "x").exists()


