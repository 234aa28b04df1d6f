"""The generic KKT algebra of the loaded sensitivities (gearopt.synthesis.loaded.kkt): the range of a
parameter over which an active set holds, on a parametric problem solved by hand, and the singular
KKT system refused before SuperLU passes BLAS a negative dimension."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from gearopt.errors import GearoptError
from gearopt.synthesis.loaded.kkt import active_set_derivatives, active_set_range, sparse_lu


def test_active_set_range_of_a_projection():
    """``min (x - p)^2 + (y - 2 p)^2`` s.t. ``x <= 1`` (a row), ``y >= 0`` (a bound): the optimum is
    ``x = min(p, 1)``, ``y = max(2 p, 0)``. At ``p = 0.4`` no constraint is active: the row becomes
    active at ``p = 1`` (+0.6) and the bound at ``p = 0`` (-0.4). At ``p = 1.5`` the row is active
    with the multiplier ``2 (p - 1) = 1`` (``d lam / dp = 2``): it leaves at ``p = 1`` (-0.5)."""
    inf = np.inf
    common = dict(lbg=np.array([-inf]), ubg=np.array([1.0]), lbx=np.array([-inf, 0.0]), ubx=np.array([inf, inf]),
                  watch_g=np.array([True]), watch_x=np.array([False, True]))
    # p = 0.4: nothing active; dx/dp = 1, dy/dp = 2; the row g = x
    p = 0.4
    lo, hi, why = active_set_range(np.array([[1.0], [2.0]]), np.zeros((0, 1)), np.array([], int), np.array([], int),
                                   np.array([p]), np.array([[1.0]]), lam_g=np.array([0.0]), x=np.array([p, 2 * p]),
                                   lam_x=np.zeros(2), act_g=np.array([False]), act_x=np.array([False, False]),
                                   **common)
    assert hi[0] == pytest.approx(0.6) and lo[0] == pytest.approx(-0.4)
    assert why[0] == (("x", 1, "reaches its lower bound"), ("g", 0, "reaches its upper bound"))
    # p = 1.5: the row active (x = 1, dx/dp = 0), multiplier 1 (CasADi's sign: positive at an upper
    # bound) moving by 2 per unit; y = 3 inactive, dy/dp = 2 (reaches 0 at p = 0: -1.5)
    p = 1.5
    lo, hi, why = active_set_range(np.array([[0.0], [2.0]]), np.array([[2.0]]), np.array([0]), np.array([], int),
                                   np.array([1.0]), np.array([[0.0]]), lam_g=np.array([2 * (p - 1)]),
                                   x=np.array([1.0, 2 * p]), lam_x=np.zeros(2), act_g=np.array([True]),
                                   act_x=np.array([False, False]), **common)
    assert lo[0] == pytest.approx(-0.5) and hi[0] == np.inf
    assert why[0] == (("g", 0, "leaves the active set"), ("", -1, ""))


def _structurally_singular() -> sp.csc_matrix:
    """A 214 x 214 sparse matrix with a zero row, on which SciPy's SuperLU calls DGEMV with a negative
    dimension before it reports the singular factor (found among random matrices with a zero row)."""
    A = (sp.random(214, 214, density=0.05, random_state=142) + sp.eye(214)).tolil()
    A[155, :] = 0.0
    return A.tocsc()


def test_a_structurally_singular_kkt_system_is_refused_before_blas_sees_it(capfd):
    """A singular KKT system raises the library's error naming it, and BLAS prints nothing: SuperLU
    itself, given this matrix, makes OpenBLAS print "On entry to DGEMV parameter number 2 had an
    illegal value" (seen during benchmarks/loaded_sensitivity_fd.py runs) before it fails."""
    A = _structurally_singular()
    with pytest.raises(RuntimeError):
        spla.splu(A)
    raw = capfd.readouterr()
    if "DGEMV" not in raw.out + raw.err:
        pytest.skip("this BLAS does not report SuperLU's negative dimension on this matrix")
    with pytest.raises(GearoptError, match="singular"):
        sparse_lu(A, "the test's system")
    out = capfd.readouterr()
    assert "DGEMV" not in out.out + out.err
    # a regular system is factored as before
    lu = sparse_lu((sp.random(50, 50, density=0.1, random_state=1) + 4 * sp.eye(50)).tocsc(), "a regular system")
    assert np.allclose(lu.solve(np.ones(50)), spla.spsolve((sp.random(50, 50, density=0.1, random_state=1)
                                                            + 4 * sp.eye(50)).tocsc(), np.ones(50)))


def _mirror_rows(c2: float):
    """``min (t - 5)^2 / 2 + (y1^2 + y2^2) / 4 + s`` over ``(t, y1, y2, s)`` with the equalities
    ``y1 = c t``, ``y2 = c2 t`` (two mirror-image slices of a symmetric design, ``c2`` = ``c`` = 0.3 up
    to rounding) and the rows ``y1 - s <= 1 + p1 + p2``, ``y2 - s <= 1 + p1 - p2`` (their common slack
    ``s`` priced, as the edge rows' ``slack_e``): at ``p = 0`` both rows are active and depend on each
    other through the equalities (LICQ fails). The optimum: ``t = (5 - c) / (1 + c^2)`` and
    ``s = c t - 1 - p1 - |p2|``: ``d(t, y1, y2, s)/dp1 = (0, 0, 0, -1)`` (both rows stay active), and
    along ``p2`` a kink (one row leaves on each side)."""
    c = 0.3
    H = sp.csc_matrix(np.diag([1.0, 0.5, 0.5, 0.0]))
    Jg = sp.csr_matrix(np.array([[-c, 1.0, 0.0, 0.0], [-c2, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, -1.0],
                                 [0.0, 0.0, 1.0, -1.0]]))
    Gp = sp.csr_matrix(np.array([[0.0, 0.0], [0.0, 0.0], [-1.0, -1.0], [-1.0, 1.0]]))
    return H, Jg, Gp, sp.csr_matrix((4, 2))


@pytest.mark.parametrize("c2", [0.3, 0.1 * 3])  # exactly dependent, and dependent up to rounding (0.30000000000000004)
def test_active_set_derivatives_drop_a_dependent_active_row(c2):
    """Two active rows dependent through the equalities (the edge rows of two slices mirror images about
    the face's middle, problems/microgeometry_te_target.toml): the full KKT system is singular in their
    multipliers (exactly, or up to rounding: SuperLU then gives multipliers of 1e16 and derivatives off);
    one row is dropped and the derivatives are the analytic ones, ``(0, 0, 0, -1)``; along
    ``p2`` the dropped row does not stay active: flagged (``off``)."""
    H, Jg, Gp, Lzp = _mirror_rows(c2)
    d_z, d_nu, dep, off = active_set_derivatives(H, Jg, Gp, Lzp, np.array([0, 1]), np.array([2, 3]),
                                                 np.array([], int), "the test's system")
    assert d_z[:, 0] == pytest.approx([0.0, 0.0, 0.0, -1.0], abs=1e-12)
    assert dep.tolist() in ([False, True], [True, False])
    assert off.tolist() == [False, True]
    # the multipliers' derivatives: the dropped row's not determined (NaN), the kept one's finite
    assert np.isnan(d_nu[2 + int(np.flatnonzero(dep)[0]), 0]) and np.isfinite(d_nu[2 + int(np.flatnonzero(~dep)[0]), 0])
    # independent rows are all kept: the same problem without y2's equality (y2 free, its row alone on it)
    _, d_nu2, dep2, off2 = active_set_derivatives(H, Jg, Gp, Lzp, np.array([0]), np.array([2, 3]),
                                                  np.array([], int), "the test's system")
    assert not dep2.any() and not off2.any() and np.isfinite(d_nu2).all()


def test_results_say_where_the_sensitivities_hold_in_the_results_units():
    """``design.sensitivities.valid_range_*`` and ``kink`` of results.json: the optimiser's ranges (rad, mm,
    N m offsets) converted to arcmin / mm / N m, an unbounded side as None, a side under KINK_RANGE named."""
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.studies.loaded_microgeometry import validity_dict
    from gearopt.units import ARCMIN

    kinds = Misalignment.names()
    unit = {k: (ARCMIN, f"{k}_arcmin") if Misalignment.meta(k)["unit"] == "angle" else (1.0, f"{k}_mm")
            for k in kinds}
    rng = np.array([[-2.0 * ARCMIN, np.inf]] * len(kinds))
    lengths = [j for j, k in enumerate(kinds) if unit[k][0] == 1.0]
    angles = [j for j, k in enumerate(kinds) if unit[k][0] != 1.0]
    rng[lengths[0]] = [-1e-12, 7.5e-4]
    S = {"range_mis": rng, "range_torque": np.array([[-5.0, 12.0], [-np.inf, 3.0]]),
         "kink_mis": np.array([j == lengths[0] for j in range(len(kinds))]),
         "kink_torque": np.array([False, False])}
    out = validity_dict(S, kinds, unit)
    a = kinds[angles[0]]
    assert out["valid_range_mis"][unit[a][1]][0] == pytest.approx(-2.0)
    assert out["valid_range_mis"][unit[a][1]][1] is None
    assert out["valid_range_mis"][unit[kinds[lengths[0]]][1]] == pytest.approx([-1e-12, 7.5e-4])
    assert out["valid_range_torque_Nm"] == [[-5.0, 12.0], [None, 3.0]]
    assert out["kink"] == {"mis": [unit[kinds[lengths[0]]][1]], "torque_index": []}
    json.dumps(out)  # plain JSON: no inf, no numpy scalars
