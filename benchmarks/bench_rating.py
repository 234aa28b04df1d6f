"""ISO 6336 rating (gearopt.rating): the ISO/TR 6336-30:2017 example 1 factor by factor, and run times
(run: `PYTHONPATH=. python benchmarks/bench_rating.py`, ~30 s).

1. The TR's example 1 (single helical case-carburized pair, m_n 8 mm, z 17/103; inputs and published
   values of tests/test_rating_iso.py, the one place they are written): computed against published,
   with the relative deviation, every factor the TR publishes.
2. The wall time of one ``rate()`` call (median of 200) on that example.
3. The rating study on problems/rating_spur.toml (six torques): the ISO-only rating of all its torques
   (the study's ``rate`` at each, ISO's load factors) against the study's ``run()`` (the loaded TCA of
   the pair and of the reference pair at every torque, then the rating with its load factors), and
   their ratio, measured in the same process.

Exit status 1 when a factor deviates from the published value by more than 0.5 % (the tolerance of
tests/test_rating_iso.py::test_tr_6336_30_example_1).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_rating_iso import PUBLISHED, tr_example_1  # noqa: E402  (the TR's inputs and published values)

TOL = 5e-3


def tr_table() -> int:
    """Print the TR example's computed against published factors; return the number above TOL."""
    r = tr_example_1()
    print("ISO/TR 6336-30:2017 example 1 (m_n 8 mm, z 17/103, beta 15.8 deg, T1 9 kN m, 360 1/min)")
    print(f"{'symbol':<14}{'member':<8}{'published':>14}{'gearopt':>14}{'deviation':>12}")
    bad = 0
    for sym, i, ref in PUBLISHED:
        v = r[sym]
        v = v[i] if i is not None else (v[0] if isinstance(v, tuple) else v)
        dev = v / ref - 1
        bad += abs(dev) > TOL
        member = "" if i is None else ("pinion" if i == 0 else "wheel")
        print(f"{sym:<14}{member:<8}{ref:>14.6g}{v:>14.6g}{100 * dev:>+11.3f}%{'  > 0.5 %' if abs(dev) > TOL else ''}")
    print(f"{len(PUBLISHED)} published values, {bad} beyond {100 * TOL:.1f} %")
    return bad


def rate_time(n: int = 200) -> float:
    """Median wall time of one ``rate()`` call on the TR example [s]."""
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        tr_example_1()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def study_times() -> dict:
    """Times of the rating study on problems/rating_spur.toml [s]: scene load and study set-up, the
    ISO-only rating of its torques, and ``run()`` (loaded TCA + rating)."""
    from gearopt.io.scene import load_scene

    t0 = time.perf_counter()
    scene = load_scene(ROOT / "problems" / "rating_spur.toml")
    study = scene.build()
    t1 = time.perf_counter()
    for t in [*study.torques, study.torque]:
        study.rate(t)
    t2 = time.perf_counter()
    study.run()
    t3 = time.perf_counter()
    return {"setup_s": t1 - t0, "iso_s": t2 - t1, "run_s": t3 - t2, "n_torques": len(study.torques) + 1}


def main() -> int:
    bad = tr_table()
    print(f"\none rate() call (TR example 1): {1e3 * rate_time():.2f} ms (median of 200)")
    s = study_times()
    print(f"\nrating study, problems/rating_spur.toml ({s['n_torques']} ratings):")
    print(f"  scene load + study set-up (generated tooth forms, ISO at every torque): {s['setup_s']:.2f} s")
    print(f"  ISO-only rating of the torques:                                        {s['iso_s']:.3f} s")
    print(f"  run() with the loaded TCA (pair and reference pair, every torque):     {s['run_s']:.2f} s")
    print(f"  ratio run() with LTCA / ISO-only:                                      {s['run_s'] / s['iso_s']:.0f}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
