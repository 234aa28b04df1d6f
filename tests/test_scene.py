"""Scene loading: schema, units, error messages (gearopt.io.scene) and the study registry."""

from __future__ import annotations

import dataclasses
import math

import pytest

from conftest import GOOD_SCENE
from gearopt import studies as registry
from gearopt.errors import SceneError
from gearopt.io.scene import Bounds, Field, Scene, Section, load_scene
from gearopt.units import DEG, INCH


def edit(*pairs, append=""):
    """GOOD_SCENE with (old, new) replacements (each old must occur) and text appended."""
    text = GOOD_SCENE
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text + append


# (id, scene text, substrings the message must contain)
BAD = [
    ("toml-syntax", edit(("[pair]", "[pair")), ["TOML syntax error", "line"]),
    ("empty-file", "", ["[scene]", "missing required section"]),
    ("no-scene-section", edit(("[scene]", "[scenery]")), ["[scene]", "missing"]),
    ("missing-name", edit(('name = "dummy spur"\n', "")), ["[scene] name", "missing required key"]),
    ("missing-study", edit(('study = "dummy"\n', "")), ["[scene] study", "missing required key"]),
    ("unknown-study", edit(('study = "dummy"', 'study = "dumy"')), ["[scene] study", '"dumy"', "Did you mean 'dummy'"]),
    ("unknown-key-scene", edit(("description =", "descripton =")), ["[scene] descripton", "unknown key",
                                                                       "Did you mean 'description'"]),
    ("unknown-key-pinion", edit(("z = 20", "teeth = 20")), ["[pinion] teeth", "unknown key", "[pinion] z",
                                                             "missing required key"]),
    ("typo-key-pair", edit(("m_n = 2", "m_n = 2\nbeat = 10")), ["[pair] beat", "Did you mean 'beta'"]),
    ("unknown-section", edit(append="[outptu]\nplots = false\n"), ["[outptu]", "unknown section",
                                                                   "Did you mean 'output'"]),
    ("top-level-key", "study = 'dummy'\n" + GOOD_SCENE, ["top-level key 'study'", "belongs in [scene]"]),
    ("section-not-table", "output = 3\n" + GOOD_SCENE, ["[output]", "must be a table"]),
    ("missing-gear", edit(('[gear]\nz = 40\nb = "0.1 in"\n', "")), ["[gear]", "missing required section"]),
    ("missing-face-width", edit(("z = 20\nb = 20", "z = 20")), ["[pinion] b", "missing required key", "length"]),
    ("z-float", edit(("z = 20", "z = 20.5")), ["[pinion] z = 20.5", "expected an integer"]),
    ("z-string", edit(("z = 20", 'z = "20"')), ["[pinion] z", "expected an integer", "string"]),
    ("z-too-small", edit(("z = 20", "z = 2")), ["[pinion] z = 2", "z >= 3"]),
    ("undercut", edit(("z = 20", "z = 8")), ["[pinion] x", "allow_undercut", "x >= 0.5"]),
    ("pointed-tip", edit(("z = 20\nb = 20", "z = 20\nb = 20\nx = 2")), ["[pinion] x = 2", "pointed"]),
    ("bool-not-bool", edit(("z = 20\nb = 20", "z = 20\nb = 20\nallow_undercut = 1")),
     ["[pinion] allow_undercut = 1", "true or false"]),
    ("b-negative", edit(("z = 20\nb = 20", "z = 20\nb = -1")), ["[pinion] b = -1", "b > 0"]),
    ("b-wrong-unit", edit(("z = 20\nb = 20", 'z = 20\nb = "20 deg"')), ["[pinion] b", "'deg'", "angle unit",
                                                                        "length"]),
    ("b-bad-string", edit(("z = 20\nb = 20", 'z = 20\nb = "twenty"')), ["[pinion] b", "'<number> <unit>'"]),
    ("b-unknown-unit", edit(("z = 20\nb = 20", 'z = 20\nb = "20 furlong"')), ["[pinion] b", "'furlong'",
                                                                             "unknown unit"]),
    ("alpha-length-unit", edit(append='[rack]\nalpha_n = "20 mm"\n'), ["[rack] alpha_n", "'mm'", "length unit",
                                                                       "deg"]),
    ("alpha-too-big", edit(append="[rack]\nalpha_n = 50\n"), ["[rack] alpha_n = 50", "0 < alpha_n < 45 deg"]),
    ("alpha-too-big-rad", edit(append='[rack]\nalpha_n = "1 rad"\n'), ['[rack] alpha_n = "1 rad"', "57.2958 deg",
                                                                        "45 deg"]),
    ("member-rack-alpha", edit(("z = 40", "z = 40\nrack = { alpha_n = 0 }")), ["[gear.rack] alpha_n = 0",
                                                                                "0 < alpha_n"]),
    ("member-rack-unknown", edit(("z = 40", "z = 40\nrack = { alpha = 20 }")), ["[gear.rack] alpha",
                                                                                 "Did you mean 'alpha_n'"]),
    ("rack-preset", edit(append='[rack]\npreset = "E"\n'), ['[rack] preset = "E"', '"A", "B", "C", "D"']),
    ("rack-h_aP", edit(append="[rack]\nh_aP = 0\n"), ["[rack] h_aP = 0", "h_aP > 0"]),
    ("rack-h_fP", edit(append="[rack]\nh_fP = 0.5\n"), ["[rack] h_fP = 0.5", "h_fP >= h_aP"]),
    ("rack-a_c-negative", edit(append="[rack]\na_c = -0.001\n"), ["[rack] a_c = -0.001", "a_c >= 0"]),
    ("rack-a_c-unit", edit(append='[rack]\na_c = "0.001 mm"\n'), ["[rack] a_c", "'mm'", "inverse length"]),
    ("alpha-mismatch", edit(("z = 40", "z = 40\nrack = { alpha_n = 25 }"), append="[rack]\nrho_fP = 0.2\n"),
     ["[gear.rack] alpha_n = 25", "equal to pinion.rack.alpha_n"]),
    ("m_n-and-P_n", edit(("m_n = 2", "m_n = 2\nP_n = 8")), ["m_n", "P_n", "exactly one"]),
    ("no-module", edit(("m_n = 2", "beta = 0")), ["[pair] m_n", "P_n", "exactly one"]),
    ("m_n-zero", edit(("m_n = 2", "m_n = 0")), ["[pair] m_n = 0", "m_n > 0 mm"]),
    ("P_n-zero", edit(("m_n = 2", "P_n = 0")), ["[pair] P_n = 0", "P_n > 0 1/in"]),
    ("P_n-length", edit(("m_n = 2", 'P_n = "8 in"')), ["[pair] P_n", "'in'", "length unit", "bare number means 1/in"]),
    ("beta-45", edit(("m_n = 2", 'm_n = 2\nbeta = "45 deg"')), ["[pair] beta", "0 <= beta < 45 deg"]),
    ("hand-typo", edit(("m_n = 2", 'm_n = 2\nhand = "rigth"')), ['[pair] hand = "rigth"', '"right", "left"',
                                                                 "Did you mean 'right'"]),
    ("a-too-small", edit(("m_n = 2", "m_n = 2\na = 59")), ["[pair] a = 59", "a >= a_0 = 60"]),
    ("a-inside-base", edit(("m_n = 2", "m_n = 2\na = 50")), ["[pair] a = 50", "r_b1 + r_b2"]),
    ("study-int", edit(("n = 4", "n = 0")), ["[dummy] n = 0", "1 <= n <= 100"]),
    ("study-angle-range", edit(('angle = "20 deg"', 'angle = "2 rad"')), ['[dummy] angle = "2 rad"',
                                                                           "0 < angle <= 90 deg"]),
    ("study-choice", edit(("n = 4", 'n = 4\nmode = "slow"')), ['[dummy] mode = "slow"', '"fast", "exact"']),
    ("study-unknown-key", edit(("n = 4", "n = 4\nspan_mm = 3")), ["[dummy] span_mm", "Did you mean 'span'"]),
    ("output-dpi", edit(append="[output]\ndpi = 0\n"), ["[output] dpi = 0", "10 <= dpi <= 2400"]),
    ("output-plots", edit(append='[output]\nplots = "yes"\n'), ['[output] plots = "yes"', "true or false"]),
    ("nan", edit(("m_n = 2", "m_n = nan")), ["[pair] m_n", "finite"]),
    ("inf-P_n", edit(("m_n = 2", "P_n = inf")), ["[pair] P_n = inf", "finite"]),
]


@pytest.mark.parametrize("text,expected", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_scene_raises_one_scene_error(dummy_study, scene_file, text, expected):
    path = scene_file(text, "bad.toml")
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: "), msg
    for part in expected:
        assert part in msg, f"{part!r} not in {msg!r}"
    assert "Traceback" not in msg


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(SceneError, match="no such scene file"):
        load_scene(tmp_path / "nope.toml")
    with pytest.raises(SceneError, match="is a directory"):
        load_scene(tmp_path)


def test_not_utf8(tmp_path):
    p = tmp_path / "latin1.toml"
    p.write_bytes(b'[scene]\nname = "Zahnr\xe4der"\n')
    with pytest.raises(SceneError, match="not UTF-8"):
        load_scene(p)


def test_several_problems_in_one_error(dummy_study, scene_file):
    text = edit(("z = 20", "z = 20.5"), ("m_n = 2", "m_n = 2\nhnad = 'left'"), append="[output]\ndpi = 5\n")
    with pytest.raises(SceneError) as exc:
        load_scene(scene_file(text))
    msg = str(exc.value)
    assert "3 problems" in msg
    for part in ("[pinion] z = 20.5", "[pair] hnad", "Did you mean 'hand'", "[output] dpi = 5"):
        assert part in msg


def test_section_of_another_study(dummy_study, scene_file):
    from gearopt.studies import StudySpec, register, unregister

    register(StudySpec("other", [Section("otheropts", [Field("q", "int")])], build=lambda s: None))
    try:
        with pytest.raises(SceneError, match=r"\[otheropts\].*belongs to study \"other\""):
            load_scene(scene_file(GOOD_SCENE + "[otheropts]\nq = 1\n"))
    finally:
        unregister("other")


def test_good_scene_internal_units(dummy_study, scene_file):
    s = load_scene(scene_file(GOOD_SCENE))
    assert isinstance(s, Scene)
    assert (s.name, s.description, s.study) == ("dummy spur", "test scene", "dummy")
    p, g = s.pair.pinion, s.pair.gear
    assert (p.z, g.z) == (20, 40)
    assert p.m_n == g.m_n == 2.0
    assert p.b == 20.0
    assert g.b == pytest.approx(2.54)  # "0.1 in"
    assert (p.name, g.name) == ("pinion", "gear")
    assert p.rack.name == "ISO 53 A" and p.rack.alpha_n == pytest.approx(20 * DEG)
    assert s.pair.a is None and s.pair.a_w == pytest.approx(60.0)
    o = s.options["dummy"]
    assert o["n"] == 4
    assert o["span"] == pytest.approx(0.5 * INCH)
    assert o["angle"] == pytest.approx(math.radians(20))
    assert o["mode"] == "fast" and o["curv"] == 0.0  # defaults
    assert s.output == {"plots": True, "dpi": 120, "svg": False}
    assert s.source.name == "scene.toml"
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.name = "other"  # frozen


@pytest.mark.parametrize("pitch", ["P_n = 8", 'P_n = "8 1/in"', 'P_n = "0.31496062992125984 1/mm"'])
def test_diametral_pitch(dummy_study, scene_file, pitch):
    s = load_scene(scene_file(edit(("m_n = 2", pitch))))
    assert s.pair.pinion.m_n == pytest.approx(3.175)
    assert s.pair.gear.m_n == pytest.approx(3.175)


def test_units_in_strings(dummy_study, scene_file):
    text = edit(("z = 20\nb = 20", 'z = 20\nb = "2 cm"\na_pl = "0.0254 1/in"'),
                ("m_n = 2", 'm_n = "2 mm"\na = "6.05 cm"'),
                ('angle = "20 deg"', 'angle = "1200 arcmin"'),
                append='[rack]\nalpha_n = "0.3490658503988659 rad"\nu_0 = "1 mm"\na_c = "0.5 1/m"\n')
    s = load_scene(scene_file(text))
    p = s.pair.pinion
    assert p.b == pytest.approx(20.0)
    assert p.a_pl == pytest.approx(0.001)
    assert s.pair.a == pytest.approx(60.5)
    assert s.options["dummy"]["angle"] == pytest.approx(20 * DEG)
    assert p.rack.alpha_n == pytest.approx(20 * DEG)
    assert p.rack.a_c == pytest.approx(5e-4) and p.rack.u_0 == 1.0
    assert p.rack.name == "ISO 53 A, modified"


def test_helical_hands(dummy_study, scene_file):
    s = load_scene(scene_file(edit(("m_n = 2", 'm_n = 2\nbeta = 15\nhand = "left"'))))
    assert s.pair.pinion.beta == pytest.approx(15 * DEG)
    assert (s.pair.pinion.hand, s.pair.gear.hand) == ("left", "right")
    s = load_scene(scene_file(edit(("m_n = 2", "m_n = 2\nbeta = 15"))))
    assert (s.pair.pinion.hand, s.pair.gear.hand) == ("right", "left")


def test_rack_merging(dummy_study, scene_file):
    text = edit(("z = 40", 'z = 40\nrack = { preset = "D", rho_fP = 0.3 }'),
                append='[rack]\npreset = "B"\nh_aP = 0.9\n')
    s = load_scene(scene_file(text))
    rp, rg = s.pair.pinion.rack, s.pair.gear.rack
    assert (rp.h_aP, rp.h_fP, rp.rho_fP) == (0.9, 1.25, 0.30)  # B with common override
    assert (rg.h_aP, rg.h_fP, rg.rho_fP) == (0.9, 1.40, 0.3)  # own preset D, common h_aP, own rho_fP
    assert rg.name == "ISO 53 D, modified"


def test_allow_undercut(dummy_study, scene_file):
    s = load_scene(scene_file(edit(("z = 20\nb = 20", "z = 12\nb = 20\nallow_undercut = true"))))
    assert s.pair.pinion.undercut


def test_build_uses_registry(dummy_study, scene_file):
    from conftest import DummyStudy

    study = load_scene(scene_file(GOOD_SCENE)).build()
    assert isinstance(study, DummyStudy)


# --- schema and registry ------------------------------------------------------------------------

def test_schema_definition_errors():
    with pytest.raises(ValueError, match="unknown kind"):
        Field("q", "velocity")
    with pytest.raises(ValueError, match="does not fit"):
        Field("q", "angle", unit="mm")
    with pytest.raises(ValueError, match="duplicate"):
        Section("s", [Field("a", "int"), Field("a", "float")])


def test_field_callable_check():
    f = Field("q", "float", check=lambda v: None if v < 3 else "q < 3")
    assert f.convert(1, "[s] q") == 1.0
    with pytest.raises(SceneError, match=r"\[s\] q = 5 is out of range; valid: q < 3"):
        f.convert(5, "[s] q")


def test_bounds_text():
    assert Bounds(lo=0, lo_open=True).text("b", "mm") == "b > 0 mm"
    assert Bounds(lo=0, hi=45, lo_open=True, hi_open=True).text("alpha", "deg") == "0 < alpha < 45 deg"


def test_register_rejects_bad_specs():
    from gearopt.studies import StudySpec, register

    with pytest.raises(TypeError):
        register("geometry")
    with pytest.raises(TypeError):
        register(StudySpec("x", [], build=None))
    with pytest.raises(ValueError):
        register(StudySpec("", [], build=lambda s: None))


def test_missing_builtin_module_is_skipped_and_broken_one_reported(monkeypatch, tmp_path):
    (tmp_path / "broken_study_mod.py").write_text("raise RuntimeError('boom')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "BUILTIN_MODULES", ("gearopt.studies.does_not_exist", "broken_study_mod"))
    monkeypatch.setattr(registry, "_loaded", False)
    monkeypatch.setattr(registry, "_broken", {})
    monkeypatch.delenv(registry.ENV_MODULES, raising=False)
    assert registry.get_study("does_not_exist") is None
    assert "broken_study_mod" in registry.broken_modules()
    with pytest.raises(ImportError, match="boom"):
        registry.get_study("broken_study_mod")


def test_env_study_modules(monkeypatch, tmp_path):
    (tmp_path / "plugin_study_mod.py").write_text(
        "from gearopt.studies import StudySpec, register\n"
        "register(StudySpec('plugin_study', [], build=lambda scene: scene))\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(registry, "_loaded", False)
    monkeypatch.setattr(registry, "_broken", {})
    monkeypatch.setenv(registry.ENV_MODULES, "plugin_study_mod")
    try:
        assert registry.get_study("plugin_study") is not None
        assert "plugin_study" in registry.studies()
    finally:
        registry.unregister("plugin_study")


def test_a_scene_imports_its_own_study_module_only_until_a_hint_needs_the_others(tmp_path):
    """load_scene and build of a built-in study import that study's module alone (a new process: the
    other study modules, e.g. rating and dynamics, stay unimported); a key written in the wrong
    section still gets its hint naming another study's section (which imports the others then)."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    bad = tmp_path / "bad.toml"
    bad.write_text((root / "problems" / "tca_helical.toml").read_text().replace("[tca]", "[tca]\nte_level = 1.0", 1))
    code = (
        "import sys\n"
        "from gearopt.errors import SceneError\n"
        "from gearopt.io.scene import load_scene\n"
        f"load_scene({str(root / 'problems' / 'tca_helical.toml')!r}).build()\n"
        "print(sorted(m for m in ('gearopt.studies.rating', 'gearopt.studies.dynamics', 'gearopt.studies.fea',"
        " 'gearopt.studies.crowning') if m in sys.modules))\n"
        "try:\n"
        f"    load_scene({str(bad)!r})\n"
        "except SceneError as e:\n"
        "    print(e)\n")
    env = {k: v for k, v in __import__("os").environ.items() if k != registry.ENV_MODULES}
    env["PYTHONPATH"] = str(root)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=root, check=True)
    lines = out.stdout.splitlines()
    assert lines[0] == "[]", out.stdout
    assert 'te_level belongs in [crowning] of study "crowning"' in out.stdout, out.stdout
