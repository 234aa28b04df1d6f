"""What every comparison figure shares (:mod:`gearopt.plot.compare`): one colour per design, one line
style per misalignment case, the cases of several designs matched by their misalignment, the legend
below the axes and the grid of panels.

Units: misalignments as in results.json (``*_arcmin`` [arcmin], ``*_mm`` [mm]); figure sizes in
inches.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["LEGEND_BELOW", "floats", "design_color", "line_width", "case_style", "case_key", "case_name",
           "match_cases", "legend_below", "panel_grid"]

_LINESTYLES = ("-", "--", ":", "-.")
#: the keyword arguments of a legend below its axes, one entry a line
LEGEND_BELOW: dict[str, Any] = dict(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=1, frameon=False)


def floats(v: Any) -> np.ndarray:
    """A sequence of numbers read from results.json as a float array, ``None`` (no value) as NaN."""
    return np.array([np.nan if x is None else x for x in v], dtype=float)


def design_color(i: int) -> str:
    """Colour of the ``i``-th design (0 = the reference), the same in every comparison figure."""
    return f"C{i % 10}"


def line_width(i: int) -> float:
    """Line width [pt] of the ``i``-th design: the first, the reference, drawn thicker."""
    return 2.6 if i == 0 else 1.7


def case_style(j: int) -> str:
    """Line style of the ``j``-th misalignment case (0: the first, usually the aligned drive)."""
    return _LINESTYLES[j % len(_LINESTYLES)]


def case_key(misalignment: Mapping[str, float] | None) -> tuple:
    """A hashable key of a misalignment (``{"crossing_arcmin": 3.0, ...}``): its non-zero kinds,
    rounded to 1e-6 of their unit; ``()`` for the aligned drive. Cases of different designs with
    the same key are the same operating condition."""
    if not misalignment:
        return ()
    return tuple(sorted((k, round(float(v), 6)) for k, v in misalignment.items() if v))


def case_name(misalignment: Mapping[str, float] | None) -> str:
    """The misalignment in words: ``"aligned"``, ``"crossing +3 arcmin"``, ``"dE +0.05 mm, ..."``."""
    key = case_key(misalignment)
    if not key:
        return "aligned"
    parts = []
    for k, v in key:
        for suffix in ("_arcmin", "_mm"):
            if k.endswith(suffix):
                parts.append(f"{k[:-len(suffix)]} {v:+g} {suffix[1:]}")
                break
        else:
            parts.append(f"{k} {v:+g}")
    return ", ".join(parts)


def match_cases(per_design: Mapping[str, Sequence[dict]]) -> list[tuple[tuple, str, dict[str, dict]]]:
    """Group the cases of several designs by their misalignment (:func:`case_key`).

    Returns
    -------
    list of (key, name, {label: case})
        One entry per misalignment found, in the order of first appearance (the first design's
        cases first); ``name`` is :func:`case_name` of it. A design without that case is absent
        from its dict.
    """
    out: dict[tuple, tuple[str, dict[str, dict]]] = {}
    for label, cases in per_design.items():
        for c in cases:
            key = case_key(c.get("misalignment"))
            if key not in out:
                out[key] = (case_name(c.get("misalignment")), {})
            out[key][1].setdefault(label, c)
    return [(k, name, by) for k, (name, by) in out.items()]


def legend_below(ax: Axes, **kw: Any) -> None:
    """The legend of ``ax`` below the axes (:data:`LEGEND_BELOW`, updated by ``kw``); none when
    nothing is labelled."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        ax.legend(**{**LEGEND_BELOW, **kw})


def panel_grid(n: int, width: float = 5.2, height: float = 4.2, ncols: int = 3) -> tuple[Figure, list[Axes]]:
    """A figure of ``n`` panels, ``ncols`` a row at most, each ``width`` x ``height`` [in] (plus
    0.6 in a row for the legend); the unused cells of the last row hidden.

    Returns
    -------
    (Figure, list of Axes)
        The figure and its ``n`` panels, row by row.
    """
    import matplotlib.pyplot as plt

    cols = min(n, ncols)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows + 0.6 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, list(axes.flat[:n])

