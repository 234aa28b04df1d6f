"""Loaded tooth contact analysis (docs/ltca.md): slices of the potential contact, tooth
compliance, and the contact problem as a convex QP solved by a CasADi conic solver."""
