"""Solver machinery shared by the surface TCA and the edge-contact branches.

A square system ``G(w, prm) = 0`` is solved at many parameter columns (one per position) by one
mapped CasADi rootfinder call from first guesses predicted by the implicit function theorem, then
every point is checked and failures are re-solved by continuation (:class:`Branch`). The solver
settings and the acceptance tolerances live here, documented, and supply the scene defaults.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..compiled import (ColumnMap, available, cached_function, call, compile_derived, derived_library, keyed_by, map_columns,
                        mapped, select, source_tag)
from ..graph_cache import built_once
from ..settings import ContactSettings  # re-exported: declared with the other option sets (gearopt.settings)

NORMAL_TOL = 1e-8  #: accepted contact points have n1 . n2 < -1 + NORMAL_TOL (tangency, not crossing)
REGULARITY_MIN = 1e-6  #: and (dr/du x dr/dz) . n > REGULARITY_MIN on both flanks' valid branches (no cusp)
STALL_RES = 0.5  #: [mm or 1] a Newton residual below this, above the tolerance, stalled near a root (line-search Newton retries it)
#: a coarse continuation sweep (too few positions for the knots, Branch.predict_knots) of at least this many
#: columns starts from the cubic Taylor guesses (Branch.predict_taylor): their terms at a new anchor cost about
#: what 1.3 Newton steps fewer save on some 40-60 columns (evaluation, and the graph where not cached)
TAYLOR_MIN_COLUMNS = 64
#: names the construction of Branch.taylor_function in the key of its compiled library (change it with the code)
TAYLOR_TAG = "taylor3/1"
_taylor_graphs: dict = {}  # Branch.taylor_function by (branch name, SHA-256 of the residual's graph): built once a process


@dataclass(frozen=True)
class SolverSettings:
    """How the TCA equations are solved (the defaults of :class:`~gearopt.meshing.tca.TCA` and of the
    scenes).

    Parameters
    ----------
    solver : {"fast_newton", "newton"}
        CasADi rootfinder plugin for mapped sweeps (a line-search ``newton`` is the fallback).
    tol : float
        Acceptance threshold on the residual norm [mm].
    jit : {"auto", True, False}
        Run mapped sweeps as compiled C (:mod:`gearopt.compiled`: generated once per graph, cached on
        disk across processes): "auto" whenever the library is in the cache, whatever the size; on a
        cache miss from :data:`gearopt.compiled.MIN_COLUMNS` columns on (compiled at once), smaller
        sweeps run interpreted while it compiles in the background (:func:`gearopt.compiled.select`);
        True always (a warning and the interpreter when no compiler works), False never.
        Compiled and interpreted sweeps agree to round-off (tests/test_tca_jit.py).
    """

    solver: str = "fast_newton"
    tol: float = 1e-10
    jit: bool | str = "auto"


DELTA_DEFAULT = ContactSettings.delta  #: elastic approach for the contact ellipse [mm]


class BranchSolution(NamedTuple):
    """The solved columns of a :class:`Branch` (:meth:`Branch.solve`), one entry per column."""

    W: np.ndarray  #: (nw, N) the unknowns at every column (the scaled contact unknowns of the branch)
    res: np.ndarray  #: (N,) residual norm [mm]
    n1n2: np.ndarray  #: (N,) ``n1 . n2`` of the outward normals (-1: opposite)
    reg: np.ndarray  #: (N,) regularity of both surfaces (smallest singular value measure)
    ok: np.ndarray  #: (N,) accepted (:func:`accept_tangency` or the branch's own test)
    #: ``n_fast`` (accepted at the first pass), ``n_retry`` (by continuation), ``n_line_search``;
    #: with ``extra``: ``extra`` (the Function's outputs by name) and ``rescued`` (columns changed later)
    stats: dict


def sorted_unique(x: np.ndarray) -> np.ndarray:
    """The distinct values of ``x`` in ascending order (``np.unique`` without its first-call import of
    ``numpy.ma``, which costs a new process tens of milliseconds)."""
    x = np.sort(np.asarray(x).ravel())
    return x[np.concatenate(([True], x[1:] != x[:-1]))] if x.size else x


def accept_tangency(res: np.ndarray, n1n2: np.ndarray, reg: np.ndarray, tol: float) -> np.ndarray:
    """Acceptance of solved points: residual norm <= ``tol`` [mm], outward normals opposite
    (n1 . n2 < -1 + NORMAL_TOL: tangency, not crossing) and both surfaces regular (reg >
    REGULARITY_MIN: not at a singular point)."""
    return np.isfinite(res) & (res <= tol) & (n1n2 < -1 + NORMAL_TOL) & (reg > REGULARITY_MIN)


class Branch:
    """A square system ``G(w, prm) = 0`` solved at many parameter columns (positions): one mapped
    rootfinder call from predicted first guesses, the acceptance checks, and continuation from
    solved neighbours with line-search Newton for the points that fail. Shared by the surface
    TCA and the edge-contact branches.

    Parameters
    ----------
    name : str
    G : casadi.Function
        ``(w, prm) -> F`` with ``prm[0]`` the pinion angle phi1.
    checks : casadi.Function
        ``(w, prm) -> (n1 . n2, regularity)`` at a solved point.
    accept : callable(res, n1n2, reg) -> bool array
    tol : float
        Residual tolerance [mm] (used by ``accept``).
    solver : {"fast_newton", "newton"}
    jit : bool
    extra : casadi.Function, optional
        ``(w, prm) -> outputs`` at the solved point, evaluated in the same compiled pass
        (``solve(..., extra=True)``).
    own_maps : bool
        Compiled map sizes called again and again get libraries of their own
        (:class:`gearopt.compiled.ColumnMap`, ``own_maps``): for the sweeps a user repeats.
    taylor : bool
        Coarse sweeps of :data:`TAYLOR_MIN_COLUMNS` positions or more start from the cubic Taylor
        prediction (:meth:`predict_taylor`); False for a piecewise residual (measured flanks).
    """

    def __init__(self, name: str, G: ca.Function, checks: ca.Function, accept: Callable[..., np.ndarray], tol: float,
                 solver: str = SolverSettings.solver, jit: bool | str = SolverSettings.jit,
                 extra: ca.Function | None = None, own_maps: bool = False, taylor: bool = True):
        self.name, self.G, self.checks, self.accept, self.tol = name, G, checks, accept, tol
        self.solver, self.jit, self.own_maps = solver, jit, own_maps
        #: coarse sweeps start from the cubic Taylor prediction (:meth:`predict_taylor`); False where
        #: the residual is piecewise (measured flanks: their third derivatives jump at every knot of
        #: the grid and the graph is large)
        self.taylor = bool(taylor)
        nw, npr = G.size1_in(0), G.size1_in(1)
        # the residual and its Jacobian as one graph, common subexpressions eliminated (the Newton
        # step's whole cost); this graph and the checks' below are built once per residual graph
        # (gearopt.graph_cache: the elimination is most of a Branch's construction)
        tag = source_tag(Branch.__init__, Branch._symbolic, Branch._post_graph)

        def jac_graph():
            w, p, F = self._symbolic()
            return ca.Function(f"{name}_jac", [w, p], [ca.jacobian(F, w), F], {"cse": True})

        jac = built_once(f"{name}_jac", (G,), tag, jac_graph)
        # abstol 1e-15 reaches the float64 floor of phi2 (1.7e-16 rad) for ~4 % more time; the step
        # test stops after the Newton step below 1e-9 mm (saves one Jacobian). docs/work-precision.md
        fast_opts = {"error_on_fail": False, "abstol": 1e-15, "max_iter": 30, "jacobian_function": jac}
        if solver == "fast_newton":
            fast_opts["abstolStep"] = 1e-9
        self.rf_fast = ca.rootfinder(f"{name}_fast", solver, G, fast_opts)
        # Failed points are judged by the checks, not by CasADi's NaN warnings (off the surfaces'
        # domain, e.g. inside a base circle, the residual is NaN and the point is simply rejected).
        self.rf_safe = ca.rootfinder(f"{name}_newton", "newton", G, {"error_on_fail": False, "abstol": 1e-13,
                                                                     "abstolStep": 1e-16, "max_iter": 100,
                                                                     "line_search": True,
                                                                     "show_eval_warnings": False,
                                                                     "jacobian_function": jac})
        self._maps: dict[int, ca.Function] = {}
        self._dw_memo: dict = {}  # dw/dphi1 at solved anchors by their exact (w, prm) (predict)
        self._taylor_memo: dict = {}  # the branch's Taylor terms at solved anchors (predict_taylor)
        self._taylor: ca.Function | None = None  # built on first use (taylor_function)
        self._dw: ca.Function | None = None  # built on first use (dw)
        self._one_x: ca.Function | None = None  # built on first use (one_x)
        self.extra = extra
        self._extra_names = extra.name_out() if extra is not None else []  # (asked once: a call into CasADi)
        # one column: solve from W0, then the residual norm and the checks at the solution (the
        # compiled unit); what is evaluated there is one SX graph with common subexpressions
        # eliminated (the checks and the caller's extra outputs share the surfaces' derivatives)
        w0 = ca.MX.sym("W0", nw)
        pp = ca.MX.sym("P", npr)
        wf = self.rf_fast(w0, pp)
        at = built_once(f"{name}_post", (G, checks), tag, lambda: self._post_graph("post"))
        self.one = ca.Function(f"{name}_one", [w0, pp], [wf] + list(at(wf, pp)), ["W0", "P"],
                               ["W", "res", "n1n2", "reg"])
        self._key_column(self.one, (G, checks))

    def _key_column(self, col: ca.Function, bases: tuple[ca.Function, ...]) -> None:
        """Key the library of the column ``col`` (:attr:`one`, :attr:`one_x`) by how it is built
        (:func:`gearopt.compiled.keyed_by`) instead of by its serialisation (2 MB for a loaded-TCA
        slice's: 16 ms a process): ``bases`` (the residual, the checks[, the extras]: their graphs'
        library keys, which the graph cache's digests serialised already), the construction's code
        (the rootfinder's options, the Jacobian's and the checks' graphs, the columns: ``__init__``,
        ``_symbolic``, ``_post_graph``, ``one_x``)
        and the rootfinder plugin, the one argument that enters the column besides the bases and
        the name. Not under ``jit=False`` (looked up by no one)."""
        if self.jit is not False:
            code = source_tag(Branch.__init__, Branch._symbolic, Branch._post_graph, Branch.one_x.fget)
            keyed_by(col, bases, f"{code}/{self.solver}" if code else "")

    def _symbolic(self) -> tuple[ca.SX, ca.SX, ca.SX]:
        """``(w, p, G(w, p))``: the unknowns, the parameters and the residual as SX expressions."""
        w, p = ca.SX.sym("w", self.G.size1_in(0)), ca.SX.sym("p", self.G.size1_in(1))
        return w, p, self.G(w, p)

    def _post_graph(self, what: str) -> ca.Function:
        """``(w, p) -> (|G|, n1 . n2, regularity[, the extra outputs])`` at a solved point as one SX
        graph, common subexpressions eliminated: ``{name}_post``, or with ``extra`` ``{name}_postx``."""
        w, p, F = self._symbolic()
        c = self.checks(w, p)
        outs = [ca.norm_2(F), c[0], c[1]] + (list(self.extra(w, p)) if what == "postx" else [])
        return ca.Function(f"{self.name}_{what}", [w, p], outs, {"cse": True})

    @property
    def dw(self) -> ca.Function:
        """``(w, prm) -> dw/dphi1``: the implicit-function predictor ``-J^-1 dF/dphi1`` (J = dF/dw).
        Built on first use: a branch that never predicts (a loaded-TCA slice) saves its two
        Jacobians and the solve's graph, 10-30 ms."""
        if self._dw is None:
            w, p, F = self._symbolic()
            J = ca.jacobian(F, w)
            self._dw = ca.Function(f"{self.name}_dw", [w, p], [-ca.solve(J, ca.jacobian(F, p)[:, 0])])
        return self._dw

    @property
    def one_x(self) -> ca.Function | None:
        """The column :attr:`one` with the caller's outputs at the solved point (``extra(w, prm)``,
        e.g. the sweep's contact quantities): one compiled pass instead of two (``solve(...,
        extra=True)``); None without ``extra``. Built on first use (its graph's key serialises
        ``extra``, 3 MB for the TCA sweep's: 25 ms a process that never sweeps with it)."""
        if self._one_x is None and self.extra is not None:
            at_x = built_once(f"{self.name}_postx", (self.G, self.checks, self.extra), source_tag(Branch.__init__, Branch._symbolic, Branch._post_graph),
                              lambda: self._post_graph("postx"))
            w0 = ca.MX.sym("W0", self.G.size1_in(0))
            pp = ca.MX.sym("P", self.G.size1_in(1))
            wf = self.rf_fast(w0, pp)
            self._one_x = ca.Function(f"{self.name}_onex", [w0, pp], [wf] + list(at_x(wf, pp)), ["W0", "P"],
                                      ["W", "res", "n1n2", "reg"] + self._extra_names)
            self._key_column(self._one_x, (self.G, self.checks, self.extra))
        return self._one_x

    def __getstate__(self):
        # picklable (the robust-design studies ship it to worker processes): the Functions
        # serialise; the mapped/compiled ones are rebuilt on demand where it lands
        state = dict(self.__dict__)
        state["_maps"] = {}
        return state

    def __setstate__(self, state):
        state.setdefault("_dw_memo", {})
        state.setdefault("_taylor_memo", {})
        state.setdefault("_taylor", None)
        state.setdefault("_dw", state.pop("dw", None))
        state.setdefault("_one_x", state.pop("one_x", None))
        state.setdefault("own_maps", False)
        if "_extra_names" not in state:
            state["_extra_names"] = state["extra"].name_out() if state.get("extra") is not None else []
        self.__dict__.update(state)
        # the columns' library keys (by construction) are kept per Function object: a copy keeps its
        # objects, a Branch unpickled in another process keys its new ones again
        self._key_column(self.one, (self.G, self.checks))
        if self._one_x is not None:
            self._key_column(self._one_x, (self.G, self.checks, self.extra))

    def newton(self, w0: npt.ArrayLike, prm: npt.ArrayLike) -> np.ndarray:
        """Line-search Newton from ``w0`` at one parameter column (unchecked)."""
        return np.asarray(self.rf_safe(np.asarray(w0, float), prm)).ravel()

    def check(self, w: npt.ArrayLike, prm: npt.ArrayLike) -> tuple[float, float, float, bool]:
        """(residual norm, n1 . n2, regularity, accepted) at one point."""
        res = float(np.linalg.norm(np.asarray(self.G(w, prm)).ravel()))
        n1n2, reg = (float(v) for v in self.checks(w, prm))
        return res, n1n2, reg, bool(self.accept(res, n1n2, reg))

    def predict(self, w_a: npt.ArrayLike, prm_a: npt.ArrayLike, dphi: npt.ArrayLike) -> np.ndarray:
        """First guesses ``w_a + dw/dphi1 * dphi`` (nw, len(dphi)) around the solved anchor (dw/dphi1
        kept per exact anchor: a repeated sweep of the same design and case evaluates it once)."""
        w_a, prm_a = np.asarray(w_a, float), np.asarray(prm_a, float)
        key = (w_a.tobytes(), prm_a.tobytes())
        dw = self._dw_memo.get(key)
        if dw is None:
            dw = self._dw_at(w_a, prm_a)
            if len(self._dw_memo) >= 64:
                self._dw_memo.pop(next(iter(self._dw_memo)))
            self._dw_memo[key] = dw
        return w_a[:, None] + dw[:, None] * np.asarray(dphi)[None, :]

    def taylor_function(self) -> ca.Function:
        """``(w, prm) -> (d1, d2, d3)``: the first three derivatives of the solution branch w(phi1)
        with respect to phi1 (``prm[0]``) at a solved point, by the implicit function theorem.

        Along the branch ``F(w(phi1 + s), prm + s e_0) = 0`` for all s; with ``J = dF/dw``:
        ``d1 = -J^-1 dF/dphi1``, ``d2 = -J^-1 d^2/ds^2 F(w + s d1, prm + s e_0)`` and
        ``d3 = -J^-1 d^3/ds^3 F(w + s d1 + s^2 d2 / 2, prm + s e_0)`` at s = 0 (the terms of the
        next order enter the s-derivative of that order only through ``J``). Built on first use
        (one SX graph, about 0.1 s), once a process for every branch of the same residual graph."""
        if self._taylor is None:
            key = (self.name, hashlib.sha256(self.G.serialize().encode()).digest())  # (the same graph: the same bytes)
            self._taylor = _taylor_graphs.get(key)
        if self._taylor is None:
            G = self.G
            nw, npr = G.size1_in(0), G.size1_in(1)
            w, p, s = ca.SX.sym("w", nw), ca.SX.sym("p", npr), ca.SX.sym("s")
            shift = ca.vertcat(s, ca.SX.zeros(npr - 1))
            F = G(w, p)
            J = ca.jacobian(F, w)
            d1 = -ca.solve(J, ca.jacobian(F, p)[:, 0])

            def along(c, order):
                e = G(c, p + shift)
                for _ in range(order):
                    e = ca.jacobian(e, s)
                return ca.substitute(e, s, 0)

            d2 = -ca.solve(J, along(w + s * d1, 2))
            d3 = -ca.solve(J, along(w + s * d1 + 0.5 * s ** 2 * d2, 3))
            self._taylor = ca.Function(f"{self.name}_taylor", [w, p], [d1, d2, d3], ["w", "prm"],
                                       ["d1", "d2", "d3"], {"cse": True})
            if len(_taylor_graphs) >= 16:
                _taylor_graphs.pop(next(iter(_taylor_graphs)))
            _taylor_graphs[key] = self._taylor
        return self._taylor

    def predict_taylor(self, w_a: npt.ArrayLike, prm_a: npt.ArrayLike, dphi: npt.ArrayLike) -> np.ndarray:
        """First guesses (nw, len(dphi)) from the cubic Taylor polynomial of the branch around the
        solved anchor, ``w_a + d1 dphi + d2 dphi^2 / 2 + d3 dphi^3 / 6`` (:meth:`taylor_function`;
        kept per exact anchor): the guess error is O(dphi^4) instead of the linear prediction's
        O(dphi^2), so that Newton takes about 2.2 steps instead of 3.5 on a one-cycle sweep of three
        tooth pairs (benchmarks/bench_compiled.py). The linear prediction (:meth:`predict`) where
        the derivatives are not finite (a singular Jacobian).

        The Function runs compiled when its library is in the disk cache (found by a key derived
        from the residual's, :func:`gearopt.compiled.derived_library`, without building the graph);
        unless ``jit=False``, a miss compiles it in the background (one column never waits for the
        compiler) and it is evaluated interpreted meanwhile."""
        w_a, prm_a = np.asarray(w_a, float), np.asarray(prm_a, float)
        key = (w_a.tobytes(), prm_a.tobytes())
        c = self._taylor_memo.get(key)
        if c is None:
            g = self._taylor_compiled()
            d = np.column_stack([v.ravel() for v in call(self.taylor_function() if g is None else g, w_a, prm_a)])
            # the polynomial's coefficients (nw, 1) each; () where a derivative is not finite
            c = (d[:, :1], d[:, 1:2] / 2, d[:, 2:] / 6) if np.all(np.isfinite(d)) else ()
            if len(self._taylor_memo) >= 64:
                self._taylor_memo.pop(next(iter(self._taylor_memo)))
            self._taylor_memo[key] = c
        if not c:
            return self.predict(w_a, prm_a, dphi)
        h = np.asarray(dphi, float)[None, :]
        return w_a[:, None] + h * (c[0] + h * (c[1] + h * c[2]))

    def _taylor_compiled(self) -> ca.Function | None:
        """:meth:`taylor_function`'s library: loaded from the disk cache, or None (and compiled in the
        background unless ``jit=False``)."""
        key = ("taylor", "compiled")
        g = self._maps.get(key)
        if g is None and self.jit is not False and available():
            g = derived_library(self.G, f"{self.name}_taylor", TAYLOR_TAG)
            if g is None:
                compile_derived(self.G, self.taylor_function(), TAYLOR_TAG)
            else:
                self._maps[key] = g
        return g

    def _dw_at(self, w: np.ndarray, prm: np.ndarray) -> np.ndarray:
        """dw/dphi1 at one column: the Function itself, compiled when its library is cached (one
        column never pays for a compile, so a miss starts none)."""
        one = self._maps.get(("dw", "one"))
        if one is None and self.jit is not False and available():
            one = cached_function(self.dw)
            if one is not None:
                self._maps[("dw", "one")] = one
        return call(self.dw if one is None else one, w, prm)[0].ravel()

    def predict_knots(self, w_a: npt.ArrayLike, prm_a: npt.ArrayLike, phi: np.ndarray, anchor: float,
                      prm_of: Callable[[np.ndarray], np.ndarray], spacing: float,
                      n_total: int | None = None) -> np.ndarray:
        """First guesses (nw, len(phi)) for the positions ``phi`` [rad] of one smooth solution branch
        from solved knots: the branch is solved on a fixed grid ``anchor + j * spacing`` covering
        ``phi`` (:meth:`solve`, from the anchor's prediction), and each position is predicted by the
        cubic Hermite interpolant of the knot solutions and their implicit-function derivatives
        dw/dphi1 (error O(spacing^4): Newton then converges in one or two steps instead of four to
        nine from the anchor's linear prediction), or linearly from the nearest solved knot where a
        knot of its interval failed, or from the anchor where none was solved. A coarse sweep, whose
        knots would cost as much as its positions (more than a quarter of their number), starts from
        the anchor's prediction instead: the cubic Taylor one (:meth:`predict_taylor`) from
        :data:`TAYLOR_MIN_COLUMNS` positions on where ``taylor`` (not on measured flanks), else the
        linear one (:meth:`predict`).

        The grid depends only on ``anchor`` and ``spacing`` (not on the other positions), so a
        position's guess is the same in any sweep that covers it.

        Parameters
        ----------
        w_a, prm_a : array_like
            The solved anchor and its parameter column.
        phi : ndarray (n,)
        prm_of : callable(phi) -> (n_prm, m) parameter matrix
        spacing : float
            Knot spacing [rad].
        n_total : int, optional
            Columns of the whole sweep (chooses compiled or interpreted for the knots' solve).
        """
        phi = np.asarray(phi, float)
        if phi.size == 0:
            return self.predict(w_a, prm_a, phi - anchor)
        j0 = math.floor((float(np.minimum.reduce(phi)) - anchor) / spacing)
        j1 = math.ceil((float(np.maximum.reduce(phi)) - anchor) / spacing)
        if (max(j1, j0 + 1) + 1 - j0) * 4 > phi.size:  # a coarse sweep: the knots would cost as much as the positions
            if self.taylor and phi.size >= TAYLOR_MIN_COLUMNS:
                return self.predict_taylor(w_a, prm_a, phi - anchor)
            return self.predict(w_a, prm_a, phi - anchor)
        lin = self.predict(w_a, prm_a, phi - anchor)
        knots = anchor + spacing * np.arange(j0, max(j1, j0 + 1) + 1)
        prm_k = prm_of(knots)
        n_all = phi.size if n_total is None else n_total
        Wk, res, n1n2, reg = call(self.mapped(knots.size, n_all), self.predict(w_a, prm_a, knots - anchor), prm_k)
        okk = np.asarray(self.accept(res.ravel(), n1n2.ravel(), reg.ravel()), bool)
        if not okk.any():
            return lin
        dw_map = self._dw_map(knots.size)
        dWk = np.full(Wk.shape, np.nan)
        g = np.flatnonzero(okk)
        dWk[:, g] = call(dw_map, Wk[:, g], prm_k[:, g])[0]
        # knots that failed from the anchor's prediction: again from a solved neighbour knot (Newton
        # only; rounds while any is rescued)
        tried = np.zeros(knots.size, bool)
        while True:
            left = np.r_[False, okk[:-1]]
            right = np.r_[okk[1:], False]
            cand = np.flatnonzero(~okk & ~tried & (left | right))
            if cand.size == 0:
                break
            tried[cand] = True
            src = np.where(left[cand], cand - 1, cand + 1)
            guess = Wk[:, src] + dWk[:, src] * (knots[cand] - knots[src])[None, :]
            Wc, rc, dc, gc = call(self.mapped(cand.size, n_all), guess, prm_k[:, cand])
            good = np.asarray(self.accept(rc.ravel(), dc.ravel(), gc.ravel()), bool)
            if not good.any():
                break
            g = cand[good]
            Wk[:, g], okk[g] = Wc[:, good], True
            dWk[:, g] = call(dw_map, Wc[:, good], prm_k[:, g])[0]
        i = np.clip(np.floor((phi - knots[0]) / spacing).astype(int), 0, knots.size - 2)
        t = (phi - knots[i]) / spacing
        both = okk[i] & okk[i + 1]
        W0 = lin.copy()
        if both.any():  # cubic Hermite on [knot i, knot i + 1], by interval coefficients (Horner)
            d0, d1 = spacing * dWk[:, :-1], spacing * dWk[:, 1:]
            jump = Wk[:, 1:] - Wk[:, :-1]
            c2, c3 = 3 * jump - 2 * d0 - d1, d0 + d1 - 2 * jump
            a, tt = i[both], t[both]
            W0[:, both] = ((c3[:, a] * tt + c2[:, a]) * tt + d0[:, a]) * tt + Wk[:, a]
        one = ~both
        if one.any():  # the nearest solved knot, linearly
            good = np.flatnonzero(okk)
            near = good[np.abs(knots[good][None, :] - phi[one][:, None]).argmin(axis=1)]
            W0[:, one] = Wk[:, near] + dWk[:, near] * (phi[one] - knots[near])[None, :]
        return W0

    def mapped(self, n: int, n_total: int | None = None, extra: bool = False) -> ColumnMap:
        """(W0, P) -> (W, residual norm, n1 . n2, regularity[, the extra outputs]) on columns (any
        number; numpy in and out): the compiled column when :func:`gearopt.compiled.select` gives
        it for ``n_total`` columns in all (default n: under ``jit="auto"`` whenever its library is
        in the disk cache; on a miss compiled at once from ``MIN_COLUMNS`` columns on, else in the
        background while this call runs interpreted), or the interpreted one."""
        extra = bool(extra) and self.extra is not None
        fast = self.solver == "fast_newton" and self.jit is not False
        done = ("columns", True, extra)
        if fast and done in self._maps:  # once compiled, always (the library does not go away)
            return self._maps[done]
        col = self.one_x if extra else self.one
        f = select(col, self.jit, n if n_total is None else n_total) if fast else None
        key = ("columns", f is not None, extra)
        if key not in self._maps:
            if f is not None:
                self._maps[key] = ColumnMap(col, lambda m: map_columns(f, m), compiled=True, own_maps=self.own_maps)
            elif extra:
                self._maps[key] = ColumnMap(col, col.map)
            else:
                self._maps[key] = ColumnMap(col, lambda m: self._interpreted(self.rf_fast, m, "sweep"))
        return self._maps[key]

    def _dw_map(self, n: int) -> ColumnMap:
        """The implicit-function derivative dw/dphi1 on columns: compiled when its library is in the
        cache (:func:`gearopt.compiled.select`; a miss compiles in the background: a few dozen
        columns never pay for a compile in the call), else interpreted."""
        done = ("dw", True)
        if done in self._maps:
            return self._maps[done]
        key = ("dw", select(self.dw, self.jit, n) is not None)
        if key not in self._maps:
            self._maps[key] = mapped(self.dw, n, self.jit if key[1] else False)
        return self._maps[key]

    def _interpreted(self, rf, n: int, what: str) -> ca.Function:
        """(W0, P) -> (W, residual norm, n1 . n2, regularity): the rootfinder ``rf`` mapped over n
        columns, interpreted."""
        W0 = ca.MX.sym("W0", self.G.size1_in(0), n)
        P = ca.MX.sym("P", self.G.size1_in(1), n)
        W = rf.map(n)(W0, P)
        R = self.G.map(n)(W, P)
        c = self.checks.map(n)(W, P)
        return ca.Function(f"{self.name}_{what}", [W0, P], [W, ca.sqrt(ca.sum1(R * R)), c[0], c[1]], ["W0", "P"],
                           ["W", "res", "n1n2", "reg"])

    def _safe_mapped(self, n: int) -> ca.Function:
        """Line-search Newton from given guesses at n columns, with the residual norm and checks
        (interpreted: CasADi's ``newton`` has no C code generation)."""
        key = ("safe",)
        if key not in self._maps:
            self._maps[key] = ColumnMap(self.one, lambda m: self._interpreted(self.rf_safe, m, "retry"), stand_in=False)
        return self._maps[key]

    @staticmethod
    def _from(fun, cols, anchors, W, prm, n_total):
        """``fun(m, n_total)`` (a mapped solve) at the columns ``cols`` from the solutions at
        ``anchors`` (the ColumnMap pads the call to one of its few map sizes): (W, res, n1n2, reg)."""
        Wr, rr, dr, gr = call(fun(cols.size, n_total), W[:, anchors], prm[:, cols])[:4]
        return Wr, rr.ravel(), dr.ravel(), gr.ravel()

    @staticmethod
    def _candidates(ok: np.ndarray, order: np.ndarray, start: np.ndarray, max_gap: int) -> tuple[np.ndarray, np.ndarray]:
        """Continuation candidates of the groups concatenated in ``order`` (``start``: the position
        in ``order`` where each entry's group begins): the columns not accepted within ``max_gap``
        after the last accepted one of their group, and that one (their anchors), in ``order``."""
        okv = ok[order]
        pos = np.arange(order.size)
        last = np.maximum.accumulate(np.where(okv, pos, -1))
        j = np.flatnonzero(~okv & (last >= start) & (pos - last <= max_gap))
        return order[j], order[last[j]]

    def solve(self, W0: np.ndarray, prm: np.ndarray, groups: Sequence[npt.ArrayLike], max_gap: int = 4,
              n_total: int | None = None, extra: bool = False) -> BranchSolution:
        """Solve every column; ``groups`` are index arrays ordered by phi1. Columns that fail the
        checks are re-solved by continuation within their group, forwards then backwards: from the
        last accepted column before them, if at most ``max_gap`` columns back (Newton, and
        line-search Newton where that does not converge); all such columns of a round in one mapped
        call, rounds until no column is rescued (a rescued column is the anchor of the next ones).
        A group with no accepted column at all is first tried with line-search Newton from its own
        guesses where Newton stalled (three columns at most, ``stats["n_line_search"]``): else a whole
        tooth pair's slices, or a whole branch, would drop out without a word.

        ``n_total``: columns of the whole job these belong to (chooses compiled or interpreted,
        :func:`gearopt.compiled.select`; default the columns given). ``extra``: the first
        pass also returns the ``extra`` Function's outputs at every column's solved point, in
        ``stats["extra"]`` (by name), and the columns that continuation changed afterwards in
        ``stats["rescued"]`` (their extra outputs are those of the first pass: recompute them).

        Returns
        -------
        BranchSolution
            ``W, res, n1n2, reg, ok, stats`` by name.
        """
        n_total = prm.shape[1] if n_total is None else n_total
        extra = bool(extra) and self.extra is not None
        first = call(self.mapped(prm.shape[1], n_total, extra), W0, prm)
        W, res, n1n2, reg = first[:4]  # (new arrays: changed in place below)
        res, n1n2, reg = res.ravel(), n1n2.ravel(), reg.ravel()
        ok = np.asarray(self.accept(res, n1n2, reg), bool)
        n_fast, n_retry = int(np.count_nonzero(ok)), 0
        rescued: list = []
        groups = [np.asarray(g, int) for g in groups if len(g) > 0]
        # a group none of whose columns was accepted has no anchor for continuation: where Newton
        # stalled near a root (a residual above the tolerance but below STALL_RES, e.g. a guess across
        # the steep start of a relief; where it diverged, the residual is orders larger and there is
        # no root nearby), line-search Newton from the same guesses (interpreted, about 0.3 s a column),
        # at three of its columns at most (the first, middle and last; continuation below takes the
        # rest from any that is rescued)
        stalled = []
        for g in groups:
            if not ok[g].any():
                s = g[np.isfinite(res[g]) & (res[g] > self.tol) & (res[g] < STALL_RES)]
                stalled.append(s[sorted_unique(np.array([0, s.size // 2, s.size - 1]))] if s.size > 3 else s)
        stalled = np.concatenate(stalled) if stalled else np.zeros(0, int)
        n_line = int(stalled.size)
        if stalled.size:
            Wr, rr, dr, gr = self._from(lambda m, _: self._safe_mapped(m), stalled, np.arange(W0.shape[1])[stalled],
                                        W0, prm, None)
            good = np.asarray(self.accept(rr, dr, gr), bool)
            g = stalled[good]
            W[:, g], res[g], n1n2[g], reg[g], ok[g] = Wr[:, good], rr[good], dr[good], gr[good], True
            rescued.append(g)
        groups = [g for g in groups if g.size > 1]
        sizes = np.array([g.size for g in groups], int)
        start = np.repeat(np.cumsum(sizes) - sizes, sizes)  # where each entry's group begins
        for forward in (True, False):
            if not groups:
                break
            order = np.concatenate([g if forward else g[::-1] for g in groups])
            tried: set = set()
            while True:
                cols, anchors = [], []
                cand, anch = self._candidates(ok, order, start, max_gap)
                if cand.size == 0:
                    break
                for c, a in zip(cand.tolist(), anch.tolist()):
                    if (c, a) not in tried:
                        tried.add((c, a))
                        cols.append(c)
                        anchors.append(a)
                if not cols:
                    break
                cols, anchors = np.array(cols), np.array(anchors)
                n_retry += cols.size
                # Newton from the anchors (the sweep's own Function); line-search Newton where that
                # did not converge (a converged point that fails the checks is a root off the flank)
                Wr, rr, dr, gr = self._from(self.mapped, cols, anchors, W, prm, n_total)
                slow = ~(np.isfinite(rr) & (rr <= self.tol))
                if slow.any():
                    out = self._from(lambda m, _: self._safe_mapped(m), cols[slow], anchors[slow], W, prm, None)
                    for a, b in zip((Wr, rr, dr, gr), out):
                        a[..., slow] = b
                good = np.asarray(self.accept(rr, dr, gr), bool) & ~ok[cols]
                if not good.any():
                    break
                g = cols[good]
                W[:, g], res[g], n1n2[g], reg[g], ok[g] = Wr[:, good], rr[good], dr[good], gr[good], True
                rescued.append(g)
        stats = {"n_fast": n_fast, "n_retry": n_retry, "n_line_search": n_line}
        if extra:
            stats["extra"] = dict(zip(self._extra_names, first[4:]))
            stats["rescued"] = sorted_unique(np.concatenate(rescued)) if rescued else np.zeros(0, int)
        return BranchSolution(W=W, res=res, n1n2=n1n2, reg=reg, ok=ok, stats=stats)
