"""Comparison of gear dynamics (:mod:`gearopt.plot.compare`): the dynamic factor K_v against pinion
speed of ``dynamics`` designs, one panel per case two designs or more have (each panel drawn by
:func:`gearopt.plot.dynamics.plot_compare_dynamic_factor`).

Units: speed in rpm; K_v is dimensionless.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .common import panel_grid

if TYPE_CHECKING:
    from collections.abc import Mapping

__all__ = ["dynamics_figures"]


def dynamics_figures(designs: Mapping[str, dict]) -> list[tuple[str, str, Any]]:
    """The dynamics figure (``compare_dynamics.png``: K_v against pinion speed per case) when two
    designs or more are ``dynamics`` runs with a case of the same name.

    Returns
    -------
    list of (file name, caption, matplotlib Figure)
    """
    out: list[tuple[str, str, Any]] = []
    dyn = {lab: r for lab, r in designs.items() if r.get("study") == "dynamics" and r.get("cases")}
    if len(dyn) >= 2:
        from ..dynamics import plot_compare_dynamic_factor

        names = list(dict.fromkeys(c["name"] for r in dyn.values() for c in r["cases"]))
        names = [n for n in names if sum(any(c["name"] == n for c in r["cases"]) for r in dyn.values()) >= 2]
        if names:
            fig, axes = panel_grid(len(names), width=7.0, height=5.0, ncols=2)
            for ax, n in zip(axes, names):
                plot_compare_dynamic_factor(dyn, n, ax=ax)
            fig.suptitle("gear dynamics: dynamic factor against pinion speed, one panel per case", fontsize=10)
            out.append(("compare_dynamics.png",
                        "Dynamic factor K_v of each design against pinion speed, per case, with each design's ISO "
                        "n_E1: which design resonates where, how high K_v rises there and from which speed its teeth "
                        "lose contact (x).", fig))
    return out
