"""Every speed figure the README and docs/ state about the current code, measured in one command and
written to one generated file, docs/figures.md (issue 43: "every ratio or time stated in README/docs
regenerates from one benchmark command on this machine and is within its stated noise").

    python benchmarks/figures.py                 # measure every group, write docs/figures.md and the docs' blocks
    python benchmarks/figures.py --check         # measure again; each documented figure within / outside its noise
    python benchmarks/figures.py --only tca,run  # some groups (the other keys of docs/figures.md are kept)
    make figures                                 # the first line

About 11 minutes on this 2-core machine idle (2026-11-29 night: 4:47 for every group but ``scenes``, 6:06 for
``scenes``; 18 minutes for the first five groups at load 8-13; the loaded optimiser's
cold runs and the compiles after them are most of it); progress
on stderr. Each group runs the measurement of its benchmark (no timing code of its own):

- ``tca``: the compiled sweeps of ``benchmarks/bench_compiled.py`` (its case, its ``best`` of 5 calls, its
  ``fsolve_columns``) with the user's warm disk cache: us per position-pair (per column) of ``TCA.sweep``
  and its ratio to scipy's fsolve per column within the same repeat;
- ``ltca``: ``benchmarks/bench_ltca.py``'s ``measure`` (one torque over one cycle of 64 positions, 21 slices,
  warm, best of 5 within a repeat);
- ``loaded``: ``benchmarks/bench_loaded_synthesis.py``'s ``scene_run`` on ``microgeometry_loaded``: a cold
  process (an empty ``GEAROPT_CACHE``), then, once its detached compiles are done (``settle``), a warm one;
- ``run``: ``benchmarks/bench_run.py``'s ``run_once`` (one process of ``gearopt run``) on the demo and the
  crowning scene, after one warm-up run each;
- ``rating``: ``benchmarks/bench_rating.py``'s ``rate_time`` and ``study_times``;
- ``scenes``: the same as ``run`` on every scene of problems/ but the FE ones (CalculiX: docs/fea.md), whose run
  times problems/README.md, docs/dynamics.md and docs/rating.md state (about 8 minutes idle).

Every figure is the median over ``--repeat`` repeats (default: the group's own, 3-7) with its spread, the
range over the repeats: that range is the figure's stated noise. ``--check`` reports a figure as within its
noise when the range measured now overlaps the documented one, and exits 1 if any is outside (times move
with the machine and its load: the header of docs/figures.md names the CPU, the cores and the load
average; ratios against fsolve are taken within one repeat and move less).

The docs quote a figure through a marked block, ``<!-- figure: KEY -->VALUE<!-- /figure -->`` (``KEY range``:
``VALUE (MIN-MAX)``; ``KEY met``: ``met`` or ``not met``, its issue-43 target), which this command rewrites; tests/test_figures.py checks that every block holds the
generated value.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
OUT = ROOT / "docs" / "figures.md"
#: files whose marked blocks are rewritten
DOCS = [ROOT / "README.md", ROOT / "problems" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"<!-- figure: ([A-Za-z0-9_.]+)( range| met)? -->(.*?)<!-- /figure -->")
ROW = re.compile(r"^\| `([A-Za-z0-9_.]+)` \| ([^|]+) \| ([^|]*) \| ([^|]+) \| (\d+) \| ([^|]*) \|")


@dataclass(frozen=True)
class Figure:
    """One documented figure.

    Parameters
    ----------
    key : str
        Its name in docs/figures.md and in the docs' blocks (``group.name``).
    unit : str
        Unit of the value (``s``, ``us``, ``x`` for a ratio).
    digits : int
        Decimals written.
    what : str
        What is measured.
    target : str
        Issue 43's target for it (``"<= 5"``), or ``""``.
    """

    key: str
    unit: str
    digits: int
    what: str
    target: str = ""

    def __post_init__(self):
        if not re.fullmatch(r"[a-z]+\.[a-z0-9_]+", self.key):
            raise ValueError(f"Figure.key = {self.key!r}: must be 'group.name' in lower case")
        if self.digits not in range(5):
            raise ValueError(f"Figure.digits = {self.digits}: must be in 0 ... 4")

    @property
    def group(self) -> str:
        return self.key.split(".", 1)[0]

    def fmt(self, v: float) -> str:
        return f"{v:.{self.digits}f}"


#: positions per fsolve call (about 1-3 ms a call)
FSOLVE_COLUMNS = 25
CASE_NOTE = "crowned misaligned spur 20/40 of bench_compiled.py"
#: the scenes of problems/ timed by the ``scenes`` group: every one but the FE studies (CalculiX runs of minutes)
SCENES = tuple(sorted(p.stem for p in (ROOT / "problems").glob("*.toml")
                      if re.search(r'^study\s*=\s*"fea"', p.read_text(), re.M) is None
                      and p.stem not in ("tca_spur_crowned", "crowning_spur")))  # those two: the ``run`` group
FIGURES = [
    Figure("tca.fsolve_us", "us", 1, f"scipy fsolve per column (FD Jacobian, default xtol), 25 positions of pair 0 over a cycle, best of 10 calls (short calls: a loaded machine preempts them less), {CASE_NOTE}"),
    Figure("tca.sweep_64x3_us", "us", 2, "TCA.sweep 64 positions x 3 pairs (192 columns), default jit='auto', warm cache: "
           "wall time per position-pair, best of 5 calls", "<= 5"),
    Figure("tca.sweep_64x3_vs_fsolve", "x", 1, "fsolve per column / the 64 x 3 sweep's time per column, same repeat", ">= 6"),
    Figure("tca.sweep_64x3_interpreted_us", "us", 1, "the same sweep with jit=False (interpreted)"),
    Figure("tca.sweep_81x5_us", "us", 2, "TCA.sweep 81 x 5 (405 columns: the tca study's sweep), default, warm"),
    Figure("tca.sweep_81x5_vs_fsolve", "x", 1, "fsolve / the 81 x 5 sweep, per column, same repeat"),
    Figure("tca.sweep_2048x3_us", "us", 2, "TCA.sweep 2048 x 3 (6144 columns), default (threads by the idle-core rule), warm"),
    Figure("tca.sweep_2048x3_vs_fsolve", "x", 1, "fsolve / the 2048 x 3 sweep, per column, same repeat"),
    Figure("ltca.conjugate_s", "s", 3, "loaded TCA, one torque (200 N m) x 64 positions, 21 slices, warm: spur 20/40 conjugate "
           "(bench_ltca.py 'one torque, one cycle')", "<= 0.1"),
    Figure("ltca.crowned_s", "s", 3, "the same, spur crowned, 3' crossing", "<= 0.1"),
    Figure("ltca.helical_s", "s", 3, "the same, helical 21/53 crowned, 300 N m", "<= 0.1"),
    *(Figure(f"ltca.{k}_cpu_s", "s", 3, f"ltca.{k}_s as the process's CPU time (all threads; bench_ltca.py 'cpu')")
      for k in ("conjugate", "crowned", "helical")),
    Figure("loaded.warm_s", "s", 1, "microgeometry_loaded optimisation, warm cache: the whole process's wall time "
           "(scene read, study built, LoadedMicroOptimizer.solve)", "<= 8"),
    Figure("loaded.warm_cpu_s", "s", 1, "the same, CPU time (user + system, children included)"),
    Figure("loaded.cold_s", "s", 1, "the same, cold (an empty GEAROPT_CACHE): the process's wall time", "<= 20"),
    Figure("loaded.cold_cpu_s", "s", 1, "the same cold process, CPU time"),
    Figure("loaded.iterations", "", 0, "IPOPT iterations of the warm run (all rounds)"),
    Figure("run.demo_s", "s", 2, "`gearopt run problems/tca_spur_crowned.toml` (make demo), warm: the process's wall time", "<= 1.5"),
    Figure("run.demo_cpu_s", "s", 2, "the same, CPU time (user + system, children included)"),
    Figure("run.crowning_s", "s", 2, "`gearopt run problems/crowning_spur.toml`, warm: the process's wall time", "<= 6"),
    Figure("run.crowning_cpu_s", "s", 2, "the same, CPU time"),
    Figure("rating.rate_ms", "ms", 3, "one ISO 6336 `rate()` call (the TR example 1), median of 200 (bench_rating.py rate_time)"),
    Figure("rating.study_run_s", "s", 2, "the rating study's run() on problems/rating_spur.toml (loaded TCA of the pair and the "
           "reference pair at every torque; bench_rating.py study_times)"),
    *(Figure(f"scenes.{k}_s", "s", 1, f"`gearopt run problems/{k}.toml`, warm: the process's wall time")
      for k in SCENES),
]
BY_KEY = {f.key: f for f in FIGURES}
#: repeats per group by default (the loaded optimiser's cold run is the expensive one)
REPEATS = {"tca": 7, "ltca": 3, "loaded": 3, "run": 5, "rating": 3, "scenes": 2}
#: the command of a group's figures (its benchmark's functions: the module docstring)
COMMANDS = {g: f"python benchmarks/figures.py --only {g}" for g in REPEATS}


def _import(name: str):
    sys.path.insert(0, str(HERE))
    try:
        return __import__(name)
    finally:
        sys.path.remove(str(HERE))


def progress(msg: str, t0: list[float]) -> None:
    print(f"[{time.perf_counter() - t0[0]:6.0f} s, load {os.getloadavg()[0]:.1f}] {msg}", file=sys.stderr, flush=True)


def measure_tca(repeat: int, log) -> list[dict]:
    """bench_compiled.py's sweeps, warm (the user's cache), ``repeat`` times."""
    import numpy as np

    bc = _import("bench_compiled")
    ns: dict = {}
    exec(bc.CASE, ns)  # noqa: S102 - the benchmark's case text
    from gearopt import compiled
    from gearopt.meshing.tca import TCA

    pair, mis = ns["pair"], ns["mis"]
    phi = {n: np.linspace(-math.pi / 20, math.pi / 20, n) for n in (64, 81, 2048)}
    sweeps = {"64x3": (phi[64], (-1, 0, 1)), "81x5": (phi[81], (-2, -1, 0, 1, 2)), "2048x3": (phi[2048], (-1, 0, 1))}
    tca, tca_i = TCA(pair), TCA(pair, jit=False)
    # warm: every map size called often enough to have its own library, and the background compiles done
    for _ in range(max(1, getattr(compiled, "MAP_LIBRARY_CALLS", 1))):
        for p, pairs in sweeps.values():
            tca.sweep(p, mis=mis, pairs=pairs)
    compiled.wait_for_background()
    run_fsolve = bc.fsolve_columns(tca, mis, FSOLVE_COLUMNS)
    out = []
    for i in range(repeat):
        r = {"tca.fsolve_us": bc.best(run_fsolve, 10) / FSOLVE_COLUMNS * 1e6}
        for name, (p, pairs) in sweeps.items():
            us = bc.best(lambda p=p, pairs=pairs: tca.sweep(p, mis=mis, pairs=pairs)) / (p.size * len(pairs)) * 1e6
            r[f"tca.sweep_{name}_us"] = us
            r[f"tca.sweep_{name}_vs_fsolve"] = r["tca.fsolve_us"] / us
        p, pairs = sweeps["64x3"]
        r["tca.sweep_64x3_interpreted_us"] = bc.best(lambda: tca_i.sweep(p, mis=mis, pairs=pairs)) / 192 * 1e6
        out.append(r)
        log(f"tca repeat {i + 1}/{repeat}: 64x3 {r['tca.sweep_64x3_us']:.2f} us, fsolve {r['tca.fsolve_us']:.1f} us")
    return out


def measure_ltca(repeat: int, log) -> list[dict]:
    """bench_ltca.py's ``measure`` (best of 5 within each repeat)."""
    bl = _import("bench_ltca")
    names = {"spur 20/40 conjugate": "conjugate", "spur crowned, 3' crossing": "crowned", "helical 21/53 crowned": "helical"}
    out = []
    for i in range(repeat):
        m = bl.measure(5)
        out.append({f"ltca.{names[k]}_s": v["total"] for k, v in m.items() if k in names})
        out[-1].update({f"ltca.{names[k]}_cpu_s": v["cpu"] for k, v in m.items() if k in names})
        log(f"ltca repeat {i + 1}/{repeat}: " + ", ".join(f"{k} {v:.3f} s" for k, v in out[-1].items()))
    return out


def measure_loaded(repeat: int, log) -> list[dict]:
    """bench_loaded_synthesis.py's ``scene_run``: a cold process, then a warm one, ``repeat`` times."""
    bls = _import("bench_loaded_synthesis")
    out = []
    for i in range(repeat):
        cache = Path(tempfile.mkdtemp(prefix="gearopt-figures-loaded-"))
        try:
            cold = bls.scene_run(ROOT, "microgeometry_loaded", cache)
            bls.settle(cache)
            warm = bls.scene_run(ROOT, "microgeometry_loaded", cache)
        finally:
            shutil.rmtree(cache, ignore_errors=True)
        out.append({"loaded.warm_s": warm["process"], "loaded.warm_cpu_s": warm["cpu"], "loaded.cold_s": cold["process"],
                    "loaded.cold_cpu_s": cold["cpu"], "loaded.iterations": warm["iterations"]})
        log(f"loaded repeat {i + 1}/{repeat}: cold {cold['process']:.1f} s, warm {warm['process']:.1f} s")
    return out


def measure_rating(repeat: int, log) -> list[dict]:
    """bench_rating.py's ``rate_time`` and ``study_times`` (a new study each repeat; its loaded TCA warm after the
    first, as the disk cache is)."""
    brt = _import("bench_rating")
    brt.study_times()  # the warm-up
    out = []
    for i in range(repeat):
        out.append({"rating.rate_ms": brt.rate_time() * 1e3, "rating.study_run_s": brt.study_times()["run_s"]})
        log(f"rating {i + 1}/{repeat}: rate() {out[-1]['rating.rate_ms']:.2f} ms, run() {out[-1]['rating.study_run_s']:.2f} s")
    return out


def runs_of(group: str, scenes: dict[str, str], repeat: int, log, cpu: bool) -> list[dict]:
    """bench_run.py's ``run_once`` on each scene (``{name: scene}``), a warm-up run first."""
    br = _import("bench_run")
    work = Path(tempfile.mkdtemp(prefix="gearopt-figures-run-"))
    out = [{} for _ in range(repeat)]
    try:
        for name, scene in scenes.items():
            br.run_once(ROOT, scene, work / scene)  # the warm-up
            for i in range(repeat):
                t = br.run_once(ROOT, scene, work / scene)
                out[i][f"{group}.{name}_s"] = t["wall"]["wall"]
                if cpu:
                    out[i][f"{group}.{name}_cpu_s"] = t["cpu"]["wall"]
                log(f"{group} {name} {i + 1}/{repeat}: {t['wall']['wall']:.2f} s")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return out


def measure_run(repeat: int, log) -> list[dict]:
    """``gearopt run`` of the demo and of the crowning scene (issue 43's targets), wall and CPU."""
    return runs_of("run", {"demo": "tca_spur_crowned", "crowning": "crowning_spur"}, repeat, log, cpu=True)


def measure_scenes(repeat: int, log) -> list[dict]:
    """``gearopt run`` of every scene but the FE ones (:data:`SCENES`), whose run times problems/README.md states."""
    names = [f.key.split(".")[1][:-2] for f in FIGURES if f.group == "scenes"]
    return runs_of("scenes", {n: n for n in names}, repeat, log, cpu=False)


MEASURE = {"tca": measure_tca, "ltca": measure_ltca, "loaded": measure_loaded, "run": measure_run,
           "rating": measure_rating, "scenes": measure_scenes}


def machine() -> str:
    """CPU model, cores, Python, CasADi, commit (with ``+`` if the tree has changes)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import casadi

    def git(*a):
        r = subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True)
        return r.stdout.strip() if r.returncode == 0 else "?"

    dirty = "+" if git("status", "--porcelain", "--untracked-files=no") else ""
    return (f"{cpu}, {len(os.sched_getaffinity(0))} cores; Python {platform.python_version()}, casadi {casadi.__version__}; "
            f"commit {git('rev-parse', '--short', 'HEAD')}{dirty}")


def parse(text: str) -> dict[str, dict]:
    """docs/figures.md's rows: ``{key: {"value": str, "min": float, "max": float, "repeats": int}}``."""
    out = {}
    for line in text.splitlines():
        m = ROW.match(line)
        if m:
            lo, hi = (float(x) for x in m.group(4).strip().split(" - "))
            out[m.group(1)] = {"value": m.group(2).strip(), "unit": m.group(3).strip(), "min": lo, "max": hi,
                               "repeats": int(m.group(5)), "status": m.group(6).strip().partition(": ")[2]}
    return out


def summarise(runs: list[dict]) -> dict[str, tuple[float, float, float, int]]:
    """``{key: (median, min, max, repeats)}`` over the repeats."""
    keys = {k for r in runs for k in r}
    return {k: (statistics.median(v), min(v), max(v), len(v)) for k in keys for v in [[r[k] for r in runs if k in r]]}


def met(f: Figure, v: float) -> str:
    if not f.target:
        return ""
    op, lim = f.target.split()
    ok = v <= float(lim) if op == "<=" else v >= float(lim)
    return f"{f.target}: {'met' if ok else 'not met'}"


def write(stats: dict, old: dict, header: str) -> str:
    """docs/figures.md: the new figures, the old rows of groups not measured now."""
    lines = ["# Figures", "", "Generated by `python benchmarks/figures.py` (`make figures`): do not edit by hand; the docs quote",
             "these values through marked blocks that the same command rewrites (tests/test_figures.py checks them).",
             "Value: the median over the repeats; spread: the range (min - max) over them, the figure's stated noise",
             "(`python benchmarks/figures.py --check` measures again and says which figures are outside it).", "", header, "",
             "| key | value | unit | spread | repeats | target | what | command |", "|---|---|---|---|---|---|---|---|"]
    for f in FIGURES:
        if f.key in stats:
            v, lo, hi, n = stats[f.key]
            lines.append(f"| `{f.key}` | {f.fmt(v)} | {f.unit} | {f.fmt(lo)} - {f.fmt(hi)} | {n} | {met(f, v)} | {f.what} "
                         f"| `{COMMANDS[f.group]}` |")
        elif f.key in old:
            o = old[f.key]
            lines.append(f"| `{f.key}` | {o['value']} | {f.unit} | {f.fmt(o['min'])} - {f.fmt(o['max'])} | {o['repeats']} "
                         f"| {met(f, float(o['value']))} | {f.what} | `{COMMANDS[f.group]}` |")
    return "\n".join(lines) + "\n"


def rewrite_blocks(table: dict[str, dict]) -> list[str]:
    """Every marked block of README.md and docs/*.md set to its figure; the files changed."""
    changed = []

    def sub(m):
        key, rng = m.group(1), m.group(2)
        if key not in table:
            raise SystemExit(f"figures: a block names {key!r}, which docs/figures.md does not have")
        t = table[key]
        f = BY_KEY[key]
        if rng == " met":
            if not t["status"]:
                raise SystemExit(f"figures: a 'met' block names {key!r}, which has no target")
            val = t["status"]
        else:
            val = t["value"] + (f" ({f.fmt(t['min'])}-{f.fmt(t['max'])})" if rng else "")
        return f"<!-- figure: {key}{rng or ''} -->{val}<!-- /figure -->"

    for p in DOCS:
        s = p.read_text()
        n = BLOCK.sub(sub, s)
        if n != s:
            p.write_text(n)
            changed.append(str(p.relative_to(ROOT)))
    return changed


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="measure and compare with docs/figures.md; write nothing")
    ap.add_argument("--blocks", action="store_true", help="only rewrite the docs' blocks from docs/figures.md")
    ap.add_argument("--only", default=",".join(MEASURE), help=f"comma-separated groups (default: {','.join(MEASURE)})")
    ap.add_argument("--repeat", type=int, default=None, help="repeats per group (default: " +
                    ", ".join(f"{k} {v}" for k, v in REPEATS.items()) + ")")
    a = ap.parse_args(argv)
    groups = [g.strip() for g in a.only.split(",") if g.strip()]
    bad = [g for g in groups if g not in MEASURE]
    if bad:
        ap.error(f"--only: unknown group(s) {bad}; known: {', '.join(MEASURE)}")
    if a.repeat is not None and a.repeat < 1:
        ap.error(f"--repeat = {a.repeat}: must be >= 1")
    if a.blocks:
        print("blocks rewritten in:", ", ".join(rewrite_blocks(parse(OUT.read_text()))) or "none")
        return 0
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.path.insert(0, str(ROOT))
    old = parse(OUT.read_text()) if OUT.exists() else {}
    t0 = [time.perf_counter()]
    c0 = time.process_time()
    where = machine()  # the commit measured: at the start
    runs: list[dict] = []
    notes = {}
    for g in groups:
        n = a.repeat or REPEATS[g]
        progress(f"{g}: {n} repeats ...", t0)
        start, tg, load0 = _dt.datetime.now(_dt.timezone.utc), time.perf_counter(), os.getloadavg()[0]
        runs.extend(MEASURE[g](n, lambda msg: progress(msg, t0)))
        notes[g] = (f"- `{g}`: {start:%Y-%m-%d %H:%M} UTC, {n} repeats, {time.perf_counter() - tg:.0f} s; load average "
                    f"{load0:.2f} at its start, {os.getloadavg()[0]:.2f} at its end")
    stats = summarise(runs)
    wall = time.perf_counter() - t0[0]
    if OUT.exists():  # the groups not measured now keep their lines
        for m in re.finditer(r"^- `([a-z]+)`: .*$", OUT.read_text(), re.M):
            notes.setdefault(m.group(1), m.group(0))
    header = f"Machine: {where}.\n\n" + "\n".join(notes[g] for g in MEASURE if g in notes)
    if a.check:
        outside = 0
        print(f"{header}\n\n| key | documented (spread) | now (spread) | |\n|---|---|---|---|")
        for f in FIGURES:
            if f.key not in stats or f.key not in old:
                continue
            v, lo, hi, _ = stats[f.key]
            o = old[f.key]
            # the ranges overlap at the digits written (the documented range is rounded to them)
            ok = float(f.fmt(lo)) <= o["max"] and float(f.fmt(hi)) >= o["min"]
            outside += not ok
            print(f"| {f.key} | {o['value']} ({f.fmt(o['min'])}-{f.fmt(o['max'])}) {f.unit} | {f.fmt(v)} ({f.fmt(lo)}-{f.fmt(hi)}) "
                  f"{f.unit} | {'within' if ok else 'OUTSIDE'} |")
        print(f"\n{outside} of the figures outside their documented noise")
        return 1 if outside else 0
    OUT.write_text(write(stats, old, header))
    changed = rewrite_blocks(parse(OUT.read_text()))
    print(OUT.read_text())
    print(f"wrote {OUT.relative_to(ROOT)}; blocks rewritten in: {', '.join(changed) or 'none'}; "
          f"{wall:.0f} s wall, {time.process_time() - c0:.0f} s CPU of this process", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
