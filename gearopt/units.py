"""Units at the edges: gearopt computes in mm and rad; degrees, arcmin, arcsec, inches only here.

A scene may give a length or an angle either as a bare number (taken in the documented default
unit: mm for lengths, deg for angles) or as a string with a unit, e.g. ``"20 deg"``, ``"3 arcmin"``,
``"0.5 in"``. A unit of the wrong kind (``"20 mm"`` for an angle) is an error.

One exception, and it is a refusal, not another default: a quantity whose scene unit is one of
:data:`UNIT_REQUIRED` (micro-geometry amounts, in um) must be written with its unit (``"12 um"``);
a bare number there is refused with that hint (only a bare ``0`` is accepted, the same in every
unit), so that a bare number never means anything but mm for a length.
"""

from __future__ import annotations

import math
import re

from .errors import SceneError, check_number, shorten

DEG = math.pi / 180.0  #: one degree in rad
ARCMIN = DEG / 60.0  #: one arc minute in rad
ARCSEC = DEG / 3600.0  #: one arc second in rad
RAD_TO_ARCSEC = 1.0 / ARCSEC  #: 206264.806... arcsec per rad
INCH = 25.4  #: one inch in mm

_LENGTH = {"mm": 1.0, "m": 1000.0, "cm": 10.0, "um": 1e-3, "µm": 1e-3, "in": INCH}
_ANGLE = {"rad": 1.0, "deg": DEG, "°": DEG, "arcmin": ARCMIN, "'": ARCMIN, "arcsec": ARCSEC, '"': ARCSEC}
_INV_LENGTH = {"1/mm": 1.0, "1/m": 1e-3, "1/in": 1.0 / INCH}
#: Scene units in which a bare number is refused (the unit must be written: ``"12 um"``).
UNIT_REQUIRED = ("um",)
KINDS = {"length": (_LENGTH, "mm"), "angle": (_ANGLE, "deg"), "inverse_length": (_INV_LENGTH, "1/mm")}

_QTY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S+)?\s*$")


def _show(value) -> str:
    """A scene value as written in TOML (``true``, ``"20 mm"``, ``3.5``), abbreviated when long."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return shorten('"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"')
    return shorten(repr(value) if not isinstance(value, float) else f"{value!r}")


def _a(word: str) -> str:
    return ("an " if word[0] in "aeiou" else "a ") + word.replace("_", " ")


def deg(value_deg: float) -> float:
    """Degrees to radians."""
    if isinstance(value_deg, (str, bytes)):
        check_number("value_deg", value_deg, "a number in deg")
    return value_deg * DEG


def to_deg(value_rad: float) -> float:
    """Radians to degrees."""
    if isinstance(value_rad, (str, bytes)):
        check_number("value_rad", value_rad, "a number in rad")
    return value_rad / DEG


def parse_quantity(value: float | str, kind: str, name: str, bare_unit: str | None = None,
                   unit_required: bool | None = None) -> float:
    """Convert a scene value to gearopt's internal unit (mm, rad or 1/mm).

    Parameters
    ----------
    value : float | int | str
        A bare number (in ``bare_unit``) or ``"<number> <unit>"``.
    kind : {"length", "angle", "inverse_length"}
        Physical dimension expected.
    name : str
        Parameter name used in error messages (the errors' ``param``).
    bare_unit : str or None
        Unit of a bare number (and of a string without unit), one of the units of ``kind``;
        default the kind's default unit (mm, deg, 1/mm).
    unit_required : bool, optional
        Refuse a number without a unit (a bare ``0`` excepted); default: ``bare_unit`` is one of
        :data:`UNIT_REQUIRED` (a micro-geometry amount in um).

    Returns
    -------
    float
        The value in mm, rad or 1/mm.

    Raises
    ------
    SceneError
        With ``param = name``, ``value`` the value as written (TOML text), ``valid`` and ``detail``.
    """
    table, default = KINDS[kind]
    if bare_unit is not None:
        if bare_unit not in table:
            raise ValueError(f"bare_unit {bare_unit!r} is not a unit of kind {kind!r}; one of {sorted(table)}")
        default = bare_unit
    shown = _show(value)

    def fail(detail: str, valid: str):
        return SceneError(f"{name} = {shown}{detail}", param=name, value=shown, valid=valid, detail=detail)

    if isinstance(value, bool):
        raise fail(f": expected a {kind} (number or '<number> <unit>'), got a boolean.",
                   f"a {kind} (number or '<number> <unit>')")
    if isinstance(value, (int, float)):
        number, unit = float(value), default
    elif isinstance(value, str):
        m = _QTY.match(value)
        if not m:
            raise fail(f": expected '<number> <unit>' with unit one of {sorted(table)}.",
                       f"'<number> <unit>' with unit one of {sorted(table)}")
        number, unit = float(m.group(1)), (m.group(2) or default)
    else:
        raise fail(f": expected a {kind} (number or '<number> <unit>'), got {type(value).__name__}.",
                   f"a {kind} (number or '<number> <unit>')")
    if unit_required is None:
        unit_required = bare_unit in UNIT_REQUIRED
    if unit_required and (isinstance(value, (int, float)) or not m.group(2)) and number != 0:
        v = f"{number:g}"
        if kind == "length" and default == "um" and abs(number) < 1:  # below a micron: mm was probably meant
            fix = f"\"{v} mm\" (= {number * 1000:g} um) or \"{v} um\""
        elif kind == "length":
            fix = f"\"{v} {default}\" (or \"{number * table[default] / table['mm']:g} mm\")"
        else:
            fix = f"\"{v} {default}\""
        raise fail(f": a bare number is refused for a micro-geometry amount (a bare length is mm everywhere "
                   f"else; amounts are microns): write {fix}.",
                   f"a number with its unit, e.g. \"{v} {default}\"")
    if unit not in table:
        kinds = [k for k, (t, _) in KINDS.items() if unit in t]
        what = f"{_a(kinds[0])} unit" if kinds else "an unknown unit"
        raise fail(f": '{unit}' is {what}, but {name} is {_a(kind)}; use one of {sorted(table)} "
                   f"(a bare number means {default}).", f"one of {sorted(table)}")
    if not math.isfinite(number):
        raise fail(": not a finite number.", "a finite number")
    return number * table[unit]
