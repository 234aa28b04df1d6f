"""The response of a member's neighbouring teeth to a load on one tooth (``neighbours`` of
gearopt.fea.influence.influence_grid and line_load_compliance): the coupling of the pairs' teeth through the
rim or body that loaded TCA leaves out (docs/ltca.md section 7, "The neighbouring teeth")."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from gearopt.errors import OptionError
from gearopt.fea import MeshOptions
from gearopt.fea.influence import influence_grid, line_load_compliance
from gearopt.gears import Gear, GearPair
from gearopt.meshing.tca import TCA

_no_ccx = pytest.mark.skipif(shutil.which("ccx") is None, reason="CalculiX (ccx) is not installed: FE runs skipped")

#: a small mesh: one CalculiX load case of the full 12-tooth gear takes about 1 s
SMALL = MeshOptions(n_face=2, n_half=3, n_flank=4, n_fillet=3, n_rim=4)
E, NU = 210000.0, 0.3


@pytest.fixture(scope="module")
def member():
    pair = GearPair(Gear(z=12, m_n=3, b=10, x=0.3, name="pinion"), Gear(z=24, m_n=3, b=10, name="gear"))
    tca = TCA(pair)
    return tca.pinion.unmodified, tca.form_radius(1)


@pytest.mark.parametrize("bad", [(0,), (2,), (1, 1), (0.5,), "x"])
def test_neighbours_outside_the_model_are_refused(member, bad):
    tooth, r_form = member
    with pytest.raises(OptionError, match="neighbours"):
        line_load_compliance(tooth, mesh=SMALL, r_form=r_form, teeth=3, neighbours=bad, use_cache=False)
    with pytest.raises(OptionError, match="neighbours"):
        influence_grid(tooth, mesh=SMALL, r_form=r_form, teeth=3, neighbours=bad, use_cache=False)


@pytest.mark.calculix
@pytest.mark.slow
@_no_ccx
def test_a_full_gear_couples_its_neighbouring_teeth_through_the_body(member):
    """A line load on one tooth of a full gear held at its bore moves the next teeth by a large part of its own
    body deflection, at least the torsion of the body (an annulus held at its bore, plane stress:
    ``r_b^2 (1/r_int^2 - 1/r_f^2) / (4 pi G)`` per unit face width), and far more than a 3-tooth sector held at
    its sides (the contact model's member); reading the neighbours does not change the loaded tooth's own
    response."""
    tooth, r_form = member
    g = tooth.gear
    r_bore = 0.5 * tooth.r_root
    kw = dict(E=E, nu=NU, mesh=SMALL, r_form=r_form, rows=[2], use_cache=False, threads=1)
    full = line_load_compliance(tooth, teeth=g.z, support="bore", r_bore=r_bore, neighbours=(-2, -1, 1, 2), **kw)
    plain = line_load_compliance(tooth, teeth=g.z, support="bore", r_bore=r_bore, **kw)
    sector = line_load_compliance(tooth, teeth=3, support="sector", neighbours=(-1, 1), **kw)
    assert plain.neighbours is None
    np.testing.assert_allclose(full.C[:, 2], plain.C[:, 2], rtol=1e-9)
    own = full.C[2, 2]
    n = {d: full.neighbours[d][2, 2] for d in (-2, -1, 1, 2)}
    twist = g.r_b**2 * (1 / r_bore**2 - 1 / tooth.r_root**2) / (4 * math.pi * E / (2 * (1 + NU)))
    for d in (-1, 1):
        assert 0.15 * own < n[d] < 0.6 * own
        assert n[d] > 3 * sector.neighbours[d][2, 2]
        assert n[2 * d] < n[d]
    assert min(n.values()) > twist
    assert np.all(np.isnan(np.delete(full.neighbours[1], 2, axis=1)))
