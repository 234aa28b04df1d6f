"""The loaded TCA's contact QP: its load-independent data (:class:`ContactStructure`, :class:`HertzNodes`,
:class:`CompliancePart`), the primal-dual active-set method over all positions at once
(:func:`contact_active_set`), and the Hertz fixed point around it (Josephy-Newton steps of Weber's
contact law, qpOASES where the active set does not settle: :class:`ContactQP`, a part of
:class:`gearopt.ltca.engine.LTCA`)."""

from __future__ import annotations

import contextlib
import os
import sys
from dataclasses import dataclass
from typing import NamedTuple

import casadi as ca
import numpy as np

from .compliance import weber_tangent, weber_tangent_array

HERTZ_TOL = 1e-7  #: the Hertz fixed point stops when no slice load changes by more than this x W
HERTZ_MAX_ITER = 30
QP_SOLVER = "qpoases"  #: CasADi conic plugin of the contact QP where the active-set method does not settle
#: the contact QP's solver as results.json names it (``options.qp_solver``)
QP_METHOD = "active-set (qpoases where it does not settle)"


@contextlib.contextmanager
def _quiet_stdout():
    """Silence writes to the process's stdout (file descriptor 1) from C code."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as dn:
            os.dup2(dn.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


class CompliancePart(NamedTuple):
    """One term of the analytical tooth compliance (:meth:`LTCA.structure`), coupled across the face
    over its own length (:func:`~gearopt.ltca.compliance.face_matrix_batch`)."""

    #: (K, N, M) compliance per unit face width of each slice node [mm^2/N] (inactive nodes: the
    #: mean of the active ones)
    compliance: np.ndarray
    #: coupling length of the term across the face [mm]
    coupling_length: float


@dataclass(frozen=True)
class HertzNodes:
    """The Hertz data of slice nodes (any common shape: (K, N, M) per pair, position and node, or
    (N, K M) per position, :meth:`ContactStructure.by_position`)."""

    length: np.ndarray  #: length of contact line of each node [mm] (1 where inactive)
    R: np.ndarray  #: reduced radius of curvature across the contact line [mm] (1 where inactive)
    h1: np.ndarray  #: depth of the pinion's centreline below the point along the load line [mm] (Weber)
    h2: np.ndarray  #: the same on the gear [mm]


@dataclass(frozen=True)
class ContactStructure:
    """The load-independent parts of the loaded contact problem of a :class:`~gearopt.ltca.slices.SliceSet`
    (:meth:`LTCA.structure`): arrays (K, N, M) per tooth pair, position and slice node unless stated.

    Attributes
    ----------
    Cs : (N, K M, K M) array
        Compliance matrix of the teeth and bodies (bending, shear, compression, foundation) of each
        position over the flattened nodes ``k M + m`` [mm/N] (without the Hertz term).
    parts : tuple of CompliancePart
        The analytical compliance's terms (the teeth; the pinion's body; the gear's body) whose face
        matrices, times ``cos^2(beta_b)``, sum to ``Cs`` (with FE influence coefficients ``Cs`` is
        FE's and the parts are the analytical model's).
    ct : array
        Sum of the parts' compliances per unit face width [mm^2/N].
    length : array
        Length of contact line of each node, its width over ``cos(beta_b)`` [mm] (1 where inactive).
    R : array
        Reduced radius of curvature across the contact line [mm] (1 where inactive).
    h1, h2 : array
        Depths of the pinion's and the gear's tooth centreline below the point along the load line
        [mm] (Weber's contact term; 1 where inactive).
    radius1, radius2 : array
        Radius of the node's point on the pinion and on the gear [mm] (NaN where unused).
    """

    Cs: np.ndarray
    parts: tuple[CompliancePart, ...]
    ct: np.ndarray
    length: np.ndarray
    R: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    radius1: np.ndarray
    radius2: np.ndarray

    @property
    def hertz(self) -> HertzNodes:
        """The Hertz data (K, N, M)."""
        return HertzNodes(length=self.length, R=self.R, h1=self.h1, h2=self.h2)

    def by_position(self) -> HertzNodes:
        """The Hertz data as (N, K M) arrays: one row per position over the flattened nodes
        ``k M + m`` (the order of ``Cs``)."""
        K, N, M = self.length.shape
        flat = lambda a: np.transpose(a, (1, 0, 2)).reshape(N, K * M)  # noqa: E731
        return HertzNodes(length=flat(self.length), R=flat(self.R), h1=flat(self.h1), h2=flat(self.h2))


def row_median(a: np.ndarray) -> np.ndarray:
    """Median of each row of ``a`` (N, n) over its finite entries (NaN: none), as ``np.median`` of
    those entries gives it (the mean of the two middle ones of an even count)."""
    a = np.sort(np.where(np.isfinite(a), a, np.inf), axis=1)
    c = np.isfinite(a).sum(axis=1)
    rows = np.arange(a.shape[0])
    lo, hi = a[rows, np.maximum((c - 1) // 2, 0)], a[rows, np.minimum(c // 2, a.shape[1] - 1)]
    with np.errstate(invalid="ignore"):
        return np.where(c > 0, np.where(c % 2 == 1, lo, (lo + hi) / 2), np.nan)


#: primal-dual active-set iterations of one contact QP (:func:`contact_active_set`) before qpOASES takes over
ACTIVE_SET_MAX_ITER = 40


def contact_active_set(C: np.ndarray, s: np.ndarray, lam: np.ndarray, valid: np.ndarray, W: float,
                       P0: np.ndarray | None = None, max_iter: int = ACTIVE_SET_MAX_ITER,
                       diag: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The contact QP ``min 1/2 F^T C F + s^T F  s.t.  F >= 0, sum lam F = W`` of many positions at
    once, by the primal-dual active-set method (Hintermüller, Ito & Kunisch 2002, for this
    complementarity problem the classical load-distribution iteration of loaded TCA).

    With a contact set P, the loads on P solve ``C_PP F_P - lam_P delta = -s_P`` and ``lam_P^T F_P = W``
    (``F = 0`` off P; ``delta`` the approach, the equality's multiplier); the gaps are
    ``g = s + C F - lam delta``. The next set keeps the nodes of P whose load is not negative (to
    1e-13 W) and adds those off P whose gap is negative (to 1e-13 of the approach); when the set
    repeats, ``F >= 0`` on P, ``g = 0`` on P and ``g >= 0`` off it: the QP's optimality conditions,
    so its unique minimiser (C positive definite).
    The compliance of different tooth pairs is not coupled, so each pair with nodes in P is solved
    alone (the others carry nothing) and the approach follows from the load balance.

    Parameters
    ----------
    C : (N, K, M, M) array
        Compliance blocks of the K tooth pairs at N positions [mm/N], symmetric positive definite on
        the valid nodes.
    s : (N, K, M) array
        Separations [mm].
    lam : (N, K, M) array
        The equality's coefficients (each slice's lever over ``r_b1 cos(beta_b)``, > 0 on valid nodes).
    valid : (N, K, M) bool array
        Nodes that may carry load (others carry none).
    W : float
        Total normal load [N] (> 0).
    P0 : (N, K, M) bool array, optional
        The contact set to start from (a warm start: the previous Newton step's; default every valid node).
    max_iter : int
        Iterations before a position is given up.
    diag : (N, K, M) array, optional
        Added to the diagonal of ``C`` [mm/N] (the Hertz term of a Newton step).

    Returns
    -------
    F : (N, K, M) array
        Loads [N] (NaN where not settled).
    P : (N, K, M) bool array
        The final contact sets.
    ok : (N,) bool array
        The iteration settled at the position.
    """
    N, K, M = s.shape
    P = valid.copy() if P0 is None else (P0 & valid)
    F = np.full(s.shape, np.nan)
    ok = np.zeros(N, bool)
    todo = np.flatnonzero(valid.any(axis=(1, 2)))
    eye = np.eye(M)
    # hysteresis of the set changes (a node at zero load within rounding neither leaves nor re-enters)
    f_tol = 1e-13 * W
    for _ in range(max_iter):
        if todo.size == 0:
            break
        Pt = P[todo]
        # only the pairs with contact nodes (the others carry nothing and add nothing to the gaps)
        tb, kb = np.nonzero(Pt.any(axis=2))
        nb = todo[tb]
        Pb, Cb = Pt[tb, kb], C[nb, kb]
        if diag is not None:
            Cb = Cb + diag[nb, kb][:, :, None] * eye
        Cm = np.where(Pb[:, :, None] & Pb[:, None, :], Cb, 0.0) + (~Pb)[:, :, None] * eye
        sb, lb = s[nb, kb], lam[nb, kb]
        xy = np.linalg.solve(Cm, np.stack([np.where(Pb, -sb, 0.0), np.where(Pb, lb, 0.0)], axis=-1))
        x, y = xy[..., 0], xy[..., 1]
        lx = np.bincount(tb, weights=np.sum(lb * x, axis=1), minlength=todo.size)
        ly = np.bincount(tb, weights=np.sum(lb * y, axis=1), minlength=todo.size)
        empty = ~Pt.any(axis=(1, 2))
        d = (W - lx) / np.where(empty, 1.0, ly)
        Fb = x + d[tb, None] * y
        Ft = np.zeros(Pt.shape)
        Ft[tb, kb] = Fb
        CF = np.zeros(Pt.shape)
        CF[tb, kb] = (Cb @ Fb[:, :, None])[:, :, 0]
        st, lt = s[todo], lam[todo]
        g = st + CF - d[:, None, None] * lt
        g_tol = 1e-13 * np.maximum(np.abs(d), np.max(np.abs(st), axis=(1, 2)))[:, None, None]
        Pn = valid[todo] & np.where(Pt, Ft > -f_tol, g < -g_tol)
        same = np.all(Pn == Pt, axis=(1, 2)) & ~empty
        F[todo[same]] = Ft[same]
        ok[todo[same]] = True
        P[todo] = Pn
        todo = todo[~same & ~empty]
    return F, P, ok


class ContactQP:
    """The contact QP with the Hertz fixed point for :class:`~gearopt.ltca.engine.LTCA` (a mixin: it uses
    its ``material`` and its memo of QP Functions ``_qp``)."""

    def _weber_tangent(self, n: int) -> ca.Function:
        key = ("weber", n)
        if key not in self._qp:
            self._qp[key] = weber_tangent(self.material).map(n)
        return self._qp[key]

    def _solver(self, n: int, N: int) -> ca.Function:
        key = (n, N)
        if key not in self._qp:
            # qpOASES: an exact active-set method (daqp leaves loads of ~1e-8 W on slices that are
            # out of contact when the separations dominate, i.e. at light loads)
            with _quiet_stdout():
                qp = ca.conic("ltca_qp", QP_SOLVER, {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(1, n)},
                              {"error_on_fail": False, "printLevel": "none"})
                self._qp[key] = (qp, qp.map(N))
        return self._qp[key][1]

    def _fixed_point(self, A, s, hz: HertzNodes, Cs, W, f_min, F0=None, lam=None, block=None, P0=None):
        """The contact QP over the slices ``A`` (N, n) of each position (separations ``s``, Hertz data
        ``hz`` (N, n) and compliance ``Cs`` (N, n, n), :class:`ContactStructure`), with the Hertz fixed point:
        ``(F (N, n), done (N,), change (N,), iterations (N,))``. ``lam`` (N, n): each slice's lever
        about the pinion axis over ``r_b1 cos(beta_b)`` (the equilibrium ``sum lam F = W``; default 1).
        ``block``: the nodes per tooth pair (``Cs`` is block diagonal: pairs are not coupled); default
        one block. ``P0`` (N, n): without ``F0``, the active-set method's first contact set (default every
        slice of ``A``; the solution does not depend on it).

        Each Newton step's QP is solved by the primal-dual active-set method on all positions at once
        (:func:`contact_active_set`), started from the previous step's contact set; a position where
        that does not settle is solved again by qpOASES (:meth:`_fixed_point_qpoases`)."""
        N, n = A.shape
        M = n if block is None else int(block)
        K = n // M
        Cv = Cs.reshape(N, K, M, K, M)
        Cb = np.moveaxis(Cv[:, np.arange(K), :, np.arange(K), :], 0, 1)  # (N, K, M, M)
        if any(np.any(Cv[:, k, :, j, :]) for k in range(K) for j in range(K) if j != k):  # pairs coupled: one block
            nc = int(max(A.sum(axis=1).max(), 1))
            if nc < n:
                return self._fixed_point_compact(A, s, hz, Cs, W, f_min, nc, F0=F0, lam=lam, P0=P0)
            K, M = 1, n
            Cb = Cs.reshape(N, 1, n, n)
        valid = A
        lamv = np.where(valid, np.ones((N, n)) if lam is None else lam, 0.0)
        lv = np.where(valid, hz.length, 1.0)
        Rv, h1v, h2v = (np.where(valid, v, 1.0) for v in (hz.R, hz.h1, hz.h2))
        # start: the load spread over the active contact length, or the previous round's loads
        Fc = np.where(valid, W * lv / np.maximum((lv * valid).sum(axis=1, keepdims=True), 1e-12), 0.0)
        P = valid.copy() if P0 is None else valid & P0
        P = np.where(P.any(axis=1, keepdims=True), P, valid)
        if F0 is not None:
            Fc = np.where(valid, F0, 0.0)
            P = valid & (F0 > 0)
            P = np.where(P.any(axis=1, keepdims=True), P, valid)
        it = np.zeros(N, int)
        done = np.zeros(N, bool)
        change = np.zeros(N)
        bad = np.zeros(N, bool)
        shp = (N, K, M)
        for i in range(HERTZ_MAX_ITER):
            # Newton step of the Hertz law (Josephy-Newton: the QP with the approach linearised at the
            # last loads, delta_H(F) ~ c F_k + dc (F - F_k), dc = d(c f)/df by AD); its fixed point is the
            # contact law's, reached quadratically (the secant compliance c alone converges linearly)
            cH, dc = weber_tangent_array(Fc / lv, Rv, h1v, h2v, self.material, f_min)
            dc = np.maximum(dc, 0.5 * cH)  # keeps the QP convex far from the solution (a damped step)
            sk = s + np.where(valid, (cH - dc) / lv * Fc, 0.0)
            Fn, Pn, ok = contact_active_set(Cb, sk.reshape(shp), lamv.reshape(shp), valid.reshape(shp), W,
                                            P.reshape(shp), max_iter=ACTIVE_SET_MAX_ITER,
                                            diag=np.where(valid, dc / lv, 0.0).reshape(shp))
            Fn, P = Fn.reshape(N, n), Pn.reshape(N, n)
            bad |= ~ok
            Fn = np.where(valid, np.maximum(Fn, 0.0), 0.0)
            change = np.max(np.abs(Fn - Fc), axis=1) / W
            it = np.where(done, it, i + 1)
            done = change <= HERTZ_TOL
            Fc = Fn
            if (done | bad).all():
                break
        if bad.any():
            # the active-set iteration did not settle at some position: qpOASES there (the same QP)
            j = np.flatnonzero(bad)
            sub = HertzNodes(length=hz.length[j], R=hz.R[j], h1=hz.h1[j], h2=hz.h2[j])
            Fj, dj, cj, ij = self._fixed_point_qpoases(A[j], s[j], sub, Cs[j], W, f_min, F0=F0 if F0 is None else F0[j],
                                                       lam=None if lam is None else lam[j])
            Fc[j], done[j], change[j], it[j] = Fj, dj, cj, ij
        return Fc, done, change, it

    def _fixed_point_compact(self, A, s, hz: HertzNodes, Cs, W, f_min, nc, F0=None, lam=None, P0=None):
        """:meth:`_fixed_point` of coupled pairs (one dense block per position) on each position's valid
        nodes only, gathered into ``nc`` columns (padded with invalid nodes): the same QP, whose dense
        solves shrink from every node of every pair (most of them out of mesh) to the nodes that can carry
        load; arguments and returns as :meth:`_fixed_point`."""
        N, n = A.shape
        # each position's valid nodes first (stable: in their order), the rest as padding
        gi = np.argsort(~A, axis=1, kind="stable")[:, :nc]
        rows = np.arange(N)[:, None]
        Ac = A[rows, gi]
        take = lambda a: None if a is None else a[rows, gi]  # noqa: E731
        hzc = HertzNodes(length=take(hz.length), R=take(hz.R), h1=take(hz.h1), h2=take(hz.h2))
        Cc = Cs[rows[:, :, None], gi[:, :, None], gi[:, None, :]]
        Fc, done, change, it = self._fixed_point(Ac, take(s), hzc, Cc, W, f_min, F0=take(F0), lam=take(lam),
                                                 block=None, P0=take(P0))
        F = np.zeros((N, n))
        F[rows, gi] = np.where(Ac, Fc, 0.0)
        return F, done, change, it

    def _fixed_point_qpoases(self, A, s, hz: HertzNodes, Cs, W, f_min, F0=None, lam=None):
        """The contact QP over the slices ``A`` (N, n) of each position (separations ``s``, Hertz data
        ``hz`` (N, n) and compliance ``Cs`` (N, n, n), :class:`ContactStructure`), with the Hertz fixed point,
        each Newton step's QP solved by qpOASES (mapped over the positions); arguments and returns as
        :meth:`_fixed_point`."""
        N, n = A.shape
        nc = int(max(A.sum(axis=1).max(), 1))  # padded to the largest count
        gi = np.zeros((N, nc), int)
        valid = np.zeros((N, nc), bool)
        for j in range(N):
            a = np.flatnonzero(A[j])
            gi[j, :a.size], valid[j, :a.size] = a, True
        rows = np.arange(N)[:, None]
        take = lambda a: np.where(valid, a[rows, gi], 0.0)  # noqa: E731
        Cc = Cs[rows[:, :, None], gi[:, :, None], gi[:, None, :]]
        Cc = np.where(valid[:, :, None] & valid[:, None, :], Cc, 0.0)
        sc, lc, Rc, h1c, h2c = (take(v) for v in (s, hz.length, hz.R, hz.h1, hz.h2))
        lamc = np.where(valid, take(np.ones((N, n)) if lam is None else lam), 0.0)
        lc = np.where(valid, lc, 1.0)
        Rc, h1c, h2c = (np.where(valid, v, 1.0) for v in (Rc, h1c, h2c))
        eye = np.eye(nc)
        # start: the load spread over the active contact length, or the previous round's loads
        Fc = np.where(valid, W * lc / np.maximum((lc * valid).sum(axis=1, keepdims=True), 1e-12), 0.0)
        if F0 is not None:
            Fc = np.where(valid, F0[rows, gi], 0.0)
        qp = self._solver(nc, N)
        ubx = np.where(valid, np.inf, 0.0).T
        it = np.zeros(N, int)
        done = np.zeros(N, bool)
        change = np.zeros(N)
        wt = self._weber_tangent(N * nc)
        for i in range(HERTZ_MAX_ITER):
            # Newton step of the Hertz law (Josephy-Newton: the QP with the approach linearised at the
            # last loads, delta_H(F) ~ c F_k + dc (F - F_k), dc = d(c f)/df by AD); its fixed point is the
            # contact law's, reached quadratically (the secant compliance c alone converges linearly)
            cH, dc = (np.asarray(v).reshape(N, nc) for v in wt((Fc / lc).ravel()[None, :], Rc.ravel()[None, :],
                                                                 h1c.ravel()[None, :], h2c.ravel()[None, :], f_min))
            dc = np.maximum(dc, 0.5 * cH)  # keeps the QP convex far from the solution (a damped step)
            C = Cc + np.einsum("ni,ij->nij", np.where(valid, dc / lc, 1.0), eye)
            sk = sc + np.where(valid, (cH - dc) / lc * Fc, 0.0)
            # scaled: min 1/2 x^T (C / c_ref) x + (s_k / (W c_ref))^T x, x = F / W (same minimiser)
            cref = np.einsum("nii->n", C) / nc
            H = C / cref[:, None, None]
            with _quiet_stdout():  # qpOASES prints its banner on stdout whatever its printLevel
                r = qp(h=np.hstack(list(H)), g=(sk / (W * cref[:, None])).T, a=lamc.reshape(1, nc * N), lba=1.0,
                       uba=1.0, lbx=0.0, ubx=ubx)
            Fn = np.where(valid, np.maximum(W * np.asarray(r["x"]).T, 0.0), 0.0)
            change = np.max(np.abs(Fn - Fc), axis=1) / W
            it = np.where(done, it, i + 1)
            done = change <= HERTZ_TOL
            Fc = Fn
            if done.all():
                break
        F = np.zeros((N, n))
        jj, cc = np.nonzero(valid)
        F[jj, gi[jj, cc]] = Fc[jj, cc]
        return F, done, change, it
