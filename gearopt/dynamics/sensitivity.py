"""Sensitivities of the dynamic response over a speed range to the micro-geometry amounts, by AD
(docs/dynamics.md section 7): the objective a later optimiser minimises and its gradient per um of
each amount.

Chain: amounts -> the loaded TCA's mesh stiffness k(phi) and unloaded TE e(phi)
(:func:`gearopt.ltca.tangent.loaded_tangents`, implicit differentiation of the contact solution) ->
their Fourier coefficients P (a linear map, :func:`excitation_tangent`) -> at each speed of the sweep
the smooth peak of the dynamic factor ``K~_j`` (:meth:`GearDynamics.smooth_peak`, the implicit-function
theorem on the shooting equations) -> the objective over the speeds:

* ``aggregate = "ks"``: ``J = (1/rho) ln( (1/S) sum_j exp(rho K~_j) )``, a smooth maximum of K_v over the
  speed range (``max_j K~_j - ln(S)/rho <= J <= max_j K~_j``);
* ``aggregate = "mean"``: ``J = (1/S) sum_j K~_j``, the mean peak dynamic factor over the speeds.

Speeds whose shooting did not converge are left out of J and reported (``excluded_speeds_rpm``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
import numpy.typing as npt

from ..errors import OptionError, out_of_range
from .model import fourier_series

if TYPE_CHECKING:
    from ..gears import GearPair
    from ..ltca.compliance import Material
    from ..ltca.tangent import LoadedTangent
    from ..meshing.misalignment import Misalignment
    from .drive import LoadedMesh
    from .model import PeriodicSolution
    from .settings import DynamicsSettings

AGGREGATES = ("ks", "mean")
BRANCHES = ("up", "down", "both")
FOLD_SIGMA = 1e-6  #: smallest singular value of M - I below which a speed counts as at a fold (flagged)


def excitation_tangent(mesh: LoadedMesh, tangent: LoadedTangent, harmonics: int | None = None) -> np.ndarray:
    """``dP/d(amount)`` (n_p, P) per um of each amount: P = :meth:`MeshExcitation.params` of
    ``mesh.excitation(harmonics)`` (W, then the Fourier coefficients of k [N/m] and of
    ``e = -TE_unloaded l_2`` [m]); the static load does not depend on the amounts."""
    N = len(mesh.stiffness)
    H = (N - 1) // 2 if harmonics is None else int(harmonics)
    dk = np.asarray(tangent.d_stiffness, float) * 1e6  # N/m per um
    de = -np.asarray(tangent.d_te_unloaded, float) * mesh.lever_gear  # m per um
    kc, ks = fourier_series(dk, H)
    ec, es = fourier_series(de, H)
    return np.vstack([np.zeros((1, dk.shape[1])), kc, ks, ec, es])


def smooth_peaks(forces: Sequence[npt.ArrayLike], W: float, rho: float) -> np.ndarray:
    """``K~_j = (1/rho) ln( (1/N) sum_k exp(rho F_jk / W) )`` of each sampled force cycle ``F_j`` [N]
    (the value :meth:`GearDynamics.smooth_peak` differentiates)."""
    out = []
    for F in forces:
        k = np.asarray(F, float) / W
        m = float(k.max())
        out.append(m + math.log(float(np.mean(np.exp(rho * (k - m))))) / rho)
    return np.array(out)


def aggregate_objective(kt: npt.ArrayLike, rho: float, aggregate: str = "ks") -> tuple[float, np.ndarray]:
    """The objective over speeds of the smooth peaks ``kt`` (S,) and its weights ``dJ/dK~_j``."""
    kt = np.asarray(kt, float)
    if aggregate == "mean":
        return float(kt.mean()), np.full(kt.size, 1.0 / kt.size)
    m = float(kt.max())
    e = np.exp(rho * (kt - m))
    return m + math.log(float(e.mean())) / rho, e / e.sum()


@dataclass
class SpeedRangeSensitivity:
    """The objective over a speed range and its gradient per um of each amount
    (:func:`speed_range_sensitivity`).

    Attributes
    ----------
    names : the amounts (``"pinion.C_alpha_a"`` ...).
    objective : J (module docstring); gradient : (P,) dJ/d(amount) [per um].
    speeds_rpm : (S,) the speeds in J; branch : per speed, "up" or "down".
    K_v : (S,) the sampled peak dynamic factor; K_v_smooth : (S,) K~_j; dK_v_smooth : (S, P) per um.
    sigma_min : (S,) smallest singular value of the shooting Jacobian M - I (near 0: a fold).
    at_fold_speeds_rpm : speeds with ``sigma_min < FOLD_SIGMA`` (the derivative does not exist there).
    excluded_speeds_rpm : speeds of the sweep left out (not converged).
    kink_positions : per amount, the loaded TCA's positions [index] where the unloaded TE has a kink
        (:attr:`LoadedTangent.te0_kink`); margin_um : per amount, the smallest active-set margin of the
        loaded TCA over the cycle [um] (a finite-difference step beyond it straddles a kink).
    rho, aggregate : the objective's parameters; time_s : {"ltca_tangent", "sweep", "gradient"} [s].
    """

    names: tuple[str, ...]
    objective: float
    gradient: np.ndarray
    speeds_rpm: np.ndarray
    branch: list[str]
    K_v: np.ndarray
    K_v_smooth: np.ndarray
    dK_v_smooth: np.ndarray
    sigma_min: np.ndarray
    at_fold_speeds_rpm: list[float]
    excluded_speeds_rpm: list[float]
    kink_positions: dict[str, list[int]]
    margin_um: dict[str, float]
    rho: float
    aggregate: str
    time_s: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        """Plain numbers (gradient per um of amount)."""
        return {"names": list(self.names), "objective": self.objective,
                "gradient_per_um": dict(zip(self.names, self.gradient.tolist())),
                "speeds_rpm": self.speeds_rpm.tolist(), "branch": self.branch, "K_v": self.K_v.tolist(),
                "K_v_smooth": self.K_v_smooth.tolist(),
                "dK_v_smooth_per_um": {n: self.dK_v_smooth[:, i].tolist() for i, n in enumerate(self.names)},
                "sigma_min": self.sigma_min.tolist(), "at_fold_speeds_rpm": self.at_fold_speeds_rpm,
                "excluded_speeds_rpm": self.excluded_speeds_rpm, "kink_positions": self.kink_positions,
                "margin_um": self.margin_um, "rho": self.rho, "aggregate": self.aggregate, "time_s": self.time_s}


def pick_solutions(sweep: Any, branch: str) -> tuple[list[PeriodicSolution], list[str], list[float]]:
    """The converged solutions of a :class:`SpeedSweep` on ``branch`` ("up", "down" or "both"), their
    branches, and the speeds left out (not converged)."""
    if branch not in BRANCHES:
        raise out_of_range("branch", branch, f"one of {BRANCHES}", cls=OptionError)
    sols, brs, out = [], [], []
    for name in (("up", "down") if branch == "both" else (branch,)):
        for s in getattr(sweep, name):
            if s.converged:
                sols.append(s)
                brs.append(name)
            else:
                out.append(float(s.speed_rpm))
    return sols, brs, sorted(set(out))


def speed_range_sensitivity(pair: GearPair, torque: float, amounts: Sequence[str], speeds_rpm: npt.ArrayLike,
                            settings: DynamicsSettings | None = None, *, rho: float = 50.0, aggregate: str = "ks",
                            branch: str = "up", material: Material | None = None,
                            misalignment: Misalignment | None = None, inertias: dict | None = None,
                            tol: float = 1e-9, newton_tol: float = 1e-7, **options: Any) -> SpeedRangeSensitivity:
    """The smooth objective of the dynamic factor over ``speeds_rpm`` and its gradient per um of each
    micro-geometry amount, by AD (module docstring).

    Parameters
    ----------
    pair : GearPair; torque : pinion torque [N m].
    amounts : ``"<member>.<amount>"`` names (:func:`gearopt.ltca.tangent.amount_names`), e.g.
        ``"pinion.C_alpha_a"``.
    speeds_rpm : increasing pinion speeds [rpm] (> 0) of the sweep.
    settings : DynamicsSettings, optional
        ``damping``, ``backlash``, ``smoothing``, ``harmonics``, ``samples``, ``positions`` and the loaded
        TCA's options (keyword arguments replace its fields).
    rho : float
        Aggregation parameter [1 per unit of K_v] of the smooth peak over the cycle and of ``"ks"``.
    aggregate : "ks" (a smooth maximum over the speeds) or "mean" (the mean smooth peak).
    branch : "up", "down" or "both": the sweep's branch(es) whose converged solutions enter J.
    inertias : dict, optional
        ``J_pinion``, ``J_gear``, ``J_drive``, ``k_drive``, ``J_load``, ``k_load`` of
        :func:`gearopt.dynamics.drive.drive_train`.
    tol, newton_tol : CVODES's tolerance and the shooting residual's (scaled states).

    Raises
    ------
    OptionError
        Naming ``amounts``, ``aggregate``, ``branch``, ``rho``, ``speeds`` or ``torque``; ``speeds``
        also when no speed converged.
    """
    from ..ltca.tangent import loaded_tangents
    from .drive import drive_train, loaded_mesh_of
    from .model import GearDynamics
    from .settings import DynamicsSettings as Settings

    if aggregate not in AGGREGATES:
        raise out_of_range("aggregate", aggregate, f"one of {AGGREGATES}", cls=OptionError)
    if branch not in BRANCHES:
        raise out_of_range("branch", branch, f"one of {BRANCHES}", cls=OptionError)
    if not (isinstance(rho, (int, float)) and math.isfinite(rho) and rho > 0):
        raise out_of_range("rho", rho, "rho > 0 (1 per unit of K_v)", cls=OptionError)
    s = Settings.of(settings, **options)
    speeds = np.asarray(speeds_rpm, float).ravel()
    if speeds.size == 0 or not np.all(speeds > 0) or np.any(np.diff(speeds) <= 0):
        raise out_of_range("speeds", speeds.tolist()[:3], "increasing pinion speeds > 0 rpm", cls=OptionError)
    t0 = time.perf_counter()
    tg = loaded_tangents(pair, torque, amounts, settings=s, positions=s.positions, material=material,
                         misalignment=misalignment)
    lm = loaded_mesh_of(pair, tg.result)
    t1 = time.perf_counter()
    train = drive_train(pair, s.damping, s.backlash, **(inertias or {}))
    gd = GearDynamics(train, lm.excitation(s.harmonics), pair.pinion.z, smoothing=s.smoothing, samples=s.samples,
                      tol=tol, newton_tol=newton_tol)
    sw = gd.sweep(speeds, both=branch != "up")
    sols, brs, excluded = pick_solutions(sw, branch)
    if not sols:
        raise OptionError(f"speeds: no periodic steady state converged at any of the {speeds.size} speeds "
                          f"({speeds[0]:g} ... {speeds[-1]:g} rpm).", param="speeds", value=speeds.tolist()[:3],
                          valid="a speed range with converged steady states")
    t2 = time.perf_counter()
    dP = excitation_tangent(lm, tg, s.harmonics)
    kt, dkt, sig = [], [], []
    for sol in sols:
        k, g, sm = gd.smooth_peak(sol, rho, directions=dP)
        kt.append(k)
        dkt.append(g)
        sig.append(sm)
    kt, dkt, sig = np.array(kt), np.array(dkt), np.array(sig)
    J, w = aggregate_objective(kt, rho, aggregate)
    t3 = time.perf_counter()
    names = tg.names
    return SpeedRangeSensitivity(
        names=names, objective=J, gradient=w @ dkt, speeds_rpm=np.array([x.speed_rpm for x in sols]), branch=brs,
        K_v=np.array([float(x.force.max() / lm.W) for x in sols]), K_v_smooth=kt, dK_v_smooth=dkt, sigma_min=sig,
        at_fold_speeds_rpm=[float(x.speed_rpm) for x, v in zip(sols, sig) if v < FOLD_SIGMA],
        excluded_speeds_rpm=excluded,
        kink_positions={n: np.flatnonzero(tg.te0_kink[:, i]).tolist() for i, n in enumerate(names)},
        margin_um={n: float(np.min(tg.margin_um[:, i])) for i, n in enumerate(names)}, rho=float(rho),
        aggregate=aggregate, time_s={"ltca_tangent": t1 - t0, "sweep": t2 - t1, "gradient": t3 - t2},
        extra={"model": gd, "sweep": sw, "mesh": lm, "tangent": tg})
