"""Each scene in problems/ runs through the CLI path and gives physically right scalars.

Expected values are computed here from textbook formulas (docs/theory.md section 3), independently of
gearopt's own report code.
"""

from __future__ import annotations

import json
import math
import shutil
import tomllib
from pathlib import Path

import pytest

from gearopt.cli import main
from gearopt.errors import SceneError
from gearopt.io.scene import load_scene

from results_doc import undocumented

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
SCENES = sorted(p for p in PROBLEMS.glob("*.toml"))
#: pytest markers of the scene runs: IPOPT (crowning study), CalculiX (fea study), above about 5 s
STUDY_MARKS = {"crowning": [pytest.mark.ipopt], "fea": [pytest.mark.calculix]}
SLOW_SCENES = {"crowning_spur", "fea_spur", "edge_spur_crossed"}


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
def test_scene_runs_and_writes(scene, tmp_path):
    if tomllib.loads(scene.read_text())["scene"]["study"] == "fea" and shutil.which("ccx") is None:
        pytest.skip("CalculiX (ccx) is not installed: the FE scene cannot run (make test installs it as root)")
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["units"], "results must state units"
    # every key is documented in docs/results.md (rows of "every study" and of this study)
    assert undocumented(res, res["study"]) == [], "keys missing in docs/results.md"
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs, "plots must be written"
    for p in out.glob("*.png"):
        assert p.stat().st_size > 10_000


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


def _tca_scenes(edge=False):
    out = []
    for p in SCENES:
        raw = tomllib.loads(p.read_text())
        if raw["scene"]["study"] == "tca" and bool(raw.get("tca", {}).get("edge_contact", False)) == edge:
            out.append(p)
    return out


@pytest.fixture(scope="module")
def tca_reports():
    return {p.stem: load_scene(p).build().run().to_dict() for p in _tca_scenes()}


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
def test_edge_scene_physics(scene):
    rep = load_scene(scene).build().run().to_dict()
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
