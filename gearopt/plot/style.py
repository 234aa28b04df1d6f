"""One plot style for every figure gearopt writes: plain tick labels (no offset such as "+3e1", no
"1.27e+03" for ordinary ranges), legends that do not hide the data, figures saved with every title
and legend inside the image.

:func:`write_results` (``gearopt run``) draws every study's plots inside :func:`plot_style`; an API user
calling a result's ``save_plots`` or a plot function directly gets the same figures with::

    from gearopt.plot.style import plot_style
    with plot_style():
        report.save_plots("out")

or :func:`use_style` once (it changes ``matplotlib.rcParams`` for the session). Neither picks the
backend: only the CLI does (``MPLBACKEND=Agg``).

:func:`number` writes a value for a label or a legend in the same plain notation.
"""

from __future__ import annotations

import contextlib
import math
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterator

    from matplotlib.axes import Axes

__all__ = ["RC", "axes_or_new", "plot_style", "use_style", "number"]

#: matplotlib rcParams of gearopt's figures
RC = {
    # tick labels as plain numbers: no offset text ("+3e1", "1e-3" above the axis) on any axis, and
    # scientific notation only outside 1e-5 ... 1e6 (the magnitude of the axis's values)
    "axes.formatter.useoffset": False,
    "axes.formatter.limits": (-5, 6),
    # tick labels as plain text: with use_mathtext every label ("5", "-10") is parsed and laid out by
    # mathtext, about a quarter of the time of a figure; the two look alike (both use the minus sign
    # U+2212), and a scale factor, where one is left, reads "1e-7" instead of "x10^-7"
    "axes.formatter.use_mathtext": False,
    # a legend's frame covers what lies beneath: mostly opaque, so that a legend over a curve is
    # noticed (and avoided by loc="best") rather than read through
    "legend.framealpha": 0.9,
    # the saved image holds every artist (titles, legends outside the axes, colour bars)
    "savefig.bbox": "tight",
    "savefig.pad_inches": 0.1,
}


def axes_or_new(ax: Axes | None) -> Axes:
    """``ax``, or the Axes of a new figure when ``ax`` is None (every plot function's ``ax=``)."""
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.figure().gca()
    return ax


@contextlib.contextmanager
def plot_style(**overrides: Any) -> Iterator[None]:
    """Context manager: gearopt's plot style (:data:`RC`, updated by ``overrides``, rcParams names
    with dots written as ``__``, e.g. ``legend__fontsize=8``) for the figures made inside it."""
    import matplotlib

    rc = dict(RC)
    rc.update({k.replace("__", "."): v for k, v in overrides.items()})
    with matplotlib.rc_context(rc):
        yield


def use_style() -> None:
    """Set gearopt's plot style (:data:`RC`) in ``matplotlib.rcParams`` for the rest of the session."""
    import matplotlib

    matplotlib.rcParams.update(RC)


def number(v: float, digits: int = 3) -> str:
    """``v`` in plain notation for 1e-4 <= |v| < 1e6 (``1274``, ``7.49``, ``0.0123``, never
    ``1.27e+03``): ``digits`` significant digits, but every digit before the point; trailing zeros
    dropped, no negative zero. Scientific notation outside that range; ``"nan"``/``"inf"`` as such."""
    if not math.isfinite(v):
        return str(v)
    if v == 0:
        return "0"
    mag = math.floor(math.log10(abs(v)))
    if not -4 <= mag < 6:
        return f"{v:.{max(digits - 1, 0)}e}"
    dec = max(digits - 1 - mag, 0)
    s = f"{round(v, dec):.{dec}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "+0") else s
