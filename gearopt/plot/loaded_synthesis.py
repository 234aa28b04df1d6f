"""Plots of the loaded micro-geometry optimisation (they read the loaded_microgeometry study's results
dictionary only; ``ax=`` in, Axes out)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .ltca import torque_axes
from .style import number

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def _arr(v):
    """A results list (null: no value) as a float array with NaN."""
    return np.array([np.nan if x is None else x for x in v], float)


def _torque_colors(n):
    """``n`` colours from light to heavy load (viridis)."""
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    return [cmap(0.1 + 0.8 * i / max(n - 1, 1)) for i in range(n)]


def same_as(d: dict, c: int, tol: float = 0.01) -> int | None:
    """The first case before ``c`` whose loaded TE peak-to-peak equals case ``c``'s at every torque, before
    and after, within ``tol`` [arcsec] (mirror-image misalignments of a symmetric drive), else None."""
    des = d["design"]
    for o in range(c):
        if all(abs(row[c] - row[o]) <= tol for key in ("before", "after") for row in des[key]["te_pp_arcsec"]):
            return o
    return None


def plot_te_before_after(before: dict, after: dict, ax: Axes | None = None, which: str = "after") -> Axes:
    """Loaded TE [arcsec] over phi1 [deg] at every torque of one case (``before`` / ``after``: the
    case's loaded-TCA dictionaries), for the design named by ``which``; the other design's curves thin
    and grey for comparison."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    main, other = (after, before) if which == "after" else (before, after)
    phi = np.degrees(_arr(main["phi1"]))
    for t in other["torques"]:
        ax.plot(np.degrees(_arr(other["phi1"])), _arr(t["te_loaded_arcsec"]), color="0.75", lw=0.9)
    for c, t in zip(_torque_colors(len(main["torques"])), main["torques"]):
        ax.plot(phi, _arr(t["te_loaded_arcsec"]), color=c, lw=1.6,
                label=f"{t['torque_Nm']:.4g} N m: p-p {t['peak_to_peak_arcsec']:.2f}\"")
    ax.plot([], [], color="0.75", lw=0.9, label="before" if which == "after" else "after")
    return _finish(ax, "pinion angle phi1 [deg]", "loaded transmission error [arcsec]", f"{which} the optimisation",
                   below=True)


def _finish(ax, xlabel: str, ylabel: str, title: str, below: bool = False):
    """Labels, title, grid and the legend (``below``: under the axes, off the curves)."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    if below:
        from matplotlib.transforms import ScaledTranslation

        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=2,
                  bbox_transform=ax.transAxes + ScaledTranslation(0.0, -0.5, ax.figure.dpi_scale_trans))
    else:
        ax.legend(fontsize=7, loc="best")
    return ax


def plot_te_vs_torque_before_after(d: dict, ax: Axes | None = None) -> Axes:
    """Peak-to-peak loaded TE [arcsec] against torque [N m] for every misalignment case, before
    (dashed) and after (solid) the optimisation (verification grid). A case equal to an earlier one
    (:func:`same_as`, e.g. crossing +-2' of a symmetric drive) is drawn with larger open markers and
    a thin line over it, and its legend entry says so."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    T = np.array(d["torques_Nm"], float)
    des = d["design"]
    for c, case in enumerate(d["cases"]):
        col = f"C{c % 10}"
        twin = same_as(d, c)
        if twin is None:
            kw_b, kw_a, lab = dict(lw=1.0, ms=4), dict(lw=1.6, ms=4), case["name"]
        else:  # on top of an equal case: open markers around its filled ones, a thin line
            kw_b = kw_a = dict(lw=0.8, ms=9, mfc="none", mew=1.3)
            lab = f"{case['name']} (= {d['cases'][twin]['name']}: the same values)"
        ax.plot(T, [row[c] for row in des["before"]["te_pp_arcsec"]], "o--", color=col, **kw_b)
        ax.plot(T, [row[c] for row in des["after"]["te_pp_arcsec"]], "s-", color=col, label=lab, **kw_a)
    ax.plot([], [], "k--", lw=1.0, label="before")
    ax.plot([], [], "k-", lw=1.6, label="after")
    return torque_axes(ax, T, "loaded TE peak-to-peak [arcsec]", "TE against load, every case", pad=1.08)


def plot_rounds(design: dict, ax: Axes | None = None, objective: str = "weighted TE p-p") -> Axes:
    """The trust-region rounds: the true objective of each accepted design and the model's prediction
    of each trial [arcsec] (rejected trials marked x); ``objective`` names it on the y axis. The axis
    is logarithmic only when the values span more than a decade (plain tick labels), the rounds are
    integers."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator, NullFormatter, ScalarFormatter

    ax = ax or plt.gca()
    rounds = design["rounds"]
    k = np.arange(len(rounds))
    ax.plot(k, [r["merit"] for r in rounds], "o-", color="C0", label="true objective at the round's design")
    ax.plot(k, [r["model_objective"] for r in rounds], "s", mfc="none", color="C2", label="NLP (linearised) optimum")
    rej = [i for i, r in enumerate(rounds) if r.get("accepted") is False]
    if rej:
        ax.plot(rej, [rounds[i]["true_merit"] for i in rej], "x", color="C3", ms=8, label="rejected trial (true)")
    vals = np.array([v for r in rounds for v in (r["merit"], r["model_objective"], r.get("true_merit"))
                     if v is not None], float)
    vals = vals[np.isfinite(vals)]
    if vals.size and vals.min() > 0 and vals.max() / vals.min() > 10:
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(ScalarFormatter())
        ax.yaxis.set_minor_formatter(NullFormatter())
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlim(-0.5, len(rounds) - 0.5)
    grid = [r.get("n_positions") for r in rounds]
    for i in range(1, len(grid)):
        if grid[i] != grid[i - 1]:
            ax.axvline(i - 0.5, color="0.5", ls=":", lw=1)
            ax.annotate(f" NLP grid {grid[i - 1]} -> {grid[i]} positions", (i - 0.5, 1.0), xycoords=("data", "axes fraction"),
                        xytext=(2, -2), textcoords="offset points", fontsize=7, va="top", color="0.3")
    ax.set_xlabel("trust-region round")
    ax.set_ylabel(f"objective [arcsec]\n{objective} + penalties")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def plot_pareto(front: dict, ax: Axes | None = None, before: dict | None = None,
                objective: str = "weighted loaded TE peak-to-peak") -> Axes:
    """The Pareto front of the loaded micro-geometry (``front``: ``ParetoFront.to_dict()``): weighted
    loaded TE peak-to-peak [arcsec] against the largest peak pressure over the duty cycle [MPa], both
    verified by loaded TCA; each point labelled with its pressure limit, the optimum without a limit
    as an open circle, limits without a design as vertical dotted lines. ``before``: the start design's
    ``{"objective_arcsec", "p_max_MPa"}`` (drawn as a grey square); ``objective`` names the y axis."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    pts = [p for p in front["points"] if p["feasible"]]
    p = np.array([q["p_max_MPa"] for q in pts], float)
    f = np.array([q["objective_arcsec"] for q in pts], float)
    order = np.argsort(p)
    ax.plot(p[order], f[order], "-", color="C0", lw=1.2, zorder=1)
    for q in pts:
        if q["p_limit_MPa"] is None:
            ax.plot(q["p_max_MPa"], q["objective_arcsec"], "o", mfc="white", mec="C0", ms=8, zorder=3,
                    label="no pressure limit")
        else:
            ax.plot(q["p_max_MPa"], q["objective_arcsec"], "o", color="C0", ms=6, zorder=3)
            ax.annotate(f"p <= {q['p_limit_MPa']:.0f}", (q["p_max_MPa"], q["objective_arcsec"]), fontsize=7,
                        xytext=(4, 4), textcoords="offset points")
    ax.plot([], [], "o", color="C0", ms=6, label="optimum under a pressure limit")
    bad = [q["p_limit_MPa"] for q in front["points"] if not q["feasible"]]
    for i, lim in enumerate(bad):
        ax.axvline(lim, color="C3", ls=":", lw=1.0, label="limit without a design" if i == 0 else None)
    if before is not None:
        ax.plot(before["p_max_MPa"], before["objective_arcsec"], "s", color="0.6", ms=7, label="start design")
    ax.set_xlabel("largest peak Hertz pressure over the duty cycle [MPa]")
    ax.set_ylabel(f"{objective} [arcsec]")
    ax.set_title("Pareto front: loaded TE against pressure (verified by loaded TCA)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    return ax


def plot_unloaded_te(d: dict, ax: Axes | None = None, case: int = 0) -> Axes:
    """The unloaded-TE target of one case: the unloaded TE [arcsec] of the pair centred on each position
    over pinion angle [deg] before (open) and after (filled) the optimisation, each with its fitted
    target parabola ``c0 + c1 psi - level psi^2`` (``d``: the study's results dictionary with
    ``design.unloaded_te``)."""
    import matplotlib.pyplot as plt

    ax = ax or plt.gca()
    u = d["design"]["unloaded_te"]
    z1 = u["z1"]
    lvl = u["level_arcsec"]
    c = u["cases"][case]
    for key, mk, col in (("before", "o", "0.45"), ("after", "s", "C3")):
        e = c[key]
        psi = _arr(e["psi"])
        deg = psi * 180.0 / z1
        fine = np.linspace(-1.0, 1.0, 201)
        ax.plot(deg, _arr(e["te_arcsec"]), mk, color=col, ms=4, mfc="none" if key == "before" else col,
                label=f"{key}: RMS misfit {number(e['rms_arcsec'])}\"")
        ax.plot(fine * 180.0 / z1, e["c0_arcsec"] + e["c1_arcsec"] * fine - lvl * fine**2, "-", color=col, lw=1.0,
                label=f"{key}: its target parabola (level {number(lvl)}\", best line added)")
    return _finish(ax, "pinion angle of the pair from its mesh-cycle centre [deg]", "unloaded transmission error [arcsec]",
                   f"unloaded TE against its parabola, {c['name']} (weight {u['weight']:g})")
