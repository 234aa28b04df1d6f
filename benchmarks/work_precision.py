"""Work-precision report: TE error against run time per position for every solver path (run:
`PYTHONPATH=. python benchmarks/work_precision.py [--quick]`).

Two problems, each with an exact reference:

* **Planar** -- Litvin & Fuentes Problem 9.4.1 (``gearopt.meshing.planar``), the scene
  ``problems/problem_9_4_1.toml``: r_b1 = 37.5877 mm, r_b2 = 60.1403 mm, E = 106 mm,
  phi1 in [-15, 30] deg. Closed form (eqs. 9.4.36-9.4.41): ``phi2 = (r_b1 phi1 + (r_b1 + r_b2)
  alpha - E sin alpha) / r_b2`` with ``cos alpha = (r_b1 + r_b2) / E``, so TE is exactly 0;
  evaluated in mpmath (40 digits) with the float64 inputs taken as exact. Every solver starts from
  ``planar.initial_guess`` (alpha_guess = 20 deg; the operating angle is 22.785 deg).
* **3-D** -- the crowned, misaligned spur drive of ``benchmarks/bench_tca.py`` (``make_case``):
  pinion z=20, m_n=3, b=20, ISO 53 A rack, a_c=0.002 1/mm, a_pl=0.0004 1/mm; gear z=40; crossing 3',
  intersecting 2', dE=0.05 mm; phi1 in [-pi/z1, pi/z1], tooth pair 0. Reference: the SX algorithm of
  ``TCA.residual`` re-evaluated instruction by instruction in mpmath (40 digits, ``bench_tca.MPEval``)
  and Newton-polished from a tight float64 solution at EVERY position of every sweep (not a subset;
  it costs ~1 ms per position). That is the exact root of the same equations (float64 constants of
  the graph taken as exact), so the error is the true solver error, not a residual estimate, and
  not the modelling error of the equations. Every solver starts from the engine's predictor (the
  implicit-function step around the anchor solve at phi1 = 0).

"TE error" = max over the positions of ``|phi2 - phi2_ref|`` [rad]; TE = phi2 - (z1/z2) phi1 - const
differs from phi2 by a known function, so with the constant fixed by the reference this is the TE
error. "us/pos" = wall time of one whole call (numpy in, numpy out) / N: the fastest call, with all
configurations timed round-robin over 7 rounds (robust to bursts of load on a shared VM).

Outputs: Markdown tables on stdout; the plot (``--png``, default ``docs/work_precision.png``) and the
generated block of ``docs/work-precision.md`` (between the ``BEGIN/END GENERATED`` markers; ``--doc``).
``--quick`` (N = 50, 200; fewer settings) writes the plot to a temporary directory and no document
unless ``--png`` / ``--doc`` are given.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import casadi as ca
import mpmath
import numpy as np
import scipy
from scipy.optimize import fsolve

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
import bench_tca as bt  # noqa: E402  (make_case, MPEval, timed, jit_opts, in_tmpdir)

from gearopt.meshing import planar  # noqa: E402
from gearopt.meshing.tca import NORMAL_TOL, REGULARITY_MIN, TCA  # noqa: E402

DPS = 40
FS_DEFAULT = 1.49012e-08  # scipy's default xtol
BEGIN, END = "<!-- BEGIN GENERATED (benchmarks/work_precision.py) -->", "<!-- END GENERATED -->"

# Planar case (problems/problem_9_4_1.toml)
RB1, RB2, E_PL = 37.58770483143634, 60.14032773029814, 106.0
PHI_PL = (-15 * math.pi / 180, 30 * math.pi / 180)


# ---------------------------------------------------------------------------------------------
# Generic solver paths on a square system G(w, prm) -> F with prm = (phi1, c), c constant
# ---------------------------------------------------------------------------------------------
def mapped(G: ca.Function, plugin: str, opts: dict, n: int, jit: bool = False):
    """(W0 (nw x n), phi1 (1 x n), c) -> W through ``rootfinder(plugin).map(n)``; with ``jit`` the whole
    mapped function is compiled by the system gcc (-O2). Returns (Function, build/compile seconds)."""
    t0 = time.perf_counter()
    nw, nc = G.size1_in(0), G.size1_in(1) - 1
    rf = ca.rootfinder("rf", plugin, G, dict(opts))
    X0, phi, c = ca.MX.sym("X0", nw, n), ca.MX.sym("phi", 1, n), ca.MX.sym("c", nc)
    W = rf.map(n)(X0, ca.vertcat(phi, ca.repmat(c, 1, n)))
    if jit:
        with bt.in_tmpdir():
            f = ca.Function("wp_sweep", [X0, phi, c], [W], bt.jit_opts(["-O2"]))
            f(np.zeros((nw, n)), np.zeros((1, n)), np.zeros(nc))  # compile now, in the scratch dir
    else:
        f = ca.Function("wp_sweep", [X0, phi, c], [W])
    return f, time.perf_counter() - t0


class Fsolve:
    """``scipy.optimize.fsolve`` (MINPACK hybrd / hybrj) per position on G and its AD Jacobian, both
    called through CasADi's ``Function.buffer()`` (~1.4 us a call instead of ~30 us for
    ``Function.__call__``; see bench_tca.py)."""

    def __init__(self, G: ca.Function):
        nw, npr = G.size1_in(0), G.size1_in(1)
        w, p = ca.SX.sym("w", nw), ca.SX.sym("p", npr)
        F = G(w, p)
        J = ca.Function("J", [w, p], [ca.densify(ca.jacobian(F, w))])
        Fo = ca.Function("F", [w, p], [F])
        self.nw, self.bufs = nw, {}
        for key, f, size in (("F", Fo, nw), ("J", J, nw * nw)):
            buf, trig = f.buffer()
            x_in, p_in, out = np.zeros(nw), np.zeros(npr), np.zeros(size)
            buf.set_arg(0, memoryview(x_in))
            buf.set_arg(1, memoryview(p_in))
            buf.set_res(0, memoryview(out))
            self.bufs[key] = (buf, trig, x_in, p_in, out)

    def _f(self, x):
        _, trig, x_in, _, out = self.bufs["F"]
        x_in[:] = x
        trig()
        return out.copy()

    def _j(self, x):
        _, trig, x_in, _, out = self.bufs["J"]
        x_in[:] = x
        trig()
        return out.reshape((self.nw, self.nw), order="F").copy()

    def run(self, W0, P, xtol, ad):
        n = P.shape[1]
        W, ier, calls = np.empty((self.nw, n)), np.empty(n, int), np.empty(n)
        for i in range(n):
            self.bufs["F"][3][:] = P[:, i]
            self.bufs["J"][3][:] = P[:, i]
            x, info, ier[i], _ = fsolve(self._f, W0[:, i], fprime=self._j if ad else None, xtol=xtol,
                                        full_output=True)
            W[:, i] = x
            calls[i] = info["nfev"] + info.get("njev", 0)
        return W, ier, calls


# ---------------------------------------------------------------------------------------------
# Problems: residual, guesses, reference, evaluation
# ---------------------------------------------------------------------------------------------
class PlanarProblem:
    key, title = "planar", "Planar, Problem 9.4.1 (closed form)"

    def __init__(self, n):
        x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 4)  # p = (phi1, r_b1, r_b2, E)
        g = planar.tangency_residual(x, p[0], p[1], p[2], p[3])
        self.G = ca.Function("planar_g", [x, p], [g])
        self.n = n
        self.phi = np.linspace(*PHI_PL, n)
        self.c = np.array([RB1, RB2, E_PL])
        self.P = np.vstack([self.phi[None, :], np.tile(self.c[:, None], n)])
        self.W0 = planar.initial_guess(self.phi, RB1, RB2, E_PL)
        self.iw = 2  # phi2 is x[2] [rad]
        self.scale = 1.0
        self.tol = 1e-12  # PlanarTCA default (scaled residual)
        t0 = time.perf_counter()
        mpmath.mp.dps = DPS
        rb1, rb2, E = (mpmath.mpf(v) for v in (RB1, RB2, E_PL))
        alpha = mpmath.acos((rb1 + rb2) / E)
        L = E * mpmath.sin(alpha)
        self.ref = [(rb1 * mpmath.mpf(float(f)) + (rb1 + rb2) * alpha - L) / rb2 for f in self.phi]
        ref_x = np.array([[float(alpha + mpmath.mpf(float(f))) for f in self.phi],
                          [float((L - rb1 * (alpha + mpmath.mpf(float(f)))) / rb2) for f in self.phi],
                          [float(r) for r in self.ref]])
        self.t_ref = time.perf_counter() - t0
        self.ref_note = "closed form in mpmath, 40 digits"
        self.floor = _floor(self.G, ref_x, self.P, self.iw, self.scale)
        self.res_map = self.G.map(n)
        self.fun_map = planar.planar_functions()["residual"].map(n)

    def evaluate(self, W):
        """(errors (n,), fail mask, residual-above-tol mask)."""
        W = np.asarray(W, float)
        fin = np.all(np.isfinite(W), axis=0)
        Wz = np.where(fin, W, 0.0)
        out = self.fun_map(Wz, self.phi[None, :], RB1, RB2, E_PL)
        res = np.linalg.norm(np.asarray(out[0]), axis=0)
        ndot = np.sum(np.asarray(out[3]) * np.asarray(out[4]), axis=0)
        fail = ~fin | ~(ndot > 0) | ~((Wz[0] > 1e-6) & (Wz[1] > 1e-6))
        return _err(W[self.iw], self.ref, self.scale), fail, ~fail & ~(res <= self.tol)


class Drive3D:
    key, title = "3d", "3-D crowned, misaligned spur drive (mpmath reference)"

    def __init__(self, n):
        self.case = case = bt.make_case(n)
        self.tca = tca = case["tca"]
        self.G, self.n, self.phi, self.c, self.P, self.W0 = tca.residual, n, case["phi"], case["c"], case["P"], case["W0"]
        self.iw, self.scale, self.tol = 4, tca.scale2, tca.tol
        self.res_map = tca.residual.map(n)
        self.chk_map = tca.branch.checks.map(n)
        t0 = time.perf_counter()
        rf = ca.rootfinder("rf_ref", "newton", tca.residual, {"abstol": 1e-15, "abstolStep": 1e-17, "max_iter": 50,
                                                               "line_search": True, "error_on_fail": False})
        W_start = np.asarray(rf.map(n)(self.W0, self.P))
        self.ref, ref_x, self.last_step = _polish(tca, W_start, self.P)
        self.t_ref = time.perf_counter() - t0
        self.ref_note = (f"mpmath {DPS} digits on the SX graph of TCA.residual, Newton-polished (last step "
                         f"{self.last_step:.0e} mm)")
        self.floor = _floor(self.G, ref_x, self.P, self.iw, self.scale)

    def evaluate(self, W):
        W = np.asarray(W, float)
        fin = np.all(np.isfinite(W), axis=0)
        Wz = np.where(fin, W, 0.0)
        res = np.linalg.norm(np.asarray(self.res_map(Wz, self.P)), axis=0)
        n1n2, reg = (np.asarray(v).ravel() for v in self.chk_map(Wz, self.P))
        fail = ~fin | ~(n1n2 < -1 + NORMAL_TOL) | ~(reg > REGULARITY_MIN)
        return _err(W[self.iw], self.ref, self.scale), fail, ~fail & ~(res <= self.tol)


def _polish(tca, W_start, P):
    """Newton in mpmath on the SX algorithm of TCA.residual, float64 AD Jacobian re-evaluated at each
    (rounded) iterate; returns (phi2_ref as mpf [rad], W_ref rounded to float64, largest last step)."""
    ev = bt.MPEval(tca.residual)
    mpmath.mp.dps = DPS
    sc = mpmath.mpf(tca.scale2)
    refs, W64, last = [], np.empty_like(W_start), 0.0
    for i in range(P.shape[1]):
        p = [mpmath.mpf(float(v)) for v in P[:, i]]
        w = [mpmath.mpf(float(v)) for v in W_start[:, i]]
        for _ in range(8):
            wf = np.array([float(v) for v in w])
            J = np.asarray(tca.jacobian(wf, P[:, i]))
            Fm = ev(w, p)[0]
            d = np.linalg.solve(J, np.array([float(v) for v in Fm]))
            w = [wk - mpmath.mpf(float(dk)) for wk, dk in zip(w, d)]
            step = float(np.abs(d).max())
            if step < 1e-30:
                break
        last = max(last, step)
        refs.append(w[4] / sc)
        W64[:, i] = [float(v) for v in w]
    return refs, W64, last


def _floor(G, W_ref64, P, iw, scale):
    """float64 floor: the Newton correction computed from the residual evaluated in float64 at the
    exact root rounded to float64 -- what rounding of F alone moves phi2 by [rad]."""
    w, p = ca.SX.sym("w", G.size1_in(0)), ca.SX.sym("p", G.size1_in(1))
    step = ca.Function("step", [w, p], [ca.solve(ca.jacobian(G(w, p), w), G(w, p))]).map(P.shape[1])
    return float(np.max(np.abs(np.asarray(step(W_ref64, P))[iw]))) / scale


def _err(x_row, ref, scale):
    sc = mpmath.mpf(scale)
    return np.array([abs(float(mpmath.mpf(float(v)) / sc - r)) if np.isfinite(v) else np.inf
                     for v, r in zip(x_row, ref)])


# ---------------------------------------------------------------------------------------------
# Run every path on one problem and one N
# ---------------------------------------------------------------------------------------------
PATH_STYLE = {  # label: (colour, marker)
    "gearopt engine": ("black", "*"),
    "gearopt engine, jit": ("tab:gray", "*"),
    "gearopt continuation": ("tab:brown", "*"),
    "newton (line search) map": ("tab:blue", "o"),
    "newton (no line search) map": ("tab:cyan", "v"),
    "fast_newton map": ("tab:green", "s"),
    "fast_newton map, jit": ("tab:olive", "D"),
    "kinsol map": ("tab:purple", "^"),
    "fsolve FD Jacobian": ("tab:red", "x"),
    "fsolve AD Jacobian": ("tab:orange", "+"),
}


def run_problem(prob, quick, rounds, slice_s):
    """Build every configuration, time them round-robin (``rounds`` rounds; in each round every
    configuration is called for at least ``slice_s`` seconds; the reported time is the fastest call
    over all rounds, so a burst of load on the shared VM hits one round of all configurations rather
    than every repeat of one), then evaluate the solutions against the reference."""
    n = prob.n
    phi_row = prob.phi[None, :]
    entries = []  # dict(path, setting, series, order, note, call, info)

    def entry(path, setting, call, series="tol", note="", order=0.0, info=None):
        entries.append(dict(path=path, setting=setting, call=call, series=series, note=note, order=order,
                            info=info if info is not None else {}))

    # --- the engine's own paths -----------------------------------------------------------------
    if prob.key == "planar":
        eng = planar.PlanarTCA(RB1, RB2, E_PL)
        for path, method in (("gearopt engine", "map"), ("gearopt continuation", "continuation")):
            info = {}

            def call(m=method, info=info):
                r = eng.solve(prob.phi, method=m, on_fail="flag")
                info["solve_s"] = min(info.get("solve_s", math.inf), r.solve_time_s)
                W = np.vstack([r.theta1, r.theta2, r.phi2])
                W[:, ~r.ok] = np.nan
                return W

            entry(path, f"PlanarTCA.solve({method!r})", call, "engine", info=info)
    else:
        tca, mis = prob.tca, prob.case["mis"]

        def sweep_w(t):
            r = t.sweep(prob.phi, mis=mis, pairs=(0,))
            return np.vstack([r.u1[0], r.z1[0], r.u2[0], r.z2[0], r.phi2[0] * prob.scale])

        entry("gearopt engine", "TCA.sweep", lambda: sweep_w(tca), "engine")
        t0 = time.perf_counter()
        tca_j = TCA(tca.pair, jit=True)
        tca_j.sweep(prob.phi, mis=mis, pairs=(0,))  # compile the maps of size N
        entry("gearopt engine, jit", "TCA(jit=True).sweep", lambda: sweep_w(tca_j), "engine",
              note=f"build+compile {time.perf_counter() - t0:.1f} s")

    # --- CasADi rootfinders, mapped ---------------------------------------------------------------
    tols = (1e-6, 1e-12) if quick else (1e-6, 1e-9, 1e-12, 1e-14)
    iters = (1, 2, 3) if prob.key == "3d" else (2, 3, 4, 5)
    if quick:
        iters = iters[:2]
    variants = [("newton (line search) map", "newton", {"line_search": True}, False),
                ("newton (no line search) map", "newton", {"line_search": False}, False),
                ("fast_newton map", "fast_newton", {}, False),
                ("fast_newton map, jit", "fast_newton", {}, True),
                ("kinsol map", "kinsol", {}, False)]
    for path, plugin, extra, jit in variants:
        settings = [(f"abstol={tol:.0e}", "tol", -math.log10(tol), {"abstol": tol}) for tol in tols]
        if plugin != "kinsol":
            settings += [(f"max_iter={k}", "iter", k, {"max_iter": k}) for k in iters]
            if not quick:
                settings.append(("abstol=1e-14, abstolStep=1e-16", "tight", 50, {"abstol": 1e-14, "abstolStep": 1e-16}))
        if plugin == "fast_newton" and prob.key == "3d":
            settings.append(("engine: abstol=1e-13, abstolStep=1e-9", "engine-opts", 99,
                             {"abstol": 1e-13, "abstolStep": 1e-9, "max_iter": 30}))
        if plugin == "fast_newton":  # proposed engine setting: the step test ends it, the step is applied
            settings.append(("proposed: abstol=1e-15, abstolStep=1e-9", "engine-opts", 98,
                             {"abstol": 1e-15, "abstolStep": 1e-9, "max_iter": 30}))
        for setting, series, order, o in settings:
            opts = {"error_on_fail": False, **extra, **o}
            if plugin == "newton":
                opts["show_eval_warnings"] = False
            try:
                S, tb = mapped(prob.G, plugin, opts, n, jit)
            except Exception as exc:  # noqa: BLE001
                print(f"  {path} {setting}: not available ({str(exc).splitlines()[0][:100]})")
                continue
            entry(path, setting, lambda S=S: np.asarray(S(prob.W0, phi_row, prob.c)), series,
                  note=f"compile {tb:.2f} s" if jit else "", order=order)

    # --- MINPACK ----------------------------------------------------------------------------------
    fs = Fsolve(prob.G)
    xtols = (1e-4, FS_DEFAULT, 1e-13) if quick else (1e-4, 1e-6, FS_DEFAULT, 1e-10, 1e-13)
    for path, ad in (("fsolve FD Jacobian", False), ("fsolve AD Jacobian", True)):
        for xtol in xtols:
            info = {}

            def run(xtol=xtol, ad=ad, info=info):
                W, ier, calls = fs.run(prob.W0, prob.P, xtol, ad)
                info["ier"], info["calls"] = ier, calls
                return W

            entry(path, f"xtol={xtol:.0e}" + (" (default)" if xtol == FS_DEFAULT else ""), run, "tol",
                  order=-math.log10(xtol), info=info)

    # --- timing, round-robin ----------------------------------------------------------------------
    for e in entries:
        e["W"] = e["call"]()  # warm-up (work vectors, caches); this output is the one evaluated
        e["t"] = math.inf
    for _ in range(rounds):
        for e in entries:
            t_slice = time.perf_counter()
            while True:
                t0 = time.perf_counter()
                e["call"]()
                t1 = time.perf_counter()
                e["t"] = min(e["t"], t1 - t0)
                if t1 - t_slice >= slice_s:
                    break

    rows = []
    for e in entries:
        err, fail, restol = prob.evaluate(e["W"])
        ok = ~fail
        note, info = e["note"], e["info"]
        if "ier" in info:
            note = f"ier!=1: {int((info['ier'] != 1).sum())}; {info['calls'].mean():.1f} F+J calls/pos"
        if "solve_s" in info:
            note = f"solver alone {1e6 * info['solve_s'] / n:.1f} us/pos"
        rows.append(dict(problem=prob.key, N=n, path=e["path"], setting=e["setting"], series=e["series"],
                         order=e["order"], us=1e6 * e["t"] / n, err=float(err[ok].max()) if ok.any() else math.nan,
                         err_med=float(np.median(err[ok])) if ok.any() else math.nan,
                         fail=int(fail.sum()), restol=int(restol.sum()), note=note))
        r = rows[-1]
        print(f"  [{prob.key} N={n:4d}] {r['path']:28s} {r['setting']:26s} {r['us']:9.2f} us/pos  err {r['err']:.1e}  "
              f"fail {r['fail']}  res>tol {r['restol']} {note}", flush=True)
    return rows


# ---------------------------------------------------------------------------------------------
# Pareto front, tables, plot, document
# ---------------------------------------------------------------------------------------------
def mark_pareto(rows, floors):
    """Within each (problem, N): a configuration without failures is Pareto-optimal when no other
    configuration without failures is both at least as fast and at least as accurate (one of them
    strictly). Errors up to twice the float64 floor count as equal (rounding noise, not accuracy)."""
    for r in rows:
        r["pareto"] = False
    groups = {}
    for r in rows:
        groups.setdefault((r["problem"], r["N"]), []).append(r)
    for g in groups.values():
        cand = [r for r in g if r["fail"] == 0 and math.isfinite(r["err"])]
        fl = 2 * floors[g[0]["problem"]]
        e = {id(r): max(r["err"], fl) for r in cand}
        for r in cand:
            r["pareto"] = not any((o["us"] <= r["us"] and e[id(o)] <= e[id(r)])
                                  and (o["us"] < r["us"] or e[id(o)] < e[id(r)]) for o in cand if o is not r)


def fmt_err(e):
    return "nan" if not math.isfinite(e) else ("0" if e == 0 else f"{e:.1e}")


def tables(rows, problems, Ns):
    out = []
    for prob in problems:
        pr = [r for r in rows if r["problem"] == prob.key]
        keys = list(dict.fromkeys((r["path"], r["setting"]) for r in pr))
        out.append(f"### {prob.title}\n")
        out.append(f"Reference: {prob.ref_note}; float64 floor of phi2 (N = {prob.n}): {prob.floor:.1e} rad. "
                   f"Tolerance of the acceptance check (res>tol column): {prob.tol:g} "
                   f"{'(scaled, dimensionless)' if prob.key == 'planar' else 'mm'}.\n")
        hdr = "| path | setting | " + " | ".join(f"N={n} us/pos | N={n} max err [rad] | N={n} flags" for n in Ns) + " | note |"
        out.append(hdr)
        out.append("|" + "---|" * (3 + 3 * len(Ns)))
        for path, setting in keys:
            cells = [path, setting]
            note = ""
            for n in Ns:
                r = next((r for r in pr if r["N"] == n and r["path"] == path and r["setting"] == setting), None)
                if r is None:
                    cells += ["", "", ""]
                    continue
                flags = []
                if r["pareto"]:
                    flags.append("**P**")
                if r["fail"]:
                    flags.append(f"fail {r['fail']}")
                if r["restol"]:
                    flags.append(f"res>tol {r['restol']}")
                cells += [f"{r['us']:.2f}", fmt_err(r["err"]), ", ".join(flags)]
                note = r["note"] or note
            out.append("| " + " | ".join(cells) + f" | {note} |")
        out.append("")
    return "\n".join(out)


def summary(rows, problems, Ns):
    """Pareto-optimal configurations at the largest N."""
    n = max(Ns)
    out = [f"### Pareto-optimal configurations at N = {n}\n",
           "| problem | path | setting | us/pos | max err [rad] | median err [rad] | res>tol |",
           "|---|---|---|---|---|---|---|"]
    for prob in problems:
        for r in sorted((r for r in rows if r["problem"] == prob.key and r["N"] == n and r["pareto"]), key=lambda r: r["us"]):
            out.append(f"| {prob.key} | {r['path']} | {r['setting']} | {r['us']:.2f} | {fmt_err(r['err'])} | "
                       f"{fmt_err(r['err_med'])} | {r['restol']} |")
    out.append("")
    return "\n".join(out)


def plot(rows, problems, Ns, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from matplotlib.ticker import LogLocator, NullFormatter

    fig, axs = plt.subplots(len(problems), len(Ns), figsize=(5.2 * len(Ns), 4.6 * len(problems)), squeeze=False,
                            sharey="row", sharex=True)
    lo = 1e-18
    for i, prob in enumerate(problems):
        for j, n in enumerate(Ns):
            ax = axs[i, j]
            rs = [r for r in rows if r["problem"] == prob.key and r["N"] == n]
            for pth, (col, mk) in PATH_STYLE.items():
                for series, ls in (("tol", "-"), ("iter", ":"), ("engine", ""), ("engine-opts", ""), ("tight", "")):
                    pts = sorted((r for r in rs if r["path"] == pth and r["series"] == series), key=lambda r: r["order"])
                    if not pts:
                        continue
                    x = [r["us"] * 1e-6 for r in pts]
                    y = [max(r["err"], lo) if math.isfinite(r["err"]) else np.nan for r in pts]
                    if ls:
                        ax.plot(x, y, ls, color=col, lw=1, alpha=0.8)
                    for r, xx, yy in zip(pts, x, y):
                        big = series in ("engine", "engine-opts")
                        ax.plot(xx, yy, mk, color=col, ms=(13 if mk == "*" else 9) if big else 6,
                                mfc="none" if (r["fail"] and mk not in "x+") else col,
                                mec="red" if r["fail"] else col, label=None)
            par = sorted((r for r in rs if r["pareto"]), key=lambda r: r["us"])
            if par:
                ax.step([r["us"] * 1e-6 for r in par], [max(r["err"], lo) for r in par], where="post",
                        color="k", lw=2.2, alpha=0.35, zorder=0)
                ax.plot([r["us"] * 1e-6 for r in par], [max(r["err"], lo) for r in par], "o", ms=15, mfc="none",
                        mec="k", mew=1.2, alpha=0.6)
            ax.axhline(prob.floor, color="gray", ls="--", lw=0.8)
            ax.text(0.01, prob.floor, "float64 floor", transform=ax.get_yaxis_transform(), ha="left", va="top",
                    fontsize=7, color="gray")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.xaxis.set_major_locator(LogLocator(base=10, numticks=12))
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_title(f"{'planar 9.4.1' if prob.key == 'planar' else '3-D crowned, misaligned'}: N = {n}", fontsize=10)
            ax.grid(True, which="major", alpha=0.3)
            if i == len(problems) - 1:
                ax.set_xlabel("run time per position [s]")
            if j == 0:
                ax.set_ylabel("max TE error [rad]")
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=c, marker=m, ls="-", label=p) for p, (c, m) in PATH_STYLE.items()]
    handles += [Line2D([], [], color="k", ls=":", label="max_iter series"),
                Line2D([], [], color="k", marker="o", ms=12, mfc="none", ls="", label="Pareto-optimal (no failures)"),
                Line2D([], [], color="w", marker="s", mec="red", mfc="none", ls="", label="red edge: failures")]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=8, frameon=False)
    fig.suptitle("gearopt TCA: work-precision (error vs exact root; lines: tolerance sweeps)", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def machine_note():
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except Exception:  # noqa: BLE001
        cpu = platform.processor() or platform.machine()
    try:
        gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    except Exception:  # noqa: BLE001
        gcc = "no gcc"
    return (f"{datetime.date.today().isoformat()}; {os.cpu_count()} cores, {cpu}, {platform.system()} "
            f"{platform.machine()}; Python {platform.python_version()}, casadi {ca.__version__}, numpy "
            f"{np.__version__}, scipy {scipy.__version__}, mpmath {mpmath.__version__}; {gcc} (casadi 'shell' jit)")


def write_doc(doc, text):
    src = doc.read_text() if doc.exists() else f"# Work-precision\n\n{BEGIN}\n{END}\n"
    if BEGIN not in src or END not in src:
        src += f"\n{BEGIN}\n{END}\n"
    a, rest = src.split(BEGIN, 1)
    _, b = rest.split(END, 1)
    tmp = doc.with_suffix(".md.tmp")
    tmp.write_text(a + BEGIN + "\n" + text.rstrip() + "\n" + END + b)
    os.replace(tmp, doc)


# ---------------------------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="N = 50, 200 and fewer settings (< 1 min)")
    ap.add_argument("--png", type=Path, default=None, help="plot file (default docs/work_precision.png; quick: temp dir)")
    ap.add_argument("--doc", type=Path, default=None,
                    help="Markdown file whose generated block is replaced (default docs/work-precision.md; quick: none)")
    args = ap.parse_args(argv)
    quick = args.quick
    Ns = (50, 200) if quick else (50, 200, 1000)
    rounds, slice_s = (3, 0.01) if quick else (7, 0.03)
    png = args.png or (Path(tempfile.gettempdir()) / "work_precision_quick.png" if quick else ROOT / "docs" / "work_precision.png")
    doc = args.doc or (None if quick else ROOT / "docs" / "work-precision.md")
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    t_start = time.perf_counter()
    rows, problems = [], {}
    for cls in (PlanarProblem, Drive3D):
        for n in Ns:
            prob = cls(n)
            problems[cls.key] = prob  # keep the largest N's instance (reference note, floor)
            print(f"{prob.title}, N = {n}: reference in {prob.t_ref:.1f} s; float64 floor {prob.floor:.1e} rad", flush=True)
            rows += run_problem(prob, quick, rounds, slice_s)
    if bt._JIT_DIR is not None:
        shutil.rmtree(bt._JIT_DIR, ignore_errors=True)
    mark_pareto(rows, {k: p.floor for k, p in problems.items()})
    probs = list(problems.values())
    cmd = f"PYTHONPATH=. {sys.executable} benchmarks/work_precision.py" + (" --quick" if quick else "")
    total = time.perf_counter() - t_start
    text = "\n".join([
        f"Generated by `{cmd}` in {total:.0f} s on {machine_note()}.\n",
        "![work-precision](work_precision.png)\n" if doc is not None else "",
        summary(rows, probs, Ns),
        "### All configurations\n",
        "flags: **P** = Pareto-optimal at that N (no failures); fail k = k positions not finite or not a contact "
        "point (false root: normals, singular point); res>tol k = k positions whose residual is above the engine's "
        "acceptance tolerance (gearopt would reject and re-solve them). max err over the positions without "
        "failure.\n",
        tables(rows, probs, Ns),
    ])
    print()
    print(text)
    png.parent.mkdir(parents=True, exist_ok=True)
    plot(rows, probs, Ns, png)
    print(f"plot: {png}")
    if doc is not None:
        write_doc(doc, text)
        print(f"document: {doc} (generated block)")
    print(f"total {time.perf_counter() - t_start:.1f} s")
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
