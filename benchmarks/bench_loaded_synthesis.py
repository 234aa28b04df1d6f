"""Micro-geometry optimisation under load (docs/loaded_synthesis.md) against a grid search of the
kind commercial tools run, in one run, on the same objective.

The drive and duty cycle of problems/optimize_microgeometry.py: 20/40 spur, 4 free pinion amounts
(C_alpha, C_beta, C_alpha_a, C_alpha_f, 0 ... 40 um), 100 and 250 N m x aligned and 2 arcmin crossing,
no edge loading. Both are scored on the optimiser's final grid of positions by the exact loaded TCA,
with the same merit: the weighted loaded-TE peak-to-peak plus the exact penalty of edge loading
(`LoadedMicroOptimizer._merit`, the weight the optimiser ended with).

    python benchmarks/bench_loaded_synthesis.py              # grid of 5^4 = 625 designs, about 6 minutes
    python benchmarks/bench_loaded_synthesis.py --levels 3   # 81 designs, about 1 minute
    python benchmarks/bench_loaded_synthesis.py --duty target   # the issue's target, about 10 minutes
    python benchmarks/bench_loaded_synthesis.py --search de     # scipy's differential evolution instead

``--search de``: scipy.optimize.differential_evolution on the same merit (population 15 x 4, seed 0,
no gradient polish, ``--de-maxiter`` generations: 600 designs with the default 9, the grid's budget).

``--duty target``: the issue's target duty cycle on the same drive and free amounts: 100, 200, 300
N m x 5 misalignment cases (aligned, crossing +-2', intersecting +-2'), 12 positions (24 to verify).
The grid search, like the optimiser, solves one case of each mirror-image pair (the same merit at
every design of this grid, docs/loaded_synthesis.md section 5): 3 loaded-TCA evaluations per design.

Prints a markdown table: objective reached, edge load, loaded-TCA evaluations, wall time.

``--scene NAME``: instead, the time of a scene's optimisation (issue 43: ``microgeometry_loaded``
<= 8 s warm, <= 20 s cold), each run one fresh process that reads the scene, builds its study
(``build``) and calls ``LoadedMicroOptimizer.solve`` (``solve``); wall and CPU time (user + system,
less sensitive to the load of the machine), the whole process's wall time (``process``: interpreter
start, imports and exit too, so a wait at exit for background compiles shows), IPOPT iterations,
trust-region rounds and the optimum. Each process first does what ``gearopt run`` does at its start,
where the tree has it: ``gearopt.cli.exit_without_collecting`` (no final garbage collections at exit:
60 ms CPU of a warm run's exit) and ``gearopt.cli.limit_blas_threads`` (one OpenBLAS thread).
The first run of each tree is cold (a new, empty ``GEAROPT_CACHE``: every compiled library built),
the ``--repeat`` runs after it warm (the same cache). With ``--base REV`` the revision is exported
(``git archive``) to a temporary folder and its runs alternate with the working tree's; the optimum
of each is compared with the base's.

    python benchmarks/bench_loaded_synthesis.py --scene microgeometry_loaded --base 32efd09
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


SCENE_DRIVER = r"""
import json, sys, time
t0, c0 = time.perf_counter(), time.process_time()
import gearopt.cli as cli
for start in ("exit_without_collecting", "limit_blas_threads"):  # what `gearopt run` does at its start
    if hasattr(cli, start):  # (an older tree: what it has)
        getattr(cli, start)()
from gearopt.io.scene import load_scene
opt = load_scene(sys.argv[1]).build().optimizer
t1, c1 = time.perf_counter(), time.process_time()
d = opt.solve()
t2, c2 = time.perf_counter(), time.process_time()
print("BENCH_SCENE " + json.dumps({
    "build": t1 - t0, "solve": t2 - t1, "build_cpu": c1 - c0, "solve_cpu": c2 - c1, "iterations": d.iterations,
    "rounds": len(d.rounds), "round_iterations": [r["iterations"] for r in d.rounds],
    "ipopt": sum(r["nlp_s"] for r in d.rounds), "theta_um": [v * 1e3 for v in d.theta.values()],
    "objective": d.after.objective, "predicted": d.predicted["objective"], "positions": int(d.phi1.size)}))
"""


def scene_run(tree: Path, scene: str, cache: Path) -> dict:
    """One fresh process of :data:`SCENE_DRIVER` on ``tree``'s package and ``problems/<scene>.toml``, with
    the disk caches in ``cache``; its numbers, with the process's CPU time (``cpu``, children included)."""
    env = dict(os.environ, PYTHONPATH=str(tree), GEAROPT_CACHE=str(cache), MPLBACKEND="Agg")
    env.pop("GEAROPT_CACHE_DIR", None)
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", SCENE_DRIVER, f"problems/{scene}.toml"], cwd=tree, env=env,
                       capture_output=True, text=True)
    wall = time.perf_counter() - t
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    line = [s for s in p.stdout.splitlines() if s.startswith("BENCH_SCENE ")]
    if p.returncode or not line:
        raise SystemExit(f"bench_loaded_synthesis: {scene} in {tree} failed (rc {p.returncode}):\n{p.stderr[-3000:]}")
    out = json.loads(line[-1].split(" ", 1)[1])
    out.update(process=wall, cpu=(r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime))
    return out


def settle(cache: Path, timeout: float = 900.0) -> None:
    """Wait until no compile works in ``cache`` (a cold process may end before the background compiles it
    started, which go on detached, gearopt.compiled): the next run then finds every library, as a user's
    next run would once they are done."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and any((cache / "compiled").glob(".build-*")):
        time.sleep(0.2)


def scene_main(scene: str, base: str | None, repeat: int) -> int:
    """``--scene``: cold and warm optimisation times of ``scene`` here (and at ``base``), module docstring."""
    work = Path(tempfile.mkdtemp(prefix="gearopt-bench-loaded-"))
    trees = {"here": ROOT}
    try:
        if base:
            bt = work / "base-tree"
            bt.mkdir()
            arc = subprocess.run(["git", "archive", base], cwd=ROOT, capture_output=True)
            if arc.returncode:
                print(f"bench_loaded_synthesis: git archive {base!r} failed: {arc.stderr.decode().strip()}", file=sys.stderr)
                return 2
            subprocess.run(["tar", "-x", "-C", str(bt)], input=arc.stdout, check=True)
            trees = {"base": bt, "here": ROOT}
        runs = {k: [] for k in trees}
        for i in range(repeat + 1):  # run 0: cold (an empty cache)
            for k, tree in trees.items():
                r = scene_run(tree, scene, work / f"cache-{k}")
                runs[k].append(r)
                settle(work / f"cache-{k}")
                print(f"  {k} run {i} ({'cold' if i == 0 else 'warm'}): build {r['build']:.2f} s, solve {r['solve']:.2f} s "
                      f"(CPU {r['build_cpu']:.2f} + {r['solve_cpu']:.2f} s), process {r['process']:.2f} s, {r['iterations']} IPOPT iterations "
                      f"{r['round_iterations']}, load {os.getloadavg()[0]:.2f}", file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    load = os.getloadavg()
    print(f"{scene}: optimisation (scene read, study built, LoadedMicroOptimizer.solve) in fresh processes; "
          f"warm: median of {repeat}; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs\n")
    print("| tree | cold build + solve [s] | cold process [s] | cold CPU [s] | warm build + solve [s] | warm process [s] "
          "| warm CPU [s] | warm solve [s] "
          "| IPOPT iterations (per round) | IPOPT [s] | NLP positions | objective [arcsec] | design [um] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    med = {}
    for k, rs in runs.items():
        c, w = rs[0], rs[1:]
        m = {q: statistics.median(r[q] for r in w) for q in ("build", "solve", "build_cpu", "solve_cpu", "ipopt", "process")}
        med[k] = m
        print(f"| {k} | {c['build'] + c['solve']:.1f} | {c['process']:.1f} | {c['build_cpu'] + c['solve_cpu']:.1f} "
              f"| {m['build'] + m['solve']:.1f} | {m['process']:.1f} | {m['build_cpu'] + m['solve_cpu']:.1f} | {m['solve']:.1f} | {w[-1]['iterations']} {w[-1]['round_iterations']} "
              f"| {m['ipopt']:.1f} | {w[-1]['positions']} | {w[-1]['objective']:.9f} "
              f"| {' / '.join(f'{v:.6f}' for v in w[-1]['theta_um'])} |")
    if base:
        h, b = runs["here"][-1], runs["base"][-1]
        for q, what in (("build", "warm build + solve, wall"), ("build_cpu", "warm build + solve, CPU")):
            s = "_cpu" if q.endswith("cpu") else ""
            print(f"\nhere/base, {what}: {(med['here'][q] + med['here']['solve' + s]) / (med['base'][q] + med['base']['solve' + s]):.2f}", end="")
        dth = max(abs(x - y) for x, y in zip(h["theta_um"], b["theta_um"]))
        print(f"\noptimum here - base: largest amount {dth:.3g} um, objective {h['objective'] - b['objective']:+.3g} arcsec, "
              f"NLP prediction {h['predicted'] - b['predicted']:+.3g} arcsec")
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, default=5, help="grid levels per amount (default 5)")
    ap.add_argument("--duty", choices=("script", "target"), default="script",
                    help="duty cycle: that of problems/optimize_microgeometry.py (default) or the issue's target")
    ap.add_argument("--search", choices=("grid", "de", "both"), default="grid",
                    help="derivative-free search: the grid (default), scipy's differential evolution, or both")
    ap.add_argument("--de-maxiter", type=int, default=9, help="differential evolution: generations (default 9)")
    ap.add_argument("--scene", default=None, metavar="NAME",
                    help="time the optimisation of problems/NAME.toml instead (cold and warm, module docstring)")
    ap.add_argument("--base", default=None, metavar="REV", help="--scene: also time the git revision REV")
    ap.add_argument("--repeat", type=int, default=2, help="--scene: warm runs per tree after the cold one (default 2)")
    args = ap.parse_args(argv)
    if args.scene is not None:
        if args.repeat < 1:
            ap.error(f"--repeat = {args.repeat}: must be >= 1")
        if not (ROOT / "problems" / f"{args.scene}.toml").is_file():
            ap.error(f"--scene {args.scene!r}: no problems/{args.scene}.toml")
        return scene_main(args.scene, args.base, args.repeat)

    from gearopt.meshing.misalignment import Misalignment
    from gearopt.studies.crowning import misalignment_cases
    from gearopt.synthesis.loaded import LoadedMicroOptimizer
    from gearopt.units import ARCMIN
    from test_loaded_synthesis import FREE, drive

    def make():
        if args.duty == "target":
            cases = list(misalignment_cases(crossing=2 * ARCMIN, intersecting=2 * ARCMIN).values())
            return LoadedMicroOptimizer(drive(), FREE, torques=[100.0, 200.0, 300.0], cases=cases,
                                        n_positions=12, n_verify=24, n_slices=11)
        return LoadedMicroOptimizer(drive(), FREE, torques=[100.0, 250.0],
                                    cases=[Misalignment(), Misalignment(crossing=2 * ARCMIN)],
                                    n_positions=16, n_verify=32, n_slices=11)

    opt = make()
    calls = {"n": 0}
    solve_one = opt.ltca.solve

    def counted(*a, **k):  # one loaded-TCA evaluation = one design x one case, every torque
        calls["n"] += 1
        return solve_one(*a, **k)

    opt.ltca.solve = counted
    t0 = time.perf_counter()
    d = opt.solve()
    t_opt = time.perf_counter() - t0
    n_opt = calls["n"]
    rho = d.rho  # the penalty weight the optimiser ended with
    phi = opt.phi1  # the optimiser's final grid
    best_opt = opt._merit(opt.check(np.array(list(d.theta.values())), phi), rho)

    red = opt._reduced()  # one case per mirror-image pair, as the optimiser's loop (the same merit)
    searches = []  # (name, merit, design, check, evaluations, time)

    def scored(th):
        chk = red.check(th, phi)
        return red._merit(chk, rho), chk

    if args.search in ("grid", "both"):
        calls["n"] = 0
        levels = np.linspace(0.0, 1.0, args.levels)
        t0 = time.perf_counter()
        best = (np.inf, None, None)
        for combo in itertools.product(levels, repeat=len(opt.free)):
            th = opt.lo + np.array(combo) * (opt.hi - opt.lo)
            m, chk = scored(th)
            if m < best[0]:
                best = (m, th, chk)
        searches.append((f"grid {args.levels}^{len(opt.free)}", *best, calls["n"], time.perf_counter() - t0))
    if args.search in ("de", "both"):
        from scipy.optimize import differential_evolution

        calls["n"] = 0
        seen = {}

        def merit(th):
            m, chk = scored(np.asarray(th, float))
            seen[tuple(th)] = (m, chk)
            return m

        t0 = time.perf_counter()
        res = differential_evolution(merit, list(zip(opt.lo, opt.hi)), maxiter=args.de_maxiter, popsize=15, seed=0,
                                     polish=False, init="latinhypercube")
        t_de = time.perf_counter() - t0
        m, chk = seen[tuple(res.x)]
        searches.append((f"differential evolution ({res.nit} generations, {res.nfev} designs)", m, np.asarray(res.x),
                         chk, calls["n"], t_de))
    chk_opt = red.check(np.array(list(d.theta.values())), phi)
    for name, m, th, _, _, _ in searches:
        if red is not opt:  # each search's best design scored on the full duty cycle too (the same merit)
            full = opt._merit(opt.check(th, phi), rho)
            if not np.isclose(full, m, rtol=1e-9, atol=1e-9):
                raise RuntimeError(f"{name}: the mirror-reduced merit {m} differs from the full one {full}")
    print(f"grid of positions: {phi.size} per cycle; cases x torques: {len(opt.cases)} x {opt.torques.size}; "
          f"penalty weight {rho:g}\n")
    print("| method | merit [arcsec] | weighted TE p-p [arcsec] | largest edge load [% of W] | design C_alpha / C_beta / "
          "C_alpha_a / C_alpha_f [um] | loaded-TCA evaluations (design x case) | wall time [s] |")
    print("|---|---|---|---|---|---|---|")
    for name, m, th, chk, n, t in [("trust-region NLP (AD)", best_opt, np.array(list(d.theta.values())), chk_opt,
                                    n_opt, t_opt)] + searches:
        print(f"| {name} | {m:.2f} | {chk.objective:.2f} | {100 * chk.edge_load.max():.3g} | "
              f"{' / '.join(f'{v * 1e3:.2f}' for v in th)} | {n} | {t:.1f} |")
    print()
    for name, m, _, _, n, t in searches:
        print(f"{name}: evaluations / NLP's = {n / max(n_opt, 1):.1f}; time / NLP's = {t / t_opt:.2f}; "
              f"merit - NLP's = {m - best_opt:+.2f} arcsec")
    return 0


if __name__ == "__main__":
    sys.exit(main())
