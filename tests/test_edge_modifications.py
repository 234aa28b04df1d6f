"""Edge-contact TCA of drives with ISO flank modifications (contact/edge.py).

* The line-contact fallback of the surface branch carries the modifications: a spur pinion with
  profile crowning C_alpha only (still line contact) gives the TE of a parabolic profile deviation,
  checked against the closed form of the envelope of the tooth pairs' TEs.
* Every modification counts in the coast-side clearance: material added on the driving flank is
  not mistaken for a contact beyond the coast flank.
* A pair whose modified teeth are thicker than the backlash leaves room for jams: a clear error, with
  the thickening checked against its closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearopt.contact.edge import EdgeContact
from gearopt.errors import GeometryError
from gearopt.gears import Gear, GearPair
from gearopt.geometry.generation import generate
from gearopt.geometry.microgeometry import Microgeometry, frame, modified_tooth
from gearopt.geometry.modification import constant_offset
from gearopt.meshing.tca import TCA
from gearopt.units import RAD_TO_ARCSEC

UM = 1e-3  # mm


def spur(mods: Microgeometry | None = None, A_sne: float = 0.0) -> GearPair:
    """20/40, m 3 mm, b 20 mm (scene edge_spur_crossed), pinion modifications ``mods``."""
    p = Gear(z=20, m_n=3.0, b=20, name="pinion", modifications=mods, A_sne=A_sne)
    return GearPair(p, Gear(z=40, m_n=3.0, b=20, name="gear"))


def edge_contact(pair: GearPair) -> EdgeContact:
    return EdgeContact(TCA(pair, pinion=modified_tooth(pair, "pinion")))


@pytest.mark.slow
def test_line_contact_fallback_keeps_profile_crowning():
    # Profile crowning keeps line contact (the point TCA is singular): the surface branch is solved in
    # the mid section of the MODIFIED teeth. Each pair's TE is delta(L)/r_b2 with delta(L) =
    # -C_alpha ((L - L_m) / (L_alpha / 2))^2 along the roll length L; the envelope of pairs one base pitch
    # p_b apart has its maximum 0 at L_m and its minimum where two pairs meet, L_m +- p_b / 2: peak-to-peak
    # C_alpha (p_b / L_alpha)^2 / r_b2 [rad].
    C = 6 * UM
    pair = spur(Microgeometry(C_alpha=C))
    ec = edge_contact(pair)
    phi = np.linspace(-0.3, 0.3, 61)
    r = ec.sweep(phi, pairs=(-1, 0, 1))
    assert r.stats.get("surface_mode") == "line contact (mid section)"
    assert np.all(r.driving >= 0)
    assert not r.edge_contact()
    fr = frame(modified_tooth(pair, "pinion"), "right", pair, "pinion")
    g2 = pair.gear
    p_b = math.pi * pair.pinion.m_n * math.cos(pair.pinion.alpha_t)
    expected = C * (p_b / fr.L_alpha) ** 2 / g2.r_b * RAD_TO_ARCSEC
    env = r.te_envelope * RAD_TO_ARCSEC
    assert np.ptp(env) == pytest.approx(expected, rel=0.03)


@pytest.mark.slow
def test_jam_is_an_error_with_the_thickening_of_the_teeth():
    # Lead crowning C and helix slope f on both flanks: delta(s) = -C s^2 + f s / 2 (s = z / (b/2)) is
    # largest at s = f / (4 C), f^2 / (16 C) per flank: the tooth is f^2 / (8 C) thicker there, with no
    # backlash to take it.
    C, f = 12 * UM, 6 * UM
    ec = edge_contact(spur(Microgeometry(C_beta=C, f_H_beta=f)))
    ext = ec.modification_extent(ec.tca.pinion.p0, ec.tca.gear.p0)
    assert ext.thickening == pytest.approx(f**2 / (8 * C), rel=1e-3)
    assert ext.z_thickest == pytest.approx(f / (4 * C) * 10.0, abs=0.05)
    with pytest.raises(GeometryError, match=r"jams.*0\.375 um thicker"):
        ec.sweep(np.linspace(-0.1, 0.1, 5))
    # the slope alone: 2 x f/2 at face II
    with pytest.raises(GeometryError, match=r"jams.*6 um thicker"):
        edge_contact(spur(Microgeometry(f_H_beta=f))).sweep(np.linspace(-0.1, 0.1, 5))


@pytest.mark.slow
def test_backlash_admits_the_same_modifications():
    # Thinner pinion teeth (A_sne = -0.05 mm: j_bn ~ 47 um): no jam, the crowned contact is surface
    # contact at every position and conjugate (an unmodified profile).
    pair = spur(Microgeometry(C_beta=12 * UM, f_H_beta=6 * UM), A_sne=-0.05)
    r = edge_contact(pair).sweep(np.linspace(-0.3, 0.3, 31))
    assert np.all(r.active == 0)
    assert np.ptp(r.te_envelope) * RAD_TO_ARCSEC < 0.01


@pytest.mark.slow
def test_material_added_on_the_driving_flank_is_not_beyond_the_coast_flank():
    # A tooth moved by 5 um towards the driving side (+5 um on the right flank, -5 um on the left): no
    # thicker, so no jam even at zero backlash; the gear is 5 um ahead along the normal at every position,
    # a contact that the coast-side clearance must admit (the surface branch valid everywhere).
    pair = spur()
    tooth = generate(pair.pinion)
    tooth = tooth.with_modification(constant_offset(5 * UM, name="ahead", sides=("right",)))
    tooth = tooth.with_modification(constant_offset(-5 * UM, name="behind", sides=("left",)))
    ec = EdgeContact(TCA(pair, side="right", pinion=tooth))
    ext = ec.modification_extent(tooth.p0, ec.tca.gear.p0)
    assert ext.thickening == pytest.approx(0.0, abs=1e-9)
    assert ext.added_drive == pytest.approx(5 * UM, rel=1e-6)
    phi = np.linspace(-0.3, 0.3, 31)
    r = ec.sweep(phi, pairs=(-1, 0, 1))
    assert np.all(r.active == 0), "the surface contact was discarded"
    # the advance itself: the raw TE of the surface branch against the unmodified drive's
    plain = EdgeContact(TCA(pair, side="right")).sweep(phi, pairs=(-1, 0, 1))
    shift = (r.stats["te_zero_rad"] - plain.stats["te_zero_rad"]) * pair.gear.r_b
    assert shift == pytest.approx(5 * UM, rel=1e-3)
