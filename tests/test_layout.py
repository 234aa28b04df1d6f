"""Named parameter layout of the TCA graph (gearopt.meshing.layout), the misalignment kinds defined in
one place (gearopt.meshing.misalignment) and the shared rotations (gearopt.geometry.frames).

Oracles: the positional layout the TCA used before the names (``prm = (phi1, p1, p2, mis, z_section)``
with ``mis = (dE, crossing, intersecting, axial)``, written out here by hand), the tests' own rotation
matrices (conftest), and finite differences of TCA sweeps.
"""

import math

import casadi as ca
import numpy as np
import pytest

from conftest import Rx, Ry, Rz  # noqa: E402  (the tests' own rotation matrices)
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.geometry.frames import rot_x, rot_y, rot_z, rot_z_points
from gearopt.geometry.generation import PARAMS
from gearopt.meshing.layout import ParamLayout
from gearopt.meshing.misalignment import Misalignment
from gearopt.meshing.tca import TCA
from gearopt.units import ARCMIN

DEG = math.pi / 180
OLD_MIS = ("dE", "crossing", "intersecting", "axial")  # the positional order before the names


def _pair(a_c=0.004, a_pl=0.003):
    p = Gear(z=17, m_n=2.5, b=25, beta=15 * DEG, hand="right", rack=BasicRack(a_c=a_c), a_pl=a_pl, name="pinion")
    g = Gear(z=43, m_n=2.5, b=25, beta=15 * DEG, hand="left", name="gear")
    return GearPair(p, g)


@pytest.fixture(scope="module")
def tca():
    return TCA(_pair())


def test_names_round_trip_and_cover_every_row_once():
    lay = ParamLayout(PARAMS, PARAMS)
    assert lay.names[0] == "phi1" and lay.names[-1] == "z_section"
    rows = np.concatenate([np.arange(lay.size)[lay.slice(n)] for n in lay.names])
    assert sorted(rows.tolist()) == list(range(lay.size))  # every row named once
    assert [lay.names[i] for i in range(lay.size)] == [lay.names[lay.index(n)] for n in lay.names]
    for g in ("pinion", "gear", "mis"):
        sl = lay.slice(g)
        assert [n.split(".", 1)[1] for n in lay.names[sl]] == list(lay.member_names.get(g, Misalignment.names()))
    # pack by name -> unpack by name
    rng = np.random.default_rng(3)
    vals = {n: float(rng.normal()) for n in lay.names if n != "phi1"}
    P = lay.pack([0.1, -0.2], vals)
    got = lay.unpack(P[:, 1])
    assert got["phi1"] == -0.2 and all(got[n] == v for n, v in vals.items())
    # symbolic construction: the named pieces land in their rows
    sym = lay.symbols(ca.SX)
    prm = lay.build(sym)
    f = ca.Function("f", list(sym.values()), [prm])
    n = float(len(PARAMS))
    num = {"phi1": 0.3, "pinion": np.arange(n), "gear": 10 + np.arange(n), "mis": 20 + np.arange(float(len(Misalignment.names()))),
           "z_section": 7.0}
    col = np.asarray(f(*num.values())).ravel()
    for g in ("pinion", "gear", "mis"):
        np.testing.assert_array_equal(col[lay.slice(g)], num[g])
    assert col[lay.index("phi1")] == 0.3 and col[lay.index("z_section")] == 7.0
    with pytest.raises(KeyError, match="exactly once"):
        lay.build({k: v for k, v in sym.items() if k != "mis"})
    with pytest.raises(KeyError, match="not a TCA parameter"):
        lay.index("pinion.nope")


def test_layout_errors_are_gearopt_errors_naming_the_parameter():
    """A wrong name or size is a GearoptError (ArgumentError; a KeyError for a name) that names the
    parameter and what is valid, so `except GearoptError` catches it like any other bad argument."""
    from gearopt.errors import ArgumentError, GearoptError, ParameterNameError

    lay = ParamLayout(PARAMS, PARAMS)
    with pytest.raises(ParameterNameError) as e:
        lay.index("pinion.nope")
    assert isinstance(e.value, (GearoptError, KeyError)) and e.value.param == "pinion.nope"
    assert "pinion.a_c" in e.value.valid and str(e.value).startswith("'pinion.nope' is not a TCA parameter")
    with pytest.raises(ArgumentError) as e:
        lay.pack([0.0], {"pinion": np.zeros(len(PARAMS) + 1)})
    assert e.value.param == "pinion" and e.value.valid == f"{len(PARAMS)} numbers"
    with pytest.raises(ParameterNameError, match="duplicate parameter name 'pinion.x'"):
        ParamLayout(("x", "x"), PARAMS)


def test_layout_does_not_assume_four_surface_parameters():
    """Flank-modification parameters appended to a member's names shift everything after them."""
    n = len(PARAMS)
    lay = ParamLayout(PARAMS + ("theta0", "theta1"), PARAMS)
    assert lay.slice("pinion") == slice(1, n + 3) and lay.index("pinion.theta1") == n + 2
    assert lay.index("gear.x") == n + 3 and lay.index("mis.dE") == 2 * n + 3
    assert lay.size == 1 + (n + 2) + n + len(Misalignment.names()) + 1
    assert lay.p_index("pinion", "theta0") == n and lay.p_index("gear", "a_pl") == 3


def test_tca_layout_equals_the_old_positional_layout(tca):
    lay = tca.layout
    n = len(PARAMS)
    assert lay.index("phi1") == 0
    for i, k in enumerate(PARAMS):
        assert lay.index(f"pinion.{k}") == 1 + i and lay.index(f"gear.{k}") == 1 + n + i
    for i, k in enumerate(OLD_MIS):
        assert lay.index(f"mis.{k}") == 1 + 2 * n + i
    assert lay.index("z_section") == 1 + 2 * n + len(Misalignment.names()) == tca.residual.size1_in(1) - 1
    # TCA.prm (now ParamLayout.pack) equals the old hand-built matrix
    p1 = tca.pinion.p0 + 1e-4
    mis = Misalignment(dE=0.01, crossing=2 * ARCMIN, intersecting=-ARCMIN, axial=0.3)
    phi = np.array([-0.1, 0.0, 0.2])
    old = np.vstack([phi[None, :], np.tile(np.concatenate([p1, tca.gear.p0, [getattr(mis, k) for k in Misalignment.names()],
                                                           [1.5]])[:, None], phi.size)])
    np.testing.assert_array_equal(tca.prm(phi, p1, None, mis, 1.5), old)
    assert lay.misalignment(old[:, 0]) == mis


def test_sensitivity_by_name_equals_the_old_index_and_a_finite_difference(tca):
    """d(phi2)/d(prm) read by name equals the column the old index named, and a finite difference
    of sweeps with the named parameter perturbed."""
    phi = np.array([-0.12, 0.1])
    r = tca.sweep(phi, pairs=(0,))
    W, P = ca.SX.sym("w", 5), ca.SX.sym("p", tca.layout.size)
    F = tca.residual(w=W, prm=P)["F"]
    dwdp = ca.Function("dwdp", [W, P], [-ca.solve(ca.jacobian(F, W), ca.jacobian(F, P))])
    r_p2 = tca.scale2
    S = np.array([np.asarray(dwdp([r.u1[0, i], r.z1[0, i], r.u2[0, i], r.z2[0, i], r.phi2[0, i] * r_p2],
                                  tca.prm([phi[i]])[:, 0]))[4] / r_p2 for i in range(phi.size)])
    for name, old_idx, h in (("pinion.a_pl", 1 + PARAMS.index("a_pl"), 1e-6),
                             ("mis.intersecting", 1 + 2 * len(PARAMS) + OLD_MIS.index("intersecting"), 1e-6)):
        assert tca.layout.index(name) == old_idx
        fd = []
        for s in (1, -1):
            if name.startswith("pinion."):
                p1 = tca.pinion.p0.copy()
                p1[tca.layout.p_index("pinion", "a_pl")] += s * h
                fd.append(tca.sweep(phi, p1=p1, pairs=(0,)).phi2[0])
            else:
                fd.append(tca.sweep(phi, mis=Misalignment(intersecting=s * h), pairs=(0,)).phi2[0])
        fd = (fd[0] - fd[1]) / (2 * h)
        np.testing.assert_allclose(S[:, tca.layout.index(name)], fd, rtol=1e-4, atol=1e-7)


@pytest.mark.parametrize("m", [Misalignment(), Misalignment(dE=0.05, crossing=3 * ARCMIN, intersecting=-2 * ARCMIN,
                                                                axial=0.4)])
def test_misalignment_transform_by_name_equals_the_old_one(m):
    """Gear frame -> S_f: the old code turned by intersecting about x, then crossing about y, and
    moved points to (0, a_w + dE, axial) (docs/theory.md section 7), here with matrices."""
    a_w = 75.0
    v = np.array([3.0, -40.0, 7.0])
    old_pt = Ry(m.crossing) @ Rx(m.intersecting) @ v + np.array([0.0, a_w + m.dE, m.axial])
    old_dir = Ry(m.crossing) @ Rx(m.intersecting) @ v
    np.testing.assert_allclose(np.asarray(Misalignment.gear_to_fixed(m.as_dict(), v, a_w, True)).ravel(), old_pt,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(Misalignment.gear_to_fixed(m.as_dict(), v, a_w, False)).ravel(), old_dir,
                               rtol=0, atol=1e-12)
    back = np.asarray(Misalignment.fixed_to_gear_rotation(m.as_dict(), old_dir)).ravel()
    np.testing.assert_allclose(back, v, rtol=0, atol=1e-12)
    # symbolic, through the TCA's layout: the same numbers from a named column
    lay = ParamLayout(PARAMS, PARAMS)
    prm = ca.SX.sym("prm", lay.size)
    f = ca.Function("t", [prm], [Misalignment.gear_to_fixed(lay.named(prm)["mis_map"], ca.DM(v), a_w, True)])
    np.testing.assert_allclose(np.asarray(f(lay.pack([0.0], {"mis": m})[:, 0])).ravel(), old_pt, atol=1e-12)


def test_misalignment_kinds_drive_scene_keys_labels_and_results():
    from gearopt.studies import get_study

    kinds = Misalignment.names()
    assert kinds[:len(OLD_MIS)] == OLD_MIS
    tca_spec, crown_spec = get_study("tca"), get_study("crowning")
    sec = tca_spec.sections[0]
    keys = {f.name: f for f in sec.fields}
    case_keys = {f.name: f for f in sec.subsections[0].fields}
    crown_keys = {f.name: f for f in crown_spec.sections[0].fields}
    for k in kinds:
        unit = Misalignment.meta(k)["unit"]
        for fs in (keys, case_keys, crown_keys):
            assert fs[k].kind == unit
    m = Misalignment(dE=-0.02, crossing=3 * ARCMIN)
    assert m.label() == "dE -0.02 mm, crossing +3'"
    r = m.to_results()
    assert r["dE_mm"] == -0.02 and r["crossing_arcmin"] == pytest.approx(3.0)
    assert r["intersecting_arcmin"] == 0.0 and r["axial_mm"] == 0.0


def test_frames_rotations_match_matrices():
    v = np.array([1.5, -2.0, 0.7])
    for f, M in ((rot_x, Rx), (rot_y, Ry), (rot_z, Rz)):
        for a in (0.3, -1.2):
            np.testing.assert_allclose(np.asarray(f(a, v)).ravel(), M(a) @ v, atol=1e-15)
            s = ca.SX.sym("a")
            g = ca.Function("g", [s], [f(s, ca.DM(v))])
            np.testing.assert_allclose(np.asarray(g(a)).ravel(), M(a) @ v, atol=1e-15)
    P = np.random.default_rng(0).normal(size=(5, 3))
    np.testing.assert_allclose(rot_z_points(P, 0.4), P @ Rz(0.4).T, atol=1e-15)
    np.testing.assert_allclose(rot_z_points(P[:, :2], 0.4), (P @ Rz(0.4).T)[:, :2], atol=1e-15)


def test_operating_pitch_radii():
    pair = _pair()
    r_b1, r_b2 = pair.pinion.r_b, pair.gear.r_b
    # independent: the pitch point divides a_w so that r_w cos(alpha_wt) = r_b on both members
    c = math.cos(pair.alpha_wt)
    assert pair.r_w1 == pytest.approx(r_b1 / c, rel=1e-12)
    assert pair.r_w2 == pytest.approx(r_b2 / c, rel=1e-12)
    assert pair.r_w1 + pair.r_w2 == pytest.approx(pair.a_w, rel=1e-14)


def test_public_form_radius_and_on_flank(tca):
    assert tca.form_radius(1) == tca.flank_limit(1, 0.0).radius
    assert tca.on_active_flank == tca.on_flank
    u_lim = tca.flank_limit(2, 0.0).u
    assert tca.on_flank(2, np.array([u_lim - 0.01, u_lim + 0.01]), np.zeros(2)).tolist() == [True, False]
