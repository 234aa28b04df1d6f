"""Loaded TCA (gearopt.ltca): analytic invariants of the compliance model, the contact QP against an
independent solver, zero load against the unloaded TCA, physics of conjugate, crowned and helical
drives, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearopt.errors import ConvergenceError, GearoptError, GeometryError, OptionError
from gearopt.fea.references import hertz_line
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.compliance import Material, ToothCompliance, coupling, iso6336_stiffness, weber_contact
from gearopt.ltca.engine import LTCA
from gearopt.meshing.misalignment import Misalignment
from gearopt.meshing.tca import TCA
from gearopt.units import ARCMIN, RAD_TO_ARCSEC

DEG = math.pi / 180


def spur(**kw):
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, **kw), Gear(z=40, m_n=3.0, b=20.0))


def crowned():
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=0.0004, rack=BasicRack.iso53("A", a_c=0.002)),
                    Gear(z=40, m_n=3.0, b=20.0))


def helical(a_pl=0.0002):
    return GearPair(Gear(z=21, m_n=2.5, b=30.0, beta=18 * DEG, a_pl=a_pl),
                    Gear(z=53, m_n=2.5, b=30.0, beta=18 * DEG, hand="left"))


@pytest.fixture(scope="module")
def spur_sweep():
    L = LTCA(spur(), n_slices=11)
    return L, L.solve([1e-7, 100.0, 200.0], phi1=L.mesh_cycle(32))


# --- compliance model: analytic invariants ---------------------------------------------------
def test_coupling_is_symmetric_positive_and_exact_for_a_uniform_load():
    rng = np.random.default_rng(1)
    z = np.sort(rng.uniform(-10, 10, 9))
    z = np.concatenate([[-10.0], z, [10.0]])
    mids = 0.5 * (z[1:] + z[:-1])
    w = np.diff(np.concatenate([[-10.0], mids, [10.0]]))
    for lam in (0.0, 0.7, 3.0, 30.0):
        G = coupling(z, w, lam)
        assert np.allclose(G, G.T, atol=1e-14)
        assert np.linalg.eigvalsh(G).min() > 0
        # a uniform line load f (nodal forces w f) deflects every node by exactly c f (here c = 1)
        assert np.allclose(G @ w, 1.0, atol=1e-12)
    # no coupling: each node alone
    assert np.allclose(coupling(z, w, 0.0), np.diag(1 / w))
    # a concentrated load spreads wider with a longer coupling length
    G1, G2 = coupling(z, w, 1.0), coupling(z, w, 5.0)
    i = z.size // 2
    assert G2[i, 0] / G2[i, i] > G1[i, 0] / G1[i, i]


def test_coupling_batch_equals_each_row_alone():
    """Rows of different lengths (unused nodes NaN) in one batch give each row's own coupling."""
    from gearopt.ltca.compliance import coupling_batch

    rng = np.random.default_rng(4)
    M = 7
    Z, W = np.full((3, M), np.nan), np.zeros((3, M))
    for r, n in enumerate((7, 4, 1)):
        z = np.sort(rng.uniform(-5, 5, n))
        Z[r, :n], W[r, :n] = z, rng.uniform(0.2, 2.0, n)
    G = coupling_batch(Z, W, 1.3)
    for r, n in enumerate((7, 4, 1)):
        np.testing.assert_allclose(G[r, :n, :n], coupling(Z[r, :n], W[r, :n], 1.3), rtol=1e-12, atol=1e-14)
        assert not G[r, n:, :].any() and not G[r, :, n:].any()


def test_beam_terms_match_a_rectangular_cantilever():
    """With a constant half thickness the bending term is 4 L^3 / (E' (2x)^3) for a load normal to
    the centreline at the free end (cantilever of unit width), the shear term 1.2 * 2 (1 + nu) L / (2x E)."""
    L_tooth = generate_tooth()
    tc = ToothCompliance(L_tooth, Material(), r_int=10.0)
    x, L = 2.0, 5.0
    eta = np.linspace(0.0, 8.0, 4001)
    w3 = np.full_like(eta, 1 / (2 * x) ** 3)
    cum = lambda f: np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(eta))])  # noqa: E731
    tc._eta, tc._I, tc._J = eta, [cum(w3), cum(eta * w3), cum(eta**2 * w3)], cum(np.full_like(eta, 1 / (2 * x)))
    m = tc.material
    c = tc.per_width([[x, tc.r_f + L]], [[1.0, 0.0]])
    assert c.bending[0] == pytest.approx(4 * L**3 / (m.E_plane * (2 * x) ** 3), rel=1e-6)
    assert c.shear[0] == pytest.approx(1.2 * 2 * (1 + m.nu) * L / (2 * x * m.E), rel=1e-6)
    assert c.compression[0] == pytest.approx(0.0, abs=1e-20)
    # a load inclined by gamma: bending with the moment arm to where its line meets the centreline
    g = 20 * DEG
    n = [math.cos(g), -math.sin(g)]
    yP = tc.r_f + 3.0
    c = tc.per_width([[x, yP]], [n])
    etaF = 3.0 + x * math.tan(g)
    expect = math.cos(g) ** 2 * 4 * (etaF**3 - (etaF - 3.0) ** 3) / (m.E_plane * (2 * x) ** 3)
    assert c.bending[0] == pytest.approx(expect, rel=1e-6)


def generate_tooth():
    from gearopt.geometry.generation import generate
    return generate(Gear(z=20, m_n=3.0, b=20.0))


def test_tooth_compliance_grows_towards_the_tip_and_with_a_deeper_body():
    """Higher loads bend more; Sainsot's body term grows with the body depth (its bore is fixed)."""
    t = generate_tooth()
    tc = ToothCompliance(t, Material(), r_int=0.5 * t.gear.r_f)
    deep = ToothCompliance(t, Material(), r_int=0.25 * t.gear.r_f)
    pts, nrm = [], []
    for r in np.linspace(t.gear.r_b + 0.3, t.gear.r_a - 0.05, 8):
        u = t.u_at_radius(r)
        p, n, _ = t.point("right", "flank", u)
        pts.append(p[:2])
        nrm.append(n[:2])
    c = tc.per_width(np.array(pts), np.array(nrm)).total
    assert np.all(np.diff(c) > 0)
    assert np.all(deep.per_width(np.array(pts), np.array(nrm)).foundation > tc.per_width(np.array(pts),
                                                                                           np.array(nrm)).foundation)
    with pytest.raises(GeometryError) as e:
        ToothCompliance(t, Material(), r_int=0.9 * t.gear.r_f, member="pinion")
    assert e.value.param == "pinion.r_int" and "1.4" in str(e.value)


def test_hertz_values_match_the_fe_module_reference():
    m = Material(E=210000.0, nu=0.3)
    f, r1, r2 = 350.0, 8.0, 15.0
    R = r1 * r2 / (r1 + r2)
    _, b, p0 = weber_contact(np.array([f]), R, 3.0, 4.0, m, 1.0)
    ref = hertz_line(f, r1, r2, m.E, m.nu)
    assert p0[0] == pytest.approx(ref.p0, rel=1e-12)
    assert b[0] == pytest.approx(ref.b, rel=1e-12)
    # Weber's approach grows less than linearly with the load (the logarithm) and stays finite at zero
    c, _, _ = weber_contact(np.array([0.0, 10.0, 100.0, 1000.0]), R, 3.0, 4.0, m, 1.0)
    d = c * np.array([0.0, 10.0, 100.0, 1000.0])
    assert np.all(np.isfinite(c)) and np.all(np.diff(d) > 0) and np.all(np.diff(c[1:]) < 0)


def test_weber_tangent_is_the_approach_derivative():
    """The Newton step's tangent (AD) against central differences of Weber's approach c(f) f, and its
    compliance equal to weber_contact's; below f_min the approach is linear (tangent = c)."""
    from gearopt.ltca.compliance import weber_tangent

    m = Material(E=210000.0, nu=0.3)
    wt = weber_tangent(m)
    R, h1, h2, fmin = 5.2, 3.0, 4.0, 2.0
    for f in (5.0, 80.0, 900.0):
        c, dc = (float(v) for v in wt(f, R, h1, h2, fmin))
        assert c == pytest.approx(float(weber_contact(np.array([f]), R, h1, h2, m, fmin)[0][0]), rel=1e-14)
        h = 1e-4 * f
        app = [float(weber_contact(np.array([x]), R, h1, h2, m, fmin)[0][0]) * x for x in (f - h, f + h)]
        assert dc == pytest.approx((app[1] - app[0]) / (2 * h), rel=1e-7)
        assert 0 < dc < c  # the logarithm: the tangent is below the secant
    c, dc = (float(v) for v in wt(0.5, R, h1, h2, fmin))
    assert dc == pytest.approx(c, rel=1e-14)


def test_iso6336_reference_values():
    iso = iso6336_stiffness(spur())
    # standard steel spur pair: c' ~ 14, c_gamma ~ 20 N/(mm um) (ISO 6336-1 typical values)
    assert 11 < iso["c_prime"] < 16 and 16 < iso["c_gamma_alpha"] < 22
    q = 0.04723 + 0.15551 / 20 + 0.25791 / 40
    assert iso["q_prime"] == pytest.approx(q, rel=1e-12)


# --- zero load: the unloaded TCA ---------------------------------------------------------------
@pytest.mark.parametrize("make, mis", [(crowned, Misalignment(crossing=3 * ARCMIN)), (helical, Misalignment()),
                                       (crowned, Misalignment(intersecting=2 * ARCMIN, dE=0.02))],
                         ids=["crowned-crossing", "helical", "crowned-intersecting"])
def test_zero_torque_gives_the_unloaded_tca(make, mis):
    """At (nearly) zero torque the loaded TE is the unloaded TCA's, up to the sampling of a point contact
    by slices fixed to the tooth (docs/ltca.md section 1): between two slices the TE falls below its
    peak by at most the crowning's sagitta over half a slice spacing, ``a_pl (h/2)^2 sin(alpha_n)``
    along the normal (over ``r_b2 cos(beta_b)`` in angle); the TE zero (phi1 = 0) is sampled too, so
    the two curves may differ by twice that. Checked at 11 and 41 slices (the bound falls by 16)."""
    pair = make()
    tca = TCA(pair)
    g1, g2 = pair.pinion, pair.gear
    for n in (11, 41):
        L = LTCA(pair, n_slices=n)
        phi = L.mesh_cycle(24)
        res = L.solve(1e-7, phi1=phi, mis=mis).results[0]
        ref = tca.sweep(phi, mis=mis, pairs=L.default_pairs())
        on = np.isfinite(ref.te_envelope_arcsec)
        assert on.sum() >= 12
        h = g1.b / (n - 1)
        bound = 2 * g1.a_pl * (h / 2) ** 2 * np.sin(g1.rack.alpha_n) / (g2.r_b * np.cos(g2.beta_b)) * RAD_TO_ARCSEC
        d = np.max(np.abs(res.te_loaded_arcsec[on] - ref.te_envelope_arcsec[on]))
        assert d < bound + 1e-6, f"{n} slices: zero-load TE {d:.4g} arcsec off the TCA's (bound {bound:.4g})"


def test_conjugate_spur_unloaded_te_is_zero_and_loaded_te_negative(spur_sweep):
    L, sw = spur_sweep
    assert np.max(np.abs(sw.slices.te_unloaded)) * RAD_TO_ARCSEC < 1e-6
    for r in sw.results[1:]:
        assert np.all(r.te_loaded < 0)
    # more torque, more deflection, at every position
    assert np.all(sw.results[2].te_loaded < sw.results[1].te_loaded)


# --- the contact problem ------------------------------------------------------------------------
def test_contact_conditions_and_an_independent_qp_solver(spur_sweep):
    """Loads >= 0, gaps >= 0 and complementary, sum = W, checked here from the compliance law; and the
    QP of one position solved again by scipy (SLSQP) from the same matrices gives the same loads."""
    from scipy.optimize import minimize

    L, sw = spur_sweep
    S, st = sw.slices, sw.structure
    r = sw.results[2]
    K, N, M = S.z.shape
    lever = L.pair.gear.r_b * L.cos_bb
    for j in (3, 16):
        act = S.active[:, j, :].ravel()
        s = ((S.te_unloaded[j] - S.te[:, j, :]) * lever).ravel()[act]
        F = r.load[:, j, :].ravel()[act]
        length = st.length[:, j, :].ravel()[act]
        cH, _, _ = weber_contact(F / length, st.R[:, j, :].ravel()[act], st.h1[:, j, :].ravel()[act],
                                 st.h2[:, j, :].ravel()[act], L.material, 1e-3 * r.W * L.cos_bb / L.pair.pinion.b)
        C = st.Cs[j][np.ix_(np.flatnonzero(act), np.flatnonzero(act))] + np.diag(cH / length)
        gap = s + C @ F - r.delta[j]
        assert F.sum() == pytest.approx(r.W, rel=1e-9)
        assert F.min() >= 0
        assert gap.min() > -1e-8
        assert np.max(np.abs(F * gap)) / r.W < 1e-9
        # the same QP (compliance frozen at the solution) by an independent method
        x0 = np.full(F.size, r.W / F.size)
        sol = minimize(lambda x: 0.5 * x @ C @ x + s @ x, x0, jac=lambda x: C @ x + s, method="SLSQP",
                       bounds=[(0, None)] * F.size, constraints=[{"type": "eq", "fun": lambda x: x.sum() - r.W,
                                                                  "jac": lambda x: np.ones_like(x)}],
                       options={"ftol": 1e-14, "maxiter": 500})
        assert np.max(np.abs(sol.x - F)) / r.W < 1e-4


def test_spur_load_sharing_and_hertz_pressure(spur_sweep):
    L, sw = spur_sweep
    r = sw.results[2]
    S = sw.slices
    share = r.share
    assert np.allclose(share.sum(axis=0), 1.0, atol=1e-9)
    single = (share.max(axis=0) > 1 - 1e-9)
    single0 = (sw.results[0].share.max(axis=0) > 1 - 1e-9)
    assert 0.3 < single0.mean() < 0.42  # unloaded: eps_alpha = 1.64, about 36 % single-pair contact
    # under load the tip edges touch before the next flank contact starts (premature contact of
    # unrelieved teeth): the single-pair zone shrinks but remains
    assert 0.0 < single.mean() < single0.mean()
    # single-pair contact of a conjugate spur pair: uniform line load W/b, the Hertz pressure of the
    # involute radii there (independent formula)
    j = int(np.flatnonzero(single)[len(np.flatnonzero(single)) // 2])
    k = int(np.argmax(share[:, j]))
    i = int(np.nanargmin(np.abs(S.z[k, j])))
    rad1 = sw.structure.radius1[k, j, i]
    rad2 = sw.structure.radius2[k, j, i]
    g1, g2 = L.pair.pinion, L.pair.gear
    ref = hertz_line(r.W / g1.b, math.sqrt(rad1**2 - g1.r_b**2), math.sqrt(rad2**2 - g2.r_b**2), L.material.E,
                     L.material.nu)
    assert r.line_load[k, j, i] == pytest.approx(r.W / g1.b, rel=1e-6)
    assert r.p0[k, j, i] == pytest.approx(ref.p0, rel=1e-6)


def test_spur_mesh_stiffness_near_iso6336(spur_sweep):
    """The mean mesh stiffness of a standard steel spur pair lies within 15 % of ISO 6336-1's
    c_gamma_alpha (the gap is stated in docs/ltca.md)."""
    L, sw = spur_sweep
    iso = iso6336_stiffness(L.pair)
    cg = sw.results[2].c_gamma
    assert 0.85 < cg / iso["c_gamma_alpha"] < 1.15


def test_crowned_pattern_widens_with_load_and_pressure_follows_hertz_scaling():
    L = LTCA(crowned(), n_slices=21)
    sw = L.solve([50.0, 200.0], phi1=[0.0])
    lo, hi = sw.results
    n_lo = (lo.load > 0).sum()
    n_hi = (hi.load > 0).sum()
    assert n_hi > n_lo  # the contact ellipse grows across the face
    # point contact: p0 ~ W^(1/3) (Hertz); the slice model follows within a few percent
    ratio = hi.p_max / lo.p_max
    assert ratio == pytest.approx(4 ** (1 / 3), rel=0.08)


def test_helical_pairs_share_the_load_and_te_is_smaller_than_spur():
    L = LTCA(helical(), n_slices=11)
    r = L.solve(150.0, phi1=L.mesh_cycle(24)).results[0]
    assert (r.share > 0.01).sum(axis=0).min() >= 2  # always two or more pairs (eps_gamma > 2)
    Ls = LTCA(spur(), n_slices=11)
    rs = Ls.solve(150.0, phi1=Ls.mesh_cycle(24)).results[0]
    assert r.peak_to_peak_arcsec < 0.5 * rs.peak_to_peak_arcsec


def test_tip_edge_slices_close_beyond_the_contact_line_and_carry_load_only_under_it():
    # unmodified helical pair at three pairs in mesh: the contact lines of pairs -1 and +1 leave the
    # flanks at a tip; beyond, the tip edges are slices (pinion tip: edge 1, gear tip: edge 2)
    pair = GearPair(Gear(z=21, m_n=2.5, b=24.0, beta=15 * DEG), Gear(z=45, m_n=2.5, b=24.0, beta=15 * DEG,
                                                                     hand="left"))
    L = LTCA(pair)
    S = L.slices(phi1=np.array([0.0]))
    assert {1, 2} <= set(np.unique(S.edge[S.active]).tolist())
    g1, g2 = pair.pinion, pair.gear
    lever = g2.r_b * math.cos(g1.beta_b)
    for k in range(len(S.pairs)):
        e = S.edge[k, 0]
        on = S.active[k, 0] & (e > 0)
        if not on.any():
            continue
        # the edge point is on its tip and on the mating flank inside its limits
        tip = g1 if e[on][0] == 1 else g2
        r_own = S.r1 if e[on][0] == 1 else S.r2
        assert np.allclose(np.hypot(r_own[k, 0, on, 0], r_own[k, 0, on, 1]), tip.r_a, atol=1e-7)
        # separations: >= 0, zero only at the end of the contact line, growing away from it (convex flanks)
        sep = (S.te_unloaded[0] - S.te[k, 0, on]) * lever
        z = S.z[k, 0, on]
        flank = S.active[k, 0] & (S.edge[k, 0] == 0)
        z_end = S.z[k, 0, flank]
        d = np.min(np.abs(z[:, None] - z_end[None, :]), axis=1)
        order = np.argsort(d)
        assert np.all(sep > -1e-9) and np.all(np.diff(sep[order]) > 0)
    # the unloaded TE is the flank contact's (the edges do not touch at zero load) ...
    flank_only = np.max(np.where(S.active & (S.edge == 0), S.te, -np.inf))
    assert S.te_unloaded[0] == flank_only
    # ... and under load the edges next to the contact lines close
    light, heavy = L.solve([1.0, 400.0], slices=S).results
    edge_load = lambda r: float(np.sum(np.where(S.edge > 0, r.load, 0.0)))  # noqa: E731
    assert edge_load(light) == 0.0 and edge_load(heavy) > 0.01 * heavy.W
    assert heavy.kkt_error.max() < 1e-7


@pytest.mark.parametrize("guess", [0.0, 1e6])
def test_tip_edge_working_set_gives_the_full_qp(monkeypatch, guess):
    # the first QP round's set of tip edges only changes how many rounds it takes: none (0: every edge
    # is found by the gap check and added) or all of them (1e6: the full QP at once) give the same loads
    import gearopt.ltca.engine as engine

    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    L = LTCA(pair, n_slices=11)
    S = L.slices(phi1=L.mesh_cycle(16))
    ref = L.solve(300.0, slices=S).results[0]
    assert np.sum(np.where(S.edge > 0, ref.load, 0.0)) > 0.01 * ref.W  # edges carry load here
    monkeypatch.setattr(engine, "EDGE_GUESS", guess)
    r = L.solve(300.0, slices=S).results[0]
    assert np.max(np.abs(r.load - ref.load)) < 1e-6 * ref.W
    assert r.kkt_error.max() < 1e-7


# --- bad input ----------------------------------------------------------------------------------
@pytest.mark.parametrize("torque", [0.0, -5.0, float("nan"), [10.0, 5.0], [10.0, 10.0], "100", []])
def test_bad_torques_name_the_parameter(spur_sweep, torque):
    L, sw = spur_sweep
    with pytest.raises(OptionError) as e:
        L.solve(torque, slices=sw.slices)
    assert e.value.param == "torque"


@pytest.mark.parametrize("kw, param", [({"E": 206.0}, "E"), ({"E": float("nan")}, "E"), ({"nu": 0.5}, "nu"),
                                       ({"nu": -0.1}, "nu")])
def test_bad_material_names_the_parameter(kw, param):
    with pytest.raises(GeometryError) as e:
        Material(**kw)
    assert e.value.param == param


def test_bad_options_and_positions_without_contact():
    with pytest.raises(OptionError) as e:
        LTCA(spur(), n_slices=2)
    assert e.value.param == "n_slices"
    with pytest.raises(GeometryError) as e:
        LTCA(spur(), r_int=(15.0, 80.0))
    assert e.value.param == "gear.r_int"
    L = LTCA(spur(), n_slices=5)
    with pytest.raises(ConvergenceError):
        L.solve(100.0, phi1=[0.0, 1.0], pairs=(0,))  # phi1 = 1 rad: tooth 0 is far out of mesh


# --- FE influence coefficients (CalculiX) ---------------------------------------------------------
_needs_ccx = pytest.mark.skipif(__import__("shutil").which("ccx") is None, reason="CalculiX (ccx) is not installed")


@pytest.fixture(scope="module")
def fe_cache(tmp_path_factory):
    return tmp_path_factory.mktemp("gearopt_cache")


def _coarse_member_mesh():
    from gearopt.fea.mesh import MeshOptions
    return MeshOptions(n_face=2, n_half=3, n_flank=4, n_fillet=3, n_rim=2)


@pytest.mark.slow
@pytest.mark.calculix
@_needs_ccx
def test_influence_coefficients_are_a_compliance_and_are_cached(fe_cache, monkeypatch):
    import json
    import os
    import subprocess
    import sys

    from gearopt.fea.influence import influence_grid
    from gearopt.geometry.generation import generate

    monkeypatch.setenv("GEAROPT_CACHE", str(fe_cache))
    # the pinion's grid as LTCA(spur(), compliance="fe") asks for it (its form radius as r_form): the
    # same cache entry, so test_loaded_tca_with_fe_compliance below reads it instead of running ccx again
    tooth = generate(spur().pinion)
    r_form = TCA(spur()).form_radius(1)
    ig = influence_grid(tooth, mesh=_coarse_member_mesh(), r_form=r_form)
    assert not ig.cached
    nr, nz = ig.radius.size, ig.z.size
    G = ig.G.reshape(nr * nz, nr * nz)
    assert np.allclose(G, G.T) and np.linalg.eigvalsh(G).min() > 0
    assert ig.asymmetry < 0.08  # Maxwell reciprocity nearly holds at the response point (15 % at the row's middle node)
    # a load higher on the tooth bends it more (mid face)
    diag = [ig.G[i, nz // 2, i, nz // 2] for i in range(nr)]
    assert np.all(np.diff(diag) > 0)
    # the same order as the analytical model's tooth pair compliance per unit width / face width
    assert 1e-7 < diag[nr // 2] < 1e-4
    # the response point lies at Weber's depth: the analytical distance from the flank point along its
    # normal to the tooth's centreline (ToothCompliance, from the generated profile alone)
    from gearopt.ltca.compliance import Material, ToothCompliance

    tc = ToothCompliance(tooth, Material(E=206000.0, nu=0.3), r_int=0.5 * tooth.gear.r_f)
    surf = tooth.surface("right", "flank")
    xy, nxy = [], []
    for r in ig.radius:
        out = surf(tooth.u_at_radius(min(r, tooth.gear.r_a - 1e-9), 0.0, "right", tooth.p0), 0.0, tooth.p0)
        pt, nv = out[0], out[1]
        xy.append(np.asarray(pt).ravel()[:2])
        nxy.append(np.asarray(nv).ravel()[:2])
    h = tc.per_width(np.array(xy), np.array(nxy)).h
    assert ig.depth.shape == (nr, nz)
    # (a spur tooth's middle line is its symmetry axis, so both are the same construction; the middle
    # node of the same row lies 0.2-15 % nearer, from root to tip)
    assert np.allclose(ig.depth[:, nz // 2], h, rtol=1e-6), (ig.depth[:, nz // 2], h)
    again = influence_grid(tooth, mesh=_coarse_member_mesh(), r_form=r_form)
    assert again.cached and np.array_equal(again.G, ig.G) and np.array_equal(again.depth, ig.depth)
    # a new process reads the cache (no CalculiX run)
    code = ("import json; from gearopt.gears import Gear; from gearopt.geometry.generation import generate; "
            "from gearopt.fea.influence import influence_grid; from gearopt.fea.mesh import MeshOptions; "
            "ig = influence_grid(generate(Gear(z=20, m_n=3.0, b=20.0)), mesh=MeshOptions(n_face=2, "
            f"n_half=3, n_flank=4, n_fillet=3, n_rim=2), r_form={r_form!r}); "
            "print(json.dumps([ig.cached, float(ig.G.sum())]))")
    env = dict(os.environ, GEAROPT_CACHE=str(fe_cache), PATH="/nonexistent",
               PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    cached, total = json.loads(out.stdout.strip().splitlines()[-1])
    assert cached and total == pytest.approx(float(ig.G.sum()), rel=1e-12)


@pytest.mark.slow
@pytest.mark.calculix
@_needs_ccx
def test_loaded_tca_with_fe_compliance(fe_cache, monkeypatch):
    """Loaded TCA on the members' FE influence grids (the pinion's from the module's cache where the
    test above ran: the same call): geometry alone at zero load, a KKT point under load, a mesh
    stiffness of the analytical model's order."""
    monkeypatch.setenv("GEAROPT_CACHE", str(fe_cache))
    pair = spur()
    La = LTCA(pair, n_slices=11)
    Lf = LTCA(pair, n_slices=11, compliance="fe", fe_mesh=_coarse_member_mesh())
    phi = La.mesh_cycle(16)
    ra, rf = (L.solve([1e-7, 200.0], phi1=phi).results for L in (La, Lf))
    assert np.max(np.abs(rf[0].te_loaded_arcsec - ra[0].te_loaded_arcsec)) < 1e-6  # zero load: geometry only
    assert rf[1].kkt_error.max() < 1e-7
    assert 0.6 < rf[1].c_gamma / ra[1].c_gamma < 1.8
    with pytest.raises(OptionError) as e:
        LTCA(pair, compliance="beam")
    assert e.value.param == "compliance"


def test_slice_curvature_is_the_flank_surface_s():
    """The Hertz term's curvature of each flank (SliceSet.kappa1/2, by AD of the surface): the
    involute helicoid's cos(beta_b) / rho_t exactly on unmodified spur and helical flanks; on a
    profile-crowned pinion (rack a_c) the curvature of the generated transverse profile, measured
    independently by the circle through three neighbouring profile points."""
    from gearopt.geometry.generation import generate

    for pair in (spur(), GearPair(Gear(z=21, m_n=2.5, b=24.0, beta=math.radians(15), name="pinion"),
                                  Gear(z=45, m_n=2.5, b=24.0, beta=math.radians(15), hand="left", name="gear"))):
        L = LTCA(pair, n_slices=5)
        S = L.slices(phi1=np.array([-0.1, 0.0, 0.1]), pairs=(0,))
        ok = S.active & (S.edge == 0)
        cb = math.cos(pair.pinion.beta_b)
        for k, r, g in ((S.kappa1, S.r1, pair.pinion), (S.kappa2, S.r2, pair.gear)):
            rho_t = np.sqrt(np.hypot(r[..., 0], r[..., 1]) ** 2 - g.r_b**2)
            assert ok.sum() >= 9 and np.allclose(k[ok], cb / rho_t[ok], rtol=1e-9)
    pair = spur(rack=BasicRack.iso53("A", a_c=2e-3))
    L = LTCA(pair, n_slices=5)
    S = L.slices(phi1=np.array([-0.15, 0.0, 0.15]), pairs=(0,))
    tooth = generate(pair.pinion)
    f = tooth.surface("right", "flank")
    ok = np.flatnonzero((S.active & (S.edge == 0) & (np.abs(S.z) < 1e-9)).ravel())
    assert ok.size >= 3
    for i in ok:
        u = S.u1.ravel()[i]
        P = [np.asarray(f(u + d, 0.0, tooth.p0)[0]).ravel()[:2] for d in (-1e-3, 0.0, 1e-3)]
        a, b, c = (np.linalg.norm(P[1] - P[0]), np.linalg.norm(P[2] - P[1]), np.linalg.norm(P[2] - P[0]))
        d1, d2 = P[1] - P[0], P[2] - P[0]
        area = 0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0])
        kappa_fd = 4 * area / (a * b * c)  # 1 / circumradius
        rho_t = math.sqrt(np.hypot(*P[1]) ** 2 - pair.pinion.r_b**2)
        assert S.kappa1.ravel()[i] == pytest.approx(kappa_fd, rel=1e-4)
        assert S.kappa1.ravel()[i] > 1.02 / rho_t  # profile crowning: more curved than the involute
    # the Hertz pressure follows: higher on the more curved flank than with the involute's curvature
    p_s, p_i = (LTCA(pair, n_slices=5, curvature=c).solve(200.0, slices=S).results[0].p_max
                for c in ("surface", "involute"))
    assert p_s > 1.005 * p_i
    with pytest.raises(OptionError) as e:
        LTCA(pair, curvature="principal")
    assert e.value.param == "curvature"


@pytest.mark.slow
@pytest.mark.calculix
@_needs_ccx
def test_local_compression_of_the_tooth_section():
    """The plane-strain FE model of the tooth section under a Hertz strip reproduces the half-space's
    logarithm: its excess over Weber's term, kappa, stays put while the strip width (and Weber's
    bracket, by ln(8/3) = 0.98) changes; the finite section is softer than a half-space to the same
    depth (kappa > 0), by about what the 3-D contact model's split says (docs/ltca.md section 5: flank
    minus C 3.30 um against Weber's 3.07 um at h 2.44 mm, b_H 0.164 mm: kappa about 0.2-0.24). A strip that
    does not fit on the flank is refused."""
    from gearopt.fea.local import local_excess, section_compression, section_tooth
    from gearopt.geometry.generation import generate

    g = Gear(z=20, m_n=3.0, b=20.0, name="pinion")
    tooth = generate(g)
    r = [section_compression(tooth, g.r_p, b * g.m_n, 210000.0, 0.3) for b in (0.03, 0.08)]
    assert 0.15 < r[0]["kappa"] < 0.35
    assert abs(r[0]["kappa"] - r[1]["kappa"]) < 0.05
    for x in r:  # the compression is Weber's plus kappa: FE / Weber of the size measured in docs/ltca.md
        assert x["local"] > x["weber"] > 0 and abs(x["h"] - g.s_at(g.r_p) / 2 / math.cos(g.rack.alpha_n)) < 0.1
    with pytest.raises(GeometryError) as e:
        section_compression(tooth, g.r_a - 0.01, 0.15)
    assert e.value.param == "radius"
    with pytest.raises(GearoptError) as e:
        local_excess(tooth, [g.r_p], b_rel=0.5, use_cache=False)
    assert e.value.param == "b_rel"
    # a helical member's section: the virtual spur gear of its normal section
    h = Gear(z=21, m_n=2.5, b=24.0, beta=math.radians(15), name="pinion")
    vt, dr = section_tooth(generate(h))
    beta_b = math.asin(math.sin(h.beta) * math.cos(h.rack.alpha_n))
    assert vt.gear.is_spur and vt.gear.z == round(21 / (math.cos(beta_b) ** 2 * math.cos(h.beta)))
    assert vt.gear.m_n == h.m_n and dr == pytest.approx(vt.gear.m_n * vt.gear.z / 2 - h.r_p, abs=1e-12)


@pytest.mark.calculix
@_needs_ccx
def test_local_excess_is_cached_per_section_not_per_design():
    """The section model sees the member's mid-face transverse (spur) or normal (helical) section:
    designs that differ only in face width, lengthwise crowning or flank modifications share one
    cache entry; a different section (profile crowning of the rack, profile shift, helix angle) does
    not. The crowned spur's section is generated without its lengthwise crowning."""
    import math

    from gearopt.fea.local import _key, section_tooth
    from gearopt.geometry.generation import generate
    from gearopt.geometry.microgeometry import Microgeometry

    r = [29.0, 30.0]
    key = lambda g: _key(generate(g), r, 210000.0, 0.3, 0.05, 8.0, 24)  # noqa: E731
    rack = BasicRack.iso53("A", a_c=2e-3)
    base = Gear(z=20, m_n=3.0, b=20.0, rack=rack)
    assert key(base) == key(Gear(z=20, m_n=3.0, b=25.0, a_pl=2e-3, rack=rack,
                                 modifications=Microgeometry(C_alpha_a=0.02, d_Ca=62.0)))
    assert key(base) != key(Gear(z=20, m_n=3.0, b=20.0, rack=BasicRack.iso53("A")))
    assert key(base) != key(Gear(z=20, m_n=3.0, b=20.0, x=0.2, rack=rack))
    hel = lambda **kw: Gear(z=21, m_n=2.5, b=24.0, **kw)  # noqa: E731
    assert key(hel(beta=math.radians(15))) == key(hel(beta=math.radians(15), a_pl=2e-4))
    assert key(hel(beta=math.radians(15))) != key(hel(beta=math.radians(18)))
    sec, dr = section_tooth(generate(Gear(z=20, m_n=3.0, b=20.0, a_pl=2e-3, rack=rack)))
    assert sec.gear.a_pl == 0.0 and dr == 0.0 and sec.gear.rack == rack


@pytest.mark.slow
@pytest.mark.calculix
@_needs_ccx
def test_fe_compliance_adds_the_local_excess_of_both_members(fe_cache, monkeypatch):
    """At the pitch point (single pair, uniform line load f = W / b) the FE-coefficient model's
    approach with the local excess is the one without it plus 2 (1 - nu^2) / (pi E) (kappa1 + kappa2) f."""
    from dataclasses import replace

    monkeypatch.setenv("GEAROPT_CACHE", str(fe_cache))
    pair = spur()
    mat = Material()
    L = LTCA(pair, n_slices=11, compliance="fe", fe_mesh=_coarse_member_mesh())
    S = L.slices(phi1=np.array([0.0]), pairs=(0,))
    with_k = L.solve(200.0, slices=S).results[0]
    k1, k2 = (float(G.local_excess(r)) for G, r in zip(L.influence, (pair.pinion.r_p, pair.gear.r_p)))
    assert k1 > 0 and k2 > 0
    L.influence = tuple(replace(G, kappa=None) for G in L.influence)
    without = L.solve(200.0, slices=S).results[0]
    f = 200.0e3 / pair.pinion.r_b / pair.pinion.b
    expected = 2 * (1 - mat.nu**2) / (math.pi * mat.E) * (k1 + k2) * f
    assert with_k.delta[0] - without.delta[0] == pytest.approx(expected, rel=0.02)


@pytest.mark.slow
def test_every_slice_lies_on_its_own_gear_revolution():
    """Regression: with strong ISO profile crowning and root relief under a crossing, Newton from the
    conjugate guess landed a few slices a full gear revolution away (phi2 + 2 pi), and the loaded TE
    came out at 1.29e6 arcsec peak-to-peak with no error. Every solved slice's TE must lie within a
    gear pitch of the unloaded TE (a revolution is 2 pi, a pitch 2 pi / z2)."""
    from gearopt.geometry.microgeometry import Microgeometry

    mg = Microgeometry(C_alpha=0.030, C_beta=0.02647154359016748, d_Ca=64.0, C_alpha_f=0.00974013385169146, d_Cf=58.5)
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=mg), Gear(z=40, m_n=3.0, b=20.0))
    L = LTCA(pair, n_slices=15)
    sw = L.solve(200.0, phi1=L.mesh_cycle(24), mis=Misalignment(crossing=2 * ARCMIN))
    S = sw.slices
    pitch2 = 2 * math.pi / pair.gear.z
    te = np.where(S.converged, S.te, 0.0)
    assert np.max(np.abs(te - S.te_unloaded[None, :, None])) < pitch2
    assert sw.results[0].peak_to_peak_arcsec < 60.0


@pytest.mark.slow
def test_relieved_pair_keeps_its_slices_where_newton_stalls():
    """A deep tip relief puts the contact of an approaching pair on the relief's steep smooth start,
    far from the unmodified drive's conjugate guess: plain Newton stalls on every slice of that pair,
    and line-search Newton must take over (else the pair silently drops out and the loaded TE jumps;
    this drive lost pair -1 at C_alpha_a 27 um, 68 arcsec at 300 N m). The pair's slices stay active
    and its separations continuous as the relief deepens through that value. (One loaded TCA, the
    relief amount its parameter ``iso.C_alpha_a``: the same slices, bit for bit, as a loaded TCA built
    for each amount; the first guesses are the unmodified drive's conjugate contact either way.)"""
    from gearopt.geometry.microgeometry import Microgeometry

    phi1 = np.array([-math.pi / 24])
    te, n_act = [], []
    mg = Microgeometry(C_alpha=0.02952, C_beta=0.03247, C_alpha_a=0.0265, C_alpha_f=0.03253, d_Ca=64.0, d_Cf=58.5)
    L = LTCA(GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=mg), Gear(z=40, m_n=3.0, b=20.0)), n_slices=11)
    for c_a in (0.0265, 0.0270, 0.0275):
        p1 = np.array(L.tca.pinion.p0, float)
        p1[L.tca.layout.member_names["pinion"].index("iso.C_alpha_a")] = c_a
        S = L.slices(phi1, p1, pairs=(-1, 0, 1))
        k = S.pairs.index(-1)
        n_act.append(int(S.active[k, 0].sum()))
        te.append(S.te[k, 0, :11] * RAD_TO_ARCSEC)
    assert n_act == [11, 11, 11]
    # the deepest point of the relief moves the contact by microns: separations change smoothly
    assert np.max(np.abs(te[1] - 0.5 * (te[0] + te[2]))) < 0.05
    assert np.max(np.abs(te[2] - te[0])) < 5.0
