"""The figures of ``gearopt run`` drawn in forked processes (gearopt.cli_plots) and saved with
gearopt.plot.saving: every file written once between the processes, the same pixels as drawn in one
process, errors and warnings of a drawing process brought back to the CLI, and the cases where the
CLI draws itself."""

from __future__ import annotations

import contextlib
import os
import pickle
import threading
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from gearopt.cli_plots import PlotProcesses  # noqa: E402
from gearopt.plot.saving import drawn_here, png_saving  # noqa: E402
from gearopt.plot.style import plot_style  # noqa: E402

NAMES = ["a.png", "b.png", "c.png", "d.png", "e.png"]


class Figures:
    """A picklable study result: one small figure per name, different pixels in each; ``fail``
    raises in ``save_plots`` after the first figure, ``warn`` warns while drawing."""

    def __init__(self, names=NAMES, fail=False, warn=False):
        self.names, self.fail, self.warn = list(names), fail, warn

    def save_plots(self, directory, dpi=40):
        out = []
        for i, name in enumerate(self.names):
            if self.fail and i == 1:
                raise ValueError("figure b: drawing failed on purpose")
            if self.warn:
                warnings.warn(f"figure {name}: a case left out", UserWarning)
            fig, ax = plt.subplots(figsize=(2, 1.5))
            ax.plot([0, 1, 2], [0, i, 2 * i])
            ax.set_title(name)
            fig.savefig(Path(directory) / name, dpi=dpi)
            plt.close(fig)
            out.append(name)
        return out


#: the forking tests of this file that skipped because another thread ran in this process (an xdist
#: worker's own, or one a test of another file left): the last test runs them in a fresh process
THREAD_SKIPS: list[str] = []


def skip_unless_single_threaded(name: str) -> None:
    if threading.active_count() != 1:
        THREAD_SKIPS.append(name)
        pytest.skip("another thread runs in this process: the CLI would not fork")


def pixels(path):
    return np.asarray(Image.open(path).convert("RGBA"))


@pytest.fixture
def processes(request, tmp_path_factory, monkeypatch):
    skip_unless_single_threaded(request.node.name)
    # the drawing processes' temporary directories (claims) in a directory of this test's own, so that
    # what other test processes create in the shared /tmp meanwhile is not taken for theirs
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path_factory.mktemp("plots_tmp")))
    p = PlotProcesses.start(count=2)
    if p is None:
        pytest.skip("no fork here (not Linux)")
    yield p
    p.close()


# --- gearopt.plot.saving ----------------------------------------------------------------------------
def test_png_saving_with_claims_draws_each_file_in_the_first_process_to_reach_it(tmp_path):
    claims = tmp_path / "claims"
    claims.mkdir()
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir()
    second.mkdir()
    with png_saving(claims):  # "another process" that reached b.png and d.png first
        assert drawn_here(second / "b.png") and drawn_here(second / "d.png")
        assert drawn_here(second / "b.png")  # still its own
    with png_saving(claims):
        assert Figures().save_plots(second) == NAMES  # every name returned, taken or not
        assert not drawn_here(second / "b.png")
    assert sorted(p.name for p in second.iterdir()) == ["a.png", "c.png", "e.png"]
    with png_saving(claims):  # other paths: not taken
        Figures().save_plots(first)
    assert sorted(p.name for p in first.iterdir()) == NAMES
    assert drawn_here(second / "b.png")  # outside png_saving: every file drawn here


def test_png_saving_gives_the_pixels_of_plain_savefig_with_zlib_level_1(tmp_path, monkeypatch):
    (tmp_path / "plain").mkdir()
    (tmp_path / "fast").mkdir()
    Figures().save_plots(tmp_path / "plain")
    levels = []
    import PIL.Image

    save = PIL.Image.Image.save

    def spy(self, fp, format=None, **params):
        levels.append(params.get("compress_level"))
        return save(self, fp, format, **params)

    monkeypatch.setattr(PIL.Image.Image, "save", spy)
    with png_saving():
        Figures().save_plots(tmp_path / "fast")
    assert levels == [1] * len(NAMES)
    for name in NAMES:
        assert np.array_equal(pixels(tmp_path / "plain" / name), pixels(tmp_path / "fast" / name)), name
    import matplotlib.figure
    assert matplotlib.figure.Figure.savefig.__name__ == "savefig" and "png_saving" not in repr(
        matplotlib.figure.Figure.savefig)  # restored


def test_png_saving_leaves_file_objects_and_other_formats_alone(tmp_path):
    import io

    fig, ax = plt.subplots(figsize=(1, 1))
    ax.plot([0, 1])
    buf = io.BytesIO()
    claims = tmp_path / "claims"
    claims.mkdir()
    with png_saving(claims):  # taken by "another process"
        assert drawn_here(tmp_path / "taken.png")
    with png_saving(claims):
        fig.savefig(buf, format="png")
        fig.savefig(tmp_path / "x.svg")
        fig.savefig(tmp_path / "taken.png")
        fig.savefig(tmp_path / "free.png")
    plt.close(fig)
    assert buf.getvalue()[:4] == b"\x89PNG"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["claims", "free.png", "x.svg"]


def _laid_out(extra_text=False, equal=False):
    fig, axes = plt.subplots(2, 2, figsize=(6, 4.5), layout="constrained")
    for i, ax in enumerate(axes.ravel()):
        ax.plot([0, 1, 2], [0, i, 2 * i], label=f"curve {i}")
        ax.set_title(f"panel {i}")
        ax.set_xlabel("pinion angle [deg]")
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.3), frameon=False)  # under the axes
    fig.suptitle("a two-line\nfigure title")
    if extra_text:
        fig.text(1.02, 0.5, "a note outside the layout")
    if equal:  # drawn to scale: narrower than its cell
        axes[0, 0].set_aspect("equal")
    return fig


def test_png_saving_lays_a_constrained_figure_out_once_with_the_tight_box(tmp_path, monkeypatch):
    import matplotlib.figure

    draws = []
    draw = matplotlib.figure.Figure.draw
    monkeypatch.setattr(matplotlib.figure.Figure, "draw", lambda self, r: draws.append(1) or draw(self, r))
    with plot_style():  # bbox_inches="tight"; each figure new (the layout depends on where it starts)
        fig = _laid_out()
        fig.savefig(tmp_path / "tight.png", dpi=80)
        plt.close(fig)
        plain = len(draws)
        fig = _laid_out()
        with png_saving():
            fig.savefig(tmp_path / "fast.png", dpi=80)
    assert plain == 2 and len(draws) == plain + 1  # one draw instead of two (and no tight-box pass)
    assert fig.get_layout_engine() is not None  # the figure keeps its layout engine
    plt.close(fig)
    a, b = pixels(tmp_path / "tight.png"), pixels(tmp_path / "fast.png")
    assert abs(a.shape[0] - b.shape[0]) <= 0.03 * a.shape[0] and abs(a.shape[1] - b.shape[1]) <= 0.03 * a.shape[1]

    def ink(img):  # rows and columns with something drawn
        drawn = (img[..., :3] < 250).any(axis=2)
        return drawn.any(axis=1).sum(), drawn.any(axis=0).sum()

    # everything is in the picture: the same extent of ink (the titles, the legends under the axes)
    assert all(abs(p - q) <= 2 for p, q in zip(ink(a), ink(b))), (ink(a), ink(b))
    for img in (a, b):  # a white margin all round
        assert (img[:3] >= 250).all() and (img[-3:] >= 250).all() and (img[:, :3] >= 250).all() and \
            (img[:, -3:] >= 250).all()


@pytest.mark.parametrize("extra_text, equal", [(True, False), (False, True)])
def test_png_saving_saves_a_figure_with_a_text_outside_the_layout_or_to_scale_as_usual(tmp_path, extra_text, equal):
    with plot_style():
        for name, saving in (("tight.png", contextlib.nullcontext()), ("fast.png", png_saving())):
            fig = _laid_out(extra_text, equal)
            with saving:
                fig.savefig(tmp_path / name, dpi=80)
            plt.close(fig)
    assert np.array_equal(pixels(tmp_path / "tight.png"), pixels(tmp_path / "fast.png"))


def test_png_saving_refuses_a_bad_level_or_claims_directory(tmp_path):
    with pytest.raises(ValueError, match="compress_level = 10"):
        with png_saving(compress_level=10):
            pass
    with pytest.raises(ValueError, match="not a directory"):
        with png_saving(tmp_path / "absent"):
            pass


# --- gearopt.cli_plots ------------------------------------------------------------------------------
def test_processes_write_every_file_with_the_pixels_of_one_process(tmp_path, processes):
    serial, forked = tmp_path / "serial", tmp_path / "forked"
    serial.mkdir()
    forked.mkdir()
    with plot_style():  # as write_results draws in its own process
        Figures().save_plots(serial)
    assert processes.submit(Figures(), forked, {"dpi": 40})
    files, shown = processes.wait()
    assert files == NAMES and shown == []
    assert sorted(p.name for p in forked.iterdir()) == NAMES
    for name in NAMES:
        assert np.array_equal(pixels(serial / name), pixels(forked / name)), name
    assert processes.cpu_time > 0
    # the same processes draw the next result too
    again = tmp_path / "again"
    again.mkdir()
    assert processes.submit(Figures(NAMES[:2]), again, {})
    assert processes.wait()[0] == NAMES[:2]


def test_an_error_while_drawing_is_raised_in_the_cli_with_its_traceback(tmp_path, processes):
    assert processes.submit(Figures(fail=True), tmp_path, {})
    with pytest.raises(ValueError, match="figure b: drawing failed on purpose") as info:
        processes.wait()
    notes = "\n".join(getattr(info.value, "__notes__", []))
    assert "raised while drawing the plots in process" in notes and "save_plots" in notes


def test_warnings_of_every_drawing_process_come_back_once(tmp_path, processes, capsys):
    assert processes.submit(Figures(NAMES[:3], warn=True), tmp_path, {})
    files, shown = processes.wait()
    assert [w["message"] for w in shown] == [f"figure {n}: a case left out" for n in NAMES[:3]]
    assert {w["category"] for w in shown} == {"UserWarning"}
    err = capsys.readouterr().err
    assert all(err.count(f"figure {n}: a case left out") == 1 for n in NAMES[:3]), err


def test_a_result_that_does_not_pickle_is_left_to_the_cli(tmp_path, processes):
    r = Figures()
    r.callback = lambda: None
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        pickle.dumps(r)
    assert processes.submit(r, tmp_path, {}) is False
    assert list(tmp_path.iterdir()) == []


def test_a_result_whose_class_the_drawing_process_lacks_is_left_to_the_cli(tmp_path, processes, monkeypatch):
    import sys
    import types

    late = types.ModuleType("late_study_module")  # imported here after the drawing process was forked
    late.Late = type("Late", (Figures,), {"__module__": "late_study_module"})
    monkeypatch.setitem(sys.modules, "late_study_module", late)
    assert processes.submit(late.Late(), tmp_path, {})
    assert processes.wait() is None
    assert list(tmp_path.iterdir()) == []
    assert processes.submit(Figures(NAMES[:1]), tmp_path, {})  # still there for the next result
    assert processes.wait()[0] == NAMES[:1]


def test_close_ends_the_drawing_process(processes):
    pid = processes.pid
    processes.close()
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, 0)
    processes.close()  # again: nothing


class Slow(Figures):
    """Figures drawn slowly: 0.4 s before each."""

    def save_plots(self, directory, dpi=40):
        import time

        out = []
        for name in self.names:
            time.sleep(0.4)
            out += Figures([name]).save_plots(directory, dpi)
        return out


def test_close_while_drawing_stops_every_drawing_process_and_leaves_no_claims(tmp_path, processes):
    import glob
    import tempfile
    import time

    before = set(glob.glob(os.path.join(tempfile.gettempdir(), "gearopt-plots-*")))
    assert processes.submit(Slow(), tmp_path, {})
    time.sleep(1.0)  # drawing has begun
    assert set(glob.glob(os.path.join(tempfile.gettempdir(), "gearopt-plots-*"))) - before  # its claims
    processes.close()
    written = sorted(p.name for p in tmp_path.iterdir())
    time.sleep(1.5)  # no drawing process writes after close()
    assert sorted(p.name for p in tmp_path.iterdir()) == written and len(written) < len(NAMES)
    assert set(glob.glob(os.path.join(tempfile.gettempdir(), "gearopt-plots-*"))) == before


def test_no_processes_for_another_backend_or_one_core(monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "pdf")
    assert PlotProcesses.start() is None
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setattr("gearopt.cli_plots.usable_cores", lambda: 1)
    assert PlotProcesses.start() is None
    with pytest.raises(ValueError, match="count"):
        PlotProcesses.start(count=0)


@pytest.mark.slow
def test_gearopt_run_writes_the_same_plots_with_processes_as_on_one_core(tmp_path):
    """The demo run twice: as usual (drawing processes where there are two cores) and pinned to one
    core (the CLI draws itself): the same files, the same pixels, the same key numbers."""
    import json
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    if len(os.sched_getaffinity(0)) < 2:
        pytest.skip("one core: the drawing processes are not used")
    env = dict(os.environ, PYTHONPATH=str(root))
    env.pop("MPLBACKEND", None)
    outs = {}
    for how, pin in (("processes", None), ("one_core", lambda: os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}))):
        out = tmp_path / how
        p = subprocess.run([sys.executable, "-m", "gearopt", "run", "problems/tca_spur_crowned.toml", "--out", str(out),
                            "--quiet"], cwd=root, env=env, capture_output=True, text=True, timeout=600, preexec_fn=pin)
        assert p.returncode == 0, p.stderr[-2000:]
        outs[how] = out
    a, b = outs["processes"], outs["one_core"]
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    pngs = [n for n in names if n.endswith(".png")]
    assert pngs == ["bearing_contact.png", "compare.png", "te.png"]
    for n in pngs:
        assert np.array_equal(pixels(a / n), pixels(b / n)), n
    ra, rb = (json.loads((d / "results.json").read_text()) for d in (a, b))
    assert ra["summary"] == rb["summary"] and ra["meta"]["warnings"] == rb["meta"]["warnings"]


def test_gearopt_run_leaves_matplotlib_to_the_drawing_process(tmp_path):
    """The CLI process of gearopt run never imports matplotlib (about 0.5 s): the drawing process
    imports it while the study runs and writes the figure (the dummy study of tests/conftest.py)."""
    import subprocess
    import sys

    from conftest import GOOD_SCENE

    if len(os.sched_getaffinity(0)) < 2:
        pytest.skip("one core: the CLI draws itself")
    root, tests = Path(__file__).resolve().parents[1], Path(__file__).resolve().parent
    scene = tmp_path / "scene.toml"
    scene.write_text(GOOD_SCENE)
    code = ("import sys\n"
            "from conftest import register_dummy\n"
            "register_dummy()\n"
            "import gearopt.cli\n"
            f"rc = gearopt.cli.main(['run', {str(scene)!r}, '--out', {str(tmp_path / 'out')!r}, '--quiet'])\n"
            "print('RC', rc, 'matplotlib' in sys.modules)\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), str(tests)]))
    env.pop("MPLBACKEND", None)
    p = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.strip().splitlines()[-1] == "RC 0 False"
    assert (tmp_path / "out" / "dummy.png").stat().st_size > 0


class SlowFigures(Figures):
    """Figures that name themselves in ``captions`` and take ``seconds`` each; every figure drawn
    leaves ``<name>.pid`` with the number of the process that drew it."""

    def __init__(self, names, seconds):
        super().__init__(names)
        self.seconds = seconds

    @property
    def captions(self):
        return {n: f"figure {n}" for n in self.names}

    def save_plots(self, directory, dpi=40):
        import time

        for name in self.names:
            if drawn_here(Path(directory) / name):
                (Path(directory) / f"{name}.pid").write_text(str(os.getpid()))
                time.sleep(self.seconds)
        return super().save_plots(directory, dpi)


def test_processes_for_gives_one_process_per_named_figure_up_to_the_maximum(monkeypatch):
    from gearopt.cli_plots import MAX_PROCESSES, processes_for

    monkeypatch.setattr("gearopt.forking.idle_cores", lambda: 1)  # an idle machine

    assert processes_for(SlowFigures(NAMES[:3], 0), 2) == 3
    assert processes_for(SlowFigures(NAMES[:1], 0), 2) == 2  # never fewer than the cores
    assert processes_for(SlowFigures(NAMES * 2, 0), 2) == MAX_PROCESSES
    assert processes_for(Figures(), 2) == 2  # no captions: the cores decide

    class Broken(Figures):
        @property
        def captions(self):
            raise RuntimeError("no captions")

    assert processes_for(Broken(), 3) == 3
    monkeypatch.setattr("gearopt.forking.idle_cores", lambda: 0)  # every core busy: one per core
    assert processes_for(SlowFigures(NAMES[:3], 0), 2) == 2


def test_three_figures_are_drawn_by_three_processes_on_two(tmp_path, monkeypatch):
    # each figure takes 1.5 s: three processes each take one (two would leave one to draw two)
    skip_unless_single_threaded("test_three_figures_are_drawn_by_three_processes_on_two")
    monkeypatch.setattr("gearopt.forking.idle_cores", lambda: 1)  # an idle machine, in the drawing process too
    processes = PlotProcesses.start(count=2)
    if processes is None:
        pytest.skip("no fork here (not Linux)")
    try:
        assert processes.submit(SlowFigures(NAMES[:3], 1.5), tmp_path, {})
        files, _ = processes.wait()
    finally:
        processes.close()
    assert files == NAMES[:3]
    pids = {(tmp_path / f"{n}.pid").read_text() for n in NAMES[:3]}
    assert len(pids) == 3, pids
    assert sorted(p.name for p in tmp_path.glob("*.png")) == NAMES[:3]


def test_the_forking_tests_run_in_a_process_without_other_threads():
    """Under pytest-xdist (``make test``) a worker runs threads of its own, so the tests above that
    fork skip there (``THREAD_SKIPS``: a thread left by another file may also end meanwhile); this runs
    them in a fresh single-threaded pytest process instead, so that CI tests the drawing processes too."""
    if threading.active_count() == 1 and not THREAD_SKIPS:
        pytest.skip("single-threaded here: the forking tests above ran in this process")
    if not (hasattr(os, "fork") and os.uname().sysname == "Linux"):
        pytest.skip("no fork here (not Linux)")
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                           "-m", "not slow", str(Path(__file__)), "-k", "processes or close"],
                          cwd=root, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "skipped" not in proc.stdout.splitlines()[-1], proc.stdout[-1000:]
    assert " passed" in proc.stdout.splitlines()[-1]
