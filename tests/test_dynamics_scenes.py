"""The dynamics scenes of problems/ (docs/dynamics.md): each runs through the CLI and writes documented
results and clean plots (scenes.check_scene_run); the spur scene's relief lowers the response; bad
keys name the key and write nothing."""

from __future__ import annotations

import pytest

from scenes import SCENES, bad_scene, check_scene_run, scene_param, study


@pytest.mark.parametrize("scene", [scene_param(p) for p in SCENES if study(p) == "dynamics"])
def test_scene_runs_and_writes(scene, scene_run):
    check_scene_run(scene, scene_run)


@pytest.mark.slow
def test_dynamics_spur_relief_lowers_the_response(scene_run):
    """The relieved drive's loaded TE is lower than the unmodified one's at 200 N m, and so is its
    dynamic factor over the sweep; the unmodified drive loses contact, the relieved one not."""
    d = scene_run("dynamics_spur").results
    rel, unm = d["cases"]
    assert (rel["name"], unm["name"]) == ("as_given", "unmodified")
    assert rel["static"]["te_loaded_peak_to_peak_arcsec"] < 0.5 * unm["static"]["te_loaded_peak_to_peak_arcsec"]
    assert rel["K_v_max"] < unm["K_v_max"]
    assert unm["contact_loss_speeds_rpm"] and not rel["contact_loss_speeds_rpm"]
    for c in (rel, unm):
        assert c["up"]["K_v"][0] == pytest.approx(1.0, abs=0.25)  # 2,000 rpm: about a tenth of n_E1
        # the model's linear resonance and ISO 6336-1's n_E1 from the same masses: within the stiffnesses' ratio
        ratio = (c["static"]["c_gamma_N_per_mm_um"] / d["model"]["c_gamma_iso_N_per_mm_um"]) ** 0.5
        assert c["resonance_speeds_linear_rpm"]["order1"][0] == pytest.approx(d["model"]["n_E1_iso_rpm"] * ratio,
                                                                              rel=1e-6)


@pytest.mark.slow
def test_dynamics_helical_has_the_shaft_modes(scene_run):
    d = scene_run("dynamics_helical").results
    c = d["cases"][0]
    assert d["model"]["coordinates"] == ["drive_shaft", "mesh", "load_shaft"]
    assert len(c["natural_frequencies_Hz"]) == 3
    assert all(c["up"]["converged"])


@pytest.mark.parametrize("edit, param", [
    (("speed_max = 32000.0", "speed_max = 0.0"), "[dynamics] speed_max"),
    (("damping = 0.05", "damping = 1.0"), "[dynamics] damping"),
    (("damping = 0.05", "damping = 0.05\ninertia_pinion = 0.0"), "[dynamics] inertia_pinion"),
    (("torque = 200.0 ", "torque = 90000.0 "), "[dynamics] torque"),
    (("speed_min = 2000.0", "speed_min = 40000.0"), "[dynamics] speed_max"),
    (("damping = 0.05", 'damping = 0.05\ndE = "-0.5 mm"'), "[dynamics] dE"),
])
def test_bad_keys_name_the_key_and_write_nothing(tmp_path, edit, param):
    params, msg = bad_scene(tmp_path, "dynamics_spur", edit)
    assert param in params, msg
