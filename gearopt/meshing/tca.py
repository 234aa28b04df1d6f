"""Tooth contact analysis of 3-D involute drives with misalignment (Litvin section 9.4).

For every input angle phi1 of the pinion the unknowns ``w = (u1, z1, u2, z2, r_p2 phi2)`` (surface
coordinates of both flanks in mm, and the gear angle scaled to mm) solve (eq. 9.4.31)

    r_f1(u1, z1, phi1) - r_f2(u2, z2, phi2) = 0               (3 equations)
    n_f1 . dr_f2/du2 = 0,   n_f1 . dr_f2/dz2 = 0              (2 independent normal conditions)

with every design parameter (both tooth surfaces' parameter vectors, the misalignments) a symbolic
input of one expression graph. Newton on exact AD Jacobians (``ca.rootfinder``) solves it; sweeps go
through ``Function.map`` from first guesses predicted by the implicit function theorem at an anchor
point, then every solution is checked (residual, opposite outward normals, inside the active flank).

Frames and signs (docs/theory.md section 1)
------------------------------------------
* S_f: pinion axis = z_f; gear centre at ``(0, a + dE, axial)``; the line of centres is y_f.
* The pinion drives on its ``side`` flank ("right": the +x side of tooth 0) and turns clockwise,
  ``r_f1 = Rz(-phi1 + theta1) r_1``: phi1 > 0 in the driving direction; theta1 (half the tooth angle
  on the operating pitch circle) makes phi1 = 0 the position where tooth 0's driving flank crosses
  the operating pitch circle on the line of centres (the pitch point I).
* The gear turns counter-clockwise, ``r_f2 = O_2 + R_mis Rz(phi2) Rz(pi + theta2) r_2``: at
  phi2 = 0 its contacting flank passes through I. phi2 > 0 in the driven direction.
  (For the left flank every rotation changes sign.)
* Misalignments of the gear (frame S_q at its centre): ``crossing`` turns the gear axis about y_f
  (axes become skew), ``intersecting`` about x_f (axes stay coplanar), ``dE`` changes the centre
  distance, ``axial`` shifts the gear along its axis.
* Transmission error: ``TE(phi1) = phi2(phi1) - (z1/z2) phi1 - phi2(0)`` [rad] (positive: gear ahead).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..compiled import call, mapped, matrix_columns
from ..errors import ArgumentError, ConvergenceError, LineContactError, OptionError, check_number, out_of_range, shorten
from ..gears import GearPair
from ..geometry.frames import rot_z
from ..geometry.generation import PARAMS, FlankLimit, GeneratedTooth, generate, generate_by_rack  # noqa: F401
from ..geometry.microgeometry import modified_tooth
from .curvature import eigh2_sym, shape_matrix, unit_perp  # noqa: F401 (eigh2_sym re-exported)
from .flank_limits import FlankLimits
from .layout import ParamLayout
from .misalignment import MISALIGNMENTS, Misalignment  # noqa: F401 (re-exported)
from .solver import (DELTA_DEFAULT, NORMAL_TOL, REGULARITY_MIN, Branch, ContactSettings, accept_tangency,  # noqa: F401 (re-exported)
                     SolverSettings)
from .sweep_args import check_sweep_args, describe, no_contact
from .tca_result import SolvedSweep, TCAResult, TCAResultAssembly


KNOTS_PER_PITCH = 16  #: knots of the sweep's first guesses per angular pitch of the pinion (Branch.predict_knots)


def _bytes(v) -> bytes:
    """Exact key of a parameter vector (None: the member's defaults)."""
    return b"" if v is None else np.ascontiguousarray(np.asarray(v, float)).tobytes()



def _point_key(phi1, w0, p1, p2, mis, z_section) -> tuple | None:
    """Exact key of :meth:`TCA.solve_point`'s arguments when they are of the kinds a sweep passes (floats,
    no first guess, float vectors or None, a Misalignment or None); None for any other (checked and
    solved at every call)."""
    if w0 is not None or not isinstance(phi1, float) or not isinstance(z_section, float) \
            or not (mis is None or isinstance(mis, Misalignment)):
        return None
    parts = ["point", np.array([phi1, z_section]).tobytes(), b"" if mis is None else mis.vector().tobytes()]
    for p in (p1, p2):
        if p is None:
            parts.append(None)
        elif isinstance(p, np.ndarray) and p.dtype == np.float64 and p.ndim == 1:
            parts.append(p.tobytes())
        else:
            return None
    return tuple(parts)


class TCA(FlankLimits, TCAResultAssembly):
    """Compiled tooth contact analysis of a gear pair (build once, solve many).

    Parameters
    ----------
    pair : GearPair
        Pinion (driving) and gear; ``pair.a_w`` is the nominal centre distance.
    side : {"right", "left"}
        Driving flank of the pinion (the gear's contacting flank follows).
    pinion, gear : GeneratedTooth, optional
        Generated tooth surfaces (default: each member cut by its own tool, ``generate(gear)``).
    solver : {"fast_newton", "newton"}
        CasADi rootfinder plugin for mapped sweeps (a line-search ``newton`` is the fallback).
    tol : float
        Acceptance threshold on the residual norm [mm].
    contact : {"point", "line"}
        Point contact (crowned pinion) or line contact (conjugate surfaces, solved in a given
        pinion section ``z_section``).
    jit : {"auto", True, False}
        Run the mapped sweep (rootfinder + checks, and the contact outputs) as compiled C
        (:mod:`gearopt.compiled`: compiled once per graph, 0.2-0.8 s, cached on disk across
        processes, then ~10x faster; see benchmarks/bench_compiled.py): "auto" (default) whenever
        the library is in the cache, whatever the sweep's size; on a cache miss a sweep of at least
        :data:`gearopt.compiled.MIN_COLUMNS` columns compiles at once, a smaller one runs
        interpreted while the library compiles in the background (:func:`gearopt.compiled.select`).
        True for every sweep, False never.
        Without a working C compiler the interpreted Functions run, after a one-line warning.
    """

    def __init__(self, pair: GearPair, side: str = "right", pinion: GeneratedTooth | None = None,
                 gear: GeneratedTooth | None = None, solver: str = SolverSettings.solver,
                 tol: float = SolverSettings.tol, contact: str = "point", jit: bool | str = SolverSettings.jit):
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {describe(pair)}: expected a gearopt.gears.GearPair (pinion, gear).",
                                param="pair", value=pair, valid="a gearopt.gears.GearPair")
        if side not in ("right", "left"):
            raise out_of_range("side", side, "'right' or 'left'", cls=OptionError)
        if contact not in ("point", "line"):
            raise out_of_range("contact", contact, "'point' (crowned or misaligned drives) or 'line' (conjugate "
                               "surfaces: contact sought in the pinion section z_section)", cls=OptionError)
        if not (isinstance(jit, (bool, np.bool_)) or (isinstance(jit, str) and jit == "auto")):
            raise out_of_range("jit", jit, "'auto', True or False (run the sweeps as compiled C)", cls=OptionError)
        self.contact_type = contact
        self.jit = jit if isinstance(jit, str) else bool(jit)
        if solver not in ("fast_newton", "newton"):
            raise out_of_range("solver", solver, "'fast_newton' or 'newton'", cls=OptionError)
        tol = check_number("tol", tol, "a residual tolerance [mm]", cls=OptionError)
        if not 0 < tol <= 1e-6:
            raise out_of_range("tol", tol, "0 < tol <= 1e-6 mm (residual of the contact equations)", cls=OptionError)
        t0 = time.perf_counter()
        self.pair, self.side, self.solver, self.tol = pair, side, solver, tol
        # each member's generated tooth with its ISO micro-geometry (Gear.modifications) composed in
        self.pinion = pinion or modified_tooth(pair, "pinion")
        self.gear = gear or modified_tooth(pair, "gear")
        self._limits: dict = {}
        self._build()
        self.build_time = time.perf_counter() - t0

    # ------------------------------------------------------------------------------------------
    def _build(self):
        pair, side = self.pair, self.side
        g1, g2 = pair.pinion, pair.gear
        sgn = 1.0 if side == "right" else -1.0  # the left flank drives the other way round
        line = self.contact_type == "line"
        w = ca.SX.sym("w", 4 if line else 5)
        # Every symbolic input by name (gearopt.meshing.layout): phi1, both members' surface
        # parameters, the misalignments, and the pinion section sought in line contact.
        self.layout = lay = ParamLayout.for_teeth(self.pinion, self.gear)
        sym = lay.symbols(ca.SX)
        phi1, p1, p2, mis, zsec = sym["phi1"], sym["pinion"], sym["gear"], sym["mis"], sym["z_section"]
        m_of = lay.named(lay.build(sym))["mis_map"]  # kind -> symbol
        self.scale2 = g2.r_p  # phi2 is carried as r_p2 * phi2 [mm]
        if line:
            u1, z1, u2, z2, phi2 = w[0], zsec, w[1], w[2], w[3] / self.scale2
        else:
            u1, z1, u2, z2, phi2 = w[0], w[1], w[2], w[3], w[4] / self.scale2
        self._nw = w.numel()
        #: (w, z_section) -> the full unknowns (u1, z1, u2, z2, r_p2 phi2) [mm] (line contact: z1 = z_section)
        self.w_full = self._full = ca.Function("w_full", [w, zsec], [ca.vertcat(u1, z1, u2, z2, phi2 * self.scale2)])
        # Reference positions: at phi1 = phi2 = 0 the driving flanks of pinion tooth 0 and of the
        # gear cross their operating pitch circles on the line of centres (the pitch point I).
        r_w1 = pair.r_w1
        r_w2 = pair.a_w - r_w1
        self.theta1 = g1.s_at(r_w1) / (2 * r_w1)  # half tooth angle on the operating pitch circle
        self.theta2 = g2.s_at(r_w2) / (2 * r_w2)
        S1 = self.pinion.surface(side, "flank")
        S2 = self.gear.surface(side, "flank")

        def kin(u1, z1, u2, z2, phi2, phi1, p1, p2, mis):
            """Both flanks in S_f: points, normals and coordinate tangents (eq. 9.4.30)."""
            r1, n1 = S1(u1, z1, p1)[:2]
            r2, n2 = S2(u2, z2, p2)[:2]
            # Pinion: clockwise by phi1 for the right flank (the left flank drives counter-clockwise).
            rot1 = -sgn * phi1 + sgn * self.theta1

            def gear_to_fixed(v, point: bool):
                v = rot_z(math.pi + sgn * self.theta2, v)
                v = rot_z(sgn * phi2, v)
                return Misalignment.gear_to_fixed(m_of, v, pair.a_w, point)  # frame S_q

            rad1 = ca.vertcat(r1[0], r1[1], 0.0) / ca.sqrt(r1[0] ** 2 + r1[1] ** 2)
            rad2 = ca.vertcat(r2[0], r2[1], 0.0) / ca.sqrt(r2[0] ** 2 + r2[1] ** 2)
            return {"r1": r1, "n1": n1, "r2": r2, "n2": n2, "rot1": rot1,
                    "er1": rot_z(rot1, rad1), "er2": gear_to_fixed(rad2, False),
                    "ez2": gear_to_fixed(ca.DM([0.0, 0.0, 1.0]), False),
                    "rf1": rot_z(rot1, r1), "nf1": rot_z(rot1, n1),
                    "t1u": rot_z(rot1, ca.jacobian(r1, u1)), "t1z": rot_z(rot1, ca.jacobian(r1, z1)),
                    "rf2": gear_to_fixed(r2, True), "nf2": gear_to_fixed(n2, False),
                    "t2u": gear_to_fixed(ca.jacobian(r2, u2), False), "t2z": gear_to_fixed(ca.jacobian(r2, z2), False)}

        k = kin(u1, z1, u2, z2, phi2, phi1, p1, p2, mis)
        r1, n1, r2, n2, rot1 = k["r1"], k["n1"], k["r2"], k["n2"], k["rot1"]
        rf1, nf1, rf2, nf2, t2u, t2z = k["rf1"], k["nf1"], k["rf2"], k["nf2"], k["t2u"], k["t2z"]
        # Kinematics of any point pair q = (u1, z1, u2, z2, r_p2 phi2) (edge contact builds on it).
        q = ca.SX.sym("q", 5)
        prm_k = lay.build(sym)
        kq = kin(q[0], q[1], q[2], q[3], q[4] / self.scale2, phi1, p1, p2, mis)
        names_k = ["rf1", "nf1", "t1u", "t1z", "rf2", "nf2", "t2u", "t2z", "r1", "r2", "er1", "er2", "ez2"]
        self.kinematics = ca.Function("tca_kinematics", [q, prm_k], [kq[n] for n in names_k], ["q", "prm"], names_k)
        if line:  # line contact: n . dr2/dz2 vanishes identically; the section z1 is given
            F = ca.vertcat(rf1 - rf2, ca.dot(nf1, t2u))
        else:
            F = ca.vertcat(rf1 - rf2, ca.dot(nf1, t2u), ca.dot(nf1, t2z))
        prm = lay.build(sym)
        self._nprm = prm.numel()
        self._phi_row = lay.index("phi1")
        self.residual = ca.Function("tca_residual", [w, prm], [F], ["w", "prm"], ["F"], {"cse": True})
        self.jacobian = ca.Function("tca_jacobian", [w, prm], [ca.jacobian(F, w)], ["w", "prm"], ["J"])
        # Curvatures and contact ellipse (Litvin ch. 9; docs/theory.md section 8) at a solved point.
        q1, q2 = ca.vertcat(u1, z1), ca.vertcat(u2, z2)
        e1 = r1 * 0 + unit_perp(n1)  # tangent basis in the pinion frame
        e2 = ca.cross(n1, e1)
        E1 = ca.horzcat(e1, e2)
        B1 = shape_matrix(r1, n1, q1, E1)
        # The same basis carried into the gear frame (a rotation), where surface 2 lives.
        def fixed_to_gear(v):
            v = rot_z(rot1, v)  # pinion -> fixed
            v = Misalignment.fixed_to_gear_rotation(m_of, v)
            v = rot_z(-sgn * phi2, v)
            return rot_z(-(math.pi + sgn * self.theta2), v)
        E2 = ca.horzcat(fixed_to_gear(e1), fixed_to_gear(e2))
        # Surface 2's outward normal is -n1 at contact: its convex curvature in the same basis.
        B2 = shape_matrix(r2, n2, q2, E2)
        K1 = 0.5 * (B1 + B1.T)
        K2 = 0.5 * (B2 + B2.T)
        # Regularity of both surfaces at the point: |dr/du x dr/dz| (0 at the involute's singular point,
        # where n . dr/du = 0 holds for any normal and crossing surfaces solve the equations).
        # Signed: (r_u x r_z) . n keeps its sign on the valid branch of each flank and changes it past
        # the cusp (the reversed involute branch of an undercut tooth, whose tool normal would still
        # pass the n1 . n2 = -1 test).
        self.orient1 = self._orientation(self.pinion, pair.r_w1)
        self.orient2 = self._orientation(self.gear, pair.r_w2)
        reg = ca.fmin(self.orient1 * ca.dot(ca.cross(ca.jacobian(r1, u1), ca.jacobian(r1, z1)), n1),
                      self.orient2 * ca.dot(ca.cross(ca.jacobian(r2, u2), ca.jacobian(r2, z2)), n2))
        out = [rf1, nf1, rf2, nf2, ca.dot(nf1, nf2), r1, r2, K1, K2, E2, E1, reg]
        names = ["rf1", "nf1", "rf2", "nf2", "n1n2", "r1", "r2", "K1", "K2", "E2", "E1", "reg"]
        self.contact = ca.Function("tca_contact", [w, prm], out, ["w", "prm"], names)
        # What a sweep reports per point (compiled with the sweep): points, principal curvatures, and
        # the contact ellipse's eigenvalues lam (ascending: the major axis has the smaller one) and
        # its [major, minor] unit directions in the gear and pinion frames (closed-form symmetric
        # 2 x 2 eigen-decomposition, eigh2_sym; numbers only, never differentiated).
        lam_s, vec_s = eigh2_sym(K1 + K2)
        self.sweep_outputs = ca.Function(
            "tca_sweep_out", [w, prm], [r1, r2, rf1, eigh2_sym(K1)[0], eigh2_sym(K2)[0], lam_s, ca.mtimes(E2, vec_s),
                                        ca.mtimes(E1, vec_s)],
            ["w", "prm"], ["r1", "r2", "rf1", "kappa1", "kappa2", "lam", "dir2", "dir1"])
        checks = ca.Function("tca_checks", [w, prm], [ca.dot(nf1, nf2), reg], ["w", "prm"], ["n1n2", "reg"])
        self.branch = Branch("tca", self.residual, checks, functools.partial(accept_tangency, tol=self.tol), self.tol,
                             self.solver, self.jit, extra=self.sweep_outputs, own_maps=True,
                             taylor=not any(g.modifications is not None and g.modifications.measured
                                            for g in (pair.pinion, pair.gear)))
        self._maps: dict = {}
        # solved anchors and pitch-point guesses by their exact inputs (a repeated sweep of the same
        # design and misalignment solves its anchor once; the outputs are those of a new solve)
        self._memo: dict = {}
        self._columns: dict = {}  # parameter columns by design and misalignment (prm)
        self._checked_mis: set = set()  # misalignments check_sweep_args accepted for this pair
        self._defaults: dict = {}  # the teeth's p0 (default_vector)

    def _contact_mapped(self, n: int):
        """The sweep's contact quantities on the few columns continuation rescued (interpreted)."""
        key = ("contact",)
        if key not in self._maps:
            self._maps[key] = mapped(self.sweep_outputs, n, False)
        return self._maps[key]

    def prm(self, phi1: npt.ArrayLike, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None,
            mis: Misalignment | None = None, z_section: float = 0.0) -> np.ndarray:
        """Parameter matrix (n_prm, N) for the positions ``phi1`` (:meth:`ParamLayout.pack`, rows
        named by ``self.layout``)."""
        mis = mis or Misalignment()
        key = (_bytes(p1), _bytes(p2), mis.vector().tobytes(), z_section)  # exact (-0.0 is not 0.0 here)
        hit = self._columns.get(key)
        if hit is None:  # the column without phi1 (every entry but phi1 is the same in each column)
            p1 = self.pinion.p0 if p1 is None else np.asarray(p1, float)
            p2 = self.gear.p0 if p2 is None else np.asarray(p2, float)
            if len(self._columns) >= 64:
                self._columns.pop(next(iter(self._columns)))
            hit = self._columns[key] = self.layout.pack([0.0], {"pinion": p1, "gear": p2, "mis": mis,
                                                                 "z_section": z_section})[:, 0]
        phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        out = np.empty((hit.size, phi1.size))
        out[...] = hit[:, None]
        out[self._phi_row] = phi1
        return out

    def _full_numeric(self, W, z_section: float) -> np.ndarray:
        """:attr:`w_full` of the solved columns W (nw, n) in numpy: (5, n) (u1, z1, u2, z2, r_p2 phi2)."""
        W = np.asarray(W, float)
        if self.contact_type != "line":
            return W.copy()
        return np.vstack([W[:1], np.full((1, W.shape[1]), float(z_section)), W[1:]])

    def _reduce(self, w_full):
        w_full = np.asarray(w_full, float)
        return w_full[[0, 2, 3, 4]] if self.contact_type == "line" else w_full

    def guess(self, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None, z_section: float = 0.0) -> np.ndarray:
        """First guess at the pitch point: both flanks at their operating pitch radii, mid face
        (the unknown vector of this TCA: 5 entries, or 4 for line contact)."""
        key = ("guess", _bytes(p1), _bytes(p2), float(z_section))
        hit = self._memo.get(key)
        if hit is None:
            pair = self.pair
            r_w1 = pair.r_w1
            u1 = self.pinion.u_at_radius(r_w1, z_section, self.side, p1)
            u2 = self.gear.u_at_radius(pair.a_w - r_w1, z_section, self.side, p2)
            hit = self._remember(key, self._reduce([u1, z_section, u2, z_section, 0.0]))
        return hit.copy()

    def _pitch_angles(self, pairs: tuple[int, ...], member: int) -> np.ndarray:
        """``2 pi k / z`` [rad] of the tooth pairs k on member 1 (pinion) or 2 (gear), kept per pairs."""
        key = ("pitch", member, pairs)
        hit = self._memo.get(key)
        if hit is None:
            z = (self.pair.pinion if member == 1 else self.pair.gear).z
            hit = self._remember(key, np.array([2 * math.pi * k / z for k in pairs]))
        return hit

    def _remember(self, key: tuple, value: np.ndarray) -> np.ndarray:
        """Keep ``value`` under ``key`` in the memo of guesses and anchors (the oldest go beyond 64)."""
        if len(self._memo) >= 64:
            self._memo.pop(next(iter(self._memo)))
        self._memo[key] = value
        return value

    def _accept(self, res, n1n2, reg):
        """Acceptance of solved points: residual below tol, outward normals opposite (n1 . n2 = -1
        to NORMAL_TOL: tangency, not crossing) and both surfaces regular (not at a singular point)."""
        return accept_tangency(res, n1n2, reg, self.tol)

    def _check(self, w, prm):
        return self.branch.check(w, prm)

    def solve_point(self, phi1: float, w0: npt.ArrayLike | None = None, p1: npt.ArrayLike | None = None,
                    p2: npt.ArrayLike | None = None, mis: Misalignment | None = None,
                    z_section: float = 0.0) -> np.ndarray:
        """Solve one position with the line-search Newton; raise :class:`ConvergenceError` if the
        residual is not below ``tol`` or the normals do not oppose (a false root).

        Returns
        -------
        w : ndarray
            The unknowns (u1, z1, u2, z2, r_p2 phi2) [mm]; (u1, u2, z2, r_p2 phi2) for line contact.
        """
        known = _point_key(phi1, w0, p1, p2, mis, z_section)
        if known is not None:  # the same arguments as a solve that passed the checks: its solution
            hit = self._memo.get(known)
            if hit is not None:
                return hit.copy()
        phi1 = check_number("phi1", phi1, "a finite pinion angle [rad]")
        z_section = check_number("z_section", z_section, "a finite pinion section [mm]")
        _, p1, p2, mis, _ = check_sweep_args(self, [phi1], p1, p2, mis, pairs=(0,), z_section=z_section)
        if known is not None:
            return self._remember(known, self._solve_at(phi1, w0, p1, p2, mis, z_section)).copy()
        n_w = 4 if self.contact_type == "line" else 5
        if w0 is None:
            w0 = self.guess(p1, p2, z_section)
        else:
            try:
                w0 = np.asarray(w0, float).ravel()
            except (TypeError, ValueError):
                raise ArgumentError(f"w0 = {describe(w0)}: expected {n_w} numbers (the unknowns [mm]).",
                                    param="w0", value=w0, valid=f"{n_w} numbers") from None
            if w0.size != n_w or not np.all(np.isfinite(w0)):
                raise ArgumentError(f"w0 = {shorten(str(w0.tolist()))}: expected {n_w} finite numbers (the unknowns "
                                    f"[mm] for {self.contact_type} contact), got {w0.size}.",
                                    param="w0", value=w0.tolist(), valid=f"{n_w} finite numbers")
        return self._solve_at(phi1, w0, p1, p2, mis, z_section)

    def _solve_at(self, phi1: float, w0: np.ndarray | None, p1: np.ndarray, p2: np.ndarray, mis: Misalignment,
                  z_section: float) -> np.ndarray:
        """:meth:`solve_point` on arguments already checked (by it, or by :func:`check_sweep_args`)."""
        if w0 is None:
            w0 = self.guess(p1, p2, z_section)
        prm = self.prm([phi1], p1, p2, mis, z_section)[:, 0]
        key = ("anchor", _bytes(w0), _bytes(prm))  # everything the solve depends on
        hit = self._memo.get(key)
        if hit is not None:
            return hit.copy()
        J = np.asarray(self.jacobian(w0, prm))
        if self.contact_type == "point" and np.linalg.cond(J) > 1e14:
            raise LineContactError(
                f"TCA: the point-contact equations are singular at phi1 = {phi1:.6g} rad (Jacobian condition "
                f"{np.linalg.cond(J):.2g}): the flanks are in line contact (no crowning, no angular misalignment). "
                "Use contact='line' (TCA in a given pinion section) or crown the pinion.",
                                   param="contact", value=self.contact_type, valid="'line'")
        w = self.branch.newton(w0, prm)
        res, n1n2, reg, ok = self._check(w, prm)
        at = f"TCA at phi1 = {phi1:.6g} rad"
        g1, g2 = self.pair.pinion, self.pair.gear
        wf = np.asarray(self._full(w, z_section)).ravel()
        off_face = bool(np.all(np.isfinite(wf)) and (abs(wf[1]) > g1.b / 2 or abs(wf[3]) > g2.b / 2))
        if not np.isfinite(res) or res > self.tol:
            if off_face:
                raise ConvergenceError(
                    f"{at}: no contact point on the face: the search ran off it (last iterate z1 = {wf[1]:.4g} mm, "
                    f"z2 = {wf[3]:.4g} mm; faces +-{g1.b / 2:g} / +-{g2.b / 2:g} mm). The contact leaves the "
                    "tooth: analyse edge contact (gearopt.contact.EdgeContact, [tca] edge_contact = true) or "
                    "crown the pinion more.")
            raise ConvergenceError(f"{at}: no contact point (residual {res:.3g} mm > {self.tol:g} mm); the first "
                                   "guess may be too far or the flanks do not meet.")
        if not ok and off_face:
            # A root of the equations on the flanks' mathematical extension beyond the face (where the
            # extended surfaces may also be singular or reversed): not a contact of these teeth.
            where = self._root_facts(w, prm, wf)
            raise ConvergenceError(
                f"{at}: no contact point on the face: the tangency equations converge only off it, at z1 = "
                f"{wf[1]:.4g} mm, z2 = {wf[3]:.4g} mm (faces +-{g1.b / 2:g} / +-{g2.b / 2:g} mm; {where}). The "
                "flanks have no point contact on the teeth here: the contact is on an edge; analyse edge contact "
                "(gearopt.contact.EdgeContact, [tca] edge_contact = true) or crown the pinion more.")
        if reg <= REGULARITY_MIN:
            where = self._root_facts(w, prm, wf)
            raise ConvergenceError(f"{at}: false root at a singular point of a flank ((r_u x r_z) . n = {reg:.2g}: "
                                   f"{where}): the surfaces cross there, they do not touch. Start from another guess.")
        if n1n2 > 0:
            raise ConvergenceError(f"{at}: false root: the outward normals agree (n1 . n2 = {n1n2:.3f}, must be "
                                   "-1); typical near the involute base-circle singular point. Start from another guess.")
        if not ok:
            hint = (" The flanks are not in line contact here: use contact='point' (and crown the pinion "
                    "longitudinally)." if self.contact_type == "line" else " Start from another guess.")
            raise ConvergenceError(f"{at}: the surfaces cross instead of touching (n1 . n2 = {n1n2:.12f}, must be "
                                   f"-1 within {NORMAL_TOL:g}).{hint}")
        return self._remember(key, w).copy()

    def _root_facts(self, w, prm, wf) -> str:
        """What a rejected root is, in words: for each flank whose regularity (r_u x r_z) . n has
        the wrong sign or vanishes, where the point lies (radius against base circle and fold)."""
        k = self.kinematics(q=wf, prm=prm)
        out = []
        for member, name, orient, tu, tz, nf, r, tooth in (
                (1, "pinion", self.orient1, "t1u", "t1z", "nf1", "r1", self.pinion),
                (2, "gear", self.orient2, "t2u", "t2z", "nf2", "r2", self.gear)):
            reg = orient * float(ca.dot(ca.cross(k[tu], k[tz]), k[nf]))
            rad = float(np.hypot(*np.asarray(k[r]).ravel()[:2]))
            if reg > REGULARITY_MIN:
                continue
            p = np.asarray(prm, float).ravel()[self.layout.slice(name)]
            lim = self.flank_limit(member, 0.0, p)
            fold = (f"its flank folds at radius {lim.radius_fold:.6g} mm" if lim.folded else
                    f"its flank is regular down to the tool junction, radius {lim.radius:.6g} mm")
            side = "reversed branch" if reg < 0 else "singular point"
            cusp = "its fold" if lim.folded else "the involute's base-circle cusp"
            out.append(f"{name} point at radius {rad:.6g} mm (base circle {tooth.gear.r_b:.6g} mm; {fold}) lies on "
                       f"the {side} of its flank surface, at or past {cusp}")
        return "; ".join(out) if out else "both flanks regular there"

    def sweep(self, phi1: npt.ArrayLike, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None,
              mis: Misalignment | None = None, pairs: Sequence[int] = (-1, 0, 1),
              delta: float = DELTA_DEFAULT, anchor: float = 0.0, z_section: float = 0.0,
              continuation: bool = True) -> TCAResult:
        """TCA over the pinion angles ``phi1`` [rad] for the tooth pairs ``pairs``.

        Pair k is pinion tooth k (positions ``phi1 - 2 pi k / z1`` of pair 0), its gear angle shifted
        back by ``2 pi k / z2``. Each position is solved by the mapped rootfinder from an
        implicit-function prediction around the anchor solve at ``phi1 = anchor``; positions that
        fail the checks are re-solved by continuation from solved neighbours with line-search
        Newton, and flagged (NaN, ``converged = False``) if that fails too.

        Parameters
        ----------
        phi1 : array_like (N,)
            Pinion angles [rad] (0: pinion tooth 0 centred on the line of centres).
        p1, p2 : array_like, optional
            Surface parameter vectors of pinion and gear, one entry per ``GeneratedTooth.param_names``
            (:data:`gearopt.geometry.generation.PARAMS`, then any flank-modification parameters;
            rows named in ``self.layout``).
        mis : Misalignment, optional
        pairs : sequence of int
            Pinion teeth (tooth pairs) to analyse.
        delta : float
            Elastic approach for the contact ellipse [mm].
        anchor : float
            Pinion angle of the first (line-search Newton) solve [rad].
        continuation : bool
            Re-solve failed positions from solved neighbours. ``False``: every position is solved
            from its own prediction only, so that its result does not depend on the other positions
            of the sweep (what EdgeContact uses).
        z_section : float
            Line contact only: the pinion's axial section [mm].

        Returns
        -------
        TCAResult
            Points that fail the checks are NaN with ``converged = False``; points off the finite
            flanks have ``on_surface = False``.

        Raises
        ------
        ArgumentError
            Wrong type, shape or value of an argument (see :func:`check_sweep_args`).
        GeometryError
            A misalignment that jams or separates the teeth, or faces that do not overlap.
        ConvergenceError
            No position converged (never an all-NaN result), or the anchor solve failed.
        """
        t0 = time.perf_counter()
        phi1, p1, p2, mis, pairs = check_sweep_args(self, phi1, p1, p2, mis, pairs, delta, anchor, z_section)
        g1 = self.pair.pinion
        K, N = len(pairs), phi1.size
        # pair k's positions phi1 - 2 pi k / z1, pair after pair
        phis = (phi1[None, :] - self._pitch_angles(pairs, 1)[:, None]).ravel()
        prm = self.prm(phis, p1, p2, mis, z_section)
        w_a = self.solve_point(anchor, None, p1, p2, mis, z_section)  # the public anchor solve (EdgeContact and tests wrap it)
        prm_a = prm[:, 0].copy()  # the anchor's column: the same but phi1
        prm_a[self._phi_row] = anchor
        if continuation:  # every pair is the same branch w(phi1 - 2 pi k / z1): guesses from its knots
            W0 = self.branch.predict_knots(w_a, prm_a, phis, anchor, lambda v: self.prm(v, p1, p2, mis, z_section),
                                           2 * math.pi / g1.z / KNOTS_PER_PITCH, n_total=phis.size)
        else:
            W0 = self.branch.predict(w_a, prm_a, phis - anchor)
        groups = list(np.arange(K * N).reshape(K, N)) if continuation else []
        # solved with the contact quantities at each point in the same compiled pass
        W, res, n1n2, reg, ok, st = self.branch.solve(W0, prm, groups, extra=True)
        n_fast, n_retry = st["n_fast"], st["n_retry"]
        c = st.pop("extra")
        fix = st.pop("rescued")
        if fix.size:  # columns solved by continuation after the first pass
            f_c = self._contact_mapped(fix.size)
            for name, v in zip(f_c.name_out(), call(f_c, W[:, fix], prm[:, fix])):
                width = v.shape[1] // fix.size
                c[name][:, matrix_columns(fix, width)] = v
        Wf = self._full_numeric(W, z_section) if self.contact_type == "line" else W  # (W: this sweep's own array)
        Wf[:, ~ok] = np.nan
        # TE zero: phi2 of pair 0 at phi1 = 0 (the same for every sweep of this design and case);
        # r_p2 phi2 is the last unknown for point and line contact alike
        w_0 = w_a if anchor == 0.0 else self.solve_point(0.0, w_a, p1, p2, mis, z_section)
        phi2_ref = float(np.asarray(w_0, float)[-1]) / self.scale2
        solve_time = time.perf_counter() - t0
        stats = {"n_positions": int(phis.size), "n_fast": n_fast, "n_retry": n_retry,
                 "n_failed": ok.size - int(np.count_nonzero(ok)), "build_s": self.build_time, "solver": self.solver,
                 "contact": self.contact_type}
        folded = self.folding(p1, p2)
        if folded:
            stats["folded_flanks"] = folded
        result = self._result(SolvedSweep(phi1=phi1, pairs=pairs, W=Wf, ok=ok, res=res, n1n2=n1n2, contact=c,
                                          delta=delta, mis=mis, solve_time=solve_time, stats=stats, phi2_ref=phi2_ref,
                                          p1=p1, p2=p2))
        if not ok.any():  # all-NaN: not a result (points found off the finite flanks are kept, flagged)
            raise no_contact("TCA.sweep", phi1, pairs, g1.z)
        return result

    def _orientation(self, tooth: GeneratedTooth, r_w: float) -> float:
        """Sign of (r_u x r_z) . n on the flank's valid branch (at the operating pitch radius)."""
        u, z = ca.SX.sym("u"), ca.SX.sym("z")
        r, n = tooth.surface(self.side, "flank")(u, z, tooth.p0)[:2]
        f = ca.Function("o", [u, z], [ca.dot(ca.cross(ca.jacobian(r, u), ca.jacobian(r, z)), n)])
        return float(np.sign(float(f(tooth.u_at_radius(r_w, 0.0, self.side), 0.0))))
