"""Progress of long work: one line per step, shown by the caller (the CLI prints it on stderr).

The library never prints progress itself. A study's ``run(progress=...)`` receives a callable
taking one line of text (``None``: silent, what ``gearopt run --quiet`` passes); long steps inside
it report through that callable. Work that runs deep below a study without a ``progress``
argument of its own (the FE influence-coefficient cache of the loaded TCA, built with the
study) reports to the callable installed by :func:`reporting` for the current context, if any.

:class:`heartbeat` covers a single long call (an IPOPT solve, a CalculiX run) that has no steps
to report: while it runs, a background thread reports the elapsed time every ``every`` seconds of
silence.
"""

from __future__ import annotations

import contextlib
import contextvars
import threading
import time
from typing import Callable, Iterator

from .forking import fork_beside

__all__ = ["heartbeat", "reporting", "current"]

Progress = Callable[[str], None]

_SINK: contextvars.ContextVar[Progress | None] = contextvars.ContextVar("gearopt_progress", default=None)


@contextlib.contextmanager
def reporting(progress: Progress | None) -> Iterator[Progress | None]:
    """Install ``progress`` (callable taking one line of text, or None) as the receiver of
    :func:`current` for the block."""
    token = _SINK.set(progress)
    try:
        yield progress
    finally:
        _SINK.reset(token)


def current() -> Progress | None:
    """The progress callable installed by :func:`reporting` (None outside: stay silent)."""
    return _SINK.get()


class heartbeat:
    """Context manager: report the elapsed time of a long call every ``every`` s of silence.

    Parameters
    ----------
    progress : callable(str) or None
        Receives the lines; None: nothing happens (no thread).
    label : str
        Start of each line: ``f"{label}: {elapsed:.0f} s"``.
    every : float
        Seconds without any line (the block's own lines through the yielded callable count) after
        which the elapsed time is reported [s].

    Yields
    ------
    callable(str) or None
        ``progress`` wrapped so that the block's own lines reset the silence timer (None when
        ``progress`` is None).

    Examples
    --------
    >>> with heartbeat(print, "crowning: IPOPT", every=15.0) as say:   # doctest: +SKIP
    ...     design = optimizer.solve()
    """

    def __init__(self, progress: Progress | None, label: str, every: float = 15.0) -> None:
        if every <= 0:
            raise ValueError(f"heartbeat: every = {every!r} s; valid: > 0")
        self.progress, self.label, self.every = progress, label, float(every)
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self.t0 = self._last = 0.0

    def _say(self, msg: str) -> None:
        with self._lock:
            self._last = time.perf_counter()
            self.progress(msg)

    def _beat(self) -> None:
        while not self._stop.wait(min(1.0, self.every / 4)):
            now = time.perf_counter()
            with self._lock:
                if now - self._last >= self.every and not self._stop.is_set():
                    self._last = now
                    self.progress(f"{self.label}: {now - self.t0:.0f} s")

    def __enter__(self) -> Progress | None:
        if self.progress is None:
            return None
        self.t0 = self._last = time.perf_counter()
        self._thread = threading.Thread(target=self._beat, name="gearopt-heartbeat", daemon=True)
        fork_beside(self._thread, self._lock)  # it reports under _lock only: a fork may copy the caller beside it
        self._thread.start()
        return self._say

    def __exit__(self, *exc) -> bool:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
        return False
