"""Sensitivities of the loaded micro-geometry optimum (docs/loaded_synthesis.md section 6): mirror-image
case sets (the mirror read from every Misalignment field), the degenerate count, and the derivatives
against central differences of re-solved optima on the cheapest loaded_microgeometry scene."""

from __future__ import annotations

from dataclasses import field, make_dataclass
from pathlib import Path

import numpy as np
import pytest

import gearopt.synthesis.loaded as loaded
from gearopt.errors import ArgumentError
from gearopt.gears import Gear, GearPair
from gearopt.meshing.misalignment import Misalignment
from gearopt.synthesis.loaded import LoadedMicroOptimizer, degenerate_constraints, mirror_image
from gearopt.units import ARCMIN

ROOT = Path(__file__).resolve().parents[1]


def _optimizer(cases):
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    return LoadedMicroOptimizer(pair, {"pinion.C_beta": (0.0, 0.04)}, [100.0], cases=cases, n_positions=8,
                                n_verify=8, n_slices=7)


@pytest.fixture(scope="module")
def mirrored():
    return _optimizer([Misalignment(), Misalignment(crossing=2 * ARCMIN, axial=0.1),
                       Misalignment(dE=0.01), Misalignment(crossing=-2 * ARCMIN, axial=-0.1)])


def test_mirror_image_flips_every_odd_kind_and_keeps_the_centre_distance():
    m = Misalignment(dE=0.02, crossing=1e-3, intersecting=-2e-3, axial=0.3)
    im = mirror_image(m)
    assert set(loaded.MIRROR_SIGN) == set(Misalignment.names())  # every field has its mirror sign
    assert all(Misalignment.mirror_sign(k) == loaded.MIRROR_SIGN[k] for k in Misalignment.names())
    assert (im.dE, im.crossing, im.intersecting, im.axial) == (0.02, -1e-3, 2e-3, -0.3)


def test_mirror_classes_pair_the_mirror_images(mirrored):
    assert mirrored.mirror_classes() == [[0], [1, 3], [2]]


def _with_kind(mirror):
    """Misalignment with one more kind, ``tilt`` [rad], as a new field would be added to the class;
    ``mirror``: its declared sign under z -> -z (None: the field declares none)."""
    meta = {"unit": "angle", "doc": "a new kind", "scene_max": 1.0}
    if mirror is not None:
        meta["mirror"] = mirror
    return make_dataclass("MisalignmentPlus", [("tilt", float, field(default=0.0, metadata=meta))],
                          bases=(Misalignment,), frozen=True)


def test_a_misalignment_kind_without_a_mirror_sign_disables_the_reduction(mirrored, monkeypatch):
    """The mirror detection reads every field of the cases' Misalignment class: a new kind that
    declares no mirror sign leaves every case on its own instead of being skipped (the cases below
    differ only in it and would otherwise be taken for mirror images), and mirror_image names it."""
    Plus = _with_kind(None)
    cases = [Plus(crossing=2 * ARCMIN, tilt=1e-3), Plus(crossing=-2 * ARCMIN, tilt=-5e-3)]
    monkeypatch.setattr(mirrored, "cases", tuple(cases))
    assert mirrored.mirror_classes() is None
    with pytest.raises(ArgumentError, match="tilt"):
        mirror_image(cases[0])


def test_a_new_misalignment_kind_with_its_mirror_sign_takes_part_in_the_pairing(mirrored, monkeypatch):
    """A new kind that declares its sign is read too: cases that differ in it are mirror images only
    when it flips as declared."""
    Plus = _with_kind(-1.0)
    assert mirror_image(Plus(crossing=1e-3, tilt=2e-3)) == Plus(crossing=-1e-3, tilt=-2e-3)
    monkeypatch.setattr(mirrored, "cases", (Plus(crossing=2 * ARCMIN, tilt=1e-3), Plus(crossing=-2 * ARCMIN, tilt=-1e-3)))
    assert mirrored.mirror_classes() == [[0, 1]]
    # the same crossings with the tilt unflipped: not mirror images (the kind is not skipped)
    monkeypatch.setattr(mirrored, "cases", (Plus(crossing=2 * ARCMIN, tilt=1e-3), Plus(crossing=-2 * ARCMIN, tilt=1e-3)))
    assert mirrored.mirror_classes() is None


def test_cases_that_differ_in_a_kind_are_not_mirror_images():
    opt = _optimizer([Misalignment(crossing=2 * ARCMIN, axial=0.1), Misalignment(crossing=-2 * ARCMIN, axial=0.1)])
    assert opt.mirror_classes() is None


def test_shifted_adds_the_offset_to_every_case(mirrored):
    s = mirrored.shifted(Misalignment(crossing=0.5 * ARCMIN))
    assert [c.crossing for c in s.cases] == pytest.approx([0.5 * ARCMIN, 2.5 * ARCMIN, 0.5 * ARCMIN, -1.5 * ARCMIN])
    assert [c.axial for c in s.cases] == [c.axial for c in mirrored.cases]
    assert s.mirror_classes() is None and mirrored.mirror_classes() is not None
    with pytest.raises(ArgumentError, match="offset"):
        mirrored.shifted(0.1)


def test_degenerate_counts_active_constraints_with_a_vanishing_multiplier():
    # rows: active with a multiplier, active with none (degenerate), inactive, undecided (indicator 1/2)
    ind_g = np.array([1.0, 1.0, 0.0, 0.5])
    lam_g = np.array([3.0, 1e-9, 0.0, 1e-5])
    # variables: active bound, unbounded, active bound with a zero multiplier
    ind_x = np.array([1.0, np.nan, 0.999])
    lam_x = np.array([-2.0, 0.0, 0.0])
    n, ratio = degenerate_constraints(ind_g, lam_g, ind_x, lam_x)
    assert n == 3
    assert ratio == pytest.approx(0.0)
    n, ratio = degenerate_constraints(ind_g[[0, 2]], lam_g[[0, 2]], ind_x[:2], lam_x[:2])
    assert n == 0 and ratio == pytest.approx(2.0 / 3.0)


@pytest.mark.slow
@pytest.mark.ipopt
def test_sensitivities_of_a_mirror_set_match_re_solved_optima_and_the_nlp():
    """problems/microgeometry_pareto.toml's optimiser (aligned and +-2 arcmin crossing: a mirror pair).
    A crossing added to every case: the optimum re-solved at +-0.05 arcmin (from the optimum, on its
    grid) has a central difference of zero, as reported (before: the full problem's singular KKT
    system gave 1e7 um per rad, its sign changing between runs). The torques and the centre distance
    keep the pair mirror images: their derivatives (of the problem with one case per class) against
    central differences of that NLP solved again at perturbed parameters, within 0.1 %."""
    from gearopt.io.scene import load_scene

    opt = load_scene(ROOT / "problems" / "microgeometry_pareto.toml").build().optimizer
    design = opt.solve()
    assert design.stop in ("converged", "trust radius") and design.to_dict()["stop"] == design.stop
    S = opt.sensitivities(design, held=False)  # the NLP's own derivatives (data held)
    assert S["mirror_odd"] == ["crossing", "intersecting", "axial"]
    names = list(opt.free)
    theta = np.array([design.theta[n] for n in names])
    kinds = Misalignment.names()
    j = kinds.index("crossing")
    h = 0.05 * ARCMIN
    th = {}
    for sgn in (1, -1):
        d = opt.shifted(Misalignment(crossing=sgn * h)).solve(start=theta, grid=design.phi1)
        th[sgn] = np.array([d.theta[n] for n in names])
    fd = (th[1] - th[-1]) / (2 * h)
    assert np.all(S["d_theta_d_mis"][:, j] == 0.0) and S["d_objective_d_mis"][j] == 0.0
    assert np.all(np.abs(fd) * ARCMIN < 1e-3 * 1e-3)  # below 1e-3 um per arcmin
    # the even parameters on the NLP behind the derivatives
    nlp, (lbx, ubx) = S["nlp"], S["bounds"]
    P, T = len(names), opt.torques.size

    def solve(p):
        r = nlp.solver(x0=S["z"], lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg, p=p)
        assert nlp.solver.stats()["success"]
        return np.asarray(r["x"]).ravel()[:P] * 1e-3

    for col, hp in [(t, 1e-4) for t in range(T)] + [(T + kinds.index("dE"), 1e-4)]:
        pp, pm = S["p"].copy(), S["p"].copy()
        pp[4 + col] += hp
        pm[4 + col] -= hp
        fd = (solve(pp) - solve(pm)) / (2 * hp)
        ad = S["d_theta_d_torque"][:, col] * opt.torques[col] if col < T else S["d_theta_d_mis"][:, col - T]
        assert np.max(np.abs(ad - fd)) <= 1e-3 * np.max(np.abs(fd)) + 1e-9, (col, ad, fd)
