"""``gearopt run``'s wall time (issue 43): the interpreter's final garbage collections skipped at the
CLI's exit (gearopt.cli.exit_without_collecting), and the number of drawing processes chosen from
the figures' stated costs (gearopt.cli_plots.processes_for, plot_makespan)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from gearopt.cli_plots import MAX_PROCESSES, plot_makespan, processes_for

ROOT = Path(__file__).resolve().parent.parent


def test_the_cli_freezes_the_objects_alive_at_its_exit_only():
    # an exit handler registered before main() runs after the CLI's (exit handlers run last first):
    # it sees the objects frozen at exit; the process that goes on after main() collects as usual
    code = ("import atexit, gc, sys\n"
            "atexit.register(lambda: print('at exit frozen', gc.get_freeze_count() > 0))\n"
            "import gearopt.cli as c\n"
            "status = c.main(['studies'])\n"
            "print('after main frozen', gc.get_freeze_count() > 0)\n"
            "c.main(['studies'])\n"
            "sys.exit(status)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.splitlines()
    assert "after main frozen False" in lines
    assert lines[-1] == "at exit frozen True"


@pytest.mark.parametrize("costs, processes, cores, expected", [
    ([1, 2, 1], 2, 2, 2.0),    # te, then compare on one process; bearing_contact on the other
    ([1, 2, 1], 3, 2, 2.5),    # three share two cores: te and compare done at 1.5, bearing_contact alone after
    ([1, 1, 1], 2, 2, 2.0),    # one process draws two figures in turn
    ([1, 1, 1], 3, 2, 1.5),
    ([3, 1, 1, 1], 2, 2, 3.0),  # the second process draws the three small ones meanwhile
    ([1, 1], 4, 2, 1.0),       # more processes than figures: the extra ones draw nothing
    ([2, 2], 1, 2, 4.0),       # one process: the sum
    ([], 2, 2, 0.0),
])
def test_plot_makespan_shares_the_cores_between_the_running_processes(costs, processes, cores, expected):
    assert plot_makespan(costs, processes, cores) == pytest.approx(expected, rel=1e-12)


class Costed:
    def __init__(self, costs, captions=None):
        self.plot_costs = costs
        self.captions = captions or {}


def test_processes_for_follows_the_stated_costs_of_the_figures(monkeypatch):
    monkeypatch.setattr("gearopt.forking.idle_cores", lambda: 1)  # an idle machine
    captions = {f"{k}.png": "" for k in "abcde"}  # names more figures than are drawn: the costs decide
    # the demo's tca figures: two processes (2 units) rather than three (2.5)
    assert processes_for(Costed({"te.png": 1, "bearing_contact.png": 2, "compare.png": 1}, captions), 2) == 2
    # three equal figures: one process each (1.5 against 2)
    assert processes_for(Costed({"a.png": 1, "b.png": 1, "c.png": 1}), 2) == 3
    # five equal figures: three processes (2.5 units; two take 3, four 3)
    assert processes_for(Costed({f"{k}.png": 1 for k in range(5)}), 2) == 3
    # eight equal figures on three cores: four processes (2.67 units, as eight would; three take 3)
    assert processes_for(Costed({f"{k}.png": 1 for k in range(8)}), 3) == 4 == MAX_PROCESSES
    # never fewer than the cores
    assert processes_for(Costed({"a.png": 5}), 2) == 2
    monkeypatch.setattr("gearopt.forking.idle_cores", lambda: 0)  # every core busy: one per core
    assert processes_for(Costed({"a.png": 1, "b.png": 1, "c.png": 1}), 2) == 2


def test_the_tca_result_states_the_figures_it_draws():
    import pickle

    from gearopt.io.scene import load_scene

    pytest.importorskip("matplotlib")
    scene = load_scene(ROOT / "problems" / "tca_spur_crowned.toml")
    result = scene.build().run()
    pickle.dumps(result)
    assert list(result.plot_costs) == ["te.png", "bearing_contact.png", "compare.png"]
    assert set(result.plot_costs) <= set(result.captions)


def _figure(variant):
    """A constrained 2 x 2 figure of the kind gearopt draws (titles, labels, a legend under each
    axes), with one axes changed by ``variant``: what decides whether a spine's extent is held by
    the rest of its axes' tight box."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullFormatter

    fig, axes = plt.subplots(2, 2, figsize=(6, 4.5), layout="constrained")
    for k, ax in enumerate(axes.ravel()):
        ax.plot([0, 1, 2], [0, 10 ** k, -3 * k], label=f"case {k}")
        ax.set_title(f"panel {k}")
        ax.set_xlabel("phi1 [deg]")
        ax.set_ylabel("TE [arcsec]")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.25), fontsize=7)
    ax = axes[0, 1]
    if variant == "ticks all round":
        ax.tick_params(top=True, right=True, length=12)
    elif variant == "ticks in":
        ax.tick_params(direction="in", length=12)
    elif variant == "no tick labels":
        ax.tick_params(labelleft=False, labelbottom=False, length=12)
    elif variant == "empty tick labels":
        ax.yaxis.set_major_formatter(NullFormatter())
        ax.xaxis.set_major_locator(FixedLocator([0, 1, 2]))
        ax.xaxis.set_major_formatter(FixedFormatter(["", "", ""]))
        ax.tick_params(length=12)
    elif variant == "twin":
        ax.twinx().plot([0, 2], [5, 7], color="C3")
    elif variant == "spine moved":
        ax.spines["left"].set_position(("outward", 15))
    elif variant == "no axes":
        ax.set_axis_off()
    return fig


@pytest.mark.parametrize("variant", ["plain", "ticks all round", "ticks in", "no tick labels", "empty tick labels",
                                     "twin", "spine moved", "no axes"])
def test_png_saving_lays_a_figure_out_where_matplotlib_does(tmp_path, variant):
    # gearopt.plot.saving leaves out of the layout the spines whose extent the rest of their axes'
    # tight box holds: every axes where matplotlib's own constrained layout puts it
    import matplotlib.pyplot as plt

    from gearopt.plot.saving import png_saving

    ref = _figure(variant)
    ref.set_dpi(80)
    ref.get_layout_engine().execute(ref)
    expected = [ax.get_position().bounds for ax in ref.axes]
    plt.close(ref)
    fig = _figure(variant)
    with png_saving():
        fig.savefig(tmp_path / "f.png", dpi=80, bbox_inches="tight")
    assert [ax.get_position().bounds for ax in fig.axes] == expected
    assert all(s.get_in_layout() for ax in fig.axes for s in ax.spines.values())  # as they were
    plt.close(fig)


def test_png_saving_does_not_measure_the_spines_of_a_plain_figure_for_the_layout(tmp_path, monkeypatch):
    # each spine's extent updates its axis's ticks: none is needed for the tight boxes of gearopt's
    # figures
    import matplotlib.pyplot as plt
    import matplotlib.spines

    from gearopt.plot.saving import png_saving

    calls = []
    extent = matplotlib.spines.Spine.get_window_extent

    def counted(self, *a, **k):  # a spine's extent asked for its axes' tight box (not an axis label's place)
        if sys._getframe(1).f_code.co_name == "get_tightbbox":
            calls.append(self.spine_type)
        return extent(self, *a, **k)

    monkeypatch.setattr(matplotlib.spines.Spine, "get_window_extent", counted)
    fig = _figure("plain")
    with png_saving():
        fig.savefig(tmp_path / "f.png", dpi=80, bbox_inches="tight")
    plt.close(fig)
    assert calls == []
    fig = _figure("ticks all round")  # the top and right spines of that axes stay in the layout
    with png_saving():
        fig.savefig(tmp_path / "f.png", dpi=80, bbox_inches="tight")
    plt.close(fig)
    assert calls and set(calls) == {"top", "right"}
