"""The loaded optimiser's objective confirmed between its NLP's positions (issue 37; module
``gearopt.synthesis.loaded.exchange``, docs/loaded_synthesis.md section 4): the objective the optimiser
promises (its NLP's, on its own positions) is the loaded TE peak-to-peak of the optimum on a fine grid
of a loaded TCA built here (nothing of the optimiser); the golden-section extremes against a fine
grid; a disagreement that the exchanges allowed cannot remove raises."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gearopt.errors import OptionError
from gearopt.gears import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.ltca.engine import LTCA
from gearopt.synthesis.crowning import SynthesisError
from gearopt.synthesis.loaded import LoadedMicroOptimizer

FREE = {"pinion.C_alpha": (0.0, 0.04), "pinion.C_beta": (0.0, 0.04)}
TORQUE = 210.0  # [N m]
FINE = 384  #: positions per mesh cycle of the reference grid (4 times the confirmation grid)


def _pair(C_alpha: float = 0.005, C_beta: float = 0.010) -> GearPair:
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_alpha=C_alpha, C_beta=C_beta)),
                    Gear(z=40, m_n=3.0, b=20.0))


def _optimiser(**options) -> LoadedMicroOptimizer:
    """The tiny problem of test_loaded_fast.py (the 20/40 spur drive, one torque, 8 positions, 5 slices,
    two free amounts, the pairs uncoupled), with the exchange on (the default is off: docs/loaded_synthesis.md
    section 4, "Confirmed") unless ``options`` say otherwise."""
    options = {"exchange": True, **options}
    opt = LoadedMicroOptimizer(_pair(), FREE, torques=[TORQUE], n_positions=8, n_verify=8, n_slices=5, **options)
    opt.ltca = LTCA(opt.pair, dataclasses.replace(opt.ltca.settings, neighbours="none"), material=opt.material,
                    tca=opt.tca)
    return opt


def _fine_pp(theta: dict) -> float:
    """Loaded TE peak-to-peak [arcsec] of the drive with the amounts ``theta`` [mm] on ``FINE`` positions
    per mesh cycle, by a loaded TCA built here."""
    ltca = LTCA(_pair(theta["pinion.C_alpha"], theta["pinion.C_beta"]), n_slices=5, neighbours="none")
    return ltca.solve(TORQUE, ltca.mesh_cycle(FINE)).results[0].peak_to_peak_arcsec


@pytest.fixture(scope="module")
def solved():
    opt = _optimiser()
    return opt, opt.solve()


def test_the_promised_objective_is_the_optimums_loaded_te_on_a_fine_grid(solved):
    """The NLP's objective at the optimum (what the optimiser promises) is the loaded TE peak-to-peak of the
    optimum's drive on 384 positions per cycle within confirm_tol (1 %). Without the exchange the optimum
    on 8 positions promised 7 % less than the fine grid gives (the NLP's peak-to-peak over its positions)."""
    opt, d = solved
    fine = _fine_pp(d.theta)
    assert abs(d.promised - fine) <= opt.confirm_tol * fine, (d.promised, fine)
    # the result reports both and their difference, and they agree
    assert d.confirmed is not None and d.error["confirmed"] == pytest.approx(d.confirmed.objective - d.promised)
    assert abs(d.error["confirmed"]) <= opt.confirm_tol * d.confirmed.objective
    assert d.to_dict()["confirmed"]["objective_arcsec"] == d.confirmed.objective


def test_the_confirmed_extremes_are_those_of_a_fine_grid(solved):
    """``confirm``'s golden-section extremes (96 positions, refined between them) give at least the
    peak-to-peak of a grid four times finer and at most 0.5 % more (a grid's peak-to-peak falls short of
    the continuous one by what it misses: 0.15 % here); by a loaded TCA built here, each extreme's loaded
    TE gives the reported peak-to-peak, and the largest (smallest) is not exceeded (undercut) 1/50 of a
    grid step to either side."""
    opt, d = solved
    theta = np.array([d.theta[k] for k in opt.free])
    conf = opt.confirm(theta)
    fine = _fine_pp(d.theta)
    assert fine - 1e-9 <= conf.objective <= fine * (1 + 5e-3), (conf.objective, fine)
    assert conf.grid_objective <= conf.objective + 1e-12
    ltca = LTCA(_pair(theta[0], theta[1]), n_slices=5, neighbours="none")
    hi, lo = conf.extremes[0, 0]
    step = 2 * np.pi / 20 / 96 / 50
    x = np.array([hi - step, hi, hi + step, lo - step, lo, lo + step])
    o = np.argsort(x)
    te = np.empty(6)
    te[o] = ltca.solve(TORQUE, x[o]).results[0].te_loaded_arcsec
    assert te[1] - te[4] == pytest.approx(conf.te_pp[0, 0], abs=1e-9)
    assert te[1] >= max(te[0], te[2]) - 1e-9 and te[4] <= min(te[3], te[5]) + 1e-9, te


def test_an_objective_the_exchanges_cannot_confirm_raises():
    """With no exchange allowed, the optimum of the 8 positions (whose loaded TE extremes lie between
    them) is not confirmed: SynthesisError naming max_exchanges, both objectives in the message."""
    opt = _optimiser(max_exchanges=0)
    with pytest.raises(SynthesisError, match="not confirmed between them") as e:
        opt.solve()
    assert e.value.param == "max_exchanges"


@pytest.mark.parametrize("key,value,valid", [("confirm_tol", 0.0, "0 < confirm_tol <= 0.5"),
                                             ("confirm_tol", 0.6, "0 < confirm_tol <= 0.5"),
                                             ("max_exchanges", -1, "0 <= max_exchanges <= 20"),
                                             ("n_confirm", 4, "8 <= n_confirm <= 2000")])
def test_bad_confirmation_options_name_themselves(key, value, valid):
    """An option out of its range: an OptionError naming the option, the value and the valid range."""
    with pytest.raises(OptionError, match=f"{key} = {value} is out of range; valid: .*{valid}"):
        LoadedMicroOptimizer(_pair(), FREE, torques=[TORQUE], **{key: value})


def test_without_the_exchange_the_disagreement_is_reported():
    """``exchange=False``: the NLP's objective on its 8 positions only, and the result says by how much the
    loaded TE between them exceeds it (more than confirm_tol here: the optimum's extremes lie between the
    positions), without raising."""
    opt = _optimiser(exchange=False)
    d = opt.solve()
    assert d.exchanges == 0 and d.phi1.size == 8
    assert d.error["confirmed"] == pytest.approx(d.confirmed.objective - d.promised)
    assert d.error["confirmed"] > opt.confirm_tol * d.confirmed.objective
    assert d.confirmed.objective >= _fine_pp(d.theta) - 1e-9
