"""The crowning NLP through the compiled-function cache (issue 15: "the NLP builders reuse the
same cache"): problems/crowning_spur.toml's CrowningOptimizer built and solved interpreted
(default), with jit=True on a cold cache (code generation + compilation), and with jit=True in a
new process whose cache is warm; then the same three for the local synthesis NLP
(``local_synthesis(..., jit=...)``, the spur drive of tests/test_synthesis.py).

    python benchmarks/bench_nlp_cache.py     # about 2 minutes

Prints a markdown table: build s, IPOPT solve s, iterations, max |x - x_interpreted|.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def one(jit: bool) -> dict:
    from gearopt.io.scene import load_scene
    opt = load_scene(ROOT / "problems" / "crowning_spur.toml").build().optimizer
    opt.jit = jit
    t0 = time.perf_counter()
    opt.build()
    build = time.perf_counter() - t0
    args = dict(x0=opt._x0, lbx=opt._lbx, ubx=opt._ubx, lbg=opt._lbg, ubg=opt._ubg)
    t0 = time.perf_counter()
    r = opt._solver(**args)
    solve = time.perf_counter() - t0
    return {"build": build, "solve": solve, "iter": opt._solver.stats()["iter_count"],
            "x": np.array(r["x"]).ravel().tolist()}


def local(jit: bool) -> dict:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_synthesis import _drive, _local_target

    from gearopt.synthesis.local import local_synthesis
    pair = _drive("spur")
    t0 = time.perf_counter()
    d = local_synthesis(pair, _local_target(pair), jit=jit)
    return {"total": time.perf_counter() - t0, "x": [d.settings["a_c"], d.settings["a_pl"]]}


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        print(json.dumps(one(sys.argv[2] == "1")))
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--local":
        print(json.dumps(local(sys.argv[2] == "1")))
        return
    cache = tempfile.mkdtemp(prefix="gearopt-nlp-cache-")
    env = dict(os.environ, GEAROPT_CACHE_DIR=cache)

    def run(jit, mode="--child"):
        out = subprocess.run([sys.executable, __file__, mode, "1" if jit else "0"], env=env, capture_output=True,
                             text=True, check=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    rows = [("interpreted (default)", run(False)), ("jit=True, cold cache (generate + cc -O2)", run(True)),
            ("jit=True, new process, warm cache", run(True))]
    x0 = np.array(rows[0][1]["x"])
    print("| crowning NLP (problems/crowning_spur.toml) | build s | IPOPT solve s | iterations | max abs dx vs interpreted |")
    print("|---|---|---|---|---|")
    for name, r in rows:
        print(f"| {name} | {r['build']:.2f} | {r['solve']:.3f} | {r['iter']} | {np.abs(np.array(r['x']) - x0).max():.1e} |")
    rows = [("interpreted (default)", run(False, "--local")), ("jit=True, cold cache", run(True, "--local")),
            ("jit=True, new process, warm cache", run(True, "--local"))]
    x0 = np.array(rows[0][1]["x"])
    print()
    print("| local synthesis NLP (spur drive of tests/test_synthesis.py) | build + solve s | max rel. d(a_c, a_pl) |")
    print("|---|---|---|")
    for name, r in rows:
        print(f"| {name} | {r['total']:.2f} | {np.abs(np.array(r['x']) / x0 - 1).max():.1e} |")


if __name__ == "__main__":
    main()
