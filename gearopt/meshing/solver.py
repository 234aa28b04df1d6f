"""Solver machinery shared by the surface TCA and the edge-contact branches.

A square system ``G(w, prm) = 0`` is solved at many parameter columns (one per position) by one
mapped CasADi rootfinder call from first guesses predicted by the implicit function theorem, then
every point is checked and failures are re-solved by continuation (:class:`Branch`). The solver
settings and the acceptance tolerances live here, documented, and supply the scene defaults.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

NORMAL_TOL = 1e-8  #: accepted contact points have n1 . n2 < -1 + NORMAL_TOL (tangency, not crossing)
REGULARITY_MIN = 1e-6  #: and (dr/du x dr/dz) . n > REGULARITY_MIN on both flanks' valid branches (no cusp)


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
    jit : bool
        Compile the mapped sweep to C with the system compiler (falls back to the interpreter).
    """

    solver: str = "fast_newton"
    tol: float = 1e-10
    jit: bool = False


@dataclass(frozen=True)
class ContactSettings:
    """Contact-ellipse setting (the default of the TCA sweeps, the synthesis targets and the scenes).

    Parameters
    ----------
    delta : float
        Elastic approach of the surfaces for the contact ellipse [mm] (Litvin 9.1: 0.00632 mm).
    """

    delta: float = 0.00632


DELTA_DEFAULT = ContactSettings.delta  #: elastic approach for the contact ellipse [mm]


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
    """

    def __init__(self, name, G, checks, accept, tol, solver=SolverSettings.solver, jit=SolverSettings.jit):
        self.name, self.G, self.checks, self.accept, self.tol = name, G, checks, accept, tol
        self.solver, self.jit = solver, jit
        nw, npr = G.size1_in(0), G.size1_in(1)
        w, p = ca.SX.sym("w", nw), ca.SX.sym("p", npr)
        F = G(w, p)
        J = ca.jacobian(F, w)
        # Implicit-function predictor: dw/dphi1 = -J^-1 dF/dphi1.
        self.dw = ca.Function(f"{name}_dw", [w, p], [-ca.solve(J, ca.jacobian(F, p)[:, 0])])
        # abstol 1e-15 reaches the float64 floor of phi2 (1.7e-16 rad) for ~4 % more time; the step
        # test stops after the Newton step below 1e-9 mm (saves one Jacobian). docs/work-precision.md
        fast_opts = {"error_on_fail": False, "abstol": 1e-15, "max_iter": 30}
        if solver == "fast_newton":
            fast_opts["abstolStep"] = 1e-9
        self.rf_fast = ca.rootfinder(f"{name}_fast", solver, G, fast_opts)
        # Failed points are judged by the checks, not by CasADi's NaN warnings (off the surfaces'
        # domain, e.g. inside a base circle, the residual is NaN and the point is simply rejected).
        self.rf_safe = ca.rootfinder(f"{name}_newton", "newton", G, {"error_on_fail": False, "abstol": 1e-13,
                                                                     "abstolStep": 1e-16, "max_iter": 100,
                                                                     "line_search": True,
                                                                     "show_eval_warnings": False})
        self._maps: dict[int, ca.Function] = {}

    def newton(self, w0, prm) -> np.ndarray:
        """Line-search Newton from ``w0`` at one parameter column (unchecked)."""
        return np.asarray(self.rf_safe(np.asarray(w0, float), prm)).ravel()

    def check(self, w, prm):
        """(residual norm, n1 . n2, regularity, accepted) at one point."""
        res = float(np.linalg.norm(np.asarray(self.G(w, prm)).ravel()))
        n1n2, reg = (float(v) for v in self.checks(w, prm))
        return res, n1n2, reg, bool(self.accept(res, n1n2, reg))

    def predict(self, w_a, prm_a, dphi) -> np.ndarray:
        """First guesses ``w_a + dw/dphi1 * dphi`` (nw, len(dphi)) around the solved anchor."""
        dw = np.asarray(self.dw(w_a, prm_a)).ravel()
        return np.asarray(w_a)[:, None] + dw[:, None] * np.asarray(dphi)[None, :]

    def mapped(self, n: int) -> ca.Function:
        """(W0, P) -> (W, residual norm, n1 . n2, regularity) for n columns, compiled with jit."""
        if n not in self._maps:
            W0 = ca.MX.sym("W0", self.G.size1_in(0), n)
            P = ca.MX.sym("P", self.G.size1_in(1), n)
            W = self.rf_fast.map(n)(W0, P)
            R = self.G.map(n)(W, P)
            c = self.checks.map(n)(W, P)
            args = (f"{self.name}_sweep", [W0, P], [W, ca.sqrt(ca.sum1(R * R)), c[0], c[1]], ["W0", "P"],
                    ["W", "res", "n1n2", "reg"])
            f = _jit_function(*args) if self.jit and self.solver == "fast_newton" else None
            self._maps[n] = f if f is not None else ca.Function(*args)
        return self._maps[n]

    def solve(self, W0, prm, groups, max_gap: int = 4):
        """Solve every column; ``groups`` are index arrays ordered by phi1 (continuation runs
        within a group, forwards then backwards, from the last accepted neighbour, for at most
        ``max_gap`` consecutive failures).

        Returns
        -------
        W, res, n1n2, reg, ok, stats
        """
        W, res, n1n2, reg = (np.asarray(v) for v in self.mapped(prm.shape[1])(W0, prm))
        res, n1n2, reg = res.ravel().copy(), n1n2.ravel().copy(), reg.ravel().copy()
        W = W.copy()
        ok = np.asarray(self.accept(res, n1n2, reg), bool)
        n_fast, n_retry = int(ok.sum()), 0
        for idx in groups:
            for order in (idx, idx[::-1]):
                last, misses = None, 0
                for i in order:
                    if ok[i]:
                        last, misses = i, 0
                        continue
                    if last is None or misses >= max_gap:
                        continue  # no accepted neighbour near: the branch has ended here
                    n_retry += 1
                    w = self.newton(W[:, last], prm[:, i])
                    r, d, g, good = self.check(w, prm[:, i])
                    if good:
                        W[:, i], res[i], n1n2[i], reg[i], ok[i] = w, r, d, g, True
                        last, misses = i, 0
                    else:
                        misses += 1
        return W, res, n1n2, reg, ok, {"n_fast": n_fast, "n_retry": n_retry}


def _jit_function(name, ins, outs, in_names, out_names):
    """Compile a Function to C with the system compiler in a scratch directory; None on failure."""
    import contextlib
    import shutil
    import tempfile
    import warnings

    tmp = tempfile.mkdtemp(prefix="gearopt-jit-")
    opts = {"jit": True, "compiler": "shell", "jit_cleanup": False,
            "jit_options": {"flags": ["-O2"], "verbose": False, "cleanup": False}}
    try:
        with contextlib.chdir(tmp):
            f = ca.Function(name, ins, outs, in_names, out_names, opts)
            f(*[np.zeros(i.shape) for i in ins])  # force the compilation now, inside tmp
        return f
    except Exception as e:  # noqa: BLE001 - any compiler problem: fall back to the interpreter
        warnings.warn(f"gearopt: jit compilation failed ({e!s:.200}); using the interpreted sweep.", stacklevel=3)
        return None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
