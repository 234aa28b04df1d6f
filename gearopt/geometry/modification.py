"""Flank modifications: a normal deviation field added to a generated flank (docs/architecture.md
"Flank modifications").

A member's flank is its generated surface ``r(u, z; p)`` (Litvin's generation settings
``x, a_c, u_0, a_pl`` stay what they are) plus a deviation ``delta(u, z; theta)`` [mm] along the unit
outward normal ``n``:

    r'(u, z) = r(u, z) + delta(u, z, r, theta) n(u, z)

``delta`` is a CasADi expression of the surface coordinates with its own named symbolic parameters
``theta``; it may use the unmodified point ``r`` (3,) [mm] in the gear frame (radius, roll distance)
so shop-term modifications can be written in the terms a gear drawing uses. The modified normal is
recomputed from the tangents of ``r'``: ``n' = s c / |c|`` with ``c = r'_u x r'_z`` (AD) and the
orientation ``s = sign(c . n)`` that keeps ``n'`` continuous with the generated (tool) normal ``n``:
on the valid branch of a flank ``s`` is constant, so the signed regularity ``(r'_u x r'_z) . n'``
changes sign past a fold exactly as the generated surface's does (``GeneratedTooth.flank_limit``).

The composition is done once, in :meth:`GeneratedTooth.with_modification
<gearopt.geometry.generation.GeneratedTooth.with_modification>`: the surface Functions keep their
names, inputs ``(u, z, p)`` and outputs ``(r, n, psi[, phi_h])``, and ``p`` grows by the theta
entries (``GeneratedTooth.param_names`` ends with ``"<name>.<theta>"``). Every consumer (TCA,
edge contact, FE meshes) sees the modified flank through those Functions without any change.

Building blocks (to show that the hook is general; ISO micro-geometry comes on top of them):
:func:`constant_offset`, :func:`polynomial` (linear / parabolic in u and z), :func:`topography`
(a measured grid of deviations, interpolated by a smooth cubic B-spline).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable, TYPE_CHECKING

import casadi as ca
import numpy as np

from ..errors import ArgumentError, shorten

if TYPE_CHECKING:
    from ..types import ArrayLike, Expr

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
SIDES = ("right", "left")
NEWTON_STEPS = 2  #: Newton steps for the foot point's section zeta (see :func:`compose`)


@dataclass(frozen=True)
class FlankModification:
    """A normal deviation field ``delta(u, z, r, theta)`` [mm] added to a generated flank.

    Parameters
    ----------
    name : str
        Identifier (letters, digits, ``_``); the theta entries are called ``"<name>.<theta>"`` in
        the member's parameter vector.
    theta : tuple of (str, float, str)
        The symbolic parameters: (name, default value, unit) each, e.g. ``("c", 0.01, "mm")``.
        May be empty (a fixed deviation, e.g. a measured topography).
    delta : callable
        ``delta(u, z, r, theta) -> scalar`` [mm], CasADi-generic: ``u`` [mm] the flank coordinate
        (along the tool flank from the datum line towards the root), ``z`` [mm] the axial position
        of the modified point, ``r`` (3,) the unmodified (foot) point in the gear frame [mm] whose
        offset lands in the section ``z``, ``theta`` (k,) the parameters in the
        order of ``theta``. Positive: material added (along the outward normal). Must be built
        from CasADi operations only (``ca.sqrt``, ``ca.interpolant(..., "bspline", ...)``, ...;
        not ``math``/``numpy`` functions, which cannot take symbols) and be smooth where it is used.
    sides : tuple of str
        Flanks it applies to: ``("right", "left")`` (default), ``("right",)`` or ``("left",)``.
    """

    name: str
    theta: tuple = ()
    delta: Callable = field(default=None, repr=False)
    sides: tuple = SIDES

    def __post_init__(self):
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ArgumentError(f"modification.name = {shorten(repr(self.name))}: expected an identifier (letters, "
                                "digits, '_', not starting with a digit), e.g. 'lead'.")
        where = f"modification {self.name!r}"
        try:
            entries = tuple(tuple(t) for t in self.theta)
        except TypeError:
            raise ArgumentError(f"{where}: theta = {shorten(repr(self.theta))}: expected a sequence of "
                                "(name, default, unit) triples.") from None
        seen = set()
        for k, t in enumerate(entries):
            if len(t) != 3:
                raise ArgumentError(f"{where}: theta[{k}] = {shorten(repr(t))}: expected a (name, default, unit) "
                                    "triple, e.g. ('c', 0.01, 'mm').")
            nm, val, unit = t
            if not isinstance(nm, str) or not _NAME.match(nm):
                raise ArgumentError(f"{where}: theta[{k}] name = {shorten(repr(nm))}: expected an identifier.")
            if nm in seen:
                raise ArgumentError(f"{where}: theta name {nm!r} appears twice; every parameter needs its own name.")
            seen.add(nm)
            if isinstance(val, bool) or not isinstance(val, (int, float, np.integer, np.floating)) \
                    or not math.isfinite(val):
                raise ArgumentError(f"{where}: theta {nm!r} default = {shorten(repr(val))}: expected a finite "
                                    f"number [{unit}].")
            if not isinstance(unit, str):
                raise ArgumentError(f"{where}: theta {nm!r} unit = {shorten(repr(unit))}: expected a string "
                                    "such as 'mm', '1/mm', 'rad' or '-'.")
        object.__setattr__(self, "theta", tuple((nm, float(v), u) for nm, v, u in entries))
        if isinstance(self.sides, str) or not isinstance(self.sides, (tuple, list)) or not self.sides \
                or any(s not in SIDES for s in self.sides) or len(set(self.sides)) != len(self.sides):
            raise ArgumentError(f"{where}: sides = {shorten(repr(self.sides))} is out of range; valid: "
                                "('right', 'left'), ('right',) or ('left',).")
        object.__setattr__(self, "sides", tuple(self.sides))
        if not callable(self.delta):
            raise ArgumentError(f"{where}: delta = {type(self.delta).__name__} {shorten(repr(self.delta))}: expected "
                                "a callable delta(u, z, r, theta) -> CasADi scalar [mm].")
        args = (ca.SX.sym("u"), ca.SX.sym("z"), ca.SX.sym("r", 3), ca.SX.sym("theta", len(self.theta)))
        self._check_graph(self.expression(*args), args)

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names as they appear in the member's ``param_names``: ``"<name>.<theta>"``."""
        return tuple(f"{self.name}.{t[0]}" for t in self.theta)

    @property
    def defaults(self) -> np.ndarray:
        """Default values of theta (k,)."""
        return np.array([t[1] for t in self.theta], dtype=float)

    @property
    def units(self) -> dict[str, str]:
        """Unit of each theta entry, by its full name."""
        return {f"{self.name}.{t[0]}": t[2] for t in self.theta}

    def _check_graph(self, d, args) -> None:
        """The graph of ``delta`` on pure symbols: only its own arguments, no non-finite constants."""
        where = f"modification {self.name!r}: delta"
        u, z, r, theta = args
        d = ca.SX(d)
        # math.sin(SX) and friends silently give float('nan') (CasADi's float() of a symbol):
        # a non-finite constant in the graph means delta was not written with CasADi operations.
        fd = ca.Function("delta_check", [u, z, r, theta], [d], {"allow_free": True})
        consts = [fd.instruction_constant(k) for k in range(fd.n_instructions()) if fd.instruction_id(k) == ca.OP_CONST]
        if any(not math.isfinite(v) for v in consts):
            raise ArgumentError(f"{where}(u, z, r, theta) contains a non-finite constant on CasADi symbols: it uses "
                                "math or numpy functions (math.sin of a symbol gives nan); write it with CasADi "
                                "operations (ca.sin, ca.sqrt, ca.interpolant(..., 'bspline', ...)).")
        free = ca.symvar(d)
        allowed = set()
        for a in (u, z, r, theta):
            allowed.update(v.name() for v in ca.symvar(a))
        stray = [v.name() for v in free if v.name() not in allowed]
        if stray:
            raise ArgumentError(f"{where} depends on symbols {stray} that are not its arguments (u, z, r, theta): "
                                "declare every parameter in theta.")

    def expression(self, u: Expr, z: Expr, r: Expr, theta: Expr) -> ca.SX:
        """``delta`` evaluated on CasADi SX arguments, checked: a 1x1 SX expression [mm].

        Raises
        ------
        ArgumentError
            If ``delta`` fails on symbolic arguments (numpy/math functions, wrong arity) or does
            not return a scalar.
        """
        where = f"modification {self.name!r}: delta"
        try:
            d = self.delta(u, z, r, theta)
        except Exception as e:  # noqa: BLE001 - any failure on symbols: not CasADi-generic
            raise ArgumentError(f"{where}(u, z, r, theta) failed on CasADi symbols ({type(e).__name__}: "
                                f"{shorten(str(e), 160)}); delta must be written with CasADi operations "
                                "(ca.sqrt, ca.cos, ca.interpolant(..., 'bspline', ...)), not math or numpy "
                                "functions.") from None
        if isinstance(d, (int, float, np.integer, np.floating)) and not isinstance(d, bool):
            d = ca.SX(float(d))
        if isinstance(d, ca.DM):
            d = ca.SX(d)
        if not isinstance(d, ca.SX):
            raise ArgumentError(f"{where} returned {type(d).__name__} {shorten(repr(d))}: expected a CasADi "
                                "scalar expression [mm] (SX).")
        if d.shape != (1, 1):
            raise ArgumentError(f"{where} returned shape {d.shape}: expected a scalar deviation [mm].")
        return d


def compose(f: ca.Function, mod: FlankModification, n_p: int) -> ca.Function:
    """The surface Function ``f`` ``(q, z, p) -> (r, n, psi, ...)`` with ``mod`` composed:
    ``(q, z, p') -> (r + delta n, n', psi, ...)`` where ``p' = (p, theta)`` and ``n'`` is the unit
    normal of the modified surface oriented like ``n`` (module docstring). ``r``, ``n``, ``psi`` and
    ``delta`` are taken at the foot point ``(q, zeta)`` whose modified point lies in the section
    ``z`` (so ``z`` stays the axial coordinate, as every consumer assumes: face ends, face width);
    ``delta`` gets that section ``z`` and the foot point ``r``.
    Names of inputs and outputs are preserved; ``n_p`` is the length of ``p`` (``f``'s own
    parameter count)."""
    q, z = ca.SX.sym(f.name_in(0)), ca.SX.sym(f.name_in(1))
    k = len(mod.theta)
    P = ca.SX.sym("p", n_p + k)
    p, theta = P[:n_p], P[n_p:]
    # Keep z the axial position: the point of the modified surface with coordinates (u, z) is
    # r(u, zeta) + delta(u, z) n(u, zeta) with zeta (the foot point's section) such that its axial
    # coordinate is z: zeta + delta n_z = z (a helical flank's normal has an axial component). delta
    # is taken in the section z of the modified point (what a measuring machine reports there), with
    # the foot point r(u, zeta). NEWTON_STEPS Newton steps from zeta = z (|delta n_z| is microns and
    # its slope along zeta tiny: the first step leaves ~1e-11 mm, the second round-off; with
    # delta n_z = 0, e.g. spur, zeta = z).
    zs = ca.SX.sym("zeta")
    o_s = f.call([q, zs, p])
    g_s = zs + mod.expression(q, z, o_s[0], theta) * o_s[1][2] - z
    step = ca.Function("zeta_step", [q, zs, z, P], [g_s / ca.jacobian(g_s, zs)])
    zeta = z
    for _ in range(NEWTON_STEPS):
        zeta = zeta - step(q, zeta, z, P)
    outs = f.call([q, zeta, p])
    r, n = outs[0], outs[1]
    d = mod.expression(q, z, r, theta)
    r_m = r + d * n
    c = ca.cross(ca.jacobian(r_m, q), ca.jacobian(r_m, z))
    # orientation: +-1, constant on each branch of the flank (changes only across a fold, where the
    # normal is undefined anyway); its derivative is zero, so AD sees the smooth unit normal.
    n_m = c * ca.sign(ca.dot(c, n)) / ca.norm_2(c)
    return ca.Function(f.name(), [q, z, P], [r_m, n_m] + list(outs[2:]), f.name_in(), f.name_out())


def extend(f: ca.Function, k: int, p_index: int) -> ca.Function:
    """``f`` with its parameter input (number ``p_index``) grown by ``k`` trailing entries that it
    ignores (the fillet, the tool family and the junction of a modified tooth take the full p)."""
    ins = [ca.SX.sym(f.name_in(i), f.size_in(i)) for i in range(f.n_in())]
    n_p = f.size1_in(p_index)
    P = ca.SX.sym("p", n_p + k)
    args = list(ins)
    args[p_index] = P[:n_p]
    outs = f.call(args)
    ins[p_index] = P
    return ca.Function(f.name(), ins, outs, f.name_in(), f.name_out())


# ---------------------------------------------------------------------------------------------
# Building blocks
# ---------------------------------------------------------------------------------------------
def _check_value(where, name, v, unit):
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v):
        raise ArgumentError(f"{where}: {name} = {shorten(repr(v))}: expected a finite number [{unit}].")
    return float(v)


def constant_offset(c: float = 0.0, name: str = "offset", sides: tuple[str, ...] = SIDES) -> FlankModification:
    """Constant normal offset ``delta = c`` [mm] (positive: material added), theta ``c`` [mm].

    The offset of an involute helicoid along its normal is the same helicoid turned by
    ``c / (r_b cos beta_b)`` about the axis."""
    c = _check_value("constant_offset", "c", c, "mm")
    return FlankModification(name, (("c", c, "mm"),), lambda u, z, r, th: th[0], sides)


def polynomial(c0: float = 0.0, c_u: float = 0.0, c_z: float = 0.0, c_uu: float = 0.0, c_zz: float = 0.0,
               u_ref: float = 0.0, z_ref: float = 0.0, name: str = "poly",
               sides: tuple[str, ...] = SIDES) -> FlankModification:
    """Deviation quadratic in the flank coordinates:
    ``delta = c0 + c_u (u - u_ref) + c_z (z - z_ref) + c_uu (u - u_ref)^2 + c_zz (z - z_ref)^2`` [mm].

    ``c_z`` [mm/mm] is a lead slope (helix angle deviation), ``c_zz`` [1/mm] a parabolic lead
    crowning (``-c_zz (b/2)^2`` at the face ends), ``c_u``, ``c_uu`` a profile slope and crowning
    along the tool flank coordinate u. theta = (c0, c_u, c_z, c_uu, c_zz); ``u_ref``, ``z_ref`` [mm]
    are fixed."""
    where = "polynomial"
    vals = [_check_value(where, k, v, unit) for k, v, unit in
            (("c0", c0, "mm"), ("c_u", c_u, "mm/mm"), ("c_z", c_z, "mm/mm"), ("c_uu", c_uu, "1/mm"),
             ("c_zz", c_zz, "1/mm"))]
    u_ref = _check_value(where, "u_ref", u_ref, "mm")
    z_ref = _check_value(where, "z_ref", z_ref, "mm")

    def delta(u, z, r, th):
        du, dz = u - u_ref, z - z_ref
        return th[0] + th[1] * du + th[2] * dz + th[3] * du**2 + th[4] * dz**2

    theta = tuple(zip(("c0", "c_u", "c_z", "c_uu", "c_zz"), vals, ("mm", "mm/mm", "mm/mm", "1/mm", "1/mm")))
    return FlankModification(name, theta, delta, sides)


def topography(s_grid: ArrayLike, z_grid: ArrayLike, values: ArrayLike, along: str = "u", name: str = "topo",
               parametric: bool = False, sides: tuple[str, ...] = SIDES) -> FlankModification:
    """A measured flank topography: deviations on a grid, interpolated by the tensor-product cubic
    spline of ``ca.interpolant(..., "bspline", ...)`` (C2, exact at the grid points, differentiable
    by AD in the coordinates and, with ``parametric``, in the grid values).

    Parameters
    ----------
    s_grid : (m,) array
        Profile coordinate of the grid, strictly increasing: the flank coordinate ``u`` [mm]
        (``along = "u"``) or the transverse radius [mm] (``along = "radius"``).
    z_grid : (k,) array
        Axial positions [mm], strictly increasing.
    values : (m, k) array
        Deviations [mm] (positive: material added), ``values[i, j]`` at ``(s_grid[i], z_grid[j])``.
    along : {"u", "radius"}
    parametric : bool
        If True the grid values are the theta parameters ``"<name>.v<i>_<j>"`` [mm] (defaults
        ``values``), so TCA results can be differentiated with respect to each of them; otherwise
        they are fixed (no theta).

    Outside the grid the deviation at the nearest grid edge is held (continuous, but its slope jumps
    at the edge): let the grid cover the active flank.
    """
    where = "topography"
    if along not in ("u", "radius"):
        raise ArgumentError(f"{where}: along = {shorten(repr(along))} is out of range; valid: 'u' (flank coordinate) "
                            "or 'radius' (transverse radius).")
    grids = []
    for nm, gr in (("s_grid", s_grid), ("z_grid", z_grid)):
        try:
            a = np.asarray(gr, dtype=float)
        except (TypeError, ValueError):
            raise ArgumentError(f"{where}: {nm} = {shorten(repr(gr))}: expected a 1-D array of numbers [mm].") from None
        if a.ndim != 1 or a.size < 4:
            raise ArgumentError(f"{where}: {nm} has shape {a.shape}: expected a 1-D array of at least 4 points "
                                "(cubic B-spline).")
        if not np.all(np.isfinite(a)) or not np.all(np.diff(a) > 0):
            raise ArgumentError(f"{where}: {nm} = {shorten(str(a.tolist()))}: expected finite, strictly increasing "
                                "values [mm].")
        grids.append(a)
    try:
        V = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(f"{where}: values = {shorten(repr(values))}: expected an (m, k) array of deviations "
                            "[mm].") from None
    shape = (grids[0].size, grids[1].size)
    if V.shape != shape:
        raise ArgumentError(f"{where}: values has shape {V.shape}: expected {shape} (len(s_grid), len(z_grid)).")
    if not np.all(np.isfinite(V)):
        i, j = np.argwhere(~np.isfinite(V))[0]
        raise ArgumentError(f"{where}: values[{i}, {j}] = {V[i, j]}: every deviation must be finite [mm].")
    spline = grid_spline(name, grids[0], grids[1])
    if parametric:
        theta = tuple((f"v{i}_{j}", float(V[i, j]), "mm") for j in range(shape[1]) for i in range(shape[0]))
    else:
        theta = ()

    def delta(u, z, r, th):
        s = u if along == "u" else ca.sqrt(r[0] ** 2 + r[1] ** 2)
        Vm = ca.reshape(th, shape[0], shape[1]) if parametric else V  # column-major: v_ij at i + m j
        return spline(s, z, Vm)

    return FlankModification(name, theta, delta, sides)


def grid_spline(name: str, s_grid: ArrayLike, z_grid: ArrayLike,
                extrapolate: str = "hold") -> Callable[[Expr, Expr, Any], Expr]:
    """The tensor-product interpolating cubic spline of a grid, as a CasADi-generic callable
    ``spline(s, z, V) -> scalar`` with ``V`` (m, k) the values (numpy or a CasADi matrix: symbols
    allowed). Outside the grid (CasADi's B-spline is zero there): ``extrapolate = "hold"`` holds the
    edge values (continuous, the slope jumps at the edge), ``"linear"`` continues along the edge
    tangent (C1 across the edge: ``f(s_c) + f'(s_c) (s - s_c)`` with ``s_c`` the nearest grid value,
    in each coordinate).

    The spline is linear in the data and separable: ``f(s, z) = A(s)^T V B(z)`` with ``A_i``, ``B_j``
    the 1-D cardinal splines of each grid (the spline through the unit vector e_i), from
    ``ca.interpolant(..., "bspline", ...)``. Written so, it is differentiable in V by AD (CasADi's
    parametric interpolant gives zero derivatives with respect to its data)."""
    if extrapolate not in ("hold", "linear"):
        raise ArgumentError(f"grid_spline: extrapolate = {shorten(repr(extrapolate))} is out of range; valid: 'hold' "
                            "or 'linear'.", param="extrapolate", value=extrapolate, valid="'hold' or 'linear'")
    s_grid = np.asarray(s_grid, dtype=float)
    z_grid = np.asarray(z_grid, dtype=float)

    def cardinals(tag, gr):
        # one interpolant with gr.size outputs: output i is the spline through e_i (values are
        # ordered grid point first, output fastest)
        f = ca.interpolant(f"{name}_{tag}", "bspline", [gr.tolist()], np.eye(gr.size).ravel().tolist())
        x = ca.SX.sym("x")
        return f, ca.Function(f"{name}_{tag}_d", [x], [ca.jacobian(f(x), x)])

    (A_f, dA_f), (B_f, dB_f) = cardinals("s", s_grid), cardinals("z", z_grid)
    direct = {}  # fixed numeric values: one 2-D interpolant of the data (the same spline, far cheaper)

    def spline(s, z, V):
        s_c = ca.fmin(ca.fmax(s, float(s_grid[0])), float(s_grid[-1]))
        z_c = ca.fmin(ca.fmax(z, float(z_grid[0])), float(z_grid[-1]))
        if isinstance(V, np.ndarray):
            key = V.tobytes()
            if key not in direct:
                f = ca.interpolant(f"{name}_2d", "bspline", [s_grid.tolist(), z_grid.tolist()],
                                   np.asarray(V, dtype=float).ravel(order="F").tolist())
                x = ca.SX.sym("x", 2)
                g = ca.jacobian(f(x), x)
                direct[key] = (f, ca.Function(f"{name}_2d_d", [x], [g, ca.jacobian(g[0], x)[1]]))
            f, df = direct[key]
            x_c = ca.vertcat(s_c, z_c)
            out = f(x_c)
            if extrapolate == "linear":  # the tensor product of the 1-D tangent lines, as below
                g, f_sz = df(x_c)
                ds, dz = s - s_c, z - z_c
                out = out + g[0] * ds + g[1] * dz + f_sz * ds * dz
            return out
        A, B = A_f(s_c), B_f(z_c)
        if extrapolate == "linear":
            A = A + dA_f(s_c) * (s - s_c)
            B = B + dB_f(z_c) * (z - z_c)
        return ca.mtimes([A.T, V, B])

    return spline

