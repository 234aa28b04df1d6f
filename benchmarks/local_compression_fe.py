"""The local (Hertzian) compression of a tooth, from the tooth flank to its middle line, in a
plane-strain CalculiX model of the tooth section (gearopt.fea.local), against Weber's half-space term
(docs/ltca.md section 5).

    python benchmarks/local_compression_fe.py        # about 1 minute

1. Spur 20/40, m 3, pitch point: the compression under the Hertz strip of the pair's line load at 200
   and 50 N m over 20 mm, at three mesh levels; FE / Weber and kappa, the excess in Weber's bracket.
2. kappa along the flank of each member (the values loaded TCA with FE coefficients uses), for the
   20/40 spur and the helical 21/45 (15 deg, on its virtual spur section) and 21/53 (18 deg) drives.
"""

from __future__ import annotations

import math
import shutil
import sys

import numpy as np

from gearopt.fea.local import local_excess, section_compression, section_tooth
from gearopt.fea.references import hertz_line
from gearopt.gears import Gear
from gearopt.geometry.generation import generate

E, NU = 210000.0, 0.3


def main(argv):
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed")
        return 0
    b = 20.0
    p, g = Gear(z=20, m_n=3.0, b=b, name="pinion"), Gear(z=40, m_n=3.0, b=b, name="gear")
    rho1 = math.sqrt(p.r_p**2 - p.r_b**2)
    rho2 = math.sqrt(g.r_p**2 - g.r_b**2)
    print("1. spur 20/40 m 3 at the pitch point")
    for T in (200.0, 50.0):
        f = T * 1e3 / p.r_b / b
        b_H = hertz_line(f, rho1, rho2, E, NU).b
        for n_hertz, n_half in ((4, 12), (8, 24), (8, 40)):
            for name, gear in (("pinion", p), ("gear", g)):
                r = section_compression(generate(gear), gear.r_p, b_H, E, NU, n_hertz=n_hertz, n_half=n_half)
                s = f / r["f"]  # the model's strip load scaled to the pair's line load
                print(f"  {T:5.0f} N m  f {f:6.1f} N/mm  b_H {b_H:.4f} mm  n_hertz {n_hertz:2d} n_half {n_half:2d} "
                      f"{name:<7} h {r['h']:.3f} mm: flank - C {1e3 * s * r['local']:.3f} um, Weber "
                      f"{1e3 * s * r['weber']:.3f} um, FE / Weber {r['local'] / r['weber']:.3f}, kappa "
                      f"{r['kappa']:.3f} ({r['elements']} elements)", flush=True)
    print("2. kappa along the flank (b_H = 0.05 m_n)")
    drives = {"spur 20/40 m 3": (p, g),
              "helical 21/45 m 2.5 15 deg": (Gear(z=21, m_n=2.5, b=24, beta=math.radians(15), name="pinion"),
                                             Gear(z=45, m_n=2.5, b=24, beta=math.radians(15), hand="left", name="gear")),
              "helical 21/53 m 2.5 18 deg": (Gear(z=21, m_n=2.5, b=30, beta=math.radians(18), name="pinion"),
                                             Gear(z=53, m_n=2.5, b=30, beta=math.radians(18), hand="left", name="gear"))}
    for dname, members in drives.items():
        for gear in members:
            t = generate(gear)
            vt, _ = section_tooth(t)
            r = np.linspace(max(gear.r_form, gear.r_b) + 0.1 * gear.m_n, gear.r_a - 0.1 * gear.m_n, 7)
            k = local_excess(t, r, E, NU, use_cache=False)
            print(f"  {dname:<27} {gear.name:<6} (section z {vt.gear.z}): radius - r_p [mm] "
                  + " ".join(f"{v:+6.2f}" for v in r - gear.r_p) + " | kappa " + " ".join(f"{v:.3f}" for v in k),
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
