"""Gear materials for the ISO 6336 rating: groups, quality grades, strength numbers (ISO 6336-5).

Each entry is a material group of ISO 6336-5:2016 with the allowable stress numbers for contact,
sigma_Hlim, and bending, sigma_Flim (the nominal stress number, ISO 6336-3's sigma_FE = Y_ST
sigma_Flim with Y_ST = 2), for the quality grades ML, MQ and ME, at the typical surface hardness
stated in ``note``. The group also selects the curves that depend on the material: the life
factors Z_NT / Y_NT (ISO 6336-2:2019 Table 2, ISO 6336-3:2019 Table 3 lines), the running-in
allowances y_alpha, y_beta (ISO 6336-1:2019 8.3.4, 7.6.2), the roughness and size factors and the
slip-layer thickness rho' of Y_deltarelT (ISO 6336-3:2019 Table 4).

Source and status: ISO 6336-5:2016, 5.5, Table 1 (sigma_lim = A x + B, x the surface hardness, per
material, stress and grade; the Figures 5 to 12 draw the same lines). Checked against two public
transcriptions of Table 1 (docs/rating.md, "Materials"): NT (nitr.) all six numbers and Eh
sigma_Hlim (ML, MQ, ME) and sigma_Flim (ML, MQ, ME) agree with Table 1 (A = 0); V is Table 1's
through-hardened wrought alloy steel lines (rows 24 to 26, 30 to 32) at 300 HV. Eh/MQ sigma_Flim =
425 N/mm^2 is Table 1's row for core >= 25 HRC with the lower hardenability (the conservative one of
its three MQ rows: 461 for the higher hardenability, 500 for core >= 30 HRC; set ``sigma_Flim`` for
the actual core). Eh/MQ sigma_Hlim = 1500 N/mm^2 is also confirmed by a published
calculation (ISO/TR 6336-30:2017 example 1). Override them per member (``sigma_Hlim``,
``sigma_Flim`` keys) with the values of the actual material data sheet.
"""

from __future__ import annotations

from dataclasses import dataclass

from gearopt.errors import GeometryError

#: Quality grades of ISO 6336-5:2016, 5.1 (ML: modest; MQ: normal industrial; ME: highest).
GRADES = ("ML", "MQ", "ME")


@dataclass(frozen=True)
class MaterialGroup:
    """One material group of ISO 6336-5 with its strength numbers per grade.

    Parameters
    ----------
    key : str
        The scene's name of the group (``"Eh"``: case-hardened wrought steel, ``"NT"``: nitrided
        nitriding steel, ``"V"``: through-hardened wrought alloy steel).
    iso_group : str
        ISO 6336's abbreviation (Eh, NT (nitr.), V).
    sigma_Hlim : dict
        Allowable contact stress number per grade [N/mm^2].
    sigma_Flim : dict
        Nominal bending stress number per grade [N/mm^2].
    surface_hardened : bool
        Case-hardened or nitrided (running-in allowances 0.075 f_pb, 0.15 F_betax; ISO 6336-1:2019
        8.3.4, 7.6.2).
    slip_layer : float
        rho' of ISO 6336-3:2019 Table 4 for Y_deltarelT [mm].
    note : str
        The hardness at which the numbers hold.
    """

    key: str
    iso_group: str
    sigma_Hlim: dict
    sigma_Flim: dict
    surface_hardened: bool
    slip_layer: float
    note: str
    E: float = 206000.0        # Young's modulus [N/mm^2] (steel)
    nu: float = 0.3            # Poisson's ratio
    density: float = 7.83e-6   # [kg/mm^3]


#: The hardness at which the through-hardened alloy steel group V is tabulated [HV].
HV_V = 300.0
#: ISO 6336-5:2016 Table 1, through-hardened wrought alloy steel (V), sigma_lim = A HV + B [N/mm^2]:
#: (A, B) per grade for contact (H, rows 24 to 26) and bending (F, rows 30 to 32), valid 200 ... 360 HV
#: (ME: 390 HV).
V_ALLOY_TABLE1 = {"H": {"ML": (1.313, 188.0), "MQ": (1.313, 373.0), "ME": (2.213, 260.0)},
                  "F": {"ML": (0.423, 104.0), "MQ": (0.425, 187.0), "ME": (0.358, 231.0)}}


def _table1(ab: tuple[float, float], x: float) -> float:
    """sigma_lim = A x + B (ISO 6336-5:2016, 5.5) [N/mm^2]."""
    return round(ab[0] * x + ab[1], 6)


MATERIALS: dict[str, MaterialGroup] = {
    "Eh": MaterialGroup(
        key="Eh", iso_group="Eh", surface_hardened=True, slip_layer=0.0030,
        sigma_Hlim={"ML": 1300.0, "MQ": 1500.0, "ME": 1650.0},
        sigma_Flim={"ML": 312.0, "MQ": 425.0, "ME": 525.0},
        note="case-hardened wrought steel, surface 58..64 HRC, core >= 25 HRC (ISO 6336-5:2016 Fig. 9, 10)"),
    "NT": MaterialGroup(
        key="NT", iso_group="NT (nitr.)", surface_hardened=True, slip_layer=0.1005,
        sigma_Hlim={"ML": 1125.0, "MQ": 1250.0, "ME": 1450.0},
        sigma_Flim={"ML": 270.0, "MQ": 420.0, "ME": 468.0},
        note="nitriding steel, gas-nitrided, surface >= 650 HV (ISO 6336-5:2016 Fig. 11, 12)"),
    "V": MaterialGroup(
        key="V", iso_group="V", surface_hardened=False, slip_layer=0.0194,
        sigma_Hlim={g: _table1(ab, HV_V) for g, ab in V_ALLOY_TABLE1["H"].items()},
        sigma_Flim={g: _table1(ab, HV_V) for g, ab in V_ALLOY_TABLE1["F"].items()},
        note=f"through-hardened wrought alloy steel at {HV_V:g} HV (ISO 6336-5:2016 Table 1 rows 24-26, 30-32)"),
}


@dataclass(frozen=True)
class Material:
    """The strength data of one member as the rating uses them.

    Parameters
    ----------
    group : MaterialGroup
    grade : str
        ML, MQ or ME.
    sigma_Hlim, sigma_Flim : float
        Allowable stress numbers [N/mm^2] (the group's value for the grade unless overridden).
    """

    group: MaterialGroup
    grade: str
    sigma_Hlim: float
    sigma_Flim: float

    @property
    def E(self) -> float:
        """Young's modulus [N/mm^2]."""
        return self.group.E

    @property
    def nu(self) -> float:
        """Poisson's ratio [-]."""
        return self.group.nu


def material(group: str, grade: str = "MQ", sigma_Hlim: float | None = None, sigma_Flim: float | None = None,
             name: str = "material") -> Material:
    """The material of one member from its group and grade, with optional overrides.

    Parameters
    ----------
    group : str
        A key of :data:`MATERIALS`.
    grade : str
        ML, MQ or ME.
    sigma_Hlim, sigma_Flim : float or None
        Overrides [N/mm^2] (> 0).
    name : str
        How errors name the member's key (``"pinion.material"``).

    Raises
    ------
    GeometryError
        An unknown group or grade, or a non-positive override, naming the key.
    """
    if group not in MATERIALS:
        raise GeometryError(f"{name} = {group!r} is not a material group of the data; valid: "
                            f"{', '.join(MATERIALS)}.", param=name, value=group, valid=", ".join(MATERIALS))
    if grade not in GRADES:
        raise GeometryError(f"{name}_grade = {grade!r} is not a quality grade of ISO 6336-5; valid: "
                            f"{', '.join(GRADES)}.", param=f"{name}_grade", value=grade, valid=", ".join(GRADES))
    g = MATERIALS[group]
    out = {}
    for key, value, table in (("sigma_Hlim", sigma_Hlim, g.sigma_Hlim), ("sigma_Flim", sigma_Flim, g.sigma_Flim)):
        if value is None:
            out[key] = table[grade]
        elif not value > 0:
            raise GeometryError(f"{name}.{key} = {value!r} is out of range; valid: > 0 N/mm^2.",
                                param=f"{name}.{key}", value=value, valid="> 0 N/mm^2")
        else:
            out[key] = float(value)
    return Material(g, grade, out["sigma_Hlim"], out["sigma_Flim"])
