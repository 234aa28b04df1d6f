"""Branch.solve: the mapped solve, the checks, and continuation from accepted neighbours (rounds)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gearopt import compiled
from gearopt.meshing.solver import Branch


def _branch(jit, name="toy", rhs=lambda p: p[1]):
    # w^2 = rhs(p): two roots +-sqrt(rhs); the checks accept the positive one only (a "valid branch")
    w, p = ca.SX.sym("w"), ca.SX.sym("p", 2)
    G = ca.Function(name, [w, p], [w**2 - rhs(p)])
    checks = ca.Function(f"{name}_checks", [w, p], [w, ca.DM(1.0)])
    return Branch(name, G, checks, lambda res, s, reg: np.isfinite(res) & (res <= 1e-10) & (s > 0), 1e-10,
                  jit=jit)


@pytest.mark.parametrize("jit", [False, pytest.param(True, marks=pytest.mark.skipif(
    not compiled.available(), reason="no C compiler"))])
def test_continuation_rescues_runs_of_bad_guesses_from_accepted_neighbours(jit):
    br = _branch(jit)
    n = 24
    prm = np.vstack([np.linspace(0, 1, n), np.linspace(1.0, 4.0, n)])
    W0 = np.sqrt(prm[1:2]).copy()
    W0[0, 3:15] *= -1.0  # a run of 12 guesses (> 2 max_gap) that Newton takes to the rejected root:
    # rescued in rounds, each rescued column the anchor of the next ones
    W0[0, 20:] *= -1.0  # the last four: forwards from column 19 only
    groups = [np.arange(n)]
    W, res, s, reg, ok, st = br.solve(W0, prm, groups, max_gap=4)
    assert ok.all(), np.flatnonzero(~ok)
    np.testing.assert_allclose(W[0], np.sqrt(prm[1]), rtol=0, atol=1e-12)
    assert st["n_fast"] == n - 16 and st["n_retry"] >= 16
    # a group without any accepted column stays unsolved (nothing to continue from)
    W0b = -np.sqrt(prm[1:2])
    _, _, _, _, okb, _ = br.solve(W0b, prm, [np.arange(n)], max_gap=4)
    assert not okb.any()
    # continuation stays within its group
    W0c = np.sqrt(prm[1:2]).copy()
    W0c[0, 12:] *= -1.0
    _, _, _, _, okc, _ = br.solve(W0c, prm, [np.arange(12), np.arange(12, n)], max_gap=4)
    assert okc[:12].all() and not okc[12:].any()


def _p_of(phi):
    phi = np.atleast_1d(np.asarray(phi, float))
    return np.vstack([phi, 1.0 + phi + 0.3 * np.sin(3 * phi)])  # p[1] > 0 on [-0.5, 1]: w = sqrt(p[1])


def _branch_phi(jit):
    # w^2 = 1 + phi + 0.3 sin(3 phi) with phi = prm[0] (the implicit-function predictor
    # differentiates with respect to prm[0]); prm[1] carries the same value for the test
    return _branch(jit, "toy_phi", lambda p: 1.0 + p[0] + 0.3 * ca.sin(3 * p[0]))


@pytest.mark.parametrize("jit", [False, pytest.param(True, marks=pytest.mark.skipif(
    not compiled.available(), reason="no C compiler"))])
def test_predict_knots_hermite_guesses(jit):
    """First guesses from solved knots (cubic Hermite with the implicit-function derivatives):
    error O(h^4) -- far below the anchor's linear prediction --, the same guess for a position in
    any sweep that covers it (the knots lie on a grid fixed by the anchor), and linear from the
    nearest solved knot where the branch ends (no root past it)."""
    br = _branch_phi(jit)
    w_a = np.array([1.0])
    phi = np.linspace(-0.5, 1.0, 400)
    exact = np.sqrt(_p_of(phi)[1])
    errs = []
    for h in (0.1, 0.05):
        W0 = br.predict_knots(w_a, _p_of(0.0)[:, 0], phi, 0.0, _p_of, h)
        errs.append(np.abs(W0[0] - exact).max())
    lin = np.abs(br.predict(w_a, _p_of(0.0)[:, 0], phi)[0] - exact).max()
    assert errs[1] < 1e-5 < 0.1 < lin
    assert 10 < errs[0] / errs[1] < 40  # fourth order: 16x per halving
    # the same guesses at the same positions from a sweep over a sub-range (interior positions)
    sub = phi[100:250]
    W_sub = br.predict_knots(w_a, _p_of(0.0)[:, 0], sub, 0.0, _p_of, 0.05)
    W_all = br.predict_knots(w_a, _p_of(0.0)[:, 0], phi, 0.0, _p_of, 0.05)
    assert np.array_equal(W_sub, W_all[:, 100:250])
    # past the end of the branch (p < 0 beyond phi = -0.68...): nearest solved knot, linearly
    far = np.linspace(-1.2, 0.5, 300)
    W_far = br.predict_knots(w_a, _p_of(0.0)[:, 0], far, 0.0, _p_of, 0.05)
    assert np.all(np.isfinite(W_far))
    sel = (_p_of(far)[1] > 0.05) & (far > -0.5)
    np.testing.assert_allclose(W_far[0, sel], np.sqrt(_p_of(far[sel])[1]), atol=1e-4)
    # a coarse sweep (fewer than 4 positions per knot) keeps the anchor's linear prediction
    few = np.linspace(-0.5, 1.0, 20)
    assert np.array_equal(br.predict_knots(w_a, _p_of(0.0)[:, 0], few, 0.0, _p_of, 0.05),
                          br.predict(w_a, _p_of(0.0)[:, 0], few))


@pytest.mark.parametrize("jit", [False, pytest.param(True, marks=pytest.mark.skipif(
    not compiled.available(), reason="no C compiler"))])
def test_solve_with_extra_outputs_and_line_search_rescue(jit):
    """solve(extra=True): the caller's outputs at every solved point come from the first pass, and
    the columns that continuation changed afterwards -- here through line-search Newton, where plain
    Newton diverges on atan -- are listed in stats["rescued"]."""
    w, p = ca.SX.sym("w"), ca.SX.sym("p", 2)
    G = ca.Function("atan_toy", [w, p], [ca.atan(w - p[1])])
    checks = ca.Function("atan_checks", [w, p], [ca.DM(1.0), ca.DM(1.0)])
    extra = ca.Function("atan_extra", [w, p], [2 * w, ca.vertcat(w, p[1])], ["w", "prm"], ["dbl", "pair"])
    br = Branch("atan", G, checks, lambda res, s, reg: np.isfinite(res) & (res <= 1e-10), 1e-10, jit=jit,
                extra=extra)
    prm = np.vstack([np.arange(6.0), [0, 0, 0, 3, 3, 3]])
    W0 = np.array([[0.1, -0.1, 0.0, 10.0, 10.0, 10.0]])  # plain Newton on atan diverges from 7 away
    W, res, s, reg, ok, st = br.solve(W0, prm, [np.arange(6)], extra=True)
    assert ok.all()
    np.testing.assert_allclose(W[0], prm[1], atol=1e-10)
    assert set(st["rescued"].tolist()) == {3, 4, 5}
    first = np.setdiff1d(np.arange(6), st["rescued"])
    np.testing.assert_allclose(st["extra"]["dbl"][0, first], 2 * W[0, first], atol=1e-12)
    assert st["extra"]["pair"].shape == (2, 6)
    np.testing.assert_allclose(st["extra"]["pair"][:, first], np.vstack([W[0, first], prm[1, first]]), atol=1e-12)


def test_a_branch_builds_its_predictor_and_extra_column_on_first_use(monkeypatch):
    """Constructing a Branch (its graphs in the process's cache) takes no Jacobian: dw/dphi1 and the
    column with extras are built on first use, the same graphs as built eagerly."""
    br = _branch_phi(False)
    w, p = ca.SX.sym("w"), ca.SX.sym("p", 2)
    F = br.G(w, p)
    J = ca.jacobian(F, w)
    eager = ca.Function("toy_phi_dw", [w, p], [-ca.solve(J, ca.jacobian(F, p)[:, 0])])
    extra = ca.Function("toy_phi_extra", [w, p], [w * p[0], w + p[1]], ["w", "p"], ["wp", "wq"])
    taken = []
    orig = ca.jacobian
    monkeypatch.setattr(ca, "jacobian", lambda *a: taken.append(1) or orig(*a))
    again = Branch("toy_phi", br.G, br.checks, br.accept, br.tol, jit=False, extra=extra)
    assert taken == []
    assert again.dw.serialize() == eager.serialize() and again.dw is again.dw
    x = again.one_x(np.array([1.1]), np.array([0.2, 0.0]))
    assert again.one_x is again.one_x and again.one_x.name_out() == ["W", "res", "n1n2", "reg", "wp", "wq"]
    w_sol = float(np.sqrt(1.0 + 0.2 + 0.3 * np.sin(0.6)))
    np.testing.assert_allclose(float(x[0]), w_sol, rtol=0, atol=1e-12)
    np.testing.assert_allclose(float(x[4]), w_sol * 0.2, rtol=0, atol=1e-12)


def _small_residual(res, s, reg):  # (picklable: a module-level function)
    return res <= 1e-10


@pytest.mark.skipif(not compiled.available(), reason="no C compiler")
def test_the_columns_libraries_are_keyed_by_their_bases_construction_and_solver(monkeypatch, tmp_path):
    """A Branch's column (``one``, ``one_x``) is looked up under a key made of the residual's, the
    checks' (and the extras') library keys, the construction's code and the rootfinder plugin, without
    serialising the column; any of them changed: another library; the same: the same one, also for a
    Branch unpickled (a worker process); under jit=False the column keeps its graph's key."""
    import pickle

    from gearopt import compile_cache

    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path))
    w, p = ca.SX.sym("w"), ca.SX.sym("p", 2)
    extra = ca.Function("toy_extra", [w, p], [w * p[0], w + p[1]], ["w", "p"], ["wp", "wq"])
    extra2 = ca.Function("toy_extra", [w, p], [w * p[1], w + p[1]], ["w", "p"], ["wp", "wq"])

    def make(name="toy", rhs=lambda q: q[1], checks_value=1.0, solver="fast_newton", jit=True, ex=extra):
        G = ca.Function(name, [w, p], [w**2 - rhs(p)])
        checks = ca.Function(f"{name}_checks", [w, p], [w, ca.DM(checks_value)])
        return Branch(name, G, checks, _small_residual, 1e-10, solver=solver, jit=jit, extra=ex)

    serialised = []
    orig = compile_cache.cache_key
    monkeypatch.setattr(compile_cache, "cache_key", lambda f: serialised.append(f.name()) or orig(f))
    ref = make()
    one, one_x = compiled.library_path(ref.one), compiled.library_path(ref.one_x)
    assert not {"toy_one", "toy_onex"} & set(serialised)
    assert one.name.startswith("toy_one-") and one != tmp_path / f"toy_one-{orig(ref.one)[:24]}.so"
    assert compiled.library_path(make().one) == one and compiled.library_path(make().one_x) == one_x
    for other in (make(rhs=lambda q: q[1] + 1.0), make(checks_value=2.0), make(solver="newton")):
        assert compiled.library_path(other.one) != one and compiled.library_path(other.one_x) != one_x
    assert compiled.library_path(make(ex=extra2).one) == one
    assert compiled.library_path(make(ex=extra2).one_x) != one_x
    monkeypatch.setattr(compile_cache, "cache_key", orig)
    import gearopt.meshing.solver as solver_module

    with monkeypatch.context() as m:  # another construction (its code's tag)
        m.setattr(solver_module, "source_tag", lambda *objects: "another construction")
        assert compiled.library_path(make().one) != one
    back = pickle.loads(pickle.dumps(ref))
    assert back.one is not ref.one and compiled.library_path(back.one) == one
    assert compiled.library_path(back.one_x) == one_x
    plain = make(jit=False)
    assert compiled.library_path(plain.one) == tmp_path / f"toy_one-{orig(plain.one)[:24]}.so"
