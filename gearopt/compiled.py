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

``GEAROPT_CACHE_DIR``
    Cache directory (default ``$XDG_CACHE_HOME/gearopt/compiled``, else ``~/.cache/gearopt/compiled``).
``CC``
    The C compiler (default the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``).

Without a working compiler :func:`compile_function` returns None after one warning (a one-line
note) per process, and the callers run the interpreted Function.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
import warnings
from pathlib import Path

import casadi as ca

FLAGS = ("-O2", "-shared", "-fPIC")  #: compiler flags (part of the cache key)
MIN_COLUMNS = 1024  #: jit="auto": mapped solves of at least this many columns run compiled

_loaded: dict[str, ca.Function] = {}
_noted: set[str] = set()
_counts = {"built": 0, "loaded": 0}


def counts() -> dict:
    """Libraries this process compiled (``built``) and loaded from the disk cache (``loaded``)."""
    return dict(_counts)


def cache_dir() -> Path:
    """The directory of the compiled libraries (``GEAROPT_CACHE_DIR`` or the user cache)."""
    env = os.environ.get("GEAROPT_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "gearopt" / "compiled"


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
    """Where ``f``'s compiled library lives in the cache (whether or not it exists yet)."""
    return cache_dir() / f"{f.name()}-{cache_key(f)[:24]}.so"


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
    cc = compiler()
    if cc is None:
        _note("cc", "gearopt: no C compiler found (cc, gcc or clang; or set CC): sweeps run interpreted, "
                    "about 10x slower. Install one (e.g. apt-get install gcc) for the compiled engine.")
        return None
    try:
        path = library_path(f)
    except Exception as e:  # noqa: BLE001 - a Function CasADi cannot serialise: stay interpreted
        _note("serialize", f"gearopt: {f.name()} cannot be serialised ({e!s:.120}); it runs interpreted.")
        return None
    key = str(path)
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
    try:
        generate(tmp, src)
        so = os.path.join(tmp, "lib.so")
        out = subprocess.run([cc, *FLAGS, "-o", so, os.path.join(tmp, src), "-lm"], capture_output=True, text=True,
                             timeout=3600)
        if out.returncode != 0:
            return f"{cc} exited with {out.returncode}: {out.stderr.strip()[:300]}"
        os.replace(so, path)  # atomic: a concurrent reader sees the old file or the whole new one
        return None
    except (OSError, subprocess.SubprocessError, RuntimeError) as e:
        return str(e)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def use_compiled(jit, n: int) -> bool:
    """Whether a mapped call of ``n`` columns runs compiled under the ``jit`` setting
    (True: always; False: never; "auto": from :data:`MIN_COLUMNS` columns on, if a compiler works)."""
    if jit is True:
        return True
    if jit == "auto":
        return n >= MIN_COLUMNS and available()
    return False


def mapped(f: ca.Function, n: int, jit="auto", n_total: int | None = None) -> ca.Function:
    """``f`` mapped over ``n`` columns: the compiled library's map when :func:`use_compiled`
    (for ``n_total`` columns in all, default n) and it builds, else the interpreted map."""
    g = compile_function(f) if use_compiled(jit, n if n_total is None else n_total) else None
    return (g if g is not None else f).map(n)


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
