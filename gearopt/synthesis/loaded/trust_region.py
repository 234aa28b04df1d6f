"""The trust-region loop of linearisations (docs/loaded_synthesis.md section 3): every trial design
evaluated by exact loaded TCA, the exact penalty's weight raised where a constraint stays violated,
IPOPT warm-started from the last NLP's multipliers (:class:`TrustRegion`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..crowning import SynthesisError
from . import constants
from .constants import EDGE_TOL, LOOP_WARM_OPTS, MAX_ROUNDS, RHO, RHO_MAX, SLACK_TOL, TR_START
from .layout import param_layout
from .nlp import LoadedNLP
from .results import LoadedCheck

RHO_AT = param_layout(0, 0)["rho"].start  #: the penalty weight's place among the NLP's parameters


@dataclass
class LocalModel:
    """The trust region's model around a design (:meth:`TrustRegion._around`): the NLP of its
    linearisation, the NLP's start point and the exact loaded TCA there."""

    nlp: LoadedNLP
    z0: np.ndarray  #: the start point: the exact loaded TCA of the design (:meth:`NLPSolution._start`)
    check: LoadedCheck  #: the exact loaded TCA of the design over the duty cycle
    merit: float  #: its merit (objective plus the penalty of the violations at the current weight)
    time: float  #: [s] to linearise, build and start


class TrustRegion:
    """The trust-region loop of linearisations and the NLP solves."""

    def _trust_region(self, theta, rounds: list, progress=None, rho: float = RHO, prev: tuple | None = None):
        """Optimise and verify (module docstring).

        A trust-region loop of linearisations: the NLP around the design ``theta_k`` is solved with
        every amount within ``radius`` of ``theta_k``; the new design's slices are solved exactly and
        its loaded TCA gives the true objective. The step is accepted when the true objective falls by
        at least a tenth of what the NLP predicted (the radius doubles when the prediction was good
        and the step reached it), else the radius shrinks to a quarter of the step. It stops when the
        NLP's step is below ``THETA_TOL`` (the linearised optimum is the design itself: a stationary
        point of the exact problem, whose first derivatives the linearisation shares). Where the
        NLP's optimum, well inside the radius or at a stationary design, still needs a slack, the
        penalty weight grows tenfold (up to ``RHO_MAX``) and the same NLP is solved again. Where the
        NLP's optima of two accepted steps in a row needed a slack (the second's not tenfold smaller
        than the first's), the weight grows tenfold after the second step, for the next round.
        ``rho``: the first weight (a refinement of the grid starts from the weight the last pass ended
        with); ``prev``: the last pass's final NLP and solution (:attr:`last_solve`), whose multipliers
        start the first round's IPOPT (:meth:`_multipliers` carries them to the refined grid); every
        later round starts from the last NLP's (after a radius doubling too), unless the penalty grew.
        The final NLP's own solve is kept as :attr:`last_solve`."""
        p = self._pvec(rho)
        radius = TR_START * float(np.max(self.hi - self.lo))
        iters, status, pred, stop = 0, "", None, "trust radius"
        last_viol = 0.0  # the model's constraint violation (relative, > 1: violated) at the last accepted step
        cur = self._around(theta, 2 * radius, rho)
        for rnd in range(MAX_ROUNDS):
            nlp = cur.nlp
            lbx, ubx = self._bounds(nlp)
            th = nlp.layout.unknowns["theta"]
            lbx[th] = np.maximum(self.lo, theta - radius) * 1e3
            ubx[th] = np.minimum(self.hi, theta + radius) * 1e3
            t1 = time.perf_counter()
            # from the last NLP's multipliers, after a radius doubling too (there the cold start took
            # 59 + 104 iterations on problems/microgeometry_loaded.toml, the warm one 86 + 34 with the
            # bound push of LOOP_WARM_OPTS; the same solutions to 1e-11 um)
            warm = prev
            if rnd == 0 and warm is None and np.array_equal(theta, self.theta0):
                # the first round from the drive's own design (far from the optimum): two stages of the
                # smoothing (a start near an optimum, the Pareto sweep's, solves cold in fewer)
                r, st, it = self._solve_smoothed(nlp, cur.z0, lbx, ubx, p)
            else:
                r, st, it = self._solve_nlp(nlp, cur.z0, lbx, ubx, p, warm)
            status = st["return_status"]
            iters += it
            zs = np.asarray(r["x"]).ravel()
            new = np.clip(zs[th] * 1e-3, self.lo, self.hi)
            model = float(r["f"])
            info = {"theta_um": (new * 1e3).tolist(), "model_objective": model, "merit": cur.merit,
                    "radius_um": radius * 1e3, "rho": float(p[RHO_AT]), "status": status, "iterations": it,
                    "nlp_s": time.perf_counter() - t1, "linearise_s": cur.time, "n_loads": nlp.sizes["nx"],
                    "n_positions": int(self.phi1.size)}
            rounds.append(info)
            if not st["success"]:
                raise SynthesisError(f"loaded micro-geometry NLP: IPOPT stopped with {status} in round {rnd} "
                                     f"(design {dict(zip(self.free, (new * 1e3).round(3)))} um).",
                                     param="ipopt", value=status)
            pred = self._predicted(nlp, zs)
            step = float(np.max(np.abs(new - theta)))
            prev = (nlp, r, np.array(p, float), radius)
            stationary = step <= constants.THETA_TOL or cur.merit - model <= constants.F_TOL * max(cur.merit, 1.0)
            viol = max(np.max(pred["slack_p"]) / SLACK_TOL, np.max(pred["slack_e"]) / EDGE_TOL)  # > 1: violated
            violated = viol > 1.0
            if violated and rho < RHO_MAX and (stationary or step < 0.5 * radius):
                # a constraint still violated at a stationary point of the penalised objective, or at
                # the model's own optimum well inside the trust region: the penalty is too light (an
                # exact penalty needs a weight above the constraint's multiplier); heavier, and the
                # same model again
                rho *= 10.0
                p[RHO_AT] = rho
                cur.merit = self._merit(cur.check, rho)
                info["accepted"] = f"penalty x10 ({rho:g})"
                if progress:
                    progress(_round_text(rnd, info, self._has_settings))
                continue
            if stationary:
                info["accepted"] = "converged"
                stop = "converged"
                if progress:
                    progress(_round_text(rnd, info, self._has_settings))
                break
            trial = self._around(new, 2 * radius, rho)
            gain = cur.merit - trial.merit
            ratio = gain / max(cur.merit - model, 1e-12)
            info.update(true_merit=trial.merit, ratio=ratio)
            if ratio >= 0.1:
                info["accepted"] = True
                if ratio > 0.75 and step >= 0.9 * radius:
                    radius *= 2.0
                theta, cur = new, trial
                if violated and last_viol > 1.0 and viol > 0.1 * last_viol and rho < RHO_MAX:
                    # the model's optimum needed a slack after the last accepted step too, and not
                    # tenfold less: the penalty is too light for this drive; heavier from the next
                    # round on (the test above would raise it there, after one more solve)
                    rho *= 10.0
                    p[RHO_AT] = rho
                    cur.merit = self._merit(cur.check, rho)
                    info["rho_next"] = rho
                last_viol = viol
            else:
                info["accepted"] = False
                radius = 0.25 * step
            if progress:
                progress(_round_text(rnd, info, self._has_settings))
            if radius <= constants.THETA_TOL:
                if violated and rho < RHO_MAX:
                    # no better design nearby, but a constraint still violated: a heavier penalty, and
                    # the radius of the last accepted step again
                    rho *= 10.0
                    p[RHO_AT] = rho
                    cur.merit = self._merit(cur.check, rho)
                    radius = 16.0 * constants.THETA_TOL
                    continue
                break
        else:
            raise SynthesisError(f"loaded micro-geometry: no stationary design after {MAX_ROUNDS} linearisations "
                                 f"(last step {step * 1e3:.3g} um, trust radius {radius * 1e3:.3g} um).",
                                 param="theta", value=step)
        # the NLP's own values at the final design (its linearisation there, the design fixed): what the
        # verification below is compared with
        nlp = cur.nlp
        lbx, ubx = self._bounds(nlp)
        th = nlp.layout.unknowns["theta"]
        lbx[th] = ubx[th] = theta * 1e3
        r, st, _ = self._solve_nlp(nlp, cur.z0, lbx, ubx, p, prev)
        self.last_solve = (nlp, r, np.array(p, float), radius)
        if not st["success"]:
            raise SynthesisError(f"loaded micro-geometry: the NLP at the final design failed "
                                 f"({st['return_status']}).", param="ipopt", value=st["return_status"])
        pred = self._predicted(nlp, np.asarray(r["x"]).ravel())
        self._raise_if_infeasible(pred, cur.check, theta)
        return theta, cur, pred, iters, status, rho, stop

    def _solve_nlp(self, nlp, z0, lbx, ubx, p, prev=None):
        """Solve ``nlp`` from ``z0``. With ``prev`` (an earlier NLP of the same positions, or of a grid
        they are part of, and its solution), first from its multipliers (:meth:`_multipliers`) and a
        small barrier parameter (``LOOP_WARM_OPTS``): near the earlier optimum a few tens of iterations
        instead of hundreds; where that fails, from the cold start. Returns the solution, IPOPT's stats
        and the iterations of both."""
        args = dict(x0=z0, lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg, p=p)
        its = 0
        lam = None if prev is None or not np.array_equal(prev[2], p) else self._multipliers(prev[:2], nlp)
        if lam is not None:
            r = self._warm_solver(nlp)(lam_x0=lam[0], lam_g0=lam[1], **args)
            st = nlp.warm.stats()
            its += int(st["iter_count"])
            if st["success"]:
                return r, st, its
        r = nlp.solver(**args)
        st = nlp.solver.stats()
        return r, st, its + int(st["iter_count"])

    @staticmethod
    def _warm_solver(nlp) -> ca.Function:
        """The IPOPT solver of ``nlp`` from a given point and multipliers (``LOOP_WARM_OPTS``), built on first use."""
        if nlp.warm is None:
            nlp.warm = nlp.ipopt("loaded_microgeometry_warm", {**nlp.opts, **LOOP_WARM_OPTS})
        return nlp.warm

    def _around(self, theta, radius: float = np.inf, rho: float = RHO) -> LocalModel:
        """Linearisation, NLP and start point at ``theta``, with the exact loaded TCA there; the NLP
        leaves out the slices that stay open within ``radius`` [mm] of ``theta`` (:meth:`_keep`)."""
        t0 = time.perf_counter()
        lin = self.linearise(theta)
        sweeps = self.exact_sweeps(lin)
        nlp = self._nlp(lin, theta, self._keep(lin, sweeps, radius), radius)
        z0 = self._start(nlp, lin, theta, sweeps)
        chk = self._check_of(sweeps)
        return LocalModel(nlp=nlp, z0=z0, check=chk, merit=self._merit(chk, rho), time=time.perf_counter() - t0)


def _round_text(rnd: int, info: dict, settings: bool = False) -> str:
    th = ", ".join(f"{v:.2f}" for v in info["theta_um"]) + ("] um (settings: 1e-3/mm" if settings else "")
    true = f", true {info['true_merit']:.4g}" if "true_merit" in info else ""
    return (f"loaded micro-geometry round {rnd}: design [{th}] um, model {info['model_objective']:.4g}{true} "
            f"(from {info['merit']:.4g}), radius {info['radius_um']:.3g} um, {info['iterations']} IPOPT iterations, "
            f"{'accepted' if info.get('accepted') is True else info.get('accepted')}"
            + (f", penalty x10 ({info['rho_next']:g}) from the next round" if "rho_next" in info else ""))
