"""Misalignments of the gear: the kinds, their units and their transform, defined together.

Every kind is a field of :class:`Misalignment` whose ``metadata`` gives its unit (``"length"`` [mm]
or ``"angle"`` [rad]), its meaning, the bound the scenes accept and its sign under the mirror
z -> -z of the drive (:meth:`Misalignment.mirror_sign`: the mirror-image cases of the loaded
optimiser, :mod:`gearopt.synthesis.loaded.mirror`); :meth:`Misalignment.gear_to_fixed`
applies all of them to a vector of the gear frame (Litvin's auxiliary frame S_q, docs/theory.md
section 7). The TCA graph, the sweep checks, the scene keys, the crowning cases, the case labels and
the results derive from these fields: adding a kind is a change to this file (plus its tests).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..errors import GeometryError, out_of_range
from ..geometry.frames import rot_x, rot_y
from ..units import ARCMIN
from .curvature import Sym

if TYPE_CHECKING:
    from ..gears import GearPair

ANGLE_MAX = 600 * ARCMIN  #: largest misalignment angle accepted [rad] (10 deg)
_NAMES: dict = {}  # (class, unit) -> names of its kinds (Misalignment.names)


def _kind(unit: str, doc: str, scene_max: float, mirror: float, default=0.0):
    """A misalignment field: ``unit`` "length" [mm] or "angle" [rad]; ``scene_max``: the largest
    magnitude a scene accepts (mm, or deg for angles); ``mirror``: +1 or -1, the kind's sign under
    the mirror z -> -z of a drive symmetric about its mid-face (required: a new kind states it)."""
    return field(default=default, metadata={"unit": unit, "doc": doc, "scene_max": scene_max, "mirror": mirror})


@dataclass(frozen=True)
class Misalignment:
    """Errors of alignment of the gear (applied through the auxiliary frame S_q).

    Parameters
    ----------
    dE : float
        Change of centre distance [mm].
    crossing : float
        Crossing angle [rad]: the gear axis turned about the line of centres (skew axes).
    intersecting : float
        Intersecting angle [rad]: the gear axis turned in the plane of the axes.
    axial : float
        Axial displacement of the gear [mm].
    """

    # under the mirror z -> -z the centre distance is unchanged; the crossing and intersecting angles
    # and the axial shift change sign
    dE: float = _kind("length", "centre distance change", 5.0, mirror=1.0)
    crossing: float = _kind("angle", "crossing angle of the axes", 10.0, mirror=-1.0)
    intersecting: float = _kind("angle", "intersecting angle of the axes", 10.0, mirror=-1.0)
    axial: float = _kind("length", "axial displacement of the gear", 50.0, mirror=-1.0)

    def __post_init__(self):
        for k in self.names():
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise GeometryError(f"misalignment.{k} = {v!r} must be a finite number.",
                                    param=f"misalignment.{k}", value=v, valid="a finite number",
                                    detail="must be a finite number.")
        for k in self.names("angle"):
            if abs(getattr(self, k)) > ANGLE_MAX:
                raise out_of_range(f"misalignment.{k}", f"{getattr(self, k) / ARCMIN:.6g} arcmin",
                                   "|angle| <= 600 arcmin (10 deg)")

    # --- the kinds --------------------------------------------------------------------------
    @classmethod
    def names(cls, unit: str | None = None) -> tuple:
        """Names of the kinds (all, or those of one unit, "length" or "angle"), in vector order."""
        key = (cls, unit)
        hit = _NAMES.get(key)
        if hit is None:  # (the fields of a class do not change: looked up once)
            hit = _NAMES[key] = tuple(f.name for f in fields(cls) if unit is None or f.metadata["unit"] == unit)
        return hit

    @classmethod
    def mirror_sign(cls, name: str) -> float | None:
        """The kind's sign (+1 or -1) under the mirror z -> -z of a drive symmetric about its mid-face,
        None for a field that does not declare it."""
        return next(f for f in fields(cls) if f.name == name).metadata.get("mirror")

    @classmethod
    def meta(cls, name: str) -> dict:
        """``{"unit", "doc", "scene_max"}`` of a kind."""
        return dict(next(f for f in fields(cls) if f.name == name).metadata)

    def vector(self) -> np.ndarray:
        """The values in :meth:`names` order (mm, rad)."""
        return np.array([getattr(self, k) for k in self.names()], dtype=float)

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.names()}

    # --- the transform (CasADi-generic: SX, MX or floats) --------------------------------------
    @staticmethod
    def gear_to_fixed(m: Mapping[str, Sym | float], v: Sym, a_w: float, point: bool) -> Sym:
        """A vector ``v`` (3,) of the gear's aligned frame (origin at the gear centre) carried into
        the fixed frame S_f of the misaligned drive: the axis turned by ``intersecting`` about x_f,
        then by ``crossing`` about y_f; a point is also moved to the centre ``(0, a_w + dE, axial)``.
        ``m`` maps each kind's name to its value (symbols or numbers)."""
        v = rot_y(m["crossing"], rot_x(m["intersecting"], v))
        if point:
            v = v + ca.vertcat(0.0, a_w + m["dE"], m["axial"])
        return v

    @staticmethod
    def fixed_to_gear_rotation(m: Mapping[str, Sym | float], v: Sym) -> Sym:
        """The inverse rotation of :meth:`gear_to_fixed` (directions only)."""
        return rot_x(-m["intersecting"], rot_y(-m["crossing"], v))

    # --- checks and bounds ------------------------------------------------------------------
    def check(self, pair: GearPair, where: str = "mis") -> None:
        """Refuse a misalignment that jams or separates the teeth (``dE``: the rules of
        :meth:`GearPair.check_operating`) or whose faces do not overlap (``axial``), naming
        ``where.kind``."""
        pair.check_operating(self.dE, f"{where}.dE")
        overlap = (pair.pinion.b + pair.gear.b) / 2
        if abs(self.axial) >= overlap:
            raise out_of_range(f"{where}.axial", self.axial, f"|axial| < (b1 + b2) / 2 = {overlap:.6g} mm (beyond it "
                               "the faces do not overlap and the teeth cannot touch)")

    def backlash_opening(self, pair: GearPair) -> float:
        """Bound on the circumferential clearance the misalignment opens [mm] (dE along the line of
        action on both flanks, the angles across the face)."""
        b = max(pair.pinion.b, pair.gear.b)
        return 2 * abs(self.dE) * math.tan(pair.alpha_wt) + b * sum(abs(getattr(self, k)) for k in self.names("angle"))

    def rigid_displacement(self, lever: float) -> float:
        """Bound on how far the misalignment moves a gear point at distance ``lever`` [mm] from the
        gear centre [mm]."""
        return (sum(abs(getattr(self, k)) for k in self.names("length"))
                + sum(abs(getattr(self, k)) for k in self.names("angle")) * lever)

    # --- presentation -----------------------------------------------------------------------
    @staticmethod
    def display(name: str, value: float) -> str:
        """``value`` of kind ``name`` as text: mm for lengths, arcmin (') for angles, signed."""
        if Misalignment.meta(name)["unit"] == "angle":
            return f"{value / ARCMIN:+g}'"
        return f"{value:+g} mm"

    def label(self) -> str:
        """Short label of the non-zero kinds, e.g. "dE +0.05 mm, crossing +3'" ("aligned" if none)."""
        return ", ".join(f"{k} {self.display(k, getattr(self, k))}" for k in self.names() if getattr(self, k)) \
            or "aligned"

    def to_results(self) -> dict:
        """Values keyed by name and unit for results.json: ``<kind>_mm`` or ``<kind>_arcmin``."""
        return {(f"{k}_arcmin" if self.meta(k)["unit"] == "angle" else f"{k}_mm"):
                (getattr(self, k) / ARCMIN if self.meta(k)["unit"] == "angle" else getattr(self, k))
                for k in self.names()}


MISALIGNMENTS = Misalignment.names()


def misalignment_cases(crossing: float = 0.0, intersecting: float = 0.0, dE: float = 0.0, axial: float = 0.0,
                       combined: bool = False, **more: float) -> dict[str, Misalignment]:
    """Misalignment cases: the aligned drive plus +-each given misalignment (and with ``combined``
    all of them at +); every kind of :class:`Misalignment` may be given by name.

    Parameters
    ----------
    crossing, intersecting : float
        Angles [rad]; 0 adds no case.
    dE, axial : float
        Lengths [mm]; 0 adds no case.
    combined : bool
        Also the case with every given misalignment at once (when more than one is given).
    **more : float
        Further :class:`Misalignment` kinds by name (internal units).

    Returns
    -------
    dict[str, Misalignment]
        Case name (``"aligned"``, ``"crossing +3'"``, ...) -> misalignment, in the order of results.json.
    """
    values = {"crossing": crossing, "intersecting": intersecting, "dE": dE, "axial": axial, **more}
    unknown = set(values) - set(Misalignment.names())
    if unknown:
        raise TypeError(f"misalignment_cases: unknown misalignment kind(s) {sorted(unknown)}")
    cases = {"aligned": Misalignment()}
    order = ("crossing", "intersecting", "dE", "axial")  # the order of the cases in results.json
    order = order + tuple(k for k in Misalignment.names() if k not in order)
    given = {k: values[k] for k in order if values.get(k)}
    for k, v in given.items():
        for sgn in (1, -1):
            cases[f"{k} {Misalignment.display(k, sgn * abs(v))}"] = Misalignment(**{k: sgn * abs(v)})
    if combined and len(given) > 1:
        cases["combined +"] = Misalignment(**{k: abs(v) for k, v in given.items()})
    return cases
