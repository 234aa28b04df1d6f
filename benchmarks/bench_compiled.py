"""The compiled engine (gearopt.compiled): the sweeps of docs/scale.md section 2 and of docs/benchmarks.md
section 1 (its records), in one run (benchmarks/figures.py measures the current figures with its case).

    python benchmarks/bench_compiled.py          # about 2 minutes on 2 cores
    python benchmarks/bench_compiled.py --quick  # fewer positions and repeats, about 1 minute
    python benchmarks/bench_compiled.py --base-tree /tmp/base   # also the small sweep of another
                                                 # checkout (e.g. `git worktree add /tmp/base REV`)
    python benchmarks/bench_compiled.py --cpu    # CPU time of the process instead of wall time

Case: the crowned, misaligned spur pair of benchmarks/bench_tca.py (pinion z=20, m_n=3, b=20, a_c=0.002,
a_pl=0.0004; gear z=40; crossing 3', intersecting 2', dE=0.05 mm). Sweeps:

* **small**: one mesh cycle, 64 pinion angles x tooth pairs -1, 0, 1 (192 columns), what a user
  calls day to day;
* **tca study**: 81 angles x pairs -2 ... 2 (405 columns; the `tca` study's default is two such
  sweeps, 810 columns);
* **large**: 2048 angles x 3 pairs (6144 columns; ``--quick``: 512).

Rows: ``jit=False`` (interpreted: what ``jit="auto"`` ran below ``MIN_COLUMNS = 1024`` columns before
issue 43), the default ``jit="auto"`` with a warm disk cache (compiled whatever the size since issue
43), and for the large sweep the compiled sweep with the thread count of the old rule
(``min(cpus, columns // 512)`` threads whatever the load: ``set_threads(cpus)``), 1 thread, and the
default rule (threads only on idle cores, ``compiled.threads_for``).
"us/pos-pair": warm wall time of ``TCA.sweep`` (everything it does) per column, best of 5 calls (the
small sweep in a new process of this tree and of ``--base-tree``: best of ``NEW_PROCESS_SWEEPS`` = 300);
warm: the column's library in the cache and each sweep called often enough before that its map
sizes run their own compiled libraries (``compiled.ColumnMap``, ``MAP_LIBRARY_CALLS``).
fsolve: ``scipy.optimize.fsolve`` (finite-difference Jacobian, default xtol) on the same equations
(called through CasADi's buffer API) from the same first guesses, per column: 25 positions of pair 0 over
one cycle per call, best of 10 calls (longer calls are preempted more on a loaded machine: 100-200 positions,
best of 2, scattered 27-118 us per column at load 8 where these gave 29.6-32.8 us).

``--cpu``: every time is the process's CPU time (``time.process_time``) instead of the wall time: on
a loaded machine the wall time counts the waits for a core, the CPU time does not (it still grows
with the contention for caches); a sweep split over threads then shows the CPU time of all of them.

Noise: the whole set of timings is repeated (``--repeat``, default 3; interleaved, so a change of the
machine's load hits every row alike) and each figure is given as the median with the range over the
repeats; the ratios are taken within each repeat. The load average is printed with the tables.
The cache directory is a fresh temporary one: the cold rows include code generation and gcc.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

CASE = """
import math
from gearopt import ARCMIN, BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment
g1 = Gear(z=20, m_n=3.0, b=20.0, rack=BasicRack.iso53("A", a_c=0.002), a_pl=0.0004, name="pinion")
g2 = Gear(z=40, m_n=3.0, b=20.0, name="gear")
pair = GearPair(g1, g2)
mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
"""

CHILD = CASE + """
import json, sys, time
import numpy as np
from gearopt import compiled
N = int(sys.argv[1])
t0 = time.perf_counter()
tca = TCA(pair)
t1 = time.perf_counter()
sw = tca.sweep(np.linspace(-math.pi / 20, math.pi / 20, N), mis=mis)
t2 = time.perf_counter()
print(json.dumps({"build": t1 - t0, "first": t2 - t1, "counts": compiled.counts(),
                  "compiled": tca.branch.mapped(3 * N, extra=True).compiled}))
"""


SMALL = CASE + """
import json, sys, time
import numpy as np
tca = TCA(pair)
phi = np.linspace(-math.pi / 20, math.pi / 20, 64)
tca.sweep(phi, mis=mis)
time.sleep(3.0)  # a background compile of a cold cache (this tree) finishes; the old tree compiles nothing
tca = TCA(pair)
ts = []
clock = getattr(time, sys.argv[2])
for _ in range(5 * int(sys.argv[1])):
    t0 = clock()
    tca.sweep(phi, mis=mis)
    ts.append(clock() - t0)
import gearopt
print(json.dumps({"us": min(ts) / 192 * 1e6, "from": gearopt.__file__}))
"""


#: warm small sweeps timed in each new process (the best is its figure): a few hundred, so that a loaded
#: machine's scatter (+-30 % from one call to the next at load 15) does not decide a comparison of trees
NEW_PROCESS_SWEEPS = 300


def small_in(tree, repeat):
    """us per position-pair of the default small sweep (64 x 3, warm) run by the gearopt of ``tree``: the
    best of NEW_PROCESS_SWEEPS calls in a new process."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    # run from an empty folder: `python -c` puts the working directory first on sys.path
    out = subprocess.run([sys.executable, "-c", SMALL, str(NEW_PROCESS_SWEEPS // 5), CLOCK[0].__name__], env=env,
                         capture_output=True, text=True, timeout=600,
                         cwd=tempfile.gettempdir())
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-800:])
    res = json.loads(out.stdout.strip().splitlines()[-1])
    if not res["from"].startswith(os.path.abspath(tree)):
        raise RuntimeError(f"{tree}: gearopt was imported from {res['from']}")
    return res["us"]


CLOCK = [time.perf_counter]  # --cpu: time.process_time


def newton_steps(tca, W0, prm, abstol=1e-15, abstol_step=1e-9, max_iter=30):
    """Newton steps (Jacobian evaluations) per column from the first guesses ``W0`` under the rule of
    the sweep's compiled ``fast_newton`` (stop when max|F| <= abstol, or after a step with
    max|dw| <= abstol_step): the rootfinder reports no count, so it is replayed here in numpy with the
    TCA's residual and Jacobian Functions. max_iter + 1: not converged (NaN, off the surfaces)."""
    out = np.full(W0.shape[1], max_iter + 1)
    for j in range(W0.shape[1]):
        w, p = W0[:, j].copy(), prm[:, j]
        for k in range(max_iter):
            F = np.asarray(tca.residual(w, p)).ravel()
            if not np.all(np.isfinite(F)):
                break
            if np.max(np.abs(F)) <= abstol:
                out[j] = k
                break
            dw = np.linalg.solve(np.asarray(tca.jacobian(w, p)), F)
            w = w - dw
            if np.max(np.abs(dw)) <= abstol_step:
                out[j] = k + 1
                break
    return out


def sweep_guesses(tca, phi, mis, pairs):
    """(first guesses, parameter columns) of a sweep's first mapped solve (``Branch.solve``'s inputs)."""
    seen = {}
    solve = tca.branch.solve

    def spy(W0, prm, *a, **k):
        seen.setdefault("W0", W0.copy())
        seen.setdefault("prm", prm.copy())
        return solve(W0, prm, *a, **k)

    tca.branch.solve = spy
    try:
        tca.sweep(phi, mis=mis, pairs=pairs)
    finally:
        del tca.branch.solve
    return seen["W0"], seen["prm"]


def fsolve_columns(tca, mis, m: int):
    """A callable that solves ``m`` positions of tooth pair 0 (one cycle) with ``scipy.optimize.fsolve``
    (finite-difference Jacobian, default xtol) on ``tca``'s residual, from the sweep's own first guesses
    (the linear prediction around the anchor): fsolve's best case, the residual called through CasADi's
    buffer API (no numpy <-> DM conversion per call). Its time / ``m`` is "fsolve per column"."""
    from scipy.optimize import fsolve

    sub = np.linspace(-math.pi / 20, math.pi / 20, m)
    prm = tca.prm(sub, mis=mis)
    w_a = tca.solve_point(0.0, None, None, None, mis)
    W0 = tca.branch.predict(w_a, tca.prm([0.0], mis=mis)[:, 0], sub)
    buf, trig = tca.residual.buffer()
    x_in, p_in, f_out = np.zeros(W0.shape[0]), np.zeros(prm.shape[0]), np.zeros(W0.shape[0])
    buf.set_arg(0, memoryview(x_in))
    buf.set_arg(1, memoryview(p_in))
    buf.set_res(0, memoryview(f_out))

    def fun(w):
        x_in[:] = w
        trig()
        return f_out.copy()

    def run_fsolve():
        for i in range(m):
            p_in[:] = prm[:, i]
            fsolve(fun, W0[:, i])

    run_fsolve.buf = buf  # the buffer must outlive the calls
    return run_fsolve


def best(f, k=5):
    clock = CLOCK[0]
    ts = []
    for _ in range(k):
        t0 = clock()
        f()
        ts.append(clock() - t0)
    return min(ts)


def stat(v):
    """'median (min-max)' of the repeats."""
    v = np.asarray(v, float)
    if v.size == 1:
        return f"{v[0]:.2f}"
    return f"{np.median(v):.2f} ({v.min():.2f}-{v.max():.2f})"


def main(argv):
    quick = "--quick" in argv
    if "--cpu" in argv:
        CLOCK[0] = time.process_time
    repeat = 2 if quick else 3
    for a in argv:
        if a.startswith("--repeat="):
            repeat = max(1, int(a.split("=", 1)[1]))
    n_large = 512 if quick else 2048
    base_tree = next((a.split("=", 1)[1] for a in argv if a.startswith("--base-tree=")), None)
    if "--base-tree" in argv:
        base_tree = argv[argv.index("--base-tree") + 1]
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    cache = tempfile.mkdtemp(prefix="gearopt-bench-cache-")
    os.environ["GEAROPT_CACHE_DIR"] = cache
    ns: dict = {}
    exec(CASE, ns)  # noqa: S102 - the case text is shared with the child process
    from gearopt import compiled
    from gearopt.meshing.tca import TCA, Misalignment

    pair, mis = ns["pair"], ns["mis"]
    load0 = os.getloadavg()
    cpus = len(os.sched_getaffinity(0))
    sweeps = {"small": (np.linspace(-math.pi / 20, math.pi / 20, 64), (-1, 0, 1)),
              "tca study": (np.linspace(-math.pi / 20, math.pi / 20, 81), (-2, -1, 0, 1, 2)),
              "large": (np.linspace(-math.pi / 20, math.pi / 20, n_large), (-1, 0, 1))}

    # cold cache: the first small sweep under jit="auto" runs interpreted and compiles in the background
    tca_c = TCA(pair)  # the default: jit="auto"
    phi_s, pairs_s = sweeps["small"]
    t0 = time.perf_counter()
    tca_c.sweep(phi_s, mis=mis, pairs=pairs_s)
    t_first_small = time.perf_counter() - t0
    first_small_compiled = tca_c.branch.mapped(phi_s.size * 3, extra=True).compiled
    compiled.wait_for_background()
    t_background = time.perf_counter() - t0
    # cold cache, large sweep: compiled within the call (a fresh TCA of the same graphs finds the cache warm,
    # so this is timed in a child with its own empty cache)
    cold_env = dict(os.environ, GEAROPT_CACHE_DIR=tempfile.mkdtemp(prefix="gearopt-bench-cold-"))
    out = subprocess.run([sys.executable, "-c", CHILD, str(n_large)], env=cold_env, capture_output=True, text=True,
                         timeout=900)
    cold_large = json.loads(out.stdout.strip().splitlines()[-1]) if out.returncode == 0 else None

    tca_i = TCA(pair, jit=False)
    refs, errs, paths = {}, {}, {}
    for name, (phi, pairs) in sweeps.items():
        tca_i.sweep(phi, mis=mis, pairs=pairs)
        tca_c.sweep(phi, mis=mis, pairs=pairs)
        a, b = tca_i.sweep(phi, mis=mis, pairs=pairs), tca_c.sweep(phi, mis=mis, pairs=pairs)
        both = a.converged & b.converged
        refs[name] = (a, b)
        errs[name] = (float(np.max(np.abs(a.phi2[both] - b.phi2[both]))),
                      bool(np.array_equal(a.converged, b.converged)))
        paths[name] = tca_c.branch.mapped(phi.size * len(pairs), extra=True).compiled

    # warm: every sweep (and the large one on 1 thread too) called often enough that its map sizes have
    # their own compiled libraries (compiled.ColumnMap: from the MAP_LIBRARY_CALLS-th call of a size on,
    # in the background), and those compiles finished: what a repeated sweep runs
    for _ in range(getattr(compiled, "MAP_LIBRARY_CALLS", 0)):
        for name, (phi, pairs) in sweeps.items():
            tca_c.sweep(phi, mis=mis, pairs=pairs)
        compiled.set_threads(1)
        try:
            tca_c.sweep(sweeps["large"][0], mis=mis, pairs=sweeps["large"][1])
        finally:
            compiled.set_threads(None)
    compiled.wait_for_background()

    # Newton steps per column of the small sweep: from its first guesses, and from the linear
    # prediction around the anchor (what a coarse sweep started from before the Taylor guesses)
    W0s, prm_s = sweep_guesses(tca_c, phi_s, mis, pairs_s)
    w_an = tca_c.solve_point(0.0, None, None, None, mis)
    lin = tca_c.branch.predict(w_an, tca_c.prm([0.0], mis=mis)[:, 0], prm_s[tca_c._phi_row])
    steps = {"the sweep's first guesses": newton_steps(tca_c, W0s, prm_s),
             "linear prediction from the anchor": newton_steps(tca_c, lin, prm_s)}

    # fsolve per column on pair 0 (a subset), same equations and first guesses as the sweep's
    m = 25
    run_fsolve = fsolve_columns(tca_c, mis, m)

    rows = {}  # (sweep, row) -> list of us/pos-pair over the repeats
    fs = []
    trees = {"base": [], "here": []}

    def timed(key, f, cols):
        rows.setdefault(key, []).append(best(f) / cols * 1e6)

    k_old = min(cpus, (n_large * 3 if n_large * 3 < compiled.CHUNK else compiled.CHUNK) // compiled.MIN_PER_THREAD)
    for _ in range(repeat):
        fs.append(best(run_fsolve, 10) / m * 1e6)
        if base_tree:  # the same warm cache: this tree's libraries; the base tree reads what it can use
            trees["base"].append(small_in(base_tree, repeat))
            trees["here"].append(small_in(here, repeat))
        for name, (phi, pairs) in sweeps.items():
            cols = phi.size * len(pairs)
            timed((name, "interpreted"), lambda: tca_i.sweep(phi, mis=mis, pairs=pairs), cols)
            timed((name, "default"), lambda: tca_c.sweep(phi, mis=mis, pairs=pairs), cols)
        # the same small sweep with a new misalignment at every call: the anchor is solved each time
        # (the memo of section 1 never hits), as in a loop over designs or samples
        phi, pairs = sweeps["small"]
        step = iter(range(1, 10**6))
        timed(("small", "new misalignment"), lambda: tca_c.sweep(phi, mis=Misalignment(
            crossing=mis.crossing, intersecting=mis.intersecting, dE=mis.dE + 1e-7 * next(step)), pairs=pairs),
            phi.size * len(pairs))
        phi, pairs = sweeps["large"]
        cols = phi.size * len(pairs)
        for label, n in (("old thread rule", max(1, k_old)), ("1 thread", 1)):
            compiled.set_threads(n)
            try:
                timed(("large", label), lambda: tca_c.sweep(phi, mis=mis, pairs=pairs), cols)
            finally:
                compiled.set_threads(None)
    fs = np.array(fs)
    k_new = compiled.threads_for(compiled.CHUNK if n_large * 3 >= compiled.CHUNK else n_large * 3)

    out = subprocess.run([sys.executable, "-c", CHILD, str(64)], env=dict(os.environ), capture_output=True, text=True,
                         timeout=600)
    child = json.loads(out.stdout.strip().splitlines()[-1]) if out.returncode == 0 else None
    load1 = os.getloadavg()

    print(f"times: {'CPU time of the process (--cpu)' if CLOCK[0] is time.process_time else 'wall time'}")
    print(f"case: crowned misaligned spur 20/40; cache {cache}; {cpus} CPUs; repeats {repeat} "
          f"(median (min-max) over them); load average {load0[0]:.2f} at start, {load1[0]:.2f} at end")
    print(f"fsolve (FD Jacobian, default xtol), per column, {m} positions of pair 0: {stat(fs)} us")
    print()
    print("| sweep | columns | path | us per position-pair (warm) | vs fsolve, same run | max abs(dphi2) vs interpreted [rad] |")
    print("|---|---|---|---|---|---|")
    labels = {"interpreted": "`jit=False` (interpreted; `jit=\"auto\"` here before issue 43)",
              "default": "default `jit=\"auto\"`, warm cache",
              "new misalignment": "default, warm cache, a new misalignment at every call (anchor solved each time)",
              "old thread rule": f"compiled, {max(1, k_old)} threads (old rule: whatever the load)",
              "1 thread": "compiled, 1 thread (`set_threads(1)`)"}
    for (name, row), us in rows.items():
        phi, pairs = sweeps[name]
        cols = phi.size * len(pairs)
        us = np.array(us)
        path = ("compiled" if paths[name] else "interpreted") if row in ("default", "new misalignment") else \
            ("interpreted" if row == "interpreted" else "compiled")
        if row == "default" and paths[name] and name == "large":
            path += f", {k_new} thread{'s' if k_new > 1 else ''} (idle-core rule now)"
        err = f"{errs[name][0]:.1e}" if row != "interpreted" else "0"
        print(f"| {name} | {cols} | {labels[row]}: {path} | {stat(us)} | {stat(fs / us)}x | {err} |")
    if base_tree:
        print()
        print(f"| small sweep (64 x 3), default `jit=\"auto\"`, new process, warm cache, best of {NEW_PROCESS_SWEEPS} "
              "| us per position-pair | "
              "vs fsolve, same run |")
        print("|---|---|---|")
        for label, tree in (("before", base_tree), ("after", here)):
            v = np.array(trees["base" if label == "before" else "here"])
            print(f"| {label}: {tree} | {stat(v)} | {stat(fs / v)}x |")
    print()
    print("Newton steps per column, small sweep (64 x 3; the compiled fast_newton's rule replayed in numpy):")
    for label, v in steps.items():
        ok = v <= 30
        print(f"  {label}: mean {v[ok].mean():.2f} over the {ok.sum()} converging columns, "
              f"histogram {np.bincount(v[ok]).tolist()} (steps 0, 1, ...), {int((~ok).sum())} not converging")
    print(f"threads of the small sweep's map: {compiled.threads_for(phi_s.size * len(pairs_s))} "
          f"(below 2 x MIN_PER_THREAD = {2 * compiled.MIN_PER_THREAD} columns always 1)")
    print("same accepted points, compiled vs interpreted: " + ", ".join(f"{k} {v[1]}" for k, v in errs.items()))
    print(f"cold cache, small sweep (jit=\"auto\"): the first call {t_first_small:.3f} s "
          f"({'compiled' if first_small_compiled else 'interpreted'}; the library compiled in the background, "
          f"ready after {t_background:.2f} s)")
    if cold_large:
        print(f"cold cache, large sweep (new process): TCA build {cold_large['build']:.2f} s, first sweep "
              f"{cold_large['first']:.2f} s (code generation and gcc in the call; libraries built "
              f"{cold_large['counts']['built']})")
    if child:
        print(f"new process, warm cache, small sweep: TCA build {child['build']:.3f} s, first sweep "
              f"{child['first']:.3f} s ({'compiled' if child['compiled'] else 'interpreted'}; libraries compiled "
              f"{child['counts']['built']}, loaded {child['counts']['loaded']})")
    else:
        print("new process failed:", out.stderr[-500:])
    libs = sorted(p.name.split("-")[0] for p in Path(cache).glob("map*.so"))
    print("map libraries compiled (the loop over a size's columns in C):", ", ".join(libs) or "none")
    print("compiler:", compiled.compiler())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
