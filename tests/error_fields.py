"""Consistency of the structured fields of gearopt errors with their messages (issue 12 item 6).

:func:`check_fields` is the oracle: it reads the message as a user does (the text before ``" = "``
names the parameter) and checks that ``param``, ``value``, ``valid`` and ``detail`` say the same.
:func:`recording` collects every :class:`~gearopt.errors.GearoptError` built while a block runs
(errors caught and restated on the way up included), so that whole corpora of bad input are
checked (see the autouse fixture in conftest.py for tests/test_bad_input*.py).
"""

from __future__ import annotations

import contextlib
import math
import re

from gearopt.errors import GearoptError, SceneError

#: ``name = `` at the start of a message, after an optional ``who: `` prefix (``inv: alpha = ...``,
#: ``TCAStudy: cases = ...``): the parameter a user reads there.
_NAMED = re.compile(r"^(?:[\w.]+: )?([A-Za-z_][\w.]*(?:\[[^\]]*\][\w.]*)*) = ")


def _shown(value) -> list[str]:
    """Ways a message may show ``value``."""
    out = [str(value), repr(value), str(value)[:60], type(value).__name__]
    if isinstance(value, float) and math.isfinite(value):
        out += [f"{value:g}", f"{value:.6g}", f"{value:.4g}", f"{value:.4f}"]
    return [s if len(s) <= 60 else s[:40] for s in out]


def check_fields(e: GearoptError) -> list[str]:
    """Problems with the fields of ``e`` (empty when consistent)."""
    msg, bad = str(e), []
    for f in ("param", "value", "valid", "detail"):
        if not hasattr(e, f):
            return [f"{type(e).__name__} has no field {f!r}: {msg[:120]}"]
    if not isinstance(e, SceneError):  # the loader's own key errors are restated per file (not checked here)
        m = _NAMED.match(msg)
        if m and not (e.param == m.group(1) or (e.param or "").endswith("." + m.group(1))
                      or (e.param or "").endswith(": " + m.group(1))):
            bad.append(f"message names {m.group(1)!r} but param = {e.param!r}")
    if e.param is not None:
        key = e.param.rsplit(".", 1)[-1]
        if e.param not in msg and key not in msg:
            bad.append(f"param {e.param!r} not in the message")
        if e.value is not None and not any(s in msg for s in _shown(e.value)):
            bad.append(f"value {e.value!r} not shown in the message")
    if e.valid is not None and e.valid not in msg:
        bad.append(f"valid {e.valid!r} not in the message")
    if e.detail is not None:
        if not msg.endswith(e.detail):
            bad.append(f"detail {e.detail!r} is not the end of the message")
        elif e.param is not None and f"{e.param} = " not in msg and not isinstance(e, SceneError):
            bad.append(f"detail set but the message does not start with {e.param} = ...")
    return [f"{type(e).__name__}({msg[:160]!r}): {b}" for b in bad]


@contextlib.contextmanager
def recording():
    """Yield a list that receives every GearoptError constructed inside the block."""
    seen: list[GearoptError] = []
    init = GearoptError.__init__

    def spy(self, *args, **kw):
        init(self, *args, **kw)
        seen.append(self)

    GearoptError.__init__ = spy
    try:
        yield seen
    finally:
        GearoptError.__init__ = init
