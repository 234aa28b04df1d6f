"""Exception hierarchy of gearopt.

Every error names what is wrong, the offending value and, where one exists, the valid range,
so that a user can fix the input without reading the source.
"""

from __future__ import annotations


class GearoptError(Exception):
    """Base class of every error raised on purpose by gearopt."""


class GeometryError(GearoptError, ValueError):
    """Impossible or inconsistent gear data (undercut, pointed tip, too small centre distance, ...)."""


class ConvergenceError(GearoptError, RuntimeError):
    """A numerical solver did not reach its tolerance (the result is not returned)."""


class SceneError(GearoptError, ValueError):
    """A scene file is malformed: unknown or missing keys, wrong types or units, bad values."""


class ArgumentError(GeometryError, TypeError):
    """A public function or method was called with a wrong argument: wrong type (a dict where a
    :class:`~gearopt.meshing.tca.Misalignment` is expected), wrong vector length, an empty or
    non-finite sweep, a value outside its valid range. The message names the argument.

    A :class:`GeometryError` (hence also ``ValueError``) and a ``TypeError``, so that code catching
    either for invalid arguments keeps working."""


class ResultsError(GearoptError, ValueError):
    """Results cannot be written: a non-finite number where the schema has none, or an output
    path that cannot hold the results directory (an existing file, an unwritable place, ``""``).
    Nothing is written."""


#: Longest value text echoed in a message; longer values are abbreviated (see :func:`shorten`).
MAX_ECHO = 60


def shorten(text: str, limit: int = MAX_ECHO) -> str:
    """``text`` cut to about ``limit`` characters for an error message, saying how long it was."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit - 20]}...{text[-8:]} ({len(text)} characters)"


def check_number(name: str, value, what: str = "a finite number") -> float:
    """``value`` as a float, or :class:`ArgumentError` naming ``name`` if it is not a finite real
    number (strings such as ``"8 arcsec"``, booleans, None, NaN, inf are refused: the Python API
    takes numbers in gearopt's internal units, mm and rad)."""
    import math
    import numbers

    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        hint = " (the Python API takes plain numbers in mm and rad; units in strings are for scenes)" \
            if isinstance(value, str) else ""
        raise ArgumentError(f"{name} = {type(value).__name__} {shorten(repr(value))}: expected {what}{hint}.")
    v = float(value)
    if not math.isfinite(v):
        raise ArgumentError(f"{name} = {v}: expected {what}.")
    return v


def out_of_range(name: str, value, valid: str, hint: str = "", cls=GeometryError) -> GearoptError:
    """Build the standard 'parameter out of range' error.

    Parameters
    ----------
    name : str
        Parameter name as the user writes it (e.g. ``"pinion.z"``).
    value
        The offending value (already converted to the unit stated in ``valid``).
    valid : str
        Human-readable valid range, with units (e.g. ``"0 < alpha_n < 45 deg"``).
    hint : str
        Optional sentence saying how to fix it.
    """
    msg = f"{name} = {shorten(repr(value))} is out of range; valid: {valid}."
    if hint:
        msg += " " + hint
    return cls(msg)
