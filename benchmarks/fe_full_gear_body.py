"""The gear body of loaded TCA's default (analytical) compliance against a full gear in CalculiX, and the
validation of the default compliance's approach against an FE reference with full-gear bodies
(docs/ltca.md section 7, "The same validation with the default (analytical) compliance").

    python benchmarks/fe_full_gear_body.py            # (b) the 20/40 pinion's body per flank row: 3- to
                                                      # 19-tooth sectors held at the bore and both sides /
                                                      # at the bore only, and the full gear (20 teeth, the
                                                      # seam merged) held at its bore r_f / 2, against
                                                      # Sainsot's term (about 5 min of ccx, then cached)
    python benchmarks/fe_full_gear_body.py --mesh     # + the full gear's body at the pitch row on finer meshes
    python benchmarks/fe_full_gear_body.py --validate # (c) the validation positions of docs/ltca.md section 7
                                                      # (very fine FE level, recorded) with the FE reference's
                                                      # members' bodies replaced by full gears held at r_f / 2
                                                      # (about 15 min of ccx for the eight members, then cached):
                                                      # the default compliance (the refitted body, helical normal
                                                      # compliance) and the model before (Sainsot 2004, cos^2)
    python benchmarks/fe_full_gear_body.py --validate --recorded  # the same table from the references recorded
                                                      # by --neighbours (no CalculiX, a minute)
    python benchmarks/fe_full_gear_body.py --validate --lam-factor 0.5  # the body difference spread along the
                                                      # face over half (or X times) the body's depth (not recorded)
    python benchmarks/fe_full_gear_body.py --sainsot  # Sainsot's term on the 20/40 pinion's rows as implemented
                                                      # and with the readings of its inputs found elsewhere, against
                                                      # the full gear's FE body (cached line loads)
    python benchmarks/fe_full_gear_body.py --helical  # the helical deficit part by part (cached grids, ~1 min):
                                                      # per row the FE tooth against the analytical tooth, per pair
                                                      # the approach's share under one load distribution, and a
                                                      # point load at mid face and at the face end
    python benchmarks/fe_full_gear_body.py --neighbours  # the neighbouring teeth's coupling through the body (about
                                                      # 25 min of ccx for the eight members, then cached): a tooth's
                                                      # displacement under a line load on the tooth 1 and 2 pitches
                                                      # away, sectors and full gears; the validation's approach with it
                                                      # in the FE-coefficient model, the reference and the default model

Everything is per unit face width under a normal line load uniform over the face, at the response point of
the flank row on the tooth's middle line in the middle face layer
(:func:`gearopt.fea.influence.line_load_compliance`), in um mm/N, E 210 GPa, nu 0.3. The tooth: the member
held 0.3 m_n below its root circle (3 teeth, bottom and sides held); a body: a deep member minus that tooth.

(c), stated as what it is: the FE contact model's members (3-tooth sectors on a 1.5 m_n rim, held at the
rim's bottom and sides) are not re-run as full gears. Instead each member's body difference ``dC(r_i, r_j) =
C_full(r_i, r_j) - C_sector(r_i, r_j)`` (line loads on the flank rows, the full gear held at its bore r_f / 2,
the sector as the contact model's member, the same mesh) is added to its FE influence grid, spread along the
face by the Pasternak kernel of the body's depth r_f / 2 (``gearopt.ltca.compliance.coupling``; a uniform
line load gets exactly dC), and loaded TCA with FE coefficients is solved with the sector grids and with the
full-gear grids. The reference is the recorded FE contact model's result corrected by the difference:
approach_ref = approach_FE + (approach_full - approach_sector), likewise the section pressure and the share.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from gearopt.fea import MeshOptions
from gearopt.fea.influence import line_load_compliance
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca import Material
from gearopt.ltca.compliance import ToothCompliance, coupling
from gearopt.meshing.tca import TCA

E, NU = 210000.0, 0.3
ROOT = Path(__file__).resolve().parents[1]
#: the line-load mesh: the influence grids' rows (n_flank 8, n_fillet 5), 4 face layers (a uniform line load;
#: 4 and 10 layers agree within 0.3 % on the 3-tooth sector), 8 elements through the rim
MESH = MeshOptions(n_face=4, n_half=6, n_flank=8, n_fillet=5, n_rim=8)
SECTORS = (3, 5, 7, 9, 13, 19)
#: the analytical model before 2026-11-29 (Sainsot's 2004 body; a helical slice projected with cos^2(beta_b)), the
#: model the diagnostics below scale
OLD = dict(body="sainsot2004", helical="transverse")


def pinion_pair() -> GearPair:
    """The 20/40 drive of docs/ltca.md section 7's part-by-part table (pinion a_pl 2e-3, a_c 2e-3)."""
    return GearPair(Gear(z=20, m_n=3, b=20, a_pl=2e-3, rack=BasicRack.iso53("A", a_c=2e-3)), Gear(z=40, m_n=3, b=20))


def flank_points(tooth, radius):
    """(xy, outward normals) of the right flank at mid face at ``radius`` [mm] (transverse frame)."""
    pr = tooth.transverse_profile(z=0.0, n=400)["right_flank"]
    rr = np.hypot(pr[:, 0], pr[:, 1])
    o = np.argsort(rr)
    pr, rr = pr[o], rr[o]
    tg = np.gradient(pr, axis=0)
    nrm = np.stack([tg[:, 1], -tg[:, 0]], 1)
    nrm *= np.sign(nrm[:, :1] * pr[:, :1])
    j = np.array([int(np.argmin(np.abs(rr - r))) for r in np.atleast_1d(radius)])
    return pr[j], nrm[j]


def member_bodies(tooth, r_form, r_bore, mesh=MESH):
    """Body differences (rows, rows) [mm^2/N] of one member and its row radii [mm]: ``{"full - sector": the full
    gear held at r_bore minus the contact model's member (3 teeth, rim 1.5 m_n, bottom and sides held), "full -
    tooth": the full gear minus the tooth (rim 0.3 m_n)}``. The full gear is loaded at its lowest, middle and
    highest row, the members at every row; each difference (the teeth cancel: the same mesh) is quadratic in
    the loaded row's radius between the three (0.5 % of the largest entry on the 20/40 pinion against all nine
    rows loaded), then symmetrised."""
    kw = dict(E=E, nu=NU, r_form=r_form)
    t03 = line_load_compliance(tooth, mesh=replace(mesh, rim_depth=0.3), teeth=3, support="sector", **kw)
    sec = line_load_compliance(tooth, mesh=replace(mesh, rim_depth=1.5), teeth=3, support="sector", **kw)
    r = sec.radius
    cols = [0, r.size // 2, r.size - 1]
    full = line_load_compliance(tooth, mesh=mesh, teeth=tooth.gear.z, support="bore", r_bore=r_bore, rows=cols, **kw)
    out = {}
    for label, other in (("full - sector", sec), ("full - tooth", t03)):
        D = full.C[:, cols] - other.C[:, cols]
        D = np.array([[np.polyval(np.polyfit(r[cols], D[i], 2), rj) for rj in r] for i in range(r.size)])
        out[label] = 0.5 * (D + D.T)
    return out, r


class FEBody:
    """A :class:`~gearopt.ltca.compliance.ToothCompliance` whose body term (Sainsot's) is scaled at each flank
    radius by ``ratio``, the full gear's FE body over it, and whose teeth (bending, shear, compression) by
    ``teeth`` (a diagnostic of the validation, not a model: docs/ltca.md section 7)."""

    def __init__(self, tc, radius, ratio, teeth=1.0):
        self.tc, self.radius, self.ratio, self.teeth = tc, np.asarray(radius), np.asarray(ratio), float(teeth)

    def __getattr__(self, name):
        return getattr(self.tc, name)

    def per_width(self, xy, n_xy):
        c = self.tc.per_width(xy, n_xy)
        k = np.interp(np.hypot(*np.atleast_2d(xy).T), self.radius, self.ratio)
        kt = self.teeth
        return replace(c, bending=kt * c.bending, shear=kt * c.shear, compression=kt * c.compression,
                       foundation=k * c.foundation, total=kt * (c.total - c.foundation) + k * c.foundation)


def body_study(fine_mesh: bool) -> int:
    """(b): the 20/40 pinion's body per row, sectors held / free against the full gear and Sainsot."""
    pair = pinion_pair()
    tca = TCA(pair)
    tooth = tca.pinion.unmodified
    r_f = tooth.r_root
    r_bore = 0.5 * r_f
    depth = (r_f - r_bore) / pair.pinion.m_n
    r_form = tca.form_radius(1)
    mesh = replace(MESH, rim_depth=depth)
    t0 = time.perf_counter()
    base = line_load_compliance(tooth, E, NU, mesh=replace(MESH, rim_depth=0.3), teeth=3, r_form=r_form)
    full = line_load_compliance(tooth, E, NU, mesh=mesh, teeth=pair.pinion.z, support="bore", r_form=r_form)
    sec = {(n, s): line_load_compliance(tooth, E, NU, mesh=mesh, teeth=n, support=s, r_form=r_form)
           for n in SECTORS for s in ("sector", "bore")}
    r = base.radius
    an = ToothCompliance(tooth, Material(E=E, nu=NU), r_bore, member="pinion", **OLD)
    c = an.per_width(*flank_points(tooth, r))
    sainsot = 1e3 * c.foundation
    t_an = 1e3 * (c.total - c.foundation)
    b0 = 1e3 * np.diag(base.C)
    body = {k: 1e3 * np.diag(v.C) - b0 for k, v in sec.items()}
    b_full = 1e3 * np.diag(full.C) - b0
    print(f"20/40 pinion (a_pl 2e-3), bore r_f / 2 = {r_bore:.3f} mm (rim {depth:.4g} m_n), mesh {MESH!r}; "
          f"ccx / cache {time.perf_counter() - t0:.0f} s")
    print("body per unit face width [um mm/N] = member - tooth (rim 0.3 m_n); 'held': bore and both sides, "
          "'free': the bore only")
    print(f"{'r [mm]':>7} {'tooth':>7} {'an.tooth':>8} " + " ".join(f"{f'{n} held':>8} {f'{n} free':>8}" for n in SECTORS)
          + f" {'full gear':>9} {'Sainsot':>8} {'full/Sainsot':>12} {'full/an.':>8}")
    for i in range(r.size):
        print(f"{r[i]:7.2f} {b0[i]:7.4f} {t_an[i]:8.4f} "
              + " ".join(f"{body[(n, 'sector')][i]:8.4f} {body[(n, 'bore')][i]:8.4f}" for n in SECTORS)
              + f" {b_full[i]:9.4f} {sainsot[i]:8.4f} {b_full[i] / sainsot[i]:12.3f}"
              f" {(b_full[i] + b0[i] - t_an[i]) / sainsot[i]:8.3f}")
    print("('full/an.': the full gear minus the analytical tooth, over Sainsot: the body as Sainsot et al. define it)")
    if fine_mesh:
        i = int(np.argmin(np.abs(r - pair.pinion.r_p)))
        print(f"\nthe full gear's body at the pitch row (r {r[i]:.2f} mm) on finer meshes [um mm/N]:")
        for m, el in ((MESH, "C3D8"), (MESH, "C3D8I"), (replace(MESH, n_half=8, n_rim=16), "C3D8"),
                      (replace(MESH, n_half=8, n_rim=16), "C3D8I")):
            rows_m = [3]  # the pitch row with n_flank 8 (checked below)
            t = line_load_compliance(tooth, E, NU, mesh=replace(m, rim_depth=0.3), teeth=3, r_form=r_form, rows=rows_m,
                                     element=el)
            f = line_load_compliance(tooth, E, NU, mesh=replace(m, rim_depth=depth), teeth=pair.pinion.z, support="bore",
                                     r_form=r_form, rows=rows_m, element=el)
            k = rows_m[0]
            assert abs(t.radius[k] - r[i]) < 1e-6
            print(f"  {el} n_half {m.n_half} n_rim {m.n_rim}: tooth {1e3 * t.C[k, k]:.4f}, full gear "
                  f"{1e3 * f.C[k, k]:.4f}, body {1e3 * (f.C[k, k] - t.C[k, k]):.4f} (Sainsot {sainsot[i]:.4f}) "
                  f"ccx {f.ccx_s:.0f} s{' (cached)' if f.cached else ''}")
        # the third dimension: the same gear 2 mm wide (towards plane stress) and 80 mm wide (plane strain)
        for b, nf in ((2.0, 2), (80.0, 8)):
            pb = GearPair(Gear(z=20, m_n=3, b=b, a_pl=2e-3 * 20 / b, rack=BasicRack.iso53("A", a_c=2e-3)),
                          Gear(z=40, m_n=3, b=b))
            tb = TCA(pb)
            kw = dict(E=E, nu=NU, r_form=tb.form_radius(1), rows=[3])
            m = replace(MESH, n_face=nf)
            t = line_load_compliance(tb.pinion.unmodified, mesh=replace(m, rim_depth=0.3), teeth=3, **kw)
            f = line_load_compliance(tb.pinion.unmodified, mesh=m, teeth=20, support="bore",
                                     r_bore=0.5 * tb.pinion.unmodified.r_root, **kw)
            print(f"  face width {b:g} mm (n_face {nf}): body {1e3 * (f.C[3, 3] - t.C[3, 3]):.4f} at r {t.radius[3]:.2f} mm")
    return 0


def full_gear_grid(grid, tooth, gear, r_form, lam_factor=1.0):
    """``grid`` (a member's FE influence grid, the contact model's sector) with its body replaced by the full
    gear's held at ``r_int = r_f / 2``: ``G + dC(r_i, r_j) A^-1(z_a, z_b)`` (see the module docstring).
    Returns (new grid, dC at the grid rows [mm^2/N], the coupling length [mm])."""
    r_bore = 0.5 * gear.r_f
    cs, rl = member_bodies(tooth, r_form, r_bore)
    D = cs["full - sector"]  # (rows, rows) [mm^2/N], the same mesh
    sainsot = ToothCompliance(tooth, Material(E=E, nu=NU), r_bore, member=gear.name or "member", **OLD).per_width(
        *flank_points(tooth, rl)).foundation
    ratio = np.diag(cs["full - tooth"]) / sainsot  # the full gear's body over Sainsot's, per row
    Dg = np.array([[np.interp(ri, rl, [np.interp(rj, rl, D[k]) for k in range(rl.size)]) for rj in grid.radius]
                   for ri in grid.radius])
    z = grid.z
    w = np.zeros(z.size)
    w[:-1] += 0.5 * np.diff(z)
    w[1:] += 0.5 * np.diff(z)
    lam = lam_factor * (tooth.r_root - r_bore)  # the body's depth: loaded TCA's body coupling length (section 2)
    K = coupling(z, w, lam)
    G = grid.G + Dg[:, None, :, None] * K[None, :, None, :]
    return replace(grid, G=G), Dg, lam, (rl, ratio)


def validate(lam_factor: float = 1.0) -> int:
    """(c): the default compliance's approach, pressure and share against the FE reference corrected to
    full-gear bodies and their neighbouring teeth (the very fine level's recorded FE results):
    ``reference = FE + (FE coefficients, full gears + their neighbours) - (FE coefficients, sectors + their
    neighbours)`` (:class:`NeighbourLTCA`, :func:`neighbour_grids`); the reference without the neighbours (the
    table before 2026-11-29 evening) and the default model without them (``neighbours = "none"``) beside it."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from validate_ltca_fe import RECORD, T, drives

    from gearopt.fea import FEOptions, GearFEModel
    from gearopt.ltca.engine import LTCA

    record = json.loads(RECORD.read_text())["very fine"]
    mat = Material(E=E, nu=NU)
    names = [n for n in drives() if "tip relief" not in n]
    print(f"{T:g} N m; FE: the recorded contact model at the very fine level ({RECORD.relative_to(ROOT)}); "
          "'ref': corrected to full-gear bodies held at r_f / 2 and their neighbouring teeth; 'default': the analytical "
          "compliance with the neighbours' term (neighbours = 'full_gear'); 'ref0': the reference without the "
          "neighbours, 'none': the analytical compliance without them (neighbours = 'none', gearopt's default)")
    print(f"{'drive':<34} {'phi1':>6} {'FE app':>7} {'ref app':>7} {'default':>7} {'err %':>6} "
          f"{'FE p':>7} {'ref p':>7} {'default p':>9} {'err %':>6} {'FE sh':>6} {'ref sh':>6} {'def sh':>6} {'d sh':>6} | "
          "ref0 app, none app, err %, ref0 p, none p, err %, ref0 sh, none sh | diagnostics without the neighbours "
          "(against ref0): Sainsot's term x the full gear's FE body over it: approach, err %, p, err %, share | the same "
          "with the teeth / cos(beta_b) | Sainsot 2004 and cos^2(beta_b) (before 2026-11-29): approach, err %, p, err %, "
          "share")
    out = {}
    miss, miss_none, miss_old, n_pos = [0, 0, 0], [0, 0, 0], [0, 0, 0], 0
    for name in names:
        pair, mis = drives()[name]
        step = 2 * math.pi / pair.pinion.z
        fracs = ("0", "-0.3", "+0.3")
        phis = [float(f) * step for f in fracs]
        cb = math.cos(pair.pinion.beta_b)
        gears = (pair.pinion, pair.gear)
        res, Ss = {}, {}
        for label in ("full", "analytical", "none", "sainsot2004", "fe", "an, FE body", "an, FE body, teeth / cos beta_b"):
            # "analytical": the analytical compliance with the neighbours' term (neighbours = "full_gear"); "none":
            # without it (the default); "sainsot2004" and the
            # diagnostics: the model before 2026-11-29 (Sainsot's 2004 body, a helical slice's compliance projected
            # with cos^2(beta_b), no neighbours)
            old = dict(body="sainsot2004", helical="transverse", neighbours="none") if label not in (
                "full", "analytical", "none", "fe") else {}
            if label in ("none", "analytical"):
                old = dict(neighbours="none" if label == "none" else "full_gear")
            L = LTCA(pair, material=mat, compliance="fe" if label in ("fe", "full") else "analytical", **old)
            S = L.slices(phi1=np.array(phis), mis=mis)
            if label in ("fe", "full"):
                g = L.influence
                tt = (L.tca.pinion.unmodified, L.tca.gear.unmodified)
                rf = (L.tca.form_radius(1), L.tca.form_radius(2))
                what = "sector" if label == "fe" else "full - sector"
                nb = [neighbour_grids(tt[m], gears[m], rf[m], g[m], what) for m in (0, 1)]
            if label == "full":
                g1, g2 = L.influence
                t1, t2 = L.tca.pinion.unmodified, L.tca.gear.unmodified
                n1, d1, lam1, rat1 = full_gear_grid(g1, t1, pair.pinion, L.tca.form_radius(1), lam_factor)
                n2, d2, lam2, rat2 = full_gear_grid(g2, t2, pair.gear, L.tca.form_radius(2), lam_factor)
                L.influence = (n1, n2)
                ip = int(np.argmin(np.abs(g1.radius - pair.pinion.r_p)))
                print(f"{name}: body difference full - sector at the pinion's pitch row {1e3 * d1[ip, ip]:.4f} um mm/N "
                      f"(lam {lam1:.1f} mm), at the gear's rows {np.round(1e3 * np.diag(d2), 4).tolist()}; the full "
                      f"gear's body over Sainsot's, pinion rows {np.round(rat1[1], 3).tolist()}, gear rows "
                      f"{np.round(rat2[1], 3).tolist()}", flush=True)
            if label.startswith("an, FE body"):
                # the FE body is a normal compliance per unit face width; loaded TCA's slice terms are transverse
                # and enter the normal compliance times cos^2(beta_b) (LTCA.structure): the ratio over that
                kt = 1.0 / cb if label.endswith("cos beta_b") else 1.0
                L.teeth = tuple(FEBody(t, rl, rat / cb**2, kt) for t, (rl, rat) in zip(L.teeth, (rat1, rat2)))
            res[label], Ss[label] = L.solve(T, slices=S).results[0], S
            if label in ("fe", "full"):
                res[label + "+n"], Ss[label + "+n"] = NeighbourLTCA(L, nb).solve(T, S).results[0], S
        for j, ph in enumerate(phis):
            rec = record.get(name, {}).get(fracs[j])
            if rec is None:
                print(f"{name:<34} {math.degrees(ph):6.2f}: no FE result recorded at the very fine level")
                continue
            m = GearFEModel(pair, ph, FEOptions(torque=T * 1e3, E=E, nu=NU), mis=mis)
            k0 = min(m.hertz, key=lambda k: abs(m.contact[k]["radius1"] - pair.pinion.r_p))
            z_sec = m.contact[k0]["z1"]
            q = {}
            for label, r in res.items():
                S = Ss[label]
                kk = r.pairs.index(k0)
                ok = np.isfinite(S.z[kk, j]) & S.active[kk, j] & (S.edge[kk, j] == 0)
                o = np.argsort(S.z[kk, j][ok])
                q[label] = (1e3 * r.delta[j] / cb, float(np.interp(z_sec, S.z[kk, j][ok][o], r.p0[kk, j][ok][o])),
                            float(r.share[kk, j]))
            fe = (rec["approach_um"], rec["p_max_mid_MPa"], rec["share"])
            ref = tuple(f + (a - b) for f, a, b in zip(fe, q["full+n"], q["fe+n"]))
            ref0 = tuple(f + (a - b) for f, a, b in zip(fe, q["full"], q["fe"]))
            an, none, anb, ant = q["analytical"], q["none"], q["an, FE body"], q["an, FE body, teeth / cos beta_b"]
            old = q["sainsot2004"]
            for k in range(3):
                def off(a, b):
                    return (abs(a / b - 1) > 0.05) if k < 2 else (abs(a - b) > 0.05)
                miss[k] += off(an[k], ref[k])
                miss_none[k] += off(none[k], ref0[k])
                miss_old[k] += off(old[k], ref0[k])
            n_pos += 1
            print(f"{name:<34} {math.degrees(ph):6.2f} {fe[0]:7.3f} {ref[0]:7.3f} {an[0]:7.3f} "
                  f"{100 * (an[0] / ref[0] - 1):+6.1f} {fe[1]:7.1f} {ref[1]:7.1f} {an[1]:9.1f} {100 * (an[1] / ref[1] - 1):+6.1f} "
                  f"{fe[2]:6.3f} {ref[2]:6.3f} {an[2]:6.3f} {an[2] - ref[2]:+6.3f} | {ref0[0]:7.3f} {none[0]:7.3f} "
                  f"{100 * (none[0] / ref0[0] - 1):+6.1f} {ref0[1]:7.1f} {none[1]:7.1f} {100 * (none[1] / ref0[1] - 1):+6.1f} "
                  f"{ref0[2]:6.3f} {none[2]:6.3f} | {anb[0]:7.3f} {100 * (anb[0] / ref0[0] - 1):+6.1f}"
                  f" {anb[1]:7.1f} {100 * (anb[1] / ref0[1] - 1):+6.1f} {anb[2]:6.3f} | {ant[0]:7.3f} "
                  f"{100 * (ant[0] / ref0[0] - 1):+6.1f} {ant[1]:7.1f} {100 * (ant[1] / ref0[1] - 1):+6.1f} {ant[2]:6.3f} | "
                  f"{old[0]:7.3f} {100 * (old[0] / ref0[0] - 1):+6.1f} {old[1]:7.1f} {100 * (old[1] / ref0[1] - 1):+6.1f} "
                  f"{old[2]:6.3f}", flush=True)
            out.setdefault(name, {})[fracs[j]] = {"fe": fe, "sector_ltca_fe": q["fe"], "full_ltca_fe": q["full"],
                                                  "sector_ltca_fe_neighbours": q["fe+n"],
                                                  "full_ltca_fe_neighbours": q["full+n"],
                                                  "reference": ref, "reference_without_neighbours": ref0,
                                                  "analytical": an, "analytical_without_neighbours": none,
                                                  "analytical_sainsot2004": old, "analytical_fe_body": anb,
                                                  "analytical_fe_body_teeth_over_cos_beta_b": ant}
    print(f"within 5 % of the reference (shares: 0.05 of the total), of {n_pos} positions: with the neighbours' term: "
          f"approach {n_pos - miss[0]}, pressure {n_pos - miss[1]}, share {n_pos - miss[2]}; without the neighbours "
          f"against the reference without them: approach {n_pos - miss_none[0]}, pressure {n_pos - miss_none[1]}, share "
          f"{n_pos - miss_none[2]}; Sainsot 2004 and cos^2 (against the reference without the neighbours): "
          f"approach {n_pos - miss_old[0]}, pressure {n_pos - miss_old[1]}, share {n_pos - miss_old[2]}")
    if lam_factor != 1.0:
        return 0  # a sensitivity run: not recorded
    path = ROOT / "benchmarks" / "data" / "fe_full_gear_reference.json"
    path.write_text(json.dumps({"_about": "benchmarks/fe_full_gear_body.py --validate: (approach um, section p MPa, "
                                "share) per drive and position (pitches); fe: the recorded very fine FE contact model; "
                                "reference: fe + (full_ltca_fe_neighbours - sector_ltca_fe_neighbours) (full gears and "
                                "their neighbouring teeth); reference_without_neighbours: fe + (full_ltca_fe - "
                                "sector_ltca_fe); analytical: the default compliance (LTCASettings.neighbours "
                                "'full_gear'), analytical_without_neighbours: 'none'", "date": time.strftime("%Y-%m-%d"),
                                "torque_Nm": T, "runs": out}, indent=1) + "\n")
    print(f"recorded in {path.relative_to(ROOT)}")
    return 0


def validate_recorded() -> int:
    """(c) without CalculiX: the default compliance (the neighbours' term) and the model without it against the
    references recorded by ``--neighbours`` (benchmarks/data/fe_neighbour_teeth.json: ``ref_n`` / ``p_share_ref_n``
    with the full gears' neighbours, ``ref`` / ``p_share_ref`` without them), the same section and pair as
    :func:`validate`."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from validate_ltca_fe import T, drives

    from gearopt.fea import FEOptions, GearFEModel
    from gearopt.ltca.engine import LTCA

    rec = json.loads((ROOT / "benchmarks" / "data" / "fe_neighbour_teeth.json").read_text())["runs"]
    mat = Material(E=E, nu=NU)
    print(f"{T:g} N m; the references recorded by --neighbours (benchmarks/data/fe_neighbour_teeth.json); 'ref': with "
          "the full gears' neighbouring teeth, 'ref0': without; 'default': the analytical compliance with "
          "the neighbours' term (neighbours = 'full_gear'), 'none': neighbours = 'none' (gearopt's default)")
    print(f"{'drive':<34} {'phi1':>6} {'ref app':>7} {'default':>7} {'err %':>6} {'ref p':>7} {'default p':>9} "
          f"{'err %':>6} {'ref sh':>6} {'def sh':>6} {'d sh':>6} | {'ref0 app':>8} {'none':>7} {'err %':>6} "
          f"{'ref0 p':>7} {'none p':>7} {'err %':>6} {'ref0 sh':>7} {'none sh':>7}")
    miss, miss0, n_pos = [0, 0, 0], [0, 0, 0], 0
    out = {}
    for name, runs in rec.items():
        pair, mis = drives()[name]
        step = 2 * math.pi / pair.pinion.z
        fracs = list(runs)
        phis = [float(f) * step for f in fracs]
        cb = math.cos(pair.pinion.beta_b)
        q = {}
        for lab, nb in (("default", "full_gear"), ("none", "none")):
            L = LTCA(pair, material=mat, neighbours=nb)
            S = L.slices(phi1=np.array(phis), mis=mis)
            r = L.solve(T, slices=S).results[0]
            for j, ph in enumerate(phis):
                m = GearFEModel(pair, ph, FEOptions(torque=T * 1e3, E=E, nu=NU), mis=mis)
                k0 = min(m.hertz, key=lambda k: abs(m.contact[k]["radius1"] - pair.pinion.r_p))
                kk = r.pairs.index(k0)
                ok = np.isfinite(S.z[kk, j]) & S.active[kk, j] & (S.edge[kk, j] == 0)
                o = np.argsort(S.z[kk, j][ok])
                q[(lab, j)] = (1e3 * r.delta[j] / cb,
                               float(np.interp(m.contact[k0]["z1"], S.z[kk, j][ok][o], r.p0[kk, j][ok][o])),
                               float(r.share[kk, j]))
        for j, (f, ph) in enumerate(zip(fracs, phis)):
            rr = runs[f]
            ref = (rr["ref_n"], *rr["p_share_ref_n"])
            ref0 = (rr["ref"], *rr["p_share_ref"])
            an, none = q[("default", j)], q[("none", j)]
            for k in range(3):
                def off(a, b):
                    return (abs(a / b - 1) > 0.05) if k < 2 else (abs(a - b) > 0.05)
                miss[k] += off(an[k], ref[k])
                miss0[k] += off(none[k], ref0[k])
            n_pos += 1
            print(f"{name:<34} {math.degrees(ph):6.2f} {ref[0]:7.3f} {an[0]:7.3f} {100 * (an[0] / ref[0] - 1):+6.1f} "
                  f"{ref[1]:7.1f} {an[1]:9.1f} {100 * (an[1] / ref[1] - 1):+6.1f} {ref[2]:6.3f} {an[2]:6.3f} "
                  f"{an[2] - ref[2]:+6.3f} | {ref0[0]:8.3f} {none[0]:7.3f} {100 * (none[0] / ref0[0] - 1):+6.1f} "
                  f"{ref0[1]:7.1f} {none[1]:7.1f} {100 * (none[1] / ref0[1] - 1):+6.1f} {ref0[2]:7.3f} {none[2]:7.3f}",
                  flush=True)
            out.setdefault(name, {})[f] = {"reference": ref, "default": an, "reference_without_neighbours": ref0,
                                           "without_neighbours": none}
    print(f"within 5 % of the reference (shares: 0.05 of the total), of {n_pos} positions: with the neighbours' term "
          f"against the reference with the neighbours: approach {n_pos - miss[0]}, pressure {n_pos - miss[1]}, share "
          f"{n_pos - miss[2]}; neighbours = 'none' against the reference without them: approach {n_pos - miss0[0]}, "
          f"pressure {n_pos - miss0[1]}, share {n_pos - miss0[2]}")
    # over a mesh cycle: the mean mesh stiffness against ISO 6336-1 and the loaded TE's peak-to-peak, with and
    # without the neighbours' term
    from gearopt.ltca.compliance import iso6336_stiffness

    for name in ("spur 20/40 conjugate", "helical 15 deg"):
        pair, _ = drives()[name]
        iso = iso6336_stiffness(pair)["c_gamma_alpha"] * E / 206000.0
        for torque in (100.0, 200.0):
            r = {}
            for nb in ("full_gear", "none"):
                L = LTCA(pair, material=mat, neighbours=nb)
                r[nb] = L.solve(torque, slices=L.slices(phi1=L.mesh_cycle(32))).results[0]
            print(f"{name}, {torque:g} N m, 32 positions: c_gamma {r['full_gear'].c_gamma:.2f} N/(mm um) (neighbours "
                  f"'none' {r['none'].c_gamma:.2f}; ISO 6336-1 {iso:.2f} at E {E:g} MPa); loaded TE peak-to-peak "
                  f"{r['full_gear'].peak_to_peak_arcsec:.2f} arcsec ('none' {r['none'].peak_to_peak_arcsec:.2f})",
                  flush=True)
    return 0


def sainsot_readings() -> int:
    """Sainsot's body term on the 20/40 pinion's rows (bore r_f / 2) as implemented and with the other readings
    of its inputs found in published implementations, against the full gear's FE body (the table of
    :func:`body_study`, cached)."""
    pair = pinion_pair()
    tca = TCA(pair)
    tooth = tca.pinion.unmodified
    r_bore = 0.5 * tooth.r_root
    r_form = tca.form_radius(1)
    base = line_load_compliance(tooth, E, NU, mesh=replace(MESH, rim_depth=0.3), teeth=3, r_form=r_form)
    full = line_load_compliance(tooth, E, NU, mesh=replace(MESH, rim_depth=(tooth.r_root - r_bore) / pair.pinion.m_n),
                                teeth=pair.pinion.z, support="bore", r_form=r_form)
    r = base.radius
    fe = 1e3 * (np.diag(full.C) - np.diag(base.C))
    tc = ToothCompliance(tooth, Material(E=E, nu=NU), r_bore, member="pinion", **OLD)
    xy, n = flank_points(tooth, r)
    c = tc.per_width(xy, n)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    cg, sg = np.abs(n[:, 0]), np.abs(n[:, 1])
    L, M, P, Q = (tc.sainsot[k] for k in "LMPQ")

    def term(u_f, S_f, modulus=E):
        x = u_f / S_f
        return 1e3 * cg**2 / modulus * (L * x**2 + M * x + P * (1.0 + Q * (sg / cg) ** 2))

    print(f"20/40 pinion: r_f {tc.r_f:.3f} mm, theta_f {tc.theta_f:.4f} rad (pi / z = {math.pi / pair.pinion.z:.4f}), "
          f"h_fi {tc.h_fi:.3f}, S_f {tc.S_f:.3f} mm; L* {L:.4f} M* {M:.4f} P* {P:.4f} Q* {Q:.4f}")
    readings = {"as implemented": term(c.eta_F, tc.S_f),
                "S_f = 2 r_f theta_f (arc)": term(c.eta_F, 2 * tc.r_f * tc.theta_f),
                "u_f from the root chord": term(c.eta_F + tc.r_f * (1 - math.cos(tc.theta_f)), tc.S_f),
                "u_f = r - r_f (radial)": term(np.hypot(*xy.T) - tc.r_f, tc.S_f),
                "E / (1 - nu^2)": term(c.eta_F, tc.S_f, E / (1 - NU**2))}
    print("Sainsot's term [um mm/N] (the full gear's FE body over it)")
    print(f"{'r [mm]':>7} {'FE body':>8} " + " ".join(f"{k:>27}" for k in readings))
    for i in range(r.size):
        print(f"{r[i]:7.2f} {fe[i]:8.4f} " + " ".join(f"{v[i]:.4f} ({fe[i] / v[i]:.3f})".rjust(27) for v in readings.values()))
    return 0


def helical_split() -> int:
    """The helical deficit part by part: (1) per flank row, the FE tooth (held 0.3 m_n below its root, line
    load) over the analytical tooth's normal compliance ``cos^2(beta_b) c`` on the spur 20/40 and the helical
    21/45; (2) at phi1 = 0 of the helical 21/45, 200 N m, each pair's share of the approach
    ``(F^T C F + sum F c_Hertz F / l) / sum F`` with one load distribution F (the FE-coefficient solve with
    full-gear grids) for the FE full-gear grids and for the analytical model with the FE body (and with its
    teeth over cos(beta_b)); (3) a point load at mid face and at the face end of a flank row, FE full-gear
    grid against the analytical model with the FE body."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from validate_ltca_fe import T, drives

    from gearopt.ltca.compliance import face_matrix_batch, weber_contact
    from gearopt.ltca.engine import LTCA

    mat = Material(E=E, nu=NU)
    print("(1) FE tooth (rim 0.3 m_n, line load) over the analytical tooth's normal compliance, per row (low to high)")
    for name in ("spur 20/40 conjugate", "helical 15 deg"):
        pair, _ = drives()[name]
        tca = TCA(pair)
        cb = math.cos(pair.pinion.beta_b)
        for m, (g, t) in enumerate(((pair.pinion, tca.pinion), (pair.gear, tca.gear)), start=1):
            tooth = t.unmodified
            t03 = line_load_compliance(tooth, E, NU, mesh=replace(MESH, rim_depth=0.3), teeth=3, r_form=tca.form_radius(m))
            c = ToothCompliance(tooth, mat, 0.5 * g.r_f, **OLD).per_width(*flank_points(tooth, t03.radius))
            ratio = np.diag(t03.C) / (cb**2 * (c.total - c.foundation))
            print(f"  {name} {'pinion' if m == 1 else 'gear':<6} (cos^2 beta_b {cb**2:.4f}): "
                  + " ".join(f"{x:.3f}" for x in ratio))
    name = "helical 15 deg"
    pair, mis = drives()[name]
    cb = math.cos(pair.pinion.beta_b)
    Lf = LTCA(pair, material=mat, compliance="fe")
    g1, g2 = Lf.influence
    full = [full_gear_grid(g, t.unmodified, gear, Lf.tca.form_radius(m + 1))
            for m, (g, t, gear) in enumerate(zip((g1, g2), (Lf.tca.pinion, Lf.tca.gear), (pair.pinion, pair.gear)))]
    Lf.influence = (full[0][0], full[1][0])
    S = Lf.slices(phi1=np.array([0.0]), mis=mis)
    rf = Lf.solve(T, slices=S).results[0]
    F = np.nan_to_num(rf.load[:, 0, :])
    K, _, M = S.z.shape
    wt = S.width if S.width_tooth is None else S.width_tooth
    print(f"\n(2) {name}, phi1 = 0, {T:g} N m: pair loads " + ", ".join(
        f"{p}: {F[k].sum() / F.sum():.3f}" for k, p in enumerate(rf.pairs)) + " (the FE-coefficient solve, full-gear grids); "
        "approach parts [um] = (F^T C F + sum F c_H F / l) / sum F / cos(beta_b)")
    scale = 1e3 / F.sum() / cb

    def weber(st, k):
        ln = st.length[k, 0]
        w = weber_contact(np.maximum(F[k] / ln, 0.0), st.R[k, 0], st.h1[k, 0], st.h2[k, 0], mat, 1e-3)
        return float(np.nansum(F[k] * w.compliance * F[k] / ln))

    stf = Lf.structure(S)
    rows = {"FE full-gear grids": [(float(F[k] @ stf.Cs[0][k * M:(k + 1) * M, k * M:(k + 1) * M] @ F[k]), weber(stf, k))
                                   for k in range(K)]}
    for kt in (1.0, 1.0 / cb):
        La = LTCA(pair, material=mat, neighbours="none", **OLD)
        La.teeth = tuple(FEBody(t, rl, rat / cb**2, kt) for t, (rl, rat) in zip(La.teeth, (full[0][3], full[1][3])))
        st = La.structure(S)
        lab = "analytical, FE body" + (", teeth / cos(beta_b)" if kt != 1.0 else "")
        rows[lab] = [(float(F[k] @ st.Cs[0][k * M:(k + 1) * M, k * M:(k + 1) * M] @ F[k]), weber(st, k)) for k in range(K)]
        if kt == 1.0:
            teeth = [float(F[k] @ (cb**2 * face_matrix_batch(S.z[:, 0, :], wt[:, 0, :], [(st.parts[0].compliance[:, 0, :],
                                                                                          st.parts[0].coupling_length)]))[k] @ F[k])
                     for k in range(K)]
    print(f"  {'':<40} " + " ".join(f"{'pair ' + str(p):>22}" for p in rf.pairs) + f" {'sum':>8}")
    for lab, v in rows.items():
        print(f"  {lab:<40} " + " ".join(f"{scale * (a + b):8.3f} ({scale * a:5.3f}+{scale * b:5.3f})" for a, b in v)
              + f" {scale * sum(a + b for a, b in v):8.3f}")
    fe_rows = rows["FE full-gear grids"]
    for lab in list(rows)[1:]:
        print(f"  {lab + ' / FE':<40} " + " ".join(f"{(a + b) / (c + d):22.3f}" for (a, b), (c, d) in zip(rows[lab], fe_rows)))
    print("  (the analytical teeth's part: " + ", ".join(f"{scale * x:.3f}" for x in teeth) + " um; the solved approaches: "
          f"FE full-gear grids {1e3 * rf.delta[0] / cb:.3f} um)")
    print("\n(3) a point load on a flank row, FE full-gear grid [um/N] against the analytical model with the FE body")
    for name in ("spur 20/40 conjugate", "helical 15 deg"):
        pair, _ = drives()[name]
        cb = math.cos(pair.pinion.beta_b)
        Lf = LTCA(pair, material=mat, compliance="fe")
        La = LTCA(pair, material=mat, neighbours="none", **OLD)
        for m, (g, gear) in enumerate(zip(Lf.influence, (pair.pinion, pair.gear))):
            t = (Lf.tca.pinion, Lf.tca.gear)[m].unmodified
            grid, _, _, (rl, rat) = full_gear_grid(g, t, gear, Lf.tca.form_radius(m + 1))
            tc = FEBody(La.teeth[m], rl, rat / cb**2)
            z = grid.z
            w = np.zeros(z.size)
            w[:-1] += 0.5 * np.diff(z)
            w[1:] += 0.5 * np.diff(z)
            mid = z.size // 2
            print(f"  {name} {'pinion' if m == 0 else 'gear'} (face nodes every {z[1] - z[0]:.2f} mm): r [mm], FE mid, "
                  "an. mid, FE end, an. end, FE end / mid, an. end / mid")
            for i in range(1, grid.radius.size - 1, 2):
                c = tc.per_width(*flank_points(t, np.array([grid.radius[i]])))
                A = cb**2 * face_matrix_batch(z[None], w[None], [
                    (np.full((1, z.size), (c.total - c.foundation)[0]), La.coupling_length),
                    (np.full((1, z.size), c.foundation[0]), La.body_coupling[m])])[0]
                G = grid.G[i, :, i, :]
                print(f"    {grid.radius[i]:6.2f} {1e3 * G[mid, mid]:7.4f} {1e3 * A[mid, mid]:7.4f} {1e3 * G[0, 0]:7.4f} "
                      f"{1e3 * A[0, 0]:7.4f} {G[0, 0] / G[mid, mid]:6.3f} {A[0, 0] / A[mid, mid]:6.3f}; a uniform line load, "
                      f"FE / an. at mid face {(G @ w)[mid] / (A @ w)[mid]:.3f}, at the face end {(G @ w)[0] / (A @ w)[0]:.3f}")
    # (4) a face-end factor on the teeth's compliance per slice, 1 + a exp(-d / lam) (d: distance to the nearer face
    # end), on the helical 21/45 at phi1 = 0 with the loads of (2): each pair's approach over the FE grids'
    print("\n(4) the helical 21/45, phi1 = 0: the teeth's compliance per slice times 1 + a exp(-d / lam_teeth) near the "
          "face ends (teeth over cos(beta_b), FE body), each pair's approach over the FE grids' (loads of (2))")
    pair, _ = drives()["helical 15 deg"]
    cb = math.cos(pair.pinion.beta_b)
    La = LTCA(pair, material=mat, neighbours="none", **OLD)
    La.teeth = tuple(FEBody(t, rl, rat / cb**2, 1.0 / cb) for t, (rl, rat) in zip(La.teeth, (full[0][3], full[1][3])))
    st = La.structure(S)
    d = 0.5 * pair.pinion.b - np.abs(np.nan_to_num(S.z[:, 0, :]))
    fe = np.array([scale * (a + b) for a, b in rows["FE full-gear grids"]])
    for a in (0.0, 0.5, 1.0):
        g = 1.0 + a * np.exp(-np.maximum(d, 0.0) / st.parts[0].coupling_length)
        terms = [(st.parts[0].compliance[:, 0, :] * g, st.parts[0].coupling_length)] + [
            (p.compliance[:, 0, :], p.coupling_length) for p in st.parts[1:]]
        blk = np.nan_to_num(cb**2 * face_matrix_batch(S.z[:, 0, :], wt[:, 0, :], terms))
        an = np.array([scale * (float(F[k] @ blk[k] @ F[k]) + weber(st, k)) for k in range(K)])
        print(f"  a {a:3.1f}: " + " ".join(f"{x:.3f}" for x in an / fe) + f"; sum {an.sum():.3f} um (FE grids {fe.sum():.3f})")
    return 0


class NeighbourLTCA:
    """Loaded TCA (:class:`gearopt.ltca.engine.LTCA`, any compliance) whose compliance matrix also couples the
    pairs' teeth through the members: pinion tooth k+d moves under a load on tooth k as ``cross[0][d]``
    (grid points of tooth d per unit normal force at tooth 0's, an ``InfluenceGrid``-like 4D array on ``radius``
    and ``z``), the gear's likewise (pair k meshes pinion tooth k with gear tooth -k). A diagnostic of
    docs/ltca.md section 7, not a model."""

    def __init__(self, engine, cross):
        self.engine, self.cross = engine, cross

    def __getattr__(self, name):
        return getattr(self.engine, name)

    @staticmethod
    def _rect(c, d, ra, za, rb, zb):
        from scipy.interpolate import RegularGridInterpolator

        r, z = c["radius"], c["z"]
        f = RegularGridInterpolator((r, z, r, z), c[d])
        na, nb = ra.size, rb.size
        pts = np.stack([np.repeat(np.clip(ra, r[0], r[-1]), nb), np.repeat(np.clip(za, z[0], z[-1]), nb),
                        np.tile(np.clip(rb, r[0], r[-1]), na), np.tile(np.clip(zb, z[0], z[-1]), na)], 1)
        return f(pts).reshape(na, nb)

    def structure(self, S):
        st = type(self.engine).structure(self.engine, S)  # the engine's own (solve patches the instance's)
        K, N, M = S.z.shape
        used = np.isfinite(S.z)
        z1 = np.where(used, S.z, 0.0)
        z2 = np.where(np.isfinite(S.z2), S.z2, z1)
        rad = (np.hypot(S.r1[..., 0], S.r1[..., 1]), np.hypot(S.r2[..., 0], S.r2[..., 1]))
        Cs = st.Cs.copy()
        pairs = list(S.pairs)
        for ia, k in enumerate(pairs):
            for ib, k2 in enumerate(pairs):
                d = k2 - k
                if d <= 0:
                    continue
                for n in range(N):
                    ua, ub = np.flatnonzero(used[ia, n]), np.flatnonzero(used[ib, n])
                    if ua.size == 0 or ub.size == 0:
                        continue
                    blk = 0.0
                    for m, (c, zz) in enumerate(zip(self.cross, (z1, z2))):
                        # the response of pair k's tooth to a load on pair k2's: the pinion's tooth k2 is d pitches
                        # on, the gear's -d; with the load on tooth 0 the response tooth is -d (pinion) or +d (gear)
                        # (shift), or by Maxwell the transpose of the loaded tooth's response on +d (-d)
                        e = -d if m == 0 else d
                        a, b = (rad[m][ia, n, ua], zz[ia, n, ua]), (rad[m][ib, n, ub], zz[ib, n, ub])
                        opts = [self._rect(c, f"N{e:+d}", *a, *b)] if f"N{e:+d}" in c else []
                        opts += [self._rect(c, f"N{-e:+d}", *b, *a).T] if f"N{-e:+d}" in c else []
                        if not opts:
                            continue
                        # a 3-tooth sector: the exact one has the load on the middle tooth (pair 0)
                        blk = blk + (opts[0] if (k2 == 0 and len(opts) > 0) else opts[-1] if k == 0 else sum(opts) / len(opts))
                    if np.ndim(blk):
                        Cs[n][np.ix_(ia * M + ua, ib * M + ub)] += blk
                        Cs[n][np.ix_(ib * M + ub, ia * M + ua)] += blk.T
        return replace(st, Cs=Cs)

    def solve(self, torque, slices):
        """The engine's solve with this structure."""
        import types

        eng = self.engine
        orig = eng.structure
        eng.structure = types.MethodType(lambda _self, S: self.structure(S), eng)
        try:
            return eng.solve(torque, slices=slices)
        finally:
            eng.structure = orig


def neighbour_grids(tooth, gear, r_form, grid, what):
    """The coupling of a member's neighbouring teeth on ``grid``'s points (4D arrays ``N-2 ... N+2`` as
    :class:`NeighbourLTCA` reads them): ``what = "sector"`` the contact model's member (3 teeth, point loads,
    :func:`~gearopt.fea.influence.influence_grid` with ``neighbours``); ``"full"`` the full gear held at r_f / 2
    (line loads on three rows, quadratic between them as :func:`member_bodies`, spread along the face by the
    Pasternak kernel of the body's depth as :func:`full_gear_grid`); ``"full - sector"`` the sector's plus the
    difference of the full gear's and the sector's line-load responses (the full gear's grid, as the reference's
    own-tooth grid is built)."""
    from gearopt.fea.influence import influence_grid

    out = {"radius": grid.radius, "z": grid.z}
    kw = dict(E=E, nu=NU, r_form=r_form)
    if what in ("sector", "full - sector"):
        sec = influence_grid(tooth, mesh=None, neighbours=(-1, 1), local=False, **kw).neighbours
        out.update({f"N{d:+d}": sec[d] for d in (-1, 1)})
        if what == "sector":
            return out
    secl = line_load_compliance(tooth, mesh=replace(MESH, rim_depth=1.5), teeth=3, support="sector", neighbours=(-1, 1),
                                **kw)
    r = secl.radius
    cols = [0, r.size // 2, r.size - 1]
    full = line_load_compliance(tooth, mesh=MESH, teeth=gear.z, support="bore", r_bore=0.5 * tooth.r_root, rows=cols,
                                neighbours=(-2, -1, 1, 2), **kw)
    z = grid.z
    w = np.zeros(z.size)
    w[:-1] += 0.5 * np.diff(z)
    w[1:] += 0.5 * np.diff(z)
    K = coupling(z, w, tooth.r_root - 0.5 * gear.r_f)
    for d in (-2, -1, 1, 2):
        D = full.neighbours[d][:, cols] - (secl.neighbours[d][:, cols] if what == "full - sector" and abs(d) == 1 else 0.0)
        D = np.array([[np.polyval(np.polyfit(r[cols], D[i], 2), rj) for rj in r] for i in range(r.size)])
        Dg = np.array([[np.interp(ri, r, [np.interp(rj, r, D[k]) for k in range(r.size)]) for rj in grid.radius]
                       for ri in grid.radius])
        out[f"N{d:+d}"] = out.get(f"N{d:+d}", 0.0) + Dg[:, None, :, None] * K[None, :, None, :]
    out["line"] = {"radius": r, "sector": {d: secl.neighbours[d] for d in (-1, 1)}, "sector_self": secl.C,
                   "full": full.neighbours, "full_self": full.C, "cols": cols}
    return out


#: the candidate neighbour term's constants (docs/ltca.md section 7), fitted to the FE full gears' d = 1 and 2 responses
#: of the six members of the validation (in-sample)
CANDIDATE = (0.715, 1.261)


def candidate_grids(La, m, gear, grid):
    """The candidate analytical neighbour term of member ``m`` of the engine ``La`` on ``grid``'s points (as
    :func:`neighbour_grids`): tooth d moves by ``c_tw + A exp(-k |d| s_f / (r_f - r_int)) (c_body - c_tw)`` per
    unit line load, whatever the rows (``c_tw`` the body's torsion, an annulus held at its bore, plane stress;
    ``c_body`` the loaded tooth's body term at its pitch point along the normal; ``s_f`` the root pitch),
    spread along the face over the body's depth."""
    tc = La.teeth[m]
    tooth = (La.tca.pinion, La.tca.gear)[m].unmodified
    cb = math.cos(gear.beta_b)
    c_body = float(tc.per_width(*flank_points(tooth, np.array([gear.r_p]))).foundation[0]) * tc.body_factor * cb**2
    r_f, r_int = tooth.r_root, La.r_int[m]
    c_tw = gear.r_b**2 * (1 / r_int**2 - 1 / r_f**2) / (4 * math.pi * E / (2 * (1 + NU)))
    x = 2 * math.pi * r_f / gear.z / (r_f - r_int)
    z = grid.z
    w = np.zeros(z.size)
    w[:-1] += 0.5 * np.diff(z)
    w[1:] += 0.5 * np.diff(z)
    K = coupling(z, w, r_f - r_int)
    A, k = CANDIDATE
    out = {"radius": grid.radius, "z": z}
    for d in (-2, -1, 1, 2):
        cx = c_tw + A * math.exp(-k * abs(d) * x) * (c_body - c_tw)
        out[f"N{d:+d}"] = np.full((grid.radius.size, 1, grid.radius.size, 1), cx) * K[None, :, None, :]
    return out


def neighbours_study() -> int:
    """The neighbouring teeth's coupling through the members (docs/ltca.md section 7): per member, a tooth's
    displacement at the pitch row under a line load on the tooth d pitches away, sector and full gear; per
    validation position, the approach of the FE-coefficient model with and without the sector's coupling (against
    the CalculiX contact model, which has it), the reference with the full gear's coupling, and the default model
    with and without the full gear's FE coupling added."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from validate_ltca_fe import RECORD, T, drives

    from gearopt.fea import FEOptions, GearFEModel
    from gearopt.ltca.engine import LTCA

    record = json.loads(RECORD.read_text())["very fine"]
    mat = Material(E=E, nu=NU)
    names = [n for n in drives() if "tip relief" not in n]
    out = {"members": {}, "runs": {}}
    print(f"{T:g} N m; approach [um] along the line of action; FE: the recorded contact model (very fine); 'ref': "
          "the full-gear reference of --validate, 'ref+n': with the full gears' neighbouring teeth")
    for name in names:
        pair, mis = drives()[name]
        cb = math.cos(pair.pinion.beta_b)
        step = 2 * math.pi / pair.pinion.z
        fracs = ("0", "-0.3", "+0.3")
        phis = np.array([float(f) * step for f in fracs])
        Lf = LTCA(pair, material=mat, compliance="fe")
        S = Lf.slices(phi1=phis, mis=mis)
        g = Lf.influence
        tt = (Lf.tca.pinion.unmodified, Lf.tca.gear.unmodified)
        gears = (pair.pinion, pair.gear)
        rf = (Lf.tca.form_radius(1), Lf.tca.form_radius(2))
        sec = [neighbour_grids(tt[m], gears[m], rf[m], g[m], "sector") for m in (0, 1)]
        full = [neighbour_grids(tt[m], gears[m], rf[m], g[m], "full - sector") for m in (0, 1)]
        an_n = [neighbour_grids(tt[m], gears[m], rf[m], g[m], "full") for m in (0, 1)]
        for m in (0, 1):
            ln = full[m]["line"]
            r = ln["radius"]
            key = f"{gears[m].z} teeth ({name})"
            out["members"][key] = {"rows_mm": r[ln["cols"]].round(3).tolist(),
                                   "full_self_cols": (1e3 * np.diag(ln["full_self"][np.ix_(ln["cols"], ln["cols"])])).tolist(),
                                   **{f"full {d:+d}": (1e3 * np.diag(ln["full"][d][np.ix_(ln["cols"], ln["cols"])])).tolist()
                                      for d in (-2, -1, 1, 2)},
                                   **{f"sector {d:+d}": (1e3 * np.diag(ln["sector"][d][np.ix_(ln["cols"], ln["cols"])])).tolist()
                                      for d in (-1, 1)}}
            print(f"  {key}: rows {np.round(r[ln['cols']], 2).tolist()} mm; [um mm/N] full gear: own "
                  f"{np.round(out['members'][key]['full_self_cols'], 4).tolist()}, " + ", ".join(
                      f"d {d:+d} {np.round(out['members'][key][f'full {d:+d}'], 4).tolist()}" for d in (-2, -1, 1, 2))
                  + "; sector: " + ", ".join(f"d {d:+d} {np.round(out['members'][key][f'sector {d:+d}'], 4).tolist()}"
                                             for d in (-1, 1)), flush=True)
        res = {"sector": Lf.solve(T, slices=S).results[0]}
        res["sector+n"] = NeighbourLTCA(Lf, sec).solve(T, S).results[0]
        n1, n2 = (full_gear_grid(g[m], tt[m], gears[m], rf[m])[0] for m in (0, 1))
        Lf.influence = (n1, n2)
        res["full"] = Lf.solve(T, slices=S).results[0]
        res["full+n"] = NeighbourLTCA(Lf, full).solve(T, S).results[0]
        La = LTCA(pair, material=mat, neighbours="none")  # the uncoupled model, + the diagnostics
        res["default"] = La.solve(T, slices=S).results[0]
        res["default+n"] = NeighbourLTCA(La, an_n).solve(T, S).results[0]
        cand = [candidate_grids(La, m, gears[m], g[m]) for m in (0, 1)]
        res["default+candidate"] = NeighbourLTCA(La, cand).solve(T, S).results[0]
        for j, f in enumerate(fracs):
            rec = record.get(name, {}).get(f)
            if rec is None:
                continue
            a = {k: 1e3 * v.delta[j] / cb for k, v in res.items()}
            fe = rec["approach_um"]
            ref = fe + a["full"] - a["sector"]
            refn = fe + a["full+n"] - a["sector+n"]
            # the section pressure and the share of the pair nearest the pitch point, as --validate
            m = GearFEModel(pair, phis[j], FEOptions(torque=T * 1e3, E=E, nu=NU), mis=mis)
            k0 = min(m.hertz, key=lambda k: abs(m.contact[k]["radius1"] - pair.pinion.r_p))
            z_sec = m.contact[k0]["z1"]
            ps = {}
            for lab, rr in res.items():
                kk = rr.pairs.index(k0)
                ok = np.isfinite(S.z[kk, j]) & S.active[kk, j] & (S.edge[kk, j] == 0)
                o = np.argsort(S.z[kk, j][ok])
                ps[lab] = (float(np.interp(z_sec, S.z[kk, j][ok][o], rr.p0[kk, j][ok][o])), float(rr.share[kk, j]))
            pref = [(rec["p_max_mid_MPa"], rec["share"])[i] + ps["full"][i] - ps["sector"][i] for i in (0, 1)]
            prefn = [(rec["p_max_mid_MPa"], rec["share"])[i] + ps["full+n"][i] - ps["sector+n"][i] for i in (0, 1)]
            row = dict(fe=fe, ref=ref, ref_n=refn, **a, p_share=ps, p_share_ref=pref, p_share_ref_n=prefn)
            out["runs"].setdefault(name, {})[f] = row
            print(f"{'':<34} {'':>6} section p [MPa] / share: reference {pref[0]:.1f} / {pref[1]:.3f}, default "
                  f"{ps['default'][0]:.1f} ({100 * (ps['default'][0] / pref[0] - 1):+.1f} %) / {ps['default'][1]:.3f} "
                  f"({ps['default'][1] - pref[1]:+.3f}); with the neighbours: reference {prefn[0]:.1f} / {prefn[1]:.3f}, "
                  f"default + FE neighbours {ps['default+n'][0]:.1f} ({100 * (ps['default+n'][0] / prefn[0] - 1):+.1f} %) / "
                  f"{ps['default+n'][1]:.3f} ({ps['default+n'][1] - prefn[1]:+.3f})", flush=True)
            print(f"{name:<34} {math.degrees(phis[j]):6.2f} FE {fe:7.3f}: LTCA-fe {a['sector']:7.3f} "
                  f"({100 * (a['sector'] / fe - 1):+5.1f} %), + sector neighbours {a['sector+n']:7.3f} "
                  f"({100 * (a['sector+n'] / fe - 1):+5.1f} %) | ref {ref:7.3f}, ref+n {refn:7.3f} ({100 * (refn / ref - 1):+5.1f} %) | "
                  f"default {a['default']:7.3f} ({100 * (a['default'] / ref - 1):+5.1f} % of ref, "
                  f"{100 * (a['default'] / refn - 1):+5.1f} % of ref+n), default + FE neighbours {a['default+n']:7.3f} "
                  f"({100 * (a['default+n'] / refn - 1):+5.1f} % of ref+n), default + the candidate term "
                  f"{a['default+candidate']:7.3f} ({100 * (a['default+candidate'] / refn - 1):+5.1f} % of ref+n)", flush=True)
    # over a mesh cycle: the mean mesh stiffness against ISO 6336-1 and the loaded TE's peak-to-peak
    from gearopt.ltca.compliance import iso6336_stiffness

    for name in ("spur 20/40 conjugate", "helical 15 deg"):
        pair, _ = drives()[name]
        Lf = LTCA(pair, material=mat, compliance="fe")
        tt = (Lf.tca.pinion.unmodified, Lf.tca.gear.unmodified)
        an_n = [neighbour_grids(tt[m], (pair.pinion, pair.gear)[m], Lf.tca.form_radius(m + 1), Lf.influence[m], "full")
                for m in (0, 1)]
        La = LTCA(pair, material=mat, neighbours="none")  # the uncoupled model, + the diagnostics
        S = La.slices(phi1=La.mesh_cycle(32))
        iso = iso6336_stiffness(pair)["c_gamma_alpha"] * E / 206000.0
        for torque in (100.0, 200.0):
            r0 = La.solve(torque, slices=S).results[0]
            r1 = NeighbourLTCA(La, an_n).solve(torque, S).results[0]
            out.setdefault("cycle", {}).setdefault(name, {})[f"{torque:g}"] = dict(
                c_gamma=r0.c_gamma, c_gamma_n=r1.c_gamma, iso=iso, te_pp=r0.peak_to_peak_arcsec,
                te_pp_n=r1.peak_to_peak_arcsec)
            print(f"{name}, {torque:g} N m, 32 positions: c_gamma default {r0.c_gamma:.2f}, + the full gears' FE "
                  f"neighbours {r1.c_gamma:.2f} N/(mm um) (ISO 6336-1 {iso:.2f} at E {E:g} MPa); loaded TE peak-to-peak "
                  f"{r0.peak_to_peak_arcsec:.2f} -> {r1.peak_to_peak_arcsec:.2f} arcsec", flush=True)
    path = ROOT / "benchmarks" / "data" / "fe_neighbour_teeth.json"
    out.update(_about="benchmarks/fe_full_gear_body.py --neighbours: line-load responses [um mm/N] of teeth d pitches "
               "from the loaded one at the loaded rows (cols); approaches [um] per drive and position",
               date=time.strftime("%Y-%m-%d"), torque_Nm=T)
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"recorded in {path.relative_to(ROOT)}")
    return 0


def main(argv):
    if "-h" in argv or "--help" in argv:
        print(__doc__)
        return 0
    lam_factor = 1.0
    if "--lam-factor" in argv:
        i = argv.index("--lam-factor")
        try:
            lam_factor = float(argv[i + 1])
        except (IndexError, ValueError):
            lam_factor = float("nan")
        if not 0.05 <= lam_factor <= 20:
            print("fe_full_gear_body.py: --lam-factor needs a number 0.05 <= x <= 20 (see --help)", file=sys.stderr)
            return 2
        argv = argv[:i] + argv[i + 2:]
    bad = [a for a in argv if a not in ("--mesh", "--validate", "--sainsot", "--helical", "--neighbours", "--recorded")]
    if bad:
        print(f"fe_full_gear_body.py: unknown argument {bad[0]!r}: expected --mesh, --validate, --sainsot, --helical, "
              "--neighbours, --recorded (with --validate) "
              "or --lam-factor X (see --help)", file=sys.stderr)
        return 2
    if "--sainsot" in argv:
        return sainsot_readings()
    if "--helical" in argv:
        return helical_split()
    if "--neighbours" in argv:
        return neighbours_study()
    if "--validate" in argv and "--recorded" in argv:
        return validate_recorded()
    if "--validate" in argv:
        return validate(lam_factor)
    return body_study("--mesh" in argv)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
