"""The CalculiX contact model with 5 teeth per member at the 15 validation positions (docs/ltca.md section 7,
"The 5-tooth reference"): resumable, one position per run, recorded as soon as it is done.

    python benchmarks/fe_teeth_reference.py                 # every position not yet recorded, in the order below
    python benchmarks/fe_teeth_reference.py --list          # the queue and what is recorded (no CalculiX)
    python benchmarks/fe_teeth_reference.py --worker 0/2    # every second position of the queue from the first
                                                             # (two processes share the queue, one record)
    python benchmarks/fe_teeth_reference.py --tables        # the tables of docs/ltca.md section 7, "The 5-tooth
                                                             # reference", from the recorded runs (no contact-model
                                                             # run; the members' line loads on 5-tooth sectors once,
                                                             # then cached), recorded in fe_teeth5_tables.json
    python benchmarks/fe_teeth_reference.py --split         # the default compliance's miss against the FE
                                                             # coefficients on full gears + their neighbours, per
                                                             # pair (own tooth + Weber) and the pairs' coupling under
                                                             # one load; the helical members' FE neighbours against
                                                             # the term with and without its axial part (N2) (cached
                                                             # grids, ~2 min)
    python benchmarks/fe_teeth_reference.py --holdout       # a helical gear that is no validation member (z 60,
                                                             # beta 25 deg) and the spur of its transverse section:
                                                             # the full gears' own and neighbouring teeth's responses
                                                             # (CalculiX, a few minutes each, recorded in
                                                             # fe_helical_neighbours.json) against the default term

The FE level is validate_ltca_fe.py's default (its ``FE_MESH``), 200 N m, E 210 GPa, nu 0.3, with
``FEOptions(teeth=5)``: each member a sector of 5 teeth held at the sides of its outer teeth and its rim bottom,
so that no loaded pair sits on an outer tooth next to a held side (with 3 teeth per member the pair other than the
pitch pair always does). Each run took 84-589 s of wall time at load 9-13 (two at a time, one thread each). The records
(validate_ltca_fe.fe_record's fields, every pair's share included) go to
benchmarks/data/fe_reference_teeth5.json as ``{"default": {drive: {position: record}}}``, read by
``fe_full_gear_body.py --validate --teeth 5 --recorded``. The queue is ordered by value: the two-pair positions
first (where the 3-tooth sector biased the reference), then the three-pair ones, the single-pair ones last.
"""

from __future__ import annotations

import fcntl
import json
import math
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from validate_ltca_fe import FE_MESH, ROOT, T, drives, fe_record  # noqa: E402

from gearopt.fea import FEOptions, GearFEModel  # noqa: E402

RECORD_TEETH = {5: ROOT / "benchmarks" / "data" / "fe_reference_teeth5.json"}
TABLES = ROOT / "benchmarks" / "data" / "fe_teeth5_tables.json"
HOLDOUT = ROOT / "benchmarks" / "data" / "fe_helical_neighbours.json"
LEVEL = "default"

# (drive, position in pinion pitches): two pairs in mesh, three pairs, one pair
QUEUE = (
    ("spur crowned", "+0.3"), ("spur crowned", "-0.3"),
    ("scene ltca_helical (crowned)", "+0.3"), ("helical 15 deg", "-0.3"),
    ("scene ltca_crowned (crossing 3')", "+0.3"), ("scene ltca_crowned (crossing 3')", "-0.3"),
    ("spur 20/40 conjugate", "-0.3"), ("spur 20/40 conjugate", "+0.3"), ("helical 15 deg", "+0.3"),
    ("helical 15 deg", "0"), ("scene ltca_helical (crowned)", "0"), ("scene ltca_helical (crowned)", "-0.3"),
    ("spur 20/40 conjugate", "0"), ("spur crowned", "0"), ("scene ltca_crowned (crossing 3')", "0"),
)


def read_record(teeth: int = 5) -> dict:
    """The recorded runs with ``teeth`` teeth per member ({} when none)."""
    path = RECORD_TEETH[teeth]
    return json.loads(path.read_text()) if path.exists() else {}


def add_record(teeth: int, name: str, frac: str, rec: dict) -> None:
    """Add one run to the record, re-reading it under a lock (two workers write the same file)."""
    path = RECORD_TEETH[teeth]
    with open(Path(tempfile.gettempdir()) / f"gearopt-{path.stem}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        data = read_record(teeth)
        data.setdefault("_about", "CalculiX contact model (GearFEModel.run) with 5 teeth per member at "
                        "validate_ltca_fe.py's positions and default level, 200 N m, E 210 GPa, nu 0.3; written by "
                        "benchmarks/fe_teeth_reference.py")
        data.setdefault(LEVEL, {}).setdefault(name, {})[frac] = rec
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(data, indent=1) + "\n")
        tmp.replace(path)


def sector5_grids(tooth, gear, r_form, grid):
    """Member ``tooth``'s FE influence grid (the contact model's 3-tooth sector) moved to the 5-tooth sector of
    the 5-tooth contact model, with that sector's neighbouring teeth: ``(own grid, neighbours)`` as
    fe_full_gear_body's ``full_gear_grid`` and ``neighbour_grids`` build the full gear's. The own grid is ``G +
    (C5 - C3)(r_i, r_j) K(z_a, z_b)``, the neighbours the 3-tooth sector's point-load responses of teeth -1 and +1
    plus ``(C5 - C3)`` of theirs, and ``C5`` of teeth -2 and +2; ``C3``, ``C5``: line loads on the 3- and 5-tooth
    sectors (rim 1.5 m_n, held at its bottom and sides; loaded at three rows, quadratic between them), ``K`` the
    Pasternak kernel of the full gear's body depth (a uniform line load gets exactly the difference). The
    5-tooth sector's responses are those of its middle tooth loaded; a pair on tooth -1 or +1 of the contact model
    sees a sector less symmetric than that (not modelled)."""
    from dataclasses import replace

    from fe_full_gear_body import MESH, neighbour_grids

    from gearopt.fea.influence import line_load_compliance
    from gearopt.ltca.compliance import coupling

    kw = dict(E=210e3, nu=0.3, r_form=r_form)
    mesh = replace(MESH, rim_depth=1.5)
    c3 = line_load_compliance(tooth, mesh=mesh, teeth=3, support="sector", neighbours=(-1, 1), **kw)
    r = c3.radius
    cols = [0, r.size // 2, r.size - 1]
    c5 = line_load_compliance(tooth, mesh=mesh, teeth=5, support="sector", rows=cols, neighbours=(-2, -1, 1, 2), **kw)
    z = grid.z
    w = np.zeros(z.size)
    w[:-1] += 0.5 * np.diff(z)
    w[1:] += 0.5 * np.diff(z)
    K = coupling(z, w, tooth.r_root - 0.5 * gear.r_f)

    def on_grid(D, sym=False):
        D = np.array([[np.polyval(np.polyfit(r[cols], D[i], 2), rj) for rj in r] for i in range(r.size)])
        D = 0.5 * (D + D.T) if sym else D
        Dg = np.array([[np.interp(ri, r, [np.interp(rj, r, D[k]) for k in range(r.size)]) for rj in grid.radius]
                       for ri in grid.radius])
        return Dg[:, None, :, None] * K[None, :, None, :]

    own = replace(grid, G=grid.G + on_grid(c5.C[:, cols] - c3.C[:, cols], sym=True))
    nb = neighbour_grids(tooth, gear, r_form, grid, "sector")  # the 3-tooth sector's point loads, teeth -1, +1
    for d in (-2, -1, 1, 2):
        D = c5.neighbours[d][:, cols] - (c3.neighbours[d][:, cols] if abs(d) == 1 else 0.0)
        nb[f"N{d:+d}"] = nb.get(f"N{d:+d}", 0.0) + on_grid(D)
    info = {"rows_mm": r[cols].round(3).tolist(),
            "own_5_minus_3": (1e3 * np.diag((c5.C - c3.C)[np.ix_(cols, cols)])).round(5).tolist(),
            **{f"5-tooth {d:+d}": (1e3 * np.diag(c5.neighbours[d][np.ix_(cols, cols)])).round(5).tolist()
               for d in (-2, -1, 1, 2)},
            **{f"3-tooth {d:+d}": (1e3 * np.diag(c3.neighbours[d][np.ix_(cols, cols)])).round(5).tolist()
               for d in (-1, 1)}}
    return own, nb, info


@dataclass(frozen=True)
class FECoefficients:
    """Loaded TCA with FE coefficients of one drive at its validation positions (:func:`fe_coefficients`)."""

    ltca: Any  #: the engine (``compliance="fe"``: the members' 3-tooth sector grids)
    slices: Any  #: its slices at ``phi1``
    phi1: np.ndarray  #: [rad] the positions
    grids: tuple  #: the members' influence grids
    teeth: tuple  #: the members' unmodified teeth
    gears: tuple  #: pinion, gear
    r_form: tuple  #: [mm] the members' form radii


def fe_coefficients(pair, mis, fracs, mat) -> FECoefficients:
    """Loaded TCA with FE coefficients of ``pair`` under ``mis`` at the positions ``fracs`` (strings: fractions
    of the pinion's angular pitch, as the records name them), material ``mat``."""
    from gearopt.ltca.engine import LTCA

    phis = np.array([float(f) * 2 * math.pi / pair.pinion.z for f in fracs])
    Lf = LTCA(pair, material=mat, compliance="fe")
    return FECoefficients(ltca=Lf, slices=Lf.slices(phi1=phis, mis=mis), phi1=phis, grids=Lf.influence,
                          teeth=(Lf.tca.pinion.unmodified, Lf.tca.gear.unmodified), gears=(pair.pinion, pair.gear),
                          r_form=(Lf.tca.form_radius(1), Lf.tca.form_radius(2)))


def tables() -> int:
    """(a) loaded TCA with FE coefficients against the recorded 5-tooth contact model (3-tooth grids as they are;
    with the 3-tooth sector's neighbour coupling; moved to the 5-tooth sector with its coupling), beside the
    3-tooth record; (b) the default compliance (neighbours 'none' and 'full_gear') against the 5-tooth reference
    corrected to full-gear bodies held at r_f / 2 and their neighbouring teeth:
    ``ref = FE5 + q(full gears + their neighbours) - q(5-tooth sectors + their neighbours)`` and without the full
    gears' neighbours ``ref0 = FE5 + q(full gears) - q(5-tooth sectors + their neighbours)``, q: loaded TCA with FE
    coefficients on those members (the sector's own coupling, which the FE run carries, taken out once)."""
    from fe_full_gear_body import NeighbourLTCA, full_gear_grid, neighbour_grids
    from validate_ltca_fe import RECORD

    from gearopt.ltca.compliance import Material
    from gearopt.ltca.engine import LTCA

    rec5 = read_record(5).get(LEVEL, {})
    rec3 = json.loads(RECORD.read_text())
    mat = Material(E=210e3, nu=0.3)
    out = {"members": {}, "runs": {}}
    for name in drives():
        if name not in rec5:
            continue
        pair, mis = drives()[name]
        cb = math.cos(pair.pinion.beta_b)
        fracs = [f for f in ("0", "-0.3", "+0.3") if f in rec5[name]]
        fs = fe_coefficients(pair, mis, fracs, mat)
        Lf, S, phis, g, tt, gears, rf = fs.ltca, fs.slices, fs.phi1, fs.grids, fs.teeth, fs.gears, fs.r_form
        s5 = [sector5_grids(tt[m], gears[m], rf[m], g[m]) for m in (0, 1)]
        for m in (0, 1):
            out["members"][f"{gears[m].z} teeth ({name})"] = s5[m][2]
        res = {"fe": Lf.solve(T, slices=S).results[0]}
        res["fe+n3"] = NeighbourLTCA(Lf, [neighbour_grids(tt[m], gears[m], rf[m], g[m], "sector")
                                          for m in (0, 1)]).solve(T, S).results[0]
        Lf.influence = (s5[0][0], s5[1][0])
        res["sec5"] = Lf.solve(T, slices=S).results[0]
        res["sec5+n"] = NeighbourLTCA(Lf, [s5[m][1] for m in (0, 1)]).solve(T, S).results[0]
        Lf.influence = tuple(full_gear_grid(g[m], tt[m], gears[m], rf[m])[0] for m in (0, 1))
        res["full"] = Lf.solve(T, slices=S).results[0]
        res["full+n"] = NeighbourLTCA(Lf, [neighbour_grids(tt[m], gears[m], rf[m], g[m], "full - sector")
                                           for m in (0, 1)]).solve(T, S).results[0]
        for nb in ("none", "full_gear"):
            res[nb] = LTCA(pair, material=mat, neighbours=nb).solve(T, slices=S).results[0]
        for j, f in enumerate(fracs):
            r5 = rec5[name][f]
            m = GearFEModel(pair, phis[j], FEOptions(torque=T * 1e3, E=210e3, nu=0.3), mis=mis)
            k0 = min(m.hertz, key=lambda k: abs(m.contact[k]["radius1"] - pair.pinion.r_p))
            q = {}
            for lab, r in res.items():
                kk = r.pairs.index(k0)
                ok = np.isfinite(S.z[kk, j]) & S.active[kk, j] & (S.edge[kk, j] == 0)
                o = np.argsort(S.z[kk, j][ok])
                q[lab] = (1e3 * r.delta[j] / cb, float(np.interp(m.contact[k0]["z1"], S.z[kk, j][ok][o],
                                                                 r.p0[kk, j][ok][o])), float(r.share[kk, j]))
            fe5 = (r5["approach_um"], r5["p_max_mid_MPa"], r5["share"])
            r3 = rec3.get("default", {}).get(name, {}).get(f)
            fe3 = (r3["approach_um"], r3["p_max_mid_MPa"], r3["share"]) if r3 else (math.nan,) * 3
            # the FE level: the 3-tooth contact model's very fine over its default result at this position
            # (approach and p: ratio; share: difference), where both are recorded, else none (flagged)
            rv = rec3.get("very fine", {}).get(name, {}).get(f)
            lvl = ((rv["approach_um"] / fe3[0], rv["p_max_mid_MPa"] / fe3[1], rv["share"] - fe3[2])
                   if rv and r3 else None)
            fe5v = (fe5[0] * lvl[0], fe5[1] * lvl[1], fe5[2] + lvl[2]) if lvl else fe5
            ref = tuple(a + b - c for a, b, c in zip(fe5v, q["full+n"], q["sec5+n"]))
            ref0 = tuple(a + b - c for a, b, c in zip(fe5v, q["full"], q["sec5+n"]))
            nloaded = int(sum(float(v or 0.0) > 1e-3 for v in r5["shares"].values()))
            # per pair, loaded TCA's stiffness over the 5-tooth FE's, (share / approach) over (share / approach)
            # (benchmarks/ltca_pair_stiffness.py): where it sits, pitch pair (k0) or the others
            ratio = {lab: {str(k): (float(res[lab].share[kk, j]) / q[lab][0]) / (float(r5["shares"][str(k)]) / fe5[0])
                           for kk, k in enumerate(res[lab].pairs) if float(r5["shares"].get(str(k)) or 0.0) > 1e-3}
                     for lab in ("fe", "sec5+n")}
            row = {"drive": name, "k0": int(k0), "pair_ratio": ratio, "pos": f, "phi1_deg": math.degrees(phis[j]), "pairs": nloaded, "fe3": fe3, "fe5": fe5,
                   "level": lvl, "ref": ref, "ref0": ref0, "shares5": r5["shares"], **{k: v for k, v in q.items()}}
            out["runs"].setdefault(name, {})[f] = row
    print_tables(out)
    TABLES.write_text(json.dumps({"_about": "benchmarks/fe_teeth_reference.py --tables: (approach um, section p MPa, "
                                  "share of the pair nearest the pitch point) per drive and position; fe3 / fe5: the "
                                  "contact model with 3 / 5 teeth per member (default level); fe, fe+n3, sec5, sec5+n, "
                                  "full, full+n: loaded TCA with FE coefficients (3-tooth grids; + the 3-tooth sector's "
                                  "neighbours; moved to the 5-tooth sector; + its neighbours; full gears; + theirs); "
                                  "none, full_gear: the default compliance with LTCASettings.neighbours; level: the 3-tooth "
                                  "contact model's very fine over default (approach, p ratios; share difference) or "
                                  "null; ref, ref0: fe5 at the very fine level (fe5 x level) + full(+n) - sec5+n", "date": time.strftime("%Y-%m-%d"), "torque_Nm": T, **out},
                                 indent=1) + "\n")
    print(f"recorded in {TABLES.relative_to(ROOT)}")
    return 0


def print_tables(out: dict) -> None:
    """Print tables (a) and (b) of :func:`tables` from its record ``out``."""
    rows = [r for runs in out["runs"].values() for r in runs.values()]

    def e(a, b):
        return 100 * (a / b - 1)

    print(f"(a) loaded TCA with FE coefficients against the contact model with 5 teeth per member ({T:g} N m, default "
          "level): approach [um] (error %), section p [MPa] (error %), share of the pitch pair; fe: the 3-tooth grids "
          "as they are; fe+n3: + the 3-tooth sector's neighbours; sec5+n: the grids moved to the 5-tooth sector, + its "
          "neighbours; FE3: the 3-tooth record")
    print(f"{'drive':<34} {'phi1':>6} {'n':>1} {'FE3 app':>7} {'FE5 app':>7} {'fe':>14} {'fe+n3':>14} {'sec5+n':>14} | "
          f"{'FE5 p':>7} {'fe p':>14} {'sec5+n p':>14} | {'FE3 sh':>6} {'FE5 sh':>6} {'fe sh':>6} {'s5+n sh':>7}")
    cnt = {k: [0, 0, 0] for k in ("fe", "fe+n3", "sec5+n")}
    for r in rows:
        fe5 = r["fe5"]
        for k in cnt:
            cnt[k][0] += abs(e(r[k][0], fe5[0])) <= 5
            cnt[k][1] += abs(e(r[k][1], fe5[1])) <= 5
            cnt[k][2] += abs(r[k][2] - fe5[2]) <= 0.05
        print(f"{r['drive'][:34]:<34} {r['phi1_deg']:6.2f} {r['pairs']:1d} {r['fe3'][0]:7.3f} {fe5[0]:7.3f} "
              + " ".join(f"{r[k][0]:7.3f} ({e(r[k][0], fe5[0]):+4.1f})" for k in ("fe", "fe+n3", "sec5+n"))
              + f" | {fe5[1]:7.1f} " + " ".join(f"{r[k][1]:7.1f} ({e(r[k][1], fe5[1]):+4.1f})" for k in ("fe", "sec5+n"))
              + f" | {r['fe3'][2]:6.3f} {fe5[2]:6.3f} {r['fe'][2]:6.3f} {r['sec5+n'][2]:7.3f}")
    n = len(rows)
    print(f"within 5 % (shares 0.05) of {n}: " + "; ".join(f"{k}: approach {c[0]}, p {c[1]}, share {c[2]}"
                                                          for k, c in cnt.items()))
    print("per pair, loaded TCA's stiffness over the 5-tooth FE's - 1 [%] (pair: fe / sec5+n; * the pitch pair)")
    for r in rows:
        pr = r["pair_ratio"]
        print(f"  {r['drive'][:34]:<34} {r['phi1_deg']:6.2f} " + "  ".join(
            f"{int(k):+d}{'*' if int(k) == r['k0'] else ' '}: {100 * (pr['fe'][k] - 1):+5.1f} / "
            f"{100 * (pr['sec5+n'][k] - 1):+5.1f}" for k in sorted(pr["fe"], key=int)))
    print("(b) the default compliance against the 5-tooth reference corrected to full-gear bodies held at r_f / 2: "
          "ref = FE5' + full+n - sec5+n (with the full gears' neighbouring teeth), ref0 = FE5' + full - sec5+n "
          "(without); FE5': FE5 moved to the very fine level by the 3-tooth model's ratio there (* where no 3-tooth "
          "default-level run is recorded: FE5 as it is); 'full_gear' / 'none': LTCASettings.neighbours")
    print(f"{'drive':<34} {'phi1':>6} {'n':>1} {'ref app':>8} {'full_gear':>15} {'none':>15} {'ref0':>7} "
          f"{'none':>6} | {'ref p':>7} {'full_gear p':>15} {'none p':>15} | {'ref sh':>6} {'fg sh':>6} {'none sh':>7}")
    cnt = {k: [0, 0, 0] for k in ("full_gear", "none", "none/ref0")}
    for r in rows:
        ref, ref0 = r["ref"], r["ref0"]
        for k, (v, rr) in {"full_gear": (r["full_gear"], ref), "none": (r["none"], ref),
                           "none/ref0": (r["none"], ref0)}.items():
            cnt[k][0] += abs(e(v[0], rr[0])) <= 5
            cnt[k][1] += abs(e(v[1], rr[1])) <= 5
            cnt[k][2] += abs(v[2] - rr[2]) <= 0.05
        print(f"{r['drive'][:34]:<34} {r['phi1_deg']:6.2f} {r['pairs']:1d} {ref[0]:7.3f}{' ' if r['level'] else '*'}"
              f"{r['full_gear'][0]:7.3f} ({e(r['full_gear'][0], ref[0]):+5.1f}) {r['none'][0]:7.3f} "
              f"({e(r['none'][0], ref[0]):+5.1f}) {ref0[0]:7.3f} {e(r['none'][0], ref0[0]):+6.1f} | {ref[1]:7.1f} "
              f"{r['full_gear'][1]:7.1f} ({e(r['full_gear'][1], ref[1]):+5.1f}) {r['none'][1]:7.1f} "
              f"({e(r['none'][1], ref[1]):+5.1f}) | {ref[2]:6.3f} {r['full_gear'][2]:6.3f} {r['none'][2]:7.3f}")
    print(f"within 5 % (shares 0.05) of {n}: " + "; ".join(f"{k}: approach {c[0]}, p {c[1]}, share {c[2]}"
                                                          for k, c in cnt.items()))
    print("the 'full_gear' approach error [% of ref] = the FE-coefficient model's own miss (sec5+n - FE5') + the "
          "analytical compliance's ('full_gear' - full+n, FE coefficients on full gears + their neighbours), exactly")
    for r in rows:
        fe5v = r["ref"][0] - r["full+n"][0] + r["sec5+n"][0]
        print(f"  {r['drive'][:34]:<34} {r['phi1_deg']:6.2f} {e(r['full_gear'][0], r['ref'][0]):+6.1f} = "
              f"{100 * (r['sec5+n'][0] - fe5v) / r['ref'][0]:+5.1f} {100 * (r['full_gear'][0] - r['full+n'][0]) / r['ref'][0]:+5.1f}")


def split() -> int:
    """The default compliance's miss against loaded TCA with FE coefficients on full gears + their neighbours
    (the last column of table (b)), located: with one load distribution F (the FE-coefficient solve's) each
    pair's own part ``(F_k^T C_kk F_k + sum F_k c_Weber F_k / l) / sum F`` and the pairs' coupling ``sum_{k != k'}
    F_k^T C_kk' F_k' / sum F`` [um] for both compliances (on crowned drives the separations' part ``F^T s`` is not
    in either, so the sums are below the approach there; the differences are like for like); then per member the
    FE full gears' response of the teeth d = 1, 2 (mean of -d and +d, three rows) over the default term's (with
    its axial part (N2), the annular Mindlin plate) and over (N1) alone, and the axial part against a Kirchhoff
    plate's (thickness b, clamped at the bore r_f / 2, free at r_f; :func:`plate_axial`)."""
    from fe_full_gear_body import NeighbourLTCA, full_gear_grid, neighbour_grids

    from gearopt.ltca.compliance import Material, weber_contact
    from gearopt.ltca.engine import LTCA

    mat = Material(E=210e3, nu=0.3)
    nbr = json.loads((ROOT / "benchmarks" / "data" / "fe_neighbour_teeth.json").read_text())["members"]
    print("per position, pair by pair (own tooth + Weber) and the pairs' coupling [um], under the FE-coefficient "
          "solve's loads: FE coefficients on full gears + their neighbours (FE), the default compliance (an.)")
    for name in drives():
        if "tip relief" in name:
            continue
        pair, mis = drives()[name]
        cb = math.cos(pair.pinion.beta_b)
        fracs = ("0", "-0.3", "+0.3")
        fs = fe_coefficients(pair, mis, fracs, mat)
        Lf, S, phis, g, tt, gears, rf = fs.ltca, fs.slices, fs.phi1, fs.grids, fs.teeth, fs.gears, fs.r_form
        Lf.influence = tuple(full_gear_grid(g[m], tt[m], gears[m], rf[m])[0] for m in (0, 1))
        NL = NeighbourLTCA(Lf, [neighbour_grids(tt[m], gears[m], rf[m], g[m], "full - sector") for m in (0, 1)])
        res = NL.solve(T, S).results[0]
        sts = {"FE": NL.structure(S), "an.": LTCA(pair, material=mat).structure(S)}
        K, N, M = S.z.shape
        for j, f in enumerate(fracs):
            F = np.nan_to_num(res.load[:, j, :])
            on = [k for k in range(K) if F[k].sum() > 1e-3 * F.sum()]
            if len(on) < 2:
                continue
            scale = 1e3 / F.sum() / cb
            parts = {}
            for lab, st in sts.items():
                C = np.nan_to_num(st.Cs[j])
                own = []
                for k in on:
                    ln = st.length[k, j]
                    w = weber_contact(np.maximum(F[k] / ln, 0.0), st.R[k, j], st.h1[k, j], st.h2[k, j], mat, 1e-3)
                    own.append(float(F[k] @ C[k * M:(k + 1) * M, k * M:(k + 1) * M] @ F[k])
                               + float(np.nansum(F[k] * w.compliance * F[k] / ln)))
                Fv = F.reshape(-1)
                cross = float(Fv @ C @ Fv) - sum(float(F[k] @ C[k * M:(k + 1) * M, k * M:(k + 1) * M] @ F[k]) for k in on)
                parts[lab] = (np.array(own) * scale, cross * scale)
            (fo, fc), (ao, ac) = parts["FE"], parts["an."]
            sh = F.sum(axis=1) / F.sum()
            print(f"  {name[:30]:<30} {math.degrees(phis[j]):+5.2f} " + "  ".join(
                f"pair {res.pairs[k]:+d} ({sh[k]:.2f}): {a:6.3f}/{b:6.3f} ({100 * (b / a - 1):+5.1f} %)"
                for k, a, b in zip(on, fo, ao)) + f"  coupling: {fc:6.3f}/{ac:6.3f} ({100 * (ac / fc - 1):+5.1f} %)"
                f"  an. - FE: own {ao.sum() - fo.sum():+6.3f}, coupling {ac - fc:+6.3f} um")
    print("the full gears' FE response of the teeth d pitches away (mean of -d, +d; rows low / mid / tip) over the "
          "default term's (with the axial part (N2)) and over (N1) alone; at the mid row what (N2) adds to (N1), "
          "sin^2(beta_b) (a(d) - n_t(d)) (a: the annular Mindlin plate), and a Kirchhoff plate's whole axial part "
          "sin^2(beta_b) b w(d) [um mm/N]")
    for name in ("spur 20/40 conjugate", "helical 15 deg", "scene ltca_helical (crowned)"):
        pair, _ = drives()[name]
        La = LTCA(pair, material=mat)
        cb = math.cos(pair.pinion.beta_b)
        for m, gm in enumerate((pair.pinion, pair.gear)):
            t = La.neighbour_terms[m]
            fe = nbr[f"{gm.z} teeth ({name})"]
            for d in (1, 2):
                v = 0.5 * (np.array(fe[f"full -{d}"]) + np.array(fe[f"full +{d}"]))
                model = 1e3 * cb**2 * float(t(d))
                n1 = 1e3 * cb**2 * (t.c_tw + t.A * math.exp(-t.k * d * t.x) * (t.c_body - t.c_tw))
                ax = 1e3 * math.sin(gm.beta_b) ** 2 * gm.b * plate_axial(0.5 * gm.r_f, gm.r_f, gm.b, [2 * math.pi * d / gm.z])[0]
                print(f"  {name[:30]:<30} z {gm.z:2d} d {d}: FE / model " + " ".join(f"{x:.3f}" for x in v / model)
                      + "; FE / (N1) alone " + " ".join(f"{x:.3f}" for x in v / n1)
                      + f"; (N2) - (N1) {model - cb**2 * n1:.5f}, Kirchhoff sin^2(beta_b) b w {ax:.5f}")
    return 0


#: the hold-out member of ``--holdout``: (z, m_n [mm], b [mm], beta [deg]), a gear with 21 pinion teeth, no
#: validation member
HOLDOUT_GEAR = (60, 2.5, 24.0, 25.0)


def holdout() -> int:
    """The full gear (held at r_f / 2) of :data:`HOLDOUT_GEAR` and the spur gear of its transverse section
    (``m = m_n / cos(beta)``): each tooth's response along its normal [um mm/N] at three rows under a normal line
    load uniform over the face on the tooth d = -2 ... +2 pitches away (fe_full_gear_body's line-load mesh,
    CalculiX, recorded per gear), and against (N1): ``FE_helical(d) = cos^2(beta_b) n_t(d) + sin^2(beta_b) n_a(d)``
    with ``n_t`` the spur's in-plane response and ``n_a`` the axial one, which (N1) takes equal to ``n_t``."""
    from dataclasses import replace

    from fe_full_gear_body import MESH

    from gearopt.fea.influence import line_load_compliance
    from gearopt.gears import Gear, GearPair
    from gearopt.ltca.compliance import Material
    from gearopt.ltca.engine import LTCA
    from gearopt.meshing.tca import TCA

    z, mn, b, beta = HOLDOUT_GEAR
    data = json.loads(HOLDOUT.read_text()) if HOLDOUT.exists() else {}
    pairs = {}
    for lab, bt, m in (("helical", beta, mn), ("spur, the same transverse section", 0.0, mn / math.cos(math.radians(beta)))):
        pair = GearPair(Gear(z=21, m_n=m, b=b, beta=math.radians(bt), name="pinion"),
                        Gear(z=z, m_n=m, b=b, beta=math.radians(bt), hand="left" if bt else "right", name="gear"))
        pairs[lab] = pair
        if lab in data:
            continue
        tca = TCA(pair)
        tooth = tca.gear.unmodified
        kw = dict(E=210e3, nu=0.3, r_form=tca.form_radius(2))
        r = line_load_compliance(tooth, mesh=replace(MESH, rim_depth=1.5), teeth=3, support="sector", **kw).radius
        cols = [0, r.size // 2, r.size - 1]
        full = line_load_compliance(tooth, mesh=MESH, teeth=z, support="bore", r_bore=0.5 * tooth.r_root, rows=cols,
                                    neighbours=(-2, -1, 1, 2), **kw)
        data[lab] = {"z": z, "m_n": m, "b": b, "beta_deg": bt, "rows_mm": [round(float(full.radius[c]), 4) for c in cols],
                     "self": [1e3 * float(full.C[c, c]) for c in cols],
                     **{f"{d:+d}": [1e3 * float(full.neighbours[d][c, c]) for c in cols] for d in (-2, -1, 1, 2)}}
        data["_about"] = ("benchmarks/fe_teeth_reference.py --holdout: a full gear held at r_f / 2, line loads on three "
                          "rows, the loaded tooth's (self) and the teeth d pitches away's responses along their normals "
                          "at those rows [um mm/N], E 210 GPa, nu 0.3")
        HOLDOUT.write_text(json.dumps(data, indent=1) + "\n")
    hel, sp = data["helical"], data["spur, the same transverse section"]
    gear = pairs["helical"].gear
    s2 = math.sin(gear.beta_b) ** 2
    La = LTCA(pairs["helical"], material=Material(E=210e3, nu=0.3))
    Ls = LTCA(pairs["spur, the same transverse section"], material=Material(E=210e3, nu=0.3))
    print(f"hold-out gear z {z}, m_n {mn}, b {b}, beta {beta} deg (sin^2(beta_b) {s2:.4f}); rows low / mid / tip [um mm/N]")
    for d in (1, 2):
        h = 0.5 * (np.array(hel[f"-{d}"]) + np.array(hel[f"+{d}"]))
        t = 0.5 * (np.array(sp[f"-{d}"]) + np.array(sp[f"+{d}"]))
        th = La.neighbour_terms[1]
        n1h = 1e3 * math.cos(gear.beta_b) ** 2 * float(th(d))
        n1a = 1e3 * math.cos(gear.beta_b) ** 2 * (th.c_tw + th.A * math.exp(-th.k * d * th.x) * (th.c_body - th.c_tw))
        n1s = 1e3 * float(Ls.neighbour_terms[1](d))
        na = (h - (1 - s2) * t) / s2
        ax = 1e3 * b * plate_axial(0.5 * gear.r_f, gear.r_f, b, [2 * math.pi * d / z])[0]
        print(f"  d {d}: FE helical " + " ".join(f"{x:.5f}" for x in h) + ", spur " + " ".join(f"{x:.5f}" for x in t)
              + "; helical / spur " + " ".join(f"{x:.3f}" for x in h / t) + f"; the default term, helical {n1h:.5f} (FE / it "
              + " ".join(f"{x:.3f}" for x in h / n1h) + f"; (N1) alone {n1a:.5f}, FE / it "
              + " ".join(f"{x:.3f}" for x in h / n1a) + f"), spur {n1s:.5f} (FE / it " + " ".join(f"{x:.3f}" for x in t / n1s)
              + "); n_a from FE " + " ".join(f"{x:.4f}" for x in na) + f", Kirchhoff plate {ax:.4f}")
    print("  self: helical / spur " + " ".join(f"{x:.3f}" for x in np.array(hel["self"]) / np.array(sp["self"])))
    return 0


def plate_axial(a: float, b: float, t: float, angles, E: float = 210e3, nu: float = 0.3, nmax: int = 60) -> np.ndarray:
    """Axial deflection [mm/N] of the outer edge of an annular Kirchhoff plate (inner radius ``a`` clamped, outer
    radius ``b`` free, thickness ``t`` [mm]) at the polar ``angles`` [rad] under a unit axial point force on the
    outer edge at angle 0: the Fourier series of the edge shear ``delta(theta) / b``, each harmonic ``n`` from
    ``w = (A r^n + B r^-n + C r^(n+2) + D r^(2-n)) cos(n theta)`` (n >= 2; ``1, r^2, ln r, r^2 ln r`` for n = 0;
    ``r, r^3, 1/r, r ln r`` for n = 1) with w = w' = 0 at ``a`` and M_r = 0, V_r = the load at ``b``."""
    D = E * t**3 / (12.0 * (1.0 - nu**2))

    def rows(n, r):
        # w, w', M_r / D, V_r / D of the four basis functions at r (theta = 0), per unit amplitude
        if n == 0:
            f = [(1.0, 0.0, 0.0, 0.0), (r**2, 2 * r, 2.0, 0.0), (math.log(r), 1 / r, -1 / r**2, 2 / r**3),
                 (r**2 * math.log(r), 2 * r * math.log(r) + r, 2 * math.log(r) + 3, 2 / r)]
        elif n == 1:
            f = [(r, 1.0, 0.0, 0.0), (r**3, 3 * r**2, 6 * r, 6.0), (1 / r, -1 / r**2, 2 / r**3, -6 / r**4),
                 (r * math.log(r), math.log(r) + 1, 1 / r, -1 / r**2)]
        else:
            f = [(r**p, p * r**(p - 1), p * (p - 1) * r**(p - 2), p * (p - 1) * (p - 2) * r**(p - 3))
                 for p in (n, -n, n + 2, 2 - n)]
        out = []
        for w, w1, w2, w3 in f:
            lap_r = w3 + w2 / r - w1 / r**2 - n**2 * (w1 / r**2 - 2 * w / r**3)  # d/dr of the Laplacian
            mr = -(w2 + nu * (w1 / r - n**2 * w / r**2))
            vr = -(lap_r - (1 - nu) * n**2 * (w1 / r**2 - w / r**3))  # Kirchhoff's effective shear
            out.append((w, w1, mr, vr))
        return np.array(out).T

    ang = np.asarray(angles, float)
    total = np.zeros(ang.size)
    for n in range(nmax + 1):
        ra, rb = rows(n, a), rows(n, b)
        A = np.vstack([ra[0], ra[1], rb[2], rb[3]])
        q = 1.0 / (2 * math.pi * b) if n == 0 else 1.0 / (math.pi * b)
        c = np.linalg.solve(A, np.array([0.0, 0.0, 0.0, q / D]))
        total += float(rb[0] @ c) * np.cos(n * ang)
    return total


def check_args(argv) -> str | None:
    """The first problem with the command line, or None."""
    i = 0
    while i < len(argv):
        if argv[i] == "--worker":
            v = argv[i + 1].split("/") if i + 1 < len(argv) else []
            if len(v) != 2 or not all(x.isdigit() for x in v) or not 0 <= int(v[0]) < int(v[1]):
                return "--worker needs I/N with 0 <= I < N (e.g. 0/2)"
            i += 2
            continue
        if argv[i] not in ("--list", "--tables", "--recorded", "--split", "--holdout"):
            return f"unknown argument {argv[i]!r}: expected --list, --worker I/N, --tables [--recorded], --split, --holdout"
        i += 1
    if "--recorded" in argv and "--tables" not in argv:
        return "--recorded goes with --tables"
    return None


def main(argv) -> int:
    if "-h" in argv or "--help" in argv:
        print(__doc__)
        return 0
    problem = check_args(argv)
    if problem is not None:
        print(f"fe_teeth_reference.py: {problem} (see --help)", file=sys.stderr)
        return 2
    teeth = 5
    if "--split" in argv:
        return split()
    if "--holdout" in argv:
        return holdout()
    if "--tables" in argv:
        if "--recorded" in argv:  # print the recorded tables (no loaded TCA, no CalculiX)
            print_tables(json.loads(TABLES.read_text()))
            return 0
        return tables()
    done = read_record(teeth).get(LEVEL, {})
    queue = [q for q in QUEUE if q[1] not in done.get(q[0], {})]
    if "--list" in argv:
        for name, frac in QUEUE:
            rec = done.get(name, {}).get(frac)
            print(f"{name:<34} {frac:>5} " + (f"approach {rec['approach_um']:.3f} um ({rec['date']})" if rec else "-"))
        return 0
    if "--worker" in argv:
        i, n = (int(v) for v in argv[argv.index("--worker") + 1].split("/"))
        queue = queue[i::n]
    for name, frac in queue:
        if frac in read_record(teeth).get(LEVEL, {}).get(name, {}):
            continue
        pair, mis = drives()[name]
        ph = float(frac) * 2 * math.pi / pair.pinion.z
        t0 = time.process_time()
        w0 = time.perf_counter()
        opts = FEOptions(torque=T * 1e3, E=210e3, nu=0.3, mesh=FE_MESH, teeth=teeth, threads=1, timeout=3 * 3600.0)
        d = GearFEModel(pair, ph, opts, mis=mis).run().to_dict()
        rec = fe_record(d, pair)
        rec["teeth"] = teeth
        rec["wall_s"] = round(time.perf_counter() - w0, 1)
        add_record(teeth, name, frac, rec)
        print(f"{name} {frac}: approach {rec['approach_um']:.3f} um, shares {rec['shares']}, "
              f"{rec['wall_s']:.0f} s wall ({time.process_time() - t0:.0f} s CPU in Python)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
