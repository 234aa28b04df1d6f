"""Clear failures of the TCA: line-contact mode on a drive that is not in line contact."""

from __future__ import annotations

import numpy as np
import pytest

from gearopt import BasicRack, ConvergenceError, Gear, GearPair, deg
from gearopt.meshing.tca import TCA


def _helical(a_c):
    rack = BasicRack.iso53("A", a_c=a_c)
    return GearPair(Gear(z=21, m_n=2.5, b=30, beta=deg(18), rack=rack, name="pinion"),
                    Gear(z=53, m_n=2.5, b=30, beta=deg(18), hand="left", name="gear"))


def test_line_mode_on_profile_crowned_helical_pair_says_use_point_contact():
    # A profile-crowned helical pinion touches the gear at points, not along lines: in a fixed
    # section the equations still have roots, but there the surfaces cross (n1 . n2 != -1).
    with pytest.raises(ConvergenceError, match="not in line contact.*contact='point'"):
        TCA(_helical(0.002), contact="line").solve_point(0.0, z_section=5.0)
    # The same drive in point contact solves, with opposite normals.
    t = TCA(_helical(0.002))
    w = t.solve_point(0.0)
    assert float(t.contact(w=w, prm=t.prm([0.0])[:, 0])["n1n2"]) == pytest.approx(-1.0, abs=1e-12)


def test_line_mode_on_conjugate_helical_pair_is_accepted():
    t = TCA(_helical(0.0), contact="line")
    r = t.sweep(np.linspace(-0.1, 0.1, 9), pairs=(0,), z_section=5.0)
    assert r.converged.all()
    assert np.nanmax(np.abs(r.te)) < 1e-12
