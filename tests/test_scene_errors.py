"""Structured errors of the scene loader's own key checks (gearopt.io.scene).

Every problem the loader finds (wrong type, unit, choice, range, unknown or missing key, a bad tool
table) is a SceneError whose ``param`` is the ``[section] key`` as the user wrote it, ``value`` the
value as written (TOML text) and ``valid`` the type, set or range it must be in; a SceneError that
collects several problems keeps them in ``problems``. ``SceneError.source`` ties an error to its
scene file, and the CLI decides by that field (not by the message's words) whether an error is
already stated for the scene. Errors about the gear data found while a study is built or run
(a shaper-cut pinion refused by the crowning synthesis) are stated for the gear key the user wrote.

The expected fields are read off the scene text written in each test (the key, the value as typed)
and the documented valid ranges (docs/errors.md, `gearopt studies`), not off the loader's output. This
module is also one of the corpora checked by tests/error_fields.py (conftest.py).
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

import gearopt
from conftest import GOOD_SCENE
from gearopt.errors import GeometryError, SceneError, out_of_range
from gearopt.io.scene import load_scene


def _edit(*pairs, add=""):
    text = GOOD_SCENE
    for old, new in pairs:
        assert old in text
        text = text.replace(old, new, 1)
    return text + add


def _error(scene_file, text) -> tuple[SceneError, Path]:
    path = scene_file(text, "bad.toml")
    with pytest.raises(SceneError) as ei:
        load_scene(path)
    return ei.value, path


# ------------------------------------------------------------------------------------------------
# 1. One problem: the fields of each kind of key check
# ------------------------------------------------------------------------------------------------
ONE = [
    # (id, scene text, param, value as typed, valid (exact) or a callable checking it)
    ("int", _edit(("z = 20", "z = 20.5")), "[pinion] z", "20.5", "an integer"),
    ("float", _edit(add="[rack]\nh_aP = \"big\"\n"), "[rack] h_aP", '"big"', "a number"),
    ("float-inf", _edit(add="[rack]\nh_aP = inf\n"), "[rack] h_aP", "inf", "a finite number"),
    ("bool", _edit(add="[output]\nplots = \"yes\"\n"), "[output] plots", '"yes"', "true or false"),
    ("str", _edit(('description = "test scene"', "description = 3")), "[scene] description", "3",
     "a string (in quotes)"),
    ("length-bool", _edit(("z = 20\nb = 20", "z = 20\nb = true")), "[pinion] b", "true",
     "a length (number or '<number> <unit>')"),
    ("length-array", _edit(("z = 20\nb = 20", "z = 20\nb = [1, 2]")), "[pinion] b", "[1, 2]",
     'a length (number or "<number> <unit>")'),
    ("angle-unit", _edit(("m_n = 2", 'm_n = 2\nbeta = "20 mm"')), "[pair] beta", '"20 mm"',
     lambda v: v.startswith("one of [") and "'deg'" in v and "'arcmin'" in v and "'mm'" not in v),
    ("pitch-unit", _edit(("m_n = 2", 'P_n = "8 in"')), "[pair] P_n", '"8 in"',
     lambda v: v.startswith("one of [") and "'1/in'" in v and "'1/mm'" in v),
    ("choice", _edit(("m_n = 2", 'm_n = 2\nhand = "up"')), "[pair] hand", '"up"', 'one of "right", "left"'),
    ("bounds", _edit(add="[output]\ndpi = 5\n"), "[output] dpi", "5", "10 <= dpi <= 2400"),
    ("bare-slip", _edit(add="[rack]\nalpha_n = 0.35\n"), "[rack] alpha_n", "0.35", "10 <= alpha_n < 45 deg"),
    ("study-bounds", _edit(("n = 4", "n = 0")), "[dummy] n", "0", "1 <= n <= 100"),
    ("study-angle", _edit(('angle = "20 deg"', 'angle = "2 rad"')), "[dummy] angle", '"2 rad"', "0 < angle <= 90 deg"),
    ("tool-key", _edit(("z = 20\nb = 20", 'z = 20\nb = 20\ntool = {kind = "hob", z = 9}')), "[pinion] tool.z", "9",
     "1 <= z <= 8"),
    ("tool-length", _edit(("z = 40\nb", 'z = 40\ntool = {kind = "hob", d_p0 = -60}\nb')), "[gear] tool.d_p0", "-60",
     "d_p0 > 0 mm"),
    ("tool-kind", _edit(("z = 20\nb = 20", 'z = 20\nb = 20\ntool = {kind = "planer"}')), "[pinion] tool.kind",
     '"planer"', 'one of "rack", "hob", "shaper"'),
    ("tool-not-table", _edit(("z = 20\nb = 20", 'z = 20\nb = 20\ntool = "shaper"')), "[pinion] tool", '"shaper"',
     lambda v: v.startswith("an inline table") and '"shaper"' in v),
    ("tool-foreign-key", _edit(("z = 20\nb = 20", 'z = 20\nb = 20\ntool = {kind = "shaper", d_p0 = 60}')),
     "[pinion] tool.d_p0", None, "kind, z, x"),
    ("unknown-key", _edit(("z = 20\nb = 20", "z = 20\nb = 20\nmodul = 3")), "[pinion] modul", None,
     lambda v: "z" in v.split(", ") and "tool" in v.split(", ")),
    ("missing-key", _edit(("z = 20\nb = 20", "z = 20")), "[pinion] b", None, lambda v: v.startswith("length")),
    ("study-name", _edit(('study = "dummy"', 'study = "dumy"')), "[scene] study", '"dumy"',
     lambda v: '"dummy"' in v),
    ("scene-name", _edit(('name = "dummy spur"', 'name = "a/b"')), "[scene] name", '"a/b"',
     lambda v: v.startswith("a name that can be a file name")),
    ("top-level", "module = 3\n" + GOOD_SCENE, "module", "3", "inside a section"),
    ("section-not-table", "output = 3\n" + GOOD_SCENE, "[output]", "3", lambda v: v.startswith("a table")),
    ("missing-section", GOOD_SCENE.replace("[gear]\nz = 40\nb = \"0.1 in\"\n", ""), "[gear]", None, None),
]


@pytest.mark.parametrize("text, param, value, valid", [c[1:] for c in ONE], ids=[c[0] for c in ONE])
def test_a_loader_problem_carries_param_value_valid(dummy_study, scene_file, text, param, value, valid):
    e, path = _error(scene_file, text)
    assert e.source == path and len(e.problems) == 1, str(e)
    p = e.problems[0]
    assert str(e) == f"{path}: {p}"
    assert (e.param, e.value, e.valid) == (p.param, p.value, p.valid)
    assert e.param == param, (e.param, str(e))
    assert e.value == value, (e.value, str(e))
    if callable(valid):
        assert e.valid is not None and valid(e.valid), (e.valid, str(e))
    else:
        assert e.valid == valid, (e.valid, str(e))
    if value is not None:  # the message shows the key and the value as typed
        assert (f"{param} = {value}" if e.detail is not None else value) in str(e)
    assert str(path) not in str(p)  # a problem is stated without the file (the error adds it once)


def test_an_array_of_tables_names_the_case(scene_file):
    """A key of the second [[tca.cases]] table is named with its index."""
    text = _edit(('study = "dummy"', 'study = "tca"'), ("[dummy]\nn = 4\nspan = \"0.5 in\"\nangle = \"20 deg\"\n", ""),
                 add='[[tca.cases]]\ndE = 0.01\n[[tca.cases]]\ndE = "2 deg"\n')
    e, _ = _error(scene_file, text)
    assert (e.param, e.value) == ("[tca.cases][1] dE", '"2 deg"'), str(e)
    assert e.valid.startswith("one of [") and "'mm'" in e.valid


def test_several_problems_are_kept_in_order(dummy_study, scene_file):
    text = _edit(("z = 20", "z = 20.5"), ("z = 40", "z = 0.5"), ("n = 4", "n = 500"))
    e, path = _error(scene_file, text)
    assert [p.param for p in e.problems] == ["[pinion] z", "[gear] z", "[dummy] n"]
    assert [p.value for p in e.problems] == ["20.5", "0.5", "500"]
    assert [p.valid for p in e.problems] == ["an integer", "an integer", "1 <= n <= 100"]
    assert all(isinstance(p, SceneError) and p.source is None and p.problems == [] for p in e.problems)
    # the message is as before: the file, the count, one line per problem
    assert str(e) == f"{path}: 3 problems:\n" + "\n".join(f"  - {p}" for p in e.problems)
    assert (e.param, e.value, e.valid) == ("[pinion] z", "20.5", "an integer")
    assert e.detail is None  # the message does not end with the first problem's words


def test_a_quantity_with_its_own_bare_unit_is_stated_from_fields(scene_file, dummy_study):
    """[pair] P_n: a bare number means 1/in (not the kind's 1/mm), in the message and when read."""
    e, _ = _error(scene_file, _edit(("m_n = 2", 'P_n = "8 deg"')))
    assert e.param == "[pair] P_n" and e.value == '"8 deg"'
    assert e.detail.endswith("(a bare number means 1/in).") and "1/mm)" not in str(e)
    # a unit-less string is a bare number, in the field's unit: 8 teeth per inch = 25.4 / 8 mm module
    for written in ("P_n = 8", 'P_n = "8"', 'P_n = "8 1/in"'):
        sc = load_scene(scene_file(_edit(("m_n = 2", written)), "ok.toml"))
        assert sc.pair.pinion.m_n == pytest.approx(25.4 / 8, rel=1e-14), written


def test_field_convert_error_fields():
    """Field.convert, used alone: param is the key path (without "(default)"), value as written."""
    from gearopt.io.schema import Bounds, Field

    f = Field("q", "length", check=Bounds(lo=0, lo_open=True))
    with pytest.raises(SceneError) as ei:
        f.convert("-2 in", "[s] q")
    e = ei.value
    assert (e.param, e.value, e.valid) == ("[s] q", '"-2 in"', "q > 0 mm")
    assert str(e) == '[s] q = "-2 in" ' + e.detail and e.detail == "is out of range; valid: q > 0 mm."
    with pytest.raises(SceneError) as ei:
        Field("q", "int").convert("3", "[s] q (default)", param="[s] q")
    assert ei.value.param == "[s] q" and str(ei.value).startswith("[s] q (default) = ")


def test_no_message_rewriting_in_the_loader():
    """Field.convert builds its messages from fields; it does not edit another error's text."""
    root = Path(gearopt.__file__).parent
    for rel in ("io/schema.py", "io/scene.py", "cli.py", "units.py"):
        src = (root / rel).read_text(encoding="utf-8")
        assert ".replace(f\"(a bare number" not in src and "str(e).replace" not in src, rel
        assert "str(err).startswith" not in src and "str(e).startswith" not in src, rel


# ------------------------------------------------------------------------------------------------
# 2. SceneError.source: the CLI passes through what is stated for its scene, by the field
# ------------------------------------------------------------------------------------------------
@pytest.fixture
def raising_study():
    """A study named "raising" whose build raises ``raising_study[0](scene)``."""
    from gearopt.studies import StudySpec, register, unregister

    hook = [None]

    def build(scene):
        raise hook[0](scene)

    register(StudySpec(name="raising", sections=[], build=build, doc="raises on build"))
    yield hook
    unregister("raising")


RAISING = GOOD_SCENE.replace('study = "dummy"', 'study = "raising"').split("[dummy]")[0]


def test_cli_passes_through_an_error_stated_for_the_scene(raising_study, scene_file, capsys):
    from gearopt.cli import main

    path = scene_file(RAISING)
    # stated for this scene (source set): printed as it is, not restated as a failure of the study
    raising_study[0] = lambda sc: SceneError(f"{sc.source}: [raising] knob = 3 is out of range; valid: knob < 2.",
                                             param="[raising] knob", value="3", valid="knob < 2", source=sc.source)
    assert main(["check", str(path)]) == 2
    assert capsys.readouterr().err == f"error: {path}: [raising] knob = 3 is out of range; valid: knob < 2.\n"


def test_cli_restates_a_scene_error_not_stated_for_the_scene(raising_study, scene_file, capsys):
    from gearopt.cli import main

    path = scene_file(RAISING)
    # a SceneError of other origin that merely starts with the file name is tied to the scene
    raising_study[0] = lambda sc: SceneError(f"{sc.source}: something else")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: study 'raising' failed: ") and err.rstrip().endswith("something else")


def test_every_scene_error_of_a_study_carries_its_source():
    """Every SceneError gearopt raises with the scene file in its message says so in ``source``
    (the CLI relies on the field)."""
    root = Path(gearopt.__file__).parent
    missing = []
    for f in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "SceneError" and node.args):
                continue
            first = node.args[0]
            head = first.values[0] if isinstance(first, ast.JoinedStr) and first.values else None
            names_file = isinstance(head, ast.FormattedValue) and ast.unparse(head.value) in (
                "src", "label", "source", "path", "scene.source", "self.source")
            if names_file and not any(k.arg == "source" for k in node.keywords):
                missing.append(f"{f.relative_to(root)}:{node.lineno}")
    assert not missing, missing


# ------------------------------------------------------------------------------------------------
# 3. Gear-data errors found while a study is built or run: stated for the gear key
# ------------------------------------------------------------------------------------------------
CROWNING = """\
[scene]
name = "c"
study = "crowning"
[pair]
m_n = {m}
{pair}
[pinion]
z = {z1}
b = 20
tool = {tool}
[gear]
z = {z2}
b = 20
[crowning]
te_level = "8 arcsec"
crossing = "3 arcmin"
"""


@pytest.mark.parametrize("m, z1, z2, pair, tool", [
    (3, 20, 40, "", '{kind = "shaper", z = 30}'),
    (2.5, 23, 61, 'beta = "15 deg"', '{kind = "shaper", z = 41, x = 0.2}'),
])
def test_crowning_refuses_a_shaper_cut_pinion_at_its_tool_key(scene_file, capsys, m, z1, z2, pair, tool):
    from gearopt.cli import _in_scene, main

    path = scene_file(CROWNING.format(m=m, z1=z1, z2=z2, pair=pair, tool=tool))
    scene = load_scene(path)
    with pytest.raises(SceneError) as ei:
        with _in_scene(scene):
            scene.build()
    e = ei.value
    written = json.dumps(scene.raw["pinion"]["tool"])  # the inline table as typed, in the messages' notation
    assert e.param == "[pinion] tool" and e.value == written and e.source == path
    assert e.valid.startswith("kind 'rack' or 'hob'")
    assert str(e).startswith(f"{path}: [pinion] tool = {written}") and "is out of range" in str(e)
    assert "[crowning]" not in str(e) and "pinion.tool" not in str(e)
    assert main(["check", str(path)]) == 2
    assert capsys.readouterr().err == f"error: {e}\n"


@pytest.fixture
def gear_scene(scene_file, dummy_study):
    def make(**edits):
        text = GOOD_SCENE
        if "rack" in edits:
            text += f"[rack]\n{edits['rack']}\n"
        if "gear_rack" in edits:
            text = text.replace('z = 40\nb = "0.1 in"', f'z = 40\nb = "0.1 in"\nrack = {{{edits["gear_rack"]}}}')
        if "pair" in edits:
            text = text.replace("m_n = 2", edits["pair"])
        return load_scene(scene_file(text, "g.toml"))
    return make


@pytest.mark.parametrize("edits, param, where, shown", [
    (dict(rack='a_c = "0.002 1/mm"'), "gear.rack.a_c", "[rack] a_c", '"0.002 1/mm"'),
    (dict(gear_rack='a_c = 0.003'), "gear.rack.a_c", "[gear.rack] a_c", "0.003"),
    (dict(pair="P_n = 12"), "pinion.m_n", "[pair] P_n", "12"),
    (dict(pair='m_n = "0.1 in"'), "gear.m_n", "[pair] m_n", '"0.1 in"'),
    (dict(), "pinion.z", "[pinion] z", "20"),
])
def test_run_and_study_errors_about_gear_data_name_the_gear_key(gear_scene, edits, param, where, shown):
    """An error of the gear code (param as gearopt.gears names it) raised while a study is built
    or runs is stated at the key the scene file sets, with the value as typed."""
    scene = gear_scene(**edits)
    err = out_of_range(param, 1.5, "x < 1", cls=GeometryError)
    for e in (scene.study_error("dummy", err), scene.run_error(err)):
        assert e.param == where and e.value == shown and e.valid == "x < 1" and e.source == scene.source, str(e)
        assert f"{where} = {shown}" in str(e) and "is out of range; valid: x < 1." in str(e)
    # a gear parameter the scene does not set (the rack's a_c from the preset): the gearopt name stays
    e = scene.study_error("dummy", out_of_range("pinion.rack.a_c", 2.0, "a_c < 1", cls=GeometryError)) \
        if "rack" not in edits and "gear_rack" not in edits else None
    if e is not None:
        assert e.param == "[dummy] pinion.rack.a_c" and "[dummy] pinion.rack.a_c = 2.0" in str(e)
    # nor is a derived quantity a key: the tip radius stays as gearopt names it
    e = scene.run_error(out_of_range("gear.r_a", 2.0, "r_a > 3 mm", cls=GeometryError))
    assert e.param is None and str(e).endswith(": gear.r_a = 2.0 is out of range; valid: r_a > 3 mm.")
