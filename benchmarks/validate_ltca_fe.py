"""Loaded TCA against the CalculiX contact model (docs/ltca.md, validation table).

    python benchmarks/validate_ltca_fe.py            # every drive below (about 25 minutes)
    python benchmarks/validate_ltca_fe.py --spur     # the conjugate spur drive only
    python benchmarks/validate_ltca_fe.py --only helical
    python benchmarks/validate_ltca_fe.py --fine     # the FE reference at the refinement study's fine
                                                      # level (benchmarks/bench_fea_refine.py; ~40 min)
    python benchmarks/validate_ltca_fe.py --only scene  # the drives of problems/ltca_crowned.toml
                                                      # (crowned spur, 3' crossing) and ltca_helical.toml
                                                      # (lead-crowned helical 21/53), with their misalignment
                                                      # (default level ~8 min, --fine ~25 min)
    python benchmarks/validate_ltca_fe.py --only "tip relief"  # the crowned helical with 20 um tip relief on
                                                      # both members (no tip-edge contact)
    python benchmarks/validate_ltca_fe.py --recorded [--fine]  # loaded TCA only, against the FE results
                                                      # recorded in benchmarks/data/fe_reference.json (~2 min)
    python benchmarks/validate_ltca_fe.py --recorded --compliance analytical  # the pressure, share and pattern
                                                      # columns from loaded TCA with the default analytical
                                                      # compliance instead of the FE coefficients
    python benchmarks/validate_ltca_fe.py --very-fine --only "spur crowned" --pos -0.3  # one position
                                                      # (0, -0.3 or +0.3 pitches) at bench_fea_refine's very
                                                      # fine level (about an hour per position)

Every CalculiX run records its results in benchmarks/data/fe_reference.json (per FE level, drive and
position), which --recorded reads back: a change of loaded TCA is validated without the FE runs.

For each drive and three pinion angles (single and double contact), at 200 N m (E 210 GPa, nu 0.3):
the loaded approach along the line of action (FE: the loaded pinion rotation times r_b1; loaded TCA:
delta / cos(beta_b)), and the peak contact pressure in the section through each loaded pair's contact
(FE: nodal pressure along the profile; loaded TCA: the slice p0 of that pair interpolated to the same
section, and the largest slice p0 of the pair, "max p"), the centre of that pair's contact pattern
along the face (FE: its nodal pressure integrated over the pinion flank; loaded TCA: its slice loads;
"z_c" [mm]), with the
analytical compliance and with the FE influence coefficients of the same members (default member
mesh of gearopt.fea.influence; cached in $GEAROPT_CACHE/influence, default ~/.cache/gearopt), and the load share of that
pair (FE: its contact force over the sum of all pairs', from the ccx contact statistics).
"FE p/lay": the FE's section peak divided by what its penalty contact's compliant layer leaves of a Hertz
peak at that half-width (gearopt.fea.references.penalty_layer_factor, 0.97-0.99 at the default 50 E; docs/fea.md),
the reference loaded TCA, which has no such layer, is compared with in the "err %" column after it.
"max dsh": the largest difference between FE and loaded TCA in the share of any pair in mesh (of the
total; FE runs recorded since 2026-11-28 keep every pair's share).
"LTCA-an" (the default analytical compliance's approach) is not like for like: the FE members are
3-tooth sectors held at their sides and rim bottom, whose body is 0.43-0.60 of the analytical model's
full-gear body term (Sainsot et al.) at the same bore, while the teeth agree within 5 %
(benchmarks/ltca_face_coupling.py --body; docs/ltca.md section 7, "part by part"). Its reference with
full-gear bodies held at r_f / 2: benchmarks/fe_full_gear_body.py --validate.
"""

from __future__ import annotations

import json
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from gearopt.fea import FEOptions, GearFEModel, MeshOptions, penalty_layer_estimate
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.compliance import Material
from gearopt.ltca.engine import LTCA

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "benchmarks" / "data" / "fe_reference.json"

T = 200.0
# the contact model's default mesh with 8 face layers instead of 4: the helical pair's approach moves by
# 3 % from 4 to 8 layers and by 0.4 % from 8 to 12 (docs/ltca.md section 7)
FE_MESH = MeshOptions(n_face=8)


def _scene(name):
    """(pair, misalignment) of a scene of problems/ (its [ltca] misalignment keys)."""
    from gearopt.io.scene import load_scene
    from gearopt.studies.tca import misalignment_from

    sc = load_scene(ROOT / "problems" / f"{name}.toml")
    return sc.pair, misalignment_from(sc.options.get("ltca", {}) or {})


def drives():
    """{name: (pair, misalignment or None)}."""
    b = math.radians(15)
    plain = {
        "spur 20/40 conjugate": GearPair(Gear(z=20, m_n=3.0, b=20.0, name="pinion"), Gear(z=40, m_n=3.0, b=20.0, name="gear")),
        "spur crowned": GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=4e-4, rack=BasicRack.iso53("A", a_c=2e-3), name="pinion"),
                                 Gear(z=40, m_n=3.0, b=20.0, name="gear")),
        "helical 15 deg": GearPair(Gear(z=21, m_n=2.5, b=24, beta=b, name="pinion"),
                                   Gear(z=45, m_n=2.5, b=24, beta=b, hand="left", name="gear")),
    }
    out = {k: (v, None) for k, v in plain.items()}
    out["scene ltca_crowned (crossing 3')"] = _scene("ltca_crowned")
    out["scene ltca_helical (crowned)"] = _scene("ltca_helical")
    # the same with 20 um linear tip relief from 1 mm below the tip diameter on both members: no tip-edge
    # contact at 200 N m (the unrelieved pair's tips press on the mating flanks in both models, each
    # with its own corner: docs/ltca.md section 7)
    from dataclasses import replace

    from gearopt.geometry.microgeometry import Microgeometry

    hp, hm = out["scene ltca_helical (crowned)"]
    relieved = [replace(g, modifications=Microgeometry(C_alpha_a=0.020, d_Ca=2 * g.r_a - 1.0)) for g in (hp.pinion, hp.gear)]
    out["helical crowned, tip relief 20 um"] = (GearPair(*relieved), hm)
    return out


def section_line_load(profile) -> float:
    """The FE's nodal pressure integrated along the profile of the contact section [N/mm] (trapezoids)."""
    s, p = np.asarray(profile["s"], float), np.asarray(profile["p"], float)
    o = np.argsort(s)
    return float(np.trapezoid(p[o], s[o]))


def fe_record(d: dict, pair) -> dict:
    """The record of one CalculiX run (``GearFEModel.run().to_dict()``) kept in the FE reference files."""
    k0 = d["contact"]["hertz_pair"]
    return {"approach_um": 1000 * abs(d["pinion_rotation_rad"]) * pair.pinion.r_b,
            "p_max_mid_MPa": d["contact"]["p_max_mid"], "share": d["pair_share"].get(str(k0)) or 0.0,
            "z_c_mm": d["contact"]["pattern"][str(k0)]["z_centroid"], "date": time.strftime("%Y-%m-%d"),
            # the nodal pressure integrated over the pair's flank over its contact force, and
            # over the section's profile [N/mm]: how far the nodal field is from equilibrium
            "nodal_over_force": d["contact"]["pattern"][str(k0)]["nodal_over_force"],
            "w_section_Nmm": section_line_load(d["contact"]["profiles"][str(k0)]),
            "shares": d["pair_share"]}  # every pair's (tooth id: share)


FLAGS = ("--spur", "--fine", "--very-fine", "--recorded")
VALUED = {"--only": None, "--pos": ("0", "-0.3", "+0.3"), "--compliance": ("fe", "analytical")}


def check_args(argv) -> str | None:
    """The first problem with the command line (unknown flag, missing or invalid value), or None."""
    i = 0
    while i < len(argv):
        a = argv[i]
        if a in VALUED:
            if i + 1 >= len(argv):
                return f"{a} needs a value"
            valid = VALUED[a]
            if valid is not None and argv[i + 1] not in valid:
                return f"{a} {argv[i + 1]!r}: expected one of {', '.join(valid)}"
            i += 2
            continue
        if a not in FLAGS:
            return f"unknown argument {a!r}: expected {', '.join(FLAGS + tuple(VALUED))}"
        i += 1
    return None


def main(argv):
    if "-h" in argv or "--help" in argv:
        print(__doc__)
        return 0
    problem = check_args(argv)
    if problem is not None:
        print(f"validate_ltca_fe.py: {problem} (see --help)", file=sys.stderr)
        return 2
    if "--only" in argv and not any(argv[argv.index("--only") + 1] in n for n in drives()):
        print(f"validate_ltca_fe.py: --only {argv[argv.index('--only') + 1]!r} matches no drive: {', '.join(drives())}",
              file=sys.stderr)
        return 2
    if shutil.which("ccx") is None and "--recorded" not in argv:
        print("ccx (CalculiX) not installed: nothing to validate")
        return 0
    names = ["spur 20/40 conjugate"] if "--spur" in argv else list(drives())
    if "--only" in argv:  # --only WORD: the drives whose name holds WORD (e.g. crowned, helical)
        names = [n for n in drives() if argv[argv.index("--only") + 1] in n]
    mat = Material(E=210000.0, nu=0.3)
    fe_level = dict(mesh=FE_MESH)
    if "--fine" in argv or "--very-fine" in argv:
        sys.path.insert(0, __file__.rsplit("/", 1)[0])
        from bench_fea_refine import LEVELS, VERY_FINE
        fe_level = dict(VERY_FINE["very fine"], timeout=7200.0) if "--very-fine" in argv else LEVELS["fine"]
    print(f"FE reference mesh: {fe_level}")
    if "--compliance" in argv:
        print(f"LTCA-fe p, share, z_c, max dsh columns: loaded TCA with compliance = "
              f"{argv[argv.index('--compliance') + 1]!r}")
    print(f"{'drive':<22} {'phi1 deg':>8} {'pairs':>7} {'FE approach um':>14} {'LTCA-an':>8} {'LTCA-fe':>8} "
          f"{'err an %':>8} {'err fe %':>8} {'FE p MPa':>9} {'LTCA-fe p':>9} {'err %':>6} {'max p':>9} {'FE share':>8} "
          f"{'LTCA-fe':>7} {'FE z_c':>7} {'LTCA z_c':>8} {'FE s':>6} {'FE p/lay':>9} {'err %':>6} {'max dsh':>7}")
    recorded = "--recorded" in argv
    level = "very fine" if "--very-fine" in argv else "fine" if "--fine" in argv else "default"
    only_pos = argv[argv.index("--pos") + 1] if "--pos" in argv else None  # --pos 0, -0.3 or +0.3 (pitches)
    record = json.loads(RECORD.read_text()) if RECORD.exists() else {}
    for name in names:
        pair, mis = drives()[name]
        z1 = pair.pinion.z
        step = 2 * math.pi / z1
        fracs = ("0", "-0.3", "+0.3")
        phis = [float(f) * step for f in fracs]
        cb = math.cos(pair.pinion.beta_b)
        lt = {}
        for c in ("analytical", "fe"):
            L = LTCA(pair, material=mat, compliance=c)
            S = L.slices(phi1=np.array(phis), mis=mis)
            lt[c] = L.solve(T, slices=S).results[0]
        cc = argv[argv.index("--compliance") + 1] if "--compliance" in argv else "fe"  # the p, share, z_c columns
        for j, ph in enumerate(phis):
            if only_pos is not None and fracs[j] != only_pos:
                continue
            t0 = time.perf_counter()
            opts = FEOptions(torque=T * 1e3, E=mat.E, nu=mat.nu, **fe_level)
            m = GearFEModel(pair, ph, opts, mis=mis)
            k0 = min(m.hertz, key=lambda k: abs(m.contact[k]["radius1"] - pair.pinion.r_p))  # as GearFEModel.run
            if recorded:
                rec = record.get(level, {}).get(name, {}).get(fracs[j])
                if rec is None:
                    print(f"{name:<22} {math.degrees(ph):8.3f}: no FE result recorded at the {level} level")
                    continue
                loaded = m.loaded
            else:
                d = m.run().to_dict()
                k0 = d["contact"]["hertz_pair"]
                rec = fe_record(d, pair)
                record.setdefault(level, {}).setdefault(name, {})[fracs[j]] = rec
                loaded = d["loaded_pairs"]
            t_fe = time.perf_counter() - t0
            fe_app = rec["approach_um"] / 1000
            an = lt["analytical"].delta[j] / cb
            fe = lt["fe"].delta[j] / cb
            kk = lt[cc].pairs.index(k0)
            # the slice pressure in the FE's section (through the contact: mid face for line contact)
            z_sec = m.contact[k0]["z1"]
            ok = np.isfinite(S.z[kk, j]) & S.active[kk, j] & (S.edge[kk, j] == 0)  # flank slices
            o = np.argsort(S.z[kk, j][ok])
            p_lt = float(np.interp(z_sec, S.z[kk, j][ok][o], lt[cc].p0[kk, j][ok][o]))
            p_lt_max = float(np.max(lt[cc].p0_flank[kk, j]))
            p_fe = rec["p_max_mid_MPa"]
            # the FE peak without its penalty layer's compliance (docs/fea.md, "Penalty")
            p_fe0 = penalty_layer_estimate(p_fe, m.hertz[k0], opts)["p_max_mid_penalty_free"]
            sh_fe = rec["share"]
            sh_lt = float(lt[cc].share[kk, j])
            zc_fe = rec["z_c_mm"] if rec["z_c_mm"] is not None else float("nan")
            F_lt = lt[cc].load[kk, j][ok]
            zc_lt = float((F_lt * S.z[kk, j][ok]).sum() / F_lt.sum())
            # every pair's share (recorded since 2026-11-28): the largest difference [share of the total]
            d_sh = float("nan")
            if rec.get("shares"):
                d_sh = max(abs((v or 0.0) - (float(lt[cc].share[lt[cc].pairs.index(int(k)), j])
                                             if int(k) in lt[cc].pairs else 0.0)) for k, v in rec["shares"].items())
            print(f"{name:<22} {math.degrees(ph):8.3f} {str(loaded):>7} {1000 * fe_app:14.3f} "
                  f"{1000 * an:8.3f} {1000 * fe:8.3f} {100 * (an / fe_app - 1):8.1f} {100 * (fe / fe_app - 1):8.1f} "
                  f"{p_fe:9.1f} {p_lt:9.1f} {100 * (p_lt / p_fe - 1):6.1f} {p_lt_max:9.1f} {sh_fe:8.3f} {sh_lt:7.3f} "
                  f"{zc_fe:7.2f} {zc_lt:8.2f} {'rec' if recorded else f'{t_fe:.1f}':>6} {p_fe0:9.1f} {100 * (p_lt / p_fe0 - 1):6.1f} {d_sh:7.3f}",
                  flush=True)
            if not recorded:
                RECORD.parent.mkdir(parents=True, exist_ok=True)
                RECORD.write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
