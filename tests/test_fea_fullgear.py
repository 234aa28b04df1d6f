"""A member held at its bore only, and the full gear (every tooth, the seam merged): the FE reference of
the analytical compliance's body term (gearopt.fea.mesh.MemberMesh.held, gearopt.fea.influence
.line_load_compliance; docs/ltca.md section 7)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from gearopt.errors import GearoptError, OptionError
from gearopt.fea import MeshOptions
from gearopt.fea.influence import influence_grid, line_load_compliance
from gearopt.fea.mesh import ToothMesher, build_member
from gearopt.gears import Gear, GearPair
from gearopt.meshing.tca import TCA

_no_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed: FE runs skipped")

#: a small mesh: one CalculiX load case of the full 12-tooth gear takes about 1 s
SMALL = MeshOptions(n_face=2, n_half=3, n_flank=4, n_fillet=3, n_rim=4)


@pytest.fixture(scope="module")
def member():
    pair = GearPair(Gear(z=12, m_n=3, b=10, x=0.3, name="pinion"), Gear(z=24, m_n=3, b=10, name="gear"))
    tca = TCA(pair)
    return tca.pinion.unmodified, tca.form_radius(1)


def mesh_of(tooth, teeth, r_rim=None, opt=SMALL):
    m = ToothMesher(tooth, opt, r_rim=r_rim)
    return build_member(m, tuple(range(-(teeth // 2), teeth - teeth // 2)), {}, "pinion", 0.0)


def test_bore_support_holds_only_the_bottom_arc(member):
    tooth, _ = member
    mm = mesh_of(tooth, 3)
    r = np.hypot(mm.nodes[:, 0], mm.nodes[:, 1])
    bore, sector = mm.held("bore"), mm.held("sector")
    assert np.allclose(r[bore], mm.r_rim, atol=1e-9)  # every held node on the bottom arc...
    assert bore.size == np.count_nonzero(np.abs(r - mm.r_rim) < 1e-9)  # ...and every node of the arc
    assert set(bore) < set(sector)
    sides = np.setdiff1d(sector, bore)
    assert sides.size > 0 and np.all(r[sides] > mm.r_rim + 1e-6)  # the sides: above the bottom arc
    assert not mm.full_ring


def test_full_ring_merges_its_seam_and_has_no_sides(member):
    tooth, _ = member
    z = tooth.gear.z
    ring, open_ = mesh_of(tooth, z), mesh_of(tooth, z - 1)
    assert ring.full_ring and not open_.full_ring
    per_tooth = open_.nodes.shape[0] - mesh_of(tooth, z - 2).nodes.shape[0]  # the nodes one tooth adds
    seam = open_.rim_sides.size // 2  # one radial line of the rim, every layer
    # closing the ring adds one tooth but not its second radial line: merged with the first tooth's
    assert ring.nodes.shape[0] == open_.nodes.shape[0] + per_tooth - seam
    assert ring.elements.shape[0] == z * (open_.elements.shape[0] // (z - 1))
    with pytest.raises(OptionError, match="support = 'sector'.*full ring"):
        ring.held("sector")
    r = np.hypot(ring.nodes[:, 0], ring.nodes[:, 1])
    assert np.allclose(r[ring.held("bore")], ring.r_rim)


def test_bore_radius_replaces_the_rim_depth(member):
    tooth, _ = member
    r_f = tooth.r_root
    mm = mesh_of(tooth, 3, r_rim=0.5 * r_f)
    assert mm.r_rim == pytest.approx(0.5 * r_f)
    assert np.hypot(mm.nodes[:, 0], mm.nodes[:, 1]).min() == pytest.approx(0.5 * r_f)
    for bad in (0.1 * r_f, r_f, 1.2 * r_f):
        with pytest.raises(OptionError, match="r_rim"):
            ToothMesher(tooth, SMALL, r_rim=bad)


@pytest.mark.parametrize("kw, match", [(dict(teeth=0), "teeth = 0"), (dict(teeth=13), "teeth = 13.*1 <= teeth <= 12"),
                                       (dict(teeth=2.5), "teeth = 2.5"), (dict(support="sides"), "support = 'sides'"),
                                       (dict(rows=[9]), "rows"), (dict(rows=[1, 1]), "rows"),
                                       (dict(element="C3D20"), "element = .C3D20.")])
def test_bad_arguments_are_named(member, kw, match):
    tooth, r_form = member
    with pytest.raises(GearoptError, match=match):
        line_load_compliance(tooth, mesh=SMALL, r_form=r_form, use_cache=False, **kw)


def test_influence_grid_support_checked(member):
    tooth, r_form = member
    with pytest.raises(OptionError, match="support = 'ring'"):
        influence_grid(tooth, mesh=SMALL, r_form=r_form, support="ring", use_cache=False)
    with pytest.raises(OptionError, match="teeth = 14"):
        influence_grid(tooth, mesh=SMALL, r_form=r_form, teeth=14, use_cache=False)


@pytest.mark.calculix
@pytest.mark.slow
@_no_ccx
def test_full_gear_between_the_sectors_held_and_free(member):
    """The full gear on its bore is bracketed by sectors of the same body: held at the sides (more
    constrained: stiffer) and free at the sides (material removed: softer), and the bracket narrows
    as the sector widens."""
    tooth, r_form = member
    r_bore = 0.5 * tooth.r_root
    kw = dict(E=210000.0, nu=0.3, mesh=SMALL, r_form=r_form, r_bore=r_bore, rows=[2], use_cache=False, threads=1)
    full = line_load_compliance(tooth, teeth=tooth.gear.z, support="bore", **kw)
    assert full.full_ring
    c = {}
    for n in (3, 7):
        for s in ("sector", "bore"):
            c[n, s] = line_load_compliance(tooth, teeth=n, support=s, **kw).C[2, 2]
    f = full.C[2, 2]
    assert c[3, "sector"] < c[7, "sector"] < f < c[7, "bore"] < c[3, "bore"]
    # the unloaded rows are NaN, the loaded row's responses decrease down the tooth (a line load's lever)
    assert np.all(np.isnan(np.delete(full.C, 2, axis=1)))
    assert np.all(np.diff(full.C[:, 2]) > 0)
