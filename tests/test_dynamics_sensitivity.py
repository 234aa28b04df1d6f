"""Sensitivities of the dynamic response to micro-geometry amounts (docs/dynamics.md section 7): the loaded
TCA's tangents (gearopt.ltca.tangent) and the smooth objective over a speed range with its AD gradient
(gearopt.dynamics.sensitivity), each against finite differences of re-run loaded TCAs and sweeps; kinks
of the active set flagged; bad input refused."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from gearopt.dynamics import DriveTrain, GearDynamics, MeshExcitation
from gearopt.errors import OptionError
from gearopt.gears import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.settings import LTCASettings

MODS = Microgeometry(C_alpha_a=0.025, d_Ca=62.0, tip_shape="linear")
LTCA_OPTS = {"n_slices": 11}
POSITIONS = 16
H_MM = 1e-4  # finite-difference step of an amount [mm] = 0.1 um


def relieved(mods: Microgeometry = MODS) -> GearPair:
    """The ltca_spur drive (20/40, m 3 mm, b 20 mm) with a linear tip relief of 25 um on the pinion."""
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=mods), Gear(z=40, m_n=3.0, b=20.0))


def engine(mods: Microgeometry) -> tuple:
    """The loaded TCA of the engine itself (no tangent code): stiffness [N/um], unloaded TE [rad] with
    the TE zero added back (the tangents hold it), loaded TE [rad] likewise."""
    from gearopt.ltca.engine import LTCA

    L = LTCA(relieved(mods), **LTCA_OPTS)
    sw = L.solve(200.0, phi1=L.mesh_cycle(POSITIONS))
    r = sw.results[0]
    z = sw.slices.phi2_ref
    return r.stiffness, r.te_unloaded + z, r.te_loaded + z


def central(key: str) -> tuple:
    v = getattr(MODS, key)
    p, m = engine(replace(MODS, **{key: v + H_MM})), engine(replace(MODS, **{key: v - H_MM}))
    return tuple((a - b) / (2 * H_MM * 1e3) for a, b in zip(p, m))  # per um


@pytest.fixture(scope="module")
def tangent():
    from gearopt.ltca.tangent import loaded_tangents

    return loaded_tangents(relieved(), 200.0, ["pinion.C_alpha_a", "pinion.f_H_alpha"], positions=POSITIONS,
                           settings=LTCASettings(**LTCA_OPTS))


@pytest.mark.slow  # about 15 s: the tangents and four loaded TCAs
def test_loaded_tangents_match_finite_differences(tangent):
    """d(stiffness)/d(C_alpha_a) and d(loaded TE)/d(C_alpha_a) by implicit differentiation against central
    differences of the engine's loaded TCA (0.1 um steps): to 1e-3 of their largest value at every
    position (no position is within the step of an active-set change for the tip relief)."""
    dk, dte0, dtel = central("C_alpha_a")
    assert np.all(tangent.margin_um[:, 0] > 10 * H_MM * 1e3)
    assert np.abs(dk).max() > 1.0  # N/um per um: the relief softens the mesh where it acts
    assert tangent.d_stiffness[:, 0] == pytest.approx(dk, abs=1e-3 * np.abs(dk).max())
    assert tangent.d_te_loaded[:, 0] == pytest.approx(dtel, abs=1e-3 * np.abs(dtel).max())
    assert tangent.d_te_unloaded[:, 0] == pytest.approx(dte0, abs=1e-12)


@pytest.mark.slow  # about 15 s
def test_active_set_changes_of_a_profile_slope_are_flagged(tangent):
    """A profile slope deviation f_H_alpha moves the two conjugate pairs of the double contact apart:
    the unloaded TE (the larger of the two pairs' TE) has a kink there. Those positions are flagged
    (te0_kink, margin 0) and so are their neighbours within the step (margin below 0.1 um); everywhere
    else the tangents agree with the differences."""
    dk, dte0, _ = central("f_H_alpha")
    kink = tangent.te0_kink[:, 1]
    assert kink.any() and np.all(tangent.margin_um[kink, 1] == 0.0)
    assert not tangent.te0_kink[:, 0].any()  # the tip relief leaves the double contact's tie alone
    far = tangent.margin_um[:, 1] > 10 * H_MM * 1e3
    assert far.sum() >= POSITIONS // 2
    assert tangent.d_stiffness[far, 1] == pytest.approx(dk[far], abs=1e-3 * np.abs(dk).max())
    assert tangent.d_te_unloaded[far, 1] == pytest.approx(dte0[far], abs=1e-3 * np.abs(dte0).max())


def test_bad_amounts_are_refused():
    from gearopt.dynamics.sensitivity import speed_range_sensitivity
    from gearopt.ltca.tangent import loaded_tangents

    for bad in (["pinion.d_Ca"], ["wheel.C_alpha"], [], ["gear.C_alpha_a"]):  # the gear has no tip relief start
        with pytest.raises(OptionError) as e:
            loaded_tangents(relieved(), 200.0, bad)
        assert e.value.param == "amounts"
    for kw, param in (({"aggregate": "max"}, "aggregate"), ({"branch": "sideways"}, "branch"), ({"rho": 0.0}, "rho"),
                      ({"speeds_rpm": [0.0, 100.0]}, "speeds")):
        args = {"speeds_rpm": [1000.0, 2000.0], **kw}
        with pytest.raises(OptionError) as e:
            speed_range_sensitivity(relieved(), 200.0, ["pinion.C_alpha_a"], **args)
        assert e.value.param == param


# a one-degree-of-freedom pair (tests/test_dynamics.py)
J1, J2, L1, L2, K0, W, Z1 = 2e-4, 1e-3, 0.028, 0.056, 4e8, 7000.0, 20
M_E = 1.0 / (L1**2 / J1 + L2**2 / J2)
N_RES = 60.0 * math.sqrt(K0 / M_E) / (2 * math.pi) / Z1


def ks(force: np.ndarray, W: float, rho: float) -> float:
    """(1/rho) ln(mean exp(rho F/W)), written out."""
    k = force / W
    return float(k.max() + np.log(np.mean(np.exp(rho * (k - k.max())))) / rho)


@pytest.mark.parametrize("ratio", [0.5, 0.93])
def test_smooth_peak_gradient_matches_finite_differences(ratio):
    """d K~ / d P by AD (adjoint sensitivities, implicit-function theorem on the shooting equations)
    against central differences of freshly built models (their own damping c_m and smoothing width,
    which the AD follows through the mean stiffness and the load): 1e-5 relative; 0.93 loses contact."""
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=0.05, backlash=1e-4)
    P0 = MeshExcitation([K0, 0.15 * K0, 0.02 * K0], [0.05 * K0, 0.01 * K0], [0.0, 12e-6, 2e-6], [1e-6, 0.5e-6],
                        W).params()
    rho = 50.0

    def model(P):
        gd = GearDynamics(tr, MeshExcitation(P[1:4], P[4:6], P[6:9], P[9:11], P[0]), Z1, tol=1e-12, newton_tol=1e-10)
        s = gd.solve(ratio * N_RES)
        assert s.converged
        return gd, s, ks(s.force, P[0], rho)

    gd, s, k0 = model(P0)
    kt, g, sig = gd.smooth_peak(s, rho)
    assert kt == pytest.approx(k0, rel=1e-12) and sig > 0.1
    for i in (0, 1, 2, 5, 7, 8, 10):  # the load, the mean stiffness (c_m), harmonics of k and e
        h = 1e-4 * abs(P0[i])
        Pp, Pm = P0.copy(), P0.copy()
        Pp[i] += h
        Pm[i] -= h
        fd = (model(Pp)[2] - model(Pm)[2]) / (2 * h)
        assert g[i] == pytest.approx(fd, rel=1e-5, abs=1e-9 / abs(P0[i])), i


@pytest.mark.slow  # about 40 s: the tangents, three loaded TCAs and three sweeps
def test_speed_range_gradient_matches_finite_differences():
    """The KS objective of K_v over 12,000 ... 24,000 rpm and its gradient in the tip relief amount
    (AD through the loaded TCA's tangents, the Fourier map and the shooting) against the objective of
    sweeps re-run on the loaded TCAs of the displaced designs (0.1 um): to 1e-3 relative, each speed's
    smooth peak to 1e-3 of the largest; the speed that did not converge is reported and left out."""
    from gearopt.dynamics.drive import drive_train, loaded_mesh
    from gearopt.dynamics.sensitivity import aggregate_objective, pick_solutions, smooth_peaks, speed_range_sensitivity

    speeds = np.linspace(12000.0, 24000.0, 7)
    r = speed_range_sensitivity(relieved(), 200.0, ["pinion.C_alpha_a"], speeds, positions=32)

    def objective(mods):
        pair = relieved(mods)
        lm = loaded_mesh(pair, 200.0, positions=32)
        gd = GearDynamics(drive_train(pair, 0.05), lm.excitation(), 20, tol=1e-9, newton_tol=1e-7)
        sols, _, excluded = pick_solutions(gd.sweep(speeds, both=False), "up")
        kt = smooth_peaks([s.force for s in sols], lm.W, 50.0)
        return aggregate_objective(kt, 50.0)[0], kt, excluded

    J0, kt0, ex0 = objective(MODS)
    assert r.objective == pytest.approx(J0, rel=1e-7)
    assert r.excluded_speeds_rpm == ex0 and len(r.speeds_rpm) + len(ex0) == len(speeds)
    (Jp, kp, exp), (Jm, km, exm) = (objective(replace(MODS, C_alpha_a=MODS.C_alpha_a + s * H_MM)) for s in (1, -1))
    assert exp == exm == ex0
    fd = (Jp - Jm) / (2 * H_MM * 1e3)
    assert r.gradient[0] == pytest.approx(fd, rel=1e-3)
    dk = (kp - km) / (2 * H_MM * 1e3)
    assert r.dK_v_smooth[:, 0] == pytest.approx(dk, abs=1e-3 * np.abs(dk).max())
    assert not r.at_fold_speeds_rpm and r.kink_positions["pinion.C_alpha_a"] == []
