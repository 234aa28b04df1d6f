"""Gear data of a gearopt pair for the ISO 6336 rating, and the load factors from its loaded TCA.

:func:`pair_data` reads a :class:`gearopt.gears.GearPair` into :class:`~gearopt.rating.iso6336.PairData`
(the basic rack of the pinion's tool; tip diameters, centre distance as built). :func:`ltca_load_factors`
runs gearopt's loaded TCA (:class:`gearopt.ltca.engine.LTCA`) at given torques and returns the face
and transverse load factors it implies (docs/rating.md, "Load factors from the loaded TCA").
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from gearopt.errors import GeometryError
from gearopt.rating.iso6336 import PairData

if TYPE_CHECKING:  # pragma: no cover
    from gearopt.gears import GearPair
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.settings import LTCAStudySettings


def pair_data(pair: GearPair) -> PairData:
    """The ISO 6336 gear data of ``pair`` (ISO 21771 symbols; the common face width min(b1, b2)).

    Raises
    ------
    GeometryError
        A member cut by a tool without a basic rack (a shaper: ISO 6336-3 method B's Y_F, Y_S are
        those of a rack-generated root), or members cut by different racks, naming the key.
    """
    g1, g2 = pair.pinion, pair.gear
    for key, g in (("pinion.tool", g1), ("gear.tool", g2)):
        if not g.tool.rack_settings:
            raise GeometryError(f"{key} = {g.tool.kind!r}: the ISO 6336-3 method B tooth form (Y_F, Y_S) is that of a "
                                "rack-generated root; valid: a rack-type tool (rack, hob).", param=key,
                                value=g.tool.kind, valid="a rack-type tool")
    r1, r2 = g1.rack, g2.rack
    if (r1.h_fP, r1.rho_fP) != (r2.h_fP, r2.rho_fP):
        raise GeometryError(f"gear.rack = {r2.name!r}: the rating takes one basic rack for both members (the pinion's "
                            f"{r1.name!r}); valid: the same h_fP and rho_fP.", param="gear.rack", value=r2.name,
                            valid="the pinion's rack")
    return PairData(z1=g1.z, z2=g2.z, m_n=g1.m_n, alpha_n=r1.alpha_n, beta=g1.beta, b=min(g1.b, g2.b), x1=g1.x,
                    x2=g2.x, a=pair.a_w, h_aP=r1.h_aP, h_fP=r1.h_fP, rho_fP=r1.rho_fP, d_a1=2 * g1.r_a,
                    d_a2=2 * g2.r_a)


def reference_pair(pair: GearPair) -> GearPair:
    """``pair`` without micro-geometry: no flank modifications, no plunging crowning, straight tool."""
    from gearopt.gears import GearPair as GP

    def plain(g: Any) -> Any:
        return dataclasses.replace(g, modifications=None, a_pl=0.0, rack=dataclasses.replace(g.rack, a_c=0.0))

    return GP(plain(pair.pinion), plain(pair.gear), a=pair.a)


def pair_line_loads(ltca: Any, torques: Sequence[float], misalignment: Misalignment | None,
                    positions: int) -> tuple[list, list]:
    """Run the loaded TCA at ``torques`` [N m]: per torque the face load factor (the engine's
    ``K_Hbeta``: peak over mean line load across the face of the most loaded contact) and the largest
    mean line load of a tooth pair over the mesh cycle [N/mm] (its normal load over its contact
    line's length within the face)."""
    from gearopt.ltca.engine import LoadedSweep

    S = ltca.slices(ltca.mesh_cycle(positions), mis=misalignment)
    results = [ltca.solve(t, slices=S).results[0] for t in torques]
    sweep = LoadedSweep(slices=S, results=results, separation_time=0.0, structure=ltca.structure(S),
                        te_zero_rad=S.phi2_ref, ltca=ltca)
    d = sweep.to_dict(ltca.pair.pinion.z)
    length = np.nansum(np.where(np.isfinite(S.z), S.width, 0.0), axis=2)
    w_max = [float(np.max(r.pair_load / np.maximum(length, 1e-12))) for r in results]
    return [t["K_Hbeta"] for t in d["torques"]], w_max


def ltca_load_factors(pair: GearPair, torques: Sequence[float], misalignment: Misalignment | None,
                      settings: LTCAStudySettings, progress: Any = None) -> dict:
    """K_Hbeta and K_Halpha from gearopt's loaded TCA at ``torques`` [N m].

    K_Hbeta: peak over mean line load across the face (ISO 6336-1:2019 3.1 definition) of the contact
    with the largest line load of the cycle, with the pair's micro-geometry and ``misalignment``.
    K_Halpha: the largest mean line load of a tooth pair over the cycle divided by the same of the
    unmodified, aligned pair at the same torque (ISO's K_Halpha covers the departure from the ideal
    sharing that Z_epsilon, Z_B assume), not below 1 (ISO 6336-1:2019 8.3.4).

    Returns
    -------
    dict
        ``K_Hbeta``, ``K_Halpha`` (lists per torque), ``K_Halpha_raw``, ``w_pair_max_N_per_mm``,
        ``w_pair_max_reference_N_per_mm``.
    """
    from gearopt.ltca.engine import LTCA
    from gearopt.meshing.misalignment import Misalignment as Mis

    say = progress or (lambda _m: None)
    say(f"rating: loaded TCA of the pair at {len(torques)} torques")
    khb, w = pair_line_loads(LTCA(pair, settings), torques, misalignment, settings.positions)
    say("rating: loaded TCA of the unmodified, aligned pair (reference load sharing)")
    _, w_ref = pair_line_loads(LTCA(reference_pair(pair), settings), torques, Mis(), settings.positions)
    raw = [a / b for a, b in zip(w, w_ref)]
    return {"K_Hbeta": khb, "K_Halpha": [max(1.0, r) for r in raw], "K_Halpha_raw": raw,
            "w_pair_max_N_per_mm": w, "w_pair_max_reference_N_per_mm": w_ref}
