"""gearopt: CasADi-based local synthesis and tooth contact analysis of gear drives.

After Litvin & Fuentes, *Gear Geometry and Applied Theory*, sections 9.4-9.6 and chapter 10.
Lengths in mm, angles in rad inside; see :mod:`gearopt.units` for the edges.
"""

from .contact.edge import EdgeContact, EdgeTCAResult
from .errors import ConvergenceError, GearoptError, GeometryError, SceneError
from .gears import BasicRack, Gear, GearPair
from .geometry.generation import (PARAMS, GeneratedTooth, Hob, Shaper, generate, generate_by_hob, generate_by_rack,
                                  generate_by_shaper)
from .geometry.tools import RackCutter, Tool
from .geometry.involute import inv, inv_inverse
from .io.scene import load_scene
from .meshing.planar import PlanarTCA, solve_planar_tca
from .geometry.microgeometry import Microgeometry
from .meshing.misalignment import misalignment_cases
from .meshing.tca import TCA, Misalignment, TCAResult
from .units import ARCMIN, ARCSEC, DEG, deg, to_deg
from .version import __version__


__all__ = [
    "GearoptError", "GeometryError", "ConvergenceError", "SceneError",
    "BasicRack", "Gear", "GearPair",
    "PARAMS", "GeneratedTooth", "Tool", "RackCutter", "Hob", "Shaper", "generate", "generate_by_rack",
    "generate_by_hob", "generate_by_shaper",
    "Microgeometry", "TCA", "Misalignment", "misalignment_cases", "TCAResult", "PlanarTCA", "solve_planar_tca", "EdgeContact", "EdgeTCAResult",
    "load_scene", "TCAStudy", "CrowningStudy", "LoadedMicroStudy", "inv", "inv_inverse",
    "DEG", "ARCMIN", "ARCSEC", "deg", "to_deg", "__version__",
]


def __getattr__(name):
    """Study classes load lazily (``gearopt.TCAStudy``, ``gearopt.CrowningStudy``,
    ``gearopt.LoadedMicroStudy``): importing gearopt stays cheap."""
    if name == "TCAStudy":
        from .studies.tca import TCAStudy
        return TCAStudy
    if name == "CrowningStudy":
        from .studies.crowning import CrowningStudy
        return CrowningStudy
    if name == "LoadedMicroStudy":
        from .studies.loaded_microgeometry import LoadedMicroStudy
        return LoadedMicroStudy
    raise AttributeError(f"module 'gearopt' has no attribute {name!r}")
