"""The CalculiX contact model with 5 teeth per member at the validation positions
(benchmarks/data/fe_reference_teeth5.json, written by benchmarks/fe_teeth_reference.py) and the tables built on
it (benchmarks/data/fe_teeth5_tables.json, ``fe_teeth_reference.py --tables``; docs/ltca.md section 7, "The
5-tooth reference")."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "benchmarks" / "data"


def records():
    return json.loads((DATA / "fe_reference_teeth5.json").read_text())["default"]


def tables():
    return json.loads((DATA / "fe_teeth5_tables.json").read_text())


def test_recorded_5_tooth_runs_are_whole_and_softer_than_the_3_tooth_sectors():
    """Every recorded run is a 5-tooth run whose pair shares sum to one and hold the pitch pair's; its approach is
    larger than the 3-tooth contact model's at the same position and level (the sector's held sides are a pitch
    further from every loaded tooth, and the neighbours of the loaded teeth are free teeth)."""
    rec5 = records()
    rec3 = json.loads((DATA / "fe_reference.json").read_text())["default"]
    n = 0
    for name, runs in rec5.items():
        for f, r in runs.items():
            assert r["teeth"] == 5, (name, f)
            shares = [float(v or 0.0) for v in r["shares"].values()]
            assert abs(sum(shares) - 1.0) < 1e-9, (name, f)
            assert min(abs(r["share"] - v) for v in shares) < 1e-12, (name, f)
            r3 = rec3.get(name, {}).get(f)
            if r3 is not None:
                assert r["approach_um"] > r3["approach_um"], (name, f)
                n += 1
    assert n >= 1


def test_tables_are_built_from_every_recorded_run():
    """The tables' record holds every recorded 5-tooth run (re-run ``--tables`` after a run), with its FE values,
    and its references are the stated sums: ref = FE5 x level + (full gears + neighbours) - (5-tooth sectors +
    neighbours), ref0 the same with the full gears alone."""
    rec5, tab = records(), tables()
    assert {(n, f) for n, runs in rec5.items() for f in runs} == {(n, f) for n, runs in tab["runs"].items() for f in runs}
    for name, runs in tab["runs"].items():
        for f, row in runs.items():
            r5 = rec5[name][f]
            assert row["fe5"] == [r5["approach_um"], r5["p_max_mid_MPa"], r5["share"]]
            lvl = row["level"]
            fe5 = (row["fe5"][0] * lvl[0], row["fe5"][1] * lvl[1], row["fe5"][2] + lvl[2]) if lvl else row["fe5"]
            for i in range(3):
                assert row["ref"][i] == pytest.approx(fe5[i] + row["full+n"][i] - row["sec5+n"][i], rel=1e-12)
                assert row["ref0"][i] == pytest.approx(fe5[i] + row["full"][i] - row["sec5+n"][i], rel=1e-12)


@pytest.mark.slow
def test_tables_default_compliance_columns_are_loaded_tca_now():
    """The default compliance's columns of the tables (``neighbours = "none"`` and ``"full_gear"``: approach,
    section pressure, pitch pair's share) are what loaded TCA gives now, for the first recorded drive (no
    CalculiX: the analytical compliance, the FE model only for its contact geometry)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from validate_ltca_fe import T, drives

    from gearopt.fea import FEOptions, GearFEModel
    from gearopt.ltca import Material
    from gearopt.ltca.engine import LTCA

    name, runs = next(iter(tables()["runs"].items()))
    pair, mis = drives()[name]
    fracs = list(runs)
    phis = np.array([float(f) * 2 * math.pi / pair.pinion.z for f in fracs])
    cb = math.cos(pair.pinion.beta_b)
    for nb in ("none", "full_gear"):
        L = LTCA(pair, material=Material(E=210e3, nu=0.3), neighbours=nb)
        S = L.slices(phi1=phis, mis=mis)
        r = L.solve(T, slices=S).results[0]
        for j, f in enumerate(fracs):
            m = GearFEModel(pair, phis[j], FEOptions(torque=T * 1e3, E=210e3, nu=0.3), mis=mis)
            k0 = min(m.hertz, key=lambda k: abs(m.contact[k]["radius1"] - pair.pinion.r_p))
            kk = r.pairs.index(k0)
            ok = np.isfinite(S.z[kk, j]) & S.active[kk, j] & (S.edge[kk, j] == 0)
            o = np.argsort(S.z[kk, j][ok])
            p = float(np.interp(m.contact[k0]["z1"], S.z[kk, j][ok][o], r.p0[kk, j][ok][o]))
            got = (1e3 * r.delta[j] / cb, p, float(r.share[kk, j]))
            assert got == pytest.approx(runs[f][nb], rel=1e-6), (nb, f)


def test_every_reference_is_moved_to_the_very_fine_level():
    """Each 5-tooth run's reference is moved to the very fine level by the 3-tooth contact model's very fine over
    default ratio at its position: every position with a 3-tooth very fine run also has its 3-tooth default run,
    and the tables use that ratio (``level``, not the FE5 as it is). The lead-crowned helical 21/53's default
    runs (recorded 2026-11-29) show why it matters: its section pressure falls by 5.8-8.6 % from the default to
    the very fine level, its approach by 0.2-1.3 %."""
    rec3 = json.loads((DATA / "fe_reference.json").read_text())
    tab = tables()
    n = 0
    for name, runs in records().items():
        for f in runs:
            rv = rec3["very fine"].get(name, {}).get(f)
            if rv is None:
                continue
            r3 = rec3["default"].get(name, {}).get(f)
            assert r3 is not None, (name, f)
            lvl = tab["runs"][name][f]["level"]
            assert lvl is not None, (name, f)
            assert lvl[0] == pytest.approx(rv["approach_um"] / r3["approach_um"], rel=1e-12)
            assert lvl[1] == pytest.approx(rv["p_max_mid_MPa"] / r3["p_max_mid_MPa"], rel=1e-12)
            n += 1
    assert n == 15
