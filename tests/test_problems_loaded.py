"""The loaded scenes of problems/ (loaded TCA, micro-geometry optimisation under load): each runs through the
CLI path; the loaded TCA scenes against ISO 6336-1's mesh stiffness and the trends of load; the
optimisation's results against their own limits (scenes.py); bad keys name the key and write nothing."""

from __future__ import annotations


import pytest


from scenes import SCENES, bad_scene, check_scene_run, scene_param, study



@pytest.mark.parametrize("scene", [scene_param(p) for p in SCENES if study(p) in ("ltca", "loaded_microgeometry")])
def test_scene_runs_and_writes(scene, scene_run):
    """The scene runs through the CLI (once per test process: conftest.scene_run, whose results the
    physics tests read) and writes documented results and clean plots (scenes.check_scene_run)."""
    check_scene_run(scene, scene_run)


# --- loaded TCA scenes ----------------------------------------------------------------------------
LTCA_SCENES = ("ltca_spur", "ltca_crowned", "ltca_helical")


@pytest.fixture(scope="module")
def ltca_reports(scene_run):
    return {s: scene_run(s).results for s in LTCA_SCENES}


@pytest.mark.slow
def test_ltca_spur_scene(ltca_reports):
    d = ltca_reports["ltca_spur"]
    assert d["unloaded_peak_to_peak_arcsec"] < 1e-6  # conjugate
    T = [t["torque_Nm"] for t in d["torques"]]
    assert T[0] == pytest.approx(0.1 * d["nominal_torque_Nm"]) and T[-1] == pytest.approx(1.5 * d["nominal_torque_Nm"])
    pp = [t["peak_to_peak_arcsec"] for t in d["torques"]]
    assert all(b > a for a, b in zip(pp, pp[1:]))  # an unmodified pair: TE grows with load
    # ISO 6336-1 mean mesh stiffness of this standard steel pair, computed here from the standard
    z1, z2 = d["pair"]["z1"], d["pair"]["z2"]
    q = 0.04723 + 0.15551 / z1 + 0.25791 / z2
    c_gamma = 1 / q * 0.8 * 0.975 * (0.75 * d["pair"]["eps_alpha"] + 0.25)
    assert d["iso6336"]["c_gamma_alpha"] == pytest.approx(c_gamma, rel=1e-9)
    assert 0.85 < d["iso6336"]["ltca_c_gamma_at_nominal"] / c_gamma < 1.15
    for t in d["torques"]:
        assert t["kkt_error_max_mm"] < 1e-7
        share = [[v or 0.0 for v in row] for row in t["pair_share"]]
        assert all(abs(sum(col) - 1) < 1e-9 for col in zip(*share))


@pytest.mark.slow
def test_ltca_crowned_and_helical_scenes(ltca_reports):
    c = ltca_reports["ltca_crowned"]
    assert c["unloaded_peak_to_peak_arcsec"] > 5  # the crossing's TE, absorbed by the parabola
    t20, t200 = c["torques"][0], c["torques"][4]
    assert t200["torque_Nm"] == 200.0 and t20["torque_Nm"] == 20.0
    # light load: the loaded TE follows the unloaded one; at 200 N m the pattern has spread
    assert abs(t20["peak_to_peak_arcsec"] - c["unloaded_peak_to_peak_arcsec"]) < 0.5 * c["unloaded_peak_to_peak_arcsec"]
    assert 1000 < t200["p_max_MPa"] < 2500
    h = ltca_reports["ltca_helical"]
    nom = [t for t in h["torques"] if t["torque_Nm"] == h["nominal_torque_Nm"]][0]
    spur_nom = [t for t in ltca_reports["ltca_spur"]["torques"] if t["torque_Nm"] == 200.0][0]
    assert nom["peak_to_peak_arcsec"] < 0.25 * spur_nom["peak_to_peak_arcsec"]
    shares = [[v or 0.0 for v in row] for row in nom["pair_share"]]
    assert min(sum(1 for v in col if v > 0.01) for col in zip(*shares)) >= 2


@pytest.mark.parametrize("edit, param", [
    (("torque = 200.0", "torque = 200.0\ntorques = [100.0, 50.0]"), "[ltca] torques"),
    (("torque = 200.0", "torque = 200.0\ntorques = [0.0, 50.0]"), "[ltca] torques"),
    (("torque = 200.0", "torque = -1.0"), "[ltca] torque"),
    (("E = 206000.0", "E = 206.0"), "[ltca] E"),
    (("nu = 0.3", "nu = 0.6"), "[ltca] nu"),
    (("torque = 200.0", "torque = 200.0\nr_int_pinion = \"29 mm\""), "[ltca] r_int_pinion"),
    (("torque = 200.0", "torque = 200.0\nslices = 11"), "[ltca] slices"),
])
def test_bad_ltca_keys_name_the_key_and_write_nothing(tmp_path, edit, param):
    params, _ = bad_scene(tmp_path, "ltca_spur", edit)
    assert param in params



@pytest.mark.parametrize("edit, param", [
    (('C_alpha = { lo = "0 um", hi = "40 um" }', 'C_gamma = { lo = "0 um", hi = "40 um" }'),
     "[loaded_microgeometry.free.pinion] C_gamma"),
    (('C_alpha = { lo = "0 um", hi = "40 um" }', 'C_alpha = { lo = "30 um", hi = "20 um" }'), None),
    (('C_alpha = { lo = "0 um", hi = "40 um" }', 'C_alpha = { lo = "0 um", hi = "2 um" }'), None),  # start 5 um
    (('d_Ca = "64 mm"      # tip relief from d = 64 mm to the tip (d_a = 66 mm)', ''), None),  # no tip relief start
    (("torques = [100.0, 250.0]", "torques = [250.0, 100.0]"), "[loaded_microgeometry] torques"),
    (("torques = [100.0, 250.0]", "torques = [100.0, 250.0]\nweights = [1.0]"), "[loaded_microgeometry] weights"),
    (("p_limit = 2600.0", "p_limit = 20.0"), "[loaded_microgeometry] p_limit"),
    (("p_limit = 2600.0", "p_limit = 2600.0\nharmonics = [1.0, -0.5]"), "[loaded_microgeometry] harmonics"),
    (("p_limit = 2600.0", "p_limit = 2600.0\npareto = [2000.0, 2000.0]"), "[loaded_microgeometry] pareto"),
    (("p_limit = 2600.0", "p_limit = 2600.0\npareto = [50.0]"), "[loaded_microgeometry] pareto"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0 um"'), "[loaded_microgeometry] edge_margin"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { level = "-8 arcsec" }'),
     "[loaded_microgeometry.unloaded_te] level"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { level = "8 arcsec", weight = 0.0 }'),
     "[loaded_microgeometry.unloaded_te] weight"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { weight = 2.0 }'),
     "[loaded_microgeometry.unloaded_te] level"),
    (('edge_margin = "0.5 um"', 'edge_margin = "0.5 um"\nunloaded_te = { level = "8 arcsec", wieght = 2.0 }'),
     "[loaded_microgeometry.unloaded_te] wieght"),
])
def test_bad_loaded_microgeometry_keys_name_the_key_and_write_nothing(tmp_path, edit, param):
    """Bad keys of the loaded micro-geometry scene stop before the optimisation, naming the key (the
    bounds of a free amount, as checked by the optimiser, name the amount), and write nothing."""
    params, msg = bad_scene(tmp_path, "microgeometry_loaded", edit)
    if param is not None:
        assert param in params
    else:
        assert any(p and ("C_alpha" in p or "free" in p) for p in params) or "C_alpha" in msg
