"""How ``gearopt run`` saves figures: PNG files written faster, and the figures of a run shared out
between processes that draw them side by side (:mod:`gearopt.cli_plots`).

:func:`png_saving` is a context manager around a study's ``save_plots``; while it is active,
``Figure.savefig`` to a ``.png`` path

* compresses with zlib level ``compress_level`` (default :data:`PNG_COMPRESS_LEVEL`, 1) instead of
  Pillow's 6, unless the call gives ``pil_kwargs={"compress_level": ...}``: the same pixels, the
  file about 5 % larger, the encoding about twice as fast (it is a tenth of the time of a figure);
* saves a figure laid out by matplotlib's constrained layout with ``bbox_inches="tight"`` (gearopt's
  style) after one layout and one draw, as the figure's area with the ``pad_inches`` margin around
  the layout's own padding, instead of the layout, a draw to place the artists, a pass for their
  extents (the tight box) and the draw: a quarter to a third less time, the same picture, the
  image a few pixels larger where the layout leaves room at an edge. A figure with anything the
  layout does not place (a figure legend, a text but the sup-title and -labels, ...) or with an
  axes of fixed aspect (narrower than its cell: room the tight box crops) is saved as usual. The
  layout runs without the spines whose extent the rest of their axes' tight box holds (the same
  positions; each spine's extent would update its axis's ticks once more);
* with ``claims`` (a directory shared by several processes that run the same ``save_plots`` side
  by side) draws and writes a PNG file only if this process is the first to reach it (creates
  its claim file there); a process that finds a file taken moves on to the next, so that a
  process done with a quick figure takes the next one while another draws a slow one. Between
  them the processes write every file once. :func:`drawn_here` tells a ``save_plots`` whether to
  build a figure at all; a figure built but taken by another process is neither drawn nor
  written. Saving to a file object or another format is never shared out.

It picks no backend; figures saved outside it are saved as matplotlib does.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterator

__all__ = ["PNG_COMPRESS_LEVEL", "drawn_here", "png_saving"]

#: zlib compression level of the PNG files gearopt run writes (0-9; Pillow's default is 6)
PNG_COMPRESS_LEVEL = 1


@contextlib.contextmanager
def png_saving(claims: str | os.PathLike | None = None,
               compress_level: int = PNG_COMPRESS_LEVEL) -> Iterator[None]:
    """Context manager: ``Figure.savefig`` to ``.png`` paths with ``compress_level``, a constrained
    layout laid out once, and with ``claims`` only the files this process reaches first (see the
    module docstring).

    Parameters
    ----------
    claims : path, optional
        An existing directory shared by the processes that draw the same figures side by side
        (it gets one empty file per PNG file); None: every file is drawn here.
    compress_level : int
        zlib level of the PNG files, 0 (none, fastest) ... 9 (smallest).

    Raises
    ------
    ValueError
        ``compress_level`` outside 0 ... 9, or ``claims`` not a directory.
    """
    if not 0 <= compress_level <= 9:
        raise ValueError(f"png_saving: compress_level = {compress_level}: need 0 ... 9")
    if claims is not None and not os.path.isdir(claims):
        raise ValueError(f"png_saving: claims = {os.fspath(claims)!r}: not a directory")
    import matplotlib.figure

    saved = matplotlib.figure.Figure.savefig
    share = _Share(None if claims is None else os.fspath(claims))

    def savefig(fig: Any, fname: Any, *args: Any, **kwargs: Any) -> Any:
        fmt = kwargs.get("format")
        if isinstance(fname, (str, os.PathLike)) and (
                str(fmt).lower() == "png" if fmt is not None else os.fspath(fname).lower().endswith(".png")):
            if not share.owns(fname):
                return None
            kwargs["pil_kwargs"] = {"compress_level": compress_level, **(kwargs.get("pil_kwargs") or {})}
            if not args and _tight_by_layout(fig, kwargs):
                return _save_laid_out(saved, fig, fname, kwargs)
        return saved(fig, fname, *args, **kwargs)

    matplotlib.figure.Figure.savefig = savefig
    _shares.append(share)
    try:
        yield
    finally:
        _shares.remove(share)
        matplotlib.figure.Figure.savefig = saved


class _Share:
    """The PNG files of one :func:`png_saving`: with a claims directory, those this process claimed
    first (an exclusive create of the claim file is atomic between processes)."""

    def __init__(self, claims: str | None) -> None:
        self.claims = claims
        self.mine: dict[str, bool] = {}

    def owns(self, path: Any) -> bool:
        if self.claims is None:
            return True
        key = os.path.abspath(os.fspath(path))
        if key not in self.mine:
            name = hashlib.sha1(key.encode("utf-8", "surrogateescape")).hexdigest()
            try:
                os.close(os.open(os.path.join(self.claims, name), os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
                self.mine[key] = True
            except FileExistsError:
                self.mine[key] = False
        return self.mine[key]


_shares: list[_Share] = []  # the active png_saving contexts, innermost last


def drawn_here(path: str | os.PathLike) -> bool:
    """Whether the PNG file ``path`` is drawn in this process: False only inside
    :func:`png_saving` with ``claims`` when another process has taken the file (then ``savefig``
    to it writes nothing, and a ``save_plots`` may skip building the figure; it still returns the
    file's name). True claims the file for this process: call it just before building the
    figure.

    Parameters
    ----------
    path : path
        The PNG file a figure is about to be saved to.

    Returns
    -------
    bool
    """
    return not _shares or _shares[-1].owns(path)


def _tight_by_layout(fig: Any, kwargs: dict) -> bool:
    """Whether ``fig``, saved with ``bbox_inches="tight"``, can be saved as its constrained layout
    leaves it: laid out by the constrained layout engine, nothing outside the layout's reach
    (figure legends, texts other than the sup-title and -labels, lines, patches, images, subfigures)
    and no axes of fixed aspect (a mesh drawn to scale: the layout leaves room beside it)."""
    import matplotlib
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    bbox = kwargs.get("bbox_inches", matplotlib.rcParams["savefig.bbox"])
    pad = kwargs.get("pad_inches", matplotlib.rcParams["savefig.pad_inches"])
    if bbox != "tight" or not isinstance(pad, (int, float)) or kwargs.get("bbox_extra_artists"):
        return False
    if not isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine) or not fig.axes:
        return False
    if fig.legends or fig.lines or fig.patches or fig.images or fig.artists or fig.subfigs:
        return False
    if any(ax.get_aspect() != "auto" for ax in fig.axes):  # narrower than its cell: tight crops the room
        return False
    sup = {fig.get_suptitle(), fig.get_supxlabel(), fig.get_supylabel()} - {""}
    return all(t.get_text() in sup and t.get_in_layout() for t in fig.texts)


def _covered_spines(fig: Any) -> list:
    """The spines of ``fig``'s axes whose extent the constrained layout can leave out, as the
    rest of their axes' tight box holds it: the layout gives the same positions without them, and
    it does not update each spine's axis's ticks once more to find how far its tick marks stick
    out (four spines per axes, two layout passes: a few per cent of a figure's drawing time).

    A spine at its default place (the axes' edge, inside the axes' box) qualifies where no tick
    mark of its side sticks out beyond the box (the top and right spines with ticks on the bottom
    and left only, or ticks pointing in), or where the tick labels of its side stick out further
    (the bottom and left spines of an axis with a plain number formatter, whose labels sit a pad
    beyond the tick marks). Spines not in the layout already, moved, or of an axis with other
    labels are left in it."""
    from matplotlib.ticker import ScalarFormatter

    out = []
    for ax in fig.axes:
        if not ax.axison:
            continue
        for side, spine in ax.spines.items():
            axis = getattr(spine, "axis", None)
            if (side not in ("left", "right", "top", "bottom") or axis is None or not spine.get_in_layout()
                    or spine.get_position() != ("outward", 0.0)):
                continue
            if not axis.get_visible():
                out.append(spine)  # the spine's extent is its line on the axes' edge
                continue
            first = side in ("left", "bottom")  # tick1 and label1 of the axis are on this side
            major, minor = axis.majorTicks[0], axis.minorTicks[0]
            if not any((t.tick1line if first else t.tick2line).get_visible() and t.get_tickdir() != "in"
                       for t in (major, minor)):
                out.append(spine)  # no tick mark sticks out of the axes' box on this side
            elif first and major.label1.get_visible() and isinstance(axis.get_major_formatter(), ScalarFormatter):
                out.append(spine)  # the tick labels stick out further
    return out


def _save_laid_out(saved: Any, fig: Any, fname: Any, kwargs: dict) -> Any:
    """Save ``fig`` (see :func:`_tight_by_layout`) laid out once by its constrained layout and
    drawn once, the image the figure's area with the margin ``pad_inches`` around the layout's own
    padding: what ``bbox_inches="tight"`` gives, where the layout fills the figure, without the
    two extra passes over every artist that finding the tight box takes (a draw to place them,
    then their extents). Where the layout leaves room (an axes of fixed aspect narrower than its
    cell; not taken here), that room would stay in the image. Falls back to the usual
    ``savefig`` when the layout engine warns (it could not fit the decorations)."""
    import warnings

    import matplotlib
    from matplotlib.transforms import Bbox

    engine = fig.get_layout_engine()
    dpi = kwargs.get("dpi", matplotlib.rcParams["savefig.dpi"])
    if dpi == "figure" or dpi is None:
        dpi = fig.dpi
    pad = kwargs.get("pad_inches", matplotlib.rcParams["savefig.pad_inches"])
    info = engine.get()
    dx, dy = pad - info["w_pad"], pad - info["h_pad"]
    original = fig.dpi
    fig.dpi = dpi  # the layout as savefig makes it: text measured at the saving resolution
    covered = _covered_spines(fig)
    try:
        for spine in covered:
            spine.set_in_layout(False)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            engine.execute(fig)
    finally:
        fig.dpi = original
        for spine in covered:
            spine.set_in_layout(True)
    if caught:  # not laid out (the usual savefig will warn again)
        return saved(fig, fname, **kwargs)
    w, h = fig.get_size_inches()
    fig.set_layout_engine(None)  # laid out: the axes stay where they are, and savefig draws only once
    if fig.get_layout_engine() is not None:  # the rcParams ask for a layout engine
        fig.set_layout_engine(engine)
        return saved(fig, fname, **kwargs)
    try:
        return saved(fig, fname, **{**kwargs, "bbox_inches": Bbox.from_extents(-dx, -dy, w + dx, h + dy)})
    finally:
        fig.set_layout_engine(engine)
