"""The Pareto front of loaded TE against peak pressure: an epsilon-constraint sweep of the pressure
limit (docs/loaded_synthesis.md section 7; :class:`ParetoSweep`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
import math

import numpy as np

from ...errors import ArgumentError, OptionError, out_of_range
from ...settings import LoadedMicroSettings
from ..crowning import SynthesisError
from .results import MicroDesign, ParetoFront


class ParetoSweep:
    """The epsilon-constraint sweep of the pressure limit."""

    def with_p_limit(self, p_limit: float | None) -> ParetoSweep:
        """This optimiser with another pressure limit [MPa] (None: none); it shares the compiled slices,
        the loaded TCA and the sensitivities' functions with this one. A limit outside the option's range
        raises the option's error (:class:`~gearopt.settings.LoadedMicroSettings`)."""
        LoadedMicroSettings(p_limit=p_limit)  # the one check of the option
        o = copy.copy(self)
        o.p_limit = p_limit
        return o

    def pareto(self, p_limits: Sequence[float], progress: Callable[[str], None] | None = None,
               anchor: MicroDesign | None = None) -> ParetoFront:
        """Loaded TE against peak pressure: the epsilon-constraint sweep of the pressure limit.

        The anchor is the optimum without a pressure limit; then each limit of ``p_limits`` [MPa]
        (taken in decreasing order) is solved from the previous optimum, with the edge-loading
        constraint and everything else of this optimiser. Every point is verified by loaded TCA on the
        verification grid (:meth:`solve`). A limit no design within the bounds meets (with the
        edge-loading constraint; solved from the previous optimum and again from the start design)
        ends the sweep: it and every lower limit get no design and the reason.
        Where a tighter limit's optimum has the lower loaded TE (the looser one stopped in a local
        optimum), the looser limit is solved again from it, so the front is monotone.

        Parameters
        ----------
        p_limits : sequence of float
            Peak Hertz pressure limits [MPa], each 100 ... 10000, distinct.
        progress : callable, optional
            Takes one line of text per trust-region round and per point.
        anchor : MicroDesign, optional
            The optimum without a pressure limit, if already solved (by this optimiser with
            ``p_limit=None``): not solved again.

        Returns
        -------
        ParetoFront
        """
        try:
            lims = sorted((float(v) for v in p_limits), reverse=True)
        except (TypeError, ValueError):
            raise out_of_range("p_limits", p_limits, "a list of pressure limits [MPa]", cls=OptionError) from None
        if not lims or len(set(lims)) != len(lims) or not all(math.isfinite(v) and 100.0 <= v <= 1e4 for v in lims):
            raise out_of_range("p_limits", p_limits, "a non-empty list of distinct limits, 100 ... 10000 MPa each",
                               cls=OptionError)

        at = self.with_p_limit
        say = progress or (lambda m: None)
        first = at(None)
        if anchor is None:
            anchor = first.solve(progress=progress)
            grid = first.phi1  # with the positions the verification added: the next points start there
        else:
            if self.p_limit is not None:
                raise ArgumentError("anchor: given for an optimiser with a pressure limit; the anchor is the "
                                    "optimum without one (p_limit=None).", param="anchor", value=self.p_limit,
                                    valid="an optimiser with p_limit=None")
            grid = self.phi1
        say(f"loaded micro-geometry Pareto: no pressure limit: {anchor.after.objective:.4g} arcsec at "
            f"{np.max(anchor.after.p_max):.1f} MPa")
        designs, msgs = [], []
        theta = np.array(list(anchor.theta.values()))
        for lim in lims:
            if designs and designs[-1] is None:
                designs.append(None)
                msgs.append(f"not solved: a higher limit ({lims[len(designs) - 2]:g} MPa) has no design")
                continue
            o = at(lim)
            d = None
            # from the previous optimum; where that finds no design, once more from the start design (a
            # local method: the sweep's path may end in a corner the start design is not in)
            for start in (theta, self.theta0):
                if d is not None or (start is self.theta0 and np.allclose(theta, self.theta0)):
                    continue
                try:
                    d = o.solve(progress=progress, start=start, grid=grid)
                except SynthesisError as e:
                    if getattr(e, "param", None) not in ("p_limit", "edge_margin"):
                        raise  # a solver failure, not an infeasible limit
                    err = e
                    o = at(lim)
            if d is None:
                designs.append(None)
                msgs.append(f"{err} (solved from the previous optimum and from the start design)")
                say(f"loaded micro-geometry Pareto: p_limit {lim:g} MPa: no design ({err})")
                continue
            designs.append(d)
            msgs.append("")
            theta, grid = np.array(list(d.theta.values())), o.phi1
            say(f"loaded micro-geometry Pareto: p_limit {lim:g} MPa: {d.after.objective:.4g} arcsec at "
                f"{np.max(d.after.p_max):.1f} MPa")
        # A design meeting a limit meets every looser one, so a looser limit's point is never worse than a
        # tighter one's on the front's measure (the verified objective: loaded TCA on the verification
        # grid). Each design is optimal on its NLP's positions only, a subset of that grid: where the
        # objective is flat in the amounts, the sampled peak-to-peak's optimum and the verified one's
        # differ (docs/loaded_synthesis.md section 7). Tightest first: where a tighter limit's design is
        # the better, the looser limit is solved again from it; if that is still worse, the looser limit
        # keeps the tighter limit's design. Either way the point's note says so.
        solved = [(None, anchor)] + [(lim, d) for lim, d in zip(lims, designs) if d is not None]
        notes = {}
        # the limit whose NLP each point's design solves (its own, or a tighter one's whose design it keeps)
        under = {lim: lim for lim, _ in solved}
        # (with an unloaded-TE target its term counts too: the objective the designs minimise)
        tot = lambda m: m.after.objective + m.after.te0_term  # noqa: E731
        for i in range(len(solved) - 2, -1, -1):
            lim, d = solved[i]
            better = solved[i + 1][1]
            if not tot(better) < tot(d):
                continue
            what = "no pressure limit" if lim is None else f"p_limit {lim:g} MPa"
            tighter = f"{solved[i + 1][0]:g} MPa"
            d2 = at(lim).solve(progress=progress, start=np.array(list(better.theta.values())), grid=grid)
            if tot(d2) <= tot(better):
                solved[i] = (lim, d2)
                notes[lim] = (f"solved again from the {tighter} design ({tot(better):.6g} arcsec): "
                              f"{tot(d):.6g} -> {tot(d2):.6g} arcsec")
            else:
                solved[i] = (lim, better)
                under[lim] = under[solved[i + 1][0]]
                notes[lim] = (f"the {tighter} design ({tot(better):.6g} arcsec): this limit's own optimum "
                              f"{tot(d):.6g} arcsec, solved again from that design {tot(d2):.6g} arcsec "
                              "(each optimal on its NLP's positions only)")
            say(f"loaded micro-geometry Pareto: {what}: {notes[lim]}")
        anchor = solved[0][1]
        again = {lim: d for lim, d in solved[1:]}
        designs = [again.get(lim) if d is not None else None for lim, d in zip(lims, designs)]
        return ParetoFront(anchor=anchor, p_limits=tuple(lims), designs=tuple(designs), messages=tuple(msgs),
                           notes=tuple(notes.get(lim, "") for lim in (None, *lims)),
                           solved_under=tuple(under.get(lim) for lim in (None, *lims)))
