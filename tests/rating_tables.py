"""Regenerate the validation tables of docs/rating.md (prints Markdown):

1. ISO/TR 6336-30:2017 example 1, factor by factor: published value, gearopt's, relative deviation.
2. Bending (and pitting) factors against a KISSsoft report (NREL 5 MW stage 3, ISO 6336:2006).
3. K_Hbeta of gearopt's loaded TCA beside ISO 6336-1 method B's for the 20/40 spur drive of
   problems/rating_spur.toml at 100 N m, over crossing angles and lead crownings.

4. With ``--fe`` only: the FE root stress of rating_spur at 100 N m beside ISO's sigma_F0 over mesh
   refinement and element type (CalculiX; 12 ccx runs, ~10 min on an idle machine).

Run: ``PYTHONPATH=. python tests/rating_tables.py`` (about a minute: 2 loaded TCA runs per cell);
``PYTHONPATH=. python tests/rating_tables.py --fe`` for table 4.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def tr_table() -> str:
    from test_rating_iso import PUBLISHED, tr_example_1

    r = tr_example_1()
    lines = ["| symbol | member | published | gearopt | deviation |", "|---|---|---|---|---|"]
    for sym, i, ref in PUBLISHED:
        got = r[sym] if i is None else r[sym][i]
        member = "" if i is None else ("pinion", "wheel")[i]
        lines.append(f"| {sym} | {member} | {ref:.6g} | {got:.6g} | {100 * (got / ref - 1):+.3f} % |")
    return "\n".join(lines)


def kisssoft_table() -> str:
    from test_rating_iso import KISSSOFT_STAGE3, stage3

    r = stage3.__wrapped__() if hasattr(stage3, "__wrapped__") else None
    if r is None:
        raise RuntimeError("fixture not callable")
    lines = ["| symbol | member | KISSsoft report | gearopt | deviation |", "|---|---|---|---|---|"]
    for sym, i, ref in KISSSOFT_STAGE3:
        got = r[sym] if i is None else r[sym][i]
        member = "" if i is None else ("pinion", "wheel")[i]
        lines.append(f"| {sym} | {member} | {ref:.6g} | {got:.6g} | {100 * (got / ref - 1):+.2f} % |")
    return "\n".join(lines)


def khb_table(torque: float = 100.0, scene_name: str = "rating_spur.toml", crossings: tuple = (0.0, 2.0, 4.0)) -> str:
    from gearopt.geometry.microgeometry import Microgeometry
    from gearopt.io.scene import load_scene
    from gearopt.meshing.misalignment import Misalignment
    from gearopt.rating.iso6336 import geometry, rate
    from gearopt.rating.pair import ltca_load_factors, mesh_misalignment
    from gearopt.studies.rating import RatingStudy
    from gearopt.units import ARCMIN

    scene = load_scene(Path(__file__).resolve().parents[1] / "problems" / scene_name)
    study = scene.build()
    assert isinstance(study, RatingStudy)
    pair0, pd = study.pair, study.pair_data
    alpha_wt = geometry(pd).alpha_wt
    lines = ["| crossing [arcmin] | lead crowning C_beta [um] | ISO f_ma [um] | K_Hbeta gearopt LTCA | "
             "K_Hbeta ISO 6336-1 | S_H pinion LTCA | S_H pinion ISO |", "|---|---|---|---|---|---|---|"]
    for c_beta in (0.0, 10.0, 20.0):
        mods = dataclasses.replace(pair0.pinion.modifications or Microgeometry(), C_beta=c_beta * 1e-3)
        pinion = dataclasses.replace(pair0.pinion, modifications=mods, a_pl=0.0)
        pair = type(pair0)(pinion, pair0.gear, a=pair0.a)
        for cross in crossings:
            f_ma = mesh_misalignment(pd.b, alpha_wt, cross * ARCMIN, 0.0)
            acc = dataclasses.replace(study.accuracy(), f_ma=f_ma)
            iso = rate(pd, study.operation(torque), *study.materials, acc)
            lf = ltca_load_factors(pair, [torque], Misalignment(crossing=cross * ARCMIN), study.settings)
            r = rate(pd, study.operation(torque, lf["K_Hbeta"][0], lf["K_Halpha"][0]), *study.materials, acc)
            lines.append(f"| {cross:g} | {c_beta:g} | {f_ma:.1f} | {lf['K_Hbeta'][0]:.3f} | {iso['K_Hbeta']:.3f} | "
                         f"{r['S_H'][0]:.3f} | {iso['S_H'][0]:.3f} |")
    return "\n".join(lines)


#: (n_half, n_flank, n_fillet, n_rim, n_face), element type: the refinement table of docs/rating.md
FE_LEVELS = [((4, 6, 4, 3, 2), "C3D8"), ((6, 8, 10, 4, 2), "C3D8"), ((8, 10, 16, 6, 2), "C3D8"),
             ((8, 10, 16, 6, 4), "C3D8"), ((6, 8, 10, 4, 2), "C3D8I"), ((8, 10, 16, 6, 2), "C3D8I")]


def fe_table(torque: float = 100.0) -> str:
    from gearopt.io.scene import load_scene
    from gearopt.rating.fe_root import fe_root_stress
    from gearopt.rating.iso6336 import geometry, tooth_form
    from gearopt.studies.rating import RatingStudy

    scene = load_scene(Path(__file__).resolve().parents[1] / "problems" / "rating_spur.toml")
    study = RatingStudy(scene.pair, torque)
    p = study.pair_data
    d_en = (tooth_form(0, p, geometry(p))["d_en"], tooth_form(1, p, geometry(p))["d_en"])
    s0 = study.iso_nominal["sigma_F0"]
    lines = ["| mesh n_half / n_flank / n_fillet / n_rim, n_face | elements | element | sigma_FE pinion | ratio pinion | "
             "sigma_FE gear | ratio gear | neighbour pairs' force [N] |", "|---|---|---|---|---|---|---|---|",
             f"| ISO sigma_F0 (generated tooth) | | | {s0[0]:.1f} | | {s0[1]:.1f} | | |"]
    for (nh, nfl, nfi, nr, nf), et in FE_LEVELS:
        fe = fe_root_stress(scene.pair, torque, d_en, s0, mesh=dict(n_half=nh, n_flank=nfl, n_fillet=nfi, n_rim=nr,
                                                                      n_face=nf), element_type=et)["members"]
        other = sum(v for m in fe for k, v in m["pair_force_N"].items() if k != "0")
        lines.append(f"| {nh} / {nfl} / {nfi} / {nr}, {nf} | {fe[0]['n_elements']} / {fe[1]['n_elements']} | {et} | "
                     f"{fe[0]['sigma_FE']:.1f} | {fe[0]['sigma_FE'] / s0[0]:.3f} | {fe[1]['sigma_FE']:.1f} | "
                     f"{fe[1]['sigma_FE'] / s0[1]:.3f} | {other:g} |")
    return "\n".join(lines)


if __name__ == "__main__":
    if "--fe" in sys.argv[1:]:
        print("### FE root stress beside ISO's sigma_F0 (rating_spur at 100 N m, the rated pair alone)\n")
        print(fe_table())
        raise SystemExit(0)
    print("### ISO/TR 6336-30:2017 example 1\n")
    print(tr_table())
    print("\n### Bending: a KISSsoft report (ISO 6336:2006 method B)\n")
    print(kisssoft_table())
    print("\n### K_Hbeta: loaded TCA and ISO 6336-1 (rating_spur at 100 N m)\n")
    print(khb_table())
    print("\n### K_Hbeta: loaded TCA and ISO 6336-1 (rating_helical, no plunging crowning, at 150 N m)\n")
    print(khb_table(150.0, "rating_helical.toml", (0.0, 3.0, 6.0)))
