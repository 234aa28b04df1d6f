"""Comparison of ISO 6336 ratings (:mod:`gearopt.plot.compare`): the safety factors against torque
with the load factors each design uses and its minimum safety, both methods' face and transverse
load factors, and the results against a load spectrum (ISO 6336-6), of ``rating`` designs.

Units: torque in N m; safety factors, load factors and Miner damage sums are dimensionless.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..style import number
from ..ticks import plain_ticks
from .common import LEGEND_BELOW, case_name, design_color, floats, legend_below, line_width, panel_grid

if TYPE_CHECKING:
    from collections.abc import Mapping

    from matplotlib.axes import Axes

__all__ = ["rating_of", "plot_safety", "plot_rating_factor", "plot_rating_spectrum", "rating_figures"]

_METHOD = {"ltca": "gearopt LTCA", "iso": "ISO 6336-1"}
#: the fixed ticks of a logarithmic safety-factor axis (as gearopt.plot.rating)
_SAFETY_TICKS = (0.3, 0.5, 0.7, 0.8, 0.9, 1.0, 1.2, 1.4, 1.7, 2.0, 2.5, 3.0, 4.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 50.0)


def rating_of(res: dict) -> dict | None:
    """The ISO 6336 rating of a design (the ``rating`` study's results: ``torques``, ``nominal``,
    ``options``), None for other studies."""
    if res.get("study") == "rating" and res.get("torques") and isinstance(res.get("nominal"), dict):
        return res
    return None


def _ratings(designs: Mapping[str, dict]) -> dict[str, tuple[int, dict]]:
    """label -> (index of the design, its rating) for the designs that have a rating."""
    out = {}
    for i, (label, res) in enumerate(designs.items()):
        r = rating_of(res)
        if r is not None:
            out[label] = (i, r)
    return out


def _torque_axis(ax: Axes, ratings: Mapping[str, tuple[int, dict]]) -> None:
    """The pinion torque axis from 0 to the largest torque rated, and a dotted line at each nominal
    torque (naming the designs when they differ)."""
    tmax = max(float(t["torque_Nm"]) for _, r in ratings.values() for t in r["torques"])
    ax.set_xlim(0, 1.05 * tmax)
    noms: dict[float, list[str]] = {}
    for label, (_, r) in ratings.items():
        noms.setdefault(round(float(r["nominal"]["torque_Nm"]), 9), []).append(label)
    for t, labs in noms.items():
        who = "" if len(noms) == 1 else f" ({', '.join(labs)})"
        ax.axvline(t, color="0.5", ls=":", lw=1, label=f"nominal {number(t)} N m{who}")
    ax.set_xlabel("pinion torque [N m]")


def _design_text(label: str, r: dict, used: bool = True) -> str:
    """``label: <misalignment>[, <load factors> load factors]`` for a legend."""
    mis = r.get("misalignment_text") or case_name(r.get("misalignment"))
    if not used:
        return f"{label}: {mis}"
    return f"{label}: {mis}, {_METHOD.get(r.get('load_factors_used'), r.get('load_factors_used'))} factors"


def plot_safety(designs: Mapping[str, dict], sym: str = "S_H", ax: Axes | None = None) -> Axes:
    """Pitting (``sym="S_H"``) or bending (``"S_F"``) safety factor of pinion (solid) and gear
    (dashed) against the pinion torque [N m] of every design with an ISO 6336 rating
    (:func:`rating_of`), one colour per design, with the load factors each design's safety factors
    use (``load_factors_used``, in the legend) and the minimum safety factor(s) (``S_Hmin``,
    ``S_Fmin``) as horizontal lines; logarithmic axis as in :func:`gearopt.plot.rating.plot_safety_vs_torque`.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    if sym not in ("S_H", "S_F"):
        raise ValueError(f"sym = {sym!r}: expected 'S_H' or 'S_F'")
    ax = ax or plt.figure().gca()
    ratings = _ratings(designs)
    lo, hi = math.inf, 0.0
    for label, (i, r) in ratings.items():
        used = r["load_factors_used"]
        T = floats([t["torque_Nm"] for t in r["torques"]])
        for m, ls in ((0, "-"), (1, "--")):
            y = floats([t[sym][used][m] for t in r["torques"]])
            ax.plot(T, y, ls=ls, marker="o" if m == 0 else "s", ms=4, color=design_color(i), lw=line_width(i),
                    label=_design_text(label, r) if m == 0 else None)
            if np.isfinite(y).any():
                lo, hi = min(lo, float(np.nanmin(y))), max(hi, float(np.nanmax(y)))
    mins: dict[float, list[str]] = {}
    for label, (_, r) in ratings.items():
        mins.setdefault(float(r["options"][f"{sym}min"]), []).append(label)
    for k, (v, labs) in enumerate(sorted(mins.items())):
        who = "" if len(mins) == 1 else f" ({', '.join(labs)})"
        ax.axhline(v, color="0.25", ls=("-.", (0, (1, 1)))[k % 2], lw=1.3, label=f"{sym}min = {v:g}{who}")
        lo, hi = min(lo, v), max(hi, v)
    ax.plot([], [], "k-", marker="o", ms=4, label="solid: pinion")
    ax.plot([], [], "k--", marker="s", ms=4, label="dashed: gear")
    if ratings:
        _torque_axis(ax, ratings)
    mode = "pitting" if sym == "S_H" else "bending"
    ax.set_yscale("log")  # S near 1 and of several, both readable
    if hi > 0:
        ax.set_ylim(0.85 * lo, 1.3 * hi)
    ax.yaxis.set_major_locator(FixedLocator(list(_SAFETY_TICKS)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_ylabel(f"{mode} safety {sym} [-] (log scale)")
    ax.set_title(f"{mode} safety {sym} against torque (ISO 6336-{2 if sym == 'S_H' else 3})", fontsize=9)
    ax.grid(alpha=0.3)
    ax.xaxis.get_major_formatter().set_useOffset(False)
    legend_below(ax)
    return ax


def plot_rating_factor(designs: Mapping[str, dict], sym: str = "K_Hbeta", ax: Axes | None = None) -> Axes:
    """The face (``sym="K_Hbeta"``) or transverse (``"K_Halpha"``) load factor against the pinion
    torque [N m] by both methods, gearopt's loaded TCA (solid) and ISO 6336-1 method B (dashed), of
    every design with an ISO 6336 rating, one colour per design."""
    import matplotlib.pyplot as plt

    if sym not in ("K_Hbeta", "K_Halpha"):
        raise ValueError(f"sym = {sym!r}: expected 'K_Hbeta' or 'K_Halpha'")
    ax = ax or plt.figure().gca()
    ratings = _ratings(designs)
    top = 1.0
    for label, (i, r) in ratings.items():
        T = floats([t["torque_Nm"] for t in r["torques"]])
        for method, ls, mk in (("ltca", "-", "o"), ("iso", "--", "s")):
            y = floats([t[sym][method] for t in r["torques"]])
            ax.plot(T, y, ls=ls, marker=mk, ms=4, color=design_color(i), lw=line_width(i),
                    label=_design_text(label, r, used=False) if method == "ltca" else None)
            if np.isfinite(y).any():
                top = max(top, float(np.nanmax(y)))
    ax.plot([], [], "k-", marker="o", ms=4, label=f"solid: {_METHOD['ltca']}")
    ax.plot([], [], "k--", marker="s", ms=4, label=f"dashed: {_METHOD['iso']} method B")
    if ratings:
        _torque_axis(ax, ratings)
    ax.set_ylim(0.95, 1 + 1.15 * (top - 1) + 0.05)
    what = "face load factor" if sym == "K_Hbeta" else "transverse load factor"
    ax.set_ylabel(f"{what} {sym} [-]")
    ax.set_title(f"{what} {sym} against torque, both methods", fontsize=9)
    ax.grid(alpha=0.3)
    legend_below(ax)
    plain_ticks(ax)
    return ax


def plot_rating_spectrum(designs: Mapping[str, dict], quantity: str = "damage", ax: Axes | None = None) -> Axes:
    """The load-spectrum result (ISO 6336-6) of every design with a spectrum, per mode and member
    (pitting pinion, pitting gear, bending pinion, bending gear) as grouped bars, one colour per
    design, each bar's value written on it: ``quantity="damage"`` the Miner damage sums D [-]
    (0: no bin above the S-N line's endurance level), ``"safety"`` the safety factors against the
    spectrum S [-] with the designs' S_Hmin / S_Fmin marked over their groups."""
    import matplotlib.pyplot as plt

    if quantity not in ("damage", "safety"):
        raise ValueError(f"quantity = {quantity!r}: expected 'damage' or 'safety'")
    ax = ax or plt.figure().gca()
    groups = [("pitting", 0), ("pitting", 1), ("bending", 0), ("bending", 1)]
    shown = [(lab, i, r) for lab, (i, r) in _ratings(designs).items() if r.get("spectrum")]
    w = 0.8 / max(len(shown), 1)
    x = np.arange(len(groups))
    top = 0.0
    for slot, (label, i, r) in enumerate(shown):
        sp = r["spectrum"][quantity]
        h = np.array([np.nan if sp[mode][m] is None else float(sp[mode][m]) for mode, m in groups], float)
        bars = ax.bar(x - 0.4 + w * (slot + 0.5), np.nan_to_num(h), width=w, color=design_color(i), label=label)
        for bar, v in zip(bars, h):
            text = "n/a" if not math.isfinite(v) else ("0" if v == 0 else number(v, 3))
            ax.annotate(text, (bar.get_x() + bar.get_width() / 2, max(np.nan_to_num(v), 0.0)), ha="center",
                        va="bottom", fontsize=7, xytext=(0, 2), textcoords="offset points")
        top = max(top, float(np.nanmax(h)) if np.isfinite(h).any() else 0.0)
    if quantity == "safety":  # each design's minimum over its own bars
        for slot, (_label, _i, r) in enumerate(shown):
            for g, (mode, _m) in enumerate(groups):
                v = float(r["options"]["S_Hmin" if mode == "pitting" else "S_Fmin"])
                xb = x[g] - 0.4 + w * slot
                ax.plot([xb, xb + w], [v, v], color="0.15", lw=1.6,
                        label="minimum safety S_Hmin, S_Fmin" if slot == 0 and g == 0 else None)
                top = max(top, v)
    ax.set_xticks(x, [f"{mode}\n{('pinion', 'gear')[m]}" for mode, m in groups], fontsize=8)
    if quantity == "damage":
        ax.set_ylabel("Miner damage sum D [-] (1: end of life)")
        ax.set_title("damage sums against the load spectrum (ISO 6336-6)", fontsize=9)
    else:
        ax.set_ylabel("safety against the load spectrum S [-]")
        ax.set_title("safety factors against the load spectrum (ISO 6336-6)", fontsize=9)
    ax.set_ylim(0, 1.2 * top if top > 0 else 1.0)
    ax.grid(alpha=0.3, axis="y")
    handles, names = ax.get_legend_handles_labels()
    if handles:  # the designs first, then the minimum line
        order = sorted(range(len(names)), key=lambda k: names[k].startswith("minimum"))
        ax.legend([handles[k] for k in order], [names[k] for k in order],
                  **{**LEGEND_BELOW, "bbox_to_anchor": (0.5, -0.25), "ncol": len(shown) + 1})
    plain_ticks(ax)
    return ax


def rating_figures(designs: Mapping[str, dict]) -> list[tuple[str, str, Any]]:
    """The rating figure (``compare_rating.png``: S_H, S_F, K_Hbeta, K_Halpha against torque) when
    two designs or more have an ISO 6336 rating, and the load spectrum figure
    (``compare_rating_spectrum.png``: damage sums, safety factors) when two of them have a spectrum.

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    if len(_ratings(designs)) >= 2:
        fig, axes = panel_grid(4, width=5.6, height=4.6, ncols=2)
        plot_safety(designs, "S_H", ax=axes[0])
        plot_safety(designs, "S_F", ax=axes[1])
        plot_rating_factor(designs, "K_Hbeta", ax=axes[2])
        plot_rating_factor(designs, "K_Halpha", ax=axes[3])
        fig.suptitle("ISO 6336 rating: safety factors with the load factors each design uses; both methods' "
                     "load factors", fontsize=10)
        out.append(("compare_rating.png",
                    "Pitting and bending safety of pinion (solid) and gear (dashed) against torque with the minimum "
                    "safety lines, and K_Hbeta, K_Halpha by gearopt's loaded TCA and by ISO 6336-1: where each design "
                    "falls below its minimum and how much of the difference the face load factor makes.", fig))
        if sum(bool(r.get("spectrum")) for _, r in _ratings(designs).values()) >= 2:
            fig, axes = panel_grid(2, width=5.6, height=4.6, ncols=2)
            plot_rating_spectrum(designs, "damage", ax=axes[0])
            plot_rating_spectrum(designs, "safety", ax=axes[1])
            fig.suptitle("ISO 6336 rating against the load spectrum (Miner's rule, ISO 6336-6)", fontsize=10)
            out.append(("compare_rating_spectrum.png",
                        "Miner damage sums and safety factors against each design's load spectrum per mode and member: "
                        "the lower damage and the higher safety is the better design (0: no bin above the endurance "
                        "level).", fig))
    return out
