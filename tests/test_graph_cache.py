"""gearopt.graph_cache: a Branch's CSE graphs built once per residual graph, in the process and on disk,
the same Functions bit for bit as built."""

from __future__ import annotations

import math

import numpy as np

import gearopt.graph_cache as gc
import gearopt.meshing.solver as solver
from gearopt.compiled import no_background
from gearopt.gears import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.meshing.tca import TCA

DEG = math.pi / 180


def _pair(beta=15.0):
    return GearPair(Gear(z=19, m_n=3.0, b=24, beta=beta * DEG, hand="right", name="pinion",
                         modifications=Microgeometry(C_beta=0.010)),
                    Gear(z=37, m_n=3.0, b=24, beta=beta * DEG, hand="left", name="gear"))


def _run(pair):
    """(serialised one column, serialised column with extras, a sweep's TE and contact points)"""
    tca = TCA(pair, jit=False)
    r = tca.sweep(np.linspace(-0.12, 0.12, 9))
    return tca.branch.one.serialize(), tca.branch.one_x.serialize(), r.te, r.rf, r.residual


def test_branch_graphs_are_built_once_and_read_back_as_built(tmp_path, monkeypatch):
    """Built (cache off), built and written, found in the process, read from disk in a "new process":
    the same column Functions (so the same compiled-library keys) and the same sweep bit for bit; a
    different pair builds its own; ``no_background`` (gearopt check) writes nothing."""
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(gc, "_graphs", {})
    pair = _pair()
    # the construction without the cache (each graph as built, serialised and read back: what the cache keeps)
    monkeypatch.setattr(solver, "built_once",
                        lambda name, bases, tag, build: __import__("casadi").Function.deserialize(build().serialize()))
    ref = _run(pair)
    monkeypatch.undo()
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(gc, "_graphs", {})

    def same(got):
        assert got[0] == ref[0] and got[1] == ref[1]
        for a, b in zip(got[2:], ref[2:]):
            assert np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)

    c0 = gc.counts()
    same(_run(pair))  # built: jac, post, postx
    c1 = gc.counts()
    assert c1["built"] - c0["built"] == 3 and c1["memo"] == c0["memo"] and c1["disk"] == c0["disk"]
    files = sorted((tmp_path / "cache" / "graphs").glob("*.casadi.z"))
    assert len(files) == 3
    same(_run(pair))  # this process's
    c2 = gc.counts()
    assert c2["memo"] - c1["memo"] == 3 and c2["built"] == c1["built"]
    monkeypatch.setattr(gc, "_graphs", {})  # a new process
    same(_run(pair))  # the disk's
    c3 = gc.counts()
    assert c3["disk"] - c2["disk"] == 3 and c3["built"] == c2["built"]
    # another residual graph: its own graphs (the column with extras, postx, on first use only);
    # within no_background none is written
    monkeypatch.setattr(gc, "_graphs", {})
    with no_background():
        other = TCA(_pair(beta=12.0), jit=False)
        assert gc.counts()["built"] - c3["built"] == 2
        assert other.branch.one_x is other.branch.one_x
    assert gc.counts()["built"] - c3["built"] == 3
    assert sorted((tmp_path / "cache" / "graphs").glob("*")) == files


def test_a_corrupt_or_foreign_cache_file_is_rebuilt(tmp_path, monkeypatch):
    """A truncated file, or one holding another graph, under a graph's key: built again (and rewritten)."""
    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(gc, "_graphs", {})
    import casadi as ca

    x = ca.SX.sym("x", 2)
    base = ca.Function("base", [x], [ca.sin(x[0]) * x[1]])
    e = base(x)
    make = lambda: ca.Function("derived", [x], [ca.jacobian(e, x), e], {"cse": True})  # noqa: E731
    f = gc.built_once("derived", (base,), "t1", make)
    (path,) = (tmp_path / "cache" / "graphs").glob("*.casadi.z")
    assert np.array_equal(np.asarray(f([0.3, 2.0])[0]), np.asarray(make()([0.3, 2.0])[0]))
    for bad in (path.read_bytes()[:100], __import__("zlib").compress(base.serialize().encode())):
        path.write_bytes(bad)
        monkeypatch.setattr(gc, "_graphs", {})
        n = gc.counts()["built"]
        g = gc.built_once("derived", (base,), "t1", make)
        assert g.name() == "derived" and gc.counts()["built"] == n + 1
        assert g.serialize() == f.serialize()
    # another construction tag: another graph
    n = gc.counts()["built"]
    gc.built_once("derived", (base,), "t2", make)
    assert gc.counts()["built"] == n + 1


def test_eliminated_computes_each_repeated_operation_once_with_the_same_numbers():
    """graph_cache.eliminated: a graph that builds the same subexpression twice (as separate nodes)
    evaluates it once, with the same outputs bit for bit."""
    import casadi as ca

    x, y = ca.SX.sym("x", 3), ca.SX.sym("y")

    def term():  # a new node each call (the same operations on the same operands)
        return ca.sin(x * y) / (1 + ca.dot(x, x)) + ca.exp(-y) * ca.cos(x)

    f = ca.Function("twice", [x, y], [term() + 2 * term(), term()], ["x", "y"], ["a", "b"])
    g = gc.eliminated(f)
    assert g.name() == f.name() and g.name_in() == f.name_in() and g.name_out() == f.name_out()
    assert g.n_instructions() < 0.6 * f.n_instructions()
    rng = np.random.default_rng(3)
    X, Y = rng.normal(size=(3, 200)), rng.normal(size=(1, 200))
    for a, b in zip(f.map(200)(X, Y), g.map(200)(X, Y)):
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_the_slices_geometry_is_evaluated_with_its_common_subexpressions_eliminated(tmp_path, monkeypatch):
    """LTCA slices evaluate their geometry (points, normals, curvatures, levers) with
    ``SliceSolver.geometry_columns``: the geometry graph with its common subexpressions eliminated,
    under half its instructions, the same numbers bit for bit at the columns a loaded TCA asks for."""
    import gearopt.ltca.slices as slices
    from gearopt import compiled
    from gearopt.ltca.engine import LTCA

    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("GEAROPT_JIT_BACKGROUND", "0")
    monkeypatch.setattr(gc, "_graphs", {})
    calls = []

    def spy(f, n, jit):
        cm = compiled.mapped(f, n, jit)

        def run(W, prm):
            calls.append((f, np.array(W), np.array(prm)))
            return cm(W, prm)
        return run

    monkeypatch.setattr(slices, "mapped", spy)
    L = LTCA(GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_beta=0.010)),
                      Gear(z=40, m_n=3.0, b=20.0)), n_slices=5)
    L.slices(L.mesh_cycle(6))
    s = L.slicer
    g, f = s.geometry_columns(), s.geometry
    assert calls and all(c[0] is g for c in calls)
    assert g.n_instructions() < 0.5 * f.n_instructions() and g.name_out() == f.name_out()
    W, P = np.hstack([c[1] for c in calls]), np.hstack([c[2] for c in calls])
    for a, b in zip(f.map(W.shape[1])(W, P), g.map(W.shape[1])(W, P)):
        assert np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
