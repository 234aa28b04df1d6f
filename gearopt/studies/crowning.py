"""Crowning optimization study: optimize the pinion crowning for a predesigned parabolic TE over a
set of misalignments, then compare the drive before and after (TE and bearing contact, every case).

Scene section ``[crowning]``:

(The keys of :class:`gearopt.settings.CrowningTarget` and :class:`~gearopt.settings.CrowningStudySettings`
are declared there, with their defaults and ranges: ``te_level``, ``ellipse_share``, ``edge_margin``,
``tip_margin``, ``objective``, ``positions``, ``quiet``.)

``te_level``       predesigned TE level (angle; e.g. "8 arcsec").
``crossing``, ``intersecting`` (angles), ``dE``, ``axial`` (lengths): each non-zero value adds the
                   cases +value and -value to the aligned drive.
``combined``       also the case with all given misalignments at their + values (default false).
``ellipse_share``  minimum contact-ellipse major axis at the mean point / face width (default 0).
``edge_margin``    distance the transfer contact points keep from the face ends [mm] (0).
``tip_margin``     radial distance they keep from the tip and form circles [mm] (0).
``positions``      TCA positions per case in the NLP (default 41).
``objective``      "sum" (default) or "worst".
``quiet``          no IPOPT iteration output (default true).

The TCA of the drive before optimisation does not depend on the optimisation: on Linux with two or
more cores it runs in a forked process while the NLP is built and solved (:class:`ForkedCall`; the
same numbers as computed in place).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar

import numpy as np

from ..contact.edge import EdgeContact
from ..forking import ForkedCall, split_forked
from ..gears import GearPair
from ..meshing.misalignment import misalignment_cases  # noqa: F401 - re-exported (the crowning study's cases)
from ..meshing.tca import TCA, Misalignment
from ..progress import heartbeat
from ..settings import CrowningStudySettings
from ..synthesis.crowning import SENSITIVITY_UNITS, CrowningOptimizer, CrowningTarget  # noqa: F401 - re-exported
from ..summary import KeyNumber, crowning_summary

UNITS = {"length": "mm", "angle": "rad", "te": "arcsec (suffix _arcsec)", "settings": "1/mm",
         "sensitivities": "d(TE level)/d(variable), in the unit given per variable in design.sensitivity_units "
                          "(arcsec per arcmin for the misalignment angles, as the scene gives them)",
         "time": "s", "see": "docs/results.md"}

@dataclass(frozen=True)
class CrowningReport:
    scene: str
    design: dict
    before: list
    after: list
    timing: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"study": "crowning", "scene": self.scene, "units": UNITS, "design": self.design,
                "before": self.before, "after": self.after, "timing": self.timing}

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "before_after_te.png": "Actual TE of every misalignment case before (left) and after (right) the crowning "
                               "optimisation, each row on common axes: read that after it every case shows the "
                               "predesigned parabolic TE of the target level, with no edge contact.",
        "before_after_contact_gear.png": "Paths of contact on the gear flank before (left) and after (right), one row "
                                         "per case: read that the optimised path stays on the flank surface, clear of "
                                         "the face ends, in every case.",
        "before_after_contact_pinion.png": "Paths of contact on the pinion flank before (left) and after (right), one "
                                           "row per case: read the same on the pinion.",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.crowning_summary`), read from :meth:`to_dict`."""
        return crowning_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        import matplotlib.pyplot as plt
        from pathlib import Path

        from ..plot.saving import drawn_here
        from ..plot.tca import plot_crowning_comparison

        out = Path(out_dir)
        files = []
        for name, member in (("before_after_te.png", None), ("before_after_contact_gear.png", "gear"),
                             ("before_after_contact_pinion.png", "pinion")):
            files.append(name)
            if not drawn_here(out / name):  # another process draws it (gearopt run, gearopt.plot.saving)
                continue
            n = len(self.after)
            fig, axes = plt.subplots(n, 2, figsize=(13, 3.6 * n + (0.6 * n if member else 0)), squeeze=False,
                                     layout="constrained")
            plot_crowning_comparison(self.before, self.after, axes=axes, member=member)
            what = "actual TE" if member is None else f"paths of contact on the {member} flank"
            fig.suptitle(f"{self.scene}: {what}, before (left) and after (right) crowning optimization\n"
                         "(each row on common axes)")
            fig.savefig(out / name, dpi=dpi, bbox_inches="tight")
            plt.close(fig)
        return files


class CrowningStudy:
    def __init__(self, pair: GearPair, target: CrowningTarget, cases: dict,
                 settings: CrowningStudySettings | None = None, *, name: str = "crowning", **options: Any) -> None:
        """``settings``: ``positions`` (per case in the NLP) and ``quiet`` (no IPOPT output), or those
        as keywords (:class:`gearopt.settings.CrowningStudySettings`)."""
        s = CrowningStudySettings.of(settings, **options)
        self.settings = s
        self.pair, self.target, self.cases, self.quiet, self.name = pair, target, cases, s.quiet, name
        self.optimizer = CrowningOptimizer(pair, target, cases=cases, positions=s.positions)

    def _optimise(self, phi: np.ndarray, progress: Callable[[str], None] | None, alongside: bool = False) -> tuple:
        """Build and solve the NLP, then the TCA of the optimised drive at ``phi`` [rad]: (design,
        the cases' dicts)."""
        if progress:
            progress("crowning: building the NLP" + (f" (the TCA of the drive before optimization, {len(self.cases)} "
                                                     "cases, alongside)" if alongside else ""))
        with heartbeat(progress, "crowning: building the NLP", every=15.0):
            self.optimizer.build(verbose=not self.quiet)
        if progress:
            progress(f"crowning: NLP built in {self.optimizer.build_time:.1f} s; solving (IPOPT, "
                     f"{self.optimizer._x0.size} variables)")
        with heartbeat(progress, "crowning: solving (IPOPT), then verifying the design by TCA", every=15.0):
            d = self.optimizer.solve(verbose=not self.quiet)
        if progress:
            progress(f"crowning: IPOPT {d.status} in {d.iterations} iterations, {d.solve_time:.3f} s; design verified; "
                     f"TCA of the optimised drive ({len(self.cases)} cases)")
        ec1 = d.edge if d.edge is not None else EdgeContact(TCA(d.pair))  # compiled once, in solve()
        lim1 = {"pinion": {"b": d.pair.pinion.b, "r_a": d.pair.pinion.r_a, "r_form": ec1.r_form[1]},
                "gear": {"b": d.pair.gear.b, "r_a": d.pair.gear.r_a, "r_form": ec1.r_form[2]}}
        def swept(cases: list) -> list:
            return [ec1.sweep(phi, mis=m, pairs=(-2, -1, 0, 1, 2)).to_dict(c, d.pair.pinion.z, lim1) for c, m in cases]

        # The first case here (it solves the first guesses, which the other cases share), then the
        # last ones in a forked process (split_forked, ForkedCall: the same numbers) beside the others here.
        after = split_forked(swept, self.cases.items(),
                             around=lambda: heartbeat(progress, "crowning: TCA of the optimised drive", every=15.0))
        return d, after

    def run(self, progress: Callable[[str], None] | None = None) -> CrowningReport:
        t0 = time.perf_counter()
        z1 = self.pair.pinion.z
        pitch = 2 * math.pi / z1
        phi = np.linspace(-pitch, pitch, 162, endpoint=False)

        def before_tca() -> list:
            ec0 = EdgeContact(TCA(self.pair))
            lim0 = {"pinion": {"b": self.pair.pinion.b, "r_a": self.pair.pinion.r_a, "r_form": ec0.r_form[1]},
                    "gear": {"b": self.pair.gear.b, "r_a": self.pair.gear.r_a, "r_form": ec0.r_form[2]}}
            return [ec0.sweep(phi, mis=m, pairs=(-2, -1, 0, 1, 2)).to_dict(c, z1, lim0)
                    for c, m in self.cases.items()]

        # The drive before optimisation does not depend on the optimisation: its TCA runs in a forked
        # process where that applies (ForkedCall) while this one builds and solves the NLP and sweeps
        # the optimised drive; otherwise here, first, as the results are the same either way.
        side = ForkedCall(before_tca)
        try:
            if not side.forked:
                if progress:
                    progress(f"crowning: TCA of the drive before optimization ({len(self.cases)} cases)")
                with heartbeat(progress, "crowning: TCA of the drive before optimization", every=15.0):
                    side.result()
            try:
                d, after = self._optimise(phi, progress, alongside=side.forked)
            except Exception:
                side.result()  # an error of the drive before optimisation first, as without the fork
                raise
            if progress and side.forked:
                progress("crowning: waiting for the TCA of the drive before optimization")
            before = side.result()
        finally:
            side.close()
        design = d.to_dict()
        self.design = d
        return CrowningReport(scene=self.name, design=design, before=before, after=after,
                              timing={"run_s": time.perf_counter() - t0})


def _from_scene(scene) -> CrowningStudy:
    from ..errors import GeometryError, OptionError

    from .tca import check_misalignment_keys

    o = scene.options.get("crowning", {}) or {}
    check_misalignment_keys(scene, "crowning", o, signs=(1, -1))
    try:
        cases = misalignment_cases(combined=bool(o.get("combined")),
                                   **{k: o.get(k) or 0.0 for k in Misalignment.names()})
        return CrowningStudy(scene.pair, CrowningTarget.from_scene(o), cases, CrowningStudySettings.from_scene(o),
                             name=scene.name)
    except (GeometryError, OptionError) as e:
        raise scene.study_error("crowning", e) from e


def _register():
    from ..schema import Field, Section
    from . import StudySpec, register
    from .tca import misalignment_fields

    register(StudySpec(
        name="crowning",
        doc="Optimize pinion crowning (a_c, a_pl) for a parabolic TE over a misalignment set; before/after plots",
        sections=[Section("crowning", [
            CrowningTarget.scene_field("te_level"),
            *misalignment_fields(signed=False, prefix="+- ", suffix=" cases"),
            Field("combined", "bool", default=False, doc="also all misalignments together"),
            *[CrowningTarget.scene_field(n) for n in ("ellipse_share", "edge_margin", "tip_margin")],
            CrowningStudySettings.scene_field("positions"),
            CrowningTarget.scene_field("objective"),
            CrowningStudySettings.scene_field("quiet"),
        ], required=True)],
        settings=(CrowningTarget, CrowningStudySettings),
        build=_from_scene,
    ))


_register()
