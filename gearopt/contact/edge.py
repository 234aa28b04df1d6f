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
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..compiled import ColumnMap
from ..errors import ArgumentError, ConvergenceError, LineContactError, OptionError, out_of_range
from ..meshing.misalignment import Misalignment
from ..meshing.solver import REGULARITY_MIN, Branch
from ..meshing.sweep_args import check_sweep_args
from ..meshing.tca import TCA
from .edge_clearance import EdgeClearance
from .edge_guesses import EdgeFirstGuesses
from .edge_kinds import EDGES, LIMIT_EDGES, SURFACE, edge_kind
from .edge_result import EdgeCombination, EdgeSolved, EdgeTCAResult

if TYPE_CHECKING:
    from collections.abc import Sequence
    from ..types import ArrayLike, Param


class EdgeContact(EdgeFirstGuesses, EdgeClearance, EdgeCombination):
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
            member, kind, sign = edge_kind(name)
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
            member, kind, _ = edge_kind(name)
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
        return self._combine(EdgeSolved(phi1=phi1, pairs=pairs, names=names, Q=Q, conv=conv, cone=cone, prm=prm,
                                         mis=mis, surf=surf, stats=stats, t0=t0, p1=p1, p2=p2))


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


def _cname(name: str) -> str:
    return name.replace("+", "_pos").replace("-", "_neg").replace("/", "_x_")
