"""Background compiles of gearopt's libraries: a queue per process, detached compilers, the hand-over at exit.

A library that a call does not wait for (:func:`gearopt.compiled.select` on a cache miss of a small
sweep, a map size called again and again, a large derived graph) is compiled in a background
thread (:func:`compile_in_background`, :func:`start`) that writes its C source into a scratch
directory inside the cache and queues it. The compilers run detached: at most
:func:`compile_slots` per process at a time: a library that a large call wants (:func:`compiling`)
first, then the one whose interpreted stand-in has cost this process the most per byte of its source
(:func:`note_interpreted`), then the smallest source. A process that ends hands its queued compiles to one
detached process and never waits for them (:func:`_exit_wait`); each library appears whole at its
path (atomic rename), where the next process finds it.
"""

from __future__ import annotations

import atexit
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

import casadi as ca

from . import compile_cache
from .compile_cache import compiler, lookup

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

#: this process's background compiles under way, by library path (:func:`start`)
pending: dict[str, threading.Thread] = {}
#: library paths whose background compile failed in this process (not tried again)
failed: set[str] = set()
#: [s] time this process spent evaluating a Function interpreted while its library waited to compile,
#: by library path (:func:`note_interpreted`): what the library would have saved had it been there
interpreted: dict[str, float] = {}
_lock = threading.Lock()


def compile_in_background(f: ca.Function) -> threading.Thread | None:
    """Compile ``f`` into the disk cache in a background thread (one per library and process) and
    return the thread; None when the library is loaded or on disk already, a compile of it is under
    way or failed before in this process, or no compiler works. The compiler runs detached
    (:func:`compile_into`): a process that ends before it does never waits for it, the compile goes
    on and moves the library into the cache by an atomic rename (the thread, a daemon, only waits for
    it; at exit the process waits only while the C source is being written, :func:`_exit_wait`). The
    caller keeps running ``f`` interpreted; :func:`gearopt.compiled.cached_function` finds the library once it is there
    (in this process or the next)."""
    _, path, g = lookup(f)
    if path is None or g is not None:
        return None
    return start(path, lambda: f, f.name())


def start(path: Path, make: Callable[[], ca.Function], name: str) -> threading.Thread | None:
    """Compile ``make()`` into ``path`` in a background thread (:func:`compile_in_background`)."""
    key = str(path)
    with _lock:
        if key in compile_cache.loaded_libraries or key in pending or key in failed or path.exists():
            return None
        job = threading.Thread(target=_background_job, args=(make, key), name=f"gearopt-compile-{name}",
                               daemon=True)
        pending[key] = job
    job.start()
    return job


def _background_job(make: Callable[[], ca.Function], key: str) -> None:
    # (no warning from this thread: the warnings filters are process-wide; a failed build is kept in
    # failed, so it is not tried again in the background, and a synchronous compile reports it)
    _detached.on = True
    try:
        err = build(make(), Path(key), compiler()[0]) if not Path(key).exists() else None
        if err is None:
            compile_cache.count("built")
        else:
            failed.add(key)
    except Exception:  # noqa: BLE001 - never let a background compile raise into the interpreter
        failed.add(key)
    finally:
        with _lock:
            pending.pop(key, None)


def compiling(f: ca.Function) -> bool:
    """Whether ``f``'s library is being compiled in the background by this process; if so, it moves
    to the front of the queue of compiles (:func:`_compile_detached`): a call that would have compiled
    it at once (:data:`gearopt.compiled.MIN_COLUMNS` columns or more) runs interpreted meanwhile."""
    _, path, _ = lookup(f)
    job = None if path is None else pending.get(str(path))
    if job is None or not job.is_alive():
        return False
    with _turn:
        _urgent.add(str(path))
        _turn.notify_all()
    return True


def note_interpreted(f: ca.Function, seconds: float) -> None:
    """Count ``seconds`` [s] of interpreted evaluation of ``f`` (one column Function, mapped) in this
    process towards its library while that compiles in the background (:data:`interpreted`; ignored
    otherwise): the queue compiles first the library that has cost the most per byte of its C source
    (a compile takes roughly its size in time), since it is the one whose time keeps being lost
    (:func:`_order`)."""
    if not pending:
        return
    _, path, _ = lookup(f)
    if path is not None and str(path) in pending:
        key = str(path)
        interpreted[key] = interpreted.get(key, 0.0) + seconds


def wait_for_background(timeout: float | None = None) -> bool:
    """Wait for this process's background compiles (:func:`compile_in_background`); True when none
    is left running. ``timeout`` [s] per compile (None: no limit)."""
    for job in list(pending.values()):
        job.join(timeout)
    return not any(j.is_alive() for j in list(pending.values()))


def build(f: ca.Function, path: Path, cc: str) -> str | None:
    """Generate and compile ``f`` into ``path`` (atomic rename); None on success, else the reason."""
    def generate(tmp, src):
        cg = ca.CodeGenerator(src, {"with_header": False})
        cg.add(f)
        cg.generate(tmp + os.sep)
    return compile_into(generate, f"{f.name()}.c", path, cc)


def compile_into(generate: Callable[[str, str], None], src: str, path: Path, cc: str) -> str | None:
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
        for flags in compile_cache.flag_sets(os.path.getsize(os.path.join(tmp, src))):  # (BASE_FLAGS last)
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
#: [scratch directory, C source, library path, flag sets to try in order]), the compiler, the processes to let
#: end first (JSON: process ids, the compiles running when the process that queued the jobs ended). It
#: compiles them one after the other, each into its scratch directory, moves the library into place by an atomic rename
#: (skipped when another process put it there meanwhile), removes the scratch directory and reports a
#: failure on its standard output (whose reader may be gone: the process that started it may have ended)
_DETACHED_JOB = r"""
import json, os, shutil, subprocess, sys
import time
jobs, cc, before = json.loads(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3])
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
for tmp, src, path, flag_sets in jobs:
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
    the largest a 2 MB source); run all at once, the compilers would share the cores with the
    process that waits for nothing but its own work (on two cores: a third of one core for it with
    five compilers), so they wait in a queue (:func:`_order`, :func:`_compile_detached`).
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


def _order(job: _Job) -> tuple[bool, float, int]:
    """Queue order of the background compiles: those a large call waits for (:func:`compiling`)
    first, then by the interpreted time their Function has cost this process so far per byte of
    source, the most first (:func:`note_interpreted`; the loaded optimiser's first run: the tip-edge
    solves and the slice geometry, 1-5 s interpreted, before the smaller sensitivities it calls a few
    times, 0.1 s), then the smallest source first."""
    key = str(job.path)
    return key not in _urgent, -interpreted.get(key, 0.0) / max(job.size, 1), job.size


def _spawn(jobs: list[_Job], cc: str, after: Sequence[int] = ()) -> subprocess.Popen:
    """Start the detached process that compiles ``jobs`` in this order, once the processes ``after``
    have ended (its own session, no inherited descriptors: the process that starts it may end first,
    neither waits for the other)."""
    try:
        return subprocess.Popen([sys.executable, "-I", "-S", "-c", _DETACHED_JOB,
                                 json.dumps([[j.tmp, j.src, str(j.path), [list(f) for f in compile_cache.flag_sets(j.size)]]
                                             for j in jobs]), cc, json.dumps(list(after))],
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                start_new_session=True, close_fds=True)
    except OSError:
        for j in jobs:
            shutil.rmtree(j.tmp, ignore_errors=True)
        raise


def _compile_detached(tmp: str, src: str, path: Path, cc: str) -> str | None:
    """Compile the C source ``src`` of the scratch directory ``tmp`` into ``path`` in a detached
    process and wait for it while this process runs. The compile waits its turn: at most
    :func:`compile_slots` at a time per process, the queued ones in :func:`_order` (a library
    that a large call wants, then by interpreted cost per byte of source, then the smallest). When the
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
    (in :func:`_order`) after this process has ended."""
    def writing() -> bool:
        with _turn:
            ready = {str(j.path) for j in _queue} | _started
            return any(job.is_alive() and key not in ready for key, job in pending.items())

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
