"""Finite element models of gear drives from the tooth surface equations (Litvin section 9.5),
solved with CalculiX: :mod:`gearopt.fea.mesh` (analytic hexahedral tooth meshes),
:mod:`gearopt.fea.calculix` (input deck, runner, .dat reader), :mod:`gearopt.fea.model` (the
two-member model at a TCA position), :mod:`gearopt.fea.references` (Hertz and ISO 6336-3 references, the
penalty layer's share of the peak pressure, the checks of a deck and a result), :mod:`gearopt.fea.result`
(the result of one position)."""

from .calculix import CalculixError, ccx_path, read_dat, run_ccx, write_inp
from .mesh import MeshOptions, ToothMesher, build_member, hex_min_jacobian
from .model import FEOptions, GearFEModel
from .references import (HertzLine, HertzPoint, hertz_line, penalty_layer_estimate, penalty_layer_factor,
                         root_stress_estimate)
from .result import FEResult

__all__ = ["CalculixError", "ccx_path", "read_dat", "run_ccx", "write_inp", "MeshOptions", "ToothMesher",
           "build_member", "hex_min_jacobian", "FEOptions", "FEResult", "GearFEModel", "HertzLine", "HertzPoint",
           "hertz_line", "penalty_layer_estimate", "penalty_layer_factor", "root_stress_estimate"]
