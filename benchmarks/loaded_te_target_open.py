"""An open case of the loaded micro-geometry optimiser (docs/loaded_synthesis.md section 6), kept out of
the test suite (it was a strict xfail there, a minute of every run): the unloaded-TE target at weight 1
with every edge held open (the drive and duty cycle of tests/test_loaded_synthesis.py).

Open since 2026-11-28 (the bodies coupled over their depth, the slices fixed to the tooth): the loop
converges (step below THETA_TOL) on its trust-region NLP, but the sensitivities' NLP around the design
with every slice and no radius finds its optimum about 22 um away (``model_step``; the study warns,
``at_design`` False), so there is no derivative of the design to check. The same target at weight 0.1
with edge loading allowed is tested (tests/test_loaded_synthesis_objectives.py::
test_sensitivities_with_the_unloaded_te_target_match_finite_differences).

    python benchmarks/loaded_te_target_open.py            # about a minute alone on one core
    python benchmarks/loaded_te_target_open.py --strict   # exit status 1 while the case is open

Prints the optimum, the loop's stop and the sensitivities' ``model_step``; when the NLP's optimum is at
the design, also checks the AD sensitivities against central differences of the re-solved NLP (as the
tests do). With ``--strict`` the exit status is 1 while the case is open (``model_step`` above 1e-4 mm,
or the check fails; without it 0, so that ``make bench`` runs on), 0 when it is fixed: then the test
belongs back in tests/test_loaded_synthesis_objectives.py.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--strict", action="store_true", help="exit status 1 while the case is open")
    strict = ap.parse_args(argv).strict
    sys.path.insert(0, str(ROOT / "tests"))
    from test_loaded_synthesis import assert_sensitivities_match_finite_differences, optimizer

    from gearopt.units import RAD_TO_ARCSEC

    t0 = time.perf_counter()
    opt = optimizer(te_level=8.0 / RAD_TO_ARCSEC, te_weight=1.0)
    design = opt.solve()
    sens = opt.sensitivities(design)
    print(f"optimum {design.theta_um()} um, stop {design.stop!r}; sensitivities: model_step "
          f"{sens['model_step'] * 1e3:.3f} um, at_design {sens['at_design']}, degenerate {sens['degenerate']} "
          f"({time.perf_counter() - t0:.1f} s)")
    if sens["model_step"] >= 1e-4:
        print("open: the NLP's optimum lies away from the design; no derivative of the design to check")
        return int(strict)
    try:
        assert sens["degenerate"] == 0
        assert_sensitivities_match_finite_differences(opt, sens)
    except AssertionError as e:
        print(f"open: the sensitivities do not match central differences: {e}")
        return int(strict)
    print("fixed: the sensitivities match central differences; move the test back into the suite")
    return 0


if __name__ == "__main__":
    sys.exit(main())
