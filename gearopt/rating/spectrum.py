"""Service life under a load spectrum (ISO 6336-6:2019): Palmgren-Miner damage with the S-N curves of
ISO 6336-2/-3, and the safety factor against the spectrum.

The S-N curve of a member and mode is its permissible stress without the life factor (the
reference level, Z_NT = 1 or Y_NT = 1) times the life factor's log-log lines (ISO 6336-2:2019 Table 2,
ISO 6336-3:2019 Table 3). As in ISO 6336-6:2019 Annex C, the finite-life line continues above the
static corner for the damage (a bin above the static strength is flagged), and stresses below the
curve's value at 1e10 cycles do no damage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from gearopt.errors import OptionError, out_of_range
from gearopt.rating.iso6336 import (Accuracy, Operation, PairData, Rating, life_points_F, life_points_H, rate)
from gearopt.rating.materials import Material


@dataclass(frozen=True)
class SNCurve:
    """An S-N curve: ``sigma(N) = sigma_ref * factor(N)``, ``factor`` linear in log-log between ``points``.

    Parameters
    ----------
    sigma_ref : float
        The stress at factor 1 [N/mm^2].
    points : tuple of (N, factor)
        Corner points, increasing N, decreasing factor (static, reference, 1e10 cycles).
    """

    sigma_ref: float
    points: tuple

    def segments(self) -> list[tuple[float, float, float]]:
        """(N_0, factor_0, slope) of each line, slope = d ln(factor) / d ln(N)."""
        pts = self.points
        return [(n0, y0, math.log(y1 / y0) / math.log(n1 / n0)) for (n0, y0), (n1, y1) in zip(pts[:-1], pts[1:])]

    def factor(self, N: float) -> float:
        """The life factor at ``N`` cycles (the first line extended below its start; constant past the end)."""
        if N >= self.points[-1][0]:
            return self.points[-1][1]
        for (n0, y0, k), (n1, _) in zip(self.segments(), self.points[1:]):
            if N <= n1:
                return y0 * (N / n0) ** k
        return self.points[-1][1]

    def stress(self, N: float) -> float:
        """sigma(N) [N/mm^2]."""
        return self.sigma_ref * self.factor(N)

    def cycles(self, sigma: float) -> float:
        """Cycles to failure at stress ``sigma`` [N/mm^2] (``math.inf`` at or below the last point's level)."""
        f = sigma / self.sigma_ref
        if f <= self.points[-1][1]:
            return math.inf
        for (n0, y0, k), (_, y1) in zip(self.segments(), self.points[1:]):
            if f >= y1:
                return n0 * (f / y0) ** (1.0 / k)
        return math.inf


def miner(sigma: Sequence[float], cycles: Sequence[float], curve: SNCurve) -> dict:
    """Palmgren-Miner damage (ISO 6336-6:2019, clause 5): per bin the cycles to failure N_i at its stress
    and the damage n_i / N_i, and their sum.

    Parameters
    ----------
    sigma : sequence of float
        Stress of each bin [N/mm^2].
    cycles : sequence of float
        Load cycles of each bin.
    curve : SNCurve
    """
    N = [curve.cycles(s) for s in sigma]
    U = [0.0 if math.isinf(Ni) else n / Ni for n, Ni in zip(cycles, N)]
    return {"N": [None if math.isinf(x) else x for x in N], "U": U, "D": float(sum(U))}


def spectrum_safety(sigma: Sequence[float], cycles: Sequence[float], curve: SNCurve) -> float:
    """Safety factor against the spectrum: S = k, the factor by which every bin's stress may be
    multiplied before the damage sum reaches 1 (D(k sigma_i) = 1; S > 1: the spectrum does less than
    the life's damage). Bisection in log k; ``math.inf`` when no bin has load and cycles."""
    if not any(c > 0 and s > 0 for s, c in zip(sigma, cycles)):
        return math.inf

    def D(k: float) -> float:
        return miner([k * s for s in sigma], cycles, curve)["D"]

    lo, hi = 1e-3, 1e3
    if D(hi) < 1.0:
        return hi
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if D(mid) < 1.0 else (lo, mid)
        if hi / lo < 1 + 1e-12:
            break
    return math.sqrt(lo * hi)


@dataclass(frozen=True)
class Bin:
    """One bin of a load spectrum: pinion torque T [N m], pinion speed n [1/min], share of the life."""

    T: float
    n: float
    share: float


def check_bins(bins: Sequence[Bin], name: str = "spectrum") -> None:
    """Refuse an empty spectrum, a bin with T <= 0, n <= 0 or a negative share, and shares that do not
    add up to 1 (within 1e-6), naming ``name``."""
    if not bins:
        raise out_of_range(name, [], "at least one bin (torque, speed, share)", cls=OptionError)
    for i, b in enumerate(bins):
        if not (b.T > 0 and b.n > 0 and b.share >= 0):
            raise out_of_range(f"{name}[{i}]", (b.T, b.n, b.share), "torque > 0 N m, speed > 0 1/min, share >= 0",
                               cls=OptionError)
    total = sum(b.share for b in bins)
    if abs(total - 1.0) > 1e-6:
        raise out_of_range(f"{name}_share", round(total, 9), "shares of the life adding up to 1", cls=OptionError,
                           hint="Give each bin's share of the required life (hours of the bin over the life).")


def rate_spectrum(p: PairData, bins: Sequence[Bin], op: Operation, mat1: Material, mat2: Material,
                  acc: Accuracy | None = None, load_factors: dict | None = None,
                  tooth_forms: tuple | None = None) -> dict:
    """Damage sums and safety factors of both members, pitting and bending, under a load spectrum.

    Parameters
    ----------
    p : PairData
    bins : sequence of Bin
        The spectrum; shares of ``op.L_h`` adding up to 1.
    op : Operation
        The requirements and conditions (``T1``, ``n1`` are replaced by each bin's).
    mat1, mat2 : Material
    acc : Accuracy or None
    load_factors : dict or None
        ``{T: (K_Hbeta, K_Halpha)}`` given per bin torque (from the loaded TCA); None: ISO's.
    tooth_forms : (dict, dict) or None
        As :func:`gearopt.rating.iso6336.rate`.

    Returns
    -------
    dict
        ``bins`` (per bin: torque, speed, hours, cycles, sigma_H, sigma_F, N, U per member and mode),
        ``damage`` and ``safety`` per mode and member, ``curves`` (sigma_ref and corner points).
    """
    import dataclasses

    check_bins(bins)
    acc = Accuracy() if acc is None else acc
    mats = (mat1, mat2)
    ratings: list[Rating] = []
    for b in bins:
        kh = (load_factors or {}).get(b.T, (None, None))
        ratings.append(rate(p, dataclasses.replace(op, T1=b.T, n1=b.n, K_Hbeta=kh[0], K_Halpha=kh[1]), mat1, mat2, acc,
                            tooth_forms))
    u = p.z2 / p.z1
    hours = [b.share * op.L_h for b in bins]
    cyc = [[60.0 * b.n * h for b, h in zip(bins, hours)], [60.0 * b.n * h / u for b, h in zip(bins, hours)]]
    out_bins = [{"torque_Nm": b.T, "speed_rpm": b.n, "share": b.share, "hours": h, "cycles": [cyc[0][i], cyc[1][i]]}
                for i, (b, h) in enumerate(zip(bins, hours))]
    damage, safety, curves = {}, {}, {}
    for mode, sig_key in (("pitting", "sigma_H"), ("bending", "sigma_F")):
        damage[mode], safety[mode], curves[mode] = [], [], []
        for m in range(2):
            sig = [r[sig_key][m] for r in ratings]
            # the reference level of each bin: its permissible stress without the life factor (S_min = 1)
            if mode == "pitting":
                ref = [r["sigma_Hlim"][m] * r["Z_L"] * r["Z_v"] * r["Z_R"] * r["Z_W"] * r["Z_X"][m] for r in ratings]
                pts = life_points_H(mats[m], op.y_lim)
            else:
                ref = [r["sigma_Flim"][m] * r["Y_ST"] * r["Y_deltarelT"][m] * r["Y_RrelT"][m] * r["Y_X"][m]
                       for r in ratings]
                pts = life_points_F(mats[m], op.y_lim)
            # one curve with the reference of the bin, expressed as the bin stress over its reference
            unit = SNCurve(1.0, pts)
            ratio = [s / rf for s, rf in zip(sig, ref)]
            res = miner(ratio, cyc[m], unit)
            damage[mode].append(res["D"])
            safety[mode].append(spectrum_safety(ratio, cyc[m], unit))
            curves[mode].append({"sigma_ref": ref, "points": [list(x) for x in pts]})
            static = pts[0][1]
            for i, ob in enumerate(out_bins):
                ob.setdefault(sig_key, []).append(sig[i])
                ob.setdefault(f"N_{mode}", []).append(res["N"][i])
                ob.setdefault(f"U_{mode}", []).append(res["U"][i])
                ob.setdefault(f"above_static_{mode}", []).append(ratio[i] > static)
    return {"bins": out_bins, "damage": damage, "safety": safety, "curves": curves}
