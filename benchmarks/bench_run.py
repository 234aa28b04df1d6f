"""``gearopt run`` wall time, split into its phases (issue 43: demo <= 1.5 s, crowning <= 6 s warm).

    python benchmarks/bench_run.py                       # the demo and the crowning scene, 2 warm runs each
    python benchmarks/bench_run.py --base 27920d5        # the same, the base revision in the same run (ratios)
    python benchmarks/bench_run.py tca_spur_crowned --repeat 5

Each run is one fresh process (``python -c DRIVER``, ``MPLBACKEND=Agg``) that calls
``gearopt.cli.main(["run", SCENE, "--out", DIR, "--quiet"])`` with timers around its phases:

- ``import``: ``import gearopt.cli`` and the modules ``gearopt run`` imports before it reads the scene;
- ``build``: reading the scene and building its study (``load_scene``, ``Scene.build``);
- ``study``: the study's ``run()``;
- ``plots``: the result's ``save_plots`` (the figures, drawn and saved as PNG), or where the CLI has
  them drawn in separate processes (``gearopt.cli_plots``), from handing the result over to the end
  of the wait for them (the CLI writes the tables meanwhile; CPU: the CLI's and theirs);
- ``write``: the rest of ``write_results`` (results.json, the tables, report.html, installing the files);
- ``wall``: the process, start to exit, seen from outside (interpreter start-up and exit included).

A phase's CPU time includes the processes forked and reaped in it (the crowning study's TCA of the
drive before optimisation runs in one, :class:`gearopt.studies.crowning.ForkedCall`).

Imports made lazily inside a phase count in that phase. The first run of each scene is a warm-up
(the CasADi disk cache, the ``.pyc`` files, written even where ``PYTHONDONTWRITEBYTECODE`` is set,
the OS file cache) and is not shown; the table gives the
median of the ``--repeat`` runs after it ("warm" = second run and later). With ``--base REV`` the
revision is checked out into a temporary git worktree and its runs alternate with the working tree's,
so that the ratio ``here/base`` of each phase is measured under the same load (the absolute times
move with the load of the machine: ``uptime`` is printed with the table).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SCENES = ["tca_spur_crowned", "crowning_spur"]  # `make demo` (Makefile SCENE) and problems/crowning*.toml
PHASES = ["import", "build", "study", "plots", "write", "wall"]

DRIVER = r"""
import functools, json, os, sys, time
os.environ.setdefault("MPLBACKEND", "Agg")
T, C = {}, {}
t, c = time.perf_counter(), time.process_time()
import gearopt.cli as cli
import gearopt.io.results as results, gearopt.io.scene as scene_mod, gearopt.progress  # what _run imports first
T["import"], C["import"] = time.perf_counter() - t, time.process_time() - c

import resource
def cpu():  # this process and its children reaped so far (a study's forked helpers, e.g. the crowning study's)
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + r.ru_utime + r.ru_stime

def timed(name, f):
    @functools.wraps(f)
    def g(*a, **k):
        t, c = time.perf_counter(), cpu()
        try:
            return f(*a, **k)
        finally:
            T[name] = T.get(name, 0.0) + time.perf_counter() - t
            C[name] = C.get(name, 0.0) + cpu() - c
    return g

load = scene_mod.load_scene
def load_scene(*a, **k):
    s = timed("build", load)(*a, **k)
    build = type(s).build
    def built(self, *a, **k):
        study = timed("build", build)(self, *a, **k)
        cls = type(study)
        cls.run = timed("study", cls.run)
        return study
    type(s).build = built
    return s
scene_mod.load_scene = load_scene

try:  # the drawing processes of gearopt run (gearopt.cli_plots): from submit() to the end of wait()
    from gearopt.cli_plots import PlotProcesses
except ImportError:
    PlotProcesses = None
if PlotProcesses is not None:
    submit, wait, T0 = PlotProcesses.submit, PlotProcesses.wait, {}
    def submit_(self, *a, **k):
        T0["t"], T0["c"] = time.perf_counter(), time.process_time()
        return submit(self, *a, **k)
    def wait_(self, *a, **k):
        try:
            return wait(self, *a, **k)
        finally:  # the CLI's own work in between (tables, page template) included; and the CPU time
            # of the drawing processes
            T["plots"] = T.get("plots", 0.0) + time.perf_counter() - T0["t"]
            C["plots"] = C.get("plots", 0.0) + time.process_time() - T0["c"]
            C["workers"] = C.get("workers", 0.0) + self.cpu_time
    PlotProcesses.submit, PlotProcesses.wait = submit_, wait_

write = results.write_results
def write_results(out, result, **k):
    cls = type(result)
    cls.save_plots = timed("plots", cls.save_plots)  # where the CLI draws itself
    return timed("write", write)(out, result, **k)
results.write_results = write_results

import contextlib, io
with contextlib.redirect_stdout(io.StringIO()):
    rc = cli.main(["run", sys.argv[1], "--out", sys.argv[2], "--quiet"])
for D in (T, C):
    D["write"] = D.get("write", 0.0) - D.get("plots", 0.0)
C["plots"] = C.get("plots", 0.0) + C.pop("workers", 0.0)
print("BENCH_RUN " + json.dumps({"rc": rc, "wall": T, "cpu": C}))
"""


def run_once(tree: Path, scene: str, out: Path) -> dict[str, dict[str, float]]:
    """One process of ``gearopt run`` (the package of ``tree``); its phase times in s, ``{"wall": {phase:
    s}, "cpu": {phase: s}}`` (CPU: user + system time of the process, less sensitive to the load)."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's warm run reads the .pyc files the first run wrote
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", DRIVER, f"problems/{scene}.toml", str(out)], cwd=tree, env=env,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    line = [s for s in p.stdout.splitlines() if s.startswith("BENCH_RUN ")]
    if p.returncode or not line:
        raise SystemExit(f"bench_run: {scene} in {tree} failed (rc {p.returncode}):\n{p.stderr[-2000:]}")
    d = json.loads(line[-1].split(" ", 1)[1])
    if d.pop("rc"):
        raise SystemExit(f"bench_run: gearopt run {scene} returned an error:\n{p.stderr[-2000:]}")
    return {"wall": {**{k: d["wall"].get(k, 0.0) for k in PHASES[:-1]}, "wall": wall},
            "cpu": {**{k: d["cpu"].get(k, 0.0) for k in PHASES[:-1]}, "wall": cpu}}


def fmt_row(name: str, t: dict[str, float]) -> str:
    return f"{name:<28}" + "".join(f"{t[k]:>8.2f}" for k in PHASES)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", default=SCENES, help=f"scene names (default: {' '.join(SCENES)})")
    ap.add_argument("--repeat", type=int, default=2, help="warm runs per scene and tree after the warm-up (default 2)")
    ap.add_argument("--base", default=None, help="git revision to time in the same run (a temporary worktree)")
    ap.add_argument("--json", default=None, metavar="FILE", help="also write every run's times to FILE")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error(f"--repeat = {a.repeat}: must be >= 1")
    known = sorted(p.stem for p in (ROOT / "problems").glob("*.toml"))
    unknown = [s for s in a.scenes if s not in known]
    if unknown:
        ap.error(f"unknown scene(s) {unknown}; known: {', '.join(known)}")
    work = Path(tempfile.mkdtemp(prefix="gearopt-bench-run-"))
    print(f"outputs in {work} (base/<scene>, here/<scene>: compare them with benchmarks/compare_results.py)",
          file=sys.stderr)
    trees = {"here": ROOT}
    if a.base:
        base = work / "base-tree"
        r = subprocess.run(["git", "worktree", "add", "--detach", str(base), a.base], cwd=ROOT,
                           capture_output=True, text=True)
        if r.returncode:
            print(f"bench_run: git worktree add {a.base!r} failed: {r.stderr.strip()}", file=sys.stderr)
            return 2
        trees = {"base": base, "here": ROOT}
    runs: dict[str, dict[str, list]] = {s: {k: [] for k in trees} for s in a.scenes}
    try:
        for s in a.scenes:
            for i in range(a.repeat + 1):  # run 0: the warm-up
                for k, tree in trees.items():
                    t = run_once(tree, s, work / k / s)
                    if i:
                        runs[s][k].append(t)
                    print(f"  {s} {k} run {i}{' (warm-up)' if not i else ''}: " + ", ".join(
                        f"{p} {t['wall'][p]:.2f}" for p in PHASES) + f" s (CPU {t['cpu']['wall']:.2f} s)",
                        file=sys.stderr, flush=True)
    finally:
        if a.base:
            subprocess.run(["git", "worktree", "remove", "--force", str(trees["base"])], cwd=ROOT, capture_output=True)
    load = os.getloadavg()
    for clock, what in (("wall", "wall time"), ("cpu", "CPU time (user + system; 'wall' column: the whole process)")):
        print(f"\ngearopt run, warm, {what}, s: median of {a.repeat} runs after a warm-up; load average "
              f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
        print(f"{'scene':<28}" + "".join(f"{k:>8}" for k in PHASES))
        for s in a.scenes:
            med = {}
            for k in trees:
                med[k] = {p: statistics.median(r[clock][p] for r in runs[s][k]) for p in PHASES}
                print(fmt_row(f"{s} ({k})" if a.base else s, med[k]))
            if a.base:
                print(f"{'  here/base':<28}" + "".join(
                    f"{med['here'][p] / med['base'][p]:>8.2f}" if med["base"][p] > 0.005 else f"{'-':>8}"
                    for p in PHASES))
    if a.json:
        Path(a.json).write_text(json.dumps({"load": load, "runs": runs}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
