"""The rating study (gearopt.studies.rating): scenes, refusals, the loaded TCA's load factors, outputs.

The fast tier checks the refusals (a scene with a bad key exits 2 naming it and writes nothing) and
the face load factor of a load map built here by hand; the slow tier runs problems/rating_*.toml and
checks the outputs against docs/results.md and the ISO relations between the two sets of factors.
"""

from __future__ import annotations

import csv
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from gearopt.cli import main
from gearopt.rating.pair import face_load_factor

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"
sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_doc import undocumented  # noqa: E402


def variant(tmp_path: Path, name: str, old: str, new: str) -> Path:
    text = (PROBLEMS / name).read_text()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(("old", "new", "key"), [
    ('pinion_material = "Eh"', 'pinion_material = "Steel42"', "pinion_material"),
    ('gear_material = "Eh"', 'gear_material = "Eh"\ngear_grade = "MX"', "gear_grade"),
    ("speed = 1500.0", "speed = 0.0", "speed"),
    ("life = 20000.0", "life = 0.0", "life"),
    ("z = 40", "z = -40", "z"),
])
def test_scene_refusals_write_nothing(tmp_path, capsys, old, new, key):
    """Unknown material or grade, speed 0 (K_v method B), life 0, an internal gear: exit 2, the key named,
    no output directory."""
    scene = variant(tmp_path, "rating_spur.toml", old, new)
    out = tmp_path / "out"
    capsys.readouterr()
    rc = main(["run", str(scene), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "\nerror: " in "\n" + err and "Traceback" not in err, err
    assert re.search(rf"\b{key}\b", err), err
    assert not out.exists()


@pytest.mark.parametrize(("old", "new", "key"), [
    ("spectrum_share = [0.10, 0.30, 0.30, 0.20, 0.08, 0.02]", "spectrum_share = [0.10, 0.30, 0.30, 0.20, 0.08, 0.12]",
     "spectrum_share"),
    ("spectrum_share = [0.10, 0.30, 0.30, 0.20, 0.08, 0.02]", "spectrum_share = [0.5, 0.5]", "spectrum_share"),
    ("spectrum_speed = [3000.0, 3000.0, 3000.0, 3000.0, 2500.0, 2000.0]", "", "spectrum_speed"),
])
def test_spectrum_refusals_write_nothing(tmp_path, capsys, old, new, key):
    """Spectrum shares that do not add up to 1, lists of different lengths, a missing list: exit 2 naming
    the key, nothing written."""
    scene = variant(tmp_path, "rating_spectrum.toml", old, new)
    out = tmp_path / "out"
    rc = main(["run", str(scene), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and re.search(rf"\b{key}\b", err), err
    assert not out.exists()


def test_high_contact_ratio_is_refused_before_the_ltca(tmp_path, capsys):
    """An 80/160 pair cut by a 14.5 deg deep-tooth rack (eps_alpha = 3.2, outside ISO 6336's range):
    refused when the study is built, naming eps_alpha; nothing written."""
    text = (PROBLEMS / "rating_spur.toml").read_text()
    text = text.replace('[rack]\npreset = "A"', '[rack]\nalpha_n = "14.5 deg"\nh_aP = 1.4\nh_fP = 1.65\nrho_fP = 0.2')
    text = text.replace("[pinion]\nz = 20", "[pinion]\nz = 80").replace("[gear]\nz = 40", "[gear]\nz = 160")
    text = text.replace('C_alpha_a = "10 um"\nd_Ca = "64 mm"', "")
    scene = tmp_path / "rating_hcr.toml"
    scene.write_text(text)
    out = tmp_path / "out"
    rc = main(["run", str(scene), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "eps_alpha" in err and "2.5" in err, err
    assert not out.exists()


def test_face_load_factor_by_hand():
    """One pair, one position, a load rising linearly across 5 equal sections 1:2:3:4:5 (mean 3):
    K_Hbeta = 5/3. Two pairs in contact at a section add; an unused node (NaN) counts nothing."""
    w = np.full((1, 1, 5), 2.0)
    load = np.array([[[1.0, 2.0, 3.0, 4.0, 5.0]]]) * 2.0
    k, dist = face_load_factor(load, w)
    assert k == pytest.approx(5 / 3)
    assert dist == pytest.approx([1, 2, 3, 4, 5])
    two = np.concatenate([load, np.array([[[np.nan, np.nan, 0.0, 0.0, 0.0]]])], axis=0)
    assert face_load_factor(two, np.concatenate([w, w]))[0] == pytest.approx(5 / 3)
    # two positions, uniform then linear: the cycle mean is 1, 1.5, 2, 2.5, 3 (peak over mean 3/2)
    cyc = np.array([[[1.0, 1.0, 1.0, 1.0, 1.0], [1.0, 2.0, 3.0, 4.0, 5.0]]]) * 2.0
    assert face_load_factor(cyc, np.full((1, 2, 5), 2.0))[0] == pytest.approx(1.5)
    flat = np.full((2, 3, 4), 10.0)
    assert face_load_factor(flat, np.full((2, 3, 4), 1.0))[0] == pytest.approx(1.0)


@pytest.fixture(scope="module")
def spur_run(scene_run):
    """problems/rating_spur.toml through the CLI: the session's shared run (conftest.scene_run), its
    output directory and results."""
    run = scene_run("rating_spur")
    assert run.status == 0
    return run.out, run.results


@pytest.mark.slow
def test_rating_spur_outputs(spur_run):
    """Every results.json key documented; the tables and the plot written; the nominal torque rated."""
    out, d = spur_run
    assert undocumented(d, "rating") == []
    assert {p.name for p in out.iterdir()} >= {"results.json", "rating_factors.csv", "rating_vs_torque.csv",
                                               "rating_safety.png"}
    rows = list(csv.reader((out / "rating_factors.csv").open()))
    symbols = {r[0] for r in rows[1:]}
    assert {"K_v", "K_Hbeta", "K_Halpha", "Z_H", "Z_E", "Z_eps", "Z_B", "Z_NT", "Z_L", "Z_v", "Z_R", "Z_X", "Y_F",
            "Y_S", "Y_beta", "Y_B", "Y_DT", "Y_NT", "Y_deltarelT", "Y_RrelT", "Y_X", "S_H", "S_F"} <= symbols
    assert d["load_factors_used"] == "ltca" and d["nominal"]["sources"]["K_Hbeta"] == "given"
    assert len(d["torques"]) == 6


@pytest.mark.slow
def test_rating_spur_two_sets_obey_iso(spur_run):
    """sigma_H scales with sqrt(K_Hbeta K_Halpha) and sigma_F with K_Fbeta K_Falpha between the two sets
    (ISO 6336-2 eq. for sigma_H, 6336-3 for sigma_F); K_Fbeta = K_Hbeta^N_F with the same N_F."""
    _, d = spur_run
    for r in d["torques"]:
        ratio_H = math.sqrt(r["K_Hbeta"]["ltca"] * r["K_Halpha"]["ltca"] / (r["K_Hbeta"]["iso"] * r["K_Halpha"]["iso"]))
        for i in range(2):
            assert r["sigma_H"]["ltca"][i] == pytest.approx(r["sigma_H"]["iso"][i] * ratio_H, rel=1e-10)
            assert r["S_H"]["ltca"][i] == pytest.approx(r["S_H"]["iso"][i] / ratio_H, rel=1e-10)
        nf_l = math.log(r["K_Fbeta"]["ltca"]) / math.log(r["K_Hbeta"]["ltca"])
        nf_i = math.log(r["K_Fbeta"]["iso"]) / math.log(r["K_Hbeta"]["iso"])
        assert nf_l == pytest.approx(nf_i, rel=1e-10)
        # the face distribution's peak over its mean is the K_Hbeta reported
        w = np.array(r["w_face_N_per_mm"])
        z = np.array(d["z_face_mm"])
        wt = np.gradient(z)
        wt[[0, -1]] = wt[[0, -1]] / 2
        assert r["K_Hbeta"]["ltca"] == pytest.approx(w.max() / (np.sum(w * wt) / np.sum(wt)), rel=1e-9)
        # K_Halpha of the loaded TCA: the pair line-load ratio to the unmodified aligned pair, at least 1
        raw = r["w_pair_max_N_per_mm"] / r["w_pair_max_reference_N_per_mm"]
        assert r["K_Halpha_ltca_raw"] == pytest.approx(raw, rel=1e-12)
        assert r["K_Halpha"]["ltca"] == pytest.approx(max(1.0, raw), rel=1e-12)
    # crowning and a crossing: the loaded TCA's K_Hbeta falls with torque (the contact spreads)
    k = [r["K_Hbeta"]["ltca"] for r in d["torques"]]
    assert all(b < a for a, b in zip(k, k[1:]))


from scenes import SCENES, check_scene_run, scene_param, study  # noqa: E402


@pytest.mark.parametrize("scene", [scene_param(p) for p in SCENES if study(p) == "rating"])
def test_rating_scenes_run_and_write(scene, scene_run):
    """Every rating scene runs through the CLI and writes documented results and clean plots
    (tests/scenes.check_scene_run: every key in docs/results.md, the plot linter)."""
    check_scene_run(scene, scene_run)


def test_generated_tooth_section_matches_the_closed_form_and_follows_the_allowance():
    """Spur: the critical section measured on gearopt's generated tooth equals ISO's closed form of the
    basic rack (s_Fn, rho_F, h_Fe within 0.05 %); a tooth thinned by A_sne = -0.1 mm has a smaller s_Fn on
    the generated tooth (the closed form does not know the allowance) and a larger Y_F."""
    import dataclasses

    from gearopt.io.scene import load_scene
    from gearopt.rating.iso6336 import form_factors, geometry, tooth_form
    from gearopt.rating.pair import generated_tooth_forms, pair_data

    pair = load_scene(PROBLEMS / "rating_spur.toml").pair
    p = pair_data(pair)
    g = geometry(p)
    gen = generated_tooth_forms(pair, p)
    for i in range(2):
        closed = tooth_form(i, p, g)
        for k in ("s_Fn", "rho_F", "h_Fe"):
            assert gen[i][k] == pytest.approx(closed[k], rel=5e-4), (i, k)
    thin = type(pair)(dataclasses.replace(pair.pinion, A_sne=-0.1, A_sni=-0.1), pair.gear, a=pair.a)
    gen_thin = generated_tooth_forms(thin)
    assert gen_thin[0]["s_Fn"] < gen[0]["s_Fn"] - 0.05
    Y = [form_factors(t["s_Fn"], t["h_Fe"], t["rho_F"], t["alpha_Fen"], p.m_n, p.alpha_n)["Y_F"] for t in (gen[0], gen_thin[0])]
    assert Y[1] > Y[0]
    # rate() uses the measured sections when given
    from gearopt.rating import Operation, material, rate

    m = material("Eh", "MQ")
    r = rate(p, Operation(T1=100.0, n1=1500.0), m, m, None, (gen_thin[0], gen[1]))
    assert r.sources["Y_F"] == "generated tooth"
    assert r["Y_F"][0] == pytest.approx(Y[1], rel=1e-12)
    assert r["s_Fn"][0] == pytest.approx(gen_thin[0]["s_Fn"], rel=1e-12)


@pytest.mark.parametrize(("options", "key"), [
    ({"pinion_material": "Steel42"}, "pinion_material"),
    ({"gear_grade": "MX"}, "gear_grade"),
    ({"life": 0.0}, "life"),
    ({"spectrum_torque": [50.0, 100.0], "spectrum_speed": [1000.0, 1000.0], "spectrum_share": [0.5, 0.4]},
     "spectrum_share"),
    ({"spectrum_torque": [50.0, 100.0], "spectrum_share": [0.5, 0.5]}, "spectrum_speed"),
])
def test_api_refusals(options, key):
    """The study's API refuses the same inputs as the scene, naming the option, before any loaded TCA runs."""
    from gearopt.errors import GearoptError
    from gearopt.io.scene import load_scene
    from gearopt.studies.rating import RatingStudy

    pair = load_scene(PROBLEMS / "rating_spur.toml").pair
    with pytest.raises(GearoptError) as e:
        RatingStudy(pair, 100.0, **options)
    assert e.value.param == key, (e.value.param, str(e.value))
