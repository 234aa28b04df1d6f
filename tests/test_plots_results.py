"""Plots a gear engineer can read and results.json keys that say what they hold (gearopt.plot, gearopt.io.results).

The plot tests inspect the Axes (legend entries against the drawn artists, transfer lines, axis
limits, clipping, layout boxes) of figures drawn from real TCA runs and from small hand-made case
dicts; the results tests check key meanings against the engine's own arrays and independent facts
(the central pair drives at the pitch point of a crowned drive).
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import gearopt  # noqa: E402
from gearopt import ARCMIN, BasicRack, Gear, GearPair, Misalignment  # noqa: E402
from gearopt.errors import SceneError  # noqa: E402
from gearopt.io.results import write_results  # noqa: E402
from gearopt.io.scene import load_scene  # noqa: E402
from gearopt.plot import tca as P  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RAD_TO_ARCSEC = 180 / math.pi * 3600


# --- helpers -----------------------------------------------------------------------------------
def _legend_labels(ax):
    leg = ax.get_legend()
    return [] if leg is None else [t.get_text() for t in leg.get_texts()]


def _finite_lines(ax):
    out = {}
    for ln in ax.get_lines():
        xy = np.asarray(ln.get_xydata(), float)
        if xy.size and np.isfinite(xy).all(axis=1).any() or ln.get_gid() == "legend-proxy":
            out.setdefault(ln.get_label(), []).append(ln)
    return out


def _check_legend(ax):
    """Every legend entry names a drawn artist (finite data), once."""
    labels = _legend_labels(ax)
    assert len(labels) == len(set(labels)), f"duplicate legend labels {labels}"
    drawn = _finite_lines(ax)
    for lab in labels:
        assert lab in drawn, f"legend entry {lab!r} has no drawn artist"
    return labels


def _vlines(ax):
    """Vertical lines (axvline): two points with equal x."""
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == ln.get_xdata()[1]
            and ln.get_transform() is not ax.transData]


# --- real runs ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def crowned_report():
    pinion = Gear(z=20, m_n=3.0, b=20, a_pl=0.0004, rack=BasicRack.iso53("A", a_c=0.002), name="pinion")
    pair = GearPair(pinion, Gear(z=40, m_n=3.0, b=20, name="gear"))
    study = gearopt.TCAStudy(pair, positions=21, name="crowned",
                             cases=[("crossing +3'", Misalignment(crossing=3 * ARCMIN)),
                                    ("dE +0.05 mm", Misalignment(dE=0.05))])
    return study, study.run()


@pytest.fixture(scope="module")
def conjugate_edge_report():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20, name="pinion"), Gear(z=40, m_n=3.0, b=20, name="gear"))
    study = gearopt.TCAStudy(pair, contact="line", positions=41, edge_contact=True, name="conj",
                             misalignment=Misalignment(crossing=3 * ARCMIN))
    return study.run()


def test_top_level_names():
    from gearopt.geometry.involute import inv, inv_inverse
    from gearopt.studies.crowning import CrowningStudy
    from gearopt.studies.tca import TCAStudy
    assert gearopt.TCAStudy is TCAStudy and gearopt.CrowningStudy is CrowningStudy
    assert gearopt.inv is inv and gearopt.inv_inverse is inv_inverse
    assert {"TCAStudy", "CrowningStudy", "inv", "inv_inverse"} <= set(gearopt.__all__)
    assert gearopt.inv(0.35) == pytest.approx(math.tan(0.35) - 0.35, abs=1e-16)


def test_study_over_a_list_of_cases_and_result_keys(crowned_report):
    study, rep = crowned_report
    d = json.loads(json.dumps(rep.to_dict()))
    assert [c["label"] for c in d["cases"]] == ["aligned", "crossing +3'", "dE +0.05 mm"]
    assert d["cases"][1]["misalignment"] == {"dE_mm": 0.0, "crossing_arcmin": pytest.approx(3.0),
                                             "intersecting_arcmin": 0.0, "axial_mm": 0.0}
    assert d["cases"][2]["misalignment"]["dE_mm"] == 0.05
    for case in d["cases"]:
        # driving_pair is the tooth pair number (the central pair 0 drives at the pitch point of a
        # crowned drive), one of case["pairs"] or None
        assert set(case["driving_pair"]) <= set(case["pairs"]) | {None}
        phi = np.asarray(case["phi1"])
        assert case["driving_pair"][int(np.argmin(np.abs(phi)))] == 0
        i = int(np.argmin(np.abs(phi - 2 * math.pi / 20)))  # one pitch later: the next pair, +1
        assert case["driving_pair"][i] == 1
        for m in ("pinion", "gear"):
            assert "axial" in case[m] and "z" not in case[m]
        assert "delta_mm" in case and "delta" not in case
        assert "ellipse_semi_major_mm" in case and "ellipse_a" not in case
        a, b = np.asarray(case["ellipse_semi_major_mm"], float), np.asarray(case["ellipse_semi_minor_mm"], float)
        ok = np.isfinite(a) & np.isfinite(b)
        assert ok.any() and (a[ok] >= b[ok]).all()
        assert case["actual_te_at_every_position"] is True and "all_converged" not in case
        assert "n_failed" not in case["stats"]
        assert case["stats"]["n_pair_positions_without_contact"] > 0  # pairs +-2 are out of mesh
        assert case["conjugate"] is False
    assert "docs/results.md" in d["units"]["see"]


def test_peak_to_peak_arcsec_property(crowned_report):
    study, _ = crowned_report
    res = study.tca.sweep(np.linspace(-0.3, 0.3, 31))
    env = res.te_envelope[np.isfinite(res.te_envelope)]
    assert res.peak_to_peak_arcsec == pytest.approx((env.max() - env.min()) * RAD_TO_ARCSEC, rel=1e-12)


def test_csv_tables_beside_results(crowned_report, tmp_path):
    _, rep = crowned_report
    out = tmp_path / "out"
    files = write_results(out, rep, plots=False)
    names = sorted(p.name for p in files)
    assert "te_path_aligned.csv" in names and "te_path_dE_+0_05_mm.csv" in names
    d = json.loads((out / "results.json").read_text())
    for case in d["cases"]:
        rows = list(csv.DictReader((out / f"te_path_{P_slug(case['label'])}.csv").open()))
        assert len(rows) == len(case["phi1"])
        for row, phi, te, drv, z in zip(rows, case["phi1"], case["te_envelope_arcsec"], case["driving_pair"],
                                        case["pinion"]["axial"]):
            assert float(row["phi1_deg"]) == pytest.approx(math.degrees(phi), rel=1e-14)
            assert (row["te_envelope_arcsec"] == "") == (te is None)
            if te is not None:
                assert float(row["te_envelope_arcsec"]) == te
            assert row["driving_pair"] == ("" if drv is None else str(drv))
            if z is not None:
                assert float(row["pinion_axial_mm"]) == z


def P_slug(label):
    from gearopt.studies.tca import _slug
    return _slug(label)


@pytest.mark.slow
def test_te_plot_legend_and_layout(crowned_report, tmp_path, monkeypatch):
    _, rep = crowned_report
    figs = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figs.append(fig))
    rep.save_plots(tmp_path)
    assert len(figs) == 3
    for fig in figs:
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        fbox = fig.get_window_extent(r)
        sup = fig._suptitle.get_window_extent(r)
        for ax in fig.axes:
            t = ax.title.get_window_extent(r)
            # titles inside the figure (not clipped) and below the suptitle (no overlap)
            assert t.x0 >= fbox.x0 - 1 and t.x1 <= fbox.x1 + 1 and t.y1 <= fbox.y1 + 1
            assert t.y1 <= sup.y0 + 1 or t.width == 0, "suptitle over a panel title"
            _check_legend(ax)
            assert "(aligned)" not in ax.get_title()
    te_fig = figs[0]
    for ax in te_fig.axes:
        labels = _legend_labels(ax)
        # transfer lines are labelled once; pairs outside the view are not listed
        if _vlines(ax):
            assert sum("transfer" in lab for lab in labels) == 1
        assert "tooth pair -2" not in labels and "tooth pair +2" not in labels


def test_compare_marks_coinciding_curves(crowned_report):
    _, rep = crowned_report
    a = rep.cases[0]
    b = json.loads(json.dumps(a))
    b["label"] = "copy"
    fig, axes = plt.subplots(1, 2)
    P.plot_compare({"aligned": a, "copy": b}, axes=axes)
    lines = [ln for ln in axes[0].get_lines() if ln.get_label().startswith(("aligned", "copy"))]
    assert len(lines) == 2 and lines[0].get_linestyle() != lines[1].get_linestyle()
    assert "coincides with aligned" in lines[1].get_label()
    assert all("coincides" not in lab for lab in _legend_labels(axes[0])[:1])
    _check_legend(axes[0])
    _check_legend(axes[1])
    plt.close(fig)


def test_bearing_contact_ellipses_clipped_to_the_flank(crowned_report):
    _, rep = crowned_report
    case = rep.cases[0]
    fig, ax = plt.subplots()
    P.plot_bearing_contact(case, "pinion", ax=ax, every=1)
    lim = case["limits"]["pinion"]
    ell = [ln for ln in ax.get_lines() if ln.get_color() == "C0"]
    assert ell
    fig.canvas.draw()
    # some ellipse reaches past the tip: its drawn (clipped) extent stays inside the flank box
    reach = max(np.nanmax(ln.get_ydata()) for ln in ell)
    assert reach > lim["r_a"]
    box = [p for p in ax.patches][0].get_window_extent()
    for ln in ell:
        clip = ln.get_clip_box()  # a Rectangle clip path becomes the clip box of the line
        assert clip is not None and ln.get_clip_on()
        assert clip.y1 == pytest.approx(box.y1, abs=1) and clip.x1 == pytest.approx(box.x1, abs=1)
        assert clip.y0 == pytest.approx(box.y0, abs=1) and clip.x0 == pytest.approx(box.x0, abs=1)
    _check_legend(ax)
    assert "delta" in ax.get_title()
    plt.close(fig)


@pytest.mark.slow
def test_conjugate_edge_case(conjugate_edge_report):
    d = json.loads(json.dumps(conjugate_edge_report.to_dict()))
    aligned, mis = d["cases"]
    assert aligned["conjugate"] is True and aligned["transfers"] == [] and aligned["transfer_phi1"] == []
    assert mis["conjugate"] is False
    assert set(aligned["driving_pair"]) <= set(aligned["pairs"]) | {None}
    fig, axes = plt.subplots(2, 1)
    P.plot_edge_te(aligned, ax=axes[0])
    P.plot_edge_te(mis, ax=axes[1])
    assert not _vlines(axes[0]), "transfer lines drawn for a conjugate drive"
    assert "conjugate: TE = 0" in _legend_labels(axes[0])
    assert "conjugate" in axes[0].get_title() and "(aligned)" not in axes[0].get_title()
    lo, hi = axes[0].get_ylim()
    assert hi - lo >= 1.0  # not a round-off scale
    for ax in axes:
        labels = _check_legend(ax)
        assert not any("_" in lab for lab in labels), f"internal names in the legend: {labels}"
    labels = _legend_labels(axes[1])
    assert any("face end" in lab for lab in labels) and sum("transfer" in lab for lab in labels) == 1
    plt.close(fig)
    # the surface plot of the same conjugate TE
    case = dict(aligned, te_arcsec=aligned["te_arcsec"])
    fig, ax = plt.subplots()
    P.plot_te(case, ax=ax)
    assert not _vlines(ax) and "conjugate" in ax.get_title()
    plt.close(fig)
    # paths: the conjugate drive's central pair carries load wherever it is in contact, and no
    # straight segment joins separate pieces of a path
    for case in (aligned, mis):
        for member in ("pinion", "gear"):
            fig, ax = plt.subplots()
            P.plot_edge_paths(case, member, ax=ax)
            lim = case["limits"][member]
            for ln in ax.get_lines():
                xy = np.asarray(ln.get_xydata(), float)
                if len(xy) < 2:
                    continue
                step = np.hypot(np.diff(xy[:, 0]) / lim["b"], np.diff(xy[:, 1]) / (lim["r_a"] - lim["r_form"]))
                step = step[np.isfinite(step)]
                assert step.size == 0 or step.max() <= 0.2 + 1e-12, "a jump drawn as a line"
            labels = _check_legend(ax)
            assert not any("_" in lab for lab in labels)
            plt.close(fig)
    surf = aligned["paths_central_pair"]["surface"]
    k0 = aligned["pairs"].index(0)
    ties = [z is not None and te is not None and abs(te - env) < 1e-5 and act == "surface"
            for z, te, env, act in zip(surf["pinion"]["axial"], aligned["te_arcsec"][k0],
                                       aligned["te_envelope_arcsec"], aligned["active_branch"])]
    assert sum(ties) > 40
    assert all(c for c, t in zip(surf["carries_load"], ties) if t), "a loaded stretch of the conjugate path shown idle"


def _edge_case(label, te, active, mis=None, transfers=()):
    n = len(te)
    phi = list(np.linspace(-0.3, 0.3, n))
    return {"label": label, "edge_analysis": True, "phi1": phi, "pairs": [0], "te_arcsec": [te],
            "te_envelope_arcsec": te, "active_branch": active, "edge_carries_load": any(a != "surface" for a in active),
            "transfers": [{"phi1": t} for t in transfers], "transfer_phi1": list(transfers),
            "peak_to_peak_arcsec": float(np.ptp(te)), "conjugate": bool(np.ptp(te) < 1e-5),
            "misalignment": mis or {"dE_mm": 0.0, "crossing_arcmin": 0.0, "intersecting_arcmin": 0.0, "axial_mm": 0.0},
            "limits": {m: {"b": 20.0, "r_a": 33.0, "r_form": 28.0} for m in ("pinion", "gear")},
            "paths_central_pair": {}}


def test_every_feature_has_its_own_colour_and_name():
    names = list(P.BRANCH_NAMES)
    n = len(names) * 4
    te = list(np.linspace(0, 1, n) ** 2)
    active = [names[i // 4] for i in range(n)]
    case = _edge_case("many", te, active, {"dE_mm": 0.0, "crossing_arcmin": 2.0, "intersecting_arcmin": 0.0,
                                           "axial_mm": 0.0})
    fig, ax = plt.subplots()
    P.plot_edge_te(case, ax=ax)
    thick = [ln for ln in ax.get_lines() if ln.get_linewidth() > 2]
    colours = [matplotlib.colors.to_hex(ln.get_color()) for ln in thick]
    assert len(thick) == len(names) and len(set(colours)) == len(colours)
    labels = _check_legend(ax)
    assert len([lab for lab in labels if "contact" in lab]) == len(names)
    assert not any("_" in lab for lab in labels)
    plt.close(fig)


def test_before_after_rows_share_axes():
    from gearopt.plot.tca import plot_crowning_comparison
    b = _edge_case("crossing +3'", [0.0, 0.005, 0.0, 0.005], ["pinion_face-"] * 4,
                   {"dE_mm": 0.0, "crossing_arcmin": 3.0, "intersecting_arcmin": 0.0, "axial_mm": 0.0})
    a = _edge_case("crossing +3'", [0.0, -8.0, 0.0, -8.0], ["surface"] * 4,
                   {"dE_mm": 0.0, "crossing_arcmin": 3.0, "intersecting_arcmin": 0.0, "axial_mm": 0.0})
    fig, axes = plt.subplots(1, 2, squeeze=False)
    plot_crowning_comparison([b], [a], axes=axes)
    assert axes[0, 0].get_ylim() == axes[0, 1].get_ylim()
    assert axes[0, 0].get_xlim() == axes[0, 1].get_xlim()
    plt.close(fig)


def test_fe_plots_distinct_curves_and_loaded_te():
    from gearopt.plot.fea import plot_contact_pressure, plot_loaded_te

    def pos(phi, pairs, te):
        prof = {str(k): {"s": [-0.2, 0.0, 0.2], "p": [0.0, 1000.0 + 100 * k, 0.0]} for k in pairs}
        return {"phi1": phi, "loaded_pairs": pairs, "single_pair_contact": len(pairs) == 1, "loaded_te_arcsec": te,
                "contact": {"profiles": prof, "hertz_b": 0.15, "hertz_p0": 1400.0, "ratio_mid_to_hertz": 1.05}}
    rep = {"positions": [pos(-0.1, [-1, 0], -50.0), pos(0.0, [0], -90.0), pos(0.1, [0, 1], -51.0)]}
    fig, ax = plt.subplots()
    plot_contact_pressure(rep, ax=ax)
    fe = [ln for ln in ax.get_lines() if ln.get_label().startswith("FE")]
    assert len(fe) == 5
    assert len({matplotlib.colors.to_hex(ln.get_color()) for ln in fe}) == 5, "two pairs in one colour"
    _check_legend(ax)
    plt.close(fig)
    fig, ax = plt.subplots()
    plot_loaded_te(rep, ax=ax)
    pts = np.vstack([ln.get_xydata() for ln in ax.get_lines() if ln.get_linestyle() == "None"])
    assert sorted(pts[:, 1]) == sorted([-50.0, -90.0, -51.0])
    assert "TE" in ax.get_ylabel()
    _check_legend(ax)
    plt.close(fig)


def test_fe_line_load_plot_reads_the_pattern():
    """fea_pattern.png: one curve per loaded pair and position (its load per mm of face), its centre
    marked, the face ends at +-b1/2, the misalignment in the title."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gearopt.plot.fea import plot_line_load

    def pos(phi, pairs):
        pat = {str(k): {"z": [-7.5, -2.5, 2.5, 7.5], "z_layers": [-10.0, -5.0, 0.0, 5.0, 10.0],
                        "q": [100.0, 300.0 + 10 * k, 200.0, 50.0], "force": 3000.0,
                        "z_centroid": -1.0 + k} for k in pairs}
        return {"phi1": phi, "loaded_pairs": pairs, "contact": {"pattern": pat}}
    rep = {"positions": [pos(-0.1, [-1, 0]), pos(0.0, [0])], "pair": {"b1": 20.0},
           "options": {"misalignment": {"dE_mm": 0.0, "crossing_arcmin": 3.0}}}
    fig, ax = plt.subplots()
    plot_line_load(rep, ax=ax)
    curves = [ln for ln in ax.get_lines() if ln.get_label().startswith("phi1")]
    assert sorted(float(np.max(ln.get_ydata())) for ln in curves) == [290.0, 300.0, 300.0]
    xs = sorted(float(ln.get_xdata()[0]) for ln in ax.get_lines() if not ln.get_label().startswith("phi1"))
    assert xs == [-10.0, -2.0, -1.0, -1.0, 10.0]  # face ends and the three centres
    assert "crossing +3 arcmin" in ax.get_title() and "N/mm" in ax.get_ylabel()
    steps = [p for p in ax.patches if type(p).__name__ == "StepPatch"]
    assert len(steps) == 3 and list(steps[0].get_data().edges) == [-10.0, -5.0, 0.0, 5.0, 10.0]
    _check_legend(ax)
    plt.close(fig)


def test_fe_study_writes_the_loaded_te_plot():
    import inspect
    from gearopt.studies.fea import FEReport
    assert "fea_te.png" in inspect.getsource(FEReport.save_plots)


# --- scene: [[tca.cases]] ----------------------------------------------------------------------
CASES_SCENE = """
[scene]
name = "cases"
study = "tca"
[pair]
m_n = 3
[pinion]
z = 20
b = 20
a_pl = 0.0004
rack = {{ a_c = 0.002 }}
[gear]
z = 40
b = 20
[tca]
positions = 9
{extra}
[[tca.cases]]
label = "crossing +3'"
crossing = "3 arcmin"
[[tca.cases]]
dE = "0.05 mm"
intersecting = "-2 arcmin"
"""


def test_scene_list_of_cases(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(CASES_SCENE.format(extra=""))
    study = load_scene(f).build()
    assert [c[0] for c in study.cases] == ["aligned", "crossing +3'", "dE +0.05 mm, intersecting -2'"]
    assert study.cases[2][1].intersecting == pytest.approx(-2 * ARCMIN)
    f.write_text(CASES_SCENE.format(extra='crossing = "1 arcmin"'))
    with pytest.raises(SceneError, match=r"\[tca\] cases and the single keys"):
        load_scene(f).build()
    f.write_text(CASES_SCENE.format(extra="").replace('crossing = "3 arcmin"', 'crossing = "3 mm"'))
    with pytest.raises(SceneError, match=r"\[tca\.cases\]\[0\] crossing"):
        load_scene(f)
    out = subprocess.run([sys.executable, "-m", "gearopt", "studies", "tca"], capture_output=True, text=True, cwd=ROOT,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert "[[tca.cases]]" in out.stdout


def test_readme_and_makefile():
    readme = (ROOT / "README.md").read_text()
    assert "relative to the current working directory" in readme
    assert "positive when the gear is ahead" in readme
    assert "[[tca.cases]]" in readme
    assert "planned FE" not in (ROOT / "Makefile").read_text()
    doc = (ROOT / "docs" / "results.md").read_text()
    for key in ("driving_pair", "actual_te_at_every_position", "n_pair_positions_without_contact", "delta_mm",
                "ellipse_semi_major_mm", "sensitivity_units", "backlash_normal", "a_minus_a_0_um", "g_alpha"):
        assert key in doc, key


def test_planar_conjugate_te_plot():
    """Problem 9.4.1: involutes are conjugate at any centre distance; the plot says TE = 0 instead of
    drawing round-off on a 1e-11 scale."""
    from gearopt.plot.planar import plot_transmission_error
    rep = load_scene(ROOT / "problems" / "problem_9_4_1.toml").build().run()
    fig, ax = plt.subplots()
    plot_transmission_error(rep, ax=ax)
    lo, hi = ax.get_ylim()
    assert hi - lo >= 1.0
    assert "conjugate" in ax.get_title()
    assert any("conjugate: TE = 0" in lab for lab in _check_legend(ax))
    plt.close(fig)


# --- offsets, masked non-contacts, contact lines, legends, loaded TCA plots ----------------------
def _offset_texts(fig):
    """The offset / scale-factor texts ("+3e1", "1e3") of every axis of ``fig`` after a draw."""
    fig.canvas.draw()
    return [t for ax in fig.axes for t in (ax.xaxis.get_offset_text().get_text(),
                                           ax.yaxis.get_offset_text().get_text()) if t]


@pytest.mark.slow
def test_no_offset_text_on_any_tca_axis(conjugate_edge_report, crowned_report, tmp_path, monkeypatch):
    """The misaligned edge drive's TE sits near +30 arcsec with a 0.005 arcsec ripple: matplotlib
    would print "+3e1" and ticks -0.000..-0.008; every tick label must be the value itself."""
    figs = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figs.append(fig))
    conjugate_edge_report.save_plots(tmp_path)
    crowned_report[1].save_plots(tmp_path)
    assert len(figs) >= 5
    for fig in figs:
        assert _offset_texts(fig) == []
    mis = conjugate_edge_report.to_dict()["cases"][1]
    fig, ax = plt.subplots()
    P.plot_edge_te(mis, ax=ax)
    fig.canvas.draw()
    lo, hi = ax.get_ylim()
    assert 25 < lo < hi < 35  # the level is on the tick labels
    assert any(float(t.get_text().replace("\u2212", "-")) > 25 for t in ax.get_yticklabels() if t.get_text())
    plt.close(fig)


def test_te_axis_states_its_zero(conjugate_edge_report, crowned_report):
    """An edge-only drive is measured from the aligned conjugate position (its TE is +30 arcsec),
    a drive with surface contact from pair 0 at phi1 = 0: the axis label says which."""
    mis = conjugate_edge_report.to_dict()["cases"][1]
    assert isinstance(mis["stats"]["surface"], str) and mis["stats"]["te_zero_rad"] == 0.0
    fig, axes = plt.subplots(2, 1)
    P.plot_edge_te(mis, ax=axes[0])
    P.plot_te(crowned_report[1].cases[0], ax=axes[1])
    assert "zero: aligned conjugate drive" in axes[0].get_ylabel()
    assert "pair 0 at phi1 = 0" in axes[1].get_ylabel()
    plt.close(fig)


def test_pair_te_left_out_where_not_a_contact_on_the_flanks(crowned_report):
    """Points of a pair whose contact lies outside the active flanks are not drawn (they can rise
    far above the actual TE, which no real contact can); every drawn pair point is on the flanks
    and none lies above the envelope."""
    case = json.loads(json.dumps(crowned_report[1].cases[1]))
    flags = np.array(case["on_surface_pairs"], bool)
    te = np.array([[np.nan if v is None else v for v in row] for row in case["te_arcsec"]])
    assert flags.shape == te.shape and (np.isfinite(te) & ~flags).any(), "the run has off-flank points"
    env = np.array([np.nan if v is None else v for v in case["te_envelope_arcsec"]])
    # a made-up off-flank point far above the envelope, as the solver returns it
    k = case["pairs"].index(1)
    i = int(np.flatnonzero(~flags[k] & np.isfinite(te[k]))[0])
    case["te_arcsec"][k][i] = float(np.nanmax(env) + 5.0)
    fig, ax = plt.subplots()
    P.plot_te(case, ax=ax)
    phi = np.degrees(case["phi1"])
    for ln in ax.get_lines():
        if not ln.get_label().startswith("tooth pair"):
            continue
        y = np.asarray(ln.get_ydata(), float)
        assert not np.isfinite(y[~flags[case["pairs"].index(int(ln.get_label().split()[-1]))]]).any()
        with np.errstate(invalid="ignore"):
            assert not (y > env + 1e-6).any()
        assert np.allclose(ln.get_xdata(), phi)
    plt.close(fig)


def test_line_contact_drawn_as_contact_lines_across_the_face(conjugate_edge_report):
    """The aligned unmodified spur drive is in line contact: the flank map shows instantaneous
    contact lines from face end to face end (constant radius for a spur), not a path at z = 0."""
    aligned = conjugate_edge_report.to_dict()["cases"][0]
    for member in ("pinion", "gear"):
        fig, ax = plt.subplots()
        P.plot_edge_paths(aligned, member, ax=ax)
        lim = aligned["limits"][member]
        lines = [ln for ln in ax.get_lines() if ln.get_color() == "C3"]
        assert len(lines) >= 8
        for ln in lines:
            z, r = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
            assert z.min() == pytest.approx(-lim["b"] / 2, abs=1e-6) and z.max() == pytest.approx(lim["b"] / 2, abs=1e-6)
            assert np.ptp(r) < 1e-6 * lim["r_a"]  # spur: a contact line at one radius
        radii = sorted(float(ln.get_ydata()[0]) for ln in lines)
        assert radii[-1] - radii[0] > 0.5 * (lim["r_a"] - lim["r_form"])  # spread over the profile
        assert any("contact lines" in lab for lab in _check_legend(ax))
        assert "line contact" in ax.get_title()
        plt.close(fig)


def test_helical_contact_lines_follow_the_points_of_the_features():
    """Helical line contact: each contact line passes through the points of the features at its
    position (mid section, face end, tip) and is smooth (r^2 quadratic in z) between them."""
    n = 9
    phi = list(np.linspace(-0.2, 0.2, n))
    rb, k = 26.0, 0.3  # base radius [mm], ds/dz = tan(beta_b)
    s0 = np.linspace(8.0, 12.0, n)
    r_of = lambda s: float(np.hypot(rb, s))  # noqa: E731
    paths = {}
    for name, z in (("surface", 0.0), ("pinion_face-", -10.0), ("pinion_face+", 10.0)):
        rr = [r_of(s + k * z) for s in s0]
        paths[name] = {m: {"axial": [z] * n, "radius": rr} for m in ("pinion", "gear")}
        paths[name]["carries_load"] = [True] * n
    case = _edge_case("aligned", [0.0] * n, ["surface"] * n)
    case.update(paths_central_pair=paths, stats={"surface_mode": "line contact (mid section)", "te_zero_rad": 0.0},
                te_branches_central_arcsec={name: [0.0] * n for name in paths}, phi1=phi)
    lines, on_line = P.contact_lines(case, "pinion", every=1)
    assert len(lines) == n and all(v.all() for v in on_line.values())
    for (z, r, loaded), s in zip(lines, s0):
        assert loaded and z[0] == -10.0 and z[-1] == 10.0
        assert np.allclose(r, [r_of(s + k * zz) for zz in z], atol=1e-9)


def test_legend_lists_only_visible_lines():
    """A dashed line whose finite points are isolated (no segment) draws nothing: not in the legend."""
    fig, ax = plt.subplots()
    ax.plot([0, 1, 2, 3], [0, np.nan, 1, np.nan], ls="--", label="isolated points")
    ax.plot([0, 1], [0, 1], label="a segment")
    ax.plot([0, 1, 2], [0, np.nan, 1], "o", label="markers")
    assert _legend_labels(ax) == [] and P.legend(ax) is not None
    assert _legend_labels(ax) == ["a segment", "markers"]
    plt.close(fig)


def _ltca_dict():
    pat = {"torque_Nm": 100.0, "pair": [0, 0, 0, 0, 0], "phi1": [0.0, 0.0, 0.1, 0.1, 0.1],
           "p0_MPa": [1000.0, 2000.0, 1000.0, 2000.0, 500.0], "b_H_mm": [0.1] * 5, "edge": [0, 0, 0, 0, 1],
           "pinion": {"axial": [-5.0, 5.0, -5.0, 5.0, 8.0], "from": [-10.0, 0.0, -10.0, 0.0, 7.0],
                      "to": [0.0, 10.0, 0.0, 10.0, 9.0], "radius": [30.0, 30.0, 31.0, 31.0, 33.0], "r_b": 28.0}}
    face = {"phi1": 0.01, "pairs": [-1, 0, 1], "axial": [[-5.0, 0.0, 5.0]] * 3,
            "line_load_N_per_mm": [[0.0, 0.0, 0.0], [200.0, 210.0, 200.0], [100.0, 110.0, 100.0]],
            "p0_MPa": [[0.0, 0.0, 0.0], [1000.0, 1010.0, 1000.0], [1400.0, 1453.0, 1400.0]],
            "edge": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]}
    return {"pairs": [-1, 0, 1], "pattern": pat, "face_load": face,
            "limits": {"pinion": {"b": 20.0, "r_a": 33.0, "r_form": 28.5}},
            "misalignment": {"dE_mm": 0.0, "crossing_arcmin": 3.0, "intersecting_arcmin": 0.0, "axial_mm": 0.0},
            "phi1": [0.0, 0.1], "te_unloaded_arcsec": [0.0, -1.0],
            "torques": [{"torque_Nm": 100.0, "te_loaded_arcsec": [-10.0, -10.5], "peak_to_peak_arcsec": 0.5}]}


@pytest.mark.parametrize("stacked", [True, False])
def test_face_load_one_colour_and_entry_per_pair_peak_visible(stacked):
    from gearopt.plot.ltca import plot_face_load
    d = _ltca_dict()
    fig, (ax, axp) = plt.subplots(2, 1)
    plot_face_load(d, ax=ax, ax_pressure=axp if stacked else None)
    if not stacked:
        axp = [a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds][0]
    labels = _legend_labels(ax)
    assert labels.count("pair 0 (central)") == 1 and labels.count("pair +1") == 1
    assert not any(lab.startswith("pair -1") for lab in labels)  # pair -1 carries nothing here
    q = {ln.get_label(): matplotlib.colors.to_hex(ln.get_color()) for ln in ax.get_lines()}
    dashed = [ln for ln in axp.get_lines() if ln.get_linestyle() == "--"]
    assert sorted(matplotlib.colors.to_hex(ln.get_color()) for ln in dashed) == sorted(
        [q["pair 0 (central)"], q["pair +1"]]), "a pair's pressure not in its own colour"
    star = [ln for ln in axp.get_lines() if ln.get_marker() == "*"]
    assert len(star) == 1 and star[0].get_ydata()[0] == 1453.0
    lo, hi = axp.get_ylim()
    assert lo <= 1453.0 < hi and "1453 MPa" in ax.get_title() and "pair +1" in ax.get_title()
    assert _offset_texts(fig) == []
    plt.close(fig)


def test_contact_pattern_smooth_named_and_labels_in_legend():
    from gearopt.plot.ltca import pattern_field, plot_contact_pattern
    d = _ltca_dict()
    zc, rc, img = pattern_field(d, "pinion")
    i, j = int(np.argmin(np.abs(rc - 30.0))), int(np.argmin(np.abs(zc - 0.0)))
    # linear along the contact line between the slice points (1000 at z = -5, 2000 at z = +5)
    assert img[i, j] == pytest.approx(1000.0 + 1000.0 * (zc[j] + 5.0) / 10.0, rel=1e-9)
    assert np.isnan(img[int(np.argmin(np.abs(rc - 28.6))), j])  # never touched (one row step below): blank
    # the line reaches the face ends of its first and last slice
    assert np.isfinite(img[i, 0]) and np.isfinite(img[i, -1])
    fig, ax = plt.subplots()
    plot_contact_pattern(d, "pinion", ax=ax)
    assert "crossing +3 arcmin" in ax.get_title() and "100 N m" in ax.get_title()
    labels = _legend_labels(ax)
    assert any(lab.startswith("tip circle") for lab in labels) and any(lab.startswith("form circle") for lab in labels)
    assert not ax.texts, "labels drawn in the data area"
    leg = ax.get_legend()
    fig.canvas.draw()
    assert leg.get_window_extent().y1 <= ax.get_window_extent().y0 + 1, "legend over the pattern"
    assert _offset_texts(fig) == []
    plt.close(fig)


def test_loaded_te_legend_outside_the_data():
    from gearopt.plot.ltca import plot_loaded_te
    fig, ax = plt.subplots()
    plot_loaded_te(_ltca_dict(), ax=ax)
    fig.canvas.draw()
    assert ax.get_legend().get_window_extent().x0 >= ax.get_window_extent().x1 - 1
    plt.close(fig)


def test_pair_mesh_title_names_the_scene_and_pitch_point_label_at_its_point(tmp_path):
    from gearopt.plot.geometry import plot_pair_mesh
    from gearopt.plot.planar import plot_line_of_action
    rep = load_scene(ROOT / "problems" / "spur_geometry.toml").build().run()
    fig, ax = plt.subplots()
    plot_pair_mesh(rep, ax=ax)
    assert ax.get_title().startswith("spur_geometry: ")
    plt.close(fig)
    rep = load_scene(ROOT / "problems" / "problem_9_4_1.toml").build().run()
    for zoom in (False, True):
        fig, ax = plt.subplots(figsize=(7, 7))
        plot_line_of_action(rep, ax=ax, zoom=zoom)
        fig.canvas.draw()
        ann = [t for t in ax.texts if t.get_text().startswith("I")]
        assert len(ann) == 1 and ann[0].get_text() == "I"
        box = ann[0].get_window_extent()
        px, py = ax.transData.transform((0.0, rep.tca.y_I))
        # the nearest corner of the label within 12 px (1/10 in at 120 dpi) of its point
        assert min(np.hypot(x - px, y - py) for x in (box.x0, box.x1) for y in (box.y0, box.y1)) < 12
        plt.close(fig)


@pytest.mark.slow
def test_tca_iso_grade_judges_measured_flanks_only(tmp_path):
    """[tca] iso_grade: the K-charts of a measured flank (no designed amounts on the member) carry the
    class's ISO 1328-1 tolerances and the verdict; a designed flank is never judged; a class outside
    1 ... 11 is refused naming the key."""
    import shutil as _sh

    from gearopt.cli import main as cli_main
    from gearopt.robust.tolerances import tolerances

    problems = Path(__file__).resolve().parents[1] / "problems"
    for f in ("measured_flank_right.csv", "measured_flank_left.csv"):
        _sh.copy(problems / f, tmp_path / f)
    # a few positions: the tolerances and the verdict judge the flanks, not the TCA's sweep
    text = (problems / "measured_flank.toml").read_text().replace("positions = 81", "positions = 9\niso_grade = 5")
    (tmp_path / "mf.toml").write_text(text)
    assert cli_main(["run", str(tmp_path / "mf.toml"), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    res = json.loads((tmp_path / "out" / "results.json").read_text())
    tol = res["inspection"]["pinion"]["right"]["tolerances_um"]
    ref = tolerances(5, 21 * 2.5 / math.cos(math.radians(18)), 2.5, 30.0)
    assert tol["grade"] == 5 and tol["f_H_beta"] == ref["f_HbetaT"] and tol["F_alpha"] == ref["F_alphaT"]
    # designed amounts: not judged
    text2 = (problems / "microgeometry_spur.toml").read_text()
    assert "[tca]" in text2
    assert "positions = 81" in text2
    # (its figures are not what this checks: none drawn)
    (tmp_path / "ms.toml").write_text(text2.replace("[tca]", "[tca]\niso_grade = 5", 1).replace("positions = 81", "positions = 9")
                                      + "\n[output]\nplots = false\n")
    assert cli_main(["run", str(tmp_path / "ms.toml"), "--out", str(tmp_path / "out2"), "--quiet"]) == 0
    res2 = json.loads((tmp_path / "out2" / "results.json").read_text())
    assert all("tolerances_um" not in d for sides in res2["inspection"].values() for d in sides.values())
    (tmp_path / "bad.toml").write_text(text.replace("iso_grade = 5", "iso_grade = 12"))
    assert cli_main(["check", str(tmp_path / "bad.toml")]) == 2
