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

from gearopt import ARCMIN, BasicRack, Gear, GearPair, compiled
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
def test_extra_compiler_flags_give_the_same_numbers_bit_for_bit(tmp_path):
    """FLAGS (inlined runtime helpers, sqrt without errno) reorder no floating-point operation: the
    library of a Newton column gives the numbers of one built with the plain -O2 flags."""
    f = _newton_column()
    assert set(compiled.BASE_FLAGS) < set(compiled.FLAGS)
    libs = []
    for flags in (compiled.FLAGS, compiled.BASE_FLAGS):
        path = tmp_path / f"ovh_col-{len(libs)}.so"
        saved = compiled.FLAGS
        compiled.FLAGS = flags  # _compile_into compiles with FLAGS first
        try:
            assert compiled._build(f, path, compiled.compiler()[0]) is None
        finally:
            compiled.FLAGS = saved
        libs.append(ca.external("ovh_col", str(path)))
    rng = np.random.default_rng(3)
    W0, P = rng.normal(size=(2, 400)), rng.uniform(0.5, 2.0, size=(2, 400))
    a = [np.asarray(v) for v in libs[0].map(400)(W0, P)]
    b = [np.asarray(v) for v in libs[1].map(400)(W0, P)]
    for x, y in zip(a, b):
        assert np.array_equal(x, y, equal_nan=True)


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
