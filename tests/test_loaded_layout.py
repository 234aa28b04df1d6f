"""The named layout of the loaded micro-geometry NLP (gearopt/synthesis/loaded/layout.py): every
unknown, row and parameter of the assembled NLP belongs to exactly one named block, in the NLP's own
order, and the start point, bounds and predicted values read them by name."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gearopt.errors import ParameterNameError
from gearopt.gears import Gear, GearPair
from gearopt.meshing.misalignment import Misalignment
from gearopt.synthesis.loaded import LoadedMicroOptimizer
from gearopt.synthesis.loaded.layout import ROWS, UNKNOWNS, BlockLayout, block_vector
from gearopt.units import ARCMIN


@pytest.fixture(scope="module")
def around():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    opt = LoadedMicroOptimizer(pair, {"pinion.C_beta": (0.0, 0.04), "pinion.C_alpha": (0.0, 0.04)}, [100.0, 200.0],
                               cases=[Misalignment(), Misalignment(crossing=ARCMIN)], p_limit=2500.0,
                               n_positions=8, n_verify=8, n_slices=7)
    return opt, opt._around(opt.theta0.copy())


@pytest.mark.slow
def test_the_layout_covers_the_nlp_in_its_order(around):
    opt, cur = around
    nlp = cur.nlp
    lay, pr = nlp.layout, nlp.problem
    assert lay.unknowns.names == UNKNOWNS and lay.rows.names == ROWS
    assert lay.unknowns.size == pr["x"].shape[0]
    assert lay.rows.size == pr["g"].shape[0] == nlp.lbg.size
    assert lay.params.size == pr["p"].shape[0] == len(opt._pvec(1000.0))
    # each block of unknowns is the NLP's symbol of that name, in place
    syms = {s.name(): s for s in ca.symvar(pr["x"])}
    names = {"theta": "theta_um"}
    for k in lay.unknowns.names:
        n = lay.unknowns.count(k)
        if n:
            sl = lay.unknowns[k]
            picked = ca.Function("pick", [pr["x"]], [pr["x"][sl.start:sl.stop]])
            probe = np.arange(lay.unknowns.size, dtype=float)
            assert np.array_equal(np.asarray(picked(probe)).ravel(), probe[sl])
            assert syms[names.get(k, k)].shape[0] == n
    # the sizes: one load and one gap per slice held, one approach per block
    s = lay.sizes()
    assert s["nx"] == sum(b.count for b in nlp.blocks) and s["nB"] == len(nlp.blocks)
    assert s["P"] == 2 and s["TC"] == 4 and lay.rows.count("pressure") == nlp.rows["flank"].size > 0
    # the equality rows (contact conditions) and the inequality rows (TE bounds, pressure) by name
    eq = nlp.lbg == nlp.ubg
    for k in ("stiffness", "gap", "complementarity", "balance"):
        assert eq[lay.rows[k]].all()
    for k in ("te_hi", "te_lo", "pressure"):
        assert not eq[lay.rows[k]].any()


@pytest.mark.slow
def test_start_point_and_bounds_by_name(around):
    opt, cur = around
    nlp, z0 = cur.nlp, cur.z0
    U = nlp.layout.unknowns
    assert np.allclose(U.take(z0, "theta"), opt.theta0 * 1e3)
    x, y = U.take(z0, "x"), U.take(z0, "y")
    assert np.allclose(x * y, 1e-8, rtol=1e-6) and np.all(x > 0) and np.all(y > 0)  # x y = MU
    assert np.all(U.take(z0, "te_hi").reshape(2, 2) >= U.take(z0, "te_lo").reshape(2, 2))
    lbx, ubx = opt._bounds(nlp)
    assert np.array_equal(U.take(lbx, "theta"), opt.lo * 1e3) and np.array_equal(U.take(ubx, "theta"), opt.hi * 1e3)
    assert np.all(U.take(lbx, "slack_p") == 0.0) and np.all(U.take(lbx, "slack_e") == 0.0)
    assert np.all(np.isinf(np.delete(lbx, np.r_[U["theta"], U["slack_p"], U["slack_e"]])))
    pred = opt._predicted(nlp, z0)  # the exact loaded TCA's TE at the start point
    assert np.allclose(pred["te_pp"], cur.check.te_pp, atol=1e-3)


def test_a_block_layout_refuses_an_unknown_name():
    lay = BlockLayout(dict(a=2, b=0, c=3))
    assert lay.size == 5 and lay["c"] == slice(2, 5) and lay.count("b") == 0 and lay.span("a", "c") == slice(0, 5)
    assert np.array_equal(block_vector(lay, {"c": 1.0}, fill=-1.0), [-1, -1, 1, 1, 1])
    with pytest.raises(ParameterNameError, match="'d'"):
        lay["d"]
    with pytest.raises(ParameterNameError, match="negative"):
        BlockLayout(dict(a=-1))
