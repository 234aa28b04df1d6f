"""Branch.solve: the mapped solve, the checks, and continuation from accepted neighbours (rounds)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gearopt import compiled
from gearopt.meshing.solver import Branch


def _branch(jit):
    # w^2 = p: two roots +-sqrt(p); the checks accept the positive one only (a "valid branch")
    w, p = ca.SX.sym("w"), ca.SX.sym("p", 2)
    G = ca.Function("toy", [w, p], [w**2 - p[1]])
    checks = ca.Function("toy_checks", [w, p], [w, ca.DM(1.0)])
    return Branch("toy", G, checks, lambda res, s, reg: np.isfinite(res) & (res <= 1e-10) & (s > 0), 1e-10,
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
