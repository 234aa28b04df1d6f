"""Executors of the robust-design studies: chunks of samples run in this process, in local
processes, or on a Dask distributed cluster, with the same numbers whichever runs them.

The kernel (:class:`~gearopt.robust.batch.TCAKernel`: CasADi Functions and numbers, no Python
graph building) is serialised once and sent to every worker once (a spawned process's argument;
Dask ``scatter(broadcast=True)``); a task carries only its chunk of samples. Results come back in chunk
order, so the concatenated figures are bit-identical for any executor and worker count.

Faults: a local worker process that dies has its chunk run again on a new process (up to
:data:`RETRIES` replacements per worker). On Dask the scheduler reschedules the tasks of a lost
worker itself. An unreachable scheduler raises :class:`~gearopt.errors.ExecutionError` within
:data:`CONNECT_TIMEOUT` seconds. Nothing is written while chunks run (the study writes its results
only when every chunk is back).
"""

from __future__ import annotations

import pickle
import sys
from typing import Any, Callable

from ..errors import ExecutionError, OptionError, out_of_range

EXECUTORS = ("serial", "processes", "dask")
RETRIES = 3  #: replacements per worker after worker deaths (local processes); Dask task retries
CONNECT_TIMEOUT = 5.0  #: [s] to reach a Dask scheduler



def check_executor(executor: str | Any, workers: int | None) -> tuple[str | Any, int | None]:
    """Validated (executor, workers): a name of :data:`EXECUTORS` or a ``distributed.Client``;
    workers an integer 1 ... 1024 or None (processes: the CPU count; Dask local: 2)."""
    if not isinstance(executor, str):
        if type(executor).__name__ != "Client":
            raise out_of_range("executor", executor, "'serial', 'processes', 'dask' or a dask.distributed.Client",
                               cls=OptionError)
    elif executor not in EXECUTORS:
        raise out_of_range("executor", executor, "'serial', 'processes' or 'dask'", cls=OptionError)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= 1024):
        raise out_of_range("workers", workers, "an integer 1 ... 1024 (worker processes)", cls=OptionError)
    return executor, workers


def _evaluate(kernel, chunk: dict) -> dict:
    from .. import compiled
    compiled.set_threads(1)  # a worker is one process per core: its compiled maps run in one thread
    return kernel.evaluate(chunk)


def _bar(progress, total: int, label: str):
    """A tqdm progress bar on stderr (samples done), or None when ``progress`` is None (quiet)."""
    if progress is None:
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc=f"gearopt: {label}", unit="sample", file=sys.stderr, dynamic_ncols=True,
                mininterval=0.5, leave=True)


def run_chunks(kernel: Any, chunks: list, executor: str | Any = "serial", workers: int | None = None,
               scheduler: str | None = None, progress: Callable[[str], None] | None = None,
               label: str = "samples") -> list:
    """``kernel.evaluate(chunk)`` of every chunk, in chunk order.

    Parameters
    ----------
    kernel : TCAKernel
    chunks : list of dict
    executor : {"serial", "processes", "dask"} or dask.distributed.Client
    workers : int, optional
        Local processes or local Dask workers.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``); implies Dask.
    progress : callable(str), optional
        When given, a progress bar is shown on stderr.

    Raises
    ------
    ExecutionError
        The scheduler cannot be reached, or the chunks keep failing on new workers.
    """
    executor, workers = check_executor(executor, workers)
    bar = _bar(progress, sum(len(c["p1"]) for c in chunks), label)
    try:
        if scheduler is not None or not isinstance(executor, str) or executor == "dask":
            return _dask(kernel, chunks, executor, workers, scheduler, bar)
        if executor == "processes":
            return _processes(kernel, chunks, workers, bar)
        out = []
        for c in chunks:
            out.append(kernel.evaluate(c))
            if bar is not None:
                bar.update(len(c["p1"]))
        return out
    finally:
        if bar is not None:
            bar.close()


def _worker(blob: bytes, tasks, results) -> None:
    """A local worker process: the kernel once, then chunks until None."""
    import traceback
    from .. import compiled
    compiled.set_threads(1)  # one process per core
    kernel = pickle.loads(blob)
    while True:
        item = tasks.get()
        if item is None:
            return
        i, chunk = item
        try:
            results.put((i, True, kernel.evaluate(chunk)))
        except BaseException:  # noqa: BLE001 - reported to the parent, which raises
            results.put((i, False, traceback.format_exc(limit=8)))


def _processes(kernel, chunks, workers, bar) -> list:
    """Chunks on ``workers`` spawned processes, one chunk in flight per process; a process that
    dies has its chunk run again on a new process (at most RETRIES x workers replacements)."""
    import multiprocessing as mp
    import os
    import queue

    ctx = mp.get_context("spawn")
    blob = pickle.dumps(kernel)
    n = min(workers or os.cpu_count() or 1, len(chunks)) or 1
    results = ctx.Queue()
    pool: dict = {}  # slot -> [process, task queue, chunk in flight or None]

    def start(slot):
        q = ctx.Queue()
        p = ctx.Process(target=_worker, args=(blob, q, results), daemon=True)
        p.start()
        pool[slot] = [p, q, None]

    todo = list(range(len(chunks)))[::-1]
    done: dict[int, dict] = {}
    restarts = 0
    try:
        for slot in range(n):
            start(slot)
        while len(done) < len(chunks):
            for slot, w in pool.items():
                if w[2] is None and todo:
                    w[2] = todo.pop()
                    w[1].put((w[2], chunks[w[2]]))
            try:
                i, ok, value = results.get(timeout=0.5)
            except queue.Empty:
                for slot, w in list(pool.items()):
                    if not w[0].is_alive():
                        if w[2] is not None and w[2] not in done:
                            todo.append(w[2])
                        restarts += 1
                        if restarts > RETRIES * n:
                            raise ExecutionError(f"local worker processes died {restarts} times; {len(chunks) - len(done)}"
                                                 f" of {len(chunks)} chunks not done (last exit code "
                                                 f"{w[0].exitcode}).")
                        start(slot)
                continue
            if not ok:
                raise ExecutionError(f"a worker process failed on chunk {i}:\n{value}")
            done[i] = value
            for w in pool.values():
                if w[2] == i:
                    w[2] = None
            if bar is not None:
                bar.update(len(chunks[i]["p1"]))
    finally:
        for w in pool.values():
            if w[0].is_alive():
                w[1].put(None)
        for w in pool.values():
            w[0].join(timeout=5)
            if w[0].is_alive():
                w[0].kill()
                w[0].join(timeout=5)
    return [done[i] for i in range(len(chunks))]


def connect(scheduler: str, timeout: float = CONNECT_TIMEOUT) -> Any:
    """A ``distributed.Client`` of the scheduler at ``scheduler``; ExecutionError if it cannot be
    reached within ``timeout`` s."""
    try:
        from distributed import Client
    except ImportError as e:  # pragma: no cover - a dependency
        raise ExecutionError("the Dask executor needs dask.distributed (pip install 'dask[distributed]').") from e
    check_scheduler(scheduler)
    try:
        return Client(scheduler, timeout=f"{timeout}s")
    except ValueError as e:  # an address distributed cannot parse (unknown protocol, bad port)
        raise OptionError(f"scheduler = {scheduler!r}: not a Dask scheduler address ({e}); valid: {SCHEDULER_FORMS}.",
                          param="scheduler", value=scheduler, valid=SCHEDULER_FORMS) from None
    except (OSError, TimeoutError) as e:
        raise ExecutionError(f"scheduler = {scheduler!r}: no Dask scheduler answered within {timeout:g} s ({e}). "
                             "Start one (`dask scheduler`, then `dask worker ADDRESS`) or check the address.",
                             param="scheduler", value=scheduler, valid="the address of a running Dask scheduler") \
            from None


#: the scheduler addresses accepted (distributed's comm protocols)
SCHEDULER_PROTOCOLS = ("tcp", "tls", "inproc", "ucx", "ws", "wss")
SCHEDULER_FORMS = "tcp://HOST:PORT (e.g. tcp://127.0.0.1:8786), tls://HOST:PORT, ws://, wss://, ucx://, or HOST:PORT"


def check_scheduler(scheduler: str) -> str:
    """``scheduler`` if it reads as a Dask scheduler address (``PROTOCOL://HOST:PORT`` with a
    protocol of :data:`SCHEDULER_PROTOCOLS`, or ``HOST:PORT``), else :class:`OptionError` naming
    ``scheduler``, the value and the accepted forms. Contacts nothing."""
    import re

    if not isinstance(scheduler, str) or not scheduler.strip():
        raise out_of_range("scheduler", scheduler, SCHEDULER_FORMS, cls=OptionError)
    proto, sep, rest = scheduler.partition("://")
    if not sep:
        proto, rest = "tcp", scheduler
    if proto not in SCHEDULER_PROTOCOLS:
        raise OptionError(f"scheduler = {scheduler!r}: unknown protocol {proto!r}; valid: {SCHEDULER_FORMS}.",
                          param="scheduler", value=scheduler, valid=SCHEDULER_FORMS)
    if proto != "inproc":
        m = re.fullmatch(r"(\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+)(?::(\d+))?/?", rest)
        if m is None or (m.group(2) is not None and not 0 < int(m.group(2)) < 65536):
            raise OptionError(f"scheduler = {scheduler!r}: not HOST:PORT after {proto}://; valid: {SCHEDULER_FORMS}.",
                              param="scheduler", value=scheduler, valid=SCHEDULER_FORMS)
    return scheduler


def _dask(kernel, chunks, executor, workers, scheduler, bar) -> list:
    from distributed import Client, LocalCluster, as_completed

    own = []
    if scheduler is not None:
        client = connect(scheduler)
        own.append(client)
    elif isinstance(executor, str):
        cluster = LocalCluster(n_workers=workers or 2, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
        own += [client, cluster]
    else:
        client = executor
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    try:
        k = client.scatter(kernel, broadcast=True)
        futs = [client.submit(_evaluate, k, c, pure=False, retries=RETRIES) for c in chunks]
        index = {f.key: i for i, f in enumerate(futs)}
        resubmitted = [0] * len(chunks)
        results: dict[int, dict] = {}
        done = as_completed(futs)
        for f in done:
            i = index[f.key]
            try:
                results[i] = f.result()
            except (CancelledError, KilledWorker) as e:
                # the chunk's task was lost with its workers (or the scattered kernel with all the
                # workers that held it, e.g. when a loaded machine misses heartbeats): scatter the
                # kernel again and resubmit the chunk, RETRIES times at most
                if resubmitted[i] >= RETRIES:
                    raise ExecutionError(f"chunk {i} of {len(chunks)} was lost {RETRIES + 1} times on the Dask "
                                         f"cluster ({type(e).__name__}: {e!s:.200}); the workers keep dying: check "
                                         "their memory and logs.") from e
                resubmitted[i] += 1
                k = client.scatter(kernel, broadcast=True)
                nf = client.submit(_evaluate, k, chunks[i], pure=False, retries=RETRIES)
                index[nf.key] = i
                done.add(nf)
                continue
            if bar is not None:
                bar.update(len(chunks[i]["p1"]))
        return [results[i] for i in range(len(chunks))]
    finally:
        for o in own:
            o.close()
