"""Convergence of loaded TCA in the number of slices (docs/ltca.md, sections 1 and 8).

    python benchmarks/ltca_slice_convergence.py            # 11/21/41/81 slices, three drives (about 2 minutes)
    python benchmarks/ltca_slice_convergence.py --quick    # 11/21/41 slices

The slices are fixed to the tooth (``b/(n_slices-1)`` apart, both face ends are slices), so a result
moves with the slice count only by the discretisation of the contact along the face. Per drive and
slice count: the loaded TE peak-to-peak over one mesh cycle [arcsec], the largest Hertz peak pressure
of the flank contact over the cycle [MPa], the largest and the smallest loaded approach (``delta``) [um],
the largest load share of a tip edge, and the time of one solve (slices + one torque) [s]; each figure's
change from the finest count in the last columns.

Drives (analytical compliance, 32 positions of one mesh cycle): a Litvin-crowned 20/40 spur pinion
(a_pl 4e-4 /mm, profile crowning a_c 0.002) with a 3 arcmin crossing at 200 N m; the 20/40 spur of the
loaded optimiser's optimum (docs/loaded_synthesis.md section 5: ISO C_alpha 40, C_beta 28.29, tip
relief 3.26 from d 64 mm, root relief 15.16 from d 58.5 mm [um]) with a 2 arcmin crossing at 250 N m;
the lead-crowned helical 21/53 (a_pl 2e-4 /mm) at 300 N m.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from gearopt.geometry.microgeometry import Microgeometry
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.engine import LTCA
from gearopt.meshing.misalignment import Misalignment
from gearopt.units import ARCMIN

UM = 1e-3  # mm


def drives():
    A = BasicRack.iso53("A")
    opt = Microgeometry(C_alpha=40 * UM, C_beta=28.29 * UM, C_alpha_a=3.26 * UM, d_Ca=64.0, C_alpha_f=15.16 * UM,
                        d_Cf=58.5)
    return {
        "spur Litvin-crowned, 3' crossing, 200 N m": (
            GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=0.0004, rack=BasicRack.iso53("A", a_c=0.002)),
                     Gear(z=40, m_n=3.0, b=20.0, rack=A)), Misalignment(crossing=3 * ARCMIN), 200.0),
        "spur ISO optimum, 2' crossing, 250 N m": (
            GearPair(Gear(z=20, m_n=3.0, b=20.0, name="pinion", modifications=opt),
                     Gear(z=40, m_n=3.0, b=20.0, name="gear")),
            Misalignment(crossing=2 * ARCMIN), 250.0),
        "helical 21/53 crowned, 300 N m": (
            GearPair(Gear(z=21, m_n=2.5, b=30.0, beta=math.radians(18), a_pl=0.0002, rack=A),
                     Gear(z=53, m_n=2.5, b=30.0, beta=math.radians(18), hand="left", rack=A)), Misalignment(), 300.0),
    }


def main(argv):
    counts = (11, 21, 41) if "--quick" in argv else (11, 21, 41, 81)
    pp_head = 'TE p-p "'
    head = (f"{'n_slices':>8} {pp_head:>9} {'p_max MPa':>9} {'delta max um':>12} {'delta min um':>12} "
            f"{'edge share':>10} {'time s':>6} | {'d p-p %':>7} {'d p_max %':>9} {'d delta %':>9}")
    for name, (pair, mis, T) in drives().items():
        rows = []
        for n in counts:
            L = LTCA(pair, n_slices=n)
            phi = L.mesh_cycle(32)
            L.solve(T, phi1=phi[:2], mis=mis)  # compile outside the timing
            t0 = time.perf_counter()
            r = L.solve(T, phi1=phi, mis=mis).results[0]
            dt = time.perf_counter() - t0
            rows.append((n, r.peak_to_peak_arcsec, r.p_max, 1e3 * float(np.max(r.delta)), 1e3 * float(np.min(r.delta)),
                         float(np.max(r.edge_share)), dt))
        ref = rows[-1]
        print(f"\n{name}\n{head}")
        for n, pp, p, dmax, dmin, e, dt in rows:
            print(f"{n:8d} {pp:9.4f} {p:9.1f} {dmax:12.4f} {dmin:12.4f} {e:10.4f} {dt:6.2f} | "
                  f"{100 * (pp / ref[1] - 1):7.2f} {100 * (p / ref[2] - 1):9.2f} {100 * (dmax / ref[3] - 1):9.3f}")


if __name__ == "__main__":
    main(sys.argv[1:])
