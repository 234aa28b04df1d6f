"""Plots a gear engineer can read and results.json keys that say what they hold (issue 11).

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
