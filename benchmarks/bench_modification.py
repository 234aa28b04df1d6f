"""Cost of a flank modification in the TCA (run: `PYTHONPATH=. python benchmarks/bench_modification.py`).

Case: the crowned, misaligned drive of bench_tca.py (pinion z=20, m_n=3, b=20, ISO 53 A rack with
a_c=0.002 1/mm, a_pl=0.0004 1/mm; gear z=40; crossing 3', intersecting 2', dE=0.05 mm), and the
same drive made helical (beta = 15 deg, where the modified flank needs the foot-point section
zeta, see gearopt/geometry/modification.py). The pinion carries

* none (the generated flank),
* ``polynomial`` (lead slope + profile parabola, 5 symbolic theta),
* ``topography`` 12 x 8 grid, fixed values (no theta), and with the 96 values symbolic;
* ISO 21771 micro-geometry (``Gear.modifications``, gearopt/geometry/microgeometry.py): every term
  (crowning, slopes, bias, tip, root and both end reliefs: 9 symbolic amounts), and a measured
  grid 40 x 20 per flank (both flanks) as the imported cubic B-spline.

For each: TCA build time [s], size of the residual graph (SX instructions), and the wall time of
``TCA.sweep`` over N = 1000 positions and 3 tooth pairs (median of 3; interpreted, no jit).
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from gearopt import ARCMIN, BasicRack, Gear, GearPair
from gearopt.geometry.generation import generate_by_rack
from gearopt.geometry.microgeometry import FIXED_POINT_STEPS, Microgeometry, modified_tooth
from gearopt.geometry.modification import polynomial, topography
from gearopt.meshing.tca import TCA, Misalignment


def pair(beta):
    hand = {} if beta == 0 else {"beta": beta, "hand": "right"}
    other = {} if beta == 0 else {"beta": beta, "hand": "left"}
    g1 = Gear(z=20, m_n=3.0, b=20.0, rack=BasicRack.iso53("A", a_c=0.002), a_pl=0.0004, name="pinion", **hand)
    return GearPair(g1, Gear(z=40, m_n=3.0, b=20.0, name="gear", **other))


def mods(g):
    s = np.linspace(-4.5, 4.5, 12)
    z = np.linspace(-11.0, 11.0, 8)
    S, Z = np.meshgrid(s, z, indexing="ij")
    V = 1e-3 * (0.5 * np.cos(S) + 0.05 * Z)
    return {"none": None,
            "polynomial": polynomial(c_z=1e-4, c_uu=-2e-4, name="poly"),
            "topography": topography(s, z, V, name="topo"),
            "topography (96 theta)": topography(s, z, V, name="topo", parametric=True),
            "ISO, every term": "iso", "measured 2 x 40 x 20": "measured"}


def iso_mods(pr, which):
    """The pinion tooth with ISO micro-geometry: every term, or a synthetic measured grid per flank."""
    from collections import namedtuple

    Grid = namedtuple("Grid", "side profile s z deviation source")  # (the fields of inspection.FlankGrid)
    g = pr.pinion
    if which == "iso":
        mg = Microgeometry(C_alpha=0.004, f_H_alpha=0.002, C_beta=0.008, f_H_beta=0.003, S_alpha=0.002,
                           C_alpha_a=0.01, d_Ca=2 * (g.r_a - 0.25 * g.m_n), C_alpha_f=0.006, d_Cf=2 * (g.r_p - 0.3 * g.m_n),
                           C_beta_I=0.01, b_I=3.0, C_beta_II=0.01, b_II=3.0)
    else:
        d = np.linspace(2 * g.r_form + 0.01, 2 * g.r_a, 40)
        z = np.linspace(-g.b / 2, g.b / 2, 20)
        D, Z = np.meshgrid(d, z, indexing="ij")
        V = -0.008 * (2 * Z / g.b) ** 2 + 3e-4 * np.sin(3 * D)
        mg = Microgeometry(measured=tuple(Grid(sd, "d_y", tuple(d), tuple(z), tuple(map(tuple, V)), "bench")
                                          for sd in ("right", "left")))
    return modified_tooth(GearPair(g.with_(modifications=mg), pr.gear, pr.a), "pinion")


def main(n=1000, repeats=3):
    print(f"(ISO terms: {FIXED_POINT_STEPS} fixed-point steps for the modified point's roll length)")
    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    print(f"{'case':10s} {'modification':24s} {'build s':>8s} {'SX instr':>9s} {'sweep s':>8s} {'us/pos':>7s}")
    for label, beta in (("spur", 0.0), ("helical", 15 * math.pi / 180)):
        pr = pair(beta)
        phi = np.linspace(-math.pi / pr.pinion.z, math.pi / pr.pinion.z, n)
        for name, mod in mods(pr.pinion).items():
            tooth = generate_by_rack(pr.pinion)
            if isinstance(mod, str):
                tooth = iso_mods(pr, mod)
            elif mod is not None:
                tooth = tooth.with_modification(mod)
            t0 = time.perf_counter()
            tca = TCA(pr, pinion=tooth)
            build = time.perf_counter() - t0
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                res = tca.sweep(phi, mis=mis)
                times.append(time.perf_counter() - t0)
            t = statistics.median(times)
            assert res.converged.any()
            print(f"{label:10s} {name:24s} {build:8.2f} {tca.residual.n_instructions():9d} {t:8.2f} "
                  f"{1e6 * t / (3 * n):7.1f}")


if __name__ == "__main__":
    main()
