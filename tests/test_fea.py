"""Finite element model (Litvin 9.5): analytic mesh, CalculiX deck and run, validation against
Hertz, T / r_b1 and ISO 6336-3 (the CalculiX runs skip where ccx is missing)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from gearopt.fea import CalculixError, FEOptions, GearFEModel, MeshOptions, hertz_line, hex_min_jacobian, read_dat
from gearopt.fea.calculix import read_frd_block, write_inp
from gearopt.gears import BasicRack, Gear, GearPair

_no_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed: FE runs skipped")


def needs_ccx(test):
    """Mark a test that runs CalculiX: skipped without ccx, marker ``calculix``."""
    return pytest.mark.calculix(_no_ccx(test))

#: CI-sized mesh (~1900 C3D8 elements, ~5 s per ccx run on 2 cores).
COARSE = dict(n_hertz=2.0, mesh=MeshOptions(n_face=2, n_half=4, n_flank=6, n_fillet=4, n_rim=3))


@pytest.fixture(scope="module")
def pair():
    r = BasicRack.iso53("A")
    return GearPair(Gear(z=20, m_n=3, b=10, rack=r, name="pinion"), Gear(z=30, m_n=3, b=10, rack=r, name="gear"))


@pytest.fixture(scope="module")
def model(pair):
    return GearFEModel(pair, 0.0, FEOptions(torque=100e3, **COARSE))


def test_flank_nodes_are_surface_points(model, pair):
    """Nodes on the flanks are the surface Functions' points, and lie on the involute (independent check)."""
    g = pair.pinion
    S = model.pin_tooth.surface("right", "flank")
    for t in model.pinion_mesh.teeth:
        r0, r1 = t["section"].segments["flank"]
        for L, z in enumerate(model.pinion_mesh.meta["z"]):
            X = model.pinion_mesh.nodes[t["nodes"][L, r0:r1 + 1, -1]]
            X = np.c_[np.cos(-t["angle"]) * X[:, 0] - np.sin(-t["angle"]) * X[:, 1],
                      np.sin(-t["angle"]) * X[:, 0] + np.cos(-t["angle"]) * X[:, 1], X[:, 2]]  # back to tooth 0
            u = t["u_rows"].copy()
            u[0] = model.pin_tooth.u_at_radius(g.r_a, z)
            R = np.array([np.asarray(S(ui, z, model.pin_tooth.p0)[0]).ravel() for ui in u])
            assert np.abs(X - R).max() < 1e-9
            # involute: polar angle from the tooth centreline = s/(2r_p) + inv(alpha_t) - inv(alpha(r))
            rad = np.hypot(X[:, 0], X[:, 1])
            theta = np.arctan2(X[:, 0], X[:, 1])
            alpha = np.arccos(g.r_b / rad)
            inv = lambda a: np.tan(a) - a  # noqa: E731
            expect = g.s_t / (2 * g.r_p) + inv(g.alpha_t) - inv(alpha)
            assert np.abs(theta - expect).max() * g.r_p < 1e-8  # mm
            assert np.isclose(rad[0], g.r_a)


def test_mesh_quality_and_structure(model):
    for m in (model.pinion_mesh, model.gear_mesh):
        assert hex_min_jacobian(m.nodes, m.elements).min() > 0
        assert len(np.unique(m.elements)) == len(m.nodes)  # every node belongs to an element (merged sides)
        assert len(m.rim_bottom) and len(m.rim_sides)
        r = np.hypot(m.nodes[m.rim_bottom, 0], m.nodes[m.rim_bottom, 1])
        assert np.allclose(r, m.r_rim)
        # six sub-volumes: flank, fillet, root+rim segments on both halves of every tooth
        for t in m.teeth:
            seg = t["section"].segments
            assert seg["flank"][1] == seg["fillet"][0] and seg["fillet"][1] == seg["root"][0]
    assert 1000 < model.n_elements < 4000


def test_members_placed_in_contact(model, pair):
    """The TCA contact point is on both placed flanks: pinion and gear nodes near it nearly touch."""
    k = model.loaded[0]
    rf = model.tca_result.rf[model.tooth_ids.index(k), 0]
    Mid = lambda X: X[np.abs(X[:, 2]) < 1e-9]  # noqa: E731
    P, G = Mid(model.nodes_pinion), Mid(model.nodes_gear)
    dP = np.linalg.norm(P - rf, axis=1).min()
    dG = np.linalg.norm(G - rf, axis=1).min()
    assert dP < model.mesh_options.h_contact and dG < model.mesh_options.h_contact
    assert model.loaded == [0]  # single-pair contact at the pitch point of this 20/30 pair


def test_hertz_formula():
    h = hertz_line(354.7, 10.26, 15.39, 210e3, 0.3)
    assert h["p0"] == pytest.approx(1455, rel=2e-3)  # Hertz reference value of docs/fea.md (validation)
    assert h["b"] == pytest.approx(0.155, rel=5e-3)


def test_deck_lines_and_sets(model, tmp_path):
    d = model.deck()
    path = write_inp(d, tmp_path / "m.inp")
    text = path.read_text()
    for line in text.splitlines():  # docs/theory.md section 12.3, rule 5: at most 16 entries per line
        if not line.startswith("*"):
            assert len(line.split(",")) <= 16
    assert "ADJUST" not in text and "*BOUNDARY, OP=NEW" in text and "*RIGID BODY" in text
    assert text.count("*CONTACT PAIR") == 3
    assert d.close_rotation < 0 and d.moment < 0  # the pinion drives clockwise


def test_readers():
    dat = """
 total force (fx,fy,fz) for set GFIX and time  0.2000000E+01

       -3.333401E+03 -1.215928E+03 -3.735678E-12

 contact stress (slave element+face,press,tang1,tang2) for all contact elements and time 0.2000000E+01

      1032          4  5.982913E+02  0.000000E+00  0.000000E+00
"""
    b = read_dat(dat)
    assert [x.what for x in b] == ["total force", "contact stress"]
    assert b[0].set == "GFIX" and b[0].time == 2.0 and b[0].rows == [[-3333.401, -1215.928, -3.735678e-12]]
    frd = " -4  CONTACT     6    1\n -5  CPRESS      1    4    1    2\n -1         7 1.00000E+00 2.00000E+00 3.00000E+00 4.50000E+02\n -3\n"
    assert read_frd_block(frd, "CONTACT") == {7: [1.0, 2.0, 3.0, 450.0]}


def test_missing_ccx_is_a_clear_error(model, monkeypatch):
    monkeypatch.setenv("GEAROPT_CCX", "no-such-ccx-executable")
    with pytest.raises(CalculixError, match="not installed"):
        model.run()


@needs_ccx
def test_run_pitch_point_against_hertz_and_reaction(model, pair):
    res = model.run().to_dict()
    R = res["reaction"]
    assert R["rel_error"] < 0.01  # gear reaction = T / r_b1 (measured 0.01 %)
    c = res["contact"]
    assert c["n_positive"] > 0 and c["p_max_mid"] > 0
    # CI mesh (2 elements per Hertz half-width): +8.7 % measured; the 3-4 per b_H mesh of the
    # benchmark gives +1.5 % (docs/fea.md)
    assert c["ratio_mid_to_hertz"] == pytest.approx(1.0, abs=0.15)
    assert c["hertz_p0"] == pytest.approx(1454.7, rel=1e-3)
    # root stress: the same order as ISO 6336-3 (method B geometry, load at the pitch point)
    for member in ("pinion", "gear"):
        assert 0.7 < res["root"][member]["ratio_to_iso"] < 1.3
    # loaded TE: the pinion turns further in its driving (clockwise) direction under load
    rot = res["pinion_rotation_rad"]
    assert rot < 0 and abs(rot) * pair.pinion.r_b == pytest.approx(0.019, rel=0.3)  # ~19 um along the line of action
