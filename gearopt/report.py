"""Helpers shared by the result objects' ``to_dict()``: the one JSON schema of results.json.

Every result object (:class:`gearopt.meshing.tca.TCAResult`, :class:`gearopt.contact.edge.EdgeTCAResult`,
:class:`gearopt.meshing.planar.PlanarTCAResult`, :class:`gearopt.synthesis.crowning.CrowningDesign`,
:class:`gearopt.synthesis.local.LocalDesign`, :class:`gearopt.fea.result.FEResult`) builds its own
dictionary with these conversions; the studies assemble those dictionaries and the plots read them.
Every key, unit and meaning is documented in docs/results.md (a test walks every scene's
results.json against it). This module imports only NumPy and :mod:`gearopt.units`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np


if TYPE_CHECKING:
    from collections.abc import Sequence
    from numpy.typing import ArrayLike
    from .meshing.misalignment import Misalignment

__all__ = ["CONJUGATE_ARCSEC", "arr", "te_harmonics", "misalignment_dict", "pair_numbers", "finite_or_none", "csv_cell"]

#: A drive whose actual TE has a smaller peak-to-peak [arcsec] is conjugate (TE = 0 up to round-off).
CONJUGATE_ARCSEC = 1e-5


def csv_cell(v: object) -> str:
    """One cell of a results CSV table: empty for None and non-finite floats, ``1``/``0`` for
    booleans, ``repr`` of a float (round-trip exact), ``str`` of anything else."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    return repr(v) if isinstance(v, float) else str(v)


def arr(a: ArrayLike) -> list:
    """An array as nested lists of floats, non-finite entries (no contact) as ``None``."""
    a = np.asarray(a, dtype=float)
    if a.ndim != 1:
        return [arr(row) for row in a]
    # tolist() gives the same Python floats as float(v), without a numpy scalar per entry
    return [v if f else None for v, f in zip(a.tolist(), np.isfinite(a).tolist())]


def finite_or_none(v: float | None) -> float | None:
    """``float(v)``, or ``None`` when it is not finite."""
    v = float(v)
    return v if math.isfinite(v) else None


def te_harmonics(phi1: np.ndarray, te: np.ndarray, z1: int, n: int = 5) -> list[float] | None:
    """Amplitudes of the first ``n`` mesh-frequency harmonics of a TE sampled uniformly over a whole
    number of mesh cycles ``[phi0, phi0 + c 2 pi / z1)`` (same unit as ``te``); None if the samples
    do not span whole cycles or contain gaps."""
    te = np.asarray(te, float)
    phi1 = np.asarray(phi1, float)
    span = (phi1[-1] - phi1[0]) * phi1.size / (phi1.size - 1)
    cycles = span * z1 / (2 * math.pi)
    c = int(round(cycles))
    if c < 1 or abs(cycles - c) > 1e-9 or te.size < 2 * c * n + 1 or not np.all(np.isfinite(te)):
        return None
    f = np.fft.rfft(te - te.mean()) / te.size
    return [float(2 * abs(f[c * k])) for k in range(1, n + 1)]


def misalignment_dict(mis: Misalignment) -> dict:
    """A :class:`~gearopt.meshing.tca.Misalignment` as results.json gives it: ``dE_mm``,
    ``crossing_arcmin``, ``intersecting_arcmin``, ``axial_mm``."""
    return mis.to_results()  # every kind by name and unit: <kind>_mm or <kind>_arcmin


def pair_numbers(driving: ArrayLike, pairs: Sequence[int]) -> list:
    """Driving tooth pair at each position as the pair number (pinion tooth, 0 = central), or None."""
    return [int(pairs[v]) if v >= 0 else None for v in np.asarray(driving, int)]
