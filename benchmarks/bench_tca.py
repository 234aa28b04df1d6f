"""TCA sweep: CasADi rootfinders vs MINPACK on the same equations (run:
`PYTHONPATH=. python benchmarks/bench_tca.py [--quick]`).

Case: a crowned, misaligned 3-D spur pair (pinion z=20, m_n=3, b=20, ISO 53 A rack with profile
crowning a_c=0.002 1/mm, plunging a_pl=0.0004 1/mm; gear z=40; crossing 3', intersecting 2',
dE=0.05 mm); N=1000 pinion angles over one cycle [-pi/z1, pi/z1], tooth pair 0.

Every method solves the equations of ``TCA.residual`` (w = (u1, z1, u2, z2, r_p2 phi2), prm) from
the same first guesses: the implicit-function predictor of ``TCA.sweep``
(``w0(phi1) = w_a - (J^-1 dF/dphi1)(w_a) (phi1 - 0)`` around the anchor solve at phi1 = 0).

Reference phi2: the SX algorithm of ``TCA.residual`` (the very same expression graph, with its
float64 constants taken as exact) is re-evaluated instruction by instruction in mpmath at 32
digits, and Newton-polished from the float64 solution (correction ``J^-1 F_mp`` with the float64 AD
Jacobian, which still converges linearly with a factor ~cond(J) eps) until the last correction is
below 1e-25 mm. "phi2 err" is ``max |phi2 - phi2_ref|`` [rad] over the positions a method solved;
the float64 floor (rounding of the residual itself) is printed as well.

Timing: "us/pos" is the wall time of the solve call divided by N (median over repeats), numpy
arrays in and out (the conversion of numpy <-> DM costs ~65 ns per double, so the mapped
functions take phi1 as a 1xN row and the 13 design parameters as one column broadcast inside);
"build" is the graph construction, "compile" the C code generation + gcc (jit).
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import hashlib
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
import warnings

import casadi as ca
import mpmath
import numpy as np
from scipy.optimize import fsolve

from gearopt import ARCMIN, BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment

FS_TOL = 1.49012e-08  # scipy default xtol
RF_OPTS = {"abstol": 1e-13, "max_iter": 30, "error_on_fail": False}  # the engine's fast_newton options
RF_OPTS_STEP = {"abstol": 1e-13, "abstolStep": 1e-9, "max_iter": 30, "error_on_fail": False}


# ---------------------------------------------------------------------------------------------
# Case
# ---------------------------------------------------------------------------------------------
def make_case(n):
    t0 = time.perf_counter()
    g1 = Gear(z=20, m_n=3.0, b=20.0, rack=BasicRack.iso53("A", a_c=0.002), a_pl=0.0004, name="pinion")
    g2 = Gear(z=40, m_n=3.0, b=20.0, name="gear")
    tca = TCA(GearPair(g1, g2))
    t_build = time.perf_counter() - t0
    mis = Misalignment(crossing=3 * ARCMIN, intersecting=2 * ARCMIN, dE=0.05)
    phi = np.linspace(-math.pi / g1.z, math.pi / g1.z, n)
    P = tca.prm(phi, mis=mis)
    c = P[1:, 0].copy()  # design parameters + misalignments + z_section (constant over the sweep)
    # The engine's predictor: anchor solve at phi1 = 0, then w0 = w_a + dw/dphi1 * phi1.
    w_a = tca.solve_point(0.0, mis=mis)
    w, p = ca.SX.sym("w", 5), ca.SX.sym("p", P.shape[0])
    F = tca.residual(w, p)
    dwf = ca.Function("dw", [w, p], [-ca.solve(ca.jacobian(F, w), ca.jacobian(F, p)[:, 0])])
    dw = np.asarray(dwf(w_a, np.concatenate([[0.0], c]))).ravel()
    W0 = w_a[:, None] + dw[:, None] * phi[None, :]
    return dict(tca=tca, mis=mis, phi=phi, P=P, c=c, w_a=w_a, dw=dw, W0=W0, t_build=t_build, g1=g1, g2=g2)


# ---------------------------------------------------------------------------------------------
# Reference: the SX algorithm of TCA.residual evaluated in mpmath
# ---------------------------------------------------------------------------------------------
def _mp_ops():
    m = mpmath
    un = {ca.OP_NEG: lambda a: -a, ca.OP_SQ: lambda a: a * a, ca.OP_TWICE: lambda a: 2 * a, ca.OP_SIN: m.sin,
          ca.OP_COS: m.cos, ca.OP_TAN: m.tan, ca.OP_SQRT: m.sqrt, ca.OP_EXP: m.exp, ca.OP_LOG: m.log,
          ca.OP_ASIN: m.asin, ca.OP_ACOS: m.acos, ca.OP_ATAN: m.atan, ca.OP_FABS: abs, ca.OP_INV: lambda a: 1 / a,
          ca.OP_ASSIGN: lambda a: a, ca.OP_SIGN: m.sign, ca.OP_SINH: m.sinh, ca.OP_COSH: m.cosh,
          ca.OP_TANH: m.tanh}
    bi = {ca.OP_ADD: lambda a, b: a + b, ca.OP_SUB: lambda a, b: a - b, ca.OP_MUL: lambda a, b: a * b,
          ca.OP_DIV: lambda a, b: a / b, ca.OP_POW: lambda a, b: a**b, ca.OP_CONSTPOW: lambda a, b: a**b,
          ca.OP_ATAN2: m.atan2, ca.OP_FMIN: min, ca.OP_FMAX: max, ca.OP_HYPOT: m.hypot,
          ca.OP_IF_ELSE_ZERO: lambda a, b: b if a != 0 else m.mpf(0)}
    return un, bi


class MPEval:
    """Evaluate an SX Function's algorithm in mpmath (inputs and constants exact as float64)."""

    def __init__(self, f: ca.Function):
        un, bi = _mp_ops()
        self.prog, self.n_out = [], [f.nnz_out(i) for i in range(f.n_out())]
        for k in range(f.n_instructions()):
            op, ins, outs = f.instruction_id(k), f.instruction_input(k), f.instruction_output(k)
            if op == ca.OP_CONST:
                self.prog.append(("c", outs[0], mpmath.mpf(f.instruction_constant(k))))
            elif op == ca.OP_INPUT:
                self.prog.append(("i", outs[0], ins[0], ins[1]))
            elif op == ca.OP_OUTPUT:
                self.prog.append(("o", ins[0], outs[0], outs[1]))
            elif op in un:
                self.prog.append(("u", outs[0], un[op], ins[0]))
            elif op in bi:
                self.prog.append(("b", outs[0], bi[op], ins[0], ins[1]))
            else:
                raise NotImplementedError(f"SX operation {op} in the reference evaluator")

    def __call__(self, *args):
        w, out = {}, [[None] * n for n in self.n_out]
        for ins in self.prog:
            t = ins[0]
            if t == "b":
                w[ins[1]] = ins[2](w[ins[3]], w[ins[4]])
            elif t == "u":
                w[ins[1]] = ins[2](w[ins[3]])
            elif t == "c":
                w[ins[1]] = ins[2]
            elif t == "i":
                w[ins[1]] = args[ins[2]][ins[3]]
            else:
                out[ins[2]][ins[3]] = w[ins[1]]
        return out


def reference(case, W_start):
    """Newton-polish every position in mpmath; returns (W_ref as mpf lists, max last step [mm])."""
    tca, P = case["tca"], case["P"]
    ev = MPEval(tca.residual)
    mpmath.mp.dps = 32
    refs, last = [], 0.0
    for i in range(P.shape[1]):
        p = [mpmath.mpf(float(v)) for v in P[:, i]]
        w = [mpmath.mpf(float(v)) for v in W_start[:, i]]
        J = np.asarray(tca.jacobian(W_start[:, i], P[:, i]))
        for _ in range(6):
            Fm = ev(w, p)[0]
            d = np.linalg.solve(J, np.array([float(v) for v in Fm]))
            w = [wk - mpmath.mpf(float(dk)) for wk, dk in zip(w, d)]
            step = float(np.abs(d).max())
            if step < 1e-25:
                break
        last = max(last, step)
        refs.append(w)
    return refs, last


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------
_JIT_DIR = None


@contextlib.contextmanager
def in_tmpdir():
    """CasADi's jit writes its C/.so files into the working directory: build in a private temporary
    directory (removed at the end of the run; CasADi's own cleanup is off so that nothing is deleted
    twice while the libraries are still loaded)."""
    global _JIT_DIR
    if _JIT_DIR is None:
        _JIT_DIR = tempfile.mkdtemp(prefix="gearopt_jit_")
    old = os.getcwd()
    os.chdir(_JIT_DIR)
    try:
        yield _JIT_DIR
    finally:
        os.chdir(old)


def jit_opts(flags):
    return {"jit": True, "compiler": "shell", "jit_cleanup": False,
            "jit_options": {"flags": list(flags), "verbose": False, "cleanup": False}}


def compile_cached(fun: ca.Function, flags, cache_dir):
    """Code-generate ``fun``, compile it with gcc into ``cache_dir`` (keyed by a hash of the C source and
    the flags) and load it with ``ca.external``. Returns (Function, compile_s, cache_hit)."""
    t0 = time.perf_counter()
    cg = ca.CodeGenerator(fun.name() + ".c")
    cg.add(fun)
    src = cg.dump()
    key = hashlib.sha1((src + "|" + " ".join(flags)).encode()).hexdigest()[:16]
    so = os.path.join(cache_dir, f"{fun.name()}_{key}.so")
    hit = os.path.exists(so)
    if not hit:
        cfile = os.path.join(cache_dir, f"{fun.name()}_{key}.c")
        with open(cfile, "w") as fh:
            fh.write(src)
        subprocess.run(["gcc", *flags, "-fPIC", "-shared", cfile, "-o", so + ".tmp", "-lm"], check=True)
        os.replace(so + ".tmp", so)
    return ca.external(fun.name(), so), time.perf_counter() - t0, hit


def timed(f, repeats, min_time=0.25):
    """Median wall time of ``f()`` over at least ``repeats`` calls and at least ``min_time`` seconds."""
    f()  # warm-up (first call allocates the work vectors)
    ts = []
    while len(ts) < repeats or sum(ts) < min_time:
        t0 = time.perf_counter()
        out = f()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts)), out


# ---------------------------------------------------------------------------------------------
# Mapped CasADi solvers: S(W0 (5xN), phi1 (1xN), c (13x1)) -> W (5xN)
# ---------------------------------------------------------------------------------------------
def mapped_solver(case, plugin, opts, n, jit_flags=None, mode="serial", fused=False):
    """Build the mapped rootfinder. ``fused``: the predictor w0 = w_a + dw phi1 is computed inside
    (inputs phi1 (1xN), w_a, dw, c) so only N doubles cross the Python boundary."""
    G = case["tca"].residual
    nc = case["c"].size
    rf = ca.rootfinder("rf", plugin, G, dict(opts))
    phi = ca.MX.sym("phi", 1, n)
    c = ca.MX.sym("c", nc)
    wa, dw = ca.MX.sym("wa", 5), ca.MX.sym("dw", 5)
    X0 = ca.MX.sym("W0", 5, n)
    if mode == "thread":
        # Compile (if jit) one position, then let CasADi's thread map run it on 2 cores.
        ph1, x1 = ca.MX.sym("ph1"), ca.MX.sym("x1", 5)
        if fused:
            one = ca.Function("tca_one", [ph1, wa, dw, c], [rf(wa + dw * ph1, ca.vertcat(ph1, c))],
                              {} if jit_flags is None else jit_opts(jit_flags))
            M = one.map(n, "thread", 2)
            return ca.Function("S", [phi, wa, dw, c], [M(phi, wa, dw, c)])
        one = ca.Function("tca_one", [x1, ph1, c], [rf(x1, ca.vertcat(ph1, c))],
                          {} if jit_flags is None else jit_opts(jit_flags))
        M = one.map(n, "thread", 2)
        return ca.Function("S", [X0, phi, c], [M(X0, phi, c)])
    M = rf.map(n, mode) if mode != "serial" else rf.map(n)
    prm = ca.vertcat(phi, ca.repmat(c, 1, n))
    o = {} if jit_flags is None else jit_opts(jit_flags)
    if fused:
        W0 = ca.repmat(wa, 1, n) + ca.mtimes(dw, phi)
        return ca.Function("tca_sweep_fused", [phi, wa, dw, c], [M(W0, prm)], o)
    return ca.Function("tca_sweep", [X0, phi, c], [M(X0, prm)], o)


# ---------------------------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="N=200 positions, fewer repeats and variants (~20 s)")
    args = ap.parse_args(argv)
    quick = args.quick
    n = 200 if quick else 1000
    rep = 7 if quick else 21
    rep_fs = 1 if quick else 3
    t_start = time.perf_counter()
    warnings.filterwarnings("ignore", category=RuntimeWarning)

    case = make_case(n)
    tca, phi, P, c, W0 = case["tca"], case["phi"], case["P"], case["c"], case["W0"]
    scale2 = tca.scale2
    phi_row = phi[None, :]
    res_map = tca.residual.map(n)
    con_map = tca.contact.map(n)

    # Reference (mpmath) from a tight float64 line-search Newton solution.
    t0 = time.perf_counter()
    rf_ref = ca.rootfinder("rf_ref", "newton", tca.residual, {"abstol": 1e-15, "abstolStep": 1e-17,
                                                                 "max_iter": 50, "line_search": True,
                                                                 "error_on_fail": False})
    W_start = np.asarray(rf_ref.map(n)(W0, P))
    refs, ref_step = reference(case, W_start)
    phi2_ref = [r[4] / mpmath.mpf(scale2) for r in refs]
    t_ref = time.perf_counter() - t0
    # float64 floor: the Newton correction computed from the residual evaluated in float64 at the
    # (rounded) exact root -- what rounding in F alone moves phi2 by.
    W_ref64 = np.array([[float(v) for v in r] for r in refs]).T
    F64 = np.asarray(res_map(W_ref64, P))
    J64 = [np.asarray(tca.jacobian(W_ref64[:, i], P[:, i])) for i in range(n)]
    floor = max(abs(np.linalg.solve(J64[i], F64[:, i])[4]) for i in range(n)) / scale2

    def evaluate(W):
        """phi2 error vs the reference, and failures by the engine's checks (residual, normals)."""
        W = np.asarray(W, float)
        res = np.linalg.norm(np.asarray(res_map(np.nan_to_num(W), P)), axis=0)
        c = con_map(np.nan_to_num(W), P)
        n1n2, reg = np.asarray(c[4]).ravel(), np.asarray(c[11]).ravel()
        err = np.array([abs(float(mpmath.mpf(float(W[4, i])) / mpmath.mpf(scale2) - phi2_ref[i]))
                        if np.isfinite(W[4, i]) else np.inf for i in range(n)])
        ok = tca._accept(res, n1n2, reg) & (err < 1e-9)
        return (float(err[ok].max()) if ok.any() else float("nan")), int((~ok).sum())

    rows = []

    def add(name, build, comp, t_solve, W, note=""):
        e, fails = evaluate(W)
        rows.append(dict(name=name, build=build, comp=comp, us=1e6 * t_solve / n, err=e, fails=fails, note=note))
        r = rows[-1]
        print(f"  {name:58s} {r['us']:9.2f} us/pos  err {e:.2e}  fail {fails}", flush=True)

    print(f"case built in {case['t_build']:.3f} s; reference ({n} positions, mpmath 32 digits) in {t_ref:.1f} s; "
          f"last polish step {ref_step:.1e} mm; float64 floor of phi2 {floor:.2e} rad", flush=True)

    # (a) the engine as is
    tca.sweep(phi, mis=case["mis"], pairs=(0,))  # builds and caches the map of size N
    t, r = timed(lambda: tca.sweep(phi, mis=case["mis"], pairs=(0,)), rep)
    Wsw = np.vstack([r.u1[0], r.z1[0], r.u2[0], r.z2[0], r.phi2[0] * scale2])
    add("a) TCA.sweep (fast_newton map + checks + curvatures)", case["t_build"], 0.0, t, Wsw,
        "engine solve_time includes anchor solve, checks, contact ellipses")

    # (a') the engine with jit=True (mapped solve + checks + contact outputs compiled to C)
    t0 = time.perf_counter()
    tca_j = TCA(tca.pair, jit=True)
    tca_j.sweep(phi, mis=case["mis"], pairs=(0,))  # builds and compiles the maps of size N
    tb = time.perf_counter() - t0
    t, r = timed(lambda: tca_j.sweep(phi, mis=case["mis"], pairs=(0,)), rep)
    Wsw = np.vstack([r.u1[0], r.z1[0], r.u2[0], r.z2[0], r.phi2[0] * scale2])
    add("a') TCA(jit=True).sweep (everything a) does)", case["t_build"], tb, t, Wsw,
        "compile time = build + first sweep")

    # (b) fast_newton map, no jit
    t0 = time.perf_counter()
    S = mapped_solver(case, "fast_newton", RF_OPTS, n)
    tb = time.perf_counter() - t0
    t, W = timed(lambda: np.asarray(S(W0, phi_row, c)), rep)
    add("b) fast_newton map, no jit (engine options)", tb, 0.0, t, W)
    t0 = time.perf_counter()
    S = mapped_solver(case, "fast_newton", RF_OPTS_STEP, n)
    tb = time.perf_counter() - t0
    t, W = timed(lambda: np.asarray(S(W0, phi_row, c)), rep)
    add("b') fast_newton map, no jit, abstolStep=1e-9", tb, 0.0, t, W)

    # (c) jit
    jit_variants = [("c) fast_newton map, jit -O2 (engine options)", RF_OPTS, ["-O2"], "serial", False),
                    ("c) fast_newton map, jit -O2, abstolStep=1e-9", RF_OPTS_STEP, ["-O2"], "serial", False),
                    ("c) fused predictor, jit -O2, abstolStep=1e-9", RF_OPTS_STEP, ["-O2"], "serial", True),
                    ("c) fused, jit -O2, abstolStep, thread map x2", RF_OPTS_STEP, ["-O2"], "thread", True)]
    if not quick:
        jit_variants += [("c) fused, jit -O1, abstolStep=1e-9", RF_OPTS_STEP, ["-O1"], "serial", True),
                         ("c) fused, jit -O3 -march=native, abstolStep=1e-9", RF_OPTS_STEP,
                          ["-O3", "-march=native"], "serial", True)]
    # Not measured: map(N, "openmp") -- this casadi wheel is built without OpenMP and the shell
    # compiler's .so built with -fopenmp does not link libgomp (the process dies on GOMP_parallel).
    best_fused = None
    for name, opts, flags, mode, fused in jit_variants:
        try:
            t0 = time.perf_counter()
            with in_tmpdir():
                S = mapped_solver(case, "fast_newton", opts, n, jit_flags=flags, mode=mode, fused=fused)
            tc = time.perf_counter() - t0
            if fused:
                call = lambda S=S: np.asarray(S(phi_row, case["w_a"], case["dw"], c))  # noqa: E731
            else:
                call = lambda S=S: np.asarray(S(W0, phi_row, c))  # noqa: E731
            t, W = timed(call, rep)
            add(name, 0.0, tc, t, W)
            if fused and mode == "serial" and flags == ["-O2"]:
                best_fused = (opts, flags)
        except Exception as exc:  # a plugin/flag combination that does not build here
            print(f"  {name}: not available ({str(exc).splitlines()[0][:100]})")

    # (c') the same fused function, code-generated and compiled into a cache directory, then reloaded
    if best_fused is not None:
        with tempfile.TemporaryDirectory(prefix="gearopt_jitcache_") as cache:
            S0 = mapped_solver(case, "fast_newton", best_fused[0], n, fused=True)
            S, t_cold, _ = compile_cached(S0, best_fused[1], cache)
            S, t_warm, hit = compile_cached(S0, best_fused[1], cache)
            t, W = timed(lambda: np.asarray(S(phi_row, case["w_a"], case["dw"], c)), rep)
            add("c') fused, codegen + gcc -O2 cached .so (ca.external)", 0.0, t_cold, t, W,
                f"cache hit: load {t_warm:.3f} s")

    # (d) newton with line search, (e) kinsol
    for name, plugin, opts in [("d) newton (line search) map, no jit", "newton",
                                {"abstol": 1e-13, "max_iter": 30, "line_search": True, "error_on_fail": False}),
                               ("d) newton (no line search) map, no jit", "newton",
                                {"abstol": 1e-13, "max_iter": 30, "line_search": False, "error_on_fail": False}),
                               ("e) kinsol map, no jit", "kinsol", {"abstol": 1e-13, "error_on_fail": False})]:
        try:
            t0 = time.perf_counter()
            S = mapped_solver(case, plugin, opts, n)
            tb = time.perf_counter() - t0
            t, W = timed(lambda S=S: np.asarray(S(W0, phi_row, c)), rep)
            add(name, tb, 0.0, t, W)
        except Exception as exc:
            print(f"  {name}: not available ({str(exc).splitlines()[0][:100]})")

    # (f) MINPACK hybrd / hybrj per position on the same Functions. The residual is called through
    # CasADi's FunctionBuffer (~1.4 us a call; a plain ``Function.__call__`` from Python costs ~30 us).
    t0 = time.perf_counter()
    bufs = {}
    ws, ps = ca.SX.sym("w", 5), ca.SX.sym("p", P.shape[0])
    jac_dense = ca.Function("J", [ws, ps], [ca.densify(tca.jacobian(ws, ps))])  # buffer needs all 25 entries
    for key, f, shape in (("F", tca.residual, (5,)), ("J", jac_dense, (5, 5))):
        buf, trig = f.buffer()
        x_in, p_in, out = np.zeros(5), np.zeros(P.shape[0]), np.zeros(int(np.prod(shape)))
        buf.set_arg(0, memoryview(x_in))
        buf.set_arg(1, memoryview(p_in))
        buf.set_res(0, memoryview(out))
        bufs[key] = (buf, trig, x_in, p_in, out, shape)
    tb = time.perf_counter() - t0

    def fun_buf(x, key="F"):
        _, trig, x_in, _, out, shape = bufs[key]
        x_in[:] = x
        trig()
        return out.reshape(shape, order="F").copy()

    def fun_plain(x, p_i):
        return np.asarray(tca.residual(x, p_i)).ravel()

    fs_rows = [("f) fsolve, FD Jacobian, default xtol", "FD", FS_TOL), ("f) fsolve, FD Jacobian, xtol=1e-13", "FD", 1e-13),
               ("f) fsolve, AD Jacobian (fprime), default xtol", "AD", FS_TOL),
               ("f) fsolve, AD Jacobian (fprime), xtol=1e-13", "AD", 1e-13),
               ("f) fsolve, FD, default xtol, plain Function call", "plain", FS_TOL)]
    for name, kind, xtol in fs_rows:
        nfev = []

        def run(kind=kind, xtol=xtol):
            W = np.empty((5, n))
            nfev.clear()
            for i in range(n):
                if kind == "plain":
                    p_i = P[:, i].copy()
                    fun, jac = (lambda x, p_i=p_i: fun_plain(x, p_i)), None
                else:
                    bufs["F"][3][:] = P[:, i]
                    bufs["J"][3][:] = P[:, i]
                    fun = fun_buf
                    jac = (lambda x: fun_buf(x, "J")) if kind == "AD" else None
                x, info, ier, _ = fsolve(fun, W0[:, i], fprime=jac, xtol=xtol, full_output=True)
                W[:, i] = x if ier == 1 or np.linalg.norm(info["fvec"]) <= tca.tol else np.nan
                nfev.append(info["nfev"] + info.get("njev", 0))
            return W

        t, W = timed(run, rep_fs)
        add(name, tb, 0.0, t, W, f"{np.mean(nfev):.1f} F/J calls per position")

    # Table
    base = next(r for r in rows if r["name"].startswith("f) fsolve, FD Jacobian, default"))
    print()
    print(f"N = {n} positions, pair 0, phi1 in [-pi/z1, pi/z1]; {os.cpu_count()} cores; "
          f"{platform.processor() or platform.machine()}; casadi {ca.__version__}; "
          f"{datetime.date.today().isoformat()}")
    print(f"reference: mpmath 32 digits on the same SX graph; float64 floor of phi2 = {floor:.1e} rad")
    hdr = f"| {'method':58s} | build s | compile s | us/pos | vs fsolve FD | max phi2 err [rad] | fail |"
    print(hdr)
    print("|" + "-" * 60 + "|---------|-----------|--------|--------------|--------------------|------|")
    for r in rows:
        print(f"| {r['name']:58s} | {r['build']:7.3f} | {r['comp']:9.2f} | {r['us']:6.2f} | "
              f"{base['us'] / r['us']:11.1f}x | {r['err']:18.1e} | {r['fails']:4d} |"
              + (f" {r['note']}" if r["note"] else ""))
    best = min((r for r in rows if r["fails"] == 0 and r["err"] <= 1e-13), key=lambda r: r["us"], default=None)
    best_serial = min((r for r in rows if r["fails"] == 0 and r["err"] <= 1e-13 and "thread" not in r["name"]
                       and "openmp" not in r["name"]), key=lambda r: r["us"], default=None)
    print()
    for label, b in (("fastest accurate (any)", best), ("fastest accurate (1 thread)", best_serial)):
        if b is None:
            print(f"{label}: none meets err <= 1e-13 without failures")
            continue
        print(f"{label}: {b['name'].strip()}: {b['us']:.2f} us/pos "
              f"[target <= 2 us: {'met' if b['us'] <= 2 else 'NOT met'}], "
              f"{base['us'] / b['us']:.0f}x vs fsolve FD [target >= 20x: "
              f"{'met' if base['us'] / b['us'] >= 20 else 'NOT met'}], "
              f"phi2 err {b['err']:.1e} rad [target <= 1e-13: {'met' if b['err'] <= 1e-13 else 'NOT met'}]")
    print(f"total benchmark time {time.perf_counter() - t_start:.1f} s")
    if _JIT_DIR is not None:
        shutil.rmtree(_JIT_DIR, ignore_errors=True)
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
