"""The loaded micro-geometry optimiser's speed (issue 43, docs/benchmarks.md "Loaded optimiser"): a
refined grid's first NLP starts from the last pass's multipliers, carried by position, and the
trust-region loop hands each pass's final solve to the next; the linearisation's sensitivities run
compiled once their library is cached."""

from __future__ import annotations

import copy
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gearopt import compiled
from gearopt.gears import Gear, GearPair
from gearopt.meshing.misalignment import Misalignment
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.synthesis.loaded import LoadedMicroOptimizer
from gearopt.synthesis.loaded.constants import MU
from gearopt.synthesis.loaded.layout import nlp_layout
from gearopt.synthesis.loaded.trust_region import LocalModel

FREE = {"pinion.C_alpha": (0.0, 0.04), "pinion.C_beta": (0.0, 0.04)}


@pytest.fixture(scope="module")
def small():
    """A small duty cycle (one torque, the aligned drive, 8 positions, 7 slices)."""
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_alpha=0.005, C_beta=0.010)),
                    Gear(z=40, m_n=3.0, b=20.0))
    return LoadedMicroOptimizer(pair, FREE, torques=[200.0], n_positions=8, n_verify=16, n_slices=7)


def _solve(opt, cur, theta, radius, prev=None):
    nlp = cur.nlp
    lbx, ubx = opt._bounds(nlp)
    th = nlp.layout.unknowns["theta"]
    lbx[th] = np.maximum(opt.lo, theta - radius) * 1e3
    ubx[th] = np.minimum(opt.hi, theta + radius) * 1e3
    return opt._solve_nlp(nlp, cur.z0, lbx, ubx, opt._pvec(1000.0), prev)


@pytest.mark.slow
@pytest.mark.ipopt
def test_multipliers_carry_onto_a_refined_grid_by_position(small):
    """The NLP of a grid with one position more (a refinement) takes each row's multiplier from the row
    of the same torque, case, position (by its angle, not its index) and slice; the new position's rows
    start at 0; a grid that does not hold the earlier one gets nothing."""
    opt = small
    th = opt.theta0.copy()
    grid = opt.ltca.mesh_cycle(opt.n_positions)
    opt.phi1 = grid
    a = opt._around(th, 0.004)
    ra, st, _ = _solve(opt, a, th, 0.004)
    assert st["success"]
    finer = np.sort(np.append(grid, 0.5 * (grid[1] + grid[2])))  # a position between the 2nd and 3rd
    opt.phi1 = finer
    b = opt._around(th, 0.004)
    lam = opt._multipliers((a.nlp, ra), b.nlp)
    assert lam is not None
    lg = lam[1]
    na, nb = a.nlp, b.nlp
    rows_a = na.layout.rows.take(np.asarray(ra["lam_g"]).ravel(), "complementarity")
    rows_b = nb.layout.rows.take(lg, "complementarity")
    key = lambda n, k, phi: (int(k[0]), int(k[1]), float(phi[k[2]]), int(k[3]))  # noqa: E731
    old = {key(na, k, grid): v for k, v in zip(na.keys, rows_a)}
    new_pos = int(np.flatnonzero(~np.isin(finer, grid))[0])
    hits = 0
    for k, v in zip(nb.keys, rows_b):
        if k[2] == new_pos:
            assert v == 0.0
        else:
            assert v == old.get(key(nb, k, finer), 0.0)
            hits += key(nb, k, finer) in old
    assert hits > 0.5 * nb.sizes["nx"] and np.count_nonzero(rows_b) > 0
    # positions after the new one moved up by one index: their rows still found their own multipliers
    later = [i for i, k in enumerate(nb.keys) if k[2] > new_pos and key(nb, k, finer) in old]
    assert later and all(rows_b[i] == old[key(nb, nb.keys[i], finer)] for i in later)
    # the warm solve on the refined grid converges (no cold fallback) to the cold solve's optimum
    cold, st_c, _ = _solve(opt, b, th, 0.004)
    warm, st_w, it_w = _solve(opt, b, th, 0.004, prev=(na, ra, np.array(opt._pvec(1000.0), float)))
    assert st_c["success"] and st_w["success"] and it_w == nb.warm.stats()["iter_count"]
    assert abs(float(warm["f"]) - float(cold["f"])) < 1e-7 * abs(float(cold["f"]))
    P = len(opt.free)
    assert np.max(np.abs(np.asarray(warm["x"])[:P] - np.asarray(cold["x"])[:P])) < 1e-5  # [um]
    # a grid that does not hold every earlier position: nothing carried
    opt.phi1 = grid + 1e-3
    c = opt._around(th, 0.004)
    assert opt._multipliers((na, ra), c.nlp) is None
    opt.phi1 = grid


@pytest.mark.slow
def test_the_sensitivities_switch_to_the_compiled_library_once_it_is_cached(small, monkeypatch):
    """With ``jit``, a linearisation's sensitivities run interpreted while their library is not in the
    disk cache, and the compiled library's maps from the first linearisation after it is (gearopt.compiled
    stood in by the graph itself: which maps run is what is tested; compiled and interpreted columns agree
    to round-off, tests/test_tca_jit.py); without ``jit``, interpreted whatever the cache holds."""
    small.phi1 = small.ltca.mesh_cycle(small.n_positions)
    th = small.theta0.copy()
    cache = {}
    monkeypatch.setattr(compiled, "cached_function", lambda f: cache.get(f.name()))
    monkeypatch.setattr(compiled, "select", lambda f, jit, n: cache.get(f.name()) if jit else None)
    monkeypatch.setattr(compiled, "keyed_library", lambda name, bases, tag: cache.get(name))  # (found before building)
    monkeypatch.setattr(small, "_sens_maps", {})
    monkeypatch.setattr(small, "_lin_memo", {})  # (none kept by an earlier test: each call here linearises)
    monkeypatch.setattr(small, "jit", True)
    miss = small.linearise(th)  # a cache miss: interpreted
    kinds = sorted(small._sens_maps)
    assert kinds and not any(m.compiled for m in small._sens_maps.values())
    for k in kinds:  # the libraries arrive in the cache
        cache[small._sensitivity(k).name()] = small._sensitivity(k)
    hit = small.linearise(th)
    assert all(small._sens_maps[k].compiled for k in kinds)
    monkeypatch.setattr(small, "jit", False)
    monkeypatch.setattr(small, "_sens_maps", {})
    off = small.linearise(th)
    assert not any(m.compiled for m in small._sens_maps.values())
    for a, b, c in zip(miss, hit, off):
        for k in ("J", "Jm", "Jr", "Jk"):
            assert np.array_equal(getattr(a, k), getattr(c, k)) and np.array_equal(getattr(b, k), getattr(c, k))
        assert np.count_nonzero(c.J) > 0


def test_a_design_linearised_again_at_the_same_positions_is_the_kept_linearisation(small):
    """A case linearised again at the same design, positions and misalignment (a Pareto point's first
    round is the last point's final design, the KKT sensitivities the loop's last round), by the optimiser
    or a copy, is the kept linearisation and loaded TCA, which a fresh linearisation gives bit for bit;
    another design, grid or case is linearised anew."""
    opt = copy.copy(small)
    opt.phi1 = opt.ltca.mesh_cycle(opt.n_positions)
    # (interpreted sensitivities whatever the disk cache holds: under jit a linearisation is kept only once
    # they run compiled, whose numbers every later one then gives)
    opt.jit, opt._sens_maps, opt._lin_memo, opt._lin_sweeps = False, {}, {}, {}
    th = opt.theta0 + np.array([0.002, -0.001])
    (a,) = opt.linearise(th)
    (sa,) = opt.exact_sweeps([a])
    twin = copy.copy(opt)  # shares the kept ones (a Pareto point's optimiser)
    (b,) = twin.linearise(th.copy())
    assert b is a and twin.exact_sweeps([b])[0] is sa
    fresh = copy.copy(opt)
    fresh._lin_memo, fresh._lin_sweeps = {}, {}
    (c,) = fresh.linearise(th)
    (sc,) = fresh.exact_sweeps([c])
    assert c is not a
    for k in ("a", "J", "Jm", "Jr", "Jk", "lam", "da"):
        assert np.array_equal(getattr(a, k), getattr(c, k)), k
    assert np.array_equal(a.slices.te, c.slices.te, equal_nan=True) and np.array_equal(a.structure.Cs, c.structure.Cs)
    for r, q in zip(sa.results, sc.results):
        assert np.array_equal(r.load, q.load) and np.array_equal(r.te_loaded, q.te_loaded)
    # another grid, design or case: not the kept one
    opt.phi1 = opt.ltca.mesh_cycle(opt.n_positions + 1)
    (d,) = opt.linearise(th)
    assert d.slices.phi1.size == opt.n_positions + 1
    opt.phi1 = fresh.phi1
    (e,) = opt.linearise(th + np.array([0.001, 0.0]))
    assert e is not a and not np.array_equal(e.a, a.a)
    (f,) = opt.shifted(Misalignment(crossing=1e-4)).linearise(th)
    assert f is not a and f.mis.crossing == 1e-4 and not np.array_equal(f.a, a.a)
    assert opt.linearise(th)[0] is a


def test_a_refined_grid_takes_the_kept_gradients_of_the_slices_it_shares(small, monkeypatch):
    """A design linearised on a grid with one position more than a kept linearisation of it (a refined
    grid's first round) evaluates the sensitivities of the new position's slices only; its linearisation
    is a fresh one's bit for bit."""
    opt = copy.copy(small)
    opt.jit, opt._sens_maps, opt._lin_memo, opt._lin_sweeps = False, {}, {}, {}
    grid = opt.ltca.mesh_cycle(opt.n_positions)
    th = opt.theta0 + np.array([0.001, 0.002])
    opt.phi1 = grid
    opt.linearise(th)
    finer = np.sort(np.append(grid, 0.5 * (grid[2] + grid[3])))
    fresh = copy.copy(opt)
    fresh._lin_memo, fresh._lin_sweeps = {}, {}
    fresh.phi1 = finer
    (c,) = fresh.linearise(th)
    cols = []
    run = type(opt).separation_gradients
    monkeypatch.setattr(type(opt), "separation_gradients",
                        lambda self, kind, wv, prm: (cols.append(wv.shape[1]), run(self, kind, wv, prm))[1])
    opt.phi1 = finer
    (b,) = opt.linearise(th)
    new = int(np.flatnonzero(~np.isin(finer, grid))[0])
    assert 0 < sum(cols) == int(b.slices.active[:, new].sum())  # the new position's active slices alone
    for k in ("a", "J", "Jm", "Jr", "Jk", "lam", "da"):
        assert np.array_equal(getattr(b, k), getattr(c, k)), k
    assert np.count_nonzero(b.J[:, new]) > 0 and np.count_nonzero(b.J) > 2 * np.count_nonzero(b.J[:, new])


class _Toy(LoadedMicroOptimizer):
    """The trust-region loop and ``solve`` (unchanged) on a one-amount problem solved in closed form
    (merit (t - 30)^2 [t in um]); the verification adds one position once. Records every NLP solve's
    ``prev``."""

    def __init__(self):  # none of the drive's machinery: the loop alone
        self.free, self.lo, self.hi = ("pinion.C_alpha",), np.array([0.0]), np.array([0.1])
        self.theta0, self.cases, self.p_limit, self.te_level = np.array([0.0]), (None,), None, None
        self.n_positions, self.n_verify, self.refine = 2, 4, [0.25]
        self.ltca = SimpleNamespace(mesh_cycle=lambda n: np.linspace(0.0, 1.0, n, endpoint=False))
        self._has_settings, self.phi1, self.solves, self.last_solve = False, np.zeros(2), [], None

    def _reduced(self):
        return self

    def _pvec(self, rho):
        return [1.0, 0.0, MU, rho]

    def _bounds(self, nlp):
        return np.array([0.0]), np.array([100.0])

    def check(self, theta, phi1=None, known=None):
        t = float(theta[0]) * 1e3
        return SimpleNamespace(t=t, te_pp=np.array([[(t - 30.0) ** 2]]), objective=(t - 30.0) ** 2, sweeps=())

    def _violated_positions(self, chk, phi1):
        add, self.refine = np.array(self.refine), []
        return add

    def confirm(self, theta, n=None, refine=True, check=None):  # no loaded TCA here: no objective to confirm between positions
        return None

    def _raise_if_verification_fails(self, *checks):
        pass

    def _binding(self, theta, pred, ver):
        return ()

    def _merit(self, chk, rho=1000.0):
        return chk.objective

    def _around(self, theta, radius=np.inf, rho=1000.0):
        chk = self.check(theta)
        lay = nlp_layout(P=1, nx=1, nB=0, TC=0, nw=0, n0=0, nB0=0, n_pressure=0, n_edge=0, n_torques=1, n_kinds=4)
        return LocalModel(nlp=SimpleNamespace(sizes={"nx": 1}, layout=lay, phi1=self.phi1.copy()), z0=theta * 1e3,
                          check=chk, merit=self._merit(chk, rho), time=0.0)

    def _solve_smoothed(self, nlp, z0, lbx, ubx, p):  # the first round: one solve of the toy, as every other
        return self._solve_nlp(nlp, z0, lbx, ubx, p)

    def _solve_nlp(self, nlp, z0, lbx, ubx, p, prev=None):
        self.solves.append((prev, nlp.phi1.size))
        t = float(np.clip(30.0, lbx[0], ubx[0]))
        return ({"x": [t], "f": (t - 30.0) ** 2}, {"return_status": "Solve_Succeeded", "success": True}, 1)

    def _predicted(self, nlp, zs):
        t = float(zs[0])
        return {"slack_p": np.array([[-1.0]]), "slack_e": np.array([[0.0]]), "te_pp": np.array([[(t - 30.0) ** 2]]),
                "objective": (t - 30.0) ** 2}

    def _raise_if_infeasible(self, pred, chk=None, theta=None):
        pass


def test_a_refinement_starts_from_the_last_passs_final_solve():
    toy = _Toy()
    d = toy.solve()
    assert d.theta["pinion.C_alpha"] == pytest.approx(0.030, abs=1e-12)
    sizes = [s[1] for s in toy.solves]
    assert sizes[0] == 2 and sizes[-1] == 3  # two passes: the grid grew by the verification's position
    assert toy.solves[0][0] is None  # the first NLP: nothing earlier
    first_refined = sizes.index(3)
    prev, _ = toy.solves[first_refined]
    assert prev is not None and prev[0].phi1.size == 2  # the last pass's final NLP and solution
    assert prev[1]["x"] == [30.0] and toy.solves[first_refined - 1][1] == 2
    assert toy.last_solve[0].phi1.size == 3  # the refined pass's own final solve



def test_only_an_optimisations_first_round_is_solved_along_the_smoothing():
    """The first round of a first pass (no earlier NLP) from the drive's own design goes through the two
    stages of the smoothing (:meth:`NLPBuilder._solve_smoothed`); a refined pass's first round (the
    last pass's multipliers), every later round and a first round from another design do not."""

    class Rec(_Toy):
        def _solve_smoothed(self, nlp, z0, lbx, ubx, p):
            self.smoothed.append(nlp.phi1.size)
            return super()._solve_smoothed(nlp, z0, lbx, ubx, p)

    toy = Rec()
    toy.smoothed = []
    toy.solve()
    assert toy.smoothed == [2]  # the first pass's round 0 only (2 positions); the refined pass (3) warm
    assert len(toy.solves) > 2
    toy.refine = [0.25]
    toy.solve(start=[0.010])  # from another design than the drive's own (a Pareto point's start): cold
    assert toy.smoothed == [2] and len(toy.solves) > 5


def test_every_round_after_the_first_starts_from_the_last_nlps_multipliers():
    """Every round after the first is solved from the last NLP's solution and multipliers, the round after
    the trust radius doubled too (the toy's first step reaches the 25 um radius with an exact prediction:
    the radius doubles to 50 um and the next round is solved from round 0's NLP and solution)."""
    toy = _Toy()
    rounds = []
    d = toy.solve(progress=rounds.append)
    assert d.theta["pinion.C_alpha"] == pytest.approx(0.030, abs=1e-12)
    assert d.rounds[0]["radius_um"] == pytest.approx(25.0) and d.rounds[1]["radius_um"] == pytest.approx(50.0)
    assert toy.solves[0][0] is None  # the first NLP: nothing earlier
    prev = toy.solves[1][0]
    assert prev is not None and prev[1]["x"] == [25.0] and prev[3] == pytest.approx(0.025)
    assert all(s[0] is not None for s in toy.solves[1:])


@pytest.mark.slow
@pytest.mark.ipopt
def test_the_first_round_along_the_smoothing_reaches_the_cold_solves_optimum(small, monkeypatch):
    """The first round's two stages (the NLP at ``MU_START``, then at ``MU`` from that solution and its
    multipliers) end at the optimum of the plain cold solve at ``MU``: the design within 1e-6 um, the
    objective within 1e-9 relative; the first stage solves at ``MU_START`` with the monotone barrier
    (``SMOOTH_STAGE_OPTS``), the second at ``MU`` with the loop's warm start (adaptive barrier)."""
    import casadi as ca

    from gearopt.synthesis.loaded import nlp as nlp_mod
    from gearopt.synthesis.loaded.layout import param_layout

    opt = small
    th = opt.theta0.copy()
    opt.phi1 = opt.ltca.mesh_cycle(opt.n_positions)
    cur = opt._around(th, 0.008)
    cold, st_c, it_c = _solve(opt, cur, th, 0.004)
    lbx, ubx = opt._bounds(cur.nlp)
    k = cur.nlp.layout.unknowns["theta"]
    lbx[k] = np.maximum(opt.lo, th - 0.004) * 1e3
    ubx[k] = np.minimum(opt.hi, th + 0.004) * 1e3
    seen = []
    at = param_layout(0, 0)["mu"].start
    nlpsol = ca.nlpsol

    def spied(name, plugin, oracle, opts):  # every IPOPT solver built from here on records the barrier of its calls
        return _Spy(nlpsol(name, plugin, oracle, opts), seen, at, opts.get("ipopt.mu_strategy"))

    monkeypatch.setattr(ca, "nlpsol", spied)
    r, st, it = opt._solve_smoothed(cur.nlp, cur.z0, lbx, ubx, opt._pvec(1000.0))
    assert st_c["success"] and st["success"]
    assert seen[:2] == [(nlp_mod.MU_START, "monotone"), (MU, "adaptive")]
    assert nlp_mod.MU_START > 100 * MU
    P = len(opt.free)
    assert np.max(np.abs(np.asarray(r["x"])[:P] - np.asarray(cold["x"])[:P])) < 1e-6  # [um]
    assert abs(float(r["f"]) - float(cold["f"])) < 1e-9 * abs(float(cold["f"]))


class _Spy:
    """An IPOPT solver that records the smoothing ``mu`` of every call."""

    def __init__(self, f, seen, at, strategy=None):
        self.f, self.seen, self.at, self.strategy = f, seen, at, strategy

    def __call__(self, **kw):
        self.seen.append((float(np.asarray(kw["p"]).ravel()[self.at]), self.strategy))
        return self.f(**kw)

    def stats(self):
        return self.f.stats()


_EXITER = r"""
import sys
import casadi as ca
from gearopt import compiled
x = ca.SX.sym("x")
f = ca.Function("exit_test", [x], [ca.sin(x) * 3.25 + x**2], ["x"], ["y"])
assert compiled.compile_in_background(f) is not None
print(compiled.library_path(f), flush=True)
"""


@pytest.mark.skipif(not compiled.available(), reason="no C compiler")
def test_a_process_never_waits_at_exit_for_its_background_compile(tmp_path, monkeypatch):
    """A process that started a background compile (the linearisation's sensitivities on a cache miss)
    ends without waiting for the compiler; the compile goes on detached and its library appears in the
    cache whole (atomic rename: a half-written file is never at the library's path) and loads. The
    compiler here is held at a gate (a file) the test opens only after the process has ended: a
    process that waited for it at exit would hang (timeout) instead."""
    import os
    import subprocess
    import sys
    import time

    cc = compiled.compiler()[0]
    gate = tmp_path / "gate"
    fake = tmp_path / "cc"
    fake.write_text(f"""#!/bin/sh
if [ "$1" = "--version" ]; then exec {cc} --version; fi
out=""; prev=""
for a in "$@"; do [ "$prev" = "-o" ] && out="$a"; prev="$a"; done
printf 'half a library' > "$out"
i=0; while [ ! -e {gate} ] && [ $i -lt 1200 ]; do sleep 0.05; i=$((i+1)); done
exec {cc} "$@"
""")
    fake.chmod(0o755)
    cache = tmp_path / "cache"
    env = dict(os.environ, CC=str(fake), GEAROPT_CACHE_DIR=str(cache), GEAROPT_JIT_BACKGROUND="1")
    p = subprocess.run([sys.executable, "-c", _EXITER], env=env, capture_output=True, text=True, timeout=45)
    assert p.returncode == 0, p.stderr
    lib = Path(p.stdout.strip().splitlines()[-1])
    assert lib.parent == cache
    # the process has ended; its compiler still waits at the gate with a partial output in scratch
    for _ in range(400):
        if list(cache.glob(".build-*/lib.so")):
            break
        time.sleep(0.05)
    assert list(cache.glob(".build-*/lib.so")) and not lib.exists()
    gate.touch()
    for _ in range(1200):
        if lib.exists():
            break
        time.sleep(0.05)
    assert lib.exists()
    for _ in range(200):  # the detached job removes its scratch directory after the rename
        if not list(cache.glob(".build-*")):
            break
        time.sleep(0.05)
    assert not list(cache.glob(".build-*"))
    import casadi as ca

    g = ca.external("exit_test", str(lib))
    assert float(g(0.5)) == pytest.approx(np.sin(0.5) * 3.25 + 0.25, rel=1e-15)


@pytest.mark.slow
@pytest.mark.ipopt
def test_solver_options_and_oracle_leave_the_iterates_bit_for_bit(small):
    """The loaded NLP's IPOPT gives MUMPS a workspace of at most 100 % over its estimate (IPOPT's
    default, 1000 %, is memory every factorisation allocates afresh and the kernel zeroes: about a
    quarter of IPOPT's time on microgeometry_loaded); the iterates are those of the default workspace
    bit for bit (a factorisation that needs more is repeated by IPOPT with a larger one). The cold and
    warm solvers share one oracle Function."""
    from gearopt.synthesis.loaded.nlp import LoadedNLP

    opt = small
    th = opt.theta0.copy()
    opt.phi1 = opt.ltca.mesh_cycle(opt.n_positions)
    cur = opt._around(th, 0.004)
    assert cur.nlp.opts["ipopt.mumps_mem_percent"] <= 100
    small_ws, st_s, it_s = _solve(opt, cur, th, 0.004)
    default = {k: v for k, v in cur.nlp.opts.items() if k != "ipopt.mumps_mem_percent"}
    ref = LoadedNLP(**{**{k: getattr(cur.nlp, k) for k in LoadedNLP.__dataclass_fields__ if not k.startswith("_")
                          and k not in ("warm",)}, "opts": default})
    big_ws, st_b, it_b = _solve(opt, LocalModel(nlp=ref, z0=cur.z0, check=cur.check, merit=cur.merit, time=0.0), th,
                                0.004)
    assert st_s["success"] and st_b["success"] and it_s == it_b
    assert np.array_equal(np.asarray(small_ws["x"]), np.asarray(big_ws["x"]))
    # the cold and the warm solver of an NLP are built from its one oracle Function (its derivatives'
    # construction shared), and solve as the solver built from the problem's expressions, bit for bit
    import casadi as ca
    from gearopt.synthesis.loaded.trust_region import TrustRegion

    warm = TrustRegion._warm_solver(cur.nlp)
    assert cur.nlp.solver.oracle().__hash__() == warm.oracle().__hash__() == cur.nlp.oracle.__hash__()
    own = ca.nlpsol("own", "ipopt", cur.nlp.problem, cur.nlp.opts)
    lbx, ubx = opt._bounds(cur.nlp)
    args = dict(x0=cur.z0, lbx=lbx, ubx=ubx, lbg=cur.nlp.lbg, ubg=cur.nlp.ubg, p=opt._pvec(1000.0))
    assert np.array_equal(np.asarray(own(**args)["x"]), np.asarray(cur.nlp.solver(**args)["x"]))


@pytest.mark.slow
def test_a_first_run_solves_the_slices_interpreted_while_they_compile_in_the_background(monkeypatch):
    """Under ``jit="auto"`` the optimiser's slices of fewer than ``compiled.MIN_COLUMNS`` columns whose
    library is not in the disk cache run interpreted while it compiles in the background (the loop's
    later solves pick it up): a first run no longer waits for five compiles before its first
    linearisation. ``jit=True`` compiles at once, ``jit=False`` never; with the background compiles off
    (``GEAROPT_JIT_BACKGROUND=0``, this suite's default) ``"auto"`` compiles at once too."""
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "0")
    off = LoadedMicroOptimizer(GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0)),
                               {"pinion.C_alpha": (0.0, 0.04)}, torques=[200.0], n_positions=8, n_verify=16)
    assert off.tca.jit is compiled.available()
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "1")
    opt = LoadedMicroOptimizer(GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_alpha=0.005)),
                                        Gear(z=40, m_n=3.0, b=20.0)), {"pinion.C_alpha": (0.0, 0.04)},
                               torques=[200.0], n_positions=8, n_verify=16, n_slices=5)
    assert opt.tca.jit == "auto"
    assert opt.jit is compiled.available()  # the sensitivities: compiled whenever a compiler is present
    if not compiled.available():
        return
    fg, bg = [], []
    monkeypatch.setattr(compiled, "cached_function", lambda f: None)  # every library a cache miss
    monkeypatch.setattr(compiled, "compile_function", lambda f: fg.append(f.name()))
    monkeypatch.setattr(compiled, "compile_in_background", lambda f: bg.append(f.name()))
    p1, p2 = opt.params(opt.theta0)
    S = opt.ltca.slices(opt.phi1, p1, p2, opt.cases[0])
    assert S.active.any()
    assert fg == [] and any(n.startswith("ltca_slice") for n in bg)
    forced = LoadedMicroOptimizer(opt.pair, {"pinion.C_alpha": (0.0, 0.04)}, torques=[200.0], n_positions=8,
                                  n_verify=16, n_slices=5, jit=True)
    assert forced.tca.jit is True
    forced.ltca.slices(forced.phi1, p1, p2, forced.cases[0])
    assert any(n.startswith("ltca_slice") for n in fg)  # compiled at once (here: the stub's None, interpreted)
    assert LoadedMicroOptimizer(opt.pair, {"pinion.C_alpha": (0.0, 0.04)}, torques=[200.0], n_positions=8,
                                n_verify=16, n_slices=5, jit=False).tca.jit is False


@pytest.mark.slow
def test_the_nlp_takes_the_analytical_compliance_as_the_analysiss_dense_blocks(small, monkeypatch):
    """With few slices across the face (``n_slices <= DENSE_SLICES_MAX``) the loaded NLP has no deflection
    unknowns: its gaps take ``LTCA.structure``'s compliance ``Cs`` (each pair's face coupling and the pairs'
    coupling through the bodies) as dense blocks over each block's held loads, ``d gap / d x = Cs W / g_ref``
    off the diagonal (the diagonal: the Hertz term). The stiffness form (deflection unknowns, forced here)
    has the same compliance once its deflections are eliminated: ``G_x - G_w S_w^-1 S_x``."""
    import casadi as ca

    from gearopt.synthesis.loaded import nlp as nlp_module
    from gearopt.synthesis.loaded.constants import G_REF

    opt = small
    th = opt.theta0.copy()
    opt.phi1 = opt.ltca.mesh_cycle(opt.n_positions)

    def jacobians(nlp, z0):
        z = ca.MX.sym("z", z0.size)
        U, R = nlp.layout.unknowns, nlp.layout.rows
        ones, zeros = np.ones(opt.torques.size), np.zeros(nlp.Jk.shape[1] - th.size)
        Jg = np.asarray(ca.Function("jg", [z], [ca.jacobian(nlp.gap(z, ones, zeros), z)])(z0))
        p = ca.MX.sym("p", nlp.problem["p"].shape[0])
        g = ca.Function("g", [nlp.problem["x"], nlp.problem["p"]], [nlp.problem["g"]])
        Js = np.asarray(ca.Function("js", [z, p], [ca.jacobian(g(z, p), z)])(z0, opt._pvec(1000.0)))[R["stiffness"]]
        return Jg[:, U["x"]], Jg[:, U["w"]], Js[:, U["x"]], Js[:, U["w"]]

    cur = opt._around(th, 0.004)
    nlp = cur.nlp
    assert nlp.sizes["nw"] == 0 and nlp.layout.rows.count("stiffness") == 0
    Gx = jacobians(nlp, cur.z0)[0]
    lin = opt.linearise(th)
    expected = np.zeros_like(Gx)
    cross = 0
    for b in nlp.blocks:
        A = nlp.keys[b.first:b.first + b.count, 3]
        M = lin[b.case].slices.z.shape[2]
        s = slice(b.first, b.first + b.count)
        expected[s, s] = lin[b.case].structure.Cs[b.position][np.ix_(A, A)] * nlp.Wt[b.torque] / G_REF
        cross += np.count_nonzero(expected[s, s][(A // M)[:, None] != (A // M)[None, :]])
    assert cross > 0  # the pairs' coupling through the bodies is there
    off = ~np.eye(Gx.shape[0], dtype=bool)
    assert np.max(np.abs(Gx - expected)[off]) <= 1e-12 * np.max(np.abs(expected))
    # the stiffness form, its deflections eliminated
    monkeypatch.setattr(nlp_module, "DENSE_SLICES_MAX", 0)
    cur_w = opt._around(th, 0.004)
    assert cur_w.nlp.sizes["nw"] > 0 and np.array_equal(cur_w.nlp.keys, nlp.keys)
    gx, gw, sx, sw = jacobians(cur_w.nlp, cur_w.z0)
    total = gx - gw @ np.linalg.solve(sw, sx)
    assert np.max(np.abs(total - expected)[off]) <= 1e-9 * np.max(np.abs(expected))
