"""Warnings raised while the plots and tables of a run are written (a plot that has to leave a case out)
are recorded like the study's own: in results.json ``meta.warnings`` (after the run's) and on
report.html, and still shown where Python shows them (gearopt/warning_log.py, gearopt/io/results.py
write_results, docs/results.md ``meta.warnings``)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from gearopt.io.results import write_results  # noqa: E402
from gearopt.version import __version__  # noqa: E402
from gearopt.warning_log import WarningLog, source_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def plot_cases(ax, cases: dict) -> None:
    """A plot function that leaves out a case it cannot draw, and says so by a warning."""
    for name, y in cases.items():
        if y is None:
            warnings.warn(f"case {name!r} has no TE: left out of the plot", UserWarning, stacklevel=1)
            continue
        ax.plot(y, label=name)


class _Result:
    """A study result: its run warned once (``run_warnings``), its table and its plot may warn."""

    captions = {"te.png": "TE per case."}

    def __init__(self, table_warns: bool = False):
        self.table_warns = table_warns

    def to_dict(self):
        return {"study": "tca", "units": {"te": "arcsec"}}

    def summary(self):
        return []

    def save_tables(self, d):
        if self.table_warns:
            warnings.warn("table: 2 rows without a value", RuntimeWarning, stacklevel=1)
        (Path(d) / "t.csv").write_text("a\n1\n")
        return ["t.csv"]

    def save_plots(self, d):
        fig, ax = plt.subplots()
        plot_cases(ax, {"aligned": [0.0, 1.0, 0.0], "crossing +3 arcmin": None})
        fig.savefig(Path(d) / "te.png")
        plt.close(fig)
        return ["te.png"]


RUN = [{"category": "UserWarning", "message": "feasible fraction 0.4 < 0.5", "source": "gearopt/x.py:1"}]


def test_a_warning_of_a_plot_is_in_meta_warnings_and_on_the_page(tmp_path):
    out = tmp_path / "out"
    with warnings.catch_warnings(record=True) as shown:  # still shown as Python shows them
        warnings.simplefilter("always")
        write_results(out, _Result(table_warns=True), warnings=RUN)
    assert sorted(str(w.message) for w in shown) == ["case 'crossing +3 arcmin' has no TE: left out of the plot",
                                                     "table: 2 rows without a value"]
    meta = json.loads((out / "results.json").read_text())["meta"]
    # the run's warning first, then the table's and the plot's, each with where it was raised
    assert [(w["category"], w["message"]) for w in meta["warnings"]] == [
        ("UserWarning", "feasible fraction 0.4 < 0.5"),
        ("RuntimeWarning", "table: 2 rows without a value"),
        ("UserWarning", "case 'crossing +3 arcmin' has no TE: left out of the plot")]
    line = next(i for i, text in enumerate(Path(__file__).read_text().splitlines(), 1)
                if "left out of the plot\", UserWarning" in text)
    assert meta["warnings"][2]["source"] == f"test_plot_warnings.py:{line}"  # the line in plot_cases
    page = (out / "report.html").read_text()
    assert "UserWarning: case &#39;crossing +3 arcmin&#39; has no TE: left out of the plot" in page \
        or "UserWarning: case 'crossing +3 arcmin' has no TE: left out of the plot" in page
    assert "RuntimeWarning: table: 2 rows without a value" in page
    assert "3 warnings raised by this run" in page


def test_without_plots_nothing_of_the_plot_is_recorded(tmp_path):
    write_results(tmp_path / "out", _Result(), warnings=RUN, plots=False)
    meta = json.loads((tmp_path / "out" / "results.json").read_text())["meta"]
    assert meta["warnings"] == RUN


@pytest.mark.slow
def test_a_warning_planted_in_a_plot_of_a_scene_is_recorded(tmp_path, monkeypatch):
    """``gearopt run`` of a real scene whose plot function (gearopt.plot.geometry.plot_tooth, drawn
    twice) warns: the warning is in results.json meta.warnings once, with its source, and on
    report.html."""
    from gearopt.cli import main
    import gearopt.plot.geometry as geometry_plots

    drawn = geometry_plots.plot_tooth

    def plot_tooth(*args, **kwargs):
        warnings.warn("planted: a flank left out of the plot", UserWarning, stacklevel=1)
        return drawn(*args, **kwargs)

    monkeypatch.setattr(geometry_plots, "plot_tooth", plot_tooth)
    # drawn in this process (pytest.warns sees this process's warnings; the drawing processes' warnings
    # coming back once: tests/test_cli_plots.py)
    monkeypatch.setattr("gearopt.cli_plots.PlotProcesses.start", classmethod(lambda cls, count=None: None))
    out = tmp_path / "o"
    with pytest.warns(UserWarning, match="planted"):
        assert main(["run", str(ROOT / "problems" / "spur_geometry.toml"), "--out", str(out), "-q"]) == 0
    meta = json.loads((out / "results.json").read_text())["meta"]
    planted = [w for w in meta["warnings"] if w["message"] == "planted: a flank left out of the plot"]
    assert len(planted) == 1 and planted[0]["category"] == "UserWarning"
    assert planted[0]["source"] == f"test_plot_warnings.py:{plot_tooth.__code__.co_firstlineno + 1}"
    assert "UserWarning: planted: a flank left out of the plot" in (out / "report.html").read_text()


def test_the_log_records_and_still_shows():
    log = WarningLog()
    with pytest.warns(RuntimeWarning, match="two"):
        with log:
            warnings.warn("two", RuntimeWarning, stacklevel=1)
    with pytest.warns(UserWarning, match="three"), log:  # re-entrant in sequence: the records add up
        for _ in range(2):  # the same warning from the same line: recorded once
            warnings.warn("three", UserWarning, stacklevel=1)
    assert [(r["category"], r["message"]) for r in log.records] == [("RuntimeWarning", "two"), ("UserWarning", "three")]
    assert source_text("/x/y/gearopt/plot/tca.py", 7) == "gearopt/plot/tca.py:7"
    assert source_text("/x/y/script.py", 3) == "script.py:3"


def _design_dir(path: Path) -> Path:
    """A tca result directory as gearopt run leaves it (pair, no arrays: no figure of its own)."""
    path.mkdir(parents=True)
    data = {"study": "tca", "scene": path.name, "summary": [], "units": {"length": "mm"},
            "pair": {"z1": 20, "z2": 40, "m_n": 3.0, "side": "right", "ratio": 2.0},
            "meta": {"gearopt_version": __version__, "scene": None, "warnings": []}}
    (path / "results.json").write_text(json.dumps(data))
    (path / ".gearopt-output.json").write_text(json.dumps({"written_by": "gearopt", "files": ["results.json"]}))
    return path


def test_a_warning_of_a_comparison_figure_is_in_comparison_json_and_on_the_page(tmp_path, monkeypatch):
    """``gearopt compare``: a warning planted in one group's figures (gearopt.plot.compare.figures) is in
    comparison.json ``meta.warnings`` with its source and on the comparison page."""
    import gearopt.plot.compare.figures as figures
    from gearopt.io.compare import compare

    def dynamics_figures(designs):
        warnings.warn("planted: design 'b' has no K_v, left out", UserWarning, stacklevel=1)
        return []

    monkeypatch.setattr(figures, "dynamics_figures", dynamics_figures)
    out = tmp_path / "cmp"
    with pytest.warns(UserWarning, match="planted"):
        compare([_design_dir(tmp_path / "a"), _design_dir(tmp_path / "b")], out)
    meta = json.loads((out / "comparison.json").read_text())["meta"]
    assert meta["warnings"] == [{"category": "UserWarning", "message": "planted: design 'b' has no K_v, left out",
                                 "source": f"test_plot_warnings.py:{dynamics_figures.__code__.co_firstlineno + 1}"}]
    page = (out / "report.html").read_text()
    assert "comparison figures: UserWarning: planted: design" in page
