"""Plots of the robust-design studies (Monte Carlo, design sweeps): histograms and CDFs of TE
peak-to-peak and harmonics, scatter against inputs, ranked sensitivities, and the probability map
of the contact pattern on the pinion flank. Each takes ``ax=`` and returns the Axes; they only read
the result (``RobustResult`` pieces as a dict). :func:`save_plots` draws them all for a result."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..robust.study import FEASIBLE_WARN, RobustResult, display, usable_fraction
from ..units import RAD_TO_ARCSEC
from .style import number

if TYPE_CHECKING:
    from matplotlib.axes import Axes

LABELS = {"te_p2p": "TE peak-to-peak [arcsec]", "h1": "1st mesh harmonic of TE [arcsec]",
          "loaded_te_p2p": "loaded TE peak-to-peak [arcsec]", "p_max": "peak Hertz pressure, flank [MPa]"}
GREY = "0.65"  #: colour of the correlations that are not significant
NEVER = "0.82"  #: colour of the flank cells of the pattern map that no sample reached
NOMINAL = {"loaded_te_p2p": "loaded_te_p2p_arcsec", "p_max": "p_max_MPa"}  #: key of the nominal value


#: readable names of the sampled inputs (the CSV column names are the keys)
_MEMBER_INPUTS = {"f_H_alpha": "profile slope deviation $f_{H\\alpha}$", "f_H_beta": "helix slope deviation $f_{H\\beta}$",
                  "f_pt_0": "single pitch deviation $f_{pt}$, teeth -1/0",
                  "f_pt_1": "single pitch deviation $f_{pt}$, teeth 0/+1",
                  "a_c": "profile crowning $a_c$ (rack parabola)", "a_pl": "lead crowning $a_{pl}$ (plunging)",
                  "C_alpha": "profile crowning $C_\\alpha$", "C_beta": "lead crowning $C_\\beta$"}
_MIS_INPUTS = {"crossing": "crossing of the axes", "intersecting": "intersecting angle of the axes",
               "dE": "centre distance change $\\Delta E$", "axial": "axial displacement of the gear"}


def input_label(name: str, unit: str | None = None) -> str:
    """A sampled input as a reader names it, with its unit: ``pinion.f_pt_1`` -> "pinion single
    pitch deviation $f_{pt}$, teeth 0/+1 [um]", ``mis.dE`` -> "centre distance change ... [mm]",
    ``torque`` -> "pinion torque [N m]"; an unknown name as it is."""
    member, _, kind = name.rpartition(".")
    if name == "torque":
        text = "pinion torque"
    elif member == "mis" and kind in _MIS_INPUTS:
        text = _MIS_INPUTS[kind]
    elif member in ("pinion", "gear") and kind in _MEMBER_INPUTS:
        text = f"{member} {_MEMBER_INPUTS[kind]}"
    else:
        text = name
    return f"{text} [{unit}]" if unit else text


def significance_limit(n: int, level: float = 0.05) -> float:
    """|rho| below which a rank correlation of ``n`` samples is not significant at ``level`` (two-sided):
    ``z / sqrt(n - 1)``, the large-sample normal approximation of Spearman's rho under independence
    (z = 1.96 at 5 %); 1 for n < 3."""
    from scipy.stats import norm

    if n < 3:
        return 1.0
    return float(norm.ppf(1 - level / 2) / math.sqrt(n - 1))


def _values(d: dict, key: str) -> np.ndarray:
    f = d["figures"]
    if key == "p_max":
        return np.asarray(f["p_max"], float)
    if key in ("te_p2p", "loaded_te_p2p"):
        return f[key] * RAD_TO_ARCSEC
    return f["harmonics"][:, int(key[1:]) - 1] * RAD_TO_ARCSEC


def _ax(ax):
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    return ax


def plot_histogram(d: dict, key: str = "te_p2p", ax: Axes | None = None, bins: int | None = None) -> Axes:
    """Histogram of ``key`` ("te_p2p", "h1", ...) over the samples, samples with edge contact
    stacked in their own colour; the 50 / 95 % percentiles and the nominal drive marked; the samples
    without a value (not solved, or no defined harmonic) counted in the legend's title."""
    ax = _ax(ax)
    v = _values(d, key)
    edge = np.asarray(d["figures"]["edge_contact"], bool)
    fin = np.isfinite(v)
    if not fin.any():
        ax.text(0.5, 0.5, f"no sample with a defined value ({v.size} samples)", ha="center", transform=ax.transAxes)
        ax.set_xlabel(LABELS.get(key, key))
        return ax
    bins = bins or int(min(40, max(8, fin.sum() // 5)))
    n_s, n_e = int((fin & ~edge).sum()), int((fin & edge).sum())
    if n_e:
        ax.hist([v[fin & ~edge], v[fin & edge]], bins=bins, stacked=True, color=["tab:blue", "tab:red"],
                label=[f"surface contact ({n_s})", f"edge contact ({n_e})"])
    else:
        ax.hist(v[fin], bins=bins, color="tab:blue", label=f"surface contact ({n_s}; none at an edge)")
    for q, ls in ((50, "--"), (95, ":")):
        x = np.percentile(v[fin], q)
        ax.axvline(x, color="k", ls=ls, lw=1, label=f"{q} %: {number(x)}")
    nom = d.get("nominal", {}).get(NOMINAL.get(key, f"{key}_arcsec"))
    if nom is not None:
        ax.axvline(nom, color="tab:green", lw=1.5, label=f"nominal: {number(nom)}")
    ax.set_xlabel(LABELS.get(key, key))
    ax.set_ylabel("samples")
    ax.set_ylim(0, 1.5 * ax.get_ylim()[1])  # headroom: the legend above the bars
    from matplotlib.ticker import MaxNLocator
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    missing = _missing(d, v)
    ax.legend(fontsize=8, title=missing, title_fontsize=7)
    return ax


def _missing(d: dict, v: np.ndarray) -> str | None:
    """The samples without a value of ``v``, by cause, for a legend title (None: every sample has one)."""
    f = d["figures"]
    bad = ~np.isfinite(v)
    if not bad.any():
        return None
    feas = np.asarray(f.get("feasible", np.ones(v.size, bool)), bool)
    edge = np.asarray(f["edge_contact"], bool)
    parts = []
    for n, what in ((int((bad & ~feas).sum()), "infeasible (teeth jam or separate)"),
                    (int((bad & feas & edge).sum()), "with edge contact"),
                    (int((bad & feas & ~edge).sum()), "other")):
        if n:
            parts.append(f"{n} {what}")
    return f"not shown: {int(bad.sum())} of {v.size} samples without a value\n(" + ", ".join(parts) + ")"


def plot_cdf(d: dict, key: str = "te_p2p", ax: Axes | None = None) -> Axes:
    """Empirical CDF of ``key`` over the samples whose value is defined."""
    ax = _ax(ax)
    allv = _values(d, key)
    v = np.sort(allv[np.isfinite(allv)])
    if v.size:
        ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", color="tab:blue",
                label=f"{v.size} of {allv.size} samples" + (" (the others have no value)" if v.size < allv.size else ""))
        for q in (0.5, 0.95):
            ax.axhline(q, color="0.7", lw=0.8)
        ax.legend(fontsize=8, loc="lower right")
    ax.set_xlabel(LABELS.get(key, key))
    ax.set_ylabel("share of samples <= value")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    return ax


def plot_scatter(d: dict, name: str, key: str = "te_p2p", ax: Axes | None = None, level: float = 0.05) -> Axes:
    """``key`` against the input ``name`` (its display unit), edge-contact samples in red (a legend
    only when there are some); the title gives the input's Spearman rho (with the input and with its
    distance from the median) and whether it is significant at ``level`` (:func:`significance_limit`)."""
    ax = _ax(ax)
    x, unit = display(name, d["inputs"][name])
    y = _values(d, key)
    edge = np.asarray(d["figures"]["edge_contact"], bool)
    ax.scatter(x[~edge], y[~edge], s=4, alpha=0.5, color="tab:blue", label="surface contact", rasterized=True)
    if edge.any():
        ax.scatter(x[edge], y[edge], s=6, alpha=0.7, color="tab:red", label="edge contact", rasterized=True)
        ax.legend(fontsize=7, markerscale=2)
    ax.set_xlabel(f"{input_label(name, unit)}\n({name})", fontsize=9)
    ax.set_ylabel(LABELS.get(key, key))
    row = next((r for r in d.get("sensitivities", {}).get(key, []) if r["input"] == name), None)
    if row is not None:
        n = int((np.isfinite(y) & np.asarray(d["figures"].get("ok", np.ones(y.size, bool)), bool)).sum())
        lim = significance_limit(n, level)
        sig = max(abs(row["spearman"]), abs(row["spearman_abs"])) >= lim
        ax.set_title(f"rho {row['spearman']:+.2f}, with |input - median| {row['spearman_abs']:+.2f}\n"
                     + ("significant" if sig else f"not significant: |rho| < {lim:.2f}") + f" at {100 * level:g} %, "
                     f"n = {n}", fontsize=8, color="k" if sig else "0.4")
    ax.grid(alpha=0.3)
    return ax


def plot_sensitivity(d: dict, key: str = "te_p2p", ax: Axes | None = None, level: float = 0.05) -> Axes:
    """Ranked influence of the inputs on ``key``: Spearman rank correlation with the input
    (monotonic effect) and with its distance from the median (even effect), as bars. Correlations
    within the band of no significance at ``level`` for the number n of samples with a value
    (:func:`significance_limit`) are drawn grey: indistinguishable from noise."""
    from matplotlib.patches import Patch

    ax = _ax(ax)
    rows = d["sensitivities"].get(key, [])[::-1]
    f = d["figures"]
    v = _values(d, key)
    n = int((np.isfinite(v) & np.asarray(f.get("ok", np.ones(v.size, bool)), bool)).sum())
    lim = significance_limit(n, level)
    y = np.arange(len(rows))
    ax.axvspan(-lim, lim, color="0.92", zorder=0,
               label=f"not significant at {100 * level:g} %:\n|rho| < 1.96/sqrt(n - 1) = {lim:.2f} (n = {n} samples)")
    for off, k, col, lab in ((0.2, "spearman", "tab:blue", "rho with the input (monotonic effect)"),
                             (-0.2, "spearman_abs", "tab:orange", "rho with |input - median| (even effect)")):
        val = np.array([r[k] for r in rows], float)
        sig = np.abs(val) >= lim
        ax.barh(y[sig] + off, val[sig], height=0.4, color=col, label=lab)
        ax.barh(y[~sig] + off, val[~sig], height=0.4, color=GREY, label=None)
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Patch(color=GREY))
    labels.append("either, not significant (noise)")
    ax.set_yticks(y, [input_label(r["input"], _unit(d, r["input"])) for r in rows], fontsize=8)
    ax.axvline(0, color="k", lw=0.8)
    ax.set_xlim(-1.05, 1.05)
    ax.set_ylim(-0.6, len(rows) - 0.4)
    ax.set_xlabel(f"Spearman rank correlation with the {LABELS.get(key, key).split(' [')[0]} (-1 ... 1)")
    _legend_below(ax, handles, labels, fontsize=7)
    return ax


def _legend_below(ax, handles, labels, fontsize=8, ncol=2, drop_in: float = 0.55):
    """A legend centred under the axes, ``drop_in`` inches below their bottom (clear of the tick
    labels and the x label, whatever the axes' height)."""
    from matplotlib.transforms import ScaledTranslation

    below = ax.transAxes + ScaledTranslation(0.0, -drop_in, ax.figure.dpi_scale_trans)
    ax.legend(handles, labels, fontsize=fontsize, loc="upper center", bbox_to_anchor=(0.5, 0.0), bbox_transform=below,
              ncol=ncol)


def _unit(d: dict, name: str) -> str | None:

    return display(name, 0.0)[1] if name in d.get("inputs", {}) else None


def plot_pattern_probability(d: dict, ax: Axes | None = None) -> Axes:
    """Probability of each point of the pinion flank (face position x radius) being in the contact
    pattern (the major axes of the contact ellipses of every pair over the mesh cycle), with the
    face ends, the tip and the form circle, and the nominal drive's pattern outline."""
    ax = _ax(ax)
    gz, gr = np.asarray(d["grid_z"]), np.asarray(d["grid_r"])
    prob = np.asarray(d["pattern_count"], float) / max(d["n"], 1)
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    # cells that no sample reached in a colour of their own (not the colour map's 0, not left blank)
    never = prob <= 0
    if never.any():
        ax.pcolormesh(gz, gr, np.where(never, 0.0, np.nan), cmap=ListedColormap([NEVER]), vmin=0, vmax=1,
                      shading="flat")
    m = ax.pcolormesh(gz, gr, np.where(prob > 0, prob, np.nan), cmap="viridis", vmin=0, vmax=1, shading="flat")
    ax.figure.colorbar(m, ax=ax, label=f"probability of contact ({d['n']} samples)")
    lim = d["limits"]
    b, r_a, r_f = lim["b"], lim["r_a"], lim["r_form"]
    ax.plot([-b / 2, b / 2, b / 2, -b / 2, -b / 2], [r_f, r_f, r_a, r_a, r_f], color="k", lw=1.2,
            label="active flank (face, form circle, tip)")
    nom = d.get("nominal") or {}
    zz, rr = nom.get("pattern_z_mm"), nom.get("pattern_radius_mm")
    if zz and rr and None not in zz and None not in rr:
        ax.plot([zz[0], zz[1], zz[1], zz[0], zz[0]], [rr[0], rr[0], rr[1], rr[1], rr[0]], color="tab:red", ls="--",
                lw=1.2, label="nominal pattern extent")
    handles, labels = ax.get_legend_handles_labels()
    if never.any():
        handles.append(Patch(color=NEVER))
        labels.append(f"no sample in contact there ({int(never.sum())} of {never.size} cells)")
    ax.set_xlabel("face position z [mm]")
    ax.set_ylabel("radius on the pinion [mm]")
    pad = 0.04 * b
    ax.set_xlim(-b / 2 - pad, b / 2 + pad)
    ax.set_ylim(r_f - 0.05 * (r_a - r_f), r_a + 0.05 * (r_a - r_f))
    _legend_below(ax, handles, labels, fontsize=8)
    return ax


def save_plots(result: RobustResult, out_dir: str | Path, dpi: int = 120) -> list[str]:
    """The figures of a Monte Carlo or design sweep result into ``out_dir`` (file names returned):
    ``distribution.png`` (histograms and CDFs of TE p2p and first harmonic), ``scatter.png`` (TE p2p
    against the four most influential inputs, edge contact marked), ``pattern.png`` (probability of
    each pinion flank point being in the contact pattern) and ``sensitivity.png`` (ranked Spearman
    correlations, those not significant at 5 % grey)."""
    import matplotlib.pyplot as plt

    from .saving import drawn_here

    out = Path(out_dir)

    frac = usable_fraction(result.figures)
    flag = f" [WARNING: only {100 * frac:.3g} % of the samples have results]" if frac < FEASIBLE_WARN else ""

    def save(name, fig, title):
        fig.suptitle(f"{result.scene}: {title}{flag}")
        fig.savefig(out / name, dpi=dpi, bbox_inches="tight")
        plt.close(fig)
        return name

    d = {"figures": result.figures, "inputs": result.inputs, "statistics": result.statistics(),
         "sensitivities": result.sensitivities(), "nominal": result.nominal}
    loaded = "loaded_te_p2p" in result.figures
    # a figure another process draws (gearopt run, gearopt.plot.saving) is not built here
    files = ["distribution.png"]
    if drawn_here(out / "distribution.png"):
        fig, axes = plt.subplots(3 if loaded else 2, 2, figsize=(12, 12 if loaded else 8), layout="constrained")
        plot_histogram(d, "te_p2p", ax=axes[0, 0])
        plot_cdf(d, "te_p2p", ax=axes[0, 1])
        plot_histogram(d, "h1", ax=axes[1, 0])
        plot_cdf(d, "h1", ax=axes[1, 1])
        if loaded:
            plot_histogram(d, "loaded_te_p2p", ax=axes[2, 0])
            plot_histogram(d, "p_max", ax=axes[2, 1])
        what = "Monte Carlo" if result.study == "montecarlo" else "design sweep"
        save("distribution.png", fig, f"{what} of {result.n} samples: TE peak-to-peak and first mesh harmonic"
             + ("; loaded TE and peak pressure" if loaded else ""))
    ranked = [r["input"] for r in d["sensitivities"].get("te_p2p", [])][:4]
    if ranked:
        files.append("scatter.png")
        if drawn_here(out / "scatter.png"):
            # two columns at most: four panels in one row shrink to unreadable text on a page or a screen
            cols = min(2, len(ranked))
            rows = -(-len(ranked) // cols)
            fig, axes = plt.subplots(rows, cols, figsize=(5.5 * cols, 4.2 * rows), squeeze=False,
                                     layout="constrained")
            for ax, nm in zip(axes.ravel(), ranked):
                plot_scatter(d, nm, "te_p2p", ax=ax)
            for ax in axes.ravel()[len(ranked):]:
                ax.set_visible(False)
            save("scatter.png", fig, "TE peak-to-peak against the most influential inputs")
        files.append("sensitivity.png")
        if drawn_here(out / "sensitivity.png"):
            fig, ax = plt.subplots(figsize=(9, 0.5 + 0.45 * len(d["sensitivities"]["te_p2p"]) + 2.2),
                                   layout="constrained")
            plot_sensitivity(d, "te_p2p", ax=ax)
            save("sensitivity.png", fig, "which inputs drive the TE peak-to-peak (Spearman rank correlation)")
    files.append("pattern.png")
    if drawn_here(out / "pattern.png"):
        fig, ax = plt.subplots(figsize=(9, 5.5), layout="constrained")
        plot_pattern_probability({"pattern_count": result.pattern_count, "grid_z": result.grid_z,
                                  "grid_r": result.grid_r, "n": int(result.figures["ok"].sum()),
                                  "limits": result.limits, "nominal": result.nominal}, ax=ax)
        save("pattern.png", fig, "contact pattern envelope on the pinion flank (every pair over the cycle)")
    return files
