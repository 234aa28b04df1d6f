"""Unloaded separations of the potential contact, slice by slice (docs/ltca.md, section 1).

At a pinion angle phi1 the potential contact of each tooth pair is cut by transverse pinion
sections ``z1 = z_j`` (slices). In each slice the gear angle ``phi2_j`` at which the pinion's
profile curve in that section first touches the gear flank solves, with the unknowns
``w = (u1, u2, z2, r_p2 phi2)`` [mm],

    r_f1(u1, z_j, phi1) - r_f2(u2, z2, phi2) = 0      (the slice's point lies on the gear flank)
    n_f2 . dr_f1/du1 = 0                              (the profile curve is tangent to the flank)

built on the TCA's own kinematics Function, so every flank modification, tool setting and
misalignment of the TCA is in it (the same symbolic parameter column). Where the surfaces are in
line contact these are the line-contact TCA equations; for a crowned pinion the slice through the
point contact gives the unloaded TCA's phi2 exactly and every other slice touches later. The slices
are fixed to the tooth: the same ``n_slices`` pinion sections across the face for every pair,
position and design (:func:`slice_nodes`), so the loaded results are continuous in every
modification and misalignment. A slice carries load where its point lies on both active flanks
(below both tips, above both flank limits, on both faces), and, with a share that vanishes as the
boundary reaches its neighbour, just past a boundary (:func:`_partial_widths`); the face ends are
slices themselves, so contact at a face end (edge contact of a crowned or misaligned drive) is a
slice at ``z = +-b/2``.

The transmission error of slice j is ``te_j = phi2_j - (z1/z2) phi1 - phi2_ref`` [rad]; at zero
load the gear rests on the slice with the largest te (the unloaded TE), and the separation of
slice j along the contact normal is ``s_j = (te_max - te_j) r_b2 cos(beta_b)`` [mm] (the normal
displacement of an involute helicoid turned by an angle about its axis).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..compiled import call, mapped, source_tag, use_compiled
from ..errors import ArgumentError, ConvergenceError
from ..graph_cache import built_once, eliminated
from ..meshing.curvature import Sym, eigh2_sym, shape_matrix, unit_perp
from ..meshing.misalignment import Misalignment
from ..meshing.solver import REGULARITY_MIN, Branch
from ..meshing.sweep_args import check_sweep_args
from ..meshing.tca import TCA

SLICE_NORMAL_TOL = 0.05  #: accepted slice points have n1 . n2 < -1 + this (crowning tilts the normals)
_SECTIONS = (-0.5, -0.25, 0.0, 0.25, 0.5)  #: pinion sections of the conjugate first guesses [b1]
PARTNER_MIN = 1e-4  #: smallest weight [share of the slice spacing] with which a node past a boundary joins the contact
EDGE_CHUNK = 256  #: columns per mapped tip-edge solve at most
CONJUGATE_CACHE = 4  #: first-guess sets (conjugate sections) a SliceSolver keeps (per angles and tool shifts)


@dataclass
class SliceSet:
    """Slices of every tooth pair at every position, shape (K, N, M): K pairs, N positions, M
    slice nodes (unused nodes: ``z`` NaN, ``active`` False).

    Attributes
    ----------
    phi1 : (N,) pinion angles [rad]; pairs : tuple of pinion tooth numbers.
    z : (K, N, M) pinion section of each slice node [mm] (ascending over M), NaN if unused.
    width : (K, N, M) the node's share of the contact [mm], the length of its Hertz contact (face ends:
        half a gap; where the contact line leaves the active flanks, up to the crossing, shared with the
        node past it: ``_partial_widths``); unused nodes: their tooth width.
    width_tooth : (K, N, M) the node's tributary width of the tooth [mm] (the trapezoidal weights of the
        fixed grid, :func:`slice_nodes`), for the compliance along the face: the tooth is there whether
        or not the contact covers it.
    z_lo, z_hi : (K, N, M) the node's tributary interval [mm] (its contact where active).
    te : (K, N, M) TE at which the slice touches [rad] (NaN where unsolved).
    active : (K, N, M) the slice carries load: its point lies on both active flanks (``inside``), or it is
        the neighbour past the boundary where the contact line leaves them (a ``partner``: it carries its
        linear-interpolation share of the contact up to the crossing, see ``_partial_widths``).
    inside : (K, N, M) the slice's point lies on both active flanks.
    te_bound : (K, N, M) TE at the crossings next to each inside node [rad] (NaN: none), for the
        unloaded TE.
    partner_of, partner_t : (K, N, M) of a partner, its inside neighbour (node index, -1: not a partner)
        and the fraction of the gap from that neighbour at which the contact line leaves the flanks
        (a partner's ``te`` is interpolated to that crossing, and so is the pressure reported for it,
        :class:`~gearopt.ltca.engine.LTCA`).
    converged : (K, N, M) the slice equations were solved.
    r1, n1, r2, n2 : (K, N, M, 3) point and outward unit normal on pinion / gear in their own frames.
    rf : (K, N, M, 3) the point in the fixed frame [mm].
    u1, u2, z2 : (K, N, M) surface coordinates [mm].
    edge : (K, N, M) int: 0 surface contact, 1 the pinion's tip edge on the gear flank, 2 the gear's
        tip edge on the pinion flank (slices whose conjugate point lies beyond that tip).
    w : (K, N, M, 4) the solved unknowns ``(u1, u2, z2, r_p2 phi2)`` [mm] of each slice's equations
        (flank or tip-edge; NaN where unsolved), for sensitivities of the slices.
    kappa1, kappa2 : (K, N, M) normal curvature of the pinion / gear flank across the contact line at
        the slice's point [1/mm] (:func:`across_line_curvatures`; at a tip-edge slice, of the flank
        surface continued to the edge), NaN where unsolved.
    nc1, nc2 : (K, N, M, 3) the line of action of the slice's force in the pinion's / gear's own frame,
        pointing out of that member (the load on the tooth is along -nc): ``n1`` / ``n2`` on a flank
        slice; at the pinion's tip edge (1) the gear flank's normal, at the gear's tip edge (2) the
        pinion flank's normal.
    lever1, lever2 : (K, N, M) moment arm of the slice's force about the pinion / gear axis [mm]
        (``r_b cos(beta_b)`` on an involute helicoid; smaller on a tip edge, whose force is the mating
        flank's normal at a point off the path of contact), NaN where unsolved.
    """

    phi1: np.ndarray
    pairs: tuple
    z: np.ndarray
    width: np.ndarray
    z_lo: np.ndarray
    z_hi: np.ndarray
    te: np.ndarray
    active: np.ndarray
    converged: np.ndarray
    r1: np.ndarray
    n1: np.ndarray
    r2: np.ndarray
    n2: np.ndarray
    rf: np.ndarray
    u1: np.ndarray
    u2: np.ndarray
    z2: np.ndarray
    phi2_ref: float
    stats: dict
    edge: np.ndarray | None = None
    w: np.ndarray | None = None
    kappa1: np.ndarray | None = None
    kappa2: np.ndarray | None = None
    nc1: np.ndarray | None = None
    nc2: np.ndarray | None = None
    lever1: np.ndarray | None = None
    lever2: np.ndarray | None = None
    inside: np.ndarray | None = None
    te_bound: np.ndarray | None = None
    partner_of: np.ndarray | None = None
    partner_t: np.ndarray | None = None
    width_tooth: np.ndarray | None = None

    @property
    def te_unloaded(self) -> np.ndarray:
        """(N,) unloaded TE [rad]: the largest TE of the slices on the active flanks and of the points
        where the contact lines leave them (``te_bound``) (NaN: no contact)."""
        on = self.active if self.inside is None else self.inside
        t = np.max(np.where(on, self.te, -np.inf), axis=(0, 2))
        if self.te_bound is not None:
            t = np.maximum(t, np.max(np.where(np.isfinite(self.te_bound), self.te_bound, -np.inf), axis=(0, 2)))
        return np.where(np.isfinite(t), t, np.nan)


def across_line_curvatures(rf1: Sym, nf1: Sym, q1: Sym, rf2: Sym, nf2: Sym, q2: Sym) -> tuple[Sym, Sym]:
    """Normal curvatures [1/mm] of both flanks across the contact line at a contact point (convex
    positive, each with its own outward normal): with ``K1``, ``K2`` the surfaces' curvature matrices
    in one orthonormal tangent basis (:func:`gearopt.meshing.curvature.shape_matrix`; ``rf``, ``nf`` in the
    fixed frame as CasADi expressions of the surface coordinates ``q``), the direction ``v`` of the
    larger eigenvalue of ``K1 + K2`` (the relative curvature ``1 / R*``; the smaller one lies along
    the contact line, zero for line contact) gives ``(v^T K1 v, v^T K2 v)``."""
    e1 = unit_perp(nf1)
    E = ca.horzcat(e1, ca.cross(nf1, e1))
    K1, K2 = (shape_matrix(r, n, q, E) for r, n, q in ((rf1, nf1, q1), (rf2, nf2, q2)))
    K1, K2 = 0.5 * (K1 + K1.T), 0.5 * (K2 + K2.T)
    v = eigh2_sym(K1 + K2)[1][:, 1]
    return ca.mtimes([v.T, K1, v]), ca.mtimes([v.T, K2, v])


def slice_nodes(b: float, n_slices: int, shape: tuple[int, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Slice nodes fixed to the tooth: ``n_slices`` pinion sections ``z_j = -b/2 + j b/(n_slices-1)``
    [mm] across a face of width ``b`` (both face ends are nodes), the same for every pair and position,
    so a node never moves with the design, the misalignment or the pinion angle. Returns ``z`` and the
    tributary ``width`` (the trapezoidal rule's weights: ``b/(n_slices-1)``, half of it at the face ends)
    as arrays of shape ``shape + (n_slices,)``."""
    dz = b / (n_slices - 1)
    z = np.linspace(-b / 2, b / 2, n_slices)
    w = np.full(n_slices, dz)
    w[[0, -1]] = dz / 2
    return np.broadcast_to(z, tuple(shape) + (n_slices,)).copy(), np.broadcast_to(w, tuple(shape) + (n_slices,)).copy()


class SliceSolver:
    """The slice equations of a TCA, compiled once (see the module docstring).

    Parameters
    ----------
    tca : TCA
        The drive (point or line contact), with its modifications and symbolic parameters.
    """

    def __init__(self, tca: TCA):
        self.tca = tca
        lay = tca.layout
        w = ca.SX.sym("w", 4)
        prm = ca.SX.sym("prm", lay.size)
        zs = prm[lay.index("z_section")]
        q = ca.vertcat(w[0], zs, w[1], w[2], w[3])
        k = dict(zip(tca.kinematics.name_out(), tca.kinematics(q, prm)))
        F = ca.vertcat(k["rf1"] - k["rf2"], ca.dot(k["nf2"], k["t1u"]))
        self.G = ca.Function("ltca_slice", [w, prm], [F], ["w", "prm"], ["F"])
        reg = ca.fmin(tca.orient1 * ca.dot(ca.cross(k["t1u"], k["t1z"]), k["nf1"]),
                      tca.orient2 * ca.dot(ca.cross(k["t2u"], k["t2z"]), k["nf2"]))
        checks = ca.Function("ltca_slice_checks", [w, prm], [ca.dot(k["nf1"], k["nf2"]), reg], ["w", "prm"],
                             ["n1n2", "reg"])
        # both flanks in their own frames (compliance), the point in the fixed frame
        p1, p2 = prm[lay.slice("pinion")], prm[lay.slice("gear")]
        r1, n1 = tca.pinion.surface(tca.side, "flank")(w[0], zs, p1)[:2]
        r2, n2 = tca.gear.surface(tca.side, "flank")(w[1], w[2], p2)[:2]
        # each flank's normal curvature across the contact line at the point, for the Hertz term:
        # both surfaces' curvature matrices in one tangent basis of the fixed frame (by AD, as the TCA's
        # contact ellipse), the direction across the line the one of their sum's larger eigenvalue
        # (1 / R*); the involute's cos(beta_b) / rho_t on an unmodified flank, changed by profile
        # crowning, reliefs and every modification
        k1, k2 = across_line_curvatures(k["rf1"], k["nf1"], ca.vertcat(w[0], zs), k["rf2"], k["nf2"],
                                        ca.vertcat(w[1], w[2]))
        # the line of action of the slice's force: the flank's common normal, or at a tip edge the mating
        # flank's normal (edge 1: -n_f2, edge 2: n_f1); ``nc*`` orient it out of the pinion (fixed frame)
        # and give it in each member's own frame, out of that member (the load on the tooth is -nc);
        # the levers are the normal velocities of the contact points per unit rotation,
        # L_1 = nc . d r_f1 / d phi1 and L_2 = nc . d r_f2 / d phi2 [mm], the moment arms of that force
        # about the pinion and the gear axis (r_b cos(beta_b) on an involute helicoid)
        drf1 = ca.jacobian(k["rf1"], prm[lay.index("phi1")])
        drf2 = ca.jacobian(k["rf2"], w[3]) * tca.scale2
        B1o = ca.horzcat(ca.jacobian(r1, w[0]), ca.jacobian(r1, zs), n1)
        B1f = ca.horzcat(k["t1u"], k["t1z"], k["nf1"])
        B2o = ca.horzcat(ca.jacobian(r2, w[1]), ca.jacobian(r2, w[2]), n2)
        B2f = ca.horzcat(k["t2u"], k["t2z"], k["nf2"])
        geo_out = [r1, n1, r2, n2, k["rf1"], k1, k2]
        names = ["r1", "n1", "r2", "n2", "rf", "kappa1", "kappa2"]
        for tag, nc in (("", k["nf1"]), ("_e1", -k["nf2"])):
            # own-frame components of a fixed-frame vector: v_own = B_own B_fix^-1 v_fix (both bases map
            # onto each other by the member's rigid motion)
            geo_out += [ca.mtimes(B1o, ca.solve(B1f, nc)), ca.mtimes(B2o, ca.solve(B2f, -nc)),
                        ca.dot(nc, drf1), ca.dot(nc, drf2)]
            names += [f"nc1{tag}", f"nc2{tag}", f"lever1{tag}", f"lever2{tag}"]
        self.geometry = ca.Function("ltca_slice_geometry", [w, prm], geo_out, ["w", "prm"], names)
        self.branch = Branch("ltca_slice", self.G, checks, self._accept, tca.tol, tca.solver, tca.jit)
        # tip-edge slices (Litvin section 9.6 in a slice): where the slice's conjugate point lies beyond
        # a member's tip, that member's tip edge in the section touches the mating flank,
        #   r_f1 - r_f2 = 0,  (x^2 + y^2 - r_a^2) / (2 r_a) = 0 on the tip member,
        # a genuine touch when the mating flank's inward normal lies in the edge's wedge (between the
        # flank's and the tip cylinder's outward normals)
        self.edge_branch = {}
        for member, g_m in ((1, tca.pair.pinion), (2, tca.pair.gear)):
            r_own = k["r1"] if member == 1 else k["r2"]
            g_tip = (r_own[0] ** 2 + r_own[1] ** 2 - g_m.r_a**2) / (2 * g_m.r_a)
            a, c = (k["nf1"], k["er1"]) if member == 1 else (k["nf2"], k["er2"])
            n_other = k["nf2"] if member == 1 else k["nf1"]
            Mc = ca.horzcat(a, c)
            coef = ca.solve(ca.mtimes(Mc.T, Mc), ca.mtimes(Mc.T, -n_other))
            Ge = ca.Function(f"ltca_tip{member}", [w, prm], [ca.vertcat(k["rf1"] - k["rf2"], g_tip)], ["w", "prm"],
                             ["F"])
            ce = ca.Function(f"ltca_tip{member}_checks", [w, prm], [ca.fmin(coef[0], coef[1]), reg], ["w", "prm"],
                             ["cone", "reg"])
            self.edge_branch[member] = Branch(f"ltca_tip{member}", Ge, ce, self._accept_edge, tca.tol, tca.solver,
                                              tca.jit)
        self._line = None
        self._geo_maps: dict = {}
        self._geo_cse: ca.Function | None = None  # geometry_columns
        self._conj_cache: dict = {}

    def __getstate__(self):
        # the geometry's maps hold compiled libraries (rebuilt on demand where it lands)
        state = dict(self.__dict__)
        state["_geo_maps"] = {}
        return state

    def _accept(self, res, n1n2, reg):
        return np.isfinite(res) & (res <= self.tca.tol) & (n1n2 < -1 + SLICE_NORMAL_TOL) & (reg > REGULARITY_MIN)

    def _accept_edge(self, res, cone, reg):
        return np.isfinite(res) & (res <= self.tca.tol) & (cone >= -1e-9) & (reg > REGULARITY_MIN)

    def _line_tca(self) -> TCA:
        if self._line is None:
            t = self.tca
            self._line = TCA(t.pair, side=t.side, pinion=t.pinion.unmodified, gear=t.gear.unmodified,
                             solver=t.solver, contact="line")
        return self._line

    def _conjugate(self, phis, p1, p2) -> dict:
        """Conjugate contact of the aligned, unmodified drive in the sections ``s b1`` at the angles
        ``phis``: {z: (4, P) unknowns (u1, u2, z2, r_p2 phi2), NaN where none} (first guesses)."""
        from ..contact.edge_guesses import conjugate_sections

        # they depend on the angles and the tool shifts x in p1, p2 only (conjugate_sections: not on the
        # modifications or the misalignment): kept for the last few calls (a torque or misalignment
        # sweep, an optimiser's designs at the same positions solve them once)
        lay = self.tca.layout
        key = (np.asarray(phis, float).tobytes(), np.asarray(p1, float)[lay.p_index("pinion", "x")].tobytes(),
               np.asarray(p2, float)[lay.p_index("gear", "x")].tobytes())
        hit = self._conj_cache.get(key)
        if hit is not None:
            return {z: W.copy() for z, W in hit.items()}
        b1 = self.tca.pair.pinion.b
        secs = conjugate_sections(self.tca, self._line_tca(), phis, p1, p2, [s * b1 for s in _SECTIONS])
        out = {z: W[[0, 2, 3, 4]] for z, W in secs.items()}
        if len(self._conj_cache) >= CONJUGATE_CACHE:
            self._conj_cache.pop(next(iter(self._conj_cache)))
        self._conj_cache[key] = {z: W.copy() for z, W in out.items()}
        return out

    def solve(self, phi1: npt.ArrayLike, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None,
              mis: Misalignment | None = None, pairs: Sequence[int] = (-1, 0, 1), n_slices: int = 21,
              offsets: tuple[npt.ArrayLike, npt.ArrayLike] | None = None) -> SliceSet:
        """Slices of every pair at the pinion angles ``phi1`` [rad] (argument checks as
        :meth:`TCA.sweep`); the TE zero is the unloaded gear angle of pair 0 at phi1 = 0.

        ``offsets``: optional ``(e1, e2)``, each (K,) [rad]: angular position deviations of the
        pinion and gear teeth of each pair (pitch deviations; positive: the tooth ahead in the
        direction of rotation). Pair k's pinion tooth is solved at ``phi1 + e1[k]`` and its gear
        angle gains ``e2[k]`` (exact rigid offsets)."""
        t_start = time.perf_counter()
        tca = self.tca
        pair = tca.pair
        g1, g2 = pair.pinion, pair.gear
        phi1, p1, p2, mis, pairs = check_sweep_args(tca, phi1, p1, p2, mis, pairs, z_section=None)
        pairs = tuple(int(k) for k in pairs)
        e1, e2 = (np.zeros(len(pairs)), np.zeros(len(pairs))) if offsets is None else \
            (np.asarray(offsets[0], float).ravel(), np.asarray(offsets[1], float).ravel())
        if e1.shape != (len(pairs),) or e2.shape != (len(pairs),) or not np.all(np.isfinite(e1) & np.isfinite(e2)):
            raise ArgumentError(f"offsets: expected two arrays of {len(pairs)} finite angles [rad] (one per pair).",
                                param="offsets", valid=f"(e1, e2), each {len(pairs)} finite angles [rad]")
        stats: dict = {}
        # the slice nodes: fixed pinion sections across the face (slice_nodes), the same for every pair
        # and position, so the separations, compliances and widths are continuous in the design
        K, N = len(pairs), phi1.size
        Z, Wd = slice_nodes(g1.b, n_slices, (K, N))
        M = Z.shape[2]
        # every column: (pair k, position n, node m), plus pair 0 at phi1 = 0 for the TE zero
        phis = (phi1[None, :] - 2 * math.pi * np.array(pairs)[:, None] / g1.z) + e1[:, None]  # (K, N)
        zero_Z, zero_W = slice_nodes(g1.b, n_slices)
        col_phi = np.concatenate([np.repeat(phis.ravel(), M), np.zeros(M)])
        col_z = np.concatenate([Z.ravel(), zero_Z])
        used = np.isfinite(col_z)
        zz = np.where(used, col_z, 0.0)
        prm = tca.prm(col_phi, p1, p2, mis)
        prm[tca.layout.index("z_section"), :] = zz
        # first guesses: conjugate contact of the aligned, unmodified drive, interpolated in z
        uphi, inv = np.unique(np.round(col_phi, 13), return_inverse=True)
        conj = self._conjugate(uphi, p1, p2)
        if not conj:
            raise ConvergenceError("loaded TCA: the unmodified drive has no conjugate contact in any pinion section; "
                                   "the pair does not mesh (check the gear data).")
        zsec = np.array(sorted(conj))
        Wsec = np.stack([conj[s] for s in zsec])  # (S, 4, U)
        W0 = _interp_sections(zsec, Wsec[:, :, inv], zz)
        have = np.all(np.isfinite(W0), axis=0) & used
        W0 = np.where(have, W0, 0.0)
        # one group per row of slice nodes (a pair at a position, and the TE zero's): its columns with a guess
        flat = np.flatnonzero(have[:(K * N + 1) * M])
        groups = np.split(flat, np.cumsum(np.bincount(flat // M, minlength=K * N + 1))[:-1])
        W, res, n1n2, reg, ok, st = self.branch.solve(W0, prm, groups)
        # the gear angle on the guess's revolution (the kinematics are 2 pi periodic in phi2, and
        # Newton from a distant start may land a revolution away); farther than a gear pitch from the
        # conjugate guess is another tooth's flank: rejected
        rev = 2 * math.pi * g2.r_p
        with np.errstate(invalid="ignore"):
            W[3] -= rev * np.round((W[3] - W0[3]) / rev)
            ok = ok & have & (np.abs(W[3] - W0[3]) < rev / g2.z)
        stats.update(st)
        stats["n_by_position"] = self._continue_positions(W, ok, W0, have, prm, (K, N, M), rev / g2.z)
        geo = self._geometry(np.where(ok, W, W0), prm)
        # both tips' signed margins [mm] at the conjugate (surface) solution, before tip edges replace it:
        # where an edge slice's conjugate point left the zone of action (for the widths below)
        tip_conj = np.stack([g1.r_a - np.hypot(geo["r1"][0], geo["r1"][1]),
                             g2.r_a - np.hypot(geo["r2"][0], geo["r2"][1])])
        tip_conj = np.where(ok, tip_conj, np.nan)
        ok_fl = ok
        W, ok, edge = self._tip_edges(W, ok, prm, geo, g1, g2, n_keep=K * N * M)
        stats["n_edge"] = int((edge > 0).sum())
        redo = np.flatnonzero((edge > 0) | (ok != ok_fl))  # columns the tip edges changed
        if redo.size:
            for name, v in self._geometry(np.where(ok, W, W0)[:, redo], prm[:, redo]).items():
                geo[name][:, redo] = v
        r1, n1, r2, n2, rf = (geo[n].T for n in ("r1", "n1", "r2", "n2", "rf"))
        kap1, kap2 = (np.where(ok, geo[n].ravel(), np.nan) for n in ("kappa1", "kappa2"))
        # the force's line of action and its levers (see __init__): the pinion's flank normal on flank
        # slices and on the gear's tip edge (2), the gear flank's normal on the pinion's tip edge (1)
        e1c = (edge == 1)[:, None]
        nc1 = np.where(e1c, geo["nc1_e1"].T, n1)
        nc2 = np.where(e1c, geo["nc2_e1"].T, np.where((edge == 2)[:, None], geo["nc2"].T, n2))
        lev1, lev2 = (np.where(ok, np.where(edge == 1, geo[f"{n}_e1"].ravel(), geo[n].ravel()), np.nan)
                      for n in ("lever1", "lever2"))
        t = W[3] / g2.r_p  # phi2 of the column's own tooth pair
        shift2 = np.concatenate([np.repeat(np.repeat(2 * math.pi * np.array(pairs) / g2.z + e2, N), M), np.zeros(M)])
        ratio = g1.z / g2.z
        te_raw = np.where(ok, t + shift2 - ratio * np.concatenate([np.repeat(np.tile(phi1, K), M), np.zeros(M)]),
                          np.nan)
        # the slice's point on both active flanks (and both faces, below both tips)
        eps = 1e-9
        rad1 = np.hypot(r1[:, 0], r1[:, 1])
        rad2 = np.hypot(r2[:, 0], r2[:, 1])
        on1 = tca.on_flank(1, np.where(ok, W[0], np.nan), zz, p1)
        on2 = tca.on_flank(2, np.where(ok, W[1], np.nan), np.where(ok, W[2], 0.0), p2)
        on1 = on1 | (edge == 1)  # a tip-edge slice lies on its own tip by construction
        on2 = on2 | (edge == 2)
        act = (ok & on1 & on2 & ((rad1 <= g1.r_a + eps) | (edge == 1)) & ((rad2 <= g2.r_a + eps) | (edge == 2))
               & (np.abs(W[2]) <= g2.b / 2 + eps))
        # Where a pair's contact line leaves the active flanks between two slices, the active slice's
        # tributary width ends at the crossing (a linear interpolation of the signed margin to the
        # flank boundaries), so the contact length changes continuously with phi1.
        form1, form2 = tca.form_radius(1, p1), tca.form_radius(2, p2)
        margin = np.stack([g1.r_a - rad1, rad1 - form1, g2.r_a - rad2, rad2 - form2, g2.b / 2 - np.abs(W[2])])
        margin[0] = np.where(edge == 1, 1.0, margin[0])  # an edge slice lies on its own tip
        margin[2] = np.where(edge == 2, 1.0, margin[2])
        margin = np.where(ok, margin, np.nan)
        n = K * N * M
        # the widths (and the partners past the flank boundaries) of every pair's row, and of the TE zero's
        R = K * N + 1
        W_tooth = Wd.copy()
        Wd, z_lo, z_hi, part, te_b, p_of, p_t = _partial_widths(
            np.concatenate([Z.reshape(-1, M), zero_Z[None]]), np.concatenate([Wd.reshape(-1, M), zero_W[None]]),
            act.reshape(R, M), margin.reshape(5, R, M), g1.b, edge.reshape(R, M),
            np.stack([margin[0], tip_conj[0], margin[2], tip_conj[1]]).reshape(4, R, M),
            solved=ok.reshape(R, M), te=te_raw.reshape(R, M))
        # a partner stands for the contact up to the crossing: its TE (so its gap) is the one there,
        # interpolated from its neighbour on the flanks, te_i + t (te_o - te_i) (no lower than the
        # unloaded TE: the contact conditions hold on the contact, not at the partner's own point past it)
        rr, mm = np.nonzero(p_of >= 0)
        if rr.size:
            T2 = te_raw.reshape(R, M)
            ti, to = T2[rr, p_of[rr, mm]], T2[rr, mm]
            T2[rr, mm] = np.where(np.isfinite(to), ti + p_t[rr, mm] * (to - ti), ti)
            te_raw = T2.ravel()
        # TE zero: the unloaded gear angle of pair 0 at phi1 = 0 (its largest slice on the flanks, or
        # where its contact line leaves them; of the solved slices if none is on them)
        z_act = act[-M:]
        if not z_act.any():
            z_act = ok[-M:]
        phi2_ref = float(np.max(te_raw[-M:][z_act])) if z_act.any() else 0.0
        if act[-M:].any() and np.isfinite(te_b[-1]).any():
            phi2_ref = max(phi2_ref, float(np.nanmax(te_b[-1])))
        Wd, z_lo, z_hi, part, te_b, p_of, p_t = (v[:-1].reshape(K, N, M)
                                                 for v in (Wd, z_lo, z_hi, part, te_b, p_of, p_t))
        te = te_raw - phi2_ref
        te_b = te_b - phi2_ref
        shp = lambda a: a[:n].reshape(K, N, M)  # noqa: E731
        shp3 = lambda a: a[:n].reshape(K, N, M, 3)  # noqa: E731
        stats["n_columns"] = int(n)
        stats["n_active"] = int(act[:n].sum())
        stats["time_s"] = time.perf_counter() - t_start
        if not act[:n].any():
            raise ConvergenceError(
                f"loaded TCA: no slice of any tooth pair {list(pairs)} is in contact on the active flanks at "
                f"phi1 = {phi1.min():.6g} ... {phi1.max():.6g} rad; the positions must lie in the mesh cycle "
                "(e.g. -pi/z1 ... pi/z1) of a pair that meshes.")
        stats["n_partner"] = int(part.sum())
        return SliceSet(phi1=phi1, pairs=pairs, z=Z, width=Wd, z_lo=z_lo, z_hi=z_hi, te=shp(te),
                        active=shp(act) | part, inside=shp(act), te_bound=te_b, partner_of=p_of, partner_t=p_t,
                        width_tooth=W_tooth,
                        converged=shp(ok),
                        r1=shp3(r1), n1=shp3(n1), r2=shp3(r2), n2=shp3(n2), rf=shp3(rf), u1=shp(W[0]), u2=shp(W[1]),
                        z2=shp(W[2]), phi2_ref=phi2_ref, stats=stats, edge=shp(edge),
                        w=np.where(ok, W, np.nan)[:, :n].T.reshape(K, N, M, 4), kappa1=shp(kap1), kappa2=shp(kap2),
                        nc1=shp3(nc1), nc2=shp3(nc2), lever1=shp(lev1), lever2=shp(lev2))

    def _continue_positions(self, W: np.ndarray, ok: np.ndarray, W0: np.ndarray, have: np.ndarray, prm: np.ndarray,
                            shape: tuple[int, int, int], pitch: float) -> int:
        """Continuation across the positions (in place on ``W``, ``ok``): a slice node whose row failed
        from the conjugate guesses is solved again from the same pair's node at the neighbouring
        position, predicted to its angle (``w_a + dw/dphi1 dphi``, the implicit-function tangent of
        :class:`~gearopt.meshing.solver.Branch`), passes until no node is rescued. The conjugate
        guess is the unmodified drive's point; a parabolic profile (Litvin's ``a_c``) with a root
        relief moves the contact so far from it near the start of contact that Newton from there
        lands on the generated surface's fold beyond its singular line (regularity < 0) or diverges
        at every node of the row, so continuation along the face has no anchor (docs/ltca.md
        section 1). ``shape`` (K, N, M): the nodes' layout of the first columns; ``pitch``: the
        largest distance of ``r_p2 phi2`` from the conjugate guess [mm] (another tooth's flank
        beyond). Returns the nodes rescued."""
        K, N, M = shape
        n = K * N * M
        if N < 2:
            return 0
        idx = np.arange(n).reshape(K, N, M)
        tried: set = set()
        total = 0
        for _ in range(N):  # each pass may anchor the next position
            okg, hv = ok[:n].reshape(K, N, M), have[:n].reshape(K, N, M)
            anchor = np.full((K, N, M), -1)
            for s in (1, -1):  # from the previous position, else the next (each pair of nodes once)
                nb_ok = np.roll(okg, s, axis=1)
                nb_ok[:, 0 if s == 1 else -1] = False
                sel = hv & ~okg & nb_ok & (anchor < 0)
                for c, a in zip(idx[sel].tolist(), np.roll(idx, s, axis=1)[sel].tolist()):
                    if (c, a) not in tried:
                        anchor.flat[c] = a
            cols, anc = idx[anchor >= 0], anchor[anchor >= 0]
            if not cols.size:
                break
            tried.update(zip(cols.tolist(), anc.tolist()))
            dw = np.asarray(self.branch.dw.map(cols.size)(W[:, anc], prm[:, anc]))
            guess = W[:, anc] + dw * (prm[0, cols] - prm[0, anc])[None, :]
            # one Newton pass from the predictions (each node has its own anchor: no continuation
            # across the face, no line search)
            Wr, rr, dr, gr = call(self.branch.mapped(cols.size), guess, prm[:, cols])[:4]
            okr = np.asarray(self.branch.accept(rr.ravel(), dr.ravel(), gr.ravel()), bool)
            with np.errstate(invalid="ignore"):
                Wr[3] -= 2 * math.pi * self.tca.pair.gear.r_p * np.round(
                    (Wr[3] - W0[3, cols]) / (2 * math.pi * self.tca.pair.gear.r_p))
                okr = okr & (np.abs(Wr[3] - W0[3, cols]) < pitch)
            W[:, cols[okr]] = Wr[:, okr]
            ok[cols[okr]] = True
            total += int(okr.sum())
        return total

    def geometry_columns(self) -> ca.Function:
        """:attr:`geometry` with its common subexpressions eliminated, the Function that evaluates it
        on columns (interpreted or compiled): the same operations on the same operands, so the same
        numbers bit for bit, with 21,800 instead of 53,500 instructions on a crowned spur drive
        (interpreted 2.3x faster, its C source 0.52 instead of 1.25 MB; docs/benchmarks.md "The slice
        geometry's common subexpressions"). Built once per geometry graph
        (:func:`gearopt.graph_cache.built_once`: the elimination takes about 0.1 s); :attr:`geometry`
        itself stays the graph that the loaded optimiser's sensitivities differentiate."""
        if self._geo_cse is None:
            g = self.geometry
            self._geo_cse = built_once(g.name(), (g,), source_tag(eliminated), lambda: eliminated(g))
        return self._geo_cse

    def _geometry(self, W, prm) -> dict:
        """Both flanks' points and normals and the fixed-frame point at the columns of ``W``:
        {name: (3, columns)}."""
        key = use_compiled(self.tca.jit, W.shape[1])
        if key not in self._geo_maps:  # one ColumnMap (its maps built once) per mode
            self._geo_maps[key] = mapped(self.geometry_columns(), W.shape[1], self.tca.jit)
        f = self._geo_maps[key]
        return {n: np.array(v) for n, v in zip(self.geometry.name_out(), f(W, prm))}

    def _tip_edges(self, W, ok, prm, geo, g1, g2, n_keep):
        """Replace the solved slices whose point lies beyond one member's tip (the first ``n_keep``
        columns; the TE-zero columns stay surface contact) by that tip edge's contact in the same
        section; ``geo`` is :meth:`_geometry` at the solved columns. Returns ``(W, ok, edge)``;
        ``edge`` 1/2 marks the pinion's/gear's tip edge, and an edge slice whose equations fail keeps
        ``ok`` False (it carries no load)."""
        r1, r2 = geo["r1"], geo["r2"]
        rad1, rad2 = np.hypot(r1[0], r1[1]), np.hypot(r2[0], r2[1])
        eps = 1e-9
        edge = np.zeros(W.shape[1], int)
        keep = np.arange(W.shape[1]) < n_keep
        W, ok = W.copy(), ok.copy()
        for member, beyond in ((1, ok & keep & (rad1 > g1.r_a + eps) & (rad2 <= g2.r_a + eps)),
                               (2, ok & keep & (rad2 > g2.r_a + eps) & (rad1 <= g1.r_a + eps))):
            if not beyond.any():
                continue
            # mapped solves from the conjugate slices, of the columns alone, compiled or interpreted
            # (the ColumnMap pads them to one of its few map sizes, at most a fifth more: a compiled
            # chunk padded to 256 columns cost a few-position loaded TCA 6 ms of its 20); no
            # continuation retries: a slice whose edge equations fail from there lies far beyond the
            # contact line's end
            br = self.edge_branch[member]
            cols = np.flatnonzero(beyond)
            We = np.full(W.shape, np.nan)
            oke = np.zeros(W.shape[1], bool)
            for i in range(0, cols.size, EDGE_CHUNK):
                idx = cols[i:i + EDGE_CHUNK]
                cm = br.mapped(EDGE_CHUNK, W.shape[1])
                Wc, rc, cc, gc = (np.asarray(v) for v in cm(W[:, idx], prm[:, idx]))
                We[:, idx] = Wc[:, :idx.size]
                oke[idx] = br.accept(rc.ravel()[:idx.size], cc.ravel()[:idx.size], gc.ravel()[:idx.size])
            # the gear angle on the conjugate slice's branch (Newton may land a revolution away), and
            # within a gear pitch of it (else another tooth's flank: rejected)
            rev = 2 * math.pi * g2.r_p
            with np.errstate(invalid="ignore"):  # NaN where the edge equations failed
                We[3] -= rev * np.round((We[3] - W[3]) / rev)
                good = beyond & oke & (np.abs(We[3] - W[3]) < rev / g2.z)
            W[:, beyond] = np.where(good[beyond], We[:, beyond], W[:, beyond])
            ok = np.where(beyond, good, ok)
            edge = np.where(good, member, edge)
        return W, ok, edge


def _interp_sections(zsec, vals, zz) -> np.ndarray:
    """Piecewise-linear interpolation in z of section values (S, 4, P) at ``zz`` (P,), held
    constant beyond the outer sections; columns with missing sections use the finite ones."""
    S = zsec.size
    if S == 1:
        return vals[0].copy()
    out = np.full(vals.shape[1:], np.nan)
    full = np.all(np.isfinite(vals), axis=(0, 1))
    zc = np.clip(zz, zsec[0], zsec[-1])
    i = np.clip(np.searchsorted(zsec, zc) - 1, 0, S - 2)
    t = (zc - zsec[i]) / (zsec[i + 1] - zsec[i])
    cols = np.arange(zz.size)
    out[:, full] = ((1 - t) * vals[i, :, cols].T + t * vals[i + 1, :, cols].T)[:, full]
    for c in np.flatnonzero(~full):
        ok = np.all(np.isfinite(vals[:, :, c]), axis=1)
        if ok.sum() >= 2:
            out[:, c] = [np.interp(zz[c], zsec[ok], vals[ok, r, c]) for r in range(vals.shape[1])]
        elif ok.sum() == 1:
            out[:, c] = vals[ok, :, c][0]
    return out


def _partial_widths(Z, Wd, act, margin, b, edge=None, tips=None, solved=None, te=None):
    """Each node's share of the contact along rows of slice nodes (:func:`_partial_widths_rows`, whose
    arguments and returns these are): rows whose nodes are all used (the fixed grid of
    :func:`slice_nodes`) gap by gap for all rows at once, any other row by the row loop. The
    arithmetic of each gap is the row loop's, in the same order, so both give the same numbers."""
    R, M = Z.shape
    full = np.all(np.isfinite(Z), axis=1)
    if M < 2 or not full.any():
        return _partial_widths_rows(Z, Wd, act, margin, b, edge, tips, solved, te)
    out = np.zeros((R, M))
    LO = np.full(Z.shape, np.nan)
    HI = np.full(Z.shape, np.nan)
    TB = np.full(Z.shape, np.nan)
    OF = np.full(Z.shape, -1)
    TT = np.zeros(Z.shape)
    kind = np.zeros(Z.shape, int) if edge is None else edge
    solved = np.ones(Z.shape, bool) if solved is None else solved
    rows = np.arange(R)

    def put(sel, m, lo, hi):
        # out[r, m] += hi - lo; the node's interval grows to [lo, hi] (rows sel, nodes m)
        r = rows[sel]
        out[r, m[sel]] += hi[sel] - lo[sel]
        cur = LO[r, m[sel]]
        LO[r, m[sel]] = np.where(np.isfinite(cur), np.minimum(cur, lo[sel]), lo[sel])
        cur = HI[r, m[sel]]
        HI[r, m[sel]] = np.where(np.isfinite(cur), np.maximum(cur, hi[sel]), hi[sel])

    def tau_of(i, o):
        # tau_of of _partial_widths_rows for every row (nodes i, o: (R,) index arrays)
        ki, ko = kind[rows, i], kind[rows, o]
        tau = np.full(R, 0.5)
        r = np.flatnonzero((ki > 0) != (ko > 0))  # a flank node beside an edge node
        if tips is None or r.size == 0:
            return tau
        i, o, ko = i[r], o[r], ko[r]
        fl = np.where(ko > 0, i, o)
        ed = np.where(ko > 0, o, i)
        k = kind[r, ed]
        mi = tips[2 * (k - 1), r, fl]
        mo = tips[2 * (k - 1) + 1, r, ed]
        with np.errstate(invalid="ignore", divide="ignore"):
            good = np.isfinite(mi) & np.isfinite(mo) & (mi >= 0) & (0 > mo)
            f = mi / (mi - mo)
        tau[r] = np.where(good, np.where(fl == i, f, 1.0 - f), 0.5)
        return tau

    for p in range(M - 1):
        q = p + 1
        zp, zq = Z[:, p], Z[:, q]
        h = zq - zp
        ap, aq = act[:, p] & full, act[:, q] & full
        P_, Q_ = np.full(R, p), np.full(R, q)
        both = ap & aq
        if both.any():
            zt = zp + tau_of(P_, Q_) * h
            put(both, P_, zp, zt)
            put(both, Q_, zt, zq)
        one = ap != aq
        if not one.any():
            continue
        i = np.where(ap, p, q)
        o = np.where(ap, q, p)
        sgn = np.where(ap, 1.0, -1.0)
        zi = Z[rows, i]
        mi, mo = margin[:, rows, i], margin[:, rows, o]
        with np.errstate(invalid="ignore", divide="ignore"):
            cross = np.isfinite(mi) & np.isfinite(mo) & (mi >= 0) & (mo < 0)
            ratio = np.where(cross, mi / (mi - mo), np.inf)
        anyc = cross.any(axis=0)
        # no boundary found between them: i keeps half the gap
        half = one & ~anyc
        if half.any():
            zm = zi + sgn * 0.5 * h
            put(half, i, np.minimum(zi, zm), np.maximum(zi, zm))
        sel = one & anyc
        if not sel.any():
            continue
        t = np.clip(np.min(ratio, axis=0), 0.0, 1.0)
        zs = zi + sgn * t * h
        if te is not None:
            te_i, te_o = te[rows, i], te[rows, o]
            tb = np.where(np.isfinite(te_o), te_i + t * (te_o - te_i), te_i)
            upd = sel & np.isfinite(te_i)
            cur = TB[rows, i]
            TB[rows[upd], i[upd]] = np.where(np.isfinite(cur), np.maximum(cur, tb), tb)[upd]
        same_kind = (kind[rows, i] > 0) == (kind[rows, o] > 0)
        tau = tau_of(i, o)
        so = solved[rows, o]
        share_i = np.where(~so, t, np.where(same_kind, t - t * t / 2, np.minimum(t, tau)))
        share_o = np.where(~so, 0.0, np.where(same_kind, t * t / 2, np.maximum(t - tau, 0.0)))
        zend = zi + sgn * share_i * h
        put(sel, i, np.minimum(zi, zend), np.maximum(zi, zend))
        po = sel & (share_o >= PARTNER_MIN)
        if po.any():
            zo = zs - sgn * share_o * h
            put(po, o, np.minimum(zo, zs), np.maximum(zo, zs))
            better = po & (t > TT[rows, o])
            OF[rows[better], o[better]] = i[better]
            TT[rows[better], o[better]] = t[better]
    part = (out > 0) & ~act
    out = np.where(act, np.maximum(out, 1e-9), np.where(part, out, Wd))
    res = [out, LO, HI, part, TB, np.where(part, OF, -1), np.where(part, TT, 0.0)]
    if not full.all():
        j = np.flatnonzero(~full)
        sub = _partial_widths_rows(Z[j], Wd[j], act[j], margin[:, j], b, None if edge is None else edge[j],
                                   None if tips is None else tips[:, j], solved[j], None if te is None else te[j])
        for v, w in zip(res, sub):
            v[j] = w
    return tuple(res)


def _partial_widths_rows(Z, Wd, act, margin, b, edge=None, tips=None, solved=None, te=None):
    """Each node's share of the contact along a row of slice nodes (pinion sections ``Z`` (rows, M),
    ascending, unused NaN), gap by gap between neighbouring nodes p < q, h = z_q - z_p:

    * both on the active flanks (``act``): the gap is split at its middle; between a flank node and a
      tip-edge node (``edge`` (rows, M): 1 pinion tip, 2 gear tip) at the fraction tau where the flank
      contact line leaves the zone of action over that tip: the zero of that tip's margin interpolated
      between the flank node's point and the edge node's conjugate point (``tips`` (4, rows, M): pinion
      tip margin, its conjugate value, gear tip margin, its conjugate value [mm]); the margins are
      concave in z along a contact line, so the chord's zero lies inside and the flank contact never
      extends beyond the zone of action.
    * one on the active flanks (i), one not (o): the contact ends at the fraction t of the gap from i
      where one of the signed margins to the flank boundaries (``margin`` (B, rows, M), > 0 inside)
      crosses zero (linear interpolation; the nearest crossing). The piece ``t h`` is shared by i and
      o as the linear interpolation between them shares it (the hat functions' weights): i takes
      ``h (t - t^2/2)``, o takes ``h t^2/2`` and carries load (a *partner*; its solution is the
      surfaces continued past the boundary); between a flank node and an edge node, i takes
      ``min(t, tau) h`` and o ``max(t - tau, 0) h``. Where o is not solved (``solved`` (rows, M)
      False) i takes the whole piece ``t h``.

    At t = 1 the shares are those of two nodes on the flanks and at t = 0 nothing is left of the
    piece, so every width is continuous as a boundary (a face end, a flank limit, a tip) crosses a
    node: the slices are fixed to the tooth and the loads change continuously with the design.

    ``te`` (rows, M): each node's TE [rad], interpolated to the crossings for the unloaded TE.
    Returns ``(width, lo, hi, partner, te_bound, partner_of, partner_t)`` (rows, M): widths [mm]; each
    node's contact interval [mm] (NaN where none); the nodes off the flanks that carry a share
    (partners); the TE at the crossings next to each node on the flanks (the largest; NaN where none);
    each partner's node on the flanks (index in the row, -1: none) and the crossing's fraction t of the
    gap from that node (the larger of two)."""
    R, M = Z.shape
    out = np.zeros((R, M))
    LO = np.full(Z.shape, np.nan)
    HI = np.full(Z.shape, np.nan)
    TB = np.full(Z.shape, np.nan)
    OF = np.full(Z.shape, -1)
    TT = np.zeros(Z.shape)
    kind = np.zeros(Z.shape, int) if edge is None else edge
    solved = np.ones(Z.shape, bool) if solved is None else solved

    def put(r, m, lo, hi):
        out[r, m] += hi - lo
        LO[r, m] = lo if not np.isfinite(LO[r, m]) else min(LO[r, m], lo)
        HI[r, m] = hi if not np.isfinite(HI[r, m]) else max(HI[r, m], hi)

    def tau_of(r, i, o):
        """Fraction of the gap from i to o where a flank node's contact meets an edge node's (1/2 if
        both are of one kind or the tip's margins do not cross between them)."""
        if (kind[r, i] > 0) == (kind[r, o] > 0) or tips is None:
            return 0.5
        fl, ed = (i, o) if kind[r, o] > 0 else (o, i)
        k = kind[r, ed]
        mi, mo = tips[2 * (k - 1), r, fl], tips[2 * (k - 1) + 1, r, ed]
        if not (np.isfinite(mi) and np.isfinite(mo) and mi >= 0 > mo):
            return 0.5
        f = mi / (mi - mo)  # from the flank node
        return f if fl == i else 1.0 - f

    for r in range(R):
        z, a = Z[r], act[r]
        used = np.flatnonzero(np.isfinite(z))
        for j in range(used.size - 1):
            p, q = used[j], used[j + 1]
            h = z[q] - z[p]
            if a[p] and a[q]:
                zt = z[p] + tau_of(r, p, q) * h
                put(r, p, z[p], zt)
                put(r, q, zt, z[q])
                continue
            if not (a[p] or a[q]):
                continue
            i, o = (p, q) if a[p] else (q, p)
            sgn = 1.0 if i == p else -1.0
            mi, mo = margin[:, r, i], margin[:, r, o]
            cross = np.isfinite(mi) & np.isfinite(mo) & (mi >= 0) & (mo < 0)
            if not cross.any():  # no boundary found between them: i keeps half the gap
                zm = z[i] + sgn * 0.5 * h
                put(r, i, *sorted((z[i], zm)))
                continue
            t = float(np.clip(np.min(mi[cross] / (mi[cross] - mo[cross])), 0.0, 1.0))
            zs = z[i] + sgn * t * h
            if te is not None and np.isfinite(te[r, i]):
                tb = te[r, i] + t * (te[r, o] - te[r, i]) if np.isfinite(te[r, o]) else te[r, i]
                TB[r, i] = tb if not np.isfinite(TB[r, i]) else max(TB[r, i], tb)
            if not solved[r, o]:
                share_i, share_o = t, 0.0
            elif (kind[r, i] > 0) == (kind[r, o] > 0):
                share_i, share_o = t - t * t / 2, t * t / 2
            else:
                tau = tau_of(r, i, o)
                share_i, share_o = min(t, tau), max(t - tau, 0.0)
            put(r, i, *sorted((z[i], z[i] + sgn * share_i * h)))
            if share_o >= PARTNER_MIN:
                put(r, o, *sorted((zs - sgn * share_o * h, zs)))
                if t > TT[r, o]:
                    OF[r, o], TT[r, o] = i, t
        if used.size == 1 and a[used[0]]:
            put(r, used[0], -b / 2, b / 2)
    part = (out > 0) & ~act
    out = np.where(act, np.maximum(out, 1e-9), np.where(part, out, Wd))
    return out, LO, HI, part, TB, np.where(part, OF, -1), np.where(part, TT, 0.0)
