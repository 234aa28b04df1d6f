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
