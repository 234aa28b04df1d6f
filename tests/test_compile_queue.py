"""Background compiles wait in a queue (gearopt.compiled.compile_slots at a time per process, first
the one whose interpreted stand-in has cost the process the most per byte of source, then the
smallest C source), and a process that ends hands its queued compiles to one detached process:
it never waits for them, each library appears in the cache whole or not at all, and the next process
finds them. The compiler is a wrapper around the real one that logs when each compile starts and
ends and may be held at a gate (a file)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from gearopt import compile_cache, compile_queue, compiled

pytestmark = pytest.mark.skipif(not compiled.available(), reason="no C compiler")


def _logging_cc(tmp_path: Path) -> tuple[Path, Path, Path]:
    """A compiler that appends ``start <source> <time>`` and ``end <source> <time>`` to ``log``, and
    before compiling waits (up to 60 s) for ``gate`` to exist."""
    cc = compiled.compiler()[0]
    gate, log, fake = tmp_path / "gate", tmp_path / "cc.log", tmp_path / "cc"
    fake.write_text(f"""#!/bin/sh
if [ "$1" = "--version" ]; then exec {cc} --version; fi
src=""
for a in "$@"; do case "$a" in *.c) src=$(basename "$a");; esac; done
echo "start $src $(date +%s.%N)" >> {log}
i=0; while [ ! -e {gate} ] && [ $i -lt 1200 ]; do sleep 0.05; i=$((i+1)); done
sleep 0.2
{cc} "$@"; rc=$?
echo "end $src $(date +%s.%N)" >> {log}
exit $rc
""")
    fake.chmod(0o755)
    return fake, gate, log


def _intervals(log: Path) -> list[tuple[str, float, float]]:
    """(source, start, end) of each compile in the log, in the order they started."""
    start, end = {}, {}
    for line in log.read_text().splitlines():
        kind, src, t = line.split()
        (start if kind == "start" else end)[src] = float(t)
    assert set(start) == set(end), "a compile that started never ended"
    return sorted(((s, start[s], end[s]) for s in start), key=lambda x: x[1])


def _fun(name: str, terms: int) -> ca.Function:
    """A Function whose C source grows with ``terms``."""
    x = ca.SX.sym("x")
    return ca.Function(name, [x], [sum(ca.sin((k + 1) * x) / (k + 1) for k in range(terms))], ["x"], ["y"])


def _value(terms: int, x: float) -> float:
    return sum(np.sin((k + 1) * x) / (k + 1) for k in range(terms))


SIZES = {"queue_mid": 60, "queue_big": 400, "queue_small": 5}


@pytest.fixture
def queued_cc(tmp_path, monkeypatch):
    """This process's background compiles through :func:`_logging_cc`'s compiler into an empty cache, one
    compile slot, nothing loaded or pending: ``(gate, log)``."""
    fake, gate, log = _logging_cc(tmp_path)
    monkeypatch.setenv("CC", str(fake))
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("GEAROPT_JIT_BACKGROUND", raising=False)
    monkeypatch.setattr(compile_cache, "loaded_libraries", {})
    monkeypatch.setattr(compile_queue, "pending", {})
    monkeypatch.setattr(compile_queue, "compile_slots", lambda: 1)
    return gate, log


def test_background_compiles_run_one_at_a_time_smallest_first(queued_cc, tmp_path):
    """With one compile slot, three background compiles started at once run one after the other (no
    two compilers at the same time: on two cores the process keeps one to itself), the first one
    queued at once, the others the smallest source first; each library gives the Function's values."""
    gate, log = queued_cc
    gate.touch()
    funs = {name: _fun(name, n) for name, n in SIZES.items()}
    for f in funs.values():
        assert compiled.compile_in_background(f) is not None
    assert compiled.wait_for_background(300)
    runs = _intervals(log)
    assert [r[0] for r in runs][1:] == [n + ".c" for n in sorted(SIZES, key=SIZES.get) if n + ".c" != runs[0][0]]
    for (_, _, end), (_, start, _) in zip(runs, runs[1:]):
        assert start >= end  # one compiler at a time
    for name, f in funs.items():
        g = compiled.cached_function(f)
        assert g is not None and float(g(0.7)) == pytest.approx(_value(SIZES[name], 0.7), rel=1e-13)
    assert not list((tmp_path / "cache").glob(".build-*"))


def test_the_queue_compiles_first_what_its_interpreted_stand_in_costs(queued_cc, monkeypatch):
    """With one compile slot busy (held at the gate), of two queued compiles the one whose Function
    has run interpreted meanwhile (an interpreted ColumnMap of it: its time is noted) goes first,
    though its source is the larger; a map of another evaluation of the column (``stand_in=False``)
    notes nothing."""
    gate, log = queued_cc
    monkeypatch.setattr(compile_queue, "interpreted", {})
    funs = {name: _fun(name, n) for name, n in SIZES.items()}
    assert compiled.compile_in_background(funs["queue_mid"]) is not None
    for _ in range(1200):  # the first compile has started (held at the gate)
        if log.exists():
            break
        time.sleep(0.05)
    for name in ("queue_big", "queue_small"):
        assert compiled.compile_in_background(funs[name]) is not None
    for _ in range(1200):  # both sources written and queued behind it
        if len(compile_queue._queue) == 2:
            break
        time.sleep(0.05)
    assert len(compile_queue._queue) == 2
    x = np.linspace(0.0, 1.0, 64)[None, :]
    other = compiled.ColumnMap(funs["queue_small"], funs["queue_small"].map, stand_in=False)
    assert np.allclose(other(x), [[_value(SIZES["queue_small"], v) for v in x.ravel()]], rtol=1e-13)
    assert not compile_queue.interpreted
    big = compiled.mapped(funs["queue_big"], x.size, jit=False)  # interpreted, as a cache miss runs
    assert np.allclose(big(x), [[_value(SIZES["queue_big"], v) for v in x.ravel()]], rtol=1e-13)
    assert compile_queue.interpreted[str(compiled.library_path(funs["queue_big"]))] > 0.0
    gate.touch()
    assert compiled.wait_for_background(300)
    assert [r[0] for r in _intervals(log)] == ["queue_mid.c", "queue_big.c", "queue_small.c"]


_ENDER = r"""
import sys
import casadi as ca
from gearopt import compiled
for name, terms in (("queue_mid", 60), ("queue_big", 400), ("queue_small", 5)):
    x = ca.SX.sym("x")
    f = ca.Function(name, [x], [sum(ca.sin((k + 1) * x) / (k + 1) for k in range(terms))], ["x"], ["y"])
    assert compiled.compile_in_background(f) is not None
    print(compiled.library_path(f), flush=True)
"""

_FINDER = r"""
import sys
import casadi as ca
from gearopt import compiled
for name, terms in (("queue_mid", 60), ("queue_big", 400), ("queue_small", 5)):
    x = ca.SX.sym("x")
    f = ca.Function(name, [x], [sum(ca.sin((k + 1) * x) / (k + 1) for k in range(terms))], ["x"], ["y"])
    g = compiled.cached_function(f)
    print(name, "missing" if g is None else repr(float(g(0.7))), compiled.counts()["built"], flush=True)
"""


def test_a_process_hands_its_queued_compiles_over_at_exit(tmp_path):
    """A process that ends with three background compiles, the first held at the compiler's gate and
    two queued behind it, ends without waiting; no library is at its path while the compiler is held
    (a half-written one never is: atomic rename); once the gate opens the queued ones are compiled
    after the first, one at a time, the smaller first, and a second process finds all three in the
    cache (loaded, none compiled) with the Functions' values."""
    fake, gate, log = _logging_cc(tmp_path)
    cache = tmp_path / "cache"
    env = dict(os.environ, CC=str(fake), GEAROPT_CACHE_DIR=str(cache), GEAROPT_JIT_BACKGROUND="1")
    p = subprocess.run([sys.executable, "-c", _ENDER], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    libs = [Path(s) for s in p.stdout.split()]
    assert len(libs) == 3 and all(lib.parent == cache for lib in libs)
    # the process has ended: its sources are written (three scratch directories), no library is there
    assert len(list(cache.glob(".build-*/*.c"))) == 3 and not any(lib.exists() for lib in libs)
    for _ in range(400):
        if log.exists():
            break
        time.sleep(0.05)
    assert log.exists()
    gate.touch()
    for _ in range(2400):
        if all(lib.exists() for lib in libs) and not list(cache.glob(".build-*")):
            break
        time.sleep(0.05)
    assert all(lib.exists() for lib in libs) and not list(cache.glob(".build-*"))
    runs = _intervals(log)
    assert len(runs) == 3
    rest = [r[0] for r in runs[1:]]
    assert rest == sorted(rest, key=lambda s: SIZES[s[:-2]])  # after the first: the smaller first
    for (_, _, end), (_, start, _) in zip(runs, runs[1:]):
        assert start >= end
    q = subprocess.run([sys.executable, "-c", _FINDER], env=env, capture_output=True, text=True, timeout=120)
    assert q.returncode == 0, q.stderr
    for line in q.stdout.splitlines():
        name, value, built = line.split()
        assert value != "missing" and built == "0"
        assert float(value) == pytest.approx(_value(SIZES[name], 0.7), rel=1e-13)


def test_a_library_a_large_call_wants_is_compiled_next(queued_cc):
    """A call of MIN_COLUMNS columns or more whose library waits in the queue runs interpreted and
    moves that library to the front: with the first compile held at the gate and a small and a big
    source queued, the big one, wanted by a large call, is compiled second, before the small one."""
    gate, log = queued_cc
    first = _fun("queue_first", 20)
    assert compiled.compile_in_background(first) is not None
    for _ in range(600):  # the first compile holds the slot, at the gate
        if log.exists():
            break
        time.sleep(0.05)
    assert log.exists()
    big, small = _fun("queue_big", SIZES["queue_big"]), _fun("queue_small", SIZES["queue_small"])
    assert compiled.compile_in_background(small) is not None and compiled.compile_in_background(big) is not None
    n = compiled.MIN_COLUMNS
    cm = compiled.mapped(big, n, "auto")
    assert not cm.compiled
    x = np.linspace(-1.0, 1.0, n)[None, :]
    interpreted = cm(x)[0]
    gate.touch()
    assert compiled.wait_for_background(300)
    assert [r[0] for r in _intervals(log)] == ["queue_first.c", "queue_big.c", "queue_small.c"]
    again = compiled.mapped(big, n, "auto")
    assert again.compiled
    np.testing.assert_allclose(again(x)[0], interpreted, rtol=1e-13, atol=1e-15)
