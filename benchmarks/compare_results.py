"""Compare two trees of gearopt results (``results.json`` files) numerically.

Every ``results.json`` under A is paired with the file of the same relative path under B; the two
JSON documents are walked together and every pair of numbers is compared by its relative difference
``|a - b| / max(|a|, |b|, floor)``. Keys whose values are not results of the computation (wall
times, dates, versions, paths: ``--ignore``) are skipped. Integers (IPOPT iteration counts, sizes)
must be equal. Strings, booleans and the structure (keys, list lengths) must match.

    python benchmarks/compare_results.py A B                  # exit 0: every number within --rtol
    python benchmarks/compare_results.py A B --rtol 1e-9 --show 10

Prints, per file, the number of values compared, the largest relative difference and where it is;
then the mismatches (at most ``--show``). Exit status 0 when every file matches within ``--rtol``,
1 when some value differs, 2 on bad arguments (a missing tree, no results.json in A).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path

#: keys not compared by default: wall times, dates and provenance (regular expressions on the key)
IGNORE = (r"(^|_)time(_s)?$", r"_s$", r"^timing$", r"^meta$", r"^date", r"^version", r"^path$", r"^out(_dir)?$",
          r"^host", r"^wrote$", r"^files$")


def compare(a, b, rtol: float, floor: float, ignore: list, path: str = "") -> tuple[int, float, str, list]:
    """Walk two JSON values together.

    Parameters
    ----------
    a, b : JSON values (dict, list, number, str, bool, None).
    rtol : float
        Largest relative difference accepted for a float.
    floor : float
        Smallest denominator of the relative difference (values near zero compare absolutely).
    ignore : list of compiled patterns
        Dict keys skipped.

    Returns
    -------
    count : int
        Numbers compared.
    worst : float
        Largest relative difference of a float (0 when none).
    where : str
        The path of that value.
    bad : list of str
        Mismatches: structure, strings, integers, floats beyond ``rtol``.
    """
    if isinstance(a, dict) and isinstance(b, dict):
        n, worst, where, bad = 0, 0.0, "", []
        ka, kb = set(a), set(b)
        for k in sorted(ka ^ kb):
            if not any(p.search(k) for p in ignore):
                bad.append(f"{path}/{k}: only in {'A' if k in ka else 'B'}")
        for k in sorted(ka & kb):
            if any(p.search(k) for p in ignore):
                continue
            c, w, wh, bd = compare(a[k], b[k], rtol, floor, ignore, f"{path}/{k}")
            n += c
            bad += bd
            if w > worst:
                worst, where = w, wh
        return n, worst, where, bad
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return 0, 0.0, "", [f"{path}: lengths {len(a)} and {len(b)}"]
        n, worst, where, bad = 0, 0.0, "", []
        for i, (x, y) in enumerate(zip(a, b)):
            c, w, wh, bd = compare(x, y, rtol, floor, ignore, f"{path}[{i}]")
            n += c
            bad += bd
            if w > worst:
                worst, where = w, wh
        return n, worst, where, bad
    if isinstance(a, bool) or isinstance(b, bool) or isinstance(a, str) or isinstance(b, str) or a is None or b is None:
        return 0, 0.0, "", ([] if a == b else [f"{path}: {a!r} and {b!r}"])
    if isinstance(a, int) and isinstance(b, int):
        return 1, 0.0, "", ([] if a == b else [f"{path}: integers {a} and {b}"])
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        fa, fb = float(a), float(b)
        if math.isnan(fa) or math.isnan(fb) or math.isinf(fa) or math.isinf(fb):
            same = (math.isnan(fa) and math.isnan(fb)) or fa == fb
            return 1, 0.0, "", ([] if same else [f"{path}: {fa!r} and {fb!r}"])
        rel = abs(fa - fb) / max(abs(fa), abs(fb), floor)
        return 1, rel, path, ([] if rel <= rtol else [f"{path}: {fa!r} and {fb!r} (relative {rel:.3g})"])
    return 0, 0.0, "", [f"{path}: types {type(a).__name__} and {type(b).__name__}"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", help="first results tree (a folder with results.json files, or one results.json)")
    ap.add_argument("b", help="second results tree, the same layout")
    ap.add_argument("--rtol", type=float, default=1e-9, help="largest relative difference of a float (default 1e-9)")
    ap.add_argument("--floor", type=float, default=1e-12,
                    help="smallest denominator of the relative difference (default 1e-12)")
    ap.add_argument("--ignore", action="append", default=None,
                    help="a regular expression of keys not compared (repeatable; default: times, dates, meta)")
    ap.add_argument("--show", type=int, default=20, help="mismatches shown per file (default 20)")
    a = ap.parse_args(argv)
    if not a.rtol >= 0 or not a.floor > 0:
        ap.error(f"--rtol = {a.rtol!r} must be >= 0 and --floor = {a.floor!r} > 0")
    A, B = Path(a.a), Path(a.b)
    for p, name in ((A, "a"), (B, "b")):
        if not p.exists():
            print(f"compare_results: {name} = {str(p)!r} does not exist", file=sys.stderr)
            return 2
    files = [Path("")] if A.is_file() else sorted(p.relative_to(A) for p in A.rglob("results.json"))
    if not files:
        print(f"compare_results: no results.json under {str(A)!r}", file=sys.stderr)
        return 2
    ignore = [re.compile(r) for r in (IGNORE if a.ignore is None else a.ignore)]
    ok = True
    overall = 0.0
    for rel in files:
        fa, fb = (A / rel, B / rel) if rel != Path("") else (A, B)
        if not fb.exists():
            print(f"{rel}: missing in B")
            ok = False
            continue
        n, worst, where, bad = compare(json.loads(fa.read_text()), json.loads(fb.read_text()), a.rtol, a.floor, ignore)
        overall = max(overall, worst)
        print(f"{rel or fa.name}: {n} numbers, largest relative difference {worst:.3g}"
              + (f" at {where}" if where else "") + (f", {len(bad)} mismatches" if bad else ", match"))
        for m in bad[:a.show]:
            print(f"    {m}")
        ok &= not bad
    print(f"largest relative difference over all files: {overall:.3g} ({'match' if ok else 'MISMATCH'}, rtol {a.rtol:g})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
