"""A call computed in a forked process while the caller goes on (:class:`ForkedCall`), and the
number of cores idle at this moment (:func:`idle_cores`), which decides whether a fork pays.

Used by the crowning study (the TCA of the drive before optimisation beside the NLP, the last
cases of the optimised drive's sweeps) and its optimizer (the verification sweeps of the last cases,
:class:`gearopt.synthesis.crowning.CrowningOptimizer`), and by ``gearopt run``'s drawing processes (:mod:`gearopt.cli_plots`: a process per figure beyond the
cores only on an idle machine).
"""

from __future__ import annotations

import os
import sys
import threading
import weakref
from typing import Any, Callable, ClassVar

__all__ = ["ForkedCall", "fork_beside", "idle_cores", "running_children", "split_forked"]

#: threads beside which a ForkedCall may fork, each with the lock it holds for all its work
_BESIDE: weakref.WeakKeyDictionary[threading.Thread, Any] = weakref.WeakKeyDictionary()


def fork_beside(thread: threading.Thread, lock: Any) -> None:
    """Let :class:`ForkedCall` fork while ``thread`` runs: a thread that only waits, and holds
    ``lock`` (a :class:`threading.Lock`) for all else it does (e.g. :class:`gearopt.progress.heartbeat`,
    writing a line). :class:`ForkedCall` holds ``lock`` across the fork, so the forked process (which
    copies only the calling thread) starts with none of that thread's work half done."""
    _BESIDE[thread] = lock


def running_children() -> int:
    """This process's child processes running or runnable now (state ``R`` in ``/proc``; 0 where
    that is unknown): work of this same run, such as ``gearopt run``'s drawing process importing
    matplotlib (:mod:`gearopt.cli_plots`), which :func:`idle_cores` does not count as load."""
    n = 0
    try:
        tids = os.listdir("/proc/self/task")
    except OSError:
        return 0
    for tid in tids:
        try:
            with open(f"/proc/self/task/{tid}/children") as f:
                pids = f.read().split()
        except OSError:
            continue
        for pid in pids:
            try:
                with open(f"/proc/{pid}/stat") as f:
                    stat = f.read()
            except OSError:
                continue
            if stat[stat.rindex(")") + 2:].startswith("R"):  # field 3, after "pid (comm) "
                n += 1
    return n


def idle_cores() -> int:
    """Cores not running a task at this moment: the usable cores less the machine's runnable tasks
    other than this one and its own running children (:func:`running_children`, this run's work)
    (``/proc/loadavg``, instantaneous, unlike the 1-minute load average of
    :func:`gearopt.compiled.idle_cpus`); the usable cores where that is unknown. Negative on a
    machine with more runnable tasks than cores."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1
    try:
        with open("/proc/loadavg") as f:
            running = int(f.read().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return cores
    return cores - max(running - 1 - running_children(), 0)


class ForkedCall:
    """``fn()`` computed in a forked process while the caller goes on; :meth:`result` gives its
    value (pickled back through a pipe), :meth:`close` ends the process if it still runs.

    A fork copies the whole process (every compiled Function, cache and memo of the caller), so the
    value is the one ``fn()`` gives here, number for number. Forked only where that is safe and
    pays: Linux, two or more usable cores, a core idle now (:attr:`min_idle_cores`) and no thread
    but the calling one (a fork copies only that thread) except those declared by
    :func:`fork_beside` (a progress heartbeat); otherwise, and when the forked process
    fails (it then says nothing of why), :meth:`result` calls ``fn()`` itself, so that its error is
    raised here.

    Parameters
    ----------
    fn : callable
        Called without arguments; its value must pickle.
    """

    #: fork where it applies (False: always compute in :meth:`result`)
    enabled: ClassVar[bool] = True
    #: fork only with at least this many cores idle at the call (:func:`idle_cores`; None: whatever
    #: the load): on a machine whose cores are busy the forked process only waits for one, and the
    #: fork and the work it repeats (its own edge branches) make the run slower
    min_idle_cores: ClassVar[int | None] = 1


    def __init__(self, fn: Callable[[], Any]) -> None:
        self.fn = fn
        self.pid: int | None = None
        self._fd: int | None = None
        self._done = False
        self._value: Any = None
        try:
            cores = len(os.sched_getaffinity(0))
        except (AttributeError, OSError):
            cores = 1
        me = threading.current_thread()
        locks = [_BESIDE.get(t) for t in threading.enumerate() if t is not me]
        if not (self.enabled and sys.platform.startswith("linux") and hasattr(os, "fork") and cores >= 2
                and all(lock is not None for lock in locks)):
            return
        if self.min_idle_cores is not None and idle_cores() < self.min_idle_cores:
            return
        import pickle

        r, w = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        import warnings

        for lock in locks:  # no thread beside this one half-way through its work at the fork
            lock.acquire()
        try:
            with warnings.catch_warnings():  # Python >= 3.12 warns of a fork beside threads: fork_beside's
                warnings.simplefilter("ignore", DeprecationWarning)
                pid = os.fork()
        finally:
            for lock in locks:  # here and in the forked process (its copies)
                lock.release()
        if pid == 0:  # the forked process: fn(), its value down the pipe, never returns
            status = 1
            try:
                os.close(r)
                try:
                    data = pickle.dumps(("ok", fn()), protocol=pickle.HIGHEST_PROTOCOL)
                except BaseException:  # noqa: BLE001 - the caller computes it again and raises it there
                    data = pickle.dumps(("error", None))
                with os.fdopen(w, "wb") as f:
                    f.write(data)
                status = 0
            finally:
                os._exit(status)
        os.close(w)
        self.pid, self._fd = pid, r

    @property
    def forked(self) -> bool:
        """Whether ``fn()`` runs in a forked process."""
        return self.pid is not None

    def result(self) -> Any:
        """``fn()``'s value: from the forked process (waiting for it), or computed here (where none
        was forked or it failed; ``fn()``'s error is raised). Computed once."""
        if self._done:
            return self._value
        if self.pid is not None:
            import pickle

            try:
                with os.fdopen(self._fd, "rb") as f:
                    self._fd = None
                    data = f.read()
                kind, value = pickle.loads(data)
            except Exception:  # noqa: BLE001 - a forked process that died: computed here
                kind, value = "error", None
            finally:
                self.close()
            if kind == "ok":
                self._value, self._done = value, True
                return value
        self._value, self._done = self.fn(), True
        return self._value

    def close(self) -> None:
        """End the forked process if it still runs, and wait for it (calling it again does nothing)."""
        import signal

        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        if self.pid is None:
            return
        pid, self.pid = self.pid, None
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        try:
            os.waitpid(pid, 0)
        except ChildProcessError:
            pass


def split_forked(fn: Callable[[list], list], items: Any, around: Callable[[], Any] | None = None) -> list:
    """``fn(items)`` for independent ``items`` in three parts: the first item here (its work may fill
    memos the others share), the last half in a :class:`ForkedCall` beside the middle ones here; the
    parts' lists concatenated in the items' order, the same numbers as ``fn(items)`` where ``fn`` of
    an item does not depend on the items before it. ``around``: a context manager factory entered
    around each part done here (e.g. a progress heartbeat)."""
    import contextlib

    items = list(items)
    ctx = around or contextlib.nullcontext
    half = (len(items) + 2) // 2
    with ctx():
        out = list(fn(items[:1]))
    tail = items[half:]
    rest = ForkedCall(lambda: fn(tail)) if tail else None
    try:
        with ctx():
            out += fn(items[1:half])
            if rest is not None:
                out += rest.result()
    finally:
        if rest is not None:
            rest.close()
    return out
