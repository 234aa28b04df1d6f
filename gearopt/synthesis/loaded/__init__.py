"""Micro-geometry optimisation under load (docs/loaded_synthesis.md).

The design ``theta`` is a set of ISO 21771 amounts of either member (``"pinion.C_alpha"``,
``"pinion.C_alpha_a"``...; :class:`gearopt.geometry.microgeometry.Microgeometry`) and/or Litvin's
settings (``"pinion.a_c"``, ``"pinion.a_pl"``), each with manufacturing bounds. The duty cycle is a
list of pinion torques times a list of misalignment cases, each (torque, case) with a weight. The
objective is the weighted sum of the loaded TE's peak-to-peak [arcsec] over one mesh cycle (or of
its first mesh harmonics' weighted amplitudes); the constraints are a peak Hertz pressure limit on the
flank slices at every torque and case, and no edge loading: every tip-edge slice, every face-end
slice and every flank slice near a tip (graded weight, :func:`~gearopt.synthesis.loaded.edges.edge_weight`) keeps its load share below
``mu / edge_margin`` (a gap of at least ``edge_margin`` on the smoothed manifold); the exact loaded TCA
of the optimum must show at most ``EDGE_TOL`` of the load on any of them.

One IPOPT NLP holds the whole duty cycle. Its unknowns are the design, every slice load ``x = F / W``
(share of the normal load), every slice gap ``y`` [um] and every position's approach, for every
(torque, case, position). The loaded-contact conditions of :mod:`gearopt.ltca.engine` are
constraints of the NLP:

    y = (a(theta) + W C x + delta_H(W x) - delta) / g_ref     (the gap of every slice)
    x + y - sqrt(x^2 + y^2 + 2 mu) = 0                         (Fischer-Burmeister, smoothed)
    sum x = 1                                                  (the load balance)

The smoothed Fischer-Burmeister function is zero exactly where ``x >= 0, y >= 0, x y = mu``. So the
complementarity ``F g = 0`` of the contact problem is relaxed to ``x y = mu``: an open slice at a gap
of 1 um carries ``mu`` of the load, and a loaded slice's gap is ``mu / x`` um. With the default
``mu = 1e-8`` that changes the loaded TE by less than 1e-3 arcsec; each optimum reports the
difference to the exact loaded TCA (below). Why one NLP and not a bilevel scheme: the contact
problem's active set changes with the design (slices open and close as relief grows), which makes
the loaded TE only piecewise smooth in theta for an outer solver; the smoothed NLP is smooth, IPOPT
sees every load and gap, and its exact Hessian is sparse (every nonlinearity acts on one slice).

The separations ``a`` [mm] of the slices are linear in the design: ``a(theta) = a_k + J_k (theta -
theta_k)`` with ``J_k`` the exact sensitivity of every slice's TE at ``theta_k`` (the implicit
function theorem on the slice equations, by AD). The slices' positions and compliance are those of
``theta_k``; the Hertz term's relative curvature ``1 / R*`` (each flank's own across the contact line,
as the default loaded TCA's) is linear in the design the same way (its sensitivity ``Jk`` by AD).
A trust-region loop moves the design: every trial design's slices are solved exactly and its loaded
TCA (:class:`gearopt.ltca.engine.LTCA`, the default one: exact slices, each flank's own curvature,
the QP contact solver) decides whether the step is taken. The optimum is verified by the same loaded
TCA on the NLP's positions and on a finer grid; positions of the finer grid that violate a constraint
join the NLP's grid, and an optimum that still exceeds ``p_limit`` by more than ``P_VERIFY_TOL`` or
loads an edge anywhere raises ``SynthesisError``. The result reports the NLP's values, the loaded
TCA's, and their difference.

:meth:`LoadedMicroOptimizer.sensitivities` differentiates the optimum with respect to the torques and
a misalignment (the KKT system of its active set, read from IPOPT's central path, by CasADi); :meth:`LoadedMicroOptimizer.pareto`
sweeps the pressure limit (epsilon-constraint) for the front of loaded TE against peak pressure.

Optionally (``te_level``, ``te_weight``) Litvin's predesigned parabolic TE of the unloaded drive is a
second term of the objective: the RMS misfit of each case's unloaded TE (the pair centred on each
position, its smallest separation by the same smoothed complementarity at zero load) to the parabola
plus its least-squares line (docs/loaded_synthesis.md section 9).

The package, one concept per module:

- ``constants``: units, smoothing, penalty and loop tolerances;
- ``results``: :class:`LoadedCheck`, :class:`MicroDesign`, :class:`ParetoFront`;
- ``problem``: the design space, the duty cycle and the checks of every argument;
- ``mirror``: mirror-image cases (the signs declared by :class:`~gearopt.meshing.misalignment.Misalignment`);
- ``edges``: the graded edge weights, the loaded edge, the gaps of a loaded result;
- ``verify``: loaded TCA of a design, the unloaded-TE target, the merit;
- ``linearise``: the separations' sensitivities to the design (:class:`Linearisation`);
- ``layout``: the named blocks of the NLP's unknowns, rows and parameters (:class:`NLPLayout`);
- ``nlp``: the NLP's assembly; ``solution``: its start, bounds, predicted values and warm multipliers;
- ``trust_region``: the loop of linearisations; ``optimizer``: :class:`LoadedMicroOptimizer` and ``solve``;
- ``pareto``: the pressure-limit sweep; ``sensitivity``: the optimum's derivatives by its KKT system;
- ``kkt``: generic interior-point algebra (central-path indicators, degenerate constraints).
"""

from __future__ import annotations

from .constants import (DEGENERATE_REL, EDGE_TOL, F_TOL, G_REF, HARM_EPS, LOOP_WARM_OPTS, MAX_REFINE, MAX_ROUNDS, MU, NONNEG, RHO,
                        RHO_MAX, SETTINGS, SLACK_TOL, TE0_EPS, THETA_TOL, TIP_BAND, TR_START, WARM_OPTS)
from .edges import edge_mask, edge_weight, edge_weight_lin, edge_where, loaded_gaps
from .kkt import central_path_indicators, degenerate_constraints
from .mirror import MIRROR_SIGN, mirror_image
from .optimizer import LoadedMicroOptimizer
from .results import LoadedCheck, MicroDesign, ParetoFront

__all__ = ["LoadedMicroOptimizer", "LoadedCheck", "MicroDesign", "ParetoFront", "MIRROR_SIGN", "mirror_image",
           "central_path_indicators", "degenerate_constraints", "edge_weight", "edge_weight_lin", "edge_where",
           "edge_mask", "loaded_gaps", "DEGENERATE_REL", "EDGE_TOL", "F_TOL", "G_REF", "HARM_EPS", "MAX_REFINE",
           "MAX_ROUNDS", "MU", "NONNEG", "RHO", "RHO_MAX", "SETTINGS", "SLACK_TOL", "TE0_EPS", "THETA_TOL",
           "TIP_BAND", "TR_START", "WARM_OPTS", "LOOP_WARM_OPTS"]
