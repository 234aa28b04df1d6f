"""Plots of flank inspection results (gearopt.geometry.inspection): the topography of a flank and
its profile and lead charts, drawn as a measuring chart shows them. They read the JSON-able dicts
of :meth:`FlankGrid.to_dict` (``s_mm``, ``z_mm``, ``deviation_um``, ``profile``, ``side``,
``member``) and of the chart values (um), take ``ax=`` and return the Axes.

Conventions: deviations in um, ISO transverse (along the base tangent), positive = material added;
profile coordinate the roll length L_y [mm] (or the diameter d_y); face position z [mm] with face I at
-b/2 and face II at +b/2.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..robust.tolerances import tolerances
from .style import axes_or_new, number

if TYPE_CHECKING:
    from matplotlib.axes import Axes

_SYM = {"F_alpha": "$F_\\alpha$", "f_f_alpha": "$f_{f\\alpha}$", "f_H_alpha": "$f_{H\\alpha}$", "C_alpha": "$C_\\alpha$",
        "S_alpha": "$S_\\alpha$", "F_beta": "$F_\\beta$", "f_f_beta": "$f_{f\\beta}$", "f_H_beta": "$f_{H\\beta}$",
        "C_beta": "$C_\\beta$"}
_PROFILE_LABEL = {"L_y": "roll length $L_y$ [mm]", "d_y": "diameter $d_y$ [mm]"}


def plot_topography(grid: dict, ax: Axes | None = None, levels: int = 20) -> Axes:
    """Filled contour map of one flank's deviation [um] over face position (horizontal, face I on
    the left) and profile position (vertical, tip at the top), with a colour bar. The levels span
    the data's own range (a slope of a few um shows beside a larger crowning or relief), the colours
    diverge symmetrically at zero (white: the involute), and the colour bar states the range."""
    from matplotlib.colors import Normalize
    from matplotlib.ticker import MaxNLocator

    ax = axes_or_new(ax)
    s, z = np.asarray(grid["s_mm"]), np.asarray(grid["z_mm"])
    V = np.asarray(grid["deviation_um"], dtype=float)
    lo, hi = float(np.nanmin(V)), float(np.nanmax(V))
    if hi - lo < 1e-3:  # a flat map: one level around its value
        lo, hi = lo - 0.5e-3, hi + 0.5e-3
    lv = MaxNLocator(levels).tick_values(lo, hi)
    lv = lv[(lv > lo - (lv[1] - lv[0])) & (lv < hi + (lv[1] - lv[0]))]
    span = max(abs(lv[0]), abs(lv[-1]), 1e-3)
    norm = Normalize(-span, span)  # colour by |deviation| alike on both sides: white at zero
    cs = ax.contourf(z, s, V, levels=lv, cmap="RdBu_r", norm=norm)
    ax.contour(z, s, V, levels=[v for v in lv if abs(v) > 1e-12], colors="k", linewidths=0.3, alpha=0.5)
    cb = ax.figure.colorbar(cs, ax=ax, shrink=0.9)
    step = number(float(lv[1] - lv[0]))
    cb.set_label(f"deviation [um] (+ = material added)\nrange {number(lo)} ... {number(hi)} um, levels every {step} um",
                 fontsize=8)
    ax.set_xlabel("face position z [mm] (face I left, face II right)")
    ax.set_ylabel(_PROFILE_LABEL.get(grid.get("profile"), "profile [mm]") + " (tip up)")
    ax.set_title(f"{grid.get('member', '')} {grid.get('side', '')} flank: topography".strip(), fontsize=10)
    return ax


def _signed(v: float) -> str:
    """``v`` [um] with sign and two decimals, never "-0.00"."""
    return f"{round(float(v), 2) + 0.0:+.2f}"


def _trace(ax, x, dev, xlabel, title, values: dict, keys, tolerances: dict | None = None, grade=None):
    ax.plot(x, dev, "C3-", lw=1.5, label="trace")
    ax.axhline(0.0, color="k", lw=0.6)
    for xe in (x[0], x[-1]):
        ax.axvline(xe, color="0.5", lw=0.6, ls=":")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("deviation [um]")
    text = "   ".join(f"{_SYM.get(k, k)} = {_signed(values[k])}" for k in keys if k in values) + "  [um]"
    span = max(float(np.ptp(dev)), 2.0)
    mid = (float(np.max(dev)) + float(np.min(dev))) / 2
    if tolerances:
        # ISO 1328-1 tolerances of the class: the total deviation F within a band of width F_T about
        # the trace's mid-range, the slope f_H within +-f_HT over the evaluation range (the "K" of
        # the chart, through the trace's mean at the middle of the range)
        F_T, fH_T = (tolerances.get(k) for k in keys[:3:2])
        x0, x1 = float(x[0]), float(x[-1])
        if F_T is not None:
            ax.axhspan(mid - F_T / 2, mid + F_T / 2, color="C2", alpha=0.12, lw=0,
                       label=f"{_SYM.get(keys[0], keys[0])} tolerance {F_T:g} um")
            span = max(span, 1.1 * F_T)
        if fH_T is not None:
            ym = float(np.mean(dev))
            for sgn in (1, -1):
                ax.plot([x0, x1], [ym - sgn * fH_T / 2, ym + sgn * fH_T / 2], color="C2", lw=0.9, ls="--",
                        label=f"{_SYM.get(keys[2], keys[2])} tolerance +-{fH_T:g} um" if sgn > 0 else None)
        out = [k for k, t in zip(keys[:3:2], (F_T, fH_T)) if t is not None and abs(values.get(k, 0.0)) > t]
        text += f"\nISO 1328-1 class {grade}: " + (("outside: " + ", ".join(_SYM.get(k, k) for k in out))
                                                    if out else "within the tolerances")
        ax.legend(fontsize=6, loc="lower center")
    ax.set_title(f"{title}\n{text}", fontsize=8)
    ax.set_ylim(mid - 0.65 * span, mid + 0.65 * span)
    return ax


def chart_tolerances(grade: int, d: float, m_n: float, b: float) -> dict:
    """The ISO 1328-1:2013 chart tolerances of class ``grade`` [um] keyed as the chart values
    (``F_alpha``, ``f_f_alpha``, ``f_H_alpha``, ``F_beta``, ``f_f_beta``, ``f_H_beta``) for
    :func:`plot_profile_chart` / :func:`plot_lead_chart` (d reference diameter, m_n normal module,
    b face width [mm]; :func:`gearopt.robust.tolerances.tolerances`)."""
    t = tolerances(grade, d, m_n, b)
    return {"F_alpha": t["F_alphaT"], "f_f_alpha": t["f_falphaT"], "f_H_alpha": t["f_HalphaT"],
            "F_beta": t["F_betaT"], "f_f_beta": t["f_fbetaT"], "f_H_beta": t["f_HbetaT"], "grade": grade}


def plot_profile_chart(grid: dict, charts: dict, ax: Axes | None = None, tolerances: dict | None = None) -> Axes:
    """Profile chart (K-chart) at mid face: deviation [um] along the profile, evaluation range marked
    (dotted), with F_alpha, f_f_alpha, f_H_alpha, C_alpha, S_alpha [um] (``charts``: the chart values
    in um, ``z_profile_mm`` the section of the trace); ``tolerances`` (:func:`chart_tolerances`): the
    ISO 1328-1 bands of F_alpha and f_H_alpha drawn and the values judged against them."""
    ax = axes_or_new(ax)
    s, z = np.asarray(grid["s_mm"]), np.asarray(grid["z_mm"])
    V = np.asarray(grid["deviation_um"], dtype=float)
    z0 = charts.get("z_profile_mm", 0.0)
    dev = np.array([np.interp(z0, z, row) for row in V])
    return _trace(ax, s, dev, _PROFILE_LABEL.get(grid.get("profile"), "profile [mm]") + " (root -> tip)",
                  f"{grid.get('member', '')} {grid.get('side', '')}: profile at z = {z0:g} mm",
                  charts, ("F_alpha", "f_f_alpha", "f_H_alpha", "C_alpha", "S_alpha"), tolerances,
                  (tolerances or {}).get("grade"))


def plot_lead_chart(grid: dict, charts: dict, ax: Axes | None = None, tolerances: dict | None = None) -> Axes:
    """Helix (lead) chart at mid profile: deviation [um] along the face from face I to face II, with
    F_beta, f_f_beta, f_H_beta, C_beta [um]; ``tolerances`` as :func:`plot_profile_chart`'s."""
    ax = axes_or_new(ax)
    s, z = np.asarray(grid["s_mm"]), np.asarray(grid["z_mm"])
    V = np.asarray(grid["deviation_um"], dtype=float)
    i = int(np.argmin(np.abs(s - (s[0] + s[-1]) / 2)))
    return _trace(ax, z, V[i], "face position z [mm] (face I -> face II)",
                  f"{grid.get('member', '')} {grid.get('side', '')}: lead at {grid.get('profile', 's')} = {s[i]:.3g} mm",
                  charts, ("F_beta", "f_f_beta", "f_H_beta", "C_beta"), tolerances, (tolerances or {}).get("grade"))
