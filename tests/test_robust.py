"""Robust-design studies (gearopt.robust): ISO 1328-1 tolerances, distributions and designs against
scipy, the batched TCA kernel against independent TCA sweeps (misalignment, design settings, pitch
and flank deviations), executors (serial, local processes, Dask LocalCluster, a real `dask
scheduler` with two `dask worker` processes) bit-identical with a worker killed mid-run, an
unreachable scheduler, interrupted runs, bad input."""

from __future__ import annotations

import math
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from gearopt.errors import ExecutionError, OptionError, SceneError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.meshing.misalignment import Misalignment
from gearopt.robust import tolerances as tol
from gearopt.robust.sampling import Distribution, design
from gearopt.robust.study import DesignSweep, MonteCarlo
from gearopt.units import ARCMIN, RAD_TO_ARCSEC

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def pair():
    # the drive of problems/montecarlo_spur.toml (50 um backlash allowance on the centre distance)
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=0.0004, rack=BasicRack.iso53("A", a_c=0.002)),
                    Gear(z=40, m_n=3.0, b=20.0), a=90.05)


MIS = {"crossing": Distribution("normal", sd=1.5 * ARCMIN), "intersecting": Distribution("normal", sd=1.5 * ARCMIN)}


# --- ISO 1328-1 -------------------------------------------------------------------------------
def test_iso1328_class5_by_hand_and_rounding():
    d, m, b = 60.0, 3.0, 20.0
    t = tol.tolerances(5, d, m, b, rounded=False)
    assert t["f_pT"] == pytest.approx(0.001 * 60 + 0.4 * 3 + 5)  # 6.26
    assert t["f_HbetaT"] == pytest.approx(0.07 * math.sqrt(60) + 0.45 * math.sqrt(20) + 3)
    assert t["f_HalphaT"] == pytest.approx(2 * math.sqrt(3) + 0.14 * math.sqrt(60) + 0.5)
    r = tol.tolerances(5, d, m, b)
    assert r["f_pT"] == 6.5  # 5 ... 10 um: to 0.5 um
    assert r["F_pT"] == round(0.002 * 60 + 0.55 * math.sqrt(60) + 0.7 * 3 + 12)  # > 10 um: integer
    assert tol.iso_round(4.23) == 4.2 and tol.iso_round(4.25) == 4.3 and tol.iso_round(10.4) == 10.0
    # one class up is sqrt(2) times the tolerance, exactly, before rounding
    for A in range(1, 11):
        lo, hi = tol.tolerances(A, d, m, b, rounded=False), tol.tolerances(A + 1, d, m, b, rounded=False)
        for k in tol.NAMES:
            assert hi[k] / lo[k] == pytest.approx(math.sqrt(2), rel=1e-12)


@pytest.mark.parametrize("args,param", [((0, 60, 3, 20), "iso_grade"), ((12, 60, 3, 20), "iso_grade"),
                                        ((5, 2.0, 3, 20), "d"), ((5, 60, 0.2, 20), "m_n"),
                                        ((5, 60, 3, 2000), "b"), ((5.5, 60, 3, 20), "iso_grade")])
def test_iso1328_bad_input_names_the_key(args, param):
    with pytest.raises(OptionError) as e:
        tol.tolerances(*args)
    assert e.value.param == param and e.value.valid


# --- distributions and designs ----------------------------------------------------------------
def test_distributions_match_scipy():
    from scipy import stats
    u = np.linspace(0.001, 0.999, 57)
    cases = [(Distribution("uniform", lo=-2, hi=3), stats.uniform(-2, 5)),
             (Distribution("normal", mean=1, sd=0.5), stats.norm(1, 0.5)),
             (Distribution("truncnormal", mean=0, sd=1, lo=-1, hi=2), stats.truncnorm(-1, 2)),
             (Distribution("triangular", lo=0, mode=1, hi=4), stats.triang(0.25, 0, 4))]
    for mine, ref in cases:
        np.testing.assert_allclose(mine.ppf(u), ref.ppf(u), rtol=1e-9, atol=1e-12)
    assert np.all(Distribution("fixed", value=2.5).ppf(u) == 2.5)


@pytest.mark.parametrize("kw,param", [(dict(kind="gauss"), "x.kind"), (dict(kind="normal", sd=0.0), "x.sd"),
                                      (dict(kind="uniform", lo=1, hi=1), "x.hi"),
                                      (dict(kind="triangular", lo=0, mode=5, hi=4), "x.mode"),
                                      (dict(kind="uniform", lo=0, hi=float("nan")), "x.hi")])
def test_bad_distributions_name_the_key(kw, param):
    with pytest.raises(OptionError) as e:
        Distribution(name="x", **kw)
    assert e.value.param == param


def test_designs_are_seeded_stratified_and_factorial():
    ins = {"a": Distribution("uniform", lo=0, hi=1), "b": Distribution("uniform", lo=10, hi=20)}
    a1, a2 = design(ins, "random", 50, 7), design(ins, "random", 50, 7)
    assert all(np.array_equal(a1[k], a2[k]) for k in ins)
    assert not np.array_equal(a1["a"], design(ins, "random", 50, 8)["a"])
    lhs = design(ins, "lhs", 40, 3)
    for k, (lo, hi) in (("a", (0, 1)), ("b", (10, 20))):  # one point in each of 40 strata
        strata = np.floor((lhs[k] - lo) / (hi - lo) * 40).astype(int)
        assert sorted(strata) == list(range(40))
    ff = design(ins, "full_factorial", 0, 0, levels=3)
    assert len(ff["a"]) == 9 and sorted(set(ff["a"])) == [0.0, 0.5, 1.0] and sorted(set(ff["b"])) == [10.0, 15.0, 20.0]
    for bad in (0, -3, 2.5):
        with pytest.raises(OptionError, match="samples"):
            design(ins, "random", bad, 0)


# --- the batched kernel against independent TCA sweeps ----------------------------------------
def _envelope(tca, phi, p1, mis, e1=(0, 0, 0), e2=(0, 0, 0)):
    """TE envelope over phi from one TCA.sweep per pair, pitch offsets applied by hand."""
    z1, z2 = tca.pair.pinion.z, tca.pair.gear.z
    tes = []
    for k, a, b in zip((-1, 0, 1), e1, e2):
        r = tca.sweep(phi + a, p1=p1, mis=mis, pairs=(k,), continuation=True)
        # TCAResult TE is referred to phi1 + a; the body angle is phi1: add back ratio * a, and the gear tooth's b
        te = np.where(r.on_surface[0], r.te[0] + (z1 / z2) * a + b, -np.inf)
        tes.append(te)
    env = np.max(tes, axis=0)
    return env


def test_kernel_matches_tca_sweeps(pair):
    mc = MonteCarlo(pair, 4, seed=1, misalignment=MIS, iso_grade=7, f_a=0.02)
    tca = mc._tca()
    kern = mc._kernel(tca, 4)
    vals = mc.values()
    chunk = mc._chunks(vals, 4, kern, tca)[0]
    out = kern.evaluate(chunk)
    lay = tca.layout
    for i in range(4):
        mis = Misalignment(*chunk["mis"][i])
        env = _envelope(tca, kern.phi, chunk["p1"][i], mis, chunk["e1"][i], chunk["e2"][i])
        assert np.all(np.isfinite(env))
        p2p = env.max() - env.min()
        assert out["te_p2p"][i] * RAD_TO_ARCSEC == pytest.approx(p2p * RAD_TO_ARCSEC, abs=1e-7)
        h = np.abs(np.fft.rfft(env - env.mean())) * 2 / env.size
        np.testing.assert_allclose(out["harmonics"][i] * RAD_TO_ARCSEC, h[1:4] * RAD_TO_ARCSEC, atol=1e-7)
    # the sampled deviations reached the flank and the pitch offsets are not all zero
    i_dev = lay.index("pinion.dev.f_H_beta") - lay.groups["pinion"].start
    assert np.ptp(chunk["p1"][:, i_dev]) > 1e-4 and np.abs(chunk["e1"]).max() > 1e-5


def test_relative_deviation_equals_microgeometry(pair):
    """f_H_beta and f_H_alpha sampled on the pinion through the study's light modification give
    the TE of the same amounts as ISO Microgeometry (an independent graph, with the exact roll
    length of the modified point)."""
    from dataclasses import replace

    from gearopt.geometry.microgeometry import Microgeometry
    from gearopt.meshing.tca import TCA

    fHb, fHa = 0.008, -0.006
    mc = MonteCarlo(pair, 1, misalignment={"crossing": Distribution("fixed", value=2 * ARCMIN)}, iso_grade=6)
    tca = mc._tca()
    kern = mc._kernel(tca, 1)
    chunk = {"p1": kern.p1_0[None, :].copy(), "p2": kern.p2_0[None, :], "mis": Misalignment(crossing=2 * ARCMIN).vector()[None, :]}
    lay = tca.layout
    off = lay.groups["pinion"].start
    chunk["p1"][0, lay.index("pinion.dev.f_H_beta") - off] = fHb
    chunk["p1"][0, lay.index("pinion.dev.f_H_alpha") - off] = fHa
    mine = kern.evaluate(chunk)["te_p2p"][0]
    mod = replace(pair, pinion=replace(pair.pinion, modifications=Microgeometry(f_H_beta=fHb, f_H_alpha=fHa)))
    ref_tca = TCA(mod)
    env = _envelope(ref_tca, kern.phi, None, Misalignment(crossing=2 * ARCMIN))
    ref = env.max() - env.min()
    assert mine == pytest.approx(ref, rel=2e-3)
    plain = kern.evaluate({**chunk, "p1": kern.p1_0[None, :]})["te_p2p"][0]
    assert abs(mine - plain) > 20 * abs(mine - ref)  # the deviation matters far more than the model's error


def test_design_sweep_kernel_matches_tca(pair):
    sw = DesignSweep(pair, {"pinion.a_pl": (0.0002, 0.0008), "mis.crossing": (-3 * ARCMIN, 3 * ARCMIN)},
                     design="full_factorial", levels=2)
    res = sw.run()
    tca = sw._tca()
    vals = sw.values()
    phi = np.linspace(-math.pi / 20, math.pi / 20, 64, endpoint=False)
    ia = tca.layout.index("pinion.a_pl") - tca.layout.groups["pinion"].start
    for i in range(4):
        p1 = tca.pinion.p0.copy()
        p1[ia] = vals["pinion.a_pl"][i]
        env = _envelope(tca, phi, p1, Misalignment(crossing=vals["mis.crossing"][i]))
        assert res.figures["te_p2p"][i] == pytest.approx(env.max() - env.min(), abs=1e-12)
    # a spur pair is symmetric about its mid face: crossing +-3 arcmin give the same TE amplitude
    f = res.figures["te_p2p"]
    assert f[1] == pytest.approx(f[0], rel=1e-6) and f[3] == pytest.approx(f[2], rel=1e-6)


def test_edge_contact_flag_follows_the_tca(pair):
    """A crossing angle on a lightly crowned pinion drives the contact off the face: the kernel
    flags edge contact exactly where the TCA's highest tangency is off the flank, and where the
    TCA finds no contact on the face at all (its anchor runs off the face)."""
    from dataclasses import replace

    from gearopt.errors import ConvergenceError
    light = replace(pair, pinion=replace(pair.pinion, a_pl=0.00005))
    mc = MonteCarlo(light, 3, misalignment={"crossing": Distribution("uniform", lo=0.0, hi=1e-9)})
    tca = mc._tca()
    kern = mc._kernel(tca, 3)
    cs = (0.0, 1.0, 2.0, 8.0)
    mis = np.array([Misalignment(crossing=c * ARCMIN).vector() for c in cs])
    out = kern.evaluate({"p1": np.tile(kern.p1_0, (4, 1)), "p2": np.tile(kern.p2_0, (4, 1)), "mis": mis})
    for i, c in enumerate(cs):
        try:
            r = tca.sweep(kern.phi, mis=Misalignment(crossing=c * ARCMIN), pairs=(-1, 0, 1))
        except ConvergenceError as e:
            assert "no contact point on the face" in str(e)
            expect = True
        else:
            te = np.where(r.converged, r.te, -np.inf)
            drv = te.argmax(axis=0)
            expect = bool((~r.on_surface[drv, np.arange(kern.phi.size)]).any() or np.isnan(r.te_envelope).any())
        assert bool(out["edge_contact"][i]) == expect, c
        assert out["ok"][i] and np.isfinite(out["te_p2p"][i]) == (not expect)
    assert list(out["edge_contact"]) == [False, False, True, True]


# --- studies, executors -----------------------------------------------------------------------
def _same(a, b):
    return all(np.array_equal(a.figures[k], b.figures[k], equal_nan=True) for k in a.figures) and \
        np.array_equal(a.pattern_count, b.pattern_count)


@pytest.fixture(scope="module")
def serial_run(pair):
    return MonteCarlo(pair, 96, seed=5, misalignment=MIS, iso_grade=6, f_a=0.02, chunk=16).run()


def test_monte_carlo_statistics(pair, serial_run):
    r = serial_run
    d = r.to_dict()
    st = d["statistics"]
    assert st["n_samples"] == 96 and st["n_failed"] == 0
    v = r.figures["te_p2p"] * RAD_TO_ARCSEC
    assert st["te_p2p_arcsec"]["p50"] == pytest.approx(np.median(v))
    assert st["te_p2p_arcsec"]["min"] <= d["nominal"]["te_p2p_arcsec"] * 1.5
    p = st["p_edge_contact"]
    assert p["lo"] <= p["p"] <= p["hi"] and p["n"] == 96
    prob = np.array(d["pattern"]["probability"])
    assert prob.max() <= 1.0 and prob.max() > 0.9  # the pattern's middle is covered by every sample
    assert [r_["input"] for r_ in d["sensitivities"]["te_p2p"]]  # ranked inputs exist
    # the chunk size does not change a number
    assert _same(r, MonteCarlo(pair, 96, seed=5, misalignment=MIS, iso_grade=6, f_a=0.02, chunk=40).run())


def _swap_kernel(mc, cls, marker):
    """Make the study build its kernel as ``cls`` (a faulty kernel of tests/faulty_kernel.py) that
    acts once across processes (the ``marker`` file), never in this test process; returns the
    kernel factory."""
    base = mc._kernel

    def factory(tca, n):
        k = base(tca, n)
        k.__class__ = cls
        k.marker, k.parent_pid = str(marker), os.getpid()
        return k
    mc._kernel = factory
    return factory


@pytest.mark.slow
def test_processes_and_local_dask_are_bit_identical_and_survive_a_killed_worker(pair, serial_run, tmp_path):
    from faulty_kernel import DieOnceKernel

    for executor in ("processes", "dask"):
        mc = MonteCarlo(pair, 96, seed=5, misalignment=MIS, iso_grade=6, f_a=0.02, chunk=16, executor=executor,
                        workers=2)
        marker = tmp_path / f"died-{executor}"
        _swap_kernel(mc, DieOnceKernel, marker)
        r = mc.run()
        assert marker.exists(), "a worker process died mid-run"
        assert int(marker.read_text()) != os.getpid()
        assert _same(r, serial_run), executor


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="class")
def dask_cli_cluster():
    """A real ``dask scheduler`` and two ``dask worker`` processes (each under its nanny, which
    restarts a worker that dies), started from the command line: the scheduler's address. Shared by
    the tests of :class:`TestDaskCommandLineCluster` (one cluster start instead of one LocalCluster
    per run: the worker processes' imports are most of their CPU) and stopped after them (idle Dask
    processes keep polling)."""
    dask = shutil.which("dask", path=os.path.dirname(sys.executable)) or shutil.which("dask")
    if dask is None:
        pytest.skip("the dask command line is not installed")
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(ROOT / "tests"), os.environ.get("PYTHONPATH", "")]))
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([dask, "worker", addr, "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
                                          env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client
        with Client(addr, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        yield addr
    finally:
        # the workers first, while their scheduler still answers (a nanny whose scheduler has gone
        # waits 8 s for its worker process and then kills it), then the scheduler
        for group in (procs[1:], procs[:1]):
            for p in group:
                p.terminate()
            for p in group:
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()


@pytest.mark.slow
class TestDaskCommandLineCluster:
    """A real `dask scheduler` with two `dask worker` processes (:func:`dask_cli_cluster`): a lost chunk
    resubmitted, a killed worker's chunk rerun; the numbers of the serial run."""

    def test_dask_resubmits_a_lost_chunk(self, pair, serial_run, tmp_path, dask_cli_cluster, monkeypatch):
        """A chunk whose task the cluster lost (CancelledError) is resubmitted with the kernel scattered
        again: same numbers; a chunk lost every time gives an ExecutionError naming it (on the scheduler
        of :func:`dask_cli_cluster`: the resubmission is the executor's, whatever the cluster; the
        LocalCluster of ``executor="dask"`` is
        test_processes_and_local_dask_are_bit_identical_and_survive_a_killed_worker's)."""
        from faulty_kernel import LoseOnceKernel

        from gearopt.robust import execution

        mc = MonteCarlo(pair, 96, seed=5, misalignment=MIS, iso_grade=6, f_a=0.02, chunk=16)
        marker = tmp_path / "lost-once"
        loser = _swap_kernel(mc, LoseOnceKernel, marker)
        r = mc.run(scheduler=dask_cli_cluster)
        assert marker.exists()
        assert _same(r, serial_run)

        class Always(LoseOnceKernel):
            def evaluate(self, chunk):
                marker.unlink(missing_ok=True)
                return super().evaluate(chunk)

        kernel = loser(mc._tca(), 1)
        kernel.__class__ = Always
        # one resubmission and one Dask retry allowed (execution.RETRIES, 3: sixteen runs and four scatters
        # of the kernel to every worker before the error): the same rule, a quarter of the attempts
        monkeypatch.setattr(execution, "RETRIES", 1)
        with pytest.raises(ExecutionError, match="chunk 0 of 1 was lost 2 times"):
            execution.run_chunks(kernel, [{"p1": np.zeros((1, 1))}], scheduler=dask_cli_cluster)

    def test_real_dask_scheduler_and_two_workers(self, pair, serial_run, tmp_path, dask_cli_cluster):
        from faulty_kernel import DieOnceKernel

        mc = MonteCarlo(pair, 96, seed=5, misalignment=MIS, iso_grade=6, f_a=0.02, chunk=16)
        marker = tmp_path / "died-cli"
        _swap_kernel(mc, DieOnceKernel, marker)
        r = mc.run(scheduler=dask_cli_cluster)
        assert marker.exists()
        assert _same(r, serial_run)


@pytest.mark.slow
def test_unreachable_scheduler_fails_fast_and_clearly(pair, tmp_path, monkeypatch):
    from gearopt.cli import main
    from gearopt.robust import execution

    addr = f"tcp://127.0.0.1:{_free_port()}"
    # the connection's time-out as an argument (default execution.CONNECT_TIMEOUT, 5 s): 1 s here
    connect = execution.connect
    monkeypatch.setattr(execution, "connect", lambda scheduler: connect(scheduler, timeout=1.0))
    t0 = time.perf_counter()
    with pytest.raises(ExecutionError) as e:
        MonteCarlo(pair, 8, misalignment=MIS).run(scheduler=addr)
    assert time.perf_counter() - t0 < 26  # the connection gives up after 1 s (+ the build)
    assert "within 1 s" in str(e.value)
    assert addr in str(e.value) and "dask scheduler" in str(e.value)
    out = tmp_path / "out"
    assert main(["run", str(ROOT / "problems" / "montecarlo_spur.toml"), "--out", str(out), "--quiet",
                 "--scheduler", addr]) == 2
    assert not out.exists()


def test_interrupted_study_writes_nothing(tmp_path, monkeypatch):
    from gearopt.cli import main
    from gearopt.robust.batch import TCAKernel

    calls = {"n": 0}
    orig = TCAKernel.evaluate

    def interrupt(self, chunk):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return orig(self, chunk)
    monkeypatch.setattr(TCAKernel, "evaluate", interrupt)
    scene = tmp_path / "mc.toml"
    scene.write_text((ROOT / "problems" / "montecarlo_spur.toml").read_text().replace("samples = 1000", "samples = 200")
                     + "chunk = 32\n")
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        main(["run", str(scene), "--out", str(out), "--quiet"])
    assert not out.exists() and calls["n"] == 3


# --- bad input ------------------------------------------------------------------------------
@pytest.mark.parametrize("kw,param", [(dict(samples=0), "samples"), (dict(samples=-5), "samples"),
                                      (dict(samples=10, iso_grade=12), "iso_grade"),
                                      (dict(samples=10, spread="gauss", f_a=0.01), "spread"),
                                      (dict(samples=10, f_a=-0.1), "f_a"),
                                      (dict(samples=10, misalignment={"twist": MIS["crossing"]}), "misalignment"),
                                      (dict(samples=10, executor="cluster", f_a=0.01), "executor"),
                                      (dict(samples=10, workers=0, f_a=0.01), "workers"),
                                      (dict(samples=10), "misalignment")])
def test_bad_monte_carlo_input_names_the_key(pair, kw, param):
    with pytest.raises(OptionError) as e:
        MonteCarlo(pair, **kw)
    assert e.value.param == param


@pytest.mark.parametrize("edit,key", [("samples = 1000", "samples = 0"), ("iso_grade = 6", "iso_grade = 13"),
                                      ('kind = "normal", mean = "0 arcmin", sd = "1.5 arcmin" }',
                                       'kind = "gaussian", sd = "1.5 arcmin" }'),
                                      ('sd = "1.5 arcmin" }', 'sd = "-1 arcmin" }')])
def test_bad_scene_keys_name_the_key(tmp_path, edit, key):
    from gearopt.cli import main
    from gearopt.io.scene import load_scene

    text = (ROOT / "problems" / "montecarlo_spur.toml").read_text()
    assert edit in text
    scene = tmp_path / "bad.toml"
    scene.write_text(text.replace(edit, key, 1))
    with pytest.raises(SceneError) as e:
        load_scene(scene).build()
    assert "[montecarlo]" in str(e.value)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 2 and not out.exists()


def test_jamming_samples_are_reported_not_solved(pair):
    from dataclasses import replace
    tight = replace(pair, a=None)  # zero backlash: any closing of the centre distance jams
    r = MonteCarlo(tight, 64, seed=2, misalignment={"dE": Distribution("uniform", lo=-0.02, hi=0.02)}).run()
    f = r.figures
    dE = r.inputs["mis.dE"]
    assert np.array_equal(f["feasible"], dE >= -0.0003)
    assert np.all(np.isnan(f["te_p2p"][~f["feasible"]])) and np.all(np.isfinite(f["te_p2p"][f["feasible"]]))
    st = r.statistics()
    assert st["n_infeasible"] == int((dE < -0.0003).sum()) > 0 and st["n_failed"] == 0
    assert st["p_edge_contact"]["n"] == int(f["feasible"].sum())


def test_inconsistent_sweep_ranges(pair):
    with pytest.raises(OptionError) as e:
        DesignSweep(pair, {"pinion.a_pl": (0.0008, 0.0002)})
    assert e.value.param == "variables.pinion.a_pl.hi"
    with pytest.raises(OptionError) as e:
        DesignSweep(pair, {"pinion.shaft": (0, 1)}).run()
    assert e.value.param == "variables"


# --- the scenes -------------------------------------------------------------------------------
@pytest.mark.slow
def test_montecarlo_scene_physics():
    """problems/montecarlo_spur.toml: the crowned drive's parabolic TE absorbs the misalignments
    (Litvin 9.4): the crossing and intersecting angles hardly move TE peak-to-peak while the pitch
    deviations of class 6 do; the nominal drive has surface contact only."""
    from gearopt.io.scene import load_scene
    st = load_scene(ROOT / "problems" / "montecarlo_spur.toml").build()
    st.samples = 400
    r = st.run()
    d = r.to_dict()
    assert d["statistics"]["n_failed"] == 0 and d["statistics"]["n_infeasible"] == 0
    assert d["nominal"]["edge_contact"] is False
    sens = {s["input"]: max(abs(s["spearman"]), abs(s["spearman_abs"])) for s in d["sensitivities"]["te_p2p"]}
    pitch = max(v for k, v in sens.items() if "f_pt" in k)
    assert pitch > 2 * sens["mis.crossing"] and pitch > 2 * sens["mis.intersecting"]
    tol6 = d["options"]["tolerances_um"]["pinion"]
    assert tol6["f_pT"] == tol.tolerances(6, 60.0, 3.0, 20.0)["f_pT"]
    dev = r.inputs["pinion.f_pt_1"] * 1000
    assert np.abs(dev).max() <= tol6["f_pT"] and dev.std() == pytest.approx(tol6["f_pT"] / 3, rel=0.2)


def test_doe_scene_ranks_profile_crowning_first():
    """problems/doe_helical.toml: the amplitude of the parabolic TE grows with the profile crowning
    a_c, so a_c is the first variable for TE peak-to-peak, with a positive rank correlation."""
    from gearopt.io.scene import load_scene
    r = load_scene(ROOT / "problems" / "doe_helical.toml").build().run()
    top = r.sensitivities()["te_p2p"][0]
    assert top["input"] == "pinion.a_c" and top["spearman"] > 0.5
    assert r.n == 64 and r.statistics()["n_failed"] == 0


def test_scheduler_option_only_for_robust_studies(tmp_path):
    from gearopt.cli import main
    out = tmp_path / "out"
    assert main(["run", str(ROOT / "problems" / "spur_geometry.toml"), "--out", str(out), "--quiet",
                 "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert not out.exists()


def test_wilson_interval_matches_scipy():
    from scipy.stats import binomtest

    from gearopt.robust.study import _wilson
    for k, n in ((0, 50), (3, 50), (25, 50), (50, 50), (7, 1000)):
        ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        w = _wilson(k, n)
        assert w["p"] == k / n
        assert w["lo"] == pytest.approx(ci.low, abs=1e-12) and w["hi"] == pytest.approx(ci.high, abs=1e-12)


@pytest.mark.slow
def test_progress_bar_on_stderr_unless_quiet(tmp_path, capfd):
    from gearopt.cli import main
    scene = tmp_path / "mc.toml"
    # no figures: the bar is the study's, not the drawing's
    scene.write_text((ROOT / "problems" / "montecarlo_spur.toml").read_text().replace("samples = 1000", "samples = 64")
                     + "\n[output]\nplots = false\n")
    assert main(["run", str(scene), "--out", str(tmp_path / "a")]) == 0
    err = capfd.readouterr().err
    assert "64/64" in err and "sample" in err
    assert main(["run", str(scene), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    assert capfd.readouterr().err == ""


@pytest.mark.parametrize("name,amount,rel", [("f_H_beta", 0.008, 0.12), ("f_H_alpha", -0.006, 0.06),
                                             ("f_H_alpha", 0.006, 0.06)])
def test_gear_deviation_as_relative_pinion_deviation(pair, name, amount, rel):
    """A gear flank deviation carried by the pinion as the relative deviation of the study changes
    the TE over the cycle as the same ISO amount composed into the gear's own flank (an independent
    graph) does, within 6 % of the change for a profile slope and 12 % for a helix slope (whose TE
    change is only 0.04 arcsec here: it moves the contact along the face). The first-order model:
    the contact points of the crowned, misaligned pair are not exactly where the line-of-action
    correspondence puts them."""
    from dataclasses import replace

    from gearopt.geometry.microgeometry import Microgeometry
    from gearopt.meshing.tca import TCA

    mis = Misalignment(crossing=2 * ARCMIN)
    mc = MonteCarlo(pair, 1, iso_grade=6)
    tca = mc._tca()
    kern = mc._kernel(tca, 1)
    vals = {k: np.zeros(1) for k in mc.inputs}
    vals[f"gear.{name}"] = np.array([amount])
    chunk = mc._chunks(vals, 1, kern, tca)[0]
    chunk["mis"] = mis.vector()[None, :]
    mine = kern.evaluate(chunk)["envelope"][0] - kern.evaluate({**chunk, "p1": kern.p1_0[None, :]})["envelope"][0]
    mod = replace(pair, gear=replace(pair.gear, modifications=Microgeometry(**{name: amount})))
    ref = _envelope(TCA(mod), kern.phi, None, mis) - _envelope(TCA(pair), kern.phi, None, mis)
    mine, ref = mine - mine.mean(), ref - ref.mean()  # TE zeros differ by a constant
    assert np.abs(ref).max() * RAD_TO_ARCSEC > 0.02  # the deviation moves the TE
    assert np.abs(mine - ref).max() < rel * np.abs(ref).max()


# --- loaded TCA per sample --------------------------------------------------------------------
@pytest.mark.slow
def test_loaded_samples_at_tiny_torque_match_the_unloaded_kernel(pair):
    """At 0.01 N m the loaded TCA of each sample (slices, with the pitch offsets of the slice
    solver) gives the unloaded TE of the point-contact kernel (its own pitch offsets): two engines,
    the same drive as built."""
    from gearopt.robust.batch import LTCAKernel
    mc = MonteCarlo(pair, 3, seed=11, misalignment=MIS, iso_grade=7, torque=0.01, n_slices=21)
    tca = mc._tca()
    kern = mc._kernel(tca, 3)
    chunk = mc._chunks(mc.values(), 3, kern, tca)[0]
    assert np.abs(chunk["e1"]).max() > 1e-5
    un = kern.evaluate(chunk)
    lk = LTCAKernel(pair, kern.phi, (-1, 0, 1), deviation_mod=True)
    lo = lk.evaluate(chunk)
    assert lo["loaded_ok"].all()
    np.testing.assert_allclose(lo["loaded_te_p2p"] * RAD_TO_ARCSEC, un["te_p2p"] * RAD_TO_ARCSEC, atol=0.05)
    np.testing.assert_allclose(lo["loaded_harmonics"][:, 0] * RAD_TO_ARCSEC, un["harmonics"][:, 0] * RAD_TO_ARCSEC,
                               atol=0.05)


@pytest.mark.slow
def test_loaded_monte_carlo_reports_pressure_and_torque_sensitivity(pair):
    r = MonteCarlo(pair, 6, seed=4, misalignment=MIS, torque=Distribution("uniform", lo=40.0, hi=200.0),
                   chunk=3).run()
    d = r.to_dict()
    ld = d["statistics"]["loaded"]
    assert ld["n_failed"] == 0 and 500 < ld["p_max_MPa"]["min"] < ld["p_max_MPa"]["max"] < 3000
    # Hertz: the peak pressure grows with the torque (rank correlation +1 over the samples)
    top = {s["input"]: s for s in d["sensitivities"]["p_max"]}
    assert top["torque"]["spearman"] > 0.8
    assert "p_max_MPa" in r.table() and d["nominal"]["torque_Nm"] == pytest.approx(120.0)


@pytest.mark.parametrize("torque", [0.0, -5.0, float("nan"), Distribution("normal", mean=100, sd=10)])
def test_bad_torque_names_the_key(pair, torque):
    with pytest.raises(OptionError) as e:
        MonteCarlo(pair, 4, misalignment=MIS, torque=torque)
    assert e.value.param == "torque"


def test_bad_side_and_delta_name_the_key(pair):
    with pytest.raises(OptionError) as e:
        MonteCarlo(pair, 4, misalignment=MIS, side="up")
    assert e.value.param == "side"
    with pytest.raises(OptionError) as e:
        MonteCarlo(pair, 4, misalignment=MIS, delta=1.0)
    assert e.value.param == "delta" and "0.3 mm" in e.value.valid
