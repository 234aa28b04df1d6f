"""The crowning study's TCA of the drive before optimisation (and of the optimised drive's last
cases), and the crowning optimizer's verification sweeps of its last cases, run in a forked process
alongside the caller (gearopt.forking.ForkedCall): the value is the one computed in the caller, a
failed or unforkable call is computed in the caller (its error raised there), close() ends the
process."""

from __future__ import annotations

import os
import threading
import time

import pytest

from gearopt.forking import ForkedCall, idle_cores, running_children


#: the tests of this file that skipped because another thread ran in this process (an xdist worker's
#: own, or one a test of another file left and that may end meanwhile): the last test reruns them
THREAD_SKIPS: list[str] = []


@pytest.fixture
def forking(monkeypatch):
    monkeypatch.setattr(ForkedCall, "min_idle_cores", None)  # fork also on a busy machine
    if threading.active_count() != 1:
        THREAD_SKIPS.append("forking")
        pytest.skip("another thread runs in this process: ForkedCall computes in the caller")
    probe = ForkedCall(lambda: None)
    forked = probe.forked
    probe.close()
    if not forked:
        pytest.skip("no fork here (not Linux, or one core)")


def test_the_value_comes_from_another_process(forking):
    me = os.getpid()
    call = ForkedCall(lambda: (os.getpid(), [1.5, None, {"a": "b"}]))
    assert call.forked
    pid, value = call.result()
    assert pid != me and value == [1.5, None, {"a": "b"}]
    assert call.result() == (pid, value)  # computed once
    assert not call.forked


def test_disabled_threaded_or_busy_computes_in_the_caller(monkeypatch):
    me = os.getpid()
    monkeypatch.setattr(ForkedCall, "min_idle_cores", None)
    monkeypatch.setattr(ForkedCall, "enabled", False)
    call = ForkedCall(os.getpid)
    assert not call.forked and call.result() == me
    monkeypatch.setattr(ForkedCall, "enabled", True)
    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    try:
        call = ForkedCall(os.getpid)
        assert not call.forked and call.result() == me
    finally:
        stop.set()
        t.join()
    # every core busy (more runnable tasks than cores): no fork
    monkeypatch.setattr("gearopt.forking.idle_cores", lambda: 0)
    monkeypatch.setattr(ForkedCall, "min_idle_cores", 1)
    call = ForkedCall(os.getpid)
    assert not call.forked and call.result() == me


def test_forks_beside_a_progress_heartbeat_but_not_beside_another_thread(forking):
    """A heartbeat (gearopt.progress, declared by fork_beside) runs during the crowning optimizer's
    solve under `gearopt run` without --quiet: the verification still forks beside it."""
    from gearopt.progress import heartbeat

    me = os.getpid()
    lines = []
    with heartbeat(lines.append, "test", every=0.01):
        assert threading.active_count() == 2
        call = ForkedCall(os.getpid)
        assert call.forked and call.result() != me
        time.sleep(0.05)
    assert lines  # the heartbeat went on reporting here
    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    try:
        with heartbeat(lines.append, "test", every=1.0):
            call = ForkedCall(os.getpid)
            assert not call.forked and call.result() == me
    finally:
        stop.set()
        t.join()


def test_idle_cores_counts_the_running_tasks_of_the_machine():
    n = idle_cores()
    assert isinstance(n, int) and n <= len(os.sched_getaffinity(0))


def test_running_children_counts_this_processs_own_running_children():
    """A child of this process that computes counts (not as load in idle_cores: gearopt run's
    drawing process importing matplotlib while the crowning study forks), one that sleeps does not."""
    if not (hasattr(os, "fork") and os.path.exists(f"/proc/self/task/{os.getpid()}/children")):
        pytest.skip("no /proc children list here")
    before = running_children()
    pids = []
    try:
        for busy in (True, False):
            pid = os.fork()
            if pid == 0:  # spin or sleep 20 s, ended below
                t = time.time()
                while time.time() - t < 20:
                    if not busy:
                        time.sleep(20)
                os._exit(0)
            pids.append(pid)
        time.sleep(0.3)
        assert running_children() == before + 1
    finally:
        for pid in pids:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
    assert running_children() == before


def test_a_failure_in_the_forked_process_is_computed_again_in_the_caller(forking):
    me = os.getpid()

    def fn():
        if os.getpid() != me:
            raise RuntimeError("failed in the forked process")
        return "computed here"

    assert ForkedCall(fn).result() == "computed here"

    def bad():
        raise ValueError("bad geometry, key 'x' = 3")

    with pytest.raises(ValueError, match="bad geometry"):  # raised in the caller, by the caller's own call
        ForkedCall(bad).result()


def test_close_ends_a_running_forked_process(forking):
    call = ForkedCall(lambda: time.sleep(60))
    pid = call.pid
    t = time.perf_counter()
    call.close()
    assert time.perf_counter() - t < 10
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    call.close()  # again: nothing


def untimed(x):
    """``x`` without its wall times (keys ending in ``_s``: solve and build times)."""
    if isinstance(x, dict):
        return {k: untimed(v) for k, v in x.items() if not k.endswith("_s")}
    if isinstance(x, list):
        return [untimed(v) for v in x]
    return x


@pytest.mark.ipopt
def test_the_crowning_optimizers_verification_forks_its_last_cases_with_the_same_numbers(monkeypatch, forking):
    """CrowningOptimizer.solve's verification sweeps: the last cases in a forked process, every
    case's verified TE, corners, peak and path the same as all computed here."""
    import numpy as np

    import gearopt.forking as forking
    from gearopt.gears import Gear, GearPair
    from gearopt.meshing.misalignment import misalignment_cases
    from gearopt.synthesis import CrowningOptimizer, CrowningTarget
    from gearopt.units import ARCMIN, ARCSEC

    calls = []

    class Recorded(ForkedCall):
        def __init__(self, fn):
            super().__init__(fn)
            calls.append(self.forked)

    monkeypatch.setattr(forking, "ForkedCall", Recorded)  # the verification's split_forked forks by it
    pair = GearPair(Gear(z=20, m_n=3, b=20, name="pinion"), Gear(z=40, m_n=3, b=20, name="gear"))
    cases = misalignment_cases(crossing=3 * ARCMIN)  # aligned, +-3': the last one forked
    opt = CrowningOptimizer(pair, CrowningTarget(te_level=8 * ARCSEC), cases=cases, positions=21)
    forked = opt.solve(sensitivities=False).cases
    assert calls == [True]
    monkeypatch.setattr(ForkedCall, "enabled", False)
    here = opt.solve(sensitivities=False).cases
    assert calls == [True, False]
    assert [c.name for c in forked] == [c.name for c in here] == list(cases)
    for a, b in zip(forked, here):
        assert (a.te_level_tca, a.edge_contact, a.corners, a.peak, a.fit_rms, a.transfer_phi1) == \
               (b.te_level_tca, b.edge_contact, b.corners, b.peak, b.fit_rms, b.transfer_phi1)
        np.testing.assert_array_equal(a.te_envelope, b.te_envelope)
        for member in ("pinion", "gear"):
            for x, y in zip(a.path[member], b.path[member]):
                np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(a.result.te, b.result.te)


@pytest.mark.slow
def test_crowning_study_before_and_after_are_the_same_forked_or_not(monkeypatch, forking):
    from gearopt.io.scene import load_scene

    runs = {}
    for enabled in (True, False):
        monkeypatch.setattr(ForkedCall, "enabled", enabled)
        study = load_scene("problems/crowning_spur.toml").build()
        runs[enabled] = study.run().to_dict()
    assert untimed(runs[True]["before"]) == untimed(runs[False]["before"])
    assert untimed(runs[True]["after"]) == untimed(runs[False]["after"])
    assert runs[True]["before"][1]["edge_carries_load"]  # the drive before has edge contact (crossing +3')


def test_the_forking_tests_run_in_a_process_without_other_threads(request):
    """Under pytest-xdist (``make test``) a worker runs threads of its own, so the tests above that
    fork skip there; this runs them in a fresh single-threaded pytest process instead (the slow one
    too where this run selects slow tests), so that CI tests the forked calls."""
    if threading.active_count() == 1 and not THREAD_SKIPS:
        pytest.skip("single-threaded here: the forking tests above ran in this process")
    if not (hasattr(os, "fork") and os.uname().sysname == "Linux" and len(os.sched_getaffinity(0)) >= 2):
        pytest.skip("no fork here (not Linux, or one core)")
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    marks = request.config.getoption("-m") or ""
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider",
                           *(["-m", marks] if marks else []), str(Path(__file__)),
                           "-k", "not without_other_threads"],
                          cwd=root, capture_output=True, text=True, timeout=900)
    last = proc.stdout.splitlines()[-1] if proc.stdout else ""
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "skipped" not in last and " passed" in last, proc.stdout[-1000:]
