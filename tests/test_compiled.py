"""The compiled engine (gearopt.compiled): C code generated once per graph, cached on disk across
processes, safe under concurrent writers, equal to the interpreted Functions, and a clear fallback
without a compiler."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
import warnings

import casadi as ca
import numpy as np
import pytest

from gearopt import compile_cache, compiled
from gearopt.errors import ArgumentError, OptionError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA

pytestmark = pytest.mark.skipif(not compiled.available(), reason="no C compiler")


def _fun(a: float) -> ca.Function:
    x = ca.SX.sym("x", 2)
    p = ca.SX.sym("p")
    return ca.Function("cmp_test", [x, p], [ca.vertcat(ca.sin(a * x[0]) * p, ca.exp(x[1]) + a)], ["x", "p"], ["y"])


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_library_key_is_memoised_per_live_function_object(cache):
    """The cache key (a serialisation of the graph) is computed once per Function object and leaves
    with it; a new Function that finds a dead one's entry under its identity gets its own key."""
    import gc
    import weakref

    f = _fun(1.5)
    path = compiled.library_path(f)
    assert path == compiled.library_path(f) == cache / f"cmp_test-{compiled.cache_key(f)[:24]}.so"
    memo = (id(f), compiled.compiler())
    assert memo in compile_cache._keys
    stale = (weakref.ref(f), compile_cache._keys[memo][1])
    del f
    gc.collect()
    assert memo not in compile_cache._keys  # evicted with its Function
    g = _fun(2.5)
    compile_cache._keys[(id(g), compiled.compiler())] = stale  # as if g took f's identity before the eviction
    assert compiled.library_path(g) == cache / f"cmp_test-{compiled.cache_key(g)[:24]}.so" != path


def test_graph_digest_and_library_key_come_from_one_serialisation(cache, monkeypatch):
    """graph_cache.digest (the key of graphs built from f) and cache_key (the key of f's library)
    serialise f once between them, and are what they were: SHA-256 of the serialisation, and of the
    serialisation, CasADi's version, the compiler and the flags, each followed by a zero byte."""
    import hashlib

    from gearopt import graph_cache

    f = _fun(1.5)
    text = f.serialize()
    calls = []
    orig = ca.Function.serialize
    monkeypatch.setattr(ca.Function, "serialize", lambda self, *a: calls.append(self.name()) or orig(self, *a))
    assert graph_cache.digest(f) == hashlib.sha256(text.encode()).hexdigest()
    want = hashlib.sha256(b"".join(part.encode() + b"\0" for part in (
        text, ca.__version__, compiled.compiler()[1], compile_cache.flags_key()))).hexdigest()
    assert compile_cache.cache_key(f) == want
    assert compiled.library_path(f) == cache / f"cmp_test-{want[:24]}.so"
    assert graph_cache.digest(f) == hashlib.sha256(text.encode()).hexdigest()
    assert calls == ["cmp_test"]
    # another graph: its own digest and key
    g = _fun(2.5)
    assert graph_cache.digest(g) != graph_cache.digest(f) and compile_cache.cache_key(g) != want


def test_compiled_equals_interpreted_and_keys_differ(cache):
    f, g = _fun(1.5), _fun(2.5)
    cf, cg = compiled.compile_function(f), compiled.compile_function(g)
    X, P = np.random.default_rng(0).normal(size=(2, 50)), np.linspace(-1, 1, 50)[None, :]
    # two graphs with the same name: different libraries, each its own numbers
    assert compiled.library_path(f) != compiled.library_path(g)
    for a, b in ((f, cf), (g, cg)):
        np.testing.assert_allclose(np.asarray(b.map(50)(X, P)), np.asarray(a.map(50)(X, P)), rtol=1e-15, atol=1e-15)
    assert len(list(cache.glob("cmp_test-*.so"))) == 2
    assert not list(cache.glob(".build-*"))  # no scratch directory left behind


_CHILD = textwrap.dedent("""
    import json, math, sys, time
    import numpy as np
    from gearopt import compiled
    from gearopt.gears import BasicRack, Gear, GearPair
    from gearopt.meshing.tca import TCA
    pair = GearPair(Gear(z=19, m_n=2.0, b=16, a_pl=4e-4, rack=BasicRack.iso53("A", a_c=0.002)), Gear(z=37, m_n=2.0, b=16))
    tca = TCA(pair, jit=True)
    phi = np.linspace(-math.pi / 19, math.pi / 19, 9)
    t0 = time.perf_counter()
    sw = tca.sweep(phi, pairs=(0,))
    print(json.dumps({"counts": compiled.counts(), "phi2": sw.phi2.ravel().tolist(), "t": time.perf_counter() - t0}))
""")


def _child(env):
    out = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_cache_reused_by_a_new_process_and_concurrent_writers(cache):
    env = dict(os.environ, GEAROPT_CACHE_DIR=str(cache))
    # four processes compile the same graphs at once: every one succeeds, one library per graph
    procs = [subprocess.Popen([sys.executable, "-c", _CHILD], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(4)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1][-1000:] for o in outs]
    res = [json.loads(o[0].strip().splitlines()[-1]) for o in outs]
    libs = sorted(p.name.split("-")[0] for p in cache.glob("*.so"))
    # the sweep's column (solve, checks and contact quantities in one pass), and any other, once each
    assert libs == sorted(set(libs)) and "tca_onex" in libs
    assert not list(cache.glob(".build-*"))
    # a new process with the warm cache compiles nothing and gets the same numbers, bit for bit
    warm = _child(env)
    assert warm["counts"]["built"] == 0 and warm["counts"]["loaded"] == len(libs)
    for r in res:
        assert r["phi2"] == warm["phi2"]


def test_truncated_library_is_rebuilt(cache):
    f = _fun(0.7)
    path = compiled.library_path(f)
    path.parent.mkdir(parents=True)
    path.write_bytes(b"not a shared library")
    g = compiled.compile_function(f)
    assert g is not None
    np.testing.assert_allclose(np.asarray(g([0.3, 0.1], 2.0)), np.asarray(f([0.3, 0.1], 2.0)), rtol=1e-15)


def test_without_compiler_one_warning_and_interpreted(cache, monkeypatch):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    monkeypatch.setattr(compile_cache, "_noted", set())
    assert not compiled.available()
    with pytest.warns(RuntimeWarning, match="no C compiler"):
        assert compiled.compile_function(_fun(1.0)) is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the note is given once per process
        assert compiled.compile_function(_fun(2.0)) is None
    assert not compiled.use_compiled("auto", 10**6)
    pair = GearPair(Gear(z=19, m_n=2.0, b=16, a_pl=4e-4, rack=BasicRack.iso53("A", a_c=0.002)), Gear(z=37, m_n=2.0, b=16))
    phi = np.linspace(-math.pi / 19, math.pi / 19, 5)
    sw = TCA(pair, jit=True).sweep(phi, pairs=(0,))  # falls back to the interpreter
    assert sw.converged.all()
    assert not cache.exists() or not list(cache.glob("*.so"))


def test_auto_policy():
    if not compiled.available():
        pytest.skip("no compiler")
    assert compiled.use_compiled(True, 1) and not compiled.use_compiled(False, 10**6)
    assert compiled.use_compiled("auto", compiled.MIN_COLUMNS)
    assert not compiled.use_compiled("auto", compiled.MIN_COLUMNS - 1)


def test_loaded_tca_slices_compiled_equal_interpreted():
    """A loaded-TCA slice set (thousands of columns: compiled under jit="auto") equals the
    interpreted one: same active slices, TE to round-off."""
    from gearopt.ltca.engine import LTCA
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.units import ARCMIN

    pair = GearPair(Gear(z=18, m_n=2.5, b=18.0, a_pl=5e-4, rack=BasicRack.iso53("A", a_c=0.002)),
                    Gear(z=31, m_n=2.5, b=18.0))
    mis = Misalignment(crossing=2 * ARCMIN)
    out = {}
    for jit in ("auto", False):
        L = LTCA(pair, tca=TCA(pair, jit=jit))
        S = L.slices(L.mesh_cycle(24), mis=mis)
        assert S.z.size >= compiled.MIN_COLUMNS
        out[jit] = (S, L.solve(150.0, slices=S).results[0])
    (Sa, ra), (Sb, rb) = out["auto"], out[False]
    assert np.array_equal(Sa.active, Sb.active) and np.array_equal(Sa.edge, Sb.edge)
    np.testing.assert_allclose(Sa.te[Sa.active], Sb.te[Sb.active], rtol=0, atol=1e-13)
    np.testing.assert_allclose(ra.te_loaded_arcsec, rb.te_loaded_arcsec, rtol=0, atol=1e-6)


def test_nlpsol_compiled_once_cached_and_equal(tmp_path, monkeypatch):
    """An NLP through gearopt.compiled.nlpsol(jit=True): compiled on the first build, loaded from the
    disk cache on the next (new key lookups, no compilation), and IPOPT finds the same optimum as
    the interpreted solver; the optimum is checked against the KKT conditions of the constrained
    Rosenbrock problem min (1-x)^2 + 100 (y-x^2)^2 s.t. x + y <= 0.75 (active constraint, gradient
    parallel to (1, 1))."""
    import casadi as ca
    import numpy as np

    from gearopt import compiled

    if not compiled.available():
        pytest.skip("no C compiler")
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    x = ca.SX.sym("x", 2)
    nlp = {"x": x, "f": (1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2, "g": x[0] + x[1]}
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-12}
    args = {"x0": [0.0, 0.0], "lbg": -np.inf, "ubg": 0.75}
    ref = compiled.nlpsol("rosen", "ipopt", nlp, opts)(**args)
    before = compiled.counts()
    s1 = compiled.nlpsol("rosen", "ipopt", nlp, opts, jit=True)
    assert compiled.counts()["built"] == before["built"] + 1
    assert len(list(tmp_path.glob("rosen_nlp-*.so"))) == 1
    out = s1(**args)
    np.testing.assert_allclose(np.array(out["x"]).ravel(), np.array(ref["x"]).ravel(), atol=1e-10)
    # the constraint is active: x + y = 0.75 and the gradient of f is parallel to (1, 1)
    xs = np.array(out["x"]).ravel()
    assert xs.sum() == pytest.approx(0.75, abs=1e-7)  # IPOPT relaxes bounds by 1e-8
    gx = -2 * (1 - xs[0]) - 400 * xs[0] * (xs[1] - xs[0] ** 2)
    gy = 200 * (xs[1] - xs[0] ** 2)
    assert gx == pytest.approx(gy, rel=1e-6) and gx < 0
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})  # a new process: the library is on disk
    monkeypatch.setattr(compiled, "_build_nlp", lambda *a: pytest.fail("a warm cache generates nothing"))
    compiled.nlpsol("rosen", "ipopt", nlp, opts, jit=True)
    after = compiled.counts()
    assert after["built"] == before["built"] + 1 and after["loaded"] == before["loaded"] + 1


def _matfun() -> ca.Function:
    # a column Function with a matrix output (2 x 2 per column) and two inputs
    x = ca.SX.sym("x", 3)
    p = ca.SX.sym("p", 2)
    M = ca.vertcat(ca.horzcat(x[0] * p[0], ca.sin(x[1])), ca.horzcat(ca.exp(x[2] * p[1]), x[0] - x[2]))
    return ca.Function("colmap_test", [x, p], [ca.sum1(x) * p[0], M], ["x", "p"], ["s", "M"])


@pytest.mark.parametrize("n", [1, 7, 300, compiled.CHUNK, 2 * compiled.CHUNK + 37])
def test_column_map_equals_plain_map(cache, n):
    """ColumnMap evaluates any number of columns through chunk maps of a few sizes (padding the
    last chunk), compiled or interpreted, with matrix outputs: equal to CasADi's own map of n."""
    f = _matfun()
    rng = np.random.default_rng(n)
    X, P = rng.normal(size=(3, n)), rng.normal(size=(2, n))
    ref = [np.asarray(v) for v in f.map(n)(X, P)]
    for jit in (False, True):
        cm = compiled.mapped(f, n, jit)
        out = cm(X, P)
        assert [o.shape for o in out] == [r.shape for r in ref]
        for o, r in zip(out, ref):
            np.testing.assert_allclose(o, r, rtol=1e-15, atol=1e-15)
        assert cm.name_out() == ["s", "M"]
    with pytest.raises(ArgumentError, match="input p"):
        compiled.mapped(f, n, False)(X, P[:, :-1] if n > 1 else np.zeros((3, 1)))


def test_threads_split_columns_bit_identical(cache):
    """A compiled map split over threads gives the same numbers bit for bit as one thread (the
    columns are independent); the thread count is a process setting (GEAROPT_THREADS, set_threads)."""
    f = _matfun()
    n = 4 * compiled.MIN_PER_THREAD + 5
    rng = np.random.default_rng(3)
    X, P = rng.normal(size=(3, n)), rng.normal(size=(2, n))
    try:
        compiled.set_threads(1)
        one = compiled.mapped(f, n, True)(X, P)
        compiled.set_threads(2)
        cm = compiled.mapped(f, n, True)
        two = cm(X, P)
        assert any("thread" in sig.f.class_name().lower() for sig in cm._maps.values())
    finally:
        compiled.set_threads(None)
    for a, b in zip(one, two):
        assert np.array_equal(a, b)
    for bad in (0, 1.5, True):
        with pytest.raises(OptionError, match="threads"):
            compiled.set_threads(bad)


def test_threads_setting_from_environment(monkeypatch):
    monkeypatch.setenv("GEAROPT_THREADS", "3")
    assert compiled.threads() == 3
    monkeypatch.setenv("GEAROPT_THREADS", "many")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert compiled.threads() == 1
    monkeypatch.delenv("GEAROPT_THREADS")
    assert compiled.threads() >= 1


def test_call_buffer_equals_casadi_call_and_checks_shapes():
    f = _matfun()
    X, P = np.arange(3.0).reshape(3, 1) + 0.5, np.array([0.3, -0.2])
    ref = [np.asarray(v) for v in f(X, P)]
    out = compiled.call(f, X, P)  # (2,) for a (2, 1) input: as many values as entries
    for o, r in zip(out, ref):
        np.testing.assert_allclose(o, r, rtol=1e-15, atol=0)
    with pytest.raises(ArgumentError, match="input x"):
        compiled.call(f, np.zeros(4), P)
    with pytest.raises(ArgumentError, match="takes 2 inputs"):
        compiled.call(f, X)


def test_one_cache_root_for_compiled_libraries_and_influence_coefficients(monkeypatch, tmp_path):
    """GEAROPT_CACHE is the root of both disk caches; GEAROPT_CACHE_DIR overrides the compiled one;
    without either, $XDG_CACHE_HOME/gearopt."""
    from gearopt.fea import influence
    monkeypatch.delenv("GEAROPT_CACHE_DIR", raising=False)
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "root"))
    assert compiled.cache_dir() == tmp_path / "root" / "compiled"
    assert influence.cache_dir() == tmp_path / "root" / "influence"
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "libs"))
    assert compiled.cache_dir() == tmp_path / "libs"
    assert influence.cache_dir() == tmp_path / "root" / "influence"
    monkeypatch.delenv("GEAROPT_CACHE")
    monkeypatch.delenv("GEAROPT_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compiled.cache_dir() == tmp_path / "xdg" / "gearopt" / "compiled"
    assert influence.cache_dir() == tmp_path / "xdg" / "gearopt" / "influence"


def test_an_interpreted_column_map_evaluates_a_large_call_unpadded():
    """An interpreted ColumnMap evaluates k columns on a map of exactly k when map_size(k) would pad
    EXACT_PADDING columns or more (539 -> 640: 101 columns interpreted in vain); with little padding
    (121 -> 128), and compiled, it keeps the few sizes; the outputs are the columns' own, bit for bit
    those of the padded map."""
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p")
    f = ca.Function("pad_test", [x, p], [ca.sin(x * p) + p ** 2, ca.dot(x, x) * ca.exp(-p)])
    rng = np.random.default_rng(5)
    X, P = rng.normal(size=(2, 539)), rng.normal(size=(1, 539))
    sizes = []
    got = compiled.ColumnMap(f, lambda m: sizes.append(m) or f.map(m))(X, P)
    assert sizes == [539]
    ref = compiled.ColumnMap(f, lambda m: sizes.append(m) or f.map(m), compiled=True, own_maps=True)(X, P)  # padded
    assert sizes == [539, 640]
    for a, b in zip(got, ref):
        assert np.array_equal(a, b)
    compiled.ColumnMap(f, lambda m: sizes.append(m) or f.map(m))(X[:, :121], P[:, :121])
    assert sizes[-1] == 128


def test_a_compiled_column_map_splits_a_call_instead_of_padding_it():
    """A compiled ColumnMap without maps of its own evaluates k columns as the largest map size below k
    and the rest where map_size(k) would pad SPLIT_PADDING columns or more (the loaded TCA's slices:
    1067 -> 1024 + 48, not 1280; 3179 -> 2048 + 1024 + 112); the outputs are bit for bit those of one
    padded map, and a call with little padding (121 -> 128) stays one call."""
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p")
    f = ca.Function("split_test", [x, p], [ca.sin(x * p) + p ** 2, ca.dot(x, x) * ca.exp(-p)])
    rng = np.random.default_rng(7)
    for n, want in ((1067, [1024, 48]), (539, [512, 28]), (3179, [2048, 1024, 112]), (121, [128])):
        X, P = rng.normal(size=(2, n)), rng.normal(size=(1, n))
        sizes = []
        got = compiled.ColumnMap(f, lambda m: sizes.append(m) or f.map(m), compiled=True)(X, P)
        assert sizes == want
        ref = compiled.ColumnMap(f, lambda m: f.map(m), compiled=True, own_maps=True)(X, P)  # one padded map
        for a, b in zip(got, ref):
            assert a.shape == b.shape == (a.shape[0], n) and np.array_equal(a, b)
    assert [compiled.map_floor(k) for k in (1, 8, 9, 10, 11, 539, 1067, 2048)] == [1, 8, 8, 10, 10, 512, 1024, 2048]
