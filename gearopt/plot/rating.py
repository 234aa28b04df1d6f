"""Plots of the rating study's results (docs/rating.md): they read the results dictionary only."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .ticks import plain_ticks

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def plot_safety_vs_torque(d: dict, ax: Axes | None = None) -> Axes:
    """S_H and S_F of pinion and gear against pinion torque [N m]: with the load factors used for the
    safety factors (solid) and with the other set (dashed), and the minimum safety factors."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    rows = d["torques"]
    T = np.array([r["torque_Nm"] for r in rows], float)
    used = d["load_factors_used"]
    other = "iso" if used == "ltca" else "ltca"
    name = {"ltca": "gearopt LTCA", "iso": "ISO 6336-1"}
    style = {("S_H", 0): ("C0", "o"), ("S_H", 1): ("C1", "s"), ("S_F", 0): ("C2", "^"), ("S_F", 1): ("C3", "v")}
    top = 0.0
    for (sym, i), (c, mk) in style.items():
        member = ("pinion", "gear")[i]
        y = np.array([r[sym][used][i] for r in rows], float)
        y2 = np.array([r[sym][other][i] for r in rows], float)
        ax.plot(T, y, "-", marker=mk, color=c, label=f"{sym} {member}")
        ax.plot(T, y2, "--", marker=mk, mfc="none", color=c)
        top = max(top, float(np.max(y)), float(np.max(y2)))
    o = d["options"]
    ax.axhline(o["S_Hmin"], color="0.3", ls=":", lw=1.2, label=f"S_Hmin = {o['S_Hmin']:g}")
    if o["S_Fmin"] != o["S_Hmin"]:
        ax.axhline(o["S_Fmin"], color="0.6", ls="-.", lw=1.2, label=f"S_Fmin = {o['S_Fmin']:g}")
    ax.plot([], [], "k-", label=f"solid: {name[used]} K_Hbeta, K_Halpha (used)")
    ax.plot([], [], "k--", label=f"dashed: {name[other]}")
    nom = d["nominal"]["torque_Nm"]
    ax.axvline(nom, color="0.5", ls=":", lw=1, label=f"nominal {nom:.4g} N m")
    ax.set_xlim(0, float(np.max(T)) * 1.05)
    ax.set_ylim(0, 1.3 * top)
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel("safety factor [-]")
    ax.set_title("safety factors against torque (ISO 6336-2/-3)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right", ncol=2)
    plain_ticks(ax)
    return ax


def plot_load_factors(d: dict, ax: Axes | None = None) -> Axes:
    """K_Hbeta and K_Halpha against pinion torque: ISO 6336-1 method B and gearopt's loaded TCA."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    rows = d["torques"]
    T = np.array([r["torque_Nm"] for r in rows], float)
    top = 1.0
    for sym, c in (("K_Hbeta", "C0"), ("K_Halpha", "C3")):
        for src, ls, mk in (("ltca", "-", "o"), ("iso", "--", "s")):
            y = np.array([np.nan if r[sym][src] is None else r[sym][src] for r in rows], float)
            ax.plot(T, y, ls, marker=mk, color=c, label=f"{sym} {'gearopt LTCA' if src == 'ltca' else 'ISO 6336-1'}")
            if np.isfinite(y).any():
                top = max(top, float(np.nanmax(y)))
    ax.set_xlim(0, float(np.max(T)) * 1.05)
    ax.set_ylim(0.9, 1 + 1.45 * (top - 1) + 0.1)
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel("load factor [-]")
    ax.set_title("face and transverse load factors")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    plain_ticks(ax)
    return ax
