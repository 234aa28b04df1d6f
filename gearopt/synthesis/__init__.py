"""Synthesis: local synthesis at a mean contact point and crowning optimization (IPOPT NLPs)."""

from .crowning import CaseReport, CrowningDesign, CrowningOptimizer, CrowningTarget, SynthesisError
from .local import LocalDesign, LocalTarget, local_synthesis, verify_at_mean_point

__all__ = ["CrowningOptimizer", "CrowningTarget", "CrowningDesign", "CaseReport", "SynthesisError",
           "LocalTarget", "LocalDesign", "local_synthesis", "verify_at_mean_point"]
