"""``gearopt compare`` of ISO 6336 rating designs (gearopt/plot/compare/rating.py, docs/compare.md): the safety
factors of both members against torque with the minimum lines, both methods' load factors, the load
spectrum's damage and safety, and the key-numbers table's rating rows. Fast: hand-made rating results
with the keys of a real rating results.json; the comparison of two real runs is slow (the scenes run)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from gearopt.cli import main  # noqa: E402
from gearopt.io.compare import compare  # noqa: E402
from gearopt.plot.compare import (  # noqa: E402
    comparison_figures, plot_rating_factor, plot_rating_spectrum, plot_safety, rating_of,
)
from gearopt.plot.style import plot_style  # noqa: E402
from gearopt.summary import rating_summary, summary_dicts  # noqa: E402
from gearopt.version import __version__  # noqa: E402

from plot_lint import lint_figure  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TORQUES = (25.0, 50.0, 100.0, 200.0)


def _rating(s_h: float, s_f: float, k_hb: float, used: str = "ltca", s_hmin: float = 1.0, s_fmin: float = 1.4,
            crossing: float = 2.0, spectrum: tuple | None = None) -> dict:
    """A rating results dict: S = s / sqrt(T / 100) (pitting) and s * 100 / T (bending) at the set used, the
    other set 10 % lower; the gear 8 % safer than the pinion; K_Hbeta (LTCA) falling from k_hb, ISO's 0.3 lower.
    ``spectrum``: (damage pitting pinion, gear, bending pinion, gear) with the safeties 1.1 ... 1.8."""
    other = "iso" if used == "ltca" else "ltca"
    rows = []
    for t in TORQUES:
        sh, sf = s_h / np.sqrt(t / 100.0), s_f * 100.0 / t
        kb = 1.0 + (k_hb - 1.0) * (100.0 / t) ** 0.5
        rows.append({"torque_Nm": t,
                     "S_H": {used: [sh, 1.08 * sh], other: [0.9 * sh, 0.9 * 1.08 * sh]},
                     "S_F": {used: [sf, 1.08 * sf], other: [0.9 * sf, 0.9 * 1.08 * sf]},
                     "sigma_H": {used: [1200.0 / s_h, 1150.0 / s_h], other: [1100.0, 1050.0]},
                     "sigma_F": {used: [250.0, 240.0], other: [230.0, 220.0]},
                     "K_Hbeta": {"ltca": kb, "iso": kb - 0.3},
                     "K_Halpha": {"ltca": 1.0, "iso": 1.0 + 2.0 / t}})
    nom = rows[2]
    res = {"study": "rating", "scene": "rating", "load_factors_used": used,
           "options": {"S_Hmin": s_hmin, "S_Fmin": s_fmin, "side": "right"},
           "pair": {"z1": 20, "z2": 40, "m_n": 3.0},
           "misalignment": {"dE_mm": 0.0, "crossing_arcmin": crossing, "intersecting_arcmin": 0.0, "axial_mm": 0.0},
           "misalignment_text": f"crossing +{crossing:g} arcmin", "torques": rows,
           "nominal": {"torque_Nm": 100.0,
                       "used": {k: nom[k][used] for k in ("S_H", "S_F", "sigma_H", "sigma_F")},
                       "iso": {"K_Hbeta": nom["K_Hbeta"]["iso"], "K_Halpha": nom["K_Halpha"]["iso"]},
                       "ltca": {"K_Hbeta": nom["K_Hbeta"]["ltca"], "K_Halpha": nom["K_Halpha"]["ltca"]}}}
    if spectrum is not None:
        res["spectrum"] = {"damage": {"pitting": list(spectrum[:2]), "bending": list(spectrum[2:])},
                           "safety": {"pitting": [1.1, 1.15], "bending": [1.7, 1.8]}}
    return res


def _lint(fig):
    with plot_style():
        fig.tight_layout()  # as save_figures lays them out
        problems = lint_figure(fig)
    plt.close(fig)
    assert problems == []


def _figures(designs):
    with plot_style():
        return {name: (caption, fig) for name, caption, fig in comparison_figures(designs)}


def _visible(fig):
    return [ax for ax in fig.axes if ax.get_visible()]


def test_safety_factors_of_both_members_per_design_with_the_minimum_lines():
    designs = {"crossing 2'": _rating(1.05, 2.9, 1.8), "ISO factors": _rating(1.2, 3.2, 1.5, used="iso")}
    figs = _figures(designs)
    assert list(figs) == ["compare_rating.png"]  # no spectrum: no spectrum figure
    s_h, s_f, k_hb, k_ha = _visible(figs["compare_rating.png"][1])
    curves = [line for line in s_h.get_lines() if len(line.get_xdata()) == len(TORQUES)]
    # one colour per design, solid pinion, dashed gear; the set each design uses (the second: ISO's)
    assert [(c.get_color(), c.get_linestyle()) for c in curves] == [("C0", "-"), ("C0", "--"), ("C1", "-"), ("C1", "--")]
    want = [[r["S_H"][d["load_factors_used"]][m] for r in d["torques"]] for d in designs.values() for m in (0, 1)]
    assert [list(c.get_ydata()) for c in curves] == want
    assert list(curves[0].get_xdata()) == list(TORQUES)
    assert s_h.get_yscale() == "log" and s_f.get_yscale() == "log"
    # the minimum safety lines at S_Hmin = 1 and S_Fmin = 1.4, the nominal torque
    flat = [line for line in s_h.get_lines() if len(line.get_ydata()) == 2 and line.get_ydata()[0] == line.get_ydata()[1]]
    assert [line.get_ydata()[0] for line in flat] == [1.0]
    assert 1.4 in [line.get_ydata()[0] for line in s_f.get_lines() if len(line.get_ydata()) == 2]
    texts = [t.get_text() for t in s_h.get_legend().get_texts()]
    assert texts[0] == "crossing 2': crossing +2 arcmin, gearopt LTCA factors"
    assert texts[1] == "ISO factors: crossing +2 arcmin, ISO 6336-1 factors"
    assert "S_Hmin = 1" in texts and "solid: pinion" in texts and "dashed: gear" in texts and "nominal 100 N m" in texts
    lo, hi = s_h.get_ylim()
    assert lo < 1.0 and hi > max(max(w) for w in want)  # every curve and the minimum inside
    for ax in (s_h, s_f, k_hb, k_ha):
        assert ax.get_xlabel() == "pinion torque [N m]" and "[-]" in ax.get_ylabel()
        assert ax.get_xlim()[0] == 0 and ax.get_xlim()[1] >= max(TORQUES)
    assert "S_H" in s_h.get_ylabel() and "S_F" in s_f.get_ylabel()
    assert "K_Hbeta" in k_hb.get_ylabel() and "K_Halpha" in k_ha.get_ylabel()
    _lint(figs["compare_rating.png"][1])


def test_load_factors_of_both_methods_per_design():
    designs = {"a": _rating(1.05, 2.9, 1.8), "b": _rating(1.1, 3.0, 2.4)}
    fig, ax = plt.subplots()
    plot_rating_factor(designs, "K_Hbeta", ax=ax)
    curves = [line for line in ax.get_lines() if len(line.get_xdata()) == len(TORQUES)]
    assert [(c.get_color(), c.get_linestyle()) for c in curves] == [("C0", "-"), ("C0", "--"), ("C1", "-"), ("C1", "--")]
    assert [list(c.get_ydata()) for c in curves] == [[r["K_Hbeta"][m] for r in d["torques"]]
                                                     for d in designs.values() for m in ("ltca", "iso")]
    assert ax.get_ylim()[1] > 1.0 + (2.4 - 1.0) * 2.0  # the largest K_Hbeta (at 25 N m) inside
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts[:2] == ["a: crossing +2 arcmin", "b: crossing +2 arcmin"]
    assert "solid: gearopt LTCA" in texts and "dashed: ISO 6336-1 method B" in texts
    _lint(fig)
    with pytest.raises(ValueError, match="K_Hbeta"):
        plot_rating_factor(designs, "K_v")


def test_different_minimum_safety_factors_are_both_drawn_and_named():
    designs = {"a": _rating(1.05, 2.9, 1.8), "b": _rating(1.1, 3.0, 1.6, s_hmin=1.3)}
    fig, ax = plt.subplots()
    plot_safety(designs, "S_H", ax=ax)
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "S_Hmin = 1 (a)" in texts and "S_Hmin = 1.3 (b)" in texts
    assert ax.get_ylim()[1] > 1.3
    plt.close(fig)


def test_spectrum_damage_and_safety_bars():
    designs = {"3'": _rating(1.05, 2.9, 1.8, spectrum=(0.0567, 0.0224, 0.0, 0.0)),
               "1'": _rating(1.1, 3.0, 1.6, spectrum=(0.0266, 0.0105, 0.0, 0.0)),
               "no spectrum": _rating(1.1, 3.0, 1.6)}
    figs = _figures(designs)
    assert list(figs) == ["compare_rating.png", "compare_rating_spectrum.png"]
    damage, safety = _visible(figs["compare_rating_spectrum.png"][1])
    heights = [p.get_height() for p in damage.patches]
    assert heights == [0.0567, 0.0224, 0.0, 0.0, 0.0266, 0.0105, 0.0, 0.0]  # per design: the four modes and members
    assert [p.get_facecolor()[:3] for p in damage.patches[::4]] == [matplotlib.colors.to_rgb("C0"),
                                                                    matplotlib.colors.to_rgb("C1")]
    assert [t.get_text() for t in damage.texts].count("0") == 4  # no damage written as 0, not left blank
    assert [t.get_text() for t in damage.get_legend().get_texts()] == ["3'", "1'"]  # the design without: left out
    assert [lab.get_text() for lab in damage.get_xticklabels()] == ["pitting\npinion", "pitting\ngear",
                                                                    "bending\npinion", "bending\ngear"]
    assert "Miner damage sum D [-]" in damage.get_ylabel() and "S [-]" in safety.get_ylabel()
    # each design's minimum over its bars: S_Hmin over pitting, S_Fmin over bending
    assert [t.get_text() for t in safety.get_legend().get_texts()] == ["3'", "1'", "minimum safety S_Hmin, S_Fmin"]
    mins = sorted({round(line.get_ydata()[0], 9) for line in safety.get_lines()})
    assert mins == [1.0, 1.4]
    assert safety.get_ylim()[1] > 1.8
    _lint(figs["compare_rating_spectrum.png"][1])
    plt.close(figs["compare_rating.png"][1])
    # one design with a spectrum: nothing to compare it with
    one = _figures({"3'": designs["3'"], "no spectrum": designs["no spectrum"]})
    assert list(one) == ["compare_rating.png"]
    plt.close(one["compare_rating.png"][1])


def _at_nominal(res: dict, k: int) -> dict:
    """``res`` rated at the nominal torque ``TORQUES[k]`` instead (its ``nominal`` from that row)."""
    row, used = res["torques"][k], res["load_factors_used"]
    res["nominal"] = {"torque_Nm": row["torque_Nm"],
                      "used": {q: row[q][used] for q in ("S_H", "S_F", "sigma_H", "sigma_F")},
                      **{m: {q: row[q][m] for q in ("K_Hbeta", "K_Halpha")} for m in ("iso", "ltca")}}
    return res


def test_designs_rated_at_different_torques_share_their_rows(tmp_path):
    """The same quantity of two designs rated at 100 and 200 N m is one row of the table (the keys do not
    carry the torque), beside the row of the nominal torques."""
    a = _rating_dir(tmp_path / "a", _rating(1.05, 2.9, 1.8))
    b = _rating_dir(tmp_path / "b", _at_nominal(_rating(1.2, 3.2, 1.5), 3))
    out = tmp_path / "cmp"
    compare([a, b], out, labels=["100", "200"])
    rows = {r["key"]: r for r in json.loads((out / "comparison.json").read_text())["key_numbers"]}
    assert rows["nominal_torque_Nm"]["values"] == {"100": 100.0, "200": 200.0}
    assert rows["nominal_torque_Nm"]["unit"] == "N m" and rows["nominal_torque_Nm"]["best"] == []
    # S_H = s / sqrt(T / 100) of the pinion: 1.05 at 100 N m, 1.2 / sqrt(2) at 200 N m
    assert rows["S_H_min"]["values"] == {"100": 1.05, "200": pytest.approx(1.2 / math.sqrt(2.0), rel=1e-12)}
    assert rows["S_H_min"]["best"] == ["100"]
    # S_F = s * 100 / T: 2.9 against 3.2 / 2
    assert rows["S_F[pinion]"]["values"] == {"100": 2.9, "200": pytest.approx(1.6, rel=1e-12)}
    assert set(rows["K_Hbeta[ltca]"]["values"]) == {"100", "200"}
    assert not [k for k in rows if k.endswith(" Nm]")]
    page = (out / "report.html").read_text()
    assert "nominal pinion torque of the rating" in page

def test_a_better_value_the_table_cannot_show_is_not_marked(tmp_path):
    """K_Halpha of gearopt's loaded TCA of two rating runs, 1.0000384 and 1.0000613 (a 2' and a 4' crossing):
    both shown as 1 on the page, neither marked better; 1.0000384 against 1.0009 is."""
    from gearopt.io.compare import load_design, key_numbers

    def design(name, k):
        res = _rating(1.05, 2.9, 1.8)
        res["nominal"]["ltca"]["K_Halpha"] = k
        return load_design(_rating_dir(tmp_path / name, res))

    rows = {r.key: r for r in key_numbers([design("a", 1.0000384), design("b", 1.0000613)])}
    assert rows["K_Halpha[ltca]"].best == []
    assert rows["K_Halpha[ltca]"].differences[1] == pytest.approx(2.29e-5, rel=1e-9)  # still the real one
    rows = {r.key: r for r in key_numbers([design("c", 1.0000384), design("d", 1.0009)])}
    assert rows["K_Halpha[ltca]"].best == [0]


def test_a_rating_and_a_tca_design_have_no_rating_figure():
    tca = {"study": "tca", "cases": []}
    assert rating_of(tca) is None and rating_of(_rating(1.0, 3.0, 1.8)) is not None
    assert _figures({"tca": tca, "rating": _rating(1.0, 3.0, 1.8)}) == {}


def _rating_dir(path: Path, res: dict) -> Path:
    """A result directory of a rating run: the results with the summary gearopt writes for them."""
    path.mkdir(parents=True)
    data = {**res, "scene": path.name, "units": {"torque": "N m"},
            "summary": summary_dicts(rating_summary(res)),
            "meta": {"gearopt_version": __version__, "scene": None}}
    (path / "results.json").write_text(json.dumps(data))
    (path / ".gearopt-output.json").write_text(json.dumps({"written_by": "gearopt", "files": ["results.json"]}))
    return path


def test_the_table_marks_the_higher_safety_and_the_lower_stress(tmp_path):
    a = _rating_dir(tmp_path / "a", _rating(1.05, 2.9, 1.8))
    b = _rating_dir(tmp_path / "b", _rating(1.2, 3.2, 1.5))
    out = tmp_path / "cmp"
    compare([a, b], out, labels=["crossing 2'", "crossing 1'"])
    data = json.loads((out / "comparison.json").read_text())
    rows = {r["key"]: r for r in data["key_numbers"]}
    assert rows["S_H_min"]["values"] == {"crossing 2'": 1.05, "crossing 1'": 1.2}
    assert rows["S_H_min"]["best"] == ["crossing 1'"]  # the higher safety is better
    assert rows["S_H_min"]["differences"]["crossing 1'"] == pytest.approx(0.15, abs=1e-12)
    assert rows["sigma_H_MPa[pinion]"]["best"] == ["crossing 1'"]  # the lower stress
    assert rows["K_Hbeta[ltca]"]["best"] == ["crossing 1'"]  # the lower face load factor
    assert rows["load_factors_used"]["best"] == []  # no direction
    # K_Halpha (LTCA) 1.0 against 1.0: equal, none marked
    assert rows["K_Halpha[ltca]"]["best"] == []
    assert [f["file"] for f in data["figures"]] == ["compare_rating.png"]
    page = (out / "report.html").read_text()
    assert "Pitting and bending safety of pinion (solid) and gear (dashed) against torque" in page  # the caption
    assert "solid pinion, dashed gear" in page  # the page says what the line styles mean


# --- two real rating runs (slow) --------------------------------------------------------------------------
@pytest.mark.slow
def test_two_real_rating_runs_compared(scene_run, tmp_path):
    """The rating demo (2' crossing) against the same drive under a 4' crossing, run through the CLI:
    the plotted safety factors are each run's own, the table's numbers each run's summary, and the
    larger misalignment is the weaker design (higher K_Hbeta, lower S_H)."""
    spur = scene_run("rating_spur")
    assert spur.status == 0
    scene = tmp_path / "rating_spur_4arcmin.toml"
    text = (ROOT / "problems" / "rating_spur.toml").read_text()
    assert 'crossing = "2 arcmin"' in text
    scene.write_text(text.replace('crossing = "2 arcmin"', 'crossing = "4 arcmin"')
                     .replace('name = "rating_spur"', 'name = "rating_spur_4arcmin"'))
    other = tmp_path / "run4"
    assert main(["run", str(scene), "--out", str(other), "--quiet"]) == 0
    out = tmp_path / "cmp"
    assert main(["compare", str(spur.out), str(other), "--labels", "2',4'", "--out", str(out), "--quiet"]) == 0
    data = json.loads((out / "comparison.json").read_text())
    assert [f["file"] for f in data["figures"]] == ["compare_rating.png"]
    assert (out / "compare_rating.png").stat().st_size > 20_000
    r4 = json.loads((other / "results.json").read_text())
    rows = {r["key"]: r for r in data["key_numbers"]}
    s2 = {r["key"]: r["value"] for r in spur.results["summary"]}
    s4 = {r["key"]: r["value"] for r in r4["summary"]}
    key = "S_H_min"
    assert rows[key]["values"] == {"2'": s2[key], "4'": s4[key]}
    assert rows[key]["best"] == ["2'"] and s4[key] < s2[key]
    assert rows["K_Hbeta[ltca]"]["best"] == ["2'"]
    # the figure draws each run's own safety factors
    designs = {"2'": spur.results, "4'": r4}
    fig, ax = plt.subplots()
    plot_safety(designs, "S_F", ax=ax)
    curves = [line for line in ax.get_lines() if len(line.get_xdata()) == len(spur.results["torques"])]
    assert list(curves[2].get_ydata()) == [t["S_F"][r4["load_factors_used"]][0] for t in r4["torques"]]
    _lint(fig)
    spec = {"2'": spur.results, "4'": r4}
    fig, ax = plt.subplots()
    plot_rating_spectrum(spec, ax=ax)  # no spectra: empty bars, no legend, still labelled
    assert not ax.patches and "D [-]" in ax.get_ylabel()
    plt.close(fig)
