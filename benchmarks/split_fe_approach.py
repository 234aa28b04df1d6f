"""Split the CalculiX contact model's loaded approach into each member's parts (docs/ltca.md section 5).

    python benchmarks/split_fe_approach.py              # C3D8, the default contact grading
    python benchmarks/split_fe_approach.py C3D8I 6      # element type, elements per Hertz half-width
    python benchmarks/split_fe_approach.py --helical    # the helical 21/45 at phi1 = 0 (three pairs), per face
                                                        # layer (validate_ltca_fe.py's default level, ~2 min)

The 20/40 spur pair (m 3, b 20) at the pitch point, 200 N m, E 210 GPa, nu 0.3. For each member, in
the middle section, the nodal displacement along the contact normal (rigid rotation removed) at: the
flank node of the contact, the point C where the load line (the flank normal through the contact)
meets the tooth's middle line, and the middle node of the contact row. Printed beside them: the
Weber-Banaschek flattening to the centreline that loaded TCA adds, and loaded TCA's tooth deflection
at C from the FE influence coefficients (``compliance = "fe"``) under its own slice loads.

``--helical``: the helical 21/45 of validate_ltca_fe.py at phi1 = 0 (pairs -1, 0, +1 in mesh), its default FE
level (8 face layers). For the pitch pair, in every inner face layer: the flank node of the largest contact
pressure (pinion) and the gear's flank node nearest to it, the displacement along the 3-D flank normal (each
member's rigid rotation removed) at the flank and at C (where the load line, projected on the layer, meets the
middle line, as gearopt.fea.influence measures), against loaded TCA's (FE coefficients) tooth at C under the
pitch pair's own slice loads and its local term (Weber with ``h e^kappa``, section 5) at the same z; and the
penalty contact's penetration, the FE approach along the normal minus the two flanks' displacements.
"""

from __future__ import annotations

import math
import shutil
import sys

import numpy as np

from gearopt.fea import FEOptions, GearFEModel
from gearopt.fea.calculix import read_frd_block
from gearopt.gears import Gear, GearPair
from gearopt.ltca.compliance import Material
from gearopt.ltca.engine import LTCA

T = 200.0


def _interp(z, zs, v):
    return float(np.interp(z, zs, v))


def helical() -> int:
    """The split of the helical 21/45's pitch pair at phi1 = 0, per face layer (module docstring)."""
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from validate_ltca_fe import FE_MESH, drives

    pair, mis = drives()["helical 15 deg"]
    mat = Material(E=210000.0, nu=0.3)
    m = GearFEModel(pair, 0.0, FEOptions(torque=T * 1e3, E=mat.E, nu=mat.nu, mesh=FE_MESH), mis=mis)
    res = m.run()
    d = res.to_dict()
    U = read_frd_block(res.frd, "DISP")
    P = read_frd_block(res.frd, "CONTACT") or {}
    theta = d["pinion_rotation_rad"]
    cb = math.cos(pair.pinion.beta_b)
    app = abs(theta) * pair.pinion.r_b * 1e3
    XA = np.vstack([m.nodes_pinion, m.nodes_gear])
    n1 = len(m.nodes_pinion)
    print(f"helical 21/45, phi1 = 0, {T:g} N m, FE default level: approach {app:.3f} um along the line of action "
          f"({app * cb:.3f} um along the normal); pair shares " +
          ", ".join(f"{k}: {v:.3f}" for k, v in sorted(d["pair_share"].items(), key=lambda kv: int(kv[0]))))

    def u3(i, centre, th):
        x, y = XA[i, 0] - centre[0], XA[i, 1] - centre[1]
        return np.asarray(U[i + 1][:3]) - th * np.array([-y, x, 0.0])

    fe, xc = {}, {}
    for name, mesh, noff, centre, th in (("pinion", m.pinion_mesh, 0, (0.0, 0.0), theta),
                                         ("gear", m.gear_mesh, n1, (0.0, pair.a_w), 0.0)):
        t = [t for t in mesh.teeth if t["k"] == 0][0]
        N = t["nodes"] + noff
        r0, r1 = t["section"].segments["flank"]
        nh = t["section"].n_half
        rows = list(range(r0, r1 + 1))
        mid_rows = np.arange(0, t["section"].segments["fillet"][1] + 1)
        for lay in range(1, N.shape[0] - 1):
            if name == "pinion":
                pr = [P.get(int(N[lay, q, -1]) + 1, [0, 0, 0, 0])[3] for q in rows]
                if max(pr) <= 0:
                    continue
                r = rows[int(np.argmax(pr))]
            else:  # the gear's flank node nearest to the pinion's contact node in the same section
                zl = XA[N[lay, rows[0], -1], 2]
                near = [zz for zz in xc if abs(zz - zl) < 0.5]
                if not near:
                    continue
                r = rows[int(np.argmin([np.linalg.norm(XA[N[lay, q, -1]] - xc[near[0]]) for q in rows]))]
            if r in (rows[0], rows[-1]):
                continue
            tv = XA[N[lay, r + 1, -1]] - XA[N[lay, r - 1, -1]]
            tz = XA[N[lay + 1, r, -1]] - XA[N[lay - 1, r, -1]]
            n = np.cross(tv, tz)
            n /= np.linalg.norm(n)
            if n[:2] @ (XA[N[lay, r, -1], :2] - XA[N[lay, r, nh], :2]) < 0:
                n = -n  # outward
            x0, dd = XA[N[lay, r, -1], :2], -n[:2] / np.linalg.norm(n[:2])
            Pm = XA[N[lay, mid_rows, nh], :2]
            hit = None
            for q in range(len(Pm) - 1):
                s_, w = np.linalg.solve(np.column_stack([dd, -(Pm[q + 1] - Pm[q])]), Pm[q] - x0)
                if s_ > 0 and -1e-9 <= w <= 1 + 1e-9 and (hit is None or s_ < hit[2]):
                    hit = (q, w, s_)
            q, w, _ = hit
            uf = -u3(N[lay, r, -1], centre, th) @ n
            uc = -((1 - w) * u3(N[lay, mid_rows[q], nh], centre, th) + w * u3(N[lay, mid_rows[q + 1], nh], centre, th)) @ n
            z = float(XA[N[lay, r, -1], 2])
            if name == "pinion":
                xc[z] = XA[N[lay, r, -1]]
            fe.setdefault(name, []).append((z, 1e3 * uf, 1e3 * uc))
    L = LTCA(pair, material=mat, compliance="fe")
    S = L.slices(phi1=np.array([0.0]), mis=mis)
    st = L.structure(S)
    r = L.solve(T, slices=S).results[0]
    k = list(S.pairs).index(0)
    u = np.flatnonzero(np.isfinite(S.z[k, 0]) & S.active[k, 0])
    F = r.load[k, 0, u]
    f = F / st.length[k, 0, u]
    b_l = np.sqrt(4 * f * st.R[k, 0, u] / (math.pi * mat.E_star))
    c = 2 * (1 - mat.nu**2) / (math.pi * mat.E) * f
    zs = S.z[k, 0, u]
    print(f"loaded TCA (FE coefficients): approach {1e3 * r.delta[0] / cb:.3f} um along the line of action "
          f"({1e3 * r.delta[0]:.3f} um along the normal); pair shares " +
          ", ".join(f"{kk}: {float(r.share[i, 0]):.3f}" for i, kk in enumerate(r.pairs)))
    print(f"{'member':<7} {'z mm':>6} {'FE flank':>8} {'FE at C':>8} {'LTCA C':>7} {'C FE/LT':>7} {'FE flank-C':>10} "
          f"{'LTCA local':>10} {'local FE/LT':>11}   [um, along the flank normal]")
    tot = {"C": [0.0, 0.0], "local": [0.0, 0.0]}
    for i, name in enumerate(("pinion", "gear")):
        rad = np.hypot(*getattr(S, f"r{i + 1}")[k, 0, u][:, :2].T)
        bend = 1e3 * (L.influence[i].matrix(rad, zs if i == 0 else S.z2[k, 0, u]) @ F)
        h = (st.h1, st.h2)[i][k, 0, u]
        loc = 1e3 * c * (np.log(2 * h / b_l) - mat.nu / (2 * (1 - mat.nu)))
        for z, uf, uc in fe[name]:
            bc, lc = _interp(z, zs, bend), _interp(z, zs, loc)
            print(f"{name:<7} {z:6.2f} {uf:8.3f} {uc:8.3f} {bc:7.3f} {uc / bc:7.3f} {uf - uc:10.3f} {lc:10.3f} "
                  f"{(uf - uc) / lc:11.3f}")
            if abs(z) < 1e-6:
                tot["C"] = [tot["C"][0] + uc, tot["C"][1] + bc]
                tot["local"] = [tot["local"][0] + uf - uc, tot["local"][1] + lc]
    flanks0 = sum(uf for nm in fe for z, uf, _ in fe[nm] if abs(z) < 1e-6)
    print(f"mid face (z = 0), both members [um, normal]: teeth at C FE {tot['C'][0]:.3f} / LTCA {tot['C'][1]:.3f}, "
          f"local FE {tot['local'][0]:.3f} / LTCA {tot['local'][1]:.3f}, penalty penetration (FE normal approach "
          f"minus the flanks) {app * cb - flanks0:.3f}")
    return 0


def main(argv):
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed: nothing to split")
        return 0
    if "--helical" in argv:
        return helical()
    et = argv[0] if argv else "C3D8"
    n_hertz = float(argv[1]) if len(argv) > 1 else 3.0
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, name="pinion"), Gear(z=40, m_n=3.0, b=20.0, name="gear"))
    mat = Material(E=210000.0, nu=0.3)
    m = GearFEModel(pair, 0.0, FEOptions(torque=T * 1e3, E=mat.E, nu=mat.nu, element_type=et, n_hertz=n_hertz))
    res = m.run()
    U = read_frd_block(res.frd, "DISP")
    P = read_frd_block(res.frd, "CONTACT") or {}
    theta = res.to_dict()["pinion_rotation_rad"]
    XA = np.vstack([m.nodes_pinion, m.nodes_gear])
    n1 = len(m.nodes_pinion)
    print(f"{et}, n_hertz {n_hertz:g}: FE approach |rotation| r_b1 = {abs(theta) * pair.pinion.r_b * 1e3:.3f} um")

    def u_n(i, centre, th, n):
        x, y = XA[i, 0] - centre[0], XA[i, 1] - centre[1]
        u = np.asarray(U[i + 1][:2]) - th * np.array([-y, x])  # the member's rigid rotation removed
        return float(u @ n)

    xc = None
    print(f"{'member':<7} {'flank um':>9} {'C um':>7} {'flank-C':>8} {'|flank C| mm':>12} {'mid row um':>10}")
    for name, mesh, noff, centre, th in (("pinion", m.pinion_mesh, 0, (0.0, 0.0), theta),
                                         ("gear", m.gear_mesh, n1, (0.0, pair.a_w), 0.0)):
        t = [t for t in mesh.teeth if t["k"] == 0][0]
        N = t["nodes"] + noff
        lay = int(np.argmin(np.abs(XA[N[:, 0, -1], 2])))
        r0, r1 = t["section"].segments["flank"]
        nh = t["section"].n_half
        rows = list(range(r0, r1 + 1))
        if xc is None:  # pinion: the flank node of the largest contact pressure
            r = rows[int(np.argmax([P.get(int(N[lay, q, -1]) + 1, [0, 0, 0, 0])[3] for q in rows]))]
            xc = XA[N[lay, r, -1], :2]
        else:  # gear: the flank node at the pinion's
            r = rows[int(np.argmin([np.linalg.norm(XA[N[lay, q, -1], :2] - xc) for q in rows]))]
        tv = XA[N[lay, r + 1, -1], :2] - XA[N[lay, r - 1, -1], :2]
        n = np.array([tv[1], -tv[0]]) / np.linalg.norm(tv)
        if n @ (XA[N[lay, r, -1], :2] - XA[N[lay, r, nh], :2]) < 0:
            n = -n  # outward
        x0 = XA[N[lay, r, -1], :2]
        mids = N[lay, : t["section"].segments["fillet"][1] + 1, nh]
        Pm = XA[mids, :2]
        hit = None
        for q in range(len(Pm) - 1):
            s_, w = np.linalg.solve(np.column_stack([-n, -(Pm[q + 1] - Pm[q])]), Pm[q] - x0)
            if s_ > 0 and 0 <= w <= 1:
                hit = (q, w, s_)
        q, w, s_ = hit
        uf = u_n(N[lay, r, -1], centre, th, n)
        uc = (1 - w) * u_n(mids[q], centre, th, n) + w * u_n(mids[q + 1], centre, th, n)
        um = u_n(N[lay, r, nh], centre, th, n)
        print(f"{name:<7} {-1e3 * uf:9.3f} {-1e3 * uc:7.3f} {1e3 * (uc - uf):8.3f} {s_:12.3f} {-1e3 * um:10.3f}")
    L = LTCA(pair, material=mat, compliance="fe")
    S = L.slices(phi1=np.array([0.0]))
    st = L.structure(S)
    r = L.solve(T, phi1=[0.0]).results[0]
    k = list(S.pairs).index(0)
    u = np.flatnonzero(np.isfinite(S.z[k, 0]))
    j = u[len(u) // 2]
    F = r.load[k, 0, u]
    rad = [np.hypot(*getattr(S, a)[k, 0, u].T) for a in ("r1", "r2")]
    f = r.load[k, 0, j] / st.length[k, 0, j]
    b_l = math.sqrt(4 * f * st.R[k, 0, j] / (math.pi * mat.E_star))
    c = 2 * (1 - mat.nu**2) / (math.pi * mat.E) * f
    print(f"loaded TCA (FE coefficients), mid face: approach {r.delta[0] * 1e3:.3f} um, line load {f:.1f} N/mm")
    for i, (name, h) in enumerate((("pinion", st.h1[k, 0, j]), ("gear", st.h2[k, 0, j]))):
        bend = (L.influence[i].matrix(rad[i], S.z[k, 0, u]) @ F)[len(u) // 2]
        weber = c * (math.log(2 * h / b_l) - mat.nu / (2 * (1 - mat.nu)))
        print(f"{name:<7} tooth at C {1e3 * bend:7.3f} um, Weber-Banaschek to h = {h:.3f} mm: {1e3 * weber:.3f} um")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
