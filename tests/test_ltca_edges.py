"""Loaded TCA at tip edges (docs/ltca.md, section 4): each slice force along its own line of action
with its own lever about the pinion axis, and flank contact widths that stop at the zone of action
where a tip-edge slice is the neighbour."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearopt.gears import Gear, GearPair
from gearopt.ltca.engine import LTCA

DEG = math.pi / 180


def _spur():
    return GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))


def _helical(a_pl=0.0):
    return GearPair(Gear(z=21, m_n=2.5, b=30.0, beta=18 * DEG, a_pl=a_pl),
                    Gear(z=53, m_n=2.5, b=30.0, beta=18 * DEG, hand="left"))


def _fixed_frame_normal(S):
    """The slices' force direction in the fixed frame: the pinion-frame ``nc1`` turned about the axis by
    the angle that takes the pinion-frame point ``r1`` onto the fixed-frame point ``rf``."""
    ang = np.arctan2(S.rf[..., 1], S.rf[..., 0]) - np.arctan2(S.r1[..., 1], S.r1[..., 0])
    c, s = np.cos(ang), np.sin(ang)
    n = S.nc1
    return np.stack([c * n[..., 0] - s * n[..., 1], s * n[..., 0] + c * n[..., 1], n[..., 2]], -1)


@pytest.fixture(scope="module")
def spur600():
    L = LTCA(_spur(), n_slices=11)
    return L, L.solve(600.0, phi1=L.mesh_cycle(24))


def test_tip_edge_force_lies_on_the_gear_flank_normal_and_torque_balances_on_its_own_lever(spur600):
    L, sw = spur600
    S, r = sw.slices, sw.results[0]
    pair = L.pair
    g1, g2 = pair.pinion, pair.gear
    nf = _fixed_frame_normal(S)
    # moment arm about the pinion axis (z through the origin of the fixed frame) from the point and
    # the force direction: |r x n|_z (independent of the levers the engine uses)
    arm1 = np.abs(S.rf[..., 0] * nf[..., 1] - S.rf[..., 1] * nf[..., 0])
    loaded = r.load > 0
    e1 = loaded & (S.edge == 1)
    assert e1.any() and np.max(r.edge_share) > 0.2  # unrelieved tips carry a large share at 600 N m
    # the pinion's tip edge is pressed by the gear's involute flank: its normal is tangent to the gear's
    # base circle, i.e. its line lies r_b2 from the gear axis (the gear centre: a_w from the pinion's
    # axis, on the line whose distance from the pinion-base tangents is r_b2 for every flank slice)
    fl = loaded & (S.edge == 0)
    arm_fl = arm1[fl]
    assert np.allclose(arm_fl, g1.r_b, rtol=1e-9)
    for centre in ((0.0, pair.a_w), (0.0, -pair.a_w), (pair.a_w, 0.0), (-pair.a_w, 0.0)):
        d = S.rf[..., :2] - np.array(centre)
        arm2 = np.abs(d[..., 0] * nf[..., 1] - d[..., 1] * nf[..., 0])
        if np.allclose(arm2[fl], g2.r_b, rtol=1e-9):
            break
    else:
        pytest.fail("no gear centre a_w from the pinion's axis has the flank forces tangent to its base circle")
    assert np.allclose(arm2[e1], g2.r_b, rtol=1e-8)
    # the edges' own levers are shorter than the flank's (0.957 ... 0.999 r_b1 where loaded)
    assert np.all(arm1[e1] < g1.r_b * (1 - 1e-3)) and np.all(arm1[e1] > 0.9 * g1.r_b)
    # pinion torque balance on each force's own lever, within 0.1 % (here: to round-off) at every position
    T = np.sum(np.where(loaded, r.load * arm1, 0.0), axis=(0, 2)) * 1e-3  # [N m]
    assert np.all(np.abs(T / 600.0 - 1.0) < 1e-3), np.abs(T / 600.0 - 1.0).max()
    assert np.all(np.abs(r.torque_balance_error) < 1e-9)
    # the shares are shares of the torque: they sum to one with the edges in
    assert np.allclose(r.share.sum(axis=0), 1.0, atol=1e-9)


@pytest.mark.parametrize("a_pl", [0.0, 0.0002])
def test_helical_torque_balances_on_own_levers_at_high_torque(a_pl):
    L = LTCA(_helical(a_pl), n_slices=11)
    r = L.solve(450.0, phi1=L.mesh_cycle(12)).results[0]
    assert np.max(r.edge_share) > 0.02
    assert np.all(np.abs(r.torque_balance_error) < 1e-3)
    assert np.max(r.kkt_error) < 1e-9


def test_flank_contact_never_exceeds_the_zone_of_action_beside_a_tip_edge():
    """The unmodified helical's contact lines are straight in the plane of action: the transverse roll
    distance xi = sqrt(r1^2 - r_b1^2) of its points is linear in z, and the zone of action is
    xi_start <= xi <= xi_a (gear tip, pinion tip). The flank slices' axial widths in contact add up to
    at most the axial extent of that line inside the zone and the face (and not much less)."""
    pair = _helical(0.0)
    L = LTCA(pair, n_slices=11)
    S = L.slices(L.mesh_cycle(24))
    g1, g2 = pair.pinion, pair.gear
    xi_a = math.sqrt(g1.r_a**2 - g1.r_b**2)
    xi_s = pair.a_w * math.sin(pair.alpha_wt) - math.sqrt(g2.r_a**2 - g2.r_b**2)
    dz = g1.b / (L.n_slices - 1)
    rad1 = np.hypot(S.r1[..., 0], S.r1[..., 1])
    n_beside = 0
    for k in range(S.z.shape[0]):
        for n in range(S.z.shape[1]):
            fl = S.active[k, n] & (S.edge[k, n] == 0)
            if fl.sum() < 2:
                continue
            z = S.z[k, n, fl]
            xi = np.sqrt(rad1[k, n, fl] ** 2 - g1.r_b**2)
            slope, icpt = np.polyfit(z, xi, 1)
            assert np.allclose(slope * z + icpt, xi, atol=1e-6)  # a straight contact line
            za, zb = sorted(((xi_s - icpt) / slope, (xi_a - icpt) / slope))
            ref = max(0.0, min(zb, g1.b / 2) - max(za, -g1.b / 2))
            total = float(np.sum(S.width[k, n, fl]))
            assert total <= ref + 1e-9 * g1.b, (k, n, total, ref)
            assert total >= ref - 0.02 * dz, (k, n, total, ref)
            n_beside += int(np.any(S.active[k, n] & (S.edge[k, n] > 0)))
    assert n_beside >= 5  # flank slices beside tip edges were checked


@pytest.mark.slow
def test_face_load_factor_is_that_of_the_most_loaded_flank_contact(tmp_path):
    """K_Hbeta (peak over mean line load across the face): 1 for the uniform line contact of the
    conjugate spur at every torque; for the lead-crowned helical of ltca_helical it falls as the
    contact ellipse spreads with the torque, and stays a face load factor (a few units), not the ratio
    of a pair just entering mesh (1110 at 225 N m) or of a sliver trimmed at a tip crossing (37 at
    450 N m)."""
    import json
    from pathlib import Path

    from gearopt.cli import main

    problems = Path(__file__).resolve().parents[1] / "problems"
    out = {}
    for scene in ("ltca_spur", "ltca_helical"):
        assert main(["run", str(problems / f"{scene}.toml"), "--out", str(tmp_path / scene), "--quiet"]) == 0
        res = json.loads((tmp_path / scene / "results.json").read_text())
        out[scene] = [t["K_Hbeta"] for t in res["torques"]]
    assert out["ltca_spur"] == pytest.approx([1.0] * len(out["ltca_spur"]), abs=1e-9)
    k = np.array(out["ltca_helical"])
    assert np.all(k > 1.0) and np.all(k < 10.0)
    assert np.all(np.diff(k) <= 1e-9), k
