"""Loaded TCA (gearopt.ltca, analytical compliance): cost of one torque over one mesh cycle of 64
positions, its accuracy checks, and the CalculiX model's cost for the same positions, in one run.

    python benchmarks/bench_ltca.py            # three drives + one CalculiX position (about 1 minute)
    python benchmarks/bench_ltca.py --quick    # without CalculiX

Per drive (conjugate spur, crowned spur with 3 arcmin crossing, crowned helical): the build time
(compiling the graphs), the first solve (the slices' mapped Functions are created on first use),
then warm: the unloaded separations (slices) and one torque (the contact QPs with the Hertz fixed
point), their sum (the "one torque, one cycle" figure), the KKT error of the contact conditions and
the zero-load error against the unloaded TCA. The FE line times one position of the spur drive's
default CalculiX model and scales it to 64 positions; the ratio is FE / loaded TCA in this run.
"""

from __future__ import annotations

import math
import shutil
import sys
import time

import numpy as np

from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.engine import LTCA
from gearopt.meshing.misalignment import Misalignment
from gearopt.meshing.tca import TCA
from gearopt.units import ARCMIN


def drives():
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


def main(argv):
    quick = "--quick" in argv
    print(f"{'drive':<28} {'build s':>7} {'first s':>7} {'slices s':>8} {'QP s':>6} {'1 torque':>8} {'iters':>5} "
          f"{'KKT mm':>8} {'0-load arcsec':>13} {'TE p-p arcsec':>13}")
    spur_time = None
    for name, (pair, mis, T) in drives().items():
        t0 = time.perf_counter()
        L = LTCA(pair)
        t_build = time.perf_counter() - t0
        phi = L.mesh_cycle(64)
        t0 = time.perf_counter()
        L.solve(T, phi1=phi, mis=mis)
        t_first = time.perf_counter() - t0
        reps = []
        for _ in range(3):
            t0 = time.perf_counter()
            S = L.slices(phi, mis=mis)
            t1 = time.perf_counter()
            sw = L.solve(T, slices=S)
            t2 = time.perf_counter()
            reps.append((t1 - t0, t2 - t1))
        t_sep, t_qp = min(r[0] for r in reps), min(r[1] for r in reps)
        r = sw.results[0]
        zero = L.solve(1e-9, slices=S).results[0]  # the zero-load limit
        try:
            ref = TCA(pair).sweep(phi, mis=mis, pairs=L.default_pairs()).te_envelope_arcsec
            on = np.isfinite(ref)
            err0 = float(np.max(np.abs(zero.te_loaded_arcsec[on] - ref[on])))
        except Exception:  # noqa: BLE001 - a conjugate drive has no point contact: its unloaded TE is 0
            err0 = float(np.max(np.abs(zero.te_loaded_arcsec)))
        total = t_sep + t_qp
        if spur_time is None:
            spur_time = total
        print(f"{name:<28} {t_build:7.3f} {t_first:7.3f} {t_sep:8.3f} {t_qp:6.3f} {total:8.3f} "
              f"{int(r.hertz_iterations.max()):5d} {float(r.kkt_error.max()):8.1e} {err0:13.1e} {r.peak_to_peak_arcsec:13.3f}")
    if quick or shutil.which("ccx") is None:
        print("(CalculiX comparison skipped)" if quick else "ccx (CalculiX) not installed: FE comparison skipped")
        return 0
    from gearopt.fea import FEOptions, GearFEModel

    pair, _, T = drives()["spur 20/40 conjugate"]
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
