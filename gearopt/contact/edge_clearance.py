"""How far the gear of an edge-contact drive may advance, and whether it turns at all: the coast-side
clearance of the aligned drive plus what crowning, misalignment and flank modifications open or add
(the reach of an edge contact), the modifications' extremes (:class:`ModificationExtent`) and the jam
check against the normal backlash. :class:`EdgeClearance` is a part of
:class:`gearopt.contact.edge.EdgeContact`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import GearoptError, GeometryError
from ..meshing.misalignment import Misalignment
from .edge_kinds import exact_key

if TYPE_CHECKING:
    from ..types import Param


@dataclass(frozen=True)
class ModificationExtent:
    """Extremes of the flank modifications of a drive (:meth:`EdgeContact.modification_extent`).

    Attributes
    ----------
    added_drive : float
        Largest material added on the driving flanks, pinion plus gear [mm, along the normal].
    removed_coast : float
        Largest material removed from the coast flanks, pinion plus gear [mm].
    thickening : float
        Largest thickening of the teeth in one section: added on the drive plus the coast flank,
        both members [mm]; > normal backlash: the pair jams.
    z_thickest : float
        Section of ``thickening`` [mm].
    """

    added_drive: float
    removed_coast: float
    thickening: float
    z_thickest: float


#: tolerance of the jam check [mm] (1 nm: round-off of the sampled deviations)
JAM_TOL = 1e-6


def _flank_deviation_grid(tooth, side: str, p, zs, n_u: int) -> np.ndarray:
    """Normal deviation [mm] of ``tooth``'s modified ``side`` flank, (n_u, len(zs)): ``n_u`` points
    from the form circle (the fillet junction) to the tip circle in each section of ``zs`` [mm]."""
    p = np.asarray(p, float)
    u_f, _ = tooth.junction(p)
    out = np.full((n_u, len(zs)), np.nan)
    for j, z in enumerate(zs):
        try:
            u_a = tooth.u_at_radius(tooth.gear.r_a, float(z), side, p)
        except GearoptError:
            u_a = float(tooth.extras.get("q_pitch", 0.0))
        u = np.linspace(u_a, u_f, n_u)
        out[:, j] = tooth.normal_deviation(side, u, np.full(n_u, float(z)), p)
    return out


class EdgeClearance:
    """The clearance and jam checks of :class:`~gearopt.contact.edge.EdgeContact` (a mixin: it uses its
    ``tca``, ``members`` and the memo ``_memo`` / ``_remember``)."""

    def _coast_clearance(self, p1, p2, mis: Misalignment) -> float:
        """Upper bound of the gear's advance over the conjugate position of the aligned drive [rad]:
        circumferential backlash plus the pinion thinning by crowning plus what the misalignment can
        open, on the operating pitch circle of the gear (a generous bound of the coast-side
        clearance), plus the rigid displacement of the gear by the misalignment. Memoised per exact
        (p1, p2, mis)."""
        key = ("coast", exact_key(p1), exact_key(p2), exact_key([getattr(mis, k) for k in mis.names()]))
        hit = self._memo.get(key)
        if hit is None:
            hit = self._remember(key, self._coast_clearance_of(p1, p2, mis))
        return hit

    def _coast_clearance_of(self, p1, p2, mis: Misalignment) -> float:
        pair, tca = self.tca.pair, self.tca
        g1 = pair.pinion
        r_w2 = pair.r_w2
        a_pl, a_c, u_0 = (p1[tca.layout.p_index("pinion", k)] for k in ("a_pl", "a_c", "u_0"))
        u_f, _ = tca.pinion.junction(p1)
        u_tip = tca.pinion.u_at_radius(g1.r_a, 0.0, tca.side, p1)
        u_span = max(abs(u_tip - u_0), abs(u_f - u_0))
        thin = 2 * (a_pl * (g1.b / 2) ** 2 * math.tan(pair.alpha_wt) + a_c * u_span**2)
        opened = mis.backlash_opening(pair)
        # The misalignment also moves the gear rigidly against the conjugate position: a point P of
        # its flank moves by at most the sum of the displacements plus the angles times |P - O2|
        # (Misalignment.rigid_displacement; the angles turn the gear about its centre: for a helical
        # gear that is an axial shift of the mesh, i.e. a rotation), which the gear's rotation takes
        # up along the normal, on the lever r_b2 cos(beta_b) at least.
        g2 = pair.gear
        lever = math.hypot(g2.r_a, g2.b / 2)
        moved = mis.rigid_displacement(lever) / (g2.r_b * math.cos(g2.beta_b))
        mods = self.modification_extent(p1, p2)
        # ISO/measured modifications: material added on a driving flank lets the gear advance past the
        # conjugate position by that much along the normal; material removed on a coast flank widens
        # the coast-side gap (both on the normal lever r_b2 cos(beta_b)).
        iso = (mods.added_drive + mods.removed_coast) / (g2.r_b * math.cos(g2.beta_b))
        return (max(pair.backlash, 0.0) + thin + opened) / r_w2 + moved + iso + 1e-9

    #: grid of the modification check: flank points along the profile and sections across the face
    _MOD_GRID = (13, 41)

    def modification_extent(self, p1: Param, p2: Param) -> ModificationExtent:
        """Extremes of the flank modifications (ISO amounts, measured topographies, any
        :class:`~gearopt.geometry.modification.FlankModification`) of both members for ``p1``,
        ``p2``, sampled on the active flanks (``_MOD_GRID`` points along the profile from the form
        to the tip circle, times sections across the common face width). Cached per (p1, p2)."""
        key = (tuple(np.round(np.asarray(p1, float), 15)), tuple(np.round(np.asarray(p2, float), 15)))
        cache = self.__dict__.setdefault("_mod_cache", {})
        if key in cache:
            return cache[key]
        tca = self.tca
        nu, nz = self._MOD_GRID
        half = 0.5 * min(self.members[1].b, self.members[2].b)
        zs = np.linspace(-half, half, nz)
        drive, coast = tca.side, ("left" if tca.side == "right" else "right")
        added_drive = removed_coast = 0.0
        thick = np.zeros(nz)  # tooth thickening at each section, both members [mm, along the normal]
        for member, tooth, p in ((1, tca.pinion, p1), (2, tca.gear, p2)):
            if not tooth.modifications:
                continue
            d = {side: _flank_deviation_grid(tooth, side, p, zs, nu) for side in (drive, coast)}
            added_drive = added_drive + max(0.0, float(np.nanmax(d[drive])))
            removed_coast = removed_coast + max(0.0, -float(np.nanmin(d[coast])))
            thick = thick + np.nanmax(d[drive], axis=0) + np.nanmax(d[coast], axis=0)
        j = int(np.argmax(thick))
        t_max, z_max = float(thick[j]), float(zs[j])
        if 0 < j < nz - 1:  # the vertex of the parabola through the largest sample and its neighbours
            a, b_, c = thick[j - 1], thick[j], thick[j + 1]
            den = a - 2 * b_ + c
            if den < 0:
                s = 0.5 * (a - c) / den
                t_max, z_max = float(b_ - 0.25 * (a - c) * s), float(zs[j] + s * (zs[1] - zs[0]))
        out = ModificationExtent(added_drive=added_drive, removed_coast=removed_coast, thickening=t_max,
                                 z_thickest=z_max)
        cache[key] = out
        return out

    def _check_not_jammed(self, p1, p2) -> None:
        """A pair whose modified teeth are thicker, in some section, than the normal backlash
        leaves room for cannot turn: both flanks of a tooth touch the mating teeth (GeometryError)."""
        ext = self.modification_extent(p1, p2)
        j_bn = self.tca.pair.backlash_normal[0]
        if ext.thickening > max(j_bn, 0.0) + JAM_TOL:
            raise GeometryError(
                f"the pair jams: the flank modifications make the teeth {ext.thickening * 1e3:.3g} um thicker "
                f"(drive plus coast flank, along the normal, both members) at z = {ext.z_thickest:.3g} mm than the "
                f"unmodified teeth, while the smallest normal backlash j_bn is {max(j_bn, 0.0) * 1e3:.3g} um; the coast "
                "flanks would be in contact as well. Increase the backlash (thinner teeth: A_sne, or a larger "
                "centre distance) or remove material instead of adding it (modification amounts, sides = "
                "\"right\"/\"left\" for one flank only).")
