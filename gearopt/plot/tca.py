"""Plots of TCA results (transmission errors, bearing contact). They read the JSON-able case
dicts of a TCA report (``report.to_dict()["cases"][i]``), take ``ax=`` and return the Axes.

Conventions: TE in arcsec, positive when the gear is ahead of its conjugate position (docs/theory.md
section 1); flank maps show the axial position z [mm] against the transverse radius [mm] in the
member's own frame. A conjugate drive (peak-to-peak TE at round-off level, below
:data:`CONJUGATE_ARCSEC`) is drawn as "conjugate: TE = 0", without per-pair curves or transfers.
Legends list only what is drawn, once.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..report import CONJUGATE_ARCSEC  # the results' own threshold (``conjugate`` in results.json)
from .style import axes_or_new
from .ticks import plain_ticks

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.legend import Legend

#: Readable names and distinct colours of the contact features (edge branches) of
#: :mod:`gearopt.contact.edge`.
BRANCH_NAMES = {
    "surface": "surface contact",
    "pinion_tip": "pinion tip edge", "gear_tip": "gear tip edge",
    "pinion_face+": "pinion face end z = +b/2", "pinion_face-": "pinion face end z = -b/2",
    "gear_face+": "gear face end z = +b/2", "gear_face-": "gear face end z = -b/2",
    "pinion_corner+": "pinion tip corner z = +b/2", "pinion_corner-": "pinion tip corner z = -b/2",
    "gear_corner+": "gear tip corner z = +b/2", "gear_corner-": "gear tip corner z = -b/2",
    # edge on edge (gearopt.contact.edge): two boundary curves touching
    "pinion_tip/gear_face+": "pinion tip edge x gear face end z = +b/2",
    "pinion_tip/gear_face-": "pinion tip edge x gear face end z = -b/2",
    "pinion_face+/gear_tip": "pinion face end z = +b/2 x gear tip edge",
    "pinion_face-/gear_tip": "pinion face end z = -b/2 x gear tip edge",
    "pinion_tip/gear_tip": "pinion tip edge x gear tip edge",
}
_BRANCH_COLOR = {"surface": "C3", "pinion_tip": "C0", "gear_tip": "C2", "pinion_face+": "C4", "pinion_face-": "C5",
                 "gear_face+": "C6", "gear_face-": "C8", "pinion_corner+": "C1", "pinion_corner-": "gold",
                 "gear_corner+": "C9", "gear_corner-": "navy", "pinion_tip/gear_face+": "m",
                 "pinion_tip/gear_face-": "darkmagenta", "pinion_face+/gear_tip": "C7", "pinion_face-/gear_tip": "olive",
                 "pinion_tip/gear_tip": "k"}


def _point_like(name: str) -> bool:
    """Features that touch at a point of both flanks (edge on edge, tip corners): they often carry
    the load at single positions only, so they are drawn with markers."""
    return "/" in name or "corner" in name
_LINESTYLES = ("-", "--", ":", "-.")
_BELOW = dict(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=3, frameon=False)  # legend under the axes


def _f(v):
    return np.array([np.nan if x is None else x for x in v], dtype=float)


def branch_label(name: str) -> str:
    """Readable name of a contact feature (``"pinion_face-"`` -> ``"pinion face end z = -b/2"``)."""
    return BRANCH_NAMES.get(name, name.replace("_", " "))


def _axial(m: dict):
    return _f(m["axial"])


def is_conjugate(case: dict) -> bool:
    """True when the case's actual TE is zero up to round-off (a conjugate drive): its
    ``conjugate`` key (peak-to-peak below :data:`CONJUGATE_ARCSEC`)."""
    return bool(case["conjugate"])


def misalignment_text(case: dict) -> str:
    """The case's misalignment in words ("crossing 3 arcmin, dE 0.05 mm"), "" when aligned."""
    m = case["misalignment"]
    unit = {}
    for k in m:  # every kind is "<kind>_mm" or "<kind>_arcmin" (Misalignment.to_results)
        for suffix in ("_mm", "_arcmin"):
            if k.endswith(suffix):
                unit[k] = (k[:-len(suffix)], suffix[1:])
    return ", ".join(f"{unit.get(k, (k, ''))[0]} {v:+g} {unit.get(k, ('', ''))[1]}".rstrip() for k, v in m.items() if v)


def case_title(case: dict) -> str:
    """The case label, with the misalignment when the label does not already say it."""
    label = str(case["label"])
    mis = misalignment_text(case)
    if not mis:
        return label if "align" in label.lower() else f"{label} (aligned)"
    return label if label == mis else f"{label} ({mis})"


def legend(ax: Axes, **kw: Any) -> Legend | None:
    """A legend of the labelled artists that show data (finite points), each label once; none if
    nothing is labelled. Returns the Legend or None."""
    handles, labels = ax.get_legend_handles_labels()
    seen, H, L = set(), [], []
    for h, lab in zip(handles, labels):
        if lab in seen or not _draws(h):
            continue
        seen.add(lab)
        H.append(h)
        L.append(lab)
    if not H:
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        return None
    return ax.legend(H, L, **kw)


def _draws(artist) -> bool:
    """True when the artist leaves a visible mark: a line needs two consecutive finite points
    (a segment) unless it has markers; a proxy (gid "legend-proxy") explains a style."""
    if artist.get_gid() == "legend-proxy":
        return True
    if hasattr(artist, "get_xydata"):
        xy = np.asarray(artist.get_xydata(), float)
        ok = np.isfinite(xy).all(axis=1) if xy.size else np.zeros(0, bool)
        if artist.get_marker() not in (None, "None", "", " ", "none"):
            return bool(ok.any())
        return bool(artist.get_linestyle() not in ("None", "", " ", "none") and (ok[1:] & ok[:-1]).any())
    return True


def _transfer_lines(ax, phis_deg):
    for i, t in enumerate(phis_deg):
        ax.axvline(t, color="0.35", lw=0.7, ls=":", label="transfer: the driving tooth pair changes" if i == 0 else None)


def _draw_conjugate(ax, case, phi):
    ax.plot(phi, np.zeros_like(phi), color="C3", lw=2.4, label="conjugate: TE = 0")
    ax.text(0.5, 0.62, f"conjugate: TE = 0\n(computed peak-to-peak {case['peak_to_peak_arcsec']:.1g} arcsec: "
            "round-off)", transform=ax.transAxes, ha="center", va="center", fontsize=9,
            bbox=dict(fc="white", ec="0.6", alpha=0.9))
    ax.set_ylim(-1.0, 1.0)


def te_zero_text(case: dict) -> str:
    """Where the case's TE is zero, for the axis label: pair 0 at phi1 = 0 (the surface TCA's zero),
    or, for an edge-contact analysis without any surface-to-surface contact, the conjugate position
    of the aligned, unmodified drive ("aligned conjugate drive"; ``stats.te_zero_rad`` 0;
    docs/results.md, "TE zero")."""
    st = case.get("stats") or {}
    if case.get("edge_analysis"):
        surf = case.get("te_branches_central_arcsec", {}).get("surface") or []
        no_surface = isinstance(st.get("surface"), str) or not any(v is not None for v in surf)
        if no_surface and not st.get("te_zero_rad"):
            return "zero: aligned conjugate drive"
    return "zero: pair 0 at phi1 = 0"


def te_ylabel(case: dict) -> str:
    """TE axis label with the unit, the sign and the zero of ``case``."""
    return f"TE [arcsec] (+: gear ahead)\n{te_zero_text(case)}"


def pair_label(k: int) -> str:
    """"tooth pair 0", "tooth pair +1", "tooth pair -1"."""
    return f"tooth pair {k:+d}" if k else "tooth pair 0"


def plot_te(case: dict, ax: Axes | None = None, label_pairs: bool = True) -> Axes:
    """TE of every tooth pair (thin dashed, only where its contact lies on the active flanks of
    both members: ``on_surface_pairs``) and the actual TE, their upper envelope (thick) [arcsec]
    against the pinion angle [deg], with the transfer points (where the driving pair changes).
    A conjugate case is drawn as TE = 0. The axis label states the TE zero (:func:`te_zero_text`)."""
    ax = axes_or_new(ax)
    phi = np.degrees(_f(case["phi1"]))
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel(te_ylabel(case))
    ax.grid(alpha=0.3)
    if is_conjugate(case):
        _draw_conjugate(ax, case, phi)
        ax.set_title(f"{case_title(case)}: conjugate, TE = 0", fontsize=9)
        legend(ax, **_BELOW)
        plain_ticks(ax)
        return ax
    env = _f(case["te_envelope_arcsec"])
    finite = env[np.isfinite(env)]
    lo, hi = -np.inf, np.inf
    if finite.size:
        pad = 0.6 * max(finite.max() - finite.min(), 1e-3)
        lo, hi = finite.min() - pad, finite.max() + 0.3 * pad
        ax.set_ylim(lo, hi)
    for i, (k, te) in enumerate(zip(case["pairs"], pair_te_on_flank(case))):
        if not np.any((te >= lo) & (te <= hi)):
            continue  # this pair's TE lies outside the range shown (far from the envelope)
        ax.plot(phi, te, lw=0.9, ls="--", alpha=0.8, color=f"C{i % 10}",
                label=pair_label(k) if label_pairs else None)
    ax.plot(phi, env, color="k", lw=2.2, label="actual TE (envelope)")
    _transfer_lines(ax, np.degrees(case.get("transfer_phi1", [])))
    ok = "" if case["actual_te_at_every_position"] else "  (some positions without contact)"
    ax.set_title(f"{case_title(case)}: peak-to-peak {case['peak_to_peak_arcsec']:.2f} arcsec{ok}", fontsize=9)
    legend(ax, **_BELOW)
    plain_ticks(ax)
    return ax


def pair_te_on_flank(case: dict) -> list:
    """Every pair's TE [arcsec] (arrays in the order of ``case["pairs"]``), NaN where that pair has
    no contact on the active flanks: not converged, or converged outside them
    (``on_surface_pairs`` false; such a point transmits nothing). Without ``on_surface_pairs``
    (older results) a point above the actual TE is left out too: a contact on the flanks there
    would have been the actual TE."""
    env = _f(case["te_envelope_arcsec"])
    flags = case.get("on_surface_pairs")
    out = []
    for i, te in enumerate(case["te_arcsec"]):
        te = _f(te)
        if flags is not None:
            te = np.where(np.array(flags[i], bool), te, np.nan)
        else:
            with np.errstate(invalid="ignore"):
                te = np.where(te > env + 1e-6, np.nan, te)
        out.append(te)
    return out


def _ellipse_on_map(xyz, dirs, a, b, n=48):
    t = np.linspace(0, 2 * np.pi, n)
    d = np.asarray(dirs).reshape(2, 3)
    P = xyz[None, :] + a * np.cos(t)[:, None] * d[0] + b * np.sin(t)[:, None] * d[1]
    return P[:, 2], np.hypot(P[:, 0], P[:, 1])


def _flank_box(ax, lim, fill=False):
    """The active flank (face width x form-to-tip radii) as a patch; returns it (for clipping)."""
    from matplotlib.patches import Rectangle

    b, ra, rF = lim["b"], lim["r_a"], lim["r_form"]
    # a thin grey frame: contact paths along a face end or the tip circle (edge contact) lie on it
    # and must stay visible over it
    rect = Rectangle((-b / 2, rF), b, ra - rF, fill=fill, fc="0.95", ec="0.55", lw=0.8, zorder=0.5)
    ax.add_patch(rect)
    ax.set_xlim(-0.65 * b, 0.65 * b)
    pad = 0.08 * (ra - rF)
    ax.set_ylim(rF - pad, ra + pad)
    ax.set_xlabel("axial position z [mm]")
    ax.set_ylabel("radius [mm]")
    return rect


def plot_bearing_contact(case: dict, member: str = "gear", ax: Axes | None = None, every: int = 8,
                         ellipses: bool = True) -> Axes:
    """Path of contact of the central tooth pair on the flank map of ``member`` (axial position z
    vs transverse radius), with the tooth boundaries (face ends, form and tip radii) and contact
    ellipses (for the elastic approach ``delta``), clipped to the flank; points off the active
    flank are drawn grey."""
    ax = axes_or_new(ax)
    m = case[member]
    lim = case["limits"][member]
    z, r = _axial(m), _f(m["radius"])
    on = np.array(case["on_surface"], bool)
    b = lim["b"]
    rect = _flank_box(ax, lim, fill=True)
    ax.plot(np.where(on, z, np.nan), np.where(on, r, np.nan), color="C3", lw=2, label="path of contact")
    off = ~on & np.isfinite(z) & np.isfinite(r)
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    with np.errstate(invalid="ignore"):
        vis = off & (z >= x0) & (z <= x1) & (r >= y0) & (r <= y1)
    drawn = bool(np.any(vis[1:] & vis[:-1]))  # a dashed segment needs two neighbouring points in view
    ax.plot(np.where(off, z, np.nan), np.where(off, r, np.nan), color="0.6", lw=1, ls="--",
            label="solution off the active flank" if drawn else None)
    delta = case["delta_mm"]
    if ellipses and "ellipse_dirs" in m:
        xyz = np.array([[np.nan] * 3 if p is None else p for p in m["xyz"]], dtype=float)
        A = _f(case["ellipse_semi_major_mm"])
        B = _f(case["ellipse_semi_minor_mm"])
        dirs = m["ellipse_dirs"]
        zs, rs = [], []  # every ellipse in one line, separated by NaN (one artist to lay out and draw)
        for i in range(0, len(z), max(1, every)):
            if not on[i] or not np.isfinite(A[i]) or dirs[i] is None or None in dirs[i]:
                continue
            a = min(A[i], 2 * b)  # a near-line contact ellipse is shortened for the drawing
            ez, er = _ellipse_on_map(xyz[i], dirs[i], a, B[i])
            zs += [ez, [np.nan]]
            rs += [er, [np.nan]]
        if zs:
            (line,) = ax.plot(np.concatenate(zs), np.concatenate(rs), color="C0", lw=0.7,
                              label=f"contact ellipses (every {every}th position), clipped at the flank edges")
            line.set_clip_path(rect)
    line = (case.get("stats") or {}).get("contact") == "line"
    what = ("line contact: the path in one pinion section only (the contact line spans the face)" if line
            else f"contact ellipses for the approach delta = {delta * 1000:.2f} um")
    ax.set_title(f"{member} flank, {case_title(case)}\n{what}", fontsize=9)
    ax.grid(alpha=0.3)
    legend(ax, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=2, frameon=False)
    plain_ticks(ax)
    return ax


def _coincident(a: np.ndarray, b: np.ndarray) -> bool:
    ok = np.isfinite(a) & np.isfinite(b)
    if not ok.any() or (np.isfinite(a) != np.isfinite(b)).any():
        return False
    scale = max(np.ptp(a[ok]), np.ptp(b[ok]), 1e-9)
    return float(np.max(np.abs(a[ok] - b[ok]))) <= 5e-3 * scale


def plot_compare(cases: dict, axes: np.ndarray | None = None, member: str = "gear") -> np.ndarray:
    """Overlay several designs' or cases' actual TE (first Axes) and paths of contact on the
    ``member`` flank map (second Axes). ``cases`` maps a label to a case dict. Each case has its own
    colour and line style; a curve that coincides with an earlier one says so in the legend."""
    if axes is None:
        import matplotlib.pyplot as plt
        _, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    ax_te, ax_map = axes
    first = next(iter(cases.values()))
    _flank_box(ax_map, first["limits"][member])
    seen_te, seen_map = [], []
    for i, (label, case) in enumerate(cases.items()):
        col, ls = f"C{i % 10}", _LINESTYLES[i % len(_LINESTYLES)]
        lw = 2.6 if i == 0 else 1.8
        phi = np.degrees(_f(case["phi1"]))
        te = np.zeros_like(phi) if is_conjugate(case) else _f(case["te_envelope_arcsec"])
        same = [lab for lab, t in seen_te if _coincident(t, te)]
        note = f" (coincides with {same[0]})" if same else ""
        pp = "conjugate, TE = 0" if is_conjugate(case) else f"{case['peak_to_peak_arcsec']:.2f} arcsec p-p"
        ax_te.plot(phi, te, color=col, ls=ls, lw=lw, label=f"{label}: {pp}{note}")
        seen_te.append((label, te))
        m = case[member]
        on = np.array(case["on_surface"], bool)
        zz, rr = np.where(on, _axial(m), np.nan), np.where(on, _f(m["radius"]), np.nan)
        same = [lab for lab, (z0, r0) in seen_map if _coincident(z0, zz) and _coincident(r0, rr)]
        ax_map.plot(zz, rr, color=col, ls=ls, lw=lw, label=label + (f" (coincides with {same[0]})" if same else ""))
        seen_map.append((label, (zz, rr)))
    ax_te.set_xlabel("pinion angle phi1 [deg]")
    ax_te.set_ylabel(f"actual TE [arcsec] (+: gear ahead)\n{te_zero_text(first)}")
    ax_map.set_ylabel(f"{member} radius [mm]")
    for ax in axes:
        ax.grid(alpha=0.3)
        legend(ax, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=1, frameon=False)
        plain_ticks(ax)
    return axes


def plot_edge_te(case: dict, ax: Axes | None = None) -> Axes:
    """TE with edge contact (Litvin Figs. 9.6.3-9.6.6): every pair's TE (thin, grey), the actual
    TE coloured by the feature that carries the load (surface or which edge), transfer points.
    A conjugate case is drawn as TE = 0."""
    ax = axes_or_new(ax)
    phi = np.degrees(_f(case["phi1"]))
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel(te_ylabel(case))
    ax.grid(alpha=0.3)
    if is_conjugate(case):
        _draw_conjugate(ax, case, phi)
        ax.set_title(f"{case_title(case)}: conjugate, TE = 0; edge contact "
                     f"{'YES' if case['edge_carries_load'] else 'no'}", fontsize=9)
        legend(ax, **_BELOW)
        plain_ticks(ax)
        return ax
    for i, te in enumerate(case["te_arcsec"]):
        ax.plot(phi, _f(te), color="0.7", lw=0.8, ls="--", label="TE of each tooth pair" if i == 0 else None)
    env = _f(case["te_envelope_arcsec"])
    act = case["active_branch"]
    for name in dict.fromkeys(a for a in act if a):
        m = np.array([a == name for a in act])
        ax.plot(phi, np.where(m, env, np.nan), color=_BRANCH_COLOR.get(name, "k"), lw=2.4,
                marker="o" if _point_like(name) else None, ms=4,
                label=branch_label(name) if name == "surface" else f"edge contact: {branch_label(name)}")
    _transfer_lines(ax, np.degrees([t["phi1"] for t in case.get("transfers", [])]))
    ax.set_title(f"{case_title(case)}: p-p {case['peak_to_peak_arcsec']:.3g} arcsec; "
                 f"edge contact {'YES' if case['edge_carries_load'] else 'no'}", fontsize=9)
    finite = env[np.isfinite(env)]
    if finite.size:
        lo, hi = finite.min(), finite.max()
        pad = 0.5 * max(hi - lo, 1e-3)
        ax.set_ylim(lo - pad, hi + 0.3 * pad)
    legend(ax, **_BELOW)
    plain_ticks(ax)
    return ax


def _break_jumps(z, r, lim, tol=0.2):
    """NaN between consecutive points further apart than ``tol`` of the flank size (so that
    separate pieces of a path are not joined by straight lines)."""
    z, r = np.array(z, float), np.array(r, float)
    if z.size < 2:
        return z, r
    step = np.hypot(np.diff(z) / lim["b"], np.diff(r) / max(lim["r_a"] - lim["r_form"], 1e-9))
    cut = np.flatnonzero(step > tol)
    return np.insert(z, cut + 1, np.nan), np.insert(r, cut + 1, np.nan)


def contact_lines(case: dict, member: str, every: int = 8) -> tuple[list, dict]:
    """Instantaneous contact lines of the central pair of an edge-contact case whose flanks are in
    line contact (e.g. an aligned unmodified drive): at every ``every``-th position, the points of
    all contact features (mid section, face ends, tip edges) that the pair touches at the same TE
    (within :data:`CONJUGATE_ARCSEC`) and apart along the face lie on one contact line; they are
    joined in the order of z. Fewer than three such positions are not line contact (none returned).

    Returns
    -------
    lines : list of (z [mm], radius [mm], loaded: bool)
        One per sampled position with at least two points apart along the face (``loaded``: the
        central pair carries load there).
    on_line : dict
        Per feature name, (N,) bool: the positions where its point is a point of the contact line
        (at every position, not only the sampled ones).
    """
    paths = case.get("paths_central_pair") or {}
    if not case.get("edge_analysis") or 0 not in case["pairs"]:
        return [], {}
    te0 = _f(case["te_arcsec"][case["pairs"].index(0)])
    te_b = case.get("te_branches_central_arcsec") or {}
    b = case["limits"][member]["b"]
    on_line = {}
    for name in paths:
        t = _f(te_b.get(name, [None] * te0.size))
        with np.errstate(invalid="ignore"):
            on_line[name] = np.isfinite(t) & np.isfinite(te0) & (np.abs(t - te0) <= CONJUGATE_ARCSEC)
    raw = []
    for i in range(every // 2, te0.size, max(1, every)):
        pts, loaded = {}, False
        for name, path in paths.items():
            z, r = path[member]["axial"][i], path[member]["radius"][i]
            if on_line[name][i] and z is not None and r is not None:
                pts[round(z, 9)] = r
                loaded |= bool(path["carries_load"][i])
        if len(pts) >= 2 and max(pts) - min(pts) > 0.02 * b:
            z = np.array(sorted(pts))
            raw.append((z, np.array([pts[k] for k in sorted(pts)]), loaded))
    if len(raw) < 3:  # not line contact: at most a coincidence of two contact points
        return [], {}
    return [(*_curved(z, r, raw), loaded) for z, r, loaded in raw], on_line


def _curved(z, r, lines, n: int = 41):
    """A contact line of involute helicoids through its points (z, r): along it the roll distance
    s = sqrt(r^2 - r_b^2) is linear in z (slope tan beta_b, the same for every line), so r^2 is a
    quadratic in z whose z^2 coefficient is common to all lines. That coefficient is the median of
    the fits through lines with three or more points (0 without any: straight chords); the two
    others are fitted to each line's own points. Returns n points from the first to the last z."""
    fits = [np.polyfit(zz, rr**2, 2)[0] for zz, rr, _ in lines if zz.size >= 3]
    a = max(float(np.median(fits)), 0.0) if fits else 0.0
    bc = np.polyfit(z, r**2 - a * z**2, 1)
    zs = np.linspace(z[0], z[-1], n)
    return zs, np.sqrt(np.maximum(a * zs**2 + bc[0] * zs + bc[1], 0.0))


def plot_edge_paths(case: dict, member: str = "gear", ax: Axes | None = None, every: int = 8) -> Axes:
    """Paths of contact of the central pair on the ``member`` flank map: the surface part and the
    edge parts (thin dashed: that feature's contact of the pair while another pair drives; thick:
    where it carries the load of the drive), with the flank boundaries (thin grey frame). Line
    contact is drawn as the instantaneous contact lines across the face at every ``every``-th
    position (:func:`contact_lines`), not as a path. A conjugate drive shows only the loaded
    contact (its pairs share the load)."""
    ax = axes_or_new(ax)
    lim = case["limits"][member]
    _flank_box(ax, lim)
    dashed_any = False
    conj = is_conjugate(case)
    lines, on_line = contact_lines(case, member, every)
    for j, (z, r, loaded) in enumerate(lines):
        ax.plot(z, r, color="C3", lw=1.6 if loaded else 0.9, ls="-" if loaded or conj else "--", zorder=3,
                label=f"contact lines (line contact; every {every}th position)" if j == 0 else None)
        dashed_any |= not (loaded or conj)
    for name, path in case["paths_central_pair"].items():
        col = _BRANCH_COLOR.get(name, "k")
        z, r = _axial(path[member]), _f(path[member]["radius"])
        if lines:  # the points of the contact lines are drawn as lines, not as paths
            z, r = np.where(on_line[name], np.nan, z), np.where(on_line[name], np.nan, r)
        load = np.array(path["carries_load"], bool)
        loaded = bool((load & np.isfinite(z)).any())
        if conj and not loaded:
            continue  # conjugate: edges tie with the line contact where it reaches them; not a contact of their own
        idle = np.isfinite(z) & ~load
        point = _point_like(name)
        if not conj and idle.any():  # a conjugate drive's pairs share the load: no "while another pair drives"
            (ln,) = ax.plot(*_break_jumps(z, r, lim), color=col, lw=1.3, ls="--", zorder=3,
                            marker="o" if point else None, mfc="none", ms=5,
                            label=f"{branch_label(name)} (not driving)")
            if _draws(ln):
                dashed_any = True
                if loaded:  # named once, by its loaded part
                    ln.set_label(None)
        ax.plot(*_break_jumps(np.where(load, z, np.nan), np.where(load, r, np.nan), lim), color=col, lw=2.6,
                zorder=4, marker="o" if point else None, ms=4, label=branch_label(name))
    if dashed_any:
        (proxy,) = ax.plot([], [], color="0.3", lw=1.3, ls="--",
                           label="dashed: contact while another pair drives")
        proxy.set_gid("legend-proxy")
    how = f"line contact, contact lines at every {every}th position" if lines else "thick where the central pair drives"
    ax.set_title(f"{member} flank, {case_title(case)}: {how}", fontsize=9)
    ax.grid(alpha=0.3)
    legend(ax, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=2, frameon=False)
    plain_ticks(ax)
    return ax


def plot_crowning_comparison(before: list, after: list, axes: np.ndarray, member: str | None = None) -> np.ndarray:
    """Before/after comparison of a crowning optimization, one row per misalignment case: the actual
    TE (``member=None``) or the paths of contact on the ``member`` flank; left column before, right
    column after, on common axis limits per row. ``axes`` is an (n_cases, 2) array of Axes; returns it."""
    for row, b, a in zip(axes, before, after):
        for ax, case, when in ((row[0], b, "before"), (row[1], a, "after")):
            if member is None:
                plot_edge_te(case, ax=ax)
            else:
                plot_edge_paths(case, member, ax=ax)
            ax.set_title(f"{when}: " + ax.get_title(), fontsize=8)
        lo = min(row[0].get_ylim()[0], row[1].get_ylim()[0])
        hi = max(row[0].get_ylim()[1], row[1].get_ylim()[1])
        if member is None:  # a margin on the common range, so that no curve runs along a frame edge
            pad = 0.06 * (hi - lo)
            lo, hi = lo - pad, hi + pad
        x0 = min(row[0].get_xlim()[0], row[1].get_xlim()[0])
        x1 = max(row[0].get_xlim()[1], row[1].get_xlim()[1])
        for ax in row[:2]:
            ax.set_ylim(lo, hi)
            ax.set_xlim(x0, x1)
    return axes
