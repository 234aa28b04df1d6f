"""Comparison of Monte Carlo and sweep designs (:mod:`gearopt.plot.compare`): the cumulative
distributions of their sampled results (the columns of each design's ``samples.csv``).

Units: those of the column (TE in arcsec, pressure in MPa); the share of samples is dimensionless.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..style import number
from ..ticks import plain_ticks
from .common import design_color, legend_below, line_width, panel_grid

if TYPE_CHECKING:
    from collections.abc import Mapping

    from matplotlib.axes import Axes

__all__ = ["plot_distribution", "distribution_figures"]


def plot_distribution(samples: Mapping[str, Mapping[str, np.ndarray]], column: str = "te_p2p_arcsec",
                      ax: Axes | None = None, xlabel: str | None = None) -> Axes:
    """Empirical cumulative distributions of one sampled result (a column of the designs'
    ``samples.csv``, e.g. TE peak-to-peak [arcsec]) of Monte Carlo or sweep designs, one colour per
    design, with each design's median marked.

    Parameters
    ----------
    samples : mapping label -> {column: values}
        Per design, the columns of its samples table (empty cells NaN).
    column : str
    ax : Axes, optional
    xlabel : str, optional
        The axis label (default: the column name).
    """
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    for i, (label, cols) in enumerate(samples.items()):
        v = np.asarray(cols.get(column, []), float)
        v = np.sort(v[np.isfinite(v)])
        if not v.size:
            continue
        p = np.arange(1, v.size + 1) / v.size
        med = float(np.median(v))
        ax.step(v, p, where="post", color=design_color(i), lw=line_width(i),
                label=f"{label}: median {number(med)}, p95 {number(float(np.percentile(v, 95)))} (n = {v.size})")
        ax.plot([med], [0.5], "o", color=design_color(i), ms=5)
    ax.set_xlabel(xlabel or column)
    ax.set_ylabel("share of samples at or below [-]")
    ax.set_ylim(0, 1.02)
    ax.set_title(f"distribution over the samples: {xlabel or column}", fontsize=9)
    ax.grid(alpha=0.3)
    legend_below(ax)
    plain_ticks(ax)
    return ax


def distribution_figures(samples: Mapping[str, Mapping[str, np.ndarray]] | None) -> list[tuple[str, str, Any]]:
    """The distributions (``compare_distribution.png``) of the sampled results that two designs or
    more have: TE peak-to-peak, first harmonic, loaded TE peak-to-peak, peak pressure.

    Parameters
    ----------
    samples : mapping label -> {column: values}, optional
        The samples tables of Monte Carlo / sweep designs.

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    mc = {lab: s for lab, s in (samples or {}).items() if s}
    if len(mc) >= 2:
        cols = [c for c in ("te_p2p_arcsec", "h1_arcsec", "loaded_te_p2p_arcsec", "p_max_MPa")
                if sum(np.isfinite(np.asarray(s.get(c, []), float)).any() for s in mc.values()) >= 2]
        text = {"te_p2p_arcsec": "TE peak-to-peak [arcsec]", "h1_arcsec": "1st mesh harmonic of TE [arcsec]",
                "loaded_te_p2p_arcsec": "loaded TE peak-to-peak [arcsec]", "p_max_MPa": "peak flank pressure [MPa]"}
        if cols:
            fig, axes = panel_grid(len(cols), ncols=2, width=5.6)
            for ax, c in zip(axes, cols):
                plot_distribution(mc, c, ax=ax, xlabel=text[c])
            fig.suptitle("Monte Carlo / sweep distributions", fontsize=10)
            out.append(("compare_distribution.png",
                        "Cumulative distributions over the samples: a curve further left is the better design; "
                        "the median and 95th percentile of each are in the legend.", fig))
    return out
