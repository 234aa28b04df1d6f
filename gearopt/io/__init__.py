"""Input and output at the edges: scene files (TOML) in, results (JSON + plots) out."""

from .results import write_results
from .scene import COMMON_SECTIONS, Bounds, Field, Scene, Section, load_scene

__all__ = ["load_scene", "Scene", "Field", "Section", "Bounds", "COMMON_SECTIONS", "write_results"]
