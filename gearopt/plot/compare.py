"""Plots that put several designs of the same gear pair side by side (``gearopt compare``).

Every function reads designs as a mapping ``label -> results`` (the dictionaries of their
``results.json``, in the order given on the command line), takes ``ax=`` (or ``axes=`` for a row of
panels) and returns what it drew on. Conventions, the same in every figure:

* one colour per design (``C0``, ``C1``, ... in the order of the mapping; the first design drawn
  thicker, as the reference), named in every legend;
* one line style per misalignment case (:func:`case_style`), the case named in the panel title;
* panels of the same quantity share their scale (TE axes, flank frames, pressure colour scale).

Units: TE in arcsec (positive when the gear is ahead), pinion angle in deg, flank positions in mm,
torque in N m, pressure in MPa, micro-geometry amounts in um; safety and load factors (ISO 6336) and
Miner damage sums are dimensionless.

The ``*_cases`` / ``*_of`` helpers pick a quantity out of the results of any study that has it
(``tca``: ``cases``; ``crowning``: the optimised drive ``after``; ``ltca``: the drive itself;
``loaded_microgeometry``: the optimum ``after``) so that designs of different studies are compared
on what they have in common. They return ``None`` or ``[]`` when a design has no such quantity.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..report import CONJUGATE_ARCSEC  # the results' own threshold (``conjugate`` in results.json)
from .style import number
from .ticks import plain_ticks

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from matplotlib.axes import Axes

__all__ = ["comparison_figures", "save_figures", "design_color", "case_style", "case_key", "case_name", "te_cases", "match_cases", "contact_path",
           "loaded_cases", "crowning_amounts", "plot_te", "plot_contact_paths", "plot_loaded_te",
           "plot_te_vs_torque", "plot_pressure_vs_torque", "plot_load_sharing", "plot_distribution",
           "plot_crowning", "pattern_vmax", "common_torque", "fea_positions", "plot_fea", "rating_of",
           "plot_safety", "plot_rating_factor", "plot_rating_spectrum"]

_LINESTYLES = ("-", "--", ":", "-.")
#: the pinion's micro-geometry amounts compared by :func:`plot_crowning` (ISO 21771 names)
CROWNING_AMOUNTS = ("C_alpha", "f_H_alpha", "C_beta", "f_H_beta")
_AMOUNT_TEXT = {"C_alpha": "profile crowning\n$C_\\alpha$", "f_H_alpha": "profile slope\n$f_{H\\alpha}$",
                "C_beta": "lead crowning\n$C_\\beta$", "f_H_beta": "helix slope\n$f_{H\\beta}$"}
_BELOW = dict(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=1, frameon=False)


def _f(v: Any) -> np.ndarray:
    return np.array([np.nan if x is None else x for x in v], dtype=float)


def design_color(i: int) -> str:
    """Colour of the ``i``-th design (0 = the reference), the same in every comparison figure."""
    return f"C{i % 10}"


def _lw(i: int) -> float:
    return 2.6 if i == 0 else 1.7


def case_style(j: int) -> str:
    """Line style of the ``j``-th misalignment case (0: the first, usually the aligned drive)."""
    return _LINESTYLES[j % len(_LINESTYLES)]


def case_key(misalignment: Mapping[str, float] | None) -> tuple:
    """A hashable key of a misalignment (``{"crossing_arcmin": 3.0, ...}``): its non-zero kinds,
    rounded to 1e-6 of their unit; ``()`` for the aligned drive. Cases of different designs with
    the same key are the same operating condition."""
    if not misalignment:
        return ()
    return tuple(sorted((k, round(float(v), 6)) for k, v in misalignment.items() if v))


def case_name(misalignment: Mapping[str, float] | None) -> str:
    """The misalignment in words: ``"aligned"``, ``"crossing +3 arcmin"``, ``"dE +0.05 mm, ..."``."""
    key = case_key(misalignment)
    if not key:
        return "aligned"
    parts = []
    for k, v in key:
        for suffix in ("_arcmin", "_mm"):
            if k.endswith(suffix):
                parts.append(f"{k[:-len(suffix)]} {v:+g} {suffix[1:]}")
                break
        else:
            parts.append(f"{k} {v:+g}")
    return ", ".join(parts)


def _ltca_case(d: dict, label: str | None = None) -> dict:
    """The unloaded TE of a loaded TCA dict (``ltca`` results or a ``loaded_microgeometry`` case)
    in the form of a TCA case."""
    mis = d.get("misalignment") or {}
    return {"label": label or case_name(mis), "misalignment": mis, "phi1": d["phi1"],
            "te_envelope_arcsec": d["te_unloaded_arcsec"], "peak_to_peak_arcsec": d["unloaded_peak_to_peak_arcsec"],
            "conjugate": abs(float(d["unloaded_peak_to_peak_arcsec"])) < CONJUGATE_ARCSEC, "limits": d.get("limits"), "source": "loaded TCA (unloaded slices)"}


def te_cases(res: dict) -> list[dict]:
    """The unloaded TE cases of one design's results: dicts with ``label``, ``misalignment``,
    ``phi1`` [rad], ``te_envelope_arcsec`` (the actual TE), ``peak_to_peak_arcsec``, ``conjugate``
    and, for TCA cases, the paths of contact; ``[]`` when the study has none (geometry, montecarlo,
    fea...)."""
    study = res.get("study")
    if study == "tca":
        return list(res.get("cases") or [])
    if study == "crowning":
        return list(res.get("after") or [])
    if study == "ltca" and "te_unloaded_arcsec" in res:
        return [_ltca_case(res)]
    if study == "loaded_microgeometry":
        names = [c.get("name") for c in res.get("cases") or []]
        after = res.get("after") or []
        return [_ltca_case(d, names[i] if i < len(names) else None) for i, d in enumerate(after)
                if "te_unloaded_arcsec" in d]
    return []


def match_cases(per_design: Mapping[str, Sequence[dict]]) -> list[tuple[tuple, str, dict[str, dict]]]:
    """Group the cases of several designs by their misalignment (:func:`case_key`).

    Returns
    -------
    list of (key, name, {label: case})
        One entry per misalignment found, in the order of first appearance (the first design's
        cases first); ``name`` is :func:`case_name` of it. A design without that case is absent
        from its dict.
    """
    out: dict[tuple, tuple[str, dict[str, dict]]] = {}
    for label, cases in per_design.items():
        for c in cases:
            key = case_key(c.get("misalignment"))
            if key not in out:
                out[key] = (case_name(c.get("misalignment")), {})
            out[key][1].setdefault(label, c)
    return [(k, name, by) for k, (name, by) in out.items()]


def contact_path(case: dict, member: str = "pinion") -> tuple[np.ndarray, np.ndarray] | None:
    """The central pair's path of contact on ``member``'s flank where it lies on the active flank:
    axial position z [mm] and radius [mm] (NaN elsewhere); the surface path of an edge-contact case;
    None when the case has no path (a loaded TCA case)."""
    if member in case and isinstance(case[member], dict) and "axial" in case[member]:
        on = np.array(case.get("on_surface") or [True] * len(case[member]["axial"]), bool)
        z, r = _f(case[member]["axial"]), _f(case[member]["radius"])
        return np.where(on, z, np.nan), np.where(on, r, np.nan)
    paths = case.get("paths_central_pair") or {}
    surf = paths.get("surface")
    if surf and member in surf:
        z, r = _f(surf[member]["axial"]), _f(surf[member]["radius"])
        return z, r
    return None


def loaded_cases(res: dict) -> list[dict]:
    """The loaded TCA dicts of one design (``ltca``: the results themselves; ``loaded_microgeometry``:
    the optimum of every case, ``after``), each with its ``misalignment``; ``[]`` for other studies."""
    if res.get("study") == "ltca" and "torques" in res:
        return [res]
    if res.get("study") == "loaded_microgeometry":
        names = res.get("cases") or []
        out = []
        for i, d in enumerate(res.get("after") or []):
            if "torques" in d:
                mis = {k: v for k, v in (names[i] if i < len(names) else {}).items() if k != "name"}
                out.append({**d, "misalignment": d.get("misalignment", mis)})
        return out
    return []


def crowning_amounts(res: dict) -> dict[str, float] | None:
    """The pinion's crowning and slopes in ISO 21771 terms [um] (:data:`CROWNING_AMOUNTS`): the
    generation crowning (``tca``: ``pair.pinion_iso_um``; ``crowning``: ``design.iso_um``) plus the
    ISO modifications (``pair.pinion_modifications``); the optimum of ``loaded_microgeometry``
    (``design.theta_um``, its free amounts only); None for a study without them."""
    study = res.get("study")
    if study == "tca":
        pair = res.get("pair") or {}
        gen = pair.get("pinion_iso_um") or {}
        mod = pair.get("pinion_modifications") or {}
        out = {}
        for k in CROWNING_AMOUNTS:
            g, m = gen.get(k), mod.get(f"{k}_um")
            if g is not None or m is not None:
                out[k] = float(g or 0.0) + float(m or 0.0)
        return out or None
    if study == "crowning":
        iso = (res.get("design") or {}).get("iso_um")
        return {k: float(iso[k]) for k in CROWNING_AMOUNTS if k in iso} if iso else None
    if study == "loaded_microgeometry":
        theta = (res.get("design") or {}).get("theta_um") or {}
        out = {k: float(theta[f"pinion.{k}"]) for k in CROWNING_AMOUNTS if f"pinion.{k}" in theta}
        return out or None
    return None


def _legend(ax: Axes, **kw: Any) -> None:
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(**{**_BELOW, **kw})


def plot_te(designs: Mapping[str, dict], case: tuple, ax: Axes | None = None, ylim: tuple | None = None) -> Axes:
    """Actual unloaded TE [arcsec] against the pinion angle [deg] of every design that has the case
    ``case`` (a :func:`case_key`), one colour per design, the case's line style.

    Parameters
    ----------
    designs : mapping label -> results dict
    case : tuple
        The misalignment case (:func:`case_key`; ``()`` the aligned drive).
    ax : Axes, optional
    ylim : (float, float), optional
        The TE range [arcsec], shared by the panels of one figure.
    """
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    groups = {k: (n, by) for k, n, by in match_cases({lab: te_cases(r) for lab, r in designs.items()})}
    name, by = groups.get(case, (case_name(dict(case)), {}))
    j = list(groups).index(case) if case in groups else 0
    for i, label in enumerate(designs):
        c = by.get(label)
        if c is None:
            continue
        phi = np.degrees(_f(c["phi1"]))
        te = np.zeros_like(phi) if c.get("conjugate") else _f(c["te_envelope_arcsec"])
        pp = "conjugate, TE = 0" if c.get("conjugate") else f"p-p {number(c['peak_to_peak_arcsec'])} arcsec"
        ax.plot(phi, te, color=design_color(i), ls=case_style(j), lw=_lw(i), label=f"{label}: {pp}")
    missing = [lab for lab in designs if lab not in by]
    ax.set_title(name + (f"\n(not in {', '.join(missing)})" if missing else ""), fontsize=9)
    ax.set_xlabel("pinion angle phi1 [deg]")
    from .tca import te_zero_text

    zeros = sorted({te_zero_text(c) for c in by.values()}) or ["zero: pair 0 at phi1 = 0"]
    zero = zeros[0] if len(zeros) == 1 else "zero: pair 0 at phi1 = 0, or the aligned conjugate drive (edge contact)"
    ax.set_ylabel(f"actual TE [arcsec] (+: gear ahead)\n{zero}")
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.grid(alpha=0.3)
    _legend(ax)
    plain_ticks(ax)
    return ax


def te_range(designs: Mapping[str, dict]) -> tuple[float, float] | None:
    """The TE range [arcsec] that holds every design's actual TE of every case, with a margin;
    None without any TE."""
    vals = [_f(c["te_envelope_arcsec"]) for r in designs.values() for c in te_cases(r) if not c.get("conjugate")]
    vals = np.concatenate(vals) if vals else np.zeros(0)
    vals = vals[np.isfinite(vals)]
    if not vals.size:
        return None
    lo, hi = float(vals.min()), float(vals.max())
    pad = 0.08 * max(hi - lo, 1e-3)
    return lo - pad, hi + pad


def _flank_frame(ax: Axes, lims: Sequence[dict]) -> None:
    """The active flanks of every design (face ends, form and tip radii) as outlines; the frame
    holds them all."""
    from matplotlib.patches import Rectangle

    for i, lim in enumerate(lims):
        b, ra, rf = lim["b"], lim["r_a"], lim["r_form"]
        ax.add_patch(Rectangle((-b / 2, rf), b, ra - rf, fill=i == 0, fc="0.95", ec="0.55" if i == 0 else
                               design_color(i), lw=0.8, ls="-" if i == 0 else ":", zorder=0.5))
    b = max(lim["b"] for lim in lims)
    ra, rf = max(lim["r_a"] for lim in lims), min(lim["r_form"] for lim in lims)
    ax.set_xlim(-0.65 * b, 0.65 * b)
    pad = 0.08 * (ra - rf)
    ax.set_ylim(rf - pad, ra + pad)


def _same_path(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray], lim: dict | None) -> bool:
    """True when two paths of contact lie on each other within 1 % of the flank's size (face width
    across, active profile up): one hides the other in the drawing."""
    if lim is None:
        return False
    pts = []
    for z, r in (a, b):
        ok = np.isfinite(z) & np.isfinite(r)
        pts.append(np.c_[z[ok] / lim["b"], r[ok] / max(lim["r_a"] - lim["r_form"], 1e-9)])
    if not all(p.size for p in pts):
        return False
    d = np.sqrt(((pts[0][:, None, :] - pts[1][None, :, :]) ** 2).sum(-1))
    return bool(d.min(axis=1).max() <= 0.01 and d.min(axis=0).max() <= 0.01)


def plot_contact_paths(designs: Mapping[str, dict], case: tuple, member: str = "pinion",
                       ax: Axes | None = None) -> Axes:
    """Paths of contact of the central tooth pair on the ``member`` flank (axial position z [mm]
    across, radius [mm] up; the active flank of the first design shaded, those of others outlined
    when they differ) of every design that has the case ``case``: one colour per design."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    groups = {k: (n, by) for k, n, by in match_cases({lab: te_cases(r) for lab, r in designs.items()})}
    name, by = groups.get(case, (case_name(dict(case)), {}))
    j = list(groups).index(case) if case in groups else 0
    lims = []
    for c in by.values():
        lim = (c.get("limits") or {}).get(member)
        if lim and all(lim != x for x in lims):
            lims.append(lim)
    if lims:
        _flank_frame(ax, lims)
    drawn: list[str] = []
    seen: list[tuple[str, tuple[np.ndarray, np.ndarray]]] = []
    for i, label in enumerate(designs):
        c = by.get(label)
        path = contact_path(c, member) if c is not None else None
        if path is None or not np.isfinite(path[0]).any():
            continue
        same = [lab for lab, p in seen if _same_path(p, path, lims[0] if lims else None)]
        ax.plot(path[0], path[1], color=design_color(i), ls=case_style(j), lw=_lw(i),
                label=label + (f" (on {same[0]}'s path)" if same else ""))
        seen.append((label, path))
        drawn.append(label)
    missing = [lab for lab in designs if lab not in drawn]
    ax.set_title(f"{member} flank, {name}" + (f"\n(no path: {', '.join(missing)})" if missing else ""), fontsize=9)
    ax.set_xlabel("axial position z [mm]")
    ax.set_ylabel(f"{member} radius [mm]")
    ax.grid(alpha=0.3)
    _legend(ax, ncol=2)
    plain_ticks(ax)
    return ax


def _nominal(d: dict) -> dict:
    nom = d.get("nominal_torque_Nm")
    rows = d["torques"]
    return rows[-1] if nom is None else min(rows, key=lambda t: abs(t["torque_Nm"] - nom))


def common_torque(loaded: Mapping[str, dict]) -> float | None:
    """The torque [N m] at which loaded designs are compared over the mesh cycle: one that every
    design analysed (within 1e-6 N m), the nearest to the first design's nominal torque; None when
    they share none (each is then shown at its own nominal torque)."""
    sets = [[float(t["torque_Nm"]) for t in d["torques"]] for d in loaded.values()]
    if not sets:
        return None
    common = [T for T in sets[0] if all(any(abs(T - u) <= 1e-6 for u in s) for s in sets[1:])]
    if not common:
        return None
    nom = _nominal(next(iter(loaded.values())))["torque_Nm"]
    return min(common, key=lambda T: abs(T - nom))


def _at_torque(d: dict, torque: float | None) -> dict:
    """The row of ``d["torques"]`` at ``torque`` (the nominal one when None)."""
    if torque is None:
        return _nominal(d)
    return min(d["torques"], key=lambda t: abs(t["torque_Nm"] - torque))


def _first_loaded(designs: Mapping[str, dict]) -> dict[str, dict]:
    """One loaded TCA case per design that has one (label -> ltca dict): the first misalignment
    case (of the first such design) that every design with loaded cases has, else each design's
    first case (the titles name the misalignment)."""
    per = {lab: loaded_cases(r) for lab, r in designs.items()}
    per = {lab: cs for lab, cs in per.items() if cs}
    for _, _, by in match_cases(per):
        if len(by) == len(per):
            return {lab: by[lab] for lab in designs if lab in by}
    return {lab: cs[0] for lab, cs in per.items()}


def plot_loaded_te(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Loaded TE [arcsec] over the pinion angle [deg] at a torque all designs analysed
    (:func:`common_torque`; else each design's nominal torque), solid, with its unloaded TE (dotted),
    one colour per design."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    loaded = _first_loaded(designs)
    torque = common_torque(loaded)
    for i, label in enumerate(designs):
        d = loaded.get(label)
        if d is None:
            continue
        t = _at_torque(d, torque)
        phi = np.degrees(_f(d["phi1"]))
        ax.plot(phi, _f(t["te_loaded_arcsec"]), color=design_color(i), lw=_lw(i),
                label=f"{label}: {number(t['torque_Nm'])} N m, p-p {number(t['peak_to_peak_arcsec'])} arcsec")
        ax.plot(phi, _f(d["te_unloaded_arcsec"]), color=design_color(i), lw=1.0, ls=":",
                label=f"{label}: unloaded")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("TE [arcsec] (+: gear ahead)\nzero: unloaded pair 0 at phi1 = 0")
    at = "the nominal torques" if torque is None else f"{number(torque)} N m"
    ax.set_title(f"loaded TE at {at} (dotted: unloaded)", fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax)
    plain_ticks(ax)
    return ax


def _against_torque(designs: Mapping[str, dict], ax: Axes, value, ylabel: str, title: str) -> Axes:
    loaded = _first_loaded(designs)
    tmax = 0.0
    for i, label in enumerate(designs):
        d = loaded.get(label)
        if d is None:
            continue
        T = np.array([t["torque_Nm"] for t in d["torques"]], float)
        y = np.array([np.nan if value(t) is None else value(t) for t in d["torques"]], float)
        ax.plot(T, y, "o-", color=design_color(i), lw=_lw(i), ms=4, label=label)
        tmax = max(tmax, float(np.max(T)))
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel(ylabel)
    if tmax > 0:
        ax.set_xlim(0, 1.05 * tmax)
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax, ncol=2)
    plain_ticks(ax)
    return ax


def plot_te_vs_torque(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Loaded TE peak-to-peak [arcsec] against the pinion torque [N m], one colour per design."""
    import matplotlib.pyplot as plt

    return _against_torque(designs, ax or plt.figure().gca(), lambda t: t["peak_to_peak_arcsec"],
                           "loaded TE peak-to-peak [arcsec]", "loaded TE against torque")


def plot_pressure_vs_torque(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Largest Hertz peak pressure of the flank contact over the mesh cycle [MPa] against the pinion
    torque [N m], one colour per design."""
    import matplotlib.pyplot as plt

    return _against_torque(designs, ax or plt.figure().gca(), lambda t: t.get("p_max_MPa"),
                           "peak flank pressure p_max [MPa]", "peak pressure against torque")


def plot_load_sharing(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Load share of the central tooth pair (pair 0) over the pinion angle [deg] at a torque all
    designs analysed (:func:`common_torque`; else each design's nominal torque), one colour per design."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    loaded = _first_loaded(designs)
    torque = common_torque(loaded)
    for i, label in enumerate(designs):
        d = loaded.get(label)
        if d is None or 0 not in d["pairs"]:
            continue
        t = _at_torque(d, torque)
        share = _f(t["pair_share"][list(d["pairs"]).index(0)])
        ax.plot(np.degrees(_f(d["phi1"])), share, color=design_color(i), lw=_lw(i),
                label=f"{label}: {number(t['torque_Nm'])} N m")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("load share of tooth pair 0 [-]")
    ax.set_ylim(-0.02, 1.05)
    at = "the nominal torques" if torque is None else f"{number(torque)} N m"
    ax.set_title(f"load sharing of the central pair at {at}", fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax)
    plain_ticks(ax)
    return ax


def pattern_vmax(designs: Mapping[str, dict], member: str = "pinion") -> float | None:
    """The largest Hertz peak pressure [MPa] of the contact patterns of every design (the common
    top of their colour scale; tip edges left out as in the patterns); None without patterns."""
    top = None
    for d in _first_loaded(designs).values():
        pat = d.get("pattern") or {}
        p0 = _f(pat.get("p0_MPa") or [])
        edge = _f(pat.get("edge") or [0] * p0.size) > 0
        vals = p0[~edge & np.isfinite(p0)] if p0.size == edge.size else p0[np.isfinite(p0)]
        if vals.size:
            top = max(top or 0.0, float(vals.max()))
    return top


def plot_distribution(samples: Mapping[str, Mapping[str, np.ndarray]], column: str = "te_p2p_arcsec",
                      ax: Axes | None = None, xlabel: str | None = None) -> Axes:
    """Empirical cumulative distributions of one sampled result (a column of the designs'
    ``samples.csv``, e.g. TE peak-to-peak [arcsec]) of Monte Carlo or sweep designs, one colour per
    design, with each design's median marked.

    Parameters
    ----------
    samples : mapping label -> {column: values}
        Per design, the columns of its samples table (empty cells NaN).
    column : str
    ax : Axes, optional
    xlabel : str, optional
        The axis label (default: the column name).
    """
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    for i, (label, cols) in enumerate(samples.items()):
        v = np.asarray(cols.get(column, []), float)
        v = np.sort(v[np.isfinite(v)])
        if not v.size:
            continue
        p = np.arange(1, v.size + 1) / v.size
        med = float(np.median(v))
        ax.step(v, p, where="post", color=design_color(i), lw=_lw(i),
                label=f"{label}: median {number(med)}, p95 {number(float(np.percentile(v, 95)))} (n = {v.size})")
        ax.plot([med], [0.5], "o", color=design_color(i), ms=5)
    ax.set_xlabel(xlabel or column)
    ax.set_ylabel("share of samples at or below [-]")
    ax.set_ylim(0, 1.02)
    ax.set_title(f"distribution over the samples: {xlabel or column}", fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax)
    plain_ticks(ax)
    return ax


def plot_crowning(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """The pinion's crowning and slopes in ISO 21771 terms [um] (:func:`crowning_amounts`) of every
    design that states them, as grouped bars (one colour per design)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    amounts = {lab: crowning_amounts(r) for lab, r in designs.items()}
    shown = [lab for lab in designs if amounts[lab]]
    w = 0.8 / max(len(shown), 1)
    x = np.arange(len(CROWNING_AMOUNTS))
    for i, label in enumerate(designs):
        a = amounts[label]
        if not a:
            continue
        h = np.array([a.get(k, np.nan) for k in CROWNING_AMOUNTS], float)
        slot = shown.index(label)
        bars = ax.bar(x - 0.4 + w * (slot + 0.5), np.nan_to_num(h), width=w, color=design_color(i), label=label)
        for bar, v in zip(bars, h):
            if math.isfinite(v):
                ax.annotate(number(v, 3), (bar.get_x() + bar.get_width() / 2, max(v, 0.0)), ha="center",
                            va="bottom", fontsize=7, xytext=(0, 2), textcoords="offset points")
    ax.set_xticks(x, [_AMOUNT_TEXT[k] for k in CROWNING_AMOUNTS], fontsize=8)
    ax.set_ylabel("amount [um]")
    top = max([v for a in amounts.values() if a for v in a.values()] + [0.0])
    ax.set_ylim(min(0.0, ax.get_ylim()[0]), 1.2 * top if top > 0 else 1.0)
    ax.axhline(0, color="0.3", lw=0.8)
    ax.set_title("pinion crowning in ISO 21771 terms (generation crowning + modifications)", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    _legend(ax, bbox_to_anchor=(0.5, -0.25), ncol=2)
    plain_ticks(ax)
    return ax


def fea_positions(res: dict) -> dict[str, np.ndarray] | None:
    """The FE positions of a design (``fea`` study): pinion angle ``phi1`` [rad], loaded TE
    ``te`` [arcsec], largest contact pressure ``p_max`` [MPa] and the largest principal root stress
    at mid face ``root_pinion``, ``root_gear`` [MPa] per position (NaN where absent); None for other
    studies."""
    if res.get("study") != "fea" or not res.get("positions"):
        return None
    pos = res["positions"]

    def col(get) -> np.ndarray:
        out = []
        for p in pos:
            try:
                v = get(p)
            except (KeyError, TypeError):
                v = None
            out.append(np.nan if v is None else float(v))
        return np.array(out, float)

    return {"phi1": col(lambda p: p["phi1"]), "te": col(lambda p: p["loaded_te_arcsec"]),
            "p_max": col(lambda p: p["contact"]["p_max"]),
            "root_pinion": col(lambda p: p["root"]["pinion"]["max_principal_mid"]),
            "root_gear": col(lambda p: p["root"]["gear"]["max_principal_mid"])}


def plot_fea(designs: Mapping[str, dict], quantity: str = "te", ax: Axes | None = None) -> Axes:
    """One FE quantity per position against the pinion angle [deg] (:func:`fea_positions`: ``te``
    loaded TE [arcsec], ``p_max`` contact pressure [MPa], ``root`` root stress of pinion (solid) and
    gear (dashed) [MPa]), one colour per design, the torque in the legend."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    text = {"te": ("loaded TE [arcsec] (+: gear ahead)", "loaded TE per position"),
            "p_max": ("largest contact pressure [MPa]", "contact pressure per position"),
            "root": ("largest principal root stress, mid face [MPa]", "root stress per position (dashed: gear)")}
    for i, (label, res) in enumerate(designs.items()):
        f = fea_positions(res)
        if f is None:
            continue
        phi = np.degrees(f["phi1"])
        torque = (res.get("options") or {}).get("torque_Nmm")
        lab = label + ("" if torque is None else f": {number(torque / 1000.0)} N m")
        keys = ["root_pinion", "root_gear"] if quantity == "root" else [quantity]
        for k, ls in zip(keys, ("-", "--")):
            ax.plot(phi, f[k], "o", ls=ls, color=design_color(i), lw=_lw(i), ms=5,
                    label=lab if ls == "-" else None)
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel(text[quantity][0])
    ax.set_title(text[quantity][1], fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax)
    plain_ticks(ax)
    return ax


_METHOD = {"ltca": "gearopt LTCA", "iso": "ISO 6336-1"}
#: the fixed ticks of a logarithmic safety-factor axis (as gearopt.plot.rating)
_SAFETY_TICKS = (0.3, 0.5, 0.7, 0.8, 0.9, 1.0, 1.2, 1.4, 1.7, 2.0, 2.5, 3.0, 4.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 50.0)


def rating_of(res: dict) -> dict | None:
    """The ISO 6336 rating of a design (the ``rating`` study's results: ``torques``, ``nominal``,
    ``options``), None for other studies."""
    if res.get("study") == "rating" and res.get("torques") and isinstance(res.get("nominal"), dict):
        return res
    return None


def _ratings(designs: Mapping[str, dict]) -> dict[str, tuple[int, dict]]:
    """label -> (index of the design, its rating) for the designs that have a rating."""
    out = {}
    for i, (label, res) in enumerate(designs.items()):
        r = rating_of(res)
        if r is not None:
            out[label] = (i, r)
    return out


def _torque_axis(ax: Axes, ratings: Mapping[str, tuple[int, dict]]) -> None:
    """The pinion torque axis from 0 to the largest torque rated, and a dotted line at each nominal
    torque (naming the designs when they differ)."""
    tmax = max(float(t["torque_Nm"]) for _, r in ratings.values() for t in r["torques"])
    ax.set_xlim(0, 1.05 * tmax)
    noms: dict[float, list[str]] = {}
    for label, (_, r) in ratings.items():
        noms.setdefault(round(float(r["nominal"]["torque_Nm"]), 9), []).append(label)
    for t, labs in noms.items():
        who = "" if len(noms) == 1 else f" ({', '.join(labs)})"
        ax.axvline(t, color="0.5", ls=":", lw=1, label=f"nominal {number(t)} N m{who}")
    ax.set_xlabel("pinion torque [N m]")


def _design_text(label: str, r: dict, used: bool = True) -> str:
    """``label: <misalignment>[, <load factors> load factors]`` for a legend."""
    mis = r.get("misalignment_text") or case_name(r.get("misalignment"))
    if not used:
        return f"{label}: {mis}"
    return f"{label}: {mis}, {_METHOD.get(r.get('load_factors_used'), r.get('load_factors_used'))} factors"


def plot_safety(designs: Mapping[str, dict], sym: str = "S_H", ax: Axes | None = None) -> Axes:
    """Pitting (``sym="S_H"``) or bending (``"S_F"``) safety factor of pinion (solid) and gear
    (dashed) against the pinion torque [N m] of every design with an ISO 6336 rating
    (:func:`rating_of`), one colour per design, with the load factors each design's safety factors
    use (``load_factors_used``, in the legend) and the minimum safety factor(s) (``S_Hmin``,
    ``S_Fmin``) as horizontal lines; logarithmic axis as in :func:`gearopt.plot.rating.plot_safety_vs_torque`.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    if sym not in ("S_H", "S_F"):
        raise ValueError(f"sym = {sym!r}: expected 'S_H' or 'S_F'")
    ax = ax or plt.figure().gca()
    ratings = _ratings(designs)
    lo, hi = math.inf, 0.0
    for label, (i, r) in ratings.items():
        used = r["load_factors_used"]
        T = _f([t["torque_Nm"] for t in r["torques"]])
        for m, ls in ((0, "-"), (1, "--")):
            y = _f([t[sym][used][m] for t in r["torques"]])
            ax.plot(T, y, ls=ls, marker="o" if m == 0 else "s", ms=4, color=design_color(i), lw=_lw(i),
                    label=_design_text(label, r) if m == 0 else None)
            if np.isfinite(y).any():
                lo, hi = min(lo, float(np.nanmin(y))), max(hi, float(np.nanmax(y)))
    mins: dict[float, list[str]] = {}
    for label, (_, r) in ratings.items():
        mins.setdefault(float(r["options"][f"{sym}min"]), []).append(label)
    for k, (v, labs) in enumerate(sorted(mins.items())):
        who = "" if len(mins) == 1 else f" ({', '.join(labs)})"
        ax.axhline(v, color="0.25", ls=("-.", (0, (1, 1)))[k % 2], lw=1.3, label=f"{sym}min = {v:g}{who}")
        lo, hi = min(lo, v), max(hi, v)
    ax.plot([], [], "k-", marker="o", ms=4, label="solid: pinion")
    ax.plot([], [], "k--", marker="s", ms=4, label="dashed: gear")
    if ratings:
        _torque_axis(ax, ratings)
    mode = "pitting" if sym == "S_H" else "bending"
    ax.set_yscale("log")  # S near 1 and of several, both readable
    if hi > 0:
        ax.set_ylim(0.85 * lo, 1.3 * hi)
    ax.yaxis.set_major_locator(FixedLocator(list(_SAFETY_TICKS)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_ylabel(f"{mode} safety {sym} [-] (log scale)")
    ax.set_title(f"{mode} safety {sym} against torque (ISO 6336-{2 if sym == 'S_H' else 3})", fontsize=9)
    ax.grid(alpha=0.3)
    ax.xaxis.get_major_formatter().set_useOffset(False)
    _legend(ax)
    return ax


def plot_rating_factor(designs: Mapping[str, dict], sym: str = "K_Hbeta", ax: Axes | None = None) -> Axes:
    """The face (``sym="K_Hbeta"``) or transverse (``"K_Halpha"``) load factor against the pinion
    torque [N m] by both methods, gearopt's loaded TCA (solid) and ISO 6336-1 method B (dashed), of
    every design with an ISO 6336 rating, one colour per design."""
    import matplotlib.pyplot as plt

    if sym not in ("K_Hbeta", "K_Halpha"):
        raise ValueError(f"sym = {sym!r}: expected 'K_Hbeta' or 'K_Halpha'")
    ax = ax or plt.figure().gca()
    ratings = _ratings(designs)
    top = 1.0
    for label, (i, r) in ratings.items():
        T = _f([t["torque_Nm"] for t in r["torques"]])
        for method, ls, mk in (("ltca", "-", "o"), ("iso", "--", "s")):
            y = _f([t[sym][method] for t in r["torques"]])
            ax.plot(T, y, ls=ls, marker=mk, ms=4, color=design_color(i), lw=_lw(i),
                    label=_design_text(label, r, used=False) if method == "ltca" else None)
            if np.isfinite(y).any():
                top = max(top, float(np.nanmax(y)))
    ax.plot([], [], "k-", marker="o", ms=4, label=f"solid: {_METHOD['ltca']}")
    ax.plot([], [], "k--", marker="s", ms=4, label=f"dashed: {_METHOD['iso']} method B")
    if ratings:
        _torque_axis(ax, ratings)
    ax.set_ylim(0.95, 1 + 1.15 * (top - 1) + 0.05)
    what = "face load factor" if sym == "K_Hbeta" else "transverse load factor"
    ax.set_ylabel(f"{what} {sym} [-]")
    ax.set_title(f"{what} {sym} against torque, both methods", fontsize=9)
    ax.grid(alpha=0.3)
    _legend(ax)
    plain_ticks(ax)
    return ax


def plot_rating_spectrum(designs: Mapping[str, dict], quantity: str = "damage", ax: Axes | None = None) -> Axes:
    """The load-spectrum result (ISO 6336-6) of every design with a spectrum, per mode and member
    (pitting pinion, pitting gear, bending pinion, bending gear) as grouped bars, one colour per
    design, each bar's value written on it: ``quantity="damage"`` the Miner damage sums D [-]
    (0: no bin above the S-N line's endurance level), ``"safety"`` the safety factors against the
    spectrum S [-] with the designs' S_Hmin / S_Fmin marked over their groups."""
    import matplotlib.pyplot as plt

    if quantity not in ("damage", "safety"):
        raise ValueError(f"quantity = {quantity!r}: expected 'damage' or 'safety'")
    ax = ax or plt.figure().gca()
    groups = [("pitting", 0), ("pitting", 1), ("bending", 0), ("bending", 1)]
    shown = [(lab, i, r) for lab, (i, r) in _ratings(designs).items() if r.get("spectrum")]
    w = 0.8 / max(len(shown), 1)
    x = np.arange(len(groups))
    top = 0.0
    for slot, (label, i, r) in enumerate(shown):
        sp = r["spectrum"][quantity]
        h = np.array([np.nan if sp[mode][m] is None else float(sp[mode][m]) for mode, m in groups], float)
        bars = ax.bar(x - 0.4 + w * (slot + 0.5), np.nan_to_num(h), width=w, color=design_color(i), label=label)
        for bar, v in zip(bars, h):
            text = "n/a" if not math.isfinite(v) else ("0" if v == 0 else number(v, 3))
            ax.annotate(text, (bar.get_x() + bar.get_width() / 2, max(np.nan_to_num(v), 0.0)), ha="center",
                        va="bottom", fontsize=7, xytext=(0, 2), textcoords="offset points")
        top = max(top, float(np.nanmax(h)) if np.isfinite(h).any() else 0.0)
    if quantity == "safety":  # each design's minimum over its own bars
        for slot, (_label, _i, r) in enumerate(shown):
            for g, (mode, _m) in enumerate(groups):
                v = float(r["options"]["S_Hmin" if mode == "pitting" else "S_Fmin"])
                xb = x[g] - 0.4 + w * slot
                ax.plot([xb, xb + w], [v, v], color="0.15", lw=1.6,
                        label="minimum safety S_Hmin, S_Fmin" if slot == 0 and g == 0 else None)
                top = max(top, v)
    ax.set_xticks(x, [f"{mode}\n{('pinion', 'gear')[m]}" for mode, m in groups], fontsize=8)
    if quantity == "damage":
        ax.set_ylabel("Miner damage sum D [-] (1: end of life)")
        ax.set_title("damage sums against the load spectrum (ISO 6336-6)", fontsize=9)
    else:
        ax.set_ylabel("safety against the load spectrum S [-]")
        ax.set_title("safety factors against the load spectrum (ISO 6336-6)", fontsize=9)
    ax.set_ylim(0, 1.2 * top if top > 0 else 1.0)
    ax.grid(alpha=0.3, axis="y")
    handles, names = ax.get_legend_handles_labels()
    if handles:  # the designs first, then the minimum line
        order = sorted(range(len(names)), key=lambda k: names[k].startswith("minimum"))
        ax.legend([handles[k] for k in order], [names[k] for k in order],
                  **{**_BELOW, "bbox_to_anchor": (0.5, -0.25), "ncol": len(shown) + 1})
    plain_ticks(ax)
    return ax


def _grid(n: int, width: float = 5.2, height: float = 4.2, ncols: int = 3):
    import matplotlib.pyplot as plt

    cols = min(n, ncols)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows + 0.6 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, list(axes.flat[:n])


def comparison_figures(designs: Mapping[str, dict], samples: Mapping[str, Mapping[str, np.ndarray]] | None = None
                       ) -> list[tuple[str, str, Any]]:
    """Every comparison figure the designs have data for (not saved; :func:`save_figures` saves them).

    A figure is drawn when at least two designs have its quantity (a design without it is named in
    the panel titles or left out of the legend).

    Parameters
    ----------
    designs : mapping label -> results dict
    samples : mapping label -> {column: values}, optional
        The samples tables of Monte Carlo / sweep designs (for the distributions).

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
        Each with a one-line caption saying what to read from it.
    """
    out: list[tuple[str, str, Any]] = []
    labels = list(designs)
    per = {lab: te_cases(r) for lab, r in designs.items()}
    groups = [g for g in match_cases(per) if len(g[2]) >= 2]
    if groups:
        ylim = te_range(designs)
        fig, axes = _grid(len(groups))
        for ax, (key, _, _) in zip(axes, groups):
            plot_te(designs, key, ax=ax, ylim=ylim)
        fig.suptitle("unloaded transmission error, one panel per misalignment case, same TE scale", fontsize=10)
        out.append(("compare_te.png",
                    "Unloaded TE of each design per misalignment case, on one TE scale: compare the peak-to-peak "
                    "(in the legend), the parabola's level and where the transfers (the corners) lie.", fig))
    paths = [g for g in groups if sum(contact_path(c) is not None for c in g[2].values()) >= 2]
    if paths:
        fig, axes = _grid(len(paths))
        for ax, (key, _, _) in zip(axes, paths):
            plot_contact_paths(designs, key, ax=ax)
        fig.suptitle("paths of contact on the pinion flank (same flank frame)", fontsize=10)
        out.append(("compare_contact.png",
                    "Paths of contact of the central pair on the pinion flank, per case: how far the bearing "
                    "contact moves along the face under misalignment and how close it comes to a face end or the tip.",
                    fig))
    loaded = _first_loaded(designs)
    if len(loaded) >= 2:
        fig, axes = _grid(4, width=5.6, ncols=2)
        plot_loaded_te(designs, ax=axes[0])
        plot_te_vs_torque(designs, ax=axes[1])
        plot_pressure_vs_torque(designs, ax=axes[2])
        plot_load_sharing(designs, ax=axes[3])
        fig.suptitle("loaded TCA (a misalignment case all designs have, else the first of each)", fontsize=10)
        out.append(("compare_loaded.png",
                    "Loaded TE at the nominal torque, TE peak-to-peak and peak flank pressure against torque, load "
                    "share of the central pair: which design runs quieter and with less pressure over the duty range.", fig))
        top = pattern_vmax(designs)
        from .ltca import plot_contact_pattern

        names = [lab for lab in labels if lab in loaded]
        fig, axes = _grid(len(names), width=5.6, height=4.6)
        for ax, lab in zip(axes, names):
            plot_contact_pattern(loaded[lab], "pinion", ax=ax, vmax=top, what=lab)
        fig.suptitle(f"loaded contact pattern, one colour scale 0 ... {number(top or 0.0)} MPa", fontsize=10)
        out.append(("compare_pattern.png",
                    "Loaded contact pattern on the pinion flank at each design's nominal torque, on one pressure "
                    "scale: where the load sits on the flank and whether it reaches a face end or the tip.", fig))
    mc = {lab: s for lab, s in (samples or {}).items() if s}
    if len(mc) >= 2:
        cols = [c for c in ("te_p2p_arcsec", "h1_arcsec", "loaded_te_p2p_arcsec", "p_max_MPa")
                if sum(np.isfinite(np.asarray(s.get(c, []), float)).any() for s in mc.values()) >= 2]
        text = {"te_p2p_arcsec": "TE peak-to-peak [arcsec]", "h1_arcsec": "1st mesh harmonic of TE [arcsec]",
                "loaded_te_p2p_arcsec": "loaded TE peak-to-peak [arcsec]", "p_max_MPa": "peak flank pressure [MPa]"}
        if cols:
            fig, axes = _grid(len(cols), ncols=2, width=5.6)
            for ax, c in zip(axes, cols):
                plot_distribution(mc, c, ax=ax, xlabel=text[c])
            fig.suptitle("Monte Carlo / sweep distributions", fontsize=10)
            out.append(("compare_distribution.png",
                        "Cumulative distributions over the samples: a curve further left is the better design; "
                        "the median and 95th percentile of each are in the legend.", fig))
    if sum(fea_positions(r) is not None for r in designs.values()) >= 2:
        fig, axes = _grid(3, width=5.2)
        for ax, q in zip(axes, ("te", "p_max", "root")):
            plot_fea(designs, q, ax=ax)
        fig.suptitle("finite element model (CalculiX) per position", fontsize=10)
        out.append(("compare_fea.png",
                    "FE loaded TE, contact pressure and root stress per position: the stiffer, less loaded design at "
                    "each position (the torques are in the legends).", fig))
    if sum(bool(crowning_amounts(r)) for r in designs.values()) >= 2:
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(6.4, 4.4))
        plot_crowning(designs, ax=fig.gca())
        out.append(("compare_crowning.png",
                    "The pinion's crowning and slopes of each design in ISO 21771 terms [um], as a drawing states them.", fig))
    if len(_ratings(designs)) >= 2:
        fig, axes = _grid(4, width=5.6, height=4.6, ncols=2)
        plot_safety(designs, "S_H", ax=axes[0])
        plot_safety(designs, "S_F", ax=axes[1])
        plot_rating_factor(designs, "K_Hbeta", ax=axes[2])
        plot_rating_factor(designs, "K_Halpha", ax=axes[3])
        fig.suptitle("ISO 6336 rating: safety factors with the load factors each design uses; both methods' "
                     "load factors", fontsize=10)
        out.append(("compare_rating.png",
                    "Pitting and bending safety of pinion (solid) and gear (dashed) against torque with the minimum "
                    "safety lines, and K_Hbeta, K_Halpha by gearopt's loaded TCA and by ISO 6336-1: where each design "
                    "falls below its minimum and how much of the difference the face load factor makes.", fig))
        if sum(bool(r.get("spectrum")) for _, r in _ratings(designs).values()) >= 2:
            fig, axes = _grid(2, width=5.6, height=4.6, ncols=2)
            plot_rating_spectrum(designs, "damage", ax=axes[0])
            plot_rating_spectrum(designs, "safety", ax=axes[1])
            fig.suptitle("ISO 6336 rating against the load spectrum (Miner's rule, ISO 6336-6)", fontsize=10)
            out.append(("compare_rating_spectrum.png",
                        "Miner damage sums and safety factors against each design's load spectrum per mode and member: "
                        "the lower damage and the higher safety is the better design (0: no bin above the endurance "
                        "level).", fig))
    dyn = {lab: r for lab, r in designs.items() if r.get("study") == "dynamics" and r.get("cases")}
    if len(dyn) >= 2:
        from .dynamics import plot_compare_dynamic_factor

        names = list(dict.fromkeys(c["name"] for r in dyn.values() for c in r["cases"]))
        names = [n for n in names if sum(any(c["name"] == n for c in r["cases"]) for r in dyn.values()) >= 2]
        if names:
            fig, axes = _grid(len(names), width=7.0, height=5.0, ncols=2)
            for ax, n in zip(axes, names):
                plot_compare_dynamic_factor(dyn, n, ax=ax)
            fig.suptitle("gear dynamics: dynamic factor against pinion speed, one panel per case", fontsize=10)
            out.append(("compare_dynamics.png",
                        "Dynamic factor K_v of each design against pinion speed, per case, with each design's ISO "
                        "n_E1: which design resonates where, how high K_v rises there and from which speed its teeth "
                        "lose contact (x).", fig))
    return out


def save_figures(designs: Mapping[str, dict], directory: Any, samples: Mapping[str, Mapping[str, np.ndarray]] | None = None,
                 dpi: int = 120) -> list[tuple[str, str]]:
    """Draw every comparison figure (:func:`comparison_figures`) into ``directory`` as PNG.

    Returns
    -------
    list of (file name, caption)
    """
    import matplotlib.pyplot as plt
    from pathlib import Path

    out = []
    for name, caption, fig in comparison_figures(designs, samples):
        fig.tight_layout()
        fig.savefig(Path(directory) / name, dpi=dpi)
        plt.close(fig)
        out.append((name, caption))
    return out
