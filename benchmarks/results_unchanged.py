"""Check that a change leaves every scene's results unchanged: run the scenes at a base git revision
and at the working tree, then compare their ``results.json`` with :mod:`compare_results`.

    python benchmarks/results_unchanged.py --base main                 # every problems/*.toml
    python benchmarks/results_unchanged.py --base HEAD~3 ltca_spur tca_helical --rtol 0
    python benchmarks/results_unchanged.py --base-dir /tmp/base        # reuse outputs of an earlier run

The base revision is checked out into a temporary git worktree (removed afterwards) and each scene is
run there and here with ``python -m gearopt run SCENE --out DIR --quiet``, the package imported from
the respective tree (``PYTHONPATH``). ``--base-dir`` takes base outputs written earlier
(``DIR/<scene>/results.json``) instead. Outputs go to ``--work`` (default a new temporary folder,
printed). Wall times, dates and versions are not compared (``compare_results.IGNORE``).

Prints one line per scene (numbers compared, largest relative difference, run times base/here) and
exits 0 when every scene matches within ``--rtol`` (default 0: bit-identical, which is what a pure
restructuring gives on one machine), 1 when some scene differs or fails to run, 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from compare_results import IGNORE, compare  # noqa: E402 (a sibling script, not a package)


def run_scene(tree: Path, scene: str, out: Path) -> tuple[int, float, str]:
    """Run ``tree/problems/<scene>.toml`` with the package of ``tree``; returns (rc, seconds, stderr tail)."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "gearopt", "run", f"problems/{scene}.toml", "--out", str(out), "--quiet"],
                       cwd=tree, env=env, capture_output=True, text=True)
    return p.returncode, time.perf_counter() - t, p.stderr.strip()[-400:]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", help="scene names (default: every problems/*.toml)")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--base", help="git revision to compare against (checked out into a temporary worktree)")
    g.add_argument("--base-dir", help="folder with base outputs <scene>/results.json written earlier")
    ap.add_argument("--work", help="folder for the outputs (default: a new temporary folder)")
    ap.add_argument("--rtol", type=float, default=0.0, help="largest relative difference accepted (default 0)")
    ap.add_argument("--floor", type=float, default=1e-12,
                    help="smallest denominator of a relative difference: values near zero compare absolutely "
                         "(CalculiX's zero reaction forces vary by ~1e-10 N run to run; --rtol 1e-9 --floor 1 ignores that)")
    ap.add_argument("--show", type=int, default=5, help="mismatches shown per scene (default 5)")
    a = ap.parse_args(argv)
    if not a.rtol >= 0 or not a.floor > 0:
        ap.error(f"--rtol = {a.rtol!r} must be >= 0 and --floor = {a.floor!r} > 0")
    known = sorted(p.stem for p in (ROOT / "problems").glob("*.toml"))
    scenes = a.scenes or known
    unknown = [s for s in scenes if s not in known]
    if unknown:
        ap.error(f"unknown scene(s) {unknown}; known: {', '.join(known)}")
    work = Path(a.work) if a.work else Path(tempfile.mkdtemp(prefix="gearopt-unchanged-"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"outputs in {work}")
    tree = None
    if a.base:
        tree = work / "base-tree"
        if tree.exists():
            print(f"results_unchanged: {tree} exists; pass an empty --work", file=sys.stderr)
            return 2
        r = subprocess.run(["git", "worktree", "add", "--detach", str(tree), a.base], cwd=ROOT,
                           capture_output=True, text=True)
        if r.returncode:
            print(f"results_unchanged: git worktree add {a.base!r} failed: {r.stderr.strip()}", file=sys.stderr)
            return 2
    ignore = [re.compile(r) for r in IGNORE]
    ok = True
    try:
        for s in scenes:
            tb = 0.0
            if tree is not None:
                base_out = work / "base" / s
                rc, tb, err = run_scene(tree, s, base_out)
                if rc:
                    print(f"{s}: the base run failed (rc {rc}): {err}")
                    ok = False
                    continue
            else:
                base_out = Path(a.base_dir) / s
            rc, th, err = run_scene(ROOT, s, work / "head" / s)
            if rc:
                print(f"{s}: the run of the working tree failed (rc {rc}): {err}")
                ok = False
                continue
            fa, fb = base_out / "results.json", work / "head" / s / "results.json"
            if not fa.exists():
                print(f"{s}: no base results.json in {base_out}")
                ok = False
                continue
            n, worst, where, bad = compare(json.loads(fa.read_text()), json.loads(fb.read_text()), a.rtol, a.floor, ignore)
            ok &= not bad
            print(f"{s}: {n} numbers, largest relative difference {worst:.3g}" + (f" at {where}" if where else "")
                  + (f", {len(bad)} MISMATCHES" if bad else ", match") + f"  [{tb:.1f} s base, {th:.1f} s here]",
                  flush=True)
            for m in bad[:a.show]:
                print(f"    {m}")
    finally:
        if tree is not None:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, capture_output=True)
    print("every scene matches" if ok else "SOME SCENES DIFFER")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
