"""The option sets of gearopt.settings as the one declaration of each option (issue 40): the scene
sections are generated from them, the API and the scene share each default and each range, the docs
table is the generated one, and the worked "adding a study" example of docs/extending.md runs."""

from __future__ import annotations

import ast
import dataclasses
import re
import subprocess
import sys
from pathlib import Path

import pytest

from gearopt.errors import ArgumentError, OptionError, SceneError
from gearopt.schema import Field
from gearopt.settings import (CrowningStudySettings, CrowningTarget, FEOptions, GeometryStudySettings,
                              LoadedMicroSettings, LTCASettings, LTCAStudySettings, MeshOptions, MonteCarloSettings,
                              PlanarTCASettings, Settings, SweepSettings, TCAStudySettings, option)
from gearopt.studies import markdown_tables, studies
from gearopt.units import ARCSEC

ROOT = Path(__file__).resolve().parents[1]

#: The studies whose options are declared by option sets (each must list them in StudySpec.settings).
CONVERTED = {"loaded_microgeometry": (LoadedMicroSettings,), "ltca": (LTCAStudySettings,),
             "montecarlo": (MonteCarloSettings,), "sweep": (SweepSettings,), "tca": (TCAStudySettings,),
             "geometry": (GeometryStudySettings,), "planar_tca": (PlanarTCASettings,),
             "crowning": (CrowningTarget, CrowningStudySettings), "fea": (FEOptions, MeshOptions)}


def _options():
    """(study, settings class, option name) of every option of every registered study's option sets."""
    out = []
    for name, spec in sorted(studies().items()):
        for cls in spec.settings:
            for n, (o, _) in cls.options().items():
                if o.key != "":
                    out.append(pytest.param(name, cls, n, id=f"{name}-{n}"))
    return out


def _scene_field(study: str, cls, name: str) -> Field:
    """The field of the option ``name`` in the registered study's scene section (or its sub-table)."""
    o, _ = cls.options()[name]
    spec = studies()[study]
    section = next(s for s in spec.sections if s.name == cls.SECTION)
    if o.group:
        section = next(s for s in section.subsections if s.name == o.group)
    return next(f for f in section.fields if f.name == (o.key or name))


def test_the_converted_studies_declare_their_option_sets():
    for name, classes in CONVERTED.items():
        assert studies()[name].settings == classes


@pytest.mark.parametrize("study,cls,name", _options())
def test_scene_field_is_generated_from_the_option(study, cls, name):
    """Same key, kind, default, range, choices and doc in the scene section as in the dataclass."""
    o, default = cls.options()[name]
    f = _scene_field(study, cls, name)
    assert f == cls.scene_field(name)
    assert (f.kind, f.doc, f.choices) == (o.kind, o.doc, o.choices)
    assert f.check is (o.bounds if o.bounds is not None else o.check)
    if default is None or default is dataclasses.MISSING or o.scene_required:
        assert f.default is None and f.required == (default is dataclasses.MISSING or o.scene_required)
    else:  # the scene's default loads as the API's default, exactly
        assert f.convert(f.default, "x") == default


def _required(cls) -> dict:
    """A valid value of each required option of ``cls`` (the low end of its range)."""
    return {n: o.bounds.lo + (1e-6 if o.bounds.lo_open else 0) for n, (o, d) in cls.options().items()
            if d is dataclasses.MISSING}


def api_text(cls, name, value) -> str:
    with pytest.raises(cls.ERROR) as e:
        cls(**{**_required(cls), name: value})
    return e.value.valid


@pytest.mark.parametrize("study,cls,name", _options())
def test_api_and_scene_refuse_the_same_value_naming_the_same_range(study, cls, name):
    o, _ = cls.options()[name]
    f = _scene_field(study, cls, name)
    if o.bounds is not None:
        b = o.bounds
        bad_scene = (b.hi * 2 + 1) if b.hi is not None else (b.lo - 1)  # in the scene unit
        if o.kind == "int":
            bad_scene = int(bad_scene)
        # the same value in the internal unit (mm, rad, 1/mm) for the API
        bad_api = bad_scene / f.to_scene_unit(1.0) if o.kind in ("length", "angle", "inverse_length") else bad_scene
        numbers = {float(f"{v:g}") for v in (b.lo, b.hi) if v is not None}  # as the messages print them
    elif o.choices is not None:
        bad_scene = bad_api = "nowhere"
        numbers = set()
    elif o.check is not None:  # a check that a range cannot state (a list of weights, E): the same text in both
        bad_scene = bad_api = [-1.0] if o.kind == "floats" else -1.0
        numbers = set()
        assert o.check(bad_api) in api_text(cls, name, bad_api)
    else:  # only its type
        bad_scene = bad_api = [1.0] if o.kind == "str" else "a text"
        numbers = set()
    with pytest.raises(SceneError) as scene_err:
        f.convert(bad_scene, f"[{cls.SECTION}] {f.name}")
    # a text for a number is an ArgumentError (a TypeError: units in strings are for scenes)
    text_for_number = isinstance(bad_api, str) and o.kind not in ("str", "int", "bool")
    with pytest.raises(ArgumentError if text_for_number else cls.ERROR) as api_err:
        cls(**{**_required(cls), name: bad_api})
    assert api_err.value.param == cls.PARAM + name and scene_err.value.param == f"[{cls.SECTION}] {f.name}"
    if o.kind in ("int", "float", "length"):  # the same numbers state the range, in the same unit
        def nums(text):
            return {float(x) for x in re.findall(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e[+-]?\d+)?", text)}
        assert numbers <= nums(api_err.value.valid) and numbers <= nums(scene_err.value.valid)
    for c in o.choices or ():
        assert repr(c) in api_err.value.valid and f'"{c}"' in scene_err.value.valid


def test_te_level_range_through_the_api_and_a_scene():
    """The unloaded-TE level through the API (rad, shown in arcsec) and a scene ("700 arcsec", its
    range in the scene unit as every scene key states it)."""
    with pytest.raises(OptionError, match=r"te_level = '700 arcsec' is out of range; valid: 0 < te_level <= 600 "
                                          r"arcsec \(or None\)"):
        LoadedMicroSettings(te_level=700 * ARCSEC)
    f = LoadedMicroSettings.scene_field("te_level")
    with pytest.raises(SceneError, match=r"valid: 0 < level <= 0\.166667 deg"):
        f.convert("700 arcsec", "[loaded_microgeometry.unloaded_te] level")


def test_positions_one_default_for_the_scene_and_the_optimiser(tmp_path):
    """A loaded_microgeometry scene without ``positions`` runs the NLP on LoadedMicroOptimizer's own
    default (the scene said 24, the API 32 before the option sets)."""
    from gearopt.io.scene import load_scene
    from gearopt.studies import get_study

    text = (ROOT / "problems/microgeometry_loaded.toml").read_text()
    text = re.sub(r"(?m)^positions = \d+\n", "", text)
    path = tmp_path / "s.toml"
    path.write_text(text)
    scene = load_scene(path)
    assert scene.options["loaded_microgeometry"]["positions"] == LoadedMicroSettings().n_positions == 32
    study = get_study("loaded_microgeometry").build(scene)
    assert study.optimizer.n_positions == study.optimizer.phi1.size == 32


def test_bad_positions_named_alike_by_a_scene_and_the_api(tmp_path, capsys):
    from gearopt.cli import main

    text = (ROOT / "problems/microgeometry_loaded.toml").read_text()
    path = tmp_path / "s.toml"
    path.write_text(re.sub(r"(?m)^positions = \d+$", "positions = 300", text))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "[loaded_microgeometry] positions = 300 is out of range; valid: 8 <= positions <= 256" in err
    with pytest.raises(OptionError, match=r"n_positions = 300 is out of range; valid: an integer, "
                                          r"8 <= n_positions <= 256\."):
        LoadedMicroSettings(n_positions=300)


def test_harmonics_resolved_by_the_positions():
    with pytest.raises(OptionError, match=r"harmonics = .* at most \(n_positions - 1\) / 2 = 7 of them") as e:
        LoadedMicroSettings(harmonics=[1.0] * 8, n_positions=16)
    assert e.value.param == "harmonics"
    assert LoadedMicroSettings(harmonics=[1.0] * 7, n_positions=16).harmonics == (1.0,) * 7


def test_of_takes_an_object_and_keywords():
    s = LoadedMicroSettings(n_positions=16)
    assert LoadedMicroSettings.of(s) is s
    assert LoadedMicroSettings.of(s, n_slices=9) == LoadedMicroSettings(n_positions=16, n_slices=9)
    with pytest.raises(ArgumentError, match=r"n_position: not an option of LoadedMicroSettings\. Did you mean "
                                            r"'n_positions'\?") as e:
        LoadedMicroSettings.of(s, n_position=16)
    assert e.value.param == "n_position"
    with pytest.raises(ArgumentError, match="settings = .*expected a LoadedMicroSettings"):
        LoadedMicroSettings.of(LTCASettings())
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.n_positions = 8


def test_values_are_normalised_and_none_only_where_allowed():
    import numpy as np

    s = LoadedMicroSettings(n_positions=np.int64(16), harmonics=np.array([1.0, 0.5]), p_limit=2000)
    assert type(s.n_positions) is int and s.harmonics == (1.0, 0.5) and type(s.p_limit) is float
    assert LoadedMicroSettings(edge_margin=None).edge_margin is None
    with pytest.raises(OptionError, match=r"n_slices = None is out of range; valid: an integer, 3 <= n_slices <= 201\."):
        LoadedMicroSettings(n_slices=None)
    with pytest.raises(OptionError, match=r"n_positions = True is out of range"):
        LoadedMicroSettings(n_positions=True)
    with pytest.raises(OptionError, match=r"p_limit = nan is out of range"):
        LoadedMicroSettings(p_limit=float("nan"))


def test_api_constructors_take_the_option_set():
    """LTCA and LoadedMicroOptimizer: the defaults are the option set's, a settings object is accepted
    and keywords replace its fields."""
    from gearopt.gears import Gear, GearPair
    from gearopt.ltca.engine import LTCA
    from gearopt.synthesis.loaded import LoadedMicroOptimizer

    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    L = LTCA(pair)
    assert L.settings == LTCASettings() and L.n_slices == LTCASettings().n_slices
    L = LTCA(pair, LTCASettings(n_slices=7), coupling=2.0)
    assert (L.n_slices, L.coupling_length) == (7, 2.0)
    with pytest.raises(OptionError, match=r"compliance = 'FE' is out of range; valid: 'analytical' or 'fe'\."):
        LTCA(pair, compliance="FE")
    opt = LoadedMicroOptimizer(pair, {"pinion.C_beta": (0.0, 0.04)}, [100.0], settings=LoadedMicroSettings(n_slices=7),
                               n_positions=8, n_verify=8)
    assert opt.settings == LoadedMicroSettings(n_slices=7, n_positions=8, n_verify=8)
    assert (opt.ltca.n_slices, opt.phi1.size, opt.edge_margin) == (7, 8, LoadedMicroSettings().edge_margin)


def test_a_shown_default_must_load_as_the_default():
    @dataclasses.dataclass(frozen=True)
    class Bad(Settings):
        SECTION = "bad"
        gap: float = option(5e-4, kind="length", shown="0.6 um", doc="a gap")

    with pytest.raises(ValueError, match="shown default '0.6 um' loads as"):
        Bad.section()


def test_the_docs_table_is_the_generated_one():
    doc = (ROOT / "docs/scenes.md").read_text(encoding="utf-8")
    assert markdown_tables() in doc, "regenerate it: gearopt studies --markdown (docs/scenes.md, Study options)"
    out = subprocess.run([sys.executable, "-m", "gearopt", "studies", "--markdown"], capture_output=True, text=True,
                         check=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}).stdout
    assert out == markdown_tables()


def test_settings_is_a_base_layer_module():
    """gearopt.settings and gearopt.schema import only errors, units, schema, the stdlib and numpy."""
    for mod in ("settings", "schema"):
        tree = ast.parse((ROOT / "gearopt" / f"{mod}.py").read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level:
                assert node.module in ("errors", "units", "schema"), (mod, node.module)
            elif isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module]
                assert all(not n.startswith("gearopt") for n in names), (mod, names)


def test_no_private_name_is_imported_across_modules_of_io_and_studies():
    bad = []
    for path in [*(ROOT / "gearopt/io").glob("*.py"), *(ROOT / "gearopt/studies").glob("*.py"),
                 ROOT / "gearopt/settings.py", ROOT / "gearopt/schema.py", ROOT / "gearopt/cli.py"]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "") != "__future__":
                bad += [f"{path.name}: {a.name}" for a in node.names
                        if a.name.startswith("_") and not a.name.endswith("__")]
    assert not bad


def _extending_example() -> str:
    text = (ROOT / "docs/extending.md").read_text(encoding="utf-8")
    part = text.split("## Adding a study", 1)[1]
    blocks = re.findall(r"```python\n(.*?)```", part, flags=re.S)
    assert blocks, "docs/extending.md: no python block in 'Adding a study'"
    return blocks[0]


def test_the_adding_a_study_example_of_the_docs_runs(tmp_path, monkeypatch, capsys):
    """The worked example of docs/extending.md: the module as written there, registered through
    GEAROPT_STUDY_MODULES, runs a scene, refuses a bad value and lists its keys."""
    from gearopt.cli import main
    from gearopt.studies import unregister

    (tmp_path / "face_load_study.py").write_text(_extending_example())
    scene = re.search(r"```toml\n(.*?)```", (ROOT / "docs/extending.md").read_text().split("## Adding a study", 1)[1],
                      flags=re.S).group(1)
    (tmp_path / "scene.toml").write_text(scene)
    monkeypatch.syspath_prepend(str(tmp_path))
    import importlib

    sys.modules.pop("face_load_study", None)
    importlib.import_module("face_load_study")
    try:
        out = tmp_path / "out"
        assert main(["run", str(tmp_path / "scene.toml"), "--out", str(out), "--quiet"]) == 0
        import json

        res = json.loads((out / "results.json").read_text())
        assert res["study"] == "face_load" and res["options"] == {"n_points": 11, "torque_Nm": 120.0}
        assert len(res["line_load_N_per_mm"]) == 11
        (tmp_path / "bad.toml").write_text(scene.replace("n_points = 11", "n_points = 1"))
        assert main(["check", str(tmp_path / "bad.toml")]) == 2
        assert "[face_load] n_points = 1 is out of range; valid: 2 <= n_points <= 1000" in capsys.readouterr().err
        assert main(["studies", "face_load"]) == 0
        assert "n_points (int, default 11): 2 <= n_points <= 1000; points across the face" in capsys.readouterr().out
    finally:
        unregister("face_load")
        sys.modules.pop("face_load_study", None)


def test_api_classes_take_their_defaults_from_the_option_sets():
    """Each converted API class, built with no option, holds its option set's defaults; a keyword
    replaces one field and is checked by the option set."""
    from gearopt.gears import BasicRack, Gear, GearPair
    from gearopt.robust.sampling import Distribution
    from gearopt.robust.study import DesignSweep, MonteCarlo
    from gearopt.studies.crowning import CrowningStudy, misalignment_cases
    from gearopt.studies.geometry import GeometryStudy
    from gearopt.studies.ltca import LTCAStudy
    from gearopt.studies.planar_tca import PlanarTCAStudy
    from gearopt.studies.tca import TCAStudy

    rack = BasicRack.iso53("A", a_c=0.002)
    pair = GearPair(pinion=Gear(z=21, m_n=2.0, b=14.0, a_pl=5e-4, rack=rack, name="pinion"),
                    gear=Gear(z=47, m_n=2.0, b=14.0, name="gear"))
    mis = {"crossing": Distribution("normal", sd=1e-4)}
    built = [(MonteCarlo(pair, 4, misalignment=mis), MonteCarloSettings(samples=4)),
             (DesignSweep(pair, {"mis.crossing": (-1e-3, 1e-3)}), SweepSettings()),
             (PlanarTCAStudy(30.0, 50.0, 90.0, [0.1]), PlanarTCASettings()),
             (TCAStudy(pair), TCAStudySettings()),
             (GeometryStudy(pair), GeometryStudySettings()),
             (LTCAStudy(pair, 50.0), LTCAStudySettings()),
             (CrowningStudy(pair, CrowningTarget(te_level=3e-5), misalignment_cases(crossing=3e-4)),
              CrowningStudySettings())]
    for obj, settings in built:
        assert obj.settings == settings, type(obj).__name__
    assert SweepSettings().samples == 64 and DesignSweep(pair, {"mis.crossing": (-1e-3, 1e-3)}).values()[
        "mis.crossing"].size == 64
    with pytest.raises(OptionError, match=r"positions = 8 is out of range; valid: an integer, 9 <= positions <= 5000"):
        TCAStudy(pair, positions=8)
    with pytest.raises(OptionError, match=r"levels = 1 is out of range; valid: an integer, 2 <= levels <= 101"):
        DesignSweep(pair, {"mis.crossing": (-1e-3, 1e-3)}, levels=1)
