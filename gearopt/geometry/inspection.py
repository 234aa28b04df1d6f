"""Flank inspection as a measuring machine does it: deviation topography, profile and lead charts,
and the CSV grid format for export and import (docs/microgeometry.md).

Numeric, outside any AD graph. The deviation of a flank at a transverse radius ``R`` in a section
``z`` is the ISO transverse deviation

    delta_t = s r_b (theta_act(R, z) - theta_ref(R, z))                                   [mm]

with ``theta = atan2(x, y)`` the polar angle (gear frame: tooth centred on +y, right flank on the
+x side), ``theta_act`` that of the flank (generated, possibly modified) and ``theta_ref`` that of
the design involute helicoid of the gear (straight rack at the generating shift x_E, no crowning, no
modification), in closed form; ``s = +1`` on the right flank, ``-1`` on the left, so material added is
positive. ``r_b Delta theta`` is exactly the distance between the involutes of the base circle through
the two points, measured along any base tangent in the transverse plane: the measuring direction of
ISO 1328-1 profile and helix charts. The profile coordinate is the roll length ``L_y = sqrt(R^2 -
r_b^2)`` (or the diameter ``d_y = 2R``), the face coordinate the axial position ``z`` (face I at
``-b/2``, face II at ``+b/2``).

Charts (ISO 1328-1): over an evaluation range, ``F`` is the total deviation (peak to valley of the
trace), ``f_f`` the form deviation (peak to valley of the residual from the least-squares mean line),
``f_H`` the slope deviation (rise of the least-squares line over the range: + = more material
towards the tip / face II) and ``C`` the crowning (sagitta of the least-squares parabola over the
range: + = material removed at both ends).
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ArgumentError, GeometryError, out_of_range, shorten
from .involute import inv

if TYPE_CHECKING:
    from ..gears import Gear
    from ..types import ArrayLike, Param
    from .envelope import GeneratedTooth

SIDES = ("right", "left")
PROFILES = ("L_y", "d_y")
N_PROFILE, N_FACE = 41, 21  #: default inspection grid (profile x face)


# ---------------------------------------------------------------------------------------------
# Deviation of a flank from the design involute helicoid
# ---------------------------------------------------------------------------------------------
def reference_angle(gear: Gear, side: str, R: ArrayLike, z: ArrayLike) -> np.ndarray:
    """Polar angle ``atan2(x, y)`` [rad] of the design involute helicoid of ``gear`` (straight rack at
    the generating shift ``x_E``: tooth thickness :attr:`Gear.s_t`) at radius ``R`` [mm] in the
    section ``z`` [mm]: ``+-(s_t / (2 r_p) + inv(alpha_t) - inv(alpha_R)) - h z tan(beta) / r_p`` (the
    tooth's half angle; a right-hand helix (h = +1) turns counter-clockwise with +z)."""
    R, z = np.asarray(R, dtype=float), np.asarray(z, dtype=float)
    a_R = np.arccos(np.clip(gear.r_b / R, -1.0, 1.0))
    half = gear.s_t / (2 * gear.r_p) + inv(gear.alpha_t) - (np.tan(a_R) - a_R)
    turn = gear.helix_sign * z * math.tan(gear.beta) / gear.r_p
    return (half if side == "right" else -half) - turn


def _flank_eval(tooth, side):
    # (u, z, p) -> (radius, d radius/du, angle of the point from the y axis); cached in a tuple like
    # every evaluator (with_modification composes only the surface Functions)
    key = f"{side}_inspect_eval"
    if key not in tooth.functions:
        import casadi as ca

        u, z = ca.SX.sym("u"), ca.SX.sym("z")
        p = ca.SX.sym("p", len(tooth.param_names))
        rad, drad = tooth.radius_function(side)(u, z, p)
        r = tooth.surface(side, "flank")(u, z, p)[0]
        tooth.functions[key] = (ca.Function(f"{side}_inspect", [u, z, p], [rad, drad, ca.atan2(r[0], r[1])]),)
    return tooth.functions[key][0]


def flank_deviation(tooth: GeneratedTooth, side: str, R: ArrayLike, z: ArrayLike, p: Param = None) -> np.ndarray:
    """ISO transverse deviation ``delta_t`` [mm] of a tooth's flank from the design involute helicoid
    at radii ``R`` [mm] in sections ``z`` [mm] (arrays broadcast; module docstring).

    Parameters
    ----------
    tooth : GeneratedTooth
        The member's tooth (generated, possibly with modifications composed).
    side : {"right", "left"}
    R, z : array_like
        Transverse radius and axial position [mm].
    p : array_like, optional
        The tooth's parameter vector (default ``tooth.p0``).

    Raises
    ------
    GeometryError
        Naming ``R`` when a radius is not on the flank (below the start of the real flank, its
        flank limit, or above the tip).
    """
    if side not in SIDES:
        raise out_of_range("side", side, "'right' or 'left'", cls=ArgumentError)
    g = tooth.gear
    p = np.asarray(tooth.p0 if p is None else p, dtype=float)
    R, z = np.broadcast_arrays(np.asarray(R, dtype=float), np.asarray(z, dtype=float))
    shape = R.shape
    R, z = R.ravel(), z.ravel()
    f = _flank_eval(tooth, side)
    theta = np.empty(R.size)
    for zz in np.unique(z):
        sel = z == zz
        lim = tooth.flank_limit(side, float(zz), p)
        u_lo = float(tooth.extras.get("q_above_tip", -3.0 * g.m_n))
        u_hi = float(lim.u)
        us = np.linspace(u_lo, u_hi, 400)
        F = f.map(us.size)
        rad = np.asarray(F(us[None, :], np.full((1, us.size), zz), np.repeat(p[:, None], us.size, 1))[0]).ravel()
        r_min, r_max = rad[-1], min(rad[0], g.r_a + 1e-9)
        Rs = R[sel]
        bad = (Rs < r_min - 1e-9) | (Rs > r_max + 1e-9)
        if bad.any():
            raise out_of_range(f"{g.name}.{side} flank radius R", float(Rs[bad][0]), f"{r_min:.6g} <= R <= {r_max:.6g} "
                               f"mm in the section z = {zz:.6g} mm (from the flank limit to the tip)", cls=GeometryError)
        # radius decreases along u on the real flank: interpolate a first guess, then Newton
        order = np.argsort(rad)
        u = np.interp(Rs, rad[order], us[order])
        Fm = f.map(Rs.size)
        for _ in range(8):
            rr, dr, th = (np.asarray(v).ravel() for v in Fm(u[None, :], np.full((1, Rs.size), zz),
                                                              np.repeat(p[:, None], Rs.size, 1)))
            step = (rr - Rs) / dr
            u = u - step
            if np.abs(step).max() < 1e-13:
                break
        theta[sel] = np.asarray(Fm(u[None, :], np.full((1, Rs.size), zz), np.repeat(p[:, None], Rs.size, 1))[2]).ravel()
    s = 1.0 if side == "right" else -1.0
    dev = s * g.r_b * (theta - reference_angle(g, side, R, z))
    return dev.reshape(shape)


def roll_length(gear: Gear, R: ArrayLike) -> np.ndarray:
    """Roll length ``L_y = sqrt(R^2 - r_b^2)`` [mm] of transverse radii R [mm]."""
    return np.sqrt(np.maximum(np.asarray(R, dtype=float) ** 2 - gear.r_b**2, 0.0))


def radius_of_roll_length(gear: Gear, L: ArrayLike) -> np.ndarray:
    """Transverse radius [mm] of roll lengths L [mm]."""
    return np.sqrt(np.asarray(L, dtype=float) ** 2 + gear.r_b**2)


# ---------------------------------------------------------------------------------------------
# The grid
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FlankGrid:
    """Deviations of one flank on an inspection grid (what a measuring machine reports).

    Parameters
    ----------
    side : {"right", "left"}
    profile : {"L_y", "d_y"}
        What ``s`` holds: roll lengths [mm] or diameters [mm].
    s : tuple of float
        Profile positions [mm], strictly increasing, at least 4.
    z : tuple of float
        Face positions [mm] (axial; face I at -b/2, face II at +b/2), strictly increasing, at least 4.
    deviation : tuple of tuples
        ISO transverse deviations [mm], ``deviation[i][j]`` at ``(s[i], z[j])``; + = material added.
    member, source : str
        Informational: the member's name and the file the grid was read from.
    """

    side: str
    profile: str
    s: tuple
    z: tuple
    deviation: tuple
    member: str = ""
    source: str = ""

    def __post_init__(self):
        where = f"grid {self.source or self.member or ''}".rstrip()
        if self.side not in SIDES:
            raise out_of_range(f"{where}: side", self.side, "'right' or 'left'", cls=ArgumentError)
        if self.profile not in PROFILES:
            raise out_of_range(f"{where}: profile", self.profile, "'L_y' (roll length) or 'd_y' (diameter)",
                               cls=ArgumentError)
        axes = {}
        for nm in ("s", "z"):
            try:
                a = np.asarray(getattr(self, nm), dtype=float)
            except (TypeError, ValueError):
                raise ArgumentError(f"{where}: {nm} = {shorten(repr(getattr(self, nm)))}: expected numbers [mm].",
                                    param=f"{where}: {nm}", value=getattr(self, nm), valid="numbers [mm]") from None
            if a.ndim != 1 or a.size < 4:
                raise ArgumentError(f"{where}: {nm} has {a.size} points: a cubic spline needs at least 4.",
                                    param=f"{where}: {nm}", value=a.size, valid="at least 4 points")
            bad = np.nonzero(~np.isfinite(a) | np.r_[False, np.diff(a) <= 0])[0]
            if bad.size:
                k = int(bad[0])
                raise ArgumentError(f"{where}: {nm}[{k}] = {a[k]!r}: positions must be finite and strictly increasing.",
                                    param=f"{where}: {nm}[{k}]", value=float(a[k]),
                                    valid="finite, strictly increasing positions [mm]")
            axes[nm] = tuple(float(v) for v in a)
        try:
            V = np.asarray(self.deviation, dtype=float)
        except (TypeError, ValueError):
            raise ArgumentError(f"{where}: deviation: expected a (len(s), len(z)) table of numbers [mm].",
                                param=f"{where}: deviation", valid="a table of numbers [mm]") from None
        if V.shape != (len(axes["s"]), len(axes["z"])):
            raise ArgumentError(f"{where}: deviation has shape {V.shape}: expected ({len(axes['s'])}, "
                                f"{len(axes['z'])}) (len(s), len(z)).", param=f"{where}: deviation", value=V.shape,
                                valid=f"shape ({len(axes['s'])}, {len(axes['z'])})")
        if not np.all(np.isfinite(V)):
            i, j = (int(v) for v in np.argwhere(~np.isfinite(V))[0])
            raise ArgumentError(f"{where}: deviation[{i}][{j}] = {V[i, j]!r} (at s = {axes['s'][i]:g}, z = "
                                f"{axes['z'][j]:g} mm): every deviation must be a finite number.",
                                param=f"{where}: deviation[{i}][{j}]", value=float(V[i, j]), valid="a finite number")
        object.__setattr__(self, "s", axes["s"])
        object.__setattr__(self, "z", axes["z"])
        object.__setattr__(self, "deviation", tuple(tuple(float(v) for v in row) for row in V))

    def values(self) -> np.ndarray:
        """Deviations (m, k) [mm]."""
        return np.array(self.deviation, dtype=float)

    def roll_lengths(self, r_b: float) -> np.ndarray:
        """Profile positions as roll lengths [mm]."""
        s = np.array(self.s)
        return s if self.profile == "L_y" else np.sqrt(np.maximum((s / 2) ** 2 - r_b**2, 0.0))

    def diameters(self, r_b: float) -> np.ndarray:
        """Profile positions as diameters [mm]."""
        s = np.array(self.s)
        return s if self.profile == "d_y" else 2 * np.sqrt(s**2 + r_b**2)

    def to_dict(self) -> dict:
        """JSON-able: ``side``, ``profile``, ``s_mm``, ``z_mm``, ``deviation_um`` (rows: profile)."""
        return {"member": self.member, "side": self.side, "profile": self.profile, "s_mm": list(self.s),
                "z_mm": list(self.z), "deviation_um": (self.values() * 1000).tolist()}


def inspect_flank(tooth: GeneratedTooth, side: str, n_profile: int = N_PROFILE, n_face: int = N_FACE,
                  d_range: tuple[float, float] | None = None, p: Param = None, member: str = "",
                  profile: str = "L_y") -> FlankGrid:
    """The flank's deviation topography on an inspection grid: ``n_profile`` roll lengths, equally
    spaced over ``d_range`` (diameters [mm], default the start of the real flank (its flank limit,
    the highest over the sections) to the tip; pass the active
    profile ``(d_Nf, d_a)`` of a pair), x ``n_face`` axial positions equally spaced over the face
    ``[-b/2, b/2]``. ``profile``: the grid's profile coordinate, ``"L_y"`` or ``"d_y"`` (the
    positions are equally spaced in roll length either way)."""
    g = tooth.gear
    if profile not in PROFILES:
        raise out_of_range("profile", profile, "'L_y' or 'd_y'", cls=ArgumentError)
    for nm, v in (("n_profile", n_profile), ("n_face", n_face)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 4 <= v <= 2000:
            raise out_of_range(nm, v, "an integer 4..2000", cls=ArgumentError)
    z = np.linspace(-g.b / 2, g.b / 2, n_face)
    if d_range is None:  # from the real flank's start (its flank limit, in every section) to the tip
        r_lim = max(tooth.flank_limit(side, float(zz), None if p is None else np.asarray(p, float)).radius for zz in z)
        d_range = (2 * r_lim + 1e-9, 2 * g.r_a)
    d0, d1 = (float(v) for v in d_range)
    if not 2 * g.r_b < d0 < d1 <= 2 * g.r_a + 1e-9:
        raise out_of_range("d_range", [d0, d1], f"d_b = {2 * g.r_b:.6g} < d_start < d_end <= d_a = {2 * g.r_a:.6g} mm",
                           cls=ArgumentError)
    L = np.linspace(roll_length(g, d0 / 2), roll_length(g, min(d1, 2 * g.r_a) / 2), n_profile)
    R = radius_of_roll_length(g, L)
    RR, ZZ = np.meshgrid(R, z, indexing="ij")
    dev = flank_deviation(tooth, side, RR, ZZ, p)
    s = L if profile == "L_y" else 2 * R
    return FlankGrid(side=side, profile=profile, s=tuple(s), z=tuple(z), deviation=tuple(map(tuple, dev)),
                     member=member or g.name)


#: Largest measured deviation accepted [m_n]: the bound of every micro-geometry amount
#: (:data:`gearopt.geometry.microgeometry.AMOUNT_MAX_PER_M`, 0.1 m_n: the flank tolerances of
#: ISO 1328-1:2013 class 11, the coarsest, stay below about 0.06 m_n for m_n >= 1 mm, and designed
#: reliefs and crownings are some 0.01 m_n). A larger value is a unit error or a bad cell.
DEVIATION_MAX_PER_M = 0.1


def check_grid_on_flank(grid: FlankGrid, gear: Gear, tol: float = 1e-3) -> None:
    """Refuse a grid that leaves the flank or cannot be a measurement of it, naming the file and
    the row (profile position) or column (face position):

    * a negative roll length (``L_y`` >= 0 on an involute), a profile position below the base
      circle or above the tip (by more than ``tol`` [mm] in diameter), a face position beyond
      ``b/2 + tol``;
    * a grid whose profile positions all lie below the form circle (it covers no point of the
      flank: the message states the flank's roll-length range);
    * a deviation beyond ``DEVIATION_MAX_PER_M m_n`` (a wrong ``# deviation:`` unit, an outlier).
    """
    d = grid.diameters(gear.r_b)
    where = f"grid {grid.source or grid.member}".rstrip()
    L_a = math.sqrt(max(gear.r_a**2 - gear.r_b**2, 0.0))
    for i, di in enumerate(d):
        if grid.profile == "L_y" and grid.s[i] < 0:
            raise out_of_range(f"{where}: row {i} column 0 (profile position L_y = {grid.s[i]:g} mm)", grid.s[i],
                               f"roll lengths 0 <= L_y <= L_a = {L_a:.6g} mm (on the {gear.name} flank; a roll "
                               "length is never negative)", cls=ArgumentError)
        if grid.profile == "d_y" and di <= 2 * gear.r_b or di > 2 * gear.r_a + tol:
            raise out_of_range(f"{where}: row {i} (profile position {grid.s[i]:g} mm, {grid.profile})",
                               grid.s[i], f"diameters d_b = {2 * gear.r_b:.6g} < d_y <= d_a = {2 * gear.r_a:.6g} "
                               f"mm (on the {gear.name} flank)", cls=ArgumentError)
    r_form = float(gear.r_form)
    L_form = math.sqrt(max(r_form**2 - gear.r_b**2, 0.0))
    if float(np.max(d)) < 2 * r_form - tol:
        s_max = grid.s[int(np.argmax(d))]
        unit = "L_y" if grid.profile == "L_y" else "d_y"
        raise out_of_range(f"{where}: column 0 (profile positions up to {unit} = {s_max:g} mm)", s_max,
                           f"a grid that covers part of the {gear.name} flank: roll lengths L_F = {L_form:.6g} ... "
                           f"L_a = {L_a:.6g} mm (diameters d_Ff = {2 * r_form:.6g} ... d_a = {2 * gear.r_a:.6g} mm, "
                           "the form circle to the tip); every row of this grid lies below the form circle",
                           cls=ArgumentError)
    for j, zj in enumerate(grid.z):
        if abs(zj) > gear.b / 2 + tol:
            raise out_of_range(f"{where}: column {j} (face position z = {zj:g} mm)", zj,
                               f"|z| <= b/2 = {gear.b / 2:.6g} mm", cls=ArgumentError)
    V = grid.values()
    lim = DEVIATION_MAX_PER_M * gear.m_n
    big = np.argwhere(np.abs(V) > lim)
    if big.size:
        i, j = (int(v) for v in big[np.argmax(np.abs(V[tuple(big.T)]))])
        v = V[i, j]
        n_big = len(big)
        hint = (f"{n_big} of {V.size} cells are beyond it: does the file's '# deviation:' line state the wrong unit "
                "(mm for values in um)?" if n_big > V.size / 2 else
                f"{n_big} of {V.size} cells are beyond it: a bad cell (an outlier of the measurement)?")
        valid = (f"|deviation| <= {DEVIATION_MAX_PER_M:g} m_n = {lim * 1000:.6g} um (m_n = {gear.m_n:g} mm; the bound of "
                 "any micro-geometry: flank tolerances and modifications are microns)")
        detail = f"is out of range; valid: {valid}. {hint}"
        name = (f"{where}: row {i} column {j + 1} (profile position {grid.s[i]:g} mm, face position z = {grid.z[j]:g} "
                "mm): deviation")
        raise ArgumentError(f"{name} = {v * 1000:.6g} um {detail}", param=name, value=float(v * 1000), valid=valid,
                            detail=detail)


# ---------------------------------------------------------------------------------------------
# Charts (ISO 1328-1)
# ---------------------------------------------------------------------------------------------
def _chart(x, dev, x_range, names):
    x, dev = np.asarray(x, dtype=float), np.asarray(dev, dtype=float)
    if x_range is not None:
        sel = (x >= x_range[0] - 1e-12) & (x <= x_range[1] + 1e-12)
        x, dev = x[sel], dev[sel]
        lo, hi = x_range
    else:
        lo, hi = x[0], x[-1]
    if x.size < 3:
        raise ArgumentError(f"chart: {x.size} points in the evaluation range: at least 3 are needed.",
                            param="x_range", value=x_range, valid="a range holding at least 3 points")
    t = (x - (lo + hi) / 2) / (hi - lo)
    line = np.polyfit(t, dev, 1)
    par = np.polyfit(t, dev, 2)
    resid = dev - np.polyval(line, t)
    F, f_f, f_H, C = (float(np.ptp(dev)), float(np.ptp(resid)), float(line[0]), float(-par[0] / 4))
    return dict(zip(names, (F, f_f, f_H, C)))


def profile_chart(L: ArrayLike, dev: ArrayLike, L_range: tuple[float, float] | None = None) -> dict:
    """Profile chart values [mm] of a trace (roll lengths L [mm], deviations [mm]) over its
    evaluation range (default: the whole trace): ``F_alpha``, ``f_f_alpha``, ``f_H_alpha``,
    ``C_alpha`` (module docstring; exact for ``-C (2t)^2 + f_H t + c``, ``t = (L - L_m) / L_alpha``
    on a grid symmetric about the range's middle)."""
    return _chart(L, dev, L_range, ("F_alpha", "f_f_alpha", "f_H_alpha", "C_alpha"))


def lead_chart(z: ArrayLike, dev: ArrayLike, z_range: tuple[float, float] | None = None) -> dict:
    """Helix chart values [mm] of a trace along the face: ``F_beta``, ``f_f_beta``, ``f_H_beta``,
    ``C_beta`` (as :func:`profile_chart`, positions z [mm])."""
    return _chart(z, dev, z_range, ("F_beta", "f_f_beta", "f_H_beta", "C_beta"))


def chart_values(grid: FlankGrid, r_b: float) -> dict:
    """The charts of a grid as a measuring report states them [mm]: the profile chart of the trace
    at mid face (interpolated between the two middle columns if needed), the lead chart of the
    trace at mid profile (the middle row), and the bias ``S_alpha = f_H_alpha(face II) -
    f_H_alpha(face I)`` from the profile traces at the two face ends (exact for a bilinear twist).
    Evaluation ranges: the grid's profile and face extent."""
    L = grid.roll_lengths(r_b)
    z = np.array(grid.z)
    V = grid.values()
    mid = np.array([np.interp(0.0, z, row) for row in V]) if z[0] <= 0 <= z[-1] else V[:, z.size // 2]
    prof = profile_chart(L, mid)
    i_mid = int(np.argmin(np.abs(L - (L[0] + L[-1]) / 2)))
    lead = lead_chart(z, V[i_mid])
    S = profile_chart(L, V[:, -1])["f_H_alpha"] - profile_chart(L, V[:, 0])["f_H_alpha"]
    return {**prof, **lead, "S_alpha": S, "z_profile": 0.0 if z[0] <= 0 <= z[-1] else float(z[z.size // 2]),
            "L_lead": float(L[i_mid])}


# ---------------------------------------------------------------------------------------------
# CSV
# ---------------------------------------------------------------------------------------------
_UNITS = {"um": 1e-3, "mm": 1.0}
_KEYS = ("profile", "face", "deviation", "side", "member")


def write_grid_csv(grid: FlankGrid, path: str | os.PathLike) -> Path:
    """Write a grid in gearopt's topography CSV format (docs/microgeometry.md), atomically.

    Format: comment lines ``# key: value`` (``profile: L_y mm`` or ``d_y mm``, ``face: z mm``,
    ``deviation: um``, ``side: right|left``, ``member: <name>``), then a header row
    ``<profile>\\z, z_0, z_1, ...`` and one row per profile position: its value [mm], then the
    deviations [um] at each face position."""
    path = Path(path)
    lines = ["# gearopt flank topography (ISO transverse deviation along the base tangent, + = material added)",
             f"# profile: {grid.profile} mm", "# face: z mm", "# deviation: um", f"# side: {grid.side}",
             f"# member: {grid.member}",
             f"{grid.profile}\\z," + ",".join(repr(float(v)) for v in grid.z)]
    for s, row in zip(grid.s, grid.deviation):
        lines.append(repr(float(s)) + "," + ",".join(f"{1000 * v:.6f}" for v in row))
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write("\n".join(lines) + "\n")
        os.chmod(tmp, 0o644)  # mkstemp creates 0600: give the file the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def read_grid_csv(path: str | os.PathLike, side: str | None = None) -> FlankGrid:
    """Read a grid written by :func:`write_grid_csv` (or by hand / a measuring machine in that
    format). ``side``: the flank if the file does not say it.

    Raises
    ------
    ArgumentError
        Naming the file and the line / row / column: a missing or unknown key or unit, a ragged
        row, a cell that is not a number (or NaN), positions that are not strictly increasing,
        fewer than 4 positions on an axis.
    """
    path = Path(path)
    name = path.name

    def fail(where, value, valid, what=""):
        return ArgumentError(f"{name}: {where} = {shorten(repr(value))}: {what or 'is out of range'}; valid: {valid}.",
                             param=f"{name}: {where}", value=value, valid=valid)

    try:
        raw = path.read_bytes()
    except OSError as e:
        raise ArgumentError(f"{name}: cannot read the topography file ({e.strerror}).", param="file", value=str(path),
                            valid="a readable CSV file") from None
    valid_text = "a gearopt topography CSV (UTF-8 text, docs/microgeometry.md)"
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise ArgumentError(f"{name}: not a text file (a NUL byte at byte {nul}: a binary file, e.g. a zip "
                            f"or a spreadsheet, renamed .csv?); valid: {valid_text}.", param="file", value=name,
                            valid=valid_text)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ArgumentError(f"{name}: not UTF-8 text ({e.reason} at byte {e.start}: a binary file, e.g. a zip or a "
                            f"spreadsheet, renamed .csv?); valid: {valid_text}.", param="file", value=name,
                            valid=valid_text) from None
    meta, rows = {}, []
    for ln, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            body = s[1:].strip()
            if ":" in body:
                k, _, v = body.partition(":")
                k = k.strip()
                if k in _KEYS:
                    meta[k] = v.strip()
                elif " " not in k:
                    raise fail(f"line {ln} key", k, ", ".join(_KEYS), "is not a key of the format")
            continue
        rows.append((ln, [c.strip() for c in s.split(",")]))
    for k, valid in (("profile", "'L_y mm' or 'd_y mm'"), ("face", "'z mm'"), ("deviation", "'um' or 'mm'")):
        if k not in meta:
            raise fail(f"# {k}", None, valid, "is missing (units must be stated)")
    prof = meta["profile"].split()
    if len(prof) != 2 or prof[0] not in PROFILES or prof[1] != "mm":
        raise fail("# profile", meta["profile"], "'L_y mm' (roll length) or 'd_y mm' (diameter)")
    if meta["face"].split() != ["z", "mm"]:
        raise fail("# face", meta["face"], "'z mm' (axial position)")
    unit = meta["deviation"]
    if unit not in _UNITS:
        raise fail("# deviation", unit, "'um' or 'mm'", "is not a known unit")
    sd = meta.get("side") or side
    if sd not in SIDES:
        raise fail("# side", sd, "'right' or 'left'", "is missing or out of range")
    if len(rows) < 2:
        raise fail("rows", len(rows), "a header row and at least 4 profile rows", "too few rows")
    ln, head = rows[0]
    if not head or not head[0].startswith(prof[0]):
        raise fail(f"line {ln} column 0", head[0] if head else "", f"'{prof[0]}\\z' (the header row)")

    def num(cell, where):
        try:
            v = float(cell)
        except ValueError:
            raise fail(where, cell, "a number", "is not a number") from None
        if not math.isfinite(v):
            raise fail(where, cell, "a finite number", "is not finite")
        return v

    z = [num(c, f"line {ln} column {j + 1} (face position)") for j, c in enumerate(head[1:])]
    s, V = [], []
    for i, (ln, cells) in enumerate(rows[1:]):
        if len(cells) != len(head):
            raise fail(f"line {ln} (row {i})", f"{len(cells)} cells", f"{len(head)} cells like the header",
                       "is ragged")
        s.append(num(cells[0], f"line {ln} (row {i}) column 0 (profile position)"))
        V.append([num(c, f"line {ln} (row {i}) column {j + 1}") * _UNITS[unit] for j, c in enumerate(cells[1:])])
    for axis, vals, what in (("z", z, "face positions (header)"), ("s", s, "profile positions (column 0)")):
        if len(vals) < 4:
            raise fail(what, len(vals), "at least 4 (cubic spline)", "too few points")
        for k in range(1, len(vals)):
            if not vals[k] > vals[k - 1]:
                where = f"column {k + 1} of the header" if axis == "z" else f"row {k} column 0"
                raise fail(where, vals[k], f"> {vals[k - 1]:g} (strictly increasing {what})",
                           "is not increasing")
    return FlankGrid(side=sd, profile=prof[0], s=tuple(s), z=tuple(z), deviation=tuple(map(tuple, V)),
                     member=meta.get("member", ""), source=name)
