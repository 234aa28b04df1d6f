"""Plots of loaded TCA results (they read the ltca study's results dictionary only; ``ax=`` in,
Axes out)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .tca import misalignment_text
from .ticks import plain_ticks

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import ArrayLike


def _arr(v):
    return np.array([np.nan if x is None else x for x in v], float)


def _torque_colors(n):
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    return [cmap(0.1 + 0.8 * i / max(n - 1, 1)) for i in range(n)]


def plot_loaded_te(d: dict, ax: Axes | None = None) -> Axes:
    """Loaded TE [arcsec] over phi1 [deg] at every torque, with the unloaded TE (dashed)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    phi = np.degrees(_arr(d["phi1"]))
    ax.plot(phi, _arr(d["te_unloaded_arcsec"]), "k--", lw=1.2, label="unloaded")
    for c, t in zip(_torque_colors(len(d["torques"])), d["torques"]):
        ax.plot(phi, _arr(t["te_loaded_arcsec"]), color=c, lw=1.4,
                label=f"{t['torque_Nm']:.4g} N m (p-p {t['peak_to_peak_arcsec']:.2f}\")")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("transmission error [arcsec] (+: gear ahead)\nzero: unloaded pair 0 at phi1 = 0")
    ax.set_title("loaded transmission error over one mesh cycle")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), title="pinion torque", title_fontsize=7)
    plain_ticks(ax)
    return ax


def plot_te_vs_torque(d: dict, ax: Axes | None = None) -> Axes:
    """Peak-to-peak loaded TE and its first mesh harmonic [arcsec] against torque [N m]."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    c = d["te_vs_torque"]
    T = np.array(c["torque_Nm"], float)
    ax.plot(T, _arr(c["peak_to_peak_arcsec"]), "o-", color="C0", label="peak-to-peak")
    ax.plot(T, _arr(c["harmonic1_arcsec"]), "s-", color="C3", label="1st mesh harmonic (amplitude)")
    nom = d.get("nominal_torque_Nm")
    if nom is not None:
        ax.axvline(nom, color="0.5", ls=":", lw=1, label=f"nominal {nom:.4g} N m")
    torque_axes(ax, T, "loaded TE [arcsec]", "TE against load", legend_size=8)
    # headroom above the curves for the legend (a curve may dip mid-range and rise at both ends)
    top = np.nanmax(np.r_[_arr(c["peak_to_peak_arcsec"]), _arr(c["harmonic1_arcsec"])])
    if np.isfinite(top) and top > 0:
        ax.set_ylim(0, 1.45 * top)
        ax.legend(fontsize=8, loc="upper center")
    return ax


def torque_axes(ax: Axes, T: ArrayLike, ylabel: str, title: str, legend_size: float = 7, pad: float = 1.05) -> Axes:
    """Finish an axes over pinion torque ``T`` [N m] (from 0, values from 0): labels, grid, legend."""
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel(ylabel)
    ax.set_xlim(0, float(np.max(T)) * pad)
    ax.set_ylim(bottom=0)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=legend_size)
    plain_ticks(ax)
    return ax


def plot_harmonics(d: dict, ax: Axes | None = None) -> Axes:
    """Mesh-order harmonics 1-5 of the loaded TE [arcsec] at every torque (grouped bars)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    rows = [t for t in d["torques"] if t.get("harmonics_arcsec")]
    n = len(rows)
    w = 0.8 / max(n, 1)
    for i, (c, t) in enumerate(zip(_torque_colors(n), rows)):
        h = np.array(t["harmonics_arcsec"], float)
        ax.bar(np.arange(1, h.size + 1) - 0.4 + w * (i + 0.5), h, width=w, color=c, label=f"{t['torque_Nm']:.4g} N m")
    ax.set_xlabel("mesh order")
    ax.set_ylabel("amplitude [arcsec]")
    ax.set_xticks(range(1, 6))
    ax.set_title("loaded TE harmonics")
    ax.grid(alpha=0.3, axis="y")
    if n:
        ax.legend(fontsize=7, ncol=2)
    plain_ticks(ax)
    return ax


def _nominal(d: dict) -> dict:
    nom = d["nominal_torque_Nm"]
    return min(d["torques"], key=lambda t: abs(t["torque_Nm"] - nom))


def pair_color(d: dict, k: int) -> str:
    """One colour per tooth pair ``k`` (its place in ``d["pairs"]``), the same in every LTCA plot."""
    return f"C{list(d['pairs']).index(k) % 10}"


def pair_name(k: int) -> str:
    return f"pair {k:+d}" if k else "pair 0 (central)"


def plot_load_sharing(d: dict, ax: Axes | None = None) -> Axes:
    """Share of the normal load carried by each tooth pair over phi1 at the nominal torque."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    t = _nominal(d)
    phi = np.degrees(_arr(d["phi1"]))
    share = np.array([_arr(r) for r in t["pair_share"]])
    for k, row in zip(d["pairs"], share):
        if np.nanmax(row) > 1e-6:
            ax.plot(phi, row, lw=1.5, color=pair_color(d, k), label=pair_name(k))
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("load share [-]")
    ax.set_ylim(-0.02, 1.22)  # the legend's band above the largest share
    ax.set_title(f"load sharing at {t['torque_Nm']:.4g} N m")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", ncol=3)
    plain_ticks(ax)
    return ax


def plot_mesh_stiffness(d: dict, ax: Axes | None = None) -> Axes:
    """Mesh stiffness [N/um] over phi1 at every torque, and ISO 6336-1 c_gamma b for reference."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    phi = np.degrees(_arr(d["phi1"]))
    for c, t in zip(_torque_colors(len(d["torques"])), d["torques"]):
        ax.plot(phi, _arr(t["stiffness_N_per_um"]), color=c, lw=1.2, label=f"{t['torque_Nm']:.4g} N m")
    iso = d.get("iso6336")
    if iso:
        ax.axhline(iso["c_gamma_alpha"] * d["pair"]["b"], color="k", ls="--", lw=1,
                   label=f"ISO 6336-1 c_gamma b = {iso['c_gamma_alpha'] * d['pair']['b']:.0f} N/um")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("mesh stiffness [N/um]")
    ax.set_ylim(bottom=0)
    ax.set_title("mesh stiffness (secant: load / loaded approach)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    plain_ticks(ax)
    return ax


def plot_face_load(d: dict, ax: Axes | None = None, ax_pressure: Axes | None = None) -> Axes:
    """Line load across the face [N/mm] of every loaded pair at the position of the peak flank
    pressure (nominal torque) and the Hertz peak pressure [MPa] of its flank contact: one colour
    per pair (:func:`pair_color`), the line load solid with dots, the pressure dashed; tip-edge
    contacts marked x on the line load. The pressure goes to ``ax_pressure`` (its own axes, e.g.
    below ``ax``) or, without it, to a twin axis on the right. The peak pressure is marked and
    named in the title. Returns ``ax``."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    f = d["face_load"]
    edges = f.get("edge") or [None] * len(f["pairs"])
    axp = ax_pressure if ax_pressure is not None else ax.twinx()
    peak = (-1.0, None, None, None)  # p0, pair, z
    tips = False
    for k, z, q, p, e in zip(f["pairs"], f["axial"], f["line_load_N_per_mm"], f["p0_MPa"], edges):
        z, q, p = _arr(z), _arr(q), _arr(p)
        if np.nanmax(np.nan_to_num(q)) <= 0:
            continue
        col = pair_color(d, k)
        ax.plot(z, q, "o-", ms=3, color=col, label=pair_name(k))
        tip = (np.zeros(p.shape, bool) if e is None else _arr(e) > 0)
        if np.any(tip & (np.nan_to_num(q) > 0)):
            on = tip & (np.nan_to_num(q) > 0)
            ax.plot(z[on], q[on], "x", color="k", ms=7, mew=1.5, zorder=5)
            tips = True
        flank = np.where((np.nan_to_num(p) > 0) & ~tip, p, np.nan)  # flank contact only: tip edges are marked
        if np.isfinite(flank).any():
            axp.plot(z, flank, "--", color=col, lw=1.4)
            i = int(np.nanargmax(flank))
            if flank[i] > peak[0]:
                peak = (float(flank[i]), k, float(z[i]))
    if ax_pressure is None:  # one axes pair: say which line is which (stacked: each panel's label does)
        (solid,) = ax.plot([], [], "o-", ms=3, color="0.35", label="solid: line load [N/mm]")
        (dash,) = ax.plot([], [], "--", color="0.35", label="dashed: Hertz peak pressure [MPa]")
        for h in (solid, dash):
            h.set_gid("legend-proxy")
    if tips:
        (x,) = ax.plot([], [], "x", color="k", ms=7, mew=1.5, label="tip-edge contact")
        x.set_gid("legend-proxy")
    if peak[1] is not None:
        axp.plot(peak[2], peak[0], "*", color=pair_color(d, peak[1]), mec="k", ms=13, zorder=6)
    ax.set_xlabel("face width position z [mm]")
    ax.set_ylabel("line load [N/mm]" + (" (solid)" if ax_pressure is None else ""))
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    axp.set_ylabel("Hertz peak pressure [MPa]" + (" (dashed)" if ax_pressure is None else ""))
    axp.set_ylim(bottom=0)
    qhi = ax.get_ylim()[1]
    if ax_pressure is not None:  # stacked: a band above the line loads for the legend
        axp.set_xlabel("face width position z [mm]")
        axp.grid(alpha=0.3)
        axp.set_xlim(ax.get_xlim())
        axp.set_ylim(0, axp.get_ylim()[1] * 1.08)
        ax.set_ylim(0, qhi * 1.45)
        ax.legend(fontsize=7, loc="upper center", ncol=3)
    else:  # a twin axis: the pressures in the upper half, the line loads in the lower half
        axp.set_ylim(0, axp.get_ylim()[1] * 1.05)
        ax.set_ylim(0, qhi * 2.2)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=3, frameon=False)
    where = (f"\npeak flank pressure {peak[0]:.0f} MPa ({pair_name(peak[1])}, star, z = {peak[2]:.1f} mm)"
             if peak[1] is not None else "")
    ax.set_title(f"load across the face at phi1 = {math.degrees(f['phi1']):.3f} deg{where}", fontsize=10)
    plain_ticks(ax, axp)
    return ax


def pattern_points(d: dict, member: str) -> dict:
    """The loaded slices of the pattern at the nominal torque on one member's flank, as arrays:
    ``z`` (slice contact centre), ``lo``, ``hi`` (its interval across the face), ``r`` (radius)
    [mm], ``p0`` Hertz peak pressure [MPa], ``b_H`` half-width [mm], ``edge`` (True: a tip-edge
    contact, whose pressure is nominal) and ``row``, the key of its contact line (pair, phi1)."""
    p = d["pattern"]
    m = p[member]
    out = {"z": _arr(m["axial"]), "lo": _arr(m["from"]), "hi": _arr(m["to"]), "r": _arr(m["radius"]),
           "p0": _arr(p["p0_MPa"]), "b_H": _arr(p["b_H_mm"])}
    out["edge"] = _arr(p["edge"]) > 0 if "edge" in p else np.zeros(out["z"].shape, bool)
    out["row"] = np.array([f"{k}:{phi:.12g}" for k, phi in zip(p["pair"], p["phi1"])])
    keep = np.isfinite(out["z"]) & np.isfinite(out["r"]) & (np.nan_to_num(out["p0"]) > 0)
    return {k: v[keep] for k, v in out.items()}


def pattern_field(d: dict, member: str, nz: int = 300, nr: int = 240) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The largest Hertz peak pressure [MPa] over the mesh cycle on one member's flank, on a fine
    grid: (z centres [mm], radius centres [mm], (nr, nz) pressures, NaN where the flank never
    touches). Each row of loaded slices (one tooth pair at one position: its contact line across
    the face) covers the face from its first slice's start to its last slice's end, its radius
    interpolated linearly along the face between the slice contact points (tip edges included:
    the line reaches the tip there) and its pressure between the flank contacts' p0 (held at the
    ends: a tip edge's own pressure is nominal), over a radial band of half-width the larger of
    its Hertz half-width (radial projection) and the radial step between successive positions of a pair, so
    that successive positions join without gaps; where bands overlap the larger pressure counts."""
    P = pattern_points(d, member)
    lim = d["limits"][member]
    zc = np.linspace(-lim["b"] / 2, lim["b"] / 2, nz)
    rc = np.linspace(lim["r_form"], lim["r_a"], nr)
    img = np.full((nr, nz), np.nan)
    keys = list(dict.fromkeys(P["row"][~P["edge"]]))
    if not keys:
        return zc, rc, img
    # radial step: between the mean radii of successive positions of one tooth pair
    steps = []
    for pair in {k.split(":")[0] for k in keys}:
        mine = sorted((float(k.split(":")[1]), k) for k in keys if k.split(":")[0] == pair)
        means = [float(np.mean(P["r"][(P["row"] == k) & ~P["edge"]])) for _, k in mine]
        steps.extend(np.abs(np.diff(means)))
    steps = np.array(steps)[np.array(steps) > 1e-9] if steps else np.zeros(0)
    step = float(np.median(steps)) if steps.size else (rc[1] - rc[0])
    r_b = d["pattern"][member]["r_b"]
    for key in keys:
        sel = P["row"] == key
        o = np.argsort(P["z"][sel])
        z, r, lo, hi = P["z"][sel][o], P["r"][sel][o], P["lo"][sel][o], P["hi"][sel][o]
        flank = ~P["edge"][sel][o]
        zf, pf, bf = z[flank], P["p0"][sel][o][flank], P["b_H"][sel][o][flank]
        a, b = np.nanmin(np.r_[lo, z]), np.nanmax(np.r_[hi, z])
        cols = np.flatnonzero((zc >= a - 1e-9) & (zc <= b + 1e-9))
        if cols.size == 0:  # narrower than a grid column: the nearest one
            cols = np.array([int(np.argmin(np.abs(zc - 0.5 * (a + b))))])
        ri = np.interp(zc[cols], z, r)
        pi = np.interp(zc[cols], zf, pf)
        # radial extent of the Hertz band: half-width along the profile times ds/dr = r / s
        hh = np.interp(zc[cols], zf, bf) * np.sqrt(np.maximum(ri**2 - r_b**2, 0.0)) / ri
        half = np.maximum(hh, step)
        inside = np.abs(rc[:, None] - ri[None, :]) <= half[None, :]
        img[:, cols] = np.fmax(img[:, cols], np.where(inside, pi[None, :], np.nan))
    return zc, rc, img


def plot_contact_pattern(d: dict, member: str = "pinion", ax: Axes | None = None, vmax: float | None = None,
                         what: str | None = None) -> Axes:
    """The loaded contact pattern on one flank (what a marking-compound test shows) at the nominal
    torque: the largest Hertz peak pressure of the flank contacts over the mesh cycle, interpolated
    along each contact line between the actual slice contact points (:func:`pattern_field`; blank
    where the flank never touches), face width across, radius up; tip and form circle and the face ends
    drawn and named in the legend below; loaded tip edges marked x. The title names the torque and
    the misalignment (``d["misalignment"]`` when present) and ``what`` (e.g. a case or design)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    P = pattern_points(d, member)
    flank = P["p0"][~P["edge"]]
    top = float(vmax or (np.max(flank) if flank.size else 1.0))
    zc, rc, img = pattern_field(d, member)
    mappable = ax.pcolormesh(zc, rc, np.ma.masked_invalid(img), shading="nearest", cmap="inferno_r",
                             vmin=0, vmax=top)
    lim = d["limits"][member]
    ax.axhline(lim["r_a"], color="0.25", lw=1.0, ls="-", label=f"tip circle r_a = {lim['r_a']:.2f} mm")
    ax.axhline(lim["r_form"], color="0.25", lw=1.0, ls="--", label=f"form circle r = {lim['r_form']:.2f} mm")
    for sgn in (-1, 1):
        ax.axvline(sgn * lim["b"] / 2, color="0.25", lw=1.0, ls=":", label="face ends z = +-b/2" if sgn < 0 else None)
    pat = d["pattern"]
    if "edge" in pat:
        on = _arr(pat["edge"]) > 0
        if on.any():
            m = pat[member]
            ax.plot(_arr(m["axial"])[on], _arr(m["radius"])[on], "x", color="C0", ms=4,
                    label="loaded tip edge (edge loading)")
    b, pad = lim["b"], 0.06 * (lim["r_a"] - lim["r_form"])
    ax.set_xlim(-0.54 * b, 0.54 * b)
    ax.set_ylim(lim["r_form"] - pad, lim["r_a"] + pad)
    ax.set_xlabel("face width position z [mm]")
    ax.set_ylabel("radius [mm]")
    nom = pat["torque_Nm"]
    title = f"{member} flank at {nom:.4g} N m"
    if "misalignment" in d:
        title += ", " + (misalignment_text({"misalignment": d["misalignment"]}) or "aligned")
    if what:
        title += f", {what}"
    ax.set_title(title)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, frameon=False)
    cb = plt.colorbar(mappable, ax=ax, label="Hertz peak pressure p0 [MPa]")
    plain_ticks(ax, cb)
    return ax
