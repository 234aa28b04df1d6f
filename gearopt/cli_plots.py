"""The figures of ``gearopt run`` drawn in separate processes, side by side with the study and with
each other.

Importing matplotlib takes about 0.5 s and drawing a figure 0.3-2 s, each on one core; the demo's
study takes 0.3 s. :meth:`PlotProcesses.start`, called by the CLI before it imports anything heavy,
forks one process that imports matplotlib (and the study's module, :meth:`PlotProcesses.prepare`)
while the CLI reads the scene and runs the study. :meth:`PlotProcesses.submit` sends it the
result (pickled); that process forks ``count - 1`` siblings of itself (``count``: one per usable core, or more
where the figures are done sooner so: by their stated costs or one per figure, :func:`processes_for`) (matplotlib imported once,
shared copy-on-write) and each calls the result's ``save_plots`` under gearopt's plot style, drawing
the PNG files it reaches first (:func:`gearopt.plot.saving.png_saving`): the same files as one
process would write, each drawn by one process, a process done with a quick figure taking the next. Warnings shown while drawing are gathered, shown once by the CLI
and returned for results.json; an error raised by ``save_plots`` is raised again in the CLI.

Used only where it is safe and pays: Linux (``fork``), two or more usable cores, no thread but the
main one in the CLI process at start (a fork copies only the calling thread), and no matplotlib
backend asked for but Agg (``MPLBACKEND``). Otherwise
:meth:`PlotProcesses.start` returns None and :func:`gearopt.io.results.write_results` draws in the
CLI's process as before. A result that cannot be pickled is drawn there too.
"""

from __future__ import annotations

import os
import pickle
import socket
import struct
import sys
import time
import traceback
from pathlib import Path
from typing import Any

__all__ = ["MAX_PROCESSES", "PlotProcesses", "plot_makespan", "processes_for", "usable_cores"]

#: largest number of drawing processes (a run writes 2-5 figures)
MAX_PROCESSES = 4

_HEADER = struct.Struct("!Q")


def usable_cores() -> int:
    """The number of cores this process may run on (its CPU affinity; ``os.cpu_count()`` where the
    platform has none)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _send(sock: socket.socket, obj: Any) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    sock.sendall(_HEADER.pack(len(data)) + data)


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    parts, got = [], 0
    while got < n:
        b = sock.recv(min(n - got, 1 << 20))
        if not b:
            raise EOFError("the other process closed the connection")
        parts.append(b)
        got += len(b)
    return b"".join(parts)


def _recv(sock: socket.socket) -> Any:
    (n,) = _HEADER.unpack(_recv_exact(sock, _HEADER.size))
    return pickle.loads(_recv_exact(sock, n))


class PlotProcesses:
    """The drawing processes of one ``gearopt run`` (see the module docstring).

    Use :meth:`start` (None where it does not apply), :meth:`prepare` once the study is known,
    :meth:`submit` and :meth:`wait` for the result (through
    :func:`gearopt.io.results.write_results`'s ``plotter``) and :meth:`close` at the end, also
    after an error.

    Attributes
    ----------
    count : int
        Number of processes that draw (the first forked at :meth:`start`, the others at
        :meth:`submit`).
    cpu_time : float
        CPU time [s] of the drawing processes for the last :meth:`wait` (user + system, all
        processes), for benchmarks/bench_run.py.
    """

    def __init__(self, pid: int, sock: socket.socket, count: int) -> None:
        self.pid: int | None = pid
        self.sock, self.count = sock, count
        self.cpu_time = 0.0

    @classmethod
    def start(cls, count: int | None = None) -> PlotProcesses | None:
        """Fork the first drawing process, which imports matplotlib at once; None where the
        processes do not apply (see the module docstring).

        Parameters
        ----------
        count : int, optional
            Number of drawing processes, >= 1 (default: the usable cores, at most
            :data:`MAX_PROCESSES`; None is returned below two cores).

        Returns
        -------
        PlotProcesses or None
        """
        import threading

        if count is None:
            cores = usable_cores()
            if cores < 2:
                return None
            count = min(cores, MAX_PROCESSES)
        elif count < 1:
            raise ValueError(f"PlotProcesses.start(count={count}): count must be >= 1")
        if os.environ.get("MPLBACKEND", "agg").lower() != "agg":
            return None
        if not (sys.platform.startswith("linux") and hasattr(os, "fork")) or threading.active_count() != 1:
            return None
        os.environ["MPLBACKEND"] = "Agg"  # plots go to files (as the CLI sets it)
        mine, theirs = socket.socketpair()
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # the drawing process: it never returns
            mine.close()
            status = 1
            try:
                _serve(theirs, count)
                status = 0
            except BaseException:  # noqa: BLE001 - an interrupted or failed import: the CLI draws itself
                pass
            finally:
                os._exit(status)
        theirs.close()
        return cls(pid, mine, count)

    def prepare(self, module: str) -> None:
        """Have the drawing process import ``module`` (the study's, which defines its result class)
        while the study runs."""
        try:
            _send(self.sock, ("import", module))
        except OSError:
            pass

    def submit(self, result: Any, directory: str | Path, kwargs: dict[str, Any]) -> bool:
        """Have the drawing processes call ``result.save_plots(directory, **kwargs)``, under
        gearopt's plot style (:func:`gearopt.plot.style.plot_style`); :meth:`wait` for them.

        Parameters
        ----------
        result : study result
            Its ``save_plots`` is called in every drawing process, each writing its share of the
            files.
        directory : path
            Where the PNG files go.
        kwargs : dict
            Keyword arguments of ``save_plots`` (``dpi``).

        Returns
        -------
        bool
            False when the processes cannot draw this result (it cannot be pickled, or the
            drawing process is gone): nothing is drawn, the caller draws itself.
        """
        try:
            payload = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception:  # noqa: BLE001 - any pickling failure: draw in the CLI's process
            return False
        try:
            _send(self.sock, ("draw", payload, str(directory), dict(kwargs)))
        except OSError:
            return False
        return True

    def wait(self) -> tuple[list[str], list[dict[str, str]]] | None:
        """Wait for the plots :meth:`submit` asked for.

        Returns
        -------
        tuple or None
            ``(files, warnings)``: what ``save_plots`` returned (file names) and the warnings shown
            while drawing (``{"category", "message", "source"}``; shown here on stderr, once); None
            when the drawing processes could not draw (the result's class cannot be imported there,
            or the process ended without an answer): then the caller draws itself.

        Raises
        ------
        Exception
            What ``save_plots`` raised in a drawing process (the first one's), with that process's
            traceback as a note.
        """
        try:
            kind, files, records, cpu, err = _recv(self.sock)
        except (OSError, EOFError):
            return None
        self.cpu_time = cpu
        if kind == "unavailable":
            return None
        for r in records:
            print(f"{r['source']}: {r['category']}: {r['message']}", file=sys.stderr)
        if kind == "error":
            raise err
        return files, records

    def close(self) -> None:
        """End the drawing processes (idle or, after an error, maybe still drawing) and wait for them;
        none of them writes a file after this returns. Calling it again does nothing."""
        import signal

        if self.pid is None:
            return
        pid, self.pid = self.pid, None
        try:
            self.sock.close()
        finally:
            try:
                os.kill(pid, signal.SIGTERM)
                os.waitpid(pid, 0)
            except (ProcessLookupError, ChildProcessError):
                pass


def _serve(sock: socket.socket, count: int) -> None:
    """The first drawing process: import matplotlib, then answer the CLI's messages until it closes
    the connection."""
    import importlib
    import signal

    import shutil

    children: list[int] = []
    claims: list[str] = []

    def terminate(*_: Any) -> None:  # the CLI ends this process: end the siblings it forked too, first
        for pid in children:
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except (ProcessLookupError, ChildProcessError):
                pass
        for d in claims:
            shutil.rmtree(d, ignore_errors=True)
        os._exit(1)

    signal.signal(signal.SIGTERM, terminate)
    import matplotlib.pyplot  # noqa: F401 - imported once, before the siblings are forked

    from .plot import saving, style  # noqa: F401
    from .warning_log import WarningLog  # noqa: F401

    while True:
        try:
            msg = _recv(sock)
        except EOFError:
            return
        if msg[0] == "import":
            try:
                importlib.import_module(msg[1])
            except Exception:  # noqa: BLE001 - unpickling the result will say what is missing
                pass
        elif msg[0] == "draw":
            _send(sock, _draw(msg[1], msg[2], msg[3], count, children, claims))


def _draw(payload: bytes, directory: str, kwargs: dict, count: int, children: list[int], claims: list[str]) -> tuple:
    """Fork ``count - 1`` siblings, all draw (each figure the first to reach it), gather the
    siblings' replies: ``(kind, files, warnings, cpu_s, error)``."""
    import shutil
    import tempfile

    t0 = time.process_time()
    try:
        result = pickle.loads(payload)
    except Exception:  # noqa: BLE001 - its class not importable here (a study module loaded from a file)
        return ("unavailable", [], [], time.process_time() - t0, None)
    claims.append(tempfile.mkdtemp(prefix="gearopt-plots-"))  # removed here, or by terminate()
    try:
        return _draw_shared(result, directory, kwargs, processes_for(result, count), children, claims[-1], t0)
    finally:
        shutil.rmtree(claims.pop(), ignore_errors=True)


def processes_for(result: Any, count: int) -> int:
    """The number of processes that draw ``result``'s figures: ``count`` (one per usable core), or
    more where that finishes the figures sooner, at most :data:`MAX_PROCESSES`.

    The figures are CPU-bound. Where the result states what its figures cost (``plot_costs``:
    figure file name -> relative cost, the figures it draws, in the order it draws them), the
    number of processes from ``count`` to one per figure whose figures are done first
    (:func:`plot_makespan`; the fewest where several tie): the tca study's three figures, te.png
    and compare.png of one cost and bearing_contact.png of two, take 2 cost units on two
    processes on two cores (one draws te.png then compare.png) and 2.5 on three. Otherwise one
    process per figure the result names in its ``captions`` (figure file name -> caption), where
    those are more than ``count``: figures of similar cost, as the crowning study's three of about
    1.3 s each, which three processes on two cores finish in about 1.5 figure times, where two
    processes, one of them drawing two figures in turn, take two. More processes than ``count``
    only where a core is idle now (:func:`gearopt.forking.idle_cores`); on a busy machine
    ``count``.

    Parameters
    ----------
    result : study result
        Read for ``plot_costs`` and ``captions`` only (dicts, or properties returning them;
        absent: ``count``).
    count : int
        The processes :meth:`PlotProcesses.start` chose (>= 1), one per usable core.

    Returns
    -------
    int
    """
    def named(attr: str) -> dict:
        try:
            return dict(getattr(result, attr, None) or {})
        except Exception:  # noqa: BLE001 - a property that fails: as if absent
            return {}

    costs = [float(c) for c in named("plot_costs").values()]
    figures = len(costs) if costs else len(named("captions"))
    if min(figures, MAX_PROCESSES) <= count:
        return count
    from .forking import idle_cores

    # more processes than cores only on an idle machine (a core free beside this process): on busy
    # cores the extra process's own start (its first figure) is extra work, not a gain
    if idle_cores() < 1:
        return count
    if not costs:
        return min(figures, MAX_PROCESSES)
    spans = {k: plot_makespan(costs, k, count) for k in range(count, min(figures, MAX_PROCESSES) + 1)}
    return min(spans, key=lambda k: (round(spans[k], 9), k))


def plot_makespan(costs: list[float], processes: int, cores: int) -> float:
    """When the last of the figures of ``costs`` (their drawing times, in the order they are
    drawn) is done, drawn by ``processes`` processes on ``cores`` cores: each process draws the next
    figure not yet taken when it is free (:func:`gearopt.plot.saving.png_saving`'s claims), the
    running processes sharing the cores equally.

    Parameters
    ----------
    costs : list of float
        Time of each figure on one core, >= 0 (any unit).
    processes, cores : int
        >= 1.

    Returns
    -------
    float
        In the unit of ``costs``.
    """
    queue = list(costs)
    left = [queue.pop(0) for _ in range(min(processes, len(queue)))]
    t = 0.0
    while left:
        rate = min(1.0, cores / len(left))
        step = min(left) / rate
        t += step
        left = [w - step * rate for w in left]
        done = sum(w <= 1e-12 for w in left)
        left = [w for w in left if w > 1e-12] + [queue.pop(0) for _ in range(min(done, len(queue)))]
    return t


def _draw_shared(result: Any, directory: str, kwargs: dict, count: int, children: list[int], claims: str,
                 t0: float) -> tuple:
    socks = []
    for k in range(1, count):
        mine, theirs = socket.socketpair()
        pid = os.fork()
        if pid == 0:
            status = 1
            try:
                mine.close()
                _send(theirs, _share(result, directory, kwargs, claims))
                status = 0
            finally:
                os._exit(status)
        theirs.close()
        children.append(pid)
        socks.append((pid, mine))
    replies = [_share(result, directory, kwargs, claims)]
    for pid, s in socks:
        try:
            replies.append(_recv(s))
        except EOFError:
            replies.append(("error", [], [], 0.0, RuntimeError(f"drawing process {pid} ended without an answer")))
        s.close()
        os.waitpid(pid, 0)
        children.remove(pid)
    records: list[dict[str, str]] = []
    for r in replies:
        records += [w for w in r[2] if w not in records]
    cpu = time.process_time() - t0 + sum(r[3] for r in replies[1:])
    bad = [r for r in replies if r[0] == "error"]
    if bad:
        return ("error", [], records, cpu, bad[0][4])
    return ("ok", replies[0][1], records, cpu, None)


def _share(result: Any, directory: str, kwargs: dict, claims: str) -> tuple:
    """``result.save_plots`` drawing the PNG files this process reaches first (``claims``)."""
    import warnings

    from .plot.saving import png_saving
    from .plot.style import plot_style
    from .warning_log import WarningLog

    t0 = time.process_time()
    warnings.showwarning = lambda *a, **k: None  # recorded here, shown once by the CLI
    log = WarningLog()
    try:
        with log, plot_style(), png_saving(claims):
            files = result.save_plots(directory, **kwargs)
        return ("ok", [str(f) for f in files or []], log.records, time.process_time() - t0, None)
    except Exception as e:  # noqa: BLE001 - raised again in the CLI
        return ("error", [], log.records, time.process_time() - t0, _portable(e))


def _portable(e: BaseException) -> BaseException:
    """``e`` with its traceback as a note, or a RuntimeError saying the same when ``e`` does not
    pickle."""
    tb = "".join(traceback.format_exception(e))
    try:
        e.add_note(f"(raised while drawing the plots in process {os.getpid()}:\n{tb.rstrip()})")
        pickle.loads(pickle.dumps(e))
        return e
    except Exception:  # noqa: BLE001
        return RuntimeError(f"{type(e).__name__}: {e}\n(raised while drawing the plots in process {os.getpid()}:\n"
                            f"{tb.rstrip()})")
