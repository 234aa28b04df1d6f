"""Micro-geometry optimisation under load (gearopt.synthesis.loaded, docs/loaded_synthesis.md):
the separations' AD sensitivities against finite differences of the exact slices, the smoothed
contact NLP against the exact loaded TCA (QP), an optimum checked by the exact loaded TCA alone
(its constraints, and no better design within a micron of it), infeasible requests and bad input."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from gearopt.errors import ArgumentError, OptionError
from gearopt.gears import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.meshing.misalignment import Misalignment
from gearopt.synthesis.loaded import EDGE_TOL, LoadedMicroOptimizer
from gearopt.synthesis.loaded.layout import nlp_layout
from gearopt.synthesis.loaded.trust_region import LocalModel
from gearopt.units import ARCMIN, RAD_TO_ARCSEC

FREE = {"pinion.C_alpha": (0.0, 0.04), "pinion.C_beta": (0.0, 0.04), "pinion.C_alpha_a": (0.0, 0.04),
        "pinion.C_alpha_f": (0.0, 0.04)}


def drive(**mg):
    mg = {"C_alpha": 0.005, "C_beta": 0.010, "d_Ca": 64.0, "d_Cf": 58.5, **mg}
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(**mg)), Gear(z=40, m_n=3.0, b=20.0))


def optimizer(**kw):
    opts = dict(torques=[100.0, 250.0], cases=[Misalignment(), Misalignment(crossing=2 * ARCMIN)], n_positions=16,
                n_verify=32, n_slices=11)
    opts.update(kw)
    return LoadedMicroOptimizer(drive(), FREE, **opts)


def exact_separations(opt, theta, cases=None):
    """Per case (the indices ``cases`` of ``opt.cases``, default all): the exact slices of the design
    ``theta`` [mm] (:meth:`LTCA.slices`, nothing of the linearisation) and every active slice's absolute
    separation ``-te r_b2 cos(beta_b)`` [mm] (zero where inactive), for central differences of the
    separations."""
    p1, p2 = opt.params(theta)
    lever = opt.pair.gear.r_b * opt.ltca.cos_bb
    out = []
    for c in range(len(opt.cases)) if cases is None else cases:
        S = opt.ltca.slices(opt.phi1, p1, p2, opt.cases[c])
        out.append(SimpleNamespace(slices=S, a=np.where(S.active, -S.te * lever, 0.0)))
    return out


@pytest.fixture(scope="module")
def opt():
    return optimizer()


#: The loop's start [mm] for :func:`design`: 3 um or more off the optimum in every amount (its merit 97.1
#: against the optimum's 74.2 arcsec, 2026-11-29), from which the loop reaches the optimum of the drive's
#: own start design (to 0.01 um) in 11.6 s of CPU instead of 21.9 s; the "before" design stays the drive's
#: own. (The loop from the drive's own start design: problems/microgeometry_loaded.toml's scene.)
DESIGN_START = np.array([37.0, 26.0, 4.0, 10.0]) * 1e-3


@pytest.fixture(scope="module")
def design(opt):
    return opt.solve(start=DESIGN_START)


@pytest.fixture(scope="module")
def sens(opt, design):
    return opt.sensitivities(design, held=False)  # the NLP's own derivatives (data held at the design)


@pytest.mark.slow
def test_separation_sensitivities_match_finite_differences(opt):
    """J = d a / d theta (implicit function theorem by AD) against central differences of the exact
    slices of the modified flanks, on flank and tip-edge slices of both cases; and so the radius of
    every flank slice's point on each member (Jr, which moves the edge weight's tip band). The slices
    are fixed to the tooth (docs/ltca.md section 1); compared on the slices on the flanks (a partner
    past a flank boundary has its gap interpolated to the crossing, whose motion J leaves out)."""
    th = opt.theta0 + np.array([0.010, 0.005, 0.012, 0.008])
    lin = opt.linearise(th)
    h = 1e-4  # 0.1 um
    for j in range(th.size):
        e = np.zeros(th.size)
        e[j] = h
        lp, lm = exact_separations(opt, th + e), exact_separations(opt, th - e)
        for c in range(len(opt.cases)):
            S = lin[c].slices
            both = S.inside & lp[c].slices.inside & lm[c].slices.inside
            fd = (lp[c].a - lm[c].a) / (2 * h)
            # the TE zero moves with the design (a constant per case): compare differences between slices
            ref = np.flatnonzero(both.ravel())[0]
            d_fd = (fd - fd.ravel()[ref])[both]
            d_ad = (lin[c].J[..., j] - lin[c].J[..., j].ravel()[ref])[both]
            assert both.sum() > 100
            assert np.max(np.abs(d_ad - d_fd)) < 2e-4 * max(1.0, np.max(np.abs(d_ad)))
            if j == 2:  # the tip relief moves the pinion's tip-edge slices, the root relief the gear's
                assert np.any(both & (S.edge == 1))
            if j == 3:
                assert np.any(both & (S.edge == 2))
            # the flank slices' points move along the profile (the edge weight's tip band): their
            # radius on each member against central differences
            fl = both & (S.edge == 0) & (lp[c].slices.edge == 0) & (lm[c].slices.edge == 0)
            for mem, r in ((0, "r1"), (1, "r2")):
                rad = [np.hypot(getattr(L[c].slices, r)[..., 0], getattr(L[c].slices, r)[..., 1]) for L in (lp, lm)]
                fd_r = ((rad[0] - rad[1]) / (2 * h))[fl]
                ad_r = lin[c].Jr[..., mem, j][fl]
                assert np.max(np.abs(fd_r)) > 0.1  # mm of radius per mm of amount: the point does move
                assert np.max(np.abs(ad_r - fd_r)) < 2e-3 * np.max(np.abs(fd_r))


@pytest.mark.slow
@pytest.mark.ipopt
def test_the_smoothed_nlp_reproduces_the_exact_loaded_tca(opt):
    """At a fixed design (bounds closed on it) the NLP's loads solve the smoothed contact problem; its
    loaded TE equals the exact QP's within the smoothing's effect (1e-3 arcsec)."""
    th = opt.theta0.copy()
    cur = opt._around(th)
    nlp = cur.nlp
    lbx, ubx = opt._bounds(nlp)
    P = th.size
    lbx[:P] = ubx[:P] = th * 1e3
    r = nlp.solver(x0=cur.z0, lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg,
                      p=opt._pvec(1000.0))
    assert nlp.solver.stats()["success"]
    pred = opt._predicted(nlp, np.asarray(r["x"]).ravel())
    exact = cur.check.te_pp
    assert np.max(np.abs(pred["te_pp"] - exact)) < 1e-3
    assert exact.min() > 5.0  # a real loaded TE, not a trivial match


@pytest.mark.slow
@pytest.mark.ipopt
def test_warm_start_carries_the_multipliers_by_slice_and_reaches_the_cold_optimum(opt):
    """The trust-region rounds start IPOPT from the last NLP's multipliers: each constraint row keeps
    the multiplier of the row of the same torque, case, position and slice (0 for a row the last NLP
    did not hold), and the warm solve reaches the cold solve's optimum."""
    th = opt.theta0.copy()
    P = th.size
    p = opt._pvec(1000.0)

    def solve(cur, centre, radius, prev=None):
        nlp = cur.nlp
        lbx, ubx = opt._bounds(nlp)
        lbx[:P] = np.maximum(opt.lo, centre - radius) * 1e3
        ubx[:P] = np.minimum(opt.hi, centre + radius) * 1e3
        return opt._solve_nlp(nlp, cur.z0, lbx, ubx, p, prev)

    a = opt._around(th, 0.002)  # a narrow trust region: fewer slices held
    ra, st, _ = solve(a, th, 0.002)
    assert st["success"]
    lam_a = np.asarray(ra["lam_g"]).ravel()
    # onto itself: every row keeps its own multiplier; the design's bound multipliers are dropped
    lx, lg = opt._multipliers((a.nlp, ra), a.nlp)
    assert np.array_equal(lg, lam_a)
    assert np.all(lx[:P] == 0.0) and np.count_nonzero(lx) > 0
    # onto the NLP around the new design with every active slice: matched rows keep theirs, new rows 0
    th2 = np.clip(np.asarray(ra["x"]).ravel()[:P] * 1e-3, opt.lo, opt.hi)
    b = opt._around(th2)
    assert not b.nlp.solver_built and b.nlp.warm is None  # IPOPT is built for the NLP only when it is solved
    _, lg = opt._multipliers((a.nlp, ra), b.nlp)
    na, nb = a.nlp, b.nlp
    fb = lambda n, v: n.layout.rows.take(v, "complementarity")  # noqa: E731 - one row per slice held
    ka = dict(zip((tuple(k) for k in na.keys), fb(na, lam_a)))
    fb_b = fb(nb, lg)
    keys_b = [tuple(k) for k in nb.keys]
    assert nb.sizes["nx"] > na.sizes["nx"]  # the wider NLP holds slices the narrow one left out
    assert sum(k in ka for k in keys_b) > 0.5 * len(keys_b)
    for k, v in zip(keys_b, fb_b):
        assert v == ka.get(k, 0.0)
    # the warm solve reaches the cold solve's optimum
    cold, st_c, it_c = solve(b, th2, 0.002)
    warm, st_w, it_w = solve(b, th2, 0.002, prev=(a.nlp, ra, np.array(p, float)))
    assert st_c["success"] and st_w["success"]
    assert it_w == nb.warm.stats()["iter_count"]  # the warm solve itself converged (no cold fallback)
    assert abs(float(warm["f"]) - float(cold["f"])) < 1e-6 * abs(float(cold["f"]))
    assert np.max(np.abs(np.asarray(warm["x"])[:P] - np.asarray(cold["x"])[:P])) < 1e-3  # [um]
    # positions that differ: nothing to carry
    other = dataclasses.replace(na, phi1=na.phi1 + 1e-3)
    assert opt._multipliers((other, ra), nb) is None


class _PenaltyToy(LoadedMicroOptimizer):
    """The trust-region loop (``_trust_region`` and ``solve``, unchanged) on a one-amount problem whose
    NLP is exact and solved in closed form: merit (t - 80)^2 + rho 1e-2 max(0, t - 20) [t in um]; the
    constraint t <= 20 um needs a penalty weight above 4000. Every NLP solve is recorded with its
    weight and the number of NLP positions; the verification grid finds ``refine`` positions to add
    once."""

    def __init__(self, refine=()):  # none of the drive's machinery: the loop alone
        self.free, self.lo, self.hi = ("pinion.C_alpha",), np.array([0.0]), np.array([0.1])
        self.theta0, self.cases, self.p_limit, self.te_level = np.array([0.0]), (Misalignment(),), None, None
        self.n_positions, self.n_verify, self.refine = 2, 4, list(refine)
        self.ltca = type("LTCA", (), {"mesh_cycle": staticmethod(lambda n: np.linspace(0.0, 1.0, n, endpoint=False))})
        self._has_settings, self.phi1, self.solves = False, np.zeros(2), []

    def _reduced(self):
        return self

    def _pvec(self, rho):
        return [1.0, 0.0, 1e-8, rho]

    def _bounds(self, nlp):
        return np.array([0.0]), np.array([100.0])

    def check(self, theta, phi1=None, known=None):
        t = float(theta[0]) * 1e3
        return type("Check", (), {"t": t, "te_pp": np.array([[(t - 80.0) ** 2]]), "objective": (t - 80.0) ** 2})

    def _violated_positions(self, chk, phi1):
        add, self.refine = np.array(self.refine), []
        return add

    def confirm(self, theta, n=None, refine=True, check=None):  # no loaded TCA here: no objective to confirm between positions
        return None

    def _raise_if_verification_fails(self, *checks):  # no loaded TCA here: the loop alone
        pass

    def _binding(self, theta, pred, ver):
        return ()

    def _merit(self, chk, rho=1000.0):
        return chk.objective + rho * 1e-2 * max(0.0, chk.t - 20.0)

    def _around(self, theta, radius=np.inf, rho=1000.0):
        chk = self.check(theta)
        lay = nlp_layout(P=1, nx=1, nB=0, TC=0, nw=0, n0=0, nB0=0, n_pressure=0, n_edge=0, n_torques=1, n_kinds=4)
        return LocalModel(nlp=SimpleNamespace(sizes={"nx": 1}, layout=lay), z0=theta * 1e3, check=chk,
                          merit=self._merit(chk, rho), time=0.0)

    def _solve_smoothed(self, nlp, z0, lbx, ubx, p):  # the first round: one solve of the toy, as every other
        return self._solve_nlp(nlp, z0, lbx, ubx, p)

    def _solve_nlp(self, nlp, z0, lbx, ubx, p, prev=None):
        rho = p[3]
        self.solves.append((rho, self.phi1.size))
        t = float(np.clip(max(20.0, 80.0 - rho * 1e-2 / 2), lbx[0], ubx[0]))
        return ({"x": [t], "f": self._merit(self.check([t * 1e-3]), rho)},
                {"return_status": "Solve_Succeeded", "success": True}, 1)

    def _predicted(self, nlp, zs):
        t = float(zs[0])
        return {"slack_p": np.array([[-1.0]]), "slack_e": np.array([[max(0.0, t - 20.0) * 1e-3]]),
                "te_pp": np.array([[(t - 80.0) ** 2]]), "objective": (t - 80.0) ** 2}

    def _raise_if_infeasible(self, pred, chk=None, theta=None):
        pass


def test_penalty_grows_after_two_accepted_steps_that_needed_a_slack():
    """The first accepted step whose model optimum needs a slack keeps the weight; the second in a
    row (its violation not tenfold smaller) raises it tenfold for the next round, with no re-solve
    of the same NLP; the loop still ends at the constrained optimum t = 20 um."""
    toy = _PenaltyToy()
    rounds = []
    theta, cur, pred, iters, status, rho, stop = toy._trust_region(np.array([0.0]), rounds)
    # rounds: [0, 25] -> 25 (violated, kept), [0, 75] -> 75 (violated again: x10 after it),
    # at 1e4 -> 30 well inside the radius (x10, the same NLP again), at 1e5 -> 20, converged
    assert [w for w, _ in toy.solves[:4]] == [1000.0, 1000.0, 10000.0, 100000.0]
    assert rounds[0]["accepted"] is True and rounds[1]["accepted"] is True
    assert "rho_next" not in rounds[0] and rounds[1]["rho_next"] == 1e4
    assert [r["rho"] for r in rounds] == [1e3, 1e3, 1e4, 1e5, 1e5]
    assert rounds[2]["accepted"] == "penalty x10 (100000)"
    assert rho == 1e5 and theta[0] == pytest.approx(0.020, abs=1e-9)
    assert rounds[-1]["accepted"] == "converged" and len(rounds) == 5
    assert stop == "converged"


class _MisleadingToy(_PenaltyToy):
    """The loop on a model that always predicts a decrease at the upper end of the trust region
    (model value -1), where the true merit is worse: no step is ever accepted."""

    def _solve_nlp(self, nlp, z0, lbx, ubx, p, prev=None):
        self.solves.append((p[3], self.phi1.size))
        return ({"x": [float(ubx[0])], "f": -1.0}, {"return_status": "Solve_Succeeded", "success": True}, 1)

    def _predicted(self, nlp, zs):
        return {"slack_p": np.array([[-1.0]]), "slack_e": np.array([[0.0]]), "te_pp": np.array([[0.0]]),
                "objective": 0.0}


def test_the_loop_reports_a_stop_on_its_trust_radius():
    """No step accepted: the radius shrinks below THETA_TOL and the loop says so ("trust radius", not
    "converged"), as the design it returns (the start) was never shown stationary."""
    toy = _MisleadingToy()
    toy.check = lambda theta, phi1=None, known=None: type(
        "Check", (), {"t": float(theta[0]) * 1e3, "te_pp": np.array([[0.0]]),
                      "objective": (float(theta[0]) * 1e3 - 20.0) ** 2})
    rounds = []
    theta, cur, pred, iters, status, rho, stop = toy._trust_region(np.array([0.020]), rounds)
    assert stop == "trust radius" and theta[0] == pytest.approx(0.020)
    assert all(r["accepted"] is False for r in rounds) and len(rounds) > 3


def test_a_refined_grid_goes_on_with_the_last_penalty_weight():
    """Where the verification grid adds positions to the NLP's, the loop goes on from the optimum
    with the penalty weight the last pass ended with (its merit too), not from the first weight."""
    toy = _PenaltyToy(refine=[0.125])
    d = LoadedMicroOptimizer.solve(toy)
    assert toy.phi1.size == 3 and d.rho == 1e5
    second = [w for w, n in toy.solves if n == 3]
    assert second and all(w == 1e5 for w in second)
    assert d.theta["pinion.C_alpha"] == pytest.approx(0.020, abs=1e-9)
    assert d.theta_um() == {"pinion.C_alpha": pytest.approx(20.0, abs=1e-6)}  # 0.020 mm written in um
    # the loop's first merit is taken with the weight it starts from: at t = 30 um, 50^2 + 1e4 1e-2 10
    rounds = []
    toy._trust_region(np.array([0.030]), rounds, rho=1e4)
    assert rounds[0]["merit"] == pytest.approx(2500.0 + 1000.0)


@pytest.mark.slow
@pytest.mark.ipopt
def test_optimum_is_verified_by_the_exact_loaded_tca(opt, design):
    d = design
    # the exact loaded TCA (nothing of the NLP) agrees with the NLP's prediction
    assert d.error["te_pp"] < 0.01
    # better than the start, and edge loading gone: no tip edge, face end or slice at a tip carries
    # more than EDGE_TOL (0.01 %) of the load, on the NLP's grid and on the finer verification grid
    assert d.verified.objective < 0.8 * opt.check(opt.theta0, d.verified.sweeps[0].slices.phi1).objective
    assert np.all(d.verified.edge_load <= EDGE_TOL) and np.all(d.after.edge_load <= EDGE_TOL)
    assert np.all(d.verified.edge_share <= 2 * EDGE_TOL)
    assert np.all(d.before.edge_share > 0.05)  # the start design loads its edges at every torque and case
    # no better feasible design within a micron of the optimum (coordinate probes, exact loaded TCA)
    th = np.array(list(d.theta.values()))
    best = opt._merit(d.verified)
    for j in range(th.size):
        for step in (-1e-3, 1e-3):
            t = th.copy()
            t[j] = np.clip(t[j] + step, opt.lo[j], opt.hi[j])
            if t[j] == th[j]:
                continue
            assert opt._merit(opt.check(t)) > best - 0.05
    # the verification grid (finer than the NLP's) shows the same improvement
    assert d.after.objective < 0.8 * d.before.objective
    # the loop did the work: its start (DESIGN_START) lies well above the optimum
    assert opt._merit(opt.check(DESIGN_START)) > best + 5.0


@pytest.mark.slow
@pytest.mark.ipopt
def test_sensitivities_of_the_optimum_match_finite_differences(opt, sens):
    """d(optimum)/d(torque) and d(optimum)/d(misalignment) by AD (the perturbed KKT system of the NLP
    at the optimum, the envelope theorem for the objective) against central differences of the same
    NLP solved again at perturbed parameters: every torque, every misalignment kind. (The angles by plain
    central differences within 0.1 %: at this optimum they lie within 1.2e-8 of AD, 2026-11-29; without
    the unloaded-TE target the optimum does not curve in them as with it.)"""
    assert_sensitivities_match_finite_differences(opt, sens, richardson=False)


def assert_sensitivities_match_finite_differences(opt, S, richardson=True):
    """``richardson``: the angles' differences extrapolated by Richardson and compared within 1 % (the
    optimum with the unloaded-TE target curves in the crossing), else plain and within 0.1 % as the rest."""
    from gearopt.meshing.misalignment import Misalignment as Mis

    assert S["model_step"] < 1e-4  # the NLP's optimum is the design (converged)
    nlp = S["nlp"]
    lbx, ubx = S["bounds"]
    P, T = len(opt.free), opt.torques.size
    # the re-solves to IPOPT's tolerance 1e-12 (at the NLP's 1e-9 they land 1-2e-8 mm off since every
    # compliance part has its deflection unknowns, a noise of 2e-8 / 1e-5 over the step)
    import casadi as ca

    # each re-solve starts from the optimum and its multipliers (IPOPT's warm start, the optimiser's own
    # options): the perturbed optimum lies within the step of it
    from gearopt.synthesis.loaded.constants import WARM_OPTS

    solver = ca.nlpsol("fd_check", "ipopt", nlp.problem,
                       {**nlp.opts, **WARM_OPTS, "ipopt.bound_relax_factor": 0.0, "ipopt.tol": 1e-12})

    def solve(p):
        r = solver(x0=S["z"], lam_x0=S["lam_x"], lam_g0=S["lam_g"], lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg, p=p)
        assert solver.stats()["success"]
        return np.asarray(r["x"]).ravel()[:P] * 1e-3, float(r["f"])

    kinds = Mis.names()
    moved = 0
    for j in range(T + len(kinds)):
        angle = j >= T and Mis.meta(kinds[j - T])["unit"] == "angle"
        # small steps: the optimum is smooth in the parameters only until the active set of its max/min
        # (the TE's peak positions) changes, within about 0.01 arcmin of crossing here (with each tip
        # edge on its own levers, 1e-4 mm of axial shift and 1e-4 of the top torque (unloaded-TE
        # target) moved the differences by 0.5 % and 0.4 %: 1e-5 held them within 0.01 %). The angles:
        # with the unloaded-TE target the optimum curves strongly in the crossing (central differences
        # at 1e-3, 5e-4, 2e-4 arcmin 12, 3.2, 0.5 % off, falling as h^2 onto AD, and below that the
        # re-solved NLPs' own accuracy): Richardson's extrapolation of h and h/2, within 1 % (0.27 and 0.57 % in two runs)
        # (the lengths, re-solved to 1e-12, 2026-11-28: the axial shift's objective derivative, 7.3e-4
        # arcsec per mm, within 3.6e-5 at 1e-4 mm and 2.6e-3 at 1e-5 mm, the re-solves' noise)
        # (Richardson's angles from 2.5e-4 arcmin, was 1e-3: with the bodies' coupling between the pairs in
        # mesh the unloaded-TE target's optimum curves more in the angles; re-solved at 2e-3 ... 1.25e-4
        # arcmin the central differences fall onto AD as h^2 (crossing 65.6, 48.7, 21.8, 6.7, 1.8 % off),
        # Richardson from 1e-3 / 5e-4 5.3 % off, from 2.5e-4 / 1.25e-4 0.06 %; intersecting 1.3 %, 0.01 %)
        h = 1e-5 if j < T else ((2.5e-4 if richardson else 1e-3) * ARCMIN if angle else 1e-4)
        scale = opt.torques[j] if j < T else 1.0

        def central(step):
            pp, pm = S["p"].copy(), S["p"].copy()
            pp[4 + j] += step
            pm[4 + j] -= step
            (tp, fp), (tm, fm) = solve(pp), solve(pm)
            return (tp - tm) / (2 * step) / scale, (fp - fm) / (2 * step) / scale

        fd_t, fd_f = central(h)
        tol = 1e-3
        if angle and richardson:
            half_t, half_f = central(h / 2)
            fd_t, fd_f, tol = (4 * half_t - fd_t) / 3, (4 * half_f - fd_f) / 3, 1e-2
        ad_t = S["d_theta_d_torque"][:, j] if j < T else S["d_theta_d_mis"][:, j - T]
        ad_f = S["d_objective_d_torque"][j] if j < T else S["d_objective_d_mis"][j - T]
        assert ad_f == pytest.approx(fd_f, rel=tol, abs=1e-6 * max(1.0, abs(fd_f)))
        # (+ the re-solved NLPs' design accuracy, 1e-12 mm, over the step: the axial shift moves this
        # spur optimum by 2e-6 mm per mm, where differences of 1e-5 mm are at that accuracy)
        assert np.max(np.abs(ad_t - fd_t)) <= tol * np.max(np.abs(fd_t)) + 1e-12 / h / scale + 1e-9
        moved += np.max(np.abs(fd_t)) > 1e-6
    assert moved >= 3  # the optimal design does move with the torques and misalignments


@pytest.mark.slow
@pytest.mark.ipopt
def test_sensitivities_use_the_slacks_of_a_solution_inside_its_bounds(sens):
    """The perturbed KKT system takes each inequality's slack from the solution: IPOPT must not relax
    the bounds (by default it moves each out by 1e-8, the edge rows' own scale MU / margin, and
    returned 12 rows and 7 variables beyond their bounds, whose slacks then came out with the wrong
    sign: a design derivative 0.2 % off in one test order)."""
    import casadi as ca

    S = sens
    nlp, z = S["nlp"], S["z"]
    pr = nlp.problem
    g = np.asarray(ca.Function("g", [pr["x"], pr["p"]], [pr["g"]])(z, S["p"])).ravel()
    ineq = nlp.lbg < nlp.ubg
    assert ineq.sum() > 100
    assert np.all(g[ineq] <= nlp.ubg[ineq]) and np.all(g[ineq] >= nlp.lbg[ineq])
    lbx, ubx = S["bounds"]
    assert np.all(z >= lbx) and np.all(z <= ubx)


@pytest.mark.slow
@pytest.mark.ipopt
def test_sensitivities_do_not_depend_on_how_tightly_the_nlp_is_solved(opt, design, sens, monkeypatch):
    """The derivatives are the limit of IPOPT's barrier (mu -> 0) at the active set that the central
    path's tangent identifies, so the NLP behind them solved to a tolerance of 1e-12 instead of 1e-9
    gives the same ones, within 0.1 % of each column's largest (the perturbed KKT system at IPOPT's
    final barrier point, lam^2 / mu, counted a thousand open edge slices as nearly active, with
    multipliers that fall with the barrier: 1-100 % off at 1e-12). Every inequality and bound is
    told active or inactive, none degenerate, the same at both tolerances."""
    monkeypatch.setattr(opt, "_extra_opts", {"ipopt.tol": 1e-12}, raising=False)
    tight = opt.sensitivities(design, held=False)
    assert sens["degenerate"] == tight["degenerate"] == 0
    assert sens["active"] == tight["active"] > opt.torques.size
    for k in ("d_theta_d_torque", "d_theta_d_mis"):
        a, b = sens[k], tight[k]
        for j in range(b.shape[1]):
            assert np.max(np.abs(a[:, j] - b[:, j])) <= 1e-3 * np.max(np.abs(b[:, j])) + 1e-12
    for k in ("d_objective_d_torque", "d_objective_d_mis"):
        assert sens[k] == pytest.approx(tight[k], rel=1e-3, abs=1e-9)


@pytest.mark.parametrize("kw, param", [
    (dict(te_level=-1e-5), "te_level"),
    (dict(te_level=700.0 / RAD_TO_ARCSEC), "te_level"),
    (dict(te_level=True), "te_level"),
    (dict(te_level=4e-5, te_weight=0.0), "te_weight"),
    (dict(te_level=4e-5, te_weight=float("nan")), "te_weight"),
    (dict(free={"pinion.a_c": (0.0, 0.2)}), "free.pinion.a_c"),  # above 0.05 1/mm
    (dict(free={"pinion.a_pl": (-0.001, 0.001)}), "free.pinion.a_pl"),
    (dict(harmonics=[]), "harmonics"),
    (dict(harmonics=[1.0, -1.0]), "harmonics"),
    (dict(harmonics=[1.0] * 8), "harmonics"),  # 2 * 8 + 1 > 16 positions
    (dict(free={"pinion.C_gamma": (0, 0.01)}), "free.pinion.C_gamma"),
    (dict(free={"pinion.C_beta_I": (0, 0.01)}), "free.pinion.C_beta_I"),  # no b_I: no end relief amount
    (dict(free={"pinion.C_alpha": (0.02, 0.01)}), "free.pinion.C_alpha"),
    (dict(free={"pinion.C_alpha": (-0.01, 0.01)}), "free.pinion.C_alpha"),
    (dict(free={"pinion.C_alpha": (0.0, 0.001)}), "free.pinion.C_alpha"),  # start 5 um outside
    (dict(p_limit=-5.0), "p_limit"),
    (dict(edge_margin=0.0), "edge_margin"),
    (dict(n_positions=4), "n_positions"),
    (dict(torques=[200.0, 100.0]), "torque"),
    (dict(weights=np.ones((3, 2))), "weights"),
])
def test_bad_input_names_the_parameter(kw, param):
    args = dict(torques=[100.0], n_positions=16, n_slices=11)
    free = kw.pop("free", FREE)
    args.update(kw)
    with pytest.raises((OptionError, ArgumentError)) as e:
        LoadedMicroOptimizer(drive(), free, **args)
    assert e.value.param == param


@pytest.mark.ipopt
def test_central_path_indicators_tell_active_inactive_and_degenerate_constraints():
    """d log s / d log mu on IPOPT's central path, on a separable problem whose answer is known:
    min sum (x_i - c_i)^2 with x_0 <= 0.5 (active, multiplier 1), x_1 <= 5 (inactive), x_2 <= 2 at
    c_2 = 2 (degenerate: active with a zero multiplier, slack and multiplier both sqrt(mu / 2)), the
    same three kinds as bounds x >= 0 (c = -1, 3, 0), and an equality row. Rows scaled by 1e-8 (the
    loaded NLP's edge rows) tell the same: the indicator is scale-free."""
    import casadi as ca

    from gearopt.synthesis.loaded import central_path_indicators

    c = np.array([1.0, 0.0, 2.0, -1.0, 3.0, 0.0, 0.7])
    for scale in (1.0, 1e-8):
        x = ca.MX.sym("x", 7)
        f = ca.sumsqr(x - c)
        g = ca.vertcat(scale * x[0], scale * x[1], scale * x[2], x[6] - 0.7 * 2.0)
        lbg = np.array([-np.inf, -np.inf, -np.inf, 0.0])
        ubg = np.array([0.5, 5.0, 2.0, 0.0]) * np.array([scale, scale, scale, 1.0])
        lbx = np.array([-np.inf] * 3 + [0.0] * 3 + [-np.inf])
        ubx = np.full(7, np.inf)
        solver = ca.nlpsol("ind", "ipopt", {"x": x, "f": f, "g": g},
                           {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-10,
                            "ipopt.bound_relax_factor": 0.0})
        r = solver(x0=np.ones(7), lbg=lbg, ubg=ubg, lbx=lbx, ubx=ubx)
        assert solver.stats()["success"]
        lam = ca.MX.sym("lam", 4)
        L = f + ca.dot(lam, g)
        H, J, gv = ca.Function("kkt", [x, lam], [ca.hessian(L, x)[0], ca.jacobian(g, x), g])(r["x"], r["lam_g"])
        to_sp = lambda m: np.asarray(ca.DM(m).full())  # noqa: E731
        ind_g, ind_x = central_path_indicators(to_sp(H), to_sp(J), lbg, ubg, np.asarray(gv).ravel(),
                                               np.asarray(r["lam_g"]).ravel(), lbx, ubx,
                                               np.asarray(r["x"]).ravel(), np.asarray(r["lam_x"]).ravel())
        assert ind_g[0] == pytest.approx(1.0, abs=0.05)  # active
        assert abs(ind_g[1]) < 0.05  # inactive
        assert ind_g[2] == pytest.approx(0.5, abs=0.05)  # degenerate
        assert np.isnan(ind_g[3])  # an equality row
        assert ind_x[3] == pytest.approx(1.0, abs=0.05) and abs(ind_x[4]) < 0.05
        assert ind_x[5] == pytest.approx(0.5, abs=0.05)
        assert np.isnan(ind_x[[0, 1, 2, 6]]).all()  # no finite bound
