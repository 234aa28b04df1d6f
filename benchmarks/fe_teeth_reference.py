"""The CalculiX contact model with 5 teeth per member at the 15 validation positions (docs/ltca.md section 7,
"The 5-tooth reference"): resumable, one position per run, recorded as soon as it is done.

    python benchmarks/fe_teeth_reference.py                 # every position not yet recorded, in the order below
    python benchmarks/fe_teeth_reference.py --list          # the queue and what is recorded (no CalculiX)
    python benchmarks/fe_teeth_reference.py --worker 0/2    # every second position of the queue from the first
                                                             # (two processes share the queue, one record)

The FE level is validate_ltca_fe.py's default (its ``FE_MESH``), 200 N m, E 210 GPa, nu 0.3, with
``FEOptions(teeth=5)``: each member a sector of 5 teeth held at the sides of its outer teeth and its rim bottom,
so that no loaded pair sits on an outer tooth next to a held side (with 3 teeth per member the pair other than the
pitch pair always does). Each run takes 10-30 minutes of CalculiX on a loaded machine (4-8 idle). The records
(validate_ltca_fe.fe_record's fields, every pair's share included) go to
benchmarks/data/fe_reference_teeth5.json as ``{"default": {drive: {position: record}}}``, read by
``fe_full_gear_body.py --validate --teeth 5 --recorded``. The queue is ordered by value: the two-pair positions
first (where the 3-tooth sector biased the reference), then the three-pair ones, the single-pair ones last.
"""

from __future__ import annotations

import fcntl
import json
import math
import sys
import time

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from validate_ltca_fe import FE_MESH, ROOT, T, drives, fe_record  # noqa: E402

from gearopt.fea import FEOptions, GearFEModel  # noqa: E402

RECORD_TEETH = {5: ROOT / "benchmarks" / "data" / "fe_reference_teeth5.json"}
LEVEL = "default"

# (drive, position in pinion pitches): two pairs in mesh, three pairs, one pair
QUEUE = (
    ("spur crowned", "+0.3"), ("spur crowned", "-0.3"),
    ("scene ltca_helical (crowned)", "+0.3"), ("helical 15 deg", "-0.3"),
    ("scene ltca_crowned (crossing 3')", "+0.3"), ("scene ltca_crowned (crossing 3')", "-0.3"),
    ("spur 20/40 conjugate", "-0.3"), ("spur 20/40 conjugate", "+0.3"), ("helical 15 deg", "+0.3"),
    ("helical 15 deg", "0"), ("scene ltca_helical (crowned)", "0"), ("scene ltca_helical (crowned)", "-0.3"),
    ("spur 20/40 conjugate", "0"), ("spur crowned", "0"), ("scene ltca_crowned (crossing 3')", "0"),
)


def read_record(teeth: int = 5) -> dict:
    """The recorded runs with ``teeth`` teeth per member ({} when none)."""
    path = RECORD_TEETH[teeth]
    return json.loads(path.read_text()) if path.exists() else {}


def add_record(teeth: int, name: str, frac: str, rec: dict) -> None:
    """Add one run to the record, re-reading it under a lock (two workers write the same file)."""
    path = RECORD_TEETH[teeth]
    with open(path.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        data = read_record(teeth)
        data.setdefault("_about", "CalculiX contact model (GearFEModel.run) with 5 teeth per member at "
                        "validate_ltca_fe.py's positions and default level, 200 N m, E 210 GPa, nu 0.3; written by "
                        "benchmarks/fe_teeth_reference.py")
        data.setdefault(LEVEL, {}).setdefault(name, {})[frac] = rec
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(data, indent=1) + "\n")
        tmp.replace(path)


def main(argv) -> int:
    teeth = 5
    done = read_record(teeth).get(LEVEL, {})
    queue = [q for q in QUEUE if q[1] not in done.get(q[0], {})]
    if "--list" in argv:
        for name, frac in QUEUE:
            rec = done.get(name, {}).get(frac)
            print(f"{name:<34} {frac:>5} " + (f"approach {rec['approach_um']:.3f} um ({rec['date']})" if rec else "-"))
        return 0
    if "--worker" in argv:
        i, n = (int(v) for v in argv[argv.index("--worker") + 1].split("/"))
        queue = queue[i::n]
    for name, frac in queue:
        if frac in read_record(teeth).get(LEVEL, {}).get(name, {}):
            continue
        pair, mis = drives()[name]
        ph = float(frac) * 2 * math.pi / pair.pinion.z
        t0 = time.process_time()
        w0 = time.perf_counter()
        opts = FEOptions(torque=T * 1e3, E=210e3, nu=0.3, mesh=FE_MESH, teeth=teeth, threads=1, timeout=3 * 3600.0)
        d = GearFEModel(pair, ph, opts, mis=mis).run().to_dict()
        rec = fe_record(d, pair)
        rec["teeth"] = teeth
        rec["wall_s"] = round(time.perf_counter() - w0, 1)
        add_record(teeth, name, frac, rec)
        print(f"{name} {frac}: approach {rec['approach_um']:.3f} um, shares {rec['shares']}, "
              f"{rec['wall_s']:.0f} s wall ({time.process_time() - t0:.0f} s CPU in Python)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
