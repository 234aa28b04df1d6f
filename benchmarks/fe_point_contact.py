"""The CalculiX contact model's peak pressure on the crowned 20/40 pinion whose ellipse lies inside the
face, over torque, against the Hertz ellipse (docs/ltca.md section 2, "Point contact": the reference of
tests/test_ltca_point_contact.py).

    python benchmarks/fe_point_contact.py --torque 400 --level fine   # one run (about 10-30 min of ccx)

The drive is bench_fea_refine.py's "crowned a_pl 2e-3" (20/40, m 3, b 20, pinion a_pl 2e-3, a_c 2e-3) at
phi1 = 0 (one pair in mesh), E 210 GPa, nu 0.3. Each run records in benchmarks/data/fe_point_contact.json
(per level and torque): the section peak at mid face ``p_max_mid`` [MPa], the same without the penalty
contact's compliant layer (``gearopt.fea.penalty_layer_estimate``, the reference of a model without
that layer), the Hertz ellipse (``p0``, semi-axis ``a``), the nodal pressure over the contact force
(how far the nodal field is from equilibrium) and the pinion rotation [rad].
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fea_refine import LEVELS, VERY_FINE, drives  # noqa: E402

from gearopt.fea import FEOptions, GearFEModel, penalty_layer_estimate  # noqa: E402

RECORD = Path(__file__).resolve().parent / "data" / "fe_point_contact.json"


def run(torque: float, level: str) -> dict:
    """One FE run of the crowned a_pl 2e-3 drive at ``torque`` [N m] and mesh ``level``."""
    pair = drives()["crowned a_pl 2e-3"]
    opts = FEOptions(torque=torque * 1e3, E=210000.0, nu=0.3, timeout=7200.0, **{**LEVELS, **VERY_FINE}[level])
    t0 = time.perf_counter()
    m = GearFEModel(pair, 0.0, opts)
    d = m.run().to_dict()
    k0 = d["contact"]["hertz_pair"]
    h = m.hertz[k0]
    p = d["contact"]["p_max_mid"]
    pf = penalty_layer_estimate(p, h, opts)["p_max_mid_penalty_free"]
    return dict(p_max_mid=p, p_penalty_free=pf, hertz_p0=h.p0, hertz_a=h.a, ratio=p / h.p0, ratio_penalty_free=pf / h.p0,
                nodal_over_force=d["contact"]["pattern"][str(k0)]["nodal_over_force"], rotation_rad=d["pinion_rotation_rad"],
                seconds=time.perf_counter() - t0, date=time.strftime("%Y-%m-%d"))


def main(argv) -> int:
    if "-h" in argv or "--help" in argv or "--torque" not in argv:
        print(__doc__)
        return 0 if ("-h" in argv or "--help" in argv) else 2
    torque = float(argv[argv.index("--torque") + 1])
    level = argv[argv.index("--level") + 1] if "--level" in argv else "fine"
    if level not in {**LEVELS, **VERY_FINE}:
        print(f"fe_point_contact.py: --level {level!r}: expected one of {', '.join({**LEVELS, **VERY_FINE})}",
              file=sys.stderr)
        return 2
    out = run(torque, level)
    print(json.dumps(out))
    rec = json.loads(RECORD.read_text()) if RECORD.exists() else {}
    rec.setdefault(level, {})[f"{torque:g}"] = out
    RECORD.parent.mkdir(parents=True, exist_ok=True)
    RECORD.write_text(json.dumps(rec, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
