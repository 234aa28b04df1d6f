"""The compiled (jit) sweep gives the same contact points as the interpreted one."""

from __future__ import annotations

import math
import shutil
import warnings

import numpy as np
import pytest

from gearopt import ARCMIN, BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment


@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler for jit")
def test_jit_sweep_matches_interpreted():
    rack = BasicRack.iso53("A", a_c=0.002)
    pair = GearPair(Gear(z=19, m_n=2.0, b=16, rack=rack, a_pl=4e-4, name="pinion"), Gear(z=37, m_n=2.0, b=16, name="gear"))
    mis = Misalignment(crossing=2 * ARCMIN, dE=0.02)
    phi = np.linspace(-math.pi / 19, math.pi / 19, 31)
    ref = TCA(pair).sweep(phi, mis=mis, pairs=(0,))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a silent fallback to the interpreter would hide a broken jit
        jit = TCA(pair, jit=True).sweep(phi, mis=mis, pairs=(0,))
    assert jit.converged.all() and ref.converged.all()
    np.testing.assert_allclose(jit.phi2, ref.phi2, rtol=0, atol=1e-14)
    np.testing.assert_allclose(jit.ellipse_a, ref.ellipse_a, rtol=1e-10)


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler for jit")
def test_small_sweep_compiled_from_a_warm_cache_and_never_waits_for_a_cold_one(tmp_path, monkeypatch):
    """A one-cycle sweep (far below MIN_COLUMNS columns) under jit="auto": on a cold cache it runs
    interpreted and returns while its library compiles in a background thread (the compile is held
    at a gate until the sweep is back); the next sweep, and a new process's first sweep, run
    compiled; all three give the same numbers."""
    import threading

    from gearopt import compile_cache, compile_queue, compiled

    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND", raising=False)
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    monkeypatch.setattr(compile_queue, "pending", {})
    gate, ran = threading.Event(), []
    real = compile_queue.build

    def build(f, path, cc):
        ran.append(threading.current_thread())
        assert gate.wait(300)
        return real(f, path, cc)

    monkeypatch.setattr(compile_queue, "build", build)
    rack = BasicRack.iso53("A", a_c=0.002)
    pair = GearPair(Gear(z=19, m_n=2.0, b=16, rack=rack, a_pl=4e-4, name="pinion"), Gear(z=37, m_n=2.0, b=16, name="gear"))
    mis = Misalignment(crossing=2 * ARCMIN, dE=0.02)
    phi = np.linspace(-math.pi / 19, math.pi / 19, 64)
    tca = TCA(pair)
    cold = tca.sweep(phi, mis=mis)  # would hang at the gate if it compiled in the call
    assert 3 * phi.size < compiled.MIN_COLUMNS
    assert not tca.branch.mapped(3 * phi.size, extra=True).compiled
    gate.set()
    assert compiled.wait_for_background(300)
    assert ran and all(t is not threading.main_thread() for t in ran)
    warm = tca.sweep(phi, mis=mis)
    assert tca.branch.mapped(3 * phi.size, extra=True).compiled
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})  # a new process: the libraries are on disk
    monkeypatch.setattr(compile_queue, "build", lambda *a: pytest.fail("a warm cache compiles nothing"))
    tca2 = TCA(pair)
    new = tca2.sweep(phi, mis=mis)
    assert tca2.branch.mapped(3 * phi.size, extra=True).compiled
    assert cold.converged.any()
    for other in (warm, new):
        assert np.array_equal(other.converged, cold.converged)
        np.testing.assert_allclose(other.phi2, cold.phi2, rtol=0, atol=1e-14)
        np.testing.assert_allclose(other.te_envelope, cold.te_envelope, rtol=0, atol=1e-14)
        np.testing.assert_allclose(other.ellipse_a, cold.ellipse_a, rtol=1e-10)


def test_anchor_memo_gives_the_numbers_of_a_new_solve(tmp_path, monkeypatch):
    """The anchor solve is kept per exact inputs: sweeps alternating between two misalignments and
    two crownings give, bit for bit, what a new TCA gives for each (no stale anchor)."""
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "0")
    rack = BasicRack.iso53("A", a_c=0.002)
    pair = GearPair(Gear(z=19, m_n=2.0, b=16, rack=rack, a_pl=4e-4, name="pinion"), Gear(z=37, m_n=2.0, b=16, name="gear"))
    phi = np.linspace(-math.pi / 19, math.pi / 19, 9)
    tca = TCA(pair, jit=False)
    p1 = tca.pinion.p0.copy()
    p1b = p1.copy()
    p1b[tca.pinion.param_names.index("a_c")] *= 1.5
    cases = [(Misalignment(crossing=2 * ARCMIN), p1), (Misalignment(dE=0.03), p1), (Misalignment(crossing=2 * ARCMIN), p1b)]
    first = [tca.sweep(phi, p1=p, mis=m, pairs=(0,)) for m, p in cases]
    again = [tca.sweep(phi, p1=p, mis=m, pairs=(0,)) for m, p in cases[::-1]][::-1]
    for (m, p), a, b in zip(cases, first, again):
        new = TCA(pair, jit=False).sweep(phi, p1=p, mis=m, pairs=(0,))  # a TCA that has solved nothing
        for r in (a, b):
            assert np.array_equal(r.phi2, new.phi2, equal_nan=True)
            assert np.array_equal(r.te_envelope, new.te_envelope, equal_nan=True)
    assert not np.array_equal(first[0].phi2, first[1].phi2) and not np.array_equal(first[0].phi2, first[2].phi2)
