"""The schema of scene sections: :class:`Field` (one key: kind, unit, default, checks),
:class:`Section` (a TOML table of fields and sub-tables) and :class:`Bounds` (a range in the scene
unit), with :func:`format_field` for ``gearopt studies``.

A base-layer module (it imports only :mod:`gearopt.errors` and :mod:`gearopt.units`): the option
sets of :mod:`gearopt.settings` build their scene sections with it, the study modules declare their
other keys with it, and the scene loader reads them. ``gearopt.io.schema`` and ``gearopt.io.scene``
re-export it.
"""

from __future__ import annotations

import datetime as _dt
import difflib
import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable

from .errors import SceneError, join_detail, shorten
from .units import KINDS, parse_quantity

__all__ = ["Field", "Section", "ToolSection", "Bounds", "KIND_UNITS", "ALIASES", "format_field", "problem",
           "toml_text", "type_name", "closest", "key_hint", "describe"]


#: Internal unit of each field kind (what the loaded value is in) and the unit of a bare number.
KIND_UNITS = {
    "int": ("", ""), "float": ("", ""), "bool": ("", ""), "str": ("", ""), "floats": ("", ""),
    "length": ("mm", "mm"), "angle": ("rad", "deg"), "inverse_length": ("1/mm", "1/mm"),
}



def toml_text(value: Any) -> str:
    """A value as it would be written in TOML (for messages), abbreviated when long."""
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, (_dt.date, _dt.time)):  # TOML dates and times are written bare, ISO 8601
        return shorten(value.isoformat())
    try:
        text = json.dumps(value, ensure_ascii=False,
                          default=lambda o: o.isoformat() if isinstance(o, (_dt.date, _dt.time)) else repr(o))
    except RecursionError:
        return "<an array or table nested too deeply to show>"
    except (TypeError, ValueError):
        text = repr(value)
    return shorten(text)


#: Keys that users write for a gearopt key (other standards, plain words): key -> gearopt key.
ALIASES = {
    "module": "m_n", "m": "m_n", "mn": "m_n", "m_t": "m_n", "normal_module": "m_n", "diametral_pitch": "P_n",
    "P": "P_n", "teeth": "z", "n_teeth": "z", "N": "z", "number_of_teeth": "z", "face_width": "b", "width": "b",
    "helix_angle": "beta", "pressure_angle": "alpha_n", "alpha": "alpha_n", "alpha_t": "alpha_n",
    "profile_shift": "x", "shift": "x", "x_n": "x", "center_distance": "a", "centre_distance": "a", "a_w": "a",
    "E_c": "a", "crowning": "a_pl", "lead_crowning": "a_pl", "profile_crowning": "a_c", "misalignment": "crossing",
}


@dataclass(frozen=True)
class Bounds:
    """A range check for :class:`Field`, with bounds in the field's *scene* unit (deg for angles,
    mm for lengths, ``Field.unit`` if set). ``Field(check=Bounds(lo=0, lo_open=True))`` means > 0."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False

    def text(self, name: str, unit: str) -> str:
        u = f" {unit}" if unit else ""
        lo_op = "<" if self.lo_open else "<="
        hi_op = "<" if self.hi_open else "<="
        if self.lo is not None and self.hi is not None:
            return f"{self.lo:g} {lo_op} {name} {hi_op} {self.hi:g}{u}"
        if self.lo is not None:
            return f"{name} {'>' if self.lo_open else '>='} {self.lo:g}{u}"
        if self.hi is not None:
            return f"{name} {hi_op} {self.hi:g}{u}"
        return f"any {name}"

    def ok(self, value_in_scene_unit: float) -> bool:
        v = value_in_scene_unit
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        if self.hi is not None and (v >= self.hi if self.hi_open else v > self.hi):
            return False
        return True


@dataclass(frozen=True)
class Field:
    """One key of a scene section.

    Parameters
    ----------
    name : str
        The TOML key.
    kind : {"int", "float", "floats", "bool", "str", "length", "angle", "inverse_length"}
        Value type ("floats": a non-empty TOML array of numbers, checked by a callable). Quantities are
        converted to mm, rad, 1/mm by :func:`gearopt.units.parse_quantity`.
    required : bool
        Missing key is an error.
    default
        Value used when the key is absent, written as in a scene file (``20`` for an angle means
        20 deg) and converted like a given value. Without a default an absent key loads as ``None``.
    doc : str
        One line for ``gearopt studies`` and error messages.
    choices : sequence or None
        Allowed values (compared after conversion; use with "str" or "int").
    check : Bounds | callable(value) -> str | None | bool
        Extra validation of the converted value. A :class:`Bounds` is in the scene unit. A callable
        returns ``None``/``True`` when fine, else ``False`` or a text stating the valid range.
    unit : str or None
        Unit of a bare number for a quantity when it differs from the kind's default (e.g.
        ``"1/in"`` for a diametral pitch).
    bare : Bounds or None
        Plausible range of a *bare* number (no unit written), in the scene unit. A bare number
        outside it is refused as a likely unit slip (``alpha_n = 0.35`` meant in rad, ``crossing = 2``
        meant in arcmin); the same value with its unit written out is accepted if ``check`` allows it.
    typical : str or None
        The unit this quantity is usually given in (``"arcsec"`` for a TE level); suggested first
        when a bare number is out of range but would fit in that unit.
    """

    name: str
    kind: str
    required: bool = False
    default: Any = None
    doc: str = ""
    choices: tuple | list | None = None
    check: Bounds | Callable[[Any], Any] | None = None
    unit: str | None = None
    bare: Bounds | None = None
    typical: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in KIND_UNITS:
            raise ValueError(f"Field {self.name!r}: unknown kind {self.kind!r}; one of {sorted(KIND_UNITS)}")
        if self.unit is not None and (self.kind not in KINDS or self.unit not in KINDS[self.kind][0]):
            raise ValueError(f"Field {self.name!r}: unit {self.unit!r} does not fit kind {self.kind!r}")

    @property
    def scene_unit(self) -> str:
        """Unit of a bare number in the scene file ('' for plain numbers)."""
        return self.unit or KIND_UNITS[self.kind][1]

    @property
    def internal_unit(self) -> str:
        return KIND_UNITS[self.kind][0]

    def convert(self, value: Any, where: str, param: str | None = None) -> Any:
        """Check and convert a TOML value; ``where`` is the key path for messages (``"[pinion] z"``).

        Raises
        ------
        SceneError
            With ``param`` (default ``where``), ``value`` the value as written (TOML text), ``valid``
            (the type, set or range it must be in) and ``detail`` (the message after ``where = value``).
        """
        param = where if param is None else param
        shown = toml_text(value)

        def fail(detail: str, valid: str | None) -> SceneError:
            return SceneError(join_detail(f"{where} = {shown}", detail), param=param, value=shown, valid=valid,
                              detail=detail)

        k = self.kind
        if k == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                raise fail(f": expected an integer, got {type_name(value)}.", "an integer")
            out = value
        elif k == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise fail(f": expected a number, got {type_name(value)}.", "a number")
            if not math.isfinite(value):
                raise fail(": not a finite number.", "a finite number")
            out = float(value)
        elif k == "floats":
            if (not isinstance(value, list) or not value
                    or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value)):
                raise fail(f": expected a non-empty array of numbers such as [10, 50, 100], got {type_name(value)}.",
                           "a non-empty array of numbers")
            if not all(math.isfinite(v) for v in value):
                raise fail(": every entry must be a finite number.", "an array of finite numbers")
            out = [float(v) for v in value]
        elif k == "bool":
            if not isinstance(value, bool):
                raise fail(f": expected true or false, got {type_name(value)}.", "true or false")
            out = value
        elif k == "str":
            if not isinstance(value, str):
                raise fail(f": expected a string (in quotes), got {type_name(value)}.", "a string (in quotes)")
            out = value
        else:
            if isinstance(value, (dict, list)):
                raise fail(f": expected a {k} (number or \"<number> <unit>\"), got {type_name(value)}.",
                           f"a {k} (number or \"<number> <unit>\")")
            try:
                out = parse_quantity(value, k, where, bare_unit=self.unit)
            except SceneError as e:  # its message names where; its param is where, ours may differ
                raise SceneError(str(e), param=param, value=e.value, valid=e.valid, detail=e.detail) from None
        if self.choices is not None and out not in self.choices:
            hint = closest(str(out), [str(c) for c in self.choices])
            valid = f"one of {', '.join(toml_text(c) for c in self.choices)}"
            raise fail(f"is not allowed; valid: {valid}.{hint}", valid)
        bare_number = self.kind in KINDS and isinstance(value, (int, float)) and not isinstance(value, bool)
        hint = self._unit_hint(value, self.bare) if self.bare is not None and bare_number else ""
        if hint and value != 0 and not self.bare.ok(value):  # implausible as written, plausible in another unit
            valid = self.bare.text(self.name, self.scene_unit)
            raise fail(f": a bare number is read as {value:g} {self.scene_unit}, which is implausible for "
                       f"{self.name} (plausible without a unit: {valid}). Write the unit out.{hint}", valid)
        if self.check is not None:
            if isinstance(self.check, Bounds):
                shown_internal = self.to_scene_unit(out)
                if not self.check.ok(shown_internal):
                    hint = self._unit_hint(value, self.check) if bare_number else ""
                    valid = self.check.text(self.name, self.scene_unit)
                    raise fail(f"is out of range; valid: {valid}."
                               + (f" A bare number is read as {self.scene_unit}.{hint}" if hint else ""), valid)
            else:
                res = self.check(out)
                if res is False or isinstance(res, str):
                    valid = res if isinstance(res, str) else None
                    raise fail("is out of range" + (f"; valid: {valid}." if valid else "."), valid)
        return out

    def _unit_hint(self, number: float, bounds: Bounds) -> str:
        """``' Did you mean "8 arcsec"?'`` when the bare ``number`` fits ``bounds`` in another unit of
        its kind (the :attr:`typical` unit first and alone if it fits), else ``""``."""
        table, _ = KINDS[self.kind]
        here = table[self.scene_unit]
        fits = [u for u in table if u != self.scene_unit and u.isascii() and u not in ("'", '"')
                and bounds.ok(number * table[u] / here)]
        if self.typical in fits:
            fits = [self.typical]
        if not fits:
            return ""
        alts = " or ".join(toml_text(f"{number:g} {u}") + (f" (= {number * table[u] / here:.6g} {self.scene_unit})"
                                                        if u == "rad" else "") for u in fits[:3])
        return f" Did you mean {alts}?"

    def to_scene_unit(self, internal: float) -> float:
        """An internal value (mm, rad, 1/mm) expressed in the scene unit of this field."""
        if self.kind not in KINDS:
            return internal
        table, _ = KINDS[self.kind]
        return internal / table[self.scene_unit]



def _parse_fields(fields, table: dict, loc_of, values: dict, given: set, errors: list) -> None:
    """Convert the ``fields`` of a table into ``values`` (the default, or None, when absent), adding
    the keys given to ``given`` and each problem, a structured :class:`SceneError` stated at
    ``loc_of(name)`` (e.g. ``"[pinion] z"``), to ``errors``."""
    for f in fields:
        loc = loc_of(f.name)
        if f.name in table:
            given.add(f.name)
            try:
                values[f.name] = f.convert(table[f.name], loc)
            except SceneError as e:
                errors.append(e)
        elif f.required:
            errors.append(problem(f"{loc}: missing required key ({describe(f)}).", loc, valid=describe(f)))
        else:
            values[f.name] = None if f.default is None else f.convert(f.default, loc + " (default)", param=loc)

@dataclass(frozen=True)
class Section:
    """A TOML table of a scene: its fields and nested sub-tables (``[pinion] rack = {...}``)."""

    name: str
    fields: list = field(default_factory=list)
    required: bool = False
    doc: str = ""
    subsections: list = field(default_factory=list)
    array: bool = False  #: as a subsection: an array of tables (``[[a.b]]`` or ``b = [{...}, ...]``)
    #: Keys that moved elsewhere: refused with ``moved_hint(table)``, the text saying where to (one
    #: error for all of them).
    moved: tuple = ()
    moved_hint: Callable[[dict], str] | None = None

    def __post_init__(self) -> None:
        names = [f.name for f in self.fields] + [s.name for s in self.subsections]
        if len(set(names)) != len(names):
            raise ValueError(f"Section {self.name!r}: duplicate keys in {names}")

    @property
    def keys(self) -> list[str]:
        return [f.name for f in self.fields] + [s.name for s in self.subsections]

    def parse(self, table: Any, path: str, errors: list, homes: dict | None = None) -> tuple[dict, set[str]]:
        """Convert a TOML table. Returns (values, keys given); problems are appended to ``errors``
        as :class:`~gearopt.errors.SceneError` (message without the file name; ``param`` the
        ``[section] key`` or ``[section]``, ``value`` as written, ``valid``; see :func:`problem`).

        ``values`` has every field (``None`` / default when absent) and, for each subsection, the
        parsed sub-dict (or ``None`` when absent). Given keys of subsections appear in the set as
        ``"sub.key"``. ``homes`` maps a key to the sections (``"[pair]"``) where it belongs, for the
        hint on a key written in the wrong section.
        """
        where = f"[{path}]"
        values: dict[str, Any] = {}
        given: set[str] = set()
        if not isinstance(table, dict):
            valid = f"a table (a [{path}] section or {{...}})"
            errors.append(problem(f"{where} must be a table (a [{path}] section or {{...}}), got {type_name(table)} "
                                  f"{toml_text(table)}.", where, toml_text(table), valid))
            return values, given
        gone = [k for k in table if k in self.moved]
        if gone:
            errors.append(problem(f"{where} {', '.join(gone)}: "
                                  f"{self.moved_hint(table) if self.moved_hint else 'removed'}",
                                  f"{where} {gone[0]}"))
        for key in table:
            if key not in self.keys and key not in self.moved:
                errors.append(problem(f"{where} {shorten(key)}: unknown key.{key_hint(key, self.keys, homes or {})} "
                                      f"Valid keys: {', '.join(self.keys)}.", f"{where} {shorten(key)}",
                                      valid=", ".join(self.keys)))
        _parse_fields(self.fields, table, lambda name: f"{where} {name}", values, given, errors)
        for sub in self.subsections:
            if sub.name in table and sub.array:
                items = table[sub.name]
                if not isinstance(items, list):
                    valid = f"an array of tables ([[{path}.{sub.name}]] or {sub.name} = [{{...}}, ...])"
                    errors.append(problem(f"[{path}.{sub.name}] must be {valid}, got {type_name(items)} {toml_text(items)}.",
                                          f"[{path}.{sub.name}]", toml_text(items), valid))
                    values[sub.name] = None
                    continue
                values[sub.name] = [sub.parse(item, f"{path}.{sub.name}][{i}", errors, homes)[0] for i, item in enumerate(items)]
                given |= {sub.name}
            elif sub.name in table:
                vals, sub_given = sub.parse(table[sub.name], f"{path}.{sub.name}", errors, homes)
                values[sub.name] = vals
                given |= {f"{sub.name}.{k}" for k in sub_given} | {sub.name}
            elif sub.required:
                errors.append(problem(f"{where} {sub.name}: missing required table.", f"{where} {sub.name}"))
            else:
                values[sub.name] = None
        return values, given



@dataclass(frozen=True)
class ToolSection(Section):
    """An inline table whose keys depend on its ``kind`` (``[pinion] tool = {kind = "shaper", z = 25}``):
    ``variants[kind]`` lists the fields of each kind. Problems are reported as ``[pinion] tool.<key>``."""

    variants: dict = field(default_factory=dict)
    noun: str = "tool"  #: what the table describes, in messages ("tool", "distribution")
    example: str = '{kind = "shaper", z = 25}'  #: an example table for the messages

    @property
    def keys(self) -> list[str]:
        out = ["kind"]
        for fs in self.variants.values():
            out += [f.name for f in fs if f.name not in out]
        return out

    def parse(self, table: Any, path: str, errors: list, homes: dict | None = None) -> tuple[dict, set[str]]:
        owner, _, name = path.rpartition(".")
        at = f"[{owner}] {name}" if owner else f"[{name}]"
        kinds = ", ".join(toml_text(k) for k in self.variants)
        if not isinstance(table, dict):
            valid = f"an inline table such as {self.example} (kind one of {kinds})"
            detail = f": expected {valid}, got {type_name(table)}."
            errors.append(problem(f"{at} = {toml_text(table)}{detail}", at, toml_text(table), valid, detail))
            return {}, set()
        if "kind" not in table:
            errors.append(problem(f"{at}.kind: missing; valid: one of {kinds} (the {self.noun}'s keys depend on it).",
                                  f"{at}.kind", valid=f"one of {kinds}"))
            return {}, set()
        kind = table["kind"]
        if not isinstance(kind, str) or kind not in self.variants:
            hint = closest(str(kind), list(self.variants)) if isinstance(kind, str) else ""
            detail = f"is not a {self.noun} kind; valid: one of {kinds}.{hint}"
            errors.append(problem(f"{at}.kind = {toml_text(kind)} {detail}", f"{at}.kind", toml_text(kind), f"one of {kinds}",
                                  detail))
            return {}, set()
        fs = self.variants[kind]
        names = ["kind"] + [f.name for f in fs]
        values: dict[str, Any] = {"kind": kind}
        given = {"kind"}
        for key in table:
            if key in names:
                continue
            others = [k for k, v in self.variants.items() if any(f.name == key for f in v)]
            hint = (f" {key} is a key of kind = {' or '.join(toml_text(k) for k in others)}." if others
                    else closest(str(key), names))
            errors.append(problem(f"{at}.{shorten(str(key))}: not a key of a {self.noun} of kind = {toml_text(kind)}.{hint} "
                                  f"Valid keys: {', '.join(names)}.", f"{at}.{shorten(str(key))}",
                                  valid=", ".join(names)))
        _parse_fields(fs, table, lambda name: f"{at}.{name}", values, given, errors)
        return values, given


def problem(text: str, param: str | None = None, value: Any = None, valid: str | None = None,
            detail: str | None = None) -> SceneError:
    """One problem of a scene as the loader collects them (see :meth:`Section.parse`): a
    :class:`~gearopt.errors.SceneError` with the message ``text`` (without the file name), ``param``
    the ``[section] key`` (or ``[section]``) it is about, ``value`` the value as written (TOML
    text), ``valid`` the valid type, set or range as ``text`` states it, ``detail`` the text after
    ``param = value`` when ``text`` starts so."""
    return SceneError(text, param=param, value=value, valid=valid, detail=detail)


def type_name(value: Any) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string", dict: "a table",
            list: "an array", _dt.date: "a date", _dt.datetime: "a date-time", _dt.time: "a time of day"}.get(
                type(value), type(value).__name__)


def closest(word: str, options: Iterable[str]) -> str:
    m = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    if not m:
        m = [o for o in options if o.lower() == word.lower()]
    return f" Did you mean {m[0]!r}?" if m else ""


def key_hint(key: str, keys: Iterable[str], homes: dict) -> str:
    """Hint for an unknown ``key`` in a section with ``keys``: a known alias (``module`` -> ``m_n``),
    the section(s) where the key belongs, or the closest key by spelling."""
    target = ALIASES.get(key) or ALIASES.get(key.lower())
    if target is not None and target != key:
        if target in keys:
            return f" Did you mean {target!r} (gearopt's name for it)?"
        if target in homes:
            return f" Did you mean {target!r}? It belongs in {' or '.join(homes[target])}."
    if key in homes:
        return f" {key} belongs in {' or '.join(homes[key])}, not here."
    return closest(key, keys)


def describe(f: Field) -> str:
    bits = [f.kind]
    if f.scene_unit:
        bits.append(f"bare number in {f.scene_unit}")
    if f.choices is not None:
        bits.append("one of " + ", ".join(toml_text(c) for c in f.choices))
    if f.doc:
        bits.append(f.doc)
    return "; ".join(bits)


def format_field(f: Field) -> str:
    """One line describing a field (for ``gearopt studies``)."""
    from .units import UNIT_REQUIRED

    req = "required" if f.required else (f"default {toml_text(f.default)}" if f.default is not None else "optional")
    unit = f" [{f.scene_unit}]" if f.scene_unit else ""
    shown, bounds = f.scene_unit, f.check
    if f.kind == "angle" and f.typical == "arcsec":  # TE levels: in the unit users write them
        table, _ = KINDS["angle"]
        k = table[f.scene_unit] / table["arcsec"]
        shown = "arcsec"
        unit = f' [arcsec: write "8 arcsec"; a bare number is {f.scene_unit}]'
        if isinstance(bounds, Bounds):
            bounds = Bounds(*(None if v is None else v * k for v in (bounds.lo, bounds.hi)), bounds.lo_open,
                            bounds.hi_open)
    elif f.scene_unit in UNIT_REQUIRED:
        unit = f' [{f.scene_unit}, written with its unit: "12 {f.scene_unit}"]'
    choices = f" one of {', '.join(toml_text(c) for c in f.choices)};" if f.choices is not None else ""
    check = f" {bounds.text(f.name, shown)};" if isinstance(bounds, Bounds) else ""
    return f"{f.name} ({f.kind}{unit}, {req}):{choices}{check} {f.doc}".rstrip()
