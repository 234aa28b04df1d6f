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

import math
import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from collections.abc import Callable, Iterator, Mapping
from typing import Any

from ..errors import GearoptError, GeometryError, SceneError, join_detail, shorten, value_text
from ..gears import BasicRack, Gear, GearPair
from ..geometry.tools import TOOL_KINDS, TOOLS, RackCutter  # noqa: F401
from ..schema import (  # noqa: F401 - re-exported: the schema lives in gearopt.schema
    ALIASES, KIND_UNITS, Bounds, Field, Section, ToolSection, closest, describe, key_hint, toml_text, type_name, format_field,
    problem,
)

__all__ = [
    "Field", "Section", "Bounds", "Scene", "load_scene", "COMMON_SECTIONS", "KIND_UNITS", "format_field",
]

_MISSING = object()


def _same(text: str, value) -> bool:
    """Whether a value printed by gearopt.gears equals the value written in the file."""
    if text == str(value):
        return True
    try:
        return not isinstance(value, (bool, str)) and math.isclose(float(text), float(value), rel_tol=1e-9)
    except (TypeError, ValueError):
        return False


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


class _ToolVariants(Mapping):
    """Keys of a gear's ``tool = {kind = ...}`` table for each kind (scene units: mm, deg): the
    :attr:`~gearopt.geometry.tools.Tool.scene_keys` of every class in
    :data:`~gearopt.geometry.tools.TOOLS`, read when a scene is parsed (a tool defined later counts)."""

    def __getitem__(self, kind: str) -> list[Field]:
        return [Field(k.key, k.kind, default=k.default, doc=k.doc, choices=k.choices,
                      check=Bounds(**k.bounds) if k.bounds else None) for k in TOOLS[kind].scene_keys]

    def __iter__(self):
        return iter(TOOLS)

    def __len__(self) -> int:
        return len(TOOLS)


_TOOL_VARIANTS = _ToolVariants()


def _make_tool(values: dict | None):
    """The tool from a parsed ``tool`` table (None: the rack-cutter): :meth:`Tool.from_scene`."""
    if not values:
        return RackCutter()
    return TOOLS[values["kind"]].from_scene(values)


def _modification_fields() -> list:
    """Keys of ``[<member>.modifications]``: the fields of :class:`Microgeometry` (amounts in um,
    written with their unit: ``"12 um"``, a bare number refused, see :data:`gearopt.units.UNIT_REQUIRED`;
    positions in mm), with ``d_alpha_start``/``d_alpha_end`` for the profile
    evaluation range and ``sides``."""
    from dataclasses import fields as dc_fields

    from ..geometry.microgeometry import SHAPES, Microgeometry

    out = []
    for f in dc_fields(Microgeometry):
        meta, doc = f.metadata, f.metadata.get("doc", "")
        if f.name in ("measured", "d_alpha", "sides"):
            continue
        if meta.get("scene") == "um":
            removed = f.name.startswith("C_")
            out.append(Field(f.name, "length", unit="um", default="0 um", check=Bounds(lo=0) if removed else None,
                             doc=doc + (" (>= 0: material removed)" if removed else "")))
        elif meta.get("unit") == "mm":
            out.append(Field(f.name, "length", doc=doc))
        else:
            out.append(Field(f.name, "str", default="linear", choices=SHAPES, doc=doc))
    out += [Field("d_alpha_start", "length", check=_POS, doc="start of the profile evaluation range (diameter; "
                  "default: the start of the active profile d_Nf)"),
            Field("d_alpha_end", "length", check=_POS, doc="end of the profile evaluation range (diameter; default d_a)"),
            Field("sides", "str", default="both", choices=("both", "right", "left"), doc="flanks modified")]
    return out


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
                                 "depend on kind", variants=_TOOL_VARIANTS),
                     Section("modifications", _modification_fields(),
                             doc=f"flank modifications of the {name} in ISO 21771 shop terms (amounts in um, "
                             "transverse, + = material added; docs/microgeometry.md)"),
                     Section("measured", [Field("right", "str", doc="topography CSV of the right flank (path relative "
                                                "to the scene file)"),
                                          Field("left", "str", doc="topography CSV of the left flank")],
                             doc=f"measured flank topographies of the {name} (gearopt CSV grids, "
                             "docs/microgeometry.md), added to its flanks")])


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
        Field("svg", "bool", default=False,
              doc="report.html shows each light figure as SVG (sharp at any zoom) instead of its PNG; each "
                  "such figure is drawn a second time, about doubling the time spent on plots"),
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
        ``{"plots": bool, "dpi": int, "svg": bool}``.
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
        """The value of ``[section] key`` as written in the file (TOML text), or None if absent
        (``key`` may be a path into an inline table: ``tool.d_p0``)."""
        t = self.raw
        *inner, key = key.split(".")
        for part in re.findall(r"[^.\[\]]+", section) + inner:  # "tca.cases][0" -> tca, cases, 0
            if isinstance(t, list) and part.isdigit() and int(part) < len(t):
                t = t[int(part)]
            elif isinstance(t, dict):
                t = t.get(part)
            else:
                return None
        if isinstance(t, dict) and key in t:
            return toml_text(t[key])
        return None

    def key_error(self, section: str, key: str, err: GearoptError | str, valid: str | None = None) -> SceneError:
        """A :class:`SceneError` for ``[section] key`` from an error of gear or study code (whose
        :attr:`~gearopt.errors.GearoptError.detail` follows the key and its value as written in
        the file) or from a text that follows them (``"is out of range; valid: ..."``; then
        ``valid`` is the valid range that text states, the error's ``valid``)."""
        if isinstance(err, GearoptError):
            text = err.detail if err.detail is not None else f": {err}"
            valid = err.valid if valid is None else valid
        else:
            text = str(err)
        shown = self.written(section, key)
        head = f"[{section}] {key} = {shown if shown is not None else '(default)'}"
        if not text.startswith((":", ";", ",", ".")) and not text.startswith(("is ", "must ")):
            text = ": " + text
        return SceneError(f"{self.source}: {join_detail(head, text)}", param=f"[{section}] {key}", value=shown,
                          valid=valid, source=self.source)

    def gear_key(self, param: str | None) -> tuple[str, str] | None:
        """The ``(section, key)`` of the gear data (``[pinion]``, ``[gear]``, ``[pair]``, ``[rack]``,
        ``[pinion.rack]``...) that an error's ``param`` as :mod:`gearopt.gears` names it refers to:
        ``pinion.tool`` -> ``("pinion", "tool")``, ``gear.tool.d_p0`` -> ``("gear", "tool.d_p0")``,
        ``pinion.m_n`` -> ``("pair", "m_n")``; None when it names no key written or implied by this
        scene (a derived quantity such as ``pinion.r_a`` is no key)."""
        loc = _gear_key(self.raw, None, param) if param else None
        if loc is None:
            return None
        head, _, sub = loc[0].partition(".")
        sec = next((s for s in COMMON_SECTIONS if s.name == head), None)
        if sec is not None and sub:
            sec = next((s for s in sec.subsections if s.name == sub), None)
        return loc if sec is not None and loc[1].split(".")[0] in sec.keys else None

    def gear_error(self, err: GearoptError) -> SceneError | None:
        """``err`` (about a gear parameter, e.g. ``pinion.tool`` refused by the crowning synthesis)
        restated for the key of the gear data the user wrote (see :meth:`gear_key`), as the loader
        states it; None when its ``param`` names no such key."""
        loc = self.gear_key(err.param)
        if loc is None:
            return None
        return _restate(self.source, loc[0], loc[1], _raw_value(self.raw, *loc), err)

    def locate(self, param: str | None, prefixes: tuple = ()) -> tuple[str, str] | None:
        """The ``(section, key)`` of this scene's study that an error's ``param`` names: ``mis.dE``,
        ``misalignment.dE``, ``target.te_level``, ``options.x``, ``<section>.<key>``, a bare
        ``<key>`` or ``<prefix>.<key>`` for one of ``prefixes`` (the study's own objects, e.g.
        ``hob``), when the key is a field of one of the study's sections; else None."""
        from ..studies import get_study

        if not param:
            return None
        spec = get_study(self.study)
        head, _, key = param.rpartition(".")
        for sec in (spec.sections if spec else []):
            if key in [f.name for f in sec.fields] and head in ("", "mis", "misalignment", "target", "options",
                                                                 sec.name, *prefixes):
                return sec.name, key
        return None

    def study_error(self, section: str, err: GearoptError, prefixes: tuple = ()) -> SceneError:
        """A :class:`SceneError` for an error raised while the study's objects are built from
        ``[section]``: stated for the key its ``param`` names (with the value as written; see
        :meth:`locate` for ``prefixes``) when that key is in ``[section]`` and has a value, else
        prefixed with ``[section]``."""
        loc = self.locate(err.param, prefixes)
        if loc is not None and loc[0] == section and err.detail is not None \
                and (self.options.get(section) or {}).get(loc[1]) is not None:
            return self.key_error(section, loc[1], err)
        if loc is None:
            restated = self.gear_error(err)
            if restated is not None:
                return restated
        return SceneError(f"{self.source}: [{section}] {err}", value=err.value, valid=err.valid,
                          param=f"[{section}] {err.param}" if err.param and err.detail is not None else None,
                          source=self.source)

    def run_error(self, err: Exception) -> SceneError:
        """An error raised while the study ran, tied to this scene: file name, the study's
        ``[section] key`` named by the error's ``param`` (``mis.crossing`` -> ``[tca] crossing``),
        with the value as written, and the keys the scene set, as written (deg/arcmin, not rad)."""
        from ..studies import get_study

        msg = str(err)
        loc = self.locate(getattr(err, "param", None))
        if loc is not None and getattr(err, "detail", None) is None:
            loc = None  # the message does not start with the parameter: keep its words
        if loc is not None:
            section, key = loc
            shown = self.written(section, key)
            msg = join_detail(f"[{section}] {key} = {shown if shown is not None else value_text(err.value)}", err.detail)
        elif isinstance(err, GearoptError) and self.gear_key(err.param) is not None:  # pinion.tool -> [pinion] tool
            loc = self.gear_key(err.param)
            msg = _restate_text(loc[0], loc[1], _raw_value(self.raw, *loc), err)
        spec = get_study(self.study)
        given = []
        for sec in (spec.sections if spec else []):
            for f in sec.fields:
                w = self.written(sec.name, f.name)
                if w is not None:
                    given.append(f"{f.name} = {w}")
            for sub in sec.subsections:  # e.g. [[tca.cases]]: each case as written
                rows = (self.raw.get(sec.name) or {}).get(sub.name) if isinstance(self.raw.get(sec.name), dict) else None
                if sub.array and isinstance(rows, list):
                    given += [f"{sub.name}[{i}] = {{{', '.join(f'{k} = {toml_text(v)}' for k, v in row.items())}}}"
                              for i, row in enumerate(rows) if isinstance(row, dict)]
        ctx = f" (the scene sets [{spec.sections[0].name}] {', '.join(given)})" if given and spec else ""
        return SceneError(f"{self.source}: study {self.study!r} failed{ctx}: {msg}",
                          param=f"[{loc[0]}] {loc[1]}" if loc else None,
                          value=self.written(*loc) if loc else None, valid=getattr(err, "valid", None),
                          source=self.source)

    def build(self) -> Any:
        """Build the study object (``STUDIES[study].build(self)``)."""
        from ..studies import get_study

        spec = get_study(self.study)
        if spec is None:
            raise SceneError(f"{self.source}: [scene] study = {toml_text(self.study)} is not a registered study.",
                             param="[scene] study", value=toml_text(self.study), source=self.source)
        return spec.build(self)


class _Later(Mapping):
    """A mapping made by ``make()`` on its first use (then kept)."""

    def __init__(self, make: Callable[[], Mapping]) -> None:
        self._make, self._made = make, None

    def _it(self) -> Mapping:
        if self._made is None:
            self._made = self._make()
        return self._made

    def __getitem__(self, key: Any) -> Any:
        return self._it()[key]

    def __iter__(self) -> Iterator:
        return iter(self._it())

    def __len__(self) -> int:
        return len(self._it())


def _read_toml(path: Path, label: str) -> dict:
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"{label}: no such scene file.", source=path) from None
    except IsADirectoryError:
        raise SceneError(f"{label}: is a directory, not a scene file (.toml).", source=path) from None
    except OSError as e:
        raise SceneError(f"{label}: cannot read the scene file: {e.strerror or e}.", source=path) from None
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark (some Windows editors write one) is not content
    except UnicodeDecodeError as e:
        raise SceneError(f"{label}: not UTF-8 text ({e.reason} at byte {e.start}).", source=path) from None
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise SceneError(f"{label}: arrays or inline tables are nested too deeply to read (no scene value is "
                         "nested more than two levels).", source=path) from None
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{label}: TOML syntax error: {_toml_error(e, text)}.", source=path) from None


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


def _fail(path: Path, errors: list[SceneError]):
    """Raise one SceneError for the ``errors`` collected while loading ``path`` (each a
    :func:`~gearopt.io.schema.problem`): the message lists them, ``problems`` holds them, and
    ``param``, ``value``, ``valid`` are those of the first."""
    label, first = str(path), errors[0]
    fields = dict(param=first.param, value=first.value, valid=first.valid, problems=errors)
    if len(errors) == 1:
        raise SceneError(f"{label}: {first}", detail=first.detail, source=path, **fields)
    raise SceneError(f"{label}: {len(errors)} problems:\n" + "\n".join(f"  - {e}" for e in errors), source=path,
                     **fields)


def load_scene(path: str | Path) -> Scene:
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
                            "(str or pathlib.Path).", param="path", value=path, valid="str or pathlib.Path")
    path = Path(path)
    label = str(path)
    data = _read_toml(path, label)
    errors: list[SceneError] = []  # the problems found, each a schema.problem (message without the file name)

    # [scene] first: it says which study, hence which further sections are allowed.
    head = COMMON_SECTIONS[0]
    if "scene" not in data:
        _fail(path, [problem("[scene]: missing required section (with name = \"...\" and study = \"...\").", "[scene]"),
                     *([] if data else [problem("the file is empty.")])])
    scene_vals, _ = head.parse(data["scene"], "scene", errors)
    if errors:
        _fail(path, errors)
    bad_name = _check_name(scene_vals["name"])
    if bad_name:
        shown, detail = toml_text(scene_vals["name"]), f": {bad_name[0]}"
        _fail(path, [problem(f"[scene] name = {shown}{detail}", "[scene] name", shown, bad_name[1], detail)])
    study_name = scene_vals["study"]
    spec = get_study(study_name)
    if spec is None:
        known = sorted(studies())
        broken = "".join(f" (module {m} failed to import: {e!r})" for m, e in broken_modules().items())
        valid = ", ".join(toml_text(k) for k in known) if known else "none registered"
        shown, detail = toml_text(study_name), (f"is not a registered study; valid: {valid}."
                                            f"{closest(study_name, known)}{broken}")
        _fail(path, [problem(f"[scene] study = {shown} {detail}", "[scene] study", shown, valid, detail)])

    sections = {s.name: s for s in COMMON_SECTIONS}
    for s in spec.sections:
        if s.name in sections:
            raise ValueError(f"study {spec.name!r} redefines the common section [{s.name}]")
        sections[s.name] = s

    known_homes: dict[str, list[str]] = {}

    def index(sec: Section, path: str):
        for k in sec.keys:
            known_homes.setdefault(k, []).append(f"[{path}]")
        for sub in sec.subsections:
            index(sub, f"{path}.{sub.name}")

    for n_, sec_ in sections.items():
        index(sec_, n_)

    def with_other_studies() -> dict[str, list[str]]:  # keys of other studies' sections, said as such
        for other, st in studies().items():
            if other == study_name:
                continue
            for sec_ in st.sections:
                for k in sec_.keys:
                    known_homes.setdefault(k, []).append(f"[{sec_.name}] of study {toml_text(other)}")
        return known_homes

    homes = _Later(with_other_studies)  # (read for a misplaced key's hint only: the studies imported then)
    for key, value in data.items():
        if key in sections:
            continue
        if not isinstance(value, dict):
            target = key if key in homes else ALIASES.get(key, key)
            hint = f" It belongs in {' or '.join(homes[target])}" if target in homes else ""
            hint = (hint + (f" (as {target})" if target != key else "") + ".") if hint else ""
            detail = (f": top-level key {shorten(repr(key))} is not allowed; keys must be inside a section such as "
                      f"[scene].{hint}")
            errors.append(problem(f"{shorten(key)} = {toml_text(value)}{detail}", shorten(key), toml_text(value),
                                  "inside a section", detail))
            continue
        owner = [n for n, st in studies().items() for s in st.sections if s.name == key]
        if owner:
            errors.append(problem(f"[{key}]: this section belongs to study {toml_text(owner[0])}, but this scene's "
                                  f"study is {toml_text(study_name)}.", f"[{key}]"))
        else:
            valid = ", ".join(f"[{n}]" for n in sections)
            errors.append(problem(f"[{shorten(key)}]: unknown section.{closest(key, list(sections))} Valid sections: "
                                  f"{valid}.", f"[{shorten(key)}]", valid=valid))

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
            errors.append(problem(f"[{name}]: missing required section{what}{keys} (see `gearopt studies`).",
                                  f"[{name}]"))
        else:
            parsed[name], given[name] = sec.parse({}, name, errors, homes)

    pair_given = given.get("pair", set())
    if "pair" in data and isinstance(data["pair"], dict):
        if "m_n" in pair_given and "P_n" in pair_given:
            errors.append(problem("[pair] m_n and P_n: give exactly one of them (module in mm or diametral pitch in "
                                  "1/in), not both.", "[pair] m_n", valid="exactly one of them"))
        elif "m_n" not in pair_given and "P_n" not in pair_given:
            errors.append(problem("[pair] m_n: missing; give exactly one of m_n (normal module, mm) or P_n "
                                  "(normal diametral pitch, 1/in).", "[pair] m_n",
                                  valid="exactly one of m_n (normal module, mm) or P_n (normal diametral pitch, 1/in)"))
    if errors:
        _fail(path, errors)

    pair = _build_pair(data, parsed, given, path)
    options = {s.name: parsed[s.name] for s in spec.sections}
    return Scene(name=scene_vals["name"], description=scene_vals["description"], study=study_name, pair=pair,
                 options=options, output=dict(parsed["output"]), source=path, raw=data)


_NAME_FORBIDDEN = set('/\\:*?"<>|')


def _check_name(name: str) -> tuple[str, str] | None:
    """Why a scene name cannot name files (out/<name>_ccx, ...) as ``(text, valid)`` (``valid`` the
    part of ``text`` after "valid: "), or None when it can."""
    def why(what: str, valid: str, after: str = "") -> tuple[str, str]:
        return f"{what}; valid: {valid}{after}.", valid

    if not name.strip():
        return why("empty", "a short name (letters, digits, spaces, . _ - ...) that can name a file")
    bad = sorted({c for c in name if c in _NAME_FORBIDDEN or ord(c) < 32 or ord(c) == 127})
    if bad:
        shown = ", ".join(repr(c) for c in bad)
        return why(f"contains {shown}", "a name that can be a file name (no path separators /, \\, no :*?\"<>| "
                   "or control characters)", ", since output files are named after it")
    if name.startswith(".") or name != name.strip():
        return why("starts with '.' or has leading/trailing spaces", "a plain file name (not hidden, not '..')")
    if len(name) > 120:
        return why(f"is {len(name)} characters long", "at most 120", " (it names output files)")
    return None


# --- gear objects -------------------------------------------------------------------------------

_RACK_KEYS = [f.name for f in _RACK_FIELDS if f.name != "preset"]


def _raw_value(data: dict, section: str, key: str):
    """The value of ``[section] key`` as written in the file (``section`` may be ``"pinion.rack"``,
    ``key`` may be ``"tool.d_p0"``), or ``_MISSING``."""
    t = data
    *parts, key = section.split(".") + key.split(".")
    for part in parts:
        t = t.get(part, {}) if isinstance(t, dict) else {}
    return t.get(key, _MISSING) if isinstance(t, dict) else _MISSING


def _gear_key(data: dict, member: str | None, name: str) -> tuple[str, str] | None:
    """Map a :mod:`gearopt.gears` parameter name (an error's ``param``: ``pinion.z``, ``gear.m_n``,
    ``pinion.rack.a_c``, ``rack.alpha_n`` for ``member``'s rack, ``pinion.tool``,
    ``pinion.tool.d_p0``, ``pair.a``) to ``(section, key)`` in the scene file ``data`` (as read),
    or None. A rack key maps to where the file sets it (``[pinion.rack]`` or ``[rack]``), None if it
    sets it nowhere; a tool key to the scene's name for it (``tool.N_h`` -> ``tool.z``)."""

    def rack_source(member: str, key: str) -> str | None:
        if _raw_value(data, f"{member}.rack", key) is not _MISSING:
            return f"{member}.rack"
        if _raw_value(data, "rack", key) is not _MISSING:
            return "rack"
        return None

    parts = name.split(".")
    if parts[0] in ("pinion", "gear") and len(parts) == 2:
        member, key = parts
        if key in ("m_n",):
            return ("pair", "P_n" if _raw_value(data, "pair", "m_n") is _MISSING
                    and _raw_value(data, "pair", "P_n") is not _MISSING else "m_n")
        if key in ("beta", "hand"):
            return ("pair", key)
        return (member, key)
    if parts[0] in ("pinion", "gear") and len(parts) == 3 and parts[1] == "tool":  # the tool's own key
        tool = _raw_value(data, parts[0], "tool")
        kind = tool.get("kind") if isinstance(tool, dict) else None
        key = TOOLS[kind].scene_key_of(parts[2]) if isinstance(kind, str) and kind in TOOLS else parts[2]
        return (parts[0], f"tool.{key}")
    if parts[0] in ("pinion", "gear") and len(parts) == 3 and parts[1] == "modifications":
        key = {"d_alpha": "d_alpha_start"}.get(parts[2], parts[2])
        return (f"{parts[0]}.modifications", key)
    if parts[0] in ("pinion", "gear") and len(parts) == 3 and parts[1] == "rack":
        src = rack_source(parts[0], parts[2])
        return (src, parts[2]) if src else None
    if parts[0] == "rack" and len(parts) == 2 and member is not None:
        src = rack_source(member, parts[1])
        return (src, parts[1]) if src else None
    if name == "pair.a":
        return ("pair", "a")
    if name == "P_n":
        return ("pair", "P_n")
    return None


def _restate_text(section: str, key: str, written, err: GearoptError) -> str:
    """The message of ``err`` (about a gear parameter) stated for ``[section] key`` of the scene
    file, whose value as written is ``written`` (``_MISSING`` when not set): ``[pinion] a_pl =
    "-0.001 1/mm" (= -0.001) is out of range; valid: ...`` (the converted value in parentheses when
    it reads differently), or ``[section] key: <message>`` when ``err`` is not a range error."""
    detail = err.detail or ""
    if detail.startswith(("is out of range", "must be")):
        converted = value_text(err.value)
        if written is _MISSING:
            shown = f"{converted} (not set: the default)"
        else:
            shown = toml_text(written)
            if not _same(converted, written):
                shown += f" (= {converted})"
        return join_detail(f"[{section}] {key} = {shown}", detail)
    return f"[{section}] {key}: {err}"


def _restate(source: Path, section: str, key: str, written, err: GearoptError) -> SceneError:
    """:func:`_restate_text` as the SceneError of the scene file ``source``, with ``param`` the
    ``[section] key``, ``value`` as written, ``valid`` from ``err``."""
    return SceneError(f"{source}: {_restate_text(section, key, written, err)}", param=f"[{section}] {key}",
                      value=toml_text(written) if written is not _MISSING else None, valid=err.valid, source=source)


def _make_microgeometry(v: dict, given: set, member: str, path: Path):
    """The member's :class:`Microgeometry` from ``[<member>.modifications]`` (None when absent)."""
    from ..geometry.microgeometry import Microgeometry

    m = v.get("modifications")
    if not m:
        return None
    kw = {k: val for k, val in m.items() if f"modifications.{k}" in given
          and k not in ("d_alpha_start", "d_alpha_end", "sides")}
    if m.get("d_alpha_start") is not None or m.get("d_alpha_end") is not None:
        if m.get("d_alpha_start") is None or m.get("d_alpha_end") is None:
            raise SceneError(f"{path}: [{member}.modifications] d_alpha_start and d_alpha_end: give both ends of the "
                             "profile evaluation range, or neither (the active profile).",
                             param=f"[{member}.modifications] d_alpha_end", valid="both or neither", source=path)
        kw["d_alpha"] = (m["d_alpha_start"], m["d_alpha_end"])
    side = m.get("sides") or "both"
    kw["sides"] = ("right", "left") if side == "both" else (side,)
    try:
        return Microgeometry(**kw)
    except GearoptError as e:
        key = (e.param or "").split(".", 1)[-1]
        key = {"d_alpha": "d_alpha_start"}.get(key, key)
        raise SceneError(f"{path}: [{member}.modifications] {key}: {e}", param=f"[{member}.modifications] {key}",
                         value=e.value, valid=e.valid, source=path) from None


def _with_measured(gear: Gear, files: dict, member: str, path: Path) -> Gear:
    """``gear`` with the topography grids of ``[<member>.measured]`` added to its modifications."""
    from ..geometry.inspection import check_grid_on_flank, read_grid_csv
    from ..geometry.microgeometry import Microgeometry

    grids = []
    for side in ("right", "left"):
        name = files.get(side)
        if not name:
            continue
        f = (path.parent / name) if not Path(name).is_absolute() else Path(name)
        try:
            grid = read_grid_csv(f, side=side)
            if grid.side != side:
                raise SceneError(f"{f.name}: # side = {grid.side!r} but the file is given as the {side} flank.",
                                 param="# side", value=grid.side, valid=repr(side))
            check_grid_on_flank(grid, gear)
        except GearoptError as e:
            raise SceneError(f"{path}: [{member}.measured] {side} = {toml_text(name)}: {e}",
                             param=f"[{member}.measured] {side}", value=toml_text(name), valid=e.valid,
                             source=path) from None
        grids.append(grid)
    mg = gear.modifications or Microgeometry()
    return gear.with_(modifications=replace(mg, measured=tuple(grids)))


def _build_pair(data: dict, parsed: dict, given: dict, path: Path) -> GearPair:
    label = str(path)
    pr = parsed["pair"]
    if pr["m_n"] is not None:
        m_n = pr["m_n"]
    else:
        m_n = 1.0 / pr["P_n"]
    pinion_hand = pr["hand"]
    hands = {"pinion": pinion_hand, "gear": "left" if pinion_hand == "right" else "right"}

    def raw(section: str, key: str):
        """The value as written in the file (``section`` may be ``"pinion.rack"``)."""
        return _raw_value(data, section, key)

    def reraise(err: GeometryError, member: str | None, context: str):
        """Restate an error of gearopt.gears for the key of the scene file its ``param`` names."""
        loc = _gear_key(data, member, err.param) if err.param else None
        if loc is not None:
            raise _restate(path, *loc, raw(*loc), err) from None
        raise SceneError(f"{label}: {context}: {err}", source=path) from None

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
                                 "coefficient or tip diameter).", param=f"[{member}] k", valid="at most one of them",
                                 source=path)
            r_p = m_n * v["z"] / math.cos(pr["beta"]) / 2
            k = (v["d_a"] / 2 - r_p) / m_n - rack.h_aP - v["x"]
        try:
            tool = _make_tool(v.get("tool"))
        except GeometryError as e:
            raise SceneError(f"{label}: [{member}] tool = {toml_text(raw(member, 'tool'))}: {e}", param=f"[{member}] tool",
                             value=toml_text(raw(member, "tool")), valid=e.valid, source=path) from None
        mods = _make_microgeometry(v, given[member], member, path)
        try:
            members[member] = Gear(z=v["z"], m_n=m_n, x=v["x"], b=v["b"], beta=pr["beta"], hand=hands[member],
                                   rack=rack, k=k, a_pl=v["a_pl"], allow_undercut=v["allow_undercut"],
                                   name=member, A_sne=v["A_sne"], A_sni=v.get("A_sni"), tool=tool,
                                   modifications=mods)
            if v.get("measured"):
                members[member] = _with_measured(members[member], v["measured"], member, path)
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
                raise SceneError(f"{label}: [{member}] d_a = {toml_text(raw(member, 'd_a'))} is out of range (tip "
                                 f"alteration k = {k:.4g} from it); valid: {rng} for z = {v['z']}, x = {v['x']:g}, "
                                 f"m_n = {m_n:g} mm.", param=f"[{member}] d_a", value=toml_text(raw(member, "d_a")),
                                 valid=rng, source=path) from None
            reraise(e, member, f"[{member}]")
    try:
        pair = GearPair(pinion=members["pinion"], gear=members["gear"], a=pr["a"])
    except GeometryError as e:
        reraise(e, None, "[pair]")
    _check_reliefs_in_pair(pair, data, path)
    return pair


def _check_reliefs_in_pair(pair: GearPair, data: dict, path: Path) -> None:
    """Refuse a profile relief start (``d_Ca``, ``L_Ca``, ``d_Cf``, ``L_Cf``) outside its member's
    profile evaluation range (the active profile in this pair, or ``d_alpha``), naming the key of
    ``[<member>.modifications]`` (:func:`~gearopt.geometry.microgeometry.check_relief_starts`)."""
    from ..geometry.microgeometry import active_profile, check_relief_starts

    for member in ("pinion", "gear"):
        g = getattr(pair, member)
        mg = g.modifications
        if mg is None or not any(k in mg.reliefs for k in ("C_alpha_a", "C_alpha_f")):
            continue
        r_s, r_e = (mg.d_alpha[0] / 2, mg.d_alpha[1] / 2) if mg.d_alpha is not None else active_profile(pair, member)
        try:
            check_relief_starts(mg, g, r_s, r_e, f"{member}.modifications")
        except GeometryError as e:
            loc = _gear_key(data, member, e.param)
            raise _restate(path, *loc, _raw_value(data, *loc), e) from None

