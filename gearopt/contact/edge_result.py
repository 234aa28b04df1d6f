"""The result of an edge-contact sweep: :class:`EdgeTCAResult` (the TE of every branch and pair, the
actual TE, the feature in contact, intervals and transfers, as results.json holds them), what a sweep
solved (:class:`EdgeSolved`), and their combination (:class:`EdgeCombination`: which roots lie on the
finite flanks and are reachable, one TE zero for every branch, the upper envelope over branches and
pairs), a part of :class:`gearopt.contact.edge.EdgeContact`."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..meshing.misalignment import Misalignment
from ..meshing.sweep_args import no_contact
from ..meshing.tca_result import EnvelopeTE, TCAResult
from ..report import CONJUGATE_ARCSEC, arr, misalignment_dict, pair_numbers, te_harmonics
from ..units import RAD_TO_ARCSEC


@dataclass(frozen=True)
class EdgeTCAResult(EnvelopeTE):
    """Surface and edge contact of a drive over the pinion angles, every tooth pair.

    Arrays: ``(B, K, N)`` for B branches (``branches[0] = "surface"``, then the edges), K tooth
    pairs, N positions.

    Attributes
    ----------
    phi1 : (N,) [rad].
    branches : tuple of str.
    te : (B, K, N) TE of each branch [rad], NaN where the branch is not a valid contact.
    te_pair : (K, N) TE of each pair: upper envelope of its valid branches [rad].
    branch : (K, N) index into ``branches`` of the feature in contact (-1: none).
    te_envelope : (N,) actual TE [rad]; driving : (N,) index into ``pairs`` (-1: none);
    active : (N,) branch index of the driving contact.
    z1, radius1, z2, radius2 : (B, K, N) contact point on pinion and gear [mm].
    converged : (B, K, N) solved and checked; valid : (B, K, N) on the finite edge and flank.
    intervals : list of dicts for the central pair: ``branch``, ``phi1_start``, ``phi1_end``
        (where that feature carries the central pair; eq. 9.6.3 for the surface branch).
    transfers : list of dicts along the actual TE: ``phi1``, ``from``/``to`` (pair, branch), TE
        slopes before/after [rad/rad] and their jump (the jump in gear angular velocity / omega1).
    surface : TCAResult or None (None when no surface-to-surface contact exists, e.g. misaligned
        line-contact gears).
    """

    phi1: np.ndarray
    pairs: tuple
    branches: tuple
    te: np.ndarray
    te_pair: np.ndarray
    branch: np.ndarray
    te_envelope: np.ndarray
    driving: np.ndarray
    active: np.ndarray
    z1: np.ndarray
    radius1: np.ndarray
    z2: np.ndarray
    radius2: np.ndarray
    converged: np.ndarray
    valid: np.ndarray
    intervals: list
    transfers: list
    misalignment: Misalignment
    surface: TCAResult | None = None
    solve_time: float = 0.0
    stats: dict = field(default_factory=dict)

    def edge_contact(self) -> bool:
        """True when an edge carries the load somewhere along the actual TE."""
        return bool(np.any(self.active[self.active >= 0] > 0))

    def to_dict(self, label: str = "", z1: int | None = None, limits: dict | None = None) -> dict:
        """This case as results.json holds it (``cases[]`` of the tca study with edge contact, and
        ``before`` / ``after`` of the crowning study; every key, unit and meaning in
        docs/results.md). Parameters as :meth:`gearopt.meshing.tca.TCAResult.to_dict`."""
        k0 = self.pairs.index(0) if 0 in self.pairs else 0
        env = self.te_envelope_arcsec
        branches = list(self.branches)
        conjugate = bool(self.peak_to_peak_arcsec < CONJUGATE_ARCSEC)
        # A pair carries load where its TE reaches the envelope (ties: all pairs of a conjugate drive).
        tie = CONJUGATE_ARCSEC / RAD_TO_ARCSEC
        loads = np.isfinite(self.te_pair[k0]) & (self.te_pair[k0] >= self.te_envelope - tie)
        paths = {}
        for b, name in enumerate(branches):
            v = self.valid[b, k0]
            if not v.any():
                continue
            paths[name] = {"pinion": {"axial": arr(np.where(v, self.z1[b, k0], np.nan)),
                                      "radius": arr(np.where(v, self.radius1[b, k0], np.nan))},
                           "gear": {"axial": arr(np.where(v, self.z2[b, k0], np.nan)),
                                    "radius": arr(np.where(v, self.radius2[b, k0], np.nan))},
                           "carries_load": [bool(x) for x in ((self.branch[k0] == b) & loads)]}
        return {
            "label": label, "edge_analysis": True,  # whether an edge carries load: "edge_carries_load"
            "misalignment": misalignment_dict(self.misalignment),
            "phi1": arr(self.phi1), "pairs": list(self.pairs), "branches": branches,
            "te_arcsec": arr(self.te_pair * RAD_TO_ARCSEC), "te_envelope_arcsec": arr(env),
            "te_branches_central_arcsec": {name: arr(self.te[b, k0] * RAD_TO_ARCSEC) for b, name in enumerate(branches)},
            "driving_pair": pair_numbers(self.driving, self.pairs),
            "active_branch": [branches[a] if a >= 0 else None for a in self.active],
            "edge_carries_load": self.edge_contact(),
            "intervals_central_pair": self.intervals,
            # a conjugate drive has no transfers: all pairs in contact tie (round-off picks a "driver")
            "transfers": [] if conjugate else [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                                                for k, v in t.items()} for t in self.transfers],
            "transfer_phi1": [] if conjugate else [t["phi1"] for t in self.transfers],
            "peak_to_peak_arcsec": self.peak_to_peak_arcsec,
            "conjugate": conjugate,
            "harmonics_arcsec": None if z1 is None else te_harmonics(self.phi1, env, z1),
            "paths_central_pair": paths,
            "actual_te_at_every_position": bool(np.isfinite(self.te_envelope).all()),
            "stats": {k: (v if isinstance(v, (dict, str, int, float)) else str(v)) for k, v in self.stats.items()},
            "solve_time_s": self.solve_time,
            "limits": limits,
        }


@dataclass
class EdgeSolved:
    """What :meth:`EdgeContact.sweep` solved, handed to ``_combine`` by name: positions ``phi1`` (N,),
    ``pairs``, branch ``names`` (B,), full unknowns ``Q`` (B, 5, K N), flags ``conv`` and wedge
    coefficients ``cone`` (B, K N), the parameter matrix ``prm`` (rows: ``tca.layout``), the case
    ``mis``, the surface result ``surf`` (or None), ``stats``, the start time ``t0`` and ``p1``, ``p2``."""

    phi1: np.ndarray
    pairs: tuple
    names: tuple
    Q: np.ndarray
    conv: np.ndarray
    cone: np.ndarray
    prm: np.ndarray
    mis: Misalignment
    surf: TCAResult | None
    stats: dict
    t0: float
    p1: np.ndarray
    p2: np.ndarray


class EdgeCombination:
    """The combination of an edge-contact sweep into an :class:`EdgeTCAResult` for
    :class:`~gearopt.contact.edge.EdgeContact` (a mixin: it uses its ``tca``, ``members``,
    ``build_time``, the radii ``_radius`` and the reach ``_coast_clearance``)."""

    def _inside(self, W, phis, p1, p2, mis, radii=None):
        """Columns of W (full unknowns at the pair-0 angles ``phis``) whose point lies on both finite
        active flanks and is reachable: the gear at most the coast-side clearance ahead of the
        conjugate position (or the coast flanks would interpenetrate) and less than half a gear
        pitch behind it (that would be another tooth). ``radii``: the transverse radii of the points
        on pinion and gear (:meth:`_radius`) when the caller has them."""
        g1, g2 = self.members[1], self.members[2]
        eps = 1e-9
        rad1, rad2 = (self._radius(1, W, p1), self._radius(2, W, p2)) if radii is None else radii
        with np.errstate(invalid="ignore"):
            # Form limit: the true end of each generated flank in the point's section (TCA.on_flank).
            in1 = (np.abs(W[1]) <= g1.b / 2 + eps) & self.tca.on_flank(1, W[0], W[1], p1) & (rad1 <= g1.r_a + eps)
            in2 = (np.abs(W[3]) <= g2.b / 2 + eps) & self.tca.on_flank(2, W[2], W[3], p2) & (rad2 <= g2.r_a + eps)
            te_raw = W[4] / self.tca.scale2 - (g1.z / g2.z) * np.asarray(phis)
            reach = (te_raw < self._coast_clearance(p1, p2, mis)) & (-te_raw < math.pi / g2.z)
        return in1 & in2 & reach

    def _combine(self, sv: EdgeSolved) -> EdgeTCAResult:
        phi1, pairs, names, Q, conv, cone, prm = sv.phi1, sv.pairs, sv.names, sv.Q, sv.conv, sv.cone, sv.prm
        mis, surf, stats, t0, p1, p2 = sv.mis, sv.surf, sv.stats, sv.t0, sv.p1, sv.p2
        tca = self.tca
        g1, g2 = self.members[1], self.members[2]
        K, N = len(pairs), phi1.size
        B = len(names)
        # every branch's columns in one call (each column is evaluated by itself)
        Qall = Q.transpose(1, 0, 2).reshape(5, B * Q.shape[2])
        rad1, rad2 = self._radius(1, Qall, p1), self._radius(2, Qall, p2)
        z1, z2 = Q[:, 1, :], Q[:, 3, :]
        phis = prm[tca.layout.index("phi1")]
        valid = conv & self._inside(Qall, np.tile(phis, B), p1, p2, mis, radii=(rad1, rad2)).reshape(conv.shape)
        rad1, rad2 = rad1.reshape(conv.shape), rad2.reshape(conv.shape)
        shift2 = np.concatenate([np.full(N, 2 * math.pi * k / g2.z) for k in pairs])
        phi2 = Q[:, 4, :] / tca.scale2 + shift2[None, :]
        # Raw TE: the gear angle ahead of the conjugate position of the aligned, unmodified drive
        # (phi1 = phi2 = 0 puts both driving flanks through the pitch point I).
        te_raw = phi2 - (g1.z / g2.z) * np.tile(phi1, K)[None, :]
        te_raw = te_raw.reshape(B, K, N)
        valid = valid.reshape(B, K, N)
        # One zero for every branch and every sweep of the drive: the surface TCA's (phi2 of pair 0
        # at phi1 = 0) when there is surface contact, so that the surface branch equals surf.te;
        # otherwise the conjugate position itself (raw TE). Neither depends on the sweep's grid.
        ref = self._surface_zero(surf, te_raw[0], 0) if surf is not None and np.isfinite(surf.te).any() else 0.0
        # An edge point where the flanks are tangent (gamma = 0: the mating normal is the flank's)
        # is surface contact reaching the boundary, e.g. a contact line running through a face end:
        # it counts as surface contact where the surface branch has no valid point of its own.
        tangent = (cone.reshape(B, K, N) < 1e-7) & valid
        for b in range(1, B):
            take = tangent[b] & ~valid[0]
            if take.any():
                te_raw[0] = np.where(take, te_raw[b], te_raw[0])
                z1r, z2r = z1.reshape(B, K, N), z2.reshape(B, K, N)
                r1r, r2r = rad1.reshape(B, K, N), rad2.reshape(B, K, N)
                for arr in (z1r, z2r, r1r, r2r):
                    arr[0] = np.where(take, arr[b], arr[0])
                valid[0] |= take
        te_valid = np.where(valid, te_raw, -np.inf)
        # Ties (line contact along a face end) go to the surface branch.
        te_valid[0] = np.where(valid[0] & (te_valid[0] >= te_valid.max(axis=0) - 1e-12), np.inf, te_valid[0])
        branch = np.argmax(te_valid, axis=0)
        te_pair = np.take_along_axis(np.where(valid, te_raw, -np.inf), branch[None], axis=0)[0]
        branch = np.where(np.isfinite(te_pair), branch, -1)
        drv = np.argmax(np.where(np.isfinite(te_pair), te_pair, -np.inf), axis=0)
        env = te_pair[drv, np.arange(N)]
        has = np.isfinite(env)
        k0 = pairs.index(0) if 0 in pairs else 0
        te = np.where(valid, te_raw - ref, np.nan)
        te_pair = np.where(np.isfinite(te_pair), te_pair - ref, np.nan)
        env = np.where(has, env - ref, np.nan)
        driving = np.where(has, drv, -1)
        active = np.where(has, branch[drv, np.arange(N)], -1)
        intervals = _intervals(phi1, branch[k0], names)
        transfers = _transfers(phi1, te, driving, active, pairs, names)
        if not has.any():
            raise no_contact("EdgeContact.sweep (surface and edges)", phi1, pairs, g1.z)
        return EdgeTCAResult(
            phi1=phi1, pairs=pairs, branches=names, te=te, te_pair=te_pair, branch=branch, te_envelope=env,
            driving=driving, active=active, z1=z1.reshape(B, K, N), radius1=rad1.reshape(B, K, N),
            z2=z2.reshape(B, K, N), radius2=rad2.reshape(B, K, N), converged=conv.reshape(B, K, N), valid=valid,
            intervals=intervals, transfers=transfers, misalignment=mis, surface=surf,
            solve_time=time.perf_counter() - t0, stats={"build_s": self.build_time, "te_zero_rad": ref, **stats})

    @staticmethod
    def _surface_zero(surf: TCAResult, te_raw_surface, k0) -> float:
        # The surface TCA measures TE from phi2 at phi1 = 0 of pair 0; recover that constant so that
        # the surface branch here equals surf.te.
        diff = te_raw_surface.reshape(surf.te.shape) - surf.te
        vals = diff[np.isfinite(diff)]
        return float(np.median(vals)) if vals.size else 0.0


def _intervals(phi1, branch_row, names) -> list[dict]:
    """Runs of one branch along phi1 for a pair: [{"branch", "phi1_start", "phi1_end"}]."""
    out, start = [], 0
    for i in range(1, len(phi1) + 1):
        if i == len(phi1) or branch_row[i] != branch_row[start]:
            if branch_row[start] >= 0:
                out.append({"branch": names[branch_row[start]], "phi1_start": float(phi1[start]),
                            "phi1_end": float(phi1[i - 1])})
            start = i
    return out


def _slope(x, y, i0, i1):
    """Slope of y over the samples [i0, i1] (least squares), NaN if fewer than 2 finite points."""
    xs, ys = x[i0:i1 + 1], y[i0:i1 + 1]
    m = np.isfinite(ys)
    if m.sum() < 2:
        return float("nan")
    return float(np.polyfit(xs[m], ys[m], 1)[0])


def _transfers(phi1, te, driving, active, pairs, names) -> list[dict]:
    """Changes of the driving (pair, branch) along the actual TE, with the slopes dTE/dphi1 of the
    two contacts at the transfer [rad/rad] (fitted on each one's own TE curve around it; NaN where
    a curve has fewer than 2 points there) and the jump (the jump in omega2/omega1)."""
    out = []
    n = len(phi1)
    for i in range(n - 1):
        a, b = (driving[i], active[i]), (driving[i + 1], active[i + 1])
        if a[0] < 0 or b[0] < 0 or a == b:
            continue
        before = _slope(phi1, te[a[1], a[0]], max(i - 3, 0), min(i + 1, n - 1))
        after = _slope(phi1, te[b[1], b[0]], max(i, 0), min(i + 4, n - 1))
        out.append({"phi1": float(0.5 * (phi1[i] + phi1[i + 1])),
                    "from": {"pair": pairs[a[0]], "branch": names[a[1]]},
                    "to": {"pair": pairs[b[0]], "branch": names[b[1]]},
                    "slope_before": before, "slope_after": after, "slope_jump": after - before})
    return out
