"""Options of the ``rating`` study (:class:`gearopt.studies.rating.RatingStudy`), declared once.

The ``[rating]`` keys of the same names; the loaded TCA's own options (``side``, ``n_slices``,
``positions``, ``coupling``, ``compliance``) are inherited from :class:`gearopt.settings.LTCAStudySettings`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from gearopt.rating.materials import GRADES, MATERIALS
from gearopt.schema import Bounds
from gearopt.settings import LTCAStudySettings, option


def positive_list(v: list) -> str | None:
    """Scene and API check of a list of positive numbers (None when fine)."""
    return None if v and all(x > 0 for x in v) else "one or more numbers > 0"


def share_list(v: list) -> str | None:
    """Scene and API check of a list of life shares (None when fine; their sum is checked with the spectrum)."""
    return None if v and all(0 <= x <= 1 for x in v) else "one or more shares 0 <= share <= 1"


@dataclass(frozen=True)
class RatingSettings(LTCAStudySettings):
    """Options of the rating study: operating conditions, materials, accuracy, requirements, and
    where the face and transverse load factors come from."""

    SECTION: ClassVar[str] = "rating"

    speed: float = option(1000.0, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=1e6), label="1/min",
                          doc="pinion speed n1 [1/min] (K_v method B needs it > 0)")
    K_A: float = option(1.0, kind="float", bounds=Bounds(lo=1, hi=5), doc="application factor K_A")
    life: float = option(20000.0, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=1e7), label="h",
                         doc="required life L_h [h]")
    nu40: float = option(220.0, kind="float", bounds=Bounds(lo=1, hi=10000), label="mm^2/s",
                         doc="kinematic viscosity of the oil at 40 degC [mm^2/s]")
    rz_flank: float = option(3.0, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=40), label="um",
                             doc="flank roughness Rz of both members [um]")
    rz_root: float = option(10.0, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=40), label="um",
                            doc="root roughness Rz of both members [um]")
    pinion_material: str = option("Eh", kind="str", choices=tuple(MATERIALS),
                                  doc="ISO 6336-5 material group of the pinion (Eh case-hardened, NT nitrided, "
                                      "V through-hardened)")
    gear_material: str = option("Eh", kind="str", choices=tuple(MATERIALS), doc="material group of the gear")
    pinion_grade: str = option("MQ", kind="str", choices=GRADES, doc="ISO 6336-5 quality grade of the pinion")
    gear_grade: str = option("MQ", kind="str", choices=GRADES, doc="quality grade of the gear")
    pinion_sigma_Hlim: float | None = option(None, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=3000),
                                             label="MPa", doc="override of the pinion's sigma_Hlim [N/mm^2]")
    gear_sigma_Hlim: float | None = option(None, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=3000),
                                           label="MPa", doc="override of the gear's sigma_Hlim [N/mm^2]")
    pinion_sigma_Flim: float | None = option(None, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=1500),
                                             label="MPa", doc="override of the pinion's sigma_Flim [N/mm^2]")
    gear_sigma_Flim: float | None = option(None, kind="float", bounds=Bounds(lo=0, lo_open=True, hi=1500),
                                           label="MPa", doc="override of the gear's sigma_Flim [N/mm^2]")
    f_pb: float = option(8.0, kind="float", bounds=Bounds(lo=0, hi=500), label="um",
                         doc="transverse base pitch deviation f_pb [um]")
    f_falpha: float = option(8.0, kind="float", bounds=Bounds(lo=0, hi=500), label="um",
                             doc="profile form deviation f_falpha [um]")
    f_ma: float | None = option(None, kind="float", bounds=Bounds(lo=0, hi=1000), label="um",
                                doc="mesh misalignment f_ma for ISO's K_Hbeta [um] (default: the scene's crossing and "
                                    "intersecting angles across the face in the plane of action)")
    f_sh: float | None = option(None, kind="float", bounds=Bounds(lo=0, hi=1000), label="um",
                                doc="misalignment from shaft deformation f_sh [um] (default: ISO 6336-1 with B* = 1)")
    tip_relief: float | None = option(None, kind="float", bounds=Bounds(lo=0, hi=1000), label="um",
                                      doc="tip relief C_a for K_v [um] (default: the running-in relief C_ay)")
    accuracy_grade: int = option(6, kind="int", bounds=Bounds(lo=1, hi=12), doc="ISO 1328 accuracy grade (Y_DT)")
    S_Hmin: float = option(1.0, kind="float", bounds=Bounds(lo=0.5, hi=5), doc="minimum pitting safety S_Hmin")
    S_Fmin: float = option(1.4, kind="float", bounds=Bounds(lo=0.5, hi=5), doc="minimum bending safety S_Fmin")
    y_lim: float = option(0.85, kind="float", bounds=Bounds(lo=0.85, hi=1.0),
                          doc="life factors Z_NT, Y_NT at 1e10 cycles (1.0: optimum lubrication and manufacture)")
    tooth_form: str = option("generated", kind="str", choices=("generated", "iso"),
                             doc="critical root section of Y_F, Y_S: measured on each member's generated tooth (spur "
                                 "pairs; helical pairs use ISO's closed form) or ISO 6336-3's closed form")
    y_beta_edition: str = option("2019", kind="str", choices=("2019", "2006"),
                                 doc="form of Y_beta: ISO 6336-3:2019 (with 1/cos^3 beta) or 2006 (docs/rating.md)")
    spectrum_torque: list | None = option(None, kind="floats", label="N m", check=positive_list,
                                          doc="load spectrum (ISO 6336-6): pinion torque of each bin [N m]")
    spectrum_speed: list | None = option(None, kind="floats", label="1/min", check=positive_list,
                                         doc="load spectrum: pinion speed of each bin [1/min]")
    spectrum_share: list | None = option(None, kind="floats", check=share_list,
                                         doc="load spectrum: each bin's share of the life (adding up to 1)")
    load_factors: str = option("ltca", kind="str", choices=("ltca", "iso"),
                               doc="K_Hbeta, K_Halpha of the safety factors: gearopt's loaded TCA or ISO's method B "
                                   "(the other is reported beside)")
    fe_root: bool = option(False, kind="bool",
                           doc="also compute the tooth-root stress of both members with the FE model (CalculiX ccx, "
                               "coarse mesh, two runs) at each one's outer point of single pair contact and report it "
                               "beside ISO's sigma_F0 (spur pairs; docs/rating.md)")
