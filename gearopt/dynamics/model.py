"""Lumped-parameter gear-pair dynamics along the line of action (docs/dynamics.md).

Model
-----
Rotary inertias ``J = (J_drive, J_1, J_2, J_load)`` (the drive and load ones optional) with angles
``u``; relative coordinates ``q = B u``: the drive shaft's twist ``theta_d - theta_1`` [rad], the
mesh coordinate ``x = l_1 theta_1 - l_2 theta_2`` [m] (``l_i = r_bi cos(beta_b)``: the levers of the
normal load, as the loaded TCA's ``W = T / (r_b1 cos beta_b)``) and the load shaft's twist
``theta_2 - theta_load`` [rad]. The rigid-body rotation is orthogonal to ``B`` and carries no
force when the external torques balance (``T_load = T_drive l_2 / l_1``), so with
``M u'' = T - B^T g(q, q')``:

    q'' = B M^-1 T - (B M^-1 B^T) g(q, q', t)                                   (1)

with the generalised forces ``g``: ``k_s s + c_s s'`` for a shaft and, for the mesh (excitation
form (a) of Ozguven & Houser / Kahraman & Singh: the time-varying stiffness acting on the gap to
the *unloaded* TE),

    F = k(phi) [h(s) - h(-s - b_j)] + c_m x' [h'(s) + h'(-s - b_j)],   s = x - e(phi)   (2)

``phi`` the mesh phase (``2 pi`` per mesh cycle, ``phi = omega_m t``), ``k(phi)`` the loaded TCA's
secant mesh stiffness at the operating torque (``W / delta``), ``e(phi) = -TE_unloaded l_2`` the
unloaded TE as a displacement along the line of action, ``b_j`` the backlash along it, and
``h(s) = (s + sqrt(s^2 + eps^2)) / 2`` a smoothed ``max(s, 0)`` (eps = ``smoothing`` x the static
deflection ``W / k_mean``; the smoothing keeps (2) differentiable for CVODES and Newton's method;
its error is ``eps^2 / (4 s)``, 2.5e-7 of the static deflection at eps = 1e-3). The first term is
the drive flank (no force where the teeth separate), the second the back flank beyond the backlash;
the mesh damping acts while one of them is in contact (``h'``, a smooth step from 0 to 1).
In the quasi-static limit ``F = W`` and ``x = e + W / k = e + delta``: the loaded TE
``TE_loaded = -x / l_2`` of the loaded TCA, exactly at its positions. ``c_m = 2 zeta sqrt(k_mean
m_e)``, ``m_e = (l_1^2/J_1 + l_2^2/J_2)^-1``; shafts ``c_s = 2 zeta sqrt(k_s J_a J_b / (J_a + J_b))``.

Periodic steady state
---------------------
Time is scaled to the mesh phase (``tau = phi``, period ``2 pi``) and each coordinate by its static
value, so one integrator (CasADi CVODES) serves every speed with ``omega_m`` as a parameter; the
period-1 steady state solves ``Phi(y0; omega_m) - y0 = 0`` (shooting) by Newton's method, the
Jacobian ``M - I`` from the monodromy matrix ``M = dPhi/dy0`` integrated with the state as the
variational equations (:meth:`GearDynamics.flow`); M at the solution gives the Floquet multipliers. A speed sweep continues from the
previous speed's solution, upward and downward: where the two branches differ both are reported
(the jump of the softening response with contact loss).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..errors import ConvergenceError, OptionError, check_number, out_of_range

#: CVODES options of the smooth peak's derivatives: forward sensitivities under the error control (the
#: adjoint's interpolated backward solve missed 7e-5 of the derivative in the load at contact loss)
SENS_OPTS: dict = {"fsens_err_con": True, "ad_weight": 0.0}
JUMP_PERIODS = 60  #: mesh periods the motion is integrated on at most where a branch ends (GearDynamics.jump)
JUMP_EVERY = 10  #: ... trying the shooting every this many periods
RHO_STEEL = 7830.0  #: density of steel [kg/m^3] (ISO 6336-1 method B's solid-disc masses)


def solid_disc_inertia(r_a: float, r_f: float, b: float, rho: float = RHO_STEEL) -> float:
    """Rotary inertia [kg m^2] of a gear body as a solid disc of the mean diameter ``(d_a + d_f) / 2``
    (ISO 6336-1:2019, 6.5.9, the masses of the resonance speed), face width ``b``.

    Parameters
    ----------
    r_a, r_f : float
        Tip and root radius [mm].
    b : float
        Face width [mm].
    rho : float
        Density [kg/m^3].
    """
    r = 0.5 * (r_a + r_f) * 1e-3
    return 0.5 * rho * math.pi * r**4 * b * 1e-3


def _positive(name: str, v: float, what: str) -> float:
    v = check_number(name, v, what, cls=OptionError)
    if not v > 0:
        raise out_of_range(name, v, f"{name} > 0 ({what})", cls=OptionError)
    return v


@dataclass(frozen=True)
class DriveTrain:
    """Inertias, levers, shafts and damping of the torsional model (SI units).

    Parameters
    ----------
    J_pinion, J_gear : float
        Rotary inertias of pinion and gear [kg m^2], > 0.
    l_pinion, l_gear : float
        Levers of the normal mesh force ``r_b cos(beta_b)`` [m], > 0.
    zeta : float
        Damping ratio of the mesh (and of the shafts), 0 <= zeta < 1.
    J_drive, J_load : float or None
        Drive (motor) and load inertias [kg m^2]; each with its shaft stiffness.
    k_drive, k_load : float or None
        Torsional stiffness of the drive and load shafts [N m/rad].
    backlash : float
        Backlash along the line of action [m] (the back flanks meet beyond it), > 0.
    """

    J_pinion: float
    J_gear: float
    l_pinion: float
    l_gear: float
    zeta: float = 0.05
    J_drive: float | None = None
    k_drive: float | None = None
    J_load: float | None = None
    k_load: float | None = None
    backlash: float = 1e-4

    def __post_init__(self) -> None:
        _positive("inertia_pinion", self.J_pinion, "pinion inertia [kg m^2]")
        _positive("inertia_gear", self.J_gear, "gear inertia [kg m^2]")
        _positive("l_pinion", self.l_pinion, "lever r_b1 cos(beta_b) [m]")
        _positive("l_gear", self.l_gear, "lever r_b2 cos(beta_b) [m]")
        z = check_number("damping", self.zeta, "the damping ratio", cls=OptionError)
        if not 0.0 <= z < 1.0:
            raise out_of_range("damping", z, "0 <= damping < 1 (a damping ratio)", cls=OptionError)
        _positive("backlash", self.backlash, "backlash along the line of action [m]")
        for side in ("drive", "load"):
            J, k = getattr(self, f"J_{side}"), getattr(self, f"k_{side}")
            if (J is None) != (k is None):
                raise OptionError(f"inertia_{side} and shaft_stiffness_{side} go together: give both or neither "
                                  f"(got {J!r}, {k!r}).", param=f"inertia_{side}", value=J,
                                  valid="both or neither")
            if J is not None:
                _positive(f"inertia_{side}", J, f"{side} inertia [kg m^2]")
                _positive(f"shaft_stiffness_{side}", k, f"{side} shaft stiffness [N m/rad]")

    @property
    def m_e(self) -> float:
        """Equivalent mass of the pair along the line of action [kg]."""
        return 1.0 / (self.l_pinion**2 / self.J_pinion + self.l_gear**2 / self.J_gear)

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str], int]:
        """``A = B M^-1 B^T``, ``f = B M^-1 T`` per newton of mesh load (W = 1 N), the shaft
        stiffnesses and dampings (zeros for the mesh row), coordinate names and the mesh row."""
        J, names, rows = [], [], []
        n_u = 2 + (self.J_drive is not None) + (self.J_load is not None)
        i1 = 1 if self.J_drive is not None else 0
        i2 = i1 + 1
        if self.J_drive is not None:
            J.append(self.J_drive)
        J += [self.J_pinion, self.J_gear]
        if self.J_load is not None:
            J.append(self.J_load)
        T = np.zeros(n_u)  # external torques for W = 1 N
        T[0] = self.l_pinion
        T[-1] = -self.l_gear
        ks, cs = [], []
        if self.J_drive is not None:
            r = np.zeros(n_u)
            r[0], r[i1] = 1.0, -1.0
            rows.append(r), names.append("drive_shaft"), ks.append(self.k_drive)
            cs.append(2 * self.zeta * math.sqrt(self.k_drive * self.J_drive * self.J_pinion / (self.J_drive + self.J_pinion)))
        r = np.zeros(n_u)
        r[i1], r[i2] = self.l_pinion, -self.l_gear
        mesh = len(rows)
        rows.append(r), names.append("mesh"), ks.append(0.0), cs.append(0.0)
        if self.J_load is not None:
            r = np.zeros(n_u)
            r[i2], r[-1] = 1.0, -1.0
            rows.append(r), names.append("load_shaft"), ks.append(self.k_load)
            cs.append(2 * self.zeta * math.sqrt(self.k_load * self.J_gear * self.J_load / (self.J_gear + self.J_load)))
        B = np.array(rows)
        Minv = np.diag(1.0 / np.array(J))
        return B @ Minv @ B.T, B @ Minv @ T, np.array([ks, cs]), names, mesh


def fourier_series(v: npt.ArrayLike, H: int) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients ``(a_0 ... a_H, b_1 ... b_H)`` of the trigonometric interpolation
    ``a_0 + sum_h a_h cos(h phi) + b_h sin(h phi)`` of ``N`` equally spaced samples over one cycle
    (``phi_j = 2 pi j / N``) along axis 0 (linear in the samples: the same map takes their tangents)."""
    v = np.asarray(v, float)
    N = v.shape[0]
    c = np.fft.rfft(v, axis=0) / N
    return np.concatenate([c[:1].real, 2 * c[1:H + 1].real]), -2 * c[1:H + 1].imag


@dataclass(frozen=True)
class MeshExcitation:
    """Mesh stiffness k(phi) [N/m] and unloaded TE e(phi) [m along the line of action] over one mesh
    cycle as Fourier series ``a_0 + sum_h a_h cos(h phi) + b_h sin(h phi)``, and the static mesh
    load W [N].

    Build it from samples (:meth:`from_samples`, e.g. the loaded TCA's) or give the coefficients
    (the validation cases: constant k and sinusoidal e, or k0 (1 + eps cos phi) and e = 0).
    """

    k_cos: np.ndarray
    k_sin: np.ndarray
    e_cos: np.ndarray
    e_sin: np.ndarray
    W: float

    def __post_init__(self) -> None:
        for n in ("k_cos", "k_sin", "e_cos", "e_sin"):
            object.__setattr__(self, n, np.asarray(getattr(self, n), float).ravel())
        H = len(self.k_cos) - 1
        if len(self.k_sin) != H or len(self.e_cos) != H + 1 or len(self.e_sin) != H:
            raise OptionError("k_cos/e_cos need H+1 and k_sin/e_sin H coefficients", param="excitation")
        if not self.k_cos[0] > 0:
            raise out_of_range("mesh stiffness", self.k_cos[0], "a mean mesh stiffness > 0 N/m", cls=OptionError)
        if not (math.isfinite(self.W) and self.W >= 0):
            raise out_of_range("W", self.W, "a static mesh load >= 0 N", cls=OptionError)

    @property
    def harmonics(self) -> int:
        return len(self.k_sin)

    @classmethod
    def from_samples(cls, k: npt.ArrayLike, e: npt.ArrayLike, W: float, harmonics: int | None = None) -> MeshExcitation:
        """Trigonometric interpolation of equally spaced samples over one cycle (``phi_j = 2 pi j /
        N``): with ``harmonics`` = None all up to ``(N-1)//2`` (the series passes through every
        sample).

        Parameters
        ----------
        k : (N,) mesh stiffness [N/m]; e : (N,) unloaded TE along the line of action [m]; W : [N].
        """
        k, e = np.asarray(k, float), np.asarray(e, float)
        N = len(k)
        H = (N - 1) // 2 if harmonics is None else int(harmonics)
        if not 0 <= H <= (N - 1) // 2:
            raise out_of_range("harmonics", H, f"0 <= harmonics <= {(N - 1) // 2} (half the positions)", cls=OptionError)

        kc, ks = fourier_series(k, H)
        ec, es = fourier_series(e, H)
        return cls(kc, ks, ec, es, float(W))

    def evaluate(self, phi: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """k(phi) [N/m] and e(phi) [m] at mesh phases ``phi`` [rad]."""
        phi = np.asarray(phi, float)
        h = np.arange(1, self.harmonics + 1)
        C, S = np.cos(np.multiply.outer(phi, h)), np.sin(np.multiply.outer(phi, h))
        return self.k_cos[0] + C @ self.k_cos[1:] + S @ self.k_sin, self.e_cos[0] + C @ self.e_cos[1:] + S @ self.e_sin

    def params(self) -> np.ndarray:
        """The coefficients as one vector (the CasADi parameters after omega_m)."""
        return np.r_[self.W, self.k_cos, self.k_sin, self.e_cos, self.e_sin]


@dataclass
class PeriodicSolution:
    """Period-1 steady state at one speed.

    Attributes
    ----------
    speed_rpm : pinion speed; omega_m : mesh frequency [rad/s].
    y0 : scaled initial state; converged : Newton reached its tolerance; residual : |Phi(y0) - y0|.
    phi : (N,) mesh phase [rad]; x : (N,) mesh coordinate [m]; force : (N,) dynamic mesh force [N]
    (stiffness and damping terms of (2)); gap : (N,) ``x - e`` [m] (< 0: the teeth separate).
    multipliers : Floquet multipliers (complex) or None.
    jumped : the continuation lost its branch here (a fold) and the solution was found by integrating
        the motion on from the previous speed's steady state (the jump a sweep makes, :meth:`GearDynamics.jump`).
    """

    speed_rpm: float
    omega_m: float
    y0: np.ndarray
    converged: bool
    residual: float
    phi: np.ndarray
    x: np.ndarray
    force: np.ndarray
    gap: np.ndarray
    multipliers: np.ndarray | None = None
    jumped: bool = False

    def contact_loss(self) -> bool:
        """Whether the drive flanks separate somewhere in the cycle (gap < 0)."""
        return bool(np.min(self.gap) < 0.0)

    def back_flank(self, backlash: float) -> bool:
        """Whether the back flanks meet somewhere in the cycle (gap < -backlash [m])."""
        return bool(np.min(self.gap) < -backlash)


@dataclass
class SpeedSweep:
    """Up and down continuation over speed: ``up[i]`` and ``down[i]`` at ``speeds_rpm[i]``."""

    speeds_rpm: np.ndarray
    up: list[PeriodicSolution] = field(default_factory=list)
    down: list[PeriodicSolution] = field(default_factory=list)
    time_s: float = 0.0


def sdof_response(k: float, m: float, c: float, e_amp: float, omega: float) -> tuple[float, float]:
    """Closed-form steady state of ``m x'' + c x' + k (x - e_amp cos(omega t)) = W``: the amplitude
    [m] and phase lag [rad] of ``x - W/k = X cos(omega t - psi)``:
    ``X = k e_amp / sqrt((k - m omega^2)^2 + (c omega)^2)``, ``psi = atan2(c omega, k - m omega^2)``."""
    return (k * e_amp / math.hypot(k - m * omega**2, c * omega), math.atan2(c * omega, k - m * omega**2))


class GearDynamics:
    """The periodic steady state of a gear pair driven by its mesh (module docstring, (1)-(2)).

    Parameters
    ----------
    train : DriveTrain
    excitation : MeshExcitation
    z1 : int
        Pinion teeth (mesh frequency ``z1 n / 60`` Hz at pinion speed n [rpm]).
    smoothing : float
        eps of the smoothed max over the static deflection ``W / k_mean`` (0 < smoothing <= 0.1).
    contact_loss : bool
        False: a linear mesh ``F = k (x - e) + c x'`` (the teeth never separate; validation).
    samples : int
        Points per mesh cycle of the reported force and TE.
    tol : float
        Relative and absolute tolerance of CVODES (scaled states).
    newton_tol : float
        Tolerance of the shooting residual ``|Phi(y0) - y0|`` (scaled states; above ``tol``).
    """

    def __init__(self, train: DriveTrain, excitation: MeshExcitation, z1: int, smoothing: float = 1e-3,
                 contact_loss: bool = True, samples: int = 128, tol: float = 1e-10,
                 newton_tol: float = 1e-8) -> None:
        if not 0 < smoothing <= 0.1:
            raise out_of_range("smoothing", smoothing, "0 < smoothing <= 0.1", cls=OptionError)
        self.train, self.exc, self.z1 = train, excitation, int(z1)
        self.newton_tol = float(newton_tol)
        self.contact_loss, self.samples = bool(contact_loss), int(samples)
        A, f, kc, names, mesh = train.matrices()
        self.A, self.f, self.names, self.mesh = A, f, names, mesh
        n = len(names)
        self.n = n
        W = excitation.W
        k0 = float(excitation.k_cos[0])
        self.k_mean = k0
        self.c_mesh = 2 * train.zeta * math.sqrt(k0 * train.m_e)
        # static deflections of each coordinate (the scales): the mesh W/k0, a shaft its torque / k_s
        x_ref = W / k0 if W > 0 else 1e-6
        ref = np.array([x_ref if i == mesh else (W * (train.l_pinion if names[i] == "drive_shaft" else train.l_gear)
                                                 / kc[0, i] if W > 0 else 1e-3) for i in range(n)])
        self.ref = ref
        H = excitation.harmonics
        self.H = H
        tau = ca.SX.sym("tau")
        y = ca.SX.sym("y", 2 * n)
        om = ca.SX.sym("omega_m")
        P = ca.SX.sym("P", 1 + 2 * (2 * H + 1))
        self.n_p = P.numel()
        Wp = P[0]
        kcs, kss = P[1:H + 2], P[H + 2:2 * H + 2]
        ecs, ess = P[2 * H + 2:3 * H + 3], P[3 * H + 3:4 * H + 3]
        hh = ca.DM(np.arange(1, H + 1))
        Ct, St = ca.cos(hh * tau), ca.sin(hh * tau)
        k = kcs[0] + ca.dot(kcs[1:], Ct) + ca.dot(kss, St) if H else kcs[0]
        e = ecs[0] + ca.dot(ecs[1:], Ct) + ca.dot(ess, St) if H else ecs[0]
        q = y[:n] * ref
        qd = om * y[n:] * ref  # d/dt = omega_m d/dtau
        # the mesh damping c_m = 2 zeta sqrt(k_mean m_e) and the smoothing width eps = smoothing W / k_mean
        # follow the parameters' mean stiffness and load (exactly the model's own values at its own
        # parameters): a derivative with respect to P is that of the model built from the displaced
        # excitation (section 7 of docs/dynamics.md)
        c_fac = ca.sqrt(kcs[0] / k0)  # c_m / self.c_mesh: exactly 1 at the model's own parameters
        eps = smoothing * (Wp / kcs[0]) if W > 0 else smoothing * x_ref
        g = []
        for i in range(n):
            if i == mesh:
                s = q[i] - e
                if self.contact_loss:
                    hpos = 0.5 * (s + ca.sqrt(s**2 + eps**2))
                    sb = -s - train.backlash
                    hneg = 0.5 * (sb + ca.sqrt(sb**2 + eps**2))
                    # the damping acts only while a flank pair is in contact: the smooth steps h'(s)
                    on = 0.5 * (1 + s / ca.sqrt(s**2 + eps**2)) + 0.5 * (1 + sb / ca.sqrt(sb**2 + eps**2))
                    F = k * (hpos - hneg) + self.c_mesh * qd[i] * on * c_fac
                else:
                    F = k * s + self.c_mesh * qd[i] * c_fac
                g.append(F)
                Fm, gap = F, s
            else:
                g.append(kc[0, i] * q[i] + kc[1, i] * qd[i])
        acc = ca.DM(f) * Wp - ca.mtimes(ca.DM(A), ca.vertcat(*g))
        ydot = ca.vertcat(y[n:], acc / (om**2) / ca.DM(ref))
        p_all = ca.vertcat(om, P)
        self._out = ca.Function("out", [tau, y, p_all], [q[mesh], Fm, gap])
        dae = {"x": y, "p": p_all, "t": tau, "ode": ydot}
        opts = {"abstol": tol, "reltol": tol, "max_num_steps": 200000}
        self._dae, self._opts = dae, opts
        self._flow = ca.integrator("flow", "cvodes", dae, 0.0, 2 * math.pi, opts)
        grid = np.linspace(0, 2 * math.pi, self.samples + 1)[1:]
        self._grid = ca.integrator("grid", "cvodes", dae, 0.0, list(grid), opts)
        # the variational equations dPhi/dtau = (d ydot / dy) Phi, Phi(0) = I, integrated with the state:
        # one CVODES call gives Phi(y0) and the monodromy matrix (cheaper than forward sensitivities)
        Phi = ca.SX.sym("Phi", 2 * n, 2 * n)
        var = ca.mtimes(ca.jacobian(ydot, y), Phi)
        dae_v = {"x": ca.vertcat(y, ca.vec(Phi)), "p": p_all, "t": tau, "ode": ca.vertcat(ydot, ca.vec(var))}
        self._var = ca.integrator("variational", "cvodes", dae_v, 0.0, 2 * math.pi, opts)
        self._p = excitation.params()
        self._ks: dict[int, ca.Function] = {}

    # --------------------------------------------------------------------------------------
    def omega_mesh(self, speed_rpm: float) -> float:
        """Mesh angular frequency [rad/s] at pinion speed [rpm]."""
        return 2 * math.pi * speed_rpm / 60.0 * self.z1

    def natural_frequencies(self) -> np.ndarray:
        """Undamped natural frequencies [Hz] of the model linearised at the mean mesh stiffness."""
        K = np.diag([self.k_mean if i == self.mesh else self.train.matrices()[2][0, i] for i in range(self.n)])
        lam = np.linalg.eigvals(self.A @ K)
        return np.sort(np.sqrt(np.abs(lam.real))) / (2 * math.pi)

    def static_guess(self) -> np.ndarray:
        """Scaled state of the static deflection at the mean stiffness (zero velocities)."""
        K = np.diag([self.k_mean if i == self.mesh else self.train.matrices()[2][0, i] for i in range(self.n)])
        q = np.linalg.solve(self.A @ K, self.f * self.exc.W)
        q[self.mesh] += self.exc.e_cos[0]
        return np.r_[q / self.ref, np.zeros(self.n)]

    def solve(self, speed_rpm: float, guess: npt.ArrayLike | None = None, floquet: bool = False,
              params: npt.ArrayLike | None = None, restart: bool = True) -> PeriodicSolution:
        """The period-1 steady state at pinion speed ``speed_rpm`` [rpm] (> 0) from ``guess`` (a
        scaled state; default the static one; ``restart``: from the static one too when ``guess``
        fails); ``floquet``: also the Floquet multipliers."""
        om = self.omega_mesh(_positive("speed", speed_rpm, "pinion speed [rpm]"))
        p = np.r_[om, self._p if params is None else np.asarray(params, float)]
        y0 = self.static_guess() if guess is None else np.asarray(guess, float)
        sol, res = self.shoot(y0, p)
        ok = bool(np.all(np.isfinite(sol)) and res < self.newton_tol)
        if not ok and guess is not None and restart:  # continuation lost the branch: from the static state
            return self.solve(speed_rpm, None, floquet, params)
        return self._fill(speed_rpm, om, sol, ok, res, p, floquet)

    def flow(self, y0: npt.ArrayLike, p: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``Phi(y0)`` after one mesh period and the monodromy matrix ``dPhi/dy0`` (scaled states;
        ``p`` = (omega_m, :meth:`MeshExcitation.params`))."""
        m = 2 * self.n
        r = np.array(self._var(x0=np.r_[np.asarray(y0, float), np.eye(m).ravel(order="F")], p=p)["xf"]).ravel()
        return r[:m], r[m:].reshape((m, m), order="F")

    def shoot(self, y0: npt.ArrayLike, p: npt.ArrayLike, max_iter: int = 12) -> tuple[np.ndarray, float]:
        """Newton's method on ``G(y0) = Phi(y0) - y0 = 0`` with the Jacobian ``M - I`` (M the
        monodromy matrix), each step halved until the residual falls; returns ``(y0, max|G|)``."""
        y = np.asarray(y0, float).copy()
        try:
            yT, M = self.flow(y, p)
        except RuntimeError:
            return y, math.inf
        G = yT - y
        res = float(np.max(np.abs(G)))
        I = np.eye(len(y))
        for _ in range(max_iter):
            if res < self.newton_tol:
                break
            try:
                dy = np.linalg.solve(M - I, -G)
            except np.linalg.LinAlgError:
                return y, math.inf
            t = 1.0
            while t > 0.03:
                yn = y + t * dy
                try:
                    yTn, Mn = self.flow(yn, p)
                    Gn = yTn - yn
                    rn = float(np.max(np.abs(Gn)))
                except RuntimeError:
                    rn = math.inf
                if np.isfinite(rn) and rn < (1 - 0.25 * t) * res:
                    break
                t *= 0.5
            else:
                return y, res
            y, G, M, res = yn, Gn, Mn, rn
        return y, res

    def peak_sensitivity(self, sol: PeriodicSolution) -> np.ndarray:
        """d K_v / d P: the derivative of the dynamic factor ``max_k F(phi_k) / W`` (the largest of the
        solution's samples) with respect to the excitation's parameters ``P`` =
        :meth:`MeshExcitation.params` (W, then the Fourier coefficients of k [N/m] and e [m]), by AD
        through the periodic solution: with ``G(y0, P) = Phi(y0, P) - y0 = 0`` the implicit-function
        theorem gives ``dy0/dP = -G_y^-1 G_P`` (integrator sensitivities), and the force at the peak
        sample ``F(Phi_k(y0, P), P)`` is differentiated along it (the peak's sample held: the
        derivative of the sampled maximum wherever that sample stays the largest).

        Parameters
        ----------
        sol : PeriodicSolution
            A converged solution of this model (at its speed, with the model's own parameters).
        """
        check_converged(sol)
        k = int(np.argmax(sol.force))
        y0 = ca.MX.sym("y0", 2 * self.n)
        P = ca.MX.sym("P", self.n_p)
        pa = ca.vertcat(sol.omega_m, P)
        if k == 0:
            yk = y0
        else:
            to_peak = ca.integrator("to_peak", "cvodes", self._dae, 0.0, float(sol.phi[k]), self._opts)
            yk = to_peak(x0=y0, p=pa)["xf"]
        F = self._out(float(sol.phi[k]), yk, pa)[1]
        Kv = F / P[0]
        G = self._flow(x0=y0, p=pa)["xf"] - y0
        fn = ca.Function("dKv", [y0, P], [ca.jacobian(Kv, y0), ca.jacobian(Kv, P), ca.jacobian(G, y0),
                                          ca.jacobian(G, P)])
        Ky, KP, Gy, GP = (np.array(v) for v in fn(sol.y0, self._p))
        return (KP - Ky @ np.linalg.solve(Gy, GP)).ravel()

    def smooth_peak(self, sol: PeriodicSolution, rho: float = 50.0,
                    directions: npt.ArrayLike | None = None) -> tuple[float, np.ndarray, float]:
        """A smooth peak of the dynamic factor over the cycle and its derivative with respect to the
        excitation's parameters ``P`` (:meth:`MeshExcitation.params`), by AD through the periodic solution.

        ``K~ = (1/rho) ln( (1/N) sum_k exp(rho F(phi_k) / W) )`` over the solution's ``N`` samples (the
        Kreisselmeier-Steinhauser aggregate: ``max F/W - ln(N)/rho <= K~ <= max F/W``, smooth where the
        sampled maximum is not). With ``G(y0, P) = Phi(y0, P) - y0 = 0`` the implicit-function theorem
        gives ``dy0/dP = -G_y^-1 G_P``; the samples ``F(Phi_k(y0, P), P)`` are differentiated along it
        (forward sensitivities of CVODES through CasADi). The mesh damping and the smoothing width follow
        the mean stiffness and the load in ``P`` (the derivative is that of a model built from the
        displaced excitation).

        Parameters
        ----------
        sol : PeriodicSolution
            A converged solution of this model (its own parameters).
        rho : float
            Aggregation parameter (> 0) [1 per unit of K_v].
        directions : (n_p, m) array, optional
            Directions in P (e.g. ``dP/d(amount)``): the derivative along each (m forward sensitivities
            instead of n_p); default every parameter.

        Returns
        -------
        (K~, dK~ (n_p,) or (m,), sigma_min)
            ``sigma_min``: the smallest singular value of ``G_y = M - I`` (near 0 at a fold of the
            branch, where the derivative does not exist).
        """
        check_converged(sol)
        rho = _positive("rho", rho, "the aggregation parameter")
        D = np.eye(self.n_p) if directions is None else np.asarray(directions, float).reshape(self.n_p, -1)
        m_dir = D.shape[1]
        if m_dir not in self._ks:
            m = 2 * self.n
            y0, P, om, c, r = (ca.MX.sym(v, k) for v, k in (("y0", m), ("P", self.n_p), ("om", 1), ("c", 1),
                                                              ("rho", 1)))
            Dm = ca.MX.sym("D", self.n_p, m_dir)
            pa = ca.vertcat(om, P)
            opts = dict(self._opts, **SENS_OPTS)
            grid = ca.integrator("grid_s", "cvodes", self._dae, 0.0,
                                 list(np.linspace(0, 2 * math.pi, self.samples + 1)[1:]), opts)
            flow = ca.integrator("flow_s", "cvodes", self._dae, 0.0, 2 * math.pi, opts)
            Y = grid(x0=y0, p=pa)["xf"]
            cols = ca.horzcat(y0, Y[:, :-1])
            phi = np.linspace(0, 2 * math.pi, self.samples + 1)[:-1]
            F = self._out.map(self.samples)(ca.DM(phi).T, cols, ca.repmat(pa, 1, self.samples))[1]
            Kt = c + ca.log(ca.sum2(ca.exp(r * (F / P[0] - c))) / self.samples) / r
            G = flow(x0=y0, p=pa)["xf"] - y0
            self._ks[m_dir] = ca.Function("smooth_peak", [y0, P, om, c, r, Dm],
                                          [Kt, ca.jacobian(Kt, y0), ca.jtimes(Kt, P, Dm), ca.jacobian(G, y0),
                                           ca.jtimes(G, P, Dm)])
        Kt, Ky, KD, Gy, GD = (np.array(v) for v in self._ks[m_dir](
            sol.y0, self._p, sol.omega_m, float(sol.force.max() / self._p[0]), rho, D))
        sig = float(np.linalg.svd(Gy, compute_uv=False)[-1])
        return float(Kt.item()), (KD - Ky @ np.linalg.solve(Gy, GD)).ravel(), sig

    def _fill(self, speed, om, y0, ok, res, p, floquet) -> PeriodicSolution:
        phi = np.linspace(0, 2 * math.pi, self.samples + 1)[:-1]
        if ok:
            Y = np.array(self._grid(x0=y0, p=p)["xf"])
            Y = np.column_stack([y0, Y[:, :-1]])
            out = self._out.map(self.samples)(phi, Y, p)
            x, F, gap = (np.array(o).ravel() for o in out)
        else:
            x = F = gap = np.full(self.samples, np.nan)
        mult = np.linalg.eigvals(self.flow(y0, p)[1]) if (floquet and ok) else None
        return PeriodicSolution(speed, om, y0, ok, res, phi, x, F, gap, mult)

    def monodromy(self, speed_rpm: float, y0: npt.ArrayLike) -> np.ndarray:
        """``dPhi/dy0`` over one mesh period from the scaled state ``y0`` (integrator Jacobian)."""
        p = np.r_[self.omega_mesh(speed_rpm), self._p]
        return self.flow(y0, p)[1]

    def _branch(self, speeds: np.ndarray, start: PeriodicSolution | None = None) -> list[PeriodicSolution]:
        """Natural continuation over ``speeds`` from ``start`` (the secant predictor of :func:`_secant`;
        a failed predictor falls back to the last solution, then to the static state)."""
        out: list[PeriodicSolution] = [] if start is None else [start]
        for v in speeds:
            g = _secant(out, float(v))
            # past a failed speed the static state failed already: no second restart in a row
            r = self.solve(float(v), g, restart=not out or out[-1].converged)
            if not r.converged:
                last = next((q for q in reversed(out) if q.converged), None)
                if last is not None:  # the branch ended at a fold: jump as the running drive does
                    j = self.jump(float(v), last.y0)
                    r = j if j.converged else r
            out.append(r)
        return out[1:] if start is not None else out

    def jump(self, speed_rpm: float, y0: npt.ArrayLike, periods: int = JUMP_PERIODS,
             every: int = JUMP_EVERY) -> PeriodicSolution:
        """The steady state the motion settles on at ``speed_rpm`` [rpm] from the state ``y0`` (scaled;
        e.g. the previous speed's steady state where its branch ends at a fold): the flow integrated on,
        mesh period by mesh period (the transient of the jump), with Newton's method on the shooting
        condition tried from it every ``every`` periods, at most ``periods`` periods. The solution is
        marked ``jumped``; not converged when no attempt converged."""
        om = self.omega_mesh(_positive("speed", speed_rpm, "pinion speed [rpm]"))
        p = np.r_[om, self._p]
        y = np.asarray(y0, float).copy()
        sol, res = y, math.inf
        for k in range(1, periods + 1):
            try:
                y = self.flow(y, p)[0]
            except RuntimeError:
                break
            if not np.all(np.isfinite(y)):
                break
            if k % every == 0:
                sol, res = self.shoot(y, p)
                if np.all(np.isfinite(sol)) and res < self.newton_tol:
                    out = self._fill(speed_rpm, om, sol, True, res, p, False)
                    out.jumped = True
                    return out
        return self._fill(speed_rpm, om, sol, False, res, p, False)

    def sweep(self, speeds_rpm: Sequence[float], progress: Callable[[str], None] | None = None,
              both: bool = True) -> SpeedSweep:
        """Continuation over ``speeds_rpm`` (increasing, each > 0) upward, and downward when ``both``."""
        import time

        s = np.asarray(speeds_rpm, float)
        if s.size == 0 or not np.all(s > 0):
            raise out_of_range("speeds", s.tolist()[:3], "pinion speeds > 0 rpm", cls=OptionError)
        t0 = time.perf_counter()
        out = SpeedSweep(s)
        out.up = self._branch(s)
        if progress:
            progress(f"dynamics: upward sweep of {len(s)} speeds done")
        if both:
            out.down = self._branch(s[::-1], out.up[-1] if out.up[-1].converged else None)[::-1]
            # a branch that ends at a fold (no solution nearby, none from the static state) continues
            # on the other branch's solution at that speed: the jump of a sweep in that direction
            for a, b in ((out.up, out.down), (out.down, out.up)):
                for i, r in enumerate(a):
                    if not r.converged and b[i].converged:
                        a[i] = self.solve(float(s[i]), b[i].y0)
        out.time_s = time.perf_counter() - t0
        return out


def _secant(prev: list[PeriodicSolution], v: float) -> np.ndarray | None:
    """The continuation's guess at speed ``v``: the last solution, or the secant through the last two."""
    ok = [r for r in prev[-2:] if r.converged]
    if not ok:
        return None
    if len(ok) == 1 or len(prev) < 2 or not prev[-2].converged or prev[-1].jumped:
        return ok[-1].y0  # (the secant through a jump would join two branches)
    a, b = prev[-2], prev[-1]
    if b.speed_rpm == a.speed_rpm:
        return b.y0
    return b.y0 + (b.y0 - a.y0) * (v - b.speed_rpm) / (b.speed_rpm - a.speed_rpm)


def check_converged(sol: PeriodicSolution) -> PeriodicSolution:
    """``sol``, or :class:`ConvergenceError` when its shooting did not converge."""
    if not sol.converged:
        raise ConvergenceError(f"no periodic steady state found at {sol.speed_rpm:g} rpm "
                               f"(shooting residual {sol.residual:.3g})", param="speed", value=sol.speed_rpm)
    return sol
