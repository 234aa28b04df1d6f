"""Crowning optimization: IPOPT NLPs that choose the pinion's crowning so that the drive follows a
predesigned parabolic function of transmission errors and keeps its contact on the flanks for a
set of misalignments (docs/theory.md sections 5, 9, 11).

Simultaneous formulation. For every misalignment case c and pinion angle phi_k of a mesh cycle, the
TCA unknowns ``w_ck = (u1, z1, u2, z2, r_p2 phi2)`` are NLP variables tied by the TCA equations
(equality constraints, the exact residual Function of :class:`gearopt.meshing.tca.TCA`). The TE of
each case is fitted by the target parabola plus a free line, ``TE_ck = c0_c + c1_c phi_k - A phi_k^2``
with ``A = level / (pi/z1)^2`` (a misalignment adds a line, which the parabola absorbs); the
objective is the squared misfit (sum over the cases, or the worst case). The transfer points of
the shifted parabolas, ``phi_t = p/2 + c1/(2A)`` and ``phi_t - p`` (p = 2 pi/z1), carry two more
TCA points per case whose contact must lie inside the active flanks (edge-contact avoidance), and
the contact ellipse at the mean point can be required to span a share of the face width.

Design variables are the pinion's profile crowning ``a_c`` (parabolic rack-cutter) and
longitudinal crowning ``a_pl`` (plunging), scaled to O(1). For a spur pinion ``a_pl`` barely moves
the TE: its role is the bearing contact, so a small penalty on ``a_pl`` picks the least crowning
that keeps the contact on the face (the problem is otherwise ill-posed in ``a_pl``).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from ..compiled import nlpsol
from ..contact.edge import EdgeContact, EdgeTCAResult
from ..errors import ArgumentError, ConvergenceError, OptionError, SynthesisError, check_number, out_of_range  # noqa: F401
#  (SynthesisError lives in errors.py; re-exported here)
from ..forking import split_forked
from ..gears import GearPair
from ..geometry.tools import require_rack_settings
from ..meshing.tca import TCA, Misalignment
from ..settings import CrowningStudySettings, CrowningTarget  # noqa: F401 (CrowningTarget re-exported)
from ..units import ARCMIN, RAD_TO_ARCSEC

SETTINGS = ("a_c", "a_pl")  #: design variables (entries of the pinion parameter vector)


@dataclass(frozen=True)
class CaseReport:
    """One misalignment case of an optimized design, checked by an independent TCA sweep."""

    name: str
    misalignment: Misalignment
    fit_rms: float  # RMS misfit of the case's TE to the target parabola + line in the NLP [rad]
    te_level_tca: float  # peak-to-peak of the actual TE, at its located corners and peak [rad]
    edge_contact: bool  # edge contact anywhere in the verification sweep
    transfer_phi1: tuple  # transfer points of the NLP fit [rad] (the actual corners: ``corners``)
    phi1: np.ndarray = field(repr=False)
    te_envelope: np.ndarray = field(repr=False)  # verification sweep, actual TE [rad]
    path: dict = field(repr=False)  # central pair: {"pinion": (z, radius), "gear": (z, radius)}, valid points
    result: object = field(default=None, repr=False)  # the EdgeTCAResult of the verification sweep
    corners: tuple = ()  # actual corners of the actual TE: ((phi1 [rad], TE [rad]), ...) where pairs cross
    peak: tuple = ()  # (phi1, TE) of the highest point of the actual TE [rad]

    def to_dict(self) -> dict:
        """``design.cases[]`` of results.json (docs/results.md): ``name``, verified ``te_level_arcsec``,
        ``fit_rms_arcsec``, ``edge_contact``, the NLP's ``transfer_phi1`` and the actual
        ``corners_phi1`` [rad]."""
        return {"name": self.name, "te_level_arcsec": self.te_level_tca * RAD_TO_ARCSEC,
                "fit_rms_arcsec": self.fit_rms * RAD_TO_ARCSEC, "edge_contact": self.edge_contact,
                "transfer_phi1": list(self.transfer_phi1), "corners_phi1": [float(pc) for pc, _ in self.corners]}


#: Unit of each sensitivity d(TE level)/d(variable) in results.json, and the factor from the
#: engine's arcsec per internal unit (1/mm, mm, rad).
SENSITIVITY_UNITS = {"a_c": ("arcsec per 1/mm", 1.0), "a_pl": ("arcsec per 1/mm", 1.0),
                     **{f"mis.{k}": (("arcsec per arcmin", ARCMIN) if Misalignment.meta(k)["unit"] == "angle"
                                     else ("arcsec per mm", 1.0)) for k in Misalignment.names()}}


@dataclass(frozen=True)
class CrowningDesign:
    """Result of :meth:`CrowningOptimizer.solve`.

    Attributes
    ----------
    pair : GearPair
        The drive with the optimized pinion (``pinion.rack.a_c``, ``pinion.a_pl``).
    settings : dict
        ``{"a_c": [1/mm], "a_pl": [1/mm]}``.
    status : str
        IPOPT return status; ``iterations``; ``solve_time`` and ``build_time`` [s].
    cases : list[CaseReport]
        Every misalignment case verified by an independent TCA sweep with edge contact.
    sensitivities : dict
        ``d(TE level of case) / d(setting or misalignment)`` by AD through the TCA equations
        [rad per unit of the variable: 1/mm settings, rad angles, mm distances].
    objective : float
    target : CrowningTarget or None
        What the design was asked for (echoed in :meth:`to_dict`).
    edge : EdgeContact or None
        The optimized drive's compiled TCA + edge contact (``edge.tca``) that verified the cases;
        further sweeps of the design reuse it instead of compiling it again (None without
        verification).
    """

    pair: GearPair
    settings: dict
    status: str
    iterations: int
    solve_time: float
    build_time: float
    objective: float
    cases: list
    sensitivities: dict = field(default_factory=dict)
    edge: EdgeContact | None = field(default=None, repr=False, compare=False)
    target: CrowningTarget | None = None

    def iso(self) -> dict:
        """The optimized crowning as a drawing states it: ISO 21771 amounts [mm] of the pinion over its
        active profile and face (:func:`gearopt.geometry.microgeometry.iso_from_litvin`): ``C_alpha``,
        ``f_H_alpha`` (the parabolic tool's flank), ``C_beta``, ``f_H_beta`` (the plunging)."""
        from ..geometry.microgeometry import iso_from_litvin

        return iso_from_litvin(self.pair, "pinion")

    def to_dict(self) -> dict:
        """``design`` of the crowning study's results.json (every key in docs/results.md): the
        settings [1/mm] and the same crowning in ISO shop terms [um] (:meth:`iso`), IPOPT's status,
        the target, every verified case (:meth:`CaseReport.to_dict`) and the sensitivities in the
        units of ``sensitivity_units`` (arcsec per 1/mm, mm, arcmin)."""
        t = self.target
        return {
            "settings": self.settings, "iso_um": {k: 1000 * v for k, v in self.iso().items()},
            "status": self.status, "iterations": self.iterations,
            "objective": self.objective,
            "target_te_level_arcsec": None if t is None else t.te_level * RAD_TO_ARCSEC,
            "ellipse_share": None if t is None else t.ellipse_share,
            "edge_margin": None if t is None else t.edge_margin, "tip_margin": None if t is None else t.tip_margin,
            "nlp_build_s": self.build_time, "nlp_solve_s": self.solve_time,
            "cases": [c.to_dict() for c in self.cases],
            "sensitivities": {c: {k: v * RAD_TO_ARCSEC * SENSITIVITY_UNITS.get(k, ("", 1.0))[1] for k, v in s.items()}
                              for c, s in self.sensitivities.items()},
            "sensitivity_units": {k: SENSITIVITY_UNITS.get(k, ("arcsec per internal unit", 1.0))[0]
                                  for s in self.sensitivities.values() for k in s},
        }

    def table(self) -> str:
        """A plain-text table of the cases: TE level of the verification sweep (peak-to-peak of the
        actual TE), RMS misfit to the target parabola in the NLP, edge contact."""
        rows = [f"{'case':20s} {'TE level [arcsec]':>18s} {'fit RMS [arcsec]':>17s} {'edge contact':>13s}"]
        for c in self.cases:
            rows.append(f"{c.name:20s} {c.te_level_tca * RAD_TO_ARCSEC:18.3f} {c.fit_rms * RAD_TO_ARCSEC:17.4f} "
                        f"{'YES' if c.edge_contact else 'no':>13s}")
        return "\n".join(rows)


def _default_cases() -> dict:
    g = 3 * ARCMIN
    return {"aligned": Misalignment(), "crossing +3'": Misalignment(crossing=g),
            "crossing -3'": Misalignment(crossing=-g), "intersecting +3'": Misalignment(intersecting=g),
            "intersecting -3'": Misalignment(intersecting=-g)}


class CrowningOptimizer:
    """Builder of the crowning NLP (declare, ``build()``, then ``solve()``).

    Parameters
    ----------
    pair : GearPair
        The drive; its pinion's current crowning is the first guess (0 is replaced by an estimate).
    target : CrowningTarget
    cases : dict[str, Misalignment]
        Misalignment set (default: aligned, crossing and intersecting +-3 arcmin).
    positions : int
        TCA positions per case over the cycle ``[-pi/z1, pi/z1]``.
    side : {"right", "left"}
        Driving flank.
    bounds : dict, optional
        ``{"a_c": (lo, hi), "a_pl": (lo, hi)}`` [1/mm].
    tol : float
        IPOPT's convergence tolerance. For a spur pinion a_pl is held only by the small penalty against
        the active face constraint (multiplier ~1e-8), so at the default 1e-10 it is determined to
        ~1e-5 relative; 1e-13 pins it to round-off at ~2.5x the iterations.
    jit : bool
        Run the NLP's Functions as C compiled once and cached on disk (:func:`gearopt.compiled.nlpsol`):
        the first build compiles (about 80 s for problems/crowning_spur.toml), later builds of the
        same NLP in any process load it and IPOPT runs about 8x faster (benchmarks/bench_nlp_cache.py).
        Default False: interpreted.
    """

    def __init__(self, pair: GearPair, target: CrowningTarget, cases: dict | None = None,
                 positions: int = CrowningStudySettings.positions,
                 side: str = "right", bounds: dict | None = None, tol: float = 1e-10, jit: bool = False):
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {type(pair).__name__}: expected a gearopt.gears.GearPair.",
                                param="pair", value=pair, valid="a gearopt.gears.GearPair")
        require_rack_settings(pair.pinion, "crowning synthesis")
        if not isinstance(target, CrowningTarget):
            raise ArgumentError(f"target = {type(target).__name__}: expected a CrowningTarget(te_level [rad], ...).",
                                param="target", value=target, valid="a CrowningTarget")
        if cases is not None and not isinstance(cases, dict):
            raise ArgumentError(f"cases = {type(cases).__name__}: expected a dict {{name: Misalignment}}, e.g. "
                                "misalignment_cases(crossing=3 * ARCMIN).",
                                param="cases", value=cases, valid="a dict {name: Misalignment}")
        cases = dict(_default_cases() if cases is None else cases)
        if not cases:
            raise out_of_range("cases", cases, "at least one misalignment case", cls=OptionError)
        b_min = min(pair.pinion.b, pair.gear.b)
        if target.edge_margin >= b_min / 2:
            raise out_of_range("target.edge_margin", target.edge_margin, f"0 <= edge_margin < min(b1, b2) / 2 = "
                               f"{b_min / 2:.6g} mm (the transfer points must stay on the face)")
        h_flank = min(g.r_a - max(g.r_lim, g.r_b) for g in (pair.pinion, pair.gear))
        if 2 * target.tip_margin >= h_flank:
            raise out_of_range("target.tip_margin", target.tip_margin, f"0 <= tip_margin < {h_flank / 2:.4g} mm, half "
                               "the radial height of the shorter involute flank (form to tip circle)")
        for name, m in cases.items():
            if not isinstance(m, Misalignment):
                hint = " Use Misalignment(**d) (angles in rad)." if isinstance(m, dict) else ""
                raise ArgumentError(f"cases[{name!r}] = {type(m).__name__}: expected a Misalignment.{hint}",
                                    param=f"cases[{name!r}]", value=m, valid="a Misalignment")
            m.check(pair, f"cases[{name!r}]")
        if "aligned" not in cases and target.ellipse_share > 0:
            cases = {"aligned": Misalignment(), **cases}
        if side not in ("right", "left"):
            raise out_of_range("side", side, "'right' or 'left'", cls=OptionError)
        positions = CrowningStudySettings.check("positions", positions)  # its range: declared there
        if not (isinstance(tol, float) and 0 < tol < 1e-3):
            raise out_of_range("tol", tol, "0 < tol < 1e-3", cls=OptionError)
        self.pair, self.target, self.cases, self.positions, self.side = pair, target, cases, positions, side
        self.tol = tol
        if not isinstance(jit, (bool, np.bool_)):
            raise out_of_range("jit", jit, "True or False (compile the NLP, cached on disk)", cls=OptionError)
        self.jit = bool(jit)
        self.bounds = {"a_c": (1e-7, 0.05), "a_pl": (1e-7, 0.02), **(bounds or {})}
        for k, (lo, hi) in self.bounds.items():
            if k not in SETTINGS:
                raise out_of_range("bounds", k, f"keys in {SETTINGS}", cls=OptionError)
            if not 0 <= lo < hi:
                raise out_of_range(f"bounds[{k!r}]", (lo, hi), "0 <= lo < hi [1/mm]", cls=OptionError)
        self._built = False

    # ------------------------------------------------------------------------------------------
    def initial_settings(self) -> dict:
        """First guess: the pinion's crowning, or estimates from the target (profile crowning from
        the TE level, plunging from the largest angular misalignment)."""
        p = self.pair
        g1, g2 = p.pinion, p.gear
        A = self.target.te_level / (math.pi / g1.z) ** 2
        tan_a = math.tan(p.alpha_wt)
        a_c = g1.rack.a_c or A * g2.r_b / (tan_a**2 * g1.r_b**2)  # parabolic-rack TE law (tests/test_tca.py)
        gam = max([sum(abs(getattr(m, k)) for k in Misalignment.names("angle")) for m in self.cases.values()]
                  + [1 * ARCMIN])
        a_pl = g1.a_pl or 2 * gam / (g1.b * tan_a)  # path shift gamma/(2 a_pl tan a) = b/4
        lo_c, hi_c = self.bounds["a_c"]
        lo_p, hi_p = self.bounds["a_pl"]
        return {"a_c": min(max(a_c, lo_c), hi_c), "a_pl": min(max(a_pl, lo_p), hi_p)}

    def build(self, verbose: bool = False) -> "CrowningOptimizer":
        """Assemble the NLP (SX graph, exact Hessian) around a first guess from TCA sweeps."""
        t0 = time.perf_counter()
        pair, tgt = self.pair, self.target
        g1 = pair.pinion
        s0 = self.initial_settings()
        self.scale = dict(s0)  # design variables are setting / scale
        pin0 = g1.with_(rack=replace(g1.rack, a_c=s0["a_c"]), a_pl=s0["a_pl"])
        pair0 = GearPair(pin0, pair.gear, pair.a)
        self.tca = TCA(pair0, side=self.side)
        tca = self.tca
        p1_0, p2 = tca.pinion.p0, tca.gear.p0
        K = self.positions
        z1 = g1.z
        pitch = 2 * math.pi / z1
        phis = np.linspace(-pitch / 2, pitch / 2, K)
        A_t = tgt.te_level / (pitch / 2) ** 2
        te_scale = tgt.te_level
        SYM = ca.MX  # Function calls stay nodes of the graph: fast exact-Hessian construction
        x = SYM.sym("x", len(SETTINGS))  # scaled settings
        p1 = SYM(p1_0)
        lay = tca.layout  # the TCA's parameter column by name
        for j, name in enumerate(SETTINGS):
            p1[lay.p_index("pinion", name)] = x[j] * self.scale[name]
        F = tca.residual
        vars_, lbx, ubx, x0 = [x], [], [], []
        for name in SETTINGS:
            lo, hi = self.bounds[name]
            lbx.append(lo / self.scale[name])
            ubx.append(hi / self.scale[name])
            x0.append(s0[name] / self.scale[name])
        g, lbg, ubg, gnames = [], [], [], []
        self._c_index = {}
        obj_terms = []
        self._w_index = {}
        r_form1, r_form2 = tca.form_radius(1), tca.form_radius(2)
        S1 = tca.pinion.surface(self.side, "flank")
        S2 = tca.gear.surface(self.side, "flank")
        m, mt = tgt.edge_margin, tgt.tip_margin
        nvar = len(SETTINGS)
        for ci, (cname, mis) in enumerate(self.cases.items()):
            mv = mis.vector()
            if verbose:
                print(f"gearopt: crowning: first guess for case {cname!r}", file=sys.stderr)
            res0 = tca.sweep(phis, mis=mis, pairs=(0,))
            if not res0.converged.all():
                raise SynthesisError(f"crowning: the first-guess TCA of case {cname!r} did not converge at "
                                     f"{int((~res0.converged).sum())} positions; reduce the misalignment or "
                                     "start from another crowning.")
            W0 = np.vstack([res0.u1[0], res0.z1[0], res0.u2[0], res0.z2[0],
                            res0.phi2[0] * tca.scale2])
            te0 = res0.phi2[0] - (z1 / pair.gear.z) * phis
            c = SYM.sym(f"c_{ci}", 2)  # c0, c1 of the absorbed line [rad, rad/rad]
            self._c_index[cname] = len(lbx)
            vars_.append(c)
            V = np.c_[np.ones(K), phis]
            cfit = np.linalg.lstsq(V, te0 + A_t * phis**2, rcond=None)[0]
            lbx += [-np.inf, -np.inf]
            ubx += [np.inf, np.inf]
            x0 += [cfit[0] / te_scale, cfit[1] / te_scale]
            c0, c1 = c[0] * te_scale, c[1] * te_scale
            # All positions of the case in one mapped call of the TCA residual.
            W = SYM.sym(f"W_{ci}", 5, K)
            vars_.append(ca.vec(W))
            lbx += [-np.inf] * (5 * K)
            ubx += [np.inf] * (5 * K)
            x0 += list(W0.T.ravel())
            PRM = lay.build({"phi1": ca.DM(phis).T, "pinion": ca.repmat(p1, 1, K), "gear": ca.repmat(ca.DM(p2), 1, K),
                             "mis": ca.repmat(ca.DM(mv), 1, K), "z_section": ca.DM.zeros(1, K)})
            g.append(ca.vec(F.map(K)(w=W, prm=PRM)["F"]))
            lbg += [0.0] * (5 * K)
            ubg += [0.0] * (5 * K)
            te = W[4, :] / tca.scale2 - (z1 / pair.gear.z) * ca.DM(phis).T
            fit_row = (te - (c0 + c1 * ca.DM(phis).T - A_t * ca.DM(phis**2).T)) / te_scale
            obj_terms.append(ca.sumsqr(fit_row) / K)
            # Transfer points of the shifted parabolas: phi_t = p/2 + c1/(2A), phi_t - p.
            phi_t = pitch / 2 + c1 / (2 * A_t)
            for label, ph_t, w_guess in (("B'", phi_t, W0[:, -1]), ("A'", phi_t - pitch, W0[:, 0])):
                w = SYM.sym(f"wt_{ci}_{label}", 5)
                vars_.append(w)
                lbx += [-np.inf] * 5
                ubx += [np.inf] * 5
                x0 += list(w_guess)
                g.append(F(w=w, prm=lay.build({"phi1": ph_t, "pinion": p1, "gear": p2, "mis": mv,
                                               "z_section": 0.0}))["F"])
                lbg += [0.0] * 5
                ubg += [0.0] * 5
                r1 = S1(w[0], w[1], p1)[0]
                r2 = S2(w[2], w[3], p2)[0]
                rad1 = ca.sqrt(r1[0] ** 2 + r1[1] ** 2)
                rad2 = ca.sqrt(r2[0] ** 2 + r2[1] ** 2)
                for expr, lo, hi, what in (
                        (rad1, r_form1 + mt, g1.r_a - mt, f"pinion radius at {label}"),
                        (w[1], -g1.b / 2 + m, g1.b / 2 - m, f"pinion face position at {label}"),
                        (rad2, r_form2 + mt, pair.gear.r_a - mt, f"gear radius at {label}"),
                        (w[3], -pair.gear.b / 2 + m, pair.gear.b / 2 - m, f"gear face position at {label}")):
                    g.append(expr)
                    lbg.append(lo)
                    ubg.append(hi)
                    gnames.append((cname, what, len(lbg) - 1))
            if tgt.ellipse_share > 0 and cname == "aligned":
                wm = SYM.sym("w_mean", 5)
                vars_.append(wm)
                lbx += [-np.inf] * 5
                ubx += [np.inf] * 5
                x0 += list(W0[:, K // 2])
                prm_m = lay.build({"phi1": phis[K // 2], "pinion": p1, "gear": p2, "mis": mv, "z_section": 0.0})
                g.append(F(w=wm, prm=prm_m)["F"])
                lbg += [0.0] * 5
                ubg += [0.0] * 5
                c_m = tca.contact(w=wm, prm=prm_m)
                Ks = c_m["K1"] + c_m["K2"]  # curvature matrices of both flanks in the common basis
                lam_min = 0.5 * (Ks[0, 0] + Ks[1, 1] - ca.sqrt((Ks[0, 0] - Ks[1, 1]) ** 2 + 4 * Ks[0, 1] ** 2))
                # 2 a = 2 sqrt(2 delta / lam_min) >= share b  <=>  lam_min <= 8 delta / (share b)^2
                g.append(lam_min * (tgt.ellipse_share * g1.b) ** 2 / (8 * tgt.delta))
                lbg.append(-np.inf)
                ubg.append(1.0)
                gnames.append((cname, "contact ellipse major axis at the mean point", len(lbg) - 1))
        if tgt.objective == "worst":
            t = SYM.sym("t")
            vars_.append(t)
            lbx.append(0.0)
            ubx.append(np.inf)
            x0.append(float(max(1.0, 1.0)))
            for term in obj_terms:
                g.append(t - term)
                lbg.append(0.0)
                ubg.append(np.inf)
            fit = t
        else:
            fit = ca.sum1(ca.vertcat(*obj_terms))
        # Least longitudinal crowning among equally good fits (a_pl hardly moves a spur TE).
        f = fit + 1e-6 * (x[SETTINGS.index("a_pl")]) ** 2
        X = ca.vertcat(*vars_)
        G = ca.vertcat(*g)
        self._nlp = {"x": X, "f": f, "g": G}
        self._x0, self._lbx, self._ubx = np.array(x0, float), np.array(lbx, float), np.array(ubx, float)
        self._lbg, self._ubg, self._gnames = np.array(lbg, float), np.array(ubg, float), gnames
        self._nvar, self._phis, self._A_t = nvar, phis, A_t
        self._ncase_vars = 2
        self._fit_terms = ca.Function("fit_terms", [X], obj_terms)
        opts = {"ipopt.print_level": 5 if verbose else 0, "print_time": False, "ipopt.sb": "yes",
                "ipopt.tol": self.tol, "ipopt.max_iter": 300, "ipopt.mu_strategy": "adaptive"}
        self._solver = nlpsol("crowning", "ipopt", self._nlp, opts, jit=self.jit)
        self.build_time = time.perf_counter() - t0
        self._built = True
        return self

    # ------------------------------------------------------------------------------------------
    def solve(self, x0_settings: dict | None = None, verbose: bool = False, verify: bool = True,
              sensitivities: bool = True) -> CrowningDesign:
        """Solve the NLP; verify every case by an independent TCA sweep with edge contact.

        Parameters
        ----------
        x0_settings : dict, optional
            Start from these settings instead of the build's first guess (the TCA unknowns keep
            their first guess).
        verbose : bool
            Print IPOPT's iterations and progress to stderr.

        Raises
        ------
        SynthesisError
            IPOPT did not find a feasible optimum; the message lists the binding or violated
            constraints (case, what, value, bound).
        """
        if not self._built:
            self.build(verbose=verbose)
        x0 = self._x0.copy()
        if x0_settings:
            for j, name in enumerate(SETTINGS):
                if name in x0_settings:
                    x0[j] = x0_settings[name] / self.scale[name]
        t0 = time.perf_counter()
        sol = self._solver(x0=x0, lbx=self._lbx, ubx=self._ubx, lbg=self._lbg, ubg=self._ubg)
        st = self._solver.stats()
        solve_time = time.perf_counter() - t0
        X = np.asarray(sol["x"]).ravel()
        Gv = np.asarray(sol["g"]).ravel()
        status = st.get("return_status", "unknown")
        viol = self._violations(Gv)
        if not st.get("success", False) or viol:
            raise SynthesisError(self._diagnose(status, Gv, viol))
        settings = {name: float(X[j] * self.scale[name]) for j, name in enumerate(SETTINGS)}
        g1 = self.pair.pinion
        pin = g1.with_(rack=replace(g1.rack, a_c=settings["a_c"]), a_pl=settings["a_pl"])
        pair = GearPair(pin, self.pair.gear, self.pair.a)
        # the optimised drive's TCA and edge contact are compiled once, here, and serve the
        # verification, the sensitivities and the caller's own sweeps (CrowningDesign.edge)
        tca = TCA(pair, side=self.side)
        ec = EdgeContact(tca) if verify else None
        cases = self._verify(pair, X, ec) if verify else []
        off = [c for c in cases if abs(c.te_level_tca / self.target.te_level - 1) > self.target.level_tolerance]
        if off:
            worst = max(off, key=lambda c: abs(c.te_level_tca / self.target.te_level - 1))
            raise SynthesisError(
                f"crowning: the best design misses the TE level: case {worst.name!r} has "
                f"{worst.te_level_tca * RAD_TO_ARCSEC:.3f} arcsec for a target of "
                f"{self.target.te_level * RAD_TO_ARCSEC:.3f} arcsec (tolerance "
                f"{100 * self.target.level_tolerance:.0f} %), a_c = {settings['a_c']:.4g}, a_pl = "
                f"{settings['a_pl']:.4g} 1/mm.\n" + self._diagnose(status, Gv, [], head=False))
        sens = self.sensitivities(pair, tca) if sensitivities else {}
        return CrowningDesign(pair=pair, settings=settings, status=status, iterations=int(st.get("iter_count", -1)),
                              solve_time=solve_time, build_time=self.build_time, objective=float(sol["f"]),
                              cases=cases, sensitivities=sens, edge=ec, target=self.target)

    def _violations(self, Gv, tol=1e-7):
        bad = []
        for cname, what, i in self._gnames:
            lo, hi = self._lbg[i], self._ubg[i]
            if Gv[i] < lo - tol * max(1, abs(lo)) or Gv[i] > hi + tol * max(1, abs(hi)):
                bad.append((cname, what, Gv[i], lo, hi))
        return bad

    def _describe(self, cname, what, v, lo, hi) -> str:
        if what.startswith("contact ellipse"):
            need = self.target.ellipse_share * self.pair.pinion.b
            two_a = need / math.sqrt(v) if v > 0 else float("inf")
            return f"  case {cname!r}: {what}: 2a = {two_a:.4g} mm, required >= {need:.4g} mm"
        return f"  case {cname!r}: {what} = {v:.6g} mm, allowed [{lo:.6g}, {hi:.6g}] mm"

    def _diagnose(self, status, Gv, viol, head: bool = True) -> str:
        lines = [f"crowning: no feasible design (IPOPT: {status})."] if head else []
        if viol:
            lines.append("Violated constraints at IPOPT's last point:")
            for cname, what, v, lo, hi in viol[:12]:
                lines.append(self._describe(cname, what, v, lo, hi))
        else:
            near = []
            for cname, what, i in self._gnames:
                lo, hi = self._lbg[i], self._ubg[i]
                d = min(abs(Gv[i] - lo) if np.isfinite(lo) else np.inf, abs(Gv[i] - hi) if np.isfinite(hi) else np.inf)
                near.append((d, cname, what, Gv[i], lo, hi))
            near.sort(key=lambda r: r[0])
            lines.append("Binding constraints at IPOPT's last point:")
            for d, cname, what, v, lo, hi in near[:6]:
                lines.append(self._describe(cname, what, v, lo, hi))
        lines.append("Relax the request: a larger TE level, a smaller misalignment set, smaller edge/tip margins "
                     "or ellipse share, or wider bounds on the settings.")
        return "\n".join(lines)

    def _verify(self, pair: GearPair, X, ec: EdgeContact | None = None) -> list:
        """Independent check: TCA + edge contact sweeps of the optimized drive, every case. The TE
        level is measured at the actual extremes of the actual TE, located on the engine's own
        sweeps (:func:`actual_level`), not at the NLP's fitted transfer points. ``ec``: the
        optimized drive's compiled edge contact (built here if not given)."""
        z1 = pair.pinion.z
        pitch = 2 * math.pi / z1
        phi = np.linspace(-pitch, pitch, 4 * self.positions, endpoint=False)
        if ec is None:
            ec = EdgeContact(TCA(pair, side=self.side))
        fits = dict(zip(self.cases, (float(v) for v in self._fit_terms(X))))

        def checked(items: list) -> list:
            out = []
            for cname, mis in items:
                c1 = X[self._c_index[cname] + 1] * self.target.te_level
                r = ec.sweep(phi, mis=mis, pairs=(-2, -1, 0, 1, 2))
                level, corners, peak = actual_level(ec, r, mis)
                phi_t = pitch / 2 + c1 / (2 * self._A_t)
                k0 = r.pairs.index(0)
                v = r.valid[0, k0]
                path = {"pinion": (r.z1[0, k0][v], r.radius1[0, k0][v]), "gear": (r.z2[0, k0][v], r.radius2[0, k0][v])}
                out.append(CaseReport(name=cname, misalignment=mis,
                                      fit_rms=float(np.sqrt(fits[cname])) * self.target.te_level,
                                      te_level_tca=level, edge_contact=r.edge_contact(),
                                      transfer_phi1=(float(phi_t - pitch), float(phi_t)), phi1=phi,
                                      te_envelope=r.te_envelope, path=path, result=r, corners=tuple(corners),
                                      peak=peak))
            return out

        # The first case here (its sweep solves the first guesses, memoised per angle and setting and
        # shared by the other cases: EdgeContact._first_guesses), then the last cases in a forked
        # process (split_forked: the same numbers, as a case's sweeps do not depend on the cases swept
        # before) beside the others here; all of them here where forking does not apply.
        return split_forked(checked, self.cases.items())

    def sensitivities(self, pair: GearPair, tca: TCA | None = None) -> dict:
        """d(TE level)/d(variable) of every case by AD through the TCA equations (implicit
        function theorem on each position, then the least-squares parabola fit of the TE).
        ``tca``: the compiled TCA of ``pair`` (built here if not given)."""
        if tca is None:
            tca = TCA(pair, side=self.side)
        elif tca.pair is not pair or tca.side != self.side:
            raise ArgumentError("sensitivities: tca must be the TCA of this pair on the optimizer's driving side.")
        z1, z2 = pair.pinion.z, pair.gear.z
        phis = self._phis
        K = phis.size
        V = np.c_[np.ones(K), phis, -phis**2]
        P = np.linalg.pinv(V)  # the fitted A is row 2 of P @ TE
        pitch = 2 * math.pi / z1
        names = list(SETTINGS) + [f"mis.{m}" for m in Misalignment.names()]
        out = {}
        for cname, mis in self.cases.items():
            res = tca.sweep(phis, mis=mis, pairs=(0,))
            if not res.converged.all():
                continue
            W = np.vstack([res.u1[0], res.z1[0], res.u2[0], res.z2[0], res.phi2[0] * tca.scale2])
            prm = tca.prm(phis, mis=mis)
            w_s, p_s = ca.SX.sym("w", 5), ca.SX.sym("p", prm.shape[0])
            Fw = tca.residual(w=w_s, prm=p_s)["F"]
            dwdp = ca.Function("dwdp", [w_s, p_s], [-ca.solve(ca.jacobian(Fw, w_s), ca.jacobian(Fw, p_s))])
            D = np.stack([np.asarray(dwdp(W[:, k], prm[:, k]))[4] / tca.scale2 for k in range(K)])  # dphi2/dprm
            cols = tca.layout.indices([f"pinion.{n}" for n in SETTINGS] + names[len(SETTINGS):])
            dA = P[2] @ D[:, cols]  # d(fitted A)/d(var)
            out[cname] = {n: float(v * (pitch / 2) ** 2) for n, v in zip(names, dA)}
        del z2
        return out


def actual_level(ec: EdgeContact, r: EdgeTCAResult, mis: Misalignment, zooms: int = 3,
                 points: int = 9) -> tuple[float, list[tuple[float, float]], tuple[float, float]]:
    """Peak-to-peak of the actual TE of a sweep ``r`` (an :class:`EdgeTCAResult` of ``ec``) at its
    true extremes, not at the sweep's samples.

    The actual TE is the upper envelope of the pairs' TE curves: its minima are corners where the
    driving contact changes, generally between two samples, so a sampled peak-to-peak is too low.
    Each change of the driving (pair, feature) between two samples is bracketed and the bracket
    shrunk by ``zooms`` engine sweeps of ``points`` positions of the two contacts involved; the
    corner is then where the two TE curves cross (their difference changes sign; linear
    interpolation in the last bracket, error ~A w^2 for a bracket w), or, where the earlier contact
    ends without crossing, the lowest envelope value found. The peak (a smooth maximum) is
    refined by the same zooming around the highest sample. TE values of the extra sweeps are put
    on the zero of ``r`` through a shared reference position. Each zoom of all the brackets and
    of the peak is one engine sweep (``zooms`` sweeps in all): a position's TE does not depend on
    the other positions of a sweep (:meth:`EdgeContact.sweep`).

    Returns
    -------
    level : float
        max - min of the actual TE [rad].
    corners : list of (phi1, te)
        The located corners [rad].
    peak : (phi1, te)
    """
    phi, env = r.phi1, r.te_envelope
    pairs = r.pairs
    drv, act = r.driving, r.active

    def subs(requests):
        """TE of the pairs ``ks`` at ``grid`` on the zero of r for each request (grid, ks, i_ref),
        all from one engine sweep (every position is solved by itself, EdgeContact.sweep: a
        position's TE does not depend on the others). Shared positions phi[i_ref], phi[i_ref + 1]
        precede each grid: each pair is shifted where both sweeps have it."""
        ks_all = tuple(sorted({k for _, ks, _ in requests for k in ks}))
        cols, starts = [], []
        for grid, _, i_ref in requests:
            starts.append(sum(c.size for c in cols))
            cols.append(np.r_[phi[[i_ref, min(i_ref + 1, phi.size - 1)]], grid])
        rr = ec.sweep(np.concatenate(cols), mis=mis, pairs=ks_all)
        out = []
        for (grid, ks, i_ref), s0 in zip(requests, starts):
            refs = [i_ref, min(i_ref + 1, phi.size - 1)]
            te = rr.te_pair[[ks_all.index(k) for k in ks], s0:s0 + 2 + grid.size].copy()
            for j, k in enumerate(ks):
                shift = math.nan
                for c, i_r in enumerate(refs):
                    ref = r.te_pair[pairs.index(k), i_r]
                    if np.isfinite(ref) and np.isfinite(te[j, c]):
                        shift = ref - te[j, c]
                        break
                te[j] += shift
            out.append(te[:, 2:])
        return out

    # the corners: every change of the driving (pair, feature) between two samples, bracketed
    corners_at = []
    lows = [float(np.nanmin(env))] if np.isfinite(env).any() else []
    for i in range(phi.size - 1):
        if drv[i] < 0 or drv[i + 1] < 0 or (drv[i], act[i]) == (drv[i + 1], act[i + 1]):
            continue
        ka, kb = pairs[drv[i]], pairs[drv[i + 1]]
        best = (float(phi[i + 1]), float(env[i + 1])) if env[i + 1] < env[i] else (float(phi[i]), float(env[i]))
        corners_at.append({"i": i, "ks": (ka,) if ka == kb else (ka, kb), "lo": phi[i], "hi": phi[i + 1],
                           "best": best, "cross": None, "live": True})
    # the peak: zoom around the highest sample
    peak = (math.nan, math.nan)
    apex = None
    if np.isfinite(env).any():
        i = int(np.nanargmax(env))
        peak = (float(phi[i]), float(env[i]))
        if drv[i] >= 0:
            h = float(np.median(np.diff(phi))) if phi.size > 1 else 1e-3
            # the apex may lie beyond the first or last sample
            apex = {"i": i, "ks": (pairs[drv[i]],), "lo": phi[i] - h, "hi": phi[i] + h, "live": True}
    # each zoom of every bracket and of the peak in one engine sweep
    for _ in range(zooms):
        live = [c for c in corners_at if c["live"]] + ([apex] if apex is not None and apex["live"] else [])
        if not live:
            break
        grids = [np.linspace(c["lo"], c["hi"], points) for c in live]
        for c, g, te in zip(live, grids, subs([(g, c["ks"], c["i"]) for c, g in zip(live, grids)])):
            if c is apex:
                e = te[0]
                if not np.isfinite(e).any():
                    c["live"] = False
                    continue
                j = int(np.nanargmax(e))
                if e[j] > peak[1]:
                    peak = (float(g[j]), float(e[j]))
                c["lo"], c["hi"] = g[max(j - 1, 0)], g[min(j + 1, points - 1)]
                continue
            e = np.nanmax(np.where(np.isfinite(te), te, -np.inf), axis=0)
            fin = np.isfinite(e)
            if fin.any():
                j = int(np.argmin(np.where(fin, e, np.inf)))
                if e[j] < c["best"][1]:
                    c["best"] = (float(g[j]), float(e[j]))
            if len(c["ks"]) == 1:
                # one pair changes its feature: the corner is the envelope minimum near it
                j = int(np.argmin(np.where(fin, e, np.inf)))
                c["lo"], c["hi"] = g[max(j - 1, 0)], g[min(j + 1, points - 1)]
                continue
            f = te[0] - te[1]
            a_ok = np.isfinite(f) & (f >= 0)
            if not a_ok.any() or a_ok.all():
                c["live"] = False
                continue
            j = int(np.flatnonzero(a_ok)[-1])
            if j + 1 >= points:
                c["live"] = False
                continue
            c["lo"], c["hi"] = g[j], g[j + 1]
            if np.isfinite(f[j + 1]):  # both curves on the bracket: where they cross (the finest wins)
                t = f[j] / (f[j] - f[j + 1])
                lo, hi = c["lo"], c["hi"]
                c["cross"] = (float(lo + t * (hi - lo)), float(te[0, j] + t * (te[0, j + 1] - te[0, j])))
    corners = []
    for c in corners_at:
        best = c["cross"] if c["cross"] is not None else c["best"]
        corners.append(best)
        lows.append(best[1])
    level = peak[1] - min(lows) if lows else math.nan
    return float(level), corners, peak
