"""Gear data of a gearopt pair for the ISO 6336 rating, and the load factors from its loaded TCA.

:func:`pair_data` reads a :class:`gearopt.gears.GearPair` into :class:`~gearopt.rating.iso6336.PairData`
(the basic rack of the pinion's tool; tip diameters, centre distance as built). :func:`ltca_load_factors`
runs gearopt's loaded TCA (:class:`gearopt.ltca.engine.LTCA`) at given torques and returns the face
and transverse load factors it implies (docs/rating.md, "Load factors from the loaded TCA").
"""

from __future__ import annotations

import dataclasses
import math
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


def generated_tooth_forms(pair: GearPair, p: PairData | None = None) -> tuple[dict, dict] | None:
    """The critical sections of ISO 6336-3 method B measured on each member's generated tooth (its own
    tool, tooth thickness allowance, fillet): the points where the fillet's tangent makes 30 deg with the
    tooth centre line, the fillet radius there, and the load at the outer point of single pair contact
    (``d_en`` of the closed form) along the flank normal (:func:`gearopt.fea.references.root_stress_estimate`).

    Returns
    -------
    (dict, dict) or None
        ``s_Fn``, ``h_Fe``, ``rho_F`` [mm], ``alpha_Fen`` [rad] of pinion and gear; None for a helical
        pair (ISO rates its virtual spur gear, which is not a section of the generated tooth).
    """
    from gearopt.fea.references import root_stress_estimate
    from gearopt.geometry.generation import generate
    from gearopt.rating.iso6336 import geometry, tooth_form

    if not pair.pinion.is_spur:
        return None
    p = pair_data(pair) if p is None else p
    g = geometry(p)
    out = []
    for i, gear in enumerate((pair.pinion, pair.gear)):
        d_en = tooth_form(i, p, g)["d_en"]
        est = root_stress_estimate(generate(gear), 0.5 * d_en, 1.0, 1.0)
        out.append({"s_Fn": float(est["s_Fn"]), "h_Fe": float(est["h_Fe"]), "rho_F": float(est["rho_F"]),
                    "alpha_Fen": math.radians(est["alpha_Fen_deg"])})
    return out[0], out[1]


def mesh_misalignment(b: float, alpha_wt: float, crossing: float, intersecting: float) -> float:
    """ISO 6336-1's mesh misalignment f_ma [um] equivalent to a misalignment of the axes: the separation
    across the face width ``b`` [mm] in the plane of action that the crossing (axes skewed about the
    centre line) and intersecting (axes tilted toward each other) angles [rad] open, b (|crossing| cos
    alpha_wt + |intersecting| sin alpha_wt) (the two add on one of the flanks)."""
    return 1000.0 * b * (abs(crossing) * math.cos(alpha_wt) + abs(intersecting) * math.sin(alpha_wt))


def reference_pair(pair: GearPair) -> GearPair:
    """``pair`` without micro-geometry: no flank modifications, no plunging crowning, straight tool."""
    from gearopt.gears import GearPair as GP

    def plain(g: Any) -> Any:
        return dataclasses.replace(g, modifications=None, a_pl=0.0, rack=dataclasses.replace(g.rack, a_c=0.0))

    return GP(plain(pair.pinion), plain(pair.gear), a=pair.a)


def face_load_factor(load: np.ndarray, width_tooth: np.ndarray) -> tuple[float, np.ndarray]:
    """K_Hbeta of a loaded mesh cycle: peak over mean of the load per unit face width across the face.

    Parameters
    ----------
    load : (K, N, M) array
        Normal load of each slice node [N] (pairs K, positions N, face sections M), NaN/0 where unused.
    width_tooth : (K, N, M) array
        Each node's tributary width of the face [mm].

    Returns
    -------
    (float, ndarray)
        K_Hbeta and the cycle-mean load per unit face width at the M sections [N/mm]: at each
        position the loads of all pairs in contact at a section over its width, averaged over the
        cycle (the distribution across the face that ISO 6336-1's K_Hbeta describes).
    """
    f = np.where(np.isfinite(load), load, 0.0)
    wt = np.nanmax(np.where(np.isfinite(width_tooth), width_tooth, 0.0), axis=(0, 1))   # (M,) section widths
    w = np.sum(f, axis=0) / np.maximum(wt, 1e-12)[None, :]                                # (N, M) per position
    w_mean = np.mean(w, axis=0)
    mean = float(np.sum(w_mean * wt) / np.sum(wt))
    return float(np.max(w_mean) / mean), w_mean


def pair_line_loads(ltca: Any, torques: Sequence[float], misalignment: Misalignment | None,
                    positions: int) -> dict:
    """Run the loaded TCA at ``torques`` [N m]; per torque: ``K_Hbeta`` (:func:`face_load_factor`), the
    face distribution ``w_face`` [N/mm] at the sections ``z_face`` [mm], ``K_Hbeta_line`` (the engine's
    peak over mean along the most loaded contact line) and ``w_pair_max``, the largest mean line
    load of a tooth pair over the cycle [N/mm] (its normal load over its contact line's length)."""
    from gearopt.ltca.engine import LoadedSweep

    S = ltca.slices(ltca.mesh_cycle(positions), mis=misalignment)
    # one call over the distinct torques in increasing order: the contact structure once, each torque's
    # contact set started from the previous one's; then back in the caller's order
    T = [float(t) for t in torques]
    distinct = sorted(set(T))
    solved = ltca.solve(distinct, slices=S)
    by_torque = dict(zip(distinct, solved.results))
    results = [by_torque[t] for t in T]
    sweep = LoadedSweep(slices=S, results=results, separation_time=0.0, structure=solved.structure,
                        te_zero_rad=S.phi2_ref, ltca=ltca)
    d = sweep.to_dict(ltca.pair.pinion.z)
    length = np.nansum(np.where(np.isfinite(S.z), S.width, 0.0), axis=2)
    face = [face_load_factor(np.where(np.isfinite(S.z), r.load, 0.0), S.width_tooth) for r in results]
    z = np.nanmax(np.where(np.isfinite(S.z), S.z, np.nan), axis=(0, 1))
    return {"K_Hbeta": [k for k, _ in face], "w_face": [w.tolist() for _, w in face], "z_face": z.tolist(),
            "K_Hbeta_line": [t["K_Hbeta"] for t in d["torques"]],
            "w_pair_max": [float(np.max(r.pair_load / np.maximum(length, 1e-12))) for r in results]}


def ltca_load_factors(pair: GearPair, torques: Sequence[float], misalignment: Misalignment | None,
                      settings: LTCAStudySettings, progress: Any = None) -> dict:
    """K_Hbeta and K_Halpha from gearopt's loaded TCA at ``torques`` [N m].

    K_Hbeta: peak over mean load per unit face width across the face (ISO 6336-1:2019 definition of
    the face load factor), the loads of all pairs in contact averaged over the mesh cycle, with the
    pair's micro-geometry and ``misalignment`` (:func:`face_load_factor`).
    K_Halpha: the largest mean line load of a tooth pair over the cycle divided by the same of the
    unmodified, aligned pair at the same torque (ISO's K_Halpha covers the departure from the ideal
    sharing that Z_epsilon, Z_B assume), not below 1 (ISO 6336-1:2019 8.3.4).

    Returns
    -------
    dict
        ``K_Hbeta``, ``K_Halpha`` (lists per torque), ``K_Halpha_raw``, ``K_Hbeta_line``,
        ``w_face_N_per_mm`` (per torque, at ``z_face_mm``), ``w_pair_max_N_per_mm``,
        ``w_pair_max_reference_N_per_mm``.
    """
    from gearopt.ltca.engine import LTCA
    from gearopt.meshing.misalignment import Misalignment as Mis

    say = progress or (lambda _m: None)
    say(f"rating: loaded TCA of the pair at {len(torques)} torques")
    act = pair_line_loads(LTCA(pair, settings), torques, misalignment, settings.positions)
    say("rating: loaded TCA of the unmodified, aligned pair (reference load sharing)")
    ref = pair_line_loads(LTCA(reference_pair(pair), settings), torques, Mis(), settings.positions)
    raw = [a / b for a, b in zip(act["w_pair_max"], ref["w_pair_max"])]
    return {"K_Hbeta": act["K_Hbeta"], "K_Halpha": [max(1.0, r) for r in raw], "K_Halpha_raw": raw,
            "K_Hbeta_line": act["K_Hbeta_line"], "w_face_N_per_mm": act["w_face"], "z_face_mm": act["z_face"],
            "w_pair_max_N_per_mm": act["w_pair_max"], "w_pair_max_reference_N_per_mm": ref["w_pair_max"]}
