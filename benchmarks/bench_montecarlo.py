"""Monte Carlo at scale (issue 15, docs/scale.md section 3): 10,000 samples x one mesh cycle (64
positions x 3 pairs) of unloaded TCA of the montecarlo_spur scene (ISO 1328-1 class 6 deviations,
f_a 20 um, crossing and intersecting misalignment sd 1.5 arcmin), run serially (the compiled maps
over the process's threads, and with one thread), in 2 local processes and on a 2-worker Dask
LocalCluster (one thread per worker) in the same run; and the naive baseline, one
TCA.sweep per sample, timed on 40 samples.

    python benchmarks/bench_montecarlo.py [samples]

Prints a markdown table: wall time, us per position-pair, speed-up against serial, and whether the
figures are bit-identical to the serial run.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main():
    from gearopt.io.scene import load_scene
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.robust.study import MonteCarlo

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("samples", nargs="?", type=int, default=10_000, help="Monte Carlo samples (default 10000)")
    n = ap.parse_args().samples
    if n < 1:
        ap.error(f"samples = {n}: expected a whole number >= 1")
    scene = load_scene(ROOT / "problems" / "montecarlo_spur.toml")
    study = scene.build()
    kw = dict(seed=study.seed, misalignment={k[4:]: d for k, d in study.inputs.items()
                                             if k in ("mis.crossing", "mis.intersecting")},
              iso_grade=study.iso_grade, f_a=study.f_a, positions=study.positions)
    from gearopt import compiled

    rows, ref = [], None
    # serial: the compiled maps split over the process's threads (compiled.threads()); serial, 1 thread:
    # the baseline of the process executors, whose workers run one thread each
    for executor, workers, threads in (("serial", None, None), ("serial", None, 1), ("processes", 2, None),
                                       ("dask", 2, None)):
        mc = MonteCarlo(scene.pair, n, executor=executor, workers=workers, chunk=128, **kw)
        compiled.set_threads(threads)
        t0 = time.perf_counter()
        r = mc.run()
        wall = time.perf_counter() - t0
        compiled.set_threads(None)
        same = "-" if ref is None else str(all(np.array_equal(r.figures[k], ref.figures[k], equal_nan=True)
                                               for k in ref.figures) and np.array_equal(r.pattern_count,
                                                                                        ref.pattern_count))
        ref = ref or r
        cols = r.timing["n_columns"]
        label = f"{executor}" + (f" ({workers} workers, 1 thread each)" if workers else
                                 f" ({threads or compiled.threads()} thread{'s' if (threads or compiled.threads()) > 1 else ''})")
        rows.append((label, wall, r.timing["run_s"], r.timing["run_s"] / cols * 1e6, same))
        print(f"{executor}: {wall:.1f} s", file=sys.stderr, flush=True)
    # naive baseline: one TCA.sweep per sample (same TCA graph, interpreted per call as TCA.sweep decides)
    tca = mc._tca()
    vals = mc.values()
    m = 40
    t0 = time.perf_counter()
    phi = np.linspace(-np.pi / scene.pair.pinion.z, np.pi / scene.pair.pinion.z, study.positions, endpoint=False)
    for i in range(m):
        mis = Misalignment(crossing=vals["mis.crossing"][i], intersecting=vals["mis.intersecting"][i],
                           dE=vals["mis.dE"][i])
        tca.sweep(phi, mis=mis, pairs=(-1, 0, 1))
    naive = (time.perf_counter() - t0) / m
    serial = rows[1][2]  # one thread
    print(f"\n{n} samples x {study.positions} positions x 3 pairs = {n * study.positions * 3} position-pairs; "
          f"{os.cpu_count()} CPUs\n")
    print("| executor | wall s (incl. build) | run s | us per position-pair | speed-up vs serial, 1 thread | bit-identical to serial |")
    print("|---|---|---|---|---|---|")
    for name, wall, run, us, same in rows:
        print(f"| {name} | {wall:.1f} | {run:.1f} | {us:.1f} | {serial / run:.2f}x | {same} |")
    print(f"| one TCA.sweep per sample (40 samples) | - | {naive * n:.1f} (extrapolated) | "
          f"{naive / (study.positions * 3) * 1e6:.1f} | {serial / (naive * n):.2f}x | - |")


if __name__ == "__main__":
    main()
