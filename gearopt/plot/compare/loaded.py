"""Comparison of the loaded drive (:mod:`gearopt.plot.compare`): the loaded TE at a torque every
design analysed, TE peak-to-peak and peak flank pressure against torque, the load share of the
central pair and the loaded contact patterns on one pressure scale, of ``ltca`` and
``loaded_microgeometry`` designs (one misalignment case each: one that all of them have, else the
first of each).

Units: TE in arcsec (positive when the gear is ahead), pinion angle in deg, torque in N m, pressure
in MPa.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..style import number
from ..ticks import plain_ticks
from .common import design_color, floats, legend_below, line_width, match_cases, panel_grid

if TYPE_CHECKING:
    from collections.abc import Mapping

    from matplotlib.axes import Axes

__all__ = ["loaded_cases", "common_torque", "plot_loaded_te", "plot_te_vs_torque", "plot_pressure_vs_torque",
           "plot_load_sharing", "pattern_vmax", "loaded_figures"]


def loaded_cases(res: dict) -> list[dict]:
    """The loaded TCA dicts of one design (``ltca``: the results themselves; ``loaded_microgeometry``:
    the optimum of every case, ``after``), each with its ``misalignment``; ``[]`` for other studies."""
    if res.get("study") == "ltca" and "torques" in res:
        return [res]
    if res.get("study") == "loaded_microgeometry":
        names = res.get("cases") or []
        out = []
        for i, d in enumerate(res.get("after") or []):
            if "torques" in d:
                mis = {k: v for k, v in (names[i] if i < len(names) else {}).items() if k != "name"}
                out.append({**d, "misalignment": d.get("misalignment", mis)})
        return out
    return []


def _nominal(d: dict) -> dict:
    nom = d.get("nominal_torque_Nm")
    rows = d["torques"]
    return rows[-1] if nom is None else min(rows, key=lambda t: abs(t["torque_Nm"] - nom))


def common_torque(loaded: Mapping[str, dict]) -> float | None:
    """The torque [N m] at which loaded designs are compared over the mesh cycle: one that every
    design analysed (within 1e-6 N m), the nearest to the first design's nominal torque; None when
    they share none (each is then shown at its own nominal torque)."""
    sets = [[float(t["torque_Nm"]) for t in d["torques"]] for d in loaded.values()]
    if not sets:
        return None
    common = [T for T in sets[0] if all(any(abs(T - u) <= 1e-6 for u in s) for s in sets[1:])]
    if not common:
        return None
    nom = _nominal(next(iter(loaded.values())))["torque_Nm"]
    return min(common, key=lambda T: abs(T - nom))


def _at_torque(d: dict, torque: float | None) -> dict:
    """The row of ``d["torques"]`` at ``torque`` (the nominal one when None)."""
    if torque is None:
        return _nominal(d)
    return min(d["torques"], key=lambda t: abs(t["torque_Nm"] - torque))


def _first_loaded(designs: Mapping[str, dict]) -> dict[str, dict]:
    """One loaded TCA case per design that has one (label -> ltca dict): the first misalignment
    case (of the first such design) that every design with loaded cases has, else each design's
    first case (the titles name the misalignment)."""
    per = {lab: loaded_cases(r) for lab, r in designs.items()}
    per = {lab: cs for lab, cs in per.items() if cs}
    for _, _, by in match_cases(per):
        if len(by) == len(per):
            return {lab: by[lab] for lab in designs if lab in by}
    return {lab: cs[0] for lab, cs in per.items()}


def plot_loaded_te(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Loaded TE [arcsec] over the pinion angle [deg] at a torque all designs analysed
    (:func:`common_torque`; else each design's nominal torque), solid, with its unloaded TE (dotted),
    one colour per design."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    loaded = _first_loaded(designs)
    torque = common_torque(loaded)
    for i, label in enumerate(designs):
        d = loaded.get(label)
        if d is None:
            continue
        t = _at_torque(d, torque)
        phi = np.degrees(floats(d["phi1"]))
        ax.plot(phi, floats(t["te_loaded_arcsec"]), color=design_color(i), lw=line_width(i),
                label=f"{label}: {number(t['torque_Nm'])} N m, p-p {number(t['peak_to_peak_arcsec'])} arcsec")
        ax.plot(phi, floats(d["te_unloaded_arcsec"]), color=design_color(i), lw=1.0, ls=":",
                label=f"{label}: unloaded")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("TE [arcsec] (+: gear ahead)\nzero: unloaded pair 0 at phi1 = 0")
    at = "the nominal torques" if torque is None else f"{number(torque)} N m"
    ax.set_title(f"loaded TE at {at} (dotted: unloaded)", fontsize=9)
    ax.grid(alpha=0.3)
    legend_below(ax)
    plain_ticks(ax)
    return ax


def _against_torque(designs: Mapping[str, dict], ax: Axes, value, ylabel: str, title: str) -> Axes:
    loaded = _first_loaded(designs)
    tmax = 0.0
    for i, label in enumerate(designs):
        d = loaded.get(label)
        if d is None:
            continue
        T = np.array([t["torque_Nm"] for t in d["torques"]], float)
        y = np.array([np.nan if value(t) is None else value(t) for t in d["torques"]], float)
        ax.plot(T, y, "o-", color=design_color(i), lw=line_width(i), ms=4, label=label)
        tmax = max(tmax, float(np.max(T)))
    ax.set_xlabel("pinion torque [N m]")
    ax.set_ylabel(ylabel)
    if tmax > 0:
        ax.set_xlim(0, 1.05 * tmax)
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)
    legend_below(ax, ncol=2)
    plain_ticks(ax)
    return ax


def plot_te_vs_torque(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Loaded TE peak-to-peak [arcsec] against the pinion torque [N m], one colour per design."""
    import matplotlib.pyplot as plt

    return _against_torque(designs, ax or plt.figure().gca(), lambda t: t["peak_to_peak_arcsec"],
                           "loaded TE peak-to-peak [arcsec]", "loaded TE against torque")


def plot_pressure_vs_torque(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Largest Hertz peak pressure of the flank contact over the mesh cycle [MPa] against the pinion
    torque [N m], one colour per design."""
    import matplotlib.pyplot as plt

    return _against_torque(designs, ax or plt.figure().gca(), lambda t: t.get("p_max_MPa"),
                           "peak flank pressure p_max [MPa]", "peak pressure against torque")


def plot_load_sharing(designs: Mapping[str, dict], ax: Axes | None = None) -> Axes:
    """Load share of the central tooth pair (pair 0) over the pinion angle [deg] at a torque all
    designs analysed (:func:`common_torque`; else each design's nominal torque), one colour per design."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    loaded = _first_loaded(designs)
    torque = common_torque(loaded)
    for i, label in enumerate(designs):
        d = loaded.get(label)
        if d is None or 0 not in d["pairs"]:
            continue
        t = _at_torque(d, torque)
        share = floats(t["pair_share"][list(d["pairs"]).index(0)])
        ax.plot(np.degrees(floats(d["phi1"])), share, color=design_color(i), lw=line_width(i),
                label=f"{label}: {number(t['torque_Nm'])} N m")
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel("load share of tooth pair 0 [-]")
    ax.set_ylim(-0.02, 1.05)
    at = "the nominal torques" if torque is None else f"{number(torque)} N m"
    ax.set_title(f"load sharing of the central pair at {at}", fontsize=9)
    ax.grid(alpha=0.3)
    legend_below(ax)
    plain_ticks(ax)
    return ax


def pattern_vmax(designs: Mapping[str, dict], member: str = "pinion") -> float | None:
    """The largest Hertz peak pressure [MPa] of the contact patterns of every design (the common
    top of their colour scale; tip edges left out as in the patterns); None without patterns."""
    top = None
    for d in _first_loaded(designs).values():
        pat = d.get("pattern") or {}
        p0 = floats(pat.get("p0_MPa") or [])
        edge = floats(pat.get("edge") or [0] * p0.size) > 0
        vals = p0[~edge & np.isfinite(p0)] if p0.size == edge.size else p0[np.isfinite(p0)]
        if vals.size:
            top = max(top or 0.0, float(vals.max()))
    return top


def loaded_figures(designs: Mapping[str, dict]) -> list[tuple[str, str, Any]]:
    """The loaded TCA figure (``compare_loaded.png``: loaded TE, TE peak-to-peak and peak pressure
    against torque, load sharing) and the contact patterns (``compare_pattern.png``, one pressure
    scale) when two designs or more have a loaded TCA.

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    loaded = _first_loaded(designs)
    if len(loaded) >= 2:
        fig, axes = panel_grid(4, width=5.6, ncols=2)
        plot_loaded_te(designs, ax=axes[0])
        plot_te_vs_torque(designs, ax=axes[1])
        plot_pressure_vs_torque(designs, ax=axes[2])
        plot_load_sharing(designs, ax=axes[3])
        fig.suptitle("loaded TCA (a misalignment case all designs have, else the first of each)", fontsize=10)
        out.append(("compare_loaded.png",
                    "Loaded TE at the nominal torque, TE peak-to-peak and peak flank pressure against torque, load "
                    "share of the central pair: which design runs quieter and with less pressure over the duty range.", fig))
        top = pattern_vmax(designs)
        from ..ltca import plot_contact_pattern

        names = [lab for lab in designs if lab in loaded]
        fig, axes = panel_grid(len(names), width=5.6, height=4.6)
        for ax, lab in zip(axes, names):
            plot_contact_pattern(loaded[lab], "pinion", ax=ax, vmax=top, what=lab)
        fig.suptitle(f"loaded contact pattern, one colour scale 0 ... {number(top or 0.0)} MPa", fontsize=10)
        out.append(("compare_pattern.png",
                    "Loaded contact pattern on the pinion flank at each design's nominal torque, on one pressure "
                    "scale: where the load sits on the flank and whether it reaches a face end or the tip.", fig))
    return out
