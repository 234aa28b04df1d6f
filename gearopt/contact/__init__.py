"""Contact beyond surface-to-surface tangency: edge contact (Litvin section 9.6)."""

from .edge import EdgeContact, EdgeTCAResult
from .edge_kinds import EDGES

__all__ = ["EDGES", "EdgeContact", "EdgeTCAResult"]
