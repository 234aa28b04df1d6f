"""The comparison figures (gearopt/plot/compare/): the designs on the same axes and scales, a legend
naming every design, units on the axes, and no mechanical fault (tests/plot_lint.py). Fast: the
designs are hand-made result dictionaries (parabolic TE, a straight path of contact)."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from gearopt.plot.compare import (  # noqa: E402
    comparison_figures, crowning_amounts, match_cases, plot_contact_paths, plot_crowning, plot_distribution, plot_te,
    te_cases,
)
from gearopt.plot.style import plot_style  # noqa: E402

from plot_lint import lint_figure  # noqa: E402

Z1 = 20
LIMITS = {"pinion": {"b": 20.0, "r_a": 33.0, "r_form": 28.3}, "gear": {"b": 20.0, "r_a": 63.0, "r_form": 57.0}}


def _case(level: float, crossing: float, z_path: float, label: str) -> dict:
    """A tca case: the actual TE a periodic parabola of ``level`` arcsec over two mesh cycles."""
    phi = np.linspace(-2 * math.pi / Z1, 2 * math.pi / Z1, 81)
    x = (phi + math.pi / Z1) % (2 * math.pi / Z1) - math.pi / Z1  # position in the mesh cycle
    te = -level * (x / (math.pi / Z1)) ** 2
    r = np.linspace(28.5, 32.8, phi.size)
    return {"label": label, "misalignment": {"dE_mm": 0.0, "crossing_arcmin": crossing, "intersecting_arcmin": 0.0,
                                             "axial_mm": 0.0},
            "phi1": phi.tolist(), "te_envelope_arcsec": te.tolist(), "peak_to_peak_arcsec": level, "conjugate": False,
            "pinion": {"axial": [z_path] * phi.size, "radius": r.tolist()}, "on_surface": [True] * phi.size,
            "limits": LIMITS}


def _design(level: float, shift: float, c_alpha: float, cases=("aligned", "misaligned")) -> dict:
    cs = [_case(level, 0.0, 0.0, "aligned")]
    if "misaligned" in cases:
        cs.append(_case(level * 1.02, 3.0, shift, "misaligned"))
    return {"study": "tca", "cases": cs,
            "pair": {"pinion_iso_um": {"C_alpha": c_alpha, "f_H_alpha": 1.0, "C_beta": 10.0, "f_H_beta": 0.0}}}


@pytest.fixture
def designs():
    return {"demo": _design(18.0, -3.0, 13.5), "optimised": _design(8.0, -8.5, 5.7)}


def _lint(fig):
    with plot_style():
        problems = lint_figure(fig)
    plt.close(fig)
    assert problems == []


def test_cases_matched_by_misalignment_not_label(designs):
    designs["optimised"]["cases"][1]["label"] = "crossing +3'"
    groups = match_cases({lab: te_cases(r) for lab, r in designs.items()})
    assert [(name, sorted(by)) for _, name, by in groups] == [("aligned", ["demo", "optimised"]),
                                                              ("crossing +3 arcmin", ["demo", "optimised"])]


def test_te_panels_share_one_scale_and_name_the_designs(designs):
    with plot_style():
        figs = {name: fig for name, _, fig in comparison_figures(designs)}
    assert sorted(figs) == ["compare_contact.png", "compare_crowning.png", "compare_te.png"]
    te = [ax for ax in figs["compare_te.png"].axes if ax.get_visible()]
    assert len(te) == 2 and te[0].get_ylim() == te[1].get_ylim()
    lo, hi = te[0].get_ylim()
    assert lo < -18.0 * 1.02 and hi > 0.0  # every curve inside the common range
    for ax in te:
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        assert texts[0].startswith("demo: p-p 18") and texts[1].startswith("optimised: p-p 8")
        assert "[arcsec]" in ax.get_ylabel() and "[deg]" in ax.get_xlabel()
        # one colour per design, the same in every panel
        assert [line.get_color() for line in ax.get_lines()] == ["C0", "C1"]
    # one line style per case: solid aligned, dashed crossed
    assert [ax.get_lines()[0].get_linestyle() for ax in te] == ["-", "--"]
    for fig in figs.values():
        _lint(fig)


def test_contact_paths_on_one_flank_frame(designs):
    fig, ax = plt.subplots()
    plot_contact_paths(designs, (("crossing_arcmin", 3.0),), ax=ax)
    lines = ax.get_lines()
    assert [line.get_xdata()[0] for line in lines] == [-3.0, -8.5]
    x0, x1 = ax.get_xlim()
    assert x0 < -10.0 and x1 > 10.0  # the whole face width b = 20 mm
    assert "[mm]" in ax.get_xlabel() and "[mm]" in ax.get_ylabel()
    assert "crossing +3 arcmin" in ax.get_title()
    _lint(fig)


def test_a_case_one_design_lacks_is_named(designs):
    designs["optimised"] = _design(8.0, -8.5, 5.7, cases=("aligned",))
    fig, ax = plt.subplots()
    plot_te(designs, (("crossing_arcmin", 3.0),), ax=ax)
    assert "not in optimised" in ax.get_title()
    assert [t.get_text().split(":")[0] for t in ax.get_legend().get_texts()] == ["demo"]
    plt.close(fig)
    with plot_style():
        figs = {name: fig for name, _, fig in comparison_figures(designs)}
    te = [ax for ax in figs["compare_te.png"].axes if ax.get_visible()]
    assert len(te) == 1  # only the case both designs have
    for f in figs.values():
        plt.close(f)


def test_crowning_bars(designs):
    assert crowning_amounts(designs["demo"])["C_alpha"] == 13.5
    designs["fea"] = {"study": "fea"}  # no crowning amounts: no bars, no legend entry
    fig, ax = plt.subplots()
    plot_crowning(designs, ax=ax)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["demo", "optimised"]
    heights = [p.get_height() for p in ax.patches]
    assert heights[:4] == [13.5, 1.0, 10.0, 0.0] and heights[4:] == [5.7, 1.0, 10.0, 0.0]
    assert "[um]" in ax.get_ylabel()
    _lint(fig)


def test_distribution_medians_in_the_legend():
    rng = np.random.default_rng(1)
    a, b = rng.normal(20.0, 2.0, 400), rng.normal(12.0, 1.0, 400)
    b[:7] = np.nan  # samples that did not solve are left out
    fig, ax = plt.subplots()
    plot_distribution({"A": {"te_p2p_arcsec": a}, "B": {"te_p2p_arcsec": b}}, ax=ax,
                      xlabel="TE peak-to-peak [arcsec]")
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts[0].startswith("A: median") and f"(n = {a.size})" in texts[0]
    assert f"(n = {b.size - 7})" in texts[1]
    assert "[arcsec]" in ax.get_xlabel()
    _lint(fig)


def test_a_path_hidden_under_another_says_so(designs):
    fig, ax = plt.subplots()
    plot_contact_paths(designs, (), ax=ax)  # aligned: both paths at z = 0
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["demo", "optimised (on demo's path)"]
    plt.close(fig)


def test_fe_designs_per_position():
    def fea(te, p, root):
        return {"study": "fea", "options": {"torque_Nmm": 100000.0},
                "positions": [{"phi1": math.radians(a), "loaded_te_arcsec": t, "contact": {"p_max": q},
                               "root": {"pinion": {"max_principal_mid": r}, "gear": {"max_principal_mid": r - 30}}}
                              for a, t, q, r in zip((-6, 0, 6), te, p, root)]}

    designs = {"coarse": fea((-52, -88, -50), (1361, 1663, 1648), (229, 299, 225)),
               "fine": fea((-50, -85, -49), (1500, 1800, 1750), (231, 301, 227))}
    with plot_style():
        figs = {name: fig for name, _, fig in comparison_figures(designs)}
    fig = figs["compare_fea.png"]
    te, p, root = [ax for ax in fig.axes if ax.get_visible()]
    assert list(p.get_lines()[1].get_ydata()) == [1500, 1800, 1750]
    assert [t.get_text() for t in te.get_legend().get_texts()] == ["coarse: 100 N m", "fine: 100 N m"]
    assert len(root.get_lines()) == 4  # pinion and gear of each design
    assert "[MPa]" in p.get_ylabel() and "[arcsec]" in te.get_ylabel() and "[deg]" in te.get_xlabel()
    _lint(fig)


def _dynamics(n_E1: float, peak: float, speed_peak: float, cases=("as_given", "unmodified"), loss_from=None) -> dict:
    """A dynamics result: K_v a resonance curve of height ``peak`` at ``speed_peak`` [rpm] per case."""
    v = np.linspace(2000.0, 32000.0, 31)
    out = []
    for j, name in enumerate(cases):
        kv = 1.0 + (peak - 1.0 + j) / (1.0 + ((v - speed_peak) / 1500.0) ** 2)
        loss = [bool(loss_from is not None and s >= loss_from) for s in v]
        out.append({"name": name, "speeds_rpm": v.tolist(), "K_v_max": float(kv.max()),
                    "K_v_max_speed_rpm": float(v[np.argmax(kv)]),
                    "up": {"K_v": kv.tolist(), "contact_loss": loss},
                    "down": {"K_v": (kv * 1.01).tolist(), "contact_loss": loss}})
    return {"study": "dynamics", "model": {"n_E1_iso_rpm": n_E1}, "cases": out}


def test_dynamics_designs_share_one_speed_axis_per_case():
    """Two dynamics designs: one panel per case both have (a case one design lacks gets no panel of
    its own), each design in its colour with its K_v peak in the legend, its n_E1 dotted."""
    designs = {"relieved": _dynamics(21100.0, 1.8, 20000.0),
               "stiffer": _dynamics(23000.0, 2.5, 21000.0, cases=("as_given",), loss_from=20000.0)}
    with plot_style():
        figs = {name: fig for name, _, fig in comparison_figures(designs)}
    fig = figs["compare_dynamics.png"]
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 1  # "unmodified" is in one design only
    ax = axes[0]
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(t.startswith("relieved: speed up, K_v max 1.8") for t in texts)
    assert any(t.startswith("stiffer: speed up, K_v max 2.5") for t in texts)
    assert "stiffer: contact loss" in texts and "relieved: contact loss" not in texts
    assert any("n_E1 = 23000 rpm" in t for t in texts)
    colours = {line.get_color() for line in ax.get_lines() if line.get_label().startswith("relieved")}
    assert colours == {"C0"}
    assert "[rpm]" in ax.get_xlabel()
    _lint(fig)


def test_a_dynamics_design_alone_draws_no_dynamics_figure():
    designs = {"a": _dynamics(21100.0, 1.8, 19600.0), "b": {"study": "tca", "cases": []}}
    with plot_style():
        names = [name for name, _, fig in comparison_figures(designs)]
    assert "compare_dynamics.png" not in names
