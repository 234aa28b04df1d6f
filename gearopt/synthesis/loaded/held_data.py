"""The data the loaded NLP holds at its linearisation, to first order in the design and the
misalignment (docs/loaded_synthesis.md section 6.3), for the KKT sensitivities
(:meth:`~gearopt.synthesis.loaded.sensitivity.Sensitivities.kkt_sensitivities`).

The NLP sees the design and a misalignment through the separations, the relative curvature and the
edge weights (linear in both, :mod:`.linearise`); the compliance of every slice node (each part: the
teeth, each member's body; with FE influence coefficients the dense blocks), the Hertz depths ``h1``,
``h2``, the levers ``lam`` and their separation correction ``da`` it holds at the linearisation. They
are functions of the slices' contact points, force directions, levers and TE (:meth:`gearopt.ltca
.engine.LTCA.structure`, :meth:`~gearopt.synthesis.loaded.linearise.Lineariser.linearise`), and the
points move along the profile with the centre distance (and with the design). Here the motion of every
active slice's point, line of action, gear section, levers and TE in each design amount and
misalignment kind is the total derivative along the solution of its slice equations (flank or tip
edge: the implicit function theorem, by CasADi AD of the slice geometry ``LTCA.slices`` evaluates),
and the held data move with it through the same functions that compute them (``LTCA.structure``
and the levers' correction, evaluated at the points moved by ``+-eps`` along that tangent: a central
directional difference of smooth numpy functions; no derivative written by hand). So do the
separations' sensitivities ``J``, ``Jm``, ``Jr``, ``Jk`` the NLP's separations, edge weights and
curvatures are linear in about the linearisation (:func:`moved_gradients`: the function that computes
them, at the slice's unknowns moved along the tangent and the column moved; their motion is the
separations' second derivative, which the Lagrangian's gradient takes in through the contact
multipliers; docs/loaded_synthesis.md section 6.4). The NLP is then
built around the linearisation with those data, and its constraint rows, the gradient of its
Lagrangian and the Lagrangian differenced at the solution (:func:`held_derivatives`).

Held as before: the contact lengths and the face coupling (the slices are fixed to the tooth) and a tip
edge's Hertz radius (the edge rounding's). The contact width of a flank slice beside a tip-edge slice
(``SliceSet.width``, split at the zero of the tip margin) moves with the points and is held too: with
the edges kept open those slices carry no load (docs/loaded_synthesis.md section 6.3).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ... import compiled

if TYPE_CHECKING:
    from .linearise import Lineariser, Linearisation
    from .nlp import LoadedNLP


#: the largest motion of a contact point [mm] of the central directional difference through
#: ``LTCA.structure`` (its data are smooth in the points: the tooth integrals are interpolated on a
#: 600-point table, whose knots lie 0.01 mm apart, so a step well below that stays on one piece)
POINT_STEP = 1e-5


def point_tangent_function(lr: Lineariser, kind: int) -> ca.Function:
    """``(w, prm) -> (dr1, dr2, dn1, dn2, dz2, dl1, dl2, dte)`` of a slice of ``kind`` (0: flank, 1/2:
    the pinion's / gear's tip edge): the total derivatives of its point on the pinion and on the gear
    (own frames) [mm per unit], of the force's line of action in each member's frame (``SliceSet.nc1``,
    ``nc2``) [1 per unit], of the gear section ``z2`` [mm per unit], of the force's levers about the
    pinion and the gear axis (``SliceSet.lever1``, ``lever2``) [mm per unit] and of its TE [rad per
    unit], (3 or 1, P + Q) each, in the design amounts and misalignment kinds of the optimiser's
    parameter columns (the implicit function theorem on the slice equations, CasADi AD, as
    ``LTCA.slices`` evaluates the geometry). ``lr``: the optimiser (a
    :class:`~gearopt.synthesis.loaded.linearise.Lineariser`)."""
    cache = lr.__dict__.setdefault("_held_tangent", {})
    if kind not in cache:
        slicer = lr.ltca.slicer
        t = lr.slice_tangent(kind)
        geo = dict(zip(slicer.geometry.name_out(), slicer.geometry(t.w, t.prm)))
        tag = "_e1" if kind == 1 else ""
        # the line of action as LTCA.slices picks it per kind (the flank's normal, or at a tip edge the
        # mating flank's)
        nc1 = geo["nc1_e1"] if kind == 1 else geo["n1"]
        nc2 = geo["nc2_e1"] if kind == 1 else (geo["nc2"] if kind == 2 else geo["n2"])
        outs = [t.total(v) for v in (geo["r1"], geo["r2"], nc1, nc2)]
        outs.append(t.dw[2, :])
        outs += [t.total(v) for v in (geo[f"lever1{tag}"], geo[f"lever2{tag}"])]
        outs.append(t.dw[3, :] / lr.pair.gear.r_p)
        outs.append(t.dw)
        cache[kind] = lr.keyed_by_construction(
            ca.Function(f"ltca_point_tangent_{kind}", [t.w, t.prm], outs, ["w", "prm"],
                        ["dr1", "dr2", "dn1", "dn2", "dz2", "dl1", "dl2", "dte", "dw"]), kind, point_tangent_function)
    return cache[kind]


def point_tangent_columns(lr: Lineariser, kind: int, n: int) -> compiled.ColumnMap:
    """:func:`point_tangent_function` of slice kind ``kind`` on ``n`` columns, as
    :meth:`~gearopt.synthesis.loaded.linearise.Lineariser.sensitivity_columns`: with ``lr.jit`` the
    compiled library from the disk cache (``jit="auto"``: on a cache miss it compiles in the background
    while these columns run interpreted; the AD graph interpreted took 0.8 s of the sensitivities of
    problems/microgeometry_loaded.toml, compiled milliseconds)."""
    maps = lr.__dict__.setdefault("_held_tangent_maps", {})
    cm = maps.get(kind)
    if cm is not None and cm.compiled:
        return cm
    if cm is None and kind not in lr.__dict__.get("_held_tangent", {}):
        # the library in the cache: the AD graph is not built (0.15-0.26 s per kind)
        cm = lr.cached_construction(f"ltca_point_tangent_{kind}", kind, point_tangent_function)
        if cm is not None:
            maps[kind] = cm
            return cm
    f = point_tangent_function(lr, kind)
    if cm is None or (not cm.compiled and lr.jit and compiled.cached_function(f) is not None):
        cm = maps[kind] = compiled.mapped(f, n, jit="auto" if lr.jit else False)
    return cm


#: the tangents of :func:`point_tangents` and their rows (3: a vector, 1: a number)
TANGENTS = (("r1", 3), ("r2", 3), ("n1", 3), ("n2", 3), ("z2", 1), ("lever1", 1), ("lever2", 1), ("te", 1),
            ("w", 4))


def point_tangents(lr: Lineariser, theta: np.ndarray, lin: list[Linearisation]) -> list[dict]:
    """Per case of ``lin`` (the :class:`~gearopt.synthesis.loaded.linearise.Linearisation` of the design
    ``theta`` [mm]): the tangents of :func:`point_tangent_function` at every active slice, as arrays
    ``r1``, ``r2``, ``n1``, ``n2`` (K, N, M, 3, P + Q) and ``z2``, ``lever1``, ``lever2``, ``te``
    (K, N, M, P + Q); zero at the inactive slices."""
    import math

    p1, p2 = lr.params(theta)
    z1 = lr.pair.pinion.z
    nq = len(lr._prm_index)
    out = []
    for L in lin:
        S = L.slices
        K, N, M = S.z.shape
        tg = {k: np.zeros((K, N, M, r, nq) if r > 1 else (K, N, M, nq)) for k, r in TANGENTS}
        tg["prm"] = np.full((K, N, M, lr.tca.layout.size), np.nan)
        kinds = np.zeros((K, N, M), int) if S.edge is None else S.edge
        phis = S.phi1[None, :] - 2 * math.pi * np.array(S.pairs)[:, None] / z1
        for kind in (0, 1, 2):
            sel = S.active & (kinds == kind)
            if not sel.any():
                continue
            kk, nn, mm = np.nonzero(sel)
            prm = lr.tca.prm(phis[kk, nn], p1, p2, L.mis)
            prm[lr.tca.layout.index("z_section"), :] = S.z[kk, nn, mm]
            wv = S.w[kk, nn, mm].T
            n = wv.shape[1]
            vals = point_tangent_columns(lr, kind, n)(wv, prm)
            for (key, r), v in zip(TANGENTS, vals):
                # (r, n * nq): the columns of each slice side by side
                v = v.reshape(r, n, nq).transpose(1, 0, 2)
                tg[key][kk, nn, mm] = v if r > 1 else v[:, 0, :]
            tg["prm"][kk, nn, mm] = prm.T
        out.append(tg)
    return out


def moved(lr: Lineariser, L: Linearisation, tg: dict, col: int, step: float,
          gradients: tuple | None = None) -> Linearisation:
    """The linearisation ``L`` with the data the NLP holds at it (``LTCA.structure`` of its slices, the
    levers ``lam`` and their separation correction ``da``, :meth:`~gearopt.synthesis.loaded.linearise
    .Lineariser.linearise`) of every active slice's point, line of action, gear section, levers and TE
    moved by ``step`` times its tangent ``tg`` (:func:`point_tangents`) in column ``col``; with
    ``gradients`` (``(J, Jm, Jr, Jk)`` of :func:`moved_gradients` at the same motion) the separations'
    sensitivities too."""
    S = L.slices

    def mv(v, t):
        return None if v is None else v + step * np.nan_to_num(t[..., col])

    S2 = dataclasses.replace(
        S, r1=mv(S.r1, tg["r1"]), r2=mv(S.r2, tg["r2"]), z2=mv(S.z2, tg["z2"]),
        n1=S.n1 if S.nc1 is not None else mv(S.n1, tg["n1"]), n2=S.n2 if S.nc2 is not None else mv(S.n2, tg["n2"]),
        nc1=mv(S.nc1, tg["n1"]), nc2=mv(S.nc2, tg["n2"]), te=mv(S.te, tg["te"]),
        lever1=mv(S.lever1, tg["lever1"]), lever2=mv(S.lever2, tg["lever2"]))
    st = lr.ltca.structure(S2)
    # the levers and the separation's correction for them as Lineariser.linearise computes them
    lever = lr.pair.gear.r_b * lr.ltca.cos_bb
    lam, lev2 = lr._levers(S2)
    te0 = S2.te_unloaded[None, :, None]
    te0 = np.where(np.isfinite(te0), te0, 0.0)
    da = np.where(S.active, -(S2.te - te0) * (lev2 - lever) - te0 * (lam - 1.0) * lever, 0.0)
    if gradients is None:
        return dataclasses.replace(L, structure=st, lam=lam, da=da)
    J, Jm, Jr, Jk = gradients
    return dataclasses.replace(L, structure=st, lam=lam, da=da, J=J, Jm=Jm, Jr=Jr, Jk=Jk)


def moved_gradients(lr: Lineariser, L: Linearisation, tg: dict, motions: list[tuple[int, float]]) -> list[tuple]:
    """The separations' sensitivities of ``L`` (``J``, ``Jm``, ``Jr``, ``Jk`` of :class:`~gearopt.synthesis
    .loaded.linearise.Linearisation`) with every active slice moved along the solution of its slice
    equations by ``step`` in column ``col``, for each ``(col, step)`` of ``motions``: the slice's unknowns
    ``w`` by ``step`` times their tangent ``tg["w"]`` (:func:`point_tangents`) and the column's own
    parameter by ``step``, evaluated by the function that computes them at the linearisation
    (:meth:`~gearopt.synthesis.loaded.linearise.Lineariser._sensitivity`, all motions in one call per slice
    kind). They are the separations' first derivatives, so their motion is the separations' second
    derivative in the design and the misalignment (a relief's ``J`` is its shape at the point, which
    moves along the profile), which the Lagrangian's gradient in the design takes in through the
    contact multipliers. A partner slice's is interpolated to its crossing and a curvature's held where
    the slice has none, as :meth:`~gearopt.synthesis.loaded.linearise.Lineariser.linearise` does."""
    S = L.slices
    K, N, M = S.z.shape
    nq, P, nm = len(lr._prm_index), len(lr.free), len(motions)
    J = np.zeros((nm, K, N, M, nq))
    Jr = np.zeros((nm, K, N, M, 2, nq))
    Jk = np.zeros((nm, K, N, M, nq))
    kinds = np.zeros((K, N, M), int) if S.edge is None else S.edge
    for kind in (0, 1, 2):
        sel = S.active & (kinds == kind)
        if not sel.any():
            continue
        kk, nn, mm = np.nonzero(sel)
        w0, prm0, dw = S.w[kk, nn, mm], tg["prm"][kk, nn, mm], tg["w"][kk, nn, mm]
        ws, prms = [], []
        for col, step in motions:
            ws.append(w0 + step * dw[..., col])
            prm = prm0.copy()
            prm[:, lr._prm_index[col]] += step
            prms.append(prm)
        dJ, dJr, dJk = lr.separation_gradients(kind, np.concatenate(ws).T, np.concatenate(prms).T)
        J[:, kk, nn, mm] = dJ.reshape(nm, kk.size, -1)
        Jr[:, kk, nn, mm] = dJr.reshape(nm, kk.size, 2, -1)
        Jk[:, kk, nn, mm] = dJk.reshape(nm, kk.size, -1)
    if S.partner_of is not None:
        kk, nn, mm = np.nonzero(S.partner_of >= 0)
        ii, tt = S.partner_of[kk, nn, mm], S.partner_t[kk, nn, mm][:, None]
        J[:, kk, nn, mm] = J[:, kk, nn, ii] + tt * (J[:, kk, nn, mm] - J[:, kk, nn, ii])
    if S.kappa1 is None:
        Jk[:] = 0.0
    else:
        Jk = np.where((S.active & np.isfinite(S.kappa1) & np.isfinite(S.kappa2))[..., None], Jk, 0.0)
    return [(J[i, ..., :P], J[i, ..., P:], Jr[i], Jk[i]) for i in range(nm)]


def held_derivatives(lr: Lineariser, theta: np.ndarray, lin: list[Linearisation], nlp: LoadedNLP,
                     build: Callable[[list[Linearisation]], LoadedNLP], z: np.ndarray, p: np.ndarray,
                     lam: np.ndarray, columns: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The derivatives of the NLP's constraint rows, of the gradient of its Lagrangian in the unknowns
    and of the Lagrangian, at the solution ``z`` with multipliers ``lam`` and parameters ``p``, through
    the held data's motion with each of ``columns`` (indices into the design and misalignment
    columns of ``lr._prm_index``).

    Parameters
    ----------
    lr : Lineariser
        The optimiser.
    theta : (P,) array
        The linearisation's design [mm].
    lin : list of Linearisation
        Its linearisation, one per case.
    nlp : LoadedNLP
        The NLP built around ``lin`` (its layout is the one compared against).
    build : callable
        ``lin -> LoadedNLP``: the NLP built around another linearisation as ``nlp`` was.
    z, p, lam : arrays
        The solution, the parameters and the constraints' multipliers.
    columns : list of int
        The columns differentiated in.

    Returns
    -------
    dg : (m, len(columns)) array
        The constraint rows' derivatives [row unit per unit].
    dgz : (n, len(columns)) array
        The derivatives of the Lagrangian's gradient in the unknowns.
    dL : (len(columns),) array
        The Lagrangian's derivatives.
    """
    tgs = point_tangents(lr, theta, lin)
    m, n = nlp.lbg.size, z.size
    dg, dgz, dL = np.zeros((m, len(columns))), np.zeros((n, len(columns))), np.zeros(len(columns))
    # the points move by at most POINT_STEP
    big = [max(float(np.max(np.abs(np.nan_to_num(t[k][..., col])))) for t in tgs for k in ("r1", "r2"))
           for col in columns]
    keys = [(col, sgn) for col, b in zip(columns, big) if b > 0.0 for sgn in (1.0, -1.0)]
    motions = [(col, sgn * POINT_STEP / b) for col, b in zip(columns, big) if b > 0.0 for sgn in (1.0, -1.0)]
    grads = [dict(zip(keys, moved_gradients(lr, L, t, motions))) for L, t in zip(lin, tgs)]
    for j, col in enumerate(columns):
        if big[j] == 0.0:
            continue
        eps = POINT_STEP / big[j]
        vals = []
        for sgn in (1.0, -1.0):
            other = build([moved(lr, L, t, col, sgn * eps, g[(col, sgn)]) for L, t, g in zip(lin, tgs, grads)])
            if other.lbg.size != m or other.layout.unknowns.size != n:
                raise RuntimeError("held data: the NLP built with the moved data has another layout")
            pr = other.problem
            lm = ca.MX.sym("lam", m)
            Lg = pr["f"] + ca.dot(lm, pr["g"])
            fun = ca.Function("held", [pr["x"], pr["p"], lm], [pr["g"], ca.gradient(Lg, pr["x"]), Lg])
            vals.append([np.asarray(v).ravel() for v in fun(z, p, lam)])
        (gp, zp, lp), (gm, zm, lm_) = vals
        dg[:, j], dgz[:, j], dL[j] = (gp - gm) / (2 * eps), (zp - zm) / (2 * eps), float((lp - lm_)[0]) / (2 * eps)
    return dg, dgz, dL
