"""What keeps ``gearopt run`` fast (issue 43; timings: benchmarks/bench_run.py): the demo's path does
not import scipy.optimize (about 0.3-0.5 s), and tick labels are not laid out by mathtext (about a
quarter of a figure's drawing time)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from gearopt.plot.style import plot_style  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def test_the_demo_scene_builds_and_runs_without_scipy_optimize():
    code = ("import sys\n"
            "from gearopt.io.scene import load_scene\n"
            "load_scene('problems/tca_spur_crowned.toml').build().run()\n"
            "print(sorted(m for m in sys.modules if m.startswith('scipy.optimize')))\n")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert p.stdout.strip() == "[]", f"scipy.optimize imported on the demo's path: {p.stdout.strip()}"


def test_tick_labels_are_plain_text_in_the_plot_style():
    with plot_style():
        fig, ax = plt.subplots()
        ax.plot([-10, 10], [0.5, 2.5])
        fig.canvas.draw()
        labels = [t.get_text() for t in ax.get_xticklabels() + ax.get_yticklabels()]
    plt.close(fig)
    assert labels and all(lab and "$" not in lab for lab in labels), labels
    assert "\u22125.0" in labels  # the minus sign U+2212, as with mathtext
