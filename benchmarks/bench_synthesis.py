"""Time and iterations of the local synthesis and of the global crowning NLP (run:
`.venv/bin/python benchmarks/bench_synthesis.py`).

Global NLP: 41 TCA positions x 5 misalignment cases (aligned, crossing and intersecting +-3 arcmin)
plus the transfer points, for a spur and a helical drive. Build (SX graph + IPOPT set-up, including
the first-guess TCA sweeps) and solve are timed separately; each solve is repeated and the median
reported. Targets from the issue: solve <= 0.5 s, build <= 1 s.
"""

from __future__ import annotations

import math
import statistics
import time

from gearopt import ARCSEC, Gear, GearPair, deg
from gearopt.synthesis import CrowningOptimizer, CrowningTarget, LocalTarget, local_synthesis


def drives():
    return {
        "spur 20/40 m3 b20": GearPair(Gear(z=20, m_n=3, b=20, name="pinion"), Gear(z=40, m_n=3, b=20, name="gear")),
        "helical 21/53 m2.5 b18deg": GearPair(Gear(z=21, m_n=2.5, b=30, beta=deg(18), name="pinion"),
                                              Gear(z=53, m_n=2.5, b=30, beta=deg(18), hand="left", name="gear")),
    }


def main():
    print(f"{'drive':26s} {'problem':34s} {'vars':>6s} {'build s':>8s} {'solve s':>8s} {'iter':>5s}  result")
    for name, pair in drives().items():
        z1 = pair.pinion.z
        A = 8 * ARCSEC / (math.pi / z1) ** 2
        t0 = time.perf_counter()
        d = local_synthesis(pair, LocalTarget(mprime21=-2 * A, major_axis=0.5 * pair.pinion.b))
        t_loc = time.perf_counter() - t0
        print(f"{name:26s} {'local synthesis (m21, 2a)':34s} {17:6d} {t_loc - d.solve_time:8.3f} {d.solve_time:8.3f} "
              f"{d.iterations:5d}  m'21 {d.verified['mprime21']:.6g} (target {-2 * A:.6g}), "
              f"2a {d.verified['major_axis']:.4f} mm")
        opt = CrowningOptimizer(pair, CrowningTarget(te_level=8 * ARCSEC, ellipse_share=0.25), positions=41)
        t0 = time.perf_counter()
        opt.build()
        t_build = time.perf_counter() - t0
        times, it = [], None
        for _ in range(5):
            res = opt.solve(verify=False, sensitivities=False)
            times.append(res.solve_time)
            it = res.iterations
        design = opt.solve()
        worst = max(abs(c.te_level_tca / (8 * ARCSEC) - 1) for c in design.cases)
        edge = any(c.edge_contact for c in design.cases)
        print(f"{name:26s} {'global NLP 41 pos x 5 cases':34s} {opt._x0.size:6d} {t_build:8.3f} "
              f"{statistics.median(times):8.3f} {it:5d}  a_c {design.settings['a_c']:.4g}, a_pl "
              f"{design.settings['a_pl']:.4g}; worst level dev {100 * worst:.1f} %, edge contact {edge}")


if __name__ == "__main__":
    main()
