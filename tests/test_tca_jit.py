"""The compiled (jit) sweep gives the same contact points as the interpreted one."""

from __future__ import annotations

import math
import shutil
import warnings

import numpy as np
import pytest

from gearopt import ARCMIN, BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment


@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler for jit")
def test_jit_sweep_matches_interpreted():
    rack = BasicRack.iso53("A", a_c=0.002)
    pair = GearPair(Gear(z=19, m_n=2.0, b=16, rack=rack, a_pl=4e-4, name="pinion"), Gear(z=37, m_n=2.0, b=16, name="gear"))
    mis = Misalignment(crossing=2 * ARCMIN, dE=0.02)
    phi = np.linspace(-math.pi / 19, math.pi / 19, 31)
    ref = TCA(pair).sweep(phi, mis=mis, pairs=(0,))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a silent fallback to the interpreter would hide a broken jit
        jit = TCA(pair, jit=True).sweep(phi, mis=mis, pairs=(0,))
    assert jit.converged.all() and ref.converged.all()
    np.testing.assert_allclose(jit.phi2, ref.phi2, rtol=0, atol=1e-14)
    np.testing.assert_allclose(jit.ellipse_a, ref.ellipse_a, rtol=1e-10)
