"""Each scene in problems/ runs through the CLI path and gives physically right scalars.

Expected values are computed here from textbook formulas (docs/theory.md section 3), independently of
gearopt's own report code.
"""

from __future__ import annotations

import math
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gearopt.cli import main
from gearopt.errors import SceneError
from gearopt.io.scene import load_scene

from results_doc import undocumented

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
SCENES = sorted(p for p in PROBLEMS.glob("*.toml"))
#: pytest markers of the scene runs: IPOPT (crowning study), CalculiX (fea study), above about 5 s
STUDY_MARKS = {"crowning": [pytest.mark.ipopt], "fea": [pytest.mark.calculix], "loaded_microgeometry": [pytest.mark.ipopt]}
SLOW_SCENES = {"crowning_spur", "fea_spur", "fea_crowned", "edge_spur_crossed", "montecarlo_spur", "montecarlo_loaded",
               "microgeometry_loaded", "microgeometry_pareto", "microgeometry_te_target"}


def _scene_param(scene: Path):
    marks = list(STUDY_MARKS.get(tomllib.loads(scene.read_text())["scene"]["study"], []))
    if scene.stem in SLOW_SCENES:
        marks.append(pytest.mark.slow)
    return pytest.param(scene, marks=marks, id=scene.stem)


def _inv(a):
    return math.tan(a) - a


def _inv_inverse(t):
    from scipy.optimize import brentq
    return brentq(lambda a: math.tan(a) - a - t, 1e-9, 1.55, xtol=1e-15)


@pytest.mark.parametrize("scene", [_scene_param(p) for p in SCENES])
def test_scene_runs_and_writes(scene, scene_run):
    """The scene runs through the CLI (once per test process: conftest.scene_run, whose results the
    physics tests below read) and writes documented results and clean plots."""
    if tomllib.loads(scene.read_text())["scene"]["study"] == "fea" and shutil.which("ccx") is None:
        pytest.skip("CalculiX (ccx) is not installed: the FE scene cannot run (make test installs it as root)")
    run = scene_run(scene.stem)
    assert run.status == 0
    res, out = run.results, run.out
    assert res["units"], "results must state units"
    # every key is documented in docs/results.md (rows of "every study" and of this study)
    assert undocumented(res, res["study"]) == [], "keys missing in docs/results.md"
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs, "plots must be written"
    for p in out.glob("*.png"):
        assert p.stat().st_size > 10_000
    if res["study"] == "loaded_microgeometry":
        _loaded_microgeometry_scalars(res, out)
    if res["scene"] == "fea_crowned":
        _fea_crowned_scalars(res)
    # what can be checked mechanically in every plot (tests/plot_lint.py): no offset text, every legend entry
    # drawn, nothing cut at the image's edge, no overlaps, no legend over the data where avoidable
    assert run.plot_problems == [], "plot problems:\n" + "\n".join(run.plot_problems)


def _fea_crowned_scalars(res):
    """The crowned spur pinion under a 3 arcmin crossing (problems/fea_crowned.toml): one pair at the
    pitch point, two at +-5.4 deg; the reaction is T / r_b1; every loaded pair's pattern integrates to
    its contact force and its centre lies off mid face on the side the crossing moves the TCA contact
    to (z1 < 0), by more than a millimetre at the pitch point."""
    assert res["options"]["misalignment"]["crossing_arcmin"] == pytest.approx(3.0)
    assert [len(p["loaded_pairs"]) for p in res["positions"]] == [2, 1, 2]
    for p in res["positions"]:
        assert p["reaction"]["rel_error"] < 0.01
        for k in p["loaded_pairs"]:
            pat = p["contact"]["pattern"][str(k)]
            q, zl = np.array(pat["q"]), np.array(pat["z_layers"])
            assert zl[0] == pytest.approx(-10.0) and zl[-1] == pytest.approx(10.0)  # the whole face
            assert np.sum(q * np.diff(zl)) == pytest.approx(p["pair_force_N"][str(k)], rel=1e-6)
            assert pat["z_centroid"] < -0.5 and p["contact_points"][str(k)]["z1"] < 0
    assert res["positions"][1]["contact"]["pattern"]["0"]["z_centroid"] < -1.0


def _loaded_microgeometry_scalars(res, out):
    """The micro-geometry optimisation under load (problems/microgeometry_loaded.toml): the start design
    loads its tip edges at every torque and case; the optimum loads none (verification grid, exact
    loaded TCA), agrees with the exact loaded TCA within 0.01 arcsec, lowers the objective by a third,
    keeps the pressure limit, and stays within its bounds."""
    d = res["design"]
    assert d["error"]["te_pp"] < 0.01
    assert d["after"]["objective_arcsec"] < d["before"]["objective_arcsec"]
    if res["scene"] == "microgeometry_loaded":
        assert min(min(r) for r in d["before"]["edge_share"]) > 0.2
        assert max(max(r) for r in d["after"]["edge_share"]) < 1e-4
        assert d["after"]["objective_arcsec"] < 0.67 * d["before"]["objective_arcsec"]
        assert max(max(r) for r in d["after"]["p_max_MPa"]) <= res["options"]["p_limit_MPa"] * 1.001
        # the derivatives are taken at the design (a converged optimum: the NLP's optimum is the design)
        assert d["sensitivities"]["model_step_um"] < 0.1 and d["sensitivities"]["at_design"]
    sens = d["sensitivities"]
    assert sens["at_design"] == (sens["model_step_um"] <= 1.0)
    # the active set is read cleanly from IPOPT's central path (no degenerate constraint: unique derivatives)
    assert sens["degenerate"] == 0 and sens["active"] >= 1
    assert all(math.isfinite(v) for v in sens["objective_arcsec_per_Nm"]) and len(sens["objective_arcsec_per_Nm"]) == \
        len(res["torques_Nm"])
    for k, v in d["theta_um"].items():
        lo, hi = res["options"]["free"][k]
        assert lo - 1e-6 <= v <= hi + 1e-6
    assert (out / "loaded_microgeometry.csv").read_text().count("\n") == 1 + len(res["cases"]) * len(res["torques_Nm"])
    if "pareto" in res:
        _pareto_scalars(res, out)
    if res["options"]["unloaded_te"] is not None:
        _unloaded_te_scalars(res, out)


def _unloaded_te_scalars(res, out):
    """The unloaded parabolic-TE target (problems/microgeometry_te_target.toml): the NLP's misfit is the
    exact slices'; each case's misfit recomputed here from the written unloaded TE (numpy least squares
    of the parabola plus a line) is the reported one; the term of the objective is the weighted sum
    of the smoothed misfits; the mirror-image cases (crossing +-2') have the same unloaded TE."""
    d, u = res["design"], res["design"]["unloaded_te"]
    assert d["error"]["te0_rms"] < 1e-4
    lvl = res["options"]["unloaded_te"]["level_arcsec"]
    W = np.sum(np.array(res["options"]["weights"]), axis=0)
    for key in ("before", "after"):
        rms = []
        for c, case in enumerate(u["cases"]):
            e = case[key]
            psi, te = np.array(e["psi"]), np.array(e["te_arcsec"])
            assert psi.size >= 0.9 * res["options"]["verify_positions"] and np.all(np.abs(psi) <= 1.0)
            V = np.stack([np.ones_like(psi), psi], axis=1)
            coef, *_ = np.linalg.lstsq(V, te + lvl * psi**2, rcond=None)
            rms.append(float(np.sqrt(np.mean((te + lvl * psi**2 - V @ coef) ** 2))))
            assert e["rms_arcsec"] == pytest.approx(rms[-1], abs=1e-9)
            assert d[key]["te0_rms_arcsec"][c] == pytest.approx(rms[-1], abs=1e-9)
        weight = res["options"]["unloaded_te"]["weight"]
        assert d[key]["te0_term_arcsec"] == pytest.approx(weight * float(np.sum(W * np.sqrt(np.array(rms) ** 2 + 1e-6))),
                                                          rel=1e-9)
        names = [c["name"] for c in u["cases"]]
        assert rms[names.index("crossing +2'")] == pytest.approx(rms[names.index("crossing -2'")], abs=1e-6)
    assert (out / "loaded_micro_unloaded_te.png").stat().st_size > 10_000


def _pareto_scalars(res, out):
    """The Pareto front (problems/microgeometry_pareto.toml): the optimum without a limit is the
    scene's design; every point meets its limit on the verification grid; the loaded TE rises as
    the limit tightens, by more than an arcsec over the front; the CSV has a row per point."""
    pts = res["pareto"]["points"]
    assert pts[0]["p_limit_MPa"] is None
    assert pts[0]["objective_arcsec"] == res["design"]["after"]["objective_arcsec"]
    ok = [p for p in pts if p["feasible"]]
    assert len(ok) >= 3
    for p in ok[1:]:
        assert p["p_max_MPa"] <= p["p_limit_MPa"] * 1.001
    te = [p["objective_arcsec"] for p in ok]
    assert all(b >= a - 1e-6 for a, b in zip(te, te[1:])) and te[-1] > te[0] + 1.0
    assert (out / "loaded_micro_pareto.csv").read_text().count("\n") == 1 + len(pts)
    assert (out / "loaded_micro_pareto.png").stat().st_size > 10_000


@pytest.mark.parametrize("scene", [p for p in SCENES if tomllib.loads(p.read_text())["scene"]["study"] == "geometry"],
                         ids=lambda p: p.stem)
def test_geometry_scene_scalars(scene):
    raw = tomllib.loads(scene.read_text())
    rep = load_scene(scene).build().run()
    s = load_scene(scene)
    p, g = s.pair.pinion, s.pair.gear
    m_n, beta, al_n = p.m_n, p.beta, p.rack.alpha_n
    al_t = math.atan(math.tan(al_n) / math.cos(beta))
    z1, z2, x1, x2 = raw["pinion"]["z"], raw["gear"]["z"], raw["pinion"].get("x", 0.0), raw["gear"].get("x", 0.0)
    r1, r2 = m_n * z1 / (2 * math.cos(beta)), m_n * z2 / (2 * math.cos(beta))
    rb1, rb2 = r1 * math.cos(al_t), r2 * math.cos(al_t)
    def tip(member, r, h_aP, x):  # d_a as written in the scene ("82.46 mm"), else k = 0
        d_a = raw[member].get("d_a")
        return float(str(d_a).split()[0]) / 2 if d_a is not None else r + m_n * (h_aP + x + raw[member].get("k", 0.0))
    ra1, ra2 = tip("pinion", r1, p.rack.h_aP, x1), tip("gear", r2, g.rack.h_aP, x2)
    # centre distance from x1 + x2 (inv alpha_w) unless given
    aw0 = _inv_inverse(_inv(al_t) + 2 * math.tan(al_n) * (x1 + x2) / (z1 + z2))
    a0 = (r1 + r2) * math.cos(al_t) / math.cos(aw0)
    a = s.pair.a if s.pair.a is not None else a0
    alw = math.acos((rb1 + rb2) / a)
    eps = (math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - a * math.sin(alw)) / (math.pi * m_n / math.cos(beta) * math.cos(al_t))
    assert rep.pair["a_0"] == pytest.approx(a0, rel=1e-12)
    assert rep.pair["eps_alpha"] == pytest.approx(eps, rel=1e-12)
    assert rep.pair["eps_beta"] == pytest.approx(min(p.b, g.b) * math.sin(beta) / (math.pi * m_n), rel=1e-12)
    assert rep.members["pinion"]["r_b"] == pytest.approx(rb1, rel=1e-14)
    assert rep.members["gear"]["r_b"] == pytest.approx(rb2, rel=1e-14)
    # Generated profile: the sampled flank is the involute of r_b and spans form radius .. tip radius.
    for name, rb, ra in (("pinion", rb1, ra1), ("gear", rb2, ra2)):
        fl = rep.profiles[name]["right_flank"]
        radii = [math.hypot(*pt) for pt in fl]
        assert max(radii) == pytest.approx(ra, abs=1e-9)
        assert min(radii) > rb
        m = rep.members[name]
        assert m["r_f"] < m["r_form"] < m["r_active_start"] < ra  # no involute interference in these scenes
    assert rep.pair["involute_interference"] is False
    assert 1.2 < rep.pair["eps_alpha"] < 2.0


def test_former_geometry_tool_keys_say_what_to_write(tmp_path):
    # [geometry] generation / N_s / ... (one tool for both members) moved to the gear-level tool.
    text = (PROBLEMS / "spur_geometry.toml").read_text().replace("points = 80", 'generation = "shaper"\nN_s = 30')
    f = tmp_path / "old.toml"
    f.write_text(text)
    with pytest.raises(SceneError, match=r'\[geometry\] generation, N_s: .*tool = \{kind = "shaper", z = 30\} under '
                                         r'\[pinion\] and under \[gear\]'):
        load_scene(f)


def test_shaper_generation_scene(tmp_path):
    text = (PROBLEMS / "spur_geometry.toml").read_text().replace('x = 0.3\n', 'x = 0.3\ntool = {kind = "shaper", z = 30}\n')
    f = tmp_path / "shaper.toml"
    f.write_text(text)
    rep = load_scene(f).build().run()
    # The shaper cuts a different root than the rack (cutting centre distance from x_s + x).
    assert rep.members["pinion"]["generation"] == "shaper"
    assert rep.members["gear"]["generation"] == "rack"
    assert rep.members["pinion"]["r_f"] != pytest.approx(rep.members["pinion"]["r_p"] + 3 * (0.3 - 1.25), abs=1e-6)


#: tca scenes with their own physics tests below (tip relief, measured flanks: not the parabolic TE
#: with symmetric transfers that test_tca_scene_physics expects)
MICRO = {"microgeometry_helical", "measured_flank"}


def _tca_scenes(edge=False):
    out = []
    for p in SCENES:
        raw = tomllib.loads(p.read_text())
        if raw["scene"]["study"] == "tca" and bool(raw.get("tca", {}).get("edge_contact", False)) == edge \
                and p.stem not in MICRO:
            out.append(p)
    return out


@pytest.fixture(scope="module")
def tca_reports(scene_run):
    return {p.stem: scene_run(p.stem).results for p in _tca_scenes()}


@pytest.mark.parametrize("name", [p.stem for p in _tca_scenes()])
def test_tca_scene_physics(tca_reports, name):
    rep = tca_reports[name]
    z1 = rep["pair"]["z1"]
    aligned, mis = rep["cases"][0], rep["cases"][1]
    for case in (aligned, mis):
        assert case["actual_te_at_every_position"]
        assert case["max_residual"] < 1e-10
        assert case["min_normal_dot"] == pytest.approx(-1.0, abs=1e-9) or case["min_normal_dot"] < -0.999999
        # A periodic parabola f = -a x^2 on [-L, L] has Fourier amplitudes 4 a L^2 / (pi^2 k^2):
        # the envelope of a parabolic-TE drive must show harmonics falling as 1/k^2.
        h = case["harmonics_arcsec"]
        assert h is not None
        assert h[0] / h[1] == pytest.approx(4.0, rel=0.05)
        assert h[0] / h[2] == pytest.approx(9.0, rel=0.08)
        assert h[0] == pytest.approx(4 * case["peak_to_peak_arcsec"] / math.pi**2, rel=0.05)
    # Aligned: transfer points at +-pi/z1 (symmetric parabolas), contact at mid face for a spur drive.
    phi = aligned["phi1"]
    step = phi[1] - phi[0]
    tr = sorted(aligned["transfer_phi1"])
    assert tr[0] == pytest.approx(-math.pi / z1, abs=step)
    assert tr[-1] == pytest.approx(math.pi / z1, abs=step)
    # The misalignment moves the transfer points (a linear TE absorbed by the parabola) or the path.
    z_al = [v for v, on in zip(aligned["pinion"]["axial"], aligned["on_surface"]) if on]
    z_mi = [v for v, on in zip(mis["pinion"]["axial"], mis["on_surface"]) if on]
    if rep["pair"]["beta_deg"] == 0:
        assert max(abs(v) for v in z_al) < 1e-9
        assert min(abs(v) for v in z_mi) > 0.5  # crossing shifts the bearing contact along the face
    else:
        assert sorted(mis["transfer_phi1"])[0] < tr[0] - 2 * step  # TE parabola shifted
    # The parabolic TE absorbs the misalignment: the level stays within 10 %.
    assert mis["peak_to_peak_arcsec"] == pytest.approx(aligned["peak_to_peak_arcsec"], rel=0.10)


EDGE_EXPECT = {  # scene: (edge contact aligned, edge contact misaligned, an edge that must carry load)
    "edge_spur_crossed": (False, True, "pinion_face-"),
    "edge_helical_crossing": (False, True, "pinion_tip"),
    "edge_helical_intersecting": (False, True, "gear_tip"),
    "edge_crowned_tip": (False, True, "pinion_tip"),
    "edge_crowned_avoided": (False, False, None),
}


@pytest.mark.parametrize("scene", _tca_scenes(edge=True), ids=lambda p: p.stem)
def test_edge_scene_physics(scene, scene_run):
    rep = scene_run(scene.stem).results
    aligned, mis = rep["cases"]
    exp_al, exp_mis, edge = EDGE_EXPECT[scene.stem]
    assert aligned["edge_carries_load"] is exp_al
    assert mis["edge_carries_load"] is exp_mis
    for case in (aligned, mis):
        env = [v for v in case["te_envelope_arcsec"] if v is not None]
        assert len(env) == len(case["phi1"]), "a position without any contact"
    if edge is not None:
        assert edge in set(a for a in mis["active_branch"] if a)
        # Edge contact makes the gear's angular velocity jump at the transfers (Litvin 9.6).
        # Scale: the mean TE slope over a cycle, p-p / (pi / z1).
        jumps = [abs(t["slope_jump"]) for t in mis["transfers"] if t["slope_jump"] is not None]
        scale = mis["peak_to_peak_arcsec"] / 206264.806 / (math.pi / rep["pair"]["z1"])
        assert max(jumps) > 0.5 * scale
    if rep["pair"]["pinion_a_c"] == 0 and rep["pair"]["pinion_a_pl"] == 0:
        # Unmodified gears: the aligned drive is conjugate, TE identically zero.
        assert max(abs(v) for v in aligned["te_envelope_arcsec"]) < 1e-7  # 5e-13 rad


# ------------------------------------------------------------------------------------------------
# Micro-geometry scenes (docs/microgeometry.md)
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def micro_reports(scene_run):
    return {s: scene_run(s).results
            for s in ("microgeometry_spur", "microgeometry_helical", "measured_flank", "tca_spur_crowned")}


def test_microgeometry_spur_is_tca_spur_crowned_in_shop_terms(micro_reports):
    """The ISO amounts of the scene are Litvin's settings of tca_spur_crowned converted (to the 0.01
    um the scene writes), and the two drives' TE agree: lead crowning = plunging exactly, the tool
    parabola ~ a parabola in roll length (a few per cent of the TE level)."""
    from gearopt.geometry.microgeometry import iso_from_litvin

    iso = iso_from_litvin(load_scene(PROBLEMS / "tca_spur_crowned.toml").pair)
    mods = micro_reports["microgeometry_spur"]["pair"]["pinion_modifications"]
    for k in ("C_alpha", "f_H_alpha", "C_beta"):
        assert mods[f"{k}_um"] == pytest.approx(1000 * iso[k], abs=0.005)
    for a, b in zip(micro_reports["microgeometry_spur"]["cases"], micro_reports["tca_spur_crowned"]["cases"]):
        env_a = [v for v in a["te_envelope_arcsec"] if v is not None]
        env_b = [v for v in b["te_envelope_arcsec"] if v is not None]
        assert len(env_a) == len(env_b) == len(a["phi1"])
        assert max(abs(x - y) for x, y in zip(env_a, env_b)) < 0.06 * b["peak_to_peak_arcsec"]
        assert a["peak_to_peak_arcsec"] == pytest.approx(b["peak_to_peak_arcsec"], rel=0.05)


def test_microgeometry_helical_charts_and_tip_relief(micro_reports):
    rep = micro_reports["microgeometry_helical"]
    raw = tomllib.loads((PROBLEMS / "microgeometry_helical.toml").read_text())["pinion"]["modifications"]
    d_Ca = float(raw["d_Ca"].split()[0])
    for side in ("right", "left"):
        ch = rep["inspection"]["pinion"][side]["charts_um"]
        assert ch["C_beta"] == pytest.approx(12.0, abs=1e-3)  # the lead trace at mid profile: C_beta alone
        assert abs(ch["f_H_beta"]) < 1e-6
        grid = rep["inspection"]["pinion"][side]["grid"]
        tip = [row[grid["z_mm"].index(0.0)] for row in grid["deviation_um"]][-1]
        # at the tip: profile crowning at the end of the evaluation range plus the full tip relief
        assert tip == pytest.approx(-6.0 - 8.0, abs=1e-6)
    s = load_scene(PROBLEMS / "microgeometry_helical.toml")
    r_b = s.pair.pinion.r_b
    L_Ca = math.sqrt((d_Ca / 2) ** 2 - r_b**2)
    for case in rep["cases"]:
        # the driving contact stays below the relief start (within its smooth start, a tenth of the
        # relief length): the tip relief shortens the path of contact there
        radii = [r for r, d, on in zip(case["pinion"]["radius"], case["driving_pair"], case["on_surface"])
                 if d == 0 and on and r is not None]
        L_max = max(math.sqrt(r**2 - r_b**2) for r in radii)
        L_a = math.sqrt(s.pair.pinion.r_a**2 - r_b**2)
        assert L_max <= L_Ca + 0.05 * (L_a - L_Ca) + 1e-6
        # the central pair's contact climbs the pinion flank up to the relief start, never past it
        # (without the relief it would run on to the tip): the path of contact ends at d_Ca
        L_all = [math.sqrt(r**2 - r_b**2) for r, on in zip(case["pinion"]["radius"], case["on_surface"])
                 if on and r is not None]
        assert L_Ca - 0.05 * (L_a - L_Ca) <= max(L_all) <= L_Ca + 0.05 * (L_a - L_Ca)


def test_measured_flank_reports_its_deviations(micro_reports):
    rep, design = micro_reports["measured_flank"], micro_reports["microgeometry_helical"]
    for side, slope in (("right", 2.0), ("left", -1.0)):  # measured_flank_make.py
        ch = rep["inspection"]["pinion"][side]["charts_um"]
        assert ch["f_H_beta"] == pytest.approx(slope, abs=0.01)
        assert ch["C_beta"] == pytest.approx(12.0, abs=0.01)
    assert rep["pair"]["pinion_modifications"]["measured"][0]["source"] == "measured_flank_right.csv"
    # the measured deviations differ from the design by at most 1.3 um (slope 1 um at the face ends
    # + 0.3 um bulge): the TE by at most 1.3 um / r_b2 (transverse, along the line of action)
    r_b2 = load_scene(PROBLEMS / "measured_flank.toml").pair.gear.r_b
    bound = 1.3e-3 / r_b2 * 206264.806
    for a, b in zip(rep["cases"], design["cases"]):
        d = [abs(x - y) for x, y in zip(a["te_envelope_arcsec"], b["te_envelope_arcsec"]) if x is not None and y is not None]
        assert len(d) == len(a["phi1"])
        assert 0.01 < max(d) < bound


@pytest.mark.parametrize("edit, param", [
    (('C_beta = "12 um"', 'C_beta = "12 deg"'), "[pinion.modifications] C_beta"),
    (('C_beta = "12 um"', 'C_beta = "-3 um"'), "[pinion.modifications] C_beta"),
    (('d_Ca = "59.2 mm"', 'd_Ca = "70 mm"'), "[pinion.modifications] d_Ca"),
    (('d_Ca = "59.2 mm"', 'd_Cx = "59.2 mm"'), "[pinion.modifications] d_Cx"),
    (('tip_shape = "linear"', 'tip_shape = "round"'), "[pinion.modifications] tip_shape"),
    (('C_beta = "12 um"', 'C_beta = "500 um"'), "[pinion.modifications] C_beta"),
])
def test_bad_modification_keys_name_the_key(tmp_path, edit, param):
    text = (PROBLEMS / "microgeometry_helical.toml").read_text()
    assert edit[0] in text
    f = tmp_path / "bad.toml"
    f.write_text(text.replace(edit[0], edit[1]))
    with pytest.raises(SceneError) as e:
        load_scene(f)
    assert e.value.param == param or param in [getattr(p, "param", None) for p in getattr(e.value, "problems", [])]


def test_bad_measured_files_name_the_file_and_row(tmp_path):
    text = (PROBLEMS / "measured_flank.toml").read_text()
    good = (PROBLEMS / "measured_flank_right.csv").read_text().splitlines()
    (tmp_path / "measured_flank_left.csv").write_text((PROBLEMS / "measured_flank_left.csv").read_text())
    bad = good[:10] + [good[10].replace(",", ",nan,", 1).replace(",nan,", ",", 0)] + good[11:]
    row = good[10].split(",")
    row[3] = "nan"
    (tmp_path / "measured_flank_right.csv").write_text("\n".join(good[:10] + [",".join(row)] + good[11:]) + "\n")
    f = tmp_path / "m.toml"
    f.write_text(text)
    with pytest.raises(SceneError) as e:
        load_scene(f)
    assert e.value.param == "[pinion.measured] right" and "line 11" in str(e.value) and "column 3" in str(e.value)
    (tmp_path / "measured_flank_right.csv").unlink()
    with pytest.raises(SceneError) as e:
        load_scene(f)
    assert e.value.param == "[pinion.measured] right"
    del bad


# --- loaded TCA scenes ----------------------------------------------------------------------------
LTCA_SCENES = ("ltca_spur", "ltca_crowned", "ltca_helical")


@pytest.fixture(scope="module")
def ltca_reports(scene_run):
    return {s: scene_run(s).results for s in LTCA_SCENES}


def test_ltca_spur_scene(ltca_reports):
    d = ltca_reports["ltca_spur"]
    assert d["unloaded_peak_to_peak_arcsec"] < 1e-6  # conjugate
    T = [t["torque_Nm"] for t in d["torques"]]
    assert T[0] == pytest.approx(0.1 * d["nominal_torque_Nm"]) and T[-1] == pytest.approx(1.5 * d["nominal_torque_Nm"])
    pp = [t["peak_to_peak_arcsec"] for t in d["torques"]]
    assert all(b > a for a, b in zip(pp, pp[1:]))  # an unmodified pair: TE grows with load
    # ISO 6336-1 mean mesh stiffness of this standard steel pair, computed here from the standard
    z1, z2 = d["pair"]["z1"], d["pair"]["z2"]
    q = 0.04723 + 0.15551 / z1 + 0.25791 / z2
    c_gamma = 1 / q * 0.8 * 0.975 * (0.75 * d["pair"]["eps_alpha"] + 0.25)
    assert d["iso6336"]["c_gamma_alpha"] == pytest.approx(c_gamma, rel=1e-9)
    assert 0.85 < d["iso6336"]["ltca_c_gamma_at_nominal"] / c_gamma < 1.15
    for t in d["torques"]:
        assert t["kkt_error_max_mm"] < 1e-7
        share = [[v or 0.0 for v in row] for row in t["pair_share"]]
        assert all(abs(sum(col) - 1) < 1e-9 for col in zip(*share))


def test_ltca_crowned_and_helical_scenes(ltca_reports):
    c = ltca_reports["ltca_crowned"]
    assert c["unloaded_peak_to_peak_arcsec"] > 5  # the crossing's TE, absorbed by the parabola
    t20, t200 = c["torques"][0], c["torques"][4]
    assert t200["torque_Nm"] == 200.0 and t20["torque_Nm"] == 20.0
    # light load: the loaded TE follows the unloaded one; at 200 N m the pattern has spread
    assert abs(t20["peak_to_peak_arcsec"] - c["unloaded_peak_to_peak_arcsec"]) < 0.5 * c["unloaded_peak_to_peak_arcsec"]
    assert 1000 < t200["p_max_MPa"] < 2500
    h = ltca_reports["ltca_helical"]
    nom = [t for t in h["torques"] if t["torque_Nm"] == h["nominal_torque_Nm"]][0]
    spur_nom = [t for t in ltca_reports["ltca_spur"]["torques"] if t["torque_Nm"] == 200.0][0]
    assert nom["peak_to_peak_arcsec"] < 0.25 * spur_nom["peak_to_peak_arcsec"]
    shares = [[v or 0.0 for v in row] for row in nom["pair_share"]]
    assert min(sum(1 for v in col if v > 0.01) for col in zip(*shares)) >= 2


@pytest.mark.parametrize("edit, param", [
    (("torque = 200.0", "torque = 200.0\ntorques = [100.0, 50.0]"), "[ltca] torques"),
    (("torque = 200.0", "torque = 200.0\ntorques = [0.0, 50.0]"), "[ltca] torques"),
    (("torque = 200.0", "torque = -1.0"), "[ltca] torque"),
    (("E = 206000.0", "E = 206.0"), "[ltca] E"),
    (("nu = 0.3", "nu = 0.6"), "[ltca] nu"),
    (("torque = 200.0", "torque = 200.0\nr_int_pinion = \"29 mm\""), "[ltca] r_int_pinion"),
    (("torque = 200.0", "torque = 200.0\nslices = 11"), "[ltca] slices"),
])
def test_bad_ltca_keys_name_the_key_and_write_nothing(tmp_path, edit, param):
    params, _ = _bad_scene(tmp_path, "ltca_spur", edit)
    assert param in params


def _bad_scene(tmp_path, scene: str, edit) -> tuple[list, str]:
    """Write ``problems/<scene>.toml`` with ``edit = (old, new)`` applied; check that building it raises
    SceneError and that ``gearopt run`` fails writing nothing. Returns the error's params (its own and
    its problems') and its message."""
    text = (PROBLEMS / f"{scene}.toml").read_text()
    assert edit[0] in text
    f = tmp_path / "bad.toml"
    f.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(SceneError) as e:
        load_scene(f).build()
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--quiet"]) != 0
    assert not out.exists()
    return [e.value.param] + [getattr(p, "param", None) for p in getattr(e.value, "problems", [])], str(e.value)


@pytest.mark.parametrize("edit, param", [
    (('C_alpha = { lo = "0 um", hi = "40 um" }', 'C_gamma = { lo = "0 um", hi = "40 um" }'),
     "[loaded_microgeometry.free.pinion] C_gamma"),
    (('C_alpha = { lo = "0 um", hi = "40 um" }', 'C_alpha = { lo = "30 um", hi = "20 um" }'), None),
    (('C_alpha = { lo = "0 um", hi = "40 um" }', 'C_alpha = { lo = "0 um", hi = "2 um" }'), None),  # start 5 um
    (('d_Ca = "64 mm"      # tip relief from d = 64 mm to the tip (d_a = 66 mm)', ''), None),  # no tip relief start
    (("torques = [100.0, 250.0]", "torques = [250.0, 100.0]"), "[loaded_microgeometry] torques"),
    (("torques = [100.0, 250.0]", "torques = [100.0, 250.0]\nweights = [1.0]"), "[loaded_microgeometry] weights"),
    (("p_limit = 2600.0", "p_limit = 20.0"), "[loaded_microgeometry] p_limit"),
    (("p_limit = 2600.0", "p_limit = 2600.0\nharmonics = [1.0, -0.5]"), "[loaded_microgeometry] harmonics"),
    (("p_limit = 2600.0", "p_limit = 2600.0\npareto = [2000.0, 2000.0]"), "[loaded_microgeometry] pareto"),
    (("p_limit = 2600.0", "p_limit = 2600.0\npareto = [50.0]"), "[loaded_microgeometry] pareto"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0 um"'), "[loaded_microgeometry] edge_margin"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { level = "-8 arcsec" }'),
     "[loaded_microgeometry.unloaded_te] level"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { level = "8 arcsec", weight = 0.0 }'),
     "[loaded_microgeometry.unloaded_te] weight"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { weight = 2.0 }'),
     "[loaded_microgeometry.unloaded_te] level"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { level = "8 arcsec", wieght = 2.0 }'),
     "[loaded_microgeometry.unloaded_te] wieght"),
])
def test_bad_loaded_microgeometry_keys_name_the_key_and_write_nothing(tmp_path, edit, param):
    """Bad keys of the loaded micro-geometry scene stop before the optimisation, naming the key (the
    bounds of a free amount, as checked by the optimiser, name the amount), and write nothing."""
    params, msg = _bad_scene(tmp_path, "microgeometry_loaded", edit)
    if param is not None:
        assert param in params
    else:
        assert any(p and ("C_alpha" in p or "free" in p) for p in params) or "C_alpha" in msg
