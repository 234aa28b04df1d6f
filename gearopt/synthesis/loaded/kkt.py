"""Generic interior-point algebra at an NLP solution (no gear in it): which inequalities and bounds
are active in the limit of a vanishing barrier (the tangent of the central path), the degenerate
ones, and the sparse helpers of the KKT systems (docs/loaded_synthesis.md section 6)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..crowning import SynthesisError
from .constants import DEGENERATE_REL

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
    import scipy.sparse.linalg as spla

    try:
        return spla.splu(K)
    except RuntimeError as exc:  # singular: the active constraints' gradients are dependent (no LICQ)
        raise SynthesisError(f"loaded micro-geometry sensitivities: {what} is singular ({exc}); the active "
                             "constraints' gradients are linearly dependent at this optimum, so its "
                             "derivatives are not unique.", param="sensitivities", value=what) from exc
