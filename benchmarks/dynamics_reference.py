"""The reference integration of tests/test_dynamics.py::test_nonlinear_response_against_solve_ivp:
scipy's implicit Radau against the explicit DOP853 (Dormand-Prince 8(5,3)) on the test's
one-degree-of-freedom system (periodic stiffness k0 (1 + 0.15 cos phi), TE 12 um cos phi, 5 % damping,
100 um backlash, smoothed contact), from the static state over 120 mesh periods, rtol 1e-9, atol 1e-13.

    python benchmarks/dynamics_reference.py      # about a minute on 2 cores

Prints per speed ratio and method: CPU seconds, right-hand-side calls, the peak mesh force of the last
period [N], its relative difference to the shooting solution (gearopt.dynamics) and the least
separation (x - e) [m] (negative: the teeth lose contact). The system is not stiff (one natural
frequency, 5 % damping): both methods give the same peak to about 1e-7, DOP853 at about a tenth of
Radau's time (the test uses DOP853).
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.integrate import solve_ivp

from gearopt.dynamics import DriveTrain, GearDynamics, MeshExcitation

J1, J2, L1, L2, K0, W, Z1 = 2e-4, 1e-3, 0.028, 0.056, 4e8, 7000.0, 20
M_E = 1.0 / (L1**2 / J1 + L2**2 / J2)
N_RES = 60.0 * math.sqrt(K0 / M_E) / (2 * math.pi) / Z1  # pinion rpm at mesh frequency = natural frequency


def rhs(k0: float, eps_k: float, E: float, zeta: float, backlash: float, smooth: float):
    """Equation (2) of docs/dynamics.md for one degree of freedom, in numpy (as the test writes it)."""
    c = 2 * zeta * math.sqrt(k0 * M_E)

    def h(s):
        return 0.5 * (s + np.sqrt(s * s + smooth**2))

    def dh(s):
        return 0.5 * (1 + s / np.sqrt(s * s + smooth**2))

    def f(t, y, w):
        ph = w * t
        k = k0 * (1 + eps_k * np.cos(ph))
        s = y[0] - E * np.cos(ph)
        F = k * (h(s) - h(-s - backlash)) + c * y[1] * (dh(s) + dh(-s - backlash))
        return [y[1], (W - F) / M_E], F

    return f


def main() -> None:
    k0, eps_k, E, zeta, bl, sm = K0, 0.15, 12e-6, 0.05, 100e-6, 1e-3
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=zeta, backlash=bl)
    print(f"{'ratio':>5} {'method':>7} {'CPU s':>7} {'calls':>8} {'peak N':>12} {'vs shooting':>12} {'min sep m':>10}")
    for ratio in (0.5, 0.93, 1.4):
        gd = GearDynamics(tr, MeshExcitation([k0, k0 * eps_k], [0.0], [0.0, E], [0.0], W), Z1, smoothing=sm)
        s = gd.solve(ratio * N_RES)
        w, peak = s.omega_m, float(s.force.max())
        f = rhs(k0, eps_k, E, zeta, bl, sm * W / k0)
        T, n = 2 * math.pi / w, 120
        for method in ("Radau", "DOP853"):
            t0 = time.process_time()
            sol = solve_ivp(lambda t, y: f(t, y, w)[0], (0, n * T), [W / k0, 0.0], method=method, rtol=1e-9,
                            atol=1e-13, dense_output=True)
            t = (n - 1) * T + np.linspace(0, T, 400, endpoint=False)
            F = np.array([f(ti, sol.sol(ti), w)[1] for ti in t])
            sep = float((sol.sol(t)[0] - E * np.cos(w * t)).min())
            cpu = time.process_time() - t0
            print(f"{ratio:5.2f} {method:>7} {cpu:7.2f} {sol.nfev:8d} {F.max():12.6g} {peak / F.max() - 1:12.2e} {sep:10.3g}")


if __name__ == "__main__":
    main()
