"""The face coupling of loaded TCA's analytical compliance against CalculiX influence grids
(docs/ltca.md, section 2, "Point contact").

    python benchmarks/ltca_face_coupling.py          # the members of docs/ltca.md section 7 (cached grids)
    python benchmarks/ltca_face_coupling.py --hertz  # crowned pinions' peak pressure (default compliance,
                                                     # 21 and 41 slices) against the Hertz ellipse (~1 min);
                                                     # the spur also with its teeth rigid along the face,
                                                     # with FE coefficients and the recorded FE contact runs
    python benchmarks/ltca_face_coupling.py --rim    # + the 20/40 pinion with a rim 0.3, 1.5 and 4.375 m_n
                                                     # deep (n_face 10, n_rim 8; about 10 min of ccx each
                                                     # on 2 shared cores, then cached)
    python benchmarks/ltca_face_coupling.py --body   # the same grids (cached by --rim): the 20/40 pinion's
                                                     # compliance under a line load uniform over the face, per
                                                     # flank row, against the analytical tooth and body terms

For each member's influence grid (gearopt.fea.influence, its tooth's normal compliance between the
points of a rows x face-layers grid of the flank), the coupling length ``lam`` of the Pasternak
Green's function (``w - lam^2 w'' = c f``, free face ends; ``gearopt.ltca.compliance.coupling`` on a
fine grid) that fits the grid's face-direction matrix of each row best (least squares, the amplitude
free), and the fit's relative error. With ``--rim``: the same for the 20/40 pinion held 0.3, 1.5 and
4.375 m_n below its root circle (4.375 m_n: r_f / 2, loaded TCA's default bore), and the body's part,
the deep grid minus the 1.5 m_n one: its response to a force at mid face over the response there, at
2 mm steps to the face end, against the Pasternak kernel of length r_f - r_int (13.1 mm). With
``--body``: per grid row, the compliance per unit face width under a line load uniform over the face
(the grid row's face matrix times the tributary widths, at mid face) of the three rims, against the
analytical model's tooth (bending, shear, compression: a cantilever clamped at the root circle) and
body terms (Sainsot et al. 2004 with the bore at r_f / 2 = the 4.375 m_n rim's bottom).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from gearopt.fea import MeshOptions
from gearopt.fea.influence import influence_grid
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.compliance import coupling
from gearopt.meshing.tca import TCA

E, NU = 210000.0, 0.3
ROOT = Path(__file__).resolve().parents[1]


def green(zg, b, lam, n=801):
    """Pasternak Green's function [1/mm] between the points ``zg`` of a face ``b`` wide (free ends)."""
    zf = np.linspace(-b / 2, b / 2, n)
    w = np.full(n, zf[1] - zf[0])
    w[[0, -1]] /= 2
    idx = [int(round((z + b / 2) / (zf[1] - zf[0]))) for z in zg]
    return coupling(zf, w, lam)[np.ix_(idx, idx)]


def fit(M, z):
    """(lam [mm], relative squared error) of the Pasternak kernel fitted to the face matrix ``M``."""
    b = z[-1] - z[0]

    def err(lam):
        P = green(z, b, lam)
        c = (M * P).sum() / (P * P).sum()
        return np.sum((M - c * P) ** 2) / np.sum(M**2)

    r = minimize_scalar(err, bounds=(0.3, 60.0), method="bounded")
    return float(r.x), float(r.fun)


def pairs():
    b15, b18 = math.radians(15), math.radians(18)
    return {
        "spur 20/40": GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0)),
        "helical 21/45": GearPair(Gear(z=21, m_n=2.5, b=24, beta=b15), Gear(z=45, m_n=2.5, b=24, beta=b15, hand="left")),
        "helical 21/53": GearPair(Gear(z=21, m_n=2.5, b=30, beta=b18), Gear(z=53, m_n=2.5, b=30, beta=b18, hand="left")),
    }


def hertz_table() -> int:
    """The crowned pinions of tests/test_ltca_point_contact.py at phi1 = 0: loaded TCA's peak pressure
    (default analytical compliance) against the Hertz ellipse of the whole normal load (the unloaded
    TCA's curvatures, gearopt.fea.references.hertz_point), and its log-slope over the torques."""
    from gearopt.fea import FEOptions, GearFEModel
    from gearopt.ltca import LTCA, Material

    mat = Material(E=E, nu=NU)
    b15 = math.radians(15)
    crown = dict(a_pl=2e-3, rack=BasicRack.iso53("A", a_c=2e-3))
    cases = {"spur 20/40": (GearPair(Gear(z=20, m_n=3, b=20, **crown), Gear(z=40, m_n=3, b=20)), [25, 50, 100, 200, 400]),
             "helical 21/45": (GearPair(Gear(z=21, m_n=2.5, b=24, beta=b15, **crown),
                                        Gear(z=45, m_n=2.5, b=24, beta=b15, hand="left")), [25, 50, 100])}
    for name, (pair, T) in cases.items():
        hz = []
        for t in T:
            (h,) = GearFEModel(pair, 0.0, FEOptions(torque=t * 1e3, E=E, nu=NU)).hertz.values()
            hz.append(h)
        for n in (21, 41):
            sw = LTCA(pair, material=mat, n_slices=n).solve([float(t) for t in T], phi1=np.array([0.0]))
            p = np.array([r.p_max for r in sw.results])
            slope = np.polyfit(np.log(T), np.log(p), 1)[0]
            print(f"{name}, crowned, {n} slices: log-slope {slope:.3f}")
            for t, h, r, pp in zip(T, hz, sw.results, p):
                print(f"  {t:5.0f} N m  Hertz {h.p0:7.1f} MPa (a {h.a:.2f} mm)  loaded TCA {pp:7.1f} MPa "
                      f"({100 * (pp / h.p0 - 1):+.1f} %)  pair share {float(np.max(r.share)):.4f}")
        if name != "spur 20/40":
            continue
        # why the spur falls behind Hertz as the ellipse grows: the same drive with every part of the
        # compliance uniform along the face (the teeth and bodies rigid sections: Weber's term per slice
        # alone), with the tooth's bending along the face only (the bodies uniform), with the FE influence
        # coefficients (the FE's own face coupling; cached grids or CalculiX), and the contact model
        variants = {"rigid along the face (coupling 200, body_coupling 2000 mm)": dict(coupling=200.0, body_coupling=2000.0),
                    "bodies uniform along the face (body_coupling 2000 mm)": dict(body_coupling=2000.0),
                    "FE influence coefficients": dict(compliance="fe")}
        for label, kw in variants.items():
            try:
                sw = LTCA(pair, material=mat, **kw).solve([float(t) for t in T], phi1=np.array([0.0]))
            except Exception as e:  # FE coefficients without CalculiX and without cached grids
                print(f"{name}, {label}: not available ({type(e).__name__}: {e})")
                continue
            p = np.array([r.p_max for r in sw.results])
            print(f"{name}, {label}: log-slope {np.polyfit(np.log(T), np.log(p), 1)[0]:.3f}; against Hertz "
                  + " / ".join(f"{100 * (pp / h.p0 - 1):+.1f}" for pp, h in zip(p, hz)) + " %")
        record = ROOT / "benchmarks" / "data" / "fe_point_contact.json"
        if record.exists():
            for level, runs in json.loads(record.read_text()).items():
                for t, r in sorted(runs.items(), key=lambda kv: float(kv[0])):
                    print(f"{name}, CalculiX contact model ({level} level, benchmarks/fe_point_contact.py) at {t} N m: "
                          f"{r['p_max_mid']:.1f} MPa ({100 * (r['ratio'] - 1):+.1f} %), without the penalty layer "
                          f"{r['p_penalty_free']:.1f} MPa ({100 * (r['ratio_penalty_free'] - 1):+.1f} %), nodal / force "
                          f"{r['nodal_over_force']:.3f}")
    return 0


def rim_grids(pair, tca):
    """The 20/40 pinion's influence grids with its rim 0.3, 1.5 and 4.375 m_n deep (cached)."""
    grids = {}
    for depth in (0.3, 1.5, 4.375):
        mesh = MeshOptions(n_face=10, n_half=6, n_flank=8, n_fillet=5, n_rim=8, rim_depth=depth)
        grids[depth] = influence_grid(tca.pinion.unmodified, E, NU, mesh=mesh, r_form=tca.form_radius(1), local=False)
    return grids


def body_table() -> int:
    """Per flank row of the 20/40 pinion: FE compliance under a uniform line load (rims 0.3 / 1.5 / 4.375
    m_n) against the analytical tooth and Sainsot's body term at the same bore (r_f / 2)."""
    from gearopt.ltca import Material
    from gearopt.ltca.compliance import ToothCompliance

    pair = GearPair(Gear(z=20, m_n=3, b=20, a_pl=2e-3, rack=BasicRack.iso53("A", a_c=2e-3)), Gear(z=40, m_n=3, b=20))
    tca = TCA(pair)
    grids = rim_grids(pair, tca)
    tooth = ToothCompliance(tca.pinion.unmodified, Material(E=E, nu=NU), 0.5 * pair.pinion.r_f, member="pinion")
    pr = tca.pinion.unmodified.transverse_profile(z=0.0, n=400)["right_flank"]
    rr = np.hypot(pr[:, 0], pr[:, 1])
    o = np.argsort(rr)
    pr, rr = pr[o], rr[o]
    tg = np.gradient(pr, axis=0)
    nrm = np.stack([tg[:, 1], -tg[:, 0]], 1)
    nrm *= np.sign(nrm[:, :1] * pr[:, :1])  # outward: away from the tooth's centreline
    z = grids[1.5].z
    w = np.full(z.size, z[1] - z[0])
    w[[0, -1]] /= 2
    mid = z.size // 2
    rows = []
    print("20/40 pinion (a_pl 2e-3), compliance per unit face width under a uniform line load [um mm/N]:")
    print(f"{'r [mm]':>7} {'FE rim 0.3':>10} {'FE rim 1.5':>10} {'FE rim 4.375':>12} {'an. tooth':>9} "
          f"{'FE 0.3 / an. tooth':>18} {'FE body: 4.375 - 0.3':>20} {'Sainsot, r_f/2':>14} {'FE body / Sainsot':>17}")
    for i, r in enumerate(grids[1.5].radius):
        j = int(np.argmin(np.abs(rr - r)))
        c = tooth.per_width(pr[j:j + 1], nrm[j:j + 1])
        u = {d: 1e3 * float((g.G[i, :, i, :] @ w)[mid]) for d, g in grids.items()}
        t, sb = 1e3 * float(c.total[0] - c.foundation[0]), 1e3 * float(c.foundation[0])
        print(f"{r:7.2f} {u[0.3]:10.4f} {u[1.5]:10.4f} {u[4.375]:12.4f} {t:9.4f} {u[0.3] / t:18.3f} "
              f"{u[4.375] - u[0.3]:20.4f} {sb:14.4f} {(u[4.375] - u[0.3]) / sb:17.3f}")
        rows.append({"radius_mm": float(r), "xy_mm": pr[j].tolist(), "normal": (nrm[j] / np.linalg.norm(nrm[j])).tolist(),
                     **{f"fe_rim_{d:g}_mm2_per_N": 1e-3 * u[d] for d in u}})
    # the FE rows, recorded for tests/test_ltca_point_contact.py (the grids need CalculiX or the cache)
    out = ROOT / "benchmarks" / "data" / "fe_rim_rows.json"
    out.write_text(json.dumps({"drive": "20/40 m 3 pinion, a_pl 2e-3, a_c 2e-3 (right flank, mid face)", "E": E, "nu": NU,
                               "mesh": "n_face 10, n_half 6, n_flank 8, n_fillet 5, n_rim 8",
                               "date": time.strftime("%Y-%m-%d"), "rows": rows}, indent=1) + "\n")
    print(f"recorded in {out.relative_to(ROOT)}")
    return 0


def main(argv):
    if "-h" in argv or "--help" in argv:
        print(__doc__)
        return 0
    bad = [a for a in argv if a not in ("--rim", "--hertz", "--body")]
    if bad:
        print(f"ltca_face_coupling.py: unknown argument {bad[0]!r}: expected --rim, --hertz or --body (see --help)",
              file=sys.stderr)
        return 2
    if "--hertz" in argv:
        return hertz_table()
    if "--body" in argv:
        return body_table()
    print("member            half tooth height [mm]   fitted lam [mm] per grid row (relative error)")
    for name, pair in pairs().items():
        tca = TCA(pair)
        for m, (g, t) in enumerate(((pair.pinion, tca.pinion), (pair.gear, tca.gear)), start=1):
            G = influence_grid(t.unmodified, E, NU, r_form=tca.form_radius(m), local=False)
            fits = [fit(G.G[i, :, i, :], G.z) for i in range(1, G.radius.size - 1)]
            print(f"{name} {'pinion' if m == 1 else 'gear':<7} {0.5 * (g.r_a - g.r_f):10.3f}   "
                  + " ".join(f"{lam:.2f} ({e:.3f})" for lam, e in fits))
    if "--rim" in argv:
        pair = GearPair(Gear(z=20, m_n=3, b=20, a_pl=2e-3, rack=BasicRack.iso53("A", a_c=2e-3)), Gear(z=40, m_n=3, b=20))
        tca = TCA(pair)
        grids = rim_grids(pair, tca)
        z = grids[1.5].z
        w = np.full(z.size, z[1] - z[0])
        w[[0, -1]] /= 2
        mid = z.size // 2
        lam_b = pair.pinion.r_f / 2
        P = green(z, z[-1] - z[0], lam_b)[:, mid]
        print(f"\n20/40 pinion (a_pl 2e-3), rim depth [m_n]: fitted lam [mm] per row; body part = 4.375 - 1.5 m_n grid;"
              f" Pasternak kernel of lam = r_f / 2 = {lam_b:.3f} mm at 0, 2, ... 10 mm: {np.round(P[mid:] / P[mid], 3)}")
        for i in range(1, grids[1.5].radius.size - 1, 2):
            row = [f"r {grids[1.5].radius[i]:.2f}"]
            for depth, G in grids.items():
                lam, e = fit(G.G[i, :, i, :], z)
                row.append(f"rim {depth}: {lam:.2f} ({e:.3f})")
            Mb = grids[4.375].G[i, :, i, :] - grids[1.5].G[i, :, i, :]
            row.append(f"body kernel {np.round(Mb[mid:, mid] / Mb[mid, mid], 3)}, its uniform-load compliance "
                       f"{(Mb @ w)[mid]:.3e} mm^2/N")
            print("  ".join(row))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
