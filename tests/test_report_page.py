"""report.html, the page every ``gearopt run`` writes beside results.json (gearopt.io.page), checked
as a person uses it: parsed (tests/page_check.py: every image inline, every link to a file beside
the page, nothing fetched from elsewhere, the key numbers first, every figure with its caption,
every warning of the run shown) and opened in headless Chromium (every image decoded, nothing wider
than a 1280 px window). The browser tests are skipped, with the reason, where Chromium is absent
(``make chromium`` installs it as root). One run per scene of every study also checks its summary
(tests/summary_check.py); with GEAROPT_PAGE_SCREENSHOTS=DIR it keeps a 1280 px screenshot of each
page in DIR, to be looked at."""

from __future__ import annotations

import json
import os
import shutil
import warnings
from pathlib import Path
from urllib.parse import unquote

import pytest

from gearopt.io.page import (Cell, PageFigure, Table, figure_from_file, key_numbers_table, key_numbers_tables,
                             render_page)
from gearopt.io.results import MANIFEST, write_results
from gearopt.summary import KeyNumber

from page_check import browser, browser_check, parse, screenshot, static_problems
from scenes import STUDY_MARKS
from summary_check import check_summary

needs_browser = pytest.mark.skipif(browser() is None, reason="Chromium is not installed (make chromium installs it "
                                   "as root: apt-get install chromium): the page is not opened in a browser")

PNG_1PX = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010806000000"
                        "1f15c4890000000d49444154789c6360f8cfc0f01f0005000201e2b3"
                        "d4c80000000049454e44ae426082")


def _plot(directory: Path, name: str, n: int = 200) -> str:
    import matplotlib

    matplotlib.use("Agg")  # a test stands in for the CLI here (only the CLI picks the backend in gearopt)
    import matplotlib.pyplot as plt

    import numpy as np

    fig, ax = plt.subplots(figsize=(6, 3))
    ax.plot(range(200), [v % 7 for v in range(200)])
    if n > 200:  # a dense scatter: every marker one SVG element
        ax.scatter(np.random.default_rng(0).uniform(0, 200, n), np.random.default_rng(1).uniform(0, 7, n), s=2)
    ax.set_xlabel("pinion angle phi1 [deg]")
    fig.savefig(Path(directory) / name, dpi=80, bbox_inches="tight")
    plt.close(fig)
    return name


class _Result:
    """A study result as write_results sees it: dictionary, a table, two figures with captions."""

    captions = {"light.png": "A light figure: read the sawtooth.", "heavy.png": "A heavy figure."}

    def __init__(self, heavy_points: int = 200):
        self.heavy_points = heavy_points

    def to_dict(self):
        return {"study": "tca", "scene": "demo <&> scene", "units": {"te": "arcsec"}, "warnings": ["carried <warn>"]}

    def summary(self):
        return [KeyNumber("te_pp_arcsec[aligned]", "TE peak-to-peak, aligned", 18.35, "arcsec", "lower", "unloaded TE"),
                KeyNumber("edge_contact[aligned]", "an edge carries load, aligned", True, "", "lower", "unloaded TE"),
                KeyNumber("te_h1_arcsec[aligned]", "TE harmonic 1, aligned", None, "arcsec", "lower", "unloaded TE"),
                KeyNumber("z1", "pinion teeth z1", 20)]

    def save_tables(self, d):
        (Path(d) / "table one.csv").write_text("a,b\n1,2\n")
        return ["table one.csv"]

    def save_plots(self, d):
        return [_plot(d, "light.png"), _plot(d, "heavy.png", self.heavy_points)]


# --- the renderer ------------------------------------------------------------------------------------
def test_render_page_escapes_and_inlines(tmp_path):
    png = tmp_path / "f.png"
    png.write_bytes(PNG_1PX)
    fig = figure_from_file(png, "caption <i>here</i>")
    assert fig.data_uri.startswith("data:image/png;base64,") and fig.kind == "png"
    svg = b'<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"/>'
    assert figure_from_file(png, "c", svg=svg).data_uri.startswith("data:image/svg+xml;base64,")
    assert figure_from_file(png, "c", svg=svg, svg_limit=10).kind == "png"  # too heavy: the PNG
    table = Table("Key numbers", ["quantity", "A", "B"], ["a group <b>", ["p_max", Cell("1453", "better"),
                                                                          Cell("\u2014", "absent")]], numeric=(1, 2))
    text = render_page("title <script>", {"scene": "x & y"}, [table], ["<script>alert(1)</script>"], [fig],
                       [("table one.csv", "table one.csv")])
    (tmp_path / "table one.csv").write_text("a\n")
    page_file = tmp_path / "p.html"
    page_file.write_text(text)
    assert "<script>" not in text and "&lt;script&gt;alert(1)&lt;/script&gt;" in text
    assert "caption &lt;i&gt;here&lt;/i&gt;" in text
    assert static_problems(page_file) == []
    page = parse(page_file)
    assert page.tables[0][0] == ["quantity", "A", "B"] and page.tables[0][1] == ["a group <b>"]
    assert 'class="num better"' in text and 'class="num absent"' in text


def test_static_checks_find_what_is_wrong(tmp_path):
    """The checks of page_check.py fail on a planted page: a linked image, a missing file, a remote
    script and style sheet, a link leaving the directory."""
    (tmp_path / "page").mkdir()
    bad = tmp_path / "page" / "bad.html"
    bad.write_text('<html><head><link rel="stylesheet" href="https://cdn.example/x.css">'
                   '<script src="http://example.com/x.js"></script></head><body>'
                   '<img src="te.png"><a href="missing.csv">m</a><a href="../outside.txt">o</a>'
                   '<a href="https://example.com">w</a></body></html>')
    (tmp_path / "outside.txt").write_text("x")
    found = static_problems(bad)
    assert any("image not inline" in f for f in found)
    assert any("missing.csv" in f for f in found)
    assert any("outside" in f for f in found)
    assert any("https://example.com" in f for f in found)
    assert any("<link>" in f for f in found) and any("<script>" in f for f in found)


def test_key_numbers_table_groups_marks_and_orders():
    t = key_numbers_table(_Result().summary())
    rows = t.rows
    assert rows[0] == "geometry" and rows[2] == "unloaded TE"  # GROUPS order, not input order
    cells = {r[4].text: r[1] for r in rows if not isinstance(r, str)}
    assert cells["te_pp_arcsec[aligned]"].text == "18.35"
    assert cells["edge_contact[aligned]"].text == "yes" and cells["edge_contact[aligned]"].mark == "warn"
    assert cells["te_h1_arcsec[aligned]"].mark == "absent"


def test_key_numbers_tables_put_a_quantity_over_cases_in_one_row():
    """A quantity given at several torques (cases, statistics...) becomes one row with a column each;
    one given once stays in the first table; a column a quantity lacks is blank, a None value a dash."""
    k = [KeyNumber("z1", "pinion teeth z1", 20),
         KeyNumber("lte_pp_arcsec[20 Nm]", "loaded TE peak-to-peak, 20 Nm", 4.9, "arcsec", "lower", "loaded"),
         KeyNumber("lte_pp_arcsec[200 Nm]", "loaded TE peak-to-peak, 200 Nm", 44.1, "arcsec", "lower", "loaded"),
         KeyNumber("p_max_MPa[200 Nm]", "peak contact pressure, 200 Nm", None, "MPa", "lower", "loaded"),
         KeyNumber("p_max_MPa[300 Nm]", "peak contact pressure, 300 Nm", 1778.0, "MPa", "lower", "loaded"),
         KeyNumber("K_Hbeta[200 Nm]", "face load factor K_Hbeta, 200 Nm", 1.48, "", "lower", "loaded"),
         KeyNumber("status", "optimiser status", "Solve_Succeeded", group="optimisation")]
    first, per_torque = key_numbers_tables(k)
    assert [r if isinstance(r, str) else r[4].text for r in first.rows] == [
        "geometry", "z1", "optimisation", "status", "loaded", "K_Hbeta[200 Nm]"]
    assert per_torque.title == "loaded per torque"
    assert per_torque.columns == ["quantity", "20 Nm", "200 Nm", "300 Nm", "key"]
    rows = {r[0].text: [c.text for c in r[1:4]] for r in per_torque.rows}
    assert rows == {"loaded TE peak-to-peak [arcsec]": ["4.9", "44.1", ""],
                    "peak contact pressure [MPa]": ["", "\u2014", "1778"]}
    assert per_torque.rows[0][4].text == "lte_pp_arcsec[\u00b7]"


# --- write_results and gearopt run -----------------------------------------------------------------------
def test_write_results_writes_the_page(tmp_path):
    out = tmp_path / "out"
    files = write_results(out, _Result(heavy_points=20_000), svg=True,
                          warnings=[{"category": "UserWarning", "message": "p_max above <limit>", "source": "x.py:1"}])
    assert files[-1] == out / "report.html"
    assert "report.html" in json.loads((out / MANIFEST).read_text())["files"]
    data = json.loads((out / "results.json").read_text())
    assert data["meta"]["warnings"] == [{"category": "UserWarning", "message": "p_max above <limit>",
                                         "source": "x.py:1"}]
    page_file = out / "report.html"
    assert static_problems(page_file) == []
    page = parse(page_file)
    text = page_file.read_text()
    # the key numbers first: the first table, right after the header and the warnings
    assert page.tables[0][0][0] == "quantity" and ["TE peak-to-peak, aligned", "18.35", "arcsec", "lower",
                                                  "te_pp_arcsec[aligned]"] in page.tables[0]
    assert text.index("Key numbers") < text.index("Figure 1")
    # both warnings: the one gearopt run recorded and the one the result carries, escaped
    assert "UserWarning: p_max above &lt;limit&gt; (x.py:1)" in text and "carried &lt;warn&gt;" in text
    assert "2 warnings raised by this run" in text
    # every figure, with its declared caption; the light one as SVG, the heavy one (a scatter of 20000
    # points: an SVG of megabytes) as PNG
    assert page.figcaptions[0].endswith("A light figure: read the sawtooth.")
    assert len(page.images) == 2 and page.images[0].startswith("data:image/svg+xml;base64,")
    assert page.images[1].startswith("data:image/png;base64,")
    # links to the table and results.json, which exist beside the page
    assert set(page.links) == {"results.json", "table%20one.csv"}


def test_heavy_figures_go_as_png(tmp_path, monkeypatch):
    import gearopt.io.page as page_mod

    monkeypatch.setattr(page_mod, "SVG_LIMIT", 2000)  # every figure "heavy"
    out = tmp_path / "out"
    write_results(out, _Result(), svg=True)
    page = parse(out / "report.html")
    assert page.images and all(i.startswith("data:image/png;base64,") for i in page.images)


def test_figures_go_as_their_png_unless_svg_is_asked_for(tmp_path, monkeypatch):
    """By default the page embeds the PNGs as written (no second drawing of any figure); a scene's
    ``[output] svg = true`` asks for SVG."""
    import gearopt.io.page as page_mod

    drawn = []
    monkeypatch.setattr(page_mod.SVGCapture, "add", lambda self, fig, name, kw: drawn.append(name))
    write_results(tmp_path / "out", _Result())
    page = parse(tmp_path / "out" / "report.html")
    assert page.images and all(i.startswith("data:image/png;base64,") for i in page.images)
    assert drawn == []
    write_results(tmp_path / "out2", _Result(), svg=True)
    assert drawn


def test_no_plots_still_writes_the_page(tmp_path):
    out = tmp_path / "out"
    write_results(out, _Result(), plots=False)
    page = parse(out / "report.html")
    assert page.images == [] and set(page.links) == {"results.json", "table%20one.csv"}
    assert static_problems(out / "report.html") == []


def test_run_records_warnings(tmp_path):
    """A warning raised while the study runs still goes where Python sends it (stderr; here pytest's
    record), and is recorded in results.json meta.warnings and highlighted on the page."""
    from gearopt.cli import main
    from gearopt.studies import StudySpec, register, unregister

    class Study:
        def __init__(self, scene):
            self.scene = scene

        def run(self):
            warnings.warn("feasible fraction 0.4 < 0.5", UserWarning, stacklevel=1)
            return _Result()

    register(StudySpec(name="warner", build=Study, doc="emits a warning"))
    scene = tmp_path / "s.toml"
    scene.write_text('[scene]\nname = "warner"\nstudy = "warner"\n[pinion]\nz = 20\nb = 20\n[gear]\nz = 40\nb = 20\n'
                     '[pair]\nm_n = 2\n')
    try:
        with pytest.warns(UserWarning, match="feasible fraction 0.4 < 0.5"):
            assert main(["run", str(scene), "--out", str(tmp_path / "o"), "-q"]) == 0
    finally:
        unregister("warner")
    meta = json.loads((tmp_path / "o" / "results.json").read_text())["meta"]
    assert [(w["category"], w["message"]) for w in meta["warnings"]] == [("UserWarning", "feasible fraction 0.4 < 0.5")]
    assert meta["warnings"][0]["source"].startswith("test_report_page.py:")
    assert "UserWarning: feasible fraction 0.4 &lt; 0.5" in (tmp_path / "o" / "report.html").read_text()


# --- in a browser ----------------------------------------------------------------------------------------
@needs_browser
def test_browser_finds_a_broken_image_and_an_overflow(tmp_path):
    """The browser probe is not blind: a page with an undecodable image and a 2000 px wide block."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html><body><img alt="broken" src="data:image/png;base64,AAAA">'
                   '<div style="width:2000px">wide</div></body></html>')
    r = browser_check(bad)
    assert r["broken"] == ["broken"] and r["scroll_width"] > 1280 and r["wider"]


@needs_browser
def test_browser_opens_the_page(tmp_path):
    out = tmp_path / "out"
    write_results(out, _Result())
    r = browser_check(out / "report.html")
    assert r["n_images"] == 2 and r["broken"] == []
    assert r["scroll_width"] <= 1280 and r["wider"] == []
    assert r["smallest_table_font_px"] >= 11


# --- every study's scene: summary, page, browser (slow) -------------------------------------------------
#: One scene per study (and the edge-contact and measured-flank variants of tca).
PAGE_SCENES = ["tca_spur_crowned", "edge_spur_crossed", "measured_flank", "spur_geometry", "problem_9_4_1", "ltca_spur",
               "montecarlo_loaded", "doe_helical", "crowning_spur", "microgeometry_loaded", "fea_spur", "rating_spectrum", "dynamics_spur"]


def _study(name: str) -> str:
    import tomllib

    return tomllib.loads((Path(__file__).resolve().parents[1] / "problems" / f"{name}.toml").read_text())["scene"]["study"]


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=STUDY_MARKS.get(_study(n), []), id=n) for n in PAGE_SCENES])
def test_every_study_summary_and_page(name, scene_run):
    if _study(name) == "fea" and shutil.which("ccx") is None:
        pytest.skip("CalculiX (ccx) is not installed: the FE scene cannot run (make test installs it as root)")
    run = scene_run(name)
    assert run.status == 0
    check_summary(run.results, run.out)
    page_file = run.out / "report.html"
    assert static_problems(page_file) == []
    page = parse(page_file)
    written = set(json.loads((run.out / MANIFEST).read_text())["files"])
    figures = sorted(f for f in written if f.endswith(".png"))
    others = sorted(f for f in written - set(figures) if f != "report.html")
    assert len(page.images) == len(figures), "every figure on the page"
    assert len(page.figcaptions) == len(figures)
    assert all(" read " in c or ": read" in c for c in page.figcaptions), "every figure says what to read from it"
    assert sorted(unquote(h) for h in page.links) == others, "a link to every other file"
    assert page.tables[0][0][0] == "quantity" and len(page.tables[0]) > 3, "the key numbers first"
    if browser() is not None:
        r = browser_check(page_file)
        assert r["broken"] == [] and r["n_images"] == len(figures)
        assert r["scroll_width"] <= 1280 and r["wider"] == [], f"wider than 1280 px: {r['wider']}"
        shots = os.environ.get("GEAROPT_PAGE_SCREENSHOTS")  # a directory: keep a screenshot to look at
        if shots:
            Path(shots).mkdir(parents=True, exist_ok=True)
            screenshot(page_file, Path(shots) / f"{name}.png", 1280, 9000)


def test_page_figure_is_frozen():
    f = PageFigure("a.png", "c", "data:image/png;base64,")
    with pytest.raises(AttributeError):
        f.caption = "x"


def test_a_wheel_carries_the_template_and_jinja2_is_a_dependency():
    """The template is package data (pyproject's [tool.setuptools.package-data] matches it, so a
    non-editable install has it) and Jinja2 is a declared dependency."""
    import fnmatch
    import tomllib

    root = Path(__file__).resolve().parents[1]
    cfg = tomllib.loads((root / "pyproject.toml").read_text())
    assert any(d.split(">")[0].split("=")[0].strip().lower() == "jinja2" for d in cfg["project"]["dependencies"])
    data = cfg["tool"]["setuptools"]["package-data"]["gearopt.io"]
    templates = [p.relative_to(root / "gearopt" / "io").as_posix() for p in (root / "gearopt" / "io").rglob("*.j2")]
    assert templates and all(any(fnmatch.fnmatch(t, pat) for pat in data) for t in templates)


def test_svg_elements_counts_what_the_svg_would_hold():
    """Figures too heavy for SVG are recognised before rendering: mesh cells and markers count, a
    rasterized collection is one image."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from gearopt.io.page import SVG_MAX_ELEMENTS, svg_elements

    fig, ax = plt.subplots()
    ax.pcolormesh(np.zeros((40, 60)))
    assert svg_elements(fig) >= 2400 > SVG_MAX_ELEMENTS
    plt.close(fig)
    fig, ax = plt.subplots()
    ax.scatter(np.arange(5000), np.arange(5000), rasterized=True)
    ax.plot(np.arange(200))
    assert svg_elements(fig) < 50
    plt.close(fig)
