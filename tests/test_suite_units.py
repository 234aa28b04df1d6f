"""How ``make test`` hands out the suite (tests/conftest.py work_unit, UNIT_COST and the scheduler it
gives pytest-xdist; tests/suite_units.py): tests that read the same scene run share a work unit, the
others go by file, units go out heaviest first, and a worker takes the next unit with two tests left."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest
from conftest import UNIT_COST, work_unit
from suite_units import simulate

TESTS = Path(__file__).resolve().parent


def item(file: str, fixtures=(), **params):
    return SimpleNamespace(path=TESTS / file, fixturenames=list(fixtures),
                           callspec=SimpleNamespace(params=params) if params else None)


def test_tests_of_one_scene_share_its_unit_and_others_go_by_file():
    problems = TESTS.parent / "problems"
    run = ("scene_run",)
    # the scene test, the page test and a physics check of one scene: one unit
    assert work_unit(item("test_dynamics_scenes.py", run, scene=problems / "dynamics_spur.toml")) == "scenes"
    assert work_unit(item("test_report_page.py", run, name="dynamics_spur")) == "scenes"
    assert work_unit(item("test_dynamics_scenes.py", run)) == "scenes"
    # the loaded scenes: their own unit, whichever file reads them
    assert work_unit(item("test_report_page.py", run, name="microgeometry_loaded")) == "scenes-loaded"
    assert work_unit(item("test_problems_loaded.py", run, scene=problems / "ltca_helical.toml")) == "scenes-loaded"
    assert work_unit(item("test_problems_loaded.py", run)) == "scenes-loaded"
    # no scene run: the file (its module fixtures built once)
    assert work_unit(item("test_report_page.py", ("tmp_path",))) == "test_report_page.py"
    assert work_unit(item("test_fea.py", (), a_pl=1e-4)) == "test_fea.py"
    assert UNIT_COST["scenes"] > UNIT_COST.get("test_report_page.py", 0.0)


def test_the_hand_out_follows_pytest_xdist():
    """Two workers: each starts with one unit and takes the next when it has at most two tests left
    (xdist's LoadScopeScheduling._reschedule); units in the given order (heaviest first)."""
    units = [("a", [50.0, 50.0, 50.0, 50.0]), ("b", [120.0]), ("c", [30.0]), ("d", [20.0, 20.0])]
    (t0, u0), (t1, u1) = simulate(units, 2)
    # worker 1: b has one test, so it takes c at once; worker 0 takes d when two of a's tests are left
    assert u0 == ["a", "d"] and u1 == ["b", "c"]
    assert (t0, t1) == pytest.approx((240.0, 150.0))
