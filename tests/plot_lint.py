"""Mechanical checks of a matplotlib figure, as a gear engineer would first see its faults:
:func:`lint_figure` draws the figure and lists what it finds.

Checks (each problem names the axes by its title, else its axis labels):

* no axis shows an offset text ("+3e1", "1e-3" beside the ticks): the values must be readable from
  the tick labels alone; no tick label in mantissa-times-power form ("9.4x10^1", "1.27e+03") and
  no negative zero ("-0.00") in a tick label or any text;
* every legend entry stands for something drawn: an artist with that label that shows data inside
  the axes (not empty, not all NaN, not a zero-height bar), or, for a proxy entry (a style key such as
  "dashed: before"), a drawn artist of the same line style and marker, in the same colour unless the
  key is black or grey;
* titles, axis labels, texts and legends lie inside the saved image (the figure, or its tight
  bounding box when saved with ``bbox_inches="tight"``);
* no title, axis label or legend of one axes overlaps another axes or its texts, and the figure's
  title overlaps no axes title;
* no legend inside the axes covers the data (more than 1 % of the drawn points, at least 4) when
  a corner or edge position of the same size would cover (almost) none.
"""

from __future__ import annotations

import re

import numpy as np

#: a legend covers the data when it holds more than this share of the drawn points (and > MIN_POINTS)
OVER_SHARE = 0.01
MIN_POINTS = 3
#: spacing of the points sampled along drawn lines [px]
STEP_PX = 2.0

_SCI = re.compile(r"\d\s*[eE][+-]?\d|\\times\s*10|×\s*10")
_NEG_ZERO = re.compile(r"(?<![\w.])[-\u2212]0(?:\.0+)?(?![\d.])")


def lint_figure(fig, tight: bool | None = None) -> list[str]:
    """The problems found in ``fig`` (an empty list: none).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure as it will be saved (it is drawn here).
    tight : bool, optional
        Whether it is saved with ``bbox_inches="tight"`` (the image is the figure's tight bounding
        box); default: ``rcParams["savefig.bbox"] == "tight"``.
    """
    import matplotlib

    if tight is None:
        tight = matplotlib.rcParams["savefig.bbox"] == "tight"
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    out: list[str] = []
    axes = [ax for ax in fig.axes if ax.get_visible()]
    for ax in axes:
        out += _tick_problems(ax)
    out += _negative_zero_texts(fig)
    for ax in axes:
        leg = ax.get_legend()
        if leg is not None and leg.get_visible():
            out += _legend_entries(leg, ax, _twins(ax, axes), r)
            out += _legend_over_data(leg, ax, _twins(ax, axes), r)
    for leg in fig.legends:
        out += _legend_entries(leg, None, axes, r)
    out += _outside(fig, axes, r, tight)
    out += _overlaps(fig, axes, r)
    return out


# --- names ---------------------------------------------------------------------------------------
def axes_name(ax) -> str:
    """The axes as a reader finds it: its title, else its axis labels, else its position."""
    for loc in ("center", "left", "right"):
        t = ax.get_title(loc).strip()
        if t:
            return f"axes {t.splitlines()[0][:60]!r}"
    lab = " / ".join(s for s in (ax.get_ylabel().strip(), ax.get_xlabel().strip()) if s)
    if lab:
        return f"axes [{lab[:60]}]"
    fig = ax.figure
    return f"axes #{fig.axes.index(ax)}"


def _strip(s: str) -> str:
    return s.replace("$", "").replace("\\mathdefault{", "").replace("}", "").replace("{", "").strip()


# --- ticks ---------------------------------------------------------------------------------------
def _axes_of(ax):
    out = [("x", ax.xaxis), ("y", ax.yaxis)]
    if hasattr(ax, "zaxis"):
        out.append(("z", ax.zaxis))
    return out


def _tick_problems(ax) -> list[str]:
    out = []
    for nm, axis in _axes_of(ax):
        if not axis.get_visible():
            continue
        off = axis.get_offset_text()
        if off.get_visible() and off.get_text().strip():
            out.append(f"{axes_name(ax)}: {nm} axis shows the offset text {off.get_text()!r} (tick labels must "
                       "read as values)")
        lo, hi = sorted(axis.get_view_interval())
        tol = 1e-9 * max(abs(lo), abs(hi), 1e-300)
        for which in (axis.major, axis.minor):
            try:
                locs = np.asarray(which.locator(), float)
            except Exception:  # a locator that cannot tick this view (e.g. too many ticks)
                continue
            locs = locs[(locs >= lo - tol) & (locs <= hi + tol)]
            if not locs.size:
                continue
            labels = which.formatter.format_ticks(list(locs))
            bad = [s for s in labels if s and _SCI.search(s)]
            if bad:
                out.append(f"{axes_name(ax)}: {nm} tick labels in scientific form {[_strip(s) for s in bad[:3]]}")
            neg = [s for s in labels if s and _NEG_ZERO.fullmatch(_strip(s))]
            if neg:
                out.append(f"{axes_name(ax)}: {nm} tick label negative zero {_strip(neg[0])!r}")
    return out


def _negative_zero_texts(fig) -> list[str]:
    from matplotlib.text import Text

    out = []
    ticks = set()
    for ax in fig.axes:
        for _, axis in _axes_of(ax):
            for t in axis.get_major_ticks() + axis.get_minor_ticks():
                ticks.update((id(t.label1), id(t.label2)))
    for t in fig.findobj(Text):
        if id(t) in ticks or not t.get_visible():
            continue
        s = _strip(t.get_text())
        m = _NEG_ZERO.search(s)
        if m:
            out.append(f"text {s[:70]!r}: negative zero {m.group(0)!r}")
    return out


# --- legend entries ------------------------------------------------------------------------------
def _twins(ax, axes):
    """``ax`` and the axes drawn in the same box (twinx/twiny)."""
    b = ax.get_position().bounds
    return [ax] + [o for o in axes if o is not ax and np.allclose(o.get_position().bounds, b)]


def _artists(ax):
    return list(ax.lines) + list(ax.collections) + list(ax.patches) + list(ax.images) + list(ax.containers)


def _inside(ax, pts, pad=1.0):
    b = ax.bbox
    return (pts[:, 0] >= b.x0 - pad) & (pts[:, 0] <= b.x1 + pad) & (pts[:, 1] >= b.y0 - pad) & (pts[:, 1] <= b.y1 + pad)


def _line_drawn(ln, ax) -> bool:
    if not ln.get_visible() or ln.get_alpha() == 0:
        return False
    xy = np.asarray(ln.get_xydata(), float)
    if xy.size == 0:
        return False
    fin = np.isfinite(xy).all(axis=1)
    if not fin.any():
        return False
    pts = ln.get_transform().transform(np.where(fin[:, None], xy, 0.0))
    ins = _inside(ax, pts) & fin if ln.get_clip_on() else fin
    has_marker = ln.get_marker() not in (None, "None", "", " ", "none") and ln.get_markersize() > 0
    has_line = ln.get_linestyle() not in ("None", "", " ", "none") and ln.get_linewidth() > 0
    if has_marker and ins.any():
        return True
    if has_line:
        seg = fin[:-1] & fin[1:]
        if not seg.any():
            return False
        if not ln.get_clip_on():
            return True
        for i in np.flatnonzero(seg):
            a, b = pts[i], pts[i + 1]
            if (max(a[0], b[0]) >= ax.bbox.x0 and min(a[0], b[0]) <= ax.bbox.x1
                    and max(a[1], b[1]) >= ax.bbox.y0 and min(a[1], b[1]) <= ax.bbox.y1):
                return True
    return False


def _extent_drawn(art, ax, r) -> bool:
    if not art.get_visible():
        return False
    from matplotlib.collections import Collection
    from matplotlib.transforms import Bbox

    try:
        bb = art.get_window_extent(r)
        if isinstance(art, Collection) and not np.isfinite(np.asarray(bb.extents, float)).all():
            # a collection without offsets (lines, polygons, a mesh): its paths' data limits
            dl = art.get_datalim(ax.transData)
            bb = Bbox(ax.transData.transform(np.asarray(dl.get_points(), float)))
    except Exception:
        return True  # an artist that cannot say: not judged
    ext = np.asarray(bb.extents, float)
    if not np.isfinite(ext).all() or (bb.width <= 0.5 and bb.height <= 0.5):
        return False
    if art.get_clip_on():
        return bool(bb.overlaps(ax.bbox))
    return True


def _drawn(art, ax, r) -> bool:
    from matplotlib.container import Container
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle

    if isinstance(art, Container):
        return any(_drawn(c, ax, r) for c in art.get_children() if c is not None)
    if isinstance(art, Line2D):
        return _line_drawn(art, ax)
    if isinstance(art, Rectangle) and (art.get_width() == 0 or art.get_height() == 0):
        return False
    if hasattr(art, "get_offsets") and hasattr(art, "get_paths") and type(art).__name__ == "PathCollection":
        off = np.asarray(art.get_offsets(), float).reshape(-1, 2)
        fin = np.isfinite(off).all(axis=1)
        if not art.get_visible() or not fin.any():
            return False
        pts = art.get_offset_transform().transform(off[fin])
        return bool(_inside(ax, pts).any()) if art.get_clip_on() else True
    return _extent_drawn(art, ax, r)


def _style(ln):
    import matplotlib.colors as mc

    return ln.get_linestyle(), str(ln.get_marker()), np.asarray(mc.to_rgba(ln.get_color()))[:3]


def _achromatic(rgb) -> bool:
    return float(np.ptp(rgb)) < 0.02


def _proxy_matches(handle, axes, r) -> bool:
    """A proxy entry (a style key) matches a drawn artist: same line style and marker, and the same
    colour unless the key is black or grey (a style for every colour)."""
    import matplotlib.colors as mc
    from matplotlib.lines import Line2D

    if isinstance(handle, Line2D):
        ls, mk, col = _style(handle)
        for ax in axes:
            for ln in ax.lines:
                if not _line_drawn(ln, ax):
                    continue
                ls2, mk2, col2 = _style(ln)
                same_style = (ls == ls2 or ls in ("None", "")) and (mk == mk2 or mk in ("None", ""))
                if same_style and (np.allclose(col, col2, atol=0.03) or _achromatic(col)):
                    return True
        return False
    try:
        fc = np.asarray(mc.to_rgba(handle.get_facecolor()))[:3] if hasattr(handle, "get_facecolor") else None
    except (ValueError, TypeError):
        fc = None
    for ax in axes:
        for art in list(ax.patches) + list(ax.collections):
            if not _drawn(art, ax, r):
                continue
            if fc is None:
                return True
            try:
                fcs = np.atleast_2d(np.asarray(mc.to_rgba_array(art.get_facecolor()), float))[:, :3]
            except (ValueError, TypeError):
                continue
            if fcs.size and np.any(np.all(np.abs(fcs - fc) < 0.03, axis=1)):
                return True
    return False


def _legend_entries(leg, ax, axes, r) -> list[str]:
    where = axes_name(ax) if ax is not None else "figure legend"
    out = []
    handles = getattr(leg, "legend_handles", None) or getattr(leg, "legendHandles", [])
    for h, t in zip(handles, leg.get_texts()):
        lab = t.get_text()
        if not lab or h is None:
            continue
        src = [(a, o) for o in axes for a in _artists(o) if a.get_label() == lab]
        if any(_drawn(a, o, r) for a, o in src):
            continue
        if _proxy_matches(h, axes, r):
            continue
        out.append(f"{where}: legend entry {lab!r} stands for nothing drawn (empty, all NaN, outside the "
                   "axes, or a style seen nowhere)")
    return out


# --- legend over the data -----------------------------------------------------------------------
def _densify(pts: np.ndarray) -> np.ndarray:
    """Points every STEP_PX along a polyline [px] (NaN breaks the line)."""
    out = [pts[np.isfinite(pts).all(axis=1)]]
    for a, b in zip(pts[:-1], pts[1:]):
        if not (np.isfinite(a).all() and np.isfinite(b).all()):
            continue
        n = int(np.hypot(*(b - a)) // STEP_PX)
        if n > 1:
            t = np.linspace(0, 1, n + 1)[1:-1, None]
            out.append(a + t * (b - a))
    return np.vstack(out) if out else np.empty((0, 2))


def _data_points(ax, axes) -> np.ndarray:
    """Display points [px] of the data drawn in ``ax`` (and its twins): lines in data coordinates
    sampled along their segments, scatter offsets, the outlines of bars and step patches."""
    from matplotlib.container import BarContainer
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle, StepPatch

    pts = []
    for o in axes:
        for ln in o.lines:
            if not isinstance(ln, Line2D) or ln.get_transform() != o.transData or not _line_drawn(ln, o):
                continue
            xy = ln.get_transform().transform(np.asarray(ln.get_xydata(), float))
            has_line = ln.get_linestyle() not in ("None", "", " ", "none")
            pts.append(_densify(xy) if has_line else xy[np.isfinite(xy).all(axis=1)])
        for c in o.collections:
            if type(c).__name__ == "PathCollection" and c.get_visible():
                off = np.asarray(c.get_offsets(), float).reshape(-1, 2)
                off = off[np.isfinite(off).all(axis=1)]
                if off.size:
                    pts.append(c.get_offset_transform().transform(off))
        bars = [p for cont in o.containers if isinstance(cont, BarContainer) for p in cont.patches]
        for p in bars + [p for p in o.patches if isinstance(p, StepPatch)]:
            if isinstance(p, Rectangle) and (p.get_height() == 0 or p.get_width() == 0):
                continue
            if not p.get_visible():
                continue
            path = p.get_path().transformed(p.get_transform())
            pts.append(_densify(path.vertices))
    if not pts:
        return np.empty((0, 2))
    P = np.vstack(pts)
    return P[_inside(ax, P, pad=0.0)]


def _count(P, x0, y0, w, h) -> int:
    return int(np.sum((P[:, 0] >= x0) & (P[:, 0] <= x0 + w) & (P[:, 1] >= y0) & (P[:, 1] <= y0 + h)))


def _legend_over_data(leg, ax, axes, r) -> list[str]:
    bb = leg.get_window_extent(r)
    A = ax.bbox
    if not bb.overlaps(A):
        return []  # a legend outside the axes covers no data
    P = _data_points(ax, axes)
    if len(P) == 0:
        return []
    n_in = _count(P, bb.x0, bb.y0, bb.width, bb.height)
    if n_in <= max(MIN_POINTS, OVER_SHARE * len(P)):
        return []
    w, h = bb.width, bb.height
    if w > A.width or h > A.height:
        return [f"{axes_name(ax)}: legend larger than the axes covers {n_in} of {len(P)} data points"]
    pad = 0.02 * min(A.width, A.height)
    xs = {"left": A.x0 + pad, "center": A.x0 + (A.width - w) / 2, "right": A.x1 - pad - w}
    ys = {"lower": A.y0 + pad, "center": A.y0 + (A.height - h) / 2, "upper": A.y1 - pad - h}
    free = []
    for yn, y0 in ys.items():
        for xn, x0 in xs.items():
            if _count(P, x0, y0, w, h) <= max(1, 0.002 * len(P)):
                free.append("center" if xn == yn == "center" else f"{yn} {xn}")
    if not free:
        return []  # nowhere better inside the axes (a legend outside would be the fix)
    return [f"{axes_name(ax)}: legend covers {n_in} of {len(P)} data points while {free[0]!r} is free"]


# --- inside the image, overlaps --------------------------------------------------------------------
def _texts_of(ax):
    """The texts of an axes a reader must see whole: titles, axis labels, texts, annotations."""
    out = [ax.title]
    for loc in ("left", "right"):
        t = getattr(ax, f"_{loc}_title", None)
        if t is not None:
            out.append(t)
    out += [ax.xaxis.label, ax.yaxis.label] + list(ax.texts)
    return [t for t in out if t.get_visible() and t.get_text().strip()]


def _ext(art, r):
    try:
        bb = art.get_window_extent(r)
    except Exception:
        return None
    e = np.asarray(bb.extents, float)
    return bb if np.isfinite(e).all() and (bb.width > 0 or bb.height > 0) else None


def _outside(fig, axes, r, tight: bool) -> list[str]:
    from matplotlib.transforms import Bbox

    if tight:
        tb = fig.get_tightbbox(r)
        region = Bbox.from_extents(*(np.asarray(tb.extents, float) * fig.dpi))
    else:
        region = fig.bbox
    out = []
    items = [("figure title", fig._suptitle)] if getattr(fig, "_suptitle", None) is not None else []
    items += [("figure text", t) for t in fig.texts]
    items += [("figure legend", leg) for leg in fig.legends]
    for ax in axes:
        items += [(axes_name(ax), t) for t in _texts_of(ax)]
        if ax.get_legend() is not None and ax.get_legend().get_visible():
            items.append((axes_name(ax) + " legend", ax.get_legend()))
    for where, art in items:
        if not art.get_visible():
            continue
        if hasattr(art, "get_text") and not art.get_text().strip():
            continue
        if hasattr(art, "get_text") and art.get_clip_on() and (art.get_clip_box() is not None
                                                               or art.get_clip_path() is not None):
            continue  # clipped to its axes: not drawn outside them
        if not _annotation_drawn(art):
            continue
        bb = _ext(art, r)
        if bb is None:
            continue
        if (bb.x0 < region.x0 - 1 or bb.x1 > region.x1 + 1 or bb.y0 < region.y0 - 1 or bb.y1 > region.y1 + 1):
            what = "legend" if not hasattr(art, "get_text") else repr(art.get_text()[:50])
            out.append(f"{where}: {what} is cut at the edge of the image")
    return out


def _annotation_drawn(art) -> bool:
    """False for an annotation that matplotlib does not draw: its point (data coordinates) outside
    its axes while annotation_clip is None or True."""
    from matplotlib.text import Annotation

    if not isinstance(art, Annotation) or art.axes is None:
        return True
    clip = art.get_annotation_clip()
    if clip is False or (clip is None and art.xycoords != "data"):
        return True
    x, y = art.axes.transData.transform(art.xy)
    return bool(art.axes.contains_point((x, y)))


def _overlap(a, b, min_px=2.0) -> bool:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return w > min_px and h > min_px


def _axes_items(ax, r):
    """(name, display bbox) of what an axes draws around itself: titles, the x label, tick labels, legend."""
    texts = [ax.title, ax.xaxis.label] + [t for t in (getattr(ax, "_left_title", None),
                                                       getattr(ax, "_right_title", None)) if t is not None]
    texts += drawn_tick_labels(ax.xaxis) + drawn_tick_labels(ax.yaxis)
    items = [(repr(t.get_text()[:40]), _ext(t, r)) for t in texts if t.get_visible() and t.get_text().strip()]
    leg = ax.get_legend()
    if leg is not None and leg.get_visible():
        items.append(("its legend", _ext(leg, r)))
    return [(n, b) for n, b in items if b is not None]


def drawn_tick_labels(axis) -> list:
    """The tick labels an axis draws (ticks inside its view interval)."""
    try:
        ticks = axis._update_ticks()  # matplotlib's own selection of the ticks it draws
    except Exception:
        lo, hi = sorted(axis.get_view_interval())
        ticks = [t for t in axis.get_major_ticks() + axis.get_minor_ticks() if lo <= t.get_loc() <= hi]
    return [lab for t in ticks for lab in (t.label1, t.label2) if lab.get_visible()]


def _contains(a, b) -> bool:
    return a.x0 <= b.x0 and a.y0 <= b.y0 and a.x1 >= b.x1 and a.y1 >= b.y1


def _overlaps(fig, axes, r) -> list[str]:
    groups: dict = {}
    for ax in axes:  # twins (one box) form one group
        groups.setdefault(tuple(np.round(ax.get_position().bounds, 6)), []).append(ax)
    boxes = list(groups.values())
    out = []
    for i, ga in enumerate(boxes):
        for gb in boxes[i + 1:]:
            A, B = ga[0].bbox, gb[0].bbox
            if _contains(A, B) or _contains(B, A):
                continue  # an inset
            ia = [(n, b) for ax in ga for n, b in _axes_items(ax, r)]
            ib = [(n, b) for ax in gb for n, b in _axes_items(ax, r)]
            hit = next((f"{na} overlaps {nb}" for na, ba in ia for nb, bb in ib if _overlap(ba, bb)), None)
            hit = hit or next((f"{na} lies over the other axes" for na, ba in ia if _overlap(ba, B)), None)
            hit = hit or next((f"{nb} lies over the other axes" for nb, bb in ib if _overlap(bb, A)), None)
            if hit:
                out.append(f"{axes_name(ga[0])} and {axes_name(gb[0])}: {hit}")
    for ax in axes:  # an axes' own legend over its own titles, labels and tick labels
        leg = ax.get_legend()
        lb = _ext(leg, r) if leg is not None and leg.get_visible() else None
        if lb is None:
            continue
        for o in _twins(ax, axes):
            texts = _texts_of(o) + drawn_tick_labels(o.xaxis) + drawn_tick_labels(o.yaxis)
            hit = next((t for t in texts if t.get_text().strip() and _ext(t, r) is not None
                        and _overlap(lb, _ext(t, r))), None)
            if hit is not None:
                out.append(f"{axes_name(ax)}: its legend overlaps {hit.get_text()[:40]!r}")
                break
    sup = getattr(fig, "_suptitle", None)
    if sup is not None and sup.get_visible() and sup.get_text().strip():
        sb = _ext(sup, r)
        for ax in axes:
            for t in _texts_of(ax):
                tb = _ext(t, r)
                if sb is not None and tb is not None and _overlap(sb, tb):
                    out.append(f"the figure title overlaps {axes_name(ax)}'s {t.get_text()[:40]!r}")
    return out
