"""What a small compiled sweep does around its compiled columns (issue 43): the compiler flags give
the same library numbers, the reused call buffers hand out independent arrays, the memoised
parameter columns, misalignment checks and anchor derivatives give what a fresh computation gives,
and the small helpers equal what they replace."""

from __future__ import annotations

import math
import threading

import casadi as ca
import numpy as np
import pytest

from gearopt import ARCMIN, BasicRack, Gear, GearPair, compile_cache, compile_queue, compiled
from gearopt.errors import GeometryError
from gearopt.meshing.solver import sorted_unique
from gearopt.meshing.tca import TCA, Misalignment

needs_cc = pytest.mark.skipif(not compiled.available(), reason="no C compiler")


@pytest.fixture(scope="module")
def crowned():
    g1 = Gear(z=20, m_n=3.0, b=20.0, rack=BasicRack.iso53("A", a_c=0.002), a_pl=0.0004, name="pinion")
    g2 = Gear(z=40, m_n=3.0, b=20.0, name="gear")
    return TCA(GearPair(g1, g2), jit=False)


def _newton_column() -> ca.Function:
    """A small column Function of the sweeps' kind: fast_newton from a guess, then outputs at the root."""
    w, p = ca.SX.sym("w", 2), ca.SX.sym("p", 2)
    G = ca.Function("ovh_g", [w, p], [ca.vertcat(ca.sin(w[0]) + w[1] ** 3 - p[0], ca.exp(w[0] * p[1]) - w[1] - 1)])
    rf = ca.rootfinder("ovh_rf", "fast_newton", G, {"error_on_fail": False, "abstol": 1e-15, "abstolStep": 1e-9,
                                                    "max_iter": 30})
    w0, pp = ca.MX.sym("w0", 2), ca.MX.sym("pp", 2)
    ws = rf(w0, pp)
    return ca.Function("ovh_col", [w0, pp], [ws, ca.norm_2(G(ws, pp)), ca.cos(ws[0]) * ws[1]])


@needs_cc
def test_extra_compiler_flags_give_the_same_numbers_bit_for_bit(tmp_path, monkeypatch):
    """FLAGS (inlined runtime helpers, sqrt without errno) and LARGE_FLAGS (no partial-redundancy
    elimination or code hoisting) reorder no floating-point operation: the library of a Newton
    column built with each gives the numbers of one built with the plain -O2 flags; the compiler is
    called with the flags asked for (LARGE_FLAGS for a source of LARGE_SOURCE bytes or more)."""
    import subprocess

    f = _newton_column()
    assert set(compiled.BASE_FLAGS) < set(compiled.FLAGS)
    assert not set(compile_cache.LARGE_FLAGS) & set(compiled.FLAGS)
    seen = []
    run = subprocess.run

    def spy(cmd, *a, **k):
        seen.append(tuple(cmd))
        return run(cmd, *a, **k)

    monkeypatch.setattr(subprocess, "run", spy)
    libs = []
    for flags, large in ((compiled.FLAGS, 0), (compiled.FLAGS, 10 ** 9), (compiled.BASE_FLAGS, 10 ** 9)):
        path = tmp_path / f"ovh_col-{len(libs)}.so"
        monkeypatch.setattr(compile_cache, "FLAGS", flags)  # compile_into compiles with compile_cache.flag_sets
        monkeypatch.setattr(compile_cache, "LARGE_SOURCE", large)  # 0: every source is large
        seen.clear()
        assert compile_queue.build(f, path, compiled.compiler()[0]) is None
        used = set(seen[0])
        assert set(flags) <= used and (set(compile_cache.LARGE_FLAGS) <= used) == (large == 0)
        libs.append(ca.external("ovh_col", str(path)))
    rng = np.random.default_rng(3)
    W0, P = rng.normal(size=(2, 400)), rng.uniform(0.5, 2.0, size=(2, 400))
    ref = [np.asarray(v) for v in libs[-1].map(400)(W0, P)]
    for lib in libs[:-1]:
        for x, y in zip((np.asarray(v) for v in lib.map(400)(W0, P)), ref):
            assert np.array_equal(x, y, equal_nan=True)


def test_large_sources_get_the_large_flags_and_the_rule_is_in_the_key():
    """flag_sets: LARGE_FLAGS from LARGE_SOURCE bytes on, BASE_FLAGS last; the key's flags name the rule."""
    c = compile_cache
    assert c.flag_sets(c.LARGE_SOURCE - 1) == (c.FLAGS, c.BASE_FLAGS)
    assert c.flag_sets(c.LARGE_SOURCE) == (c.FLAGS + c.LARGE_FLAGS, c.BASE_FLAGS)
    assert all(x in c.flags_key() for x in c.FLAGS + c.LARGE_FLAGS) and str(c.LARGE_SOURCE) in c.flags_key()


def test_reused_buffer_hands_out_independent_arrays_and_serves_threads():
    """compiled.call reuses one buffer per Function: two calls' outputs are separate arrays (changing
    one changes neither the other nor the next call), and calls from several threads at once (one
    waits for the buffer or takes its own) all get their own numbers."""
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p")
    f = ca.Function("ovh_buf", [x, p], [x * p, ca.sum1(x) + p]).map(50)
    X = np.arange(150.0).reshape(3, 50, order="F")
    a = compiled.call(f, X, np.full((1, 50), 2.0))
    b = compiled.call(f, X, np.full((1, 50), 3.0))
    assert np.array_equal(a[0], 2 * X) and np.array_equal(b[0], 3 * X)
    a[0][:] = -1.0
    assert np.array_equal(b[0], 3 * X) and np.array_equal(compiled.call(f, X, np.full((1, 50), 2.0))[0], 2 * X)
    out, errors = {}, []

    def work(k):
        try:
            for _ in range(50):
                r = compiled.call(f, X + k, np.full((1, 50), float(k)))
                if not (np.array_equal(r[0], (X + k) * k) and np.allclose(r[1], (X + k).sum(axis=0) + k)):
                    errors.append(k)
            out[k] = True
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(repr(e))

    threads = [threading.Thread(target=work, args=(k,)) for k in range(1, 5)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(out) == 4


def test_map_sizes_unpadded_up_to_eight():
    assert [compiled.map_size(k) for k in range(1, 9)] == list(range(1, 9))
    assert compiled.map_size(9) == 10 and compiled.map_size(192) == 192


def test_sorted_unique_equals_numpy_unique():
    rng = np.random.default_rng(0)
    for n in (0, 1, 2, 7, 40):
        x = rng.integers(0, 12, n)
        assert np.array_equal(sorted_unique(x), np.unique(x)) and sorted_unique(x).dtype == np.unique(x).dtype


def test_parameter_columns_equal_a_fresh_pack(crowned):
    """TCA.prm keeps the column of each design and misalignment: what it returns equals the layout's
    pack, -0.0 is not taken for 0.0, and changing a returned matrix changes no later one."""
    t = crowned
    phi = np.linspace(-0.2, 0.2, 7)
    p1 = t.pinion.p0.copy()
    for mis in (Misalignment(crossing=3 * ARCMIN, dE=0.05), Misalignment(crossing=-0.0), Misalignment()):
        ref = t.layout.pack(phi, {"pinion": p1, "gear": t.gear.p0, "mis": mis, "z_section": 0.0})
        got = t.prm(phi, p1, None, mis)
        assert np.array_equal(got, ref) and np.array_equal(np.signbit(got), np.signbit(ref))
        got[:] = 7.0
        assert np.array_equal(t.prm(phi, p1, None, mis), ref)
    p1[1] += 1e-4  # another design: another column
    assert not np.array_equal(t.prm(phi, p1), t.prm(phi))


def test_misalignment_check_is_remembered_only_when_it_passes(crowned):
    """A misalignment that jams the teeth is refused at every sweep (only checks that passed are
    remembered); an accepted one is accepted again."""
    phi = np.linspace(-0.05, 0.05, 5)
    bad = Misalignment(dE=-5.0)
    for _ in range(2):
        with pytest.raises(GeometryError, match="dE"):
            crowned.sweep(phi, mis=bad)
    ok = Misalignment(crossing=2 * ARCMIN)
    crowned.sweep(phi, mis=ok, pairs=(0,))
    assert ok in crowned._checked_mis and bad not in crowned._checked_mis


def test_repeated_sweep_equals_the_first_and_a_new_tca(crowned):
    """A repeated sweep (the anchor, its dw/dphi1 and the parameter columns memoised) gives the
    first sweep's numbers bit for bit, and so does a new TCA that memoised nothing."""
    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    phi = np.linspace(-math.pi / 20, math.pi / 20, 24)
    first = crowned.sweep(phi, mis=mis)
    again = crowned.sweep(phi, mis=mis)
    fresh = TCA(crowned.pair, jit=False).sweep(phi, mis=mis)
    for r in (again, fresh):
        for name in ("phi2", "te", "te_envelope", "u1", "z2", "r1", "rf", "kappa1", "ellipse_a", "ellipse_dir2",
                     "residual", "on_surface", "converged", "driving"):
            assert np.array_equal(getattr(r, name), getattr(first, name), equal_nan=True), name


@needs_cc
def test_map_library_gives_the_numbers_of_casadis_map_bit_for_bit(tmp_path, monkeypatch):
    """A compiled ColumnMap called again and again with one size compiles that size's map as a
    library of its own (the loop over the columns in C) in the background and switches to it once
    it is done: the same numbers bit for bit as CasADi's map of the column's library; a new
    ColumnMap finds it in the cache at its first call; its pickled state drops the background job."""
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND", raising=False)
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    monkeypatch.setattr(compile_queue, "pending", {})
    f = _newton_column()
    rng = np.random.default_rng(5)
    W0, P = rng.normal(size=(2, 40)), rng.uniform(0.5, 2.0, size=(2, 40))
    ref = [np.asarray(v) for v in compiled.compile_function(f).map(40)(W0, P)]
    assert compiled.map_library(f, 40) is None  # nothing compiled for the map yet
    lib_f = compiled.compile_function(f)
    assert not compiled.mapped(f, 40, True).own_maps  # other maps than the TCA's: CasADi's map of the library
    cm = compiled.ColumnMap(f, lambda m: compiled.map_columns(lib_f, m), compiled=True, own_maps=True)
    for _ in range(compiled.MAP_LIBRARY_CALLS):
        out = compiled.call(cm, W0, P)
        assert cm._maps[(40, 1)].f.class_name() == "Map"  # CasADi's map of the column's library
    assert cm._open and cm.__getstate__()["_open"] == {}  # (a thread does not pickle)
    assert compiled.wait_for_background(120)
    out = compiled.call(cm, W0, P)  # the first call after the compile: the map's own library
    assert cm._maps[(40, 1)].f.class_name() != "Map"
    lib = compiled.map_library(f, 40)
    assert lib is not None and cm._maps[(40, 1)].f is lib and not cm._open
    for x, y in zip(ref, out):
        assert np.array_equal(x, y, equal_nan=True)
    fresh = compiled.ColumnMap(f, lambda m: compiled.map_columns(lib_f, m), compiled=True, own_maps=True)  # (a new process)
    for x, y in zip(ref, compiled.call(fresh, W0, P)):
        assert np.array_equal(x, y, equal_nan=True)
    assert fresh._maps[(40, 1)].f is lib


def test_map_library_not_compiled_for_a_one_off_size_or_without_background(tmp_path, monkeypatch):
    """Fewer calls of a size than MAP_LIBRARY_CALLS, or the background compile off, start no compile;
    looking the map's library up builds no map (its key derives from the column's)."""
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    monkeypatch.setattr(compile_queue, "pending", {})
    built = []
    monkeypatch.setattr(compile_queue, "build", lambda f, path, cc: built.append(f.name()) or "not here")
    col = _newton_column()
    cm = compiled.ColumnMap(col, lambda m: col.map(m), compiled=True, own_maps=True)
    W0, P = np.zeros((2, 3)), np.ones((2, 3))
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND", raising=False)
    for _ in range(compiled.MAP_LIBRARY_CALLS - 1):
        compiled.call(cm, W0, P)
    assert compiled.wait_for_background(60) and built == [] and cm._open
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "0")
    cm2 = compiled.ColumnMap(col, lambda m: col.map(m), compiled=True, own_maps=True)
    for _ in range(compiled.MAP_LIBRARY_CALLS + 2):
        compiled.call(cm2, W0, P)
    assert compiled.wait_for_background(60) and built == [] and not cm2._open  # looked once, then settled
    if compiled.available():
        path = compiled.map_library_path(col, 3)
        assert path.name.startswith("map3_ovh_col-") and path.parent == compiled.library_path(col).parent
        assert path != compiled.map_library_path(col, 4)


@needs_cc
def test_repeated_sweep_checks_its_arguments_once_and_looks_up_no_library(crowned, monkeypatch):
    """A repeated compiled sweep checks its arguments once (the anchor solve of the same arguments
    returns the remembered solution without checking them again) and looks up no library path
    (the compiled maps are settled after the first few calls)."""
    from gearopt.meshing import solver
    from gearopt.meshing import tca as tca_mod

    tca = TCA(crowned.pair, jit=True)
    mis = Misalignment(crossing=3 * ARCMIN, dE=0.05)
    phi = np.linspace(-0.1, 0.1, 9)
    for _ in range(compiled.MAP_LIBRARY_CALLS + 1):
        first = tca.sweep(phi, mis=mis)
    assert tca.branch.mapped(27, extra=True).compiled and tca.branch.mapped(27, extra=True).own_maps
    calls = []
    real = tca_mod.check_sweep_args

    def counting(*a, **kw):
        calls.append(a[1])
        return real(*a, **kw)

    monkeypatch.setattr(tca_mod, "check_sweep_args", counting)
    for name in ("select", "cached_function", "mapped"):
        monkeypatch.setattr(solver, name, lambda *a, **kw: pytest.fail("a library looked up in a repeated sweep"))
    monkeypatch.setattr(compiled, "library_path", lambda *a, **kw: pytest.fail("a cache path looked up"))
    for _ in range(2):
        again = tca.sweep(phi, mis=mis)
    assert len(calls) == 2  # once per sweep (twice before: the anchor's solve_point checked them again)
    for name in ("phi2", "te", "te_envelope", "r1", "kappa2", "ellipse_b", "ellipse_dir1", "converged"):
        assert np.array_equal(getattr(again, name), getattr(first, name), equal_nan=True), name


def test_remembered_anchor_equals_a_fresh_solve_and_bad_input_still_fails(crowned):
    """solve_point's remembered solutions (by the exact arguments) equal a new TCA's solve; a new
    design is solved anew; bad arguments are refused whatever was solved before."""
    from gearopt.errors import ArgumentError

    mis = Misalignment(crossing=2 * ARCMIN)
    p1 = crowned.pinion.p0.copy()
    a = crowned.solve_point(0.0, None, p1, None, mis)
    b = crowned.solve_point(0.0, None, p1, None, mis)
    fresh = TCA(crowned.pair, jit=False).solve_point(0.0, None, p1, None, mis)
    assert np.array_equal(a, fresh) and np.array_equal(b, fresh)
    b[:] = 0.0  # the caller's copy
    assert np.array_equal(crowned.solve_point(0.0, None, p1, None, mis), fresh)
    p1[1] *= 1.5  # another design
    other = crowned.solve_point(0.0, None, p1, None, mis)
    assert not np.array_equal(other, fresh)
    assert np.array_equal(other, TCA(crowned.pair, jit=False).solve_point(0.0, None, p1, None, mis))
    with pytest.raises(ArgumentError, match="phi1"):
        crowned.solve_point(float("nan"), None, p1, None, mis)
    with pytest.raises(ArgumentError, match="p1"):
        crowned.solve_point(0.0, None, np.r_[p1, 1.0], None, mis)


def test_result_arrays_are_the_sweep_outputs_at_the_solved_points(crowned):
    """The result's points, curvatures and ellipse axes are the contact Function's outputs at each
    accepted column, in the documented layout ((K, N, 3) points, (K, N, 2) curvatures, (K, N, 2, 3)
    [major, minor] directions), NaN where not accepted."""
    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    phi = np.linspace(-math.pi / 20, math.pi / 20, 16)
    pairs = (-1, 0, 1)
    r = crowned.sweep(phi, mis=mis, pairs=pairs)
    assert (~r.converged).any() and r.converged.any()
    f = crowned.sweep_outputs
    z1 = crowned.pair.pinion.z
    for k, pk in enumerate(pairs):
        for j in range(phi.size):
            if not r.converged[k, j]:
                for name in ("r1", "rf", "kappa1", "ellipse_a", "ellipse_dir2", "ellipse_dir1"):
                    assert np.isnan(getattr(r, name)[k, j]).all(), name
                continue
            w = np.array([r.u1[k, j], r.z1[k, j], r.u2[k, j], r.z2[k, j], r.phi2[k, j]])
            w[4] = (r.phi2[k, j] - 2 * math.pi * pk / crowned.pair.gear.z) * crowned.scale2
            prm = crowned.prm([phi[j] - 2 * math.pi * pk / z1], mis=mis)[:, 0]
            out = dict(zip(f.name_out(), (np.asarray(v) for v in f(w, prm))))
            tol = {"rtol": 1e-9, "atol": 1e-9}
            np.testing.assert_allclose(r.r1[k, j], out["r1"].ravel(), **tol)
            np.testing.assert_allclose(r.r2[k, j], out["r2"].ravel(), **tol)
            np.testing.assert_allclose(r.rf[k, j], out["rf1"].ravel(), **tol)
            np.testing.assert_allclose(r.kappa1[k, j], out["kappa1"].ravel(), **tol)
            np.testing.assert_allclose(r.kappa2[k, j], out["kappa2"].ravel(), **tol)
            lam = out["lam"].ravel()
            np.testing.assert_allclose([r.ellipse_a[k, j], r.ellipse_b[k, j]], np.sqrt(2 * r.delta / lam), rtol=1e-9)
            np.testing.assert_allclose(r.ellipse_dir2[k, j], out["dir2"].T, **tol)  # rows: major, minor
            np.testing.assert_allclose(r.ellipse_dir1[k, j], out["dir1"].T, **tol)
            np.testing.assert_allclose(r.radius1[k, j], np.hypot(*out["r1"].ravel()[:2]), rtol=1e-12)


def _branch_point(tca: TCA, phi1: float, mis: Misalignment) -> tuple[np.ndarray, np.ndarray]:
    """The solved point of the branch at ``phi1`` (line-search Newton from the linear prediction)."""
    w_a = tca.solve_point(0.0, None, None, None, mis)
    prm_a = tca.prm([0.0], mis=mis)[:, 0]
    prm = tca.prm([phi1], mis=mis)[:, 0]
    return tca.branch.newton(tca.branch.predict(w_a, prm_a, [phi1])[:, 0], prm), prm


def test_taylor_terms_are_the_derivatives_of_the_solved_branch(crowned):
    """d1, d2, d3 of taylor_function at a solved point equal central differences of solutions of
    the contact equations at neighbouring angles (solved independently, line-search Newton)."""
    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    h = 2e-3
    W = np.column_stack([_branch_point(crowned, k * h, mis)[0] for k in (-2, -1, 0, 1, 2)])
    d = [np.asarray(v).ravel() for v in crowned.branch.taylor_function()(W[:, 2], crowned.prm([0.0], mis=mis)[:, 0])]
    fd1 = (W[:, 3] - W[:, 1]) / (2 * h)
    fd2 = (W[:, 3] - 2 * W[:, 2] + W[:, 1]) / h ** 2
    fd3 = (W[:, 4] - 2 * W[:, 3] + 2 * W[:, 1] - W[:, 0]) / (2 * h ** 3)
    scale = lambda v: np.max(np.abs(v)) + 1e-9  # noqa: E731
    assert np.max(np.abs(d[0] - fd1)) < 1e-4 * scale(fd1)
    assert np.max(np.abs(d[1] - fd2)) < 1e-3 * scale(fd2)
    assert np.max(np.abs(d[2] - fd3)) < 2e-2 * scale(fd3)


def test_taylor_guesses_are_closer_and_the_sweep_the_same(crowned):
    """A coarse sweep (one cycle of three pairs: too few positions for the knots) starts from the
    cubic Taylor guesses: at +-1.5 pitches from the anchor they are far closer to the solutions than
    the linear prediction, and the sweep accepts the same points with the same numbers to round-off
    as from the linear guesses."""
    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    br = crowned.branch
    w_a = crowned.solve_point(0.0, None, None, None, mis)
    prm_a = crowned.prm([0.0], mis=mis)[:, 0]
    far = [0.1, -0.15, 0.2]
    sol = np.column_stack([_branch_point(crowned, v, mis)[0] for v in far])
    err_lin = np.max(np.abs(br.predict(w_a, prm_a, far) - sol), axis=0)
    err_tay = np.max(np.abs(br.predict_taylor(w_a, prm_a, far) - sol), axis=0)
    assert np.all(err_tay < 0.05 * err_lin)
    phi = np.linspace(-math.pi / 20, math.pi / 20, 64)
    saved = br.predict_taylor
    used = []
    br.predict_taylor = lambda *args: used.append(1) or saved(*args)
    try:
        a = crowned.sweep(phi, mis=mis)
    finally:
        br.predict_taylor = saved
    assert used  # the coarse sweep's guesses
    br.predict_taylor = br.predict  # the linear guesses
    try:
        b = crowned.sweep(phi, mis=mis)
    finally:
        br.predict_taylor = saved
    assert np.array_equal(a.converged, b.converged) and np.array_equal(a.on_surface, b.on_surface)
    ok = a.converged
    assert np.max(np.abs(a.phi2[ok] - b.phi2[ok])) < 1e-14
    assert np.max(np.abs(a.u1[ok] - b.u1[ok])) < 1e-11 and np.max(np.abs(a.z1[ok] - b.z1[ok])) < 1e-11


def test_taylor_prediction_falls_back_to_linear_when_not_finite(crowned):
    """Derivatives that are not finite (a singular Jacobian) give the linear prediction."""
    br = crowned.branch
    w = np.full(5, np.nan)
    prm = crowned.prm([0.0])[:, 0]
    assert np.array_equal(br.predict_taylor(w, prm, [0.1, 0.2]), br.predict(w, prm, [0.1, 0.2]), equal_nan=True)


@needs_cc
def test_derived_library_found_without_building_and_keyed_by_its_construction(tmp_path, monkeypatch):
    """A Function built from another by a named construction (the TCA's Taylor terms from its
    residual) compiles in the background into a path keyed by the base's key and the tag: found
    there afterwards with the interpreted numbers bit for bit, not under another tag; with the
    background compiles off nothing compiles."""
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND", raising=False)
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    monkeypatch.setattr(compile_queue, "pending", {})
    base = _newton_column()
    w, p = ca.SX.sym("w", 2), ca.SX.sym("p", 2)
    f = ca.Function("ovh_derived", [w, p], [ca.sin(w[0]) * p[1] + ca.exp(w[1] - p[0])])
    assert compiled.derived_library(base, "ovh_derived", "t/1") is None
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "0")
    assert compiled.compile_derived(base, f, "t/1") is None
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND")
    assert compiled.compile_derived(base, f, "t/1") is not None
    assert compiled.wait_for_background(120)
    g = compiled.derived_library(base, "ovh_derived", "t/1")
    assert g is not None and compiled.derived_library(base, "ovh_derived", "t/2") is None
    x, q = np.array([0.3, -0.2]), np.array([1.1, 0.7])
    assert np.array_equal(np.asarray(g(x, q)), np.asarray(f(x, q)))
    path = compiled.derived_library_path(base, "ovh_derived", "t/1")
    assert path.exists() and path.parent == compiled.library_path(base).parent


def test_taylor_guesses_only_from_taylor_min_columns(crowned, monkeypatch):
    """A coarse sweep of fewer than TAYLOR_MIN_COLUMNS columns keeps the linear prediction; from
    TAYLOR_MIN_COLUMNS on it starts from the Taylor guesses."""
    from gearopt.meshing import solver

    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    br = crowned.branch
    used = []
    saved = br.predict_taylor
    monkeypatch.setattr(br, "predict_taylor", lambda *a: used.append(1) or saved(*a))
    n = solver.TAYLOR_MIN_COLUMNS - 1
    phi = np.linspace(-0.15, 0.15, n)  # one pair: n columns, 17 knots (coarse: more than n / 4)
    crowned.sweep(phi, mis=mis, pairs=(0,))
    assert not used
    crowned.sweep(np.linspace(-0.15, 0.15, n + 1), mis=mis, pairs=(0,))
    assert used
