"""Optimise a pinion's micro-geometry for the loaded TE from a script: copy this file and change the
drive, the duty cycle and the free amounts.

Run:  .venv/bin/python problems/optimize_microgeometry.py [--out DIR] [--quiet]

It chooses the profile crowning, lead crowning, tip relief and root relief of a 20/40 spur pinion
(ISO 21771 amounts, 0 ... 40 um each) that minimise the loaded TE peak-to-peak at 100 and 250 N m,
aligned and with a 2 arcmin crossing of the axes, with no edge loading (every tip edge and face end
open by 0.5 um under load). It prints the design and the loaded TE before and after, verified by
independent loaded TCA sweeps, and writes the before/after plots (docs/loaded_synthesis.md).
"""

from __future__ import annotations

import argparse
import os
import sys

from gearopt.errors import GearoptError
from gearopt.io.results import check_out_dir, write_results
from gearopt import ARCMIN, Gear, GearPair, LoadedMicroStudy, Microgeometry, misalignment_cases

UM = 1e-3  # mm


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/optimize_microgeometry", help="output folder for the plots")
    ap.add_argument("--quiet", action="store_true", help="no progress output")
    args = ap.parse_args(argv)
    os.environ.setdefault("MPLBACKEND", "Agg")  # the plots go to files, never to a window
    say = (lambda m: None) if args.quiet else (lambda m: print(m, file=sys.stderr))
    try:
        out = check_out_dir(args.out)  # before the work: a directory of the user's own files is refused
    except GearoptError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    # 1. The drive and its start design: light crowning, the reliefs' starts given, amounts zero.
    start = Microgeometry(C_alpha=5 * UM, C_beta=10 * UM, d_Ca=64.0, d_Cf=58.5)
    pair = GearPair(Gear(z=20, m_n=3.0, b=20, name="pinion", modifications=start), Gear(z=40, m_n=3.0, b=20, name="gear"))
    # 2. The free amounts with their manufacturing bounds [mm], the duty cycle, the limits.
    free = {f"pinion.{a}": (0.0, 40 * UM) for a in ("C_alpha", "C_beta", "C_alpha_a", "C_alpha_f")}
    cases = {k: v for k, v in misalignment_cases(crossing=2 * ARCMIN).items() if not k.startswith("crossing -")}
    study = LoadedMicroStudy(pair, free, torque=250.0, torques=[100.0, 250.0], cases=cases, edge_margin=0.5 * UM,
                             n_positions=16, n_verify=32, n_slices=11, name="optimize_microgeometry")
    # (Litvin's unloaded parabolic TE as a second term of the objective: add te_level=8 * ARCSEC,
    # te_weight=1.0 above; docs/loaded_synthesis.md section 9.)
    # 3. Optimise, verify with independent loaded TCA sweeps, plot.
    report = study.run(progress=say)
    d = report.design
    print(f"{len(d['rounds'])} trust-region rounds, {d['iterations']} IPOPT iterations, {d['time_s']:.1f} s")
    print("amount      start [um]   optimum [um]")
    for k in d["theta_um"]:
        print(f"{k:18s} {d['theta0_um'][k]:8.2f} {d['theta_um'][k]:12.2f}")
    print(f"\nNLP vs independent loaded TCA: {d['error']['te_pp']:.2g} arcsec")
    print(f"{'case':14s} {'torque':>7s} {'p-p before':>11s} {'p-p after':>10s} {'edge load before':>17s} {'after':>6s}")
    for c, case in enumerate(report.cases):
        for t, T in enumerate(report.torques):
            b, a = d["before"], d["after"]
            print(f"{case['name']:14s} {T:7.0f} {b['te_pp_arcsec'][t][c]:10.2f}\" {a['te_pp_arcsec'][t][c]:9.2f}\" "
                  f"{100 * b['edge_share'][t][c]:16.1f}% {100 * a['edge_share'][t][c]:5.1f}%")
    sens = d["sensitivities"]  # of the optimum, by AD (docs/loaded_synthesis.md section 6)
    print("\nsensitivity of the optimum      objective [arcsec]   " + "  ".join(f"{k.split('.')[1]:>10s}" for k in d["theta_um"]))
    for t, T in enumerate(report.torques):
        print(f"per N m at {T:5.0f} N m        {sens['objective_arcsec_per_Nm'][t]:12.4f}        "
              + "  ".join(f"{sens['theta_um_per_Nm'][k][t]:10.4f}" for k in d["theta_um"]) + "  [um]")
    print(f"per arcmin of crossing         {sens['objective_arcsec_per_mis']['crossing_arcmin']:12.4f}        "
          + "  ".join(f"{sens['theta_um_per_mis'][k]['crossing_arcmin']:10.4f}" for k in d["theta_um"]) + "  [um]")
    print(f"(at {sens['active']} active constraints and bounds, {sens['degenerate']} degenerate)")
    # results.json and the plots, in gearopt's plot style; like `gearopt run`, never over a file
    # gearopt did not write (the directory was checked before the work)
    for f in write_results(out, report):
        print(f"wrote {f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
