"""Scene files: TOML input that declares a gear pair and the study to run on it.

A scene declares only what its study needs. The common sections (see :data:`COMMON_SECTIONS`)::

    [scene]   name (required), description, study (required; a registered study)
    [rack]    optional, for both members: preset ("A".."D", ISO 53), alpha_n, h_aP, h_fP, rho_fP, a_c, u_0
    [pinion]  z, b (required), x, k or d_a, A_sne, A_sni, a_pl, allow_undercut; optional subtables
              rack = {...} (overrides [rack]) and tool = {kind = "rack" | "hob" | "shaper", ...} (the
              cutting tool; default the rack-cutter)
    [gear]    same as [pinion]
    [pair]    m_n or P_n (exactly one), beta, hand (the pinion's; the gear gets the opposite), a
    [output]  optional: plots, dpi

and each study adds its own sections (:mod:`gearopt.studies`). Lengths are mm, angles deg, unless a
value carries its unit as a string (``"0.5 in"``, ``"20 deg"``, ``"0.3 rad"``; see
:mod:`gearopt.units`). Internally everything is mm, rad, 1/mm.

Every problem (TOML syntax, unknown or missing key, wrong type or unit, impossible gear) raises one
:class:`~gearopt.errors.SceneError` whose message starts with the file name and names the key as
``[section] key``.
"""

from __future__ import annotations

import datetime as _dt
import difflib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

from ..errors import GeometryError, SceneError, shorten
from ..gears import BasicRack, Gear, GearPair
from ..geometry.tools import TOOL_KINDS, TOOLS, RackCutter
from ..units import KINDS, parse_quantity

__all__ = [
    "Field", "Section", "Bounds", "Scene", "load_scene", "COMMON_SECTIONS", "KIND_UNITS", "format_field",
]

#: Internal unit of each field kind (what the loaded value is in) and the unit of a bare number.
KIND_UNITS = {
    "int": ("", ""), "float": ("", ""), "bool": ("", ""), "str": ("", ""),
    "length": ("mm", "mm"), "angle": ("rad", "deg"), "inverse_length": ("1/mm", "1/mm"),
}

_MISSING = object()


def _toml(value) -> str:
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
    kind : {"int", "float", "bool", "str", "length", "angle", "inverse_length"}
        Value type. Quantities are converted to mm, rad, 1/mm by :func:`gearopt.units.parse_quantity`.
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

    def __post_init__(self):
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

    def convert(self, value, where: str) -> Any:
        """Check and convert a TOML value; ``where`` is the key path for messages."""
        k = self.kind
        if k == "int":
            if isinstance(value, bool) or not isinstance(value, int):
                raise SceneError(f"{where} = {_toml(value)}: expected an integer, got {_type(value)}.")
            out = value
        elif k == "float":
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise SceneError(f"{where} = {_toml(value)}: expected a number, got {_type(value)}.")
            if not math.isfinite(value):
                raise SceneError(f"{where} = {_toml(value)}: not a finite number.")
            out = float(value)
        elif k == "bool":
            if not isinstance(value, bool):
                raise SceneError(f"{where} = {_toml(value)}: expected true or false, got {_type(value)}.")
            out = value
        elif k == "str":
            if not isinstance(value, str):
                raise SceneError(f"{where} = {_toml(value)}: expected a string (in quotes), got {_type(value)}.")
            out = value
        else:
            if isinstance(value, (dict, list)):
                raise SceneError(f"{where} = {_toml(value)}: expected a {k} (number or \"<number> <unit>\"), "
                                 f"got {_type(value)}.")
            if self.unit is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
                value_in = f"{value!r} {self.unit}"
                try:
                    out = parse_quantity(value_in, k, where)
                except SceneError:  # e.g. inf: report the value as written
                    raise SceneError(f"{where} = {_toml(value)}: not a finite number.") from None
            else:
                try:
                    out = parse_quantity(value, k, where)
                except SceneError as e:
                    if self.unit is None:
                        raise
                    msg = str(e).replace(f"(a bare number means {KINDS[k][1]})", f"(a bare number means {self.unit})")
                    raise SceneError(msg) from None
        if self.choices is not None and out not in self.choices:
            hint = _closest(str(out), [str(c) for c in self.choices])
            raise SceneError(f"{where} = {_toml(value)} is not allowed; valid: one of "
                             f"{', '.join(_toml(c) for c in self.choices)}.{hint}")
        bare_number = self.kind in KINDS and isinstance(value, (int, float)) and not isinstance(value, bool)
        hint = self._unit_hint(value, self.bare) if self.bare is not None and bare_number else ""
        if hint and value != 0 and not self.bare.ok(value):  # implausible as written, plausible in another unit
            raise SceneError(f"{where} = {_toml(value)}: a bare number is read as {value:g} {self.scene_unit}, which "
                             f"is implausible for {self.name} (plausible without a unit: "
                             f"{self.bare.text(self.name, self.scene_unit)}). Write the unit out.{hint}")
        if self.check is not None:
            if isinstance(self.check, Bounds):
                shown = self.to_scene_unit(out)
                if not self.check.ok(shown):
                    hint = self._unit_hint(value, self.check) if bare_number else ""
                    raise SceneError(f"{where} = {_toml(value)} is out of range; valid: "
                                     f"{self.check.text(self.name, self.scene_unit)}."
                                     + (f" A bare number is read as {self.scene_unit}.{hint}" if hint else ""))
            else:
                res = self.check(out)
                if res is False or isinstance(res, str):
                    valid = f"; valid: {res}" if isinstance(res, str) else ""
                    raise SceneError(f"{where} = {_toml(value)} is out of range{valid}.")
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
        alts = " or ".join(_toml(f"{number:g} {u}") + (f" (= {number * table[u] / here:.6g} {self.scene_unit})"
                                                        if u == "rad" else "") for u in fits[:3])
        return f" Did you mean {alts}?"

    def to_scene_unit(self, internal: float) -> float:
        """An internal value (mm, rad, 1/mm) expressed in the scene unit of this field."""
        if self.kind not in KINDS:
            return internal
        table, _ = KINDS[self.kind]
        return internal / table[self.scene_unit]


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

    def __post_init__(self):
        names = [f.name for f in self.fields] + [s.name for s in self.subsections]
        if len(set(names)) != len(names):
            raise ValueError(f"Section {self.name!r}: duplicate keys in {names}")

    @property
    def keys(self) -> list[str]:
        return [f.name for f in self.fields] + [s.name for s in self.subsections]

    def parse(self, table, path: str, errors: list[str], homes: dict | None = None) -> tuple[dict, set[str]]:
        """Convert a TOML table. Returns (values, keys given); problems are appended to ``errors``.

        ``values`` has every field (``None`` / default when absent) and, for each subsection, the
        parsed sub-dict (or ``None`` when absent). Given keys of subsections appear in the set as
        ``"sub.key"``. ``homes`` maps a key to the sections (``"[pair]"``) where it belongs, for the
        hint on a key written in the wrong section.
        """
        where = f"[{path}]"
        values: dict[str, Any] = {}
        given: set[str] = set()
        if not isinstance(table, dict):
            errors.append(f"{where} must be a table (a [{path}] section or {{...}}), got {_type(table)} "
                          f"{_toml(table)}.")
            return values, given
        gone = [k for k in table if k in self.moved]
        if gone:
            errors.append(f"{where} {', '.join(gone)}: {self.moved_hint(table) if self.moved_hint else 'removed'}")
        for key in table:
            if key not in self.keys and key not in self.moved:
                errors.append(f"{where} {shorten(key)}: unknown key.{_key_hint(key, self.keys, homes or {})} "
                              f"Valid keys: {', '.join(self.keys)}.")
        for f in self.fields:
            loc = f"{where} {f.name}"
            if f.name in table:
                given.add(f.name)
                try:
                    values[f.name] = f.convert(table[f.name], loc)
                except SceneError as e:
                    errors.append(str(e))
            elif f.required:
                errors.append(f"{loc}: missing required key ({_describe(f)}).")
            elif f.default is not None:
                values[f.name] = f.convert(f.default, loc + " (default)")
            else:
                values[f.name] = None
        for sub in self.subsections:
            if sub.name in table and sub.array:
                items = table[sub.name]
                if not isinstance(items, list):
                    errors.append(f"[{path}.{sub.name}] must be an array of tables ([[{path}.{sub.name}]] or "
                                  f"{sub.name} = [{{...}}, ...]), got {_type(items)} {_toml(items)}.")
                    values[sub.name] = None
                    continue
                values[sub.name] = [sub.parse(item, f"{path}.{sub.name}][{i}", errors, homes)[0] for i, item in enumerate(items)]
                given |= {sub.name}
            elif sub.name in table:
                vals, sub_given = sub.parse(table[sub.name], f"{path}.{sub.name}", errors, homes)
                values[sub.name] = vals
                given |= {f"{sub.name}.{k}" for k in sub_given} | {sub.name}
            elif sub.required:
                errors.append(f"{where} {sub.name}: missing required table.")
            else:
                values[sub.name] = None
        return values, given


@dataclass(frozen=True)
class ToolSection(Section):
    """An inline table whose keys depend on its ``kind`` (``[pinion] tool = {kind = "shaper", z = 25}``):
    ``variants[kind]`` lists the fields of each kind. Problems are reported as ``[pinion] tool.<key>``."""

    variants: dict = field(default_factory=dict)

    @property
    def keys(self) -> list[str]:
        out = ["kind"]
        for fs in self.variants.values():
            out += [f.name for f in fs if f.name not in out]
        return out

    def parse(self, table, path: str, errors: list[str], homes: dict | None = None) -> tuple[dict, set[str]]:
        owner, _, name = path.rpartition(".")
        at = f"[{owner}] {name}" if owner else f"[{name}]"
        kinds = ", ".join(_toml(k) for k in self.variants)
        if not isinstance(table, dict):
            errors.append(f"{at} = {_toml(table)}: expected an inline table such as {{kind = \"shaper\", z = 25}} "
                          f"(kind one of {kinds}), got {_type(table)}.")
            return {}, set()
        if "kind" not in table:
            errors.append(f"{at}.kind: missing; valid: one of {kinds} (the tool's keys depend on it).")
            return {}, set()
        kind = table["kind"]
        if not isinstance(kind, str) or kind not in self.variants:
            hint = _closest(str(kind), list(self.variants)) if isinstance(kind, str) else ""
            errors.append(f"{at}.kind = {_toml(kind)} is not a tool kind; valid: one of {kinds}.{hint}")
            return {}, set()
        fs = self.variants[kind]
        names = ["kind"] + [f.name for f in fs]
        values: dict[str, Any] = {"kind": kind}
        given = {"kind"}
        for key in table:
            if key in names:
                continue
            others = [k for k, v in self.variants.items() if any(f.name == key for f in v)]
            hint = (f" {key} is a key of kind = {' or '.join(_toml(k) for k in others)}." if others
                    else _closest(str(key), names))
            errors.append(f"{at}.{shorten(str(key))}: not a key of a tool of kind = {_toml(kind)}.{hint} Valid keys: "
                          f"{', '.join(names)}.")
        for f in fs:
            loc = f"{at}.{f.name}"
            if f.name in table:
                given.add(f.name)
                try:
                    values[f.name] = f.convert(table[f.name], loc)
                except SceneError as e:
                    errors.append(str(e))
            elif f.required:
                errors.append(f"{loc}: missing required key ({_describe(f)}).")
            else:
                values[f.name] = None if f.default is None else f.convert(f.default, loc + " (default)")
        return values, given


def _same(text: str, value) -> bool:
    """Whether a value printed by gearopt.gears equals the value written in the file."""
    if text == str(value):
        return True
    try:
        return not isinstance(value, (bool, str)) and math.isclose(float(text), float(value), rel_tol=1e-9)
    except (TypeError, ValueError):
        return False


def _type(value) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string", dict: "a table",
            list: "an array", _dt.date: "a date", _dt.datetime: "a date-time", _dt.time: "a time of day"}.get(
                type(value), type(value).__name__)


def _closest(word: str, options) -> str:
    m = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    if not m:
        m = [o for o in options if o.lower() == word.lower()]
    return f" Did you mean {m[0]!r}?" if m else ""


def _key_hint(key: str, keys, homes: dict) -> str:
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
    return _closest(key, keys)


def _describe(f: Field) -> str:
    bits = [f.kind]
    if f.scene_unit:
        bits.append(f"bare number in {f.scene_unit}")
    if f.choices is not None:
        bits.append("one of " + ", ".join(_toml(c) for c in f.choices))
    if f.doc:
        bits.append(f.doc)
    return "; ".join(bits)


def format_field(f: Field) -> str:
    """One line describing a field (for ``gearopt studies``)."""
    req = "required" if f.required else (f"default {_toml(f.default)}" if f.default is not None else "optional")
    unit = f" [{f.scene_unit}]" if f.scene_unit else ""
    choices = f" one of {', '.join(_toml(c) for c in f.choices)};" if f.choices is not None else ""
    check = f" {f.check.text(f.name, f.scene_unit)};" if isinstance(f.check, Bounds) else ""
    return f"{f.name} ({f.kind}{unit}, {req}):{choices}{check} {f.doc}".rstrip()


# --- common sections ----------------------------------------------------------------------------

_POS = Bounds(lo=0, lo_open=True)
_RACK_FIELDS = [
    Field("preset", "str", default="A", choices=("A", "B", "C", "D"),
          doc="ISO 53 basic rack profile (alpha_n = 20 deg); the other keys override it"),
    Field("alpha_n", "angle", bare=Bounds(lo=10, hi=45, hi_open=True),
          doc="normal pressure angle, 0 < alpha_n < 45 deg (a bare number, in deg, must be >= 10: pressure "
              "angles below 10 deg undercut any gear of fewer than 66 teeth; smaller values need a unit)"),
    Field("h_aP", "float", doc="addendum of the basic rack [m_n], > 0"),
    Field("h_fP", "float", doc="dedendum of the basic rack [m_n], >= h_aP"),
    Field("rho_fP", "float", doc="root fillet radius of the basic rack [m_n] (tool tip radius)"),
    Field("a_c", "inverse_length", doc="parabolic profile coefficient of the rack-cutter (0 = straight)"),
    Field("u_0", "length", doc="apex of the profile parabola along the profile, from the datum line"),
]


#: Keys of a gear's ``tool = {kind = ...}`` table for each kind (scene units: mm, deg).
_TOOL_VARIANTS = {
    "rack": [],
    "hob": [
        Field("z", "int", default=1, check=Bounds(lo=1, hi=8), doc="hob threads (starts)"),
        Field("d_p0", "length", default=60.0, check=_POS, doc="hob reference diameter; lead angle asin(z m_n / "
              "d_p0) from 0.1 to 30 deg"),
        Field("hand", "str", default="right", choices=("right", "left"), doc="hand of the hob thread"),
    ],
    "shaper": [
        Field("z", "int", default=25, check=Bounds(lo=8, hi=400), doc="shaper teeth (enough to reach the gear's "
              "tip: the smallest count is stated otherwise); a helical shaper has the gear's helix angle, "
              "opposite hand"),
        Field("x", "float", default=0.0, check=Bounds(lo=-1, hi=2), doc="shaper profile shift coefficient"),
    ],
}
#: Tool dataclass field of each tool key (kind -> scene key -> field).
_TOOL_ATTRS = {"hob": {"z": "N_h", "d_p0": "d_p0", "hand": "hand"}, "shaper": {"z": "N_s", "x": "x_s"}}


def _make_tool(values: dict | None):
    """The tool dataclass from a parsed ``tool`` table (None: the rack-cutter)."""
    if not values:
        return RackCutter()
    kind = values["kind"]
    attrs = _TOOL_ATTRS.get(kind, {})
    return TOOLS[kind](**{attrs[k]: v for k, v in values.items() if k != "kind"})


def _member(name: str) -> Section:
    return Section(name, [
        Field("z", "int", required=True, doc="number of teeth, z >= 3"),
        Field("b", "length", required=True, doc="face width, > 0"),
        Field("x", "float", default=0.0, doc="profile shift coefficient"),
        Field("k", "float", default=0.0, doc="tip alteration coefficient"),
        Field("d_a", "length", check=_POS, doc="tip diameter (instead of k: k = (d_a / 2 - r_p) / m_n - h_aP - x)"),
        Field("A_sne", "length", default=0.0, doc="upper tooth thickness allowance, normal, on the reference circle "
              "(DIN 3967; negative = thinner)"),
        Field("A_sni", "length", doc="lower tooth thickness allowance (<= A_sne; default A_sne)"),
        Field("a_pl", "inverse_length", default=0.0, doc="longitudinal crowning by tool plunging, >= 0"),
        Field("allow_undercut", "bool", default=False, doc="accept an undercut gear"),
    ], required=True, doc=f"the {name}" + (" (driving member)" if name == "pinion" else " (driven member)"),
        subsections=[Section("rack", _RACK_FIELDS, doc=f"rack-cutter of the {name}, overrides [rack] key by key"),
                     ToolSection("tool", doc=f"the tool that cuts the {name} (default: its rack-cutter); the keys "
                                 "depend on kind", variants=_TOOL_VARIANTS)])


#: Sections every scene may have (``[scene]`` and the gear data), in order.
COMMON_SECTIONS: list[Section] = [
    Section("scene", [
        Field("name", "str", required=True, doc="short name of the scene"),
        Field("description", "str", default="", doc="free text"),
        Field("study", "str", required=True, doc="which study to run (see `gearopt studies`)"),
    ], required=True, doc="what this scene is and which study it runs"),
    Section("rack", _RACK_FIELDS, doc="basic rack (rack-cutter) of both members"),
    _member("pinion"),
    _member("gear"),
    Section("pair", [
        Field("m_n", "length", check=_POS, doc="normal module (give m_n or P_n)"),
        Field("P_n", "inverse_length", unit="1/in", check=_POS,
              doc="normal diametral pitch, bare number in 1/in (give m_n or P_n)"),
        Field("beta", "angle", default=0.0, bare=Bounds(lo=1, hi=45, hi_open=True),
              doc="helix angle, 0 <= beta < 45 deg (0 = spur; a bare number, in deg, must be 0 or >= 1: smaller "
                  "helix angles need a unit)"),
        Field("hand", "str", default="right", choices=("right", "left"),
              doc="hand of the pinion's helix; the gear gets the opposite"),
        Field("a", "length", doc="centre distance; default the zero-backlash distance a_0"),
    ], required=True, doc="meshing data"),
    Section("output", [
        Field("plots", "bool", default=True, doc="write plots next to results.json"),
        Field("dpi", "int", default=120, check=Bounds(lo=10, hi=2400), doc="resolution of raster plots"),
    ], doc="what to write"),
]


# --- the scene ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Scene:
    """A loaded, validated scene.

    Attributes
    ----------
    name, description, study : str
        From ``[scene]``.
    pair : GearPair
        Pinion and gear (``pair.pinion``, ``pair.gear``), validated by :mod:`gearopt.gears`.
    options : dict[str, dict[str, Any]]
        The study's sections: ``options[section][key]`` in internal units (mm, rad, 1/mm);
        absent optional keys without default are ``None``.
    output : dict
        ``{"plots": bool, "dpi": int}``.
    source : Path
        The scene file.
    """

    name: str
    description: str
    study: str
    pair: GearPair
    options: dict
    output: dict
    source: Path
    raw: dict = field(default_factory=dict, repr=False, compare=False)

    def written(self, section: str, key: str) -> str | None:
        """The value of ``[section] key`` as written in the file (TOML text), or None if absent."""
        t = self.raw
        for part in re.findall(r"[^.\[\]]+", section):  # "tca.cases][0" -> tca, cases, 0
            if isinstance(t, list) and part.isdigit() and int(part) < len(t):
                t = t[int(part)]
            elif isinstance(t, dict):
                t = t.get(part)
            else:
                return None
        if isinstance(t, dict) and key in t:
            return _toml(t[key])
        return None

    def key_error(self, section: str, key: str, err) -> SceneError:
        """A :class:`SceneError` for ``[section] key`` from an error (or text) of gear or study code:
        its leading ``name = value`` (internal name and units) is replaced by the key and the value
        as written in the file."""
        msg = re.sub(r"^[\w.\[\] -]*?\b" + re.escape(key) + r" = \S+( \w+)? (?=is |must |:)", "", str(err))
        shown = self.written(section, key)
        sep = " " if msg.startswith(("is ", "must ")) else ": "
        return SceneError(f"{self.source}: [{section}] {key} = {shown if shown is not None else '(default)'}{sep}"
                          f"{msg.lstrip(': ')}")

    def run_error(self, err: Exception) -> SceneError:
        """An error raised while the study ran, tied to this scene: file name, the study's
        ``[section] key`` names instead of internal ones (``mis.crossing`` -> ``[tca] crossing``) and
        the keys the scene set, as written (deg/arcmin, not rad)."""
        from ..studies import get_study

        msg = str(err)
        spec = get_study(self.study)
        given = []
        for sec in (spec.sections if spec else []):
            for f in sec.fields:
                msg = re.sub(r"\b(?:mis|misalignment|target|options|" + re.escape(sec.name) + r")\." + re.escape(f.name)
                             + r"\b", f"[{sec.name}] {f.name}", msg)
                w = self.written(sec.name, f.name)
                if w is not None:
                    given.append(f"{f.name} = {w}")
            for sub in sec.subsections:  # e.g. [[tca.cases]]: each case as written
                rows = (self.raw.get(sec.name) or {}).get(sub.name) if isinstance(self.raw.get(sec.name), dict) else None
                if sub.array and isinstance(rows, list):
                    given += [f"{sub.name}[{i}] = {{{', '.join(f'{k} = {_toml(v)}' for k, v in row.items())}}}"
                              for i, row in enumerate(rows) if isinstance(row, dict)]
        ctx = f" (the scene sets [{spec.sections[0].name}] {', '.join(given)})" if given and spec else ""
        return SceneError(f"{self.source}: study {self.study!r} failed{ctx}: {msg}")

    def build(self):
        """Build the study object (``STUDIES[study].build(self)``)."""
        from ..studies import get_study

        spec = get_study(self.study)
        if spec is None:
            raise SceneError(f"{self.source}: [scene] study = {_toml(self.study)} is not a registered study.")
        return spec.build(self)


def _read_toml(path: Path, label: str) -> dict:
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"{label}: no such scene file.") from None
    except IsADirectoryError:
        raise SceneError(f"{label}: is a directory, not a scene file (.toml).") from None
    except OSError as e:
        raise SceneError(f"{label}: cannot read the scene file: {e.strerror or e}.") from None
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark (some Windows editors write one) is not content
    except UnicodeDecodeError as e:
        raise SceneError(f"{label}: not UTF-8 text ({e.reason} at byte {e.start}).") from None
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise SceneError(f"{label}: arrays or inline tables are nested too deeply to read (no scene value is "
                         "nested more than two levels).") from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{label}: TOML syntax error: {_toml_error(e, text)}.") from None


def _toml_error(e: Exception, text: str) -> str:
    """tomllib's message, naming the key or table when it is defined twice."""
    msg = str(e)
    m = re.search(r"\(at line (\d+), column \d+\)", msg)
    if not m or not ("overwrite" in msg or "twice" in msg):
        return msg
    lines = text.splitlines()
    n = int(m.group(1))
    line = lines[n - 1] if 0 < n <= len(lines) else ""
    head = re.match(r"^\s*\[\[?\s*([^\]]+?)\s*\]", line)
    if head:
        return f"table [{shorten(head.group(1))}] is defined twice (line {n}); merge the two"
    key = line.split("=", 1)[0].strip()
    section, start = "", 0
    for i in range(n - 2, -1, -1):
        h = re.match(r"^\s*\[\[?\s*([^\]]+?)\s*\]", lines[i])
        if h:
            section, start = f"[{h.group(1)}] ", i + 1
            break
    first = next((i + 1 for i in range(start, n - 1) if "=" in lines[i] and lines[i].split("=", 1)[0].strip() == key),
                 None)
    where = f" (first on line {first})" if first else ""
    return f"duplicate key {section}{shorten(key)} on line {n}{where}; a key may be given once per table"


def _fail(label: str, errors: list[str]):
    if len(errors) == 1:
        raise SceneError(f"{label}: {errors[0]}")
    raise SceneError(f"{label}: {len(errors)} problems:\n" + "\n".join(f"  - {e}" for e in errors))


def load_scene(path) -> Scene:
    """Read, validate and convert a scene file.

    Raises
    ------
    SceneError
        For any problem, with the file name and ``[section] key`` in the message.
    """
    from ..studies import broken_modules, get_study, studies

    if not isinstance(path, (str, Path)) or str(path) == "":
        from ..errors import ArgumentError
        raise ArgumentError(f"path = {type(path).__name__} {shorten(repr(path))}: expected the path of a scene file "
                            "(str or pathlib.Path).")
    path = Path(path)
    label = str(path)
    data = _read_toml(path, label)
    errors: list[str] = []

    # [scene] first: it says which study, hence which further sections are allowed.
    head = COMMON_SECTIONS[0]
    if "scene" not in data:
        _fail(label, ["[scene]: missing required section (with name = \"...\" and study = \"...\").",
                      *([] if data else ["the file is empty."])])
    scene_vals, _ = head.parse(data["scene"], "scene", errors)
    if errors:
        _fail(label, errors)
    bad_name = _check_name(scene_vals["name"])
    if bad_name:
        _fail(label, [f"[scene] name = {_toml(scene_vals['name'])}: {bad_name}"])
    study_name = scene_vals["study"]
    spec = get_study(study_name)
    if spec is None:
        known = sorted(studies())
        broken = "".join(f" (module {m} failed to import: {e!r})" for m, e in broken_modules().items())
        valid = ", ".join(_toml(k) for k in known) if known else "none registered"
        _fail(label, [f"[scene] study = {_toml(study_name)} is not a registered study; valid: {valid}."
                      f"{_closest(study_name, known)}{broken}"])

    sections = {s.name: s for s in COMMON_SECTIONS}
    for s in spec.sections:
        if s.name in sections:
            raise ValueError(f"study {spec.name!r} redefines the common section [{s.name}]")
        sections[s.name] = s

    homes: dict[str, list[str]] = {}

    def index(sec: Section, path: str):
        for k in sec.keys:
            homes.setdefault(k, []).append(f"[{path}]")
        for sub in sec.subsections:
            index(sub, f"{path}.{sub.name}")

    for n_, sec_ in sections.items():
        index(sec_, n_)
    for other, st in studies().items():  # keys of other studies' sections, said as such
        if other == study_name:
            continue
        for sec_ in st.sections:
            for k in sec_.keys:
                homes.setdefault(k, []).append(f"[{sec_.name}] of study {_toml(other)}")
    for key, value in data.items():
        if key in sections:
            continue
        if not isinstance(value, dict):
            target = key if key in homes else ALIASES.get(key, key)
            hint = f" It belongs in {' or '.join(homes[target])}" if target in homes else ""
            hint = (hint + (f" (as {target})" if target != key else "") + ".") if hint else ""
            errors.append(f"{shorten(key)} = {_toml(value)}: top-level key {shorten(repr(key))} is not allowed; keys must be inside a "
                          f"section such as [scene].{hint}")
            continue
        owner = [n for n, st in studies().items() for s in st.sections if s.name == key]
        if owner:
            errors.append(f"[{key}]: this section belongs to study {_toml(owner[0])}, but this scene's "
                          f"study is {_toml(study_name)}.")
        else:
            errors.append(f"[{shorten(key)}]: unknown section.{_closest(key, list(sections))} Valid sections: "
                          f"{', '.join(f'[{n}]' for n in sections)}.")

    parsed: dict[str, dict] = {}
    given: dict[str, set] = {}
    for name, sec in sections.items():
        if name == "scene":
            continue
        if name in data:
            parsed[name], given[name] = sec.parse(data[name], name, errors, homes)
        elif sec.required:
            needs = [f.name for f in sec.fields if f.required]
            what = f" ({sec.doc})" if sec.doc else ""
            keys = f"; it needs {', '.join(needs)}" if needs else ""
            errors.append(f"[{name}]: missing required section{what}{keys} (see `gearopt studies`).")
        else:
            parsed[name], given[name] = sec.parse({}, name, errors, homes)

    pair_given = given.get("pair", set())
    if "pair" in data and isinstance(data["pair"], dict):
        if "m_n" in pair_given and "P_n" in pair_given:
            errors.append("[pair] m_n and P_n: give exactly one of them (module in mm or diametral pitch in 1/in), "
                          "not both.")
        elif "m_n" not in pair_given and "P_n" not in pair_given:
            errors.append("[pair] m_n: missing; give exactly one of m_n (normal module, mm) or P_n "
                          "(normal diametral pitch, 1/in).")
    if errors:
        _fail(label, errors)

    pair = _build_pair(data, parsed, given, label)
    options = {s.name: parsed[s.name] for s in spec.sections}
    return Scene(name=scene_vals["name"], description=scene_vals["description"], study=study_name, pair=pair,
                 options=options, output=dict(parsed["output"]), source=path, raw=data)


_NAME_FORBIDDEN = set('/\\:*?"<>|')


def _check_name(name: str) -> str | None:
    """Why a scene name cannot name files (out/<name>_ccx, ...), or None when it can."""
    if not name.strip():
        return "empty; valid: a short name (letters, digits, spaces, . _ - ...) that can name a file."
    bad = sorted({c for c in name if c in _NAME_FORBIDDEN or ord(c) < 32 or ord(c) == 127})
    if bad:
        shown = ", ".join(repr(c) for c in bad)
        return (f"contains {shown}; valid: a name that can be a file name (no path separators /, \\, no :*?\"<>| "
                "or control characters), since output files are named after it.")
    if name.startswith(".") or name != name.strip():
        return "starts with '.' or has leading/trailing spaces; valid: a plain file name (not hidden, not '..')."
    if len(name) > 120:
        return f"is {len(name)} characters long; valid: at most 120 (it names output files)."
    return None


# --- gear objects -------------------------------------------------------------------------------

_RACK_KEYS = [f.name for f in _RACK_FIELDS if f.name != "preset"]


def _build_pair(data: dict, parsed: dict, given: dict, label: str) -> GearPair:
    pr = parsed["pair"]
    if pr["m_n"] is not None:
        m_n, m_key = pr["m_n"], "m_n"
    else:
        m_n, m_key = 1.0 / pr["P_n"], "P_n"
    pinion_hand = pr["hand"]
    hands = {"pinion": pinion_hand, "gear": "left" if pinion_hand == "right" else "right"}

    def raw(section: str, key: str):
        """The value as written in the file (``section`` may be ``"pinion.rack"``)."""
        t = data
        *parts, key = section.split(".") + key.split(".")
        for part in parts:
            t = t.get(part, {}) if isinstance(t, dict) else {}
        return t.get(key, _MISSING) if isinstance(t, dict) else _MISSING

    def rack_source(member: str, key: str) -> str | None:
        if f"rack.{key}" in given[member]:
            return f"{member}.rack"
        if key in given["rack"]:
            return "rack"
        return None

    def locate(member: str | None, name: str) -> tuple[str, str] | None:
        """Map a gearopt.gears parameter name to (section, key) in the scene file."""
        parts = name.split(".")
        if parts[0] in ("pinion", "gear") and len(parts) == 2:
            member, key = parts
            if key in ("m_n",):
                return ("pair", m_key)
            if key in ("beta", "hand"):
                return ("pair", key)
            return (member, key)
        if parts[0] in ("pinion", "gear") and len(parts) == 3 and parts[1] == "tool":  # the tool's own key
            kind = (parsed[parts[0]].get("tool") or {}).get("kind")
            key = {v: k for k, v in _TOOL_ATTRS.get(kind, {}).items()}.get(parts[2], parts[2])
            return (parts[0], f"tool.{key}")
        if parts[0] in ("pinion", "gear") and len(parts) == 3 and parts[1] == "rack":
            src = rack_source(parts[0], parts[2])
            return (src, parts[2]) if src else None
        if parts[0] == "rack" and len(parts) == 2 and member is not None:
            if parts[1] == "preset":
                src = rack_source(member, "preset")
                return (src, "preset") if src else None
            src = rack_source(member, parts[1])
            return (src, parts[1]) if src else None
        if name == "pair.a":
            return ("pair", "a")
        if name == "P_n":
            return ("pair", "P_n")
        return None

    def reraise(err: GeometryError, member: str | None, context: str):
        msg = str(err)
        m = re.match(r"^([A-Za-z_][\w.]*) = ", msg)
        loc = locate(member, m.group(1)) if m else None
        if loc is not None:
            section, key = loc
            value = raw(section, key)
            rest = msg[m.end():]
            cut = re.search(r" (is out of range|must be)", rest)
            if cut:
                converted = rest[:cut.start()].strip("'\"")
                if value is _MISSING:
                    shown = f"{converted} (not set: the default)"
                else:
                    shown = _toml(value)
                    if not _same(converted, value):
                        shown += f" (= {converted})"
                raise SceneError(f"{label}: [{section}] {key} = {shown}{rest[cut.start():]}") from None
            raise SceneError(f"{label}: [{section}] {key}: {msg}") from None
        raise SceneError(f"{label}: {context}: {msg}") from None

    members = {}
    for member in ("pinion", "gear"):
        own = parsed[member]["rack"] or {}
        common = parsed["rack"]
        preset = own["preset"] if "rack.preset" in given[member] else common["preset"]
        changes = {k: common[k] for k in _RACK_KEYS if k in given["rack"]}
        changes.update({k: own[k] for k in _RACK_KEYS if f"rack.{k}" in given[member]})
        ctx = f"[{member}] rack (ISO 53 {preset}" + (f" with {', '.join(changes)} changed)" if changes else ")")
        try:
            rack = BasicRack.iso53(preset, **changes)
            if changes:
                rack = replace(rack, name=f"ISO 53 {preset}, modified")
        except GeometryError as e:
            reraise(e, member, ctx)
        v = parsed[member]
        k = v["k"]
        if v.get("d_a") is not None:
            if "k" in given[member]:
                raise SceneError(f"{label}: [{member}] k and d_a: give at most one of them (tip alteration "
                                 "coefficient or tip diameter).")
            r_p = m_n * v["z"] / math.cos(pr["beta"]) / 2
            k = (v["d_a"] / 2 - r_p) / m_n - rack.h_aP - v["x"]
        try:
            tool = _make_tool(v.get("tool"))
        except GeometryError as e:
            raise SceneError(f"{label}: [{member}] tool = {_toml(raw(member, 'tool'))}: {e}") from None
        try:
            members[member] = Gear(z=v["z"], m_n=m_n, x=v["x"], b=v["b"], beta=pr["beta"], hand=hands[member],
                                   rack=rack, k=k, a_pl=v["a_pl"], allow_undercut=v["allow_undercut"],
                                   name=member, A_sne=v["A_sne"], A_sni=v.get("A_sni"), tool=tool)
        except GeometryError as e:
            bounds = getattr(e, "k_bounds", None)
            if bounds is not None and v.get("d_a") is not None:  # k came from d_a: restate the range for d_a
                r_p = m_n * v["z"] / math.cos(pr["beta"]) / 2

                def d_a_of(kk):
                    return 2 * (r_p + m_n * (rack.h_aP + v["x"] + kk))
                lo, hi = (None if b is None else d_a_of(b) for b in bounds)
                rng = (f"d_a > {lo:.6g} mm (the root circle)" if hi is None else
                       f"d_a < {hi:.6g} mm (beyond it the tip is pointed)" if lo is None else
                       f"{lo:.6g} < d_a < {hi:.6g} mm")
                raise SceneError(f"{label}: [{member}] d_a = {_toml(raw(member, 'd_a'))} is out of range (tip "
                                 f"alteration k = {k:.4g} from it); valid: {rng} for z = {v['z']}, x = {v['x']:g}, "
                                 f"m_n = {m_n:g} mm.") from None
            reraise(e, member, f"[{member}]")
    try:
        return GearPair(pinion=members["pinion"], gear=members["gear"], a=pr["a"])
    except GeometryError as e:
        reraise(e, None, "[pair]")
    raise AssertionError("unreachable")  # pragma: no cover

