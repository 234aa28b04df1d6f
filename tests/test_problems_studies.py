"""The scenes of problems/ of the crowning optimisation, the FE model (CalculiX), Monte Carlo and the design
sweep: each runs through the CLI path (scenes.check_scene_run, with the FE pattern's scalars); the
crowning scene's design measured against its target.

Expected values are stated by the scenes (8 arcsec TE level, +-3' misalignments), not by gearopt.
"""

from __future__ import annotations

import math

import pytest

from gearopt.studies.crowning import misalignment_cases
from gearopt.units import ARCMIN

from scenes import SCENES, check_scene_run, scene_param, study

G3 = 3 * ARCMIN


@pytest.mark.parametrize("scene", [scene_param(p) for p in SCENES if study(p) in ("crowning", "fea", "montecarlo", "sweep")])
def test_scene_runs_and_writes(scene, scene_run):
    """The scene runs through the CLI (once per test process: conftest.scene_run) and writes
    documented results and clean plots (scenes.check_scene_run)."""
    check_scene_run(scene, scene_run)


@pytest.mark.slow
@pytest.mark.ipopt
def test_crowning_scene_meets_its_level_without_edge_contact(scene_run):
    """problems/crowning_spur.toml through the CLI (the run of test_scene_runs_and_writes): positive
    crowning settings, the case set of the study, every case of the design at 8 arcsec within 10 %
    with no edge carrying load, the unmodified drive loading an edge, and its three plots."""
    run = scene_run("crowning_spur")
    assert run.status == 0
    res, out = run.results, run.out
    assert res["study"] == "crowning"
    s = res["design"]["settings"]
    assert set(s) == {"a_c", "a_pl"} and all(math.isfinite(v) and v > 0 for v in s.values())
    names = [c["label"] for c in res["after"]]
    assert names == [c["label"] for c in res["before"]] == list(misalignment_cases(crossing=G3, intersecting=G3))
    # NB: the key "edge_contact" of a case is True for every case (it marks an edge-contact
    # analysis); whether an edge carries load is "edge_carries_load".
    for c in res["after"]:
        assert c["edge_carries_load"] is False, c["label"]
        assert set(c["active_branch"]) <= {"surface"}, c["label"]
        assert abs(c["peak_to_peak_arcsec"] / 8 - 1) <= 0.10, c["label"]
    assert any(c["edge_carries_load"] for c in res["before"])
    assert not any(c["edge_contact"] for c in res["design"]["cases"])
    assert sorted(p.name for p in out.glob("*.png")) == ["before_after_contact_gear.png",
                                                       "before_after_contact_pinion.png", "before_after_te.png"]
