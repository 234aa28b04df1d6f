"""The dynamic model of a :class:`~gearopt.gears.GearPair` from its loaded TCA (docs/dynamics.md):
the mesh stiffness and unloaded TE over the mesh cycle at the operating torque, the inertias of the
gear bodies, and ISO 6336-1's resonance speed from the same masses."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..errors import OptionError, out_of_range
from .model import DriveTrain, MeshExcitation, solid_disc_inertia

if TYPE_CHECKING:
    from ..gears import GearPair
    from ..ltca.compliance import Material
    from ..ltca.engine import LoadedResult
    from ..meshing.misalignment import Misalignment
    from ..settings import LTCASettings


@dataclass(frozen=True)
class LoadedMesh:
    """The loaded TCA at the operating torque as the dynamic model uses it.

    Attributes
    ----------
    phi1 : (N,) pinion angles over one mesh cycle [rad]; phase : (N,) mesh phase [rad], 0 ... 2 pi.
    stiffness : (N,) secant mesh stiffness W / delta [N/um].
    te_unloaded, te_loaded : (N,) unloaded and loaded TE [rad] (positive: the gear ahead).
    W : static normal mesh load [N]; torque : pinion torque [N m].
    lever_gear : r_b2 cos(beta_b) [m]; c_gamma : loaded TCA's mean mesh stiffness per face width
    [N/(mm um)].
    """

    phi1: np.ndarray
    phase: np.ndarray
    stiffness: np.ndarray
    te_unloaded: np.ndarray
    te_loaded: np.ndarray
    W: float
    torque: float
    lever_gear: float
    c_gamma: float

    def excitation(self, harmonics: int | None = None) -> MeshExcitation:
        """Form (a): k(phi) [N/m] on the gap to the unloaded TE ``e = -TE_unloaded l_2`` [m]."""
        return MeshExcitation.from_samples(self.stiffness * 1e6, -self.te_unloaded * self.lever_gear, self.W,
                                           harmonics)


def loaded_mesh(pair: GearPair, torque: float, settings: LTCASettings | None = None, positions: int = 64,
                material: Material | None = None, misalignment: Misalignment | None = None) -> LoadedMesh:
    """Loaded TCA of ``pair`` at pinion torque ``torque`` [N m] over one mesh cycle of ``positions``.

    Raises
    ------
    OptionError
        Naming ``torque`` when no loaded TCA is possible there (not > 0, or beyond the contact
        model's range: :func:`gearopt.ltca.validity.check_torque_range`, ``check_validity``).
    """
    from ..ltca.engine import LTCA
    from ..ltca.validity import check_torque_range, check_validity

    LTCA.validate_torques(torque)
    L = LTCA(pair, settings, material=material)
    check_torque_range(pair, torque, L.material)
    phi = L.mesh_cycle(positions)
    r = L.solve(float(torque), phi1=phi, mis=misalignment).results[0]
    check_validity(r, pair, L.material)
    return loaded_mesh_of(pair, r)


def loaded_mesh_of(pair: GearPair, result: LoadedResult) -> LoadedMesh:
    """The :class:`LoadedMesh` of a loaded TCA ``result`` of ``pair`` over one mesh cycle (equally
    spaced positions, :meth:`gearopt.ltca.engine.LTCA.mesh_cycle`)."""
    r, phi = result, np.asarray(result.phi1, float)
    z1 = pair.pinion.z
    return LoadedMesh(phi1=phi, phase=z1 * (phi - phi[0]), stiffness=np.asarray(r.stiffness, float),
                      te_unloaded=np.asarray(r.te_unloaded, float), te_loaded=np.asarray(r.te_loaded, float),
                      W=float(r.W), torque=float(r.torque),
                      lever_gear=pair.gear.r_b * math.cos(pair.pinion.beta_b) * 1e-3, c_gamma=float(r.c_gamma))


def drive_train(pair: GearPair, zeta: float, backlash: float | None = None, J_pinion: float | None = None,
                J_gear: float | None = None, J_drive: float | None = None, k_drive: float | None = None,
                J_load: float | None = None, k_load: float | None = None) -> DriveTrain:
    """The :class:`DriveTrain` of ``pair``: inertias [kg m^2] given or the bodies' solid discs
    (:func:`solid_disc_inertia`), levers ``r_b cos(beta_b)``, backlash [mm] along the line of action
    (default: the pair's smallest normal backlash ``j_bn``, or 0.05 m_n when it has none)."""
    g1, g2 = pair.pinion, pair.gear
    cb = math.cos(g1.beta_b)
    if backlash is None:
        jbn = pair.backlash_normal[0]
        backlash = jbn if jbn > 1e-6 else 0.05 * g1.m_n
    if not backlash > 0:
        raise out_of_range("backlash", backlash, "backlash > 0 mm", cls=OptionError)
    J1 = solid_disc_inertia(g1.r_a, g1.r_f, g1.b) if J_pinion is None else J_pinion
    J2 = solid_disc_inertia(g2.r_a, g2.r_f, g2.b) if J_gear is None else J_gear
    return DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=g1.r_b * cb * 1e-3, l_gear=g2.r_b * cb * 1e-3, zeta=zeta,
                      J_drive=J_drive, k_drive=k_drive, J_load=J_load, k_load=k_load, backlash=backlash * 1e-3)


def iso_resonance_speed(pair: GearPair, train: DriveTrain, c_gamma: float) -> float:
    """ISO 6336-1:2019 eq. (13): ``n_E1 = 30000 / (pi z1) sqrt(c_gamma / m_red)`` [rpm] with the
    mesh stiffness per face width ``c_gamma`` [N/(mm um)], ``m_red = m1 m2 / (m1 + m2)`` per face width
    [kg/mm] from the pair's inertias over ``r_b^2`` (eq. (14)); b the smaller face width. The same
    as ``60 f_n / z1`` of the one-degree-of-freedom mesh with ``k = c_gamma b``."""
    b = min(pair.pinion.b, pair.gear.b)
    m_red = train.m_e / b  # kg/mm along the line of action (helical: along the normal, as the LTCA's load)
    return 30000.0 / (math.pi * pair.pinion.z) * math.sqrt(c_gamma / m_red)


def microgeometry_sensitivity(pair: GearPair, torque: float, speed_rpm: float, member: str, keys: Sequence[str],
                              zeta: float = 0.05, positions: int = 64, rel_step: float = 1e-3,
                              settings: LTCASettings | None = None) -> dict:
    """d K_v / d (micro-geometry amount) at one speed: the AD derivative of the dynamic factor with
    respect to the excitation (:meth:`GearDynamics.peak_sensitivity`) chained with the derivative of
    the excitation (Fourier coefficients of the loaded TCA's k and e) with respect to each amount,
    the latter by central differences of the loaded TCA (two solves per amount). The mesh damping
    follows the displaced designs' mean stiffness (:class:`GearDynamics`); the state scales stay those
    of the given design. For amounts (not starts such as ``d_Ca``) the AD chain through the loaded TCA
    is :func:`gearopt.dynamics.sensitivity.speed_range_sensitivity`.

    Parameters
    ----------
    pair : GearPair; torque : pinion torque [N m]; speed_rpm : pinion speed [rpm].
    member : "pinion" or "gear"; keys : fields of its
        :class:`~gearopt.geometry.microgeometry.Microgeometry` (amounts in mm, e.g. ``"C_alpha_a"``).
    rel_step : float
        Step of the differences, relative to the amount (absolute 1e-4 mm for a zero amount).

    Returns
    -------
    dict
        ``K_v``, ``speed_rpm``, ``keys``: per key ``dKv_dmm`` (per mm), ``step_mm`` and the excitation
        parameters of the two displaced designs ``P_plus``, ``P_minus``; ``model`` (the
        :class:`GearDynamics`) and ``solution`` for further use.
    """
    from dataclasses import replace

    from ..geometry.microgeometry import Microgeometry
    from ..gears import GearPair as Pair
    from .model import GearDynamics

    if member not in ("pinion", "gear"):
        raise out_of_range("member", member, "'pinion' or 'gear'", cls=OptionError)
    base = loaded_mesh(pair, torque, settings, positions)
    gd = GearDynamics(drive_train(pair, zeta), base.excitation(), pair.pinion.z, tol=1e-10, newton_tol=1e-9)
    sol = gd.solve(speed_rpm)
    if not sol.converged:
        from .model import check_converged

        check_converged(sol)
    g = gd.peak_sensitivity(sol)
    gear = getattr(pair, member)
    mods = gear.modifications or Microgeometry()
    out: dict = {"K_v": float(sol.force.max() / base.W), "speed_rpm": float(speed_rpm), "keys": {},
                 "model": gd, "solution": sol}
    for key in keys:
        v = getattr(mods, key)
        h = rel_step * abs(v) if v else 1e-4
        P = []
        for s in (1, -1):
            m = replace(mods, **{key: v + s * h})
            g2 = gear.with_(modifications=m)
            p2 = Pair(g2, pair.gear, a=pair.a) if member == "pinion" else Pair(pair.pinion, g2, a=pair.a)
            P.append(loaded_mesh(p2, torque, settings, positions).excitation().params())
        dP = (P[0] - P[1]) / (2 * h)
        out["keys"][key] = {"dKv_dmm": float(g @ dP), "step_mm": h, "P_plus": P[0], "P_minus": P[1]}
    return out
