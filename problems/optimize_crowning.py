"""Optimize pinion crowning from a script: copy this file and change the drive, target and cases.

Run:  .venv/bin/python problems/optimize_crowning.py [--out DIR] [--quiet]

It optimizes the profile crowning (parabolic rack-cutter, a_c) and the longitudinal crowning
(plunging, a_pl) of a helical pinion for an 8 arcsec parabolic TE over crossing/intersecting
misalignments of +-3 arcmin and their combination, prints a table and writes the plots of the
crowning study (before_after_te.png, before_after_contact_gear.png, before_after_contact_pinion.png:
the TE and the bearing contact before and after, for every case) in gearopt's plot style.
"""

from __future__ import annotations

import argparse
import os
import sys

from gearopt.errors import GearoptError
from gearopt.io.results import check_out_dir, write_results
from gearopt import ARCMIN, ARCSEC, CrowningStudy, Gear, GearPair, deg, misalignment_cases
from gearopt.synthesis import CrowningTarget


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/optimize_crowning", help="output folder for the plots")
    ap.add_argument("--quiet", action="store_true", help="no progress output")
    args = ap.parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files, never to a window
    say = (lambda m: None) if args.quiet else (lambda m: print(m, file=sys.stderr))
    try:
        out = check_out_dir(args.out)  # before the work: a directory of the user's own files is refused
    except GearoptError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    # 1. The drive (unmodified pinion: the "before" design).
    pair = GearPair(Gear(z=21, m_n=2.5, b=30, beta=deg(18), hand="right", name="pinion"),
                    Gear(z=53, m_n=2.5, b=30, beta=deg(18), hand="left", name="gear"))
    # 2. What it must do, and under which misalignments.
    target = CrowningTarget(te_level=8 * ARCSEC, ellipse_share=0.25, edge_margin=1.0)  # 1 mm from the face ends
    cases = misalignment_cases(crossing=3 * ARCMIN, intersecting=3 * ARCMIN, combined=True)
    # 3. Optimize and verify every case with an independent TCA sweep (with edge contact).
    study = CrowningStudy(pair, target, cases, positions=41, name="optimize_crowning")
    report = study.run(progress=say)
    d = report.design
    print(f"IPOPT: {d['status']} in {d['iterations']} iterations; NLP build {d['nlp_build_s']:.2f} s, "
          f"solve {d['nlp_solve_s']:.3f} s")
    print(f"a_c = {d['settings']['a_c']:.6g} 1/mm (profile crowning), a_pl = {d['settings']['a_pl']:.6g} 1/mm "
          "(plunging)\n")
    print(f"{'case':18s} {'before: p-p TE':>15s} {'edge':>5s} {'after: p-p TE':>14s} {'edge':>5s}")
    for b, a in zip(report.before, report.after):
        print(f"{b['label']:18s} {b['peak_to_peak_arcsec']:13.3f}\" {'YES' if b['edge_carries_load'] else 'no':>5s} "
              f"{a['peak_to_peak_arcsec']:12.3f}\" {'YES' if a['edge_carries_load'] else 'no':>5s}")
    print("\nSensitivity of the TE level [arcsec per arcmin of misalignment], aligned design:")
    s = d["sensitivities"]["aligned"]  # already in arcsec per arcmin (design["sensitivity_units"])
    print("  " + ", ".join(f"{k}: {s[k]:+.4f}" for k in ("mis.crossing", "mis.intersecting")))
    # 4. Plots: TE and bearing contact before/after, every case (the crowning study's figures).
    # results.json and the plots, in gearopt's plot style; like `gearopt run`, never over a file
    # gearopt did not write (the directory was checked before the work)
    for f in write_results(out, report):
        print(f"wrote {f}")


if __name__ == "__main__":
    sys.exit(main())
