"""Generic interior-point algebra at an NLP solution (no gear in it): which inequalities and bounds
are active in the limit of a vanishing barrier (the tangent of the central path), the degenerate
ones, and the sparse helpers of the KKT systems (docs/loaded_synthesis.md section 6)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..crowning import SynthesisError
from .constants import DEGENERATE_REL, DEPENDENT_REL

if TYPE_CHECKING:
    import scipy.sparse
    import scipy.sparse.linalg


def degenerate_constraints(ind_g: np.ndarray, lam_g: np.ndarray, ind_x: np.ndarray,
                           lam_x: np.ndarray) -> tuple[int, float | None]:
    """Degenerate inequalities and bounds at a solution: those active (central-path indicator above
    1/2, :func:`central_path_indicators`) whose multiplier vanishes (strict complementarity fails: the
    optimum is then only directionally differentiable), i.e. at most ``DEGENERATE_REL`` times the
    largest active multiplier, and those the indicator cannot tell active from inactive (between 0.1
    and 0.9). ``ind_g``, ``lam_g``: the inequality rows' indicators and multipliers; ``ind_x``,
    ``lam_x``: the variables' (indicator NaN: no finite bound). Returns ``(count, smallest active
    multiplier over the largest)`` (None without an active one)."""
    ind_g, lam_g, ind_x, lam_x = (np.asarray(v, float).ravel() for v in (ind_g, lam_g, ind_x, lam_x))
    bx = np.isfinite(ind_x)
    act_g, act_x = ind_g > 0.5, bx & (np.where(bx, ind_x, 0.0) > 0.5)
    mult = np.concatenate([np.abs(lam_g[act_g]), np.abs(lam_x[act_x])])
    big = float(mult.max()) if mult.size else 0.0
    tol = DEGENERATE_REL * big
    deg_g = (act_g & (np.abs(lam_g) <= tol)) | (np.abs(ind_g - 0.5) < 0.4)
    deg_x = (act_x & (np.abs(lam_x) <= tol)) | (bx & (np.abs(np.where(bx, ind_x, 0.0) - 0.5) < 0.4))
    return int(deg_g.sum() + deg_x.sum()), (float(mult.min()) / big if big > 0 else None)


def central_path_indicators(H: scipy.sparse.spmatrix, Jg: scipy.sparse.spmatrix, lbg: np.ndarray, ubg: np.ndarray,
                            g: np.ndarray, lam_g: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, x: np.ndarray,
                            lam_x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How each inequality and bound of an interior-point solution behaves as the barrier vanishes.

    At IPOPT's solution ``x`` (multipliers ``lam_g``, ``lam_x`` in CasADi's signs: positive at an
    upper bound) of ``min f(x)`` s.t. ``lbg <= g(x) <= ubg``, ``lbx <= x <= ubx``, the tangent of the
    central path (every complementarity product lam s scaled together with the barrier parameter
    mu; the perturbed KKT system with ``H`` the Hessian of the Lagrangian and ``Jg`` the constraint
    Jacobian, sparse) gives each slack's d log s / d log mu: about 1 for an active constraint (its
    slack vanishes like mu), 0 for an inactive one (its multiplier does), 1/2 for a degenerate one
    (active with a zero multiplier: both vanish like sqrt(mu)). Scale-free, unlike lam / s.

    Parameters
    ----------
    H : (n, n) array or sparse matrix
        Hessian of the Lagrangian ``f + lam_g' g`` in ``x`` at the solution.
    Jg : (m, n) array or sparse matrix
        Jacobian of ``g`` at the solution.
    lbg, ubg, g, lam_g : (m,) arrays
        Constraint bounds (equal for an equality row), values and multipliers.
    lbx, ubx, x, lam_x : (n,) arrays
        Variable bounds (+-inf where none), the solution and the bounds' multipliers. The solve
        should run without IPOPT's bound relaxation (``bound_relax_factor`` 0), so that every slack
        is the solution's own.

    Returns
    -------
    ind_g : (m,) array
        Indicator of every constraint row (NaN for equality rows).
    ind_x : (n,) array
        Indicator of every variable's bound (NaN for a variable without finite bounds).
    """
    import scipy.sparse as sp_

    lbg, ubg, g, lam_g = (np.asarray(v, float).ravel() for v in (lbg, ubg, g, lam_g))
    lbx, ubx, x, lam_x = (np.asarray(v, float).ravel() for v in (lbx, ubx, x, lam_x))
    H, Jg = sp_.csc_matrix(H), sp_.csr_matrix(Jg)
    eq = lbg == ubg
    I_, E = np.flatnonzero(~eq), np.flatnonzero(eq)
    s_g = np.abs(np.where(lam_g[I_] > 0, ubg[I_] - g[I_], g[I_] - lbg[I_]))
    s_x = np.abs(np.where(lam_x > 0, ubx - x, x - lbx))
    bx = np.isfinite(s_x)
    tiny = 1e-300
    sig_g = np.abs(lam_g[I_]) / np.maximum(s_g, tiny)
    sig_x = np.where(bx, np.abs(lam_x) / np.where(bx, np.maximum(s_x, tiny), 1.0), 0.0)
    JI = Jg[I_]
    K = sp_.bmat([[H + JI.T @ sp_.diags(sig_g) @ JI + sp_.diags(sig_x), Jg[E].T], [Jg[E], None]], format="csc")
    # d(lam_i s_i) = lam_i s_i d(log mu): the stationarity's right-hand side is -(J^T lam + lam_x)
    dx = sparse_lu(K, "IPOPT's perturbed KKT system").solve(
        np.concatenate([-(JI.T @ lam_g[I_]) - np.where(bx, lam_x, 0.0), np.zeros(E.size)]))[:x.size]
    ind_g = np.full(lbg.size, np.nan)
    ind_g[I_] = -np.sign(lam_g[I_]) * (JI @ dx) / np.maximum(s_g, tiny)
    ind_x = np.where(bx, -np.sign(lam_x) * dx / np.where(bx, np.maximum(s_x, tiny), 1.0), np.nan)
    return ind_g, ind_x


def csc_of_dm(m: ca.DM | np.ndarray) -> scipy.sparse.csc_matrix:
    import scipy.sparse as sp_

    m = ca.DM(m)
    i, j = m.sparsity().get_triplet()
    return sp_.csc_matrix((np.array(m.nonzeros()), (i, j)), shape=m.shape)


def sparse_lu(K: scipy.sparse.spmatrix, what: str) -> scipy.sparse.linalg.SuperLU:
    """The sparse LU factors of the square ``K`` (``what``: its name in the error).

    A structurally singular ``K`` (no perfect matching of its rows and columns: a zero row, or more
    active rows than the unknowns they act on) is refused before it is factored: SuperLU meets a
    zero pivot column there and passes BLAS a negative dimension (OpenBLAS prints "On entry to DGEMV
    parameter number 2 had an illegal value") before it reports the singular factor.

    Raises
    ------
    SynthesisError
        When ``K`` is singular, structurally or numerically (the active constraints' gradients are
        dependent: no LICQ, the derivatives are not unique).
    """
    import scipy.sparse.linalg as spla
    from scipy.sparse.csgraph import structural_rank

    def singular(why):
        return SynthesisError(f"loaded micro-geometry sensitivities: {what} is singular ({why}); the active "
                              "constraints' gradients are linearly dependent at this optimum, so its "
                              "derivatives are not unique.", param="sensitivities", value=what)

    K = K.tocsc()
    rank = structural_rank(K)
    if rank < K.shape[0]:
        raise singular(f"structurally: rank at most {rank} of {K.shape[0]}")
    try:
        return spla.splu(K)
    except RuntimeError as exc:  # numerically singular
        raise singular(exc) from exc


def dependent_active_rows(A_eq: scipy.sparse.spmatrix, A_act: scipy.sparse.spmatrix,
                          tol: float = DEPENDENT_REL) -> np.ndarray:
    """Which active inequality rows (and bound rows) of a KKT system depend linearly on the equalities'
    and on the other active rows: LICQ fails there, the KKT matrix ``[[H, A'], [A, 0]]`` is singular
    in the multipliers (``A' nu = 0`` has a solution) and an LU, which may not see it in rounding, gives
    multipliers of 1e30 whose rounding swamps the solution's own derivatives.

    Each active row ``a_r`` (scaled to unit length) is projected onto the null space of ``A_eq`` (one
    sparse LU of ``[[I, A_eq'], [A_eq, 0]]``, every row at once); the projections span at most that
    null space's few dimensions, and a QR with column pivoting of them keeps a largest independent set:
    a row whose pivot is below ``tol`` is dependent on the equalities and the rows kept before it. (The
    equalities are taken as independent: the NLP's model, which IPOPT solved.)

    Parameters
    ----------
    A_eq : (e, n) sparse matrix
        The equality rows' Jacobian.
    A_act : (a, n) sparse matrix
        The active inequality rows' Jacobian and the active bounds' unit rows.
    tol : float
        A row is dependent where its QR pivot (of the unit row's projection) is at most this.

    Returns
    -------
    (a,) bool array
        True for each dependent row (dropped from the KKT system: the primal derivatives are those of
        the remaining, independent active set where the dropped rows' own constraints stay satisfied
        along them, which the caller checks).
    """
    import scipy.linalg as sla
    import scipy.sparse as sp_

    A_act = sp_.csr_matrix(A_act)
    a, n = A_act.shape
    dep = np.zeros(a, bool)
    if a == 0:
        return dep
    Ad = A_act.toarray()
    Ad /= np.maximum(np.linalg.norm(Ad, axis=1), 1e-300)[:, None]
    M = sp_.bmat([[sp_.identity(n, format="csc"), sp_.csc_matrix(A_eq).T], [sp_.csc_matrix(A_eq), None]], format="csc")
    proj = sparse_lu(M, "the equalities' projection").solve(
        np.vstack([Ad.T, np.zeros((A_eq.shape[0], a))]))[:n]
    _, R, piv = sla.qr(proj, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    dep[piv[:d.size][d <= tol]] = True
    dep[piv[d.size:]] = True  # (more active rows than unknowns)
    return dep


def active_set_derivatives(H: scipy.sparse.spmatrix, Jg: scipy.sparse.spmatrix, Gp: scipy.sparse.spmatrix,
                           Lzp: scipy.sparse.spmatrix, eq: np.ndarray, act_rows: np.ndarray, act_bounds: np.ndarray,
                           what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The derivatives of a solution at a fixed active set in its parameters (Fiacco): the KKT system
    ``[[H, A'], [A, 0]] [dz; dnu] = -[Lzp; Gp_A]`` of the equalities ``eq``, the active rows
    ``act_rows`` and the active bounds ``act_bounds`` (unknowns' indices), one sparse LU for all
    parameters, with the active rows and bounds that depend on the others dropped
    (:func:`dependent_active_rows`: LICQ fails there; the full system is singular in their
    multipliers).

    A dropped row's constraint must stay active along the derivatives of the rest (as where a
    parameter moves two mirror-image rows alike): where it does not, within 1e-6 of the row's own
    terms, the active set holds on neither side of that parameter and its derivatives are one-sided
    (``off``).

    Parameters
    ----------
    H : (n, n) sparse matrix
        The Lagrangian's Hessian in the unknowns (the inactive rows' multipliers zero).
    Jg, Gp : (m, n) and (m, q) sparse matrices
        The constraint rows' Jacobians in the unknowns and in the ``q`` parameters.
    Lzp : (n, q) sparse matrix
        The Lagrangian's gradient's Jacobian in the parameters.
    eq, act_rows, act_bounds : int arrays
        The equality rows, the active inequality rows and the unknowns on an active bound.
    what : str
        The system's name in errors.

    Returns
    -------
    d_z : (n, q) array
        The solution's derivatives.
    d_nu : (len(eq) + len(act_rows) + len(act_bounds), q) array
        The multipliers' derivatives in that order (NaN for a dropped row or bound: not determined).
    dependent : (len(act_rows) + len(act_bounds),) bool array
        The dropped rows and bounds.
    off : (q,) bool array
        The parameters along which a dropped row or bound does not stay active.
    """
    import scipy.sparse as sp_

    Jg, Gp = sp_.csr_matrix(Jg), sp_.csr_matrix(Gp)
    n = H.shape[0]
    eq, act_rows, act_bounds = (np.asarray(v, int) for v in (eq, act_rows, act_bounds))

    def units(B):
        return sp_.csr_matrix((np.ones(B.size), (np.arange(B.size), B)), shape=(B.size, n))

    dep = dependent_active_rows(Jg[eq], sp_.vstack([Jg[act_rows], units(act_bounds)]))
    na = act_rows.size
    rows, B = np.concatenate([eq, act_rows[~dep[:na]]]), act_bounds[~dep[na:]]
    A = sp_.vstack([Jg[rows], units(B)])
    K = sp_.bmat([[H, A.T], [A, None]], format="csc")
    rhs = -sp_.vstack([Lzp, Gp[rows], sp_.csr_matrix((B.size, Gp.shape[1]))]).toarray()
    sol = sparse_lu(K, what).solve(rhs)
    d_z = sol[:n]
    kept = np.concatenate([np.ones(eq.size, bool), ~dep])
    d_nu = np.full((kept.size, rhs.shape[1]), np.nan)
    d_nu[kept] = sol[n:]
    drop_g, drop_x = act_rows[dep[:na]], act_bounds[dep[na:]]
    d_g = np.asarray(Jg[drop_g] @ d_z) + Gp[drop_g].toarray()
    scale = np.abs(Gp[drop_g].toarray()) + np.abs(Jg[drop_g]) @ np.abs(d_z)
    off = np.any(np.abs(d_g) > 1e-6 * np.maximum(scale, 1e-300), axis=0)
    off |= np.any(np.abs(d_z[drop_x]) > 1e-6 * np.maximum(np.max(np.abs(d_z), axis=0), 1e-300), axis=0)
    return d_z, d_nu, dep, off


def active_set_range(d_z: np.ndarray, d_nu: np.ndarray, rows: np.ndarray, bounds: np.ndarray, g: np.ndarray,
                     d_g: np.ndarray, lbg: np.ndarray, ubg: np.ndarray, lam_g: np.ndarray, x: np.ndarray,
                     lbx: np.ndarray, ubx: np.ndarray, lam_x: np.ndarray, act_g: np.ndarray, act_x: np.ndarray,
                     watch_g: np.ndarray, watch_x: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[tuple]]:
    """How far each parameter may move before the active set of a solution changes, to first order
    (Fiacco's parametric sensitivity: the derivatives at a fixed active set hold while every active
    inequality keeps the sign of its multiplier and every inactive one stays within its bounds).

    Along the derivatives ``d_z`` of the solution and ``d_nu`` of the active rows' and bounds'
    multipliers, an active row or bound leaves the active set where its multiplier ``lam + t d_lam``
    crosses zero, and an inactive one joins it where its value ``g + t d_g`` (or ``x + t d_x``) reaches
    a bound. A derivative that changes the active set at ``t`` of the order of the solution's own
    tolerance is that of a kink: the optimum is only directionally differentiable there, and the
    derivative of the fixed active set is one side's at most.

    Parameters
    ----------
    d_z : (n, q) array
        The solution's derivatives in the ``q`` parameters (the active set's KKT system).
    d_nu : (len(rows) + len(bounds), q) array
        The multipliers' derivatives of the KKT system's constraint rows (``rows``) and bounds (``bounds``).
    rows, bounds : int arrays
        The rows of ``g`` and the unknowns of ``x`` in the KKT system (equalities, active inequalities,
        active bounds), in the order of ``d_nu``.
    g, d_g : (m,) and (m, q) arrays
        The constraint rows' values at the solution and their total derivatives in the parameters.
    lbg, ubg, lam_g : (m,) arrays
        Their bounds and multipliers (CasADi's signs: positive at an upper bound).
    x, lbx, ubx, lam_x : (n,) arrays
        The solution, its bounds and their multipliers.
    act_g, act_x : (m,) and (n,) bool arrays
        The active inequality rows and bounds.
    watch_g, watch_x : (m,) and (n,) bool arrays
        The inequality rows and bounds whose changes count (the others change smoothly in the NLP,
        e.g. a smoothed complementarity's loads and gaps).

    Returns
    -------
    lo, hi : (q,) arrays
        The largest negative and smallest positive parameter offsets at which a watched row or bound
        changes (``-inf`` / ``inf``: none to first order).
    why : list of tuple
        Per parameter, the change at ``lo`` and the one at ``hi``, each ``("g", row, what)`` or ``("x",
        unknown, what)`` (``("", -1, "")``: none).
    """
    q = d_z.shape[1]
    rows, bounds = np.asarray(rows, int), np.asarray(bounds, int)
    nu_of = {("g", int(i)): k for k, i in enumerate(rows)}
    nu_of.update({("x", int(j)): rows.size + k for k, j in enumerate(bounds)})
    cands = []  # (offsets (q,), (kind, index, what))
    for i in np.flatnonzero(watch_g & act_g):
        cands.append((-lam_g[i] / _nz(d_nu[nu_of[("g", int(i))]]), ("g", int(i), "leaves the active set")))
    for i in np.flatnonzero(watch_g & ~act_g):
        for b, side in ((lbg[i], "lower"), (ubg[i], "upper")):
            if np.isfinite(b):
                cands.append(((b - g[i]) / _nz(d_g[i]), ("g", int(i), f"reaches its {side} bound")))
    for j in np.flatnonzero(watch_x & act_x):
        cands.append((-lam_x[j] / _nz(d_nu[nu_of[("x", int(j))]]), ("x", int(j), "leaves its bound")))
    for j in np.flatnonzero(watch_x & ~act_x):
        for b, side in ((lbx[j], "lower"), (ubx[j], "upper")):
            if np.isfinite(b):
                cands.append(((b - x[j]) / _nz(d_z[j]), ("x", int(j), f"reaches its {side} bound")))
    lo, hi = np.full(q, -np.inf), np.full(q, np.inf)
    none = ("", -1, "")
    why = [[none, none] for _ in range(q)]
    for t, what in cands:
        t = np.asarray(t, float).ravel()
        for k in range(q):
            tk = t[k]
            if not np.isfinite(tk):
                continue
            if tk > 0 and tk < hi[k]:
                hi[k], why[k][1] = tk, what
            elif tk <= 0 and tk > lo[k]:
                lo[k], why[k][0] = tk, what
    return lo, hi, [tuple(w) for w in why]


def _nz(v: np.ndarray) -> np.ndarray:
    """``v`` with its zeros as NaN (a quotient by it is then NaN: no crossing)."""
    v = np.asarray(v, float).ravel()
    return np.where(v == 0.0, np.nan, v)
