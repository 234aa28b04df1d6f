"""Robust-design studies (docs/scale.md): ``montecarlo`` (tolerances of an ISO 1328-1 class and
misalignments sampled) and ``sweep`` (a design of experiments over design variables), both by
unloaded TCA of one mesh cycle per sample.

Scene section ``[montecarlo]``:

``samples``     number of samples (required); ``seed`` (default 0); ``sampling`` "random" or "lhs".
``iso_grade``   ISO 1328-1:2013 flank tolerance class 1 ... 11 of both members (helix slope, profile
                slope and single pitch deviations sampled within the tolerances).
``spread``      "normal" (N(0, (T/3)^2) within +-T, default) or "uniform" (on +-T).
``f_a``         centre-distance tolerance +-f_a (dE sampled like a deviation).
``crossing``, ``intersecting``, ``dE``, ``axial``: a distribution of that misalignment, an inline
                table ``{kind = "normal", mean = "0 arcmin", sd = "1 arcmin"}`` (kinds: fixed
                value; uniform lo, hi; normal mean, sd; truncnormal mean, sd, lo, hi; triangular lo,
                mode, hi).
``torque``      a distribution of the pinion torque [N m] (``{kind = "uniform", lo = 50, hi = 150}``,
                or ``fixed`` value, ``truncnormal``, ``triangular``): every sample also runs the loaded
                TCA (analytical compliance, ``n_slices`` slices): loaded TE, peak pressure, tip-edge
                load share, mesh stiffness.
``positions``, ``side``, ``chunk`` (samples per task), ``executor`` ("serial", "processes",
                "dask"), ``workers``.

Scene section ``[sweep]``: ``design`` ("lhs", "full_factorial", "random"), ``samples`` (lhs,
random), ``levels`` (full factorial), ``seed``, and ``[sweep.vary]`` with a ``{lo, hi}`` table per
variable: ``a_c``, ``a_pl`` (the pinion's crowning settings), ``crossing``, ``intersecting``,
``dE``, ``axial``; plus ``positions``, ``side``, ``chunk``, ``executor``, ``workers``.

Results: ``results.json`` (statistics, ranked sensitivities, the pattern probability map),
``samples.csv`` (one row per sample) and the plots; docs/results.md.
"""

from __future__ import annotations

from typing import ClassVar, TYPE_CHECKING

from ..robust.study import UNITS, DesignSweep, MonteCarlo, RobustResult  # noqa: F401 (UNITS: results.json's units)
from ..summary import KeyNumber, robust_summary

if TYPE_CHECKING:  # pragma: no cover
    from pathlib import Path

    from ..schema import Section

SCHEDULER_NOTE = "run it with `gearopt run SCENE --scheduler tcp://HOST:PORT` for a Dask cluster"


def _dist_section(name: str, kind: str):
    """A ``{kind = ..., ...}`` distribution table of a misalignment in its unit."""
    from ..io.schema import Field, ToolSection
    from ..meshing.misalignment import Misalignment

    meta = Misalignment.meta(name)
    fk = "angle" if meta["unit"] == "angle" else "length"
    extra = {"typical": "arcmin"} if fk == "angle" else {}
    F = lambda n, doc, **kw: Field(n, fk, doc=doc, **extra, **kw)  # noqa: E731
    variants = {
        "fixed": [F("value", "the value", required=True)],
        "uniform": [F("lo", "lower bound", required=True), F("hi", "upper bound", required=True)],
        "normal": [F("mean", "mean", default=0.0), F("sd", "standard deviation", required=True)],
        "truncnormal": [F("mean", "mean", default=0.0), F("sd", "standard deviation (before truncation)", required=True),
                        F("lo", "lower bound", required=True), F("hi", "upper bound", required=True)],
        "triangular": [F("lo", "lower bound", required=True), F("mode", "mode", required=True),
                       F("hi", "upper bound", required=True)],
    }
    ex = '{kind = "normal", sd = "1 arcmin"}' if fk == "angle" else '{kind = "uniform", lo = "-0.02 mm", hi = "0.02 mm"}'
    return ToolSection(name, variants=variants, noun="distribution", example=ex,
                       doc=f"distribution of the {meta['doc']}")


def _torque_section():
    """``torque = {kind = ..., ...}``: the pinion torque of the loaded TCA per sample [N m]."""
    from ..io.schema import Field, ToolSection
    F = lambda n, doc, **kw: Field(n, "float", doc=doc + " [N*m]", **kw)  # noqa: E731
    variants = {
        "fixed": [F("value", "the torque", required=True)],
        "uniform": [F("lo", "lower bound", required=True), F("hi", "upper bound", required=True)],
        "truncnormal": [F("mean", "mean", required=True), F("sd", "standard deviation (before truncation)", required=True),
                        F("lo", "lower bound", required=True), F("hi", "upper bound", required=True)],
        "triangular": [F("lo", "lower bound", required=True), F("mode", "mode", required=True),
                       F("hi", "upper bound", required=True)],
    }
    return ToolSection("torque", variants=variants, noun="distribution", example='{kind = "uniform", lo = 50, hi = 150}',
                       doc="pinion torque per sample [N*m]: runs the loaded TCA of every sample (analytical compliance)")


def range_section(name: str, kind: str, doc: str) -> Section:
    """A ``name = {lo = ..., hi = ...}`` table of a range of a quantity of ``kind``."""
    from ..io.schema import Field, Section
    extra = {"typical": "arcmin"} if kind == "angle" else {}
    return Section(name, [Field("lo", kind, required=True, doc="lower end", **extra),
                          Field("hi", kind, required=True, doc="upper end", **extra)], doc=doc)


def _common_fields() -> list:
    """The keys of where the samples run (``executor``, ``workers``): keywords of the API classes, not
    options (the figures do not depend on them)."""
    from ..schema import Bounds, Field
    return [
        Field("executor", "str", default="serial", choices=("serial", "processes", "dask"),
              doc=f"where the chunks run: this process, local processes, or Dask ({SCHEDULER_NOTE})"),
        Field("workers", "int", check=Bounds(lo=1, hi=1024), doc="worker processes (default: the CPU count for processes, 2 for a local Dask cluster)"),
    ]


def _distribution(name: str, d: dict):
    from ..robust.sampling import Distribution
    kw = {k: v for k, v in d.items() if k != "kind" and v is not None}
    return Distribution(d["kind"], name=name, **kw)


class RobustReport(RobustResult):
    """The result of a ``montecarlo`` or ``sweep`` scene: :class:`~gearopt.robust.study.RobustResult`
    with its figures (:func:`gearopt.plot.robust.save_plots`)."""

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "distribution.png": "Histograms (left) and cumulative distributions (right) of the TE peak-to-peak and first "
                            "mesh harmonic (with a torque also the loaded TE and peak pressure), nominal drive and "
                            "50 %/95 % marked: read the spread the tolerances give and how far the 95 % value lies "
                            "from the nominal.",
        "scatter.png": "TE peak-to-peak against the most influential inputs, one dot per sample, edge contact marked: "
                       "read the trend each input drives.",
        "sensitivity.png": "Inputs ranked by their Spearman rank correlation with the TE peak-to-peak, the grey band "
                           "not significant at 5 %: read which tolerance or misalignment to tighten first.",
        "pattern.png": "Probability of each point of the pinion flank being in the contact pattern, over the samples, "
                       "nominal extent dashed: read how often the pattern reaches a face end or the tip.",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.robust_summary`), read from :meth:`to_dict`."""
        return robust_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``distribution.png``, ``scatter.png``, ``sensitivity.png``, ``pattern.png``
        (:func:`gearopt.plot.robust.save_plots`)."""
        from ..plot.robust import save_plots
        return save_plots(self, out_dir, dpi)


class MonteCarloStudy(MonteCarlo):
    """The ``montecarlo`` study: :class:`~gearopt.robust.study.MonteCarlo` returning a :class:`RobustReport`."""

    result_class = RobustReport


class DesignSweepStudy(DesignSweep):
    """The ``sweep`` study: :class:`~gearopt.robust.study.DesignSweep` returning a :class:`RobustReport`."""

    result_class = RobustReport


def _montecarlo(scene):
    from ..errors import GeometryError, OptionError
    from ..meshing.misalignment import Misalignment
    from ..settings import MonteCarloSettings

    o = scene.options.get("montecarlo", {}) or {}
    mis = {}
    try:
        for kind in Misalignment.names():
            if o.get(kind):
                mis[kind] = _distribution(kind, o[kind])
        torque = _distribution("torque", o["torque"]) if o.get("torque") else None
        return MonteCarloStudy(scene.pair, settings=MonteCarloSettings.from_scene(o), misalignment=mis,
                          executor=o["executor"], workers=o.get("workers"), name=scene.name, torque=torque)
    except (GeometryError, OptionError) as e:
        # misalignment.<kind>.<parameter> -> [montecarlo] <kind>.<parameter>, as written
        # torque.<parameter> -> [montecarlo] torque.<parameter>
        parts = (e.param or "").split(".")
        key = ".".join(parts[1:]) if len(parts) == 3 and parts[0] == "misalignment" and parts[1] in mis else \
            e.param if len(parts) == 2 and parts[0] == "torque" else None
        if key is not None and e.detail is not None and scene.written("montecarlo", key) is not None:
            raise scene.key_error("montecarlo", key, e) from e
        raise scene.study_error("montecarlo", e) from e


def _sweep(scene):
    from ..errors import GeometryError, OptionError
    from ..settings import SweepSettings

    o = scene.options.get("sweep", {}) or {}
    vary = o.get("vary") or {}
    variables = {}
    for key, v in vary.items():
        if v:
            name = f"pinion.{key}" if key in ("a_c", "a_pl") else f"mis.{key}"
            variables[name] = (v["lo"], v["hi"])
    if not variables:
        raise scene.key_error("sweep", "vary", "is missing: give at least one variable, e.g. [sweep.vary] "
                              "a_pl = {lo = \"0.0002 1/mm\", hi = \"0.001 1/mm\"}.", valid="at least one variable")
    try:
        return DesignSweepStudy(scene.pair, variables, settings=SweepSettings.from_scene(o), executor=o["executor"],
                                workers=o.get("workers"), name=scene.name)
    except (GeometryError, OptionError) as e:
        # variables.<name> (an end of a range) -> [sweep.vary] <key>, as written
        key = next((k for k, v in vary.items() if v and e.param in (f"variables.pinion.{k}", f"variables.mis.{k}")),
                   None)
        if key is not None and e.detail is not None:
            raise scene.key_error("sweep.vary", key, e) from e
        raise scene.study_error("sweep", e) from e


def _register():
    from ..meshing.misalignment import Misalignment
    from ..schema import Section
    from ..settings import MonteCarloSettings, SweepSettings
    from . import StudySpec, register

    register(StudySpec(
        name="montecarlo",
        doc="Tolerance (ISO 1328-1 class) and misalignment Monte Carlo of the unloaded TCA: TE spread, "
            "probability of edge contact, contact-pattern envelope, ranked sensitivities",
        sections=[MonteCarloSettings.section("montecarlo", [
            "samples", "sampling", "iso_grade", "spread", "f_a", "n_slices", "positions", "side", "chunk",
            *_common_fields(), "seed",
        ], subsections=[*[_dist_section(k, None) for k in Misalignment.names()], _torque_section()], required=True)],
        settings=(MonteCarloSettings,),
        build=_montecarlo,
    ))
    register(StudySpec(
        name="sweep",
        doc="Design sweep / DOE (Latin hypercube, full factorial) of the unloaded TCA over the pinion's crowning "
            "settings and misalignments: TE, edge contact, pattern, sensitivities",
        sections=[SweepSettings.section("sweep", [
            "design", "samples", "levels", "positions", "side", "chunk", *_common_fields(), "seed",
        ], subsections=[Section("vary", [], subsections=[
            range_section("a_c", "inverse_length", "pinion profile crowning a_c range"),
            range_section("a_pl", "inverse_length", "pinion plunging (longitudinal crowning) a_pl range"),
            *[range_section(k, "angle" if Misalignment.meta(k)["unit"] == "angle" else "length",
                             f"{Misalignment.meta(k)['doc']} range") for k in Misalignment.names()],
        ], doc="the variables and their ranges", required=True)], required=True)],
        settings=(SweepSettings,),
        build=_sweep,
    ))


_register()
