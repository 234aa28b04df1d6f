"""``gearopt compare`` (gearopt/io/compare.py, docs/compare.md): the key-numbers table against the
designs' own summaries, the refusals (not the same pair, not a design, another schema), the output
directory's rules, and the comparison of real runs (slow: the scenes run)."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from gearopt.cli import main
from gearopt.errors import GeometryError, OptionError, ResultsError
from gearopt.io.compare import compare, key_numbers, load_design
from gearopt.version import __version__

ROOT = Path(__file__).resolve().parents[1]
NA = "n/a"  # what the table shows for a quantity a design does not have (docs/compare.md), never 0
DEMO = ROOT / "problems" / "tca_spur_crowned.toml"


def _row(key, value, better="lower", unit="arcsec", group="unloaded TE", label=None):
    return {"key": key, "label": label or key, "value": value, "unit": unit, "better": better, "group": group}


def _result_dir(path: Path, z1=20, z2=40, m_n=3.0, side="right", summary=None, version=__version__,
                study="tca", name=None, pair=True) -> Path:
    """A result directory as gearopt run leaves it, with a hand-written summary (no arrays)."""
    path.mkdir(parents=True)
    data = {"study": study, "scene": name or path.name,
            "summary": summary if summary is not None else [],
            "units": {"length": "mm"},
            "pair": {"z1": z1, "z2": z2, "m_n": m_n, "side": side, "ratio": z2 / z1},
            "meta": {"gearopt_version": version, "scene": None}}
    if not pair:
        del data["pair"]
    (path / "results.json").write_text(json.dumps(data))
    (path / ".gearopt-output.json").write_text(json.dumps({"written_by": "gearopt", "files": ["results.json"]}))
    return path


def _csv(path: Path) -> list[dict]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


# --- the table --------------------------------------------------------------------------------------
def test_table_values_differences_better_and_missing(tmp_path):
    a = _result_dir(tmp_path / "a", summary=[_row("z1", 20, None, "", "geometry"),
                                             _row("te_pp_arcsec[aligned]", 18.0),
                                             _row("eps_alpha", 1.6, "higher", "", "geometry"),
                                             _row("te_h1_arcsec[aligned]", None)])
    b = _result_dir(tmp_path / "b", summary=[_row("z1", 20, None, "", "geometry"),
                                             _row("te_pp_arcsec[aligned]", 7.5),
                                             _row("eps_alpha", 1.7, "higher", "", "geometry"),
                                             _row("lte_pp_arcsec[200 Nm]", 30.0, group="loaded"),
                                             _row("before.te_pp_arcsec[aligned]", 0.0)])
    out = tmp_path / "cmp"
    compare([a, b], out, labels=["demo", "optimised"])
    table = _csv(out / "key_numbers.csv")
    rows = {r["key"]: r for r in table}
    # by group, the quantities both designs have first; the start design of an optimisation left out
    assert [r["key"] for r in table] == ["z1", "eps_alpha", "te_pp_arcsec[aligned]", "te_h1_arcsec[aligned]",
                                         "lte_pp_arcsec[200 Nm]"]
    te = rows["te_pp_arcsec[aligned]"]
    assert (float(te["demo"]), float(te["optimised"])) == (18.0, 7.5)
    assert float(te["optimised - demo"]) == pytest.approx(-10.5, abs=1e-12)
    assert te["best"] == "optimised"  # lower TE is better
    assert rows["eps_alpha"]["best"] == "optimised"  # a higher contact ratio is better
    assert rows["z1"]["best"] == "" and float(rows["z1"]["optimised - demo"]) == 0.0  # no direction: none marked
    loaded = rows["lte_pp_arcsec[200 Nm]"]  # only the second design has it: n/a, never 0
    assert loaded["demo"] == NA and float(loaded["optimised"]) == 30.0
    assert loaded["optimised - demo"] == "" and loaded["best"] == ""
    h1 = rows["te_h1_arcsec[aligned]"]  # the first has it without a value, the second not at all
    assert h1["demo"] == "" and h1["optimised"] == NA
    # the page holds the same table
    page = (out / "report.html").read_text()
    assert "demo" in page and "optimised" in page and NA in page
    data = json.loads((out / "comparison.json").read_text())
    assert [d["label"] for d in data["designs"]] == ["demo", "optimised"]


def test_equal_values_mark_no_design(tmp_path):
    a = _result_dir(tmp_path / "a", summary=[_row("te_pp_arcsec[aligned]", 8.0)])
    b = _result_dir(tmp_path / "b", summary=[_row("te_pp_arcsec[aligned]", 8.0)])
    rows = key_numbers([load_design(a), load_design(b)])
    assert rows[0].best == [] and rows[0].differences == [None, 0.0]


def test_cases_of_different_labels_share_a_row_by_their_misalignment(tmp_path):
    """A tca run's "misaligned" case and a crowning run's "crossing +3'" case under the same 3'
    crossing are one row of the table."""
    mis = {"dE_mm": 0.0, "crossing_arcmin": 3.0, "intersecting_arcmin": 0.0, "axial_mm": 0.0}
    a = _result_dir(tmp_path / "a", summary=[_row("te_pp_arcsec[misaligned]", 18.4)])
    b = _result_dir(tmp_path / "b", summary=[_row("te_pp_arcsec[crossing +3']", 8.0)])
    for d, label in ((a, "misaligned"), (b, "crossing +3'")):
        data = json.loads((d / "results.json").read_text())
        data["cases"] = [{"label": label, "misalignment": mis}]
        (d / "results.json").write_text(json.dumps(data))
    rows = key_numbers([load_design(a), load_design(b)])
    assert [(r.key, r.values) for r in rows] == [("te_pp_arcsec[crossing +3 arcmin]", [18.4, 8.0])]


# --- refusals -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, why", [
    (dict(z1=21, z2=53), "different ratios z2/z1"),
    (dict(z1=21, z2=42), "different tooth numbers"),
    (dict(m_n=4.0), "different normal modules"),
    (dict(side="left"), "different driving flanks"),
])
def test_other_pair_refused_naming_both_designs(tmp_path, kw, why):
    a = _result_dir(tmp_path / "first")
    b = _result_dir(tmp_path / "second", **kw)
    out = tmp_path / "cmp"
    with pytest.raises(GeometryError, match=why) as e:
        compare([a, b], out)
    assert "'first'" in str(e.value) and "'second'" in str(e.value)
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["first", "second"]  # nothing written


def test_scene_of_another_pair_refused_before_it_runs(tmp_path):
    other = tmp_path / "helical.toml"
    other.write_text(DEMO.read_text().replace("z = 40", "z = 53"))
    a = _result_dir(tmp_path / "demo")
    out = tmp_path / "cmp"
    ran = []
    with pytest.raises(GeometryError, match="different ratios"):
        compare([a, other], out, run_scene=lambda s, d: ran.append(s))
    assert ran == [] and not out.exists()


def test_a_design_whose_pair_is_unknown_is_compared_with_a_note(tmp_path):
    """A crowning result states no pair; without its scene the pair is not checked, and the page
    says so for that design."""
    a = _result_dir(tmp_path / "a")
    b = _result_dir(tmp_path / "b", study="crowning", pair=False)
    compare([a, b], tmp_path / "cmp")
    notes = {d["label"]: d["warnings"] for d in json.loads((tmp_path / "cmp" / "comparison.json").read_text())["designs"]}
    assert notes["a"] == [] and "z1, z2, m_n are not in its results" in notes["b"][0]
    assert "b: its z1, z2, m_n are not in its results" in (tmp_path / "cmp" / "report.html").read_text()


def test_arguments_that_are_no_design(tmp_path):
    a = _result_dir(tmp_path / "a")
    foreign = tmp_path / "notes"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    text = tmp_path / "x.csv"
    text.write_text("1,2\n")
    for bad, match in ((foreign, "without results.json"), (tmp_path / "missing", "no such file"),
                       (text, "neither a result directory nor a scene")):
        with pytest.raises(OptionError, match=match) as e:
            compare([a, bad], tmp_path / "cmp")
        assert e.value.param == "DESIGN" and str(bad) in str(e.value)
    with pytest.raises(OptionError, match="at least two"):
        compare([a], tmp_path / "cmp")
    with pytest.raises(OptionError, match="2 labels for 3 designs"):
        compare([a, a, a], tmp_path / "cmp", labels=["x", "y"])
    assert not (tmp_path / "cmp").exists()


def test_results_of_another_schema_refused(tmp_path):
    a = _result_dir(tmp_path / "a")
    old = _result_dir(tmp_path / "old", version="7.2.0")
    with pytest.raises(ResultsError, match="written by gearopt 7.2.0"):
        compare([a, old], tmp_path / "cmp")
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "results.json").write_text(json.dumps({"cases": []}))
    with pytest.raises(ResultsError, match="not a gearopt results file"):
        compare([a, junk], tmp_path / "cmp")
    unknown = _result_dir(tmp_path / "unknown", study="gearbox")
    with pytest.raises(ResultsError, match="'gearbox' is not a study"):
        compare([a, unknown], tmp_path / "cmp")
    assert not (tmp_path / "cmp").exists()


# --- the output directory -------------------------------------------------------------------------------
def test_out_dir_rules(tmp_path):
    a = _result_dir(tmp_path / "a", summary=[_row("te_pp_arcsec[aligned]", 18.0)])
    b = _result_dir(tmp_path / "b", summary=[_row("te_pp_arcsec[aligned]", 8.0)])
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    with pytest.raises(ResultsError, match="holds files gearopt did not write"):
        compare([a, b], mine)
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]
    with pytest.raises(ResultsError, match="the design"):  # the comparison would replace a design's files
        compare([a, b], a)
    # a previous comparison is replaced, a note added to it kept
    out = tmp_path / "cmp"
    compare([a, b], out)
    inside = _result_dir(out / "c")  # a design kept inside the comparison's directory
    with pytest.raises(ResultsError, match="holds the design"):
        compare([inside, b], out)
    shutil.rmtree(inside)
    (out / "note.txt").write_text("keep")
    compare([b, a], out, labels=["B", "A"])
    assert _csv(out / "key_numbers.csv")[0]["B"] == "8.0"
    assert (out / "note.txt").read_text() == "keep"
    manifest = json.loads((out / ".gearopt-output.json").read_text())["files"]
    assert "key_numbers.csv" in manifest and "report.html" in manifest and "note.txt" not in manifest
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".cmp")]  # no temporary directory left


def test_cli_refusal_exit_status_and_message(tmp_path, capsys):
    a = _result_dir(tmp_path / "a")
    b = _result_dir(tmp_path / "b", z1=21, z2=53)
    assert main(["compare", str(a), str(b), "--out", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: gearopt compare: designs 'a'") and "different ratios" in err
    assert not (tmp_path / "cmp").exists()


# --- real runs (slow) ------------------------------------------------------------------------------------
@pytest.mark.slow
def test_two_crownings_compared_through_the_cli(tmp_path, capsys):
    """Two tca scenes of the demo drive with different profile crowning, run by compare itself:
    the table's numbers are those of each run's own summary, the differences right."""
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    text = DEMO.read_text().replace("positions = 81", "positions = 41")
    a.write_text(text)
    b.write_text(text.replace('a_c = "0.002 1/mm"', 'a_c = "0.001 1/mm"').replace(
        'name = "tca_spur_crowned"', 'name = "less_profile_crowning"'))
    out = tmp_path / "cmp"
    assert main(["compare", str(a), str(b), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out.split()
    assert str(out / "key_numbers.csv") in printed and str(out / "report.html") in printed
    ra = json.loads((out / "tca_spur_crowned" / "results.json").read_text())
    rb = json.loads((out / "less_profile_crowning" / "results.json").read_text())
    rows = {r["key"]: r for r in _csv(out / "key_numbers.csv")}
    sa = {r["key"]: r["value"] for r in ra["summary"]}
    sb = {r["key"]: r["value"] for r in rb["summary"]}
    pp = "te_pp_arcsec[aligned]"
    assert float(rows[pp]["tca_spur_crowned"]) == sa[pp]
    assert float(rows[pp]["less_profile_crowning"]) == sb[pp]
    assert float(rows[pp]["less_profile_crowning - tca_spur_crowned"]) == pytest.approx(sb[pp] - sa[pp], abs=1e-12)
    # less profile crowning: a lower parabola, the better TE
    assert sb[pp] < sa[pp] and rows[pp]["best"] == "less_profile_crowning"
    # the misaligned case is keyed by its misalignment
    assert float(rows["te_pp_arcsec[crossing +3 arcmin]"]["tca_spur_crowned"]) == sa["te_pp_arcsec[misaligned]"]
    for png in ("compare_te.png", "compare_contact.png", "compare_crowning.png"):
        assert (out / png).stat().st_size > 10_000, png
    data = json.loads((out / "comparison.json").read_text())
    assert [f["file"] for f in data["figures"]] == ["compare_te.png", "compare_contact.png", "compare_crowning.png"]
    assert (out / "tca_spur_crowned" / "te.png").is_file()  # the scene's own run is kept beside
    shutil.rmtree(out)


@pytest.mark.slow
def test_tca_scene_and_ltca_run_compare_their_unloaded_te(scene_run, tmp_path):
    """Different studies of the same pair combine what they have in common: the tca demo and the loaded
    TCA of the same drive share the unloaded TE of the crossed case; the loaded numbers exist only for
    the ltca run (n/a for the tca run)."""
    ltca = scene_run("ltca_crowned")
    out = tmp_path / "cmp"
    # the tca design as a scene, run here by the library's own runner (no run_scene given)
    compare([DEMO, ltca.out], out, labels=["tca", "ltca"])
    assert json.loads((out / "tca" / "results.json").read_text())["study"] == "tca"
    data = json.loads((out / "comparison.json").read_text())
    assert "compare_te.png" in [f["file"] for f in data["figures"]]
    # the unloaded TE of the 3' crossing on one row: the tca case and the ltca run's unloaded slices
    te = {r["key"]: r for r in data["key_numbers"]}["te_pp_arcsec[crossing +3 arcmin]"]["values"]
    tca = json.loads((out / "tca" / "results.json").read_text())
    assert te["tca"] == tca["cases"][1]["peak_to_peak_arcsec"]
    assert te["ltca"] == ltca.results["unloaded_peak_to_peak_arcsec"]
    assert te["ltca"] == pytest.approx(te["tca"], rel=0.02)  # the same drive, one mesh cycle of 64 positions
    rows = {r["key"]: r for r in _csv(out / "key_numbers.csv")}
    loaded = [r for r in rows.values() if r["group"] == "loaded"]
    assert loaded and all(r["tca"] == NA and r["ltca"] != NA for r in loaded)


def test_monte_carlo_designs_compare_their_sample_distributions(tmp_path):
    """The samples tables beside two montecarlo results are read (empty cells: samples that did not
    solve) and drawn as distributions."""
    dirs = []
    for name, values in (("class6", ["21.0", "18.5", "", "19.0"]), ("class5", ["12.0", "11.5", "13.0", "12.5"])):
        d = _result_dir(tmp_path / name, study="montecarlo",
                        summary=[_row("mc_te_pp_arcsec[p50]", float(sorted(v for v in values if v)[1]),
                                      group="Monte Carlo")])
        data = json.loads((d / "results.json").read_text())
        data["samples_csv"] = "samples.csv"
        (d / "results.json").write_text(json.dumps(data))
        (d / "samples.csv").write_text("sample,te_p2p_arcsec\n" + "".join(f"{i},{v}\n" for i, v in enumerate(values)))
        dirs.append(d)
    design = load_design(dirs[0])
    te = design.samples["te_p2p_arcsec"]
    assert te.size == 4 and np.isnan(te[2]) and te[0] == 21.0
    out = tmp_path / "cmp"
    compare(dirs, out)
    data = json.loads((out / "comparison.json").read_text())
    assert [f["file"] for f in data["figures"]] == ["compare_distribution.png"]
    assert data["key_numbers"][0]["best"] == ["class5"]


@pytest.mark.slow
def test_loaded_designs_on_one_pressure_scale(scene_run):
    """Two ltca runs of the 20/40 drive: the contact patterns share one colour scale up to the larger
    of the two designs' peak flank pressures; the loaded TE is compared at a torque both analysed."""
    import matplotlib.pyplot as plt

    from gearopt.plot.compare import common_torque, comparison_figures
    from gearopt.plot.style import plot_style

    res = {lab: scene_run(name).results for lab, name in (("unmodified", "ltca_spur"), ("crowned", "ltca_crowned"))}
    top = 0.0
    for r in res.values():
        pat = r["pattern"]
        top = max([top] + [p for p, e in zip(pat["p0_MPa"], pat["edge"]) if p is not None and not e])
    with plot_style():
        figs = {name: fig for name, _, fig in comparison_figures(res)}
    # ltca_spur runs aligned, ltca_crowned under a 3' crossing: no common case for the unloaded TE panels
    assert sorted(figs) == ["compare_loaded.png", "compare_pattern.png"]
    meshes = [c for ax in figs["compare_pattern.png"].axes for c in ax.collections if hasattr(c, "get_clim")
              and c.get_array() is not None and c.get_array().ndim >= 1]
    assert len(meshes) >= 2 and all(m.get_clim() == pytest.approx((0.0, top)) for m in meshes)
    shared = set(res["unmodified"]["options"]["torques_Nm"]) & set(res["crowned"]["options"]["torques_Nm"])
    assert common_torque(res) in shared
    assert common_torque(res) == min(shared, key=lambda T: abs(T - res["unmodified"]["nominal_torque_Nm"]))
    for f in figs.values():
        plt.close(f)


# --- the page ----------------------------------------------------------------------------------------------
def _mc_pair(tmp_path) -> list[Path]:
    dirs = []
    for name, values, p95 in (("class6", [21.0, 18.5, 19.0, 23.0], 22.7), ("class5", [12.0, 11.5, 13.0, 12.5], 12.9)):
        d = _result_dir(tmp_path / name, study="montecarlo",
                        summary=[_row("z1", 20, None, "", "geometry"),
                                 _row("mc_te_pp_arcsec[p95]", p95, group="Monte Carlo"),
                                 *([_row("mc_p_edge", 0.1, group="Monte Carlo", unit="")] if name == "class6" else [])])
        data = json.loads((d / "results.json").read_text())
        data["samples_csv"] = "samples.csv"
        data["warnings"] = ["only 60 % of the samples are feasible"] if name == "class6" else []
        (d / "results.json").write_text(json.dumps(data))
        (d / "samples.csv").write_text("sample,te_p2p_arcsec\n" + "".join(f"{i},{v}\n" for i, v in enumerate(values)))
        dirs.append(d)
    return dirs


def test_page_table_first_figures_inline_links_beside(tmp_path):
    from page_check import parse, static_problems

    out = tmp_path / "cmp"
    compare(_mc_pair(tmp_path), out, labels=["class 6", "class 5"])
    page = out / "report.html"
    assert static_problems(page) == []  # images inline, links to files beside the page, nothing fetched
    parsed = parse(page)
    table = parsed.tables[0]  # the key numbers come first
    assert table[0] == ["quantity", "unit", "better", "class 6", "class 5", "class 5 \u2212 class 6"]
    cells = {r[0]: r for r in table[1:] if len(r) > 1}
    assert cells["mc_te_pp_arcsec[p95]"][3:] == ["22.7", "12.9", "-9.8"]
    assert cells["mc_p_edge"][3:5] == ["0.1", NA]  # class 5 has no such number: n/a, never 0
    text = " ".join(parsed.text)
    assert "class 6: only 60 % of the samples are feasible" in text  # a design's warning, highlighted
    assert parsed.figcaptions and len(parsed.images) == 1
    assert sorted(parsed.links) == ["comparison.json", "key_numbers.csv"]  # the designs lie elsewhere


def test_page_in_a_browser(tmp_path):
    from page_check import browser, browser_check

    if browser() is None:
        pytest.skip("Chromium is not installed (make chromium installs it as root): the page is not opened")
    out = tmp_path / "cmp"
    compare(_mc_pair(tmp_path), out)
    r = browser_check(out / "report.html", width=1280)
    assert r["n_images"] == 1 and r["broken"] == []
    assert r["scroll_width"] <= r["inner_width"] and r["wider"] == []  # nothing overflows 1280 px
    assert r["smallest_table_font_px"] >= 11


def test_bad_scene_refused_and_a_failed_run_leaves_nothing(tmp_path):
    from gearopt.errors import GearoptError, SceneError

    a = _result_dir(tmp_path / "a")
    bad = tmp_path / "bad.toml"
    bad.write_text(DEMO.read_text().replace("z = 20", "z = -20"))
    with pytest.raises(SceneError, match=r"\[pinion\] z"):
        compare([a, bad], tmp_path / "cmp")
    good = tmp_path / "good.toml"
    good.write_text(DEMO.read_text())

    def fails(scene, directory):
        directory.mkdir()
        (directory / "results.json").write_text("{}")  # half-written when the run fails
        raise GearoptError(f"the scene {scene} did not run")

    with pytest.raises(GearoptError, match="did not run"):
        compare([a, good], tmp_path / "cmp", run_scene=fails)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "bad.toml", "good.toml"]  # no output, no temporary


@pytest.mark.slow
@pytest.mark.ipopt
def test_the_documented_comparison_of_the_demo_and_its_optimised_crowning(tmp_path, monkeypatch, scene_run):
    """The command of docs/compare.md, as written there (run from the repository root, into a
    temporary --out; its two scenes replaced by their runs of this test session, which is what the
    command runs first: test_two_crownings_compared_through_the_cli runs scenes through compare),
    and the numbers that page states."""
    import re
    import shlex

    doc = (ROOT / "docs" / "compare.md").read_text()
    block = re.search(r"## The demo against its optimised crowning\n\n```sh\n(.*?)```", doc, re.S).group(1)
    argv = shlex.split(block.replace("\\\n", " "))
    assert argv[:2] == ["gearopt", "compare"]
    argv[argv.index("--out") + 1] = str(tmp_path / "compare_crowning")
    scenes = [a for a in argv if a.startswith("problems/") and a.endswith(".toml")]
    assert scenes == ["problems/tca_spur_crowned.toml", "problems/crowning_spur.toml"]
    runs = {a: scene_run(Path(a).stem).out for a in scenes}
    argv = [str(runs.get(a, a)) for a in argv]
    monkeypatch.chdir(ROOT)
    assert main([*argv[1:], "--quiet"]) == 0
    out = tmp_path / "compare_crowning"
    rows = {r["key"]: r for r in _csv(out / "key_numbers.csv")}
    pp = rows["te_pp_arcsec[aligned]"]
    assert round(float(pp["demo crowning"]), 1) == 18.4 and round(float(pp["optimised crowning"]), 1) == 7.9
    assert pp["best"] == "optimised crowning"
    crossed = rows["te_pp_arcsec[crossing +3 arcmin]"]
    assert crossed["demo crowning"] != NA and crossed["optimised crowning"] != NA
    opt = json.loads((runs["problems/crowning_spur.toml"] / "results.json").read_text())
    iso = opt["design"]["iso_um"]
    assert (round(iso["C_alpha"], 1), round(iso["C_beta"], 1)) == (5.7, 4.9)
    demo = json.loads((runs["problems/tca_spur_crowned.toml"] / "results.json").read_text())["pair"]["pinion_iso_um"]
    assert (round(demo["C_alpha"], 1), round(demo["C_beta"], 1)) == (13.5, 13.7)
    path = [c for c in opt["after"] if c["misalignment"]["crossing_arcmin"] == 3.0][0]
    z = [v for v in path["paths_central_pair"]["surface"]["pinion"]["axial"] if v is not None]
    assert -8.6 < min(z) and max(z) < -8.2  # "z = -8.3 ... -8.5 mm, 1.5 mm from the face end"
    data = json.loads((out / "comparison.json").read_text())
    assert [f["file"] for f in data["figures"]] == ["compare_te.png", "compare_contact.png", "compare_crowning.png"]


def test_designs_of_the_same_name_get_distinct_labels(tmp_path):
    a = _result_dir(tmp_path / "x" / "run", name="demo")
    b = _result_dir(tmp_path / "y" / "run", name="demo")
    c = _result_dir(tmp_path / "z" / "other", name="demo")
    compare([a, b, c], tmp_path / "cmp")
    labels = [d["label"] for d in json.loads((tmp_path / "cmp" / "comparison.json").read_text())["designs"]]
    assert labels == ["demo (#1)", "demo (#2)", "demo (other)"]
