"""Exception hierarchy of gearopt.

Every error names what is wrong, the offending value and, where one exists, the valid range,
so that a user can fix the input without reading the source.

Besides its message, every :class:`GearoptError` carries the same facts as fields, for code that
acts on them (the scene loader maps them back to ``[section] key`` of the scene file):

``param``
    The parameter as gearopt names it: ``"pinion.z"``, ``"rack.alpha_n"``, ``"pair.a"``,
    ``"mis.dE"``, ``"target.te_level"``, ``"fea.teeth"``, ``"solver"``... (for a
    :class:`SceneError`: ``"[section] key"``). ``None`` when the error is not about one parameter
    (a solver that did not converge, a missing compiler).
``value``
    The offending value, in the unit the message shows it in (``None`` when there is no single
    value, e.g. an empty sweep).
``valid``
    The valid range or set as the message states it (``"z >= 3 teeth"``), or ``None``.
``detail``
    When the message starts with ``param = value``: the rest of it, without a leading space
    (``"is out of range; valid: ..."``, ``": expected a finite number."``), so that a caller can
    restate the error for the key as the user wrote it (see :func:`join_detail`); else ``None``.

Classes:

=====================  =========================================================================
GearoptError           base class
GeometryError          impossible or inconsistent gear data (also a ``ValueError``)
ArgumentError          a wrong argument of a public function (a ``GeometryError`` and ``TypeError``)
OptionError            a solver or study option out of its valid set (not gear data; a ``ValueError``)
ConvergenceError       a solver did not reach its tolerance (also a ``RuntimeError``)
LineContactError       the point-contact TCA is singular: the flanks are in line contact
SynthesisError         the crowning / local synthesis NLP found no design
SceneError             a malformed scene file
ResultsError           results cannot be written
CalculixError          CalculiX is missing, failed, or its results fail the physical checks
ExecutionError         a study's executor failed: no Dask scheduler answers, workers keep dying
=====================  =========================================================================
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterable


class GearoptError(Exception):
    """Base class of every error raised on purpose by gearopt.

    Parameters
    ----------
    *args
        The message (as for :class:`Exception`).
    param : str or None
        The parameter the error is about, as gearopt names it (``"pinion.z"``); None if none.
    value
        The offending value, in the unit of the message; None if none.
    valid : str or None
        The valid range or set, as the message states it; None if not stated.
    detail : str or None
        The message after its leading ``param = value`` (when it starts so), e.g. ``"is out of
        range; valid: z >= 3 teeth."``; None otherwise.
    """

    def __init__(self, *args: object, param: str | None = None, value: Any = None, valid: str | None = None,
                 detail: str | None = None) -> None:
        super().__init__(*args)
        self.param = param
        self.value = value
        self.valid = valid
        self.detail = detail


class GeometryError(GearoptError, ValueError):
    """Impossible or inconsistent gear data (undercut, pointed tip, too small centre distance, ...)."""


class ConvergenceError(GearoptError, RuntimeError):
    """A numerical solver did not reach its tolerance (the result is not returned)."""


class LineContactError(ConvergenceError):
    """The point-contact tangency equations are singular because the flanks are in line contact
    (conjugate surfaces: no crowning, no angular misalignment). Solve line contact instead (a TCA
    with ``contact="line"`` in a given pinion section); :class:`gearopt.contact.EdgeContact` does
    that on its own."""


class SynthesisError(ConvergenceError):
    """The NLP found no design: infeasible request or solver failure (message names the binding
    constraints)."""


class SceneError(GearoptError, ValueError):
    """A scene file is malformed: unknown or missing keys, wrong types or units, bad values.
    ``param`` is ``"[section] key"`` when the error is about one key (``"[pinion] z"``,
    ``"[pinion] tool.d_p0"``, ``"[tca.cases][0] dE"``; ``"[section]"`` for a whole section) and
    ``value`` the value as written in the file (TOML text).

    Parameters
    ----------
    *args, param, value, valid, detail
        As for :class:`GearoptError`.
    source : path or None
        The scene file the error is about (set for every error the loader and the studies raise
        for a scene; its message then starts with it).
    problems : sequence of SceneError
        The individual problems the loader collected into this error (one or several; each with
        its own ``param``, ``value``, ``valid`` and a message without the file name; the message of
        this error lists them in this order), its own ``param``, ``value``, ``valid`` being those of
        the first. ``[]`` for an error not collected from problems.
    """

    def __init__(self, *args: object, source: str | None = None, problems: Iterable[SceneError] = (),
                 **fields: Any) -> None:
        super().__init__(*args, **fields)
        self.source = source
        self.problems = list(problems)


class ArgumentError(GeometryError, TypeError):
    """A public function or method was called with a wrong argument: wrong type (a dict where a
    :class:`~gearopt.meshing.tca.Misalignment` is expected), wrong vector length, an empty or
    non-finite sweep, a value outside its valid range. The message names the argument.

    A :class:`GeometryError` (hence also ``ValueError``) and a ``TypeError``, so that code catching
    either for invalid arguments keeps working."""


class ParameterNameError(ArgumentError, KeyError):
    """A name that the TCA parameter layout (``tca.layout``) does not have, or gives twice. Also a
    ``KeyError``, as a failed look-up by name."""

    __str__ = Exception.__str__  # the message as written (KeyError would quote it)


class OptionError(GearoptError, ValueError):
    """A solver or study option is outside its valid set: the TCA's ``solver``, ``contact``,
    ``side``, ``delta``, ``z_section``; positions and case counts; tolerances; optimizer bounds;
    finite element mesh and solver settings. Not gear data, hence not a :class:`GeometryError`."""


class ResultsError(GearoptError, ValueError):
    """Results cannot be written: a non-finite number where the schema has none, or an output
    path that cannot hold the results directory (an existing file, an unwritable place, ``""``).
    Nothing is written."""


class CalculixError(GearoptError, RuntimeError):
    """CalculiX is missing, failed, timed out, or its result fails the physical checks."""


class ExecutionError(GearoptError, RuntimeError):
    """A study's executor failed: the Dask scheduler cannot be reached, or workers keep dying."""


#: Longest value text echoed in a message; longer values are abbreviated (see :func:`shorten`).
MAX_ECHO = 60


def shorten(text: str, limit: int = MAX_ECHO) -> str:
    """``text`` cut to about ``limit`` characters for an error message, saying how long it was."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit - 20]}...{text[-8:]} ({len(text)} characters)"


def check_number(name: str, value: Any, what: str = "a finite number", cls: type[GearoptError] | None = None) -> float:
    """``value`` as a float, or an error naming ``name`` if it is not a finite real number
    (strings such as ``"8 arcsec"``, booleans, None, NaN, inf are refused: the Python API takes
    numbers in gearopt's internal units, mm and rad). The error is ``cls`` (default
    :class:`ArgumentError`) with ``param=name``, ``value=value``, ``valid=what``."""
    import math
    import numbers

    cls = ArgumentError if cls is None else cls
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        hint = " (the Python API takes plain numbers in mm and rad; units in strings are for scenes)" \
            if isinstance(value, str) else ""
        detail = f": expected {what}{hint}."
        raise cls(f"{name} = {type(value).__name__} {shorten(repr(value))}{detail}",
                  param=name, value=value, valid=what, detail=detail)
    v = float(value)
    if not math.isfinite(v):
        raise cls(f"{name} = {v}: expected {what}.", param=name, value=v, valid=what, detail=f": expected {what}.")
    return v


def out_of_range(name: str, value: Any, valid: str, hint: str = "",
                 cls: type[GearoptError] = GeometryError) -> GearoptError:
    """Build the standard 'parameter out of range' error.

    Parameters
    ----------
    name : str
        Parameter name as the user writes it (e.g. ``"pinion.z"``); the error's ``param``.
    value
        The offending value (already converted to the unit stated in ``valid``); the error's ``value``.
    valid : str
        Human-readable valid range, with units (e.g. ``"0 < alpha_n < 45 deg"``); the error's ``valid``.
    hint : str
        Optional sentence saying how to fix it.
    cls : type
        The error class: :class:`GeometryError` for gear data, :class:`OptionError` for solver and
        study options, :class:`ArgumentError` for other arguments.
    """
    detail = f"is out of range; valid: {valid}." + (" " + hint if hint else "")
    return cls(f"{name} = {shorten(repr(value))} {detail}", param=name, value=value, valid=valid, detail=detail)


def value_text(value: Any) -> str:
    """How a message shows ``value`` after ``name = `` (strings bare, other values by repr,
    abbreviated)."""
    return shorten(value if isinstance(value, str) else repr(value))


def join_detail(head: str, detail: str) -> str:
    """``head`` (``"[pinion] z = 2"``) followed by an error's :attr:`~GearoptError.detail`, with a
    space unless the detail starts with punctuation."""
    return head + ("" if detail.startswith((":", ";", ",", ".")) else " ") + detail


def option_error(name: str, value: Any, valid: str, hint: str = "") -> OptionError:
    """:func:`out_of_range` for a solver or study option (an :class:`OptionError`)."""
    return out_of_range(name, value, valid, hint, cls=OptionError)
