"""Consistency of the structured fields of gearopt errors with their messages (gearopt.errors, docs/errors.md).

:func:`check_fields` is the oracle: it reads the message as a user does (the text before ``" = "``
names the parameter) and checks that ``param``, ``value``, ``valid`` and ``detail`` say the same.
:func:`recording` collects every :class:`~gearopt.errors.GearoptError` built while a block runs
(errors caught and restated on the way up included), so that whole corpora of bad input are
checked (see the autouse fixture in conftest.py for tests/test_bad_input*.py). A
:class:`~gearopt.errors.SceneError` is read after the scene file name (its ``source``): a message
starting ``[section] key`` (or ``[section]``) must have that ``param`` and, after `` = ``, show its
``value`` as written; one that lists several problems must hold them in ``problems``.
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


#: ``[section] key`` at the start of a scene problem as a user reads it: the section (``[pinion]``,
#: ``[pinion.rack]``, ``[tca.cases][0]``), then optionally the key (``z``, ``tool.d_p0``; after an
#: optional ``who: `` such as ``TCAStudy: ``) ended by `` = ``, ``:``, `` and ``, ``, `` (or by
#: `` (default) = ``, a field's default that fails its own check) or the
#: section alone ended by ``:`` or `` must``. Group 1 the section, group 2 the key (or None).
_SCENE_NAMED = re.compile(r"^(\[[^\]\n]+\](?:\[\d+\])?)(?:(?: (?:\w+: )?([A-Za-z_][\w.]*)(?:(?= = |: |:$| and |, )"
                          r"| \(default\)(?= = )))"
                          r"|(?=:| must ))")
#: A run-time failure restated by Scene.run_error: the text after it names the key.
_RUN_FAILED = re.compile(r"^study '[^']*' failed(?: \(the scene sets .*?\))?: ")
#: Words of a message that state a valid type, set or range.
_STATES_VALID = re.compile(r"; valid: |: expected |[Vv]alid keys: |Valid sections: ")


def _scene_problems(e: SceneError, msg: str) -> list[str]:
    """Problems of a :class:`SceneError`: read the message as a user does."""
    bad = []
    for f in ("source", "problems"):
        if not hasattr(e, f):
            return [f"SceneError has no field {f!r}"]
    body = msg
    if e.source is not None:
        if not msg.startswith(f"{e.source}: "):
            return [f"source {str(e.source)!r} does not start the message"]
        body = msg[len(f"{e.source}: "):]
    listed = re.match(r"^(\d+) problems:\n", body)
    if listed or e.problems:
        lines = [ln[4:] for ln in body.split("\n")[1:]] if listed else [body]
        if listed and not all(ln.startswith("  - ") for ln in body.split("\n")[1:]):
            bad.append("a listed problem does not start with '  - '")
        if [str(p) for p in e.problems] != lines:
            bad.append(f"problems {[str(p)[:60] for p in e.problems]} are not the problems the message lists "
                       f"{[ln[:60] for ln in lines]}")
        elif (e.param, e.value, e.valid) != (e.problems[0].param, e.problems[0].value, e.problems[0].valid):
            bad.append("param, value, valid are not those of the first problem")
        if listed and e.detail is not None:
            bad.append("detail set on a list of problems")
        return bad
    run = _RUN_FAILED.match(body)
    if run:
        body = body[run.end():]
    m = _SCENE_NAMED.match(body)
    if m:
        named = m.group(1) + (f" {m.group(2)}" if m.group(2) else "")
        if e.param != named:
            bad.append(f"message names {named!r} but param = {e.param!r}")
        elif m.group(2) and body[m.end():].startswith(" = ") and e.value is not None \
                and not body[m.end() + 3:].startswith(str(e.value)):
            bad.append(f"value {e.value!r} is not the value the message shows after {named} = ")
    elif not run and _NAMED.match(body):  # a top-level key: ``key = value: ...``
        if e.param != _NAMED.match(body).group(1):
            bad.append(f"message names {_NAMED.match(body).group(1)!r} but param = {e.param!r}")
    elif e.param is not None and not run:
        bad.append(f"param {e.param!r} set but the message starts with no [section] key")
    if _STATES_VALID.search(body) and e.valid is None and (m or run):
        bad.append("the message states what is valid but valid is None")
    return bad


def check_fields(e: GearoptError) -> list[str]:
    """Problems with the fields of ``e`` (empty when consistent)."""
    msg, bad = str(e), []
    for f in ("param", "value", "valid", "detail"):
        if not hasattr(e, f):
            return [f"{type(e).__name__} has no field {f!r}: {msg[:120]}"]
    if isinstance(e, SceneError):  # named as [section] key, after the file name
        bad += _scene_problems(e, msg)
    else:
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
