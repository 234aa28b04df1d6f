"""Contact beyond surface-to-surface tangency: edge contact (Litvin section 9.6)."""

from .edge import EDGES, EdgeContact, EdgeTCAResult

__all__ = ["EDGES", "EdgeContact", "EdgeTCAResult"]
