"""gearopt.plot.rating in the fast tier: the rating study's figures of a small drive (the 20/40 spur drive,
two torques and a two-bin load spectrum, about 0.5 s), drawn onto axes of a Figure given here, show the
results dictionary's values (the slow tier renders problems/rating_*.toml to PNG)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # the test picks the backend, never the library

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from gearopt.gears import Gear, GearPair  # noqa: E402
from gearopt.plot.rating import (plot_load_factors, plot_safety_vs_torque, plot_spectrum_damage,  # noqa: E402
                                 plot_spectrum_sn)
from gearopt.studies.rating import RatingStudy  # noqa: E402

TORQUES = [50.0, 250.0]  # [N m]; 250 N m loads the flanks above the pitting S-N line's 1e10 level: damage


@pytest.fixture(scope="module")
def data():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    return RatingStudy(pair, 100.0, torques=TORQUES, spectrum_torque=TORQUES, spectrum_speed=[1500.0, 1500.0],
                       spectrum_share=[0.5, 0.5]).run().data


def _line(ax, label):
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == label]
    return np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)


def test_safety_factors_plotted_are_the_results_and_fall_with_torque(data):
    ax = plot_safety_vs_torque(data, ax=Figure().add_subplot())
    used = data["load_factors_used"]
    for sym in ("S_H", "S_F"):
        for i, member in enumerate(("pinion", "gear")):
            x, y = _line(ax, f"{sym} {member}")
            np.testing.assert_array_equal(x, TORQUES)
            np.testing.assert_array_equal(y, [r[sym][used][i] for r in data["torques"]])
            assert y[1] < y[0]  # a higher torque, a lower safety
    _, y = _line(ax, f"S_Hmin = {data['options']['S_Hmin']:g}")
    assert np.all(y == data["options"]["S_Hmin"])


def test_load_factors_plotted_are_the_results(data):
    ax = plot_load_factors(data, ax=Figure().add_subplot())
    for sym in ("K_Hbeta", "K_Halpha"):
        for src, name in (("ltca", "gearopt LTCA"), ("iso", "ISO 6336-1")):
            x, y = _line(ax, f"{sym} {name}")
            np.testing.assert_array_equal(x, TORQUES)
            np.testing.assert_array_equal(y, [r[sym][src] for r in data["torques"]])
            assert np.all(y >= 1.0 - 1e-12)  # a load factor is at least 1


def test_spectrum_figures_show_the_s_n_lines_the_bins_and_their_damage(data):
    sp = data["spectrum"]
    fig = Figure()
    ax1, ax2 = fig.add_subplot(121), fig.add_subplot(122)
    plot_spectrum_sn(data, ax=ax1)
    for mode in ("pitting", "bending"):
        x, y = _line(ax1, f"S-N line, {mode} ({'Z_NT' if mode == 'pitting' else 'Y_NT'})")
        pts = np.array(sp["curves"][mode][0]["points"], float)
        np.testing.assert_array_equal(x[1:-1], pts[:, 0])  # through the curve's corner points
        np.testing.assert_array_equal(y[1:-1], pts[:, 1])
        sym = "sigma_H" if mode == "pitting" else "sigma_F"
        for i, member in enumerate(("pinion", "gear")):
            x, y = _line(ax1, f"spectrum, {member} {mode}")
            ref = sp["curves"][mode][i]["sigma_ref"]
            ratio = sorted((b[sym][i] / r for b, r in zip(sp["bins"], ref)), reverse=True)
            np.testing.assert_allclose(y[1:], ratio, rtol=1e-15)  # the stair: highest bin first
            assert x[-1] == sum(b["cycles"][i] for b in sp["bins"])  # every bin's cycles accumulated
    plot_spectrum_damage(data, ax=ax2)
    heights = [p.get_height() for p in ax2.patches]
    expected = [b[f"U_{mode}"][i] for mode in ("pitting", "bending") for i in (0, 1) for b in sp["bins"]]
    np.testing.assert_array_equal(heights, expected)
    assert sp["damage"]["pitting"][0] > 0  # the 250 N m bin does damage, drawn as a bar above zero
    assert np.isclose(sum(b["U_pitting"][0] for b in sp["bins"]), sp["damage"]["pitting"][0])
    text = ax2.texts[0].get_text()
    assert f"pitting pinion: D = {sp['damage']['pitting'][0]:.3g}" in text
