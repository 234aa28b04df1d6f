"""Shared fixtures: a tiny dummy study for the scene loader and the CLI, and scene-file helpers."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import pytest

DUMMY = "dummy"

#: A valid scene for the dummy study (spur pair 20/40, m_n = 2 mm).
GOOD_SCENE = """\
[scene]
name = "dummy spur"
description = "test scene"
study = "dummy"

[pinion]
z = 20
b = 20

[gear]
z = 40
b = "0.1 in"

[pair]
m_n = 2

[dummy]
n = 4
span = "0.5 in"
angle = "20 deg"
"""


class DummyResult:
    def __init__(self, scene, nan=False, fail_plots=False):
        self.scene, self.nan, self.fail_plots = scene, nan, fail_plots

    def to_dict(self):
        p = self.scene.pair
        opts = self.scene.options[DUMMY]
        return {
            "units": {"r_a": "mm", "angle": "rad", "a_w": "mm"},
            "r_a": [p.pinion.r_a, p.gear.r_a],
            "a_w": p.a_w,
            "angle": math.nan if self.nan else opts["angle"],
            "n": opts["n"],
        }

    def save_plots(self, directory):
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        if self.fail_plots:
            (Path(directory) / "partial.png").write_bytes(b"not a png")
            raise RuntimeError("plotting failed on purpose")
        fig, ax = plt.subplots(figsize=(2, 2))
        ax.plot(range(self.scene.options[DUMMY]["n"]))
        path = Path(directory) / "dummy.png"
        fig.savefig(path, dpi=self.scene.output["dpi"])
        plt.close(fig)
        return [str(path)]


class DummyStudy:
    def __init__(self, scene):
        self.scene = scene

    def run(self, progress=None):
        if progress:
            progress("dummy study running")
        o = self.scene.options[DUMMY]
        return DummyResult(self.scene, nan=o["nan"], fail_plots=o["fail_plots"])


def dummy_spec():
    from gearopt.io.scene import Bounds, Field, Section
    from gearopt.studies import StudySpec

    section = Section(DUMMY, [
        Field("n", "int", default=3, check=Bounds(lo=1, hi=100), doc="number of points"),
        Field("span", "length", default=1.0, doc="a length"),
        Field("angle", "angle", default=10, check=Bounds(lo=0, hi=90, lo_open=True), doc="an angle"),
        Field("mode", "str", default="fast", choices=("fast", "exact"), doc="how"),
        Field("curv", "inverse_length", default=0.0, doc="a curvature"),
        Field("nan", "bool", default=False, doc="put a NaN into the results"),
        Field("fail_plots", "bool", default=False, doc="raise while plotting"),
    ], doc="dummy study options")
    return StudySpec(name=DUMMY, sections=[section], build=DummyStudy, doc="dummy study for tests")


def register_dummy():
    """Register the dummy study (also used by a plugin module in a subprocess test)."""
    from gearopt.studies import register

    return register(dummy_spec())


@pytest.fixture
def dummy_study():
    from gearopt.studies import unregister

    spec = register_dummy()
    yield spec
    unregister(DUMMY)


@pytest.fixture
def scene_file(tmp_path):
    """``scene_file(text, name="scene.toml") -> Path``: write a scene into tmp_path."""

    def write(text: str, name: str = "scene.toml") -> Path:
        path = tmp_path / name
        path.write_text(textwrap.dedent(text), encoding="utf-8")
        return path

    return write


# Rotation matrices of the tests' own (independent) frames.
def Rz(a):
    import math

    import numpy as np
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def Ry(a):
    import math

    import numpy as np
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def Rx(a):
    import math

    import numpy as np
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


#: Test modules whose every GearoptError is checked by tests/error_fields.py: the bad-input corpora,
#: the scene loader's bad scenes (test_scene.py), the CLI and the planar study's scene errors.
_ERROR_CORPORA = ("test_bad_input", "test_scene", "test_cli", "test_planar_tca")


@pytest.fixture(autouse=True)
def _error_fields(request):
    """In the bad-input corpora (:data:`_ERROR_CORPORA`): every GearoptError built during a test
    has ``param``, ``value``, ``valid`` consistent with its message, and one that names a
    parameter (``name = value ...``, for a SceneError ``[section] key ...`` after the file name)
    says which in ``param``; a SceneError that lists several problems holds them in ``problems``
    (docs/errors.md)."""
    if not request.module.__name__.split(".")[-1].startswith(_ERROR_CORPORA):
        yield
        return
    from error_fields import check_fields, recording

    with recording() as seen:
        yield
    problems = [p for e in seen for p in check_fields(e)]
    assert not problems, "\n".join(problems)
