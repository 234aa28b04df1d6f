"""Gear dynamics (gearopt.dynamics, docs/dynamics.md): the validation figures of docs/dynamics.md and the
speed of a 200-speed sweep, in one run.

    python benchmarks/bench_dynamics.py           # about 30 s
    python benchmarks/bench_dynamics.py --quick   # the sweep timing only

Cases: (1) the linear time-invariant limit (constant stiffness 4e8 N/m, TE 2 um cos(phi), damping
ratio 0.05, one degree of freedom of m_e = 0.1508 kg) against the closed-form amplitude and phase;
(2) the Mathieu chart: Floquet multipliers of k0 (1 + 0.2 cos phi) without damping, the edges of the
first principal region found by bisection against McLachlan's transition curves; (3) the low-speed
limit of the ltca_spur drive at 200 N m (loaded TCA, 64 positions) against its static loaded TE;
(4) the 200-speed sweep (up only, then up and down) of that drive from 0.2 to 1.5 x its resonance, with
the counts of converged speeds and of the branch's jumps; (5) the speed-range sensitivity to two
micro-geometry amounts (docs/dynamics.md section 7).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from gearopt.dynamics import DriveTrain, GearDynamics, MeshExcitation
from gearopt.dynamics.drive import drive_train, loaded_mesh
from gearopt.gears import Gear, GearPair

J1, J2, L1, L2, K0, W, Z1 = 2e-4, 1e-3, 0.028, 0.056, 4e8, 7000.0, 20
M_E = 1.0 / (L1**2 / J1 + L2**2 / J2)
N_RES = 60.0 * math.sqrt(K0 / M_E) / (2 * math.pi) / Z1


def lti() -> None:
    zeta, E = 0.05, 2e-6
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=zeta)
    gd = GearDynamics(tr, MeshExcitation([K0, 0.0], [0.0], [0.0, E], [0.0], W), Z1, contact_loss=False)
    c = 2 * zeta * math.sqrt(K0 * M_E)
    print("LTI limit: speed / resonance, amplitude [um] model, closed form, rel. error; phase error [rad]")
    worst = 0.0
    for r in (0.3, 0.8, 0.97, 1.0, 1.05, 1.6):
        s = gd.solve(r * N_RES)
        w = s.omega_m
        X = K0 * E / math.hypot(K0 - M_E * w**2, c * w)
        psi = math.atan2(c * w, K0 - M_E * w**2)
        cx = np.fft.rfft(s.x) / len(s.x)
        amp, ph = 2 * abs(cx[1]), -np.angle(cx[1])
        err = abs(amp / X - 1)
        worst = max(worst, err)
        print(f"  {r:5.2f}  {amp * 1e6:9.5f}  {X * 1e6:9.5f}  {err:.1e}  {abs(ph - psi):.1e}")
    print(f"  largest relative amplitude error {worst:.1e}")


def mathieu() -> None:
    from scipy.optimize import brentq

    eps = 0.2
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=0.0)
    gd = GearDynamics(tr, MeshExcitation([K0, K0 * eps], [0.0], [0.0, 0.0], [0.0], 0.0), Z1, contact_loss=False,
                      tol=1e-12)

    def rho(Wr):
        return float(np.abs(np.linalg.eigvals(gd.monodromy(Wr * N_RES, np.zeros(2)))).max())

    def chart(sign):
        return brentq(lambda Wr: 4 / Wr**2 - (1 + sign * 2 * eps / Wr**2 - (2 * eps / Wr**2) ** 2 / 8
                                              - sign * (2 * eps / Wr**2) ** 3 / 64), 1.5, 2.5)

    def edge(a, b):
        for _ in range(40):
            m = 0.5 * (a + b)
            a, b = (a, m) if rho(m) > 1 + 1e-7 else (m, b)
        return 0.5 * (a + b)

    lo, hi = sorted((chart(1), chart(-1)))
    print(f"Mathieu, eps = {eps}: first principal region of omega_mesh / omega_n")
    print(f"  chart {lo:.6f} ... {hi:.6f}; Floquet {edge(lo - 0.05, 2.0):.6f} ... {edge(hi + 0.05, 2.0):.6f}; "
          f"largest |multiplier| at 2.0: {rho(2.0):.4f}")


def low_speed(pair, lm) -> None:
    tr = drive_train(pair, 0.05)
    gd = GearDynamics(tr, lm.excitation(), pair.pinion.z, samples=2 * len(lm.phi1))
    n = 60 * gd.natural_frequencies()[0] / pair.pinion.z
    print("low-speed limit of ltca_spur at 200 N m (speed / resonance, K_v - 1, min F/W - 1, "
          "largest |dynamic TE - loaded TE| over its peak-to-peak)")
    for r in (0.01, 0.002):
        s = gd.solve(r * n)
        te = -s.x[::2] / lm.lever_gear
        print(f"  {r:6.3f}  {s.force.max() / lm.W - 1:+.2e}  {s.force.min() / lm.W - 1:+.2e}  "
              f"{np.max(np.abs(te - lm.te_loaded)) / np.ptp(lm.te_loaded):.2e}")


def sweep(pair, lm) -> None:
    tr = drive_train(pair, 0.05)
    t0 = time.perf_counter()
    gd = GearDynamics(tr, lm.excitation(), pair.pinion.z, tol=1e-9, newton_tol=1e-7)
    t_build = time.perf_counter() - t0
    n = 60 * gd.natural_frequencies()[0] / pair.pinion.z
    v = np.linspace(0.2, 1.5, 200) * n
    t0 = time.perf_counter()
    sw = gd.sweep(v, both=False)
    t_up = time.perf_counter() - t0
    t0 = time.perf_counter()
    sw2 = gd.sweep(v, both=True)
    t_both = time.perf_counter() - t0
    ok = sum(s.converged for s in sw.up)
    ok2 = sum(s.converged for s in sw2.up + sw2.down)
    jumped = [f"{s.speed_rpm:.0f}" for s in sw.up if s.jumped]
    failed = [f"{s.speed_rpm:.0f}" for s in sw.up if not s.converged]
    failed2 = [f"{s.speed_rpm:.0f}" for s in sw2.up + sw2.down if not s.converged]
    print(f"200-speed sweep of ltca_spur at 200 N m ({lm.excitation().harmonics} harmonics): build {t_build:.2f} s, "
          f"up {t_up:.1f} s ({ok}/200 converged, {len(jumped)} jumps of the branch at {', '.join(jumped) or '-'} rpm, "
          f"not converged: {', '.join(failed) or 'none'}), up and down {t_both:.1f} s ({ok2}/400"
          f"{', not converged: ' + ', '.join(failed2) if failed2 else ''})")


def sensitivity() -> None:
    """The KS objective of K_v over 40 speeds (0.5 ... 1.3 x the resonance) of the relieved ltca_spur pinion
    and its gradient per um of the tip relief and the profile crowning (docs/dynamics.md section 7)."""
    from gearopt.dynamics.sensitivity import speed_range_sensitivity
    from gearopt.geometry.microgeometry import Microgeometry

    mods = Microgeometry(C_alpha_a=0.025, d_Ca=62.0, tip_shape="linear")
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=mods), Gear(z=40, m_n=3.0, b=20.0))
    t0 = time.perf_counter()
    r = speed_range_sensitivity(pair, 200.0, ["pinion.C_alpha_a", "pinion.C_alpha"], np.linspace(9500, 24500, 40))
    g = ", ".join(f"{n} {v:+.3e}" for n, v in zip(r.names, r.gradient))
    print(f"speed-range sensitivity (40 speeds, KS rho {r.rho:g}): J = {r.objective:.4f}, dJ/d(amount) per um: {g}; "
          f"{len(r.speeds_rpm)} speeds in J, excluded {r.excluded_speeds_rpm or 'none'}; "
          f"{time.perf_counter() - t0:.1f} s (loaded TCA + tangents {r.time_s['ltca_tangent']:.1f} s, sweep "
          f"{r.time_s['sweep']:.1f} s, gradient {r.time_s['gradient']:.1f} s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    t0 = time.perf_counter()
    lm = loaded_mesh(pair, 200.0)
    print(f"loaded TCA: {time.perf_counter() - t0:.2f} s")
    if not a.quick:
        lti()
        mathieu()
        low_speed(pair, lm)
    sweep(pair, lm)
    if not a.quick:
        sensitivity()


if __name__ == "__main__":
    main()
