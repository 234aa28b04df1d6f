"""Edge contact (gearopt.contact.edge): no real contact discarded, results independent of the sweep
grid.

The reference is an oracle that shares none of the engine's equations (benchmarks/edge_oracle.py):
the largest gear advance over the points of the pinion's finite flank that lie over the gear's
finite flank ("patch-maximum rigid contact"), with both involute helicoids written from the
textbook formulas and the frames written out again. It covers surface, edge, corner and edge-on-edge
contact alike, without tangency equations. The drives here are unmodified (the oracle's formulas),
misaligned by crossing or intersecting angles of both signs, on both flanks.
"""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from edge_oracle import Oracle  # noqa: E402

from gearopt.contact.edge import EdgeContact  # noqa: E402
from gearopt.gears import Gear, GearPair  # noqa: E402
from gearopt.meshing.tca import TCA, Misalignment  # noqa: E402
from test_edge import Frames, edge_tangent, reconstruct  # noqa: E402

DEG = math.pi / 180
ARCMIN = DEG / 60
AS = 180 * 3600 / math.pi
TOL_AS = 5e-3  # engine vs oracle [arcsec] (the oracle converges from below; the defects are 1-10 arcsec)

#: (z1, z2, m_n, b, beta [deg], side, misalignment kwargs [arcmin / mm], positions)
CASES = {
    "helical 23/61 b30 beta20 intersecting +6'": (23, 61, 2.5, 30, 20, "right", dict(intersecting=6), 21),
    "helical 23/61 b30 beta20 intersecting -6'": (23, 61, 2.5, 30, 20, "right", dict(intersecting=-6), 21),
    "helical 17/40 b20 beta30 crossing +3'": (17, 40, 4.0, 20, 30, "right", dict(crossing=3), 21),
    "helical 17/40 b20 beta30 crossing -3' left": (17, 40, 4.0, 20, 30, "left", dict(crossing=-3), 21),
    "helical 27/63 b12 beta35 intersecting +4' left": (27, 63, 1.5, 12, 35, "left", dict(intersecting=4), 41),
    "helical 31/43 b12 beta12 intersecting -10' axial": (31, 43, 1.5, 12, 12, "right",
                                                         dict(intersecting=-10, axial=0.02), 41),
    "helical 17/56 b30 beta30 intersecting +3'": (17, 56, 4.0, 30, 30, "right", dict(intersecting=3), 41),
    "spur 25/25 b16 crossing 8'": (25, 25, 2.0, 16, 0, "right", dict(crossing=8), 21),
}
#: case whose actual TE is carried by the gear's tip/face corner at one position of the grid
CORNER = "helical 17/56 b30 beta30 intersecting +3'"
#: cases whose actual TE is carried by an edge crossing an edge somewhere on the 41-point grid
SLOW_GRID = {"helical 27/63 b12 beta35 intersecting +4' left"}  #: above about 5 s (pytest marker "slow")
EDGE_ON_EDGE = ["helical 27/63 b12 beta35 intersecting +4' left", "helical 31/43 b12 beta12 intersecting -10' axial"]


def _mis(kw):
    return Misalignment(**{k: (v * ARCMIN if k in ("crossing", "intersecting") else v) for k, v in kw.items()})


@functools.lru_cache(maxsize=None)
def drive(name):
    z1, z2, m, b, beta, side, mis, n = CASES[name]
    p = Gear(z=z1, m_n=m, b=b, beta=beta * DEG, hand="right", name="pinion")
    g = Gear(z=z2, m_n=m, b=b, beta=beta * DEG, hand="left" if beta else "right", name="gear")
    pair = GearPair(p, g)
    ec = EdgeContact(TCA(pair, side=side))
    phi = np.linspace(-math.pi / z1, math.pi / z1, n)
    return ec, _mis(mis), phi


@functools.lru_cache(maxsize=None)
def dense(name):
    ec, mis, phi = drive(name)
    return ec.sweep(phi, mis=mis)


@functools.lru_cache(maxsize=None)
def oracle(name):
    ec, mis, phi = drive(name)
    o = Oracle(ec.tca.pair, ec.tca.side, mis, n=121, levels=8)
    # the written flanks are the generated ones (orientation and helix sense): one point each
    assert o.calibrate(ec.tca.pinion, ec.tca.gear) < 1e-12
    return o, o.envelope(phi)


def _raw(r):
    """The engine's actual TE measured from the conjugate position (its documented zero added back)."""
    return r.te_envelope + r.stats["te_zero_rad"]


# ------------------------------------------------------------------------------------------------
# 1. The actual TE is the patch maximum: no contact missed, no spurious contact accepted
# ------------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
def test_envelope_is_the_patch_maximum(name):
    r = dense(name)
    _, (env, _) = oracle(name)
    assert np.array_equal(np.isnan(r.te_envelope), np.isnan(env))
    d = (r.te_envelope - env) * AS
    # shape first (a missed contact shows as a dip, a spurious one as a spike), then the zero
    assert np.nanmax(np.abs(d - np.nanmedian(d))) < TOL_AS, np.round(d - np.nanmedian(d), 4)
    d_abs = (_raw(r) - env) * AS
    assert np.nanmax(np.abs(d_abs)) < TOL_AS, np.round(d_abs, 4)


@pytest.mark.slow
def test_corner_contact_found_in_the_dense_sweep():
    """The gear's tip/face corner carries the load at one position of the 41-point grid: the dense
    sweep finds it (it used to depend on one sweep-wide anchor of the corner branch)."""
    r = dense(CORNER)
    _, (env, _) = oracle(CORNER)
    corners = [b for b, nm in enumerate(r.branches) if "corner" in nm]
    on = np.isin(r.active, corners)
    assert on.any()
    assert np.all(np.abs(_raw(r)[on] - env[on]) * AS < TOL_AS)


# ------------------------------------------------------------------------------------------------
# 2. A contact does not depend on the other positions of the sweep
# ------------------------------------------------------------------------------------------------
def _same(ra, ia, rb, ib):
    """Identical contact at position ia of ra and ib of rb: TE, driving pair and feature."""
    assert abs(ra.te_envelope[ia] - rb.te_envelope[ib]) <= 1e-13 or (
        np.isnan(ra.te_envelope[ia]) and np.isnan(rb.te_envelope[ib])), (ra.te_envelope[ia], rb.te_envelope[ib])
    pa = ra.pairs[ra.driving[ia]] if ra.driving[ia] >= 0 else None
    pb = rb.pairs[rb.driving[ib]] if rb.driving[ib] >= 0 else None
    assert pa == pb
    na = ra.branches[ra.active[ia]] if ra.active[ia] >= 0 else None
    nb = rb.branches[rb.active[ib]] if rb.active[ib] >= 0 else None
    assert na == nb


@pytest.mark.slow
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_GRID else n for n in CASES])
def test_contacts_do_not_depend_on_the_grid(name):
    ec, mis, phi = drive(name)
    r = dense(name)
    n = phi.size
    # every position alone
    for i in range(0, n, 2):
        _same(r, i, ec.sweep(phi[i:i + 1], mis=mis), 0)
    # the same positions shuffled, and a coarse grid over a wider span sharing some positions
    perm = np.random.default_rng(10).permutation(n)
    rs = ec.sweep(phi[perm], mis=mis)
    for j, i in enumerate(perm):
        _same(r, i, rs, j)
    z1 = ec.tca.pair.pinion.z
    wide = np.concatenate([phi[::5], np.linspace(-3 * math.pi / z1, 3 * math.pi / z1, 7)])
    rw = ec.sweep(wide, mis=mis)
    for j, i in enumerate(range(0, n, 5)):
        _same(r, i, rw, j)


# ------------------------------------------------------------------------------------------------
# 3. Edge on edge: the accepted points satisfy both boundary equations, r_f1 = r_f2 and the touch
#    along the common perpendicular from outside (recomputed with the tests' own frames)
# ------------------------------------------------------------------------------------------------
def _wedge_normal(fr, c, edge):
    """Outward normal in S_f of the tip cylinder / face end forming the edge with the flank."""
    member = 1 if edge.startswith("pinion") else 2
    R = c["R1"] if member == 1 else c["R2"]
    if edge.endswith("tip"):
        u, z = (c["u1"], c["z1"]) if member == 1 else (c["u2"], c["z2"])
        r_own = fr.own_point(member, u, z)[0]
        v = np.array([r_own[0], r_own[1], 0.0])
        return R @ (v / np.linalg.norm(v))
    return R @ np.array([0.0, 0.0, 1.0 if edge.endswith("+") else -1.0])


def _in_cone(n, a, c):
    coef = np.linalg.lstsq(np.column_stack([a, c]), n, rcond=None)[0]
    resid = np.linalg.norm(np.column_stack([a, c]) @ coef - n)
    return coef.min(), resid


@pytest.mark.slow
@pytest.mark.parametrize("name", EDGE_ON_EDGE)
def test_edge_on_edge_contact(name):
    ec, mis, phi = drive(name)
    r = dense(name)
    o, (env, te_or) = oracle(name)
    fr = Frames(ec, mis)
    g = fr.g
    cross = [b for b, nm in enumerate(r.branches) if "/" in nm]
    assert np.isin(r.active, cross).any(), "an edge crossing an edge carries the load somewhere"
    checked = 0
    for b in cross:
        e1, e2 = r.branches[b].split("/")
        for k, i in zip(*np.nonzero(r.valid[b])):
            c = reconstruct(fr, r, b, k, i)
            # on both boundary curves
            for member, e in ((1, e1), (2, e2)):
                if e.endswith("tip"):
                    rad = r.radius1[b, k, i] if member == 1 else r.radius2[b, k, i]
                    assert abs(rad - g[f"r_a{member}"]) < 1e-8
                else:
                    zz = r.z1[b, k, i] if member == 1 else r.z2[b, k, i]
                    assert abs(zz - (1 if e.endswith("+") else -1) * g[f"b{member}"] / 2) < 1e-9
            # one point of space
            assert c["mismatch"] < 1e-7 and np.linalg.norm(c["rf1"] - c["rf2"]) < 1e-7
            # the common perpendicular of the two edges is the contact normal; each member's wedge
            # (flank + tip cylinder / face end) lies on its own side of the plane normal to it
            t1, t2 = edge_tangent(fr, e1, c), edge_tangent(fr, e2, c)
            n = np.cross(t1, t2)
            n /= np.linalg.norm(n)
            a1, a2 = c["nf1"], c["nf2"]
            if n @ a1 < 0:
                n = -n
            m1, res1 = _in_cone(n, a1, _wedge_normal(fr, c, e1))
            m2, res2 = _in_cone(-n, a2, _wedge_normal(fr, c, e2))
            assert res1 < 1e-6 and res2 < 1e-6 and m1 > -1e-6 and m2 > -1e-6, (m1, m2, res1, res2)
            # and the touching angle is the pair's patch maximum
            k_or = list(r.pairs).index(r.pairs[k])
            if r.branch[k, i] == b:
                assert abs(r.te[b, k, i] + r.stats["te_zero_rad"] - te_or[k_or, i]) * AS < TOL_AS
            checked += 1
    assert checked


@pytest.mark.slow
def test_stability_benchmark_edge_block():
    """The edge-corner / edge-on-edge block of benchmarks/stability.py (its quick case) agrees with
    the oracle and between grids."""
    import stability as S

    case = next(c for c in S.edge_grid_cases() if c.fast)
    row = S.run_edge_grid_case(case, singles=8)
    assert row["ok"], row
    assert any("/" in f for f in row["features"]), row["features"]
