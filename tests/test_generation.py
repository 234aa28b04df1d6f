"""Tests of gearopt.geometry.generation against independent analytic geometry.

Every expectation below is computed from textbook formulas written out here (involute polar form,
standard tooth thickness, Litvin's extended involute eq. 10.2.11, the interference point of the
line of action, ...), not from the code under test. Reference formulas used throughout:

* Transverse section of an involute flank (Litvin eqs. 10.2.6-10.2.9): a point at radius ``rad``
  of the right flank has the polar angle (measured from +y towards +x)
  ``theta = s_t/(2 r_p) + inv(alpha_t) - inv(alpha_r)``, ``cos alpha_r = r_b / rad``,
  ``r_b = r_p cos alpha_t``; left flank: ``-theta``. A helix of hand sigma (+1 right) turns the
  section at axial position z by ``-sigma z tan(beta) / r_p``.
* Standard transverse thickness on the reference circle ``s_t = m_t (pi/2 + 2 x tan alpha_n)``.
* Straight rack flank in contact with a gear: the contact point lies on the line of action through
  the pitch point I at the transverse pressure angle; a tool point at height ``h`` below the
  rolling (pitch) line touches at distance ``d = h / sin(alpha_t)`` from I, i.e. at roll angle
  ``phi = (r_p sin alpha_t - d) / r_b`` of the generated involute.
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from gearopt.errors import GeometryError
from gearopt.gears import BasicRack, Gear
from gearopt.geometry.generation import (
    PARAMS,
    Hob,
    Shaper,
    generate_by_hob,
    generate_by_rack,
    generate_by_shaper,
)

DEG = math.pi / 180
SIDES = (("right", 1.0), ("left", -1.0))


# ------------------------------------------------------------------------------------------------
# Independent helpers (numpy / math only)
# ------------------------------------------------------------------------------------------------
def inv(a: float) -> float:
    return math.tan(a) - a


def polar(r) -> tuple[float, float]:
    """Transverse radius and polar angle from +y towards +x."""
    return math.hypot(r[0], r[1]), math.atan2(r[0], r[1])


def involute_theta(g: Gear, rad: float, x: float | None = None) -> float:
    """Polar angle of the right flank of ``g`` (profile shift ``x``) at radius ``rad``, section z = 0."""
    x = g.x if x is None else x
    alpha_n = g.rack.alpha_n
    m_t = g.m_n / math.cos(g.beta)
    r_p = m_t * g.z / 2
    alpha_t = math.atan(math.tan(alpha_n) / math.cos(g.beta))
    r_b = r_p * math.cos(alpha_t)
    assert rad > r_b * (1 + 1e-9), "test point below the base circle"
    s_t = m_t * (math.pi / 2 + 2 * x * math.tan(alpha_n))
    alpha_r = math.atan2(math.sqrt((rad - r_b) * (rad + r_b)), r_b)
    return s_t / (2 * r_p) + inv(alpha_t) - inv(alpha_r)


def sigma(g: Gear) -> float:
    return 0.0 if g.beta == 0 else (1.0 if g.hand == "right" else -1.0)


def ev(f: ca.Function, *args):
    return [np.asarray(v, dtype=float).ravel() for v in f(*args)]


@functools.lru_cache(maxsize=None)
def rack_tooth(z, m_n, x, beta_deg=0.0, hand="right", a_c=0.0, u_0=0.0, a_pl=0.0, undercut=False):
    g = Gear(z=z, m_n=m_n, x=x, beta=beta_deg * DEG, hand=hand, rack=BasicRack.iso53("A", a_c=a_c, u_0=u_0),
             a_pl=a_pl, allow_undercut=undercut)
    return generate_by_rack(g)


@functools.lru_cache(maxsize=None)
def hob_tooth(z, m_n, x, beta_deg=0.0, hand="right", N_h=1, d_p0=60.0):
    g = Gear(z=z, m_n=m_n, x=x, beta=beta_deg * DEG, hand=hand)
    return generate_by_hob(g, Hob(N_h=N_h, d_p0=d_p0))


@functools.lru_cache(maxsize=None)
def shaper_tooth(z, m_n, x, N_s, x_s=0.0):
    return generate_by_shaper(Gear(z=z, m_n=m_n, x=x), Shaper(N_s=N_s, x_s=x_s))


RACK_CASES = [  # (z, m_n, x, beta_deg, hand): no undercut (Gear validates), both hands, x < 0 and > 0
    (20, 3.0, 0.0, 0.0, "right"),
    (13, 2.0, 0.4, 0.0, "right"),
    (40, 5.0, -0.5, 0.0, "right"),
    (18, 3.0, 0.2, 15.0, "right"),
    (30, 2.0, -0.3, 25.0, "left"),
    (11, 4.0, 0.6, 30.0, "left"),
    (23, 2.5, 0.1, 20.0, "right"),
]
SHAPER_CASES = [  # (z, m_n, x, N_s, x_s)
    (20, 3.0, 0.0, 25, 0.0),
    (15, 2.0, 0.3, 12, 0.2),
    (40, 4.0, -0.4, 60, -0.1),
    (17, 3.0, 0.05, 31, 0.35),
]
Z_POSITIONS = (-10.0, -3.3, 0.0, 7.1, 10.0)


def tooth_for(method, case):
    if method == "rack":
        return rack_tooth(*case)
    if method == "hob":
        return hob_tooth(*case)
    return shaper_tooth(*case)


def flank_q_values(T, n=7):
    """Flank coordinates covering the tip region down to (just before) the fillet junction."""
    g = T.gear
    u_f = T.junction()[0]
    if T.method == "shaper":
        N_s, m = T.extras["N_s"], g.m_n
        r_bs = m * N_s / 2 * math.cos(g.rack.alpha_n)
        r_ws = T.extras["a_cut"] * N_s / (N_s + g.z)
        R_lo = max(r_bs * 1.002, r_ws - 1.2 * m)  # shaper radius cutting beyond the gear tip
        q_lo = math.sqrt((R_lo / r_bs) ** 2 - 1)
        return np.linspace(q_lo, u_f * (1 - 1e-9), n)
    return np.linspace(-1.3 * g.m_n, u_f * (1 - 1e-9), n)


ALL_FLANK_CASES = ([("rack", c) for c in RACK_CASES] + [("hob", c) for c in RACK_CASES[::2]]
                   + [("shaper", c) for c in SHAPER_CASES])


# ------------------------------------------------------------------------------------------------
# 1. Generated flanks are the analytic involute (helicoid)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("method,case", ALL_FLANK_CASES, ids=lambda v: str(v))
def test_flank_is_involute_of_standard_thickness(method, case):
    T = tooth_for(method, case)
    g = T.gear
    alpha_t = math.atan(math.tan(g.rack.alpha_n) / math.cos(g.beta))
    m_t = g.m_n / math.cos(g.beta)
    r_p = m_t * g.z / 2
    r_b = r_p * math.cos(alpha_t)
    for side, s in SIDES:
        F = T.surface(side, "flank")
        for zz in (Z_POSITIONS if method != "shaper" else (-10.0, 0.0, 4.0)):
            for q in flank_q_values(T):
                r, n, psi = ev(F, q, zz, T.p0)[:3]
                rad, th = polar(r)
                expected = s * involute_theta(g, rad) - sigma(g) * zz * math.tan(g.beta) / r_p
                assert abs(r[2] - zz) < 1e-12
                assert abs(th - expected) * rad < 1e-10, (side, zz, q, (th - expected) * rad)
                if method != "shaper":
                    # u -> point mapping: the tool point at height u cos(alpha_n) - x m_n below the
                    # rolling line touches on the line of action at roll angle phi (module docstring).
                    h = q * math.cos(g.rack.alpha_n) - g.x * g.m_n
                    phi = (r_p * math.sin(alpha_t) - h / math.sin(alpha_t)) / r_b
                    assert abs(rad - r_b * math.hypot(1.0, phi)) < 1e-10 * rad


# ------------------------------------------------------------------------------------------------
# 2. Normals: unit, orthogonal to AD tangents, outward (analytic direction on the flank)
# ------------------------------------------------------------------------------------------------
def _tangent_function(F):
    q, z = ca.SX.sym("q"), ca.SX.sym("z")
    p = ca.SX.sym("p", len(PARAMS))
    r = F(q, z, p)[0]
    return ca.Function("tan", [q, z, p], [ca.jacobian(r, q), ca.jacobian(r, z)])


@pytest.mark.parametrize("method,case", ALL_FLANK_CASES[::2] + [("shaper", SHAPER_CASES[1])], ids=lambda v: str(v))
def test_normals_unit_orthogonal_outward(method, case):
    T = tooth_for(method, case)
    g = T.gear
    r_p = g.m_n / math.cos(g.beta) * g.z / 2
    r_b = r_p * math.cos(math.atan(math.tan(g.rack.alpha_n) / math.cos(g.beta)))
    u_f, phi_max = T.junction()
    for side, s in SIDES:
        for seg, qs in (("flank", flank_q_values(T, 5)), ("fillet", np.linspace(0, phi_max, 5))):
            F = T.surface(side, seg)
            Tf = _tangent_function(F)
            for zz in (-6.0, 0.0, 9.0):
                for q in qs:
                    r, n = ev(F, q, zz, T.p0)[:2]
                    r_q, r_z = ev(Tf, q, zz, T.p0)
                    assert abs(np.linalg.norm(n) - 1) < 1e-14
                    assert abs(n @ r_q) < 1e-12 * max(np.linalg.norm(r_q), 1e-3), (side, seg, q)
                    assert abs(n @ r_z) < 1e-12 * np.linalg.norm(r_z)
                    rad, th = polar(r)
                    e_r = np.array([math.sin(th), math.cos(th), 0.0])
                    e_th = np.array([math.cos(th), -math.sin(th), 0.0])
                    if seg == "flank":
                        # Outward normal of the involute helicoid theta = +-(C - inv alpha_r) - sigma z tb/r_p:
                        # grad of s*(theta - theta_flank) ~ tan(alpha_r) e_r + s e_theta + s sigma rad tan(beta)/r_p e_z
                        ta = math.sqrt(rad**2 - r_b**2) / r_b
                        n_exp = ta * e_r + s * e_th + np.array([0, 0, s * sigma(g) * rad * math.tan(g.beta) / r_p])
                        n_exp /= np.linalg.norm(n_exp)
                        assert np.linalg.norm(n - n_exp) < 1e-10, (side, q, zz, n, n_exp)
                    else:
                        # The fillet normal turns from the flank direction to radial: away from the
                        # tooth centre line and out of the material.
                        assert s * (n @ e_th) > -1e-12 and n @ e_r > -1e-12
            # at the pitch point the normal points away from the tooth centre line towards the side
            q_p = 0.0 if T.method != "shaper" else float(T.extras["q_pitch"])
            r, n = ev(T.surface(side, "flank"), q_p, 0.0, T.p0)[:2]
            _, th = polar(r)
            assert s * (n @ np.array([math.cos(th), -math.sin(th), 0.0])) > 0.5


# ------------------------------------------------------------------------------------------------
# 3. Equation of meshing checked on the tool family (independent of the closed-form psi)
# ------------------------------------------------------------------------------------------------
MESH_CASES = [("rack", RACK_CASES[0]), ("rack", RACK_CASES[3]), ("rack", RACK_CASES[4]),
              ("hob", RACK_CASES[5]), ("shaper", SHAPER_CASES[0]), ("shaper", SHAPER_CASES[1])]


@pytest.mark.parametrize("method,case", MESH_CASES, ids=lambda v: str(v))
def test_equation_of_meshing_on_family(method, case):
    T = tooth_for(method, case)
    q, z, ps = ca.SX.sym("q"), ca.SX.sym("z"), ca.SX.sym("psi")
    p = ca.SX.sym("p", len(PARAMS))
    u_f, phi_max = T.junction()
    for side, _ in SIDES:
        for seg, qs in (("flank", flank_q_values(T, 5)), ("fillet", np.linspace(0, phi_max, 5))):
            fam = T.functions[f"{side}_{seg}_family"]
            r_fam, n_fam = fam(q, z, ps, p)
            f = ca.Function("f", [q, z, ps, p], [r_fam, n_fam, ca.jacobian(r_fam, ps)])
            F = T.surface(side, seg)
            for zz in (-5.0, 0.0, 8.0):
                for qq in qs:
                    r, n, psi = ev(F, qq, zz, T.p0)[:3]
                    r1, n1, v = ev(f, qq, zz, psi[0], T.p0)
                    # the family member at the returned psi passes through the surface point
                    assert np.linalg.norm(r1 - r) < 1e-10 and np.linalg.norm(n1 - n) < 1e-12
                    assert abs(v @ n) < 1e-12 * np.linalg.norm(v), (side, seg, qq, v @ n)
                    _, n2, v2 = ev(f, qq, zz, psi[0] + 0.05, T.p0)
                    assert abs(v2 @ n2) > 5e-3 * np.linalg.norm(v2), (side, seg, qq, v2 @ n2)


# ------------------------------------------------------------------------------------------------
# 4. AD Jacobians vs central finite differences; SX-built vs MX-called
# ------------------------------------------------------------------------------------------------
def _stack(F, q, z, p):
    r, n, psi = ev(F, q, z, p)[:3]
    return np.concatenate([r, n, psi])


JAC_CASES = [
    ("rack", dict(z=18, m_n=3.0, x=0.25, beta_deg=15.0, hand="right", a_c=0.002, u_0=0.5, a_pl=1e-3)),
    ("rack", dict(z=25, m_n=2.0, x=-0.2, beta_deg=0.0, a_c=0.004, u_0=-0.3, a_pl=5e-4)),
    ("shaper", dict(z=20, m_n=3.0, x=0.1, N_s=25, x_s=0.1)),
]


@pytest.mark.parametrize("method,kw", JAC_CASES, ids=lambda v: str(v))
def test_ad_jacobians_vs_fd_and_mx(method, kw):
    T = rack_tooth(**kw) if method == "rack" else shaper_tooth(**kw)
    p0 = T.p0
    step_of = {"x": 1e-6, "a_c": 1e-7, "u_0": 1e-6, "a_pl": 1e-7}  # FD steps of p's entries (else 1e-6)
    steps = np.array([1e-6, 1e-5] + [step_of.get(n, 1e-6) for n in PARAMS])  # q, z, p
    qm, zm = ca.MX.sym("q"), ca.MX.sym("z")
    pm = ca.MX.sym("p", len(PARAMS))
    u_f, phi_max = T.junction()
    for side, _ in SIDES:
        for seg, q0 in (("flank", 0.6 * u_f), ("fillet", 0.4 * phi_max)):
            F = T.surface(side, seg)
            # SX AD Jacobian of (r, n, psi) w.r.t. (q, z, p)
            qs, zs = ca.SX.sym("q"), ca.SX.sym("z")
            ps = ca.SX.sym("p", len(PARAMS))
            out = ca.vertcat(*F(qs, zs, ps)[:3])
            J = ca.Function("J", [qs, zs, ps], [ca.jacobian(out, ca.vertcat(qs, zs, ps))])
            z0 = 3.7
            J_ad = np.asarray(J(q0, z0, p0), dtype=float)
            x0 = np.concatenate([[q0, z0], p0])
            J_fd = np.zeros_like(J_ad)
            for k in range(len(x0)):
                e = np.zeros_like(x0)
                e[k] = steps[k]
                hi, lo = x0 + e, x0 - e
                J_fd[:, k] = (_stack(F, hi[0], hi[1], hi[2:]) - _stack(F, lo[0], lo[1], lo[2:])) / (2 * steps[k])
            scale = 1.0 + np.abs(J_ad).max(axis=0)
            assert np.all(np.abs(J_ad - J_fd) <= 1e-6 * scale), (side, seg, np.abs(J_ad - J_fd) / scale)
            # MX call of the SX Function
            out_m = ca.vertcat(*F(qm, zm, pm)[:3])
            G = ca.Function("G", [qm, zm, pm], [out_m, ca.jacobian(out_m, ca.vertcat(qm, zm, pm))])
            val_m, J_m = (np.asarray(v, dtype=float) for v in G(q0, z0, p0))
            assert np.allclose(val_m.ravel(), _stack(F, q0, z0, p0), rtol=0, atol=1e-13)
            assert np.allclose(J_m, J_ad, rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------------------------------------
# 5. Fillet: junction continuity, root circle, offset of the extended involute (trochoid)
# ------------------------------------------------------------------------------------------------
JUNCTION_CASES = [
    ("rack", dict(z=20, m_n=3.0, x=0.0)),
    ("rack", dict(z=18, m_n=3.0, x=0.25, beta_deg=15.0, hand="left")),
    ("rack", dict(z=18, m_n=3.0, x=0.25, beta_deg=15.0, a_c=0.01, u_0=0.3)),
    ("rack", dict(z=30, m_n=2.0, x=-0.2, a_c=0.02, u_0=-0.5, a_pl=2e-3)),
    ("rack", dict(z=9, m_n=2.0, x=0.0, undercut=True)),
    ("shaper", dict(z=20, m_n=3.0, x=0.2, N_s=25, x_s=0.1)),
    ("shaper", dict(z=15, m_n=2.0, x=0.3, N_s=12, x_s=0.2)),
]


@pytest.mark.parametrize("method,kw", JUNCTION_CASES, ids=lambda v: str(v))
def test_fillet_junction_continuity_and_root_circle(method, kw):
    T = rack_tooth(**kw) if method == "rack" else shaper_tooth(**kw)
    g = T.gear
    u_f, phi_max = T.junction()
    if method == "rack":
        r_root = g.r_p + g.m_n * (g.x - g.rack.h_fP)  # tool tip line, independent of profile crowning
    else:
        r_root = T.r_root
    for side, _ in SIDES:
        for zz in (-7.0, 0.0, 10.0):
            r_a, n_a = ev(T.surface(side, "flank"), u_f, zz, T.p0)[:2]
            r_b, n_b = ev(T.surface(side, "fillet"), 0.0, zz, T.p0)[:2]
            assert np.linalg.norm(r_a - r_b) < 1e-10, (side, zz, r_a - r_b)
            assert np.linalg.norm(n_a - n_b) < 1e-10, (side, zz, n_a - n_b)
            r_e, n_e = ev(T.surface(side, "fillet"), phi_max, zz, T.p0)[:2]
            rad, th = polar(r_e)
            assert abs(rad - (r_root - g.a_pl * zz**2)) < 1e-10, (rad, r_root)
            # the fillet ends tangent to the root circle (radial normal)
            n_t = n_e[:2] / np.linalg.norm(n_e[:2])
            assert abs(n_t @ np.array([math.sin(th), math.cos(th)]) - 1) < 1e-12
            # and the root circle is the minimum radius of the fillet
            for phi in np.linspace(0, phi_max, 9)[:-1]:
                assert polar(ev(T.surface(side, "fillet"), phi, zz, T.p0)[0])[0] > rad


@pytest.mark.parametrize("z,m_n,x", [(20, 3.0, 0.0), (12, 2.0, 0.4), (40, 4.0, -0.5), (30, 1.5, 0.2)])
def test_rack_fillet_is_offset_of_extended_involute(z, m_n, x):
    T = rack_tooth(z, m_n, x)
    g, rk = T.gear, T.gear.rack
    a, r_p = rk.alpha_n, g.r_p
    rho = rk.rho_fP * m_n
    # tool tip fillet centre (normal section = transverse for spur): tangent to the tip line
    # eta = -h_fP m and to the flank line through (pi m/4, 0) at the profile angle (inside the tool)
    eta_c = -rk.h_fP * m_n + rho
    xi_c = math.pi * m_n / 4 + (rho - math.sin(a) * eta_c) / math.cos(a)
    y_c = eta_c + r_p + x * m_n  # distance of the centre from the gear axis when under the axis
    h = r_p - y_c  # offset of the traced point from the rolling line, towards the centre
    assert np.allclose(np.asarray(T.functions["junction"](T.p0)[2]).ravel(), [xi_c, eta_c], atol=1e-12)
    u_f, phi_max = T.junction()

    def trochoid(t, sx):
        # Litvin eq. 10.2.11 (extended involute, rolling radius r_p, offset h), turned so that the
        # traced point lies at the polar angle xi_c / r_p when it crosses the line of centres.
        X = (r_p - h) * math.sin(t) - r_p * t * math.cos(t)
        Y = (r_p - h) * math.cos(t) + r_p * t * math.sin(t)
        c, s = math.cos(xi_c / r_p), math.sin(xi_c / r_p)
        return np.array([sx * (X * c + Y * s), -X * s + Y * c])

    ts = np.linspace(-1.0, 1.0, 801)
    for side, sx in SIDES:
        F = T.surface(side, "fillet")
        for phi in np.linspace(0.0, phi_max, 9):
            r, n = ev(F, phi, 2.0, T.p0)[:2]
            P = r[:2]
            d2 = [np.sum((trochoid(t, sx) - P) ** 2) for t in ts]
            k = int(np.argmin(d2))
            res = minimize_scalar(lambda t: np.sum((trochoid(t, sx) - P) ** 2),
                                  bounds=(ts[max(k - 2, 0)], ts[min(k + 2, 800)]), method="bounded",
                                  options={"xatol": 1e-13})
            Q = trochoid(res.x, sx)
            dist = np.linalg.norm(Q - P)
            assert abs(dist - rho) < 1e-9, (side, phi, dist, rho)
            assert abs(n[2]) < 1e-14
            # the gear normal points out of the material, towards the tool fillet centre
            assert np.linalg.norm(n[:2] - (Q - P) / dist) < 1e-7, (side, phi, n, (Q - P) / dist)


# ------------------------------------------------------------------------------------------------
# 6. Undercut: singular point of the generated flank
# ------------------------------------------------------------------------------------------------
def _flank_derivative(T, side="right"):
    u = ca.SX.sym("u")
    r = T.surface(side, "flank")(u, 0.0, T.p0)[0]
    return ca.Function("d", [u], [r, ca.jacobian(r, u)])


@pytest.mark.parametrize("z,x,undercut", [(10, 0.0, True), (14, -0.1, True), (12, 0.2, True), (8, 0.5, True),
                                          (18, 0.0, False), (25, 0.0, False), (12, 0.35, False), (30, -0.7, False)])
def test_undercut_singular_point(z, x, undercut):
    m_n = 2.0
    T = rack_tooth(z, m_n, x, undercut=True)
    g = T.gear
    a = g.rack.alpha_n
    h_lim = g.rack.h_fP - g.rack.rho_fP * (1 - math.sin(a))  # tool flank / tip fillet junction [m_n]
    assert (x < h_lim - z * math.sin(a) ** 2 / 2) == undercut
    r_p = g.r_p
    r_b = r_p * math.cos(a)
    # Interference point: the line of action touches the base circle at T, r_p sin(a) from the pitch
    # point, i.e. r_p sin^2(a) below the rolling line; the tool point there has
    # u cos(a) - x m = r_p sin^2(a).
    u_star = (r_p * math.sin(a) ** 2 + x * m_n) / math.cos(a)
    u_f = T.junction()[0]
    assert (u_star < u_f) == undercut
    for side, _ in SIDES:
        D = _flank_derivative(T, side)
        t0 = ev(D, 0.0)[1]
        # exact speed law of the generated involute: |dr/du| = cot^2(a) |u* - u| / r_b
        for u in np.linspace(-1.2 * m_n, u_f, 11):
            speed = np.linalg.norm(ev(D, u)[1])
            assert abs(speed - abs(u_star - u) / (math.tan(a) ** 2 * r_b)) < 1e-12, (u, speed)
        f = lambda u: float(ev(D, u)[1] @ t0)  # noqa: E731  sign change where the tangent vanishes
        if undercut:
            us = brentq(f, 0.0, u_f, xtol=1e-15, rtol=1e-15)
            r, d = ev(D, us)
            assert np.linalg.norm(d) < 1e-10 * np.linalg.norm(t0)
            assert abs(us - u_star) < 1e-10
            assert abs(math.hypot(r[0], r[1]) - r_b) < 1e-9  # singular point on the base circle
        else:
            us = np.linspace(-1.2 * m_n, u_f, 200)
            vals = np.array([f(u) for u in us])
            assert np.all(vals > 0)
            rads = np.array([polar(ev(D, u)[0])[0] for u in us])
            assert np.all(np.diff(rads) < 0)  # radius decreases monotonically down to the fillet


# ------------------------------------------------------------------------------------------------
# 7. Longitudinal crowning by plunging
# ------------------------------------------------------------------------------------------------
def _u_at_radius(T, side, zz, radius):
    F = T.surface(side, "flank")
    return brentq(lambda u: polar(ev(F, u, zz, T.p0)[0])[0] - radius, -1.5 * T.gear.m_n, 0.9 * T.junction()[0],
                  xtol=1e-14, rtol=1e-15)


@pytest.mark.parametrize("beta_deg,hand", [(0.0, "right"), (20.0, "left")])
def test_plunging_crowning_thickness(beta_deg, hand):
    a_pl = 1.5e-3
    z_t, m_n, x = 21, 3.0, 0.15
    T = rack_tooth(z_t, m_n, x, beta_deg, hand, a_pl=a_pl)
    T0 = rack_tooth(z_t, m_n, x, beta_deg, hand)
    g = T.gear
    alpha_t = math.atan(math.tan(g.rack.alpha_n) / math.cos(g.beta))
    r_p = g.r_p
    # The tool at z is the unplunged tool shifted by -a_pl z^2 (transverse y). Its normal gains only an
    # axial component (dR/dq x dR/dz with dR/dz = (-sigma tan b, -2 a_pl z, 1)): the transverse
    # components are those of the unplunged tool, and the meshing velocity is transverse, so the
    # section at z is EXACTLY the involute of profile shift x - a_pl z^2 / m_n. Hence
    # s_t(z) = s_t(0) - 2 a_pl z^2 tan(alpha_t), exact (no small-tilt error): tolerance 1e-10 mm.
    s_t0 = g.m_t * (math.pi / 2 + 2 * x * math.tan(g.rack.alpha_n))
    for zz in (-10.0, -4.0, 0.0, 3.0, 10.0):
        th = {}
        for side, s in SIDES:
            u = _u_at_radius(T, side, zz, r_p)
            th[side] = polar(ev(T.surface(side, "flank"), u, zz, T.p0)[0])[1]
        s_z = r_p * (th["right"] - th["left"])
        assert abs(s_z - (s_t0 - 2 * a_pl * zz**2 * math.tan(alpha_t))) < 1e-10, (zz, s_z)
        # the whole section is the shifted involute
        x_eff = x - a_pl * zz**2 / m_n
        for side, s in SIDES:
            for u in np.linspace(-m_n, 0.95 * T.junction()[0], 5):
                r = ev(T.surface(side, "flank"), u, zz, T.p0)[0]
                rad, th_ = polar(r)
                exp = s * involute_theta(g, rad, x_eff) - sigma(g) * zz * math.tan(g.beta) / r_p
                assert abs(th_ - exp) * rad < 1e-10
    # without plunging a spur flank is a cylinder: identical transverse sections, axial normal 0
    if beta_deg == 0:
        for side, _ in SIDES:
            for seg, q in (("flank", -1.0), ("flank", 1.5), ("fillet", 0.5)):
                r0, n0 = ev(T0.surface(side, seg), q, 0.0, T0.p0)[:2]
                for zz in (-10.0, 3.0, 10.0):
                    r1, n1 = ev(T0.surface(side, seg), q, zz, T0.p0)[:2]
                    assert np.allclose(r1[:2], r0[:2], atol=1e-13) and abs(r1[2] - zz) < 1e-14
                    assert np.allclose(n1, n0, atol=1e-15) and n1[2] == 0
                # and the plunged surface does depend on z
                r2 = ev(T.surface(side, seg), q, 10.0, T.p0)[0]
                assert np.linalg.norm(r2[:2] - r0[:2]) > 0.05


# ------------------------------------------------------------------------------------------------
# 8. Profile crowning (parabolic rack-cutter)
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("x,u_0", [(0.0, 0.0), (0.0, 1.0), (0.4, 0.0), (0.4, -0.8)])
def test_profile_crowning_deviation(x, u_0):
    """Material removed along the involute normal: delta = a_c (u - u_0)^2 to first order.

    Second order: the crowned tool normal is tilted by eps = 2 a_c (u - u_0), so the contact point
    moves sideways by d*eps from the line of action (d = distance from the pitch point); on a flank of
    curvature radius rho (= r_b tan alpha_r) a tangential displacement s lowers the normal deviation
    by s^2 / (2 rho). Hence delta = a_c (u-u_0)^2 - 2 a_c^2 (u-u_0)^2 d^2 / rho + O(a_c^3); with
    a_c = 1e-3 /mm the third-order rest is < 4 % of the second-order term (scales with a_c), so
    10 % of the second-order term is the tolerance (plus 1e-12 mm round-off).
    """
    a_c, z, m_n = 1e-3, 20, 3.0
    T = rack_tooth(z, m_n, x, a_c=a_c, u_0=u_0)
    g = T.gear
    a = g.rack.alpha_n
    r_p = g.r_p
    r_b = r_p * math.cos(a)
    for side, s in SIDES:
        F = T.surface(side, "flank")
        for u in (-2.5, -1.0, u_0, 0.5, 1.7, 2.5):
            r = ev(F, u, 0.0, T.p0)[0]
            rad, th = polar(r)
            delta = r_b * (involute_theta(g, rad) - s * th)  # distance along the normal (base tangent)
            d = (u * math.cos(a) - x * m_n) / math.sin(a)
            rho = r_p * math.sin(a) - d
            e1 = a_c * (u - u_0) ** 2
            e2 = e1 - 2 * a_c**2 * (u - u_0) ** 2 * d**2 / rho
            if u == u_0:
                assert abs(delta) < 1e-12
                continue
            assert delta > 0  # material removed
            assert abs(delta - e2) <= 0.1 * abs(e1 - e2) + 1e-12, (side, u, delta, e1, e2)
            assert abs(delta - e1) <= 0.05 * e1  # the leading-order statement itself


# ------------------------------------------------------------------------------------------------
# 9. Shaper
# ------------------------------------------------------------------------------------------------
def _shaper_cut_distance(m, N_s, N_2, x_sum, alpha):
    theta = inv(alpha) + 2 * math.tan(alpha) * x_sum / (N_s + N_2)
    a_w = brentq(lambda t: inv(t) - theta, 1e-6, 1.4, xtol=1e-16, rtol=1e-15)
    return m * (N_s + N_2) / 2 * math.cos(alpha) / math.cos(a_w)


@pytest.mark.parametrize("case", SHAPER_CASES)
def test_shaper_root_radius(case):
    z, m_n, x, N_s, x_s = case
    T = shaper_tooth(*case)
    a_cut = _shaper_cut_distance(m_n, N_s, z, x + x_s, 20 * DEG)
    r_as = m_n * N_s / 2 + m_n * (1.25 + x_s)
    assert abs(T.r_root - (a_cut - r_as)) < 1e-10
    phi_max = T.junction()[1]
    for side, _ in SIDES:
        r = ev(T.surface(side, "fillet"), phi_max, 1.0, T.p0)[0]
        assert abs(polar(r)[0] - (a_cut - r_as)) < 1e-10
    if x + x_s == 0:
        assert abs(T.r_root - T.gear.r_f) < 1e-10


def _fillet_angle_at(T, radius, side="right"):
    F = T.surface(side, "fillet")
    phi_max = T.junction()[1]
    phi = brentq(lambda ph: polar(ev(F, ph, 0.0, T.p0)[0])[0] - radius, 0.0, phi_max, xtol=1e-15, rtol=1e-15)
    return polar(ev(F, phi, 0.0, T.p0)[0])[1]


def test_shaper_fillet_converges_to_rack_fillet():
    z, m_n, x = 20, 3.0, 0.2
    TR = rack_tooth(z, m_n, x)
    dists = []
    for N_s in (20, 80, 320, 1280):
        TS = shaper_tooth(z, m_n, x, N_s, 0.1)
        d = 0.0
        for side, _ in SIDES:
            for radius in (TR.gear.r_f + 0.1 * m_n, TR.gear.r_f + 0.3 * m_n):
                d = max(d, abs(_fillet_angle_at(TS, radius, side) - _fillet_angle_at(TR, radius, side)) * radius)
        dists.append(d)
    assert dists[0] > 0.01 * m_n  # clearly a different fillet for a small shaper
    for d0, d1 in zip(dists, dists[1:]):
        assert 3.0 < d0 / d1 < 5.0, dists  # ~ 1/N_s
    assert dists[-1] < 1e-3 * m_n


def test_shaper_rejects_crowned():
    # (helical gears are cut by helical shapers: tests/test_tools.py)
    with pytest.raises(GeometryError):
        generate_by_shaper(Gear(z=20, m_n=3.0, a_pl=1e-3))
    with pytest.raises(GeometryError):
        generate_by_shaper(Gear(z=20, m_n=3.0, rack=BasicRack(a_c=1e-3)))


# ------------------------------------------------------------------------------------------------
# 10. Hob
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("N_h,d_p0", [(1, 60.0), (2, 80.0)])
def test_hob_rotation_and_lead_angle(N_h, d_p0):
    z, m_n = 23, 2.5
    T = hob_tooth(z, m_n, 0.1, 20.0, "right", N_h, d_p0)
    u_f, phi_max = T.junction()
    for side, _ in SIDES:
        for seg, q in (("flank", -1.0), ("flank", 0.7 * u_f), ("fillet", 0.5 * phi_max)):
            r, n, psi, phi_h = ev(T.surface(side, seg), q, 4.0, T.p0)
            assert abs(psi[0]) > 1e-3
            assert abs(phi_h[0] - z / N_h * psi[0]) < 1e-12 * abs(phi_h[0])  # Litvin eq. 10.3.4
    # lead angle: normal pitch pi m_n, axial pitch pi m_n / cos(lam), lead N_h * axial pitch,
    # tan(lam) = lead / (pi d_p0)
    lam = T.extras["lead_angle"]
    assert abs(math.tan(lam) - N_h * math.pi * m_n / math.cos(lam) / (math.pi * d_p0)) < 1e-14
    assert abs(lam - math.asin(N_h * m_n / d_p0)) < 1e-15
    assert abs(Hob(N_h=N_h, d_p0=d_p0).lead_angle(m_n) - lam) == 0
