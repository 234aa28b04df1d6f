"""The flank deviations a Monte Carlo samples (ISO 1328-1 profile and helix slope deviations) as a
flank modification of the pinion, shared by the study (:mod:`gearopt.robust.study`) and the batched
kernels (:mod:`gearopt.robust.batch`). Lengths in mm."""

from __future__ import annotations

import math

from ..gears import GearPair
from ..geometry.generation import generate
from ..geometry.microgeometry import Frame, frame, roll_length_of
from ..geometry.modification import FlankModification


def deviation_modification(pair: GearPair) -> tuple[FlankModification, Frame]:
    """The pinion's relative deviation modification ``dev``: theta (f_H_alpha, f_H_beta) [mm],
    transverse deviation ``f_H_alpha (L - L_m) / L_alpha + f_H_beta z / b`` on both flanks at the
    foot point's roll length (the fixed-point correction of microgeometry is below 1e-3 of it); with
    the pinion's right-flank :class:`~gearopt.geometry.microgeometry.Frame`."""
    tooth = generate(pair.pinion)
    fr = frame(tooth, "right", pair, "pinion")
    c = math.cos(fr.beta_b)

    def delta(u, z, r, th):
        L = roll_length_of(r, fr.r_b)
        return c * (th[0] * (L - fr.L_m) / fr.L_alpha + th[1] * z / fr.b)

    return FlankModification("dev", (("f_H_alpha", 0.0, "mm"), ("f_H_beta", 0.0, "mm")), delta), fr
