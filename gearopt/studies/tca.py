"""Tooth contact analysis study: transmission errors, paths of contact and bearing contact of a
drive, aligned and under a misalignment (Litvin section 9.4).

Scene section ``[tca]``:

``side``          driving flank of the pinion, "right" (default) or "left".
``contact``       "point" (crowned pinion, default) or "line" (conjugate / profile-crowned spur:
                  contact sought in the pinion section ``z_section``).
``z_section``     pinion section for line contact [mm] (default 0).
``positions``     positions per mesh cycle (default 81, 9..5000); two cycles are analysed.
``delta``         elastic approach for the contact ellipse [mm] (default ``ContactSettings.delta``, 0.00632).
``dE``, ``crossing``, ``intersecting``, ``axial``: the misalignment case analysed beside the
                  aligned drive [mm, angle, angle, mm] (all 0 by default: aligned only).
``[[tca.cases]]`` a list of misalignment cases instead (array of tables, each with ``label`` and
                  any of ``dE``, ``crossing``, ``intersecting``, ``axial``); the aligned drive is
                  analysed first unless a case is aligned itself. Not together with the single keys.

results.json keys are described in docs/results.md; beside it, ``te_path_<case>.csv`` holds each
case's TE and path table. TE sign: positive when the gear is ahead of its conjugate position.
``edge_contact``  also solve edge contact and combine it with surface contact (default false;
                  needed for unmodified gears under misalignment).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, TYPE_CHECKING
from pathlib import Path

import numpy as np

from ..gears import GearPair
from ..contact.edge import EdgeContact, EdgeTCAResult
from ..meshing.tca import TCA, Misalignment, TCAResult
from ..report import CONJUGATE_ARCSEC, csv_cell, te_harmonics  # noqa: F401 - re-exported (their home: gearopt.report)
from ..geometry.microgeometry import GLOBAL_AMOUNTS
from ..settings import TCAStudySettings
from ..summary import KeyNumber, tca_summary
from ..units import DEG

if TYPE_CHECKING:  # pragma: no cover
    from ..io.scene import Scene

UNITS = {"length": "mm (suffix _mm where a key could be read otherwise)", "angle": "rad", "phi1": "rad",
         "te": "arcsec (suffix _arcsec); positive: the gear is ahead of its conjugate position",
         "curvature": "1/mm (kappa: principal curvatures)",
         "misalignment": "dE_mm, axial_mm in mm; crossing, intersecting in arcmin (suffix _arcmin)",
         "time": "s", "flank_map": "pinion/gear axial = axial position z [mm], radius = transverse radius [mm], "
                                   "member's own frame", "see": "docs/results.md"}

def case_dict(res: TCAResult, pair: GearPair, label: str, limits: dict) -> dict:
    """JSON-able summary of one TCA case (what results.json holds and the plots read): the
    result's own :meth:`TCAResult.to_dict`."""
    return res.to_dict(label, pair.pinion.z, limits)


def edge_case_dict(res: EdgeTCAResult, pair: GearPair, label: str, limits: dict) -> dict:
    """JSON-able summary of a TCA case with edge contact: the result's own
    :meth:`EdgeTCAResult.to_dict`."""
    return res.to_dict(label, pair.pinion.z, limits)


@dataclass(frozen=True)
class TCAReport:
    """Result of the TCA study: one entry per case (aligned, misaligned)."""

    scene: str
    pair: dict
    cases: list
    timing: dict = field(default_factory=dict)
    inspection: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        out = {"study": "tca", "scene": self.scene, "units": UNITS, "pair": self.pair, "cases": self.cases,
               "timing": self.timing}
        if self.inspection:
            out["inspection"] = self.inspection
        return out

    #: One line per figure for report.html: what to read from it (the edge-contact variants in
    #: :attr:`EDGE_CAPTIONS`).
    CAPTIONS: ClassVar[dict[str, str]] = {
        "te.png": "Transmission error of each tooth pair (dashed) and the actual TE (their envelope, black) over two "
                  "mesh cycles, one row per case: read the peak-to-peak and the parabolic shape between the transfers "
                  "(grey lines), where the driving pair changes.",
        "bearing_contact.png": "Path of contact (red) and contact ellipses (blue) on the pinion (left) and gear (right) "
                               "flanks, one row per case; the grey box is the active flank: read whether the bearing "
                               "pattern stays inside it, clear of the face ends and the tip.",
        "compare.png": "The cases overlaid: actual TE (left) and path of contact on the gear flank (right): read how far "
                       "the misalignment shifts the TE and moves the contact across the face.",
        "topography.png": "Flank topography, ISO transverse deviation from the involute over the active flank: read "
                          "the crowning and reliefs the flank carries (design or measurement).",
        "k_charts.png": "Profile (left) and lead (right) charts evaluated from the flanks, with the ISO 1328-1 tolerances "
                        "where a measured flank is judged: read the deviations F, f_f, f_H against the class.",
    }
    #: The captions of the figures with edge contact analysed (``[tca] edge_contact = true``).
    EDGE_CAPTIONS: ClassVar[dict[str, str]] = {
        **CAPTIONS,
        "te.png": "Transmission error with edge contact (Litvin 9.6), one row per case: surface and edge branches of "
                  "the central pair and the actual TE; read whether an edge (tip or face end) carries the load and "
                  "the TE level it gives.",
        "bearing_contact.png": "Paths of contact of the central pair split into their surface and edge parts, on the "
                               "pinion (left) and gear (right) flanks, one row per case: read where an edge of the "
                               "flank touches (face end, tip) instead of the surface.",
    }

    @property
    def captions(self) -> dict[str, str]:
        """Figure file name -> one-line caption for report.html."""
        edge = bool(self.cases and self.cases[0].get("edge_analysis"))
        return dict(self.EDGE_CAPTIONS if edge else self.CAPTIONS)

    @property
    def plot_costs(self) -> dict[str, float]:
        """The figures :meth:`save_plots` draws, in its order, each with its relative drawing time
        (``gearopt run`` shares them out between its drawing processes,
        :func:`gearopt.cli_plots.processes_for`): bearing_contact.png, two panels per case with
        their ellipses and legends, about twice te.png or compare.png (0.52 against 0.27 and 0.24 s
        CPU for the demo's two cases)."""
        n = len(self.cases)
        edge = bool(self.cases and self.cases[0].get("edge_analysis"))
        costs = {"te.png": 1.0, "bearing_contact.png": 2.0}
        if n > 1 and not edge:
            costs["compare.png"] = 1.0
        if self.inspection:
            costs["topography.png"] = 1.0
            costs["k_charts.png"] = 1.0
        return costs

    def summary(self) -> list[KeyNumber]:
        """Key numbers (:func:`gearopt.summary.tca_summary`): geometry, and per case the TE
        peak-to-peak and harmonics, read from :meth:`to_dict`."""
        return tca_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``te.png`` (TE per pair and envelope, every case), ``bearing_contact.png`` (paths of
        contact with contact ellipses on both flanks, every case) and, with several cases,
        ``compare.png`` (their actual TE and gear-flank paths overlaid)."""
        import matplotlib.pyplot as plt
        from pathlib import Path

        from ..plot.saving import drawn_here
        from ..plot.tca import plot_bearing_contact, plot_compare, plot_te
        from ..plot.ticks import plain_ticks

        out = Path(out_dir)
        n = len(self.cases)
        edge = bool(self.cases and self.cases[0].get("edge_analysis"))
        if edge:
            from ..plot.tca import plot_edge_paths as plot_paths, plot_edge_te as plot_te_case
            te_title = "transmission errors with edge contact (Litvin 9.6)"
            path_title = "paths of contact, surface and edge parts (central tooth pair)"
        else:
            plot_paths, plot_te_case = plot_bearing_contact, plot_te
            te_title = "transmission errors"
            path_title = "bearing contact (paths of contact and contact ellipses)"

        def save(name, fig, title):
            plain_ticks(*fig.axes)  # every tick label the value itself (no "+3e1" offset), whoever drew it
            fig.suptitle(f"{self.scene}: {title}")
            fig.savefig(out / name, dpi=dpi, bbox_inches="tight")
            plt.close(fig)
            return name

        # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
        files = ["te.png"]
        if drawn_here(out / "te.png"):
            fig, axes = plt.subplots(n, 1, figsize=(9, 3.7 * n), squeeze=False, layout="constrained")
            for ax, case in zip(axes[:, 0], self.cases):
                plot_te_case(case, ax=ax)
            save("te.png", fig, te_title)
        files.append("bearing_contact.png")
        if drawn_here(out / "bearing_contact.png"):
            fig, axes = plt.subplots(n, 2, figsize=(12, 4.4 * n), squeeze=False, layout="constrained")
            for row, case in zip(axes, self.cases):
                plot_paths(case, "pinion", ax=row[0])
                plot_paths(case, "gear", ax=row[1])
            save("bearing_contact.png", fig, path_title)
        if n > 1 and not edge:
            files.append("compare.png")
            if drawn_here(out / "compare.png"):
                fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
                plot_compare({c["label"]: c for c in self.cases}, axes=axes)
                save("compare.png", fig, "cases compared (actual TE, path of contact on the gear flank)")
        if self.inspection:
            from ..plot.topography import plot_lead_chart, plot_profile_chart, plot_topography

            flanks = [(m, sd, d) for m, sides in self.inspection.items() for sd, d in sides.items()]
            rows = len(flanks)
            fig, axes = plt.subplots((rows + 1) // 2, 2, figsize=(12, 4.2 * ((rows + 1) // 2)), squeeze=False,
                                     layout="constrained")
            for ax, (m, sd, d) in zip(axes.ravel(), flanks):
                plot_topography(d["grid"], ax=ax)
            for ax in axes.ravel()[rows:]:
                ax.set_visible(False)
            files.append(save("topography.png", fig, "flank topography (ISO transverse deviation from the involute)"))
            fig, axes = plt.subplots(rows, 2, figsize=(12, 3.4 * rows), squeeze=False, layout="constrained")
            for row, (m, sd, d) in zip(axes, flanks):
                plot_profile_chart(d["grid"], d["charts_um"], ax=row[0], tolerances=d.get("tolerances_um"))
                plot_lead_chart(d["grid"], d["charts_um"], ax=row[1], tolerances=d.get("tolerances_um"))
            files.append(save("k_charts.png", fig, "profile and lead charts (ISO 1328-1, evaluated from the flanks)"))
        return files

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """One CSV per case, ``te_path_<case>.csv``: per pinion angle the actual TE, the driving pair,
        every pair's TE and the central pair's path of contact (see docs/results.md)."""
        from pathlib import Path

        files, used = [], set()
        for i, case in enumerate(self.cases):
            name = f"te_path_{_slug(case['label'])}.csv"
            if name in used:
                name = f"te_path_{i}_{_slug(case['label'])}.csv"
            used.add(name)
            cols = case_table(case)
            rows = zip(*cols.values())
            text = ",".join(cols) + "\n" + "".join(",".join(csv_cell(v) for v in row) + "\n" for row in rows)
            (Path(out_dir) / name).write_text(text, encoding="utf-8")
            files.append(name)
        if self.inspection:
            from ..geometry.inspection import FlankGrid, write_grid_csv

            for m, sides in self.inspection.items():
                for sd, d in sides.items():
                    g = d["grid"]
                    grid = FlankGrid(side=sd, profile=g["profile"], s=tuple(g["s_mm"]), z=tuple(g["z_mm"]),
                                     deviation=tuple(tuple(v / 1000 for v in row) for row in g["deviation_um"]),
                                     member=m)
                    write_grid_csv(grid, Path(out_dir) / d["csv"])
                    files.append(d["csv"])
        return files


def _slug(label: str) -> str:
    import re
    return re.sub(r"[^A-Za-z0-9+-]+", "_", str(label)).strip("_") or "case"


def case_table(case: dict) -> dict:
    """Columns of a case's CSV table (name -> list, one entry per pinion angle): ``phi1_deg``,
    ``te_envelope_arcsec``, ``driving_pair``, ``te_pair_<k>_arcsec`` for every pair and the central
    pair's path: ``<member>_axial_mm``, ``<member>_radius_mm`` (surface contact), the contact
    ellipse semi-axes, or, with edge contact, ``active_feature`` and per feature
    ``<feature>_<member>_axial_mm`` / ``_radius_mm``. Empty cells: no value."""
    cols = {"phi1_deg": [None if v is None else math.degrees(v) for v in case["phi1"]],
            "te_envelope_arcsec": case["te_envelope_arcsec"], "driving_pair": case["driving_pair"]}
    for k, te in zip(case["pairs"], case["te_arcsec"]):
        cols[f"te_pair_{k:+d}_arcsec"] = te
    if case.get("edge_analysis"):
        cols["active_feature"] = case["active_branch"]
        for name, path in case["paths_central_pair"].items():
            for member in ("pinion", "gear"):
                cols[f"{name}_{member}_axial_mm"] = path[member]["axial"]
                cols[f"{name}_{member}_radius_mm"] = path[member]["radius"]
    else:
        for member in ("pinion", "gear"):
            cols[f"{member}_axial_mm"] = case[member]["axial"]
            cols[f"{member}_radius_mm"] = case[member]["radius"]
        cols["on_active_flank"] = case["on_surface"]
        cols["ellipse_semi_major_mm"] = case["ellipse_semi_major_mm"]
        cols["ellipse_semi_minor_mm"] = case["ellipse_semi_minor_mm"]
    return cols


class TCAStudy:
    """Compiled TCA of a pair; ``run()`` sweeps one mesh cycle for each case."""

    def __init__(self, pair: GearPair, settings: TCAStudySettings | None = None, *,
                 misalignment: Misalignment | None = None, name: str = "tca", cases: Any = None,
                 **options: Any) -> None:
        """``settings``: the options (``side``, ``contact``, ``z_section``, ``positions``, ``delta``,
        ``edge_contact``, ``inspection``, ``iso_grade``; defaults and ranges declared by
        :class:`gearopt.settings.TCAStudySettings`), or those as keywords. ``misalignment``: one case
        beside the aligned drive; or ``cases``: a list of ``(label, Misalignment)`` (or a dict label
        -> Misalignment) analysed in order, with the aligned drive first unless one of them is
        aligned. ``iso_grade``: ISO 1328-1:2013 flank tolerance class 1 ... 11; the profile and lead
        charts of measured flanks are judged against its tolerances (a design modification is not a
        deviation: those charts are not judged)."""
        from ..errors import ArgumentError, OptionError, option_error

        s = TCAStudySettings.of(settings, **options)
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {type(pair).__name__}: expected a gearopt.gears.GearPair (pinion, gear).",
                                param="pair", value=pair, valid="a gearopt.gears.GearPair")
        self.settings = s
        positions, delta, z_section, side, contact = s.positions, s.delta, s.z_section, s.side, s.contact
        edge_contact, inspection = s.edge_contact, s.inspection
        if not delta <= 0.1 * pair.pinion.m_n:
            raise option_error("delta", delta, f"0 < delta <= 0.1 m_n = {0.1 * pair.pinion.m_n:.4g} mm (elastic "
                               "approach for the contact ellipse, microns)")
        if abs(z_section) > pair.pinion.b / 2:
            raise option_error("z_section", z_section, f"|z_section| <= b1 / 2 = {pair.pinion.b / 2:.6g} mm (a "
                               "section of the pinion face)")
        if misalignment is not None and not isinstance(misalignment, Misalignment):
            raise ArgumentError(f"misalignment = {type(misalignment).__name__}: expected a Misalignment"
                                + (" (use Misalignment(**d), angles in rad)." if isinstance(misalignment, dict)
                                   else "."),
                                param="misalignment", value=misalignment, valid="a Misalignment")
        self.iso_grade = s.iso_grade
        self.pair, self.name = pair, name
        self.positions, self.delta, self.z_section = positions, delta, z_section
        self.cases = [("aligned", Misalignment())]
        if cases is not None:
            if misalignment is not None and np.any(misalignment.vector() != 0):
                raise OptionError("TCAStudy: give misalignment or cases, not both.", param="cases")
            items = list(cases.items()) if isinstance(cases, dict) else [tuple(c) for c in cases]
            for item in items:
                if len(item) != 2 or not isinstance(item[1], Misalignment):
                    raise OptionError(f"TCAStudy: cases = {item!r}: each case must be (label, Misalignment).",
                                      param="cases", value=item, valid="(label, Misalignment)")
            if any(np.all(m.vector() == 0) for _, m in items):
                self.cases = []
            self.cases += [(str(lab), m) for lab, m in items]
            labels = [lab for lab, _ in self.cases]
            if len(set(labels)) != len(labels):
                raise OptionError(f"TCAStudy: case labels {labels} must be distinct (the aligned drive is "
                                  "'aligned').", param="cases", value=labels, valid="distinct labels")
        elif misalignment is not None and np.any(misalignment.vector() != 0):
            self.cases.append(("misaligned", misalignment))
        for lab, m in self.cases:  # the rules of TCA.sweep, before anything runs
            m.check(pair, "misalignment" if lab == "misaligned" and cases is None else f"cases[{lab!r}]")
        self.tca = TCA(pair, side=side, contact=contact)
        self.edge = EdgeContact(self.tca) if edge_contact else None
        # inspect the flanks of the members that carry micro-geometry (default), or of both
        self.inspect = [m for m in ("pinion", "gear") if getattr(pair, m).modifications is not None] \
            if inspection is None else (["pinion", "gear"] if inspection else [])

    def limits(self) -> dict:
        t = self.tca
        return {"pinion": {"b": self.pair.pinion.b, "r_a": self.pair.pinion.r_a,
                           "r_form": t.form_radius(1)},
                "gear": {"b": self.pair.gear.b, "r_a": self.pair.gear.r_a, "r_form": t.form_radius(2)}}

    def run(self, progress: Callable[[str], None] | None = None) -> TCAReport:
        t0 = time.perf_counter()
        z1 = self.pair.pinion.z
        # Two mesh cycles centred on the pitch point, so that the transfers between pairs show.
        phi = np.linspace(-2 * math.pi / z1, 2 * math.pi / z1, 2 * self.positions, endpoint=False)
        cases = []
        lim = self.limits()
        for label, mis in self.cases:
            if progress:
                progress(f"tca: {label} ({2 * self.positions} positions x 5 tooth pairs)")
            if self.edge is not None:
                eres = self.edge.sweep(phi, mis=mis, pairs=(-2, -1, 0, 1, 2))
                cases.append(eres.to_dict(label, z1, lim))
                continue
            res = self.tca.sweep(phi, mis=mis, delta=self.delta, z_section=self.z_section, pairs=(-2, -1, 0, 1, 2))
            if not np.isfinite(res.te_envelope).any():
                from ..errors import ConvergenceError
                raise ConvergenceError(f"tca case {label!r}: every contact point found lies off the active flanks "
                                       "(beyond the face or the tip/form circles), so there is no transmission error "
                                       "to report. Analyse edge contact ([tca] edge_contact = true), crown the pinion "
                                       "more, or reduce the misalignment.")
            cases.append(res.to_dict(label, z1, lim))
        p = self.pair
        inspection = self.inspection(progress)
        pair = {"z1": p.pinion.z, "z2": p.gear.z, "m_n": p.pinion.m_n, "beta_deg": p.pinion.beta / DEG,
                "a": p.a_w, "ratio": p.ratio, "side": self.tca.side, "contact": self.tca.contact_type,
                "pinion_a_c": p.pinion.rack.a_c, "pinion_a_pl": p.pinion.a_pl, "eps_alpha": p.eps_alpha,
                "eps_beta": p.eps_beta, "alpha_wt_deg": p.alpha_wt / DEG, "a_minus_a_0_um": p.a_minus_a_0 * 1000,
                "backlash_circumferential": p.backlash,
                "edge_contact_analysis": self.edge is not None, "folded_flanks": self.tca.folding()}
        from ..geometry.microgeometry import iso_from_litvin

        # the pinion's generation crowning as a drawing states it (docs/microgeometry.md)
        pair["pinion_iso_um"] = {k: 1000 * v for k, v in iso_from_litvin(p, "pinion").items()}
        for m in ("pinion", "gear"):
            mg = getattr(p, m).modifications
            if mg is not None:
                pair[f"{m}_modifications"] = mg.to_dict()
        return TCAReport(scene=self.name, pair=pair, cases=cases,
                         timing={"build_s": self.tca.build_time, "run_s": time.perf_counter() - t0},
                         inspection=inspection)

    def inspection(self, progress: Callable[[str], None] | None = None) -> dict:
        """Per inspected member and flank: the deviation grid over the active profile and the face
        (:func:`gearopt.geometry.inspection.inspect_flank`, ``grid``), its chart values in um
        (``charts_um``: ISO 1328-1 F, f_f, f_H, C of profile and lead, S_alpha) and its CSV name."""
        from ..geometry.inspection import chart_values, inspect_flank
        from ..geometry.microgeometry import active_profile

        out = {}
        for m in self.inspect:
            tooth = self.tca.pinion if m == "pinion" else self.tca.gear
            g = getattr(self.pair, m)
            r_s, r_e = active_profile(self.pair, m)
            out[m] = {}
            for sd in ("right", "left"):
                if progress:
                    progress(f"tca: inspecting the {m} {sd} flank")
                grid = inspect_flank(tooth, sd, d_range=(2 * r_s, 2 * r_e), member=m)
                cv = chart_values(grid, g.r_b)
                charts = {k: 1000 * v for k, v in cv.items() if k not in ("z_profile", "L_lead")}
                charts.update(z_profile_mm=cv["z_profile"], L_lead_mm=cv["L_lead"])
                out[m][sd] = {"grid": grid.to_dict(), "charts_um": charts, "csv": f"topography_{m}_{sd}.csv"}
                tol = self._tolerances(m, sd)
                if tol is not None:
                    out[m][sd]["tolerances_um"] = tol
        return out

    def _tolerances(self, member: str, side: str) -> dict | None:
        """ISO 1328-1 chart tolerances [um] of ``iso_grade`` for a flank whose topography is a
        measured deviation from the plain involute (a measured grid on a member without design
        amounts); None otherwise: a designed crowning or relief is not a deviation to judge."""
        if self.iso_grade is None:
            return None
        g = getattr(self.pair, member)
        mg = g.modifications
        if mg is None or not any(grid.side == side for grid in mg.measured):
            return None
        designed = bool(mg.reliefs) or any(getattr(mg, a) != 0 for a in GLOBAL_AMOUNTS)
        if designed:
            return None
        from ..robust.tolerances import tolerances

        t = tolerances(self.iso_grade, 2 * g.r_p, g.m_n, g.b)
        return {"grade": self.iso_grade, "F_alpha": t["F_alphaT"], "f_f_alpha": t["f_falphaT"],
                "f_H_alpha": t["f_HalphaT"], "F_beta": t["F_betaT"], "f_f_beta": t["f_fbetaT"],
                "f_H_beta": t["f_HbetaT"]}


# --- scene binding ------------------------------------------------------------------------------
def check_misalignment_keys(scene: Scene, section: str, o: dict, signs: tuple[int, ...] = (1,)) -> None:
    """Refuse, before running, misalignments that make the study meaningless
    (:meth:`Misalignment.check`: a centre distance change dE that jams the teeth (a + dE < a_0, the
    rule of [pair] a) or separates them (contact ratio < 1), an axial displacement beyond the
    overlap of the faces), naming the scene key. ``o``: the section's values by kind; ``signs``:
    the cases analysed (+v only, or +-v)."""
    from ..errors import GeometryError

    for k in Misalignment.names():
        v = o.get(k) or 0.0
        for s in signs:
            try:
                Misalignment(**{k: s * v}).check(scene.pair, "mis")
            except GeometryError as e:
                case = "" if s > 0 else f" (the case -{k} = {Misalignment.display(k, -v).lstrip('+')})"
                raise scene.key_error(section, k, f"is out of range{case}; valid: {e.valid}.", valid=e.valid) from None


_check_operating = check_misalignment_keys  # (old private name)


def misalignment_from(o: dict) -> Misalignment:
    """The :class:`Misalignment` of a scene section's keys (one per kind; absent keys are 0)."""
    return Misalignment(**{k: o.get(k) or 0.0 for k in Misalignment.names()})


def misalignment_fields(signed: bool = True, prefix: str = "", suffix: str = "") -> list:
    """Scene keys of every misalignment kind, from the fields of :class:`Misalignment` (unit, meaning,
    bound): signed values, or magnitudes (``signed=False``: the +- cases of the crowning study)."""
    from ..io.schema import Bounds, Field

    out = []
    for k in Misalignment.names():
        meta = Misalignment.meta(k)
        hi = meta["scene_max"]
        lo = -hi if signed else 0.0
        if meta["unit"] == "angle":
            # Misalignment angles of real drives are arcminutes (Litvin's examples: 3 arcmin); a bare
            # number above 1 deg (60 arcmin, 0.35 mm across a 20 mm face) is almost surely an arcmin
            # value written without its unit. Refused unless the unit is written out ("2 deg" is accepted).
            out.append(Field(k, "angle", default=0.0, check=Bounds(lo=lo, hi=hi),
                             bare=Bounds(lo=-1 if signed else 0, hi=1), typical="arcmin",
                             doc=f"{prefix}{meta['doc']}{suffix} (a bare number is deg: |{k}| <= 1)"))
        else:
            out.append(Field(k, "length", default=0.0, check=Bounds(lo=lo, hi=hi), doc=prefix + meta["doc"] + suffix))
    return out


def _from_scene(scene) -> TCAStudy:
    from ..errors import GeometryError, OptionError, SceneError

    o = scene.options.get("tca", {}) or {}
    try:
        mis = misalignment_from(o)
        cases = None
        if o.get("cases") is not None:
            if np.any(mis.vector() != 0):
                raise SceneError(f"{scene.source}: [tca] cases and the single keys {', '.join(Misalignment.names())}: "
                                 "give the misalignments either as [[tca.cases]] or as the single keys, not both.",
                                 param="[tca] cases", source=scene.source)
            cases = []
            for i, c in enumerate(o["cases"]):
                m = misalignment_from(c)
                label = c.get("label") or _auto_label(m)
                if label in [lab for lab, _ in cases]:
                    raise SceneError(f"{scene.source}: [tca.cases][{i}] label = {label!r}: the labels of the cases "
                                     "must be distinct.",
                                     param=f"[tca.cases][{i}] label", value=label, valid="distinct labels",
                                     source=scene.source)
                check_misalignment_keys(scene, f"tca.cases][{i}", c, signs=(1,))
                cases.append((label, m))
            if not cases:
                raise SceneError(f"{scene.source}: [tca] cases = []: give at least one case or leave it out.",
                                 param="[tca] cases", value=[], valid="at least one case", source=scene.source)
        if cases is None:
            check_misalignment_keys(scene, "tca", o, signs=(1,))
        if o.get("contact") == "line" and abs(o.get("z_section") or 0.0) > scene.pair.pinion.b / 2:
            valid = f"|z_section| <= b1 / 2 = {scene.pair.pinion.b / 2:g} mm"
            raise scene.key_error("tca", "z_section", f"is out of range; valid: {valid} (a section of the pinion "
                                  f"face, [pinion] b = {scene.pair.pinion.b:g} mm).", valid=valid)
        if o.get("contact") == "line" and not o.get("edge_contact"):
            # crossed or intersecting axes turn the line contact into point or edge contact: the
            # surfaces then cross in every section (Litvin 9.6); the line TCA has no solution
            rows = [("tca", o)] if cases is None else [(f"tca.cases][{i}", c) for i, c in enumerate(o["cases"])]
            for sec, row in rows:
                for key in Misalignment.names("angle"):
                    if row.get(key):
                        raise scene.key_error(sec, key, "is not allowed with contact = \"line\"; valid: 0 (line "
                                              "contact needs aligned axes: crossed or intersecting axes give point "
                                              "or edge contact). Use contact = \"point\" with a crowned pinion, or "
                                              "set edge_contact = true.", valid="0")
        mg1 = scene.pair.pinion.modifications
        lead_crowned = mg1 is not None and (mg1.C_beta > 0 or bool(mg1.measured) or "C_beta_I" in mg1.reliefs)
        if o.get("contact") == "point" and scene.pair.pinion.a_pl == 0 and not lead_crowned \
                and not o.get("edge_contact"):
            raise SceneError(f"{scene.source}: [tca] contact = \"point\" needs a longitudinally crowned pinion "
                             "([pinion] a_pl > 0 or [pinion.modifications] C_beta > 0); for conjugate or profile-crowned spur pinions use contact = "
                             "\"line\".",
                             param="[tca] contact", value="point", source=scene.source)
        return TCAStudy(scene.pair, TCAStudySettings.from_scene(o), misalignment=None if cases else mis,
                        name=scene.name, cases=cases)
    except (GeometryError, OptionError) as e:
        raise scene.study_error("tca", e) from e


def _auto_label(m: Misalignment) -> str:
    return m.label()


def _register():
    from ..schema import Field, Section
    from . import StudySpec, register

    register(StudySpec(
        name="tca",
        doc="Tooth contact analysis: TE per pair and envelope, paths of contact, contact ellipses, aligned and misaligned",
        sections=[TCAStudySettings.section("tca", [
            "side", "contact", "z_section", "positions", "delta", *misalignment_fields(), "edge_contact", "inspection",
            "iso_grade",
        ], required=False, subsections=[Section("cases", [
            Field("label", "str", doc="name of the case in plots and results (default: its misalignments)"),
            *misalignment_fields(),
        ], array=True, doc="list of misalignment cases ([[tca.cases]]), instead of the single keys; the aligned "
                           "drive comes first unless a case is aligned")])],
        settings=(TCAStudySettings,),
        build=_from_scene,
    ))


_register()
