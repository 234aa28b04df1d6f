"""Loaded TCA is continuous in the design (docs/ltca.md, section 1): the slices are fixed to the tooth,
so loaded TE, pressure, load shares and edge loads change by little when a modification amount or a
misalignment changes by little, also across the events where a boundary (a face end, a relief start)
crosses a slice.

Each sweep steps one amount or one misalignment finely across such an event and bounds every jump
between neighbouring values: the loaded TE at every position by 1 % of its peak-to-peak, the peak
pressure by 1 %, each pair's load share and the tip-edge share by 0.01. Before the slices were fixed
to the tooth (grids centred on the unloaded point contact), the 20/40 optimum of
docs/loaded_synthesis.md section 5 at 250 N m went from 6.75" to 5.98" loaded TE peak-to-peak between
the aligned drive and a crossing of 1e-4 arcmin, and from 10.61" to 8.01" between C_beta = 13.7 and
13.8 um (11 slices, 8 positions, 2 arcmin crossing).
"""

from __future__ import annotations

import numpy as np
import pytest

from gearopt import ARCMIN, DEG, Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.ltca import LTCA
from gearopt.meshing.misalignment import Misalignment

UM = 1e-3  # mm
TORQUE = 250.0  # N m
N_POS = 8
N_SLICES = 11
TE_JUMP = 0.01  # share of the loaded TE peak-to-peak
P_JUMP = 0.01  # share of the peak pressure
SHARE_JUMP = 0.01  # load share


#: The ISO amounts [mm] of :func:`optimum`.
OPTIMUM = dict(C_alpha=40 * UM, C_beta=28.29 * UM, C_alpha_a=3.26 * UM, C_alpha_f=15.16 * UM, d_Ca=64.0, d_Cf=58.5)


def optimum(**kw):
    """The 20/40 spur drive of docs/loaded_synthesis.md section 5 at its optimum (ISO amounts [mm])."""
    amounts = {**OPTIMUM, **kw}
    return GearPair(Gear(z=20, m_n=3.0, b=20, name="pinion", modifications=Microgeometry(**amounts)),
                    Gear(z=40, m_n=3.0, b=20, name="gear"))


def litvin(a_pl=4e-4):
    return GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=a_pl, name="pinion"), Gear(z=40, m_n=3.0, b=20.0, name="gear"))


def helical():
    return GearPair(Gear(z=21, m_n=2.5, b=30.0, beta=18 * DEG, a_pl=2e-4, name="pinion"),
                    Gear(z=53, m_n=2.5, b=30.0, beta=18 * DEG, hand="left", name="gear"))


_LTCA = {}


def ltca(pair_fn, **kw) -> LTCA:
    """The loaded TCA of ``pair_fn(**kw)``, built once per module: a keyword that repeats the drive's own
    value (``optimum(d_Ca=64.0)``) names the same drive and reuses its loaded TCA."""
    if pair_fn is optimum:
        kw = {k: v for k, v in kw.items() if OPTIMUM.get(k) != v}
    key = (pair_fn.__name__, tuple(sorted(kw.items())))
    if key not in _LTCA:
        _LTCA[key] = LTCA(pair_fn(**kw), n_slices=N_SLICES)
    return _LTCA[key]


def figures(L: LTCA, mis=None, p1=None) -> dict:
    r = L.solve(TORQUE, phi1=L.mesh_cycle(N_POS), p1=p1, mis=mis).results[0]
    return {"te": r.te_loaded_arcsec, "pp": r.peak_to_peak_arcsec, "p": r.p_max, "share": r.share,
            "edge": r.edge_share}


def assert_no_jump(runs, what, order=1):
    """Neighbouring runs of a sweep differ by less than the module's bounds: their differences
    (``order`` 1, for steps so small that a continuous result cannot move by the bound) or their second
    differences (``order`` 2, equal steps: a smooth change of the result with the amount is linear over
    a few steps, a jump shows in full)."""
    pp = max(r["pp"] for r in runs)
    p = max(r["p"] for r in runs)
    keys = ("te", "pp", "p", "share", "edge")
    val = [{k: np.asarray(r[k], float) for k in keys} for r in runs]
    if order == 1:
        diffs = [{k: b[k] - a[k] for k in keys} for a, b in zip(val[:-1], val[1:])]
    else:
        diffs = [{k: c[k] - 2 * b[k] + a[k] for k in keys} for a, b, c in zip(val[:-2], val[1:-1], val[2:])]
    pps = " -> ".join(f"{r['pp']:.4f}" for r in runs)
    for i, d in enumerate(diffs):
        d_te, d_pp, d_p, d_sh, d_e = (float(np.max(np.abs(d[k]))) for k in keys)
        msg = (f"{what}, step {i} (difference of order {order}): loaded TE by {d_te:.4g}\" "
               f"(p-p {pps}\"), peak pressure by {d_p:.3g} MPa "
               f"(of {p:.1f}), pair shares by {d_sh:.3g}, tip-edge share by {d_e:.3g}")
        assert d_te < TE_JUMP * pp and d_pp < TE_JUMP * pp, msg
        assert d_p < P_JUMP * p, msg
        assert d_sh < SHARE_JUMP and d_e < SHARE_JUMP, msg


def with_amount(L, name, value):
    p1 = np.array(L.tca.pinion.p0, float)
    p1[L.tca.layout.member_names["pinion"].index(name)] = value
    return p1


# --- misalignments across the face-end event (equal faces: the gear's face ends cross the pinion's) ---
@pytest.mark.slow
@pytest.mark.parametrize("kind, steps", [("crossing", np.array([-1e-3, -1e-4, 0.0, 1e-4, 1e-3]) * ARCMIN),
                                         ("intersecting", np.array([-1e-3, -1e-4, 0.0, 1e-4, 1e-3]) * ARCMIN),
                                         ("axial", np.array([-1e-3, -1e-4, 0.0, 1e-4, 1e-3])),
                                         ("dE", np.array([-1e-4, 0.0, 1e-4]))])
def test_misalignment_sweeps_have_no_jumps(kind, steps):
    L = ltca(optimum)
    assert_no_jump([figures(L, Misalignment(**{kind: float(v)})) for v in steps], f"optimum, {kind}")


@pytest.mark.slow
def test_axial_shift_across_a_slice_has_no_jumps():
    """The gear's face end runs over the pinion slice at z = -8 mm (11 slices, 2 mm apart) as the gear
    shifts by 2 mm axially: the slice leaves the contact and its neighbour's share ends at the face."""
    L = ltca(optimum)
    assert_no_jump([figures(L, Misalignment(axial=float(a))) for a in (1.97, 1.98, 1.99, 2.0, 2.01, 2.02)],
                   "optimum, axial shift near 2 mm", order=2)


def test_litvin_crowned_misalignment_and_a_pl_sweeps_have_no_jumps():
    L = ltca(litvin)
    assert_no_jump([figures(L, Misalignment(crossing=float(v) * ARCMIN)) for v in (-1e-4, 0.0, 1e-4)],
                   "Litvin-crowned, crossing")
    mis = Misalignment(crossing=2 * ARCMIN)
    assert_no_jump([figures(L, mis, with_amount(L, "a_pl", a)) for a in (3.98e-4, 3.99e-4, 4.0e-4, 4.01e-4)],
                   "Litvin-crowned, a_pl", order=2)


def test_helical_crossing_sweep_has_no_jumps():
    L = ltca(helical)
    assert_no_jump([figures(L, Misalignment(crossing=float(v) * ARCMIN)) for v in (-1e-4, 0.0, 1e-4)],
                   "helical, crossing")


# --- ISO amounts in 0.1 um steps, under a crossing misalignment (the contact off the face centre) --------
@pytest.mark.slow
@pytest.mark.parametrize("name, centre", [("iso.C_beta", 28.29), ("iso.C_beta", 13.75), ("iso.f_H_beta", 0.0),
                                          ("iso.C_alpha", 40.0), ("iso.C_alpha_a", 3.26), ("iso.C_alpha_f", 15.16)])
def test_iso_amount_sweeps_have_no_jumps(name, centre):
    L = ltca(optimum)
    mis = Misalignment(crossing=2 * ARCMIN)
    vals = (centre + np.array([-0.2, -0.1, 0.0, 0.1, 0.2])) * UM
    assert_no_jump([figures(L, mis, with_amount(L, name, v)) for v in vals], f"optimum, {name} near {centre} um",
                   order=2)


# --- relief starts (not parameters: one drive each) ----------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("start, values", [("d_Ca", (63.98, 63.99, 64.0, 64.01)),
                                           ("d_Cf", (58.48, 58.49, 58.5, 58.51))])
def test_relief_start_sweeps_have_no_jumps(start, values):
    runs = [figures(ltca(optimum, **{start: v}), Misalignment(crossing=2 * ARCMIN)) for v in values]
    assert_no_jump(runs, f"optimum, {start}", order=2)
