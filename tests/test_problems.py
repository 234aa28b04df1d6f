"""Each scene in problems/ runs through the CLI path and gives physically right scalars.

Expected values are computed here from textbook formulas (THEORY.md section 3), independently of
gearopt's own report code.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import pytest

from gearopt.cli import main
from gearopt.errors import SceneError
from gearopt.io.scene import load_scene

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
SCENES = sorted(p for p in PROBLEMS.glob("*.toml"))


def _inv(a):
    return math.tan(a) - a


def _inv_inverse(t):
    from scipy.optimize import brentq
    return brentq(lambda a: math.tan(a) - a - t, 1e-9, 1.55, xtol=1e-15)


@pytest.mark.parametrize("scene", SCENES, ids=[p.stem for p in SCENES])
def test_scene_runs_and_writes(scene, tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["units"], "results must state units"
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
    ra1, ra2 = r1 + m_n * (p.rack.h_aP + x1), r2 + m_n * (g.rack.h_aP + x2)
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


def test_tool_option_for_other_tool_is_rejected(tmp_path):
    text = (PROBLEMS / "spur_geometry.toml").read_text().replace('generation = "rack"', 'generation = "rack"\nN_s = 30')
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(SceneError, match="N_s applies only with generation"):
        load_scene(f).build()


def test_shaper_generation_scene(tmp_path):
    text = (PROBLEMS / "spur_geometry.toml").read_text().replace('generation = "rack"', 'generation = "shaper"\nN_s = 30')
    f = tmp_path / "shaper.toml"
    f.write_text(text)
    rep = load_scene(f).build().run()
    # The shaper cuts a different root than the rack (cutting centre distance from x_s + x).
    assert rep.members["pinion"]["generation"] == "shaper"
    assert rep.members["pinion"]["r_f"] != pytest.approx(rep.members["pinion"]["r_p"] + 3 * (0.3 - 1.25), abs=1e-6)
