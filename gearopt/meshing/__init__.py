"""Meshing and tooth contact analysis (TCA), Litvin & Fuentes section 9.4.

* :mod:`gearopt.meshing.planar` -- Problem 9.4.1: two planar involute profiles, tangency equations
  (eqs. 9.4.31-9.4.35) solved by a CasADi Newton rootfinder over the pinion angle, with the derived
  gear ratio, line of action and transmission error (eqs. 9.4.36-9.4.46).
* :mod:`gearopt.meshing.tca` -- 3-D TCA of generated spur/helical tooth surfaces with misalignment:
  point or line contact, sweeps over the pinion angle, several tooth pairs, contact ellipses.
"""

from .planar import (FLAG_FALSE_ROOT, FLAG_NAMES, FLAG_NOT_CONVERGED, FLAG_RESIDUAL, FLAG_SINGULAR,
                     PlanarTCA, PlanarTCAResult, planar_functions, solve_planar_tca)

from .tca import TCA, Misalignment, TCAResult

__all__ = ["TCA", "Misalignment", "TCAResult", "PlanarTCA", "PlanarTCAResult", "solve_planar_tca", "planar_functions", "FLAG_NAMES",
           "FLAG_NOT_CONVERGED", "FLAG_RESIDUAL", "FLAG_FALSE_ROOT", "FLAG_SINGULAR"]
