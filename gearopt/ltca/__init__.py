"""Loaded tooth contact analysis (docs/ltca.md): slices of the potential contact, tooth
compliance, and the contact problem as a convex QP solved by a CasADi conic solver."""

from .compliance import Material, iso6336_stiffness  # noqa: F401 (public API)
from .engine import LTCA, ContactStructure, LoadedResult, LoadedSweep  # noqa: F401
