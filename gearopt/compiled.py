"""Compiled CasADi Functions, cached on disk across processes (the fast engine, docs/scale.md).

A Function (one column of a sweep: the rootfinder, its residual and its checks) is written as C by
CasADi's code generator, compiled once by the system C compiler into a shared library and loaded
with :func:`casadi.external`; sweeps map the loaded Function over their columns. The library is
kept in a cache directory under a key (:mod:`gearopt.compile_cache`: the serialised Function, the
CasADi version, the compiler and the flags), so a new process with a warm cache loads it in
milliseconds instead of compiling again (0.2-0.8 s per graph). Writing is safe when several
processes compile the same Function at once: each compiles in its own scratch directory inside the
cache and moves the library into place with an atomic rename.

The three modules of the engine: :mod:`gearopt.compile_cache` (where a library lives, its key, the
compiler, whether anything may be written), :mod:`gearopt.compile_queue` (the background compiles:
the queue, the detached compilers, the hand-over at exit) and this one (the Functions a caller
runs: :func:`compile_function`, :func:`select`, :func:`mapped`, :class:`ColumnMap`, :func:`call`,
:func:`nlpsol`, the threads). This module re-exports the public names of the other two
(:data:`__all__`), the API the library and its users call.

Settings (environment): ``GEAROPT_CACHE``, ``GEAROPT_CACHE_DIR``, ``CC``, ``GEAROPT_JIT_BACKGROUND``
(:mod:`gearopt.compile_cache`) and

``GEAROPT_THREADS``
    Threads over which a compiled mapped call splits its columns (default: the CPUs of the
    process that are idle, :func:`threads_for`; :func:`set_threads` in code).

When a sweep runs compiled (``jit="auto"``, :func:`select`): whenever its library is in the disk
cache, whatever its size (loading costs milliseconds); on a cache miss, a sweep of at least
:data:`MIN_COLUMNS` columns compiles at once (the compile pays within the call), a smaller one runs
interpreted while the library compiles in a background thread (:func:`compile_in_background`), so a
small sweep never waits for the compiler; the next call finds the library (a large call whose library
compiles in the background already runs interpreted too). The background compilers run in detached
processes, :func:`compile_slots` at a time, in the order of :mod:`gearopt.compile_queue` (first what its
interpreted stand-in has cost the process per byte of source); a process that ends hands its
queued compiles to one detached process and never waits for them (:mod:`gearopt.compile_queue`). A map
size that a process calls again and again (:data:`MAP_LIBRARY_CALLS`) gets a library of its own, the
loop over its columns in C (:func:`map_library`, compiled in the background; the same numbers bit for bit).

Without a working compiler :func:`compile_function` returns None after one warning (a one-line
note) per process, and the callers run the interpreted Function.
"""

from __future__ import annotations

import hashlib
import math
import os
import threading
import time
import weakref
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from . import compile_cache, compile_queue
from .compile_cache import (
    BASE_FLAGS,
    FLAGS,
    available,
    background,
    cache_dir,
    cache_key,
    cache_root,
    compiler,
    construction_key,
    counts,
    derived_library_path,
    keyed_by,
    library_path,
    lookup,
    map_library_path,
    no_background,
    note,
    source_tag,
    write_cache_file,
    writes_nothing,
)
from .compile_queue import compile_in_background, compile_slots, wait_for_background
from .errors import ArgumentError, OptionError

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from numpy.typing import ArrayLike

__all__ = [
    # gearopt.compile_cache
    "BASE_FLAGS", "FLAGS", "available", "background", "cache_dir", "cache_key", "cache_root", "compiler", "counts",
    "derived_library_path", "keyed_by", "library_path", "map_library_path", "no_background", "source_tag",
    "write_cache_file", "writes_nothing",
    # gearopt.compile_queue
    "compile_in_background", "compile_slots", "wait_for_background",
    # this module
    "CHUNK", "EXACT_MAPS", "EXACT_PADDING", "MAP_LIBRARY_CALLS", "SPLIT_PADDING", "MIN_COLUMNS", "MIN_PER_THREAD", "WAIT_COLUMNS", "ColumnMap", "cached_function",
    "call", "compile_derived", "compile_function", "derived_library", "idle_cpus", "keyed_library", "map_columns",
    "map_floor", "map_library", "map_size", "mapped", "matrix_columns", "nlpsol", "select", "set_threads", "threads",
    "threads_for", "use_compiled",
]

#: jit="auto", cache miss: mapped solves of at least this many columns compile at once (the compile,
#: 0.2-2.5 s, pays within the call); smaller ones run interpreted while it compiles in the background
MIN_COLUMNS = 1024
# A call of at least this many columns waits for its library's background compile instead of running
# interpreted: about 2 s interpreted at ~30 us per column, longer than a compile of the library.
WAIT_COLUMNS = 65536

MIN_PER_THREAD = 512  #: a compiled mapped call is split over threads only with at least this many columns each
#: a compiled ColumnMap's serial map of one size compiles as a library of its own (ColumnMap._settle) from
#: this call of the size on: a size a process calls again and again (a loop over designs, samples or
#: misalignments, a benchmark), not the few calls of a scene, which would only wait for the compile at exit
MAP_LIBRARY_CALLS = 8

_threads: list[int | None] = [None]


def compile_function(f: ca.Function) -> ca.Function | None:
    """``f`` compiled to C and loaded from the disk cache (compiled on a cache miss).

    Parameters
    ----------
    f : casadi.Function
        A Function that CasADi can generate C code for (SX/MX graphs, ``fast_newton`` rootfinders).

    Returns
    -------
    casadi.Function or None
        The loaded library's Function (same inputs, outputs and names as ``f``), or None when no C
        compiler works or the cache directory cannot be written (one warning per process and
        cause; the caller then runs ``f`` interpreted).
    """
    cc, path, g = lookup(f)
    if cc is None:
        note("cc", "gearopt: no C compiler found (cc, gcc or clang; or set CC): sweeps run interpreted, "
                    "about 10x slower. Install one (e.g. apt-get install gcc) for the compiled engine.")
        return None
    if path is None or g is not None:
        return g
    key = str(path)
    job = compile_queue.pending.get(key)
    if job is not None:  # being compiled in the background: wait for it rather than compile twice
        job.join()
        if key in compile_cache.loaded_libraries:
            return compile_cache.loaded_libraries[key]
    for attempt in (0, 1):
        built = False
        if not path.exists():
            err = compile_queue.build(f, path, cc[0])
            if err is not None:
                note("build", f"gearopt: compiling {f.name()} failed ({err:.200}); it runs interpreted.")
                return None
            built = True
        try:
            g = ca.external(f.name(), str(path))
        except Exception as e:  # noqa: BLE001 - a truncated or foreign library: rebuild it once
            if attempt == 0:
                path.unlink(missing_ok=True)
                continue
            note("load", f"gearopt: loading {path} failed ({e!s:.160}); {f.name()} runs interpreted.")
            return None
        compile_cache.loaded_libraries[key] = g
        compile_cache.count("built" if built else "loaded")
        return g
    return None


def cached_function(f: ca.Function) -> ca.Function | None:
    """``f``'s compiled library if it is in the disk cache (loaded: milliseconds), else None; never
    compiles. None too without a working compiler (the cache key names the compiler)."""
    cc, path, g = lookup(f)
    if cc is None or path is None or g is not None:
        return g
    return _load(f.name(), path)


def _load(name: str, path: Path) -> ca.Function | None:
    """The library at ``path`` (its Function ``name``), loaded once per process; None while it is
    compiled in the background here, when it is not on disk, or cannot be loaded."""
    key = str(path)
    g = compile_cache.loaded_libraries.get(key)
    if g is not None:
        return g
    if key in compile_queue.pending and compile_queue.pending[key].is_alive():
        return None
    if not path.exists():
        return None
    try:
        g = ca.external(name, key)
    except Exception:  # noqa: BLE001 - a truncated or foreign file: compile_function rebuilds it
        return None
    compile_cache.loaded_libraries[key] = g
    compile_cache.count("loaded")
    return g


def keyed_library(name: str, bases: Sequence[ca.Function], tag: str) -> ca.Function | None:
    """The library of the Function ``name`` that :func:`keyed_by` keys by ``bases`` and ``tag``, if it is
    in the disk cache (loaded once per process), else None: the derived graph need not be built when
    its library is there (0.3-0.6 s for the loaded optimiser's); never compiles."""
    h = construction_key(name, bases, tag)
    return None if h is None else _load(name, cache_dir() / f"{name}-{h[:24]}.so")


def select(f: ca.Function, jit: bool | str, n: int) -> ca.Function | None:
    """The compiled Function that evaluates ``n`` columns of ``f`` under the ``jit`` setting, or
    None for the interpreted ``f``.

    ``jit=True``: compiled (compiling on a cache miss; None without a compiler). ``False``: None.
    ``"auto"``: the cached library whenever there is one, whatever ``n``; on a cache miss, compiled
    at once when ``n >= MIN_COLUMNS``, else None while the library compiles in the background
    (:func:`compile_in_background`, unless :func:`background` is off). A call of ``MIN_COLUMNS`` or
    more whose library is already compiling in the background runs interpreted (None) meanwhile,
    unless it has ``WAIT_COLUMNS`` columns or more: then it waits for that library. Compiled and interpreted
    columns agree to round-off (tests/test_tca_jit.py), so which one runs changes no result beyond it.
    """
    if jit is True:
        return compile_function(f)
    if jit != "auto" or not available():
        return None
    g = cached_function(f)
    if g is not None:
        return g
    if n >= MIN_COLUMNS:
        if compile_queue.compiling(f):  # its background compile is under way and first in the queue now
            if n < WAIT_COLUMNS:  # interpreted meanwhile: cheaper than waiting
                return None
            _, path, _ = lookup(f)
            job = compile_queue.pending.get(str(path))
            if job is not None:
                job.join()
            g = cached_function(f)
            if g is not None:
                return g
        return compile_function(f)
    if background():
        compile_in_background(f)
    return None




def threads() -> int:
    """Threads over which a compiled mapped call splits its columns: :func:`set_threads`, else
    ``GEAROPT_THREADS``, else the CPUs this process may run on. The columns are independent, so
    the results are the same bit for bit with any number of threads."""
    if _threads[0] is not None:
        return _threads[0]
    env = os.environ.get("GEAROPT_THREADS", "").strip()
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            note("threads", f"gearopt: GEAROPT_THREADS = {env!r} is not a whole number; one thread is used.")
            return 1
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def threads_for(n: int) -> int:
    """Threads for a compiled mapped call of ``n`` columns: ``min(threads(), n // MIN_PER_THREAD)``
    (a thread's share must outweigh starting it), and, unless the count was set
    (:func:`set_threads`, ``GEAROPT_THREADS``), at most the CPUs idle now: ``floor(cpus + 1 -
    load)`` with ``load`` the 1-minute load average (this process's own running thread counts in it).
    On a machine whose cores are busy a second thread only waits for a core and the call gets slower
    (2 threads 7.0 us vs 1 thread 3.9 us per column measured under load), so the rule keeps one."""
    if n < 2 * MIN_PER_THREAD:  # one thread whatever the setting (asked first: threads() reads the system)
        return 1
    k = min(threads(), n // MIN_PER_THREAD)
    if k <= 1:
        return 1
    if _threads[0] is None and not os.environ.get("GEAROPT_THREADS", "").strip():
        k = min(k, idle_cpus())
    return max(1, k)


def idle_cpus() -> int:
    """CPUs of this process left idle by the others: ``floor(cpus + 1 - load average over 1 min)``,
    between 1 and the CPUs (all of them where the load average is unknown)."""
    try:
        cpus = max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        cpus = max(1, os.cpu_count() or 1)
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        return cpus
    return int(min(cpus, max(1, math.floor(cpus + 1 - load))))


def set_threads(n: int | None) -> None:
    """Threads of the compiled mapped calls of this process (None: back to the default of
    :func:`threads`). The robust-design workers use 1 (one process per core)."""
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise OptionError(f"threads = {n!r}: expected a whole number >= 1 (or None for the default)",
                          param="threads", value=n, valid="an int >= 1 or None")
    _threads[0] = n


CHUNK = 2048  #: ColumnMap: columns per mapped call (maps are built for this and a few smaller sizes)
#: an interpreted ColumnMap evaluates k columns on a map of exactly k when map_size(k) would pad at least
#: this many columns (ColumnMap._size; up to a fifth of a call, each padded column interpreted in vain)
EXACT_PADDING = 32
EXACT_MAPS = 64  #: ... while it holds fewer maps than this (each size it meets is built once)
#: a compiled ColumnMap without maps of its own evaluates k columns as the largest map size below k plus
#: the rest (ColumnMap._pieces) where map_size(k) would pad at least this many columns: a padded column
#: of the loaded TCA's slices costs 6-22 us compiled, a second mapped call about as much as one
SPLIT_PADDING = 8


class ColumnMap:
    """A column Function evaluated on any number of columns, through maps of a few fixed sizes.

    Building a CasADi map of n columns costs about 2.8 us per column (its dense n-column sparsity
    patterns), as much as the compiled solve of the column itself; so the columns are evaluated in
    chunks of :data:`CHUNK` (the last one padded to one of a few sizes, :func:`map_size`), whose maps are
    built once per ColumnMap and process. Inputs and outputs are numpy arrays (:func:`call`).

    Parameters
    ----------
    column : casadi.Function
        The Function of one column (for ``name_out`` and the shapes).
    factory : callable(m) -> casadi.Function
        The column Function mapped over m columns (compiled, threaded or interpreted).
    compiled : bool
        Whether ``factory`` maps a compiled library (what :func:`select` chose; for tests and
        benchmarks: which path a sweep took).
    own_maps : bool
        With ``compiled``: a map size called again and again gets a compiled library of its own
        (:func:`map_library`, from its :data:`MAP_LIBRARY_CALLS`-th call). For the sweeps a user
        repeats (the TCA's); off by default, so that other repeated maps (loaded TCA, optimisers)
        do not compile more in the background.
    stand_in : bool
        Without ``compiled``: whether the maps evaluate what ``column``'s library would (default),
        so that their time counts towards that library's place in the queue of background compiles
        while it compiles (:func:`gearopt.compile_queue.note_interpreted`); False for maps of
        another evaluation of the same column (a line-search Newton instead of its fast Newton).
    """

    def __init__(self, column: ca.Function, factory: Callable[[int], ca.Function], compiled: bool = False,
                 own_maps: bool = False, stand_in: bool = True) -> None:
        self.column, self.factory, self.compiled = column, factory, bool(compiled)
        self.stand_in = bool(stand_in) and not self.compiled
        self.own_maps = bool(own_maps) and self.compiled
        self._maps: dict[tuple, _Signature] = {}
        self._sig = _Signature(column)
        self._open: dict[tuple, list] = {}  # map keys still on CasADi's map: [calls, background compile]

    def name_out(self) -> list[str]:
        return self.column.name_out()

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_maps"], state["_open"] = {}, {}
        return state

    def __setstate__(self, state):
        state.setdefault("_open", {})
        state.setdefault("own_maps", False)
        state.setdefault("stand_in", False)
        self.__dict__.update(state)

    def _size(self, k: int) -> int:
        """Columns of the map that evaluates ``k`` columns: :func:`map_size` (a few sizes, each map
        built once), but ``k`` itself for an interpreted map whose padding would be
        :data:`EXACT_PADDING` columns or more (an interpreted column costs 30-200 us, building a
        map about 3 us per column), while this ColumnMap holds fewer than :data:`EXACT_MAPS` maps.
        Each column is evaluated alone, so the size changes no number."""
        m = map_size(k)
        if not self.compiled and m - k >= EXACT_PADDING and len(self._maps) < EXACT_MAPS:
            return k
        return m

    def _map(self, m: int) -> _Signature:
        key = (m, threads_for(m))
        sig = self._maps.get(key)
        if sig is None or key in self._open:
            sig = self._settle(key, sig)
        return sig

    def _settle(self, key: tuple[int, int], sig: _Signature | None) -> _Signature:
        """The map of ``key = (m, threads)``. With ``own_maps``, a compiled column's serial map of m columns is a library
        of its own once one is in the cache (:func:`map_library`: the loop over the columns in C);
        until then CasADi's map of the column's library, and from the :data:`MAP_LIBRARY_CALLS`-th
        call of that size on (a size that is called again and again) the map's library compiles in
        the background (:func:`compile_in_background`); the first call after it is done switches.
        The numbers are the same bit for bit (tests/test_sweep_overhead.py)."""
        m, k = key
        if not self.own_maps or k > 1:
            sig = self._maps[key] = _Signature(self.factory(m))
            return sig
        state = self._open.get(key)
        if state is None:  # the first call of this size
            g = map_library(self.column, m)
            if g is not None:
                sig = self._maps[key] = _Signature(g)
                return sig
            sig = self._maps[key] = _Signature(self.factory(m))
            self._open[key] = state = [0, None]
        state[0] += 1
        job = state[1]
        if job is None:
            if state[0] >= MAP_LIBRARY_CALLS:
                job = _compile_map(self.column, m) if background() else None
                if job is None:  # on disk already (another process), or no compile here: look once
                    g = map_library(self.column, m)
                    self._open.pop(key, None)
                    if g is not None:
                        sig = self._maps[key] = _Signature(g)
                    return sig
                state[1] = job
            return sig
        if job.is_alive():
            return sig
        self._open.pop(key, None)  # compiled (or failed: then CasADi's map stays)
        g = map_library(self.column, m)
        if g is not None:
            sig = self._maps[key] = _Signature(g)
        return sig

    def __call__(self, *args: ArrayLike) -> np.ndarray | list[np.ndarray]:
        """Outputs (rows, columns * their columns per column) as numpy arrays: a list, or the
        array itself for a one-output Function (like a CasADi call)."""
        res = self.outputs(*args)
        return res[0] if len(res) == 1 else res

    def outputs(self, *args: ArrayLike) -> list[np.ndarray]:
        """The outputs as a list of numpy arrays (rows, columns * their columns per column),
        whatever their number (what :func:`call` returns)."""
        if self.stand_in and compile_queue.pending:  # interpreted while the library compiles: its cost counts
            t = time.perf_counter()
            try:
                return self._outputs(args)
            finally:
                compile_queue.note_interpreted(self.column, time.perf_counter() - t)
        return self._outputs(args)

    def _outputs(self, args: tuple) -> list[np.ndarray]:
        sig = self._sig
        if len(args) != len(sig.shape_in):
            raise ArgumentError(f"{self.column.name()} takes {len(sig.shape_in)} inputs, {len(args)} given",
                                param="args", value=len(args), valid=f"{len(sig.shape_in)} arrays")
        a = [np.asarray(v, dtype=float) for v in args]
        a = [v.reshape(r, -1, order="F") if v.ndim != 2 else v for v, (r, _) in zip(a, sig.shape_in)]
        cin, cout = sig.cols_in, sig.cols_out
        n = a[0].shape[1] // cin[0]
        for i, (v, (r, c)) in enumerate(zip(a, sig.shape_in)):
            if v.shape != (r, c * n):
                name = self.column.name_in(i)
                raise ArgumentError(f"{self.column.name()}: input {name} of {n} columns must be ({r}, {c * n}), "
                                    f"got {v.shape}", param=name, value=v.shape, valid=f"shape ({r}, {c * n})")
        pieces = self._pieces(n)
        if len(pieces) == 1 and n > 0:  # one mapped call: its outputs (new arrays) are the result
            m = pieces[0][1]
            if m == n:
                return self._map(m).run(a)
            sel = np.arange(m)
            sel[n:] = 0  # padding: copies of the first column
            res = self._map(m).run([v[:, matrix_columns(sel, c)] for v, c in zip(a, cin)])
            return [r[:, :n * c] for r, c in zip(res, cout)]
        outs = [np.empty((r, c * n), order="F") for r, c in sig.shape_out]
        start = 0
        for k, m in pieces:
            if m == k:
                chunk = [v[:, start * c:(start + k) * c] for v, c in zip(a, cin)]
            else:
                sel = np.arange(start, start + m)
                sel[k:] = start  # padding: copies of the chunk's first column
                chunk = [v[:, matrix_columns(sel, c)] for v, c in zip(a, cin)]
            res = self._map(m).run(chunk)
            for o, r, c in zip(outs, res, cout):
                o[:, start * c:(start + k) * c] = r[:, :k * c]
            start += k
        return outs

    def _pieces(self, n: int) -> list[tuple[int, int]]:
        """The mapped calls that evaluate ``n`` columns, in order: (columns, map size) each; chunks of
        :data:`CHUNK`, the rest on :meth:`_size`'s map, or, for a compiled ColumnMap without maps of its
        own where that would pad :data:`SPLIT_PADDING` columns or more, on the largest map size
        (:func:`map_size`) below it and the rest likewise (1067 -> 1024 + 48 instead of 1280: the
        padded columns are solved too). Each column is evaluated alone, so the pieces change no
        number."""
        out = []
        while n > 0:
            k = min(CHUNK, n)
            m = CHUNK if k == CHUNK else self._size(k)
            if m - k >= SPLIT_PADDING and self.compiled and not self.own_maps:
                m = k = map_floor(k)
            out.append((k, m))
            n -= k
        return out


def map_library(column: ca.Function, m: int) -> ca.Function | None:
    """The compiled library of ``column.map(m)`` (the loop over m columns in C) if it is in the disk
    cache, else None (never compiles; :class:`ColumnMap` compiles it in the background for a size
    it calls again and again). Its numbers are those of the column's own library mapped by CasADi,
    bit for bit, about 0.3 us less per column (CasADi's map calls the column's library through its
    generic evaluation, once per column). Its key derives from the column's (:func:`map_library_path`),
    so looking it up builds and serialises no map."""
    path = map_library_path(column, m)
    return None if path is None else _load(f"map{m}_{column.name()}", path)


def derived_library(base: ca.Function, name: str, tag: str) -> ca.Function | None:
    """The library of :func:`derived_library_path` if it is in the disk cache (loaded once per
    process), else None; never compiles (:func:`compile_derived`)."""
    path = derived_library_path(base, name, tag)
    return None if path is None else _load(name, path)


def compile_derived(base: ca.Function, f: ca.Function, tag: str) -> threading.Thread | None:
    """Compile ``f`` (built from ``base`` by the construction ``tag``) into
    :func:`derived_library_path` in a background thread, like :func:`compile_in_background`; None
    when it is there already, being compiled, failed before, background compiles are off
    (:func:`background`) or no compiler works."""
    if not background():
        return None
    path = derived_library_path(base, f.name(), tag)
    return None if path is None else compile_queue.start(path, lambda: f, f.name())



def _compile_map(column: ca.Function, m: int) -> threading.Thread | None:
    """Compile ``column.map(m)`` into :func:`map_library_path` in the background (the map is built
    in the compile's thread)."""
    path = map_library_path(column, m)
    if path is None:
        return None
    name = f"map{m}_{column.name()}"

    def make() -> ca.Function:
        f = column.map(m)
        if f.name() != name:  # the name the library is loaded by
            raise RuntimeError(f"CasADi named the map {f.name()}, not {name}")
        return f

    return compile_queue.start(path, make, name)


def map_size(k: int) -> int:
    """Columns of the map that evaluates ``k`` columns (the rest padded): ``k`` itself up to 8,
    else the smallest ``2^j * q / 4`` (q = 5, 6, 7, 8) that holds them, so at most a fifth of a
    call is padding (the padded columns are solved too) while the sizes, whose maps are built once
    each, stay few."""
    if k <= 8:
        return max(k, 1)
    j = (k - 1).bit_length() - 1  # 2^j < k <= 2^(j+1)
    return next(m for m in ((q << j) >> 2 for q in (5, 6, 7, 8)) if m >= k)  # j >= 3: whole numbers


def map_floor(k: int) -> int:
    """The largest :func:`map_size` (a size whose map holds its columns unpadded) not above ``k`` >= 1."""
    if k <= 8:
        return k
    j = k.bit_length() - 1  # 2^j <= k < 2^(j+1)
    return max(m for m in ((q << i) >> 2 for i in (j - 1, j) for q in (5, 6, 7, 8)) if m <= k)


def matrix_columns(idx: np.ndarray, c: int) -> np.ndarray:
    """Matrix columns of the columns ``idx`` of a map whose Function has c columns per column."""
    return idx if c == 1 else (idx[:, None] * c + np.arange(c)).ravel()


def map_columns(g: ca.Function, n: int) -> ca.Function:
    """The compiled column Function ``g`` mapped over ``n`` columns, split over
    :func:`threads_for` ``(n)`` threads (CasADi's thread map) when that is more than one."""
    k = threads_for(n)
    return g.map(n, "thread", k) if k > 1 else g.map(n)


def use_compiled(jit: bool | str, n: int) -> bool:
    """Whether a mapped call of ``n`` columns compiles on a cache miss under the ``jit`` setting
    (True: always; False: never; "auto": from :data:`MIN_COLUMNS` columns on, if a compiler works).
    Whatever this says, ``jit="auto"`` runs a library that is in the cache (:func:`select`)."""
    if jit is True:
        return True
    if jit == "auto":
        return n >= MIN_COLUMNS and available()
    return False


def mapped(f: ca.Function, n: int, jit: bool | str = "auto", n_total: int | None = None) -> ColumnMap:
    """``f`` on columns (:class:`ColumnMap`): the compiled library's maps when :func:`select` gives
    one (for ``n_total`` columns in all, default n), else the interpreted maps. The choice is made
    here, once: a ColumnMap built on a cache miss stays interpreted (build a new one to pick up a
    library compiled since)."""
    g = select(f, jit, n if n_total is None else n_total)
    if g is None:
        return ColumnMap(f, f.map)
    return ColumnMap(f, lambda m: map_columns(g, m), compiled=True)


class _Signature:
    """Shapes and density of a Function's inputs and outputs (queried once: each query crosses
    into CasADi), and the Function's buffer (:meth:`casadi.Function.buffer`) with its input and
    output arrays, made once and reused by every call (the numbers are copied in and out)."""

    def __init__(self, f: ca.Function):
        self.f = f
        self.shape_in = [(f.size1_in(i), f.size2_in(i)) for i in range(f.n_in())]
        self.shape_out = [(f.size1_out(i), f.size2_out(i)) for i in range(f.n_out())]
        self.cols_in = [c for _, c in self.shape_in]
        self.cols_out = [c for _, c in self.shape_out]
        self.dense = all(f.sparsity_in(i).is_dense() for i in range(f.n_in())) and \
            all(f.sparsity_out(i).is_dense() for i in range(f.n_out()))
        ends = np.cumsum([0] + [r * c for r, c in self.shape_out]).tolist()
        #: where each output lies in the block of all outputs: (start, end, columns, rows)
        self._views = [(ends[i], ends[i + 1], c, r) for i, (r, c) in enumerate(self.shape_out)]
        self._size = ends[-1]
        self._buf: tuple | None = None
        self._busy = threading.Lock()

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_buf"], state["_busy"] = None, None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._busy = threading.Lock()

    def _shaped(self, i: int, a, shape: tuple[int, int]) -> np.ndarray:
        a = np.asarray(a, dtype=float)
        if a.shape != shape:
            if a.size == shape[0] * shape[1]:
                a = a.reshape(shape, order="F")
            elif a.size == 1:
                a = np.full(shape, float(a.ravel()[0]))
            else:
                raise ArgumentError(f"{self.f.name()}: input {self.f.name_in(i)} has shape {shape}, got {a.shape}",
                                    param=self.f.name_in(i), value=a.shape, valid=f"shape {shape}")
        return a

    def __call__(self, *args) -> list[np.ndarray]:
        f = self.f
        if len(args) != len(self.shape_in):
            raise ArgumentError(f"{f.name()} takes {len(self.shape_in)} inputs, {len(args)} given",
                                param="args", value=len(args), valid=f"{len(self.shape_in)} arrays")
        if not self.dense:
            return [np.asarray(v) for v in f.call(list(args))]
        return self.run([self._shaped(i, a, shape) for i, (a, shape) in enumerate(zip(args, self.shape_in))])

    def run(self, args: list[np.ndarray]) -> list[np.ndarray]:
        """The call on float arrays of the inputs' shapes (checked by the caller: :meth:`__call__`,
        :meth:`ColumnMap.outputs`)."""
        if not self.dense:
            return [np.asarray(v) for v in self.f.call(list(args))]
        if not self._busy.acquire(blocking=False):  # another thread is in this Function: a buffer of its own
            return self._fresh(args)
        try:
            if self._buf is None:
                buf, trigger = self.f.buffer()
                ins = [np.empty((c, r)) for r, c in self.shape_in]  # CasADi's column-major layout
                block = np.empty(self._size)  # every output, one after the other
                for i, a in enumerate(ins):
                    buf.set_arg(i, memoryview(a))
                for i, (a, b, _, _) in enumerate(self._views):
                    buf.set_res(i, memoryview(block[a:b]))
                self._buf = (buf, trigger, ins, block)
            _, trigger, ins, block = self._buf
            for a, into in zip(args, ins):
                into[...] = a.T
            trigger()
            out = block.copy()  # the outputs: (rows, columns) views of one new array
            return [out[a:b].reshape(c, r).T for a, b, c, r in self._views]
        finally:
            self._busy.release()

    def _fresh(self, args: list[np.ndarray]) -> list[np.ndarray]:
        """The call through a buffer of its own (numbers read and written in place)."""
        buf, trigger = self.f.buffer()
        keep = []
        for i, a in enumerate(args):
            a = np.ascontiguousarray(a.T)  # CasADi's column-major layout
            keep.append(a)
            buf.set_arg(i, memoryview(a))
        outs = []
        for i, (r, c) in enumerate(self.shape_out):
            o = np.empty((c, r))
            outs.append(o)
            buf.set_res(i, memoryview(o))
        trigger()
        return [o.T for o in outs]


def call(f: ca.Function, *args: ArrayLike) -> list[np.ndarray]:
    """``f(*args)`` with numpy arrays in and out, through CasADi's buffer API: the inputs and outputs
    are read and written in place (no conversion to and from ``DM``, which costs about 35 ns per
    double, as much as the compiled solve of a sweep's column).

    Parameters
    ----------
    f : casadi.Function or ColumnMap
        Dense inputs and outputs (a mapped sweep: (rows, columns) each).
    *args : array_like
        One per input: its shape, or a scalar (broadcast), or as many values as the input has
        entries (a vector for a (1, n) or (n, 1) input).

    Returns
    -------
    list of numpy.ndarray
        One (rows, columns) float array per output (Fortran-ordered views).
    """
    if isinstance(f, ColumnMap):
        return f.outputs(*args)
    key = id(f)
    hit = _signatures.get(key)
    if hit is None or hit[0]() is not f:  # shapes queried once per live Function object
        # the callback holds the dict itself: at interpreter exit the module's globals are already None
        hit = _signatures[key] = (weakref.ref(f, lambda _, k=key, d=_signatures: d.pop(k, None)), _Signature(f))
    return hit[1](*args)


_signatures: dict[int, tuple] = {}  # id of a Function -> (weak reference, its _Signature)


def nlpsol(name: str, plugin: str, nlp: dict, opts: dict, jit: bool = False) -> ca.Function:
    """``casadi.nlpsol(name, plugin, nlp, opts)``; with ``jit`` the NLP's Functions (objective,
    constraints and their derivatives, Hessian of the Lagrangian) run as C compiled once and cached
    on disk like the sweeps' columns (:func:`compile_function`).

    The key is the SHA-256 of the NLP (``x``, ``p`` -> ``f``, ``g`` as a serialised Function), the
    plugin and its options, the CasADi version, the compiler and the flags, so a warm cache loads
    the library without generating anything; a cold one generates the source
    (``generate_dependencies``) and compiles it (large NLPs: tens of seconds, e.g. the crowning NLP
    of problems/crowning_spur.toml, a 4 MB source: about 80 s, then 8x faster IPOPT iterations; see
    benchmarks/bench_nlp_cache.py). Without a working compiler: one warning, the interpreted solver.
    ``jit=False`` (the default of the NLP builders) is the interpreted solver.
    """
    solver = ca.nlpsol(name, plugin, nlp, opts)
    if not jit:
        return solver
    cc = compiler()
    if cc is None:
        note("cc", "gearopt: no C compiler found (cc, gcc or clang; or set CC): the NLP runs interpreted.")
        return solver
    ins = [nlp["x"]] + ([nlp["p"]] if "p" in nlp else [])
    outs = [nlp.get("f", 0), nlp.get("g", ca.DM.zeros(0, 1))]
    h = hashlib.sha256(ca.Function(f"{name}_nlp", ins, outs).serialize().encode())
    for part in (plugin, repr(sorted((k, repr(v)) for k, v in opts.items())), ca.__version__, cc[1], compile_cache.flags_key()):
        h.update(b"\0" + part.encode())
    base = cache_dir()
    path = base / f"{name}_nlp-{h.hexdigest()[:24]}.so"
    key = str(path)
    if key in compile_cache.loaded_libraries:
        return compile_cache.loaded_libraries[key]
    built = False
    if not path.exists():
        err = _build_nlp(solver, name, path, cc[0])
        if err is not None:
            note("build", f"gearopt: compiling {name} failed ({err:.200}); it runs interpreted.")
            return solver
        built = True
    try:
        compile_cache.loaded_libraries[key] = ca.nlpsol(name, plugin, str(path), opts)
    except RuntimeError as e:
        note("load", f"gearopt: loading {path} failed ({e!s:.160}); {name} runs interpreted.")
        return solver
    compile_cache.count("built" if built else "loaded")
    return compile_cache.loaded_libraries[key]


def _build_nlp(solver, name: str, path: Path, cc: str) -> str | None:
    """Generate the NLP's Functions and compile them into ``path`` (atomic rename); None on success."""
    def generate(tmp, src):
        cwd = os.getcwd()
        os.chdir(tmp)  # generate_dependencies writes into the working directory
        try:
            solver.generate_dependencies(src, {})
        finally:
            os.chdir(cwd)
    return compile_queue.compile_into(generate, f"{name}_nlp.c", path, cc)
