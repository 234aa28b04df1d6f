"""Plots of flank inspection results (gearopt.geometry.inspection): the topography of a flank and
its profile and lead charts, drawn as a measuring chart shows them. They read the JSON-able dicts
of :meth:`FlankGrid.to_dict` (``s_mm``, ``z_mm``, ``deviation_um``, ``profile``, ``side``,
``member``) and of the chart values (um), take ``ax=`` and return the Axes.

Conventions: deviations in um, ISO transverse (along the base tangent), positive = material added;
profile coordinate the roll length L_y [mm] (or the diameter d_y); face position z [mm] with face I at
-b/2 and face II at +b/2.
"""

from __future__ import annotations

import numpy as np

from .geometry import _axes

_SYM = {"F_alpha": "$F_\\alpha$", "f_f_alpha": "$f_{f\\alpha}$", "f_H_alpha": "$f_{H\\alpha}$", "C_alpha": "$C_\\alpha$",
        "S_alpha": "$S_\\alpha$", "F_beta": "$F_\\beta$", "f_f_beta": "$f_{f\\beta}$", "f_H_beta": "$f_{H\\beta}$",
        "C_beta": "$C_\\beta$"}
_PROFILE_LABEL = {"L_y": "roll length $L_y$ [mm]", "d_y": "diameter $d_y$ [mm]"}


def plot_topography(grid: dict, ax=None, levels: int = 15):
    """Filled contour map of one flank's deviation [um] over face position (horizontal, face I on
    the left) and profile position (vertical, tip at the top), with a colour bar."""
    ax = _axes(ax)
    s, z = np.asarray(grid["s_mm"]), np.asarray(grid["z_mm"])
    V = np.asarray(grid["deviation_um"], dtype=float)
    from matplotlib.ticker import MaxNLocator

    lim = max(float(np.abs(V).max()), 1e-3)
    lv = MaxNLocator(levels, symmetric=True).tick_values(-lim, lim)
    cs = ax.contourf(z, s, V, levels=lv, cmap="RdBu_r", extend="both")
    ax.contour(z, s, V, levels=[v for v in lv if abs(v) > 1e-12], colors="k", linewidths=0.3, alpha=0.5)
    cb = ax.figure.colorbar(cs, ax=ax, shrink=0.9)
    cb.set_label("deviation [um] (+ = material added)")
    ax.set_xlabel("face position z [mm] (face I left, face II right)")
    ax.set_ylabel(_PROFILE_LABEL.get(grid.get("profile"), "profile [mm]") + " (tip up)")
    ax.set_title(f"{grid.get('member', '')} {grid.get('side', '')} flank: topography".strip(), fontsize=10)
    return ax


def _trace(ax, x, dev, xlabel, title, values: dict, keys):
    ax.plot(x, dev, "C3-", lw=1.5, label="trace")
    ax.axhline(0.0, color="k", lw=0.6)
    for xe in (x[0], x[-1]):
        ax.axvline(xe, color="0.5", lw=0.6, ls=":")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("deviation [um]")
    text = "   ".join(f"{_SYM.get(k, k)} = {values[k]:+.2f}" for k in keys if k in values) + "  [um]"
    ax.set_title(f"{title}\n{text}", fontsize=8)
    span = max(float(np.ptp(dev)), 2.0)
    mid = (float(np.max(dev)) + float(np.min(dev))) / 2
    ax.set_ylim(mid - 0.65 * span, mid + 0.65 * span)
    return ax


def plot_profile_chart(grid: dict, charts: dict, ax=None):
    """Profile chart (K-chart) at mid face: deviation [um] along the profile, evaluation range marked
    (dotted), with F_alpha, f_f_alpha, f_H_alpha, C_alpha, S_alpha [um] (``charts``: the chart values
    in um, ``z_profile_mm`` the section of the trace)."""
    ax = _axes(ax)
    s, z = np.asarray(grid["s_mm"]), np.asarray(grid["z_mm"])
    V = np.asarray(grid["deviation_um"], dtype=float)
    z0 = charts.get("z_profile_mm", 0.0)
    dev = np.array([np.interp(z0, z, row) for row in V])
    return _trace(ax, s, dev, _PROFILE_LABEL.get(grid.get("profile"), "profile [mm]") + " (root -> tip)",
                  f"{grid.get('member', '')} {grid.get('side', '')}: profile at z = {z0:g} mm",
                  charts, ("F_alpha", "f_f_alpha", "f_H_alpha", "C_alpha", "S_alpha"))


def plot_lead_chart(grid: dict, charts: dict, ax=None):
    """Helix (lead) chart at mid profile: deviation [um] along the face from face I to face II, with
    F_beta, f_f_beta, f_H_beta, C_beta [um]."""
    ax = _axes(ax)
    s, z = np.asarray(grid["s_mm"]), np.asarray(grid["z_mm"])
    V = np.asarray(grid["deviation_um"], dtype=float)
    i = int(np.argmin(np.abs(s - (s[0] + s[-1]) / 2)))
    return _trace(ax, z, V[i], "face position z [mm] (face I -> face II)",
                  f"{grid.get('member', '')} {grid.get('side', '')}: lead at {grid.get('profile', 's')} = {s[i]:.3g} mm",
                  charts, ("F_beta", "f_f_beta", "f_H_beta", "C_beta"))
