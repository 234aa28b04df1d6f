"""Self-contained HTML pages: ``report.html`` of every run (and the page of ``gearopt compare``).

A page is rendered by Jinja2 from the template ``gearopt/io/templates/page.html.j2`` (package data)
and holds everything it shows: the style sheet inline, every figure as a ``data:`` URI (SVG where
the figure's SVG is light enough, :data:`SVG_LIMIT`, PNG otherwise), no script and no network
access. Links point only to files beside the page (results.json, the CSV tables).

:func:`render_page` is the generic renderer (a header, tables, warnings, figures with captions,
links); :func:`report_page` builds the page of one run from its results dictionary, the files the
run wrote and the figures' captions. :class:`SVGCapture` records, while a study saves its PNG
figures, an SVG rendering of each, so that a light figure can go into the page as SVG.
"""

from __future__ import annotations

import base64
import functools
import io
import mimetypes
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal
from urllib.parse import quote

from ..summary import GROUPS, KeyNumber
from ..version import __version__

__all__ = ["Cell", "Table", "PageFigure", "render_page", "figure_from_file", "key_numbers_table", "key_numbers_tables",
           "report_page",
           "page_template", "SVGCapture", "SVG_LIMIT", "SVG_MAX_ELEMENTS", "svg_elements", "REPORT_FILE"]

#: The page every run writes beside results.json.
REPORT_FILE = "report.html"
#: Largest SVG [bytes] put into a page; a heavier figure (meshes, dense scatter, colour maps) goes as PNG.
SVG_LIMIT = 300_000

Mark = Literal["", "better", "worse", "absent", "warn", "key"]


@dataclass(frozen=True)
class Cell:
    """One table cell: its text and an optional mark, drawn by the page's style sheet.

    Parameters
    ----------
    text : str
        What the cell shows (escaped by the template).
    mark : str
        ``""`` (plain), ``"better"`` (green, bold), ``"worse"`` (red), ``"absent"`` (grey italic: the
        quantity does not exist for this column), ``"warn"`` (amber), ``"key"`` (small monospace:
        an identifier such as a summary key).
    title : str
        Tooltip (optional).
    """

    text: str
    mark: Mark = ""
    title: str = ""


@dataclass(frozen=True)
class Table:
    """A table of a page.

    Parameters
    ----------
    title : str
        Heading above the table.
    columns : list[str]
        Column headings.
    rows : list
        Each row a list of cells (``str`` or :class:`Cell`), one per column; a row that is a plain
        ``str`` is a group heading spanning all columns.
    note : str
        One line under the heading (optional).
    numeric : tuple[int, ...]
        Indices of the columns to right-align (numbers).
    """

    title: str
    columns: list[str]
    rows: list[Any]
    note: str = ""
    numeric: tuple[int, ...] = ()

    def cells(self) -> list[tuple[str, list[Cell]] | tuple[str, str]]:
        """Rows for the template: ``("group", text)`` or ``("row", [Cell, ...])``."""
        out: list[Any] = []
        for r in self.rows:
            if isinstance(r, str):
                out.append(("group", r))
            else:
                out.append(("row", [c if isinstance(c, Cell) else Cell(str(c)) for c in r]))
        return out


@dataclass(frozen=True)
class PageFigure:
    """A figure of a page: file name, one-line caption (what to read from it) and the image as a
    ``data:`` URI."""

    name: str
    caption: str
    data_uri: str
    kind: str = field(default="png")  # "png" or "svg": what the data URI holds


def _data_uri(data: bytes, mime: str) -> str:
    return f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"


def figure_from_file(path: str | Path, caption: str, svg: bytes | None = None,
                     svg_limit: int | None = None) -> PageFigure:
    """A page figure from an image file (PNG, JPEG or SVG), inlined as a ``data:`` URI; with ``svg``
    (the same figure rendered as SVG) no heavier than ``svg_limit`` bytes, the SVG is used instead.

    Parameters
    ----------
    path : path
        The image file.
    caption : str
        One line: what to read from the figure.
    svg : bytes, optional
        The figure as SVG (:class:`SVGCapture`).
    svg_limit : int, optional
        Largest SVG used [bytes] (default :data:`SVG_LIMIT`).

    Returns
    -------
    PageFigure
    """
    p = Path(path)
    if svg is not None and len(svg) <= (SVG_LIMIT if svg_limit is None else svg_limit):
        return PageFigure(p.name, caption, _data_uri(svg, "image/svg+xml"), "svg")
    mime = mimetypes.guess_type(p.name)[0] or "application/octet-stream"
    return PageFigure(p.name, caption, _data_uri(p.read_bytes(), mime), "svg" if mime == "image/svg+xml" else "png")


@functools.lru_cache(maxsize=1)
def page_template() -> Any:
    """The page's Jinja2 template (``templates/page.html.j2``), loaded and compiled once per process
    (importing Jinja2 and compiling take about 0.1 s: ``gearopt run`` does it while its plots are
    drawn in other processes)."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader("gearopt.io", "templates"), autoescape=True,
                             trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)
    return env.get_template("page.html.j2")


def render_page(title: str, header: dict[str, str], tables: list[Table], warnings: list[str],
                figures: list[PageFigure], links: list[tuple[str, str]], *, intro: str = "") -> str:
    """Render a self-contained HTML page (template ``templates/page.html.j2``).

    Parameters
    ----------
    title : str
        Page title and main heading.
    header : dict[str, str]
        Facts shown under the title, in order (``{"scene": ..., "study": ..., "date": ...}``).
    tables : list[Table]
        Tables, first after the header (the key numbers first).
    warnings : list[str]
        Every warning to highlight (empty: the page says there was none).
    figures : list[PageFigure]
        Figures in order, each with its caption.
    links : list[tuple[str, str]]
        ``(href, text)`` of the files beside the page (relative paths).
    intro : str
        A paragraph under the header (optional).

    Returns
    -------
    str
        The HTML document.
    """
    return page_template().render(
        title=title, header=header, tables=tables, warnings=warnings, figures=figures, links=links, intro=intro,
        generator=f"gearopt {__version__}")


def _split_key(n: KeyNumber) -> tuple[str, str, str] | None:
    """``(family, column, row label)`` of a key number with a bracketed argument: the key without its
    last argument (``lte_pp_arcsec[aligned, ·]``), that argument (``100 Nm``) and the label without
    it; None for a key without brackets or a label that does not end with the argument."""
    if not n.key.endswith("]") or "[" not in n.key:
        return None
    base, arg = n.key[:-1].split("[", 1)
    head, _, col = arg.rpartition(", ")
    if not n.label.endswith(", " + col):
        return None
    family = f"{base}[{head}, \u00b7]" if head else f"{base}[\u00b7]"
    return family, col, n.label[: -len(col) - 2]


def _columns_kind(cols: tuple[str, ...]) -> str:
    if all(c.endswith(" Nm") for c in cols):
        return "torque"
    if all(c.startswith("phi1 ") for c in cols):
        return "position"
    if set(cols) <= {"pinion", "gear"}:
        return "member"
    if all(c in ("pinion right", "pinion left", "gear right", "gear left") for c in cols):
        return "flank"
    if all(c in ("n", "mean", "sd", "min", "max") or (c[:1] == "p" and c[1:].isdigit()) for c in cols):
        return "statistic"
    return "case"


def _value_cell(n: KeyNumber) -> Cell:
    # a yes/no quantity in its worse state (an edge carries load) is highlighted
    flag = isinstance(n.value, bool) and n.better is not None and n.value == (n.better == "lower")
    return Cell(n.formatted(), "absent" if n.value is None else "warn" if flag else "", title=repr(n.value))


def key_numbers_tables(numbers: list[KeyNumber], title: str = "Key numbers") -> list[Table]:
    """The key numbers of one run as tables, in :data:`~gearopt.summary.GROUPS` order: first one
    table of the single quantities, grouped (quantity, value, unit, better, key); then, per group,
    the quantities given for several cases, torques, positions, statistics or members as one row
    each with a column per case, the unit in the quantity's name (a table per kind of columns)."""
    order = {g: i for i, g in enumerate(GROUPS)}
    by_group: dict[str, list[KeyNumber]] = {}
    for n in numbers:
        by_group.setdefault(n.group, []).append(n)
    groups = sorted(by_group, key=lambda g: order.get(g, len(order)))
    # families: the same quantity over several columns
    fam_cols: dict[tuple[str, str], list[str]] = {}
    for g in groups:
        for n in by_group[g]:
            sp = _split_key(n)
            if sp is not None:
                cols = fam_cols.setdefault((g, sp[0]), [])
                if sp[1] not in cols:
                    cols.append(sp[1])
    pivot = {k for k, cols in fam_cols.items() if len(cols) > 1}
    scalar_rows: list[Any] = []
    tables: list[Table] = []
    for g in groups:
        singles = [n for n in by_group[g] if (_split_key(n) is None or (g, _split_key(n)[0]) not in pivot)]
        if singles:
            scalar_rows.append(g)
        for n in singles:
            better = n.better or ""
            scalar_rows.append([n.label, _value_cell(n), n.unit, Cell(better, "" if better else "absent"),
                                Cell(n.key, "key")])
        # one table per kind of columns (cases, torques, ...: their union), rows in order of first appearance
        sets: dict[str, dict[str, dict]] = {}
        union: dict[str, list[str]] = {}
        for n in by_group[g]:
            sp = _split_key(n)
            if sp is None or (g, sp[0]) not in pivot:
                continue
            kind = _columns_kind(tuple(fam_cols[(g, sp[0])]))
            cols = union.setdefault(kind, [])
            if sp[1] not in cols:
                cols.append(sp[1])
            row = sets.setdefault(kind, {}).setdefault(sp[0], {"label": sp[2], "unit": n.unit,
                                                                "better": n.better or "", "cells": {}})
            row["cells"][sp[1]] = n
        for kind, rows in sets.items():
            cols = tuple(union[kind])
            body = []
            for fam, r in rows.items():
                # blank: the quantity is not given for that column (not in the summary), unlike a value None
                cells = [_value_cell(r["cells"][c]) if c in r["cells"] else Cell("", "absent") for c in cols]
                label = f"{r['label']} [{r['unit']}]" if r["unit"] else r["label"]
                body.append([Cell(label, title=f"{r['better']} is better" if r["better"] else ""), *cells,
                             Cell(fam, "key")])
            tables.append(Table(f"{g} per {kind}", ["quantity", *cols, "key"], body,
                                numeric=tuple(range(1, len(cols) + 1))))
    note = "4 significant digits; the full values are in results.json (summary). \u2014: no value."
    first = Table(title, ["quantity", "value", "unit", "better", "key in results.json"], scalar_rows, note=note,
                  numeric=(1,))
    return ([first] if scalar_rows else []) + tables


def key_numbers_table(numbers: list[KeyNumber], title: str = "Key numbers") -> Table:
    """The key numbers of one run as one flat table grouped by :data:`~gearopt.summary.GROUPS`:
    quantity, value, unit, which direction is better, key (the ``summary`` key in results.json)."""
    rows: list[Any] = []
    order = {g: i for i, g in enumerate(GROUPS)}
    groups: dict[str, list[KeyNumber]] = {}
    for n in numbers:
        groups.setdefault(n.group, []).append(n)
    for g in sorted(groups, key=lambda g: order.get(g, len(order))):
        rows.append(g)
        for n in groups[g]:
            better = n.better or ""
            rows.append([n.label, _value_cell(n), n.unit, Cell(better, "" if better else "absent"),
                         Cell(n.key, "key")])
    return Table(title, ["quantity", "value", "unit", "better", "key in results.json"], rows,
                 note="4 significant digits; the full values are in results.json (summary). \u2014: no value.",
                 numeric=(1,))


def _warning_texts(data: dict[str, Any]) -> list[str]:
    """The run's warnings: those ``gearopt run`` recorded (``meta.warnings``) and those the result
    carries (``warnings``), each once."""
    out: list[str] = []
    for w in (data.get("meta") or {}).get("warnings") or []:
        text = f"{w.get('category', 'Warning')}: {w.get('message', '')}" if isinstance(w, dict) else str(w)
        if isinstance(w, dict) and w.get("source"):
            text += f" ({w['source']})"
        out.append(text)
    seen = " ".join(out)
    for w in data.get("warnings") or []:
        if str(w) not in seen:
            out.append(str(w))
    return out


def report_page(data: dict[str, Any], files: list[str], captions: dict[str, str],
                svgs: dict[str, bytes] | None = None, directory: str | Path = ".") -> str:
    """The ``report.html`` of one run.

    Parameters
    ----------
    data : dict
        The run's results dictionary as written to results.json (``study``, ``scene``, ``meta``,
        ``summary``...).
    files : list[str]
        The files the run wrote, relative to ``directory`` (results.json, tables, figures).
    captions : dict[str, str]
        Figure file name -> one-line caption (the result's ``captions``).
    svgs : dict[str, bytes], optional
        Figure file name -> the figure as SVG (:class:`SVGCapture`).
    directory : path
        Where the files are (the figures are read from it).

    Returns
    -------
    str
        The HTML document.
    """
    meta = data.get("meta") or {}
    directory = Path(directory)
    numbers = [KeyNumber.from_dict(d) for d in data.get("summary") or []]
    run_time = meta.get("run_time_s")
    header = {"scene": str(meta.get("scene_name") or data.get("scene") or ""),
              "scene file": str(meta.get("scene") or "\u2014"),
              "study": str(meta.get("study") or data.get("study") or ""),
              "date (UTC)": str(meta.get("timestamp") or "").replace("T", " ").replace("+00:00", ""),
              "gearopt": str(meta.get("gearopt_version") or __version__),
              "run time": "\u2014" if run_time is None else f"{run_time:.3g} s"}
    figures = []
    for f in files:
        if Path(f).suffix.lower() in (".png", ".svg", ".jpg", ".jpeg"):
            figures.append(figure_from_file(directory / f, captions.get(f, ""), (svgs or {}).get(f)))
    links = [(quote(f), f) for f in files if Path(f).suffix.lower() not in (".png", ".svg", ".jpg", ".jpeg")]
    tables = key_numbers_tables(numbers)
    name = header["scene"] or "run"
    return render_page(f"{name}: {header['study']}", header, tables, _warning_texts(data), figures, links)


#: Drawn elements (:func:`svg_elements`) above which a figure is not rendered as SVG at all.
SVG_MAX_ELEMENTS = 1500


def svg_elements(fig: Any) -> int:
    """A rough count of the SVG elements ``fig`` would write: patches, the members of every
    collection (markers, polygons, mesh cells; a rasterized collection is one image) and the points
    of the lines (twenty to an element). About 200 bytes each: 1500 make the 300 kB of
    :data:`SVG_LIMIT`."""
    n = 0
    for ax in fig.axes:
        n += len(ax.patches) + len(ax.texts)
        for c in ax.collections:
            if c.get_rasterized():
                n += 1
                continue
            coords = c.get_coordinates() if hasattr(c, "get_coordinates") else None  # a QuadMesh: its cells
            if coords is not None:
                n += (coords.shape[0] - 1) * (coords.shape[1] - 1)
            else:
                offsets = c.get_offsets() if hasattr(c, "get_offsets") else ()
                n += max(len(c.get_paths()), len(offsets))
        n += sum(len(line.get_xydata()) for line in ax.lines) // 20
        if n > SVG_MAX_ELEMENTS:
            break
    return n


class SVGCapture:
    """Context manager: while active, every figure saved as PNG (``Figure.savefig``) is also
    rendered as SVG into memory, same bounding box; :attr:`svgs` maps the PNG's file name to the
    SVG bytes. Figures whose SVG exceeds ``limit`` bytes are not kept. Text is drawn as paths, so the
    SVG needs no font.

    Parameters
    ----------
    limit : int, optional
        Largest SVG kept [bytes] (default :data:`SVG_LIMIT`).
    """

    def __init__(self, limit: int | None = None) -> None:
        self.limit = SVG_LIMIT if limit is None else limit
        self.svgs: dict[str, bytes] = {}
        self._saved: Any = None

    def __enter__(self) -> SVGCapture:
        import matplotlib.figure

        self._saved = save = matplotlib.figure.Figure.savefig
        capture = self

        def savefig(fig, fname, *args, **kwargs):
            out = save(fig, fname, *args, **kwargs)
            if isinstance(fname, (str, Path)) and Path(fname).suffix.lower() == ".png":
                capture.add(fig, Path(fname).name, kwargs)
            return out

        matplotlib.figure.Figure.savefig = savefig
        return self

    def add(self, fig: Any, name: str, kwargs: dict[str, Any]) -> None:
        """Render ``fig`` as SVG under ``name`` (kept when no heavier than the limit); a figure with
        more drawn elements than :data:`SVG_MAX_ELEMENTS` is not rendered (its SVG would be too
        heavy, and rendering it costs seconds)."""
        import matplotlib

        if svg_elements(fig) > SVG_MAX_ELEMENTS:
            return
        buf = io.BytesIO()
        opts = {k: kwargs[k] for k in ("bbox_inches", "pad_inches", "facecolor") if k in kwargs}
        with matplotlib.rc_context({"svg.fonttype": "path", "svg.hashsalt": name}):
            fig.canvas.print_figure(buf, format="svg", **opts)
        data = buf.getvalue()
        if len(data) <= self.limit:
            self.svgs[name] = data

    def __exit__(self, *exc: Any) -> None:
        import matplotlib.figure

        matplotlib.figure.Figure.savefig = self._saved
