"""Each tooth pair's stiffness in loaded TCA with FE coefficients against the CalculiX contact model's
(docs/ltca.md section 7, "The helicals' three-pair misses: the pitch pair, not the partial lines").

    python benchmarks/ltca_pair_stiffness.py                  # every drive of validate_ltca_fe.py (~1 min warm)
    python benchmarks/ltca_pair_stiffness.py --only helical   # the drives whose name holds WORD
    python benchmarks/ltca_pair_stiffness.py --teeth 5 --only "spur 20/40" --pos +0.3   # runs the CalculiX
        # contact model (default level) with 5 teeth per member instead of 3 at one position (2-5 minutes)

Reads the FE results recorded in benchmarks/data/fe_reference.json (no CalculiX run; the influence grids
from the cache, else CalculiX computes them once). At a position with the approach delta (the same for
every pair of an unmodified drive: no separations where the pairs carry load) a pair's stiffness is its
load over delta, its share times W / delta. The ratio of loaded TCA's to the FE's, per pair, is
``(share_LTCA / delta_LTCA) / (share_FE / delta_FE)``; the approach error is ``delta_LTCA / delta_FE - 1``.
FE shares of every pair are recorded for some runs ("shares"); else, with two pairs in mesh, the other
pair's share is one minus the recorded pitch pair's. A pair whose ratio is above 1 is too stiff in loaded
TCA. ``--teeth N``: the contact model with N teeth per member (its sector held at the sides of the outer
teeth) at one position ``--pos``, its approach and every pair's share beside loaded TCA's (nothing recorded). The approach error is set by how the ratios of the pairs in mesh differ: where every pair is too stiff
by the same factor (equal shares), the approach is too small by that factor; where one pair is stiffer and
another softer, they offset.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from validate_ltca_fe import RECORD, T, drives  # noqa: E402

from gearopt.ltca.compliance import Material  # noqa: E402
from gearopt.ltca.engine import LTCA  # noqa: E402

FRACS = ("0", "-0.3", "+0.3")
LEVELS = ("default", "fine", "very fine")


def fe_shares(rec: dict, lt_pairs: tuple, lt_share: np.ndarray) -> dict:
    """{pair: FE share} from a record: every pair's where recorded, else (two pairs loaded in loaded
    TCA) the pitch pair's and one minus it; {} when neither."""
    if rec.get("shares"):
        return {int(k): (v or 0.0) for k, v in rec["shares"].items()}
    loaded = [k for k, s in zip(lt_pairs, lt_share) if s > 1e-6]
    k0 = lt_pairs[int(np.argmax(lt_share))]
    if len(loaded) == 1:
        return {k0: rec["share"]}
    if len(loaded) == 2:
        other = [k for k in loaded if k != k0][0]
        return {k0: rec["share"], other: 1.0 - rec["share"]}
    return {k0: rec["share"]}


def run_teeth(names, teeth: int, frac: str) -> int:
    """The contact model with ``teeth`` teeth per member at one position against loaded TCA (FE coefficients)."""
    from validate_ltca_fe import FE_MESH

    from gearopt.fea import FEOptions, GearFEModel

    mat = Material(E=210e3, nu=0.3)
    for name in names:
        pair, mis = drives()[name]
        ph = float(frac) * 2 * math.pi / pair.pinion.z
        d = GearFEModel(pair, ph, FEOptions(torque=T * 1e3, E=mat.E, nu=mat.nu, mesh=FE_MESH, teeth=teeth),
                        mis=mis).run().to_dict()
        r = LTCA(pair, material=mat, compliance="fe").solve(T, phi1=[ph], mis=mis).results[0]
        cb = math.cos(pair.pinion.beta_b)
        fe_app, app = 1000 * abs(d["pinion_rotation_rad"]) * pair.pinion.r_b, 1000 * r.delta[0] / cb
        sh = {int(k): v or 0.0 for k, v in d["pair_share"].items()}
        print(f"{name} at {frac} pitches, FE with {teeth} teeth per member: approach {fe_app:.3f} um, loaded TCA "
              f"{app:.3f} um ({100 * (app / fe_app - 1):+.1f} %); shares " + ", ".join(
                  f"{k:+d}: {float(r.share[i, 0]):.3f} / {sh.get(k, 0.0):.3f}" for i, k in enumerate(r.pairs)), flush=True)
    return 0


def main(argv) -> int:
    names = list(drives())
    if "--only" in argv:
        names = [n for n in names if argv[argv.index("--only") + 1] in n]
    if "--teeth" in argv:
        frac = argv[argv.index("--pos") + 1] if "--pos" in argv else "0"
        return run_teeth(names, int(argv[argv.index("--teeth") + 1]), frac)
    record = json.loads(RECORD.read_text())
    mat = Material(E=210e3, nu=0.3)
    print("per pair: loaded TCA (FE coefficients) share / FE share, and the pair's stiffness ratio LTCA / FE [%]")
    print(f"{'drive':<30} {'pos':>5} {'level':>9} {'FE app':>7} {'LTCA app':>8} {'err %':>6} | pairs: "
          "k: share LTCA / FE (stiffness LTCA/FE - 1 %)")
    for name in names:
        if not any(record.get(lev, {}).get(name) for lev in LEVELS):
            continue  # no FE recorded (and no influence grid computed for nothing)
        pair, mis = drives()[name]
        step = 2 * math.pi / pair.pinion.z
        L = LTCA(pair, material=mat, compliance="fe")
        S = L.slices(phi1=np.array([float(f) * step for f in FRACS]), mis=mis)
        r = L.solve(T, slices=S).results[0]
        cb = math.cos(pair.pinion.beta_b)
        for j, f in enumerate(FRACS):
            app = 1000 * r.delta[j] / cb
            for lev in LEVELS:
                rec = record.get(lev, {}).get(name, {}).get(f)
                if rec is None:
                    continue
                sh = fe_shares(rec, r.pairs, r.share[:, j])
                out = []
                for kk, k in enumerate(r.pairs):
                    s_lt = float(r.share[kk, j])
                    if s_lt < 1e-6 and not sh.get(k):
                        continue
                    s_fe = sh.get(k)
                    if s_fe is None or s_fe <= 0:
                        out.append(f"{k:+d}: {s_lt:.3f} / -")
                        continue
                    ratio = (s_lt / app) / (s_fe / rec["approach_um"])
                    out.append(f"{k:+d}: {s_lt:.3f} / {s_fe:.3f} ({100 * (ratio - 1):+5.1f})")
                print(f"{name[:30]:<30} {f:>5} {lev:>9} {rec['approach_um']:7.3f} {app:8.3f} "
                      f"{100 * (app / rec['approach_um'] - 1):+6.1f} | " + "  ".join(out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
