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
