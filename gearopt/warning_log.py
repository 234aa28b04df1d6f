"""The Python warnings of a run, recorded for results.json (``meta.warnings``) and ``report.html``.

``gearopt run`` records every warning shown while the study is built and run
(:class:`WarningLog`, in the CLI) and :func:`gearopt.io.results.write_results` those shown while the
tables and plots are written (a plot that had to leave a case out says so by a warning); both land
in ``meta.warnings``. A recorded warning is still shown where Python shows it (stderr): the warning
filters are left as they are, so a warning the filters ignore is neither shown nor recorded.

This module imports nothing of gearopt (base layer).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

__all__ = ["WarningLog", "source_text"]


def source_text(filename: str, lineno: int) -> str:
    """Where a warning was raised, ``file:line``: the file as ``gearopt/...`` when it is part of the
    package, else its name."""
    parts = Path(filename).parts
    if "gearopt" in parts:
        name = "/".join(parts[len(parts) - 1 - parts[::-1].index("gearopt"):])
    else:
        name = Path(filename).name
    return f"{name}:{lineno}"


class WarningLog:
    """Context manager (re-entrant in sequence): records every Python warning shown while active, as
    ``{"category", "message", "source"}`` in :attr:`records` (the form of results.json
    ``meta.warnings``; a warning shown again with the same text from the same line is recorded
    once), and still shows it as Python would (the filters are unchanged).
    """

    def __init__(self) -> None:
        self.records: list[dict[str, str]] = []
        self._ctx: Any = None

    def __enter__(self) -> WarningLog:
        self._ctx = warnings.catch_warnings()
        self._ctx.__enter__()  # restores warnings.showwarning (and the filters) on exit
        show = warnings.showwarning

        def record(message, category, filename, lineno, file=None, line=None):
            entry = {"category": category.__name__, "message": str(message), "source": source_text(filename, lineno)}
            if entry not in self.records:  # each once, as the default filter shows it
                self.records.append(entry)
            show(message, category, filename, lineno, file, line)

        warnings.showwarning = record
        return self

    def __exit__(self, *exc: object) -> bool | None:
        return self._ctx.__exit__(*exc)
