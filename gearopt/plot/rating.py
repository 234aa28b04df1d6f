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
    top, bottom = 0.0, np.inf
    for (sym, i), (c, mk) in style.items():
        member = ("pinion", "gear")[i]
        y = np.array([r[sym][used][i] for r in rows], float)
        y2 = np.array([r[sym][other][i] for r in rows], float)
        ax.plot(T, y, "-", marker=mk, color=c, label=f"{sym} {member}")
        ax.plot(T, y2, "--", marker=mk, mfc="none", color=c)
        top = max(top, float(np.max(y)), float(np.max(y2)))
        bottom = min(bottom, float(np.min(y)), float(np.min(y2)))
    o = d["options"]
    ax.axhline(o["S_Hmin"], color="0.3", ls=":", lw=1.2, label=f"S_Hmin = {o['S_Hmin']:g}")
    if o["S_Fmin"] != o["S_Hmin"]:
        ax.axhline(o["S_Fmin"], color="0.6", ls="-.", lw=1.2, label=f"S_Fmin = {o['S_Fmin']:g}")
    ax.plot([], [], "k-", label=f"solid: {name[used]} K_Hbeta, K_Halpha (used)")
    ax.plot([], [], "k--", label=f"dashed: {name[other]}")
    nom = d["nominal"]["torque_Nm"]
    ax.axvline(nom, color="0.5", ls=":", lw=1, label=f"nominal {nom:.4g} N m")
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ax.set_xlim(0, float(np.max(T)) * 1.05)
    ax.set_yscale("log")  # S_H near 1 and S_F of several at light load, both readable
    bottom = min(bottom, o["S_Hmin"], o["S_Fmin"])
    ax.set_ylim(0.8 * bottom, 2.2 * top)
    ax.yaxis.set_major_locator(FixedLocator([0.3, 0.5, 0.7, 0.8, 0.9, 1.0, 1.2, 1.4, 1.7, 2.0, 2.5, 3.0, 4.0, 5.0,
                                             7.0, 10.0, 15.0, 20.0, 30.0, 50.0]))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel("safety factor [-] (log scale)")
    ax.set_title("safety factors against torque (ISO 6336-2/-3)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper right", ncol=2)
    ax.xaxis.get_major_formatter().set_useOffset(False)
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


def plot_spectrum_sn(d: dict, ax: Axes | None = None) -> Axes:
    """The S-N lines of pitting (Z_NT) and bending (Y_NT) as life factors against cycles (log-log), and the
    load spectrum of each member as a stair: bin stress over its reference level (the permissible
    stress without the life factor) against the cycles accumulated from the highest bin down
    (ISO 6336-6:2019 Figure C.1)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    sp = d["spectrum"]
    bins = sp["bins"]
    colours = {"pitting": "C0", "bending": "C3"}
    lo_n, hi_y = 1e10, 1.0
    for mode, sym in (("pitting", "sigma_H"), ("bending", "sigma_F")):
        pts = np.array(sp["curves"][mode][0]["points"], float)
        n0, y0 = pts[0]
        n1, y1 = pts[1]
        k = np.log(y1 / y0) / np.log(n1 / n0)
        N = np.r_[1e2, pts[:, 0], 1e11]
        y = np.r_[y0 * (1e2 / n0) ** k, pts[:, 1], pts[-1, 1]]
        ax.plot(N, y, "-", color=colours[mode], lw=2, label=f"S-N line, {mode} ({'Z_NT' if mode == 'pitting' else 'Y_NT'})")
        for i, (member, ls) in enumerate((("pinion", "-"), ("gear", "--"))):
            ref = sp["curves"][mode][i]["sigma_ref"]
            ratio = np.array([b[sym][i] / r for b, r in zip(bins, ref)])
            cyc = np.array([b["cycles"][i] for b in bins])
            order = np.argsort(-ratio)
            cum = np.cumsum(cyc[order])
            ax.step(np.r_[1.0, cum], np.r_[ratio[order][0], ratio[order]], where="pre", ls=ls, lw=1.2,
                    color=colours[mode], alpha=0.8, label=f"spectrum, {member} {mode}")
            lo_n = min(lo_n, float(cum[0]))
            hi_y = max(hi_y, float(ratio.max()))
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(max(1e2, lo_n / 10), 1e11)
    y_lo = 0.2
    ax.set_ylim(y_lo, 1.25 * max(hi_y, 1.7))
    ax.yaxis.set_major_locator(FixedLocator([0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.2, 1.6, 2.0, 2.5, 3.0]))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("load cycles")
    ax.set_ylabel("stress / reference level (life factor) [-]")
    ax.set_title("S-N lines and the load spectrum")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower left")
    return ax


def plot_spectrum_damage(d: dict, ax: Axes | None = None) -> Axes:
    """Miner damage n_i / N_i of each spectrum bin (by its torque), pitting and bending of both members,
    with the damage sums D and the safety factors against the spectrum S in the legend (bins below
    the S-N line's 1e10 level do no damage)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    sp = d["spectrum"]
    bins = sp["bins"]
    x = np.arange(len(bins))
    width = 0.2
    k = 0
    top = 0.0
    lines: list[str] = []
    for mode, c in (("pitting", ("C0", "C9")), ("bending", ("C3", "C1"))):
        for i, member in enumerate(("pinion", "gear")):
            U = np.array([b[f"U_{mode}"][i] for b in bins], float)
            D = sp["damage"][mode][i]
            S = sp["safety"][mode][i]
            drawn = bool(U.size) and float(np.max(U)) > 0
            ax.bar(x + (k - 1.5) * width, U, width, color=c[i], label=f"{mode} {member}" if drawn else None)
            lines.append(f"{mode} {member}: D = {D:.3g}, S = {S:.3g}" + ("" if drawn else " (no damage)"))
            top = max(top, float(np.max(U)) if U.size else 0.0)
            k += 1
    ax.set_ylim(0, 1.6 * top if top > 0 else 1.0)
    ax.text(0.02, 0.97, "\n".join(lines), transform=ax.transAxes, va="top", ha="left", fontsize=8,
            bbox={"facecolor": "white", "edgecolor": "0.7", "alpha": 0.9})
    ax.set_xticks(x, [f"{b['torque_Nm']:g}" for b in bins])
    ax.set_xlabel("bin: pinion torque [N m]")
    ax.set_ylabel("damage n_i / N_i [-]")
    ax.set_title("Miner damage per bin (ISO 6336-6)")
    ax.grid(alpha=0.3, axis="y")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper right")
    plain_ticks(ax)
    return ax
