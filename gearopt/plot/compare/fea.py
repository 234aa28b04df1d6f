"""Comparison of finite element designs (:mod:`gearopt.plot.compare`): the ``fea`` study's loaded
TE, contact pressure and root stress per position.

Units: TE in arcsec (positive when the gear is ahead), pinion angle in deg, pressure and stress in
MPa, torque in N m.
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

__all__ = ["fea_positions", "plot_fea", "fea_figures"]


def fea_positions(res: dict) -> dict[str, np.ndarray] | None:
    """The FE positions of a design (``fea`` study): pinion angle ``phi1`` [rad], loaded TE
    ``te`` [arcsec], largest contact pressure ``p_max`` [MPa] and the largest principal root stress
    at mid face ``root_pinion``, ``root_gear`` [MPa] per position (NaN where absent); None for other
    studies."""
    if res.get("study") != "fea" or not res.get("positions"):
        return None
    pos = res["positions"]

    def col(get) -> np.ndarray:
        out = []
        for p in pos:
            try:
                v = get(p)
            except (KeyError, TypeError):
                v = None
            out.append(np.nan if v is None else float(v))
        return np.array(out, float)

    return {"phi1": col(lambda p: p["phi1"]), "te": col(lambda p: p["loaded_te_arcsec"]),
            "p_max": col(lambda p: p["contact"]["p_max"]),
            "root_pinion": col(lambda p: p["root"]["pinion"]["max_principal_mid"]),
            "root_gear": col(lambda p: p["root"]["gear"]["max_principal_mid"])}


def plot_fea(designs: Mapping[str, dict], quantity: str = "te", ax: Axes | None = None) -> Axes:
    """One FE quantity per position against the pinion angle [deg] (:func:`fea_positions`: ``te``
    loaded TE [arcsec], ``p_max`` contact pressure [MPa], ``root`` root stress of pinion (solid) and
    gear (dashed) [MPa]), one colour per design, the torque in the legend."""
    import matplotlib.pyplot as plt

    ax = ax or plt.figure().gca()
    text = {"te": ("loaded TE [arcsec] (+: gear ahead)", "loaded TE per position"),
            "p_max": ("largest contact pressure [MPa]", "contact pressure per position"),
            "root": ("largest principal root stress, mid face [MPa]", "root stress per position (dashed: gear)")}
    for i, (label, res) in enumerate(designs.items()):
        f = fea_positions(res)
        if f is None:
            continue
        phi = np.degrees(f["phi1"])
        torque = (res.get("options") or {}).get("torque_Nmm")
        lab = label + ("" if torque is None else f": {number(torque / 1000.0)} N m")
        keys = ["root_pinion", "root_gear"] if quantity == "root" else [quantity]
        for k, ls in zip(keys, ("-", "--")):
            ax.plot(phi, f[k], "o", ls=ls, color=design_color(i), lw=line_width(i), ms=5,
                    label=lab if ls == "-" else None)
    ax.set_xlabel("pinion angle phi1 [deg]")
    ax.set_ylabel(text[quantity][0])
    ax.set_title(text[quantity][1], fontsize=9)
    ax.grid(alpha=0.3)
    legend_below(ax)
    plain_ticks(ax)
    return ax


def fea_figures(designs: Mapping[str, dict]) -> list[tuple[str, str, Any]]:
    """The FE figure (``compare_fea.png``: loaded TE, contact pressure, root stress per position)
    when two designs or more are ``fea`` runs.

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    if sum(fea_positions(r) is not None for r in designs.values()) >= 2:
        fig, axes = panel_grid(3, width=5.2)
        for ax, q in zip(axes, ("te", "p_max", "root")):
            plot_fea(designs, q, ax=ax)
        fig.suptitle("finite element model (CalculiX) per position", fontsize=10)
        out.append(("compare_fea.png",
                    "FE loaded TE, contact pressure and root stress per position: the stiffer, less loaded design at "
                    "each position (the torques are in the legends).", fig))
    return out
