"""FE model (Litvin 9.5, CalculiX): mesh refinement study at the pitch point of a 20/30 spur pair
(m 3 mm, b 10 mm, 100 N*m) and timing of mesh generation and the ccx run vs element count.

    python benchmarks/bench_fea.py            # 3 levels (about 2 minutes on 2 cores)
    python benchmarks/bench_fea.py --quick    # the two coarser levels

Prints: elements, mesh build time, ccx time, FE/Hertz max contact pressure at mid face, reaction
error against T / r_b1, root stress (max principal, mid face) and its ratio to ISO 6336-3.
"""

from __future__ import annotations

import shutil
import sys
import time

from gearopt.fea import FEOptions, GearFEModel, MeshOptions
from gearopt.gears import BasicRack, Gear, GearPair

LEVELS = {
    "coarse (CI)": dict(n_hertz=2.0, mesh=MeshOptions(n_face=2, n_half=4, n_flank=6, n_fillet=4, n_rim=3)),
    "medium": dict(n_hertz=3.0, mesh=MeshOptions(n_face=4, n_half=6, n_flank=8, n_fillet=5, n_rim=4)),
    "fine": dict(n_hertz=5.0, mesh=MeshOptions(n_face=4, n_half=9, n_flank=10, n_fillet=8, n_rim=5)),
}


def main(argv):
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed: nothing to benchmark")
        return 0
    r = BasicRack.iso53("A")
    pair = GearPair(Gear(z=20, m_n=3, b=10, rack=r, name="pinion"), Gear(z=30, m_n=3, b=10, rack=r, name="gear"))
    levels = list(LEVELS.items())[:2] if "--quick" in argv else list(LEVELS.items())
    print(f"{'level':<12} {'elements':>8} {'mesh s':>7} {'ccx s':>7} {'p_mid':>8} {'Hertz':>7} {'FE/Hz':>6} "
          f"{'R err %':>8} {'sF1':>6} {'/ISO':>5} {'sF2':>6} {'/ISO':>5}")
    for name, kw in levels:
        t0 = time.perf_counter()
        m = GearFEModel(pair, 0.0, FEOptions(torque=100e3, **kw))
        t_mesh = time.perf_counter() - t0
        d = m.run().to_dict()
        c, rt = d["contact"], d["root"]
        print(f"{name:<12} {d['n_elements']:>8} {t_mesh:>7.2f} {d['timing']['ccx_s']:>7.1f} {c['p_max_mid']:>8.1f} "
              f"{c['hertz_p0']:>7.1f} {c['ratio_mid_to_hertz']:>6.3f} {100 * d['reaction']['rel_error']:>8.4f} "
              f"{rt['pinion']['max_principal_mid']:>6.1f} {rt['pinion']['ratio_to_iso']:>5.2f} "
              f"{rt['gear']['max_principal_mid']:>6.1f} {rt['gear']['ratio_to_iso']:>5.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
