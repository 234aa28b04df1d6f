"""The compiled engine (gearopt.compiled): default TCA sweep vs the interpreted one vs scipy's fsolve,
cold and warm disk cache, a new process with a warm cache, in one run (docs/scale.md).

    python benchmarks/bench_compiled.py          # about 1 minute
    python benchmarks/bench_compiled.py --quick  # fewer positions

Case: the crowned, misaligned spur pair of benchmarks/bench_tca.py (pinion z=20, m_n=3, b=20, a_c=0.002,
a_pl=0.0004; gear z=40; crossing 3', intersecting 2', dE=0.05 mm), N pinion angles over one cycle,
tooth pairs -1, 0, 1 (3N columns; the default ``jit="auto"`` compiles sweeps of at least
``gearopt.compiled.MIN_COLUMNS`` columns). The cache directory is a fresh temporary one, so "cold"
includes code generation and gcc. "us/pos-pair" is the warm wall time of ``TCA.sweep`` (everything it
does: anchor solve, predictor, mapped solve, checks, continuation, contact ellipses) divided by the
columns, best of 5. fsolve: ``scipy.optimize.fsolve`` (finite-difference Jacobian, default xtol) on
the same equations (called through CasADi's buffer API) from the same first guesses, per column,
on 200 positions of pair 0 (one thread). The default sweep splits its compiled columns over
``gearopt.compiled.threads()`` threads (the CPUs of the process); the 1-thread row is the same
sweep with ``set_threads(1)``. The new-process row starts a Python process with the warm cache and
times its first sweep (after building the TCA).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time

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
print(json.dumps({"build": t1 - t0, "first": t2 - t1, "counts": compiled.counts()}))
"""


def best(f, k=5):
    ts = []
    for _ in range(k):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def main(argv):
    quick = "--quick" in argv
    N = 512 if quick else 2048
    cache = tempfile.mkdtemp(prefix="gearopt-bench-cache-")
    os.environ["GEAROPT_CACHE_DIR"] = cache
    ns: dict = {}
    exec(CASE, ns)  # noqa: S102 - the case text is shared with the child process
    from scipy.optimize import fsolve

    from gearopt import compiled
    from gearopt.meshing.tca import TCA

    pair, mis = ns["pair"], ns["mis"]
    phi = np.linspace(-math.pi / 20, math.pi / 20, N)
    cols = 3 * N
    rows = []

    tca_i = TCA(pair, jit=False)
    tca_i.sweep(phi, mis=mis)
    t_i = best(lambda: tca_i.sweep(phi, mis=mis))
    ref = tca_i.sweep(phi, mis=mis)
    rows.append(("TCA.sweep, interpreted (jit=False)", 0.0, t_i / cols * 1e6, 0.0))

    tca_c = TCA(pair)  # the default: jit="auto"
    t0 = time.perf_counter()
    tca_c.sweep(phi, mis=mis)
    t_cold = time.perf_counter() - t0
    t_c = best(lambda: tca_c.sweep(phi, mis=mis))
    sw = tca_c.sweep(phi, mis=mis)
    both = ref.converged & sw.converged
    err = float(np.max(np.abs(sw.phi2[both] - ref.phi2[both])))
    same = bool(np.array_equal(ref.converged, sw.converged))
    n_threads = compiled.threads()
    rows.append((f"TCA.sweep, default (compiled, {n_threads} threads)", t_cold, t_c / cols * 1e6, err))
    compiled.set_threads(1)
    t_1 = best(lambda: tca_c.sweep(phi, mis=mis))
    sw1 = tca_c.sweep(phi, mis=mis)
    compiled.set_threads(None)
    same1 = bool(np.array_equal(sw1.phi2, sw.phi2, equal_nan=True))
    err1 = float(np.max(np.abs(sw1.phi2[both] - ref.phi2[both])))
    rows.append(("TCA.sweep, compiled, 1 thread (GEAROPT_THREADS=1)", 0.0, t_1 / cols * 1e6, err1))

    # fsolve per column on pair 0 (a subset), same equations and first guesses as the sweep's
    m = 200
    sub = np.linspace(-math.pi / 20, math.pi / 20, m)
    prm = tca_c.prm(sub, mis=mis)
    w_a = tca_c.solve_point(0.0, None, None, None, mis)
    W0 = tca_c.branch.predict(w_a, tca_c.prm([0.0], mis=mis)[:, 0], sub)
    # the residual through CasADi's buffer API (no numpy <-> DM conversion per call: fsolve's best case)
    buf, trig = tca_c.residual.buffer()
    x_in, p_in, f_out = np.zeros(W0.shape[0]), np.zeros(prm.shape[0]), np.zeros(W0.shape[0])
    buf.set_arg(0, memoryview(x_in))
    buf.set_arg(1, memoryview(p_in))
    buf.set_res(0, memoryview(f_out))

    def fun(w):
        x_in[:] = w
        trig()
        return f_out.copy()

    def run_fsolve():
        out = []
        for i in range(m):
            p_in[:] = prm[:, i]
            out.append(fsolve(fun, W0[:, i]))
        return out

    t_fs = best(run_fsolve, 2) / m
    rows.append(("scipy fsolve (FD Jacobian), per column, pair 0", 0.0, t_fs * 1e6, float("nan")))

    out = subprocess.run([sys.executable, "-c", CHILD, str(N)], env=dict(os.environ), capture_output=True, text=True,
                         timeout=600)
    child = json.loads(out.stdout.strip().splitlines()[-1]) if out.returncode == 0 else None

    print(f"case: crowned misaligned spur 20/40, {N} positions x 3 pairs = {cols} columns; cache {cache}")
    print(f"| {'sweep':48s} | cold compile s | us/pos-pair | vs fsolve | max |dphi2| vs interpreted [rad] |")
    print(f"|{'-' * 50}|----------------|-------------|-----------|-------------------------------|")
    for name, tc, us, e in rows:
        print(f"| {name:48s} | {tc:14.2f} | {us:11.2f} | {t_fs * 1e6 / us:8.1f}x | {e:29.1e} |")
    print(f"same accepted points, compiled vs interpreted: {same}; 1 thread vs {n_threads}: bit-identical {same1}")
    if child:
        print(f"new process, warm cache: TCA build {child['build']:.3f} s, first sweep {child['first']:.3f} s "
              f"(libraries compiled {child['counts']['built']}, loaded {child['counts']['loaded']})")
    else:
        print("new process failed:", out.stderr[-500:])
    print("compiler:", compiled.compiler())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
