"""Loaded TCA (gearopt.ltca, analytical compliance): cost of one torque over one mesh cycle of 64
positions, its accuracy checks, and the CalculiX model's cost for the same positions, in one run.

    python benchmarks/bench_ltca.py                      # three drives + one CalculiX position (about 1 minute)
    python benchmarks/bench_ltca.py --quick              # without CalculiX
    python benchmarks/bench_ltca.py --quick --base REV   # the same timings of git revision REV in this run

Per drive (conjugate spur, crowned spur with 3 arcmin crossing, crowned helical; 21 slices, the
default): the build time, the first solve (the slices' mapped Functions are created on first use),
then warm (minimum of ``--reps`` repetitions on the same LTCA): the unloaded separations (slices)
and one torque (the contact QPs with the Hertz fixed point), their sum (the "one torque, one cycle"
figure; ``cpu``: the process's CPU time of it, all threads, less sensitive to other processes than
the wall time), the same sum at positions not solved before (shifted by a micro-radian each repetition:
nothing cached for them), the KKT error of the contact conditions and the zero-load error against
the unloaded TCA.

``--base REV`` checks REV out into a temporary git worktree and runs the same measurement with its
package in alternating subprocesses (``--rounds`` each, the minimum kept), so both see the same
load; it prints both times, their ratio and the largest differences of the results (loaded TE,
pair load shares, peak pressure, loads). The FE line times one position of the spur drive's
default CalculiX model and scales it to 64 positions; the ratio is FE / loaded TCA in this run.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def drives():
    from gearopt.gears import BasicRack, Gear, GearPair
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.units import ARCMIN

    A = BasicRack.iso53("A")
    return {
        "spur 20/40 conjugate": (GearPair(Gear(z=20, m_n=3.0, b=20.0, rack=A), Gear(z=40, m_n=3.0, b=20.0, rack=A)),
                                 Misalignment(), 200.0),
        "spur crowned, 3' crossing": (GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=0.0004, rack=BasicRack.iso53("A", a_c=0.002)),
                                               Gear(z=40, m_n=3.0, b=20.0, rack=A)), Misalignment(crossing=3 * ARCMIN), 200.0),
        "helical 21/53 crowned": (GearPair(Gear(z=21, m_n=2.5, b=30.0, beta=math.radians(18), a_pl=0.0002, rack=A),
                                           Gear(z=53, m_n=2.5, b=30.0, beta=math.radians(18), hand="left", rack=A)),
                                  Misalignment(), 300.0),
    }


def measure(reps: int) -> dict:
    """Time every drive with the package on ``sys.path``: {drive: {figures, results}}."""
    from gearopt.ltca.engine import LTCA
    from gearopt.meshing.tca import TCA

    out = {}
    for name, (pair, mis, T) in drives().items():
        t0 = time.perf_counter()
        L = LTCA(pair)
        t_build = time.perf_counter() - t0
        phi = L.mesh_cycle(64)
        t0 = time.perf_counter()
        L.solve(T, phi1=phi, mis=mis)
        t_first = time.perf_counter() - t0
        same, fresh, cpu = [], [], []
        for i in range(reps):
            c0 = time.process_time()
            t0 = time.perf_counter()
            S = L.slices(phi, mis=mis)
            t1 = time.perf_counter()
            sw = L.solve(T, slices=S)
            t2 = time.perf_counter()
            cpu.append(time.process_time() - c0)
            same.append((t1 - t0, t2 - t1))
            t0 = time.perf_counter()
            L.solve(T, phi1=phi + (i + 1) * 1e-6, mis=mis)  # positions not solved before
            fresh.append(time.perf_counter() - t0)
        r = sw.results[0]
        try:
            zero = L.solve(1e-9, slices=S).results[0]  # the zero-load limit
            try:
                ref = TCA(pair).sweep(phi, mis=mis, pairs=L.default_pairs()).te_envelope_arcsec
                on = np.isfinite(ref)
                err0 = float(np.max(np.abs(zero.te_loaded_arcsec[on] - ref[on])))
            except Exception:  # noqa: BLE001 - a conjugate drive has no point contact: its unloaded TE is 0
                err0 = float(np.max(np.abs(zero.te_loaded_arcsec)))
        except Exception as e:  # noqa: BLE001 - reported, not fatal (an older revision's QP may fail here)
            err0 = f"failed: {type(e).__name__}"
        out[name] = {
            "build": t_build, "first": t_first, "slices": min(s for s, _ in same), "qp": min(q for _, q in same),
            "total": min(s + q for s, q in same), "fresh": min(fresh), "cpu": min(cpu), "iters": int(r.hertz_iterations.max()),
            "kkt": float(r.kkt_error.max()), "zero_load": err0, "te_pp": r.peak_to_peak_arcsec,
            "te": r.te_loaded_arcsec.tolist(), "share": r.share.tolist(), "p_max": r.p_max,
            "load": (r.load / r.W).tolist(),
        }
    return out


def load_avg() -> str:
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "?"


def child(tree: Path, reps: int) -> dict:
    """:func:`measure` in a subprocess importing gearopt from ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    p = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", "--reps", str(reps)], cwd=tree,
                       env=env, capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(f"bench_ltca child in {tree} failed: {p.stderr.strip()[-800:]}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def best(runs: list[dict]) -> dict:
    """The minimum of every time over rounds (results from the first round)."""
    out = {}
    for name in runs[0]:
        d = dict(runs[0][name])
        for k in ("build", "first", "slices", "qp", "total", "fresh", "cpu"):
            d[k] = min(r[name][k] for r in runs)
        out[name] = d
    return out


def fmt0(v) -> str:
    return f"{v:13.1e}" if isinstance(v, float) else f"{str(v):>13}"


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="skip the CalculiX comparison")
    ap.add_argument("--base", help="git revision measured in the same run (temporary worktree)")
    ap.add_argument("--reps", type=int, default=5, help="warm repetitions per drive (minimum kept; default 5)")
    ap.add_argument("--rounds", type=int, default=2, help="with --base: alternating subprocess rounds (default 2)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.reps < 1 or a.rounds < 1:
        ap.error(f"--reps = {a.reps} and --rounds = {a.rounds} must be >= 1")
    if a.child:
        print(json.dumps(measure(a.reps)))
        return 0
    print(f"load average at start: {load_avg()}")
    if a.base:
        work = Path(tempfile.mkdtemp(prefix="gearopt-bench-ltca-"))
        tree = work / "base-tree"
        r = subprocess.run(["git", "worktree", "add", "--detach", str(tree), a.base], cwd=ROOT, capture_output=True,
                           text=True)
        if r.returncode:
            print(f"bench_ltca: git worktree add {a.base!r} failed: {r.stderr.strip()}", file=sys.stderr)
            return 2
        try:
            base_runs, here_runs = [], []
            for _ in range(a.rounds):
                base_runs.append(child(tree, a.reps))
                here_runs.append(child(ROOT, a.reps))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, capture_output=True)
            shutil.rmtree(work, ignore_errors=True)
        base, here = best(base_runs), best(here_runs)
        print(f"one torque x 64 positions, warm [s] (min of {a.reps} reps x {a.rounds} rounds); base = {a.base}")
        print(f"{'drive':<28} {'base':>6} {'here':>6} {'ratio':>6} {'cpu b':>6} {'cpu h':>6} {'slices':>6} {'QP':>6} "
              f"{'new pos':>7} {'base new':>8} {'iters':>5} {'KKT mm':>8} {'dTE arcsec':>10} {'dshare':>8} {'dp_max/p':>8} "
              f"{'dload/W':>8} {'0-load b/h':>21}")
        for name in here:
            b, h = base[name], here[name]
            dte = float(np.max(np.abs(np.subtract(b["te"], h["te"]))))
            dsh = float(np.max(np.abs(np.subtract(b["share"], h["share"]))))
            dld = float(np.max(np.abs(np.subtract(b["load"], h["load"]))))
            dp = abs(b["p_max"] - h["p_max"]) / b["p_max"]
            z = f"{b['zero_load'] if isinstance(b['zero_load'], str) else format(b['zero_load'], '.1e')}/" \
                f"{h['zero_load'] if isinstance(h['zero_load'], str) else format(h['zero_load'], '.1e')}"
            print(f"{name:<28} {b['total']:6.3f} {h['total']:6.3f} {b['total'] / h['total']:5.1f}x {b['cpu']:6.3f} "
                  f"{h['cpu']:6.3f} {h['slices']:6.3f} {h['qp']:6.3f} {h['fresh']:7.3f} {b['fresh']:8.3f} {h['iters']:5d} {h['kkt']:8.1e} {dte:10.1e} "
                  f"{dsh:8.1e} {dp:8.1e} {dld:8.1e} {z:>21}")
        print(f"load average at end: {load_avg()}")
        return 0
    res = measure(a.reps)
    print(f"{'drive':<28} {'build s':>7} {'first s':>7} {'slices s':>8} {'QP s':>6} {'1 torque':>8} {'cpu s':>6} {'new pos':>7} "
          f"{'iters':>5} {'KKT mm':>8} {'0-load arcsec':>13} {'TE p-p arcsec':>13}")
    for name, r in res.items():
        print(f"{name:<28} {r['build']:7.3f} {r['first']:7.3f} {r['slices']:8.3f} {r['qp']:6.3f} {r['total']:8.3f} "
              f"{r['cpu']:6.3f} {r['fresh']:7.3f} {r['iters']:5d} {r['kkt']:8.1e} {fmt0(r['zero_load'])} {r['te_pp']:13.3f}")
    print(f"load average at end: {load_avg()}")
    if a.quick or shutil.which("ccx") is None:
        print("(CalculiX comparison skipped)" if a.quick else "ccx (CalculiX) not installed: FE comparison skipped")
        return 0
    from gearopt.fea import FEOptions, GearFEModel

    pair, _, T = drives()["spur 20/40 conjugate"]
    spur_time = res["spur 20/40 conjugate"]["total"]
    t0 = time.perf_counter()
    m = GearFEModel(pair, 0.0, FEOptions(torque=T * 1e3))
    m.run()
    t_fe = time.perf_counter() - t0
    print(f"CalculiX, default model, one position: {t_fe:.1f} s ({m.n_elements} elements); 64 positions ~ "
          f"{64 * t_fe:.0f} s; loaded TCA (spur, warm, one torque, 64 positions) {spur_time:.3f} s: "
          f"ratio {64 * t_fe / spur_time:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
