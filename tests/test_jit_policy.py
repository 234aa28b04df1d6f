"""When a mapped call runs compiled under ``jit="auto"`` (gearopt.compiled.select): a library in the
disk cache is used whatever the column count; a cache miss compiles at once only for a call of at
least MIN_COLUMNS columns, a smaller call runs interpreted while the library compiles in a background
thread; threads only where cores are idle. Every test has its own cache directory."""

from __future__ import annotations

import threading

import casadi as ca
import numpy as np
import pytest

from gearopt import compile_cache, compile_queue, compiled

pytestmark = pytest.mark.skipif(not compiled.available(), reason="no C compiler")


def _fun(a: float) -> ca.Function:
    x = ca.SX.sym("x", 2)
    p = ca.SX.sym("p")
    return ca.Function("policy_test", [x, p], [ca.vertcat(ca.sin(a * x[0]) * p, ca.exp(x[1]) + a)], ["x", "p"], ["y"])


@pytest.fixture
def fresh(tmp_path, monkeypatch):
    """An empty cache directory and a process that has loaded no library (as if new)."""
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND", raising=False)
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    monkeypatch.setattr(compile_queue, "pending", {})
    return tmp_path / "cache"


def _gated_build(monkeypatch):
    """Replace the compiler step by one that waits for ``gate`` (so a synchronous compile in the
    caller would hang the test until the timeout) and records the thread it ran in."""
    gate, ran = threading.Event(), []
    real = compile_queue.build

    def build(f, path, cc):
        ran.append(threading.current_thread())
        assert gate.wait(60), "the compile was never released"
        return real(f, path, cc)

    monkeypatch.setattr(compile_queue, "build", build)
    return gate, ran


def test_cached_library_runs_compiled_at_any_size(fresh, monkeypatch):
    f = _fun(1.5)
    assert compiled.compile_function(f) is not None  # warm the cache
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})  # a new process: the library is on disk only
    monkeypatch.setattr(compile_queue, "build", lambda *a: pytest.fail("a warm cache compiles nothing"))
    loaded = compiled.counts()["loaded"]
    for n in (1, 7, 192, 810):
        assert n < compiled.MIN_COLUMNS and not compiled.use_compiled("auto", n)
        cm = compiled.mapped(f, n, "auto")
        assert cm.compiled
        X, P = np.random.default_rng(n).normal(size=(2, n)), np.linspace(-1, 1, n)[None, :]
        np.testing.assert_allclose(cm(X, P), np.asarray(f.map(n)(X, P)), rtol=1e-15, atol=1e-15)
    assert compiled.counts()["loaded"] == loaded + 1  # loaded once, then kept
    assert not compiled.mapped(f, 7, False).compiled  # jit=False: never


def test_small_cache_miss_compiles_in_background_not_in_the_call(fresh, monkeypatch):
    f = _fun(2.5)
    gate, ran = _gated_build(monkeypatch)
    cm = compiled.mapped(f, 64, "auto")  # returns although the compile is held at the gate
    assert not cm.compiled
    X, P = np.random.default_rng(1).normal(size=(2, 64)), np.linspace(-1, 1, 64)[None, :]
    interpreted = cm(X, P)
    assert compiled.select(f, "auto", 64) is None  # still compiling: interpreted again, no second job
    assert not list(fresh.glob("*.so")) and len(compile_queue.pending) == 1
    gate.set()
    assert compiled.wait_for_background(60)
    assert len(ran) == 1 and ran[0] is not threading.main_thread()
    cm2 = compiled.mapped(f, 64, "auto")  # the next call finds the library
    assert cm2.compiled
    np.testing.assert_allclose(cm2(X, P), interpreted, rtol=1e-15, atol=1e-15)
    assert not list(fresh.glob(".build-*"))


def test_large_cache_miss_compiles_at_once(fresh, monkeypatch):
    f = _fun(3.5)
    ran = []
    real = compile_queue.build
    monkeypatch.setattr(compile_queue, "build", lambda *a: ran.append(threading.current_thread()) or real(*a))
    cm = compiled.mapped(f, compiled.MIN_COLUMNS, "auto")
    assert cm.compiled and ran == [threading.main_thread()]


def test_large_call_never_waits_for_its_background_compile(fresh, monkeypatch):
    """A call of MIN_COLUMNS columns or more whose library a background compile of this process is
    building (started by a smaller call before: the loaded TCA's slice geometry) runs interpreted
    instead of waiting for that compile, which may be queued behind others (compiled.compile_slots);
    the call after it lands runs compiled. Held at the gate, a call that waited would get the library
    only when the gate times out (60 s), compiled, not None."""
    f = _fun(5.5)
    gate, ran = _gated_build(monkeypatch)
    assert not compiled.mapped(f, 64, "auto").compiled  # the background compile, held at the gate
    n = compiled.MIN_COLUMNS
    big = compiled.mapped(f, n, "auto")
    assert not big.compiled and len(compile_queue.pending) == 1
    X, P = np.random.default_rng(2).normal(size=(2, n)), np.linspace(-1, 1, n)[None, :]
    interpreted = big(X, P)
    gate.set()
    assert compiled.wait_for_background(60)
    again = compiled.mapped(f, n, "auto")
    assert again.compiled and len(ran) == 1  # the background library, not a second compile
    np.testing.assert_allclose(again(X, P), interpreted, rtol=1e-15, atol=1e-15)


def test_a_very_large_call_waits_for_its_background_compile(fresh, monkeypatch):
    """From WAIT_COLUMNS columns a call whose library compiles in the background waits for it (running
    that many columns interpreted costs more than the compile) and runs compiled, without a second
    compile; below it the call runs interpreted (the test above)."""
    f = _fun(6.5)
    gate, ran = _gated_build(monkeypatch)
    monkeypatch.setattr(compiled, "WAIT_COLUMNS", 2 * compiled.MIN_COLUMNS)
    assert not compiled.mapped(f, 64, "auto").compiled  # the background compile, held at the gate
    threading.Timer(0.5, gate.set).start()  # the gate opens while the large call waits
    n = compiled.WAIT_COLUMNS
    big = compiled.mapped(f, n, "auto")
    assert big.compiled and len(ran) == 1
    X, P = np.random.default_rng(3).normal(size=(2, n)), np.linspace(-1, 1, n)[None, :]
    np.testing.assert_allclose(big(X, P), f.map(n)(X, P).full(), rtol=1e-14, atol=1e-14)


def test_background_compile_can_be_switched_off(fresh, monkeypatch):
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "0")
    monkeypatch.setattr(compile_queue, "build", lambda *a: pytest.fail("no compile with GEAROPT_JIT_BACKGROUND=0"))
    f = _fun(4.5)
    assert not compiled.mapped(f, 64, "auto").compiled
    assert not compile_queue.pending and not list(fresh.glob("*.so"))


def test_threads_only_on_idle_cores(monkeypatch):
    """Default thread count: at most MIN_PER_THREAD columns' worth and the cores the load average
    leaves idle (floor(cpus + 1 - load)); a count that was set is kept."""
    monkeypatch.delenv("GEAROPT_THREADS", raising=False)
    monkeypatch.setattr(compiled.os, "sched_getaffinity", lambda pid: {0, 1, 2, 3}, raising=False)
    big = 100 * compiled.MIN_PER_THREAD
    for load, want in ((0.5, 4), (1.0, 4), (2.2, 2), (3.9, 1), (12.0, 1)):
        monkeypatch.setattr(compiled.os, "getloadavg", lambda load=load: (load, load, load))
        assert compiled.threads_for(big) == want, load
    monkeypatch.setattr(compiled.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert compiled.threads_for(2 * compiled.MIN_PER_THREAD - 1) == 1  # too few columns for two
    assert compiled.threads_for(3 * compiled.MIN_PER_THREAD) == 3
    monkeypatch.setattr(compiled.os, "getloadavg", lambda: (12.0, 12.0, 12.0))
    try:
        compiled.set_threads(3)
        assert compiled.threads_for(big) == 3  # set by the user: kept under any load
    finally:
        compiled.set_threads(None)
    monkeypatch.setenv("GEAROPT_THREADS", "2")
    assert compiled.threads_for(big) == 2


def test_map_sizes_pad_at_most_a_fifth():
    sizes = set()
    for k in range(1, 5000):
        m = compiled.map_size(k)
        sizes.add(m)
        assert m >= k and (m <= 8 or (m - k) / m < 0.2), (k, m)
    assert compiled.map_size(192) == 192 and compiled.map_size(193) == 224
    assert len(sizes) <= 4 * 13  # a few sizes per octave: few maps to build


def test_failed_background_compile_is_not_retried(fresh, monkeypatch):
    """A background compile that fails leaves the calls interpreted, is not started again on every
    call, and touches no warnings filter (those are process-wide)."""
    import warnings

    calls = []
    monkeypatch.setattr(compile_queue, "build", lambda *a: calls.append(a) or "cc exited with 1: broken")
    monkeypatch.setattr(compile_queue, "failed", set())
    f = _fun(5.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        filters = list(warnings.filters)
        for _ in range(3):
            assert not compiled.mapped(f, 16, "auto").compiled
            assert compiled.wait_for_background(60)
        assert warnings.filters == filters
    assert len(calls) == 1 and not list(fresh.glob("*.so"))


def test_no_background_block_writes_nothing(fresh, monkeypatch):
    """Inside compiled.no_background() (what `gearopt check` runs in) a small cache miss starts no
    compile and the cache stays empty; after the block the next call starts one."""
    gate, ran = _gated_build(monkeypatch)
    f = _fun(6.5)
    with compiled.no_background():
        assert not compiled.mapped(f, 16, "auto").compiled
        assert not compile_queue.pending and not fresh.exists()
    assert not compiled.mapped(f, 16, "auto").compiled and len(compile_queue.pending) == 1
    gate.set()
    assert compiled.wait_for_background(60) and len(ran) == 1
