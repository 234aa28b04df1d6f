"""Plots of TCA results (transmission errors, bearing contact). They read the JSON-able case
dicts of a TCA report (``report.to_dict()["cases"][i]``), take ``ax=`` and return the Axes."""

from __future__ import annotations

import numpy as np

from .geometry import _axes


def _f(v):
    return np.array([np.nan if x is None else x for x in v], dtype=float)


def plot_te(case: dict, ax=None, label_pairs: bool = True):
    """TE of every tooth pair (thin) and the actual TE, their upper envelope (thick) [arcsec]
    against the pinion angle [deg], with the transfer points."""
    ax = _axes(ax)
    phi = np.degrees(_f(case["phi1"]))
    for k, te in zip(case["pairs"], case["te_arcsec"]):
        ax.plot(phi, _f(te), lw=0.9, ls="--", alpha=0.8, label=f"pair {k:+d}" if label_pairs else None)
    env = _f(case["te_envelope_arcsec"])
    ax.plot(phi, env, color="k", lw=2.2, label="actual TE (envelope)")
    for t in case.get("transfer_phi1", []):
        ax.axvline(np.degrees(t), color="C3", lw=0.8, ls=":")
    m = case["misalignment"]
    mis = ", ".join(f"{k} = {v:g}" for k, v in m.items() if v) or "aligned"
    ok = "" if case["all_converged"] else "  (some positions unsolved)"
    ax.set_title(f"{case['label']} ({mis}): peak-to-peak {case['peak_to_peak_arcsec']:.2f} arcsec{ok}", fontsize=9)
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("TE [arcsec]")
    finite = env[np.isfinite(env)]
    if finite.size:
        lo, hi = finite.min(), finite.max()
        pad = 0.6 * max(hi - lo, 1e-3)
        ax.set_ylim(lo - pad, hi + 0.3 * pad)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower center", ncol=4)
    return ax


def _ellipse_on_map(xyz, dirs, a, b, n=48):
    t = np.linspace(0, 2 * np.pi, n)
    d = np.asarray(dirs).reshape(2, 3)
    P = xyz[None, :] + a * np.cos(t)[:, None] * d[0] + b * np.sin(t)[:, None] * d[1]
    return P[:, 2], np.hypot(P[:, 0], P[:, 1])


def plot_bearing_contact(case: dict, member: str = "gear", ax=None, every: int = 8, ellipses: bool = True):
    """Path of contact of the central tooth pair on the flank map of ``member`` (axial position z
    vs transverse radius), with the tooth boundaries (face ends, form and tip radii) and contact
    ellipses (for the elastic approach ``delta``); points off the active flank are drawn grey."""
    ax = _axes(ax)
    m = case[member]
    lim = case["limits"][member]
    z, r = _f(m["z"]), _f(m["radius"])
    on = np.array(case["on_surface"], bool)
    b, ra, rF = lim["b"], lim["r_a"], lim["r_form"]
    ax.add_patch(__import__("matplotlib.patches", fromlist=["Rectangle"]).Rectangle(
        (-b / 2, rF), b, ra - rF, fill=True, fc="0.95", ec="k", lw=1.2))
    ax.plot(np.where(on, z, np.nan), np.where(on, r, np.nan), color="C3", lw=2, label="path of contact")
    ax.plot(np.where(~on, z, np.nan), np.where(~on, r, np.nan), color="0.6", lw=1, ls="--", label="off the flank")
    if ellipses and "ellipse_dirs" in m:
        xyz = np.array([[np.nan] * 3 if p is None else p for p in m["xyz"]], dtype=float)
        A, B = _f(case["ellipse_a"]), _f(case["ellipse_b"])
        dirs = m["ellipse_dirs"]
        for i in range(0, len(z), max(1, every)):
            if not on[i] or not np.isfinite(A[i]) or dirs[i] is None or None in dirs[i]:
                continue
            a = min(A[i], 2 * b)  # a near-line contact ellipse is clipped for the drawing
            ez, er = _ellipse_on_map(xyz[i], dirs[i], a, B[i])
            ax.plot(ez, er, color="C0", lw=0.7)
    ax.set_xlim(-0.65 * b, 0.65 * b)
    pad = 0.08 * (ra - rF)
    ax.set_ylim(rF - pad, ra + pad)
    ax.set_xlabel("axial position z [mm]")
    ax.set_ylabel("radius [mm]")
    ax.set_title(f"{member} flank, {case['label']}: contact ellipses for delta = {case['delta'] * 1000:.2f} um",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    return ax


def plot_compare(cases: dict, axes=None, member: str = "gear"):
    """Overlay several designs' or cases' actual TE (first Axes) and paths of contact on the
    ``member`` flank map (second Axes). ``cases`` maps a label to a case dict."""
    if axes is None:
        import matplotlib.pyplot as plt
        _, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    ax_te, ax_map = axes
    for i, (label, case) in enumerate(cases.items()):
        col = f"C{i}"
        phi = np.degrees(_f(case["phi1"]))
        ax_te.plot(phi, _f(case["te_envelope_arcsec"]), color=col, lw=2,
                   label=f"{label}: {case['peak_to_peak_arcsec']:.2f} arcsec p-p")
        m = case[member]
        on = np.array(case["on_surface"], bool)
        ax_map.plot(np.where(on, _f(m["z"]), np.nan), np.where(on, _f(m["radius"]), np.nan), color=col, lw=2,
                    label=label)
    first = next(iter(cases.values()))
    lim = first["limits"][member]
    b, ra, rF = lim["b"], lim["r_a"], lim["r_form"]
    ax_map.plot([-b / 2, b / 2, b / 2, -b / 2, -b / 2], [rF, rF, ra, ra, rF], color="k", lw=1.2)
    ax_te.set_xlabel("pinion angle phi1 [deg]")
    ax_te.set_ylabel("actual TE [arcsec]")
    ax_map.set_xlabel("axial position z [mm]")
    ax_map.set_ylabel(f"{member} radius [mm]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    return axes


_BRANCH_STYLE = {"surface": ("C3", "-"), "pinion_tip": ("C0", "-"), "gear_tip": ("C2", "-"),
                 "pinion_face+": ("C4", "-"), "pinion_face-": ("C5", "-"), "gear_face+": ("C6", "-"),
                 "gear_face-": ("C8", "-"), "pinion_corner+": ("C1", "-"), "pinion_corner-": ("C1", "-"),
                 "gear_corner+": ("C9", "-"), "gear_corner-": ("C9", "-")}


def plot_edge_te(case: dict, ax=None):
    """TE with edge contact (Litvin Figs. 9.6.3-9.6.6): every pair's TE (thin, grey), the actual
    TE coloured by the feature that carries the load (surface or which edge), transfer points."""
    ax = _axes(ax)
    phi = np.degrees(_f(case["phi1"]))
    for te in case["te_arcsec"]:
        ax.plot(phi, _f(te), color="0.7", lw=0.8, ls="--")
    env = _f(case["te_envelope_arcsec"])
    act = case["active_branch"]
    for name in dict.fromkeys(a for a in act if a):
        col, ls = _BRANCH_STYLE.get(name, ("k", "-"))
        m = np.array([a == name for a in act])
        ax.plot(phi, np.where(m, env, np.nan), color=col, lw=2.4, ls=ls,
                label="surface contact" if name == "surface" else f"edge contact: {name}")
    for t in case.get("transfers", []):
        ax.axvline(np.degrees(t["phi1"]), color="k", lw=0.6, ls=":")
    m = case["misalignment"]
    mis = ", ".join(f"{k} = {v:g}" for k, v in m.items() if v) or "aligned"
    ax.set_title(f"{case['label']} ({mis}): p-p {case['peak_to_peak_arcsec']:.3g} arcsec; "
                 f"edge contact {'YES' if case['edge_carries_load'] else 'no'}", fontsize=9)
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("TE [arcsec]")
    finite = env[np.isfinite(env)]
    if finite.size:
        lo, hi = finite.min(), finite.max()
        pad = 0.5 * max(hi - lo, 1e-3)
        ax.set_ylim(lo - pad, hi + 0.3 * pad)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower center", ncol=3)
    return ax


def plot_edge_paths(case: dict, member: str = "gear", ax=None):
    """Paths of contact of the central pair on the ``member`` flank map: the surface part and the
    edge parts (dashed: that feature's contact of the pair; thick: where it carries the load of the
    drive), with the flank boundaries."""
    ax = _axes(ax)
    lim = case["limits"][member]
    b, ra, rF = lim["b"], lim["r_a"], lim["r_form"]
    ax.plot([-b / 2, b / 2, b / 2, -b / 2, -b / 2], [rF, rF, ra, ra, rF], color="k", lw=1.2)
    for name, path in case["paths_central_pair"].items():
        col, _ = _BRANCH_STYLE.get(name, ("k", "-"))
        z, r = _f(path[member]["z"]), _f(path[member]["radius"])
        load = np.array(path["carries_load"], bool)
        ax.plot(z, r, color=col, lw=0.8, ls="--")
        ax.plot(np.where(load, z, np.nan), np.where(load, r, np.nan), color=col, lw=2.6,
                label="surface" if name == "surface" else name)
    ax.set_xlim(-0.65 * b, 0.65 * b)
    pad = 0.08 * (ra - rF)
    ax.set_ylim(rF - pad, ra + pad)
    ax.set_xlabel("axial position z [mm]")
    ax.set_ylabel("radius [mm]")
    ax.set_title(f"{member} flank, {case['label']}: thick where the central pair drives", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    return ax


def plot_crowning_comparison(before: list, after: list, axes, member: str | None = None):
    """Before/after comparison of a crowning optimization, one row per misalignment case: the actual
    TE (``member=None``) or the paths of contact on the ``member`` flank; left column before, right
    column after. ``axes`` is an (n_cases, 2) array of Axes; returns it."""
    for row, b, a in zip(axes, before, after):
        for ax, case, when in ((row[0], b, "before"), (row[1], a, "after")):
            if member is None:
                plot_edge_te(case, ax=ax)
            else:
                plot_edge_paths(case, member, ax=ax)
            ax.set_title(f"{when}: " + ax.get_title(), fontsize=8)
    return axes
