"""Split the CalculiX contact model's loaded approach into each member's parts (docs/ltca.md section 5).

    python benchmarks/split_fe_approach.py              # C3D8, the default contact grading
    python benchmarks/split_fe_approach.py C3D8I 6      # element type, elements per Hertz half-width

The 20/40 spur pair (m 3, b 20) at the pitch point, 200 N m, E 210 GPa, nu 0.3. For each member, in
the middle section, the nodal displacement along the contact normal (rigid rotation removed) at: the
flank node of the contact, the point C where the load line (the flank normal through the contact)
meets the tooth's middle line, and the middle node of the contact row. Printed beside them: the
Weber-Banaschek flattening to the centreline that loaded TCA adds, and loaded TCA's tooth deflection
at C from the FE influence coefficients (``compliance = "fe"``) under its own slice loads.
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


def main(argv):
    if shutil.which("ccx") is None:
        print("ccx (CalculiX) not installed: nothing to split")
        return 0
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
