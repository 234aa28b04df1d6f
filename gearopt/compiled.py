"""Compiled CasADi Functions, cached on disk across processes (the fast engine, docs/scale.md).

A Function (one column of a sweep: the rootfinder, its residual and its checks) is written as C by
CasADi's code generator, compiled once by the system C compiler into a shared library and loaded
with :func:`casadi.external`; sweeps map the loaded Function over their columns. The library is
kept in a cache directory under a key that is the SHA-256 of

* the serialised Function (``Function.serialize()``, deterministic for the same graph),
* the CasADi version, the compiler's identity (``cc --version``) and the flags,

so a new process with a warm cache loads it in milliseconds instead of compiling again
(0.2-0.8 s per graph). Writing is safe when several processes compile the same Function at once:
each compiles in its own scratch directory inside the cache and moves the library into place with
an atomic rename.

Settings (environment):

``GEAROPT_CACHE``
    Root of gearopt's disk caches (default ``$XDG_CACHE_HOME/gearopt``, else ``~/.cache/gearopt``):
    the compiled libraries go to ``compiled/`` in it, the FE influence coefficients to ``influence/``.
``GEAROPT_CACHE_DIR``
    The compiled libraries' directory alone (overrides ``GEAROPT_CACHE``/compiled).
``CC``
    The C compiler (default the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``).
``GEAROPT_THREADS``
    Threads over which a compiled mapped call splits its columns (default: the CPUs of the
    process that are idle, :func:`threads_for`; :func:`set_threads` in code).
``GEAROPT_JIT_BACKGROUND``
    ``0``: under ``jit="auto"`` a sweep below :data:`MIN_COLUMNS` columns whose library is not in
    the cache stays interpreted and compiles nothing (default ``1``: the library is compiled in a
    background thread, and the calls after it is ready run compiled).

When a sweep runs compiled (``jit="auto"``, :func:`select`): whenever its library is in the disk
cache, whatever its size (loading costs milliseconds); on a cache miss, a sweep of at least
:data:`MIN_COLUMNS` columns compiles at once (the compile pays within the call), a smaller one runs
interpreted while the library compiles in a background thread (:func:`compile_in_background`), so a
small sweep never waits for the compiler; the next call finds the library (a large call whose library
compiles in the background already runs interpreted too). The background compilers run in detached
processes, :func:`compile_slots` at a time, the smallest source first; a process that ends hands its
queued compiles to one detached process and never waits for them (:func:`_exit_wait`). A map size that a
process calls again and again (:data:`MAP_LIBRARY_CALLS`) gets a library of its own, the loop over its
columns in C (:func:`map_library`, compiled in the background; the same numbers bit for bit).

Without a working compiler :func:`compile_function` returns None after one warning (a one-line
note) per process, and the callers run the interpreted Function.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import hashlib
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import warnings
import weakref
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from .errors import ArgumentError, OptionError

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Sequence
    from numpy.typing import ArrayLike

#: compiler flags (part of the cache key). Besides -O2: the generated helpers (casadi_qr, casadi_sq, ...)
#: are global symbols, which -fno-semantic-interposition lets gcc inline instead of calling through
#: the PLT, and -fno-math-errno makes sqrt one instruction; neither reorders or contracts floating-point
#: operations, so the results are the same bit for bit (tests/test_compiled_flags.py), about 10 % faster.
FLAGS = ("-O2", "-shared", "-fPIC", "-fno-semantic-interposition", "-fno-math-errno")
BASE_FLAGS = ("-O2", "-shared", "-fPIC")  #: what a compiler that refuses FLAGS is given instead (same key)
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

_loaded: dict[str, ca.Function] = {}
_keys: dict[tuple, tuple] = {}  # (id of a Function, compiler) -> (weak reference, cache key)
_threads: list[int | None] = [None]
_noted: set[str] = set()
_counts = {"built": 0, "loaded": 0}
_pending: dict[str, threading.Thread] = {}  # library path -> its background compile
_quiet = [0]  # open no_background() blocks
_failed: set[str] = set()  # library paths whose background compile failed (not tried again)
_lock = threading.Lock()


def counts() -> dict:
    """Libraries this process compiled (``built``) and loaded from the disk cache (``loaded``)."""
    return dict(_counts)


def cache_root() -> Path:
    """Root of gearopt's disk caches: ``GEAROPT_CACHE``, else ``$XDG_CACHE_HOME/gearopt``, else
    ``~/.cache/gearopt`` (compiled libraries in ``compiled/``, FE influence coefficients in
    ``influence/``, measured flanks' B-splines in ``interpolant/``, the TCA branches' CSE graphs in
    ``graphs/``: :mod:`gearopt.graph_cache`)."""
    env = os.environ.get("GEAROPT_CACHE")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "gearopt"


def cache_dir() -> Path:
    """The directory of the compiled libraries: ``GEAROPT_CACHE_DIR``, else ``compiled/`` in
    :func:`cache_root`."""
    env = os.environ.get("GEAROPT_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    return cache_root() / "compiled"


@functools.lru_cache(maxsize=None)
def _compiler_of(cc_env: str | None, path_env: str | None) -> tuple[str, str] | None:
    names = [cc_env] if cc_env else ["cc", "gcc", "clang"]
    for name in names:
        exe = shutil.which(name)
        if exe is None:
            continue
        try:
            out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=30)
        except (OSError, subprocess.SubprocessError):
            continue
        if out.returncode == 0:
            return exe, out.stdout.strip().splitlines()[0] if out.stdout.strip() else exe
    return None


def compiler() -> tuple[str, str] | None:
    """``(path, version line)`` of the C compiler, or None when none works."""
    return _compiler_of(os.environ.get("CC"), os.environ.get("PATH"))


def available() -> bool:
    """True when a C compiler is present (compiled Functions can be built)."""
    return compiler() is not None


def _note(kind: str, msg: str) -> None:
    if kind not in _noted:
        _noted.add(kind)
        warnings.warn(msg, RuntimeWarning, stacklevel=3)


def cache_key(f: ca.Function) -> str:
    """SHA-256 key of ``f``'s compiled library (the serialised Function, CasADi, compiler, flags)."""
    cc = compiler()
    h = hashlib.sha256()
    for part in (f.serialize(), ca.__version__, cc[1] if cc else "", " ".join(FLAGS)):
        h.update(part.encode() if isinstance(part, str) else bytes(part))
        h.update(b"\0")
    return h.hexdigest()


def library_path(f: ca.Function) -> Path:
    """Where ``f``'s compiled library lives in the cache (whether or not it exists yet). The key is
    computed once per Function object and compiler (serialising a large graph takes ~20 ms)."""
    memo = (id(f), compiler())
    hit = _keys.get(memo)
    if hit is None or hit[0]() is not f:
        # (the entry leaves with its Function: a new one that reuses the id finds none)
        hit = _keys[memo] = (weakref.ref(f, lambda _, m=memo: _keys.pop(m, None)), cache_key(f))
    return cache_dir() / f"{f.name()}-{hit[1][:24]}.so"


def keyed_by(f: ca.Function, bases: Sequence[ca.Function], tag: str) -> ca.Function:
    """Key ``f``'s library (:func:`library_path`) by how it is built instead of by its graph: the
    SHA-256 of the library names of ``bases`` (their own keys: graph, CasADi, compiler, flags), of
    ``f``'s name and of ``tag``, which must name everything else the construction puts into ``f``
    (its code, e.g. :func:`source_tag`, and every number it adds). For derived graphs that are large
    (the loaded optimiser's sensitivities: 10-17 MB serialised, 0.2-0.3 s each, as long as running
    them interpreted); looking their library up then serialises only the bases, which a process
    keys anyway for their own libraries. Returns ``f``; without a compiler, or for a base CasADi
    cannot serialise, or an empty ``tag``, ``f`` stays keyed by its graph."""
    h = _construction_key(f.name(), bases, tag)
    if h is None:
        return f
    memo = (id(f), compiler())
    _keys[memo] = (weakref.ref(f, lambda _, m=memo: _keys.pop(m, None)), h)
    return f


def _construction_key(name: str, bases: Sequence[ca.Function], tag: str) -> str | None:
    """:func:`keyed_by`'s key of a Function ``name`` (None: keyed by its graph)."""
    if compiler() is None or not tag:
        return None
    paths = [_path_or_none(b) for b in bases]
    if any(p is None for p in paths):
        return None
    return hashlib.sha256("\0".join([p.name for p in paths] + [name, tag]).encode()).hexdigest()


def keyed_library(name: str, bases: Sequence[ca.Function], tag: str) -> ca.Function | None:
    """The library of the Function ``name`` that :func:`keyed_by` keys by ``bases`` and ``tag``, if it is
    in the disk cache (loaded once per process), else None: the derived graph need not be built when
    its library is there (0.3-0.6 s for the loaded optimiser's); never compiles."""
    h = _construction_key(name, bases, tag)
    return None if h is None else _load(name, cache_dir() / f"{name}-{h[:24]}.so")


@functools.lru_cache(maxsize=None)
def source_tag(*objects: Callable) -> str:
    """SHA-256 of the source code of ``objects`` (functions, methods, classes), for :func:`keyed_by`'s
    ``tag``: a change of the code that builds a graph gives its library a new key. An empty string
    when a source cannot be read (then the caller keys the graph itself: :func:`keyed_by` is for a
    non-empty tag only)."""
    import inspect

    h = hashlib.sha256()
    for o in objects:
        try:
            h.update(inspect.getsource(o).encode())
        except (OSError, TypeError):
            return ""
    return h.hexdigest()


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
    cc, path, g = _library(f)
    if cc is None:
        _note("cc", "gearopt: no C compiler found (cc, gcc or clang; or set CC): sweeps run interpreted, "
                    "about 10x slower. Install one (e.g. apt-get install gcc) for the compiled engine.")
        return None
    if path is None or g is not None:
        return g
    key = str(path)
    job = _pending.get(key)
    if job is not None:  # being compiled in the background: wait for it rather than compile twice
        job.join()
        if key in _loaded:
            return _loaded[key]
    for attempt in (0, 1):
        built = False
        if not path.exists():
            err = _build(f, path, cc[0])
            if err is not None:
                _note("build", f"gearopt: compiling {f.name()} failed ({err:.200}); it runs interpreted.")
                return None
            built = True
        try:
            g = ca.external(f.name(), str(path))
        except Exception as e:  # noqa: BLE001 - a truncated or foreign library: rebuild it once
            if attempt == 0:
                path.unlink(missing_ok=True)
                continue
            _note("load", f"gearopt: loading {path} failed ({e!s:.160}); {f.name()} runs interpreted.")
            return None
        _loaded[key] = g
        _counts["built" if built else "loaded"] += 1
        return g
    return None


def _path_or_none(f: ca.Function) -> Path | None:
    """:func:`library_path`, or None (one warning) for a Function CasADi cannot serialise."""
    try:
        return library_path(f)
    except Exception as e:  # noqa: BLE001 - a Function CasADi cannot serialise: stay interpreted
        _note("serialize", f"gearopt: {f.name()} cannot be serialised ({e!s:.120}); it runs interpreted.")
        return None


def _library(f: ca.Function) -> tuple[tuple[str, str] | None, Path | None, ca.Function | None]:
    """What :func:`compile_function`, :func:`cached_function` and :func:`compile_in_background` look up
    first: the compiler (None: none works), ``f``'s library path in the cache (None without a compiler
    or for a Function CasADi cannot serialise) and the library if this process loaded it already."""
    cc = compiler()
    if cc is None:
        return None, None, None
    path = _path_or_none(f)
    return cc, path, None if path is None else _loaded.get(str(path))


def cached_function(f: ca.Function) -> ca.Function | None:
    """``f``'s compiled library if it is in the disk cache (loaded: milliseconds), else None; never
    compiles. None too without a working compiler (the cache key names the compiler)."""
    cc, path, g = _library(f)
    if cc is None or path is None or g is not None:
        return g
    return _load(f.name(), path)


def _load(name: str, path: Path) -> ca.Function | None:
    """The library at ``path`` (its Function ``name``), loaded once per process; None while it is
    compiled in the background here, when it is not on disk, or cannot be loaded."""
    key = str(path)
    g = _loaded.get(key)
    if g is not None:
        return g
    if key in _pending and _pending[key].is_alive():
        return None
    if not path.exists():
        return None
    try:
        g = ca.external(name, key)
    except Exception:  # noqa: BLE001 - a truncated or foreign file: compile_function rebuilds it
        return None
    _loaded[key] = g
    _counts["loaded"] += 1
    return g


def background() -> bool:
    """Whether a cache miss of a small ``jit="auto"`` sweep compiles in the background
    (``GEAROPT_JIT_BACKGROUND``, default on; ``0``, ``false``, ``no`` or ``off``: it does not; off
    too inside :func:`no_background`)."""
    if _quiet[0]:
        return False
    return os.environ.get("GEAROPT_JIT_BACKGROUND", "1").strip().lower() not in ("0", "false", "no", "off")


@contextlib.contextmanager
def no_background() -> Iterator[None]:
    """Within the block no background compile starts (small sweeps of a cache miss run interpreted
    and write nothing to the cache): for what must leave the disk untouched (``gearopt check``)."""
    _quiet[0] += 1
    try:
        yield
    finally:
        _quiet[0] -= 1


def writes_nothing() -> bool:
    """True within :func:`no_background`: nothing may be written to gearopt's disk caches (the
    compiled libraries here, the measured-flank splines of :mod:`gearopt.geometry.microgeometry`)."""
    return _quiet[0] > 0


def write_cache_file(path: Path, data: bytes) -> None:
    """Write ``data`` to the cache file ``path`` atomically (a temporary file beside it, renamed: a
    concurrent reader sees no file or a whole one), best effort: nothing within :func:`no_background`,
    and a read-only or full cache only costs the next build of what it would have held."""
    if writes_nothing():  # (gearopt check leaves the disk untouched)
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_bytes(data)
        os.replace(tmp, path)
    except OSError:
        pass


def compile_in_background(f: ca.Function) -> threading.Thread | None:
    """Compile ``f`` into the disk cache in a background thread (one per library and process) and
    return the thread; None when the library is loaded or on disk already, a compile of it is under
    way or failed before in this process, or no compiler works. The compiler runs detached
    (:func:`_compile_into`): a process that ends before it does never waits for it, the compile goes
    on and moves the library into the cache by an atomic rename (the thread, a daemon, only waits for
    it; at exit the process waits only while the C source is being written, :func:`_exit_wait`). The
    caller keeps running ``f`` interpreted; :func:`cached_function` finds the library once it is there
    (in this process or the next)."""
    _, path, g = _library(f)
    if path is None or g is not None:
        return None
    return _start(path, lambda: f, f.name())


def _start(path: Path, make: Callable[[], ca.Function], name: str) -> threading.Thread | None:
    """Compile ``make()`` into ``path`` in a background thread (:func:`compile_in_background`)."""
    key = str(path)
    with _lock:
        if key in _loaded or key in _pending or key in _failed or path.exists():
            return None
        job = threading.Thread(target=_background_job, args=(make, key), name=f"gearopt-compile-{name}",
                               daemon=True)
        _pending[key] = job
    job.start()
    return job


def _background_job(make: Callable[[], ca.Function], key: str) -> None:
    # (no warning from this thread: the warnings filters are process-wide; a failed build is kept in
    # _failed, so it is not tried again in the background, and a synchronous compile reports it)
    _detached.on = True
    try:
        err = _build(make(), Path(key), compiler()[0]) if not Path(key).exists() else None
        if err is None:
            _counts["built"] += 1
        else:
            _failed.add(key)
    except Exception:  # noqa: BLE001 - never let a background compile raise into the interpreter
        _failed.add(key)
    finally:
        with _lock:
            _pending.pop(key, None)


def _compiling(f: ca.Function) -> bool:
    """Whether ``f``'s library is being compiled in the background by this process; if so, it moves
    to the front of the queue of compiles (:func:`_compile_detached`): a call that would have compiled
    it at once (:data:`MIN_COLUMNS` columns or more) runs interpreted meanwhile."""
    _, path, _ = _library(f)
    job = None if path is None else _pending.get(str(path))
    if job is None or not job.is_alive():
        return False
    with _turn:
        _urgent.add(str(path))
        _turn.notify_all()
    return True


def wait_for_background(timeout: float | None = None) -> bool:
    """Wait for this process's background compiles (:func:`compile_in_background`); True when none
    is left running. ``timeout`` [s] per compile (None: no limit)."""
    for job in list(_pending.values()):
        job.join(timeout)
    return not any(j.is_alive() for j in list(_pending.values()))


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
        if _compiling(f):  # its background compile is under way and first in the queue now
            if n < WAIT_COLUMNS:  # interpreted meanwhile: cheaper than waiting
                return None
            _, path, _ = _library(f)
            job = _pending.get(str(path))
            if job is not None:
                job.join()
            g = cached_function(f)
            if g is not None:
                return g
        return compile_function(f)
    if background():
        compile_in_background(f)
    return None


def _build(f: ca.Function, path: Path, cc: str) -> str | None:
    """Generate and compile ``f`` into ``path`` (atomic rename); None on success, else the reason."""
    def generate(tmp, src):
        cg = ca.CodeGenerator(src, {"with_header": False})
        cg.add(f)
        cg.generate(tmp + os.sep)
    return _compile_into(generate, f"{f.name()}.c", path, cc)


def _compile_into(generate, src: str, path: Path, cc: str) -> str | None:
    """``generate(tmp, src)`` writes the C source ``src`` into a scratch directory inside the cache;
    it is compiled and moved into ``path`` by an atomic rename. None on success, else the reason."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = tempfile.mkdtemp(prefix=".build-", dir=path.parent)
    except OSError as e:
        return f"cache directory {path.parent} not writable: {e}"
    if getattr(_detached, "on", False):  # a background compile: the compiler, rename and clean-up detached
        try:
            generate(tmp, src)
        except Exception as e:  # noqa: BLE001 - CasADi's code generator: no scratch directory left behind
            shutil.rmtree(tmp, ignore_errors=True)
            return str(e)
        return _compile_detached(tmp, src, path, cc)  # (the detached process removes tmp)
    try:
        generate(tmp, src)
        so = os.path.join(tmp, "lib.so")
        for flags in (FLAGS, BASE_FLAGS):  # a compiler that does not know the extra flags: without them
            out = subprocess.run([cc, *flags, "-o", so, os.path.join(tmp, src), "-lm"], capture_output=True,
                                 text=True, timeout=3600)
            if out.returncode == 0:
                break
        if out.returncode != 0:
            return f"{cc} exited with {out.returncode}: {out.stderr.strip()[:300]}"
        os.replace(so, path)  # atomic: a concurrent reader sees the old file or the whole new one
        return None
    except (OSError, subprocess.SubprocessError, RuntimeError) as e:
        return str(e)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


#: the detached compile of background jobs (:func:`_compile_detached`): argv[1:] = the jobs (JSON: a list of
#: [scratch directory, C source, library path]), the compiler, the flag sets (JSON), the processes to let
#: end first (JSON: process ids, the compiles running when the process that queued the jobs ended). It
#: compiles them one after the other, each into its scratch directory, moves the library into place by an atomic rename
#: (skipped when another process put it there meanwhile), removes the scratch directory and reports a
#: failure on its standard output (whose reader may be gone: the process that started it may have ended)
_DETACHED_JOB = r"""
import json, os, shutil, subprocess, sys
import time
jobs, cc, flag_sets, before = json.loads(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3]), json.loads(sys.argv[4])
def running(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except OSError:
            pass
        return not os.path.isdir("/proc")
for pid in before:
    while running(pid):
        time.sleep(0.05)
errors = []
for tmp, src, path in jobs:
    so = os.path.join(tmp, "lib.so")
    err = None
    try:
        if not os.path.exists(path):
            for flags in flag_sets:
                out = subprocess.run([cc, *flags, "-o", so, os.path.join(tmp, src), "-lm"], capture_output=True,
                                     text=True, timeout=3600)
                if out.returncode == 0:
                    break
            if out.returncode != 0:
                err = f"{cc} exited with {out.returncode}: {out.stderr.strip()[:300]}"
            else:
                os.replace(so, path)
    except (OSError, subprocess.SubprocessError) as e:
        err = str(e)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if err is not None:
        errors.append(err)
if errors:
    try:
        os.write(1, "; ".join(errors).encode())
    except OSError:
        pass
    sys.exit(1)
"""


def compile_slots() -> int:
    """Detached compiles a process runs at a time: one core less than it may use, at least one.

    A first run starts several background compiles within seconds (the loaded optimiser's: eight,
    the largest a 4 MB source); run all at once, the compilers would share the cores with the
    process that waits for nothing but its own work (on two cores: a third of one core for it with
    five compilers), so they wait in a queue, the smallest source first (:func:`_compile_detached`).
    """
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, cores - 1)


class _Job:
    """A background compile whose C source is written: queued, then handed to a detached process."""

    def __init__(self, tmp: str, src: str, path: Path):
        self.tmp, self.src, self.path = tmp, src, path
        try:
            self.size = os.path.getsize(os.path.join(tmp, src))
        except OSError:
            self.size = 0
        self.handed = False  # given to a detached process (by its own thread, or by _exit_wait's chain)


_queue: list[_Job] = []  # background compiles with their source written, not yet handed to a process
_urgent: set[str] = set()  # library paths a large call waits for (run interpreted meanwhile): compiled first
_running: dict[int, subprocess.Popen] = {}  # detached compiles this process started and waits for, by process id
_turn = threading.Condition(_lock)


def _order(job: _Job) -> tuple[bool, int]:
    """Queue order of the background compiles: those a large call waits for (:func:`_compiling`)
    first, then the smallest source first."""
    return str(job.path) not in _urgent, job.size


def _spawn(jobs: list[_Job], cc: str, after: Sequence[int] = ()) -> subprocess.Popen:
    """Start the detached process that compiles ``jobs`` in this order, once the processes ``after``
    have ended (its own session, no inherited descriptors: the process that starts it may end first,
    neither waits for the other)."""
    try:
        return subprocess.Popen([sys.executable, "-I", "-S", "-c", _DETACHED_JOB,
                                 json.dumps([[j.tmp, j.src, str(j.path)] for j in jobs]), cc,
                                 json.dumps([list(FLAGS), list(BASE_FLAGS)]), json.dumps(list(after))],
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                start_new_session=True, close_fds=True)
    except OSError:
        for j in jobs:
            shutil.rmtree(j.tmp, ignore_errors=True)
        raise


def _compile_detached(tmp: str, src: str, path: Path, cc: str) -> str | None:
    """Compile the C source ``src`` of the scratch directory ``tmp`` into ``path`` in a detached
    process and wait for it while this process runs. The compile waits its turn: at most
    :func:`compile_slots` at a time per process, the queued ones in :func:`_order` (the smallest
    source first, but a library that a large call wants before the others). When the
    process ends, its queued compiles are handed to one detached process that compiles them one after
    the other (:func:`_exit_wait`). The library appears at ``path`` only whole (atomic rename). None on
    success, else the reason."""
    job = _Job(tmp, src, path)
    with _turn:
        _queue.append(job)
        while not job.handed and (len(_running) >= compile_slots() or min(_queue, key=_order) is not job):
            _turn.wait()
        if job.handed:  # the process is ending: _exit_wait gave it to the chain of the queued compiles
            return "handed to the compile of the queued sources at exit"
        _queue.remove(job)
        job.handed = True
        _started.add(str(path))
        try:
            proc = _spawn([job], cc)
        except OSError as e:
            _turn.notify_all()
            return str(e)
        _running[proc.pid] = proc
    try:
        out, _ = proc.communicate()
    finally:
        with _turn:
            _running.pop(proc.pid, None)
            _turn.notify_all()
    if proc.returncode != 0:
        return out.decode(errors="replace").strip() or f"the compile exited with {proc.returncode}"
    return None if path.exists() else f"{path} missing after the compile"


_detached = threading.local()  # .on: this thread's compiles run detached (background jobs)


def _exit_wait(timeout: float = 120.0) -> None:
    """At exit: wait while a background job writes its C source (a fraction of a second: an
    interpreter ending then would leave a half-written scratch directory), not for the compiles;
    then hand the queued compiles to one detached process, which compiles them one after the other
    (the smallest first) after this process has ended."""
    def writing() -> bool:
        with _turn:
            ready = {str(j.path) for j in _queue} | _started
            return any(job.is_alive() and key not in ready for key, job in _pending.items())

    end = time.monotonic() + timeout
    while time.monotonic() < end and writing():
        time.sleep(0.01)
    with _turn:
        jobs = sorted(_queue, key=_order)
        _queue.clear()
        for j in jobs:
            j.handed = True
            _started.add(str(j.path))
        after = list(_running)
        _turn.notify_all()
    cc = compiler()
    if jobs and cc is not None:
        try:
            _spawn(jobs, cc[0], after)  # after the compiles under way: still one at a time
        except OSError:
            pass


_started: set[str] = set()  # library paths whose compile a detached process runs (or ran)


atexit.register(_exit_wait)


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
            _note("threads", f"gearopt: GEAROPT_THREADS = {env!r} is not a whole number; one thread is used.")
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
    """

    def __init__(self, column: ca.Function, factory: Callable[[int], ca.Function], compiled: bool = False,
                 own_maps: bool = False) -> None:
        self.column, self.factory, self.compiled = column, factory, bool(compiled)
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
        self.__dict__.update(state)

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
        if 0 < n <= CHUNK:  # one mapped call: its outputs (new arrays) are the result
            m = map_size(n)
            if m == n:
                return self._map(m).run(a)
            sel = np.arange(m)
            sel[n:] = 0  # padding: copies of the first column
            res = self._map(m).run([v[:, matrix_columns(sel, c)] for v, c in zip(a, cin)])
            return [r[:, :n * c] for r, c in zip(res, cout)]
        outs = [np.empty((r, c * n), order="F") for r, c in sig.shape_out]
        start = 0
        while start < n:
            k = min(CHUNK, n - start)
            m = CHUNK if k == CHUNK else map_size(k)
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


def map_library(column: ca.Function, m: int) -> ca.Function | None:
    """The compiled library of ``column.map(m)`` (the loop over m columns in C) if it is in the disk
    cache, else None (never compiles; :class:`ColumnMap` compiles it in the background for a size
    it calls again and again). Its numbers are those of the column's own library mapped by CasADi,
    bit for bit, about 0.3 us less per column (CasADi's map calls the column's library through its
    generic evaluation, once per column). Its key derives from the column's (:func:`map_library_path`),
    so looking it up builds and serialises no map."""
    path = map_library_path(column, m)
    return None if path is None else _load(f"map{m}_{column.name()}", path)


def derived_library_path(base: ca.Function, name: str, tag: str) -> Path | None:
    """Where the library of a Function named ``name``, built from ``base`` by a fixed construction
    that ``tag`` names, lives in the cache: ``<name>-<key>.so``, the key the SHA-256 of the library
    name of ``base`` (its own key: graph, CasADi, compiler, flags) and ``tag`` (which must change
    whenever the construction does); None without a compiler or for a ``base`` CasADi cannot
    serialise. Looking it up builds nothing (the derived graph can cost tens of milliseconds)."""
    if compiler() is None:
        return None
    col = _path_or_none(base)
    if col is None:
        return None
    return col.parent / f"{name}-{hashlib.sha256(f'{col.name}/{tag}'.encode()).hexdigest()[:24]}.so"


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
    return None if path is None else _start(path, lambda: f, f.name())


def map_library_path(column: ca.Function, m: int) -> Path | None:
    """Where the library of ``column.map(m)`` lives in the cache: ``map<m>_<name>-<key>.so``, the key
    the SHA-256 of the column library's name (its own key: graph, CasADi, compiler, flags) and m;
    None without a compiler or for a column CasADi cannot serialise."""
    if compiler() is None:
        return None
    col = _path_or_none(column)
    if col is None:
        return None
    return col.parent / f"map{m}_{column.name()}-{hashlib.sha256(f'{col.name}/map{m}'.encode()).hexdigest()[:24]}.so"


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

    return _start(path, make, name)


def map_size(k: int) -> int:
    """Columns of the map that evaluates ``k`` columns (the rest padded): ``k`` itself up to 8,
    else the smallest ``2^j * q / 4`` (q = 5, 6, 7, 8) that holds them, so at most a fifth of a
    call is padding (the padded columns are solved too) while the sizes, whose maps are built once
    each, stay few."""
    if k <= 8:
        return max(k, 1)
    j = (k - 1).bit_length() - 1  # 2^j < k <= 2^(j+1)
    return next(m for m in ((q << j) >> 2 for q in (5, 6, 7, 8)) if m >= k)  # j >= 3: whole numbers


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
        _note("cc", "gearopt: no C compiler found (cc, gcc or clang; or set CC): the NLP runs interpreted.")
        return solver
    ins = [nlp["x"]] + ([nlp["p"]] if "p" in nlp else [])
    outs = [nlp.get("f", 0), nlp.get("g", ca.DM.zeros(0, 1))]
    h = hashlib.sha256(ca.Function(f"{name}_nlp", ins, outs).serialize().encode())
    for part in (plugin, repr(sorted((k, repr(v)) for k, v in opts.items())), ca.__version__, cc[1], " ".join(FLAGS)):
        h.update(b"\0" + part.encode())
    base = cache_dir()
    path = base / f"{name}_nlp-{h.hexdigest()[:24]}.so"
    key = str(path)
    if key in _loaded:
        return _loaded[key]
    built = False
    if not path.exists():
        err = _build_nlp(solver, name, path, cc[0])
        if err is not None:
            _note("build", f"gearopt: compiling {name} failed ({err:.200}); it runs interpreted.")
            return solver
        built = True
    try:
        _loaded[key] = ca.nlpsol(name, plugin, str(path), opts)
    except RuntimeError as e:
        _note("load", f"gearopt: loading {path} failed ({e!s:.160}); {name} runs interpreted.")
        return solver
    _counts["built" if built else "loaded"] += 1
    return _loaded[key]


def _build_nlp(solver, name: str, path: Path, cc: str) -> str | None:
    """Generate the NLP's Functions and compile them into ``path`` (atomic rename); None on success."""
    def generate(tmp, src):
        cwd = os.getcwd()
        os.chdir(tmp)  # generate_dependencies writes into the working directory
        try:
            solver.generate_dependencies(src, {})
        finally:
            os.chdir(cwd)
    return _compile_into(generate, f"{name}_nlp.c", path, cc)
