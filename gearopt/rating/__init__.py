"""Load capacity of cylindrical gears: ISO 6336-1/-2/-3:2019 method B (docs/rating.md).

:func:`rate` rates an external pair from its gear data (:class:`PairData`), operating point
(:class:`Operation`), materials (:func:`material`, ISO 6336-5 data) and deviations
(:class:`Accuracy`); :func:`gearopt.rating.pair.pair_data` builds the gear data from a gearopt pair;
:func:`rate_spectrum` rates a load spectrum (ISO 6336-6, Miner).
"""

from gearopt.rating.iso6336 import Accuracy, Geometry, Operation, PairData, Rating, geometry, rate
from gearopt.rating.materials import GRADES, MATERIALS, Material, MaterialGroup, material
from gearopt.rating.spectrum import Bin, SNCurve, miner, rate_spectrum, spectrum_safety

__all__ = ["Accuracy", "Bin", "GRADES", "Geometry", "MATERIALS", "Material", "MaterialGroup", "Operation", "PairData",
           "Rating", "SNCurve", "geometry", "material", "miner", "rate", "rate_spectrum", "spectrum_safety"]
