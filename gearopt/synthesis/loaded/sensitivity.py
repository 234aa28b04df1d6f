"""Sensitivities of the optimum to the torques and a misalignment (docs/loaded_synthesis.md section
6): the KKT system of the NLP's active set at the optimum, by CasADi, with mirror-image case sets
reduced to one case per class (:class:`Sensitivities`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ...meshing.misalignment import Misalignment
from ..crowning import SynthesisError
from . import constants
from .constants import WARM_OPTS
from .held_data import held_derivatives
from .kkt import (active_set_derivatives, active_set_range, central_path_indicators, csc_of_dm,
                  degenerate_constraints)
from .results import MicroDesign


#: a range of the active set below this [mm, rad or N m] on either side is a kink: the derivatives
#: of the active set chosen predict no re-solved optimum (``kink_mis``, ``kink_torque``)
KINK_RANGE = 1e-9


class Sensitivities:
    """Sensitivities of an optimum by the KKT system of its active set."""

    def sensitivities(self, design: MicroDesign, held: bool = True) -> dict:
        """Sensitivities of the optimum to the torques and to a misalignment added to every case
        (docs/loaded_synthesis.md section 6; ``held``: as :meth:`kkt_sensitivities`, the held data's
        motion taken in): :meth:`kkt_sensitivities` of the duty cycle, or where its
        cases are mirror images of each other (:meth:`mirror_classes`) of the problem with one case per
        class, with each mirror-odd kind's derivatives by symmetry.

        Mirror-image cases make the full problem's active-set KKT system singular: each active row of
        a case has its twin's, and the twins' rows differ only in their own loads. The problem of one
        case per class is the full one for every perturbation that keeps the twins mirror images: the
        torques and the mirror-even kinds (``Misalignment.mirror_sign`` +1: the centre distance), whose derivatives
        it gives. An offset of a mirror-odd kind (crossing, intersecting, axial) added to every case
        breaks the pairing, but the duty cycle offset by ``-d`` is the mirror image of that offset by
        ``d``, so the optimum (symmetric amounts only, :meth:`mirror_classes`) is an even function of
        ``d``: its central derivative, and the objective's, are zero. (A kink there, an active set that
        changes at ``d = 0``, would give one-sided derivatives of opposite signs; they are not
        computed: ``benchmarks/loaded_sensitivity_fd.py`` measures them by re-solved optima.)

        Returns
        -------
        dict
            As :meth:`kkt_sensitivities`, and ``mirror_odd``: the kinds whose derivatives are zero by
            the mirror symmetry (empty without mirror-image cases; their ``range_mis`` NaN).
        """
        classes = self.mirror_classes()
        if classes is None:
            return {**self.kkt_sensitivities(design, held=held), "mirror_odd": []}
        kinds = Misalignment.names()
        odd = [j for j, k in enumerate(kinds) if Misalignment.mirror_sign(k) < 0]
        # (the held data's motion in the odd kinds is not needed: their derivatives are zero)
        out = self._reduced().kkt_sensitivities(design, held=held,
                                                held_kinds=[k for j, k in enumerate(kinds) if j not in odd])
        out["d_theta_d_mis"][:, odd] = 0.0
        out["d_objective_d_mis"][odd] = 0.0
        # (the offset breaks the mirror pairing: a kink at 0 may be there, section 6.1; not this problem's range)
        out["range_mis"][odd] = np.nan
        out["kink_mis"][odd] = False
        for j in odd:
            out["range_why"]["mis"][j] = ("mirror-odd: zero by the symmetry, one-sided derivatives not computed",) * 2
        out["mirror_odd"] = [kinds[j] for j in odd]
        out["undetermined"]["mis"] = [k for k in out["undetermined"]["mis"] if k not in out["mirror_odd"]]
        return out

    def kkt_sensitivities(self, design: MicroDesign, held: bool = True, held_kinds: list[str] | None = None,
                          derivatives: bool = True) -> dict:
        """Sensitivities of the optimum to the torques and to a misalignment, by AD (docs/loaded_synthesis.md),
        of this optimiser's own cases (:meth:`sensitivities` handles mirror-image cases).

        The NLP is built around ``design`` (its final positions, every active slice) with the torque
        scales and a misalignment offset added to every case as parameters, and solved with the design
        free within its bounds. The derivatives are those of the exact NLP (the limit mu -> 0 of IPOPT's
        barrier) at its active set, by CasADi: which inequalities and bounds are active is read from
        the tangent of IPOPT's central path at the solution (each slack's d log s / d log mu: 1 active,
        0 inactive, scale-free; rows between 0.1 and 0.9 are degenerate and counted); then the KKT
        system of the equalities and the active rows, with the inactive multipliers zero, is solved
        as one sparse system for all parameters (the optimum's derivatives at a fixed active set,
        Fiacco). The optimal objective's derivatives are those of the Lagrangian in the parameters
        (the envelope theorem).

        With ``held`` (default) the derivatives are those of the trust-region loop's optimum, the fixed
        point at which the NLP built around a design has its optimum there: the compliance, Hertz
        depths, levers and separations' sensitivities the NLP holds at its linearisation move with the contact points, which the
        design and a misalignment move (:mod:`.held_data`, docs/loaded_synthesis.md section 6.3); their
        motion enters the KKT system (the design's columns of the Hessian and the constraint Jacobian,
        the misalignment's columns of the parameters) and the objective's derivatives. Without it they
        are the NLP's own at fixed held data (its derivatives in its parameters ``torque_scale`` and
        ``mis_offset``, which differ from re-solved optima's: on problems/optimize_microgeometry.py's
        drive -17.9 against -10.9 um of tip relief per mm of dE).

        Parameters
        ----------
        design : MicroDesign
            The optimum (:meth:`solve`).
        held : bool
            Whether the held data move with the design and the misalignment (default True).
        held_kinds : list of str, optional
            The misalignment kinds (``Misalignment.names()``) whose motion of the held data is taken in
            (default all; :meth:`sensitivities` leaves out the kinds that are zero by symmetry).
        derivatives : bool
            Whether to solve the active set's KKT system (default True); without, only the NLP's optimum
            and its active set are returned (the entries from ``model_step`` on below but ``held_data``
            and the ranges): a fixed-point iteration needs no more, and the KKT system of a full
            mirror-image duty cycle is singular.

        Returns
        -------
        dict
            ``d_objective_d_torque`` (T,) [arcsec per N m] and ``d_theta_d_torque`` (P, T) [mm per N m]
            (one torque of the duty cycle changed at a time); ``d_objective_d_mis`` (4,) and
            ``d_theta_d_mis`` (P, 4), per kind of ``Misalignment.names()`` [per rad or per mm],
            the same offset added to every case; ``model_step`` [mm]: how far the NLP's optimum lies
            from ``design`` (a converged design: below ``THETA_TOL``) and ``at_design`` (it is within
            ten times that: else the loop stopped on its trust radius and the derivatives are those
            of the NLP's optimum, not of the design); ``objective`` [arcsec]: the
            NLP's optimum (with an unloaded-TE target, its term included, and so in the derivatives
            of the objective); ``active``: the inequalities and bounds active at it; ``degenerate``: the
            active ones whose multiplier vanishes (below ``DEGENERATE_REL`` times the largest), and those
            neither clearly active nor inactive (0: the derivatives are unique; else they hold on the
            side of the active set chosen, each such row counted active when its indicator is above
            1/2); ``min_multiplier``: the smallest active multiplier over the largest;
            ``nlp`` / ``z`` / ``p``: the NLP, its solution and parameters (for checks);
            ``held_data``: ``held``; ``active_rows``: the active rows of each inequality block by
            name (:data:`.layout.ROWS`); ``active_bounds``: per free amount -1 / +1 on its lower /
            upper bound, else 0; ``peaks``: the (torque, case, position) of each active ``te_hi`` and
            ``te_lo`` row (the positions of the loaded TE's maxima and minima) and, under ``edge``, the
            (torque, case, position, flat slice) of each active edge row; ``slices``: per case, the active slices and the tip-edge slices among
            them (to compare the active sets and slice sets of two optima); ``range_mis`` (4, 2) [rad or
            mm] and ``range_torque`` (T, 2) [N m]: the offsets (negative, positive) of each parameter within
            which the active set the derivatives hold for stays, to first order (an active inequality's
            or bound's multiplier, or an inactive one's slack, moved along the derivatives, crosses zero:
            :func:`~gearopt.synthesis.loaded.kkt.active_set_range`; the TE extremes, the pressure and edge
            rows, the design's bounds and the penalty slacks; +-inf: none), beyond which the optimum is
            another active set's and the derivatives no longer predict it (a range of nm at the
            optimum is a kink: they are one side's); ``kink_mis`` (4,) and ``kink_torque`` (T,) bool: the
            range on a side below :data:`KINK_RANGE` (the derivatives then predict no re-solved optimum:
            e.g. a numerically singular KKT system, whose multipliers' derivatives are huge); ``range_why``: per parameter
            (``{"mis": [...], "torque": [...]}``) the events at the two ends of its range; ``dependent``:
            the active rows and bounds that depend on the equalities and the other active ones (LICQ
            fails, e.g. two edge rows mirror images about the face's middle), dropped from the KKT
            system (:func:`~gearopt.synthesis.loaded.kkt.active_set_derivatives`), by name;
            ``undetermined`` (``{"mis": [kinds], "torque": [indices]}``): the parameters along which a
            dropped row does not stay active, whose derivatives are one-sided and given as NaN.

        Raises
        ------
        SynthesisError
            When the NLP at the optimum fails, or the active set's KKT system is singular after the
            dependent active rows are dropped (the equalities dependent, or a flat direction).
        """
        theta = np.array([design.theta[n] for n in self.free])
        if design.phi1 is not None:
            self.phi1 = np.asarray(design.phi1, float)
        # the NLP of :meth:`_around` with every active slice and no trust radius, its linearisation kept
        # (the held data's derivatives need it)
        lin = self.linearise(theta)
        sweeps = self.exact_sweeps(lin)
        keep = self._keep(lin, sweeps, np.inf)
        nlp = self._nlp(lin, theta, keep, np.inf)
        z0 = self._start(nlp, lin, theta, sweeps)
        lbx, ubx = self._bounds(nlp)
        p = np.array(self._pvec(design.rho), float)
        r = self._local_solution(nlp, z0, theta, lbx, ubx, p)
        z, lam_g, lam_x = (np.asarray(r[k]).ravel() for k in ("x", "lam_g", "lam_x"))
        pr = nlp.problem
        zs, ps, g, f = pr["x"], pr["p"], pr["g"], pr["f"]
        lam = ca.MX.sym("lam", g.shape[0])
        L = f + ca.dot(lam, g)
        lay = nlp.layout
        sel = lay.params.span("torque_scale", "mis_offset")  # the parameters differentiated in
        gz = ca.gradient(L, zs)
        fun = ca.Function("loaded_kkt", [zs, ps, lam],
                          [ca.hessian(L, zs)[0], g, ca.jacobian(g, zs), ca.jacobian(g, ps)[:, sel],
                           ca.jacobian(gz, ps)[:, sel], ca.gradient(L, ps)[sel]])
        H, gv, Jg, Gp, _, _ = fun(z, p, lam_g)
        H, Jg, Gp = csc_of_dm(H), csc_of_dm(Jg), csc_of_dm(Gp)
        gv = np.asarray(gv).ravel()
        lbg, ubg = nlp.lbg, nlp.ubg
        eq = lbg == ubg
        I_ = np.flatnonzero(~eq)
        E = np.flatnonzero(eq)
        # which inequalities and bounds are active in the limit mu -> 0 of IPOPT's barrier (the edge
        # rows' slacks are of the order of MU / margin = 2e-8, and at IPOPT's final barrier parameter
        # their barrier multipliers are 0.05: lam / s or lam^2 / mu would count a thousand open slices as
        # nearly active; the central path's tangent is scale-free)
        ind_g, ind_x = central_path_indicators(H, Jg, lbg, ubg, gv, lam_g, lbx, ubx, z, lam_x)
        ind_g = ind_g[I_]
        bx = np.isfinite(ind_x)
        act_g, act_x = ind_g > 0.5, bx & (ind_x > 0.5)
        # degenerate: an active row or bound whose multiplier vanishes (strict complementarity fails; the
        # optimum is then only directionally differentiable), i.e. below DEGENERATE_REL times the largest
        # active multiplier, or one the central path cannot tell active from inactive
        degenerate, min_mult = degenerate_constraints(ind_g, lam_g[I_], ind_x, lam_x)
        step = float(np.max(np.abs(lay.unknowns.take(z, "theta") * 1e-3 - theta)))
        # the active set by constraint block and the free amounts on a bound (lower -1, upper +1), for
        # comparing the active sets of two optima (benchmarks/loaded_sensitivity_fd.py)
        on = np.zeros(lbg.size, bool)
        on[I_[act_g]] = True
        blocks = {k: int(on[lay.rows[k]].sum()) for k in lay.rows.names if lay.rows.count(k)}
        # the TE's extremes: (torque, case, position) of each active te_hi / te_lo row (one per block)
        peaks = {k: [tuple(int(v) for v in nlp.blocks[i][:3]) for i in np.flatnonzero(on[lay.rows[k]])]
                 for k in ("te_hi", "te_lo") if lay.rows.count(k) == len(nlp.blocks)}
        # and the (torque, case, position, flat slice) of each active edge row
        ends = nlp.rows["ends"]
        if lay.rows.count("edge") == ends.size:
            peaks["edge"] = [tuple(int(v) for v in nlp.keys[ends[i]]) for i in np.flatnonzero(on[lay.rows["edge"]])]
        thx = np.arange(z.size)[lay.unknowns["theta"]]
        at_bound = {n: (int(np.sign(lam_x[i])) if act_x[i] else 0) for n, i in zip(self.free, thx)}
        state = {"model_step": step, "at_design": step <= 10 * constants.THETA_TOL, "objective": float(r["f"]),
                 "active": int(act_g.sum() + act_x.sum()), "degenerate": degenerate, "min_multiplier": min_mult,
                 "nlp": nlp, "z": z, "lam_g": lam_g, "lam_x": lam_x, "p": p, "bounds": (lbx, ubx), "z0": z0,
                 "active_rows": blocks, "active_bounds": at_bound, "peaks": peaks,
                 "slices": [(int(L.slices.active.sum()),
                             int(0 if L.slices.edge is None else np.sum(L.slices.active & (L.slices.edge > 0))))
                            for L in lin]}
        if not derivatives:
            return state

        def name_of(what: tuple) -> str:  # an event of active_set_range by block and (torque, case, position)
            kind, i, how = what
            if not kind:
                return "none"
            if kind == "x":
                k = next(k for k in lay.unknowns.names if i in range(lay.unknowns[k].start, lay.unknowns[k].stop))
                j = i - lay.unknowns[k].start
                return f"{list(self.free)[j] if k == 'theta' else f'{k}[{j}]'} {how}"
            k = next(k for k in lay.rows.names if i in range(lay.rows[k].start, lay.rows[k].stop))
            j = i - lay.rows[k].start
            at = (f" (torque, case, position) {tuple(int(v) for v in nlp.blocks[j][:3])}"
                  if k in ("te_hi", "te_lo") and lay.rows.count(k) == len(nlp.blocks) else "")
            return f"{k} row {j}{at} {how}"

        # the limit's multipliers (inactive ones zero) and the active set's KKT system: the derivatives
        # of the optimum at fixed active set (Fiacco), one sparse LU for all parameters
        lam_a = lam_g.copy()
        lam_a[I_[~act_g]] = 0.0
        H, _, _, _, Lzp, Lp = fun(z, p, lam_a)
        H, Lzp = csc_of_dm(H), csc_of_dm(Lzp)
        Lp = np.asarray(Lp).ravel()
        # the columns of the torque scales and of the misalignment offsets among the parameters ``sel``
        tq, mis = (slice(lay.params[k].start - sel.start, lay.params[k].stop - sel.start)
                   for k in ("torque_scale", "mis_offset"))
        P = len(self.free)
        dL_design = np.zeros(P)
        if held:
            # the compliance, Hertz depths and levers the NLP holds at the linearisation move with the
            # contact points, which the design and a misalignment move (:mod:`.held_data`). The loop's
            # optimum is a fixed point: the NLP built at theta* has its optimum at theta*. Its derivatives
            # take the held data's motion in the misalignment into the parameters' columns, and their
            # motion in the design into the design's columns of the Hessian and the constraint Jacobian
            # (the implicit function theorem on the fixed point; theta is in um in the NLP)
            n_mis = mis.stop - mis.start
            names = Misalignment.names()
            cols = list(range(P)) + [P + j for j in range(n_mis) if held_kinds is None or names[j] in held_kinds]
            dg, dgz, dL = np.zeros((gv.size, P + n_mis)), np.zeros((z.size, P + n_mis)), np.zeros(P + n_mis)
            dg[:, cols], dgz[:, cols], dL[cols] = held_derivatives(
                self, theta, lin, nlp, lambda ln: self._nlp(ln, theta, keep, np.inf), z, p, lam_a, cols)
            thc = lay.unknowns["theta"]
            H, Jg, Gp, Lzp = H.tolil(), Jg.tolil(), Gp.tolil(), Lzp.tolil()
            H[:, thc] = H[:, thc].toarray() + dgz[:, :P] * 1e-3
            Jg[:, thc] = Jg[:, thc].toarray() + dg[:, :P] * 1e-3
            Gp[:, mis] = Gp[:, mis].toarray() + dg[:, P:]
            Lzp[:, mis] = Lzp[:, mis].toarray() + dgz[:, P:]
            H, Jg, Gp, Lzp = H.tocsc(), Jg.tocsc(), Gp.tocsc(), Lzp.tocsc()
            Lp[mis] += dL[P:]
            dL_design = dL[:P]
        # active rows and bounds that depend on the equalities and the other active ones (LICQ fails:
        # e.g. the edge rows of two slices mirror images about the face's middle in an aligned case,
        # which the symmetric design cannot tell apart) are dropped: with them the KKT system is
        # singular in their multipliers and its LU's rounding swamps the design's derivatives
        # (docs/loaded_synthesis.md section 6.5)
        act_rows, B_all = I_[act_g], np.flatnonzero(act_x)
        d_z, d_nu, dep, off = active_set_derivatives(H, Jg, Gp, Lzp, E, act_rows, B_all,
                                                     "the active set's KKT system")
        dth = lay.unknowns.take(d_z, "theta") * 1e-3  # theta is in um in the NLP
        # how far each parameter may move before the active set changes, to first order (an active
        # inequality's multiplier crossing zero, an inactive one's value reaching its bound): the TE
        # extremes, the pressure and edge rows, the design's bounds and the penalty slacks (the loads'
        # and gaps' bounds change smoothly through the smoothed complementarity)
        n = z.size
        on_g = np.zeros(lbg.size, bool)
        on_g[I_[act_g]] = True
        watch_x = np.zeros(n, bool)
        for k in ("theta", "slack_p", "slack_e"):
            watch_x[lay.unknowns[k]] = True
        watch_x &= np.isfinite(lbx) | np.isfinite(ubx)
        d_g = np.asarray(Jg @ d_z) + Gp.toarray()
        # (a dropped row's multiplier is not determined, only its sum with those it depends on: its
        # leaving is not computed, NaN; the kept ones' own multipliers give theirs)
        rng_lo, rng_hi, rng_why = active_set_range(
            d_z, d_nu, np.concatenate([E, act_rows]), B_all, gv, d_g, lbg, ubg, lam_g, z, lbx, ubx, lam_x, on_g,
            act_x, ~eq, watch_x)
        # the optimal objective's derivatives: the Lagrangian's in the parameters (the envelope theorem),
        # and through the held data's motion with the design along the optimum's own derivatives
        dfdp = Lp + dL_design @ dth
        # a dropped row that does not stay active along a parameter: the active set holds on neither
        # side, that parameter's derivatives are one-sided, undetermined here (NaN, named in ``undetermined``)
        dth[:, off], dfdp[off] = np.nan, np.nan
        na = act_rows.size
        dependent = ([name_of(("g", int(i), "depends on the other active rows")) for i in act_rows[dep[:na]]]
                     + [name_of(("x", int(j), "depends on the other active rows")) for j in B_all[dep[na:]]])
        kinds = Misalignment.names()
        return {**state, "d_objective_d_torque": dfdp[tq] / self.torques,
                "d_theta_d_torque": dth[:, tq] / self.torques[None, :],
                "d_objective_d_mis": dfdp[mis], "d_theta_d_mis": dth[:, mis], "held_data": bool(held),
                "range_mis": np.stack([rng_lo[mis], rng_hi[mis]], axis=1),
                "range_torque": np.stack([rng_lo[tq], rng_hi[tq]], axis=1) * self.torques[:, None],
                "kink_mis": (np.minimum(-rng_lo[mis], rng_hi[mis]) < KINK_RANGE),
                "kink_torque": (np.minimum(-rng_lo[tq], rng_hi[tq]) * self.torques < KINK_RANGE),
                "range_why": {"mis": [tuple(name_of(w) for w in ws) for ws in rng_why[mis]],
                              "torque": [tuple(name_of(w) for w in ws) for ws in rng_why[tq]]},
                "dependent": dependent,
                "undetermined": {"mis": [k for k, o in zip(kinds, off[mis]) if o],
                                 "torque": [int(t) for t in np.flatnonzero(off[tq])]}}

    def _local_solution(self, nlp, z0: np.ndarray, theta: np.ndarray, lbx: np.ndarray, ubx: np.ndarray,
                        p: np.ndarray) -> dict:
        """The NLP's local optimum at the design ``theta`` [mm] (the one the trust-region loop converged
        to), for :meth:`kkt_sensitivities`.

        The NLP is not convex (the smoothed complementarity of every slice), and with every slice and no
        trust radius IPOPT from the exact loaded TCA's start point (``z0``) with its cold barrier may
        leave the design for another stationary point: with the unloaded-TE target at weight 1 on the
        tests' drive, 31 um away with a merit of 150.0 arcsec (an edge slack) against 125.08 at the
        design, whose own local optimum lies 5e-6 mm from it (docs/loaded_synthesis.md section 6.2).
        So where the cold solve ends more than ``THETA_TOL`` from the design, the NLP is solved again:
        first with the design held (as the loop's final solve), then with the design free from that
        solution and its multipliers (the design's bound multipliers dropped) and a small first barrier
        parameter (``WARM_OPTS``), which stays at the design's local optimum; the solution nearer the
        design is returned. Every solve runs without IPOPT's bound relaxation (by default every bound
        moves out by 1e-8, the scale of the edge rows' own allowance MU / margin): the slacks are then
        IPOPT's own, and so are the complementarity products the perturbed KKT system is built from.

        Raises
        ------
        SynthesisError
            When no solve succeeds.
        """
        opts = {**nlp.opts, "ipopt.bound_relax_factor": 0.0}
        th = nlp.layout.unknowns["theta"]
        args = dict(lbg=nlp.lbg, ubg=nlp.ubg, p=p)
        # (kept as the NLP's solver: checks re-solve the returned NLP with these options)
        nlp.solver = cold = ca.nlpsol("loaded_microgeometry_kkt", "ipopt", nlp.problem, opts)

        def step(r):  # [mm] from the design
            return float(np.max(np.abs(np.asarray(r["x"]).ravel()[th] * 1e-3 - theta)))

        r = cold(x0=z0, lbx=lbx, ubx=ubx, **args)
        st = cold.stats()
        if st["success"] and step(r) <= constants.THETA_TOL:
            return r
        best = r if st["success"] else None
        lbf, ubf = lbx.copy(), ubx.copy()
        lbf[th] = ubf[th] = theta * 1e3
        held = cold(x0=z0, lbx=lbf, ubx=ubf, **args)
        if cold.stats()["success"]:
            lam_x = np.asarray(held["lam_x"]).ravel().copy()
            lam_x[th] = 0.0
            warm = ca.nlpsol("loaded_microgeometry_kkt_warm", "ipopt", nlp.problem, {**opts, **WARM_OPTS})
            rw = warm(x0=held["x"], lam_x0=lam_x, lam_g0=held["lam_g"], lbx=lbx, ubx=ubx, **args)
            if warm.stats()["success"] and (best is None or step(rw) < step(best)):
                best = rw
        if best is None:
            raise SynthesisError(f"loaded micro-geometry sensitivities: the NLP at the optimum failed "
                                 f"({st['return_status']}).", param="ipopt", value=st["return_status"])
        return best
