"""Plots of FE study results (read ``FEReport.to_dict()`` only; ``ax=`` in, Axes out)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .style import axes_or_new

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def plot_mesh(report: dict, ax: Axes | None = None, zoom: bool = False) -> Axes:
    """Element edges of the model's middle transverse section (S_f) at the first analysed position,
    with the TCA contact points; ``zoom`` frames the loaded contact (a few Hertz widths)."""
    from matplotlib.collections import LineCollection

    ax = axes_or_new(ax)
    m = report["mesh"]
    for name, color in (("pinion", "C0"), ("gear", "C1")):
        seg = np.asarray(m[name], float).reshape(-1, 2, 2)
        ax.add_collection(LineCollection(seg, colors=color, linewidths=0.25 if not zoom else 0.6, label=name))
    cp = np.asarray(m["contact_points"], float).reshape(-1, 2)
    ax.plot(cp[:, 0], cp[:, 1], "r+", ms=10, mew=1.5, label="TCA contact point")
    ax.set_aspect("equal")
    allp = np.vstack([np.asarray(m[n], float).reshape(-1, 2) for n in ("pinion", "gear")])
    if zoom and len(cp):
        w = 12 * m["hertz_b"]
        ax.set_xlim(cp[0, 0] - w, cp[0, 0] + w)
        ax.set_ylim(cp[0, 1] - w, cp[0, 1] + w)
        ax.set_title(f"contact zone (+-{w:.2f} mm; Hertz half-width {m['hertz_b']:.3f} mm)", fontsize=9)
    else:
        ax.set_xlim(allp[:, 0].min() - 1, allp[:, 0].max() + 1)
        ax.set_ylim(allp[:, 1].min() - 1, allp[:, 1].max() + 1)
        p0 = report["positions"][0]
        ax.set_title(f"{report['scene']}: FE mesh, middle section, phi1 = {math.degrees(p0['phi1']):.3f} deg "
                     f"({p0['n_elements']} {p0['element_type']} elements)", fontsize=9)
    ax.set_xlabel("x_f [mm]")
    ax.set_ylabel("y_f [mm]")
    ax.legend(fontsize=7, loc="upper right")
    return ax


def plot_contact_pressure(report: dict, ax: Axes | None = None) -> Axes:
    """Nodal contact pressure along the pinion's driving flank in the section through the contact (mid
    face for line contact; arc length from the TCA
    contact point, positive towards the tip) for every position and loaded pair, with the Hertz
    ellipse p0 sqrt(1 - (s/b)^2) of the full load on one pair."""
    ax = axes_or_new(ax)
    # one colour per curve (position and tooth pair); the marker tells the pair, the colour family
    # the position is not relied on
    markers = ("o", "s", "^", "D", "v")
    curve = 0
    for pos in report["positions"]:
        c = pos["contact"]
        for j, k in enumerate(pos["loaded_pairs"]):
            pr = c["profiles"][str(k)]
            s, p = np.asarray(pr["s"]), np.asarray(pr["p"])
            sel = np.abs(s) <= 6 * c["hertz_b"]
            ax.plot(s[sel], p[sel], "-", marker=markers[j % len(markers)], ms=3.5, lw=1, color=f"C{curve % 10}",
                    label=f"FE, phi1 = {math.degrees(pos['phi1']):.2f} deg, tooth pair {int(k):+d}")
            curve += 1
        if pos["single_pair_contact"]:
            b, p0 = c["hertz_b"], c["hertz_p0"]
            t = np.linspace(-b, b, 101)
            ax.plot(t, p0 * np.sqrt(np.clip(1 - (t / b) ** 2, 0, None)), "--", color="k", lw=1,
                    label=f"Hertz, phi1 = {math.degrees(pos['phi1']):.2f} deg: p0 = {p0:.0f} MPa "
                          f"(FE/Hertz {c['ratio_mid_to_hertz']:.3f})")
    ax.set_xlabel("distance along the profile from the contact point [mm]")
    ax.set_ylabel("contact pressure [MPa]")
    ax.set_title("contact pressure on the pinion flank, section through the contact", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def _positions_note(n: int) -> str:
    return (f"FE at {n} pinion angles: points, not a curve\n(nothing is computed between them)" if n < 8
            else f"FE at {n} pinion angles")


def plot_root_stress(report: dict, ax: Axes | None = None) -> Axes:
    """Maximum principal stress in the loaded-side root fillets (mid face) of pinion and gear at each
    analysed pinion angle, with the ISO 6336-3 (method B geometry) estimate at each position and the
    max contact pressure on a second axis; markers only (the FE gives values at the analysed angles
    alone), the legend below the axes."""
    ax = axes_or_new(ax)
    pos = report["positions"]
    phi = np.degrees([p["phi1"] for p in pos])
    for member, col in (("pinion", "C0"), ("gear", "C1")):
        ax.plot(phi, [p["root"][member]["max_principal_mid"] for p in pos], "o", color=col, ms=7,
                label=f"{member} FE")
        # the estimate puts the whole load on one pair: shown at single-pair positions only
        iso = [p["root_estimate"][member].get("sigma_iso", np.nan) if p["single_pair_contact"] else np.nan
               for p in pos]
        if np.isfinite(np.asarray(iso, float)).any():
            ax.plot(phi, iso, "s", color=col, mfc="none", ms=9,
                    label=f"{member} ISO 6336-3 (single-pair positions, load at the position)")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("root stress, max principal [MPa]")
    ax2 = ax.twinx()
    ax2.plot(phi, [p["contact"]["p_max_mid"] for p in pos], "^", color="C3", ms=7, label="max contact pressure (right axis)")
    ax2.set_ylabel("contact pressure [MPa]", color="C3")
    ax.set_title("root stress and contact pressure at the analysed positions (mid face)", fontsize=9)
    ax.grid(alpha=0.3)
    _pad_x(ax, phi)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2,
              title=_positions_note(len(pos)), title_fontsize=7)
    return ax


def _pad_x(ax, x):
    """x limits a little beyond the points (markers at the ends drawn whole)."""
    x = np.asarray(x, float)
    w = max(float(np.ptp(x)), 1e-6)
    ax.set_xlim(float(x.min()) - 0.08 * w, float(x.max()) + 0.08 * w)


def plot_loaded_te(report: dict, ax: Axes | None = None) -> Axes:
    """Loaded transmission error [arcsec] from the FE solutions (pinion rotation under the torque,
    gear rim fixed) at each analysed pinion angle [deg], markers only (not a TE curve: nothing is
    computed between the positions); positive: the gear ahead of its conjugate position (the pinion
    lags under load: negative)."""
    ax = axes_or_new(ax)
    pos = report["positions"]
    phi = np.degrees([p["phi1"] for p in pos])
    te = np.array([np.nan if p.get("loaded_te_arcsec") is None else p["loaded_te_arcsec"] for p in pos], float)
    single = np.array([bool(p["single_pair_contact"]) for p in pos])
    ax.plot(phi[single], te[single], "o", color="C3", ms=8, label="loaded TE (FE), one tooth pair in contact")
    ax.plot(phi[~single], te[~single], "s", color="C0", ms=8, label="loaded TE (FE), two or more pairs in contact")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("loaded TE [arcsec] (+: gear ahead)")
    ax.set_title("loaded transmission error from the FE model at the analysed positions", fontsize=9)
    ax.grid(alpha=0.3)
    if phi.size:
        _pad_x(ax, phi)
    h, lab = ax.get_legend_handles_labels()
    keep = [(hh, ll) for hh, ll in zip(h, lab) if np.isfinite(np.asarray(hh.get_xydata(), float)).all(axis=1).any()]
    if keep:
        ax.legend(*zip(*keep), fontsize=7, title=_positions_note(len(pos)), title_fontsize=7)
    return ax


def plot_line_load(report: dict, ax: Axes | None = None) -> Axes:
    """The FE contact pattern across the face: normal load per mm of face [N/mm] of every loaded
    tooth pair against the face coordinate z [mm] (nodal pressure integrated over the pinion flank
    between two face layers, scaled to the pair's contact force: one step per strip, marked at its
    middle), its centre marked, the face ends dashed."""
    ax = axes_or_new(ax)
    markers = ("o", "s", "^", "D", "v")
    curve = 0
    for pos in report["positions"]:
        pat = pos["contact"].get("pattern") or {}
        for j, k in enumerate(pos["loaded_pairs"]):
            pt = pat.get(str(k))
            if not pt or not pt["force"]:
                continue
            color = f"C{curve % 10}"
            # the load of each strip between two face layers is its mean over the strip: steps
            ax.stairs(pt["q"], pt["z_layers"], color=color, lw=1.2, baseline=None)
            ax.plot(pt["z"], pt["q"], ls="none", marker=markers[j % len(markers)], ms=4, color=color,
                    label=f"phi1 = {math.degrees(pos['phi1']):.2f} deg, pair {int(k):+d}: {pt['force']:.0f} N, "
                          f"centre z = {round(pt['z_centroid'], 2) + 0.0:+.2f} mm")
            ax.axvline(pt["z_centroid"], color=color, lw=0.8, ls=":")
            curve += 1
    half = 0.5 * report["pair"]["b1"]
    for z in (-half, half):
        ax.axvline(z, color="k", lw=0.8, ls="--")
    ax.set_xlim(-1.08 * half, 1.08 * half)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("face coordinate z [mm] (pinion; dashed: face ends)")
    ax.set_ylabel("load per mm of face [N/mm]")
    mis = report["options"].get("misalignment") or {}
    lab = ", ".join(f"{k.rsplit('_', 1)[0]} {v:+g} {'arcmin' if k.endswith('arcmin') else 'mm'}"
                    for k, v in mis.items() if v)
    strips = _strips(report)
    res = ""
    if strips:
        n, w, uniform = strips
        res = f"; {n} element{'s' if n > 1 else ''} across the face ({'' if uniform else 'up to '}{w:.3g} mm" \
              f"{' each' if uniform else ''})"
        if n <= 4:
            ax.text(0.5, 0.04, f"the FE mesh has {n} element{'s' if n > 1 else ''} across the face: each step is one "
                    "element's mean load,\nthe distribution within an element is not resolved (finer: [fea] n_face)",
                    transform=ax.transAxes, ha="center", va="bottom", fontsize=7,
                    bbox=dict(boxstyle="round", fc="white", ec="0.6"))
    ax.set_title(f"FE contact pattern across the face ({lab or 'aligned'}{res})", fontsize=9)
    ax.grid(alpha=0.3)
    if curve:
        ax.set_ylim(top=1.45 * ax.get_ylim()[1])  # room for the legend above the steps
        ax.legend(fontsize=7, loc="upper center", ncol=2)
    return ax


def _strips(report: dict):
    """(number, largest width [mm], all widths equal) of the face strips (elements across the face)
    of the first loaded pattern, or None."""
    for pos in report["positions"]:
        for pt in ((pos.get("contact") or {}).get("pattern") or {}).values():
            zl = np.asarray(pt.get("z_layers") or [], float)
            if zl.size >= 2:
                w = np.diff(zl)
                return zl.size - 1, float(np.max(w)), bool(np.ptp(w) <= 1e-6 * np.max(w))
    return None
