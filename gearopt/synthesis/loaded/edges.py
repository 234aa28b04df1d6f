"""Edge loading of a loaded slice set: the graded weight of every slice in the edge-loading
constraint (tip edges, face ends and the tip band of the flanks), its linearisation in the design,
the edge that carries the most load, and the slices' gaps of a loaded result."""

from __future__ import annotations

import math

import numpy as np

from ...gears import GearPair
from ...ltca.slices import SliceSet

from ...ltca.engine import F_MIN_SHARE, LoadedResult, LoadedSweep
from .constants import TIP_BAND


def edge_weight(S: SliceSet, pair: GearPair) -> np.ndarray:
    """(K, N, M) weight of each slice in the edge-loading constraint: 1 on the tip-edge slices and the
    face ends z = +-b/2; on flank slices it grows linearly from 0 to 1 over the last ``TIP_BAND`` m_n
    (radial) below either member's tip circle (a contact there reaches the tip corner). Graded, so that
    the constraint does not jump when the design moves a loaded slice towards the tip, or when a slice
    turns from flank contact just below the tip into tip-edge contact."""
    e = np.zeros(S.z.shape, bool) if S.edge is None else S.edge > 0
    g1, g2 = pair.pinion, pair.gear
    with np.errstate(invalid="ignore"):
        ends = np.abs(np.abs(S.z) - g1.b / 2) < 1e-9
        w1 = (np.hypot(S.r1[..., 0], S.r1[..., 1]) - (g1.r_a - TIP_BAND * g1.m_n)) / (TIP_BAND * g1.m_n)
        w2 = (np.hypot(S.r2[..., 0], S.r2[..., 1]) - (g2.r_a - TIP_BAND * g2.m_n)) / (TIP_BAND * g2.m_n)
        w = np.clip(np.fmax(np.nan_to_num(w1, nan=0.0), np.nan_to_num(w2, nan=0.0)), 0.0, 1.0)
    return np.where(e | ends, 1.0, w)


def edge_weight_lin(S: SliceSet, pair: GearPair, Jr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edge weight of :func:`edge_weight` linearised in the design and misalignment: ``(w0, g)``,
    (K, N, M) and (K, N, M, Q). On a flank slice, ``w0`` is the unclipped band coordinate
    ``(r - (r_a - TIP_BAND m_n)) / (TIP_BAND m_n)`` of the member whose tip is nearer and ``g`` its
    gradient from the point's radial sensitivities ``Jr`` (K, N, M, 2, Q) [mm per unit]: a crowned
    contact point moves along the profile some ten microns per micron of crowning, so a weight held
    at the linearisation misses the load a step brings into the band. Tip edges and face ends: 1 and 0."""
    g1, g2 = pair.pinion, pair.gear
    band1, band2 = TIP_BAND * g1.m_n, TIP_BAND * g2.m_n
    with np.errstate(invalid="ignore"):
        w1 = np.nan_to_num((np.hypot(S.r1[..., 0], S.r1[..., 1]) - (g1.r_a - band1)) / band1, nan=-np.inf)
        w2 = np.nan_to_num((np.hypot(S.r2[..., 0], S.r2[..., 1]) - (g2.r_a - band2)) / band2, nan=-np.inf)
    pin = w1 >= w2
    w0 = np.where(pin, w1, w2)
    g = np.where(pin[..., None], Jr[..., 0, :] / band1, Jr[..., 1, :] / band2)
    with np.errstate(invalid="ignore"):
        ends = np.abs(np.abs(S.z) - g1.b / 2) < 1e-9
    fixed = edge_weight(S, pair) >= 1.0
    fixed |= (np.zeros(S.z.shape, bool) if S.edge is None else S.edge > 0) | ends
    lost = ~np.isfinite(w0) | ~S.active
    w0 = np.where(fixed, 1.0, np.where(lost, 0.0, w0))
    g = np.where((fixed | lost)[..., None], 0.0, np.nan_to_num(g))
    return w0, g


def edge_where(sw: LoadedSweep, t: int, pair: GearPair) -> tuple[str, str]:
    """Which edge carries the most weighted load at torque ``t`` of a loaded sweep, in words, and the
    modification that would open it: ``(where, hint)``."""
    S, r = sw.slices, sw.results[t]
    w = edge_weight(S, pair) * r.load
    k, n, m = np.unravel_index(int(np.argmax(np.nan_to_num(w))), w.shape)
    at = f" (pair {S.pairs[k]}, phi1 = {math.degrees(S.phi1[n]):.3g} deg, z = {S.z[k, n, m]:.3g} mm)"
    kind = 0 if S.edge is None else int(S.edge[k, n, m])
    if kind == 1:
        return "the pinion's tip edge" + at, "Free or widen the pinion's tip relief (C_alpha_a)"
    if kind == 2:
        return "the gear's tip edge" + at, "Free or widen the pinion's root relief (C_alpha_f) or the gear's tip relief"
    if abs(abs(S.z[k, n, m]) - pair.pinion.b / 2) < 1e-9:
        return "a face end" + at, "Free or widen the lead crowning (C_beta) or an end relief (C_beta_I/II)"
    return "a flank slice at a tip" + at, "Free or widen a tip or root relief"


def edge_mask(S: SliceSet, pair: GearPair) -> np.ndarray:
    """(K, N, M) slices that count in the edge loading (weight > 0, :func:`edge_weight`)."""
    return edge_weight(S, pair) > 0


def loaded_gaps(sw: LoadedSweep, r: LoadedResult) -> np.ndarray:
    """(K, N, M) gaps g = s + C F - delta [mm] of a loaded result (every active slice, exact compliance)."""
    from ...ltca.compliance import weber_contact

    S = sw.slices
    st = sw.structure
    K, N, M = S.z.shape
    lever = sw.ltca.pair.gear.r_b * sw.ltca.cos_bb
    g1 = sw.ltca.pair.pinion
    # each slice on its own levers (LTCA._solve_one): the gap closes by delta times lever1 / (r_b1 cos(beta_b))
    lev2 = lever if S.lever2 is None else np.where(S.active & np.isfinite(S.lever2), S.lever2, lever)
    lam = 1.0 if r.lever is None else r.lever / (g1.r_b * sw.ltca.cos_bb)
    s = np.where(S.active, (r.te_unloaded[None, :, None] - S.te) * lev2, 0.0)
    F = np.transpose(r.load, (1, 0, 2)).reshape(N, K * M)
    CF = np.einsum("nij,nj->ni", st.Cs, F)
    CF = np.transpose(CF.reshape(N, K, M), (1, 0, 2))
    f_min = F_MIN_SHARE * r.W * sw.ltca.cos_bb / g1.b
    cH = weber_contact(r.load / st.length, st.R, st.h1, st.h2, sw.ltca.material, f_min).compliance
    return s + CF + cH * r.load / st.length - r.delta[None, :, None] * lam
