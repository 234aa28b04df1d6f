"""Plots of loaded TCA results (they read the ltca study's results dictionary only; ``ax=`` in,
Axes out)."""

from __future__ import annotations

import math

import numpy as np


def _arr(v):
    return np.array([np.nan if x is None else x for x in v], float)


def _torque_colors(n):
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    return [cmap(0.1 + 0.8 * i / max(n - 1, 1)) for i in range(n)]


def plot_loaded_te(d: dict, ax=None):
    """Loaded TE [arcsec] over phi1 [deg] at every torque, with the unloaded TE (dashed)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    phi = np.degrees(_arr(d["phi1"]))
    ax.plot(phi, _arr(d["te_unloaded_arcsec"]), "k--", lw=1.2, label="unloaded")
    for c, t in zip(_torque_colors(len(d["torques"])), d["torques"]):
        ax.plot(phi, _arr(t["te_loaded_arcsec"]), color=c, lw=1.4,
                label=f"{t['torque_Nm']:.4g} N m (p-p {t['peak_to_peak_arcsec']:.2f}\")")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("transmission error [arcsec]")
    ax.set_title("loaded transmission error over one mesh cycle")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="best")
    return ax


def plot_te_vs_torque(d: dict, ax=None):
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
    return torque_axes(ax, T, "loaded TE [arcsec]", "TE against load", legend_size=8)


def torque_axes(ax, T, ylabel: str, title: str, legend_size: float = 7, pad: float = 1.05):
    """Finish an axes over pinion torque ``T`` [N m] (from 0, values from 0): labels, grid, legend."""
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel(ylabel)
    ax.set_xlim(0, float(np.max(T)) * pad)
    ax.set_ylim(bottom=0)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=legend_size)
    return ax


def plot_harmonics(d: dict, ax=None):
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
    return ax


def _nominal(d: dict) -> dict:
    nom = d["nominal_torque_Nm"]
    return min(d["torques"], key=lambda t: abs(t["torque_Nm"] - nom))


def plot_load_sharing(d: dict, ax=None):
    """Share of the normal load carried by each tooth pair over phi1 at the nominal torque."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    t = _nominal(d)
    phi = np.degrees(_arr(d["phi1"]))
    share = np.array([_arr(r) for r in t["pair_share"]])
    for k, row in zip(d["pairs"], share):
        if np.nanmax(row) > 1e-6:
            ax.plot(phi, row, lw=1.5, label=f"pair {k:+d}" if k else "pair 0 (central)")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("load share [-]")
    ax.set_ylim(-0.02, 1.05)
    ax.set_title(f"load sharing at {t['torque_Nm']:.4g} N m")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return ax


def plot_mesh_stiffness(d: dict, ax=None):
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
    return ax


def plot_face_load(d: dict, ax=None):
    """Line load across the face [N/mm] of every pair at the position of peak pressure (nominal
    torque), with the peak Hertz pressure on a second axis."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    f = d["face_load"]
    for k, z, q in zip(f["pairs"], f["axial"], f["line_load_N_per_mm"]):
        q = _arr(q)
        if np.nanmax(np.nan_to_num(q)) <= 0:
            continue
        ax.plot(_arr(z), q, "o-", ms=3, label=f"pair {k:+d} line load" if k else "pair 0 line load")
    ax.set_xlabel("face width position z [mm]")
    ax.set_ylabel("line load [N/mm]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    edges = f.get("edge") or [None] * len(f["pairs"])
    for k, z, p, e in zip(f["pairs"], f["axial"], f["p0_MPa"], edges):
        p = _arr(p)
        e = np.zeros(p.shape) if e is None else _arr(e)
        if np.nanmax(np.nan_to_num(p)) > 0:  # flank contact only: tip edges are marked on the line load
            ax2.plot(_arr(z), np.where((p > 0) & (e == 0), p, np.nan), "--", color="C3", lw=1)
    labelled = False
    for z, q, e in zip(f["axial"], f["line_load_N_per_mm"], edges):
        on = (np.zeros(len(z), bool) if e is None else _arr(e) > 0) & (np.nan_to_num(_arr(q)) > 0)
        if np.any(on):
            ax.plot(_arr(z)[on], _arr(q)[on], "kx", ms=6, label=None if labelled else "tip-edge contact")
            labelled = True
    ax2.set_ylabel("Hertz peak pressure [MPa] (dashed)", color="C3")
    ax2.set_ylim(bottom=0)
    ax.set_title(f"load across the face at phi1 = {math.degrees(f['phi1']):.3f} deg (peak pressure)")
    ax.legend(fontsize=8, loc="lower center")
    return ax


def contact_pattern(d: dict, member: str, nz: int = 160, nr: int = 160):
    """Raster of the largest contact pressure [MPa] over the mesh cycle on one member's flank:
    (z edges, radius edges, (nr, nz) pressures; 0 where never in contact). Each loaded slice marks
    its interval of the face (``from`` ... ``to``) and its Hertz band ``+- b_H r_b / r`` along the radius with
    the semi-elliptic pressure ``p0 sqrt(1 - s^2 / b^2)``."""
    p = d["pattern"]
    m = p[member]
    r, z0, z1 = _arr(m["radius"]), _arr(m["from"]), _arr(m["to"])
    b, p0 = _arr(p["b_H_mm"]), _arr(p["p0_MPa"])
    if "edge" in p:  # tip edges: marked by plot_contact_pattern, not rastered (their pressure is nominal)
        p0 = np.where(_arr(p["edge"]) > 0, 0.0, p0)
    lim = d["limits"][member]
    ze = np.linspace(-lim["b"] / 2, lim["b"] / 2, nz + 1)
    re = np.linspace(lim["r_form"], lim["r_a"], nr + 1)
    zc, rc = 0.5 * (ze[1:] + ze[:-1]), 0.5 * (re[1:] + re[:-1])
    img = np.zeros((nr, nz))
    dr = b * m["r_b"] / np.where(r > 0, r, 1.0)
    for za, zb, ri, di, pi in zip(z0, z1, r, dr, p0):
        if not (np.isfinite(za) and np.isfinite(zb) and np.isfinite(ri) and pi > 0 and di > 0):
            continue
        cols = np.flatnonzero((zc >= za - 1e-9) & (zc <= zb + 1e-9))
        if cols.size == 0:  # narrower than a pixel: the nearest column
            cols = np.array([int(np.argmin(np.abs(zc - 0.5 * (za + zb))))])
        rows = np.flatnonzero(np.abs(rc - ri) <= max(di, (re[1] - re[0]) / 2))
        if cols.size == 0 or rows.size == 0:
            continue
        s = np.clip((rc[rows] - ri) / max(di, 1e-12), -1, 1)
        prof = pi * np.sqrt(1 - s**2)
        img[np.ix_(rows, cols)] = np.maximum(img[np.ix_(rows, cols)], prof[:, None])
    return ze, re, img


def plot_contact_pattern(d: dict, member: str = "pinion", ax=None, vmax: float | None = None):
    """The loaded contact pattern on one flank (what a marking-compound test shows) at the nominal
    torque: the largest contact pressure over the mesh cycle, face width across, radius up."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    ze, re, img = contact_pattern(d, member)
    shown = np.ma.masked_where(img <= 0, img)
    mesh = ax.pcolormesh(ze, re, shown, cmap="inferno_r", vmin=0, vmax=vmax or float(img.max() or 1.0))
    lim = d["limits"][member]
    for y, lab in ((lim["r_a"], "tip"), (lim["r_form"], "form circle")):
        ax.axhline(y, color="0.3", lw=0.8)
        ax.text(ze[0], y, f" {lab}", va="bottom" if lab == "form circle" else "top", fontsize=7, color="0.3")
    ax.axvline(ze[0], color="0.3", lw=0.8)
    ax.axvline(ze[-1], color="0.3", lw=0.8)
    pat = d["pattern"]
    if "edge" in pat:
        e = _arr(pat["edge"])
        on = e > 0
        if on.any():
            m = pat[member]
            ax.plot(_arr(m["axial"])[on], _arr(m["radius"])[on], "x", color="C0", ms=4,
                    label="loaded tip edge (edge loading)")
            ax.legend(fontsize=7, loc="lower right")
    ax.set_xlabel("face width position z [mm]")
    ax.set_ylabel("radius [mm]")
    nom = d["pattern"]["torque_Nm"]
    ax.set_title(f"{member} flank: contact pattern at {nom:.4g} N m")
    plt.colorbar(mesh, ax=ax, label="contact pressure [MPa]")
    return ax
