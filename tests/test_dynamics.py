"""Gear dynamics (gearopt.dynamics, docs/dynamics.md): the validation cases against closed forms and an
independent integration, the low-speed limit against the loaded TCA, Floquet stability against the
Mathieu chart, and the refusals of bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from gearopt.dynamics import DriveTrain, GearDynamics, MeshExcitation
from gearopt.dynamics.drive import drive_train, iso_resonance_speed, loaded_mesh
from gearopt.dynamics.settings import DynamicsSettings
from gearopt.errors import OptionError
from gearopt.gears import Gear, GearPair

# a one-degree-of-freedom pair: m_e = (l1^2/J1 + l2^2/J2)^-1 = 0.15076... kg
J1, J2, L1, L2 = 2e-4, 1e-3, 0.028, 0.056
K0, W = 4e8, 7000.0  # N/m, N
M_E = 1.0 / (L1**2 / J1 + L2**2 / J2)
Z1 = 20


def n_res(k: float = K0) -> float:
    """Pinion speed [rpm] where the mesh frequency equals sqrt(k / m_e) (order 1)."""
    return 60.0 * math.sqrt(k / M_E) / (2 * math.pi) / Z1


def amp_phase(x: np.ndarray) -> tuple[float, float, float]:
    """Mean, first-harmonic amplitude and phase lag of samples over one period (x = a + X cos(phi - psi))."""
    c = np.fft.rfft(x) / len(x)
    return float(c[0].real), float(2 * abs(c[1])), float(-np.angle(c[1]))


@pytest.mark.parametrize("ratio", [0.3, 0.8, 0.97, 1.0, 1.05, 1.6])
def test_lti_limit_equals_closed_form_sdof(ratio):
    """Constant stiffness, sinusoidal TE e = E cos(omega t): x = W/k + X cos(omega t - psi) with
    X = k E / sqrt((k - m w^2)^2 + (c w)^2), psi = atan2(c w, k - m w^2) (written out here)."""
    zeta, E = 0.05, 2e-6
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=zeta)
    gd = GearDynamics(tr, MeshExcitation([K0, 0.0], [0.0], [0.0, E], [0.0], W), Z1, contact_loss=False)
    assert gd.natural_frequencies()[0] == pytest.approx(math.sqrt(K0 / M_E) / (2 * math.pi), rel=1e-12)
    s = gd.solve(ratio * n_res())
    assert s.converged
    w = s.omega_m
    c = 2 * zeta * math.sqrt(K0 * M_E)
    X = K0 * E / math.hypot(K0 - M_E * w**2, c * w)
    psi = math.atan2(c * w, K0 - M_E * w**2)
    mean, amp, ph = amp_phase(s.x)
    assert mean == pytest.approx(W / K0, rel=1e-9)
    assert amp == pytest.approx(X, rel=1e-6)
    assert abs((ph - psi + math.pi) % (2 * math.pi) - math.pi) < 1e-6


def _rhs(k0, eps_k, E, zeta, backlash, smooth):
    """Equation (2) of docs/dynamics.md for one degree of freedom, written independently in numpy
    (time t in s, state (x, xdot) in m, m/s)."""
    c = 2 * zeta * math.sqrt(k0 * M_E)

    def h(s):
        return 0.5 * (s + np.sqrt(s * s + smooth**2))

    def dh(s):
        return 0.5 * (1 + s / np.sqrt(s * s + smooth**2))

    def f(t, y, w):
        ph = w * t
        k = k0 * (1 + eps_k * np.cos(ph))
        s = y[0] - E * np.cos(ph)
        F = k * (h(s) - h(-s - backlash)) + c * y[1] * (dh(s) + dh(-s - backlash))
        return [y[1], (W - F) / M_E], F

    return f


@pytest.mark.slow  # 1-2 s each: scipy's integration over 120 periods
@pytest.mark.parametrize("ratio, loss", [(0.5, False), (0.93, True), (1.4, True)])
def test_nonlinear_response_against_solve_ivp(ratio, loss):
    """Periodic stiffness, TE excitation, contact loss: the shooting solution's peak mesh force
    against scipy's explicit DOP853 (Dormand-Prince 8(5,3)) integration from the static state over
    120 mesh periods (to steady state): within 1 % of the peak force; the speed with contact loss
    shows it in both. The one-degree-of-freedom system is not stiff (one natural frequency, 5 %
    damping): DOP853 gives Radau's peak to 1e-7 at a tenth of the time (benchmarks/dynamics_reference.py)."""
    k0, eps_k, E, zeta, bl, sm = K0, 0.15, 12e-6, 0.05, 100e-6, 1e-3
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=zeta, backlash=bl)
    exc = MeshExcitation([k0, k0 * eps_k], [0.0], [0.0, E], [0.0], W)
    gd = GearDynamics(tr, exc, Z1, smoothing=sm)
    s = gd.solve(ratio * n_res())
    assert s.converged
    w = s.omega_m
    f = _rhs(k0, eps_k, E, zeta, bl, sm * W / k0)
    T = 2 * math.pi / w
    n = 120
    sol = solve_ivp(lambda t, y: f(t, y, w)[0], (0, n * T), [W / k0, 0.0], method="DOP853", rtol=1e-9, atol=1e-13,
                    dense_output=True)
    t = (n - 1) * T + np.linspace(0, T, 400, endpoint=False)
    F = np.array([f(ti, sol.sol(ti), w)[1] for ti in t])
    x = sol.sol(t)[0]
    peak_ref = float(F.max())
    assert float(s.force.max()) == pytest.approx(peak_ref, rel=0.01)
    assert (x - E * np.cos(w * t)).min() < 0 if loss else (x - E * np.cos(w * t)).min() > 0
    assert s.contact_loss() == loss


def _mathieu_boundaries(eps: float) -> tuple[float, float]:
    """The first principal instability region of x'' + (1/W^2)(1 + eps cos tau) x = 0 (tau the mesh
    phase, W = omega_mesh / omega_n): with t = tau / 2 it is Mathieu's y'' + (a - 2 q cos 2t) y = 0,
    a = 4 / W^2, q = -2 eps / W^2; its transition curves a = 1 - q - q^2/8 + q^3/64 and
    a = 1 + q - q^2/8 - q^3/64 (McLachlan; |q| small) solved for W."""
    from scipy.optimize import brentq

    def curve(sign):
        def g(Wr):
            a, q = 4 / Wr**2, abs(2 * eps / Wr**2)
            return a - (1 + sign * q - q * q / 8 - sign * q**3 / 64)
        return brentq(g, 1.5, 2.5)

    return tuple(sorted((curve(+1), curve(-1))))


def test_floquet_multipliers_match_mathieu_chart():
    """Periodic stiffness k0 (1 + eps cos phi), no excitation, no damping: the Floquet multipliers
    of the monodromy matrix leave the unit circle exactly inside the first principal region (mesh
    frequency ~ 2 x natural frequency); its edges found by bisection match the chart to 1e-4."""
    eps = 0.2
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=0.0)
    gd = GearDynamics(tr, MeshExcitation([K0, K0 * eps], [0.0], [0.0, 0.0], [0.0], 0.0), Z1, contact_loss=False,
                      tol=1e-12)

    def rho(Wr):
        return float(np.abs(np.linalg.eigvals(gd.monodromy(Wr * n_res(), np.zeros(2)))).max())

    lo, hi = _mathieu_boundaries(eps)
    assert rho(2.0) > 1.05  # inside: unstable
    assert rho(0.5 * (lo + hi)) > 1.05
    for Wr in (lo - 0.02, hi + 0.02, 1.5, 2.5):
        assert rho(Wr) == pytest.approx(1.0, abs=1e-6)  # outside: on the unit circle (undamped, stable)

    def edge(a, b):  # a stable, b unstable
        for _ in range(40):
            m = 0.5 * (a + b)
            if rho(m) > 1 + 1e-7:
                b = m
            else:
                a = m
        return 0.5 * (a + b)

    assert edge(lo - 0.05, 2.0) == pytest.approx(lo, abs=1e-4)
    assert edge(hi + 0.05, 2.0) == pytest.approx(hi, abs=1e-4)


@pytest.fixture(scope="module")
def spur():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    return pair, loaded_mesh(pair, 200.0)


def test_low_speed_limit_is_the_static_loaded_te(spur):
    """Form (a) (k(phi) on the gap to the unloaded TE) at 0.2 % of the resonance speed: K_v = 1 and
    the dynamic TE equals the loaded TCA's loaded TE at its positions (form (b)'s loaded TE in
    place of the unloaded one would shift it by the whole static deflection)."""
    pair, lm = spur
    tr = drive_train(pair, 0.05)
    gd = GearDynamics(tr, lm.excitation(), pair.pinion.z, samples=2 * len(lm.phi1))
    nE = 60 * gd.natural_frequencies()[0] / pair.pinion.z
    s = gd.solve(0.002 * nE)
    assert s.converged
    assert s.force.max() / lm.W == pytest.approx(1.0, abs=2e-3)
    assert s.force.min() / lm.W == pytest.approx(1.0, abs=2e-3)
    te = -s.x[::2] / lm.lever_gear
    assert np.max(np.abs(te - lm.te_loaded)) < 5e-3 * np.ptp(lm.te_loaded)


def test_resonance_speed_against_iso(spur):
    """The model's linear resonance (mean loaded-TCA stiffness) and ISO 6336-1's n_E1 from the same
    masses agree as the two stiffnesses do: n ~ sqrt(c_gamma)."""
    pair, lm = spur
    tr = drive_train(pair, 0.05)
    gd = GearDynamics(tr, lm.excitation(), pair.pinion.z)
    n_model = 60 * gd.natural_frequencies()[0] / pair.pinion.z
    b = 20.0
    m_red = tr.m_e / b  # kg/mm
    n_E1 = 30000 / (math.pi * 20) * math.sqrt(lm.c_gamma / m_red)  # ISO 6336-1 eq. (13), written out
    assert iso_resonance_speed(pair, tr, lm.c_gamma) == pytest.approx(n_E1, rel=1e-12)
    assert n_model == pytest.approx(n_E1, rel=1e-9)  # k_mean = c_gamma b


def test_sweep_reports_both_branches_of_the_softening_jump():
    """Strong TE excitation, light damping: sweeping up and down gives two steady states over a
    speed range below the resonance (contact loss on the upper one), and the up branch jumps."""
    from gearopt.studies.dynamics import _jumps

    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=0.03, backlash=1e-3)
    gd = GearDynamics(tr, MeshExcitation([K0, 0.0], [0.0], [0.0, 8e-6], [0.0], W), Z1)
    v = np.linspace(0.4, 1.2, 33) * n_res()
    sw = gd.sweep(v)
    up = [float(s.force.max()) / W if s.converged else None for s in sw.up]
    down = [float(s.force.max()) / W if s.converged else None for s in sw.down]
    coexist, jumps = _jumps(v, up, down)
    assert coexist and max(coexist) < n_res()  # softening: the overhang lies below the linear resonance
    assert any(j["branch"] == "up" for j in jumps) and any(j["branch"] == "down" for j in jumps)
    i = int(np.argmin(np.abs(v - coexist[0])))
    assert sw.down[i].contact_loss() and down[i] > up[i]


# --- bad input ------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, param", [
    ({"zeta": 1.0}, "damping"), ({"zeta": -0.1}, "damping"), ({"J_pinion": 0.0}, "inertia_pinion"),
    ({"J_gear": -1.0}, "inertia_gear"), ({"J_drive": 1e-3}, "inertia_drive"),
    ({"J_drive": 0.0, "k_drive": 1e4}, "inertia_drive"), ({"J_load": 1.0, "k_load": 0.0}, "shaft_stiffness_load"),
])
def test_drive_train_refuses_bad_values(kw, param):
    args = dict(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2)
    args.update(kw)
    with pytest.raises(OptionError) as e:
        DriveTrain(**args)
    assert e.value.param == param and param in str(e.value)


@pytest.mark.parametrize("kw, param", [({"damping": 1.0}, "damping"), ({"speed_max": 0.0}, "speed_max"),
                                       ({"speed_min": 100.0, "speed_max": 50.0}, "speed_max"),
                                       ({"speed_min": -1.0}, "speed_min"), ({"harmonics": 40}, "harmonics")])
def test_settings_refuse_bad_values(kw, param):
    with pytest.raises(OptionError) as e:
        DynamicsSettings(**kw)
    assert e.value.param == param and param in str(e.value)


def test_speeds_without_a_positive_speed_are_refused():
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2)
    gd = GearDynamics(tr, MeshExcitation([K0, 0.0], [0.0], [0.0, 1e-6], [0.0], W), Z1)
    for bad in ([], [0.0, 100.0], [-5.0]):
        with pytest.raises(OptionError) as e:
            gd.sweep(bad)
        assert e.value.param == "speeds"
    with pytest.raises(OptionError) as e:
        gd.solve(0.0)
    assert e.value.param == "speed"


def test_torque_without_a_loaded_tca_is_refused(spur):
    from gearopt.studies.dynamics import DynamicsStudy

    pair, _ = spur
    for T in (0.0, -10.0, 1e6):
        with pytest.raises(OptionError) as e:
            DynamicsStudy(pair, T)
        assert e.value.param == "torque"
    with pytest.raises(OptionError) as e:
        DynamicsStudy(pair, 200.0, inertia_pinion=0.0)
    assert e.value.param == "inertia_pinion"


@pytest.mark.parametrize("ratio", [0.5, 0.93])
def test_peak_sensitivity_by_ad_matches_finite_differences(ratio):
    """d K_v / d P (AD through the shooting solution, implicit-function theorem) against central
    differences of re-solved models, for the load and the harmonics of k and e (the mean stiffness
    also sets c_m and the scales, which the AD derivative holds: left out); 0.93 loses contact."""
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=0.05, backlash=1e-4)
    P0 = MeshExcitation([K0, 0.15 * K0, 0.02 * K0], [0.05 * K0, 0.01 * K0], [0.0, 12e-6, 2e-6], [1e-6, 0.5e-6],
                        W).params()

    def model(P):
        exc = MeshExcitation(P[1:4], P[4:6], P[6:9], P[9:11], P[0])
        gd = GearDynamics(tr, exc, Z1, tol=1e-12, newton_tol=1e-10)
        s = gd.solve(ratio * n_res())
        assert s.converged
        return gd, s, float(s.force.max() / P[0])

    gd, s, _ = model(P0)
    g = gd.peak_sensitivity(s)
    assert g.shape == P0.shape
    for i in (0, 2, 3, 4, 5, 7, 8, 9, 10):
        h = 1e-4 * abs(P0[i])
        Pp, Pm = P0.copy(), P0.copy()
        Pp[i] += h
        Pm[i] -= h
        fd = (model(Pp)[2] - model(Pm)[2]) / (2 * h)
        assert g[i] == pytest.approx(fd, rel=2e-3, abs=1e-6 / abs(P0[i])), i


@pytest.mark.slow  # about a minute: five loaded TCAs of modified drives
def test_microgeometry_sensitivity_matches_finite_differences():
    """d K_v / d(tip relief amount, its start diameter) of the relieved ltca_spur pinion at 15,000 rpm:
    the AD chain (excitation -> K_v) times the loaded TCA's differences against the difference of K_v
    re-solved with the displaced designs' excitations (the same model's damping), to 2e-3."""
    from gearopt.dynamics.drive import microgeometry_sensitivity
    from gearopt.geometry.microgeometry import Microgeometry

    mods = Microgeometry(C_alpha_a=0.025, d_Ca=62.0, tip_shape="linear")
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=mods), Gear(z=40, m_n=3.0, b=20.0))
    r = microgeometry_sensitivity(pair, 200.0, 15000.0, "pinion", ["C_alpha_a", "d_Ca"], rel_step=2e-4)
    gd, sol = r["model"], r["solution"]
    for key, v in r["keys"].items():
        kv = []
        for P in (v["P_plus"], v["P_minus"]):
            s = gd.solve(15000.0, sol.y0, params=P)
            assert s.converged
            kv.append(float(s.force.max() / P[0]))
        fd = (kv[0] - kv[1]) / (2 * v["step_mm"])
        assert v["dKv_dmm"] == pytest.approx(fd, rel=2e-3), key
    assert r["keys"]["C_alpha_a"]["dKv_dmm"] != 0.0


def test_small_study_writes_documented_results_plots_and_tables(tmp_path, spur):
    """The study through the API on a coarse grid (fast): every results key documented in
    docs/results.md, both plots and both tables written, K_v about 1 at the lowest speed."""
    from results_doc import undocumented

    from gearopt.studies.dynamics import DynamicsStudy

    pair, _ = spur
    study = DynamicsStudy(pair, 200.0, positions=16, n_slices=5, speeds=4, speed_min=500.0, speed_max=20000.0,
                          samples=32)
    rep = study.run()
    d = rep.to_dict()
    assert undocumented(d, "dynamics") == []
    c = d["cases"][0]
    assert c["speeds_rpm"][0] == pytest.approx(500.0) and len(c["speeds_rpm"]) == 4
    assert c["up"]["K_v"][0] == pytest.approx(1.0, abs=0.1)
    files = rep.save_plots(tmp_path) + rep.save_tables(tmp_path)
    assert files == ["dynamics_factor.png", "dynamics_cycle.png", "dynamics_speeds.csv", "dynamics_cycles.csv"]
    for f in files:
        assert (tmp_path / f).stat().st_size > 1000
    head = (tmp_path / "dynamics_speeds.csv").read_text().splitlines()[0]
    assert head.startswith("case,branch,speed_rpm,converged,K_v")


def test_misalignment_reaches_the_excitation(spur):
    """A crossing angle changes the loaded TCA the model is driven by (its unloaded TE is no longer
    flat for this conjugate pair) and is reported in the results."""
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.studies.dynamics import DynamicsStudy
    from gearopt.units import ARCMIN

    pair, _ = spur
    kw = dict(positions=16, n_slices=5, speeds=3, speed_min=500.0, speed_max=2000.0, samples=32)
    aligned = DynamicsStudy(pair, 200.0, **kw).run().to_dict()
    crossed = DynamicsStudy(pair, 200.0, misalignment=Misalignment(crossing=3 * ARCMIN), **kw).run().to_dict()
    assert crossed["model"]["misalignment"]["crossing_arcmin"] == pytest.approx(3.0)
    te_a = np.array(aligned["cases"][0]["static"]["te_loaded_arcsec"])
    te_c = np.array(crossed["cases"][0]["static"]["te_loaded_arcsec"])
    assert np.max(np.abs(te_c - te_a)) > 1.0  # arcsec


def test_no_mesh_damping_force_where_the_teeth_separate():
    """Equation (2): the mesh damping acts only while a flank pair is in contact (h'(s) gates it). At a
    speed with contact loss, where the drive flanks are apart by more than 100 eps (and the back flanks
    not yet closed) the mesh force is zero to 1e-4 W, although the mesh coordinate moves fast there
    (an ungated c_m x' would be several percent of W)."""
    zeta, E, bl, sm = 0.05, 12e-6, 100e-6, 1e-3
    k0, eps_k = K0, 0.15
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=zeta, backlash=bl)
    gd = GearDynamics(tr, MeshExcitation([k0, k0 * eps_k], [0.0], [0.0, E], [0.0], W), Z1, smoothing=sm, samples=256)
    s = gd.solve(0.93 * n_res())
    assert s.converged and s.contact_loss()
    eps = sm * W / k0
    apart = (s.gap < -100 * eps) & (s.gap > -bl + 100 * eps)
    assert apart.sum() >= 10
    xdot = np.gradient(s.x, s.phi) * s.omega_m  # m/s (periodic samples: the ends are one-sided, fine here)
    c_m = 2 * zeta * math.sqrt(k0 * M_E)
    assert np.max(np.abs(c_m * xdot[apart])) > 0.01 * W  # what an ungated damper would carry
    assert np.max(np.abs(s.force[apart])) < 1e-4 * W


def test_upward_sweep_jumps_to_the_other_branch_at_the_fold():
    """Sweeping up only: where the lower branch ends at its fold the sweep jumps (the motion integrated
    on from the last steady state) and continues on the other branch, marked ``jumped``: every speed
    converges (without the jump the branch is lost from there on), and the jumped solution is the
    downward sweep's steady state there, well above the lower branch's last K_v."""
    tr = DriveTrain(J_pinion=J1, J_gear=J2, l_pinion=L1, l_gear=L2, zeta=0.03, backlash=1e-3)
    gd = GearDynamics(tr, MeshExcitation([K0, 0.0], [0.0], [0.0, 8e-6], [0.0], W), Z1)
    v = np.linspace(0.4, 1.2, 33) * n_res()
    up = gd.sweep(v, both=False).up
    both = gd.sweep(v)
    assert all(s.converged for s in up)
    jumped = [i for i, s in enumerate(up) if s.jumped]
    assert jumped
    for i in jumped:
        assert up[i].force.max() == pytest.approx(both.down[i].force.max(), rel=1e-6)
        assert up[i].force.max() > 1.2 * up[i - 1].force.max()  # up onto the resonant branch (softening)


def test_unconverged_and_jumped_speeds_are_reported_and_plotted(spur):
    """A speed without a steady state is never a silent number: K_v null, listed, counted in the summary,
    marked on dynamics_factor.png (a triangle at the bottom, with the count in the legend); a jump of
    the continuation is circled."""
    import matplotlib.pyplot as plt  # (conftest: the Agg backend)

    from gearopt.plot.dynamics import plot_dynamic_factor
    from gearopt.studies.dynamics import DynamicsStudy
    from gearopt.summary import dynamics_summary

    pair, _ = spur
    d = DynamicsStudy(pair, 200.0, positions=16, n_slices=5, speeds=4, speed_min=500.0, speed_max=20000.0,
                      samples=32).run().to_dict()
    c = d["cases"][0]
    assert c["not_converged_speeds_rpm"] == [] and len(c["up"]["jumped"]) == 4
    c["up"]["converged"][1], c["up"]["K_v"][1] = False, None
    c["not_converged_speeds_rpm"] = [c["speeds_rpm"][1]]
    c["up"]["jumped"][2] = True
    keys = {k.key: k.value for k in dynamics_summary(d)}
    assert keys["not_converged[as_given]"] == 1
    fig, ax = plt.subplots()
    plot_dynamic_factor(d, ax=ax)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("no steady state found (1 speed)" in t for t in labels)
    assert any("jumped" in t for t in labels)
    plt.close(fig)
