"""The slices find a pair's contact wherever it lies on the flanks (docs/ltca.md section 1): a slice node
whose Newton solve from the unmodified drive's conjugate point fails is solved again from the same
pair's node at the neighbouring position (:meth:`gearopt.ltca.slices.SliceSolver._continue_positions`).

The drive is the design where the loaded optimiser with Litvin's settings free stopped on its trust
radius (tests/test_loaded_synthesis_objectives.py::test_litvin_settings_as_design_variables,
docs/loaded_synthesis.md "Litvin's settings: the loop converges"): a parabolic rack-cutter profile
(a_c) with tip and root relief. From the conjugate guess Newton converged on the generated surface's
fold (regularity < 0) or diverged, and the entering pair (pinion tooth 1) lost its whole contact at
3.75 ... 5.25 deg (24 positions per cycle) for a_c >= 4e-3 ... 5.5e-3 1/mm, 0.1 ... 0.2 mm above the
pinion's form circle; its slices appeared and vanished as a_c moved by 1e-4 1/mm, and with them the
loaded TE the optimiser's NLP was compared with."""

from __future__ import annotations

import numpy as np
import pytest

from gearopt import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.ltca import LTCA
from gearopt.units import RAD_TO_ARCSEC

UM = 1e-3  # mm
A_C = np.arange(4.0e-3, 6.01e-3, 0.5e-3)  # [1/mm] the parabolic rack-cutter profile of the sweep


def litvin_drive():
    """20/40 spur, m 3, b 20: pinion lead-crowned (a_pl 7.3e-4 1/mm) with tip and root relief (9.38 and
    7.91 um from d_Ca 64 and d_Cf 58.5 mm); a_c is set per call through the parameter column."""
    mg = Microgeometry(C_alpha_a=9.38 * UM, C_alpha_f=7.91 * UM, d_Ca=64.0, d_Cf=58.5)
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=7.3e-4, modifications=mg), Gear(z=40, m_n=3.0, b=20.0))


@pytest.mark.slow
def test_entering_pair_is_found_for_every_parabolic_profile():
    """Across a_c = 4e-3 ... 6e-3 1/mm the entering pair is in contact on the flanks at every node of the
    four positions 3.75 ... 6 deg, and its slice TE is smooth in a_c: at each position the second
    differences of the middle node's TE over the sweep are below 5 % of the first ones (nearly linear:
    the profile's parabola shifts the contact's separation in proportion to a_c)."""
    L = LTCA(litvin_drive(), n_slices=11)
    lay = L.tca.layout
    p1, p2 = np.array(L.tca.pinion.p0, float), np.array(L.tca.gear.p0, float)
    te = []
    for a_c in A_C:
        p1[lay.member_names["pinion"].index("a_c")] = a_c
        # the whole cycle's positions, as the optimiser solves them; the four of the check among them
        S = L.slices(L.mesh_cycle(24), p1, p2)
        k = S.pairs.index(1)
        assert np.all(S.converged[k, 16:20]) and np.all(S.inside[k, 16:20]), f"a_c {a_c:g}"
        te.append(S.te[k, 16:20, S.z.shape[2] // 2] * RAD_TO_ARCSEC)
    te = np.array(te)  # (a_c, position) [arcsec]
    d1, d2 = np.diff(te, axis=0), np.diff(te, 2, axis=0)
    assert np.all(np.abs(d1) > 1.0)  # arcsec per step: a_c does move the contact
    assert np.max(np.abs(d2)) < 0.05 * np.min(np.abs(d1))
