"""Flank tolerances of ISO 1328-1:2013 (cylindrical gears, ISO system of flank tolerance
classification), clause 5.3: tolerance values of class A from the class-5 formulas times
``sqrt(2)^(A - 5)``, rounded as the standard rounds them (above 10 um to 1 um, 5-10 um to
0.5 um, below 5 um to 0.1 um).

Symbols (um; d reference diameter [mm], m_n normal module [mm], b face width [mm]):

=============  ===========================================================
f_pT           single pitch: 0.001 d + 0.4 m_n + 5
F_pT           total cumulative pitch: 0.002 d + 0.55 sqrt(d) + 0.7 m_n + 12
F_alphaT       total profile: 3.2 sqrt(m_n) + 0.22 sqrt(d) + 0.7
f_falphaT      profile form: 2.5 sqrt(m_n) + 0.17 sqrt(d) + 0.5
f_HalphaT      profile slope (+-): 2 sqrt(m_n) + 0.14 sqrt(d) + 0.5
F_betaT        total helix: 0.1 sqrt(d) + 0.63 sqrt(b) + 4.2
f_fbetaT       helix form: 0.07 sqrt(d) + 0.45 sqrt(b) + 3
f_HbetaT       helix slope (+-): 0.07 sqrt(d) + 0.45 sqrt(b) + 3
=============  ===========================================================

Valid for classes 1 to 11, 5 <= d <= 15000 mm, 0.5 <= m_n <= 70 mm, 4 <= b <= 1000 mm.
ISO 1328-1 has no centre-distance tolerance (that is the housing's, ISO/TR 10064-3): the Monte
Carlo study takes it as its own input.
"""

from __future__ import annotations

import math

from ..errors import OptionError, check_number, out_of_range

CLASSES = range(1, 12)  #: flank tolerance classes of ISO 1328-1:2013
RANGES = {"d": (5.0, 15000.0), "m_n": (0.5, 70.0), "b": (4.0, 1000.0)}  #: validity of the formulas [mm]

#: class-5 formulas [um] of (d, m_n, b) [mm]
_CLASS5 = {
    "f_pT": lambda d, m, b: 0.001 * d + 0.4 * m + 5.0,
    "F_pT": lambda d, m, b: 0.002 * d + 0.55 * math.sqrt(d) + 0.7 * m + 12.0,
    "F_alphaT": lambda d, m, b: 3.2 * math.sqrt(m) + 0.22 * math.sqrt(d) + 0.7,
    "f_falphaT": lambda d, m, b: 2.5 * math.sqrt(m) + 0.17 * math.sqrt(d) + 0.5,
    "f_HalphaT": lambda d, m, b: 2.0 * math.sqrt(m) + 0.14 * math.sqrt(d) + 0.5,
    "F_betaT": lambda d, m, b: 0.1 * math.sqrt(d) + 0.63 * math.sqrt(b) + 4.2,
    "f_fbetaT": lambda d, m, b: 0.07 * math.sqrt(d) + 0.45 * math.sqrt(b) + 3.0,
    "f_HbetaT": lambda d, m, b: 0.07 * math.sqrt(d) + 0.45 * math.sqrt(b) + 3.0,
}
NAMES = tuple(_CLASS5)


def iso_round(v: float) -> float:
    """ISO 1328-1:2013 rounding of a tolerance [um]: above 10 um to the integer, from 5 to 10 um
    to 0.5 um, below 5 um to 0.1 um (halves up)."""
    step = 1.0 if v > 10.0 else 0.5 if v >= 5.0 else 0.1
    return round(math.floor(v / step + 0.5) * step, 1)


def tolerances(grade: int, d: float, m_n: float, b: float, rounded: bool = True, where: str = "iso_grade") -> dict:
    """The ISO 1328-1:2013 tolerances of flank tolerance class ``grade`` [um].

    Parameters
    ----------
    grade : int
        Flank tolerance class 1 (finest) ... 11.
    d, m_n, b : float
        Reference diameter, normal module and face width [mm].
    rounded : bool
        Round as the standard does (default); False: the exact formula values.
    where : str
        Name of the grade in error messages (e.g. ``"[montecarlo] iso_grade"``).

    Returns
    -------
    dict
        ``{name: tolerance [um]}`` for every name in :data:`NAMES`.

    Raises
    ------
    OptionError
        A class outside 1..11 or gear data outside the formulas' validity.
    """
    if isinstance(grade, bool) or not isinstance(grade, int) or grade not in CLASSES:
        raise out_of_range(where, grade, "an integer flank tolerance class 1 ... 11 (ISO 1328-1:2013)",
                           cls=OptionError)
    vals = {}
    for name, v in (("d", d), ("m_n", m_n), ("b", b)):
        v = check_number(name, v, "a finite length [mm]", cls=OptionError)
        lo, hi = RANGES[name]
        if not lo <= v <= hi:
            raise out_of_range(name, v, f"{lo:g} <= {name} <= {hi:g} mm (validity of the ISO 1328-1:2013 tolerance "
                               "formulas)", cls=OptionError)
        vals[name] = v
    f = math.sqrt(2.0) ** (grade - 5)
    out = {}
    for name, fn in _CLASS5.items():
        v = fn(vals["d"], vals["m_n"], vals["b"]) * f
        out[name] = iso_round(v) if rounded else v
    return out
