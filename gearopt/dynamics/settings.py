"""Options of the dynamics study (:class:`gearopt.studies.dynamics.DynamicsStudy`), declared once: the
``[dynamics]`` keys of the same names, their defaults and ranges (docs/dynamics.md)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from ..errors import OptionError
from ..schema import Bounds
from ..settings import LTCAStudySettings, option


@dataclass(frozen=True)
class DynamicsSettings(LTCAStudySettings):
    """Options of the ``dynamics`` study: those of the loaded TCA (:class:`LTCAStudySettings`) and the
    speed sweep, damping, backlash and the mesh model's resolution."""

    SECTION: ClassVar[str] = "dynamics"

    speed_min: float | None = option(
        None, kind="float", bounds=Bounds(lo=0), label="rpm",
        doc="lowest pinion speed of the sweep [rpm] (default 0.2 x the model's first resonance speed; "
            "0: the sweep starts at speed_max / speeds)")
    speed_max: float | None = option(
        None, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=1e7), label="rpm",
        doc="highest pinion speed of the sweep [rpm] (default 1.5 x the model's first resonance speed)")
    speeds: int = option(60, kind="int", bounds=Bounds(lo=3, hi=5000), doc="speeds of the sweep (equally spaced)")
    damping: float = option(0.05, kind="float", bounds=Bounds(lo=0, hi=1, hi_open=True),
                            doc="viscous damping ratio of the mesh and the shafts")
    backlash: float | None = option(
        None, kind="length", bounds=Bounds(lo=0, lo_open=True, hi=100),
        doc="backlash along the line of action (default the pair's normal backlash j_bn, 0.05 m_n when it has none)")
    smoothing: float = option(1e-3, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=0.1),
                              doc="width of the smoothed max of contact loss over the static deflection")
    harmonics: int | None = option(None, kind="int", bounds=Bounds(lo=0, hi=999),
                                   doc="mesh harmonics of k(phi) and e(phi) (default all the positions resolve)")
    samples: int = option(128, kind="int", bounds=Bounds(lo=16, hi=4096),
                          doc="points per mesh cycle of the dynamic force and TE")
    compare_unmodified: bool = option(False, kind="bool",
                                      doc="also run the drive with both members' modifications removed")

    def validate(self) -> None:
        lo, hi = self.speed_min, self.speed_max
        if lo is not None and hi is not None and not hi > lo:
            valid = f"speed_max > speed_min = {lo:g} rpm"
            raise OptionError(f"speed_max = {hi:g} is out of range; valid: {valid}.", param="speed_max", value=hi,
                              valid=valid, detail=f"is out of range; valid: {valid}.")
        if self.harmonics is not None and self.harmonics > (self.positions - 1) // 2:
            valid = f"harmonics <= {(self.positions - 1) // 2} (half the positions = {self.positions})"
            raise OptionError(f"harmonics = {self.harmonics} is out of range; valid: {valid}.", param="harmonics",
                              value=self.harmonics, valid=valid, detail=f"is out of range; valid: {valid}.")
