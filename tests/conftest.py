"""Shared fixtures: a tiny dummy study for the scene loader and the CLI, and scene-file helpers."""

from __future__ import annotations

import json
import math
import os
import textwrap
from pathlib import Path

import pytest

# Small sweeps of a graph not yet in the disk cache run interpreted and compile nothing in the
# background (gearopt.compiled, GEAROPT_JIT_BACKGROUND): the suite's CPU goes to its tests, as on a
# clean CI machine; tests/test_jit_policy.py switches the background compile on where it tests it.
os.environ.setdefault("GEAROPT_JIT_BACKGROUND", "0")

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


# ------------------------------------------------------------------------------------------------
# Scenes of problems/, each run once per test session (whichever process asks first) through the CLI
# ------------------------------------------------------------------------------------------------
PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


class SceneRun:
    """One ``gearopt run problems/<name>.toml --out DIR --quiet``: its exit status, ``results.json``
    as read back, the output directory, and what tests/plot_lint.py found in every figure saved."""

    def __init__(self, name: str, out: Path, status: int, plot_problems: list[str]):
        self.name, self.out, self.status, self.plot_problems = name, out, status, plot_problems
        path = out / "results.json"
        self.results = json.loads(path.read_text()) if status == 0 and path.exists() else None


def _run_scene(name: str, directory: Path) -> SceneRun:
    """Run the scene with every saved figure linted first (tests/plot_lint.py)."""
    import matplotlib
    import matplotlib.figure

    from gearopt.cli import main
    from plot_lint import lint_figure

    found: list[str] = []
    save = matplotlib.figure.Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        tight = kwargs.get("bbox_inches", matplotlib.rcParams["savefig.bbox"]) == "tight"
        found.extend(f"{Path(str(fname)).name}: {p}" for p in lint_figure(self, tight=tight))
        return save(self, fname, *args, **kwargs)

    out = directory / "out"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(matplotlib.figure.Figure, "savefig", savefig)
        # the figures drawn in this process, so that the lint above sees every one of them (forked
        # drawing processes, gearopt.cli_plots, would lint into their own copy of ``found``; their
        # pixels equal this process's: tests/test_cli_plots.py)
        mp.setattr("gearopt.cli_plots.PlotProcesses.start", classmethod(lambda cls, count=None: None))
        status = main(["run", str(PROBLEMS / f"{name}.toml"), "--out", str(out), "--quiet"])
    return SceneRun(name, out, status, found)


def _shared_dir(tmp_path_factory) -> Path:
    """A directory every test process of this session sees: under pytest-xdist the parent of the
    worker's base temporary directory (one per session, shared by the workers), else the base."""
    import os

    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session")
def scene_run(tmp_path_factory):
    """``scene_run(name) -> SceneRun``: problems/<name>.toml run through the CLI once per test session,
    whichever test process asks first (a lock file per scene in the session's shared directory; the
    others read the run back: its exit status, results and plot findings); the scene tests and the
    physics checks of its results share the run; an error is raised again for every test that asks."""
    import fcntl

    runs: dict[str, SceneRun | BaseException] = {}
    shared = _shared_dir(tmp_path_factory) / "scene_runs"
    shared.mkdir(exist_ok=True)

    def run_or_read(name: str) -> SceneRun:
        directory = shared / name
        record = shared / f"{name}.json"
        with open(shared / f"{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
            if not record.exists():
                directory.mkdir(exist_ok=True)
                try:
                    run = _run_scene(name, directory)
                except Exception as e:  # noqa: BLE001 - recorded, raised again for every test that asks
                    record.write_text(json.dumps({"error": f"{type(e).__name__}: {e}"}))
                    raise
                record.write_text(json.dumps({"status": run.status, "plot_problems": run.plot_problems}))
                return run
        done = json.loads(record.read_text())
        if "error" in done:
            raise RuntimeError(f"problems/{name}.toml failed in another test process: {done['error']}")
        return SceneRun(name, directory / "out", done["status"], done["plot_problems"])

    def get(name: str) -> SceneRun:
        if name not in runs:
            try:
                runs[name] = run_or_read(name)
            except Exception as e:  # noqa: BLE001 - re-raised below for every test that uses the run
                runs[name] = e
        run = runs[name]
        if isinstance(run, BaseException):
            raise run
        return run

    return get



# ------------------------------------------------------------------------------------------------
# How pytest-xdist hands out the whole suite (make test: -n auto --dist loadgroup)
# ------------------------------------------------------------------------------------------------
#: Studies whose scene runs form the work unit ``scenes-loaded`` (the others: ``scenes``).
LOADED_SCENE_STUDIES = ("ltca", "loaded_microgeometry")

#: Time of each work unit of the whole suite [s] (a test file, or one of the two units of scene runs;
#: the junit times of the whole suite, 2026-11-30 01:30, main after the night's merge, the columns' libraries recompiled): only their order matters
#: (heaviest first, so that no heavy unit starts last and the two workers end together); a unit not
#: listed counts 0 and keeps its place. Re-measure with ``python tests/suite_units.py JUNIT.xml`` (a
#: junit report of ``make test``) after a change that moves a unit by a minute.
UNIT_COST: dict[str, float] = {
    "scenes": 156, "scenes-loaded": 60, "test_loaded_synthesis_objectives.py": 59, "test_fea.py": 33,
    "test_ltca.py": 27, "test_inspection.py": 26, "test_dynamics.py": 26, "test_robust.py": 25,
    "test_microgeometry.py": 23, "test_dynamics_sensitivity.py": 18, "test_loaded_synthesis.py": 17,
    "test_synthesis.py": 17, "test_tca_stability.py": 16, "test_flank_limit.py": 16, "test_plots_results.py": 15,
    "test_edge_grid.py": 15, "test_rating_fe.py": 14, "test_loaded_pareto.py": 14, "test_cli_plots.py": 13,
    "test_loaded_sensitivity_licq.py": 12, "test_loaded_pressure.py": 12, "test_edge_modifications.py": 12,
    "test_loaded_exchange.py": 11, "test_loaded_sensitivity.py": 11, "test_loaded_sensitivity_local.py": 10,
    "test_bad_input_studies.py": 10, "test_ltca_continuity.py": 8, "test_loaded_sensitivity_de.py": 7,
    "test_edge.py": 7, "test_loaded_fast.py": 7, "test_tca.py": 7, "test_compare_rating.py": 6,
    "test_crowning_forked.py": 6, "test_compile_queue.py": 6, "test_ltca_edges.py": 5}

#: Environment variable: the file in which the workers leave each test's work unit for the controller.
UNITS_FILE_ENV = "GEAROPT_TEST_UNITS_FILE"


def work_unit(item: pytest.Item) -> str:
    """The pytest-xdist work unit of a test: every test that reads a scene run (``scene_run``) joins
    the unit of its scenes' family (``scenes`` or ``scenes-loaded``), so that one process runs each
    scene and no other process waits for it (conftest.scene_run's lock); every other test its file's
    unit, so that a file's module fixtures are built once."""
    import tomllib

    if "scene_run" not in getattr(item, "fixturenames", ()):
        return item.path.name
    params = getattr(getattr(item, "callspec", None), "params", {})
    scene = params.get("scene", params.get("name"))
    if isinstance(scene, (str, Path)) and (PROBLEMS / f"{Path(scene).stem}.toml").is_file():
        studied = tomllib.loads((PROBLEMS / f"{Path(scene).stem}.toml").read_text())["scene"]["study"]
        return "scenes-loaded" if studied in LOADED_SCENE_STUDIES else "scenes"
    return "scenes-loaded" if item.path.name == "test_problems_loaded.py" else "scenes"


def pytest_configure(config: pytest.Config) -> None:
    """The pytest-xdist controller under ``--dist loadgroup``: a file for the workers' work units."""
    import tempfile

    if (getattr(config.option, "dist", "no") == "loadgroup" and getattr(config.option, "numprocesses", None)
            and not os.environ.get("PYTEST_XDIST_WORKER")):
        fd, path = tempfile.mkstemp(prefix="gearopt-test-units-", suffix=".json")
        os.close(fd)
        os.environ[UNITS_FILE_ENV] = path  # the workers, started after this, inherit it
        config.add_cleanup(lambda: Path(path).unlink(missing_ok=True))


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """A pytest-xdist worker under ``--dist loadgroup``: the tests ordered by work unit, heaviest unit
    first (:data:`UNIT_COST`, then the order of collection), and each test's unit written for the
    controller's scheduler (:func:`pytest_xdist_make_scheduler`)."""
    path = os.environ.get(UNITS_FILE_ENV)
    if not (path and os.environ.get("PYTEST_XDIST_WORKER")):
        return
    unit = {item.nodeid: work_unit(item) for item in items}
    first: dict[str, int] = {}
    for i, item in enumerate(items):
        first.setdefault(unit[item.nodeid], i)
    items.sort(key=lambda it: (-UNIT_COST.get(unit[it.nodeid], 0.0), first[unit[it.nodeid]]))
    tmp = f"{path}.{os.environ['PYTEST_XDIST_WORKER']}"
    Path(tmp).write_text(json.dumps(unit))
    os.replace(tmp, path)  # every worker writes the same


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """``--dist loadgroup``: pytest-xdist's scope scheduling over :func:`work_unit` (read from the
    workers' file), the units in the workers' order (heaviest first: the longest-processing-time-first
    rule; each worker takes the next unit when it has at most two tests left). pytest-xdist's own
    ``loadgroup`` (``xdist_group`` marks) does not group under pytest >= 9 (it renames ``_nodeid``)."""
    if getattr(config.option, "dist", "no") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class UnitScheduling(LoadScopeScheduling):
        units: dict[str, str] | None = None

        def _split_scope(self, nodeid: str) -> str:
            if self.units is None:
                try:
                    self.units = json.loads(Path(os.environ[UNITS_FILE_ENV]).read_text())
                except (KeyError, OSError, ValueError):
                    self.units = {}  # then one unit per file, as --dist loadfile
            return self.units.get(nodeid) or nodeid.split("::", 1)[0]

    config.option.loadscopereorder = False  # the workers' order, not by number of tests
    return UnitScheduling(config, log)
