"""A TCAKernel whose worker process dies (os._exit) in the middle of its first chunk: the
executors must rerun that chunk elsewhere and lose nothing (tests/test_robust.py). The marker
file (environment GEAROPT_TEST_DIE_ONCE) makes it die only once across all processes."""

from __future__ import annotations

import os

from gearopt.robust.batch import TCAKernel


class DieOnceKernel(TCAKernel):
    def evaluate(self, chunk):
        marker = os.environ.get("GEAROPT_TEST_DIE_ONCE") or getattr(self, "marker", None)
        if marker and os.getpid() != getattr(self, "parent_pid", None):  # never the test's own process
            try:
                fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
            except FileExistsError:
                pass
            else:
                os.write(fd, str(os.getpid()).encode())
                os.close(fd)
                os._exit(3)  # the worker process dies mid-task
        return super().evaluate(chunk)


class LoseOnceKernel(TCAKernel):
    """Its first chunk (once across all processes, by the marker file) fails as a task the cluster
    lost (CancelledError, what a client sees when the scattered kernel went down with every worker
    that held it): the Dask executor must scatter the kernel again and resubmit that chunk."""

    def evaluate(self, chunk):
        from concurrent.futures import CancelledError

        if os.getpid() == getattr(self, "parent_pid", None):  # never in the test's own process (the nominal)
            return super().evaluate(chunk)
        try:
            fd = os.open(self.marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return super().evaluate(chunk)
        os.close(fd)
        raise CancelledError("lost with its workers (test)")
