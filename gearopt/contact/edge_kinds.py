"""The edges that edge contact analyses, by name: the convex boundaries of each member's flank (tip,
face ends, corners, the ridge where a folded flank is cut off) and the edge-on-edge crossings, each
with its member and kind (:data:`EDGES`, :data:`LIMIT_EDGES`, :func:`edge_kind`); and the exact key of a
numeric vector by which edge contact memoises its first guesses and clearances."""

from __future__ import annotations

import numpy as np

#: Convex edges that can touch the mating flank (member, kind, sign of the face end).
EDGES = {
    "pinion_tip": (1, "tip", 0), "pinion_face+": (1, "face", 1), "pinion_face-": (1, "face", -1),
    "gear_tip": (2, "tip", 0), "gear_face+": (2, "face", 1), "gear_face-": (2, "face", -1),
    # the corners where the tip edge meets a face end (vertex contact between an edge's end and the mate)
    "pinion_corner+": (1, "corner", 1), "pinion_corner-": (1, "corner", -1),
    "gear_corner+": (2, "corner", 1), "gear_corner-": (2, "corner", -1),
    # an edge of the pinion crossing an edge of the gear (edge-on-edge contact of two boundary curves)
    "pinion_tip/gear_face+": (0, "cross", ("pinion_tip", "gear_face+")),
    "pinion_tip/gear_face-": (0, "cross", ("pinion_tip", "gear_face-")),
    "pinion_face+/gear_tip": (0, "cross", ("pinion_face+", "gear_tip")),
    "pinion_face-/gear_tip": (0, "cross", ("pinion_face-", "gear_tip")),
    "pinion_tip/gear_tip": (0, "cross", ("pinion_tip", "gear_tip")),
}
SURFACE = "surface"
#: Convex edges at the end of a folded flank (issue 10): where the tool cut the flank away below a
#: fold, the crossing of the flank with the cutting surface is a ridge that can carry contact.
#: Added automatically for a member whose flank ends at such a crossing (``FlankLimit.kink > 0``).
LIMIT_EDGES = {"pinion_limit": (1, "limit", 0), "gear_limit": (2, "limit", 0)}


def edge_kind(name: str) -> tuple:
    """``(member, kind, sign)`` of the edge ``name`` (a key of :data:`EDGES` or :data:`LIMIT_EDGES`):
    member 1 (pinion), 2 (gear) or 0 (edge on edge, sign: the two edges' names); kind "tip", "face",
    "corner", "limit" or "cross"; sign of the face end (+1, -1) or 0."""
    return EDGES[name] if name in EDGES else LIMIT_EDGES[name]


def exact_key(v: object) -> bytes:
    """Exact key of a numeric vector (its float64 bytes: -0.0 and 0.0 differ, NaN keys itself)."""
    return np.ascontiguousarray(np.asarray(v, float)).tobytes()
