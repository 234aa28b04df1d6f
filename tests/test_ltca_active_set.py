"""The loaded TCA's contact QP by the primal-dual active-set method (gearopt.ltca.contact_qp.contact_active_set)
against qpOASES, its fallback, and the vectorised helpers of the loaded TCA against their references
(issue 43: one torque over 64 positions in well under 0.1 s with the same results)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import gearopt.ltca.contact_qp as contact_qp
import gearopt.ltca.slices as slices_mod
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.compliance import Material, coupling_batch, weber_tangent, weber_tangent_array
from gearopt.ltca.contact_qp import contact_active_set, row_median
from gearopt.ltca.engine import LTCA
from gearopt.meshing.misalignment import Misalignment
from gearopt.units import ARCMIN


def crowned():
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=0.0004, rack=BasicRack.iso53("A", a_c=0.002)),
                    Gear(z=40, m_n=3.0, b=20.0))


def random_problem(seed, N=12, K=3, M=7):
    """Block-diagonal SPD compliances [mm/N] (scaled like the teeth's, 1e-5), separations with some far
    open nodes, levers of tip edges (< 1) among flank ones (1), some nodes not valid."""
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(N, K, M, M))
    C = 1e-5 * (np.einsum("nkij,nklj->nkil", B, B) / M + 0.2 * np.eye(M))
    s = np.abs(rng.normal(size=(N, K, M))) * 2e-3 * (rng.random((N, K, M)) < 0.7)
    s[rng.random((N, K, M)) < 0.15] += 0.05  # far open
    lam = np.where(rng.random((N, K, M)) < 0.2, rng.uniform(0.7, 1.0, (N, K, M)), 1.0)
    valid = rng.random((N, K, M)) < 0.9
    valid[:, 0, 0] = True
    return C, s, lam, valid


def qpoases(C, s, lam, valid, W):
    """One position's QP by qpOASES (CasADi conic), over the valid nodes."""
    v = valid.ravel()
    n = int(v.sum())
    H = np.zeros((C.shape[0] * C.shape[1],) * 2)
    K, M = s.shape
    for k in range(K):
        H[k * M:(k + 1) * M, k * M:(k + 1) * M] = C[k]
    H = H[np.ix_(v, v)]
    qp = ca.conic("q", "qpoases", {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(1, n)},
                  {"printLevel": "none"})
    r = qp(h=H / 1e-5, g=s.ravel()[v] / (W * 1e-5), a=lam.ravel()[v][None, :], lba=1.0, uba=1.0, lbx=0.0)
    F = np.zeros(K * M)
    F[v] = W * np.asarray(r["x"]).ravel()
    return np.maximum(F, 0.0).reshape(K, M)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_active_set_solves_the_contact_qp(seed):
    """The active-set loads satisfy the contact conditions and equal qpOASES's, position by position."""
    C, s, lam, valid = random_problem(seed)
    W = 500.0
    F, P, ok = contact_active_set(C, s, lam, valid, W)
    assert ok.all()
    F = np.where(valid, np.maximum(F, 0.0), 0.0)
    for j in range(s.shape[0]):
        Fj = F[j]
        assert np.all(Fj[~valid[j]] == 0.0)
        assert np.sum(lam[j] * Fj) == pytest.approx(W, rel=1e-12)
        CF = np.einsum("kij,kj->ki", C[j], Fj)
        loaded = Fj > 0
        delta = np.median((s[j] + CF)[loaded] / lam[j][loaded])
        gap = s[j] + CF - delta * lam[j]
        assert np.max(np.abs(gap[loaded])) < 1e-12          # touching where loaded
        assert np.min(gap[valid[j] & ~loaded]) > -1e-12      # open elsewhere
        ref = qpoases(C[j], s[j], lam[j], valid[j], W)
        assert np.max(np.abs(Fj - ref)) < 1e-8 * W


def test_active_set_warm_start_does_not_change_the_solution():
    """A start from any contact set (every node, none but one, a random one) gives the same loads."""
    C, s, lam, valid = random_problem(5)
    W = 200.0
    ref, _, ok = contact_active_set(C, s, lam, valid, W)
    rng = np.random.default_rng(3)
    P1 = np.zeros(valid.shape, bool)
    P1[:, 0, 0] = True
    for P0 in (valid, P1, rng.random(valid.shape) < 0.5):
        F, _, ok2 = contact_active_set(C, s, lam, valid, W, P0=P0)
        assert ok2.all()
        assert np.max(np.abs(F - ref)) < 1e-10 * W


def test_engine_falls_back_to_qpoases_where_the_active_set_does_not_settle(monkeypatch):
    """With one active-set iteration allowed nothing settles from the spread start, every position is
    solved by qpOASES, and the loads, loaded TE and peak pressure are those of the active set."""
    L = LTCA(crowned(), n_slices=11)
    S = L.slices(L.mesh_cycle(16), mis=Misalignment(crossing=3 * ARCMIN))
    ref = L.solve(150.0, slices=S).results[0]
    calls = []
    orig = LTCA._fixed_point_qpoases

    def spy(self, *a, **k):
        calls.append(a[0].shape[0])
        return orig(self, *a, **k)

    monkeypatch.setattr(contact_qp, "ACTIVE_SET_MAX_ITER", 1)
    monkeypatch.setattr(LTCA, "_fixed_point_qpoases", spy)
    r = L.solve(150.0, slices=S).results[0]
    assert calls and calls[0] > 0
    assert np.max(np.abs(r.load - ref.load)) < 1e-8 * ref.W
    assert np.max(np.abs(r.te_loaded_arcsec - ref.te_loaded_arcsec)) < 1e-8
    assert r.p_max == pytest.approx(ref.p_max, rel=1e-8)
    assert r.kkt_error.max() < 1e-9


def test_weber_tangent_array_is_the_ad_tangent():
    m = Material()
    f = np.array([1e-3, 0.5, 0.99, 1.01, 3.0, 100.0, 1000.0, 4000.0])
    R = np.linspace(4.0, 30.0, f.size)
    h1, h2 = np.linspace(1.5, 4.0, f.size), np.linspace(2.0, 5.0, f.size)
    c_ad, dc_ad = (np.asarray(v).ravel() for v in weber_tangent(m).map(f.size)(f[None], R[None], h1[None],
                                                                                  h2[None], 1.0))
    c, dc = weber_tangent_array(f, R, h1, h2, m, 1.0)
    np.testing.assert_allclose(c, c_ad, rtol=1e-14)
    np.testing.assert_allclose(dc, dc_ad, rtol=1e-13)
    assert np.all(dc[f < 1.0] == c[f < 1.0])  # below f_min the compliance is held: d(c f)/df = c


def test_row_median_is_numpys_median_of_the_finite_entries():
    rng = np.random.default_rng(7)
    a = rng.normal(size=(50, 9))
    a[rng.random(a.shape) < 0.4] = np.nan
    a[4] = np.nan
    ref = np.array([np.median(x[np.isfinite(x)]) if np.isfinite(x).any() else np.nan for x in a])
    assert np.array_equal(row_median(a), ref, equal_nan=True)


def test_coupling_of_repeated_rows_equals_each_row_inverted():
    z = np.tile(np.linspace(-10, 10, 6), (5, 1))
    w = np.tile(np.full(6, 4.0), (5, 1))
    z[2, 4:] = np.nan
    w[3] *= 1.5
    G = coupling_batch(z, w, 1.7)
    for r in range(5):
        one = coupling_batch(z[r:r + 1], w[r:r + 1], 1.7)[0]
        assert np.array_equal(G[r], one)


@pytest.mark.parametrize("make, mis", [(crowned, Misalignment(crossing=3 * ARCMIN)),
                                       (lambda: GearPair(Gear(z=21, m_n=2.5, b=30.0, beta=math.radians(18), a_pl=0.0002),
                                                         Gear(z=53, m_n=2.5, b=30.0, beta=math.radians(18), hand="left")),
                                        Misalignment())], ids=["crowned-crossing", "helical"])
def test_vectorised_contact_widths_equal_the_row_loop(monkeypatch, make, mis):
    """The widths, partners and crossings of the slices (computed for all rows at once) are bit for
    bit those of the row-by-row reference, on drives whose contact lines leave the flanks."""
    L = LTCA(make(), n_slices=11)
    phi = L.mesh_cycle(16)
    fast = L.slices(phi, mis=mis)
    monkeypatch.setattr(slices_mod, "_partial_widths", slices_mod._partial_widths_rows)
    ref = L.slices(phi, mis=mis)
    assert ref.stats["n_partner"] > 0
    for name in ("width", "z_lo", "z_hi", "te", "active", "inside", "te_bound", "partner_of", "partner_t"):
        assert np.array_equal(getattr(fast, name), getattr(ref, name), equal_nan=True), name


def test_a_torque_sweep_warm_started_from_the_previous_torque_gives_each_torque_alone():
    L = LTCA(crowned(), n_slices=11)
    S = L.slices(L.mesh_cycle(16), mis=Misalignment(crossing=3 * ARCMIN))
    sweep = L.solve([20.0, 150.0, 400.0], slices=S).results
    for r in sweep:
        alone = L.solve(r.torque, slices=S).results[0]
        assert np.max(np.abs(r.load - alone.load)) < 1e-10 * r.W
        assert np.max(np.abs(r.te_loaded_arcsec - alone.te_loaded_arcsec)) < 1e-9
