"""Tools as objects (gearopt.geometry.tools.Tool): the worked example of docs/extending.md ("A tool")
runs as written, and the gear data, the generation and the scene loader ask the tool instead of
choosing by its class."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from gearopt import Gear, generate
from gearopt.geometry.envelope import GeneratedTooth
from gearopt.geometry.tools import TOOLS, Hob, RackCutter, Shaper, Tool

ROOT = Path(__file__).resolve().parents[1]


def _doc_example() -> str:
    text = (ROOT / "docs" / "extending.md").read_text(encoding="utf-8")
    section = text[text.index("\n## A tool\n"):]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert len(blocks) == 1, "docs/extending.md, 'A tool': one python block (the worked example)"
    return blocks[0]


def test_the_worked_example_of_a_tool_runs(tmp_path):
    # in a fresh interpreter: the example registers its tool kind, which must not leak into other tests
    script = tmp_path / "tool_example.py"
    script.write_text(_doc_example(), encoding="utf-8")
    res = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)})
    assert res.returncode == 0, res.stderr[-3000:]
    assert "worm" not in TOOLS


def test_the_builtin_tools_register_by_kind():
    assert TOOLS == {"rack": RackCutter, "hob": Hob, "shaper": Shaper}
    assert all(issubclass(cls, Tool) for cls in TOOLS.values())


@dataclass(frozen=True)
class _DeepRack(RackCutter):
    """A rack-cutter whose closed forms are shifted: the gear data must take them from the tool."""

    def root_radius(self, gear) -> float:
        return super().root_radius(gear) - 0.125

    def form_radius(self, gear) -> float:
        return super().form_radius(gear) + 0.25

    def x_min_undercut(self, gear) -> float:
        return super().x_min_undercut(gear) - 0.5

    def generate(self, gear) -> GeneratedTooth:
        tooth = super().generate(gear)
        return GeneratedTooth(gear=gear, method="deep", functions=tooth.functions, r_root=tooth.r_root)


def test_the_gear_data_ask_the_tool():
    plain = Gear(z=23, m_n=3.0, b=20.0, x=0.2)
    deep = Gear(z=23, m_n=3.0, b=20.0, x=0.2, tool=_DeepRack())
    assert deep.r_f == plain.r_f - 0.125
    assert deep.r_lim == plain.r_lim + 0.25
    assert deep.x_min_undercut == plain.x_min_undercut - 0.5
    assert generate(deep).method == "deep"   # generate() dispatches to the tool's own method
    assert "deep" not in TOOLS                # no kind: a variant, not a scene tool


def test_a_tool_kind_names_one_class():
    from gearopt.errors import ArgumentError

    with pytest.raises(ArgumentError, match=r"_Hob2.kind = 'hob' is the kind of gearopt.geometry.tools.Hob"):
        @dataclass(frozen=True)
        class _Hob2(Hob):
            kind = "hob"
    assert TOOLS["hob"] is Hob


def test_a_shaper_has_no_rack_settings():
    from gearopt.errors import GeometryError
    from gearopt.geometry.tools import require_rack_settings

    g = Gear(z=40, m_n=3.0, b=20.0, tool=Shaper(N_s=30))
    refused = r"gear.tool = \"kind 'shaper'\" is out of range; valid: kind 'rack' or 'hob'"
    with pytest.raises(GeometryError, match=refused):
        require_rack_settings(g, "the crowning synthesis")
    with pytest.raises(GeometryError, match="a_c_max_unfolded"):
        _ = g.a_c_max_unfolded


@pytest.mark.parametrize("path", ["gearopt/gears.py", "gearopt/geometry/generation.py", "gearopt/geometry/envelope.py",
                                  "gearopt/io/scene.py", "gearopt/geometry/microgeometry.py"])
def test_no_tool_kind_is_chosen_by_its_class(path):
    """Nothing picks a behaviour by the class of ``gear.tool``; only the kind-specific entry points
    (``generate_by_hob(gear, hob=None)``) check their argument's class and default to the gear's own
    tool of their kind."""
    tree = ast.parse((ROOT / path).read_text(encoding="utf-8"))
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance" and len(node.args) == 2:
            subject, classes = (ast.unparse(a) for a in node.args)
            if "tool" in subject and any(k in classes for k in ("RackCutter", "Hob", "Shaper")):
                bad.append(f"{path}:{node.lineno} isinstance({subject}, {classes})")
    assert bad == []
