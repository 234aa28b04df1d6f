"""Comparison of the unloaded drive (:mod:`gearopt.plot.compare`): the actual unloaded TE per
misalignment case, the paths of contact on the pinion flank and the pinion's crowning in ISO 21771
terms, of designs of any study that has them.

The ``te_cases`` / ``contact_path`` / ``crowning_amounts`` helpers pick the quantity out of the
results of any study (``tca``: ``cases``; ``crowning``: the optimised drive ``after``; ``ltca``: the
unloaded slices of the drive itself; ``loaded_microgeometry``: the optimum ``after``) and return
``None`` or ``[]`` when a design has no such quantity.

Units: TE in arcsec (positive when the gear is ahead), pinion angle in deg, flank positions in mm,
micro-geometry amounts in um.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ...report import CONJUGATE_ARCSEC  # the results' own threshold (``conjugate`` in results.json)
from ..style import number
from ..ticks import plain_ticks
from .common import (
    case_name, case_style, design_color, floats, legend_below, line_width, match_cases, panel_grid,
)

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from matplotlib.axes import Axes

__all__ = ["CROWNING_AMOUNTS", "te_cases", "contact_path", "crowning_amounts", "plot_te", "te_range",
           "plot_contact_paths", "plot_crowning", "te_figures", "crowning_figures"]

#: the pinion's micro-geometry amounts compared by :func:`plot_crowning` (ISO 21771 names)
CROWNING_AMOUNTS = ("C_alpha", "f_H_alpha", "C_beta", "f_H_beta")
_AMOUNT_TEXT = {"C_alpha": "profile crowning\n$C_\\alpha$", "f_H_alpha": "profile slope\n$f_{H\\alpha}$",
                "C_beta": "lead crowning\n$C_\\beta$", "f_H_beta": "helix slope\n$f_{H\\beta}$"}


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


def contact_path(case: dict, member: str = "pinion") -> tuple[np.ndarray, np.ndarray] | None:
    """The central pair's path of contact on ``member``'s flank where it lies on the active flank:
    axial position z [mm] and radius [mm] (NaN elsewhere); the surface path of an edge-contact case;
    None when the case has no path (a loaded TCA case)."""
    if member in case and isinstance(case[member], dict) and "axial" in case[member]:
        on = np.array(case.get("on_surface") or [True] * len(case[member]["axial"]), bool)
        z, r = floats(case[member]["axial"]), floats(case[member]["radius"])
        return np.where(on, z, np.nan), np.where(on, r, np.nan)
    paths = case.get("paths_central_pair") or {}
    surf = paths.get("surface")
    if surf and member in surf:
        z, r = floats(surf[member]["axial"]), floats(surf[member]["radius"])
        return z, r
    return None


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
        phi = np.degrees(floats(c["phi1"]))
        te = np.zeros_like(phi) if c.get("conjugate") else floats(c["te_envelope_arcsec"])
        pp = "conjugate, TE = 0" if c.get("conjugate") else f"p-p {number(c['peak_to_peak_arcsec'])} arcsec"
        ax.plot(phi, te, color=design_color(i), ls=case_style(j), lw=line_width(i), label=f"{label}: {pp}")
    missing = [lab for lab in designs if lab not in by]
    ax.set_title(name + (f"\n(not in {', '.join(missing)})" if missing else ""), fontsize=9)
    ax.set_xlabel("pinion angle phi1 [deg]")
    from ..tca import te_zero_text

    zeros = sorted({te_zero_text(c) for c in by.values()}) or ["zero: pair 0 at phi1 = 0"]
    zero = zeros[0] if len(zeros) == 1 else "zero: pair 0 at phi1 = 0, or the aligned conjugate drive (edge contact)"
    ax.set_ylabel(f"actual TE [arcsec] (+: gear ahead)\n{zero}")
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.grid(alpha=0.3)
    legend_below(ax)
    plain_ticks(ax)
    return ax


def te_range(designs: Mapping[str, dict]) -> tuple[float, float] | None:
    """The TE range [arcsec] that holds every design's actual TE of every case, with a margin;
    None without any TE."""
    vals = [floats(c["te_envelope_arcsec"]) for r in designs.values() for c in te_cases(r) if not c.get("conjugate")]
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
        ax.plot(path[0], path[1], color=design_color(i), ls=case_style(j), lw=line_width(i),
                label=label + (f" (on {same[0]}'s path)" if same else ""))
        seen.append((label, path))
        drawn.append(label)
    missing = [lab for lab in designs if lab not in drawn]
    ax.set_title(f"{member} flank, {name}" + (f"\n(no path: {', '.join(missing)})" if missing else ""), fontsize=9)
    ax.set_xlabel("axial position z [mm]")
    ax.set_ylabel(f"{member} radius [mm]")
    ax.grid(alpha=0.3)
    legend_below(ax, ncol=2)
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
    legend_below(ax, bbox_to_anchor=(0.5, -0.25), ncol=2)
    plain_ticks(ax)
    return ax


def te_figures(designs: Mapping[str, dict]) -> list[tuple[str, str, Any]]:
    """The unloaded TE figure (``compare_te.png``: one panel per misalignment case two designs or
    more have, one TE scale) and the paths of contact (``compare_contact.png``: the cases where two
    designs or more have a path), when the designs have them.

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    per = {lab: te_cases(r) for lab, r in designs.items()}
    groups = [g for g in match_cases(per) if len(g[2]) >= 2]
    if groups:
        ylim = te_range(designs)
        fig, axes = panel_grid(len(groups))
        for ax, (key, _, _) in zip(axes, groups):
            plot_te(designs, key, ax=ax, ylim=ylim)
        fig.suptitle("unloaded transmission error, one panel per misalignment case, same TE scale", fontsize=10)
        out.append(("compare_te.png",
                    "Unloaded TE of each design per misalignment case, on one TE scale: compare the peak-to-peak "
                    "(in the legend), the parabola's level and where the transfers (the corners) lie.", fig))
    paths = [g for g in groups if sum(contact_path(c) is not None for c in g[2].values()) >= 2]
    if paths:
        fig, axes = panel_grid(len(paths))
        for ax, (key, _, _) in zip(axes, paths):
            plot_contact_paths(designs, key, ax=ax)
        fig.suptitle("paths of contact on the pinion flank (same flank frame)", fontsize=10)
        out.append(("compare_contact.png",
                    "Paths of contact of the central pair on the pinion flank, per case: how far the bearing "
                    "contact moves along the face under misalignment and how close it comes to a face end or the tip.",
                    fig))
    return out


def crowning_figures(designs: Mapping[str, dict]) -> list[tuple[str, str, Any]]:
    """The pinion's crowning in ISO 21771 terms (``compare_crowning.png``) when two designs or more
    state it (:func:`crowning_amounts`).

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    if sum(bool(crowning_amounts(r)) for r in designs.values()) >= 2:
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(6.4, 4.4))
        plot_crowning(designs, ax=fig.gca())
        out.append(("compare_crowning.png",
                    "The pinion's crowning and slopes of each design in ISO 21771 terms [um], as a drawing states them.", fig))
    return out
