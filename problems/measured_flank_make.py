"""Make the measured flanks of problems/measured_flank.toml.

Run (from the repository root, with the venv `make` creates, where gearopt is installed):
`.venv/bin/python problems/measured_flank_make.py`

A stand-in for a measuring machine's report: the pinion of problems/microgeometry_helical.toml as
designed (C_alpha 6 um, C_beta 12 um, tip relief 8 um from d_Ca = 59.2 mm), inspected on both
flanks over 121 roll lengths (form circle to tip) x 21 face positions, plus deterministic
manufacturing deviations of the kind a gear grinder leaves:

* a helix slope deviation f_H_beta = +2.0 um on the right flank and -1.0 um on the left (ISO
  transverse, + = more material towards face II),
* a profile form deviation: a bulge of 0.3 um (half a sine wave over the measured roll length),

written as gearopt topography CSVs (docs/microgeometry.md) beside the scene. Deterministic: the
same files every run.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

try:  # gearopt as an installed package (`make venv`: pip install -e .), not a path relative to here
    import numpy as np

    from gearopt.geometry.inspection import FlankGrid, inspect_flank, write_grid_csv
    from gearopt.geometry.microgeometry import modified_tooth
    from gearopt.io.scene import load_scene
except ModuleNotFoundError as e:
    if e.name not in ("gearopt", "numpy"):
        raise
    sys.exit(f"{Path(__file__).name}: gearopt is not installed in this Python ({sys.executable}); run `make venv`, "
             f"then `.venv/bin/python problems/measured_flank_make.py` from the repository root.")

HERE = Path(__file__).resolve().parent
SLOPE_UM = {"right": 2.0, "left": -1.0}
BULGE_UM = 0.3


def main():
    pair = load_scene(HERE / "microgeometry_helical.toml").pair
    tooth = modified_tooth(pair, "pinion")
    g = pair.pinion
    for side in ("right", "left"):
        grid = inspect_flank(tooth, side, n_profile=121, n_face=21, member="pinion")
        L, z = np.array(grid.s), np.array(grid.z)
        bulge = np.sin(math.pi * (L - L[0]) / (L[-1] - L[0]))
        extra = 1e-3 * (SLOPE_UM[side] * z[None, :] / g.b + BULGE_UM * bulge[:, None])
        out = FlankGrid(side=side, profile=grid.profile, s=grid.s, z=grid.z,
                        deviation=tuple(map(tuple, grid.values() + extra)), member="pinion")
        print(write_grid_csv(out, HERE / f"measured_flank_{side}.csv"))


if __name__ == "__main__":
    main()
