"""Constants of the loaded micro-geometry optimiser (docs/loaded_synthesis.md): units and smoothing
of the NLP's unknowns, the exact penalty, the trust-region loop's tolerances and the design space.

``THETA_TOL`` and ``F_TOL`` are read from this module at call time (``constants.THETA_TOL``), so a
study or benchmark may tighten them for every solve (``benchmarks/loaded_sensitivity_fd.py``)."""

from __future__ import annotations

G_REF = 1e-3  #: [mm] unit of the gap unknowns y (1 um)
MU = 1e-8  #: smoothing of the complementarity: x y = MU (x: load share, y: gap in um)
RHO = 1000.0  #: first exact-penalty weight of the constraint slacks [arcsec per unit share of the load on an edge slice / per unit p^2/p_limit^2], times the mean weight
RHO_MAX = 1e5  #: the weight grows tenfold while a converged design, or the NLP's optimum well inside the trust region, leaves a slack, up to this
SLACK_TOL = 1e-3  #: a pressure slack above this is a violated limit (0.05 % of the pressure limit)
EDGE_TOL = 1e-4  #: an edge slack above this (share of the normal load on one edge slice, 0.01 %) is edge loading
MAX_ROUNDS = 30  #: trust-region rounds at most
MAX_REFINE = 3  #: times the NLP's grid may grow by the verification positions that violate a constraint
TR_START = 0.25  #: first trust radius, times the widest bound interval
F_TOL = 1e-4  #: ... or when the NLP predicts a decrease of the objective below this share of it
#: IPOPT from an earlier NLP's multipliers (:meth:`LoadedMicroOptimizer._solve_nlp`): a small first barrier
#: parameter and bound push, so the start point and multipliers are kept; a warm solve that fails or
#: takes longer than this falls back to the cold start
WARM_OPTS = {"ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-4, "ipopt.warm_start_bound_push": 1e-9,
             "ipopt.warm_start_mult_bound_push": 1e-9, "ipopt.warm_start_slack_bound_push": 1e-9,
             "ipopt.max_iter": 300}
#: the trust-region loop's warm solves (:meth:`TrustRegion._warm_solver`): ``WARM_OPTS`` with the start
#: point, its slacks and the bound multipliers pushed ``1e-5`` (instead of 1e-9) into the interior. A start that
#: close to its bounds made the adaptive barrier cut its first steps short: the refined grid's first round of
#: ``problems/microgeometry_loaded.toml`` 76 -> 39 iterations, the same solution to 1e-11 um
#: (docs/benchmarks.md, "Every round warm"). The sensitivities' re-solve keeps ``WARM_OPTS``.
LOOP_WARM_OPTS = {**WARM_OPTS, "ipopt.warm_start_bound_push": 1e-5, "ipopt.warm_start_mult_bound_push": 1e-5,
                  "ipopt.warm_start_slack_bound_push": 1e-5}
#: the first stage of an optimisation's first round (:meth:`NLPBuilder._solve_smoothed`, at ``nlp.MU_START``): the
#: monotone barrier from 1e-2 (Fiacco-McCormick). That stage only gives the second one (the NLP's own ``MU``,
#: adaptive barrier, ``LOOP_WARM_OPTS``) its start and multipliers; the adaptive barrier's oracle crawled there
#: (its mu between 1e-11 and 1e-4 from one iteration to the next): ``problems/microgeometry_loaded.toml``'s
#: first round 94 + 20 -> 63 + 18 iterations, the second stage's solution the same to 3e-13 um
#: (docs/benchmarks.md, "The first stage monotone").
SMOOTH_STAGE_OPTS = {"ipopt.mu_strategy": "monotone", "ipopt.mu_init": 1e-2}
HARM_EPS = 1e-3  #: [arcsec] smoothing of a harmonic amplitude at zero, sqrt(a^2 + b^2 + eps^2)
TE0_EPS = 1e-3  #: [arcsec] smoothing of the unloaded TE's RMS misfit to its parabola at zero, sqrt(rms^2 + eps^2)
DEGENERATE_REL = 1e-6  #: an active constraint whose multiplier is below this times the largest is degenerate
DEPENDENT_REL = 1e-8  #: an active row whose unit gradient lies within this of the span of the others' is dependent (kkt.dependent_active_rows)
THETA_TOL = 1e-4  #: [mm] the design has settled when no amount moves by more than this (0.1 um: below any grinding machine's resolution)
P_VERIFY_TOL = 5e-3  #: the optimum's peak pressure (default loaded TCA) exceeds p_limit by this share at most
KAPPA_FLOOR = 1e-4  #: [1/mm] the NLP's linearised relative curvature 1 / R* is kept above about this (R* 10 m)
TIP_BAND = 0.02  #: [m_n] contact within this radial distance of a tip circle counts as tip (edge) contact
SETTINGS = {"a_c": 0.05, "a_pl": 0.02}  #: Litvin's settings a design may free, with their largest value [1/mm]
NONNEG = ("C_alpha", "C_beta", "C_alpha_a", "C_alpha_f", "C_beta_I", "C_beta_II")  #: amounts >= 0
GOLDEN_STEPS = 8  #: golden-section steps refining each loaded TE extreme between the confirmation grid's positions (the interval to 0.618^8 = 2 % of two grid steps)
CONFIRM_ATOL = 1e-2  #: [arcsec] the confirmed and the NLP's objective agree within confirm_tol of the confirmed, or this
