"""IPOPT's derivative Functions of the loaded NLP (gearopt/synthesis/loaded/derivatives.py): the Lagrangian's
Hessian and the constraints' Jacobian built there hold the values of those ``nlpsol`` builds itself
(``Function.factory``'s ``triu:hess:gamma:x:x`` and ``jac:g:x``) bit for bit, at random points, on a
small NLP of the loaded problem's shape (a few design unknowns coupled with every load, dense blocks,
the smoothed complementarity) and on a loaded NLP itself."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gearopt.gears import Gear, GearPair
from gearopt.synthesis.loaded import LoadedMicroOptimizer
from gearopt.synthesis.loaded.derivatives import constraint_jacobian, lagrangian_hessian
from gearopt.synthesis.loaded.trust_region import TrustRegion


def _shaped_oracle() -> ca.Function:
    """``(z, p) -> (f, g)``: 3 design unknowns that scale every load's curvature (hubs of the Hessian), loads
    ``x`` in dense blocks of 6, gaps ``y`` tied to them by the smoothed complementarity, an approach per
    block and a smooth max objective."""
    rng = np.random.default_rng(7)
    P, B, m = 3, 8, 6
    n = B * m
    th, x, y, d = (ca.MX.sym(k, s) for k, s in (("th", P), ("x", n), ("y", n), ("d", B)))
    p = ca.MX.sym("p", 2)
    C = np.kron(np.eye(B), rng.uniform(0.1, 1.0, (m, m)))
    Ex = np.kron(np.eye(B), np.ones((m, 1)))
    kap = ca.DM(rng.uniform(0.5, 1.5, n)) + ca.mtimes(ca.DM(rng.normal(size=(n, P))), th)
    kap = 0.5 * (kap + ca.sqrt(kap**2 + 1e-8))
    f = x * p[1]
    gap = ca.mtimes(ca.DM(C), f) + f * ca.log(1.0 + f / kap) - ca.mtimes(ca.DM(Ex), d)
    g = ca.vertcat(y - gap, x + y - ca.sqrt(x**2 + y**2 + 2 * p[0]), ca.mtimes(ca.DM(Ex.T), x) - 1.0,
                   x * kap - 2.0)
    obj = ca.sqrt(ca.sumsqr(d) + 1e-6) + ca.dot(th, th) * ca.sum1(x)
    z = ca.vertcat(th, x, y, d)
    return ca.Function("nlp", [z, p], [obj, g], ["x", "p"], ["f", "g"])


def _same_as_nlpsols(oracle: ca.Function, points: int = 3) -> None:
    hess = lagrangian_hessian(oracle)
    jac = constraint_jacobian(oracle)
    ref_h = oracle.factory("ref_h", ["x", "p", "lam:f", "lam:g"], ["triu:hess:gamma:x:x"], {"gamma": ["f", "g"]})
    ref_j = oracle.factory("ref_j", ["x", "p"], ["g", "jac:g:x"])
    assert hess.sparsity_out(0) == ref_h.sparsity_out(0)
    assert jac.sparsity_out(1) == ref_j.sparsity_out(1)
    rng = np.random.default_rng(3)
    for _ in range(points):
        z = rng.uniform(0.1, 1.0, oracle.nnz_in(0))
        p = rng.uniform(0.5, 1.5, oracle.nnz_in(1))
        lam_f, lam_g = rng.uniform(0.5, 2.0), rng.normal(size=oracle.nnz_out(1))
        a = np.array(hess(z, p, lam_f, lam_g).nonzeros())
        b = np.array(ref_h(z, p, lam_f, lam_g).nonzeros())
        assert np.array_equal(a, b)
        assert np.array_equal(np.array(jac(z, p)[1].nonzeros()), np.array(ref_j(z, p)[1].nonzeros()))


def test_the_hessian_and_jacobian_are_nlpsols_own_bit_for_bit():
    """The AD Hessian's entry (i, j) and (j, i) differ in the last bits (forward over reverse along
    different paths): the same values bit for bit need the same directions and the same choice of the
    sweep each entry is read from."""
    oracle = _shaped_oracle()
    H = oracle.factory("h", ["x", "p", "lam:f", "lam:g"], ["hess:gamma:x:x"], {"gamma": ["f", "g"]})
    assert H.sparsity_out(0).star_coloring2() == H.sparsity_out(0).star_coloring()
    _same_as_nlpsols(oracle)


@pytest.mark.slow
def test_a_loaded_nlps_hessian_and_jacobian_are_nlpsols_own_bit_for_bit():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    opt = LoadedMicroOptimizer(pair, {"pinion.C_beta": (0.0, 0.04), "pinion.C_alpha": (0.0, 0.04)}, [100.0, 200.0],
                               p_limit=2500.0, n_positions=8, n_verify=8, n_slices=7)
    nlp = opt._around(opt.theta0.copy(), 0.01).nlp
    _same_as_nlpsols(nlp.oracle, points=2)
    # built once per NLP: its solvers evaluate the same Functions
    warm = TrustRegion._warm_solver(nlp)
    for name in ("nlp_hess_l", "nlp_jac_g"):
        assert nlp.solver.get_function(name).__hash__() == warm.get_function(name).__hash__()
