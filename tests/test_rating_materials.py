"""The material data of gearopt.rating.materials against ISO 6336-5:2016 Table 1 (sigma_lim = A x + B).

The constants below are Table 1's as two public transcriptions give them (docs/rating.md, "Materials"):
a C# table of all 73 rows in the code index of public repositories (repository not named by the index)
and, for the ME rows, waa552/fyp-website (data.js); the two agree wherever both have a row. They are
typed here from those sources, not from gearopt.
"""

from __future__ import annotations

import pytest

from gearopt.rating.materials import HV_V, material

#: (group, stress, grade): (A, B) of ISO 6336-5:2016 Table 1; x in HV
TABLE1 = {
    ("Eh", "H", "ML"): (0.0, 1300.0), ("Eh", "H", "MQ"): (0.0, 1500.0), ("Eh", "H", "ME"): (0.0, 1650.0),
    ("Eh", "F", "ML"): (0.0, 312.0), ("Eh", "F", "MQ"): (0.0, 425.0), ("Eh", "F", "ME"): (0.0, 525.0),
    ("NT", "H", "ML"): (0.0, 1125.0), ("NT", "H", "MQ"): (0.0, 1250.0), ("NT", "H", "ME"): (0.0, 1450.0),
    ("NT", "F", "ML"): (0.0, 270.0), ("NT", "F", "MQ"): (0.0, 420.0), ("NT", "F", "ME"): (0.0, 468.0),
    ("V", "H", "ML"): (1.313, 188.0), ("V", "H", "MQ"): (1.313, 373.0), ("V", "H", "ME"): (2.213, 260.0),
    ("V", "F", "ML"): (0.423, 104.0), ("V", "F", "MQ"): (0.425, 187.0), ("V", "F", "ME"): (0.358, 231.0),
}


@pytest.mark.parametrize(("key", "ab"), list(TABLE1.items()), ids=["-".join(k) for k in TABLE1])
def test_material_numbers_are_table_1(key, ab):
    """Every number of the data is Table 1's line at the group's hardness (V: 300 HV; Eh, NT: A = 0)."""
    group, stress, grade = key
    m = material(group, grade)
    x = HV_V if group == "V" else 0.0
    value = m.sigma_Hlim if stress == "H" else m.sigma_Flim
    assert value == pytest.approx(ab[0] * x + ab[1], abs=1e-9), key
