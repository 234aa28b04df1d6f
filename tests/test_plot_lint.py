"""The plot linter (tests/plot_lint.py) on small figures made to pass or to fail one check each, the
plot style (gearopt.plot.style), and the plots it could not judge alone (significance of
the Monte Carlo correlations, samples without a value, equal cases, FE positions, topography
levels)."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from pathlib import Path

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from gearopt.plot.style import number, plot_style  # noqa: E402
from plot_lint import lint_figure  # noqa: E402


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def _clean():
    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.linspace(0, 10, 50)
    ax.plot(x, np.sin(x) - 2, label="a sine, lowered")
    ax.plot(x, 0.2 * x - 3, "--", label="a line")
    ax.set_ylim(-4, 2)
    ax.set_title("clean")
    ax.legend(loc="upper right")
    return fig, ax


# --- the linter -----------------------------------------------------------------------------------
def test_a_clean_figure_passes():
    fig, _ = _clean()
    fig.suptitle("a figure title")
    assert lint_figure(fig, tight=False) == []


def test_offset_text_is_found_and_the_style_removes_it():
    def fig_():
        fig, ax = plt.subplots()
        ax.plot([0, 1, 2], [30.001, 30.004, 30.008])
        ax.set_title("TE of an edge contact")
        return fig
    probs = lint_figure(fig_(), tight=False)
    assert len(probs) == 1 and "offset text" in probs[0] and "'TE of an edge contact'" in probs[0]
    with plot_style():
        assert lint_figure(fig_(), tight=False) == []


def test_scientific_and_negative_zero_labels_are_found():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [87, 94])
    ax.set_yscale("log")
    ax.set_title("rounds")
    probs = lint_figure(fig, tight=False)
    assert any("y tick labels in scientific form" in p and "times10^1" in p for p in probs)
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_title("S_alpha = -0.00 um")
    assert any("negative zero" in p for p in lint_figure(fig, tight=False))
    ax.set_title("S_alpha = +0.00 um, range 0-0.5, x = -0.05")
    assert lint_figure(fig, tight=False) == []


def test_a_legend_entry_without_drawn_data_is_found():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], color="C0", label="drawn")
    ax.plot([0, 1], [np.nan, np.nan], color="C1", label="all NaN")
    ax.plot([5, 6], [5, 6], color="C2", label="outside the view")
    ax.bar([0.5], [0.0], color="C4", label="zero-height bar")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.legend()
    probs = lint_figure(fig, tight=False)
    assert sorted(p.split("legend entry ")[1].split(" stands")[0] for p in probs) == \
        ["'all NaN'", "'outside the view'", "'zero-height bar'"]


def test_proxy_entries_must_show_a_drawn_style():
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 0.2], "--", color="C0")
    ax.plot([0, 1], [0.2, 0], "--", color="C1")
    ax.plot([], [], "k--", label="before (dashed, every colour)")  # a style key: passes
    ax.plot([], [], "o", color="C3", label="a marker seen nowhere")  # fails
    ax.set_ylim(0, 1)
    ax.legend(loc="upper center")
    probs = lint_figure(fig, tight=False)
    assert len(probs) == 1 and "'a marker seen nowhere'" in probs[0]


def test_text_cut_at_the_image_edge_is_found():
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 0.2])
    ax.set_ylim(0, 1)
    ax.set_title("fine")
    ax.legend(["a line"], loc="upper left", bbox_to_anchor=(0.9, 1.0))  # off to the right
    probs = lint_figure(fig, tight=False)
    assert len(probs) == 1 and "legend is cut" in probs[0]
    assert lint_figure(fig, tight=True) == []  # bbox_inches="tight" takes it into the image
    # not drawn, so not cut: an annotation of a point outside the axes, a text clipped to the axes
    ax.annotate("O_1", (5.0, 5.0), xytext=(6, 4), textcoords="offset points")
    ax.text(7.0, 7.0, "far", clip_on=True)
    assert lint_figure(fig, tight=True) == []
    ax.text(0.5, 1.6, "above the figure", transform=ax.transAxes, in_layout=False)
    assert ["'above the figure' is cut" in p for p in lint_figure(fig, tight=True)] == [True]


def test_overlapping_titles_are_found():
    fig, axes = plt.subplots(2, 1, figsize=(5, 3))
    for ax in axes:
        ax.plot([0, 1], [0, 1])
        ax.set_title("a long title\nover two lines\nand a third")
    probs = lint_figure(fig, tight=False)
    assert any("overlaps 'a long title" in p for p in probs)
    fig.set_layout_engine("constrained")
    fig.set_size_inches(5, 6)
    assert lint_figure(fig, tight=False) == []


def test_a_legend_over_the_data_is_found_when_a_corner_is_free():
    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.linspace(0, 10, 200)
    ax.plot(x, x, label="rising")
    ax.plot(x, 0.3 * x, label="rising less")
    ax.legend(loc="center")
    probs = lint_figure(fig, tight=False)
    assert len(probs) == 1 and "legend covers" in probs[0] and "is free" in probs[0]
    ax.legend(loc="upper left")
    assert lint_figure(fig, tight=False) == []
    # nowhere free: not flagged (the fix would be a legend outside the axes)
    fig, ax = plt.subplots(figsize=(4, 3))
    for y in np.linspace(0, 1, 12):
        ax.plot([0, 1], [y, y], label=f"{y:.2f}" if y < 0.1 else None)
    ax.legend(loc="center")
    assert lint_figure(fig, tight=False) == []


# --- the style ------------------------------------------------------------------------------------
@pytest.mark.parametrize("v, s", [(1274.2, "1274"), (1245.0, "1245"), (7.4912, "7.49"), (0.000123456, "0.000123"),
                                  (-0.00004, "-4.00e-05"), (-1e-9, "-1.00e-09"), (0.0, "0"), (-0.0001, "-0.0001"),
                                  (2.5e6, "2.50e+06"), (99.96, "100"), (-0.004, "-0.004")])
def test_number_is_plain(v, s):
    assert number(v) == s


def test_write_results_draws_in_the_style(tmp_path):
    from gearopt.io.results import write_results

    seen = {}

    class Result:
        def to_dict(self):
            return {"units": {"x": "mm"}, "x": 1.0}

        def save_plots(self, out_dir):
            seen["useoffset"] = matplotlib.rcParams["axes.formatter.useoffset"]
            seen["bbox"] = matplotlib.rcParams["savefig.bbox"]
            return []

    write_results(tmp_path / "out", Result(), plots=True)
    assert seen == {"useoffset": False, "bbox": "tight"}
    assert matplotlib.rcParams["axes.formatter.useoffset"] is True  # restored afterwards


def test_library_save_plots_do_not_pick_the_backend():
    # only the CLI chooses the matplotlib backend (MPLBACKEND in gearopt.cli); no library module does
    import gearopt

    root = Path(gearopt.__file__).parent
    offenders = [str(p.relative_to(root)) for p in root.rglob("*.py")
                 if p.name != "cli.py" and "matplotlib.use(" in p.read_text(encoding="utf-8")]
    assert offenders == []


# --- Monte Carlo plots ------------------------------------------------------------------------------
def _mc(n=24, rho_inputs=None, seed=1):
    """A Monte Carlo result dict of n samples: TE = 20 + 2 * torque-like input + noise."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=n)
    te = (20 + 2 * x + rng.normal(size=n)) / 206264.806
    figs = {"te_p2p": te, "harmonics": np.c_[te / 3], "edge_contact": np.zeros(n, bool), "ok": np.ones(n, bool),
            "feasible": np.ones(n, bool)}
    rows = [{"input": "pinion.f_pt_1", "spearman": 0.6, "spearman_abs": 0.1, "src": 0.5},
            {"input": "mis.dE", "spearman": 0.25, "spearman_abs": -0.05, "src": 0.1}]
    return {"figures": figs, "inputs": {"pinion.f_pt_1": x, "mis.dE": x}, "sensitivities": {"te_p2p": rows},
            "nominal": {"te_p2p_arcsec": 18.1}}


def test_sensitivity_greys_what_is_not_significant():
    from gearopt.plot.robust import GREY, plot_sensitivity, significance_limit

    assert significance_limit(24) == pytest.approx(1.959964 / math.sqrt(23), rel=1e-6)
    d = _mc(24)
    fig, ax = plt.subplots(figsize=(8, 4), layout="constrained")
    plot_sensitivity(d, ax=ax)
    grey = matplotlib.colors.to_rgba(GREY)
    bars = {(round(p.get_y() + p.get_height() / 2, 3), round(p.get_width(), 3)): p.get_facecolor()
            for p in ax.patches if type(p).__name__ == "Rectangle" and abs(p.get_height() - 0.4) < 1e-9}
    # rows from the bottom: mis.dE (y = 0), pinion.f_pt_1 (y = 1); |rho| < 0.41 at n = 24 is grey
    assert bars[(1.2, 0.6)] != grey and bars[(0.2, 0.25)] == grey and bars[(0.8, 0.1)] == grey
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert labels == ["centre distance change $\\Delta E$ [mm]", "pinion single pitch deviation $f_{pt}$, teeth 0/+1 [um]"]
    assert "arcsec" not in ax.get_xlabel()
    assert any("n = 24" in t.get_text() and "0.41" in t.get_text() for t in ax.get_legend().get_texts())
    assert lint_figure(fig) == []


def test_histogram_counts_the_samples_without_a_value_and_writes_plain_numbers():
    from gearopt.plot.robust import plot_histogram

    d = _mc(30)
    d["figures"]["harmonics"][:4, 0] = np.nan
    d["figures"]["edge_contact"][:3] = True
    d["figures"]["p_max"] = np.linspace(1200, 1300, 30)
    d["nominal"]["p_max_MPa"] = 1245.0
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    plot_histogram(d, "h1", ax=axes[0])
    title = axes[0].get_legend().get_title().get_text()
    assert "4 of 30 samples" in title and "3 with edge contact" in title and "1 other" in title
    plot_histogram(d, "p_max", ax=axes[1])
    texts = [t.get_text() for t in axes[1].get_legend().get_texts()]
    assert "nominal: 1240" in texts[-1] or "nominal: 1245" in texts[-1]
    assert not any("e+" in t for t in texts)
    with plot_style():
        assert lint_figure(fig) == []


def test_pattern_cells_without_contact_have_their_own_colour():
    from gearopt.plot.robust import NEVER, plot_pattern_probability

    count = np.array([[0, 2, 4], [0, 4, 4]])
    d = {"pattern_count": count, "grid_z": np.array([-10.0, -5, 5, 10]), "grid_r": np.array([28.0, 30, 33]), "n": 4,
         "limits": {"b": 20.0, "r_a": 33.0, "r_form": 28.0}, "nominal": {}}
    fig, ax = plt.subplots(layout="constrained")
    plot_pattern_probability(d, ax=ax)
    fig.canvas.draw()
    never = ax.collections[0]
    rgba = never.get_cmap()(never.norm(never.get_array()))
    assert len(ax.collections) == 2 and int(np.ma.count(never.get_array())) == 2  # the two cells without contact
    assert np.allclose(rgba[~np.ma.getmaskarray(never.get_array())][:, :3], matplotlib.colors.to_rgb(NEVER))
    assert any("no sample in contact there (2 of 6 cells)" == t.get_text() for t in ax.get_legend().get_texts())
    assert lint_figure(fig) == []


# --- loaded micro-geometry plots ----------------------------------------------------------------------
def test_rounds_on_a_linear_axis_with_integer_rounds():
    from gearopt.plot.loaded_synthesis import plot_rounds

    rounds = [{"merit": m, "model_objective": m - 3, "n_positions": 16} for m in (94.0, 90.0, 87.5)]
    fig, ax = plt.subplots()
    plot_rounds({"rounds": rounds}, ax=ax)
    fig.canvas.draw()
    assert ax.get_yscale() == "linear"
    assert all(float(t).is_integer() for t in ax.get_xticks() if -0.5 <= t <= 2.5)
    rounds[0]["merit"] = 2000.0  # over a decade: log, plain labels
    fig, ax = plt.subplots()
    plot_rounds({"rounds": rounds}, ax=ax)
    assert ax.get_yscale() == "log"
    with plot_style():
        assert lint_figure(fig) == []


def _micro(te_pp_before, te_pp_after, names):
    return {"torques_Nm": [100.0, 250.0], "cases": [{"name": n} for n in names],
            "design": {"before": {"te_pp_arcsec": te_pp_before}, "after": {"te_pp_arcsec": te_pp_after}}}


def test_equal_cases_are_said_and_both_visible():
    from gearopt.plot.loaded_synthesis import plot_te_vs_torque_before_after, same_as

    d = _micro([[17.0, 18.0, 18.0], [47.0, 48.0, 48.0]], [[11.0, 11.5, 11.5], [31.0, 30.0, 30.0]],
               ["aligned", "crossing +2'", "crossing -2'"])
    assert [same_as(d, c) for c in range(3)] == [None, None, 1]
    fig, ax = plt.subplots()
    plot_te_vs_torque_before_after(d, ax=ax)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "crossing -2' (= crossing +2': the same values)" in labels and "crossing +2'" in labels
    a, b = [ln for ln in ax.lines if ln.get_label().startswith("crossing")]
    assert b.get_markersize() > a.get_markersize() and b.get_markerfacecolor() == "none"


def test_unloaded_te_target_lines_in_their_series_colour():
    from gearopt.plot.loaded_synthesis import plot_unloaded_te

    psi = np.linspace(-0.9, 0.9, 7)
    case = {"name": "aligned", **{k: {"psi": psi.tolist(), "te_arcsec": (-8 * psi**2 + s).tolist(), "rms_arcsec": r,
                                      "c0_arcsec": s, "c1_arcsec": 0.0} for k, s, r in (("before", 0.0, 0.37),
                                                                                        ("after", -1.0, 9.41))}}
    d = {"design": {"unloaded_te": {"z1": 20, "level_arcsec": 8.0, "weight": 1.0, "cases": [case]}}}
    fig, ax = plt.subplots(figsize=(8, 5))
    plot_unloaded_te(d, ax=ax)
    leg = ax.get_legend()
    for h, t in zip(leg.legend_handles, leg.get_texts()):
        drawn = [ln for ln in ax.lines if ln.get_label() == t.get_text()]
        assert drawn and matplotlib.colors.to_hex(drawn[0].get_color()) == matplotlib.colors.to_hex(h.get_color())
    assert not any(matplotlib.colors.to_hex(ln.get_color()) == "#000000" for ln in ax.lines)


# --- FE plots ----------------------------------------------------------------------------------------
def _fe(n_strips=2):
    zl = np.linspace(-5, 5, n_strips + 1)

    def pos(phi, pairs, te):
        pat = {str(k): {"z": ((zl[1:] + zl[:-1]) / 2).tolist(), "z_layers": zl.tolist(), "q": [170.0] * n_strips,
                        "force": 1700.0, "z_centroid": 0.0} for k in pairs}
        return {"phi1": phi, "loaded_pairs": pairs, "single_pair_contact": len(pairs) == 1, "loaded_te_arcsec": te,
                "contact": {"pattern": pat, "p_max_mid": 1500.0 - 100 * len(pairs)},
                "root": {m: {"max_principal_mid": 250.0 + 10 * phi} for m in ("pinion", "gear")},
                "root_estimate": {m: {"sigma_iso": 260.0} for m in ("pinion", "gear")}}
    return {"positions": [pos(-0.1, [-1, 0], -52.0), pos(0.0, [0], -89.0), pos(0.1, [0, 1], -51.0)],
            "pair": {"b1": 10.0}, "options": {"misalignment": {"crossing_arcmin": 0.0}}}


def test_fe_positions_are_points_not_curves():
    from gearopt.plot.fea import plot_loaded_te, plot_root_stress

    rep = _fe()
    for fn in (plot_loaded_te, plot_root_stress):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        fn(rep, ax=ax)
        fig.tight_layout()
        lines = [ln for a in fig.axes for ln in a.lines]
        assert lines and all(ln.get_linestyle() == "None" for ln in lines), fn.__name__
        assert "points, not a curve" in ax.get_legend().get_title().get_text()
        with plot_style():
            assert lint_figure(fig) == [], fn.__name__


@pytest.mark.parametrize("n, said", [(2, True), (10, False)])
def test_fe_pattern_states_the_face_resolution(n, said):
    from gearopt.plot.fea import plot_line_load

    fig, ax = plt.subplots(figsize=(9, 5))
    plot_line_load(_fe(n), ax=ax)
    assert f"{n} elements across the face ({10 / n:.3g} mm each)" in ax.get_title()
    assert any("not resolved" in t.get_text() for t in ax.texts) == said
    with plot_style():
        assert lint_figure(fig) == []


# --- topography and charts ---------------------------------------------------------------------------
def _grid():
    s = np.linspace(3.5, 15.5, 13)
    z = np.linspace(-15, 15, 21)
    S, Z = np.meshgrid(s, z, indexing="ij")
    V = -12 * (Z / 15) ** 2 - 6 * ((S - 9.5) / 6) ** 2 + 1.0 * Z / 15 + 0.3
    return {"s_mm": s.tolist(), "z_mm": z.tolist(), "deviation_um": V.tolist(), "profile": "L_y", "side": "right",
            "member": "pinion"}, V


def test_topography_levels_fit_the_data_and_state_the_range():
    from gearopt.plot.topography import plot_topography

    g, V = _grid()
    fig, ax = plt.subplots(layout="constrained")
    plot_topography(g, ax=ax)
    lv = ax.collections[0].levels
    step = lv[1] - lv[0]
    assert lv[0] >= V.min() - step and lv[-1] <= V.max() + step  # not +-max|V|
    assert step <= 1.0 + 1e-9  # a 2 um slope crosses two levels at least
    label = fig.axes[-1].get_ylabel()
    assert f"range {number(V.min())} ... {number(V.max())} um" in label


def test_charts_never_write_negative_zero_and_draw_tolerances():
    from gearopt.plot.topography import chart_tolerances, plot_lead_chart, plot_profile_chart
    from gearopt.robust.tolerances import tolerances

    g, _ = _grid()
    charts = {"F_alpha": 14.3, "f_f_alpha": 13.1, "f_H_alpha": -2.4, "C_alpha": 8.8, "S_alpha": -1e-9,
              "F_beta": 13.0, "f_f_beta": 12.0, "f_H_beta": 2.0, "C_beta": 12.0, "z_profile_mm": 0.0}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4), layout="constrained")
    plot_profile_chart(g, charts, ax=axes[0])
    assert "-0.00" not in axes[0].get_title() and "= +0.00" in axes[0].get_title()
    tol = chart_tolerances(6, 55.2, 2.5, 30.0)
    ref = tolerances(6, 55.2, 2.5, 30.0)
    assert (tol["F_beta"], tol["f_H_beta"]) == (ref["F_betaT"], ref["f_HbetaT"])
    plot_lead_chart(g, charts, ax=axes[1], tolerances=tol)
    band = [p for p in axes[1].patches if type(p).__name__ == "Rectangle" and p.get_label().startswith("$F")]
    assert len(band) == 1 and band[0].get_height() == pytest.approx(ref["F_betaT"])  # axhspan: data height
    assert "class 6" in axes[1].get_title() and ("outside: $F_\\beta$" in axes[1].get_title()) == (13.0 > ref["F_betaT"])
    with plot_style():
        assert lint_figure(fig) == []
