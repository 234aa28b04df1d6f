"""Sainsot, Velex & Duverger (2004)'s gear-body term as published (docs/ltca.md section 7, "Sainsot, Velex &
Duverger's term as others write it"): ``cos^2(alpha_m) / E [L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q*
tan^2(alpha_m))]`` per unit face width, evaluated here from the tooth's geometry independently of
gearopt.ltca.compliance. Since 2026-11-29 the term is selected with ``body = "sainsot2004"`` (the default body is
the refit to FE full gears, tests/test_ltca_body.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca import Material
from gearopt.ltca.compliance import ToothCompliance
from gearopt.meshing.tca import TCA

#: Sainsot et al. (2004), Table 1, as the published implementations write it: (A, B, C, D, E, F) of
#: X* = A / theta_f^2 + B h_fi^2 + C h_fi / theta_f + D / theta_f + E h_fi + F
TABLE1 = {"L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
          "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
          "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
          "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904)}


@pytest.mark.parametrize("r_int_ratio", [0.5, 0.3])
def test_body_term_is_the_published_formula(r_int_ratio):
    pair = GearPair(Gear(z=20, m_n=3, b=20, rack=BasicRack.iso53("A")), Gear(z=40, m_n=3, b=20))
    tooth = TCA(pair).pinion.unmodified
    E, nu = 210000.0, 0.3
    prof = tooth.transverse_profile(z=0.0, n=300)
    fil = prof["right_fillet"]
    # theta_f: the half angle from the tooth centreline (+y) to where the fillet meets the root circle
    k = int(np.argmin(np.hypot(fil[:, 0], fil[:, 1])))
    r_f = float(np.hypot(*fil[k]))
    theta_f = math.atan2(abs(fil[k, 0]), fil[k, 1])
    r_int = r_int_ratio * r_f
    h_fi = r_f / r_int
    S_f = 2.0 * r_f * math.sin(theta_f)  # the root chord
    X = {n: a / theta_f**2 + b * h_fi**2 + c * h_fi / theta_f + d / theta_f + e * h_fi + f
         for n, (a, b, c, d, e, f) in TABLE1.items()}
    # load points on the flank and their outward normals (finite differences of the profile)
    fl = prof["right_flank"]
    o = np.argsort(np.hypot(fl[:, 0], fl[:, 1]))
    fl = fl[o]
    tg = np.gradient(fl, axis=0)
    nrm = np.stack([tg[:, 1], -tg[:, 0]], 1)
    nrm *= np.sign(nrm[:, :1] * fl[:, :1])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    pick = [40, 150, 260]
    got = ToothCompliance(tooth, Material(E=E, nu=nu), r_int, body="sainsot2004").per_width(fl[pick], nrm[pick]).foundation
    for j, i in enumerate(pick):
        (x, y), (nx, ny) = fl[i], nrm[i]
        alpha_m = math.atan2(abs(ny), abs(nx))  # load line against the normal to the centreline
        # u_f: from the root circle along the centreline to where the load line (through the point, along
        # the normal) crosses it
        t = -x / nx
        u_f = (y + t * ny) - r_f
        q = u_f / S_f
        want = math.cos(alpha_m) ** 2 / E * (X["L"] * q**2 + X["M"] * q + X["P"] * (1.0 + X["Q"] * math.tan(alpha_m) ** 2))
        assert got[j] == pytest.approx(want, rel=1e-9), (i, got[j], want)
