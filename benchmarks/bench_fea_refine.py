"""FE model of crowned and helical drives (Litvin 9.5, CalculiX): mesh refinement at the pitch point.

    python benchmarks/bench_fea_refine.py            # 3 levels per drive (about 25 minutes on 2 cores)
    python benchmarks/bench_fea_refine.py --quick    # the two coarser levels
    python benchmarks/bench_fea_refine.py --very-fine   # one more level, the a_pl 2e-3 pinion only
                                                        # (85 000 elements, about 22 minutes)
    python benchmarks/bench_fea_refine.py --very-fine --only "helical 15 deg"   # that level, another drive

Drives: a double-crowned spur pinion (20/40, m 3, b 20, a_pl 0.0004 1/mm, a_c 0.002 1/mm; point contact:
reference the Hertz ellipse from the TCA curvatures; the ellipse's major semi-axis, 7.7 mm, spans most
of the 10 mm half face), the same with a_pl 0.002 1/mm (semi-axis 4.2 mm: the ellipse lies within
the face, where Hertz's half-spaces apply) and an uncrowned helical pair (21/45, m_n 2.5, beta 15 deg,
b 24; line contact: reference the normal-section Hertz line contact of the whole load).
100 N*m. Prints per level: elements, ccx time, peak pressure in the section through the contact
against its Hertz reference for the whole load and for the load the FE model puts on that pair (its
contact force share), the reaction error against T / r_b1 and the loaded pinion rotation.
"""

from __future__ import annotations

import math
import shutil
import sys
import time

from gearopt.fea import FEOptions, GearFEModel, MeshOptions
from gearopt.gears import BasicRack, Gear, GearPair

LEVELS = {
    "coarse (CI)": dict(n_hertz=2.0, n_ellipse=2.0, mesh=MeshOptions(n_face=4, n_half=4, n_flank=6, n_fillet=4, n_rim=3)),
    "default": dict(),
    "fine": dict(n_hertz=4.0, n_ellipse=4.0, mesh=MeshOptions(n_face=8, n_half=8, n_flank=10, n_fillet=6, n_rim=4)),
}
#: beyond "fine": 6 elements per Hertz half-width, 6 layers per ellipse semi-axis (the convergence check
#: of the crowned pinion whose ellipse lies within the face, where the Hertz reference applies)
VERY_FINE = {"very fine": dict(n_hertz=6.0, n_ellipse=6.0,
                               mesh=MeshOptions(n_face=10, n_half=10, n_flank=12, n_fillet=6, n_rim=4))}


def drives():
    b = math.radians(15)
    return {
        "crowned spur": GearPair(Gear(z=20, m_n=3, b=20, a_pl=4e-4, rack=BasicRack.iso53("A", a_c=2e-3)),
                                 Gear(z=40, m_n=3, b=20)),
        "crowned a_pl 2e-3": GearPair(Gear(z=20, m_n=3, b=20, a_pl=2e-3, rack=BasicRack.iso53("A", a_c=2e-3)),
                                      Gear(z=40, m_n=3, b=20)),
        "helical 15 deg": GearPair(Gear(z=21, m_n=2.5, b=24, beta=b), Gear(z=45, m_n=2.5, b=24, beta=b, hand="left")),
    }


def main(argv):
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed: nothing to benchmark")
        return 0
    levels = list(LEVELS.items())[:2] if "--quick" in argv else list(LEVELS.items())
    only = None
    if "--very-fine" in argv:  # --very-fine [--only DRIVE]: default the crowned a_pl 2e-3 pinion
        levels = list(VERY_FINE.items())
        only = argv[argv.index("--only") + 1] if "--only" in argv else "crowned a_pl 2e-3"
    print(f"{'drive':<18} {'level':<12} {'elements':>8} {'ccx s':>7} {'p_sec MPa':>9} {'Hertz':>7} {'kind':>7} "
          f"{'p/Hertz':>7} {'share':>6} {'p/H(share)':>10} {'R err %':>8} {'rotation rad':>13}")
    for dname, pair in drives().items():
        if only is not None and dname != only:
            continue
        for lname, kw in levels:
            t0 = time.perf_counter()
            m = GearFEModel(pair, 0.0, FEOptions(torque=100e3, timeout=3600.0, **kw))  # (the very fine level: 22 min)
            d = m.run().to_dict()
            t = time.perf_counter() - t0
            c = d["contact"]
            # the same Hertz reference for the load the FE model puts on that pair (its contact force)
            share = d["pair_share"][str(c["hertz_pair"])] or 0.0
            p_share = c["hertz_p0"] * share ** (1 / 3 if c["hertz_kind"] == "ellipse" else 1 / 2)
            print(f"{dname:<18} {lname:<12} {m.n_elements:8d} {t:7.1f} {c['p_max_mid']:9.1f} {c['hertz_p0']:7.1f} "
                  f"{c['hertz_kind']:>7} {c['ratio_mid_to_hertz']:7.3f} {share:6.3f} {c['p_max_mid'] / p_share:10.3f} "
                  f"{100 * d['reaction']['rel_error']:8.4f} {d['pinion_rotation_rad']:13.6e}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
