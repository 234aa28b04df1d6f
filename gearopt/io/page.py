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
import io
import mimetypes
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from ..summary import GROUPS, KeyNumber
from ..version import __version__

__all__ = ["Cell", "Table", "PageFigure", "render_page", "figure_from_file", "key_numbers_table", "report_page",
           "SVGCapture", "SVG_LIMIT", "REPORT_FILE"]

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


def _environment():
    import jinja2

    return jinja2.Environment(loader=jinja2.PackageLoader("gearopt.io", "templates"), autoescape=True,
                              trim_blocks=True, lstrip_blocks=True, undefined=jinja2.StrictUndefined)


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
    return _environment().get_template("page.html.j2").render(
        title=title, header=header, tables=tables, warnings=warnings, figures=figures, links=links, intro=intro,
        generator=f"gearopt {__version__}")


def key_numbers_table(numbers: list[KeyNumber], title: str = "Key numbers") -> Table:
    """The key numbers of one run as a table grouped by :data:`~gearopt.summary.GROUPS`: quantity,
    value, unit, which direction is better, key (the ``summary`` key in results.json)."""
    rows: list[Any] = []
    order = {g: i for i, g in enumerate(GROUPS)}
    groups: dict[str, list[KeyNumber]] = {}
    for n in numbers:
        groups.setdefault(n.group, []).append(n)
    for g in sorted(groups, key=lambda g: order.get(g, len(order))):
        rows.append(g)
        for n in groups[g]:
            better = {"lower": "lower", "higher": "higher"}.get(n.better or "", "")
            # a yes/no quantity in its worse state (an edge carries load) is highlighted
            flag = isinstance(n.value, bool) and n.better is not None and n.value == (n.better == "lower")
            mark = "absent" if n.value is None else "warn" if flag else ""
            rows.append([n.label, Cell(n.formatted(), mark, title=repr(n.value)),
                         n.unit, Cell(better, "absent" if not better else ""), Cell(n.key, "key")])
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
    links = [(f, f) for f in files if Path(f).suffix.lower() not in (".png", ".svg", ".jpg", ".jpeg")]
    tables = [key_numbers_table(numbers)] if numbers else []
    name = header["scene"] or "run"
    return render_page(f"{name}: {header['study']}", header, tables, _warning_texts(data), figures, links)


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
        """Render ``fig`` as SVG under ``name`` (kept when no heavier than the limit)."""
        import matplotlib

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
