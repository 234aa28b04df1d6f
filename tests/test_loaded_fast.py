"""The loaded micro-geometry optimiser in the fast tier (issue 40): one tiny problem (the 20/40 spur drive,
one torque, 8 positions, 5 slices, two free amounts) solved once, then its prediction against the exact
loaded TCA, its sensitivities against central differences of re-solved optima, a two-point Pareto front
and the units of the result. Exercises the NLP's assembly (``nlp``), its start / bounds / prediction
(``solution``), the linearisation (``linearise``), the edge weights (``edges``), the held data's motion
(``held_data``), the KKT sensitivities (``sensitivity``) and the pressure-limit sweep (``pareto``); the
slow tier checks the same on the full problems (test_loaded_synthesis*.py, test_loaded_sensitivity*.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gearopt.gears import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.ltca.engine import LTCA
from gearopt.synthesis.loaded import LoadedMicroOptimizer

FREE = {"pinion.C_alpha": (0.0, 0.04), "pinion.C_beta": (0.0, 0.04)}
TORQUE = 210.0  # [N m] (T -+ 3 N m keep the optimum's active set: C_beta on its bound, no edge row)


def _optimiser(torque: float = TORQUE) -> LoadedMicroOptimizer:
    """The tiny problem, its pairs in mesh uncoupled (``neighbours = "none"``): TORQUE and the claims below
    (C_beta on its bound alone, no edge row, a torque derivative of C_alpha) are those of the uncoupled
    model. With the bodies' coupling (the default) the optimum sits on C_beta's bound and the edge row
    (binding ("pinion.C_beta at its upper bound", "edge"), edge_share 0.037 verified, both amounts
    fixed: no derivative to compare); the coupled optimiser is checked in test_loaded_pareto.py and the
    slow tier. The objective is the NLP's on its 8 positions (``exchange=False``): the claims below are
    those of its optimum; the exchange of the loaded TE extremes is tested in test_loaded_exchange.py."""
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_alpha=0.005, C_beta=0.010)),
                    Gear(z=40, m_n=3.0, b=20.0))
    opt = LoadedMicroOptimizer(pair, FREE, torques=[torque], n_positions=8, n_verify=8, n_slices=5, exchange=False)
    opt.ltca = LTCA(pair, dataclasses.replace(opt.ltca.settings, neighbours="none"), material=opt.material,
                    tca=opt.tca)
    return opt


@pytest.fixture(scope="module")
def tiny():
    """The optimiser and its optimum (about 1.5 s warm)."""
    opt = _optimiser()
    return opt, opt.solve()


def test_the_nlps_prediction_is_the_exact_loaded_tca_of_the_optimum(tiny):
    """The NLP's loaded TE and peak pressure at the optimum equal those of the loaded TCA (built here, the
    drive carrying the optimum's amounts) within the smoothing's 1e-3 arcsec; the optimum relieves the
    start design's edge loading and lowers its loaded TE."""
    opt, d = tiny
    ltca = LTCA(GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(
        C_alpha=d.theta["pinion.C_alpha"], C_beta=d.theta["pinion.C_beta"])), Gear(z=40, m_n=3.0, b=20.0)),
        n_slices=5, neighbours="none")
    r = ltca.solve(TORQUE, opt.phi1).results[0]
    assert abs(r.peak_to_peak_arcsec - float(d.predicted["te_pp"][0, 0])) < 1e-3
    assert abs(r.p_max - float(d.predicted["p_max"][0, 0])) < 1.0  # MPa
    assert d.error["te_pp"] < 1e-3
    assert d.before.edge_share[0, 0] > 0.05 and d.after.edge_share[0, 0] < 1e-3
    assert d.after.objective < 0.5 * d.before.objective


def test_the_results_units_agree(tiny):
    """The design [mm] is the last accepted round's [um] / 1000, within the bounds; the binding bound named
    is the one the design sits on; predicted and verified peak pressure [MPa] agree."""
    opt, d = tiny
    theta = np.array(list(d.theta.values()))
    accepted = [r for r in d.rounds if r["accepted"] is True]
    np.testing.assert_allclose(np.array(accepted[-1]["theta_um"]) / 1e3, theta, rtol=0, atol=1e-9)
    assert np.all(theta >= opt.lo - 1e-12) and np.all(theta <= opt.hi + 1e-12)
    on_bound = [n for n, v in d.theta.items() if abs(v - FREE[n][1]) < 1e-9]
    assert on_bound == ["pinion.C_beta"] and d.binding == ("pinion.C_beta at its upper bound",)
    assert 500.0 < float(d.verified.p_max[0, 0]) < 5000.0  # MPa, not Pa or GPa
    assert abs(float(d.predicted["p_max"][0, 0]) - float(d.verified.p_max[0, 0])) < 1.0


def test_the_torque_sensitivities_are_the_central_differences_of_re_solved_optima(tiny):
    """d objective / d T and d theta / d T (KKT system, with the held data's motion) against central
    differences of the optima re-solved at T -+ 3 N m (the same active set: C_beta on its bound). The held
    data's motion (:mod:`.held_data`) runs here but moves these derivatives by less than the tolerances on
    this drive; test_loaded_sensitivity*.py check its effect on the full problems."""
    opt, d = tiny
    s = opt.sensitivities(d)
    h = 3.0
    theta = np.array(list(d.theta.values()))
    lo, hi = (_optimiser(TORQUE + sgn * h).solve(start=theta) for sgn in (-1.0, 1.0))
    fd_obj = (hi.after.objective - lo.after.objective) / (2 * h)
    fd_theta = (np.array(list(hi.theta.values())) - np.array(list(lo.theta.values()))) / (2 * h)
    assert abs(s["d_objective_d_torque"][0] - fd_obj) < 0.02 * abs(fd_obj), (s["d_objective_d_torque"], fd_obj)
    np.testing.assert_allclose(s["d_theta_d_torque"][:, 0], fd_theta, rtol=0.05, atol=1e-7)
    assert abs(fd_theta[0]) > 1e-5  # the free C_alpha moves with the torque: a derivative to compare


def test_a_two_point_pareto_front_meets_each_limit_and_is_monotone(tiny):
    """Limits below the unconstrained optimum's peak pressure: each point's loaded TCA (verification grid)
    meets its limit, the limit binds (the peak is at it), and the loaded TE grows as the limit falls."""
    opt, d = tiny
    p0 = float(np.max(d.after.p_max))
    lims = [round(p0 - 60.0), round(p0 - 150.0)]
    front = opt.pareto(lims, anchor=d)
    pts = front.points()
    assert [p["p_limit_MPa"] for p in pts[1:]] == sorted(lims, reverse=True)
    te = [p["objective_arcsec"] for p in pts]
    for p in pts[1:]:
        assert p["feasible"]
        assert p["p_max_MPa"] <= p["p_limit_MPa"] * (1 + 1e-3)
        assert p["p_max_MPa"] > p["p_limit_MPa"] - 15.0  # binding
    assert te[0] < te[1] < te[2]
