"""Option sets as frozen dataclasses: one declaration per option (after do-mpc's ``MPCSettings``).

Each field of a :class:`Settings` subclass is declared with :func:`option`: its kind (which fixes its
internal unit, mm, rad, 1/mm, and the unit of a bare number in a scene), its default (in the internal
unit), its range (a :class:`~gearopt.schema.Bounds` in the scene unit, as scene fields state it), its
choices and a one-line doc::

    @dataclass(frozen=True)
    class SliceSettings(Settings):
        n_slices: int = option(15, kind="int", bounds=Bounds(3, 201), doc="slices across the face")

From that one declaration come

- the check of every value, in ``__post_init__`` (an :class:`~gearopt.errors.OptionError` naming the
  parameter, the value and the valid range, ``n_slices = 2 is out of range; valid: an integer,
  3 <= n_slices <= 201.``), so the API constructors that take the option set (or its fields as
  keywords, :meth:`Settings.of`) check nothing by hand;
- the scene section (:meth:`Settings.scene_fields`, :meth:`Settings.section`), which the scene loader
  validates with the same range and converts to the same default;
- the ``gearopt studies`` lines and the docs table (:meth:`Settings.markdown`; ``gearopt studies
  --markdown`` prints the tables of docs/scenes.md).

A base-layer module: it imports only :mod:`gearopt.errors`, :mod:`gearopt.units`,
:mod:`gearopt.schema`, the standard library and numpy, so that every library layer may import it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import MISSING, dataclass
from typing import Any, Callable, ClassVar, TypeVar

import numpy as np

from .errors import ArgumentError, GearoptError, GeometryError, OptionError, check_number, out_of_range
from .schema import KIND_UNITS, Bounds, Field, Section, closest, format_field, toml_text
from .units import KINDS

__all__ = ["Option", "option", "Settings", "Bounds", "E_RANGE", "check_modulus", "LoadedMicroSettings", "LTCASettings",
           "LTCAStudySettings", "RobustSettings", "MonteCarloSettings", "SweepSettings", "ContactSettings",
           "TCAStudySettings", "GeometryStudySettings", "PlanarTCASettings", "CrowningTarget", "CrowningStudySettings",
           "MeshOptions", "FEOptions"]

S = TypeVar("S", bound="Settings")

_KIND_TEXT = {"int": "an integer", "float": "a number", "bool": "True or False", "str": "a string",
              "floats": "a non-empty list of numbers"}


@dataclass(frozen=True)
class Option:
    """The metadata of one option (see :func:`option` for the parameters)."""

    kind: str
    doc: str
    bounds: Bounds | None = None
    choices: tuple | None = None
    check: Callable[[Any], str | None] | None = None
    key: str | None = None
    unit: str | None = None
    label: str = ""
    shown: str | None = None
    typical: str | None = None
    bare: Bounds | None = None
    valid: str | None = None
    none: bool = False
    group: str = ""
    scene_required: bool = False

    def field(self, name: str, default: Any) -> Field:
        """The scene :class:`~gearopt.schema.Field` of this option (key ``self.key or name``)."""
        if default is MISSING or self.scene_required:
            default, required = None, True
        else:
            required = False
            if self.shown is not None:
                default = self.shown
        return Field(self.key or name, self.kind, required=required, default=default, doc=self.doc,
                     choices=self.choices, check=self.bounds if self.bounds is not None else self.check,
                     unit=self.unit, bare=self.bare, typical=self.typical)

    @property
    def scene_unit(self) -> str:
        """The unit of a bare number in a scene (mm, deg, 1/mm, :attr:`unit`; '' for plain numbers)."""
        return self.unit or KIND_UNITS[self.kind][1]

    def display(self, name: str) -> tuple[float, str]:
        """(factor, unit): an internal value times ``factor`` is in ``unit``, the unit of the messages
        (the typical unit of an angle, else its scene unit, else :attr:`label`)."""
        if self.kind not in KINDS:
            return 1.0, self.label
        unit = self.typical or self.scene_unit
        return 1.0 / KINDS[self.kind][0][unit], unit

    def valid_text(self, name: str, optional: bool) -> str:
        """The valid range as the API's messages state it."""
        if self.valid is not None:
            text = self.valid
        elif self.choices is not None:
            text = " or ".join(repr(c) for c in self.choices)
        else:
            k, unit = self.display(name)
            b = self.bounds
            if b is not None and self.kind in KINDS:  # bounds in the scene unit, the message in its own
                scene_to_display = k * KINDS[self.kind][0][self.scene_unit]
                b = Bounds(*(None if v is None else v * scene_to_display for v in (b.lo, b.hi)), b.lo_open, b.hi_open)
            text = b.text(name, unit) if b is not None else _KIND_TEXT.get(self.kind, f"a {self.kind} [{unit}]")
            if self.kind == "int" and b is not None:
                text = "an integer, " + text
        return text + (" (or None)" if optional else "")

    def validate(self, name: str, value: Any, optional: bool, param: str | None = None,
                 error: type[GearoptError] = OptionError) -> Any:
        """``value`` checked and normalised (int, float, tuple of floats).

        Raises
        ------
        OptionError (or ``error``)
            Named ``param`` (default ``name``), with the value and the valid range.
        ArgumentError
            A text for a number (the API takes numbers in mm and rad; units in texts are for scenes).
        """
        if value is None and optional:
            return None
        param = name if param is None else param

        def bad(shown: Any = value, valid: str | None = None) -> GearoptError:
            if valid is None:
                valid = self.valid_text(name, optional)
            elif optional:
                valid += " (or None)"
            return out_of_range(param, shown, valid, cls=error)

        k = self.kind
        if k == "int":
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
                raise bad()
            value = int(value)
        elif k == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise bad()
            value = bool(value)
        elif k == "str":
            if not isinstance(value, str):
                raise bad()
        elif k == "floats":
            try:
                arr = np.asarray(value, float).ravel()
            except (TypeError, ValueError):
                raise bad() from None
            if isinstance(value, (str, bytes)) or arr.size == 0 or not np.all(np.isfinite(arr)):
                raise bad()
            value = tuple(float(v) for v in arr)
        else:  # float and the quantities
            if isinstance(value, str):  # "8 arcsec": units in strings are for scenes
                check_number(param, value, self.valid_text(name, optional))
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
                    or not math.isfinite(value):
                raise bad()
            value = float(value)
        if self.choices is not None and value not in self.choices:
            raise bad()
        if self.bounds is not None:
            f, unit = self.display(name)
            scene = value if k not in KINDS else value / KINDS[k][0][self.scene_unit]
            if not self.bounds.ok(scene):
                raise bad(f"{value * f:.6g} {unit}" if k in KINDS and k != "length" else value)
        if self.check is not None:
            res = self.check(list(value) if k == "floats" else value)
            if res is False or isinstance(res, str):
                # the check's own text where it states the range (``valid``, or ``valid`` and a hint)
                own = isinstance(res, str) and (self.valid is None or res.startswith(self.valid))
                raise bad(valid=res if own else None)
        return value


def option(default: Any = MISSING, *, kind: str, doc: str, bounds: Bounds | None = None,
           choices: tuple | None = None, check: Callable[[Any], str | None] | None = None, key: str | None = None,
           unit: str | None = None, label: str = "", shown: str | None = None, typical: str | None = None,
           bare: Bounds | None = None, valid: str | None = None, none: bool | None = None, group: str = "",
           scene_required: bool = False) -> Any:
    """A dataclass field of a :class:`Settings` with its metadata.

    Parameters
    ----------
    default
        The default in the internal unit (mm, rad, 1/mm, N m, MPa); ``None``: the option may be
        ``None`` (absent); no default: required.
    kind : {"int", "float", "floats", "bool", "str", "length", "angle", "inverse_length"}
        As :class:`~gearopt.schema.Field`: the type and, for quantities, the internal unit.
    doc : str
        One line for the docs, ``gearopt studies`` and the scene's messages.
    bounds : Bounds or None
        The valid range, in the scene unit (deg for angles, mm for lengths, ``unit`` if set).
    choices : tuple or None
        The allowed values.
    check : callable(value) -> None | str, optional
        A check that a range cannot state (``None`` when fine, else the valid range as a text).
    key : str or None
        The scene key when it differs from the field name (``positions`` for ``n_positions``);
        ``""``: not a scene key.
    unit : str or None
        The unit of a bare number in the scene when it differs from the kind's (``"um"``).
    label : str
        The unit of a plain number in messages and docs (``"MPa"``, ``"N m"``).
    shown : str or None
        The default as a scene writes it (``"0.5 um"``); :meth:`Settings.scene_field` checks that it
        loads as ``default`` exactly (tests/test_settings.py builds every section).
    typical, bare
        As :class:`~gearopt.schema.Field`.
    valid : str or None
        The valid range as messages state it, when ``bounds``/``choices`` do not say it all (a
        ``check``'s text that starts with it, e.g. with a unit hint, replaces it in the message;
        without ``valid`` the check's text is the message's range).
    none : bool or None
        Whether ``None`` is allowed (default: when the default is ``None``).
    group : str
        The scene sub-table of the key (``"unloaded_te"``: ``[section.unloaded_te] key``); ``""``
        the section itself.
    scene_required : bool
        The key is required in the scene (in its sub-table) although the API has a default.
    """
    meta = Option(kind=kind, doc=doc, bounds=bounds, choices=None if choices is None else tuple(choices), check=check,
                  key=key, unit=unit, label=label, shown=shown, typical=typical, bare=bare, valid=valid,
                  none=default is None if none is None else none, group=group, scene_required=scene_required)
    return dataclasses.field(default=default, metadata={"option": meta})


@dataclass(frozen=True)
class Settings:
    """Base of the option sets: validation from the fields' :func:`option` metadata.

    Subclasses are frozen dataclasses; :meth:`validate` (a hook, empty here) checks what concerns
    several options together.
    """

    #: The scene section's name (for :meth:`markdown` and :meth:`section`).
    SECTION: ClassVar[str] = ""
    #: What the errors name a field ``x``: ``PARAM + "x"`` (``"target."`` for a target's fields).
    PARAM: ClassVar[str] = ""
    #: The class of the range errors (:class:`OptionError` for options; GeometryError for gear data).
    ERROR: ClassVar[type[GearoptError]] = OptionError

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            meta = f.metadata.get("option")
            if meta is None:
                continue
            value = meta.validate(f.name, getattr(self, f.name), optional=meta.none, param=self.PARAM + f.name,
                                  error=self.ERROR)
            object.__setattr__(self, f.name, value)
        self.validate()

    def validate(self) -> None:
        """Checks of several options together (raise :class:`OptionError`); none by default."""

    @classmethod
    def check(cls, name: str, value: Any) -> Any:
        """The option ``name`` checked and normalised alone (for an API that takes it as an argument)."""
        meta = cls.options()[name][0]
        return meta.validate(name, value, optional=meta.none, param=cls.PARAM + name, error=cls.ERROR)

    @classmethod
    def field_of(cls, name: str, **changes: Any) -> Any:
        """A dataclass field with the default and metadata of the option ``name`` (the same option in
        another option set: ``delta: float = ContactSettings.field_of("delta", key="")``); ``changes``
        replace attributes of its :class:`Option` (``key``, ``doc``: how the other set shows it)."""
        meta, default = cls.options()[name]
        return dataclasses.field(default=default, metadata={"option": dataclasses.replace(meta, **changes)})

    # -- the declarations --------------------------------------------------------------------
    @classmethod
    def options(cls) -> dict[str, tuple[Option, Any]]:
        """Field name -> (its :class:`Option`, its default or ``dataclasses.MISSING``)."""
        if not dataclasses.is_dataclass(cls):
            raise TypeError(f"{cls.__name__} must be a dataclass")
        out = {}
        for f in dataclasses.fields(cls):
            if "option" in f.metadata:
                out[f.name] = (f.metadata["option"], f.default)
        return out

    @classmethod
    def scene_keys(cls, group: str = "") -> dict[str, str]:
        """Scene key -> field name of the options that are keys of the sub-table ``group``."""
        return {(o.key or n): n for n, (o, _) in cls.options().items() if o.key != "" and o.group == group}

    @classmethod
    def scene_field(cls, name: str) -> Field:
        """The scene field of the option ``name`` (same default and range)."""
        o, d = cls.options()[name]
        fld = o.field(name, d)
        if o.shown is not None and d is not MISSING:  # the default as written must load as declared
            loaded = fld.convert(o.shown, f"{cls.__name__}.{name} (shown default)")
            if loaded != d:
                raise ValueError(f"{cls.__name__}.{name}: shown default {o.shown!r} loads as {loaded!r}, "
                                 f"not the default {d!r}")
        return fld

    @classmethod
    def scene_fields(cls, layout: list | tuple | None = None, group: str = "") -> list[Field]:
        """The scene fields of the sub-table ``group`` in the order of ``layout``.

        ``layout`` mixes option names (``"n_positions"``) and other :class:`~gearopt.schema.Field`
        objects of the section; it must name every option of the group once (default: the options in
        declaration order).
        """
        names = list(cls.scene_keys(group).values())
        if layout is None:
            layout = names
        named = [x for x in layout if isinstance(x, str)]
        if sorted(named) != sorted(names):
            raise ValueError(f"{cls.__name__}: the layout of [{group or cls.SECTION}] names {sorted(named)}, "
                             f"the options are {sorted(names)}")
        return [cls.scene_field(x) if isinstance(x, str) else x for x in layout]

    @classmethod
    def section(cls, name: str | None = None, layout: list | tuple | None = None, *, subsections: tuple | list = (),
                required: bool = False, doc: str = "", group: str = "") -> Section:
        """The scene section (or sub-table ``group``): :meth:`scene_fields` and ``subsections``."""
        return Section(name or group or cls.SECTION, cls.scene_fields(layout, group), required=required, doc=doc,
                       subsections=list(subsections))

    # -- building ------------------------------------------------------------------------------
    @classmethod
    def of(cls: type[S], settings: S | None = None, **keywords: Any) -> S:
        """The option set from ``settings`` (or the defaults) with ``keywords`` replacing fields.

        Raises
        ------
        ArgumentError
            ``settings`` is not a ``cls``, or a keyword is not an option of ``cls``.
        OptionError
            A value out of its range.
        """
        if settings is not None and not isinstance(settings, cls):
            raise ArgumentError(f"settings = {settings!r:.60}: expected a {cls.__name__}.", param="settings",
                                value=settings, valid=f"a {cls.__module__}.{cls.__name__}")
        names = [f.name for f in dataclasses.fields(cls)]
        for k in keywords:
            if k not in names:
                raise ArgumentError(f"{k}: not an option of {cls.__name__}.{closest(k, names)} Valid: {', '.join(names)}.",
                                    param=k, valid=", ".join(names))
        if settings is None:
            return cls(**keywords)
        return dataclasses.replace(settings, **keywords) if keywords else settings

    @classmethod
    def from_scene(cls: type[S], values: dict, **keywords: Any) -> S:
        """The option set from a scene section's loaded values (scene keys, sub-tables as dicts or
        ``None``; internal units); ``keywords`` replace fields."""
        kw = {}
        groups = {o.group for o, _ in cls.options().values() if o.key != ""}
        for g in groups:
            table = values if not g else values.get(g) or {}
            kw.update({n: table[k] for k, n in cls.scene_keys(g).items() if table.get(k) is not None})
        kw.update(keywords)
        return cls(**kw)

    def to_dict(self) -> dict[str, Any]:
        """Field name -> value (internal units)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    # -- docs ----------------------------------------------------------------------------------
    @classmethod
    def describe(cls) -> list[str]:
        """One line per scene key (as ``gearopt studies NAME`` prints them)."""
        return [format_field(cls.scene_field(n)) for n, (o, _) in cls.options().items() if o.key != ""]

    @classmethod
    def markdown(cls, name: str | None = None) -> str:
        """A markdown table of the options: scene key, API name, kind [unit], default, valid range, doc."""
        rows = [f"`[{name or cls.SECTION}]` ({cls.__module__}.{cls.__name__})", "",
                "| key | API | kind [unit] | default | valid | |", "|---|---|---|---|---|---|"]
        for n, (o, d) in cls.options().items():
            if o.key == "":
                continue
            fld = o.field(n, d)
            key = f"{o.group}.{fld.name}" if o.group else fld.name
            unit = fld.scene_unit or o.label
            kind = f"{o.kind} [{unit}]" if unit else o.kind
            default = "required" if d is MISSING or o.scene_required else ("none" if d is None else toml_text(fld.default))
            if o.choices is not None:
                valid = ", ".join(toml_text(c) for c in o.choices)
            else:
                valid = o.valid_text(fld.name, False)
            rows.append(f"| `{key}` | `{n}` | {kind} | {default.replace('|', '/')} | {valid} | {o.doc} |")
        return "\n".join(rows) + "\n"


# ----------------------------------------------------------------------------------------------
# The option sets of the library (each the one declaration of its options: the API constructor
# takes it or its fields as keywords, the study's scene section is generated from it).
# ----------------------------------------------------------------------------------------------
def _harmonic_weights(v: list) -> str | None:
    return None if len(v) <= 10 and all(x >= 0 for x in v) and sum(v) > 0 else "1 ... 10 weights >= 0, not all 0"


@dataclass(frozen=True)
class LoadedMicroSettings(Settings):
    """Options of :class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer` (docs/loaded_synthesis.md), the
    ``[loaded_microgeometry]`` keys of the same names (``positions``, ``verify_positions``,
    ``[loaded_microgeometry.unloaded_te] level, weight``)."""

    SECTION: ClassVar[str] = "loaded_microgeometry"

    p_limit: float | None = option(None, kind="float", label="MPa", bounds=Bounds(lo=100, hi=1e4),
                                   doc="peak Hertz pressure limit [MPa] (default none)")
    harmonics: tuple[float, ...] | None = option(
        None, kind="floats", check=_harmonic_weights,
        valid="1 ... 10 weights >= 0, not all 0, one per mesh harmonic, at most (n_positions - 1) / 2 of them",
        doc="weights of the loaded TE's first mesh harmonics as the objective (default: peak-to-peak)")
    edge_margin: float | None = option(5e-4, kind="length", shown="0.5 um", none=True,
                                       bounds=Bounds(lo=0, lo_open=True, hi=0.1),
                                       doc="smallest gap of every tip edge and face end under load")
    n_positions: int = option(32, kind="int", key="positions", bounds=Bounds(lo=8, hi=256),
                              doc="positions per mesh cycle in the NLP")
    n_verify: int = option(64, kind="int", key="verify_positions", bounds=Bounds(lo=8, hi=2000),
                           doc="positions per mesh cycle of the before/after loaded TCA")
    n_confirm: int = option(96, kind="int", key="confirm_positions", bounds=Bounds(lo=8, hi=2000),
                            doc="positions per mesh cycle of the grid on which the optimum's loaded TE extremes are "
                                "found (then refined between its positions) to confirm the NLP's objective")
    confirm_tol: float = option(0.01, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=0.5),
                                doc="largest difference of the confirmed (loaded TE extremes between positions) and the "
                                    "NLP's peak-to-peak objective, a share of the confirmed one")
    max_exchanges: int = option(4, kind="int", bounds=Bounds(lo=0, hi=20),
                                doc="times the loaded TE extremes of the optimum may join the NLP's positions before "
                                    "a disagreement of the two objectives raises")
    exchange: bool = option(False, kind="bool",
                            doc="exchange the optimum's loaded TE extremes into the NLP's positions until its objective "
                                "is confirmed (false: the NLP's positions only; the confirmed objective is still reported)")
    n_slices: int = option(15, kind="int", bounds=Bounds(lo=3, hi=201), doc="slices across the face")
    side: str = option("right", kind="str", choices=("right", "left"), doc="driving flank of the pinion")
    te_level: float | None = option(None, kind="angle", key="level", group="unloaded_te", scene_required=True,
                                    typical="arcsec", bounds=Bounds(lo=0, lo_open=True, hi=600 / 3600),
                                    doc="predesigned parabolic TE level of the unloaded drive")
    te_weight: float = option(1.0, kind="float", key="weight", group="unloaded_te",
                              bounds=Bounds(lo=0, lo_open=True, hi=1e3),
                              doc="weight of its RMS misfit against the loaded TE objective")

    def validate(self) -> None:
        """The harmonics must be resolved by the NLP's positions: 2 h + 1 <= n_positions."""
        if self.harmonics is not None and 2 * len(self.harmonics) + 1 > self.n_positions:
            raise out_of_range("harmonics", list(self.harmonics),
                               "1 ... 10 weights >= 0, not all 0, one per mesh harmonic, at most (n_positions - 1) / 2 "
                               f"= {(self.n_positions - 1) // 2} of them", cls=OptionError)


#: Young's moduli [MPa] of gear materials: polymers (POM, PA: ~1000-3000) to cemented carbide (~650000)
#: (the range of the ``E`` keys).
E_RANGE = (500.0, 1.2e6)


def check_modulus(E: float) -> str | None:
    """None if ``E`` [MPa] is a gear material's modulus, else the valid range (with a unit hint)."""
    if E_RANGE[0] <= E <= E_RANGE[1]:
        return None
    hint = ""
    if E_RANGE[0] <= E * 1000 <= E_RANGE[1]:
        hint = f" (E is in MPa: {E:g} GPa is {E * 1000:g} MPa)"
    elif E_RANGE[0] <= E / 1e6 <= E_RANGE[1]:
        hint = f" (E is in MPa: {E:g} Pa is {E / 1e6:g} MPa)"
    return f"{E_RANGE[0]:g} <= E <= {E_RANGE[1]:g} MPa, the Young's moduli of gear materials{hint}"


@dataclass(frozen=True)
class LTCASettings(Settings):
    """Options of :class:`~gearopt.ltca.engine.LTCA` (docs/ltca.md) that are not data of the drive: the
    ``[ltca]`` keys of the same names. The pair-dependent limits (``coupling`` at most 10 face
    widths, ``body_coupling`` 100) are checked by :class:`~gearopt.ltca.engine.LTCA` itself."""

    SECTION: ClassVar[str] = "ltca"

    side: str = option("right", kind="str", choices=("right", "left"), doc="driving flank of the pinion")
    n_slices: int = option(21, kind="int", bounds=Bounds(lo=3, hi=201), doc="slices across the face")
    coupling: float | None = option(
        None, kind="length", bounds=Bounds(lo=0, hi=1000),
        doc="coupling length of the teeth's compliance across the face (default half the pinion tooth height; "
            "the bodies couple over their depth)")
    compliance: str = option(
        "analytical", kind="str", choices=("analytical", "fe"),
        doc="tooth compliance: the analytical thin-slice model, or influence coefficients of each member's "
            "CalculiX model (needs ccx; cached in $GEAROPT_CACHE/influence, default ~/.cache/gearopt)")
    curvature: str = option("surface", kind="str", choices=("surface", "involute"), key="",
                            doc="the flanks' curvature in the Hertz term: each modified surface's own, or the "
                                "unmodified involute's (for comparison only)")
    body_coupling: float | None = option(None, kind="length", bounds=Bounds(lo=0), key="",
                                         doc="coupling length of the gear bodies' term across the face, both members "
                                             "(default: each member's own)")
    body: str = option("full_gear_fit", kind="str", choices=("full_gear_fit", "sainsot2004"), key="",
                       doc="the gear body's term of the analytical compliance: Sainsot's form refitted to plane-stress "
                           "FE full gears held at their bores (benchmarks/fe_body_fit.py), or Sainsot, Velex & "
                           "Duverger's 2004 coefficients (docs/ltca.md section 2)")
    helical: str = option("normal", kind="str", choices=("normal", "transverse"), key="",
                          doc="a helical member's slice compliance along the normal: the teeth (bending, shear, "
                              "compression) cos(beta_b) and the body once the transverse slice's (FE full gears, "
                              "docs/ltca.md section 7), or both cos^2(beta_b) of it (the model before 2026-11-29)")
    neighbours: str = option(
        "auto", kind="str", choices=("auto", "full_gear", "none"), key="",
        doc="the coupling of the pairs in mesh through the gear bodies (a load on one tooth moves the neighbouring "
            "teeth, docs/ltca.md sections 2 and 7): 'full_gear' the analytical term fitted to FE full gears held at "
            "their bores (analytical compliance only), 'none' the pairs uncoupled, 'auto' (default) 'full_gear' with "
            "the analytical compliance and 'none' with FE influence coefficients (their members' own models)")


@dataclass(frozen=True)
class LTCAStudySettings(LTCASettings):
    """Options of the ``ltca`` study (:class:`~gearopt.studies.ltca.LTCAStudy`): those of
    :class:`LTCASettings` and the positions per mesh cycle."""

    positions: int = option(64, kind="int", bounds=Bounds(lo=16, hi=2000), doc="positions per mesh cycle")


@dataclass(frozen=True, kw_only=True)
class RobustSettings(Settings):
    """Options shared by :class:`MonteCarloSettings` and :class:`SweepSettings` (the executor, its
    workers and the elastic approach ``delta`` are keywords of the API classes: they do not change
    the samples' figures, or depend on the drive)."""

    positions: int = option(64, kind="int", bounds=Bounds(lo=16, hi=2000), doc="positions per mesh cycle")
    side: str = option("right", kind="str", choices=("right", "left"), doc="driving flank of the pinion")
    chunk: int = option(64, kind="int", bounds=Bounds(lo=1, hi=100000),
                        doc="samples per task (the results do not depend on it)")
    seed: int = option(0, kind="int", bounds=Bounds(lo=0, hi=2**63 - 1), doc="seed of the sampling")


@dataclass(frozen=True, kw_only=True)
class MonteCarloSettings(RobustSettings):
    """Options of :class:`~gearopt.robust.study.MonteCarlo` and the ``[montecarlo]`` keys of the same
    names (the distributions of the misalignments and the torque are data of the study)."""

    SECTION: ClassVar[str] = "montecarlo"

    samples: int = option(kind="int", bounds=Bounds(lo=1, hi=10_000_000), doc="number of samples")
    sampling: str = option("random", kind="str", choices=("random", "lhs"), doc="Monte Carlo (PCG64) or Latin hypercube")
    iso_grade: int | None = option(None, kind="int", bounds=Bounds(lo=1, hi=11),
                                   doc="ISO 1328-1:2013 flank tolerance class of both members (helix/profile slope, "
                                       "pitch sampled)")
    spread: str = option("normal", kind="str", choices=("normal", "uniform"),
                         doc="deviations within +-T: N(0, (T/3)^2) truncated, or uniform")
    f_a: float = option(0.0, kind="length", bounds=Bounds(lo=0, hi=5),
                        doc="centre-distance tolerance +-f_a (dE sampled)")
    n_slices: int = option(21, kind="int", bounds=Bounds(lo=3, hi=201),
                           doc="slices across the face of the loaded TCA (with torque)")


@dataclass(frozen=True, kw_only=True)
class SweepSettings(RobustSettings):
    """Options of :class:`~gearopt.robust.study.DesignSweep` and the ``[sweep]`` keys of the same names
    (the variables and their ranges are data of the study, ``[sweep.vary]``)."""

    SECTION: ClassVar[str] = "sweep"

    design: str = option("lhs", kind="str", choices=("lhs", "full_factorial", "random"), doc="the design")
    samples: int = option(64, kind="int", bounds=Bounds(lo=1, hi=1_000_000), doc="points (lhs, random)")
    levels: int = option(3, kind="int", bounds=Bounds(lo=2, hi=101), doc="levels per variable (full factorial)")


@dataclass(frozen=True)
class ContactSettings(Settings):
    """Contact-ellipse setting (the default of the TCA sweeps, the synthesis targets and the scenes).

    Parameters
    ----------
    delta : float
        Elastic approach of the surfaces for the contact ellipse [mm] (Litvin 9.1: 0.00632 mm).
    """

    delta: float = option(0.00632, kind="length", bounds=Bounds(lo=0, lo_open=True, hi=0.1),
                          doc="elastic approach for the contact ellipse")


@dataclass(frozen=True)
class CrowningTarget(Settings):
    """What the optimized drive must do (:class:`~gearopt.synthesis.crowning.CrowningOptimizer`); the
    ``[crowning]`` keys of the same names.

    Parameters
    ----------
    te_level : float
        Predesigned TE level [rad]: the parabola's drop from its apex to the transfer points
        ``pi/z1`` away (e.g. ``8 * ARCSEC``).
    ellipse_share : float
        Minimum major axis of the contact ellipse at the mean point of the aligned drive, as a share
        of the face width (0 = no constraint).
    edge_margin : float
        Distance [mm] the contact points at the transfer points keep from the face ends.
    tip_margin : float
        Radial distance [mm] they keep from the tip and form circles.
    level_tolerance : float
        Accepted relative deviation of every case's verified TE level from ``te_level``; a design
        outside it is refused with the binding constraints named (the constraints won).
    delta : float
        Elastic approach for the contact ellipse [mm].
    objective : {"sum", "worst"}
        Misfit summed over the cases, or the worst case (epigraph form).

    Errors name the field ``target.<name>`` and are :class:`~gearopt.errors.GeometryError` (a text
    for a number: :class:`~gearopt.errors.ArgumentError`, a subclass).
    """

    SECTION: ClassVar[str] = "crowning"
    PARAM: ClassVar[str] = "target."
    ERROR: ClassVar[type[GearoptError]] = GeometryError

    te_level: float = option(kind="angle", typical="arcsec", bounds=Bounds(lo=0, lo_open=True, hi=600 / 3600),
                             doc="predesigned TE level (e.g. \"8 arcsec\")")
    ellipse_share: float = option(0.0, kind="float", bounds=Bounds(lo=0, hi=1, hi_open=True),
                                  doc="min contact-ellipse major axis / face width at the mean point")
    edge_margin: float = option(0.0, kind="length", bounds=Bounds(lo=0, hi=10, hi_open=True),
                                doc="margin of the transfer contact points from the face ends")
    tip_margin: float = option(0.0, kind="length", bounds=Bounds(lo=0, hi=10, hi_open=True),
                               doc="radial margin of the transfer contact points from the tip and form circles")
    level_tolerance: float = option(0.10, kind="float", bounds=Bounds(lo=0, hi=1, lo_open=True, hi_open=True), key="",
                                    doc="accepted relative deviation of every case's verified TE level")
    delta: float = ContactSettings.field_of("delta", key="")
    objective: str = option("sum", kind="str", choices=("sum", "worst"), doc="sum of case misfits or worst case")


@dataclass(frozen=True)
class CrowningStudySettings(Settings):
    """Options of the ``crowning`` study (:class:`~gearopt.studies.crowning.CrowningStudy`) besides its
    :class:`CrowningTarget`: the NLP's positions (also the default and the check of
    :class:`~gearopt.synthesis.crowning.CrowningOptimizer`'s ``positions``) and IPOPT's output."""

    SECTION: ClassVar[str] = "crowning"

    positions: int = option(41, kind="int", bounds=Bounds(lo=7, hi=401), doc="TCA positions per case in the NLP")
    quiet: bool = option(True, kind="bool", doc="silence IPOPT's iteration output")


@dataclass(frozen=True)
class TCAStudySettings(ContactSettings):
    """Options of the ``tca`` study (:class:`~gearopt.studies.tca.TCAStudy`) and the ``[tca]`` keys of
    the same names. The pair-dependent limits (``delta`` at most 0.1 m_n, ``|z_section|`` at most
    half the pinion's face) are checked by the study."""

    SECTION: ClassVar[str] = "tca"

    side: str = option("right", kind="str", choices=("right", "left"), doc="driving flank of the pinion")
    contact: str = option("point", kind="str", choices=("point", "line"),
                          doc="point (crowned pinion) or line (conjugate/profile-crowned: in section z_section)")
    z_section: float = option(0.0, kind="length", doc="pinion section for line contact")
    positions: int = option(81, kind="int", bounds=Bounds(lo=9, hi=5000), doc="positions per mesh cycle")
    edge_contact: bool = option(False, kind="bool", doc="also solve edge contact (tips, face ends) and combine it "
                                                        "with the surface contact (Litvin 9.6)")
    inspection: bool | None = option(None, kind="bool",
                                     doc="inspect the flanks (topography CSV, profile and lead charts): default true "
                                         "for the members with [<member>.modifications] or [<member>.measured]")
    iso_grade: int | None = option(None, kind="int", bounds=Bounds(lo=1, hi=11),
                                   doc="ISO 1328-1:2013 flank tolerance class: tolerance bands on the profile and lead "
                                       "charts of measured flanks, and the chart values judged against them (designed "
                                       "amounts are not judged)")


@dataclass(frozen=True)
class GeometryStudySettings(Settings):
    """Options of the ``geometry`` study (:class:`~gearopt.studies.geometry.GeometryStudy`) and the
    ``[geometry]`` keys of the same names."""

    SECTION: ClassVar[str] = "geometry"

    points: int = option(60, kind="int", bounds=Bounds(lo=10, hi=2000), doc="samples per profile segment")
    rack_mesh: bool = option(True, kind="bool", doc="plot the rack-cutter in mesh (rack/hob-cut members)")


@dataclass(frozen=True)
class PlanarTCASettings(Settings):
    """Options of the ``planar_tca`` study (:class:`~gearopt.studies.planar_tca.PlanarTCAStudy`) and
    the ``[planar_tca]`` keys of the same names (the geometry and the rotations are its data)."""

    SECTION: ClassVar[str] = "planar_tca"

    method: str = option("continuation", kind="str", choices=("continuation", "map"),
                         doc="warm-started sequence or one mapped rootfinder call")
    alpha_guess: float = option(20 * math.pi / 180, kind="angle", shown="20 deg",
                                bounds=Bounds(lo=0, hi=90, lo_open=True, hi_open=True),
                                bare=Bounds(lo=2, hi=90, hi_open=True), typical="rad",
                                doc="pressure angle of the Newton starting point")
    profiles: int = option(3, kind="int", bounds=Bounds(lo=0, hi=20), doc="positions drawn with both profiles")


def _even(n: int) -> str | None:
    return None if n % 2 == 0 else "an even integer"


@dataclass(frozen=True)
class MeshOptions(Settings):
    """Element counts and grading of the FE tooth mesh (:mod:`gearopt.fea.mesh`); the element counts
    and ``rim_depth`` are the ``[fea]`` keys of the same names.

    Parameters
    ----------
    n_face : int
        Elements along the face width (even: a node layer lies on the middle section).
    n_half : int
        Elements across half a tooth (middle surface to flank), graded towards the flank.
    n_flank : int
        Elements along the flank of a tooth without contact (uniform).
    n_fillet : int
        Elements along each fillet.
    n_rim : int
        Elements along the radial line of the rim (plus one or two on the root arc).
    h_contact : float
        Element size [mm] along the profile at the contact point of a loaded flank, and thickness of
        the surface layer there (0: no grading, ``n_flank`` uniform elements).
    window : float
        Half-length [mm] of the profile window around the contact point meshed with ``h_contact``.
    growth : float
        Rate at which the element size grows away from the window [mm per mm], e.g. 0.25.
    rim_depth : float
        Rim thickness below the root circle, in modules m_n.

    Errors name the field ``fea.<name>`` (:class:`~gearopt.errors.OptionError`).
    """

    SECTION: ClassVar[str] = "fea"
    PARAM: ClassVar[str] = "fea."

    n_face: int = option(4, kind="int", bounds=Bounds(lo=2, hi=200), check=_even,
                         valid="an even integer, 2 <= n_face <= 200 (a node layer on the middle section)",
                         doc="elements along the face (even)")
    n_half: int = option(6, kind="int", bounds=Bounds(lo=1, hi=100), doc="elements across half a tooth")
    n_flank: int = option(8, kind="int", bounds=Bounds(lo=2, hi=400), doc="elements along an unloaded flank")
    n_fillet: int = option(5, kind="int", bounds=Bounds(lo=1, hi=200), doc="elements along each fillet")
    n_rim: int = option(4, kind="int", bounds=Bounds(lo=1, hi=200), doc="elements through the rim")
    h_contact: float = option(0.0, kind="length", bounds=Bounds(lo=0), key="",
                              doc="element size at a loaded contact point (0: no grading; the FE model derives it "
                                  "from n_hertz)")
    window: float = option(0.0, kind="length", bounds=Bounds(lo=0), key="",
                           doc="half-length of the profile window meshed with h_contact")
    growth: float = option(0.3, kind="float", label="mm per mm", bounds=Bounds(lo=0, lo_open=True, hi=2), key="",
                           doc="growth of the element size away from the window")
    rim_depth: float = option(1.5, kind="float", label="m_n", bounds=Bounds(lo=0.3, hi=10),
                              doc="rim below the root circle [m_n]")


@dataclass(frozen=True)
class FEOptions(Settings):
    """Material, load and mesh of the FE model (:class:`~gearopt.fea.model.GearFEModel`, the ``fea``
    study); the ``[fea]`` keys of the same names (the scene's ``torque`` is in N*m, the API's in N*mm).

    Parameters
    ----------
    torque : float
        Pinion torque [N*mm] (driving).
    E, nu : float
        Young's modulus [MPa] and Poisson's ratio of both members.
    teeth : int
        Teeth of each member in the model (3 = three tooth pairs).
    mesh : MeshOptions
        Element counts; ``h_contact``/``window`` 0 means: derived from ``n_hertz``.
    n_hertz : float
        Elements across the Hertz half-width b_H at a loaded contact point (0: no grading).
    n_ellipse : float
        Point contact (crowned pinion): face layers per major semi-axis of the Hertz ellipse around
        its centre (0: uniform layers).
    penalty : float
        Contact stiffness as a multiple of E [1/mm] (pressure = penalty E overclosure).
    close_fraction : float
        Step-1 rotation as a fraction of the estimated loaded approach
        (:meth:`~gearopt.fea.model.GearFEModel.approach_estimate`).
    element_type : str
        "C3D8" (default) or "C3D8I".
    threads, timeout : int, float
        ccx threads and time limit [s].
    keep_dir : str or None
        Keep the ccx files in this directory.

    Errors name the field ``fea.<name>`` (:class:`~gearopt.errors.OptionError`).
    """

    SECTION: ClassVar[str] = "fea"
    PARAM: ClassVar[str] = "fea."

    torque: float = option(100e3, kind="float", label="N*mm", bounds=Bounds(lo=0, lo_open=True, hi=1e9), key="",
                           doc="pinion torque [N*mm] (the scene's torque is in N*m)")
    E: float = option(210e3, kind="float", label="MPa", check=check_modulus,
                      valid=f"{E_RANGE[0]:g} <= E <= {E_RANGE[1]:g} MPa, the Young's moduli of gear materials",
                      doc="Young's modulus [MPa] (gear materials, from polymers to carbide)")
    nu: float = option(0.3, kind="float", bounds=Bounds(lo=0, hi=0.5, hi_open=True), doc="Poisson's ratio")
    teeth: int = option(3, kind="int", bounds=Bounds(lo=1, hi=7), doc="teeth of each member in the model")
    mesh: MeshOptions = dataclasses.field(default_factory=MeshOptions)
    n_hertz: float = option(3.0, kind="float", bounds=Bounds(lo=0, hi=50),
                            doc="elements across the Hertz half-width at the contact (0: no grading)")
    n_ellipse: float = option(2.0, kind="float", bounds=Bounds(lo=0, hi=50), key="",
                              doc="face layers per major semi-axis of the Hertz ellipse, point contact (0: uniform)")
    penalty: float = option(50.0, kind="float", label="E per mm", bounds=Bounds(lo=1, hi=1000),
                            doc="contact penalty stiffness [multiples of E per mm]")
    close_fraction: float = option(1.0, kind="float", bounds=Bounds(lo=0, hi=1), key="",
                                   doc="step-1 rotation as a fraction of the estimated loaded approach")
    element_type: str = option("C3D8", kind="str", choices=("C3D8", "C3D8I"), key="", doc="CalculiX element type")
    threads: int = option(2, kind="int", bounds=Bounds(lo=1, hi=1024), key="", doc="ccx threads")
    timeout: float = option(900.0, kind="float", label="s", bounds=Bounds(lo=0, lo_open=True), key="",
                            doc="ccx time limit [s]")
    keep_dir: str | None = option(None, kind="str", key="", doc="keep the ccx files in this directory")

    def validate(self) -> None:
        """``mesh`` must be a :class:`MeshOptions`."""
        if not isinstance(self.mesh, MeshOptions):
            raise out_of_range(self.PARAM + "mesh", self.mesh, "a gearopt.fea.mesh.MeshOptions", cls=OptionError)

    def to_dict(self) -> dict[str, Any]:
        """``options`` of the fea study's results.json (docs/results.md): ``torque_Nmm`` [N*mm],
        ``E`` [MPa], ``nu``, ``teeth``, ``n_hertz``, ``n_ellipse``, ``penalty_times_E`` [E per mm],
        ``element_type`` and the element counts ``mesh`` (``rim_depth`` in m_n)."""
        return {"torque_Nmm": self.torque, "E": self.E, "nu": self.nu, "teeth": self.teeth, "n_hertz": self.n_hertz,
                "n_ellipse": self.n_ellipse,
                "penalty_times_E": self.penalty, "element_type": self.element_type,
                "mesh": {k: getattr(self.mesh, k) for k in ("n_face", "n_half", "n_flank", "n_fillet", "n_rim",
                                                            "rim_depth")}}
