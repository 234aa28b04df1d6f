"""The results of the loaded TCA: :class:`LoadedResult` (one torque over the positions: loads, loaded TE,
approach, Hertz pressures, load sharing, mesh stiffness, the contact conditions' error) and
:class:`LoadedSweep` (a list of torques on one set of slices, as results.json holds it)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..units import RAD_TO_ARCSEC

if TYPE_CHECKING:
    from .contact_qp import ContactStructure
    from .engine import LTCA
    from .slices import SliceSet

#: Slices narrower than this share of the nominal slice width are left out of the line-load statistics
#: (``K_Hbeta``, ``line_load_max``): slivers left where a flank slice is trimmed at a tip crossing.
SLIVER = 0.25


@dataclass(frozen=True)
class LoadedResult:
    """Loaded TCA at one torque over the positions ``phi1`` (arrays (K, N, M): K tooth pairs, N
    positions, M slice nodes; see :class:`~gearopt.ltca.slices.SliceSet`).

    Attributes
    ----------
    torque : pinion torque [N m]; W : total normal load [N].
    phi1 : (N,) [rad]; pairs : tuple.
    te_unloaded, te_loaded : (N,) unloaded and loaded TE [rad].
    delta : (N,) loaded approach along the contact normal [mm].
    load : (K, N, M) slice loads [N]; line_load : (K, N, M) load per unit face width [N/mm].
    p0, b_H : (K, N, M) Hertz peak pressure [MPa] and half-width [mm] of each slice.
    pair_load : (K, N) normal load of each pair [N]; share : (K, N) its share of the pinion torque
        (``sum lever F`` of its slices over ``torque``; its share of W where every slice is a flank).
    stiffness : (N,) mesh stiffness W / delta [N/um] (secant, including the separations closed).
    kkt_error : (N,) largest violation of the contact conditions [mm].
    hertz_iterations : (N,) fixed-point iterations; solve_time [s].
    edge : (K, N, M) tip-edge slices (1 pinion tip, 2 gear tip, 0 flank; ``SliceSet.edge``).
    lever : (K, N, M) moment arm of each slice's force about the pinion axis [mm]
        (``SliceSet.lever1``: r_b1 cos(beta_b) on a flank, less on a tip edge); the pinion torque is
        ``sum(lever * load)`` at every position (:attr:`torque_balance_error`).
    """

    torque: float
    W: float
    phi1: np.ndarray
    pairs: tuple
    te_unloaded: np.ndarray
    te_loaded: np.ndarray
    delta: np.ndarray
    load: np.ndarray
    line_load: np.ndarray
    p0: np.ndarray
    b_H: np.ndarray
    pair_load: np.ndarray
    share: np.ndarray
    stiffness: np.ndarray
    kkt_error: np.ndarray
    hertz_iterations: np.ndarray
    solve_time: float
    face_width: float
    stats: dict = field(default_factory=dict)
    edge: np.ndarray | None = None
    lever: np.ndarray | None = None

    @property
    def te_loaded_arcsec(self) -> np.ndarray:
        return self.te_loaded * RAD_TO_ARCSEC

    @property
    def peak_to_peak_arcsec(self) -> float:
        """Peak-to-peak loaded TE [arcsec]."""
        t = self.te_loaded_arcsec
        return float(np.nanmax(t) - np.nanmin(t))

    @property
    def p0_flank(self) -> np.ndarray:
        """(K, N, M) Hertz peak pressure of the flank slices [MPa] (0 on tip-edge slices)."""
        return self.p0 if self.edge is None else np.where(self.edge > 0, 0.0, self.p0)

    @property
    def p_max(self) -> float:
        """Largest Hertz peak pressure of the flank contact over positions and slices [MPa] (tip-edge
        slices excluded: see :attr:`edge_share` and :attr:`p_max_edge`)."""
        return float(np.nanmax(self.p0_flank))

    @property
    def edge_share(self) -> np.ndarray:
        """(N,) share of the pinion torque carried by tip edges (edge loading of unrelieved tips)."""
        if self.edge is None:
            return np.zeros(self.phi1.size)
        lev = 1.0 if self.lever is None else self.lever / (self.torque * 1e3 / self.W)
        return np.sum(np.where(self.edge > 0, lev * self.load, 0.0), axis=(0, 2)) / self.W

    @property
    def torque_balance_error(self) -> np.ndarray:
        """(N,) ``sum(lever * load) / torque - 1``: the pinion's moment balance with each slice force on
        its own lever (``lever``); NaN without levers."""
        if self.lever is None:
            return np.full(self.phi1.size, np.nan)
        return np.nansum(self.lever * self.load, axis=(0, 2)) * 1e-3 / self.torque - 1.0

    @property
    def p_max_edge(self) -> float:
        """Largest Hertz pressure on a tip edge of rounding ``EDGE_RADIUS`` m_n (:data:`gearopt.ltca.engine.EDGE_RADIUS`) [MPa] (0: none loaded)."""
        if self.edge is None:
            return 0.0
        return float(np.max(np.where((self.edge > 0) & (self.load > 0), self.p0, 0.0)))

    @property
    def c_gamma(self) -> float:
        """Mean mesh stiffness per unit face width [N/(mm um)]."""
        return float(np.nanmean(self.stiffness)) / self.face_width


@dataclass
class LoadedSweep:
    """Loaded TCA over a list of torques (one :class:`LoadedResult` each) on one set of slices."""

    slices: SliceSet
    results: list
    separation_time: float
    structure: ContactStructure
    te_zero_rad: float
    ltca: LTCA

    @property
    def torques(self) -> np.ndarray:
        return np.array([r.torque for r in self.results])

    def te_vs_torque(self, z1: int) -> dict:
        """Peak-to-peak loaded TE and its first mesh harmonic against torque [arcsec]."""
        from ..report import te_harmonics

        pp = [r.peak_to_peak_arcsec for r in self.results]
        h1 = []
        for r in self.results:
            h = te_harmonics(r.phi1, r.te_loaded_arcsec, z1)
            h1.append(None if h is None else h[0])
        return {"torque_Nm": self.torques.tolist(), "peak_to_peak_arcsec": pp, "harmonic1_arcsec": h1}

    def to_dict(self, z1: int, nominal: float | None = None) -> dict:
        """The sweep as results.json holds it (every key, unit and meaning in docs/results.md):
        unloaded TE, one entry per torque (loaded TE, harmonics, load sharing, mesh stiffness,
        peak pressure, errors), the TE-vs-torque curve, and the slice maps (loads, pressure,
        contact bands on both flanks) at the ``nominal`` torque (default: the largest)."""
        from ..report import arr, te_harmonics

        S = self.slices
        res = self.results
        nom = res[-1] if nominal is None else min(res, key=lambda r: abs(r.torque - nominal))
        g1, g2 = self.ltca.pair.pinion, self.ltca.pair.gear
        per = []
        for r in res:
            env = r.te_loaded_arcsec
            ll = np.where(r.load > 0, r.line_load, np.nan)
            mean_ll = r.pair_load / np.maximum(np.nansum(np.where(np.isfinite(S.z), S.width, 0.0), axis=2), 1e-12)
            # K_Hbeta (ISO 6336-1, 3.4: peak over mean load per unit face width) of the flank contact that
            # carries the largest line load of the cycle: the factor of the most loaded point. (The largest
            # ratio over all pairs would be that of a pair just entering mesh with a few newtons near a
            # face end: a large ratio of a negligible load.) Tip-edge slices are not flank line loads.
            # Slivers (a flank slice trimmed at a tip crossing to less than a quarter of the nominal slice
            # width) carry a few newtons over microns: their load over width is no line load to quote.
            w_nom = float(np.nanmax(np.where(np.isfinite(S.z), S.width, np.nan)))
            whole = S.width >= SLIVER * w_nom
            on_flank = ((r.load > 0) if S.edge is None else (r.load > 0) & (S.edge == 0)) & whole
            ll_flank = np.where(on_flank & np.isfinite(r.line_load), r.line_load, 0.0)
            peak = np.max(ll_flank, axis=2)
            k_star, n_star = np.unravel_index(int(np.argmax(peak)), peak.shape)
            khb = (np.array([peak[k_star, n_star] / mean_ll[k_star, n_star]])
                   if peak[k_star, n_star] > 0 and r.pair_load[k_star, n_star] > 0 else np.array([np.nan]))
            kp, nphi, mm = np.unravel_index(int(np.nanargmax(r.p0_flank)), r.p0.shape)
            per.append({
                "torque_Nm": r.torque, "normal_load_N": r.W,
                "te_loaded_arcsec": arr(env), "peak_to_peak_arcsec": r.peak_to_peak_arcsec,
                "harmonics_arcsec": te_harmonics(r.phi1, env, z1),
                "pair_share": arr(r.share), "pair_load_N": arr(r.pair_load),
                "stiffness_N_per_um": arr(r.stiffness), "stiffness_mean_N_per_um": float(np.mean(r.stiffness)),
                "c_gamma_N_per_mm_um": r.c_gamma,
                "delta_mm": arr(r.delta),
                "p_max_MPa": r.p_max, "p_max_at": {"phi1": float(r.phi1[nphi]), "pair": int(S.pairs[kp]),
                                                   "z_mm": float(S.z[kp, nphi, mm]),
                                                   "radius_mm": float(self.structure.radius1[kp, nphi, mm])},
                "p_max_per_position_MPa": arr(np.max(r.p0_flank, axis=(0, 2))),
                "edge_share": arr(r.edge_share), "edge_share_max": float(np.max(r.edge_share)),
                "p_max_edge_MPa": r.p_max_edge,
                "line_load_max_N_per_mm": float(np.nanmax(np.where(whole, ll, np.nan)))
                if np.isfinite(np.where(whole, ll, np.nan)).any() else 0.0,
                "K_Hbeta": float(np.nanmax(khb)) if np.isfinite(khb).any() else None,
                "kkt_error_max_mm": float(np.max(r.kkt_error)), "hertz_iterations_max": int(np.max(r.hertz_iterations)),
                "solve_time_s": r.solve_time,
            })
        used = np.isfinite(S.z)
        loaded = used & (nom.load > 0)
        st = self.structure

        def flat(a):
            return arr(np.asarray(a)[loaded])

        pattern = {
            "torque_Nm": nom.torque,
            "pair": [int(S.pairs[k]) for k in np.nonzero(loaded)[0]],
            "phi1": [float(S.phi1[n]) for n in np.nonzero(loaded)[1]],
            "load_N": flat(nom.load), "line_load_N_per_mm": flat(nom.line_load), "p0_MPa": flat(nom.p0),
            "edge": flat(nom.edge if nom.edge is not None else np.zeros(S.z.shape)),
            "b_H_mm": flat(nom.b_H), "width_mm": flat(S.width),
            "pinion": {"axial": flat(S.z), "from": flat(S.z_lo), "to": flat(S.z_hi), "radius": flat(st.radius1),
                       "r_b": g1.r_b},
            "gear": {"axial": flat(S.z2), "from": flat(S.z_lo + S.z2 - S.z), "to": flat(S.z_hi + S.z2 - S.z),
                     "radius": flat(st.radius2), "r_b": g2.r_b},
        }
        n_pk = int(np.argmax(np.max(nom.p0_flank, axis=(0, 2))))  # the largest flank pressure
        face = {"phi1": float(S.phi1[n_pk]), "pairs": list(S.pairs),
                "axial": arr(S.z[:, n_pk, :]), "line_load_N_per_mm": arr(np.where(used[:, n_pk], nom.line_load[:, n_pk],
                                                                                   np.nan)),
                "p0_MPa": arr(np.where(used[:, n_pk], nom.p0[:, n_pk], np.nan)),
                "edge": arr(np.where(used[:, n_pk], nom.edge[:, n_pk], 0) if nom.edge is not None
                            else np.zeros(S.z[:, n_pk].shape))}
        return {
            "phi1": arr(S.phi1), "pairs": list(S.pairs), "te_zero_rad": self.te_zero_rad,
            "te_unloaded_arcsec": arr(S.te_unloaded * RAD_TO_ARCSEC),
            "unloaded_peak_to_peak_arcsec": float(np.ptp(S.te_unloaded) * RAD_TO_ARCSEC),
            "torques": per, "te_vs_torque": self.te_vs_torque(z1), "nominal_torque_Nm": nom.torque,
            "pattern": pattern, "face_load": face,
            "slices": {"n_slices": self.ltca.n_slices, "n_active": int(S.active.sum()), "stats": S.stats},
            "separation_time_s": self.separation_time,
        }
