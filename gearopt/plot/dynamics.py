"""Plots of the dynamics study (docs/dynamics.md): they read the result dictionary of
:class:`gearopt.studies.dynamics.DynamicsReport` (``to_dict()``, or results.json) and take ``ax=``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .ticks import plain_ticks

if TYPE_CHECKING:
    from matplotlib.axes import Axes

CASE_COLORS = ("tab:blue", "tab:red", "tab:green", "tab:purple")
ORDER_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")


def _arr(v: list) -> np.ndarray:
    return np.array([np.nan if x is None else x for x in v], float)


def plot_dynamic_factor(d: dict, ax: Axes | None = None) -> Axes:
    """K_v (peak dynamic over static mesh force) against pinion speed for every case: the upward
    branch solid, the downward dashed (they differ where two steady states coexist), speeds with
    contact loss marked x, the jumps of the continuation (a branch lost at a fold) circled, speeds
    without a steady state marked by triangles at the bottom (up ^, down v); ISO 6336-1's n_E1 (dotted) and the speeds where mesh order 1 meets a natural
    frequency of the linear model (dash-dot). The K_v axis starts at 0 when K_v exceeds 2."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    for i, c in enumerate(d["cases"]):
        col = CASE_COLORS[i % len(CASE_COLORS)]
        v = np.array(c["speeds_rpm"])
        for br, ls in (("up", "-"), ("down", "--")):
            kv = _arr(c[br]["K_v"])
            ax.plot(v, kv, ls, color=col, lw=1.4 if br == "up" else 1.1,
                    label=f"{c['name']}, {'speed up' if br == 'up' else 'speed down'}")
            loss = np.array([bool(x) for x in c[br]["contact_loss"]])
            if loss.any():
                ax.plot(v[loss], kv[loss], "x", color=col, ms=5,
                        label=f"{c['name']}: contact loss" if br == "up" else None)
            jumped = np.array([bool(x) for x in c[br].get("jumped", [False] * len(v))])
            if jumped.any():
                ax.plot(v[jumped], kv[jumped], "o", mfc="none", color=col, ms=8, mew=1.2,
                        label=f"{c['name']}, {'up' if br == 'up' else 'down'}: branch lost, jumped")
            failed = ~np.array([bool(x) for x in c[br]["converged"]])
            if failed.any():  # no steady state found: no K_v to draw, a mark at the bottom instead
                ax.plot(v[failed], np.full(failed.sum(), 0.02), "^" if br == "up" else "v", color=col, ms=7,
                        transform=ax.get_xaxis_transform(), clip_on=False,
                        label=f"{c['name']}, {'up' if br == 'up' else 'down'}: no steady state found "
                              f"({int(failed.sum())} speed{'s' if failed.sum() != 1 else ''})")
        res = [n for n in c["resonance_speeds_linear_rpm"]["order1"] if v[0] <= n <= v[-1]]
        for j, n in enumerate(res):
            ax.axvline(n, color=col, ls="-.", lw=0.9,
                       label=f"{c['name']}: linear modes, order 1: " + ", ".join(f"{r:.0f}" for r in res) + " rpm"
                       if j == 0 else None)
    ax.axvline(d["model"]["n_E1_iso_rpm"], color="k", ls=":", lw=1.2,
               label=f"ISO 6336-1 n_E1 = {d['model']['n_E1_iso_rpm']:.0f} rpm")
    _kv_axes(ax, f"dynamic factor at {d['options']['torque_Nm']:g} N m (damping ratio {d['options']['damping']:g})")
    ax.legend(fontsize=7, ncol=3)
    return ax


def _kv_axes(ax: Axes, title: str, fontsize: float | None = None) -> None:
    """The axes of a K_v-against-speed plot: the K_v = 1 line, labels with units, K_v from 0 where it
    exceeds 2, the title, a grid and plain ticks."""
    ax.axhline(1.0, color="0.5", lw=0.8)
    ax.set_xlabel("pinion speed [rpm]")
    ax.set_ylabel("K_v = peak dynamic / static mesh force")
    if ax.get_ylim()[1] > 2.0:
        ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=fontsize)
    ax.grid(alpha=0.3)
    plain_ticks(ax)


def plot_order_amplitudes(d: dict, case: int = 0, ax: Axes | None = None) -> Axes:
    """Amplitudes of mesh orders 1-5 of the dynamic TE [um along the line of action] against pinion
    speed, case ``case`` (upward branch solid, downward dashed; log scale), with the static loaded
    TE's orders at the left edge (markers)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    c = d["cases"][case]
    v = np.array(c["speeds_rpm"])
    for br, ls in (("up", "-"), ("down", "--")):
        A = np.array([[np.nan if a is None else a for a in row] for row in c[br]["order_te_um"]], float)
        for h in range(A.shape[1]):
            ax.plot(v, A[:, h], ls, color=ORDER_COLORS[h % 5], lw=1.3 if br == "up" else 0.9,
                    label=f"order {h + 1}" if br == "up" else None)
    for h, a in enumerate(c["static"]["order_te_um"]):
        ax.plot(v[0], a, "<", color=ORDER_COLORS[h % 5], ms=7, clip_on=False)
    ax.set_yscale("log")
    ax.set_xlabel("pinion speed [rpm]")
    ax.set_ylabel("dynamic TE amplitude [um]")
    ax.set_title(f"{c['name']}: mesh-order response (solid speed up, dashed down; < static loaded TE's orders)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=5)
    return ax


def plot_cycle_force(d: dict, case: int = 0, ax: Axes | None = None) -> Axes:
    """Dynamic mesh force over one mesh cycle at the case's picked speeds (the lowest, the K_v peak,
    the highest), over the static load W."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    c = d["cases"][case]
    cy = c["cycle"]
    ph = np.degrees(np.array(cy["phase"]))
    for v, F in zip(cy["speeds_rpm"], cy["force_N"]):
        ax.plot(ph, np.array(F) / c["W_N"], lw=1.3, label=f"{v:.0f} rpm")
    ax.axhline(1.0, color="k", ls="--", lw=0.9, label="static W")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("mesh phase [deg]")
    ax.set_ylabel("mesh force / W")
    ax.set_title(f"{c['name']}: dynamic mesh force (W = {c['W_N']:.0f} N)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def plot_cycle_te(d: dict, case: int = 0, ax: Axes | None = None) -> Axes:
    """Dynamic TE over one mesh cycle at the picked speeds against the static loaded and unloaded TE
    of the loaded TCA [arcsec]."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    c = d["cases"][case]
    cy = c["cycle"]
    ph = np.degrees(np.array(cy["phase"]))
    for v, te in zip(cy["speeds_rpm"], cy["te_dynamic_arcsec"]):
        ax.plot(ph, te, lw=1.3, label=f"{v:.0f} rpm")
    st = c["static"]
    ps = np.degrees(np.array(st["phase"]))
    ax.plot(ps, st["te_loaded_arcsec"], "k.", ms=3, label="static loaded TE (loaded TCA)")
    ax.plot(ps, st["te_unloaded_arcsec"], "k--", lw=0.9, label="unloaded TE")
    ax.set_xlabel("mesh phase [deg]")
    ax.set_ylabel("TE [arcsec]")
    ax.set_title(f"{c['name']}: dynamic TE")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def plot_compare_dynamic_factor(designs: dict, case: str, ax: Axes | None = None) -> Axes:
    """K_v against pinion speed of the case named ``case`` of every design of the ``dynamics`` study
    (``designs``: label -> results dict, in the order of the comparison), one colour per design
    (``C0``, ``C1``, ... as every comparison figure), the upward branch solid and the downward dashed,
    speeds with contact loss marked x; each design's ISO 6336-1 n_E1 dotted in its colour. A design
    without the case is named in the title."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    missing = []
    for i, (label, d) in enumerate(designs.items()):
        col = f"C{i % 10}"
        c = next((c for c in d["cases"] if c["name"] == case), None)
        if c is None:
            missing.append(label)
            continue
        v = np.array(c["speeds_rpm"], float)
        for br, ls in (("up", "-"), ("down", "--")):
            kv = _arr(c[br]["K_v"])
            ax.plot(v, kv, ls, color=col, lw=2.2 if i == 0 else 1.5,
                    label=f"{label}: speed {br}, K_v max {c['K_v_max']:.3g} at {c['K_v_max_speed_rpm']:.0f} rpm"
                    if br == "up" else None)
            loss = np.array([bool(x) for x in c[br]["contact_loss"]])
            if loss.any():
                ax.plot(v[loss], kv[loss], "x", color=col, ms=5, label=f"{label}: contact loss" if br == "up" else None)
        ax.axvline(d["model"]["n_E1_iso_rpm"], color=col, ls=":", lw=1.1,
                   label=f"{label}: ISO 6336-1 n_E1 = {d['model']['n_E1_iso_rpm']:.0f} rpm")
    _kv_axes(ax, f"dynamic factor, case {case} (solid: speed up, dashed: down)"
             + (f"; not in {', '.join(missing)}" if missing else ""), fontsize=9)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    return ax
