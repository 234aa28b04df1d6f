"""Tick labels a reader can take at face value: no offset ("+3e1") and no scale factor ("1e3")
printed at the end of an axis, so that every tick label is the value itself."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.colorbar import Colorbar

__all__ = ["plain_ticks"]


def plain_ticks(*axes: Axes | Colorbar) -> Axes | None:
    """Turn off the offset and the scientific scale factor of every linear axis of ``axes``
    (Axes or Colorbar objects; twin axes are separate Axes and must be passed too). Logarithmic
    and categorical axes keep their own formatters. Returns the first Axes (or None)."""
    from matplotlib.ticker import ScalarFormatter

    for a in axes:
        ax = getattr(a, "ax", a)  # a Colorbar draws on its own Axes
        for axis in (ax.xaxis, ax.yaxis):
            fmt = axis.get_major_formatter()
            if isinstance(fmt, ScalarFormatter):
                fmt.set_useOffset(False)
                fmt.set_scientific(False)
    return getattr(axes[0], "ax", axes[0]) if axes else None
