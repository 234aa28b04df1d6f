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
from dataclasses import dataclass, field
from typing import NamedTuple

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..compiled import call, mapped, matrix_columns
from ..errors import (ArgumentError, ConvergenceError, LineContactError, OptionError, check_number,
                      out_of_range, shorten)
from ..gears import GearPair
from ..geometry.frames import rot_z
from ..geometry.generation import PARAMS, FlankLimit, GeneratedTooth, generate, generate_by_rack  # noqa: F401
from ..geometry.microgeometry import modified_tooth
from ..units import RAD_TO_ARCSEC
from .curvature import eigh2_sym, shape_matrix, unit_perp  # noqa: F401 (eigh2_sym re-exported)
from .layout import ParamLayout
from .misalignment import MISALIGNMENTS, Misalignment  # noqa: F401 (re-exported)
from .solver import (DELTA_DEFAULT, NORMAL_TOL, REGULARITY_MIN, Branch, ContactSettings, accept_tangency,  # noqa: F401 (re-exported)
                     SolverSettings)


KNOTS_PER_PITCH = 16  #: knots of the sweep's first guesses per angular pitch of the pinion (Branch.predict_knots)


def _describe(v) -> str:
    return f"{type(v).__name__} {shorten(repr(v))}"


class SweepArgs(NamedTuple):
    """The checked arguments of a sweep (:func:`check_sweep_args`)."""

    phi1: np.ndarray  #: (N,) pinion angles [rad]
    p1: np.ndarray  #: the pinion's parameter vector (its ``param_names`` entries)
    p2: np.ndarray  #: the gear's
    mis: Misalignment
    pairs: tuple[int, ...]  #: tooth pairs (pinion tooth numbers)


def _bytes(v) -> bytes:
    """Exact key of a parameter vector (None: the member's defaults)."""
    return b"" if v is None else np.ascontiguousarray(np.asarray(v, float)).tobytes()


def default_vector(tca: TCA, name: str, tooth: GeneratedTooth) -> np.ndarray:
    """``tooth.p0`` (a new array), kept per TCA under ``name`` ("p1" or "p2"): the teeth of a TCA are
    fixed when it is built, and assembling p0 from the gear's data costs a few microseconds a sweep."""
    kept = getattr(tca, "_defaults", None)
    if kept is None:
        return np.asarray(tooth.p0, float)
    if name not in kept:
        kept[name] = np.asarray(tooth.p0, float)
    return kept[name].copy()


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


def check_sweep_args(tca: TCA, phi1: npt.ArrayLike, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None,
                     mis: Misalignment | None = None, pairs: Sequence[int] = (-1, 0, 1), delta: float | None = None,
                     anchor: float = 0.0, z_section: float | None = 0.0) -> SweepArgs:
    """Validate and normalise the arguments of :meth:`TCA.sweep` / ``EdgeContact.sweep``.

    Returns :class:`SweepArgs` ``(phi1 (N,), p1, p2, mis, pairs)`` (p1, p2: each member's ``param_names`` entries); raises :class:`~gearopt.errors.ArgumentError`
    (wrong type, shape, empty, non-finite) or :class:`~gearopt.errors.GeometryError` (a misalignment
    that jams or separates the teeth, faces that do not overlap, a section off the face), naming
    the argument and its valid range.
    """
    pair = tca.pair
    g1 = pair.pinion
    try:
        arr = np.asarray(phi1)
        if arr.dtype.kind in "USb":  # "0.1" would convert: the API takes numbers in rad
            raise TypeError
        arr = arr.astype(float, copy=False)
    except (TypeError, ValueError):
        raise ArgumentError(f"phi1 = {_describe(phi1)}: expected a sequence of pinion angles [rad] (numbers).",
                            param="phi1", value=phi1, valid="a sequence of pinion angles [rad] (numbers)") from None
    if arr.ndim > 1:
        raise ArgumentError(f"phi1: expected a 1-D sequence of pinion angles [rad], got shape {arr.shape}.",
                            param="phi1", valid="a 1-D sequence of pinion angles [rad]")
    arr = np.atleast_1d(arr)
    if arr.size == 0:
        raise ArgumentError("phi1 is empty: a sweep needs at least one pinion angle [rad] (one mesh cycle is "
                            f"2 pi / z1 = {2 * math.pi / g1.z:.6g} rad).",
                            param="phi1", valid="at least one pinion angle [rad]")
    fin = np.isfinite(arr)
    if not fin.all():
        bad = np.flatnonzero(~fin)
        raise ArgumentError(f"phi1[{bad[0]}] = {arr[bad[0]]}: every pinion angle must be a finite number [rad] "
                            f"({bad.size} of {arr.size} are not).",
                            param=f"phi1[{bad[0]}]", value=float(arr[bad[0]]), valid="a finite number [rad]")
    vecs = []
    for name, p, tooth in (("p1", p1, tca.pinion), ("p2", p2, tca.gear)):
        if p is None:
            vecs.append(default_vector(tca, name, tooth))
            continue
        names = tooth.param_names  # PARAMS, then the theta of any flank modification
        try:
            v = np.asarray(p, dtype=float)
        except (TypeError, ValueError):
            raise ArgumentError(f"{name} = {_describe(p)}: expected {len(names)} numbers {names}.",
                                param=name, value=p, valid=f"{len(names)} numbers {names}") from None
        if v.shape != (len(names),):
            raise ArgumentError(f"{name}: expected a vector of {len(names)} numbers {names} (x, a_c [1/mm], u_0 [mm], "
                                f"a_pl [1/mm], then any modification parameters), got shape {v.shape}.",
                                param=name, valid=f"a vector of {len(names)} numbers {names}")
        if not np.all(np.isfinite(v)):
            bad = [n_ for n_, x_ in zip(names, v) if not math.isfinite(x_)]
            raise ArgumentError(f"{name} = {v.tolist()}: every entry of {names} must be finite ({bad} are not).",
                                param=name, value=v.tolist(), valid="finite entries")
        vecs.append(v)
    if mis is None:
        mis = Misalignment()
    elif not isinstance(mis, Misalignment):
        hint = " Use Misalignment(**d) (angles in rad)." if isinstance(mis, dict) else ""
        kinds = ", ".join(f"{k} [{'rad' if Misalignment.meta(k)['unit'] == 'angle' else 'mm'}]"
                          for k in Misalignment.names())
        raise ArgumentError(f"mis = {_describe(mis)}: expected a gearopt.meshing.tca.Misalignment ({kinds}).{hint}",
                            param="mis", value=mis, valid="a gearopt.meshing.tca.Misalignment")
    checked = getattr(tca, "_checked_mis", None)  # misalignments this TCA's pair accepted (frozen: same answer)
    if checked is None or mis not in checked:
        mis.check(pair, "mis")
        if checked is not None:
            if len(checked) >= 256:
                checked.clear()
            checked.add(mis)
    try:
        seq = list(pairs)
    except TypeError:
        raise ArgumentError(f"pairs = {_describe(pairs)}: expected a sequence of tooth-pair indices (integers), "
                            "e.g. (-1, 0, 1).",
                            param="pairs", value=pairs, valid="a sequence of tooth-pair indices (integers)") from None
    if not seq:
        raise ArgumentError("pairs is empty: give at least one tooth-pair index, e.g. (0,) or (-1, 0, 1).",
                            param="pairs", valid="at least one tooth-pair index")
    out = []
    for k in seq:
        if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)):
            raise ArgumentError(f"pairs contains {_describe(k)}: tooth-pair indices are integers (pinion tooth k, "
                                f"-{g1.z} < k < {g1.z}).",
                                param="pairs", value=k, valid=f"-{g1.z} < k < {g1.z}")
        if abs(int(k)) >= g1.z:
            raise ArgumentError(f"pairs contains {int(k)}; valid: -{g1.z} < k < {g1.z} (pinion teeth from tooth 0).",
                                param="pairs", value=int(k), valid=f"-{g1.z} < k < {g1.z}")
        out.append(int(k))
    if len(set(out)) != len(out):
        raise ArgumentError(f"pairs = {tuple(out)}: every tooth pair may appear once.",
                            param="pairs", value=tuple(out), valid="every tooth pair may appear once")
    for name, v in (("delta", delta), ("anchor", anchor), ("z_section", z_section)):
        if v is None:
            continue
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)) \
                or not math.isfinite(v):
            raise ArgumentError(f"{name} = {_describe(v)}: expected a finite number.",
                                param=name, value=v, valid="a finite number", detail=": expected a finite number.")
    if delta is not None and not 0 < delta <= 0.1 * g1.m_n:
        raise out_of_range("delta", delta, f"0 < delta <= 0.1 m_n = {0.1 * g1.m_n:.4g} mm (elastic approach for the "
                           "contact ellipse, microns)", cls=OptionError)
    if tca.contact_type == "line" and z_section is not None and abs(z_section) > g1.b / 2:
        raise out_of_range("z_section", z_section, f"|z_section| <= b1 / 2 = {g1.b / 2:.6g} mm (a section of the "
                           "pinion face)", cls=OptionError)
    return SweepArgs(phi1=arr, p1=vecs[0], p2=vecs[1], mis=mis, pairs=tuple(out))


def no_contact(where: str, phi1: np.ndarray, pairs: Sequence[int], z1: int) -> ConvergenceError:
    """The error for a sweep that found no contact at any position (never an all-NaN result)."""
    return ConvergenceError(
        f"{where}: no contact at any of the {phi1.size} positions phi1 = {phi1.min():.6g} .. "
        f"{phi1.max():.6g} rad (pairs {tuple(pairs)}). The angles may lie outside the meshing cycle (pair 0 meshes "
        f"around phi1 = 0; one cycle is 2 pi / z1 = {2 * math.pi / z1:.6g} rad; angles are in rad), or the flanks do "
        "not meet under this misalignment.")


class EnvelopeTE:
    """TE-envelope helpers shared by the result objects (needs ``te_envelope`` [rad])."""

    @property
    def te_envelope_arcsec(self) -> np.ndarray:
        return self.te_envelope * RAD_TO_ARCSEC

    @property
    def peak_to_peak(self) -> float:
        """Peak-to-peak of the actual TE (envelope) [rad]."""
        v = self.te_envelope[np.isfinite(self.te_envelope)]
        return float(v.max() - v.min()) if v.size else float("nan")

    @property
    def peak_to_peak_arcsec(self) -> float:
        """Peak-to-peak of the actual TE (envelope) [arcsec]."""
        return self.peak_to_peak * RAD_TO_ARCSEC


@dataclass(frozen=True)
class TCAResult(EnvelopeTE):
    """Numeric result of a TCA sweep (one design, one misalignment case).

    Arrays have shape (K, N): K tooth pairs (pinion tooth ``pairs[k]``, positions shifted by
    2 pi/z1) and N input positions ``phi1``.

    Attributes
    ----------
    phi1 : (N,) pinion angles [rad].
    phi2, te : (K, N) gear angle and transmission error [rad] of each pair (NaN where unsolved).
    te_envelope : (N,) actual TE [rad]: the upper envelope over pairs in contact on the active flank.
    driving : (N,) index into ``pairs`` of the driving pair (-1 where none).
    u1, z1, u2, z2 : (K, N) surface coordinates [mm] of the contact points.
    r1, r2 : (K, N, 3) contact points on pinion / gear in their own frames [mm].
    radius1, radius2 : (K, N) transverse radii of the contact point on each member [mm].
    rf : (K, N, 3) contact point in the fixed frame [mm].
    kappa1, kappa2 : (K, N, 2) principal curvatures of pinion and gear flank [1/mm] (convex > 0).
    ellipse_a, ellipse_b : (K, N) contact ellipse semi-axes [mm] (major, minor) for ``delta``.
    ellipse_dir2, ellipse_dir1 : (K, N, 2, 3) unit directions of the major ([..., 0, :]) and minor
        ([..., 1, :]) axes in the gear and in the pinion frame.
    residual : (K, N) residual norm after the solve [mm].
    normal_dot : (K, N) n1 . n2 of the outward normals in S_f (-1 for a true contact point).
    converged, on_surface : (K, N) bool flags.
    solve_time : float [s]; ``stats`` dict with counts and timing.
    """

    phi1: np.ndarray
    pairs: tuple
    phi2: np.ndarray
    te: np.ndarray
    te_envelope: np.ndarray
    driving: np.ndarray
    u1: np.ndarray
    z1: np.ndarray
    u2: np.ndarray
    z2: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    rf: np.ndarray
    radius1: np.ndarray
    radius2: np.ndarray
    kappa1: np.ndarray
    kappa2: np.ndarray
    ellipse_a: np.ndarray
    ellipse_b: np.ndarray
    ellipse_dir2: np.ndarray
    ellipse_dir1: np.ndarray
    residual: np.ndarray
    normal_dot: np.ndarray
    converged: np.ndarray
    on_surface: np.ndarray
    delta: float
    misalignment: Misalignment
    solve_time: float
    stats: dict = field(default_factory=dict)

    @property
    def te_arcsec(self) -> np.ndarray:
        """TE of every pair [arcsec]."""
        return self.te * RAD_TO_ARCSEC

    def transfer_phi1(self) -> list:
        """Pinion angles [rad] where the driving pair changes (midway between the two samples);
        empty for a conjugate drive (the pairs in contact tie, round-off picks the "driving" one)."""
        from ..report import CONJUGATE_ARCSEC

        if self.peak_to_peak_arcsec < CONJUGATE_ARCSEC:
            return []
        drv = self.driving
        return [float(0.5 * (self.phi1[i] + self.phi1[i + 1])) for i in range(len(drv) - 1)
                if drv[i] >= 0 and drv[i + 1] >= 0 and drv[i] != drv[i + 1]]

    def to_dict(self, label: str = "", z1: int | None = None, limits: dict | None = None) -> dict:
        """This case as results.json holds it (``cases[]`` of the tca study; every key, unit and
        meaning in docs/results.md): TE of every pair and the actual TE [arcsec], driving pair,
        transfers, harmonics, the central pair's path of contact, curvatures and contact ellipses.

        Parameters
        ----------
        label : str
            Name of the case.
        z1 : int, optional
            Pinion tooth number, for the mesh-frequency harmonics (None: ``harmonics_arcsec`` null).
        limits : dict, optional
            Flank boundaries for the plots (``{"pinion": {"b", "r_a", "r_form"}, "gear": ...}`` [mm]).
        """
        from ..report import CONJUGATE_ARCSEC, arr, misalignment_dict, pair_numbers, te_harmonics

        k0 = self.pairs.index(0) if 0 in self.pairs else 0
        env = self.te_envelope_arcsec
        stats = dict(self.stats)
        if "n_failed" in stats:  # tooth pairs out of mesh at a position: not a failure of the drive
            stats["n_pair_positions_without_contact"] = stats.pop("n_failed")
        pp = self.peak_to_peak_arcsec

        def member(z, radius, r, kappa, dirs):
            return {"axial": arr(z[k0]), "radius": arr(radius[k0]), "xyz": arr(r[k0]), "kappa": arr(kappa[k0]),
                    "ellipse_dirs": arr(dirs[k0].reshape(-1, 6))}

        return {
            "label": label,
            "misalignment": misalignment_dict(self.misalignment),
            "phi1": arr(self.phi1), "pairs": list(self.pairs),
            "phi2": arr(self.phi2), "te_arcsec": arr(self.te_arcsec), "te_envelope_arcsec": arr(env),
            "driving_pair": pair_numbers(self.driving, self.pairs), "transfer_phi1": self.transfer_phi1(),
            "peak_to_peak_arcsec": pp, "conjugate": bool(pp < CONJUGATE_ARCSEC),
            "harmonics_arcsec": None if z1 is None else te_harmonics(self.phi1, env, z1),
            "pinion": member(self.z1, self.radius1, self.r1, self.kappa1, self.ellipse_dir1),
            "gear": member(self.z2, self.radius2, self.r2, self.kappa2, self.ellipse_dir2),
            "ellipse_semi_major_mm": arr(self.ellipse_a[k0]), "ellipse_semi_minor_mm": arr(self.ellipse_b[k0]),
            "delta_mm": self.delta,
            "converged": [bool(v) for v in self.converged[k0]], "on_surface": [bool(v) for v in self.on_surface[k0]],
            "on_surface_pairs": [[bool(v) for v in row] for row in self.on_surface],
            "actual_te_at_every_position": bool(np.isfinite(self.te_envelope).all()),
            "max_residual": float(np.max(self.residual[self.converged])),  # over the accepted points
            "min_normal_dot": float(np.min(self.normal_dot[self.converged])),
            "stats": stats, "solve_time_s": self.solve_time,
            "limits": limits,
        }



class TCA:
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
            raise ArgumentError(f"pair = {_describe(pair)}: expected a gearopt.gears.GearPair (pinion, gear).",
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
                raise ArgumentError(f"w0 = {_describe(w0)}: expected {n_w} numbers (the unknowns [mm]).",
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
        result = self._result(_Solved(phi1=phi1, pairs=pairs, W=Wf, ok=ok, res=res, n1n2=n1n2, contact=c, delta=delta,
                                      mis=mis, solve_time=solve_time, stats=stats, phi2_ref=phi2_ref, p1=p1, p2=p2))
        if not ok.any():  # all-NaN: not a result (points found off the finite flanks are kept, flagged)
            raise no_contact("TCA.sweep", phi1, pairs, g1.z)
        return result

    # ------------------------------------------------------------------------------------------
    def _result(self, sv: "_Solved"):
        phi1, pairs, W, ok, res, n1n2 = sv.phi1, sv.pairs, sv.W, sv.ok, sv.res, sv.n1n2
        delta, mis, solve_time, stats, phi2_ref, p1, p2 = (sv.delta, sv.mis, sv.solve_time, sv.stats, sv.phi2_ref,
                                                           sv.p1, sv.p2)
        c = sv.contact
        K, N = len(pairs), phi1.size
        bad = np.flatnonzero(~ok)  # the columns not accepted
        # the contact points [pinion, gear, S_f] x column x xyz, NaN where not accepted (one array)
        pts = np.concatenate([c["r1"].T, c["r2"].T, c["rf1"].T]).reshape(3, K * N, 3)
        pts[:, bad] = np.nan
        g1, g2 = self.pair.pinion, self.pair.gear
        okk = ok.reshape(K, N)
        shp = lambda a: a.reshape(K, N)  # noqa: E731
        phi2 = shp(W[4] / self.scale2) + self._pitch_angles(pairs, 2)[:, None]
        # TE relative to the pair-0 gear angle at phi1 = 0, so that every pair and sweep shares one zero.
        ratio = g1.z / g2.z
        te = phi2 - ratio * phi1[None, :] - phi2_ref
        radii = np.hypot(pts[:2, :, 0], pts[:2, :, 1])  # transverse radii of the points on pinion and gear
        radius1, radius2 = shp(radii[0]), shp(radii[1])
        z1, z2 = shp(W[1]), shp(W[3])
        eps = 1e-9
        # Above the true end of each generated flank (junction, fold or crossing; per section z).
        lim1 = self.on_flank(1, shp(W[0]), z1, p1)
        lim2 = self.on_flank(2, shp(W[2]), z2, p2)
        # on the face (|z1| <= b1 / 2, |z2| <= b2 / 2) and inside the tip circles (NaN, where not
        # accepted, compares False)
        edge = self._memo.get("edge")
        if edge is None:  # (the pair is fixed when the TCA is built)
            edge = self._remember("edge", np.array([[g1.b / 2 + eps, g1.r_a + eps], [g2.b / 2 + eps, g2.r_a + eps]]))
        inside = (np.abs(W[1:4:2]) <= edge[:, :1]) & (radii <= edge[:, 1:])
        inside = shp(inside[0] & inside[1])
        on = okk & inside & lim1 & lim2
        te_on = np.where(on, te, -np.inf)
        drv = np.argmax(te_on, axis=0)
        env = te_on[drv, np.arange(N)]
        has = np.isfinite(env)
        # A tangency past the end of a folded flank that the tool cut off at a ridge (a convex edge):
        # that pair's real contact is on the ridge, at a TE between the surface one and nothing; if
        # the surface TE is above the envelope, the surface contacts cannot tell the actual TE there.
        ridge = None
        for member, lim_ok, uu, pp in ((1, lim1, W[0], p1), (2, lim2, W[2], p2)):
            if self.flank_limit(member, 0.0, pp).kind == "intersection":
                r_m = okk & ~lim_ok & np.isfinite(shp(uu)) & inside
                ridge = r_m if ridge is None else ridge | r_m
        if ridge is not None:
            # (a tie within round-off, e.g. conjugate line contact, changes nothing: the ridge TE <= the surface TE)
            unknown = (ridge & (np.where(ridge, te, -np.inf) > np.where(has, env, -np.inf)[None, :] + 1e-13)).any(axis=0)
            if unknown.any():
                has = has & ~unknown
                stats["ridge_contact"] = (
                    f"{int(unknown.sum())} of {N} positions: a tooth pair's contact falls past the end of a folded "
                    "flank, where the tool cut it off at a ridge; that pair rests on the ridge (edge contact), "
                    "so the actual TE there is NaN here: analyse edge contact (gearopt.contact.EdgeContact)")
        env = np.where(has, env, np.nan)
        driving = np.where(has, drv, -1)
        # Curvatures and contact ellipse (eigen-decomposition of K1 + K2 in the common basis, in the
        # compiled sweep outputs): semi-axes sqrt(2 delta / lam), NaN where not converged.
        kap1 = c["kappa1"].T.copy()
        kap2 = c["kappa2"].T.copy()
        lam = c["lam"].T
        ax_len = np.full(lam.shape, np.inf)  # no contact ellipse where K1 + K2 is not positive (or NaN)
        pos = lam > 0
        ax_len[pos] = np.sqrt(2 * delta / lam[pos])
        # [major, minor] x (3,) in the gear frame and in the pinion frame (each output (3, 2 K N):
        # column 2 j + a holds axis a of column j)
        edir = c["dir2"].T.reshape(K * N, 2, 3).copy()
        edir1 = c["dir1"].T.reshape(K * N, 2, 3).copy()
        for a in (kap1, kap2, ax_len, edir, edir1):
            a[bad] = np.nan
        ea, eb = ax_len.T.copy()
        # (phi2, te and the radii are NaN where not accepted already: W and the points are)
        return TCAResult(
            phi1=phi1, pairs=pairs, phi2=phi2, te=te,
            te_envelope=env, driving=driving, u1=shp(W[0]), z1=z1, u2=shp(W[2]), z2=z2,
            r1=pts[0].reshape(K, N, 3), r2=pts[1].reshape(K, N, 3), rf=pts[2].reshape(K, N, 3),
            radius1=radius1, radius2=radius2,
            kappa1=kap1.reshape(K, N, 2), kappa2=kap2.reshape(K, N, 2),
            ellipse_a=ea.reshape(K, N), ellipse_b=eb.reshape(K, N), ellipse_dir2=edir.reshape(K, N, 2, 3),
            ellipse_dir1=edir1.reshape(K, N, 2, 3),
            residual=res.reshape(K, N), normal_dot=n1n2.reshape(K, N), converged=okk, on_surface=on,
            delta=delta, misalignment=mis, solve_time=solve_time, stats=stats)

    def _orientation(self, tooth: GeneratedTooth, r_w: float) -> float:
        """Sign of (r_u x r_z) . n on the flank's valid branch (at the operating pitch radius)."""
        u, z = ca.SX.sym("u"), ca.SX.sym("z")
        r, n = tooth.surface(self.side, "flank")(u, z, tooth.p0)[:2]
        f = ca.Function("o", [u, z], [ca.dot(ca.cross(ca.jacobian(r, u), ca.jacobian(r, z)), n)])
        return float(np.sign(float(f(tooth.u_at_radius(r_w, 0.0, self.side), 0.0))))

    def form_radius(self, member: int, p: npt.ArrayLike | None = None) -> float:
        """Form radius [mm] of member 1 (pinion) or 2 (gear) on the driving flank in the mid section
        z = 0, for the parameter vector ``p`` (default: as built): where the real generated flank
        ends (:meth:`GeneratedTooth.flank_limit`: the tool's flank/fillet junction, or below a fold
        of the flank its crossing with the reversed branch or the fillet)."""
        return self.flank_limit(member, 0.0, p).radius

    def flank_limit(self, member: int, z: float = 0.0, p: npt.ArrayLike | None = None) -> FlankLimit:
        """:class:`~gearopt.geometry.generation.FlankLimit` of member 1 (pinion) or 2 (gear) on the
        driving side in section ``z`` [mm] for the parameter vector ``p`` (default: as built)."""
        tooth = self.pinion if member == 1 else self.gear
        p = tooth.p0 if p is None else np.asarray(p, float).ravel()
        key = ("limit", member, float(z), tuple(p.tolist()))
        if key not in self._limits:
            self._limits[key] = tooth.flank_limit(self.side, float(z), p)
        return self._limits[key]

    def limit_table(self, member: int, p: npt.ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(z^2 grid, u_limit on it): the flank limit depends on z only through the plunging a_pl z^2
        (a shift of the tool in that section), so it is tabulated in z^2 across the face."""
        tooth = self.pinion if member == 1 else self.gear
        p = tooth.p0 if p is None else np.asarray(p, float).ravel()
        key = ("table", member, tuple(p.tolist()))
        if key not in self._limits:
            b = (self.pair.pinion if member == 1 else self.pair.gear).b
            a_pl = p[self.layout.p_index("pinion" if member == 1 else "gear", "a_pl")]
            s = np.array([0.0]) if a_pl == 0 else (b / 2) ** 2 * np.linspace(0.0, 1.0, 9)
            ends = [self.flank_limit(member, math.sqrt(v), p) for v in (s[0], s[-1])]
            if all(e.kind == "junction" for e in ends) and ends[0].u == ends[1].u:
                # The plunging shifts the tool monotonically in z^2, and a fold (undercut) grows with
                # the shift: regular at both ends means regular in between, and the flank ends at
                # the tool's junction, the same u in every section (checked: tests/test_flank_limit.py).
                s = s[:1]
            self._limits[key] = (s, np.array([self.flank_limit(member, math.sqrt(v), p).u for v in s]))
        return self._limits[key]

    def on_flank(self, member: int, u: npt.ArrayLike, z: npt.ArrayLike, p: npt.ArrayLike | None = None,
                 band: float = 1e-3) -> np.ndarray:
        """True where the flank point (u, z) [mm] of member 1 or 2 lies on the real generated flank
        (``u`` not past the flank limit of its section; the tip and face are checked elsewhere).
        The limit is interpolated in z^2 (:meth:`limit_table`) and recomputed exactly for points
        within ``band`` [mm] of it or within the limit's change across their table interval (the
        interpolation's error bound: the limit moves monotonically with the plunging shift).
        NaN points are False."""
        u, z = np.asarray(u, float), np.asarray(z, float)
        s_grid, u_grid = self.limit_table(member, p)
        fin = np.isfinite(u) & np.isfinite(z)
        if s_grid.size == 1:  # one limit in every section (compared where finite only)
            return np.less_equal(u, u_grid[0] + 1e-8, out=np.zeros(u.shape, bool), where=fin)
        b = (self.pair.pinion if member == 1 else self.pair.gear).b
        s = np.clip(np.where(fin, z, 0.0) ** 2, 0.0, (b / 2) ** 2)
        u_lim = np.interp(s, s_grid, u_grid) if s_grid.size > 1 else np.full(u.shape, u_grid[0])
        if s_grid.size > 1:  # within the table interval's own variation of the limit (the
            # interpolation's error bound), or within band of it: the exact limit of that section
            k = np.clip(np.searchsorted(s_grid, s, side="right") - 1, 0, s_grid.size - 2)
            width = np.maximum(band, np.abs(np.diff(u_grid))[k])
            near = fin & (np.abs(np.where(fin, u, 0.0) - u_lim) < width)
        else:
            near = np.zeros(u.shape, bool)
        for idx in zip(*np.nonzero(near)):
            u_lim[idx] = self.flank_limit(member, math.sqrt(s[idx]), p).u
        with np.errstate(invalid="ignore"):
            return fin & (u <= u_lim + 1e-8)

    on_active_flank = on_flank  #: (the old name)

    def folding(self, p1: npt.ArrayLike | None = None, p2: npt.ArrayLike | None = None) -> dict:
        """Members whose driving flank folds before the tool's junction (mid section), with the
        flank limit and the largest a_c that does not fold: ``{"pinion": {...}}``; empty if none."""
        out = {}
        for member, name, tooth, p in ((1, "pinion", self.pinion, p1), (2, "gear", self.gear, p2)):
            lim = self.flank_limit(member, 0.0, p)
            if lim.folded:
                key = ("a_c_max", member, tuple((tooth.p0 if p is None else np.asarray(p, float)).tolist()))
                if key not in self._limits:
                    self._limits[key] = float(tooth.max_unfolded_a_c(self.side, 0.0, p))
                out[name] = {"kind": lim.kind, "r_form": float(lim.radius), "u_limit": float(lim.u),
                             "r_fold": float(lim.radius_fold),
                             "r_junction": float(np.hypot(*tooth.point(self.side, "flank", lim.u_junction, 0.0,
                                                                       p)[0][:2])),
                             "a_c": float((tooth.p0 if p is None else np.asarray(p, float))[
                                 self.layout.p_index(name, "a_c")]),
                             "a_c_max_unfolded": self._limits[key]}
        return out


@dataclass
class _Solved:
    """What a sweep solved, handed to :meth:`TCA._result` by name: positions ``phi1`` (N,),
    ``pairs``, full unknowns ``W`` (5, K N) (NaN where not accepted), the per-point checks ``ok``,
    ``res``, ``n1n2`` (K N,), the mapped contact Function's outputs by name ``contact``, and the
    sweep's settings."""

    phi1: np.ndarray
    pairs: tuple
    W: np.ndarray
    ok: np.ndarray
    res: np.ndarray
    n1n2: np.ndarray
    contact: dict
    delta: float
    mis: Misalignment
    solve_time: float
    stats: dict
    phi2_ref: float
    p1: np.ndarray | None = None
    p2: np.ndarray | None = None
