"""The local (Hertzian) compression of a tooth, from the tooth flank to its middle line, in a
plane-strain CalculiX model of the tooth section, against Weber's half-space term that loaded TCA
adds to the FE influence coefficients (docs/ltca.md section 5).

    python benchmarks/local_compression_fe.py            # spur 20/40, m 3, pitch point, 200 and 50 N m
                                                         # over 20 mm (about 30 s)

Each member (pinion, gear) of the pair is meshed as a slab of the tooth section 1 mm thick, graded at
the contact point (n_hertz elements per Hertz half-width), held at its rim as the contact model holds
it, and every node's axial displacement is held (plane strain). The Hertz pressure of the line load
f [N/mm] (half-width b_H from both members' radii of curvature) is applied as nodal forces along the
flank. Printed: the normal displacement of the flank node at the pressure's centre minus that of the
point C where the load line meets the tooth's middle line, and Weber's term to the same depth,
2 f (1 - nu^2) / (pi E) (ln(2 h / b_H) - nu / (2 (1 - nu))).
"""

from __future__ import annotations

import math
import shutil
import sys

import numpy as np

from gearopt.fea import FEOptions, GearFEModel, MeshOptions
from gearopt.fea.calculix import read_dat, run_ccx
from gearopt.fea.influence import _middle_points
from gearopt.fea.model import hertz_line
from gearopt.gears import Gear, GearPair

E, NU = 210000.0, 0.3


def local_compression(model, member: str, f: float, b_H: float, threads: int = 2):
    mesh = model.pinion_mesh if member == "pinion" else model.gear_mesh
    tooth = model.pin_tooth if member == "pinion" else model.gear_tooth
    k = 0
    t = [t for t in mesh.teeth if t["k"] == k][0]
    nodes = t["nodes"]
    X = mesh.nodes
    r0, r1 = t["section"].segments["flank"]
    nh = t["section"].n_half
    rc = model.contact[0]["radius1" if member == "pinion" else "radius2"]
    rows = np.arange(r0, r1 + 1)
    rad = np.hypot(X[nodes[0, rows, -1], 0], X[nodes[0, rows, -1], 1])
    ic = int(rows[np.argmin(np.abs(rad - rc))])
    # arc length along the flank from the centre node (layer 0), towards the tip negative
    P = X[nodes[0, rows, -1], :2]
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    s = arc - arc[list(rows).index(ic)]
    u_c = t["u_rows"][ic] if np.ndim(t["u_rows"]) == 1 else t["u_rows"][0][ic]
    n3 = np.asarray(tooth.surface("right", "flank")(u_c, 0.0, tooth.p0)[1]).ravel()
    nrm = n3 / np.linalg.norm(n3)
    # Hertz pressure p0 sqrt(1 - (s/b)^2) integrated over each half segment around a node (lumped)
    p0 = 2 * f / (math.pi * b_H)
    fine = np.linspace(s[0], s[-1], 200001)
    p = p0 * np.sqrt(np.clip(1 - (fine / b_H) ** 2, 0, None))
    mids = np.concatenate([[s[0]], 0.5 * (s[1:] + s[:-1]), [s[-1]]])
    Fn = np.array([np.trapezoid(p[(fine >= a) & (fine <= b_)], fine[(fine >= a) & (fine <= b_)])
                   for a, b_ in zip(mids[:-1], mids[1:])])  # N per mm of face, per row
    zl = X[nodes[:, 0, 0], 2]
    slab = zl[-1] - zl[0]
    wz = np.zeros(zl.size)  # trapezoid weights of the layers [mm]
    wz[:-1] += 0.5 * np.diff(zl)
    wz[1:] += 0.5 * np.diff(zl)
    loads = []
    for j, r in enumerate(rows):
        if Fn[j] <= 0:
            continue
        for layer in range(zl.size):
            loads.append((int(nodes[layer, r, -1]), -Fn[j] * wz[layer] * nrm))
    total = sum(np.linalg.norm(v) for _, v in loads)
    # the response point C in layer 0
    load = np.array([[nodes[0, ic, -1]]])
    normals = nrm[None, None, :]
    mid_rows = np.arange(0, t["section"].segments["fillet"][1] + 1)
    pair_, w, depth = _middle_points(X, nodes[:1], load, normals, mid_rows, nh)
    fixed = np.unique(np.r_[mesh.rim_bottom, mesh.rim_sides]) + 1
    lines = ["*NODE, NSET=NALL"] + [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(X)]
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=EALL")
    lines += [f"{i + 1}, " + ", ".join(str(int(n) + 1) for n in e) for i, e in enumerate(mesh.elements)]
    lines += ["*NSET, NSET=FIX"] + [", ".join(str(int(v)) for v in fixed[i:i + 16]) for i in range(0, fixed.size, 16)]
    resp = [int(nodes[0, ic, -1]) + 1, int(pair_[0, 0]) + 1, int(pair_[0, 1]) + 1]
    lines += ["*NSET, NSET=RESP", ", ".join(str(v) for v in resp)]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E:.6e}, {NU:.6f}", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
              "*BOUNDARY", "FIX, 1, 3", "*BOUNDARY", "NALL, 3, 3", "*STEP", "*STATIC", "*CLOAD"]
    for nid, v in loads:
        lines += [f"{nid + 1}, {c + 1}, {v[c]:.12e}" for c in range(2)]
    lines += ["*NODE PRINT, NSET=RESP", "U", "*END STEP"]
    run = run_ccx(None, jobname="local", threads=threads, inp="\n".join(lines) + "\n")
    blk = [b for b in read_dat(run.dat) if b.what.startswith("displacements")][-1]
    U = {int(r[0]): np.array(r[1:4], float) for r in blk.rows}
    u_flank = -U[resp[0]] @ nrm
    u_C = -((1 - w[0]) * U[resp[1]] + w[0] * U[resp[2]]) @ nrm
    h = float(depth[0])
    weber = 2 * f * (1 - NU**2) / (math.pi * E) * (math.log(2 * h / b_H) - NU / (2 * (1 - NU)))
    return {"flank_um": 1e3 * u_flank, "C_um": 1e3 * u_C, "local_um": 1e3 * (u_flank - u_C), "weber_um": 1e3 * weber,
            "h_mm": h, "load_N_per_mm": total / slab, "elements": len(mesh.elements)}


def main(argv):
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed")
        return 0
    b = 20.0
    full = GearPair(Gear(z=20, m_n=3.0, b=b, name="pinion"), Gear(z=40, m_n=3.0, b=b, name="gear"))
    # (torque [N m], elements per b_H, across half a tooth, along a flank)
    levels = [(200.0, 4.0, 12, 10), (200.0, 8.0, 12, 10), (200.0, 8.0, 20, 16), (50.0, 8.0, 20, 16)]
    for T, n_hertz, n_half, n_flank in levels:
        f = T * 1e3 / full.pinion.r_b / b  # N/mm
        slab = GearPair(Gear(z=20, m_n=3.0, b=1.0, name="pinion"), Gear(z=40, m_n=3.0, b=1.0, name="gear"))
        m = GearFEModel(slab, 0.0, FEOptions(torque=f * 1.0 * slab.pinion.r_b, n_hertz=n_hertz,
                                             mesh=MeshOptions(n_face=2, n_half=n_half, n_flank=n_flank, n_fillet=5,
                                                               n_rim=4)))
        c = m.contact[0]
        rho1 = math.sqrt(c["radius1"] ** 2 - slab.pinion.r_b ** 2)
        rho2 = math.sqrt(c["radius2"] ** 2 - slab.gear.r_b ** 2)
        b_H = hertz_line(f, rho1, rho2, E, NU)["b"]
        for member in ("pinion", "gear"):
            r = local_compression(m, member, f, b_H)
            print(f"{T:g} N m, n_hertz {n_hertz:g} n_half {n_half} n_flank {n_flank} {member:<7} "
                  f"f {r['load_N_per_mm']:.1f} N/mm, b_H {b_H:.4f} mm, h {r['h_mm']:.3f} mm: "
                  f"flank {r['flank_um']:.3f} um, C {r['C_um']:.3f} um, flank - C {r['local_um']:.3f} um, Weber "
                  f"{r['weber_um']:.3f} um (FE / Weber {r['local_um'] / r['weber_um']:.3f}, (FE - Weber) / f "
                  f"{1e3 * (r['local_um'] - r['weber_um']) / f:.3f} um per N/mm x 1000); {r['elements']} elements",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
