"""Where gearopt's compiled libraries live, under which key, and whether anything may be written.

A compiled library (:mod:`gearopt.compiled`) is kept in :func:`cache_dir` under a key that is the
SHA-256 of

* the serialised Function (``Function.serialize()``, deterministic for the same graph),
* the CasADi version, the compiler's identity (``cc --version``) and the flags (:func:`flags_key`:
  :data:`FLAGS` and the rule of :data:`LARGE_FLAGS`),

or, for a large derived graph, of how it is built (:func:`keyed_by`, :func:`derived_library_path`,
:func:`map_library_path`): the names of its bases' libraries and a tag naming the construction
(:func:`source_tag`). The libraries this process has loaded are kept in :data:`loaded_libraries`.

Settings (environment):

``GEAROPT_CACHE``
    Root of gearopt's disk caches (default ``$XDG_CACHE_HOME/gearopt``, else ``~/.cache/gearopt``):
    the compiled libraries go to ``compiled/`` in it, the FE influence coefficients to ``influence/``.
``GEAROPT_CACHE_DIR``
    The compiled libraries' directory alone (overrides ``GEAROPT_CACHE``/compiled).
``CC``
    The C compiler (default the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``).
``GEAROPT_JIT_BACKGROUND``
    ``0``: nothing compiles in the background (:func:`background`; default ``1``).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import shutil
import subprocess
import warnings
import weakref
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as ca

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Sequence

#: compiler flags (part of the cache key). Besides -O2: the generated helpers (casadi_qr, casadi_sq, ...)
#: are global symbols, which -fno-semantic-interposition lets gcc inline instead of calling through
#: the PLT, and -fno-math-errno makes sqrt one instruction; neither reorders or contracts floating-point
#: operations, so the results are the same bit for bit (tests/test_compiled_flags.py), about 10 % faster.
FLAGS = ("-O2", "-shared", "-fPIC", "-fno-semantic-interposition", "-fno-math-errno")
BASE_FLAGS = ("-O2", "-shared", "-fPIC")  #: what a compiler that refuses FLAGS is given instead (same key)
#: what a C source of at least :data:`LARGE_SOURCE` bytes is compiled with besides FLAGS: without gcc's
#: partial-redundancy elimination and code hoisting (its ``pre`` pass), which take 55-60 % of the compile of
#: the long straight-line functions CasADi writes for large graphs (the loaded optimiser's slice geometry,
#: 519 kB: 15.5 -> 7.1 s CPU; the slice solve 6.8 -> 5.3 s) and find little in code whose common
#: subexpressions are eliminated already (its evaluation 2 % slower). Neither moves, reorders or contracts
#: a floating-point operation: the same numbers bit for bit (tests/test_sweep_overhead.py).
LARGE_FLAGS = ("-fno-tree-pre", "-fno-code-hoisting")
LARGE_SOURCE = 100_000  #: [bytes] C sources from this size on are compiled with LARGE_FLAGS too

#: the libraries this process has loaded, by library path (:func:`gearopt.compiled.compile_function`)
loaded_libraries: dict[str, ca.Function] = {}
_keys: dict[tuple, tuple] = {}  # (id of a Function, compiler) -> (weak reference, cache key)
_serialised: dict[int, tuple] = {}  # id of a Function -> (weak reference, SHA-256 state after its serialisation)
_noted: set[str] = set()
_counts = {"built": 0, "loaded": 0}
_quiet = [0]  # open no_background() blocks


def flag_sets(size: int) -> tuple[tuple[str, ...], ...]:
    """The flag sets a C source of ``size`` [bytes] is compiled with, in order until one works:
    :data:`FLAGS` (with :data:`LARGE_FLAGS` from :data:`LARGE_SOURCE` bytes on), then
    :data:`BASE_FLAGS` (a compiler that refuses the others). Read at call time (tests patch them)."""
    return (FLAGS + LARGE_FLAGS if size >= LARGE_SOURCE else FLAGS), BASE_FLAGS


def flags_key() -> str:
    """The flags' part of a library's key: :data:`FLAGS` and the rule of :data:`LARGE_FLAGS`."""
    return f"{' '.join(FLAGS)}; from {LARGE_SOURCE} B: {' '.join(LARGE_FLAGS)}"


def counts() -> dict:
    """Libraries this process compiled (``built``) and loaded from the disk cache (``loaded``)."""
    return dict(_counts)


def count(kind: str) -> None:
    """Count one library this process compiled (``"built"``) or loaded (``"loaded"``) (:func:`counts`)."""
    _counts[kind] += 1


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


def note(kind: str, msg: str) -> None:
    if kind not in _noted:
        _noted.add(kind)
        warnings.warn(msg, RuntimeWarning, stacklevel=3)


def _serial_hash(f: ca.Function) -> hashlib._Hash:
    """A SHA-256 object that has hashed ``f.serialize()`` (a copy: the caller may go on updating it).
    Serialised once per Function object (a large graph: 20-40 ms for 2-5 MB), for both the graph's
    digest (:func:`serial_digest`) and its library key (:func:`cache_key`); the entry leaves with
    its Function. Raises what ``serialize`` raises."""
    k = id(f)
    hit = _serialised.get(k)
    if hit is None or hit[0]() is not f:
        # (a new Function that reuses a dead one's id finds its entry gone or not its own)
        hit = _serialised[k] = (weakref.ref(f, lambda _: _serialised.pop(k, None)),
                                hashlib.sha256(f.serialize().encode()))
    return hit[1].copy()


def serial_digest(f: ca.Function) -> str:
    """SHA-256 of ``f.serialize()`` (hex; serialised once per Function object, with :func:`cache_key`)."""
    return _serial_hash(f).hexdigest()


def cache_key(f: ca.Function) -> str:
    """SHA-256 key of ``f``'s compiled library (the serialised Function, CasADi, compiler,
    :func:`flags_key`, each followed by a zero byte)."""
    cc = compiler()
    h = _serial_hash(f)
    h.update(b"\0")
    for part in (ca.__version__, cc[1] if cc else "", flags_key()):
        h.update(part.encode())
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
    h = construction_key(f.name(), bases, tag)
    if h is None:
        return f
    memo = (id(f), compiler())
    _keys[memo] = (weakref.ref(f, lambda _, m=memo: _keys.pop(m, None)), h)
    return f


def construction_key(name: str, bases: Sequence[ca.Function], tag: str) -> str | None:
    """:func:`keyed_by`'s key of a Function ``name`` (None: keyed by its graph)."""
    if compiler() is None or not tag:
        return None
    paths = [path_or_none(b) for b in bases]
    if any(p is None for p in paths):
        return None
    return hashlib.sha256("\0".join([p.name for p in paths] + [name, tag]).encode()).hexdigest()


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


def path_or_none(f: ca.Function) -> Path | None:
    """:func:`library_path`, or None (one warning) for a Function CasADi cannot serialise."""
    try:
        return library_path(f)
    except Exception as e:  # noqa: BLE001 - a Function CasADi cannot serialise: stay interpreted
        note("serialize", f"gearopt: {f.name()} cannot be serialised ({e!s:.120}); it runs interpreted.")
        return None


def lookup(f: ca.Function) -> tuple[tuple[str, str] | None, Path | None, ca.Function | None]:
    """What :func:`gearopt.compiled.compile_function`, :func:`gearopt.compiled.cached_function` and
    :func:`gearopt.compile_queue.compile_in_background` look up first: the compiler (None: none works), ``f``'s library path in the cache (None without a compiler
    or for a Function CasADi cannot serialise) and the library if this process loaded it already."""
    cc = compiler()
    if cc is None:
        return None, None, None
    path = path_or_none(f)
    return cc, path, None if path is None else loaded_libraries.get(str(path))


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


def derived_library_path(base: ca.Function, name: str, tag: str) -> Path | None:
    """Where the library of a Function named ``name``, built from ``base`` by a fixed construction
    that ``tag`` names, lives in the cache: ``<name>-<key>.so``, the key the SHA-256 of the library
    name of ``base`` (its own key: graph, CasADi, compiler, flags) and ``tag`` (which must change
    whenever the construction does); None without a compiler or for a ``base`` CasADi cannot
    serialise. Looking it up builds nothing (the derived graph can cost tens of milliseconds)."""
    if compiler() is None:
        return None
    col = path_or_none(base)
    if col is None:
        return None
    return col.parent / f"{name}-{hashlib.sha256(f'{col.name}/{tag}'.encode()).hexdigest()[:24]}.so"


def map_library_path(column: ca.Function, m: int) -> Path | None:
    """Where the library of ``column.map(m)`` lives in the cache: ``map<m>_<name>-<key>.so``, the key
    the SHA-256 of the column library's name (its own key: graph, CasADi, compiler, flags) and m;
    None without a compiler or for a column CasADi cannot serialise."""
    if compiler() is None:
        return None
    col = path_or_none(column)
    if col is None:
        return None
    return col.parent / f"map{m}_{column.name()}-{hashlib.sha256(f'{col.name}/map{m}'.encode()).hexdigest()[:24]}.so"

