"""The scenes of problems/ for gear data (geometry), planar TCA and TCA without edge contact run through
the CLI path and give physically right scalars (the other studies' scenes: test_problems_edge.py,
test_problems_loaded.py, test_problems_studies.py).

Expected values are computed here from textbook formulas (docs/theory.md section 3), independently of
gearopt's own report code.
"""

from __future__ import annotations

import math
import tomllib

import pytest

from gearopt.errors import SceneError
from gearopt.io.scene import load_scene

from scenes import PROBLEMS, SCENES, check_scene_run, edge_contact, scene_param, study



@pytest.mark.parametrize("scene", [scene_param(p) for p in SCENES if study(p) in ("geometry", "planar_tca") or (study(p) == "tca" and not edge_contact(p))])
def test_scene_runs_and_writes(scene, scene_run):
    """The scene runs through the CLI (once per test process: conftest.scene_run, whose results the
    physics tests read) and writes documented results and clean plots (scenes.check_scene_run)."""
    check_scene_run(scene, scene_run)


def _inv(a):
    return math.tan(a) - a


def _inv_inverse(t):
    from scipy.optimize import brentq
    return brentq(lambda a: math.tan(a) - a - t, 1e-9, 1.55, xtol=1e-15)


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


def tca_scenes(edge=False):
    out = []
    for p in SCENES:
        raw = tomllib.loads(p.read_text())
        if raw["scene"]["study"] == "tca" and bool(raw.get("tca", {}).get("edge_contact", False)) == edge \
                and p.stem not in MICRO:
            out.append(p)
    return out


@pytest.fixture(scope="module")
def tca_reports(scene_run):
    return {p.stem: scene_run(p.stem).results for p in tca_scenes()}


@pytest.mark.slow
@pytest.mark.parametrize("name", [p.stem for p in tca_scenes()])
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


# ------------------------------------------------------------------------------------------------
# Micro-geometry scenes (docs/microgeometry.md)
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def micro_reports(scene_run):
    return {s: scene_run(s).results
            for s in ("microgeometry_spur", "microgeometry_helical", "measured_flank", "tca_spur_crowned")}


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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
