"""The neighbouring teeth's coupling through the gear body in loaded TCA's analytical compliance
(docs/ltca.md sections 2 and 7, ``LTCASettings.neighbours``).

A line load on one tooth of a gear held at its bore deflects the body under it, and with it the other
teeth: in plane-stress FE full gears (``python benchmarks/fe_body_fit.py --neighbours``) the tooth ``d``
pitches away moves along its own normal, per unit line load [mm^2/N], by

    n(d) = c_tw + A exp(-k |d| s_f / (r_f - r_int)) (c_body - c_tw),                                 (N1)

``c_tw = r_b^2 (1 / r_int^2 - 1 / r_f^2) / (4 pi G)`` the torsion of the annulus between the bore ``r_int`` and
the root circle ``r_f`` (the ring's rotation under the load's torque; the term's limit for many teeth),
``c_body`` the loaded tooth's own body term (:class:`~gearopt.ltca.compliance.ToothCompliance`'s foundation) at its pitch point, ``s_f = 2 pi r_f / z``
the root pitch, ``A``, ``k`` :data:`NEIGHBOUR_FIT` (fitted to the FE gears of benchmarks/fe_body_fit.py). (N1) is
one number per member and ``d``, whatever the rows of the loaded and the responding slice: against the FE
within 12.3 % at every row from ``r_f / r_int`` = 3 up, -22 to +34 % at 2-2.5 (the row and the profile shift),
up to +84 % on thinner bodies (hold-out gears: 14.6 %; docs/ltca.md section 7).

On a helical member the normal load has the axial part ``sin(beta_b)``, which bends the body out of its plane (the
disc of thickness ``b`` held at its bore), a mode the plane-stress gears of (N1) do not have. With ``helical =
"normal"`` the term is

    (1 - sin^2(beta_b)) n(d) + sin^2(beta_b) a(d),                                                    (N2)

``a(d)`` the axial response of an annular Mindlin plate (:mod:`gearopt.ltca.plate`, :func:`axial_part`): no fitted
constant. Against the FE full gears' responses of the helical members of docs/ltca.md section 7 and a hold-out
gear (z 60, beta 25 deg) it puts the teeth d = 1, 2 at the mid row at 0.96-1.03 of the FE, where (N1) alone gave
1.04-1.25 (1.81 on the hold-out); the spur gears' pattern is 0.97-1.06 (section 7, "The axial part").

Loaded TCA couples the slices of pairs ``k`` and ``k'`` (pinion teeth ``|k - k'|`` pitches apart, and gear
teeth likewise) by ``cos^2(beta_b) (n_1(d) G_1 + n_2(d) G_2)``, ``G_m`` each member's body coupling across the
face (the Pasternak kernel over the body's depth, :func:`~gearopt.ltca.compliance.coupling`) on the tooth's
slice grid: a line load uniform over the face on one pair moves the other pair's slices by exactly
``cos^2(beta_b) (n_1 + n_2) f``. The compliance matrix stays symmetric; one pair in mesh is not changed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..geometry.generation import GeneratedTooth
from .compliance import ToothCompliance, coupling_batch
from .plate import axial_response

#: (A, k) of (N1): least squares on the logarithm of (n - c_tw) / (c_body - c_tw) of the fitting gears of
#: benchmarks/fe_body_fit.py (d = +-1, +-2 at three rows each; ``python benchmarks/fe_body_fit.py --neighbours
#: --record``, benchmarks/data/fe_body_fit.json "neighbour_fit"; docs/ltca.md section 7)
NEIGHBOUR_FIT = (0.6345, 1.0531)
#: the values of ``LTCASettings.neighbours``
NEIGHBOURS = ("full_gear", "none")


def torsion(tc: ToothCompliance, r_b: float) -> float:
    """``c_tw`` of (N1) [mm^2/N]: the rotation of the root circle against the bore of an annulus under a
    torque per unit face width, times ``r_b^2`` (plane stress, shear modulus ``E / (2 (1 + nu))``), in the
    frame of the member's body term (its ``body_factor``)."""
    m = tc.material
    G = m.E / (2.0 * (1.0 + m.nu))
    return tc.body_factor * r_b**2 * (1.0 / tc.r_int**2 - 1.0 / tc.r_f**2) / (4.0 * math.pi * G)


def pitch_body(tc: ToothCompliance, tooth: GeneratedTooth) -> float:
    """The body term of ``tc`` [mm^2/N] for a load at the pitch point of ``tooth``'s right flank (mid face,
    transverse section), along the flank normal: its in-plane part (without a helical member's axial part)."""
    g = tooth.gear
    pr = tooth.transverse_profile(z=0.0, n=600)["right_flank"]
    rr = np.hypot(pr[:, 0], pr[:, 1])
    o = np.argsort(rr)
    pr, rr = pr[o], rr[o]
    tg = np.gradient(pr, axis=0)
    nrm = np.stack([tg[:, 1], -tg[:, 0]], 1)
    nrm *= np.sign(nrm[:, :1] * pr[:, :1])
    r = float(np.clip(g.r_p, rr[0], rr[-1]))
    xy = np.array([[np.interp(r, rr, pr[:, k]) for k in range(2)]])
    n = np.array([[np.interp(r, rr, nrm[:, k]) for k in range(2)]])
    return float(tc.per_width(xy, n, axial=False).foundation[0])


def axial_part(tc: ToothCompliance, tooth: GeneratedTooth) -> tuple[float, ...]:
    """The body's axial response [mm^2/N] of the teeth ``d = 1, 2, ..., z // 2`` pitches from the loaded one, per
    unit axial line load over the face (N2): the annular Mindlin plate of :func:`gearopt.ltca.plate.axial_response`
    (thickness the face width ``b``, held at ``r_int``, free at ``r_f``; loaded and read at the pitch radius through
    the tooth as a rigid lever, the load spread over the angle ``b tan(beta) / r_p`` its helix spans), times ``b``
    and ``tc``'s ``body_factor``."""
    g = tooth.gear
    d = np.arange(1, max(g.z // 2, 1) + 1)
    w = axial_response(tc.r_int, tc.r_f, g.b, 2.0 * np.pi * d / g.z, lever=g.r_p - tc.r_f,
                       spread=g.b * math.tan(abs(g.beta)) / g.r_p, E=tc.material.E, nu=tc.material.nu)
    return tuple(float(x) for x in tc.body_factor * g.b * w)


@dataclass(frozen=True)
class NeighbourTerm:
    """(N1) of one member: ``n(d) = c_tw + A exp(-k |d| x) (c_body - c_tw)`` [mm^2/N] (:meth:`of`), on a helical
    member with its axial part (N2): ``(1 - q) n(d) + q a(d)``.

    Attributes
    ----------
    c_tw : float
        The body's torsion [mm^2/N] (:func:`torsion`).
    c_body : float
        The loaded tooth's own body term at its pitch point [mm^2/N] (:func:`pitch_body`).
    x : float
        ``s_f / (r_f - r_int)``, the root pitch over the body's depth.
    A, k : float
        The constants of (N1) (:data:`NEIGHBOUR_FIT`).
    q : float
        ``sin^2(beta_b)``, the axial part's share of a normal load's work (0: none, a spur gear or
        ``helical = "transverse"``).
    axial : tuple of float
        ``a(d)`` of (N2) for ``d = 1, 2, ...`` [mm^2/N] (:func:`axial_part`; beyond the last, the last).
    """

    c_tw: float
    c_body: float
    x: float
    A: float = NEIGHBOUR_FIT[0]
    k: float = NEIGHBOUR_FIT[1]
    q: float = 0.0
    axial: tuple[float, ...] = ()

    @classmethod
    def of(cls, tc: ToothCompliance, tooth: GeneratedTooth, fit: tuple[float, float] = NEIGHBOUR_FIT) -> NeighbourTerm:
        """The term of the member whose body term is ``tc`` and whose unmodified tooth is ``tooth``."""
        g = tooth.gear
        x = 2.0 * math.pi * tc.r_f / g.z / (tc.r_f - tc.r_int)
        axial = g.beta_b != 0.0 and tc.helical == "normal"
        return cls(c_tw=torsion(tc, g.r_b), c_body=pitch_body(tc, tooth), x=x, A=float(fit[0]), k=float(fit[1]),
                   q=math.sin(g.beta_b) ** 2 if axial else 0.0, axial=axial_part(tc, tooth) if axial else ())

    def __call__(self, d) -> np.ndarray:
        """``n(d)`` [mm^2/N] of the tooth ``d`` pitches from the loaded one (``d`` != 0)."""
        d = np.abs(np.asarray(d, float))
        n = self.c_tw + self.A * np.exp(-self.k * d * self.x) * (self.c_body - self.c_tw)
        if not self.q:
            return n
        a = np.asarray(self.axial)[np.clip(np.rint(d).astype(int), 1, len(self.axial)) - 1]
        return (1.0 - self.q) * n + self.q * a


def cross_blocks(Cs: np.ndarray, pairs: Sequence[int], z: tuple[np.ndarray, np.ndarray], widths: np.ndarray,
                 terms: tuple, lengths: tuple[float, float], cb: float) -> np.ndarray:
    """``Cs`` (N, K M, K M) with the pairs coupled through the bodies (module docstring).

    Parameters
    ----------
    Cs : (N, K M, K M) array
        The block-diagonal compliance (one block per pair) [mm/N]; not modified.
    pairs : sequence of int
        The pairs' indices (pinion tooth ``k`` meshes gear tooth ``-k``).
    z : ((K, N, M), (K, N, M)) arrays
        The slices' face positions on the pinion and on the gear [mm] (NaN where unused).
    widths : (K, N, M) array
        The slices' tributary widths on the tooth [mm].
    terms : (callable, callable)
        ``d -> n_m(d)`` of the pinion and the gear [mm^2/N] (:class:`NeighbourTerm`).
    lengths : (float, float)
        The bodies' coupling lengths across the face [mm].
    cb : float
        ``cos(beta_b)``.
    """
    K, N, M = widths.shape
    pairs = [int(p) for p in pairs]
    if K < 2:
        return Cs
    Cs = Cs.copy()
    Cv = Cs.reshape(N, K, M, K, M)
    used = np.isfinite(z[0])
    # the tooth's slice grid at each position: the nodes any pair uses (the slices are fixed to the tooth,
    # so every pair's used node m sits at the same face position)
    anyu = used.any(axis=0)  # (N, M)
    cnt = np.maximum(used.sum(axis=0), 1)
    wg = np.where(anyu, np.where(used, widths, 0.0).max(axis=0), 1.0)
    for zm, nfun, lam in zip(z, terms, lengths):
        zg = np.where(anyu, np.where(used, zm, 0.0).sum(axis=0) / cnt, np.nan)
        G = coupling_batch(zg, wg, float(lam))  # (N, M, M), zero at unused nodes
        for a in range(K):
            for b in range(K):
                if a == b:
                    continue
                nd = float(nfun(abs(pairs[b] - pairs[a])))
                mask = used[a][:, :, None] & used[b][:, None, :]
                Cv[:, a, :, b, :] += np.where(mask, cb**2 * nd * G, 0.0)
    return Cs


__all__ = ["NEIGHBOUR_FIT", "NEIGHBOURS", "NeighbourTerm", "axial_part", "cross_blocks", "pitch_body", "torsion"]
