"""Edge contact (Litvin section 9.6): an edge of one tooth touching the flank of the other.

The boundaries of the active flank of each member are curves on its surface ``g(u, z) = 0``:

* ``tip``: the addendum edge, transverse radius = r_a (``g = (x^2 + y^2 - r_a^2) / (2 r_a)``);
* ``face+`` / ``face-``: the face ends z = +-b/2;
* ``limit``: the end of the active flank (``TCA.on_flank``, the flank limit of each section):
  at the tool's flank/fillet junction a concave transition, not a convex edge; but where the tool
  cut a folded flank off (``FlankLimit.kind == "intersection"``) a convex ridge, analysed as the
  edges ``pinion_limit`` / ``gear_limit`` (:data:`LIMIT_EDGES`);
* ``corner+`` / ``corner-``: the vertices where the tip edge meets a face end (vertex contact:
  ``r_f1 = r_f2`` with both boundary equations, the mating normal inside the vertex's normal cone);
* ``pinion_X/gear_Y``: an edge X of the pinion touching an edge Y of the gear (edge on edge).

Edge contact of an edge of member i with the flank of member j (eqs. 9.6.1-9.6.2, written with the
edge as a level curve of g instead of an explicit parameterization):

    r_f1(u1, z1, phi1) = r_f2(u2, z2, phi2),  g_i(u_i, z_i) = 0,  t_edge,i . n_fj = 0,
    t_edge,i = dr_i/du_i dg/dz_i - dr_i/dz_i dg/du_i   (the edge tangent),

five equations in (u1, z1, u2, z2, phi2) for each phi1. An edge of the pinion crossing an edge of
the gear (``pinion_tip/gear_face+`` ...: two boundary curves touching) is

    r_f1(u1, z1, phi1) = r_f2(u2, z2, phi2),  g_1(u1, z1) = 0,  g_2(u2, z2) = 0,

again five equations; the common perpendicular of the two edges, n = t_edge,1 x t_edge,2, is the
contact normal (the gap between the two curves is measured along it, so the common-perpendicular
condition holds at the touch), and the touch is genuine when each member's wedge lies on its own
side of the plane normal to n. Each (surface or edge) branch of a tooth pair is solved with
mapped Newton and the checks, every position on its own from first guesses of that position only
(the conjugate contact of the aligned drive in several sections, moved onto the edge), so that
no contact depends on the other positions of the sweep; a branch is valid where its contact point
lies on the finite edge and on the mating active flank. For a given phi1 the gear of
a pair rests against the feature that gives it the largest advance, so the pair's TE is the upper
envelope of its valid branches; the actual TE is the upper envelope over the pairs (docs/theory.md section 9).
"""

from __future__ import annotations

import functools
import hashlib
import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..compiled import ColumnMap, mapped
from ..errors import ConvergenceError, GearoptError, GeometryError, LineContactError, OptionError, out_of_range
from ..errors import ArgumentError
from ..report import CONJUGATE_ARCSEC, arr, misalignment_dict, pair_numbers, te_harmonics
from ..units import RAD_TO_ARCSEC
from ..meshing.misalignment import Misalignment
from ..meshing.solver import REGULARITY_MIN, Branch
from ..meshing.sweep_args import check_sweep_args, no_contact
from ..meshing.tca import TCA
from ..meshing.tca_result import EnvelopeTE, TCAResult

if TYPE_CHECKING:
    from collections.abc import Sequence
    from ..types import ArrayLike, Param

#: Convex edges that can touch the mating flank (member, kind, sign of the face end).
EDGES = {
    "pinion_tip": (1, "tip", 0), "pinion_face+": (1, "face", 1), "pinion_face-": (1, "face", -1),
    "gear_tip": (2, "tip", 0), "gear_face+": (2, "face", 1), "gear_face-": (2, "face", -1),
    # the corners where the tip edge meets a face end (vertex contact between an edge's end and the mate)
    "pinion_corner+": (1, "corner", 1), "pinion_corner-": (1, "corner", -1),
    "gear_corner+": (2, "corner", 1), "gear_corner-": (2, "corner", -1),
    # an edge of the pinion crossing an edge of the gear (edge-on-edge contact of two boundary curves)
    "pinion_tip/gear_face+": (0, "cross", ("pinion_tip", "gear_face+")),
    "pinion_tip/gear_face-": (0, "cross", ("pinion_tip", "gear_face-")),
    "pinion_face+/gear_tip": (0, "cross", ("pinion_face+", "gear_tip")),
    "pinion_face-/gear_tip": (0, "cross", ("pinion_face-", "gear_tip")),
    "pinion_tip/gear_tip": (0, "cross", ("pinion_tip", "gear_tip")),
}
SURFACE = "surface"
#: Convex edges at the end of a folded flank (issue 10): where the tool cut the flank away below a
#: fold, the crossing of the flank with the cutting surface is a ridge that can carry contact.
#: Added automatically for a member whose flank ends at such a crossing (``FlankLimit.kink > 0``).
LIMIT_EDGES = {"pinion_limit": (1, "limit", 0), "gear_limit": (2, "limit", 0)}


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
class _EdgeSolved:
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


class EdgeContact:
    """Surface-to-surface and edge contact of a drive (build once, sweep many).

    Parameters
    ----------
    tca : TCA
        The surface TCA of the drive (its surfaces, frames and checks are reused).
    edges : sequence of str
        Edges to analyse (keys of :data:`EDGES`); default all.
    """

    def __init__(self, tca: TCA, edges: Sequence[str] = tuple(EDGES), limit_edges: bool = True) -> None:
        t0 = time.perf_counter()
        if not isinstance(tca, TCA):
            raise ArgumentError(f"tca = {type(tca).__name__}: expected a gearopt.meshing.tca.TCA (built from the "
                                "GearPair: EdgeContact(TCA(pair)))",
                                param="tca", value=tca, valid="a gearopt.meshing.tca.TCA")
        if isinstance(edges, str):
            edges = (edges,)
        for e in edges:
            if e not in EDGES:
                raise out_of_range("edges", e, f"one of {list(EDGES)}", cls=OptionError)
        self.tca, self.edges = tca, tuple(edges)
        pair = tca.pair
        self.members = {1: pair.pinion, 2: pair.gear}
        self.teeth = {1: tca.pinion, 2: tca.gear}
        self._limit_u = {}
        if limit_edges:  # convex edges where a folded flank is cut off (as built, see LIMIT_EDGES)
            for name, (member, _, _) in LIMIT_EDGES.items():
                U = self._limit_curve(member)
                if U is not None:
                    self._limit_u[member] = U
                    self.edges += (name,)
        self.r_form = {1: tca.form_radius(1), 2: tca.form_radius(2)}
        q = ca.SX.sym("q", 5)
        prm = ca.SX.sym("prm", tca.layout.size)  # the whole column (named rows: tca.layout)
        k = tca.kinematics(q=q, prm=prm)
        reg = ca.fmin(tca.orient1 * ca.dot(ca.cross(k["t1u"], k["t1z"]), k["nf1"]),
                      tca.orient2 * ca.dot(ca.cross(k["t2u"], k["t2z"]), k["nf2"]))  # signed, see TCA
        ez1 = ca.DM([0.0, 0.0, 1.0])
        self.branches: dict[str, Branch] = {}
        self.residuals: dict[str, ca.Function] = {}
        def boundary(member, kind, sign):
            """Boundary g = 0 of a member's flank, its edge tangent t (S_f), the flank's outward
            normal a and the outward normal c of the tip cylinder / face end (all in S_f)."""
            g_m = self.members[member]
            iu, iz = (0, 1) if member == 1 else (2, 3)
            r_own = k["r1"] if member == 1 else k["r2"]
            g = ((r_own[0] ** 2 + r_own[1] ** 2 - g_m.r_a**2) / (2 * g_m.r_a) if kind == "tip"
                 else q[iz] - sign * g_m.b / 2)
            gu, gz = ca.jacobian(g, q[iu]), ca.jacobian(g, q[iz])
            tu, tz = (k["t1u"], k["t1z"]) if member == 1 else (k["t2u"], k["t2z"])
            a = k["nf1"] if member == 1 else k["nf2"]
            c = (k["er1"] if member == 1 else k["er2"]) if kind == "tip" else sign * (ez1 if member == 1 else k["ez2"])
            return g, tu * gz - tz * gu, a, c

        def cone2(a, c, n):
            """min(alpha, gamma) of n = alpha a + gamma c (least squares in the plane of a and c)."""
            Mc = ca.horzcat(a, c)
            coef = ca.solve(ca.mtimes(Mc.T, Mc), ca.mtimes(Mc.T, n))
            return ca.fmin(coef[0], coef[1])

        for name in self.edges:
            member, kind, sign = _edge_kind(name)
            if kind == "limit":
                # The flank's end u = U(z) (the crossing with the cutting surface, U fitted in z^2);
                # edge tangent t = r_u U'(z) + r_z ... as for any level curve g = u - U(z).
                iu, iz = (0, 1) if member == 1 else (2, 3)
                n_other = k["nf2"] if member == 1 else k["nf1"]
                a = k["nf1"] if member == 1 else k["nf2"]  # the flank's outward normal
                g = q[iu] - self._limit_u[member](q[iz])
                gu, gz = ca.jacobian(g, q[iu]), ca.jacobian(g, q[iz])
                tu, tz = (k["t1u"], k["t1z"]) if member == 1 else (k["t2u"], k["t2z"])
                t_edge = tu * gz - tz * gu
                te = t_edge / ca.norm_2(t_edge)
                F = ca.vertcat(k["rf1"] - k["rf2"], g, ca.dot(t_edge, n_other) / ca.norm_2(t_edge))
                # Wedge of the ridge: the flank (outward normal a) and the cutting surface, whose normal
                # is a turned by the kink angle towards the flank's continuation d (towards the root):
                # c = cos(k) a + sin(k) d. Genuine touch: -n_mate = alpha a + gamma c, alpha, gamma >= 0.
                kink = self.tca.flank_limit(member).kink
                d = tu - ca.dot(tu, a) * a - ca.dot(tu, te) * te
                d = d / ca.norm_2(d)
                m_ = -n_other
                gamma = ca.dot(m_, d) / math.sin(kink)
                alpha = ca.dot(m_, a) - gamma * math.cos(kink)
                cone = ca.fmin(alpha, gamma)
            elif kind == "cross":
                # Edge on edge (two boundary curves touching): r_f1 = r_f2 with both boundary
                # equations, 5 equations in (u1, z1, u2, z2, r_p2 phi2). The common perpendicular of
                # the two edges, n = t1 x t2 (orthogonal to both edge tangents), is the contact
                # normal. A genuine touch from outside: each member's wedge (flank + tip cylinder or
                # face end) lies on its own side of the plane through the point normal to n, i.e.
                # n is in the cone of the pinion's outward normals (a1, c1) and -n in the gear's.
                e1, e2 = (EDGES[e] for e in sign)
                g1_, t1, a1, c1 = boundary(*e1)
                g2_, t2, a2, c2 = boundary(*e2)
                F = ca.vertcat(k["rf1"] - k["rf2"], g1_, g2_)
                n = ca.cross(t1, t2)
                n = n / ca.norm_2(n)
                n = ca.if_else(ca.dot(n, a1 + c1) >= 0, n, -n)
                cone = ca.fmin(cone2(a1, c1, n), cone2(a2, c2, -n))
            elif kind == "corner":
                g_m = self.members[member]
                r_own = k["r1"] if member == 1 else k["r2"]
                g_tip = (r_own[0] ** 2 + r_own[1] ** 2 - g_m.r_a**2) / (2 * g_m.r_a)
                g_face = q[1 if member == 1 else 3] - sign * g_m.b / 2
                n_other = k["nf2"] if member == 1 else k["nf1"]
                a = k["nf1"] if member == 1 else k["nf2"]  # the flank's outward normal
                c_tip = k["er1"] if member == 1 else k["er2"]  # the tip cylinder's
                c_face = sign * (ez1 if member == 1 else k["ez2"])  # the face end's
                # Vertex contact: the corner point lies on the mating flank (3 + 2 equations).
                F = ca.vertcat(k["rf1"] - k["rf2"], g_tip, g_face)
                Mc = ca.horzcat(a, c_tip, c_face)
                coef = ca.solve(Mc, -n_other)
                cone = ca.fmin(coef[0], ca.fmin(coef[1], coef[2]))
            else:
                g, t_edge, a, c = boundary(member, kind, sign)
                n_other = k["nf2"] if member == 1 else k["nf1"]
                F = ca.vertcat(k["rf1"] - k["rf2"], g, ca.dot(t_edge, n_other) / ca.norm_2(t_edge))
                # A genuine touch: the edge's wedge (flank with outward normal a, tip cylinder or face
                # end with outward normal c) lies outside the mating tooth, i.e. the mating outward
                # normal is n = -(alpha a + gamma c) with alpha, gamma >= 0 (gamma = 0: tangency).
                cone = cone2(a, c, -n_other)
            G = ca.Function(f"edge_{_cname(name)}", [q, prm], [F], ["w", "prm"], ["F"])
            checks = ca.Function(f"edge_checks_{_cname(name)}", [q, prm], [cone, reg], ["w", "prm"], ["cone", "reg"])
            self.residuals[name] = G
            self.branches[name] = _branch(f"edge_{_cname(name)}", G, checks, tca.tol, tca.solver, tca.jit)
        self._line: TCA | None = None
        self._line_modified: TCA | None = None
        self._colmaps: dict[tuple, ColumnMap] = {}  # the flank evaluators on columns (:meth:`_columns`)
        # first guesses and coast clearances by their exact inputs (the cases of a study share them)
        self._memo: dict[tuple, object] = {}
        self.build_time = time.perf_counter() - t0

    def _limit_curve(self, member: int):
        """U(z): the flank parameter of the convex edge where the member's folded flank is cut off
        (as built), a polynomial in z^2 through the exact limits of 9 sections (constant without
        plunging); None if the flank does not end at a convex crossing."""
        tca = self.tca
        lim0 = tca.flank_limit(member, 0.0)
        if lim0.kind != "intersection" or not lim0.kink > 0:
            return None
        s_grid, u_grid = tca.limit_table(member)
        kinds = [tca.flank_limit(member, math.sqrt(v)).kind for v in s_grid]
        if any(k != "intersection" for k in kinds):
            return None
        zs = ca.SX.sym("z")
        if s_grid.size == 1:
            expr = ca.SX(float(u_grid[0])) + 0 * zs
        else:
            c = np.polyfit(s_grid / s_grid[-1], u_grid, min(4, s_grid.size - 1))
            t = zs**2 / s_grid[-1]
            expr = 0 * zs
            for ck in c:
                expr = expr * t + float(ck)
        return ca.Function(f"limit_u{member}", [zs], [expr])

    def _accept(self, res, cone, reg):
        return _accept_edge(res, cone, reg, self.tca.tol)

    # ------------------------------------------------------------------------------------------
    def _line_tca(self) -> TCA:
        if self._line is None:
            t = self.tca
            # the unmodified generated teeth: first guesses come from the conjugate drive (see _sections)
            self._line = TCA(t.pair, side=t.side, pinion=t.pinion.unmodified, gear=t.gear.unmodified, solver=t.solver,
                             contact="line")
        return self._line

    def _surface_line_tca(self) -> TCA:
        """Line-contact TCA of the teeth as they are (every modification and crowning kept): the
        surface branch of a drive whose point-contact TCA is singular (line contact)."""
        if self._line_modified is None:
            t = self.tca
            if t.pinion is t.pinion.unmodified and t.gear is t.gear.unmodified:
                self._line_modified = self._line_tca()
            else:
                self._line_modified = TCA(t.pair, side=t.side, pinion=t.pinion, gear=t.gear, solver=t.solver,
                                          contact="line")
        return self._line_modified

    def __getstate__(self):
        # picklable like Branch: the column evaluators (possibly compiled libraries) and the memo
        # are rebuilt on demand where it lands
        state = dict(self.__dict__)
        state["_colmaps"], state["_memo"] = {}, {}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    #: entries of the memo of first guesses and clearances (the oldest go first)
    _MEMO_SIZE = 16

    def _remember(self, key: tuple, value):
        """Keep ``value`` under ``key`` in the memo (the oldest entry goes beyond ``_MEMO_SIZE``)."""
        if len(self._memo) >= self._MEMO_SIZE:
            self._memo.pop(next(iter(self._memo)))
        self._memo[key] = value
        return value

    # ------------------------------------------------------------------------------------------
    def sweep(self, phi1: ArrayLike, p1: Param = None, p2: Param = None, mis: Misalignment | None = None,
              pairs: Sequence[int] = (-1, 0, 1)) -> EdgeTCAResult:
        """Surface and edge contact over ``phi1`` [rad] for the tooth pairs ``pairs``.

        Returns
        -------
        EdgeTCAResult
        """
        t0 = time.perf_counter()
        tca = self.tca
        phi1, p1, p2, mis, pairs = check_sweep_args(tca, phi1, p1, p2, mis, pairs, z_section=None)
        self._check_not_jammed(p1, p2)
        z1 = self.members[1].z
        phis = np.concatenate([phi1 - 2 * math.pi * k / z1 for k in pairs])
        prm = tca.prm(phis, p1, p2, mis)
        # Every pair is pair 0 at a shifted angle: solve the distinct angles once, in order.
        uphi, inv_idx = np.unique(np.round(phis, 13), return_inverse=True)
        uprm = tca.prm(uphi, p1, p2, mis)
        names = (SURFACE,) + self.edges
        B, M = len(names), phis.size
        Q = np.full((B, 5, M), np.nan)
        conv = np.zeros((B, M), bool)
        cone = np.full((B, M), np.nan)  # min(alpha, gamma) of the edge points (0: tangency)
        stats = {}
        # Surface branch (line contact in the mid section when the drive is in line contact).
        surf = None
        try:
            try:
                surf = tca.sweep(phi1, p1, p2, mis, pairs=pairs, continuation=False)
            except LineContactError:
                stats["surface_mode"] = "line contact (mid section)"
                surf = self._surface_line_tca().sweep(phi1, p1, p2, mis, pairs=pairs, continuation=False)
            Q[0] = np.vstack([surf.u1.ravel(), surf.z1.ravel(), surf.u2.ravel(), surf.z2.ravel(),
                              (surf.phi2 - np.array([2 * math.pi * k / self.members[2].z for k in pairs])[:, None]
                               ).ravel() * tca.scale2])
            conv[0] = surf.converged.ravel()
        except ConvergenceError as e:
            stats["surface"] = f"no surface-to-surface contact: {e}"
        # Edge branches. Every position is solved on its own, from first guesses that depend on that
        # position only (never on the other positions of the sweep: no sweep-wide anchor, predictor
        # or continuation), so a contact does not depend on the grid. The guesses come from the
        # conjugate contact of the aligned, unmodified drive in several pinion sections at the same
        # phi1, moved onto the edge; of the accepted roots the one that gives the gear the largest
        # advance among those on the finite flanks is kept (the gear rests against it).
        guesses = self._first_guesses(uphi, p1, p2)
        Mu = uphi.size
        solved = []  # (branch index, name, G, W, ok, cone) of every branch solved
        for b, name in enumerate(self.edges, start=1):
            member, kind, _ = _edge_kind(name)
            if kind == "limit" and not np.array_equal(p1 if member == 1 else p2, self.teeth[member].p0):
                stats[name] = "skipped: the flank-limit edge is built for the member as built (p0)"
                continue
            W0s = guesses[name]
            if not W0s:
                stats[name] = "no first guess"
                continue
            br = self.branches[name]
            G = len(W0s)
            W0 = np.hstack(W0s)
            # only the columns with a first guess are solved (the others are no contact)
            good0 = np.all(np.isfinite(W0), axis=0)
            W = np.full(W0.shape, np.nan)
            res, cn, reg = (np.full(W0.shape[1], np.nan) for _ in range(3))
            if good0.any():
                g = np.flatnonzero(good0)
                P = uprm[:, g % Mu]  # column j of the G stacked guesses is at the angle uphi[j % Mu]
                W[:, g], res[g], cn[g], reg[g] = (
                    np.asarray(v).ravel() if i else np.asarray(v)
                    for i, v in enumerate(br.mapped(g.size, W0.shape[1])(W0[:, g], P)))
            ok = np.asarray(br.accept(res, cn, reg), bool) & good0
            solved.append((b, name, G, np.where(ok, W, np.nan), ok, cn))
            stats[name] = None  # (below; keeps the branches' order)
        if solved:  # which roots lie on the finite flanks: every branch's columns in one call
            W_all = np.hstack([W for *_, W, _, _ in solved])
            inside = self._inside(W_all, np.tile(uphi, sum(G for _, _, G, *_ in solved)), p1, p2, mis)
        start = 0
        for b, name, G, W, ok, cn in solved:
            valid = inside[start:start + G * Mu] & ok
            start += G * Mu
            te_g = np.where(ok, W[4] / tca.scale2, -np.inf).reshape(G, Mu)
            score = np.where(valid.reshape(G, Mu), te_g, -np.inf)
            # valid roots first; otherwise the largest accepted one (reported as converged, not valid)
            pick = np.where(np.isfinite(score).any(axis=0), np.argmax(score, axis=0), np.argmax(te_g, axis=0))
            cols = pick * Mu + np.arange(Mu)
            Wb, okb, cnb = W[:, cols], ok[cols], cn[cols]
            Q[b], conv[b], cone[b] = Wb[:, inv_idx], okb[inv_idx], cnb[inv_idx]
            stats[name] = {"n_starts": int(W.shape[1]), "n_accepted": int(ok.sum()), "n_positions": int(okb.sum())}
        return self._combine(_EdgeSolved(phi1=phi1, pairs=pairs, names=names, Q=Q, conv=conv, cone=cone, prm=prm,
                                         mis=mis, surf=surf, stats=stats, t0=t0, p1=p1, p2=p2))

    # ------------------------------------------------------------------------------------------
    _SECTIONS = (-0.5, -0.25, 0.0, 0.25, 0.5)  #: pinion sections of the first guesses [b1]

    def _first_guesses(self, uphi, p1, p2) -> dict:
        """{edge name: list of (5, M) first guesses} at the pair-0 angles ``uphi``
        (:meth:`_guesses` from :meth:`_sections`): they depend on the angles and the settings only,
        not on the misalignment, so they are memoised per exact (uphi, p1, p2) and the cases of a
        study solve them once. Callers must not write into the arrays."""
        key = ("guesses", _key(uphi), _key(p1), _key(p2))
        hit = self._memo.get(key)
        if hit is None:
            hit = self._remember(key, self._guesses(self._sections(uphi, p1, p2), p1, p2))
        return hit

    def _sections(self, uphi, p1, p2) -> dict:
        """Conjugate contact of the aligned drive with the crowning removed in the pinion sections
        z = s b1 (s in _SECTIONS) at each angle of ``uphi``: {s: (5, M) full unknowns, NaN where
        none} (:func:`conjugate_sections`)."""
        b1 = self.members[1].b
        secs = conjugate_sections(self.tca, self._line_tca(), uphi, p1, p2, [s * b1 for s in self._SECTIONS])
        return {s: secs[s * b1] for s in self._SECTIONS if s * b1 in secs}

    def _columns(self, what: str, member: int) -> ColumnMap:
        """A flank evaluator of ``member`` on any number of columns, built once per EdgeContact
        (:class:`gearopt.compiled.ColumnMap`: maps of a few fixed sizes, numpy in and out; the
        compiled library when it is in the disk cache, as the branches' solves): ``"radius"``
        (u, z, p) -> (transverse radius [mm], d radius / du) of the driving flank, ``"point"``
        (u, z, p) -> the flank point r [mm] (the surface's first output only)."""
        key = (what, member)
        cm = self._colmaps.get(key)
        if cm is None:
            tooth, side = self.teeth[member], self.tca.side
            if what == "radius":
                f = tooth.radius_function(side)
            else:
                s = tooth.surface(side, "flank")
                u, z, p = ca.SX.sym("u"), ca.SX.sym("z"), ca.SX.sym("p", s.size1_in(2))
                f = ca.Function(f"flank_point{member}", [u, z, p], [s(u, z, p)[0]], ["u", "z", "p"], ["r"])
            cm = self._colmaps[key] = mapped(f, 1, self.tca.jit)
        return cm

    def _u_at(self, member, radius, z, p):
        """Vectorised flank parameter u at transverse ``radius`` and axial ``z`` (Newton; NaN where
        it fails)."""
        tooth = self.teeth[member]
        z = np.asarray(z, float)
        n = z.size
        f = self._columns("radius", member)
        u = np.full(n, float(tooth.extras.get("q_pitch", 0.0)))
        P = np.tile(np.asarray(p, float)[:, None], n)
        zz = np.where(np.isfinite(z), z, 0.0)[None, :]
        for _ in range(40):
            rad, d = (v.ravel() for v in f(u[None, :], zz, P))
            with np.errstate(invalid="ignore", divide="ignore"):
                step = np.where(d < 0, (rad - radius) / d, np.nan)
            u = u - step
            if np.all(~np.isfinite(step) | (np.abs(step) < 1e-12)):
                break
        return np.where(np.isfinite(z) & np.isfinite(u), u, np.nan)

    def _guesses(self, sections, p1, p2) -> dict:
        """First guesses {edge name: list of (5, M)} from the conjugate section solutions
        ``sections`` ({s: (5, M)}): the section points moved onto each edge (slid along the face
        width onto a face end, along the profile onto the tip circle, or the contact line
        interpolated to where it crosses a tip circle). The points put on a member's tip circle
        are solved together (:meth:`_u_at` once per member: a point's u depends on its own z only)."""
        secs = [sections[s] for s in self._SECTIONS if s in sections]
        if not secs:
            return {name: [] for name in self.edges}
        prm_of = {1: p1, 2: p2}
        tips: dict[int, list] = {1: [], 2: []}  # points whose u_m is put on member m's tip circle

        def on_face(Qs, m, sg):  # slide the conjugate point along the face width onto the face end m
            q0 = Qs.copy()
            shift = sg * self.members[m].b / 2 - q0[1 if m == 1 else 3]
            q0[1] += shift
            q0[3] += shift
            return q0

        def on_tip(q0, m):  # q0's u_m onto member m's tip circle (in place, below: it reads z_m only)
            tips[m].append(q0)
            return q0

        # The conjugate contact line interpolated to where it crosses member m's tip circle.
        S_all = np.hstack(secs)
        M = secs[0].shape[1]
        crossing = {}
        for m in (1, 2):
            rads = self._radius(m, S_all, prm_of[m]).reshape(len(secs), M) - self.members[m].r_a
            out = np.full((5, M), np.nan)
            for j in range(len(secs) - 1):
                f0, f1 = rads[j], rads[j + 1]
                br = np.isfinite(f0) & np.isfinite(f1) & (np.sign(f0) != np.sign(f1)) & ~np.isfinite(out[0])
                with np.errstate(invalid="ignore", divide="ignore"):
                    t = np.where(br, f0 / (f0 - f1), np.nan)
                out = np.where(br, secs[j] + t * (secs[j + 1] - secs[j]), out)
            crossing[m] = out
        # the crossings on the tip circles (the tip edges' first guesses, and slid onto a face end
        # for the tip/face crossings, once they are solved)
        tipx = {m: on_tip(crossing[m].copy(), m) for m in (1, 2)}
        slide = []  # (name, face member, face sign, tip member): on_face of a solved tip crossing

        out = {}
        for name in self.edges:
            member, kind, sign = _edge_kind(name)
            if kind == "limit":  # the conjugate section points moved onto the flank's end u = U(z)
                iu, iz = (0, 1) if member == 1 else (2, 3)
                U = self._limit_u[member]
                guesses = []
                for S in secs:
                    q0 = S.copy()
                    zz = np.where(np.isfinite(q0[iz]), q0[iz], 0.0)
                    q0[iu] = np.asarray(U.map(zz.size)(zz[None, :])).ravel()
                    guesses.append(q0)
                out[name] = guesses
            elif kind == "face":
                out[name] = [on_face(secs[0 if sign < 0 else -1], member, sign)]
            elif kind == "corner":
                out[name] = [on_tip(on_face(secs[0 if sign < 0 else -1], member, sign), member)]
            elif kind == "tip":
                out[name] = [tipx[member]] + [on_tip(S.copy(), member) for S in secs]
            else:  # edge on edge
                (m1, k1, s1), (m2, k2, s2) = (EDGES[e] for e in sign)
                if k1 == "tip" and k2 == "tip":  # each tip crossing onto both tip circles
                    out[name] = [on_tip(on_tip(crossing[1].copy(), 1), 2), on_tip(on_tip(crossing[2].copy(), 2), 1)]
                else:
                    face_m, face_s, tip_m = (m2, s2, m1) if k2 == "face" else (m1, s1, m2)
                    out[name] = [on_tip(on_face(secs[0 if face_s < 0 else -1], face_m, face_s), tip_m)]
                    slide.append((name, face_m, face_s, tip_m))
        for m in (1, 2):
            if tips[m]:
                iu, iz = (0, 1) if m == 1 else (2, 3)
                z = np.concatenate([q[iz] for q in tips[m]])
                u = self._u_at(m, self.members[m].r_a, z, prm_of[m])
                n = 0
                for q in tips[m]:
                    q[iu] = u[n:n + q.shape[1]]
                    n += q.shape[1]
        for name, face_m, face_s, tip_m in slide:
            out[name].append(on_face(tipx[tip_m], face_m, face_s))
        return out

    def _radius(self, member, Q, prm=None):
        """Transverse radius of the contact point on ``member`` for the columns of Q (NaN-safe)."""
        tooth = self.teeth[member]
        iu, iz = (0, 1) if member == 1 else (2, 3)
        p = tooth.p0 if prm is None else prm
        good = np.isfinite(Q[iu]) & np.isfinite(Q[iz])
        out = np.full(Q.shape[1], np.nan)
        if good.any():
            n = int(good.sum())
            r = self._columns("point", member)(Q[iu][good][None, :], Q[iz][good][None, :],
                                               np.tile(np.asarray(p, float)[:, None], n))
            out[good] = np.hypot(r[0], r[1])
        return out

    # ------------------------------------------------------------------------------------------
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

    def _combine(self, sv: "_EdgeSolved"):
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

    def _coast_clearance(self, p1, p2, mis: Misalignment) -> float:
        """Upper bound of the gear's advance over the conjugate position of the aligned drive [rad]:
        circumferential backlash plus the pinion thinning by crowning plus what the misalignment can
        open, on the operating pitch circle of the gear (a generous bound of the coast-side
        clearance), plus the rigid displacement of the gear by the misalignment. Memoised per exact
        (p1, p2, mis)."""
        key = ("coast", _key(p1), _key(p2), _key([getattr(mis, k) for k in mis.names()]))
        hit = self._memo.get(key)
        if hit is None:
            hit = self._remember(key, self._coast_clearance_of(p1, p2, mis))
        return hit

    def _coast_clearance_of(self, p1, p2, mis: Misalignment) -> float:
        pair, tca = self.tca.pair, self.tca
        g1 = pair.pinion
        r_w2 = pair.r_w2
        a_pl, a_c, u_0 = (p1[tca.layout.p_index("pinion", k)] for k in ("a_pl", "a_c", "u_0"))
        u_f, _ = tca.pinion.junction(p1)
        u_tip = tca.pinion.u_at_radius(g1.r_a, 0.0, tca.side, p1)
        u_span = max(abs(u_tip - u_0), abs(u_f - u_0))
        thin = 2 * (a_pl * (g1.b / 2) ** 2 * math.tan(pair.alpha_wt) + a_c * u_span**2)
        opened = mis.backlash_opening(pair)
        # The misalignment also moves the gear rigidly against the conjugate position: a point P of
        # its flank moves by at most the sum of the displacements plus the angles times |P - O2|
        # (Misalignment.rigid_displacement; the angles turn the gear about its centre: for a helical
        # gear that is an axial shift of the mesh, i.e. a rotation), which the gear's rotation takes
        # up along the normal, on the lever r_b2 cos(beta_b) at least.
        g2 = pair.gear
        lever = math.hypot(g2.r_a, g2.b / 2)
        moved = mis.rigid_displacement(lever) / (g2.r_b * math.cos(g2.beta_b))
        mods = self.modification_extent(p1, p2)
        # ISO/measured modifications: material added on a driving flank lets the gear advance past the
        # conjugate position by that much along the normal; material removed on a coast flank widens
        # the coast-side gap (both on the normal lever r_b2 cos(beta_b)).
        iso = (mods.added_drive + mods.removed_coast) / (g2.r_b * math.cos(g2.beta_b))
        return (max(pair.backlash, 0.0) + thin + opened) / r_w2 + moved + iso + 1e-9

    #: grid of the modification check: flank points along the profile and sections across the face
    _MOD_GRID = (13, 41)

    def modification_extent(self, p1: Param, p2: Param) -> "ModificationExtent":
        """Extremes of the flank modifications (ISO amounts, measured topographies, any
        :class:`~gearopt.geometry.modification.FlankModification`) of both members for ``p1``,
        ``p2``, sampled on the active flanks (``_MOD_GRID`` points along the profile from the form
        to the tip circle, times sections across the common face width). Cached per (p1, p2)."""
        key = (tuple(np.round(np.asarray(p1, float), 15)), tuple(np.round(np.asarray(p2, float), 15)))
        cache = self.__dict__.setdefault("_mod_cache", {})
        if key in cache:
            return cache[key]
        tca = self.tca
        nu, nz = self._MOD_GRID
        half = 0.5 * min(self.members[1].b, self.members[2].b)
        zs = np.linspace(-half, half, nz)
        drive, coast = tca.side, ("left" if tca.side == "right" else "right")
        added_drive = removed_coast = 0.0
        thick = np.zeros(nz)  # tooth thickening at each section, both members [mm, along the normal]
        for member, tooth, p in ((1, tca.pinion, p1), (2, tca.gear, p2)):
            if not tooth.modifications:
                continue
            d = {side: _flank_deviation_grid(tooth, side, p, zs, nu) for side in (drive, coast)}
            added_drive = added_drive + max(0.0, float(np.nanmax(d[drive])))
            removed_coast = removed_coast + max(0.0, -float(np.nanmin(d[coast])))
            thick = thick + np.nanmax(d[drive], axis=0) + np.nanmax(d[coast], axis=0)
        j = int(np.argmax(thick))
        t_max, z_max = float(thick[j]), float(zs[j])
        if 0 < j < nz - 1:  # the vertex of the parabola through the largest sample and its neighbours
            a, b_, c = thick[j - 1], thick[j], thick[j + 1]
            den = a - 2 * b_ + c
            if den < 0:
                s = 0.5 * (a - c) / den
                t_max, z_max = float(b_ - 0.25 * (a - c) * s), float(zs[j] + s * (zs[1] - zs[0]))
        out = ModificationExtent(added_drive=added_drive, removed_coast=removed_coast, thickening=t_max,
                                 z_thickest=z_max)
        cache[key] = out
        return out

    def _check_not_jammed(self, p1, p2) -> None:
        """A pair whose modified teeth are thicker, in some section, than the normal backlash
        leaves room for cannot turn: both flanks of a tooth touch the mating teeth (GeometryError)."""
        ext = self.modification_extent(p1, p2)
        j_bn = self.tca.pair.backlash_normal[0]
        if ext.thickening > max(j_bn, 0.0) + JAM_TOL:
            raise GeometryError(
                f"the pair jams: the flank modifications make the teeth {ext.thickening * 1e3:.3g} um thicker "
                f"(drive plus coast flank, along the normal, both members) at z = {ext.z_thickest:.3g} mm than the "
                f"unmodified teeth, while the smallest normal backlash j_bn is {max(j_bn, 0.0) * 1e3:.3g} um; the coast "
                "flanks would be in contact as well. Increase the backlash (thinner teeth: A_sne, or a larger "
                "centre distance) or remove material instead of adding it (modification amounts, sides = "
                "\"right\"/\"left\" for one flank only).")

    @staticmethod
    def _surface_zero(surf: TCAResult, te_raw_surface, k0) -> float:
        # The surface TCA measures TE from phi2 at phi1 = 0 of pair 0; recover that constant so that
        # the surface branch here equals surf.te.
        diff = te_raw_surface.reshape(surf.te.shape) - surf.te
        vals = diff[np.isfinite(diff)]
        return float(np.median(vals)) if vals.size else 0.0


def conjugate_sections(tca: TCA, line_tca: TCA, phis: ArrayLike, p1: Param, p2: Param, z_sections: ArrayLike) -> dict:
    """Conjugate contact of the aligned drive of ``tca`` with its crowning and flank modifications
    removed (``line_tca``: a line-contact TCA of the unmodified teeth; only the tool shifts x of
    ``p1``, ``p2`` kept) in the pinion sections ``z_sections`` [mm] at the angles ``phis`` [rad]:
    {z: (5, M) full unknowns (u1, z1, u2, z2, r_p2 phi2), NaN where none}. Each column is solved by
    itself (Newton from the linear prediction around phi1 = 0, which depends on that angle only); a
    section without a solution at phi1 = 0 is left out. First guesses of edge contact and of the
    loaded-TCA slices."""
    lay = tca.layout
    n1, n2 = (len(t.unmodified.param_names) for t in (tca.pinion, tca.gear))  # generation settings only
    flat1, flat2 = np.zeros(n1), np.zeros(n2)
    flat1[lay.p_index("pinion", "x")] = p1[lay.p_index("pinion", "x")]
    flat2[lay.p_index("gear", "x")] = p2[lay.p_index("gear", "x")]
    phis = np.asarray(phis, float)
    aligned = Misalignment()
    found, W0s, prms = [], [], []
    for zs in z_sections:
        try:
            w_a = line_tca.solve_point(0.0, None, flat1, flat2, aligned, zs)
        except ConvergenceError:
            continue
        found.append(zs)
        prms.append(line_tca.prm(phis, flat1, flat2, aligned, zs))
        W0s.append(line_tca.branch.predict(w_a, line_tca.prm([0.0], flat1, flat2, aligned, zs)[:, 0], phis))
    if not found:
        return {}
    # every section's columns in one mapped solve and one w_full map (each column solved by itself)
    n = phis.size * len(found)
    W, res, _, _ = (np.asarray(v) for v in line_tca.branch.mapped(n, phis.size * len(z_sections))(
        np.hstack(W0s), np.hstack(prms)))
    res = res.ravel()
    Wf = np.asarray(line_tca.w_full.map(n)(W, np.repeat(np.asarray(found, float), phis.size)[None, :]))
    Wf[:, ~(np.isfinite(res) & (res <= 1e-8))] = np.nan
    return {zs: Wf[:, j * phis.size:(j + 1) * phis.size] for j, zs in enumerate(found)}


@dataclass(frozen=True)
class ModificationExtent:
    """Extremes of the flank modifications of a drive (:meth:`EdgeContact.modification_extent`).

    Attributes
    ----------
    added_drive : float
        Largest material added on the driving flanks, pinion plus gear [mm, along the normal].
    removed_coast : float
        Largest material removed from the coast flanks, pinion plus gear [mm].
    thickening : float
        Largest thickening of the teeth in one section: added on the drive plus the coast flank,
        both members [mm]; > normal backlash: the pair jams.
    z_thickest : float
        Section of ``thickening`` [mm].
    """

    added_drive: float
    removed_coast: float
    thickening: float
    z_thickest: float


#: tolerance of the jam check [mm] (1 nm: round-off of the sampled deviations)
JAM_TOL = 1e-6


def _flank_deviation_grid(tooth, side: str, p, zs, n_u: int) -> np.ndarray:
    """Normal deviation [mm] of ``tooth``'s modified ``side`` flank, (n_u, len(zs)): ``n_u`` points
    from the form circle (the fillet junction) to the tip circle in each section of ``zs`` [mm]."""
    p = np.asarray(p, float)
    u_f, _ = tooth.junction(p)
    out = np.full((n_u, len(zs)), np.nan)
    for j, z in enumerate(zs):
        try:
            u_a = tooth.u_at_radius(tooth.gear.r_a, float(z), side, p)
        except GearoptError:
            u_a = float(tooth.extras.get("q_pitch", 0.0))
        u = np.linspace(u_a, u_f, n_u)
        out[:, j] = tooth.normal_deviation(side, u, np.full(n_u, float(z)), p)
    return out


def _accept_edge(res, cone, reg, tol):
    # Edge contact: residual small, the edge touches from outside (cone >= 0, see
    # EdgeContact.__init__), both flanks regular at the point.
    return np.isfinite(res) & (res <= tol) & (cone > -1e-9) & (reg > REGULARITY_MIN)


#: Branches by their exact equations (:func:`_branch`): the edge system of a drive is the same graph
#: for every crowning and misalignment (symbolic parameters), so the drives before and after a
#: crowning optimisation share their rootfinders and compiled maps. The oldest go beyond 64.
_BRANCHES: dict[tuple, Branch] = {}


def _branch(name: str, G: ca.Function, checks: ca.Function, tol: float, solver: str, jit) -> Branch:
    """The :class:`Branch` of the edge system ``G`` with ``checks`` (built once per process for
    each exact graph, tolerance, solver and jit setting: the key is the serialised Functions)."""
    key = (name, hashlib.sha256((G.serialize() + checks.serialize()).encode()).hexdigest(), float(tol), solver,
           str(jit))
    br = _BRANCHES.get(key)
    if br is None:
        if len(_BRANCHES) >= 64:
            _BRANCHES.pop(next(iter(_BRANCHES)))
        br = _BRANCHES[key] = Branch(name, G, checks, functools.partial(_accept_edge, tol=tol), tol, solver, jit)
    return br


def _key(v) -> bytes:
    """Exact key of a numeric vector (its float64 bytes: -0.0 and 0.0 differ, NaN keys itself)."""
    return np.ascontiguousarray(np.asarray(v, float)).tobytes()


def _edge_kind(name: str):
    return EDGES[name] if name in EDGES else LIMIT_EDGES[name]


def _cname(name: str) -> str:
    return name.replace("+", "_pos").replace("-", "_neg").replace("/", "_x_")


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
