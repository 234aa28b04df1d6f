"""What EdgeContact keeps between sweeps (issue 43: the crowning scene's speed) changes no number.

- The first guesses of the edge branches (conjugate sections moved onto the edges) depend on the
  angles and the settings only, not on the misalignment: they are solved once per grid and design,
  and a sweep that reuses them gives the numbers of a fresh EdgeContact bit for bit.
- The flank evaluators on columns (transverse radius and flank point) are built once per
  EdgeContact and give, column by column, what the surface Function gives for one point.
- Drives that differ only in crowning share the edge branches (the same equations).
- A position's TE does not depend on the other positions of a sweep (what ``actual_level``'s one
  sweep per zoom rests on): the TE of a merged grid is the TE of its parts.

Drive: the crowned 20/40 spur pair of ``problems/crowning_spur.toml`` (m 3 mm, b 20 mm) with a
little crowning, interpreted (``jit=False``: the same arithmetic in every EdgeContact, so equality
is exact), few positions.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import gearopt.contact.edge_guesses as edge_guesses
from gearopt.contact.edge import EdgeContact
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment
from gearopt.synthesis.crowning import actual_level

ARCMIN = math.pi / 180 / 60
PAIRS = (-1, 0, 1)
CASES = (Misalignment(crossing=3 * ARCMIN), Misalignment(intersecting=-3 * ARCMIN))


def pair() -> GearPair:
    p = Gear(z=20, m_n=3.0, b=20, a_pl=2e-4, rack=BasicRack(a_c=4e-4), name="pinion")
    return GearPair(p, Gear(z=40, m_n=3.0, b=20, name="gear"))


def fresh() -> EdgeContact:
    return EdgeContact(TCA(pair(), jit=False))


@pytest.fixture(scope="module")
def ec() -> EdgeContact:
    return fresh()


def grid(n: int = 15, shift: float = 0.0) -> np.ndarray:
    pitch = 2 * math.pi / 20
    return shift + np.linspace(-0.6 * pitch, 0.6 * pitch, n)


def same(a, b) -> bool:
    return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)


def test_first_guesses_solved_once_per_grid_and_design(ec, monkeypatch):
    calls = []
    inner = ec._sections
    monkeypatch.setattr(ec, "_sections", lambda *a: calls.append(1) or inner(*a))
    phi = grid(shift=1e-3)  # angles no other test sweeps
    for mis in CASES:  # the cases of a study: the same grid and design
        ec.sweep(phi, mis=mis, pairs=PAIRS)
    assert len(calls) == 1
    ec.sweep(phi + 1e-4, mis=CASES[0], pairs=PAIRS)  # a new grid: solved again
    assert len(calls) == 2


def test_sweep_with_kept_guesses_equals_a_fresh_edge_contact(ec):
    phi = grid()
    ec.sweep(phi, mis=CASES[0], pairs=PAIRS)  # fills the memo with this grid's first guesses
    kept = ec.sweep(phi, mis=CASES[1], pairs=PAIRS)
    new = fresh().sweep(phi, mis=CASES[1], pairs=PAIRS)
    assert kept.edge_contact() or np.isfinite(kept.te_envelope).all()  # a sweep with contacts
    for name in ("te", "te_pair", "te_envelope", "z1", "radius1", "z2", "radius2", "valid", "converged", "branch"):
        assert same(getattr(kept, name), getattr(new, name)), name
    assert kept.transfers == new.transfers


def test_flank_evaluators_are_built_once_and_match_the_surface_function(ec, monkeypatch):
    built = []
    inner = edge_guesses.mapped
    monkeypatch.setattr(edge_guesses, "mapped", lambda *a, **k: built.append(a[0].name()) or inner(*a, **k))
    e = fresh()
    phi = grid(9)
    e.sweep(phi, mis=CASES[0], pairs=PAIRS)
    first = len(built)
    e.sweep(phi + 1e-4, mis=CASES[1], pairs=PAIRS)  # new guesses and new checks, no new evaluator
    assert 0 < first == len(built) <= 4  # (radius, point) x (pinion, gear)
    # each column as the surface Function gives it for one point
    rng = np.random.default_rng(4)
    Q = np.vstack([rng.uniform(-1, 1, 7), rng.uniform(-10, 10, 7), rng.uniform(-1, 1, 7), rng.uniform(-10, 10, 7),
                   np.zeros(7)])
    Q[:, 3] = np.nan  # a column without a point gives NaN
    for member, (iu, iz) in ((1, (0, 1)), (2, (2, 3))):
        tooth = e.teeth[member]
        f = tooth.surface(e.tca.side, "flank")
        got = e._radius(member, Q, tooth.p0)
        want = [math.hypot(*np.asarray(f(Q[iu, j], Q[iz, j], tooth.p0)[0]).ravel()[:2]) if np.isfinite(Q[:, j]).all()
                else math.nan for j in range(Q.shape[1])]
        assert same(got, want)


def test_tip_points_solved_together_lie_on_the_tip_circle(ec):
    z = np.r_[np.linspace(-10, 10, 5), np.nan, 3.0]
    for member in (1, 2):
        tooth, r_a = ec.teeth[member], ec.members[member].r_a
        u = ec._u_at(member, r_a, z, tooth.p0)
        assert np.isnan(u[5]) and np.isfinite(np.delete(u, 5)).all()
        f = tooth.radius_function(ec.tca.side)
        for uj, zj in zip(np.delete(u, 5), np.delete(z, 5)):
            assert abs(float(f(uj, zj, tooth.p0)[0]) - r_a) < 1e-10
        # one point alone gives the point of the batch
        assert abs(ec._u_at(member, r_a, z[6:], tooth.p0)[0] - u[6]) < 1e-12


def test_te_of_a_merged_grid_is_the_te_of_its_parts(ec):
    a, b = grid(7), grid(5, shift=0.05)
    parts = [ec.sweep(g, mis=CASES[0], pairs=PAIRS) for g in (a, b)]
    merged = ec.sweep(np.r_[a, b], mis=CASES[0], pairs=PAIRS)
    np.testing.assert_allclose(merged.te_pair, np.hstack([p.te_pair for p in parts]), rtol=0, atol=1e-13)
    assert same(merged.branch, np.hstack([p.branch for p in parts]))


def test_actual_level_sweeps_once_per_zoom(ec, monkeypatch):
    phi = np.linspace(-2 * math.pi / 20, 2 * math.pi / 20, 41, endpoint=False)
    r = ec.sweep(phi, mis=CASES[0], pairs=PAIRS)
    changes = np.flatnonzero((r.driving[:-1] >= 0) & (r.driving[1:] >= 0)
                             & ((r.driving[:-1] != r.driving[1:]) | (r.active[:-1] != r.active[1:])))
    assert changes.size >= 2  # corners to refine (and the peak)
    calls = []
    inner = ec.sweep
    monkeypatch.setattr(ec, "sweep", lambda *a, **k: calls.append(1) or inner(*a, **k))
    level, corners, peak = actual_level(ec, r, CASES[0], zooms=3)
    assert len(calls) <= 3 and len(corners) == changes.size
    # the refined extremes bound the sampled ones
    env = r.te_envelope[np.isfinite(r.te_envelope)]
    assert peak[1] >= env.max() - 1e-15 and min(c[1] for c in corners) <= env.max()
    assert level >= env.max() - env.min() - 1e-15


def test_drives_differing_in_crowning_share_the_edge_branches(ec):
    # crowning and plunging are symbolic parameters of the flanks: the same edge equations
    p = Gear(z=20, m_n=3.0, b=20, a_pl=5e-4, rack=BasicRack(a_c=1e-3), name="pinion")
    other = EdgeContact(TCA(GearPair(p, Gear(z=40, m_n=3.0, b=20, name="gear")), jit=False))
    assert all(other.branches[n] is ec.branches[n] for n in ec.edges)
    # a narrower pinion is another system (its face ends are numbers of the graph)
    p = Gear(z=20, m_n=3.0, b=18, a_pl=2e-4, rack=BasicRack(a_c=4e-4), name="pinion")
    narrow = EdgeContact(TCA(GearPair(p, Gear(z=40, m_n=3.0, b=20, name="gear")), jit=False))
    assert narrow.branches["pinion_face+"] is not ec.branches["pinion_face+"]
    # and a compiled setting is another branch
    assert EdgeContact(TCA(pair(), jit=True)).branches["gear_tip"] is not ec.branches["gear_tip"]
