"""Cost and accuracy of the generated tooth surfaces (run: `make bench` or
`.venv/bin/python benchmarks/bench_generation.py`).

For each tool (rack, hob, shaper) and a spur and a helical gear: graph build + compile time,
evaluation time per surface point (one `Function.map` call over N points, and per-point Python
calls as the baseline measured in the same run), and the largest distance of the generated flank
from the analytic involute (docs/theory.md section 2) over the active flank.
"""

from __future__ import annotations

import math
import time

import numpy as np

from gearopt import Gear, deg
from gearopt.geometry.generation import generate_by_hob, generate_by_rack, generate_by_shaper
from gearopt.geometry.involute import inv

N = 20_000


def involute_error(tooth, r, z):
    g = tooth.gear
    rad = np.hypot(r[0], r[1])
    ang = np.arctan2(r[0], r[1])
    al_r = np.arccos(g.r_b / rad)
    half = g.s_t / (2 * g.r_p) + inv(g.alpha_t) - (np.tan(al_r) - al_r)
    sig = 0 if g.is_spur else (1 if g.hand == "right" else -1)
    return np.max(rad * np.abs(ang - (half - sig * z * math.tan(g.beta) / g.r_p)))


def main():
    gears = {"spur z=19": Gear(z=19, m_n=3.0, x=0.2, name="spur"),
             "helical z=23 b=20deg": Gear(z=23, m_n=2.0, beta=deg(20), name="helical")}
    tools = {"rack": generate_by_rack, "hob": generate_by_hob, "shaper": generate_by_shaper}
    print(f"{'gear':22s} {'tool':7s} {'build ms':>9s} {'map us/pt':>10s} {'loop us/pt':>11s} {'speed-up':>9s} "
          f"{'max |err| mm':>13s}")
    for gname, g in gears.items():
        for tname, gen in tools.items():
            if tname == "shaper" and not g.is_spur:
                continue
            t0 = time.perf_counter()
            tooth = gen(g)
            f = tooth.surface("right", "flank")
            fm = f.map(N)
            t_build = time.perf_counter() - t0
            u_f, _ = tooth.junction()
            u_tip = tooth.u_at_radius(g.r_a)
            us = np.linspace(u_tip, u_f, N)
            zs = np.linspace(-g.b / 2, g.b / 2, N)
            P = np.tile(tooth.p0[:, None], N)
            fm(us, zs, P)  # warm-up
            t0 = time.perf_counter()
            r = np.asarray(fm(us, zs, P)[0])
            t_map = (time.perf_counter() - t0) / N
            k = 500
            t0 = time.perf_counter()
            for i in range(k):
                f(us[i], zs[i], tooth.p0)
            t_loop = (time.perf_counter() - t0) / k
            err = involute_error(tooth, r[:, ::7], zs[::7])
            print(f"{gname:22s} {tname:7s} {1e3 * t_build:9.1f} {1e6 * t_map:10.3f} {1e6 * t_loop:11.2f} "
                  f"{t_loop / t_map:9.0f} {err:13.2e}")


if __name__ == "__main__":
    main()
