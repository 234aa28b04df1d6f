"""Tangents of the loaded TCA with respect to micro-geometry amounts (docs/dynamics.md section 7):
the derivatives of the loaded approach, the mesh stiffness ``W / delta`` and the unloaded and loaded
TE at every position, by implicit differentiation of the loaded contact solution at its converged
active set.

At a position the loaded slices ``L`` (``F_i > 0``) and the approach ``delta`` solve
(:mod:`gearopt.ltca.engine`)

    r_i = s_i + sum_j Cs_ij F_j + H(F_i / l_i, R_i) - lam_i delta = 0   (i in L)
    sum_i lam_i F_i - W = 0                                                             (1)

with the separations ``s_i = (te_0 - te_i) L2_i``, the Hertz approach ``H(f, R) = c(f, R) f`` of
Weber & Banaschek (:func:`gearopt.contact.hertz.weber_compliance`) and the reduced radius ``R_i``.
The amounts ``theta`` move the slices' TE ``te_i`` and the flanks' curvature across the contact line
``1 / R_i``: their derivatives come from the slice equations ``G(w, prm) = 0`` of
:class:`~gearopt.ltca.slices.SliceSolver` by the implicit-function theorem,
``dw/dtheta = -G_w^-1 G_theta`` (CasADi AD of the same graphs the slices are solved with). With the
Jacobians of (1) by CasADi AD, ``d(F_L, delta)/dtheta = -r_x^-1 r_theta``. Held (their derivatives are
not taken): the compliance ``Cs`` and the Hertz depths at the slices' points, the slices' levers and
widths, the crossing fractions of partner slices and the TE zero ``phi2_ref`` (a constant of the cycle:
it shifts the TE, not the stiffness). Where the linearised active set would change within a small
step the derivative holds only on one side: :attr:`LoadedTangent.margin_um` says how far each
position is from that.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import casadi as ca
import numpy as np

from ..contact.hertz import weber_compliance
from ..errors import OptionError, out_of_range
from .engine import F_MIN_SHARE, LTCA
from .loaded_result import LoadedResult
from .validity import check_torque_range, check_validity

if TYPE_CHECKING:
    from ..gears import GearPair
    from ..meshing.misalignment import Misalignment
    from ..settings import LTCASettings
    from .compliance import Material
    from .slices import SliceSet

UM = 1e-3  #: mm per um: the tangents are given per um of amount
TIE_TOL = 1e-11  #: [rad] slices whose TE is this close to the unloaded TE tie for it
FD_STEP = 1e-3  #: step [mm of amount] of the compliance model's difference along the points' tangent


@dataclass(frozen=True)
class LoadedTangent:
    """The loaded TCA at one torque over ``phi1`` and its tangents per um of each amount.

    Attributes
    ----------
    names : the amounts, ``"pinion.C_alpha_a"`` ... (fields of :class:`~gearopt.geometry.microgeometry.Microgeometry`).
    result : LoadedResult
        The loaded TCA of the design (the engine's own solve).
    slices : SliceSet
    d_te_unloaded, d_te_loaded : (N, P) arrays
        Derivatives of the unloaded and loaded TE [rad per um of amount] (the TE zero held).
    d_delta : (N, P) array
        Derivative of the loaded approach [mm per um].
    d_stiffness : (N, P) array
        Derivative of the secant mesh stiffness ``W / delta`` [N/um per um].
    margin_um : (N, P) array
        Per position and amount, the smallest change [um] of that amount alone at which the linearised
        solution changes its active set (a loaded slice's force reaches zero, an open slice's gap
        closes, another slice takes over the unloaded TE; 0 at a kink of the unloaded TE,
        ``te0_kink``): a finite difference larger than this straddles a kink.
    te0_at_crossing : (N,) bool
        The unloaded TE of the position is that of a contact line's crossing of a flank boundary with
        no partner slice: its derivative is the inside slice's (approximate).
    te0_kink : (N, P) bool
        Several slices tie for the unloaded TE and the amount moves them apart (e.g. a profile slope on a
        spur pair in double contact, both pairs conjugate): the unloaded TE, and with it the secant
        stiffness ``W / delta`` and the excitation ``e``, have a kink there (their sum ``e + W / k``, the
        loaded TE, has none). The tangents hold the central difference's value (the mean of both
        sides) and ``margin_um`` is 0.
    """

    names: tuple[str, ...]
    result: LoadedResult
    slices: SliceSet
    d_te_unloaded: np.ndarray
    d_te_loaded: np.ndarray
    d_delta: np.ndarray
    d_stiffness: np.ndarray
    margin_um: np.ndarray
    te0_at_crossing: np.ndarray
    te0_kink: np.ndarray


def amount_names(pair: GearPair) -> list[str]:
    """Every micro-geometry amount of ``pair`` a tangent can be taken in: ``"<member>.<amount>"`` with
    the amounts of :attr:`Microgeometry.theta_names` of each member (the global ones, and the
    reliefs that have a start given)."""
    from ..geometry.microgeometry import Microgeometry

    return [f"{m}.{a}" for m in ("pinion", "gear")
            for a in (getattr(pair, m).modifications or Microgeometry()).theta_names]


def _slice_sensitivity(ltca: LTCA, kind: int, idx: list[int]) -> ca.Function:
    """``(w, prm) -> (dte [rad/mm], dk [1/mm per mm], dl1, dl2 [mm per mm])`` of one slice of ``kind``
    (0 flank, 1/2 a tip edge): ``dw/dprm = -G_w^-1 G_prm`` on the slice equations; the TE ``w_3 / r_p2``,
    the relative curvature ``kappa1 + kappa2`` (zero on a tip edge, whose Hertz radius is held) and the
    force's levers about both axes (``SliceSet.lever1/2``) totally differentiated along the solution."""
    slicer = ltca.slicer
    G = slicer.G if kind == 0 else slicer.edge_branch[kind].G
    w = ca.SX.sym("w", 4)
    prm = ca.SX.sym("prm", ltca.tca.layout.size)
    F = G(w, prm)
    dw = -ca.solve(ca.jacobian(F, w), ca.jacobian(F, prm)[:, idx])
    r_p2 = ltca.pair.gear.r_p
    geo = dict(zip(slicer.geometry.name_out(), slicer.geometry(w, prm)))

    def total(v):  # d/dprm + d/dw dw/dprm along the solution of the slice equations
        return (ca.mtimes(ca.jacobian(v, w), dw) + ca.jacobian(v, prm)[:, idx]).T

    tag = "_e1" if kind == 1 else ""
    outs = [dw[3, :].T / r_p2, total(geo["kappa1"] + geo["kappa2"]) if kind == 0 else ca.DM.zeros(len(idx)),
            total(geo[f"lever1{tag}"]), total(geo[f"lever2{tag}"])]
    # the points and force directions in each member's own frame (the compliance's input), (3 P) each
    nc1 = geo["nc1_e1"] if kind == 1 else geo["n1"]
    nc2 = geo["nc2_e1"] if kind == 1 else (geo["nc2"] if kind == 2 else geo["n2"])
    outs += [ca.vec(total(v)) for v in (geo["r1"], nc1, geo["r2"], nc2)]
    return ca.Function(f"ltca_tangent_{kind}", [w, prm], outs, ["w", "prm"],
                       ["dte", "dk", "dl1", "dl2", "dr1", "dn1", "dr2", "dn2"])


def _contact_jacobians(n: int, material: Material) -> ca.Function:
    """The residual (1) of ``n`` loaded slices and its Jacobians by AD: inputs ``x = (F, delta)``,
    ``p = (s, R, lam, h1, h2)`` (``lam`` the levers about the pinion axis over ``r_b1 cos(beta_b)``,
    ``h1``, ``h2`` Weber's depths) and ``Cs`` (n, n), ``l`` (contact lengths), ``W``,
    ``f_min``; outputs ``r_x`` (n+1, n+1) and ``r_p`` (n+1, 5n), ``p = (s, R, lam, h1, h2)``."""
    x, p = ca.SX.sym("x", n + 1), ca.SX.sym("p", 5 * n)
    Cs = ca.SX.sym("Cs", n, n)
    l = ca.SX.sym("l", n)
    W, f_min = ca.SX.sym("W"), ca.SX.sym("f_min")
    F, delta, s, R, lam, h1, h2 = x[:n], x[n], p[:n], p[n:2 * n], p[2 * n:3 * n], p[3 * n:4 * n], p[4 * n:]
    f = F / l
    c = weber_compliance(f, R, h1, h2, material.E, material.nu, material.E_star, f_min, smoothing="max")
    r = ca.vertcat(s + ca.mtimes(Cs, F) + c * f - lam * delta, ca.dot(lam, F) - W)
    return ca.Function("ltca_contact_jac", [x, p, Cs, l, W, f_min],
                       [ca.jacobian(r, x), ca.jacobian(r, p)])


def loaded_tangents(pair: GearPair, torque: float, amounts: Sequence[str], settings: LTCASettings | None = None,
                    positions: int = 64, material: Material | None = None,
                    misalignment: Misalignment | None = None) -> LoadedTangent:
    """Loaded TCA of ``pair`` at pinion torque ``torque`` [N m] over one mesh cycle of ``positions``
    and its tangents with respect to the micro-geometry ``amounts`` (module docstring).

    Parameters
    ----------
    amounts : sequence of str
        ``"<member>.<amount>"``, e.g. ``"pinion.C_alpha_a"`` (:func:`amount_names`).

    Raises
    ------
    OptionError
        Naming ``amounts`` for an unknown name, ``torque`` where no loaded TCA is possible.
    """
    from ..geometry.microgeometry import modified_tooth
    from ..meshing.tca import TCA
    from ..settings import LTCASettings as Settings

    names = tuple(str(a) for a in amounts)
    valid = amount_names(pair)
    if not names:
        raise out_of_range("amounts", list(names), f"one or more of {valid}", cls=OptionError)
    for a in names:
        if a not in valid:
            raise out_of_range("amounts", a, f"one of {valid} (a relief's amount needs its start, e.g. d_Ca)",
                               cls=OptionError)
    LTCA.validate_torques(torque)
    s = Settings.of(settings)
    # the amounts as parameters of the teeth (zero ISO terms composed where a member has none)
    tca = TCA(pair, side=s.side, pinion=modified_tooth(pair, "pinion", force_iso=True),
              gear=modified_tooth(pair, "gear", force_iso=True))
    L = LTCA(pair, s, material=material, tca=tca)
    check_torque_range(pair, torque, L.material)
    sw = L.solve(float(torque), phi1=L.mesh_cycle(positions), mis=misalignment)
    r = sw.results[0]
    check_validity(r, pair, L.material)
    S, st = sw.slices, sw.structure
    lay = tca.layout
    idx = [lay.index(f"{m}.iso.{a}") for m, a in (n.split(".", 1) for n in names)]
    P = len(idx)
    K, N, M = S.z.shape
    g1, g2 = pair.pinion, pair.gear
    z1 = g1.z
    p1, p2 = np.array(tca.pinion.p0, float), np.array(tca.gear.p0, float)
    from ..meshing.misalignment import Misalignment as Mis

    mis = misalignment or Mis()
    # slice tangents: dte (K, N, M, P) [rad/mm] and the relative curvature's dk [1/mm per mm]
    dte = np.zeros((K, N, M, P))
    dk = np.zeros((K, N, M, P))
    dl1 = np.zeros((K, N, M, P))
    dl2 = np.zeros((K, N, M, P))
    dpts = np.zeros((4, K, N, M, 3, P))  # d(r1, nc1, r2, nc2)/dtheta
    phis = S.phi1[None, :] - 2 * math.pi * np.array(S.pairs)[:, None] / z1
    kinds = np.zeros((K, N, M), int) if S.edge is None else S.edge
    for kind in (0, 1, 2):
        sel = S.active & (kinds == kind) & np.all(np.isfinite(S.w), axis=-1)
        if not sel.any():
            continue
        kk, nn, mm = np.nonzero(sel)
        prm = tca.prm(phis[kk, nn], p1, p2, mis)
        prm[lay.index("z_section"), :] = S.z[kk, nn, mm]
        f = _slice_sensitivity(L, kind, idx).map(kk.size)
        out = [np.asarray(v).T for v in f(S.w[kk, nn, mm].T, prm)]
        dte[kk, nn, mm], dk[kk, nn, mm], dl1[kk, nn, mm], dl2[kk, nn, mm] = out[:4]
        for i, v in enumerate(out[4:]):  # (cols, 3 P): vec of (P, 3), column-major -> (cols, 3, P)
            dpts[i, kk, nn, mm] = v.reshape(-1, 3, P)
    # a partner's TE is interpolated to the crossing (SliceSet.partner_t, held): so is its tangent
    te_own = dte.copy()
    if S.partner_of is not None:
        kk, nn, mm = np.nonzero(S.partner_of >= 0)
        ii, tt = S.partner_of[kk, nn, mm], S.partner_t[kk, nn, mm][:, None]
        dte[kk, nn, mm] = te_own[kk, nn, ii] + tt * (te_own[kk, nn, mm] - te_own[kk, nn, ii])
    # the unloaded TE: the largest TE of the slices on the flanks, or of a crossing (a partner's TE). Where
    # several slices tie for it (two pairs of conjugate flanks touching at once) the unloaded TE has a
    # kink in the amounts: the central difference's value, (largest + smallest tangent) / 2, and flagged
    te0 = S.te_unloaded
    inside = S.active if S.inside is None else S.inside
    cand = np.where(S.active & np.isfinite(S.te), S.te, -np.inf)
    dte0 = np.zeros((N, P))
    at_crossing = np.zeros(N, bool)
    kink = np.zeros((N, P), bool)
    te0_margin = np.full((N, P), np.inf)
    for n in range(N):
        tie = cand[:, n, :] >= te0[n] - TIE_TOL
        if not tie.any():  # a crossing without a partner: the inside neighbour's
            at_crossing[n] = True
            ins = np.where(inside[:, n, :] & np.isfinite(S.te[:, n, :]), S.te[:, n, :], -np.inf)
            tie = ins >= ins.max() - TIE_TOL
        D = dte[:, n][tie]  # (ties, P)
        hi, lo = D.max(axis=0), D.min(axis=0)
        dte0[n] = 0.5 * (hi + lo)
        kink[n] = (hi - lo) > 1e-9 * np.maximum(np.abs(D).max(axis=0), 1e-300)
        # another slice overtakes the unloaded TE after a change of (te0 - te) / (its tangent - te0's) [um]
        other = np.isfinite(cand[:, n, :]) & ~tie
        if other.any():
            gap = (te0[n] - cand[:, n, :][other])[:, None]
            rate = np.maximum(dte[:, n][other] - dte0[n], -(dte[:, n][other] - dte0[n])) * UM
            with np.errstate(divide="ignore"):
                te0_margin[n] = np.where(rate > 0, gap / rate, np.inf).min(axis=0)

    # the compliance and the Hertz depths move with the slices' points: their derivative along the
    # points' tangent (central difference of the compliance model, LTCA.structure, step FD_STEP mm of amount)
    dCs = np.zeros((P,) + st.Cs.shape)
    dh = np.zeros((2, P, N, K * M))
    if L.influence is None:
        from dataclasses import replace

        for j in range(P):
            sts = []
            for sg in (1.0, -1.0):
                move = {nm: getattr(S, nm) + sg * FD_STEP * dpts[i, ..., j]
                        for i, nm in enumerate(("r1", "nc1", "r2", "nc2")) if getattr(S, nm) is not None}
                if S.nc1 is None:
                    move["n1"], move["n2"] = move.pop("nc1"), move.pop("nc2")
                sts.append(L.structure(replace(S, **move)))
            dCs[j] = (sts[0].Cs - sts[1].Cs) / (2 * FD_STEP)
            hp, hm = sts[0].by_position(), sts[1].by_position()
            dh[0, j] = (hp.h1 - hm.h1) / (2 * FD_STEP)
            dh[1, j] = (hp.h2 - hm.h2) / (2 * FD_STEP)
    # the contact solution's tangents, position by position
    cb = L.cos_bb
    W = r.W
    lever = g2.r_b * cb
    act = S.active
    lev2 = np.full(S.z.shape, lever) if S.lever2 is None else np.where(act & np.isfinite(S.lever2), S.lever2, lever)
    lam = (np.ones(S.z.shape) if S.lever1 is None
           else np.where(act & np.isfinite(S.lever1), S.lever1 / (g1.r_b * cb), 1.0))
    use_k = (act & (kinds == 0))
    if S.kappa1 is not None and L.curvature == "surface":
        use_k &= np.isfinite(S.kappa1) & np.isfinite(S.kappa2)
    else:
        use_k &= False
    flat = lambda a: np.moveaxis(a, 1, 0).reshape((N, K * M) + a.shape[3:])  # noqa: E731
    s_f = flat(np.where(act, (te0[None, :, None] - S.te) * lev2, 0.0))
    # s = (te0 - te) L2 (engine): both factors move; lam = L1 / (r_b1 cos(beta_b))
    has_l = act & (np.isfinite(S.lever1) & np.isfinite(S.lever2) if S.lever1 is not None else False)
    gap0 = np.where(act, te0[None, :, None] - S.te, 0.0)[..., None]
    ds_f = flat(np.where(act[..., None], (dte0[None, :, None, :] - dte) * lev2[..., None]
                         + np.where(has_l[..., None], gap0 * dl2, 0.0), 0.0))
    dlam_f = flat(np.where(has_l[..., None], dl1 / (g1.r_b * cb), 0.0))
    dR_f = flat(np.where(use_k[..., None], -(st.R**2)[..., None] * dk, 0.0))
    lam_f, act_f, F_f = flat(lam), flat(act), flat(r.load)
    hz = st.by_position()
    f_min = F_MIN_SHARE * W * cb / g1.b
    d_delta = np.zeros((N, P))
    margin = np.full((N, P), np.inf)
    jac: dict[int, ca.Function] = {}
    for n in range(N):
        Ld = np.flatnonzero(act_f[n] & (F_f[n] > 1e-9 * W))
        nl = Ld.size
        if nl not in jac:
            jac[nl] = _contact_jacobians(nl, L.material)
        x = np.r_[F_f[n, Ld], r.delta[n]]
        p = np.r_[s_f[n, Ld], hz.R[n, Ld], lam_f[n, Ld], hz.h1[n, Ld], hz.h2[n, Ld]]
        rx, rp = (np.array(v) for v in jac[nl](x, p, st.Cs[n][np.ix_(Ld, Ld)], hz.length[n, Ld], W, f_min))
        dp = np.vstack([ds_f[n, Ld], dR_f[n, Ld], dlam_f[n, Ld], dh[0, :, n, Ld], dh[1, :, n, Ld]])  # (5 nl, P)
        rhs = rp @ dp
        rhs[:nl] += np.einsum("pij,j->ip", dCs[:, n][:, Ld][:, :, Ld], F_f[n, Ld])
        dx = -np.linalg.solve(rx, rhs)  # (nl + 1, P) per mm
        d_delta[n] = dx[nl]
        # the active set's margin: a loaded force reaching zero, an open gap closing (per um)
        dF = dx[:nl] * UM
        with np.errstate(divide="ignore", invalid="ignore"):
            h_on = np.where(np.abs(dF) > 0, F_f[n, Ld, None] / np.abs(dF), np.inf)
            off = np.flatnonzero(act_f[n] & ~(F_f[n] > 1e-9 * W))
            if off.size:
                Fn = F_f[n]
                gap = s_f[n, off] + st.Cs[n][off] @ Fn - lam_f[n, off] * r.delta[n]
                dgap = (ds_f[n, off] + st.Cs[n][np.ix_(off, Ld)] @ dx[:nl] - np.outer(lam_f[n, off], dx[nl])
                        - dlam_f[n, off] * r.delta[n] + np.einsum("pij,j->ip", dCs[:, n][:, off][:, :, Ld],
                                                                  F_f[n, Ld])) * UM
                h_off = np.where(np.abs(dgap) > 0, np.maximum(gap, 0.0)[:, None] / np.abs(dgap), np.inf)
            else:
                h_off = np.full((1, P), np.inf)
        margin[n] = np.minimum(h_on.min(axis=0) if nl else np.inf, h_off.min(axis=0))
    d_delta *= UM
    margin = np.where(kink, 0.0, np.minimum(margin, te0_margin))
    dte0 *= UM
    d_te_loaded = dte0 - d_delta / lever
    d_stiffness = -W / r.delta[:, None] ** 2 * d_delta / 1e3
    return LoadedTangent(names=names, result=r, slices=S, d_te_unloaded=dte0, d_te_loaded=d_te_loaded,
                         d_delta=d_delta, d_stiffness=d_stiffness, margin_um=margin, te0_at_crossing=at_crossing,
                         te0_kink=kink)
