"""The geometry study asks the member's tool object whether it cuts with the basic rack (issue 40:
tools as objects), not the generation method's name."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import pytest

from gearopt.gears import Gear, GearPair
from gearopt.geometry.envelope import GeneratedTooth, rack_generated
from gearopt.geometry.tools import TOOLS, Tool
from gearopt.studies.geometry import GeometryStudy


@pytest.fixture
def worm_tool():
    """A tool of a kind the geometry study does not know by name (docs/extending.md's grinding worm,
    reduced): the basic rack's normal section, so it has the rack-cutter's settings."""

    @dataclass(frozen=True)
    class Worm(Tool):
        kind: ClassVar[str] = "test_worm"

        def generate(self, gear: Gear) -> GeneratedTooth:
            tooth = rack_generated(gear, gear.rack, "worm")
            return GeneratedTooth(gear=gear, method="worm", functions=tooth.functions, r_root=tooth.r_root)

    try:
        yield Worm()
    finally:
        TOOLS.pop("test_worm", None)


def _pair(tool: Tool | None = None) -> GearPair:
    kw = {} if tool is None else {"tool": tool}
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, name="pinion", **kw), Gear(z=40, m_n=3.0, b=20.0, name="gear"))


def test_the_rack_outline_follows_the_tool_object(worm_tool):
    """The rack-cutter in mesh is drawn for every tool that cuts with the basic rack's profile
    (rack_settings), whatever its generation method is called; not for a shaper."""
    assert sorted(GeometryStudy(_pair()).run().to_dict()["rack_cutter"]) == ["gear", "pinion"]
    assert sorted(GeometryStudy(_pair(), generation="hob").run().to_dict()["rack_cutter"]) == ["gear", "pinion"]
    assert GeometryStudy(_pair(), generation="shaper").run().to_dict()["rack_cutter"] == {}
    d = GeometryStudy(_pair(worm_tool)).run().to_dict()
    assert d["members"]["pinion"]["generation"] == "worm"
    assert sorted(d["rack_cutter"]) == ["gear", "pinion"]
