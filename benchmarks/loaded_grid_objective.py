"""The loaded optimiser's objective (the weighted loaded TE peak-to-peak) of each design of a
loaded_microgeometry scene's results over finer and finer grids of positions: how far the NLP's sampled
peak-to-peak (``positions`` per mesh cycle) lies from the verified one (``verify_positions``) and from
a finer grid, and whether two designs' order changes with the grid (docs/loaded_synthesis.md section 7).

    python -m gearopt run problems/microgeometry_pareto.toml --out /tmp/pareto
    python benchmarks/loaded_grid_objective.py problems/microgeometry_pareto.toml /tmp/pareto/results.json
    python benchmarks/loaded_grid_objective.py SCENE RESULTS --neighbours full_gear --grids 12,24,48,96

Every design of the results is evaluated: the Pareto front's points (``pareto.points[].theta_um``) or
else the scene's optimum (``design.theta_um``), by the scene's own optimiser (``opt.check``: exact
loaded TCA at every torque and case). ``--neighbours`` sets ``LTCASettings.neighbours`` of the
optimiser's loaded TCA (default: the library's default).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from gearopt.io.scene import load_scene
from gearopt.ltca.engine import LTCA


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene", help="the scene file (.toml) the results were written by")
    ap.add_argument("results", help="its results.json")
    ap.add_argument("--grids", default="12,24,48,96", help="positions per mesh cycle, comma-separated")
    ap.add_argument("--neighbours", choices=("full_gear", "none"), default=None,
                    help="LTCASettings.neighbours of the optimiser's loaded TCA (default: the library's)")
    a = ap.parse_args(argv)
    opt = load_scene(Path(a.scene)).build().optimizer
    if a.neighbours is not None:
        opt.ltca = LTCA(opt.pair, dataclasses.replace(opt.ltca.settings, neighbours=a.neighbours),
                        material=opt.material, tca=opt.tca)
    res = json.loads(Path(a.results).read_text())
    if res.get("pareto"):
        designs = [(str(p["p_limit_MPa"]), p["theta_um"]) for p in res["pareto"]["points"] if p["feasible"]]
    else:
        designs = [("optimum", res["design"]["theta_um"])]
    grids = [int(v) for v in a.grids.split(",")]
    print(f"neighbours {opt.ltca.neighbours}; weighted loaded TE [arcsec] (largest peak pressure [MPa]) over n positions")
    print("design | amounts [um] | " + " | ".join(f"n = {n}" for n in grids))
    for name, th in designs:
        theta = np.array([th[k] for k in opt.free]) * 1e-3
        row = []
        for n in grids:
            c = opt.check(theta, opt.ltca.mesh_cycle(n))
            row.append(f"{c.objective:.3f} ({np.max(c.p_max):.0f})")
        print(f"{name} | {' / '.join(f'{v * 1e3:.2f}' for v in theta)} | " + " | ".join(row), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
