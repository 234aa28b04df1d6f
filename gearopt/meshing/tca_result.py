"""The result of a tooth contact sweep: :class:`TCAResult` (transmission error of every pair and the
actual TE, contact points, curvatures and contact ellipses, as results.json holds them), what a sweep
solved (:class:`SolvedSweep`), and its assembly into a result (:class:`TCAResultAssembly`, a part of
:class:`gearopt.meshing.tca.TCA`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..units import RAD_TO_ARCSEC
from .misalignment import Misalignment


class EnvelopeTE:
    """TE-envelope helpers shared by the result objects (needs ``te_envelope`` [rad])."""

    @property
    def te_envelope_arcsec(self) -> np.ndarray:
        return self.te_envelope * RAD_TO_ARCSEC

    @property
    def peak_to_peak(self) -> float:
        """Peak-to-peak of the actual TE (envelope) [rad]."""
        v = self.te_envelope[np.isfinite(self.te_envelope)]
        return float(v.max() - v.min()) if v.size else float("nan")

    @property
    def peak_to_peak_arcsec(self) -> float:
        """Peak-to-peak of the actual TE (envelope) [arcsec]."""
        return self.peak_to_peak * RAD_TO_ARCSEC


@dataclass(frozen=True)
class TCAResult(EnvelopeTE):
    """Numeric result of a TCA sweep (one design, one misalignment case).

    Arrays have shape (K, N): K tooth pairs (pinion tooth ``pairs[k]``, positions shifted by
    2 pi/z1) and N input positions ``phi1``.

    Attributes
    ----------
    phi1 : (N,) pinion angles [rad].
    phi2, te : (K, N) gear angle and transmission error [rad] of each pair (NaN where unsolved).
    te_envelope : (N,) actual TE [rad]: the upper envelope over pairs in contact on the active flank.
    driving : (N,) index into ``pairs`` of the driving pair (-1 where none).
    u1, z1, u2, z2 : (K, N) surface coordinates [mm] of the contact points.
    r1, r2 : (K, N, 3) contact points on pinion / gear in their own frames [mm].
    radius1, radius2 : (K, N) transverse radii of the contact point on each member [mm].
    rf : (K, N, 3) contact point in the fixed frame [mm].
    kappa1, kappa2 : (K, N, 2) principal curvatures of pinion and gear flank [1/mm] (convex > 0).
    ellipse_a, ellipse_b : (K, N) contact ellipse semi-axes [mm] (major, minor) for ``delta``.
    ellipse_dir2, ellipse_dir1 : (K, N, 2, 3) unit directions of the major ([..., 0, :]) and minor
        ([..., 1, :]) axes in the gear and in the pinion frame.
    residual : (K, N) residual norm after the solve [mm].
    normal_dot : (K, N) n1 . n2 of the outward normals in S_f (-1 for a true contact point).
    converged, on_surface : (K, N) bool flags.
    solve_time : float [s]; ``stats`` dict with counts and timing.
    """

    phi1: np.ndarray
    pairs: tuple
    phi2: np.ndarray
    te: np.ndarray
    te_envelope: np.ndarray
    driving: np.ndarray
    u1: np.ndarray
    z1: np.ndarray
    u2: np.ndarray
    z2: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    rf: np.ndarray
    radius1: np.ndarray
    radius2: np.ndarray
    kappa1: np.ndarray
    kappa2: np.ndarray
    ellipse_a: np.ndarray
    ellipse_b: np.ndarray
    ellipse_dir2: np.ndarray
    ellipse_dir1: np.ndarray
    residual: np.ndarray
    normal_dot: np.ndarray
    converged: np.ndarray
    on_surface: np.ndarray
    delta: float
    misalignment: Misalignment
    solve_time: float
    stats: dict = field(default_factory=dict)

    @property
    def te_arcsec(self) -> np.ndarray:
        """TE of every pair [arcsec]."""
        return self.te * RAD_TO_ARCSEC

    def transfer_phi1(self) -> list:
        """Pinion angles [rad] where the driving pair changes (midway between the two samples);
        empty for a conjugate drive (the pairs in contact tie, round-off picks the "driving" one)."""
        from ..report import CONJUGATE_ARCSEC

        if self.peak_to_peak_arcsec < CONJUGATE_ARCSEC:
            return []
        drv = self.driving
        return [float(0.5 * (self.phi1[i] + self.phi1[i + 1])) for i in range(len(drv) - 1)
                if drv[i] >= 0 and drv[i + 1] >= 0 and drv[i] != drv[i + 1]]

    def to_dict(self, label: str = "", z1: int | None = None, limits: dict | None = None) -> dict:
        """This case as results.json holds it (``cases[]`` of the tca study; every key, unit and
        meaning in docs/results.md): TE of every pair and the actual TE [arcsec], driving pair,
        transfers, harmonics, the central pair's path of contact, curvatures and contact ellipses.

        Parameters
        ----------
        label : str
            Name of the case.
        z1 : int, optional
            Pinion tooth number, for the mesh-frequency harmonics (None: ``harmonics_arcsec`` null).
        limits : dict, optional
            Flank boundaries for the plots (``{"pinion": {"b", "r_a", "r_form"}, "gear": ...}`` [mm]).
        """
        from ..report import CONJUGATE_ARCSEC, arr, misalignment_dict, pair_numbers, te_harmonics

        k0 = self.pairs.index(0) if 0 in self.pairs else 0
        env = self.te_envelope_arcsec
        stats = dict(self.stats)
        if "n_failed" in stats:  # tooth pairs out of mesh at a position: not a failure of the drive
            stats["n_pair_positions_without_contact"] = stats.pop("n_failed")
        pp = self.peak_to_peak_arcsec

        def member(z, radius, r, kappa, dirs):
            return {"axial": arr(z[k0]), "radius": arr(radius[k0]), "xyz": arr(r[k0]), "kappa": arr(kappa[k0]),
                    "ellipse_dirs": arr(dirs[k0].reshape(-1, 6))}

        return {
            "label": label,
            "misalignment": misalignment_dict(self.misalignment),
            "phi1": arr(self.phi1), "pairs": list(self.pairs),
            "phi2": arr(self.phi2), "te_arcsec": arr(self.te_arcsec), "te_envelope_arcsec": arr(env),
            "driving_pair": pair_numbers(self.driving, self.pairs), "transfer_phi1": self.transfer_phi1(),
            "peak_to_peak_arcsec": pp, "conjugate": bool(pp < CONJUGATE_ARCSEC),
            "harmonics_arcsec": None if z1 is None else te_harmonics(self.phi1, env, z1),
            "pinion": member(self.z1, self.radius1, self.r1, self.kappa1, self.ellipse_dir1),
            "gear": member(self.z2, self.radius2, self.r2, self.kappa2, self.ellipse_dir2),
            "ellipse_semi_major_mm": arr(self.ellipse_a[k0]), "ellipse_semi_minor_mm": arr(self.ellipse_b[k0]),
            "delta_mm": self.delta,
            "converged": [bool(v) for v in self.converged[k0]], "on_surface": [bool(v) for v in self.on_surface[k0]],
            "on_surface_pairs": [[bool(v) for v in row] for row in self.on_surface],
            "actual_te_at_every_position": bool(np.isfinite(self.te_envelope).all()),
            "max_residual": float(np.max(self.residual[self.converged])),  # over the accepted points
            "min_normal_dot": float(np.min(self.normal_dot[self.converged])),
            "stats": stats, "solve_time_s": self.solve_time,
            "limits": limits,
        }


@dataclass
class SolvedSweep:
    """What a sweep solved, handed to :meth:`TCAResultAssembly._result` by name: positions ``phi1`` (N,),
    ``pairs``, full unknowns ``W`` (5, K N) (NaN where not accepted), the per-point checks ``ok``,
    ``res``, ``n1n2`` (K N,), the mapped contact Function's outputs by name ``contact``, and the
    sweep's settings."""

    phi1: np.ndarray
    pairs: tuple
    W: np.ndarray
    ok: np.ndarray
    res: np.ndarray
    n1n2: np.ndarray
    contact: dict
    delta: float
    mis: Misalignment
    solve_time: float
    stats: dict
    phi2_ref: float
    p1: np.ndarray | None = None
    p2: np.ndarray | None = None


class TCAResultAssembly:
    """The assembly of a sweep's :class:`TCAResult` for :class:`~gearopt.meshing.tca.TCA` (a mixin: it uses
    its ``pair``, ``scale2``, ``on_flank``, ``flank_limit`` and its memo of pitch angles and face edges)."""

    def _result(self, sv: SolvedSweep) -> TCAResult:
        phi1, pairs, W, ok, res, n1n2 = sv.phi1, sv.pairs, sv.W, sv.ok, sv.res, sv.n1n2
        delta, mis, solve_time, stats, phi2_ref, p1, p2 = (sv.delta, sv.mis, sv.solve_time, sv.stats, sv.phi2_ref,
                                                           sv.p1, sv.p2)
        c = sv.contact
        K, N = len(pairs), phi1.size
        bad = np.flatnonzero(~ok)  # the columns not accepted
        # the contact points [pinion, gear, S_f] x column x xyz, NaN where not accepted (one array)
        pts = np.concatenate([c["r1"].T, c["r2"].T, c["rf1"].T]).reshape(3, K * N, 3)
        pts[:, bad] = np.nan
        g1, g2 = self.pair.pinion, self.pair.gear
        okk = ok.reshape(K, N)
        shp = lambda a: a.reshape(K, N)  # noqa: E731
        phi2 = shp(W[4] / self.scale2) + self._pitch_angles(pairs, 2)[:, None]
        # TE relative to the pair-0 gear angle at phi1 = 0, so that every pair and sweep shares one zero.
        ratio = g1.z / g2.z
        te = phi2 - ratio * phi1[None, :] - phi2_ref
        radii = np.hypot(pts[:2, :, 0], pts[:2, :, 1])  # transverse radii of the points on pinion and gear
        radius1, radius2 = shp(radii[0]), shp(radii[1])
        z1, z2 = shp(W[1]), shp(W[3])
        eps = 1e-9
        # Above the true end of each generated flank (junction, fold or crossing; per section z).
        lim1 = self.on_flank(1, shp(W[0]), z1, p1)
        lim2 = self.on_flank(2, shp(W[2]), z2, p2)
        # on the face (|z1| <= b1 / 2, |z2| <= b2 / 2) and inside the tip circles (NaN, where not
        # accepted, compares False)
        edge = self._memo.get("edge")
        if edge is None:  # (the pair is fixed when the TCA is built)
            edge = self._remember("edge", np.array([[g1.b / 2 + eps, g1.r_a + eps], [g2.b / 2 + eps, g2.r_a + eps]]))
        inside = (np.abs(W[1:4:2]) <= edge[:, :1]) & (radii <= edge[:, 1:])
        inside = shp(inside[0] & inside[1])
        on = okk & inside & lim1 & lim2
        te_on = np.where(on, te, -np.inf)
        drv = np.argmax(te_on, axis=0)
        env = te_on[drv, np.arange(N)]
        has = np.isfinite(env)
        # A tangency past the end of a folded flank that the tool cut off at a ridge (a convex edge):
        # that pair's real contact is on the ridge, at a TE between the surface one and nothing; if
        # the surface TE is above the envelope, the surface contacts cannot tell the actual TE there.
        ridge = None
        for member, lim_ok, uu, pp in ((1, lim1, W[0], p1), (2, lim2, W[2], p2)):
            if self.flank_limit(member, 0.0, pp).kind == "intersection":
                r_m = okk & ~lim_ok & np.isfinite(shp(uu)) & inside
                ridge = r_m if ridge is None else ridge | r_m
        if ridge is not None:
            # (a tie within round-off, e.g. conjugate line contact, changes nothing: the ridge TE <= the surface TE)
            unknown = (ridge & (np.where(ridge, te, -np.inf) > np.where(has, env, -np.inf)[None, :] + 1e-13)).any(axis=0)
            if unknown.any():
                has = has & ~unknown
                stats["ridge_contact"] = (
                    f"{int(unknown.sum())} of {N} positions: a tooth pair's contact falls past the end of a folded "
                    "flank, where the tool cut it off at a ridge; that pair rests on the ridge (edge contact), "
                    "so the actual TE there is NaN here: analyse edge contact (gearopt.contact.EdgeContact)")
        env = np.where(has, env, np.nan)
        driving = np.where(has, drv, -1)
        # Curvatures and contact ellipse (eigen-decomposition of K1 + K2 in the common basis, in the
        # compiled sweep outputs): semi-axes sqrt(2 delta / lam), NaN where not converged.
        kap1 = c["kappa1"].T.copy()
        kap2 = c["kappa2"].T.copy()
        lam = c["lam"].T
        ax_len = np.full(lam.shape, np.inf)  # no contact ellipse where K1 + K2 is not positive (or NaN)
        pos = lam > 0
        ax_len[pos] = np.sqrt(2 * delta / lam[pos])
        # [major, minor] x (3,) in the gear frame and in the pinion frame (each output (3, 2 K N):
        # column 2 j + a holds axis a of column j)
        edir = c["dir2"].T.reshape(K * N, 2, 3).copy()
        edir1 = c["dir1"].T.reshape(K * N, 2, 3).copy()
        for a in (kap1, kap2, ax_len, edir, edir1):
            a[bad] = np.nan
        ea, eb = ax_len.T.copy()
        # (phi2, te and the radii are NaN where not accepted already: W and the points are)
        return TCAResult(
            phi1=phi1, pairs=pairs, phi2=phi2, te=te,
            te_envelope=env, driving=driving, u1=shp(W[0]), z1=z1, u2=shp(W[2]), z2=z2,
            r1=pts[0].reshape(K, N, 3), r2=pts[1].reshape(K, N, 3), rf=pts[2].reshape(K, N, 3),
            radius1=radius1, radius2=radius2,
            kappa1=kap1.reshape(K, N, 2), kappa2=kap2.reshape(K, N, 2),
            ellipse_a=ea.reshape(K, N), ellipse_b=eb.reshape(K, N), ellipse_dir2=edir.reshape(K, N, 2, 3),
            ellipse_dir1=edir1.reshape(K, N, 2, 3),
            residual=res.reshape(K, N), normal_dot=n1n2.reshape(K, N), converged=okk, on_surface=on,
            delta=delta, misalignment=mis, solve_time=solve_time, stats=stats)
