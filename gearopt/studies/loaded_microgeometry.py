"""Micro-geometry optimisation under load (docs/loaded_synthesis.md): choose ISO flank modifications
that minimise the loaded TE over a duty cycle of torques x misalignment cases, with a pressure limit
and no edge loading; before/after loaded TCA of every case.

Scene section ``[loaded_microgeometry]``:

``torque``        nominal pinion torque [N m] (required); the maps are drawn there.
``torques``       duty-cycle torques [N m], increasing (default 50, 100, 150 % of ``torque``).
``weights``       weight of each torque in the objective (default all 1; every case weighs the same).
``p_limit``       peak Hertz pressure limit of the flank [MPa] (default none).
``harmonics``     weights of the loaded TE's first mesh harmonics: the objective is their weighted
                  amplitudes instead of the peak-to-peak (default none: peak-to-peak).
``pareto``        pressure limits [MPa] of a Pareto front (loaded TE against peak pressure, an
                  epsilon-constraint sweep from the optimum without a limit; default none).
``unloaded_te``   ``{ level = "8 arcsec", weight = 1.0 }``: the unloaded drive's predesigned parabolic TE
                  (Litvin's target of the crowning study) as a second term of the objective, weighted
                  (default none; docs/loaded_synthesis.md section 9).
``edge_margin``   smallest gap of every tip edge and face end under load (default "0.5 um").
``edge_loading``  true: edge loading allowed (no edge constraint; default false).
``positions``     positions per mesh cycle in the NLP (default 32); ``verify_positions`` of the
                  before/after loaded TCA (default 64).
``n_slices``      slices across the face (default 15). ``side``, ``E``, ``nu`` as [ltca].
``crossing``, ``intersecting`` (angles), ``dE``, ``axial`` (lengths): each non-zero value adds the
                  cases +value and -value to the aligned drive.

``[loaded_microgeometry.free.pinion]`` / ``.gear``: the free amounts with their manufacturing bounds,
``C_alpha = { lo = "0 um", hi = "40 um" }``; the start design is the member's
``[<member>.modifications]`` (a free relief needs its start there, e.g. ``d_Ca``). Litvin's settings
``a_c`` (parabolic rack) and ``a_pl`` (plunging) may be free too: ``a_c = { lo = "0 1/mm", hi = "0.01 1/mm" }``.

The optimiser's keys (``p_limit``, ``harmonics``, ``edge_margin``, ``positions``, ``verify_positions``,
``n_slices``, ``side``, ``unloaded_te``) are declared once, by :class:`gearopt.settings.LoadedMicroSettings`
(defaults, ranges, docs), for this section and for :class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`.

results.json: docs/results.md; ``loaded_microgeometry.csv`` beside it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar, Sequence, TYPE_CHECKING

import numpy as np

from ..geometry.microgeometry import GLOBAL_AMOUNTS, RELIEF_AMOUNTS
from ..progress import heartbeat
from ..summary import KeyNumber, loaded_microgeometry_summary
from ..units import RAD_TO_ARCSEC

if TYPE_CHECKING:  # pragma: no cover
    from ..gears import GearPair
    from ..ltca.compliance import Material
    from ..settings import LoadedMicroSettings
    from ..synthesis.loaded import LoadedMicroOptimizer
    from ..synthesis.loaded.results import MicroDesign

UNITS = {"amounts": "um (suffix _um)", "te": "arcsec (suffix _arcsec)", "pressure": "MPa", "torque": "N m",
         "angle": "rad", "length": "mm", "time": "s", "see": "docs/results.md"}
DEFAULT_SHARES = (0.5, 1.0, 1.5)


@dataclass
class LoadedMicroReport:
    scene: str
    design: dict
    cases: list
    torques: list
    before: list  # per case: LoadedSweep.to_dict on the verification grid
    after: list
    options: dict
    timing: dict = field(default_factory=dict)
    pareto: dict | None = None  # ParetoFront.to_dict() when the scene asks for a front

    def to_dict(self) -> dict:
        out = {"study": "loaded_microgeometry", "scene": self.scene, "units": UNITS, "options": self.options,
               "cases": self.cases, "torques_Nm": self.torques, "design": self.design, "before": self.before,
               "after": self.after, "timing": self.timing}
        if self.pareto is not None:
            out["pareto"] = self.pareto
        return out

    #: One line per figure for report.html: what to read from it.
    captions: ClassVar[dict[str, str]] = {
        "loaded_micro_te.png": "Loaded TE over the mesh cycle at every torque before (left) and after (right) the "
                               "optimisation (first case), and the loaded TE peak-to-peak against torque for every "
                               "case (below): read how much the modification lowers the TE at the design torques.",
        "loaded_micro_pattern.png": "Loaded contact pattern on the pinion flank at the nominal torque before (left) "
                                    "and after (right), one pressure scale: read that the pattern moves off the "
                                    "edges and what peak pressure it costs.",
        "loaded_micro_sharing.png": "Load sharing of the tooth pairs at the nominal torque before (left) and after "
                                    "(right): read the longer single-pair zone that the relief gives.",
        "loaded_micro_rounds.png": "Objective of each trust-region round, true (dots) against the linearised NLP's "
                                   "optimum (squares): read that the rounds converged.",
        "loaded_micro_pareto.png": "Pareto front of the weighted loaded TE against the peak pressure, with the start "
                                   "design: read the price in pressure of a lower TE.",
        "loaded_micro_unloaded_te.png": "Unloaded TE of every case before and after, against its target parabola: "
                                        "read how well the optimum keeps the unloaded TE on target.",
    }

    def summary(self) -> list[KeyNumber]:
        """Key numbers of the run (:func:`gearopt.summary.loaded_microgeometry_summary`), read from :meth:`to_dict`."""
        return loaded_microgeometry_summary(self.to_dict())

    def save_plots(self, out_dir: str | Path, dpi: int = 120) -> list[str]:
        """``loaded_micro_te.png`` (loaded TE over the mesh cycle at every torque, before and after, in
        the aligned case; TE peak-to-peak against torque for every case), ``loaded_micro_pattern.png``
        (loaded contact pattern on the pinion flank at the nominal torque, before and after),
        ``loaded_micro_sharing.png`` (load sharing of the tooth pairs at the nominal torque, before and after) and
        ``loaded_micro_rounds.png`` (the trust-region rounds); with a Pareto front,
        ``loaded_micro_pareto.png``; with an unloaded-TE target, ``loaded_micro_unloaded_te.png`` (the
        unloaded TE of every case before and after, against its target parabola)."""
        import matplotlib.pyplot as plt

        from ..plot.loaded_synthesis import (plot_pareto, plot_rounds, plot_te_before_after,
                                             plot_te_vs_torque_before_after, plot_unloaded_te)
        from ..plot.ltca import plot_contact_pattern, plot_load_sharing
        from ..plot.saving import drawn_here
        from .ltca import save_figure

        out = Path(out_dir)
        d = self.to_dict()

        def save(name, fig, title):
            return save_figure(out, self.scene, name, fig, title, dpi)

        # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
        files = ["loaded_micro_te.png", "loaded_micro_pattern.png", "loaded_micro_sharing.png",
                 "loaded_micro_rounds.png"]
        # before and after side by side, the TE against torque below (three in a row shrank the text
        # below reading size on a page or a screen)
        if drawn_here(out / "loaded_micro_te.png"):
            fig = plt.figure(figsize=(13, 9.5), layout="constrained")
            gs = fig.add_gridspec(2, 2)
            axes = [fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, :])]
            plot_te_before_after(d["before"][0], d["after"][0], ax=axes[0], which="before")
            plot_te_before_after(d["before"][0], d["after"][0], ax=axes[1], which="after")
            lo = min(axes[0].get_ylim()[0], axes[1].get_ylim()[0])
            hi = max(axes[0].get_ylim()[1], axes[1].get_ylim()[1])
            axes[0].set_ylim(lo, hi)
            axes[1].set_ylim(lo, hi)
            plot_te_vs_torque_before_after(d, ax=axes[2])
            save("loaded_micro_te.png", fig, "loaded TE before and after the micro-geometry optimisation")
        if drawn_here(out / "loaded_micro_pattern.png"):
            fig, axes = plt.subplots(1, 2, figsize=(13, 5), layout="constrained")
            pmax = max(max(t["p_max_MPa"] for t in d["before"][0]["torques"]),
                       max(t["p_max_MPa"] for t in d["after"][0]["torques"]))
            plot_contact_pattern(d["before"][0], "pinion", ax=axes[0], vmax=pmax)
            axes[0].set_title("before: " + axes[0].get_title())
            plot_contact_pattern(d["after"][0], "pinion", ax=axes[1], vmax=pmax)
            axes[1].set_title("after: " + axes[1].get_title())
            save("loaded_micro_pattern.png", fig, f"loaded contact pattern, {d['cases'][0]['name']}")
        if drawn_here(out / "loaded_micro_sharing.png"):
            fig, axes = plt.subplots(1, 2, figsize=(13, 4.5), layout="constrained")
            for ax, key in zip(axes, ("before", "after")):
                plot_load_sharing(d[key][0], ax=ax)
                ax.set_title(f"{key}: " + ax.get_title())
            save("loaded_micro_sharing.png", fig, f"load sharing of the tooth pairs, {d['cases'][0]['name']}")
        harm = self.options.get("harmonics") is not None
        if drawn_here(out / "loaded_micro_rounds.png"):
            fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
            what = "weighted mesh harmonics" if harm else "weighted TE p-p"
            plot_rounds(d["design"], ax=ax,
                        objective=what + (" + unloaded TE" if self.options.get("unloaded_te") else ""))
            save("loaded_micro_rounds.png", fig, "trust-region rounds")
        if self.pareto is not None:
            files.append("loaded_micro_pareto.png")
            if drawn_here(out / "loaded_micro_pareto.png"):
                fig, ax = plt.subplots(figsize=(7.5, 5), layout="constrained")
                b = d["design"]["before"]
                plot_pareto(self.pareto, ax=ax, before={"objective_arcsec": b["objective_arcsec"],
                                                        "p_max_MPa": float(np.max(b["p_max_MPa"]))},
                            objective="weighted loaded TE harmonics" if harm else "weighted loaded TE peak-to-peak")
                save("loaded_micro_pareto.png", fig, "Pareto front")
        if d["design"].get("unloaded_te") is not None:
            files.append("loaded_micro_unloaded_te.png")
            if drawn_here(out / "loaded_micro_unloaded_te.png"):
                C = len(d["cases"])
                fig, axes = plt.subplots(1, C, figsize=(6 * C, 4.5), layout="constrained", squeeze=False)
                for c in range(C):
                    plot_unloaded_te(d, ax=axes[0, c], case=c)
                save("loaded_micro_unloaded_te.png", fig, "unloaded TE against its target parabola")
        return files

    def save_tables(self, out_dir: str | Path) -> list[str]:
        """``loaded_microgeometry.csv``: per case and torque the loaded TE peak-to-peak, peak pressure and
        edge-load share before and after (verification grid)."""
        des = self.design
        rows = ["case,torque_Nm,te_pp_before_arcsec,te_pp_after_arcsec,p_max_before_MPa,p_max_after_MPa,"
                "edge_share_before,edge_share_after"]
        for c, case in enumerate(self.cases):
            for t, T in enumerate(self.torques):
                b, a = des["before"], des["after"]
                rows.append(",".join([case["name"], f"{T:.10g}"] + [f"{v:.10g}" for v in (
                    b["te_pp_arcsec"][t][c], a["te_pp_arcsec"][t][c], b["p_max_MPa"][t][c], a["p_max_MPa"][t][c],
                    b["edge_share"][t][c], a["edge_share"][t][c])]))
        (Path(out_dir) / "loaded_microgeometry.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        files = ["loaded_microgeometry.csv"]
        if self.pareto is not None:
            names = list(self.design["theta_um"])
            rows = ["p_limit_MPa,feasible,objective_arcsec,p_max_MPa," + ",".join(f"{n}_um" for n in names)]
            for q in self.pareto["points"]:
                lim = "" if q["p_limit_MPa"] is None else f"{q['p_limit_MPa']:.10g}"
                if q["feasible"]:
                    rows.append(",".join([lim, "1", f"{q['objective_arcsec']:.10g}", f"{q['p_max_MPa']:.10g}"]
                                         + [f"{q['theta_um'][n]:.10g}" for n in names]))
                else:
                    rows.append(",".join([lim, "0", "", ""] + [""] * len(names)))
            (Path(out_dir) / "loaded_micro_pareto.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
            files.append("loaded_micro_pareto.csv")
        return files


class LoadedMicroStudy:
    """The loaded_microgeometry study: :class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer` over the
    scene's duty cycle, then the before/after loaded TCA of every case on the verification grid."""

    def __init__(self, pair: GearPair, free: dict, torque: float, torques: Sequence[float] | None, cases: dict,
                 weights: Sequence[float] | None = None, name: str = "loaded_microgeometry",
                 pareto: Sequence[float] | None = None, settings: LoadedMicroSettings | None = None,
                 material: Material | None = None, **options: Any) -> None:
        from ..ltca.validity import check_torque_range
        from ..synthesis.loaded import LoadedMicroOptimizer

        self.pair, self.name, self.torque = pair, name, float(torque)
        check_torque_range(pair, max([float(torque), *[float(t) for t in (torques or [])]]), material,
                           name="torque" if not torques or float(torque) >= max(torques) else "torques")
        self.pareto = None if pareto is None else list(pareto)
        self.case_names = list(cases)
        C = len(cases)
        w = None if weights is None else np.outer(np.asarray(weights, float), np.ones(C))
        self.optimizer = LoadedMicroOptimizer(pair, free, torques, cases=list(cases.values()), weights=w,
                                              settings=settings, material=material, **options)

    def run(self, progress: Callable[[str], None] | None = None) -> LoadedMicroReport:
        from ..report import misalignment_dict

        t0 = time.perf_counter()
        opt = self.optimizer
        if progress:
            progress(f"loaded micro-geometry: {len(opt.free)} free amounts, {opt.torques.size} torques x "
                     f"{len(opt.cases)} cases x {opt.phi1.size} positions")
        with heartbeat(progress, "loaded micro-geometry: trust-region round running", every=30.0) as say:
            d = opt.solve(progress=say)
        front = None
        sopt = opt  # the optimiser whose NLP the shown design solves (its sensitivities)
        if self.pareto is not None:
            # the front's anchor is the optimum without a pressure limit: this design when there is none
            with heartbeat(progress, "loaded micro-geometry: Pareto front running", every=30.0) as say:
                fr = opt.pareto(self.pareto, progress=say, anchor=d if opt.p_limit is None else None)
            if opt.p_limit is None:
                d = fr.anchor  # solved again from a better point of the front, or that point's design
                if fr.solved_under and fr.solved_under[0] is not None:
                    # the design of a tighter limit: its sensitivities are those of that limit's NLP
                    sopt = opt.with_p_limit(fr.solved_under[0])
            front = fr.to_dict()
        sens = sensitivity_dict(sopt, sopt.sensitivities(d))
        unloaded = None if opt.te_level is None else unloaded_te_dict(opt, d, self.case_names)
        if progress and d.stop != "converged":
            progress("loaded micro-geometry: warning: the trust-region loop stopped on its radius (no better design "
                     "found, the design not shown stationary)")
        if progress and not sens["at_design"]:
            progress(f"loaded micro-geometry: warning: the NLP around the design (every slice, no trust radius) has its "
                     f"optimum {sens['model_step_um']:.3g} um from the design: the sensitivities are those of that point")
        if progress and sens["degenerate"]:
            progress(f"loaded micro-geometry: warning: {sens['degenerate']} constraints are degenerate at the optimum "
                     "(active with a zero multiplier): the sensitivities are one-sided, for the active set chosen")
        if progress and sens["dependent_active"]:
            progress(f"loaded micro-geometry: warning: {len(sens['dependent_active'])} active constraints depend on the "
                     "others at the optimum (dropped from the sensitivities' KKT system)"
                     + (f"; the sensitivities to {sens['undetermined']} are one-sided (a kink), not computed (NaN)"
                        if sens["undetermined"]["mis"] or sens["undetermined"]["torque_index"] else ""))
        kink = sens.get("kink", {})
        if progress and (kink.get("mis") or kink.get("torque_index")):
            progress(f"loaded micro-geometry: warning: the optimum sits at a kink in {kink}: its active set changes "
                     "at once on one side, the sensitivities there are one side's (valid_range_*)")
        if progress:
            progress(f"loaded micro-geometry: objective {d.before.objective:.4g} -> {d.after.objective:.4g} arcsec "
                     f"(verification grid); NLP vs loaded TCA {d.error['te_pp']:.2g} arcsec")
            if d.confirmed is not None:
                progress(f"loaded micro-geometry: objective promised {d.promised:.4g} arcsec (the NLP's positions), "
                         f"confirmed {d.confirmed.objective:.4g} (the loaded TE extremes between "
                         f"{d.confirmed.n_grid} positions per cycle; {d.exchanges} exchange(s))")
                gap = d.confirmed.objective - d.promised
                if abs(gap) > opt.confirm_tol * abs(d.confirmed.objective):
                    progress(f"loaded micro-geometry: warning: the loaded TE between the NLP's {d.phi1.size} positions "
                             f"per cycle is {gap:+.3g} arcsec off its objective (more than confirm_tol = "
                             f"{100 * opt.confirm_tol:g} %); exchange = true puts the extremes into the NLP")
            if opt.te_level is not None:
                progress(f"loaded micro-geometry: unloaded TE against its {opt.te_level * RAD_TO_ARCSEC:.3g} arcsec parabola, "
                         f"largest RMS misfit of a case {np.max(d.before.te0_rms):.3g} -> {np.max(d.after.te0_rms):.3g} "
                         "arcsec (verification grid)")
        z1 = self.pair.pinion.z
        t = opt.tca
        limits = {"pinion": {"b": self.pair.pinion.b, "r_a": self.pair.pinion.r_a, "r_form": t.form_radius(1)},
                  "gear": {"b": self.pair.gear.b, "r_a": self.pair.gear.r_a, "r_form": t.form_radius(2)}}
        before = [{**sw.to_dict(z1, nominal=self.torque), "limits": limits} for sw in d.before.sweeps]
        after = [{**sw.to_dict(z1, nominal=self.torque), "limits": limits} for sw in d.after.sweeps]
        cases = [{"name": n, **misalignment_dict(m)} for n, m in zip(self.case_names, opt.cases)]
        options = {"free": {k: [lo * 1e3, hi * 1e3] for k, lo, hi in zip(opt.free, opt.lo, opt.hi)},
                   "weights": opt.weights.tolist(), "p_limit_MPa": opt.p_limit,
                   "harmonics": None if opt.harmonics is None else opt.harmonics.tolist(),
                   "edge_margin_um": None if opt.edge_margin is None else opt.edge_margin * 1e3,
                   "positions": int(opt.phi1.size), "verify_positions": opt.n_verify, "n_slices": opt.ltca.n_slices,
                   "E_MPa": opt.material.E, "nu": opt.material.nu,
                   "unloaded_te": None if opt.te_level is None else {"level_arcsec": opt.te_level * RAD_TO_ARCSEC,
                                                                     "weight": opt.te_weight}}
        design = {**d.to_dict(), "sensitivities": sens}
        if unloaded is not None:
            design["unloaded_te"] = unloaded
        return LoadedMicroReport(scene=self.name, design=design, cases=cases, torques=opt.torques.tolist(),
                                 before=before, after=after, options=options, pareto=front,
                                 timing={"run_s": time.perf_counter() - t0, "optimise_s": d.time})


def unloaded_te_dict(opt: LoadedMicroOptimizer, d: MicroDesign, names: Sequence[str]) -> dict:
    """``design.unloaded_te`` of results.json: the target (level [arcsec], weight, the pinion's z1)
    and per case, before and after (verification grid), the unloaded TE of the pair centred on each
    position [arcsec] at its angle over pi/z1 (``psi``), the fitted line (c0, c1 [arcsec]) and the RMS
    misfit [arcsec]."""
    def one(chk, c):
        rms, psi, te, coef = opt.te0_misfit(chk.sweeps[c].slices, c)
        return {"psi": psi.tolist(), "te_arcsec": te.tolist(), "c0_arcsec": float(coef[0]),
                "c1_arcsec": float(coef[1]), "rms_arcsec": rms}

    return {"level_arcsec": opt.te_level * RAD_TO_ARCSEC, "weight": opt.te_weight, "z1": opt.pair.pinion.z,
            "cases": [{"name": n, "before": one(d.before, c), "after": one(d.after, c)} for c, n in enumerate(names)]}


def sensitivity_dict(opt: LoadedMicroOptimizer, S: dict) -> dict:
    """:meth:`LoadedMicroOptimizer.sensitivities` in the results' units: per N m of each torque, per
    arcmin (angles) or per mm (lengths) of a misalignment added to every case; amounts in um."""
    from ..meshing.misalignment import Misalignment
    from ..units import ARCMIN

    kinds = Misalignment.names()
    unit = {k: (ARCMIN, f"{k}_arcmin") if Misalignment.meta(k)["unit"] == "angle" else (1.0, f"{k}_mm") for k in kinds}
    return {"objective_arcsec_per_Nm": [float(v) for v in S["d_objective_d_torque"]],
            "theta_um_per_Nm": {n: [float(v) * 1e3 for v in S["d_theta_d_torque"][i]] for i, n in enumerate(opt.free)},
            "objective_arcsec_per_mis": {unit[k][1]: float(S["d_objective_d_mis"][j]) * unit[k][0]
                                         for j, k in enumerate(kinds)},
            "theta_um_per_mis": {n: {unit[k][1]: float(S["d_theta_d_mis"][i, j]) * unit[k][0] * 1e3
                                     for j, k in enumerate(kinds)} for i, n in enumerate(opt.free)},
            "model_step_um": S["model_step"] * 1e3, "at_design": bool(S["at_design"]),
            "active": int(S["active"]), "degenerate": int(S["degenerate"]), "min_multiplier": S.get("min_multiplier"),
            "mirror_odd_zero": list(S.get("mirror_odd", [])), "dependent_active": list(S.get("dependent", [])),
            "undetermined": {"mis": [unit[k][1] for k in S.get("undetermined", {}).get("mis", [])],
                             "torque_index": list(S.get("undetermined", {}).get("torque", []))},
            **validity_dict(S, kinds, unit)}


def validity_dict(S: dict, kinds: Sequence[str], unit: dict) -> dict:
    """Where the sensitivities hold (docs/loaded_synthesis.md section 6.5): per misalignment kind the
    offsets (below, above) [arcmin or mm] and per torque [N m] within which the optimum keeps its
    active set, ``None`` where no event bounds it (or a mirror-odd kind, zero by symmetry), and the
    parameters at a kink (a range under ``KINK_RANGE`` on a side: the derivatives are one side's)."""
    def bound(v, scale):
        v = float(v)
        return None if not math.isfinite(v) else v / scale

    out = {}
    if "range_mis" in S:
        out["valid_range_mis"] = {unit[k][1]: [bound(v, unit[k][0]) for v in S["range_mis"][j]]
                                  for j, k in enumerate(kinds)}
        out["valid_range_torque_Nm"] = [[bound(v, 1.0) for v in row] for row in S["range_torque"]]
    if "kink_mis" in S:
        out["kink"] = {"mis": [unit[k][1] for j, k in enumerate(kinds) if bool(S["kink_mis"][j])],
                       "torque_index": [int(t) for t in np.flatnonzero(S["kink_torque"])]}
    return out


def _from_scene(scene):
    from ..errors import GeometryError, OptionError
    from ..ltca.compliance import Material
    from ..meshing.misalignment import Misalignment
    from ..settings import LoadedMicroSettings
    from ..meshing.misalignment import misalignment_cases
    from .tca import check_misalignment_keys

    o = scene.options.get("loaded_microgeometry", {}) or {}
    check_misalignment_keys(scene, "loaded_microgeometry", o, signs=(1, -1))
    torque = o["torque"]
    torques = o.get("torques") or [s * torque for s in DEFAULT_SHARES]
    weights = o.get("weights")
    if weights is not None and len(weights) != len(torques):
        raise scene.key_error("loaded_microgeometry", "weights", f"is out of range; valid: one weight per torque "
                              f"({len(torques)} numbers >= 0).", valid=f"{len(torques)} numbers >= 0")
    free = {}
    for member in ("pinion", "gear"):
        for amount, rng in ((o.get("free") or {}).get(member) or {}).items():
            if rng is not None:
                free[f"{member}.{amount}"] = (rng["lo"], rng["hi"])
    if not free:
        raise scene.key_error("loaded_microgeometry", "free", "is missing; valid: at least one free amount, e.g. "
                              "[loaded_microgeometry.free.pinion] C_alpha = { lo = \"0 um\", hi = \"40 um\" }.",
                              valid="at least one free amount")
    cases = misalignment_cases(**{k: o.get(k) or 0.0 for k in Misalignment.names()})
    try:
        settings = LoadedMicroSettings.from_scene(o, edge_margin=None if o.get("edge_loading") else o["edge_margin"])
        return LoadedMicroStudy(scene.pair, free, torque, torques, cases, weights=weights, name=scene.name,
                                pareto=o.get("pareto"), settings=settings, material=Material(E=o["E"], nu=o["nu"]))
    except (GeometryError, OptionError) as e:
        raise scene.study_error("loaded_microgeometry", e) from e


def _register():
    from ..schema import Field, Section
    from ..settings import LoadedMicroSettings
    from . import StudySpec, register
    from .ltca import material_fields, torque_fields
    from .robust import range_section
    from .tca import misalignment_fields

    def amounts(member):
        um = [Section(a, [Field("lo", "length", required=True, unit="um", doc="lower end"),
                          Field("hi", "length", required=True, unit="um", doc="upper end")],
                      doc=f"bounds of the {member}'s {a} (with their unit, \"40 um\")")
              for a in GLOBAL_AMOUNTS + RELIEF_AMOUNTS]
        return Section(member, [], subsections=um
                       + [range_section(a, "inverse_length", f"bounds of the {member}'s Litvin setting {a} [1/mm]")
                          for a in ("a_c", "a_pl")],
                       doc=f"free amounts of the {member} with their bounds")

    register(StudySpec(
        name="loaded_microgeometry",
        doc="Optimise ISO micro-geometry for the loaded TE over torques x misalignments, with a pressure limit "
            "and no edge loading; before/after loaded TCA",
        sections=[LoadedMicroSettings.section("loaded_microgeometry", [
            *torque_fields("maps drawn there", "duty-cycle torques (default 50, 100, 150 % of torque)"),
            Field("weights", "floats", check=lambda v: None if all(x >= 0 for x in v) and sum(v) > 0
                  else "weights >= 0, not all 0", doc="weight of each torque in the objective (default all 1)"),
            "p_limit", "harmonics",
            Field("pareto", "floats", check=lambda v: None if v and all(100 <= x <= 1e4 for x in v)
                  and len(set(v)) == len(v) else "distinct pressure limits, 100 ... 10000 MPa each",
                  doc="pressure limits [MPa] of a Pareto front, loaded TE against peak pressure (default none)"),
            "edge_margin",
            Field("edge_loading", "bool", default=False,
                  doc="allow edge loading (no edge constraint; edge_margin is then not used)"),
            "n_positions", "n_verify", "n_confirm", "confirm_tol", "max_exchanges", "exchange", "n_slices", "side",
            *material_fields(),
            *misalignment_fields(signed=False, prefix="+- ", suffix=" cases"),
        ], subsections=[Section("free", [], subsections=[amounts("pinion"), amounts("gear")], required=True,
                                doc="the free amounts and their bounds"),
                        LoadedMicroSettings.section(group="unloaded_te", doc="the unloaded parabolic-TE target as a "
                                                    "second term of the objective (default none)")],
            required=True)],
        settings=(LoadedMicroSettings,),
        build=_from_scene,
    ))


_register()
