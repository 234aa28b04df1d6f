"""Micro-geometry optimisation under load (docs/loaded_synthesis.md) against a grid search of the
kind commercial tools run, in one run, on the same objective.

The drive and duty cycle of problems/optimize_microgeometry.py: 20/40 spur, 4 free pinion amounts
(C_alpha, C_beta, C_alpha_a, C_alpha_f, 0 ... 40 um), 100 and 250 N m x aligned and 2 arcmin crossing,
no edge loading. Both are scored on the optimiser's final grid of positions by the exact loaded TCA,
with the same merit: the weighted loaded-TE peak-to-peak plus the exact penalty of edge loading
(`LoadedMicroOptimizer._merit`, the weight the optimiser ended with).

    python benchmarks/bench_loaded_synthesis.py              # grid of 5^4 = 625 designs, about 6 minutes
    python benchmarks/bench_loaded_synthesis.py --levels 3   # 81 designs, about 1 minute
    python benchmarks/bench_loaded_synthesis.py --duty target   # the issue's target, about 10 minutes
    python benchmarks/bench_loaded_synthesis.py --search de     # scipy's differential evolution instead

``--search de``: scipy.optimize.differential_evolution on the same merit (population 15 x 4, seed 0,
no gradient polish, ``--de-maxiter`` generations: 600 designs with the default 9, the grid's budget).

``--duty target``: the issue's target duty cycle on the same drive and free amounts: 100, 200, 300
N m x 5 misalignment cases (aligned, crossing +-2', intersecting +-2'), 12 positions (24 to verify).
The grid search, like the optimiser, solves one case of each mirror-image pair (the same merit at
every design of this grid, docs/loaded_synthesis.md section 5): 3 loaded-TCA evaluations per design.

Prints a markdown table: objective reached, edge load, loaded-TCA evaluations, wall time.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, default=5, help="grid levels per amount (default 5)")
    ap.add_argument("--duty", choices=("script", "target"), default="script",
                    help="duty cycle: that of problems/optimize_microgeometry.py (default) or the issue's target")
    ap.add_argument("--search", choices=("grid", "de", "both"), default="grid",
                    help="derivative-free search: the grid (default), scipy's differential evolution, or both")
    ap.add_argument("--de-maxiter", type=int, default=9, help="differential evolution: generations (default 9)")
    args = ap.parse_args(argv)

    from gearopt.meshing.misalignment import Misalignment
    from gearopt.studies.crowning import misalignment_cases
    from gearopt.synthesis.loaded import LoadedMicroOptimizer
    from gearopt.units import ARCMIN
    from test_loaded_synthesis import FREE, drive

    def make():
        if args.duty == "target":
            cases = list(misalignment_cases(crossing=2 * ARCMIN, intersecting=2 * ARCMIN).values())
            return LoadedMicroOptimizer(drive(), FREE, torques=[100.0, 200.0, 300.0], cases=cases,
                                        n_positions=12, n_verify=24, n_slices=11)
        return LoadedMicroOptimizer(drive(), FREE, torques=[100.0, 250.0],
                                    cases=[Misalignment(), Misalignment(crossing=2 * ARCMIN)],
                                    n_positions=16, n_verify=32, n_slices=11)

    opt = make()
    calls = {"n": 0}
    solve_one = opt.ltca.solve

    def counted(*a, **k):  # one loaded-TCA evaluation = one design x one case, every torque
        calls["n"] += 1
        return solve_one(*a, **k)

    opt.ltca.solve = counted
    t0 = time.perf_counter()
    d = opt.solve()
    t_opt = time.perf_counter() - t0
    n_opt = calls["n"]
    rho = d.rho  # the penalty weight the optimiser ended with
    phi = opt.phi1  # the optimiser's final grid
    best_opt = opt._merit(opt.check(np.array(list(d.theta.values())), phi), rho)

    red = opt._reduced()  # one case per mirror-image pair, as the optimiser's loop (the same merit)
    searches = []  # (name, merit, design, check, evaluations, time)

    def scored(th):
        chk = red.check(th, phi)
        return red._merit(chk, rho), chk

    if args.search in ("grid", "both"):
        calls["n"] = 0
        levels = np.linspace(0.0, 1.0, args.levels)
        t0 = time.perf_counter()
        best = (np.inf, None, None)
        for combo in itertools.product(levels, repeat=len(opt.free)):
            th = opt.lo + np.array(combo) * (opt.hi - opt.lo)
            m, chk = scored(th)
            if m < best[0]:
                best = (m, th, chk)
        searches.append((f"grid {args.levels}^{len(opt.free)}", *best, calls["n"], time.perf_counter() - t0))
    if args.search in ("de", "both"):
        from scipy.optimize import differential_evolution

        calls["n"] = 0
        seen = {}

        def merit(th):
            m, chk = scored(np.asarray(th, float))
            seen[tuple(th)] = (m, chk)
            return m

        t0 = time.perf_counter()
        res = differential_evolution(merit, list(zip(opt.lo, opt.hi)), maxiter=args.de_maxiter, popsize=15, seed=0,
                                     polish=False, init="latinhypercube")
        t_de = time.perf_counter() - t0
        m, chk = seen[tuple(res.x)]
        searches.append((f"differential evolution ({res.nit} generations, {res.nfev} designs)", m, np.asarray(res.x),
                         chk, calls["n"], t_de))
    chk_opt = red.check(np.array(list(d.theta.values())), phi)
    for name, m, th, _, _, _ in searches:
        if red is not opt:  # each search's best design scored on the full duty cycle too (the same merit)
            full = opt._merit(opt.check(th, phi), rho)
            if not np.isclose(full, m, rtol=1e-9, atol=1e-9):
                raise RuntimeError(f"{name}: the mirror-reduced merit {m} differs from the full one {full}")
    print(f"grid of positions: {phi.size} per cycle; cases x torques: {len(opt.cases)} x {opt.torques.size}; "
          f"penalty weight {rho:g}\n")
    print("| method | merit [arcsec] | weighted TE p-p [arcsec] | largest edge load [% of W] | design C_alpha / C_beta / "
          "C_alpha_a / C_alpha_f [um] | loaded-TCA evaluations (design x case) | wall time [s] |")
    print("|---|---|---|---|---|---|---|")
    for name, m, th, chk, n, t in [("trust-region NLP (AD)", best_opt, np.array(list(d.theta.values())), chk_opt,
                                    n_opt, t_opt)] + searches:
        print(f"| {name} | {m:.2f} | {chk.objective:.2f} | {100 * chk.edge_load.max():.3g} | "
              f"{' / '.join(f'{v * 1e3:.2f}' for v in th)} | {n} | {t:.1f} |")
    print()
    for name, m, _, _, n, t in searches:
        print(f"{name}: evaluations / NLP's = {n / max(n_opt, 1):.1f}; time / NLP's = {t / t_opt:.2f}; "
              f"merit - NLP's = {m - best_opt:+.2f} arcsec")
    return 0


if __name__ == "__main__":
    sys.exit(main())
