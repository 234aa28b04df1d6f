"""Registry of studies: what a scene's ``[scene] study = "..."`` may name.

A study module describes the extra scene sections it reads and how to build itself, and registers
on import. Its options are declared once, by an option set of :mod:`gearopt.settings` (a frozen
dataclass: kind and unit, default, range and doc per field), from which the section is generated;
keys that are data rather than options are :class:`~gearopt.schema.Field` objects placed in the
section's layout (docs/extending.md, "Adding a study")::

    from gearopt.settings import GeometryStudySettings
    from gearopt.studies import StudySpec, register

    register(StudySpec(
        name="geometry",
        sections=[GeometryStudySettings.section("geometry")],
        settings=(GeometryStudySettings,),
        build=_from_scene,                  # callable(scene) -> object with .run() -> result
        doc="Tooth geometry of both members",
    ))

``build(scene)`` receives a :class:`gearopt.io.scene.Scene`; the values of the study's sections
are in ``scene.options[section_name][key]`` (internal units: mm, rad, 1/mm). The built object's
``run()`` (optionally ``run(progress=callable(str))``) returns a result with ``to_dict()``
(JSON-able, with a ``"units"`` mapping) and ``save_plots(directory) -> list[str]``; see
:func:`gearopt.io.results.write_results`.

Built-in study modules are imported lazily, the first time the registry is consulted
(:func:`studies`, :func:`get_study`), so importing :mod:`gearopt` stays cheap; :func:`get_study`
of a built-in study imports its own module only. Extra modules can be
named in the environment variable ``GEAROPT_STUDY_MODULES`` (comma-separated module names); they
are imported the same way.
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:  # pragma: no cover
    from gearopt.io.scene import Scene

#: Study modules shipped with gearopt (imported lazily by :func:`_load_builtin`).
BUILTIN_MODULES = ("gearopt.studies.geometry", "gearopt.studies.planar_tca", "gearopt.studies.tca",
                   "gearopt.studies.crowning", "gearopt.studies.fea", "gearopt.studies.ltca",
                   "gearopt.studies.robust", "gearopt.studies.loaded_microgeometry",
                   "gearopt.studies.rating", "gearopt.studies.dynamics")
#: Environment variable naming extra study modules to import (comma-separated).
ENV_MODULES = "GEAROPT_STUDY_MODULES"


@dataclass(frozen=True)
class StudySpec:
    """Description of a study for the scene loader and the CLI.

    Parameters
    ----------
    name : str
        The value of ``[scene] study`` that selects it.
    sections : list[Section]
        Extra scene sections the study reads (besides the common ones).
    build : callable(Scene) -> study object
        Builds the study from a loaded scene; the object has ``run()``.
    doc : str
        One line for ``gearopt studies``.
    settings : tuple of Settings subclasses
        The option sets (:mod:`gearopt.settings`) whose options are keys of the sections: the
        sections are generated from them (:meth:`~gearopt.settings.Settings.section`), and the
        docs table of docs/scenes.md (:func:`markdown_tables`).
    """

    name: str
    sections: list = field(default_factory=list)
    build: Callable[["Scene"], Any] | None = None
    doc: str = ""
    settings: tuple = ()


#: Registered studies by name. Read it through :func:`studies` / :func:`get_study`, which import the
#: built-in study modules first.
STUDIES: dict[str, StudySpec] = {}

_loaded = False
_broken: dict[str, BaseException] = {}  # module name -> error raised while importing it


def register(spec: StudySpec) -> StudySpec:
    """Add (or replace) a study in :data:`STUDIES`; returns ``spec``."""
    if not isinstance(spec, StudySpec):
        raise TypeError(f"register() needs a StudySpec, got {type(spec).__name__}")
    if not spec.name or not isinstance(spec.name, str):
        raise ValueError(f"study name must be a non-empty string, got {spec.name!r}")
    if not callable(spec.build):
        raise TypeError(f"study {spec.name!r}: build must be callable(scene)")
    names = [s.name for s in spec.sections]
    if len(set(names)) != len(names):
        raise ValueError(f"study {spec.name!r}: duplicate section names {names}")
    STUDIES[spec.name] = spec
    return spec


def unregister(name: str) -> None:
    """Remove a study (tests use it to clean up dummy studies)."""
    STUDIES.pop(name, None)


def _load_builtin() -> None:
    """Import the built-in study modules (and those named in ``GEAROPT_STUDY_MODULES``) once.

    A module that does not exist is skipped (the other studies still work). A module that exists
    but fails to import is remembered; asking for a study of that name re-raises its error, since
    that is a bug, not a scene problem.
    """
    global _loaded
    if _loaded:
        return
    _loaded = True
    extra = [m.strip() for m in os.environ.get(ENV_MODULES, "").split(",") if m.strip()]
    for mod in (*BUILTIN_MODULES, *extra):
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as e:
            if e.name != mod:  # the module exists but one of its imports is missing
                _broken[mod] = e
        except Exception as e:  # noqa: BLE001 - kept and re-raised on use, see get_study
            _broken[mod] = e


def _load_own(name: str) -> bool:
    """Import only the built-in module named like the study ``name`` (``gearopt.studies.<name>``);
    True when that registered ``name``. Not when ``GEAROPT_STUDY_MODULES`` names modules (they may
    replace a built-in study: then every module is imported, in order, by :func:`_load_builtin`).
    A scene's run needs its own study only; the other modules cost a new process 20-30 ms CPU."""
    mod = f"gearopt.studies.{name}"
    if mod not in BUILTIN_MODULES or os.environ.get(ENV_MODULES, "").strip():
        return False
    try:
        importlib.import_module(mod)
    except Exception:  # noqa: BLE001 - _load_builtin imports it again, keeps the error and get_study re-raises it
        return False
    return name in STUDIES


def studies() -> dict[str, StudySpec]:
    """All registered studies (built-in ones imported first)."""
    _load_builtin()
    return STUDIES


def get_study(name: str) -> StudySpec | None:
    """The study ``name``, or ``None`` when no such study is registered.

    Re-raises the import error of a built-in study module whose last name component is ``name``.
    Imports that module alone when it registers ``name`` (:func:`_load_own`), else every study module.
    """
    if not _loaded and _load_own(name):
        return STUDIES[name]
    _load_builtin()
    if name in STUDIES:
        return STUDIES[name]
    for mod, err in _broken.items():
        if mod.rsplit(".", 1)[-1] == name:
            raise ImportError(f"study module {mod!r} failed to import: {err!r}") from err
    return None


def broken_modules() -> dict[str, BaseException]:
    """Study modules that exist but failed to import (module name -> exception)."""
    _load_builtin()
    return dict(_broken)


#: The markers around the generated tables in docs/scenes.md (``gearopt studies --markdown``).
MARKDOWN_BEGIN = "<!-- generated by `gearopt studies --markdown`: do not edit by hand -->"
MARKDOWN_END = "<!-- end of the generated tables -->"


def markdown_tables() -> str:
    """The tables of docs/scenes.md's "Study options": for every registered study (by name) the
    options of its option sets (:attr:`StudySpec.settings`), between :data:`MARKDOWN_BEGIN` and
    :data:`MARKDOWN_END`."""
    out = [MARKDOWN_BEGIN, ""]
    for name, spec in sorted(studies().items()):
        for cls in spec.settings:
            out += [f"### `{name}`", "", cls.markdown()]
    out.append(MARKDOWN_END)
    return "\n".join(out) + "\n"
