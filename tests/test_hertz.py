"""The one Hertz / Weber implementation (gearopt/contact/hertz.py) shared by the loaded TCA, the loaded
optimiser's NLP and the FE references: NumPy and CasADi give the same numbers, the line contact
satisfies Hertz's own relations, and each smoothing of Weber's logarithm behaves as its caller needs."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from gearopt.errors import GearoptError
from gearopt.ltca.compliance import Material, weber_contact, weber_tangent
from gearopt.contact.hertz import contact_modulus, hertz_half_width, hertz_peak_pressure, weber_compliance

E, NU = 206000.0, 0.3
ES = contact_modulus(E, NU)
F = np.array([1e-3, 0.5, 10.0, 250.0, 1200.0])  # N/mm
R = np.array([3.0, 8.0, 12.5, 20.0, 40.0])  # mm
H1, H2 = np.full(5, 2.5), np.full(5, 3.5)  # mm


def test_contact_modulus_of_steel():
    # 1/E* = 2 (1 - nu^2) / E for two equal bodies (Johnson eq. 4.22): 113186.8 MPa for steel
    assert ES == pytest.approx(1.0 / (2 * (1 - 0.09) / 206000.0), rel=1e-15)
    assert ES == pytest.approx(113186.81318681, rel=1e-10)


def test_hertz_line_contact_satisfies_its_own_relations():
    b = hertz_half_width(F, R, ES)
    p0 = hertz_peak_pressure(F, R, ES)
    # the elliptical pressure p0 sqrt(1 - (x/b)^2) carries the load: f = pi b p0 / 2 (Johnson eq. 4.44)
    assert np.allclose(math.pi * b * p0 / 2.0, F, rtol=1e-13)
    # the curvature relation b = 2 R* p0 / E* (the surface strain of the contact, Johnson eq. 4.43/4.45)
    assert np.allclose(b, 2.0 * R * p0 / ES, rtol=1e-13)
    # a worked value (by hand): 1000 N/mm on R* = 10 mm of steel gives p0 = 1898.117 MPa, b = 0.335395 mm
    assert hertz_peak_pressure(1000.0, 10.0, ES) == pytest.approx(1898.117, abs=1e-3)
    assert hertz_half_width(1000.0, 10.0, ES) == pytest.approx(0.335395, abs=1e-6)


@pytest.mark.parametrize("smoothing", ["max", "hypot"])
def test_numpy_and_casadi_give_the_same_numbers(smoothing):
    f_min = 0.7
    c_np = weber_compliance(F, R, H1, H2, E, NU, ES, f_min, smoothing)
    f = ca.SX.sym("f")
    fun = ca.Function("c", [f], [weber_compliance(f, 8.0, 2.5, 3.5, E, NU, ES, f_min, smoothing)])
    c_ca = np.array([float(fun(v)) for v in F])
    c_np8 = weber_compliance(F, 8.0, 2.5, 3.5, E, NU, ES, f_min, smoothing)
    assert np.array_equal(c_ca, c_np8) or np.allclose(c_ca, c_np8, rtol=1e-15, atol=0.0)
    assert np.all(np.isfinite(c_np)) and np.all(c_np > 0)
    b = ca.MX.sym("f", 5)
    mx = ca.Function("b", [b], [hertz_half_width(b, R, ES), hertz_peak_pressure(b, R, ES)])
    bh, p0 = (np.asarray(v).ravel() for v in mx(F))
    assert np.allclose(bh, hertz_half_width(F, R, ES), rtol=1e-15) and np.allclose(p0, hertz_peak_pressure(F, R, ES), rtol=1e-15)


def test_the_smoothings_agree_above_the_floor_and_stay_finite_below():
    f_min = 0.5
    c_max = weber_compliance(F, R, H1, H2, E, NU, ES, f_min, "max")
    c_hyp = weber_compliance(F, R, H1, H2, E, NU, ES, f_min, "hypot")
    big = F > 100 * f_min
    # sqrt(f^2 + f_min^2) = f (1 + O(f_min^2 / f^2)): the logarithm moves by O(f_min^2 / f^2) / 2
    assert np.allclose(c_hyp[big], c_max[big], rtol=1e-5)
    # below the floor "max" holds the value at f_min; "hypot" tends to it smoothly
    at_floor = weber_compliance(np.full(5, f_min), R, H1, H2, E, NU, ES, f_min, "max")
    assert np.array_equal(c_max[0], at_floor[0])
    assert c_hyp[0] == pytest.approx(at_floor[0], rel=1e-5)
    # Weber's approach grows with the load more slowly than linearly (the log term shrinks): c falls
    c = weber_compliance(np.array([10.0, 100.0, 1000.0]), 10.0, 3.0, 3.0, E, NU, ES, 1e-3, "max")
    assert np.all(np.diff(c) < 0)
    # and it falls by exactly 2 (1 - nu^2) / (pi E) ln(10) per decade of load (b_H ~ sqrt(f), two logs)
    assert np.allclose(-np.diff(c), 2 * (1 - NU**2) / (math.pi * E) * math.log(10.0), rtol=1e-12)


def test_a_bad_smoothing_names_the_parameter():
    with pytest.raises(GearoptError, match="smoothing"):
        weber_compliance(F, R, H1, H2, E, NU, ES, 0.1, "min")


def test_the_ltca_functions_are_the_shared_ones():
    """weber_contact and weber_tangent (the loaded TCA) are the shared formulas with the "max"
    smoothing: the same numbers to the last bit."""
    m = Material()
    c, b, p0 = weber_contact(F, R, H1, H2, m, 0.7)
    assert np.array_equal(c, weber_compliance(F, R, H1, H2, m.E, m.nu, m.E_star, 0.7, "max"))
    assert np.array_equal(b, hertz_half_width(F, R, m.E_star))
    assert np.array_equal(p0, hertz_peak_pressure(F, R, m.E_star))
    ct = weber_tangent(m)
    for k in range(F.size):
        assert float(ct(F[k], R[k], H1[k], H2[k], 0.7)[0]) == pytest.approx(c[k], rel=1e-15)
