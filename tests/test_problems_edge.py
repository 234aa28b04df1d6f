"""The edge-contact scenes of problems/ (TCA with edge_contact = true): each runs through the CLI path, and
edge contact appears where the misalignment puts it, with the jump of the gear's angular velocity at
the transfers (Litvin & Fuentes 9.6)."""

from __future__ import annotations

import math

import pytest


from scenes import SCENES, check_scene_run, edge_contact, scene_param, study



@pytest.mark.parametrize("scene", [scene_param(p) for p in SCENES if study(p) == "tca" and edge_contact(p)])
def test_scene_runs_and_writes(scene, scene_run):
    """The scene runs through the CLI (once per test process: conftest.scene_run, whose results the
    physics tests read) and writes documented results and clean plots (scenes.check_scene_run)."""
    check_scene_run(scene, scene_run)


def tca_scenes(edge=False):
    return [p for p in SCENES if study(p) == "tca" and edge_contact(p) == edge]


EDGE_EXPECT = {  # scene: (edge contact aligned, edge contact misaligned, an edge that must carry load)
    "edge_spur_crossed": (False, True, "pinion_face-"),
    "edge_helical_crossing": (False, True, "pinion_tip"),
    "edge_helical_intersecting": (False, True, "gear_tip"),
    "edge_crowned_tip": (False, True, "pinion_tip"),
    "edge_crowned_avoided": (False, False, None),
}


@pytest.mark.slow
@pytest.mark.parametrize("scene", tca_scenes(edge=True), ids=lambda p: p.stem)
def test_edge_scene_physics(scene, scene_run):
    rep = scene_run(scene.stem).results
    aligned, mis = rep["cases"]
    exp_al, exp_mis, edge = EDGE_EXPECT[scene.stem]
    assert aligned["edge_carries_load"] is exp_al
    assert mis["edge_carries_load"] is exp_mis
    for case in (aligned, mis):
        env = [v for v in case["te_envelope_arcsec"] if v is not None]
        assert len(env) == len(case["phi1"]), "a position without any contact"
    if edge is not None:
        assert edge in set(a for a in mis["active_branch"] if a)
        # Edge contact makes the gear's angular velocity jump at the transfers (Litvin 9.6).
        # Scale: the mean TE slope over a cycle, p-p / (pi / z1).
        jumps = [abs(t["slope_jump"]) for t in mis["transfers"] if t["slope_jump"] is not None]
        scale = mis["peak_to_peak_arcsec"] / 206264.806 / (math.pi / rep["pair"]["z1"])
        assert max(jumps) > 0.5 * scale
    if rep["pair"]["pinion_a_c"] == 0 and rep["pair"]["pinion_a_pl"] == 0:
        # Unmodified gears: the aligned drive is conjugate, TE identically zero.
        assert max(abs(v) for v in aligned["te_envelope_arcsec"]) < 1e-7  # 5e-13 rad
