"""IPOPT's derivative Functions of the loaded NLP's oracle (:attr:`LoadedNLP.oracle
<gearopt.synthesis.loaded.nlp.LoadedNLP.oracle>`), built by CasADi's own AD as ``nlpsol`` builds them and
with the same values bit for bit, in about half the time, once per NLP for all its solvers
(docs/benchmarks.md "Loaded optimiser"):

* :func:`lagrangian_hessian`: ``nlpsol``'s ``nlp_hess_l`` (``triu:hess:gamma:x:x``) is CasADi's
  forward AD over CasADi's gradient of the Lagrangian, its directions a star colouring of the Hessian's
  pattern (``Sparsity.star_coloring``). The design unknowns couple with every load (the Hertz curvature,
  the pressure and edge rows), and that colouring's distance-2 search through these four hubs took 41 of
  the 51 ms of the Hessian of ``problems/microgeometry_loaded.toml``'s NLP (2884 unknowns); CasADi's other
  star colouring, ``Sparsity.star_coloring2`` (the star-based algorithm, the same largest-first
  order), found the same six colours in 6 ms. Here the same forward sweeps, seeded by that colouring, and
  the Hessian's entries taken from them as CasADi's ``XFunction::jac`` takes them (an entry from the last
  colour whose sweep holds it alone in its row, or its transposed entry so): 22 ms.
* :func:`constraint_jacobian`: ``nlpsol``'s ``nlp_jac_g`` itself, its pattern found by CasADi's plain
  bit-vector propagation instead of the hierarchical one (``GlobalOptions.setHierarchicalSparsity``; the
  same pattern: 4.6 instead of 12.4 ms on that NLP)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import casadi as ca
import numpy as np

from ...errors import SynthesisError

#: CasADi's directions per forward sweep (``FunctionInternal::max_num_dir``'s default)
MAX_NUM_DIR = 64


@contextmanager
def plain_sparsity() -> Iterator[None]:
    """CasADi's Jacobian patterns by plain bit-vector propagation (not hierarchical) within the block."""
    was = ca.GlobalOptions.getHierarchicalSparsity()
    ca.GlobalOptions.setHierarchicalSparsity(False)
    try:
        yield
    finally:
        ca.GlobalOptions.setHierarchicalSparsity(was)


def constraint_jacobian(oracle: ca.Function) -> ca.Function:
    """``nlpsol``'s ``nlp_jac_g`` of ``oracle`` (``(x, p) -> (f, g)``): ``(x, p) -> (g, jac_g_x)``, the
    constraints' Jacobian [per unit of the unknowns] by CasADi's AD, its pattern by plain propagation
    (module docstring)."""
    with plain_sparsity():
        return oracle.factory("nlp_jac_g", ["x", "p"], ["g", "jac:g:x"])


def lagrangian_hessian(oracle: ca.Function) -> ca.Function:
    """``nlpsol``'s ``nlp_hess_l`` of ``oracle`` (``(x, p) -> (f, g)``): ``(x, p, lam_f, lam_g) ->
    triu_hess_gamma_x_x``, the upper triangle of the Hessian of ``gamma = lam_f f + lam_g' g`` in ``x``,
    by CasADi's forward AD over CasADi's gradient, the directions coloured by ``star_coloring2``
    (module docstring)."""
    z, p = oracle.mx_in()
    f, g = oracle.call([z, p], True, False)
    lam_f = ca.MX.sym("lam_f", oracle.sparsity_out(0))
    lam_g = ca.MX.sym("lam_g", oracle.sparsity_out(1))
    # the Lagrangian and its gradient as CasADi's Function.factory forms them ("gamma": ["f", "g"])
    gamma = ca.MX(0)
    gamma += ca.dot(lam_f, f)
    gamma += ca.dot(lam_g, g)
    grad = ca.gradient(gamma, z)
    n = z.numel()
    sp = ca.Function("lagrangian_gradient", [z], [grad], {"allow_free": True}).sparsity_jac(0, 0, True, True)
    if sp.nnz() == 0:  # (no second derivatives: nlpsol's own, an empty pattern)
        return oracle.factory("nlp_hess_l", ["x", "p", "lam:f", "lam:g"], ["triu:hess:gamma:x:x"],
                              {"gamma": ["f", "g"]})
    colors = sp.star_coloring2()
    ci, cr = np.array(colors.colind()), np.array(colors.row())
    nc = colors.size2()
    seeds = [[ca.MX.ones(ca.Sparsity.triplet(n, 1, cr[ci[d]:ci[d + 1]].tolist(), [0] * int(ci[d + 1] - ci[d])))]
             for d in range(nc)]
    sens = []
    for first in range(0, nc, MAX_NUM_DIR):
        sens += [s[0] for s in ca.forward([grad], [z], seeds[first:first + MAX_NUM_DIR], {"always_inline": True})]
    # each nonzero (row r, column c) of the pattern: from the sweep of c's colour where c is the only
    # column of that colour with a nonzero in row r, and then its transposed (c, r) too; the last
    # such sweep wins (CasADi's XFunction::jac, symmetric)
    colind, row = np.array(sp.colind()), np.array(sp.row())
    col = np.repeat(np.arange(n), np.diff(colind))
    key = row * n + col
    order = np.argsort(key)
    trans = order[np.searchsorted(key[order], col * n + row)]  # the nonzero (c, r) of each (r, c)
    color = np.empty(n, int)
    color[cr] = np.repeat(np.arange(nc), np.diff(ci))
    src = np.full(row.size, -1)  # the nonzero of the stacked sweeps that gives each Hessian nonzero
    offset = 0
    for d, s in enumerate(sens):
        rows_d = np.array(s.sparsity().row(), int)
        at = np.full(n, -1)
        at[rows_d] = offset + np.arange(rows_d.size)
        mine = color[col] == d
        alone = np.bincount(row[mine], minlength=n) == 1
        hit = np.flatnonzero(mine & alone[row] & (at[row] >= 0))
        src[hit] = at[row[hit]]
        src[trans[hit]] = at[row[hit]]
        offset += rows_d.size
    if np.any(src < 0):  # (a star colouring determines every nonzero: a CasADi whose colouring is not one)
        raise SynthesisError(f"loaded NLP: the star colouring of the Lagrangian's Hessian ({nc} colours) left "
                             f"{int(np.sum(src < 0))} of its {src.size} nonzeros undetermined; this CasADi "
                             f"({ca.__version__}) colours otherwise: report it.", param="casadi", value=ca.__version__)
    up = row <= col
    H = ca.MX(ca.Sparsity.triplet(n, n, row[up].tolist(), col[up].tolist()), ca.vertcat(*sens).nz[src[up].tolist()])
    return ca.Function("nlp_hess_l", [z, p, lam_f, lam_g], [H], ["x", "p", "lam_f", "lam_g"],
                       ["triu_hess_gamma_x_x"])


def ipopt_derivatives(oracle: ca.Function) -> dict:
    """``nlpsol``'s options ``jac_g`` and ``hess_lag`` for ``oracle`` (:func:`constraint_jacobian`,
    :func:`lagrangian_hessian`), to be shared by every IPOPT solver of the one NLP."""
    return {"jac_g": constraint_jacobian(oracle), "hess_lag": lagrangian_hessian(oracle)}
