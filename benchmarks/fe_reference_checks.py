"""Checks of the FE side of loaded TCA's validation (docs/ltca.md section 7):

    python benchmarks/fe_reference_checks.py refine   # influence-grid refinement, helical pair (~20 min uncached)
    python benchmarks/fe_reference_checks.py cross    # tooth-to-tooth coupling through the rim (~1 min)
    python benchmarks/fe_reference_checks.py penalty  # the contact model's penalty stiffness (~6 min)

refine: the helical pair of benchmarks/validate_ltca_fe.py at its three positions, 200 N m: loaded TCA's
approach with the FE influence coefficients of grids with 6 / 12 face layers and 8 / 14 flank rows,
against the FE contact model's approach (the validation table's FE column).

cross: one unit normal load on the middle tooth's flank (mid face, mid flank) of each member's
three-tooth model (held as for the influence grid); the displacement along each tooth's own normal at
the middle-line node of the same row and layer of the neighbouring teeth over that of the loaded tooth.
Loaded TCA treats the pairs' teeth as uncoupled; this ratio bounds what that leaves out.

penalty: the FE contact model of the validation (spur at the pitch point, helical at phi1 = 0) with the
default penalty slope 50 E and with 500 E: loaded approach and peak pressure in the contact section.

    python benchmarks/fe_reference_checks.py penalty --fine [--only spur] [--pen 50,200,1000]

at the refinement study's fine level (benchmarks/bench_fea_refine.py), the conjugate spur 20/40 at the pitch
point (200 N m, line contact: Hertz applies) and the crowned a_pl 2e-3 pinion (100 N m, the Hertz ellipse
inside the face), each penalty beside what the penalty layer alone does to a Hertz line contact: an
independent boundary-element solution of two elastic half-spaces in plane strain with a linear
pressure-overclosure layer p = K g between them, whose peak over Hertz's depends on E* / (K b) only
(`gearopt.fea.references.penalty_layer_factor`).
"""

from __future__ import annotations

import math
import shutil
import sys
import time

import numpy as np

from gearopt.fea.calculix import read_dat, run_ccx
from gearopt.fea.mesh import MeshOptions, ToothMesher, build_member
from gearopt.ltca.compliance import Material
from gearopt.ltca.engine import LTCA
from gearopt.meshing.tca import TCA

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from validate_ltca_fe import T, drives  # noqa: E402

FE_APPROACH_UM = (12.209, 11.45, 10.71)  #: the FE contact model at phi1 = 0, -0.3, +0.3 pitches (validation table)
GRID = dict(n_half=6, n_fillet=5, n_rim=4)


def refine():
    pair = drives()["helical 15 deg"][0]
    step = 2 * math.pi / pair.pinion.z
    phis = np.array([0.0, -0.3 * step, 0.3 * step])
    cb = math.cos(pair.pinion.beta_b)
    print("grid (face layers x flank rows): loaded TCA approach [um] at phi1 = 0, -0.3, +0.3 pitch; error vs FE")
    for nf, nfl in ((6, 8), (12, 8), (6, 14)):
        t0 = time.perf_counter()
        L = LTCA(pair, material=Material(E=210000.0, nu=0.3), compliance="fe",
                 fe_mesh=MeshOptions(n_face=nf, n_flank=nfl, **GRID))
        d = L.solve(T, phi1=phis).results[0].delta / cb * 1e3
        err = 100 * (d / np.array(FE_APPROACH_UM) - 1)
        print(f"{nf:2d} x {nfl:2d}: {np.round(d, 3)} um, {np.round(err, 1)} %  ({time.perf_counter() - t0:.0f} s)", flush=True)


def cross():
    for name in ("spur 20/40 conjugate", "helical 15 deg"):
        pair = drives()[name][0]
        tca = TCA(pair)
        for member, tooth in (("pinion", tca.pinion.unmodified), ("gear", tca.gear.unmodified)):
            m = ToothMesher(tooth, MeshOptions(n_face=6, n_flank=8, **GRID))
            mm = build_member(m, (-1, 0, 1), {}, member, 0.0)
            X = mm.nodes
            teeth = {t["k"]: t for t in mm.teeth}
            t0 = teeth[0]
            r0, r1 = t0["section"].segments["flank"]
            nh = t0["section"].n_half
            lay, row = t0["nodes"].shape[0] // 2, (r0 + r1) // 2
            load = t0["nodes"][lay, row, -1]
            ur = t0["u_rows"]
            uu = ur[row] if np.ndim(ur) == 1 else ur[lay][row]
            n0 = np.asarray(tooth.surface("right", "flank")(uu, X[load, 2], tooth.p0)[1]).ravel()
            resp = {k: teeth[k]["nodes"][lay, row, nh] for k in (-1, 0, 1)}
            fixed = np.unique(np.r_[mm.rim_bottom, mm.rim_sides]) + 1
            lines = ["*NODE, NSET=NALL"] + [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(X)]
            lines.append("*ELEMENT, TYPE=C3D8, ELSET=EALL")
            lines += [f"{i + 1}, " + ", ".join(str(int(n) + 1) for n in e) for i, e in enumerate(mm.elements)]
            lines += ["*NSET, NSET=FIX"] + [", ".join(str(int(v)) for v in fixed[i:i + 16])
                                            for i in range(0, fixed.size, 16)]
            lines += ["*NSET, NSET=RESP", ", ".join(str(int(resp[k]) + 1) for k in (-1, 0, 1))]
            lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", "210000, 0.3", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
                      "*BOUNDARY", "FIX, 1, 3", "*STEP", "*STATIC", "*CLOAD"]
            lines += [f"{load + 1}, {c + 1}, {-n0[c]:.12e}" for c in range(3)] + ["*NODE PRINT, NSET=RESP", "U", "*END STEP"]
            run = run_ccx(None, jobname="cross", threads=2, inp="\n".join(lines) + "\n")
            b = [b for b in read_dat(run.dat) if b.what.startswith("displacements")][0]
            U = {int(r[0]) - 1: np.array(r[1:4]) for r in b.rows}
            u = {}
            for k in (-1, 0, 1):
                c, s = math.cos(k * m.pitch_angle), math.sin(k * m.pitch_angle)
                u[k] = -U[resp[k]] @ np.array([c * n0[0] - s * n0[1], s * n0[0] + c * n0[1], n0[2]])
            print(f"{name:<22} {member:<6}: loaded tooth {u[0] * 1e3:.5f} um/N; neighbours -1 / +1: "
                  f"{u[-1] / u[0]:.4f} / {u[1] / u[0]:.4f} of it", flush=True)


def penalty_fine(argv):
    """The penalty study at a refined contact mesh (module docstring)."""
    from gearopt.fea import FEOptions, GearFEModel

    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from bench_fea_refine import LEVELS, VERY_FINE
    from bench_fea_refine import drives as refine_drives

    level = dict(VERY_FINE["very fine"]) if "--very-fine" in argv else LEVELS["fine"]
    pens = [float(v) for v in argv[argv.index("--pen") + 1].split(",")] if "--pen" in argv else [50.0, 200.0, 1000.0]
    cases = {"spur 20/40 conjugate": (drives()["spur 20/40 conjugate"][0], T),
             "crowned a_pl 2e-3": (refine_drives()["crowned a_pl 2e-3"], 100.0)}
    if "--only" in argv:
        cases = {k: v for k, v in cases.items() if argv[argv.index("--only") + 1] in k}
    print(f"FE mesh: {level}")
    print(f"{'case':<22} {'penalty E':>9} {'elements':>8} {'ccx s':>6} {'approach um':>11} {'p MPa':>8} {'Hertz':>7} "
          f"{'p/Hertz':>7} {'b mm':>6} {'E*/(Kb)':>8} {'layer only':>10} {'(p/layer)/Hertz':>15}")
    for name, (pair, torque) in cases.items():
        for pen in pens:
            t0 = time.perf_counter()
            m = GearFEModel(pair, 0.0, FEOptions(torque=torque * 1e3, E=210000.0, nu=0.3, penalty=pen,
                                                 timeout=7200.0, **level))
            d = m.run().to_dict()
            c = d["contact"]
            lam = c["penalty_lambda"]  # at the half-width of the FE's own peak
            print(f"{name:<22} {pen:9.0f} {m.n_elements:8d} {time.perf_counter() - t0:6.0f} "
                  f"{abs(d['pinion_rotation_rad']) * pair.pinion.r_b * 1e3:11.4f} {c['p_max_mid']:8.1f} "
                  f"{c['hertz_p0']:7.1f} {c['ratio_mid_to_hertz']:7.4f} {c['hertz_b']:6.4f} {lam:8.4f} "
                  f"{c['penalty_layer_factor']:10.4f} {c['p_max_mid_penalty_free'] / c['hertz_p0']:15.4f}", flush=True)


def penalty():
    from gearopt.fea import FEOptions, GearFEModel

    from validate_ltca_fe import FE_MESH

    if "--fine" in sys.argv or "--very-fine" in sys.argv:
        return penalty_fine(sys.argv)
    for name in ("spur 20/40 conjugate", "helical 15 deg"):
        pair = drives()[name][0]
        for pen in (50.0, 500.0):
            m = GearFEModel(pair, 0.0, FEOptions(torque=T * 1e3, E=210000.0, nu=0.3, mesh=FE_MESH, penalty=pen))
            d = m.run().to_dict()
            shares = {k: round(v, 3) for k, v in d["pair_share"].items() if v}
            print(f"{name:<22} penalty {pen:5.0f} E: approach {abs(d['pinion_rotation_rad']) * pair.pinion.r_b * 1e3:.3f} "
                  f"um, p in the contact section {d['contact']['p_max_mid']:.1f} MPa, shares {shares}", flush=True)


if __name__ == "__main__":
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed")
        sys.exit(0)
    what = sys.argv[1] if len(sys.argv) > 1 else "cross"
    {"refine": refine, "cross": cross, "penalty": penalty}[what]()
