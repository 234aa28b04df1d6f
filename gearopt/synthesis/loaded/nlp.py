"""Assembly of the duty-cycle NLP around a linearisation (docs/loaded_synthesis.md section 2): the
loads, gaps, approaches and deflections of every (torque, case, position), the smoothed contact
conditions, the pressure and edge-loading rows with their slacks, the objective (peak-to-peak or
harmonics) and the unloaded-TE target's blocks (:class:`NLPBuilder`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ...ltca.compliance import coupling_stiffness_batch
from ...ltca.engine import F_MIN_SHARE
from ...contact.hertz import weber_compliance
from ...meshing.misalignment import Misalignment
from ...units import RAD_TO_ARCSEC
from .constants import G_REF, HARM_EPS, KAPPA_FLOOR, MU, SMOOTH_STAGE_OPTS, TE0_EPS
from .derivatives import ipopt_derivatives
from .edges import edge_weight_lin
from .layout import Block, NLPLayout, Te0Block, Te0Slices, block_vector, nlp_layout, param_layout
from .verify import harmonic_rows

#: IPOPT's ``mumps_mem_percent`` for the loaded NLP: MUMPS's workspace over its estimate [%] (:meth:`NLPBuilder._nlp`)
MUMPS_MEM_PERCENT = 50
#: the complementarity's smoothing of the first stage of a first round (:meth:`NLPBuilder._solve_smoothed`)
MU_START = 1e-5
#: the most slices across the face (``n_slices``) at which the NLP takes the analytical compliance as dense
#: blocks over each block's held loads (as FE coefficients) instead of deflection unknowns tied to the loads by
#: the face coupling's tridiagonal stiffness form (:meth:`NLPBuilder._nlp`): a block's loads are coupled
#: with each other anyway (its balance row and its approach), so the dense blocks add little fill, and the KKT
#: system loses the deflection unknowns and their rows: ``problems/microgeometry_loaded.toml``'s first NLP,
#: IPOPT's CPU per iteration dense / stiffness form 22.5 / 44 ms with 11 slices, 82 / 127 ms with 21, 209 / 379 ms
#: with 31 (docs/loaded_synthesis.md section 2; more slices not measured)
DENSE_SLICES_MAX = 31


class NLPBuilder:
    """The duty-cycle NLP around a linearisation."""

    def _nlp(self, lin, theta_k, keep=None, radius: float = np.inf) -> LoadedNLP:
        """Build the duty-cycle NLP around the linearisation ``lin`` (module docstring).

        The compliance ``LTCA.structure``'s ``Cs`` (FE influence coefficients, or the analytical compliance
        with the pairs' coupling through the bodies, :mod:`gearopt.ltca.neighbours`) enters the gaps as dense
        blocks over each block's held loads, so that the NLP's compliance is the analysis's. With the
        analytical compliance and more than ``DENSE_SLICES_MAX`` slices across the face, the deflections ``w``
        [um] of every slice node are unknowns instead, tied to the loads by the sparse stiffness form of the face
        coupling (``A (w / D) = cos^2(beta_b) D F``, A tridiagonal, docs/ltca.md section 2), and only the blocks
        between the pairs stay dense."""
        g1 = self.pair.pinion
        cb = self.ltca.cos_bb
        lever = self.pair.gear.r_b * cb
        mat = self.material
        T, C = self.torques.size, len(self.cases)
        P = len(self.free)
        Wt = self.torques * 1e3 / (g1.r_b * cb)
        # deflection unknowns (the stiffness form) only for many slices across the face (DENSE_SLICES_MAX)
        sparse = self.ltca.compliance == "analytical" and lin[0].slices.z.shape[2] > DENSE_SLICES_MAX
        trip_C = ([], [], [])  # dense compliance (Cs; the stiffness form: between pairs): gap rows x loads [mm/N]
        trip_A = ([], [], [])  # stiffness rows x deflection columns
        trip_D = ([], [], [])  # stiffness rows x load-share columns
        w_of_x = []  # per compliance part, the deflection unknown of each slice (sparse path)
        w_part = []  # the compliance part of each deflection unknown
        w_keys = []  # (torque, case, position, flat slice index) of each deflection unknown
        a0, Jx, Jmx, ln, Rx, h1x, h2x, edge, tix, blk, keys, tipe = [], [], [], [], [], [], [], [], [], [], [], []
        lamx = []  # each slice's lever about the pinion axis over r_b1 cos(beta_b)
        Jkx = []  # the sensitivity of each slice's relative curvature 1 / R* (design, misalignment)
        egx, near = [], []  # the edge weight's gradient (design, misalignment) and the rows it may reach
        blocks = []  # Block(torque, case, position, first x, count)
        nx = nw = 0
        for c, L in enumerate(lin):
            S, st = L.slices, L.structure
            K, N, M = S.z.shape
            acts = [np.transpose(S.active if keep is None else keep[c][t], (1, 0, 2)).reshape(N, K * M)
                    for t in range(T)]
            flat = lambda v: np.transpose(v, (1, 0, 2)).reshape(N, K * M)  # noqa: E731
            a_n, l_n, R_n, h1_n, h2_n = (flat(v) for v in (L.a, st.length, st.R, st.h1, st.h2))
            lam_n = flat(L.lam)
            a_n = a_n + flat(L.da)
            J_n = np.transpose(L.J, (1, 0, 2, 3)).reshape(N, K * M, P)
            Jm_n = np.transpose(L.Jm, (1, 0, 2, 3)).reshape(N, K * M, -1)
            Jk_n = np.transpose(L.Jk, (1, 0, 2, 3)).reshape(N, K * M, -1)
            e0, eg = edge_weight_lin(S, self.pair, L.Jr)
            e_n = flat(e0)
            eg_n = np.transpose(eg, (1, 0, 2, 3)).reshape(N, K * M, -1)
            # a flank slice joins the edge rows when the band can reach it within the radius
            span = np.minimum(2.0 * radius, self.hi - self.lo) if np.isfinite(radius) else self.hi - self.lo
            reach_n = np.sum(np.abs(eg_n[..., :P]) * span, axis=-1)
            tp_n = flat(np.zeros(S.z.shape, bool) if S.edge is None else S.edge > 0)
            if sparse:
                # each part of the compliance (the teeth, each member's body) coupled across the face over its
                # own length (LTCA.structure's parts, compliance.face_matrix_batch), one deflection unknown
                # per part and slice node: the gap takes their sum
                wt = S.width if S.width_tooth is None else S.width_tooth
                coup = [(coupling_stiffness_batch(S.z.reshape(K * N, M), wt.reshape(K * N, M),
                                                  p.coupling_length).reshape(K, N, M, M), np.sqrt(p.compliance))
                        for p in st.parts]
                # the pairs' coupling through the bodies (LTCA.structure's off-diagonal blocks, the analysis's
                # gearopt.ltca.neighbours term): dense between the held loads of different pairs
                Cx = st.Cs.reshape(N, K, M, K, M).copy()
                Cx[:, np.arange(K), :, np.arange(K), :] = 0.0
                Cx = Cx.reshape(N, K * M, K * M)
            for t in range(T):
                act = acts[t]
                for n in range(N):
                    A = np.flatnonzero(act[n])
                    cnt = A.size
                    pos = np.full(K * M, -1)  # the load unknown of each flat slice (-1: not held)
                    pos[A] = nx + np.arange(cnt)
                    if sparse:
                        for part, (Acoup, Dn) in enumerate(coup):
                            wi = np.full(cnt, -1)
                            for k in range(K):
                                U = np.flatnonzero(np.isfinite(S.z[k, n]))
                                qU = pos[k * M + U]
                                held = qU >= 0
                                if not held.any():
                                    continue
                                Ak = Acoup[k, n][np.ix_(U, U)]
                                Dk = Dn[k, n, U]
                                rows = nw + np.arange(U.size)
                                w_keys.append(np.stack([np.full(U.size, t), np.full(U.size, c), np.full(U.size, n),
                                                        k * M + U], axis=1))
                                w_part.append(np.full(U.size, part))
                                ii, jj = np.nonzero(Ak)
                                # row i: sum_j A_ij (D_i / D_j) w_j - cos^2(beta_b) D_i^2 W x_i / G_REF = 0
                                trip_A[0].append(rows[ii])
                                trip_A[1].append(rows[jj])
                                trip_A[2].append(Ak[ii, jj] * Dk[ii] / Dk[jj])
                                q = qU[held]
                                trip_D[0].append(rows[held])
                                trip_D[1].append(q)
                                # (D^2 by pow, as a scalar's ** 2: numpy's array square differs in the last bit)
                                trip_D[2].append(cb**2 * np.array([v**2 for v in Dk[held].tolist()]) * Wt[t] / G_REF)
                                wi[q - nx] = rows[held]
                                nw += U.size
                            if len(w_of_x) <= part:
                                w_of_x.append([])
                            w_of_x[part].append(wi)
                    Cb = (Cx if sparse else st.Cs)[n][np.ix_(A, A)]
                    ii, jj = np.nonzero(Cb)
                    trip_C[0].append(ii + nx)
                    trip_C[1].append(jj + nx)
                    trip_C[2].append(Cb[ii, jj])
                    a0.append(a_n[n, A])
                    lamx.append(lam_n[n, A])
                    Jx.append(J_n[n, A])
                    Jmx.append(Jm_n[n, A])
                    ln.append(l_n[n, A])
                    Rx.append(R_n[n, A])
                    Jkx.append(Jk_n[n, A])
                    h1x.append(h1_n[n, A])
                    h2x.append(h2_n[n, A])
                    edge.append(e_n[n, A])
                    egx.append(eg_n[n, A])
                    near.append(e_n[n, A] + reach_n[n, A] > 0)
                    tipe.append(tp_n[n, A])
                    tix.append(np.full(cnt, t))
                    blk.append(np.full(cnt, len(blocks)))
                    keys.append(np.stack([np.full(cnt, t), np.full(cnt, c), np.full(cnt, n), A], axis=1))
                    blocks.append(Block(t, c, n, nx, cnt))
                    nx += cnt
        a0, Jx, Jmx, ln, Rx, h1x, h2x, lamx, Jkx = (np.concatenate(v) for v in (a0, Jx, Jmx, ln, Rx, h1x, h2x, lamx,
                                                                                  Jkx))
        ew, tix, blk, keys, tipe, egx, near = (np.concatenate(v) for v in (edge, tix, blk, keys, tipe, egx, near))
        edge = near  # rows of the edge-loading constraint; the pressure limit holds on every non-tip-edge slice
        nB = len(blocks)

        def triplet(tr, n_rows, n_cols):
            cat = lambda v: np.concatenate(v).astype(int).tolist() if v else []  # noqa: E731
            return ca.DM.triplet(cat(tr[0]), cat(tr[1]), ca.DM(np.concatenate(tr[2]) if tr[2] else np.zeros(0)),
                                 n_rows, n_cols)

        Ex_t = ca.DM.triplet(list(range(nx)), tix.tolist(), ca.DM.ones(nx), nx, T)  # x -> torque
        Ex_b = ca.DM.triplet(list(range(nx)), blk.tolist(), ca.DM.ones(nx), nx, nB)  # x -> block
        ct = np.array([b.torque * C + b.case for b in blocks])
        Eb_ct = ca.DM.triplet(list(range(nB)), ct.tolist(), ca.DM.ones(nB), nB, T * C)
        # unknowns (scaled, :mod:`.layout`): design [um], loads x [share], gaps y [um], approach d [um], TE
        # bounds, slacks, and (analytical compliance) the deflections w [um] of every slice node
        th = ca.MX.sym("theta_um", P)
        x = ca.MX.sym("x", nx)
        y = ca.MX.sym("y", nx)
        d = ca.MX.sym("d", nB)
        u = ca.MX.sym("te_hi", T * C)
        v = ca.MX.sym("te_lo", T * C)
        sp = ca.MX.sym("slack_p", T * C)
        se = ca.MX.sym("slack_e", T * C)
        w = ca.MX.sym("w", nw)
        plim = ca.MX.sym("p_limit")
        marg = ca.MX.sym("edge_margin_um")
        mu = ca.MX.sym("mu")
        rho = ca.MX.sym("rho")
        # parameters of the sensitivities (:meth:`sensitivities`): each torque's scale (1: the duty
        # cycle's) and a misalignment added to every case (Misalignment.names() order, rad / mm)
        tq = ca.MX.sym("torque_scale", T)
        dm = ca.MX.sym("mis_offset", Jmx.shape[1])
        W = ca.mtimes(Ex_t, ca.DM(Wt) * tq)
        F = x * W
        f = F / ln
        fmin = F_MIN_SHARE * W * cb / g1.b
        # Weber's approach per unit load, the load kept off zero smoothly (the LTCA's max(f, f_min) has no
        # derivative at f_min)
        dth = th * 1e-3 - ca.DM(theta_k)
        # the Hertz data of the default loaded TCA: each flank's own curvature across the contact line, its
        # relative curvature 1 / R* linear in the design and the misalignment offsets about the
        # linearisation (its sensitivity by AD, as the separations'; exact at theta_k), kept positive
        kap = kappa_lin(Rx, Jkx, P, dth, dm)
        cH = weber_compliance(f, 1.0 / kap, h1x, h2x, mat.E, mat.nu, mat.E_star, fmin, smoothing="hypot")
        gap = ((ca.DM(a0) + ca.mtimes(ca.DM(Jx), dth) + ca.mtimes(ca.DM(Jmx), dm) + cH * f) / G_REF
               - ca.DM(lamx) * ca.mtimes(Ex_b, d))
        # the constraint rows by name (:data:`.layout.ROWS`): (expression, lower bound, upper bound)
        g_rows = {}
        if sparse:
            for wi in w_of_x:
                gap = gap + w[np.concatenate(wi).tolist()]
            w_t = np.concatenate(w_keys)[:, 0]
            E_wt = ca.DM.triplet(list(range(nw)), w_t.tolist(), ca.DM.ones(nw), nw, T)  # w row -> torque
            g_rows["stiffness"] = (ca.mtimes(triplet(trip_A, nw, nw), w) - ca.mtimes(triplet(trip_D, nw, nx), x)
                                   * ca.mtimes(E_wt, tq), 0.0, 0.0)
        if trip_C[2] and sum(v.size for v in trip_C[2]):
            # dense compliance: LTCA.structure's Cs, or (the stiffness form) its blocks between pairs
            gap = gap + ca.mtimes(triplet(trip_C, nx, nx), F) / G_REF
        fb = x + y - ca.sqrt(x**2 + y**2 + 2 * mu)  # zero where x >= 0, y >= 0, x y = mu
        te = -d * G_REF / lever * RAD_TO_ARCSEC  # (nB) loaded TE [arcsec] (up to each case's constant)
        g_rows.update(gap=(y - gap, 0.0, 0.0), complementarity=(fb, 0.0, 0.0),
                      balance=(ca.mtimes(Ex_b.T, ca.DM(lamx) * x) - 1.0, 0.0, 0.0),
                      te_hi=(ca.mtimes(Eb_ct, u) - te, 0.0, np.inf), te_lo=(te - ca.mtimes(Eb_ct, v), 0.0, np.inf))
        ct_x = ct[blk]
        flank = np.flatnonzero(~tipe)
        ends = np.flatnonzero(edge)
        if self.p_limit is not None and flank.size:
            # p0^2 = f E* / (pi R*) <= p_limit^2 (gearopt.contact.hertz.hertz_peak_pressure), per flank
            # slice, relative: linear in the load share; 1 / R* moves with the design
            k = mat.E_star / (math.pi * ln[flank])
            E_f = ca.DM.triplet(list(range(flank.size)), ct_x[flank].tolist(), ca.DM.ones(flank.size), flank.size,
                                T * C)
            g_rows["pressure"] = (x[flank.tolist()] * W[flank.tolist()] * ca.DM(k) * kap[flank.tolist()] / plim**2 - 1.0
                                  - ca.mtimes(E_f, sp), -np.inf, 0.0)
        if self.edge_margin is not None and ends.size:
            E_e = ca.DM.triplet(list(range(ends.size)), ct_x[ends].tolist(), ca.DM.ones(ends.size), ends.size, T * C)
            # a gap of at least the margin is, with x y = mu, a load share of at most mu / margin: the
            # constraint is stated in the load (the smoothed complementarity pins the gap of a loaded slice
            # to first order, so a gap bound would leave no direction that opens it)
            # the weight of a flank slice in the tip band moves with its point (linearised; negative:
            # below the band, where the row holds for any load)
            w_e = ca.DM(ew[ends]) + ca.mtimes(ca.DM(egx[ends, :P]), dth) + ca.mtimes(ca.DM(egx[ends, P:]), dm)
            g_rows["edge"] = (w_e * x[ends.tolist()] - mu / marg - ca.mtimes(E_e, se), -np.inf, 0.0)
        te0 = self._te0_blocks(lin, radius, lever) if self.te_level is not None else None
        n0 = nB0 = 0
        x0s, y0s, d0s = (ca.MX.sym(k, 0) for k in ("x0", "y0", "d0"))
        if te0 is not None:
            # the unloaded TE (zero load: no compliance, no Hertz flattening) of the pair centred on each
            # position, by the same smoothed complementarity: its approach d0 is the smallest separation
            # of the pair's slices to O(MU) (a sampled min would not be smooth); appended at the end of the
            # unknowns and rows, so the loaded NLP's indices stay as they are
            n0, nB0 = te0.a.size, len(te0.blocks)
            x0s, y0s, d0s = (ca.MX.sym(k, n) for k, n in (("x0", n0), ("y0", n0), ("d0", nB0)))
            E0 = ca.DM.triplet(list(range(n0)), te0.blk.tolist(), ca.DM.ones(n0), n0, nB0)
            gap0 = ((ca.DM(te0.a) + ca.mtimes(ca.DM(te0.J), dth) + ca.mtimes(ca.DM(te0.Jm), dm)) / G_REF
                    - ca.mtimes(E0, d0s))
            g_rows.update(te0_gap=(y0s - gap0, 0.0, 0.0),
                          te0_complementarity=(x0s + y0s - ca.sqrt(x0s**2 + y0s**2 + 2 * mu), 0.0, 0.0),
                          te0_balance=(ca.mtimes(E0.T, x0s) - 1.0, 0.0, 0.0))
            # misfit of each block's unloaded TE [arcsec] to the case's parabola c0 + c1 psi - level psi^2
            # (Litvin's predesigned function, as synthesis/crowning.py), c0 and c1 by least squares: the
            # residual is the projection of te0 + level psi^2 off the span of (1, psi), one matrix per
            # case (no fit unknowns: free c0, c1 in the NLP let IPOPT diverge along the null direction
            # they share with the approaches); its RMS per case smoothed at 0
            te_b = -d0s * G_REF / lever * RAD_TO_ARCSEC + self.te_level * RAD_TO_ARCSEC * ca.DM(te0.psi) ** 2
            rows, cols, vals = [], [], []
            for c in range(C):
                k = np.flatnonzero(te0.case == c)
                V = np.stack([np.ones(k.size), te0.psi[k]], axis=1)
                Pc = (np.eye(k.size) - V @ np.linalg.pinv(V)) / math.sqrt(k.size)  # residual / sqrt(n)
                ii, jj = np.meshgrid(k, k, indexing="ij")
                rows.append(ii.ravel())
                cols.append(jj.ravel())
                vals.append(Pc.ravel())
            res = ca.mtimes(_sparse_dm(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), nB0, nB0), te_b)
            Ec = ca.DM.triplet(list(range(nB0)), te0.case.tolist(), ca.DM.ones(nB0), nB0, C)
            ms = ca.mtimes(Ec.T, res**2)
            te0_obj = self.te_weight * ca.dot(ca.DM(self.weights.sum(axis=0)), ca.sqrt(ms + TE0_EPS**2))
        wv = ca.DM(self.weights.ravel())  # (T, C) row-major: index t * C + c
        hmap = self._harmonic_map(blocks, nB)
        if hmap is None:
            fit = ca.dot(wv, u - v)
        else:  # weighted amplitudes of the first mesh harmonics (smooth: sqrt(a^2 + b^2 + eps^2))
            ab = ca.mtimes(hmap, te)
            H = self.harmonics.size
            a2 = ab[0::2] ** 2 + ab[1::2] ** 2
            amp_w = ca.DM(np.repeat(self.weights.ravel(), H) * np.tile(self.harmonics, T * C))
            fit = ca.dot(amp_w, ca.sqrt(a2 + HARM_EPS**2))
        mult = ca.DM(self._mult.ravel())  # (T C): cases standing for their mirror images count twice
        obj = fit + rho * self._w_mean * ca.dot(mult, sp + se)
        if te0 is not None:
            obj = obj + te0_obj
        rows = dict(flank=flank if self.p_limit is not None else flank[:0],
                    ends=ends if self.edge_margin is not None else ends[:0])
        layout = nlp_layout(P=P, nx=nx, nB=nB, TC=T * C, nw=nw, n0=n0, nB0=nB0, n_pressure=rows["flank"].size,
                            n_edge=rows["ends"].size, n_torques=T, n_kinds=Jmx.shape[1])
        unknowns = dict(theta=th, x=x, y=y, d=d, te_hi=u, te_lo=v, slack_p=sp, slack_e=se, w=w, x0=x0s, y0=y0s, d0=d0s)
        z = ca.vertcat(*(unknowns[k] for k in layout.unknowns.names))
        present = [k for k in layout.rows.names if k in g_rows]
        assert all(layout.rows.count(k) == 0 for k in layout.rows.names if k not in g_rows)
        lbg = np.concatenate([np.full(layout.rows.count(k), g_rows[k][1]) for k in present])
        ubg = np.concatenate([np.full(layout.rows.count(k), g_rows[k][2]) for k in present])
        params = dict(p_limit=plim, edge_margin=marg, mu=mu, rho=rho, torque_scale=tq, mis_offset=dm)
        nlp = {"x": z, "p": ca.vertcat(*(params[k] for k in layout.params.names)), "f": obj,
               "g": ca.vertcat(*(g_rows[k][0] for k in present))}
        # the start is the exact loaded TCA of the linearisation's design, close to the optimum: IPOPT's
        # adaptive barrier from mu = 0.01 (the target case 647 -> 529 iterations, 10 % faster, than the
        # monotone barrier from 0.01; docs/loaded_synthesis.md section 5). (Without IPOPT's gradient
        # scaling some rounds took 2-6x fewer iterations, but the smallest design derivatives of the
        # sensitivities lost their accuracy.)
        # MUMPS's workspace: 50 % over its analysis's estimate (IPOPT's default 1000 % is fresh memory
        # that every factorisation allocates and the kernel zeroes page by page: 24 % of IPOPT's CPU time
        # on this NLP under load, docs/benchmarks.md "Loaded optimiser"); a factorisation that needs more
        # is repeated by IPOPT with the workspace doubled, so the iterates are the same bit for bit
        opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-9,
                "ipopt.max_iter": 1000, "ipopt.mu_strategy": "adaptive", "ipopt.mu_init": 1e-2, "error_on_fail": False,
                "ipopt.mumps_mem_percent": MUMPS_MEM_PERCENT, **getattr(self, "_extra_opts", {})}
        return LoadedNLP(problem=nlp, opts=opts, phi1=self.phi1.copy(), rows=rows, gap=ca.Function("gap", [z, tq, dm], [gap]), lbg=lbg,
                    ubg=ubg, layout=layout, sizes=layout.sizes(), blocks=blocks, ct=ct, edge=tipe, ew=np.clip(ew, 0.0, 1.0),
                    lever=lever, Wt=Wt,
                    ln=ln, Rx=Rx, Jk=Jkx, theta_k=np.asarray(theta_k, float).copy(), keys=keys, hmap=hmap, w_keys=np.concatenate(w_keys) if w_keys else np.zeros((0, 4), int),
                    w_part=np.concatenate(w_part) if w_part else np.zeros(0, int),
                    te0=te0, te0_term=ca.Function("te0_term", [z], [te0_obj if te0 is not None else ca.MX(0.0)],
                                                  ["z"], ["te0_term"]))

    def _solve_smoothed(self, nlp: LoadedNLP, z0: np.ndarray, lbx: np.ndarray, ubx: np.ndarray,
                        p: list) -> tuple[dict, dict, int]:
        """Solve ``nlp`` from ``z0`` with no earlier multipliers (the first round of an optimisation from
        the drive's own design, :meth:`TrustRegion._trust_region`) in two stages of the complementarity's smoothing ``x y = mu``: first at ``MU_START`` from ``z0``
        (IPOPT's cold start with the monotone barrier, :attr:`LoadedNLP.smoothing_solver`), then at the
        NLP's own ``p`` (``MU``) from that solution and its multipliers (``LOOP_WARM_OPTS``, adaptive
        barrier, :meth:`TrustRegion._warm_solver`); where either stage fails, the cold start at ``p``.
        Returns the solution, IPOPT's stats and the iterations of every stage.

        A cold start at ``MU`` = 1e-8 follows the smoothed kinks of every slice that opens or closes
        on the way (short steps, restorations: 236 iterations on the first round of
        ``microgeometry_loaded``); at ``MU_START`` the kinks are 30x wider and the second stage only
        sharpens them (84 + 30 iterations, the same solution to 1e-12 um; docs/benchmarks.md "Loaded
        optimiser", h4 of 2026-11-29 afternoon). The first stage with the monotone barrier
        (``SMOOTH_STAGE_OPTS``): 63 instead of 94 iterations there, the second stage's solution the same to
        3e-13 um (docs/benchmarks.md, "The first stage monotone")."""
        args = dict(x0=z0, lbx=lbx, ubx=ubx, lbg=nlp.lbg, ubg=nlp.ubg)
        at = param_layout(0, 0)["mu"].start
        q = list(p)
        q[at] = MU_START
        first = nlp.smoothing_solver
        r0 = first(p=q, **args)
        its = int(first.stats()["iter_count"])
        if first.stats()["success"]:
            r = self._warm_solver(nlp)(p=p, lam_x0=r0["lam_x"], lam_g0=r0["lam_g"], **{**args, "x0": r0["x"]})
            st = nlp.warm.stats()
            its += int(st["iter_count"])
            if st["success"]:
                return r, st, its
        r = nlp.solver(p=p, **args)
        st = nlp.solver.stats()
        return r, st, its + int(st["iter_count"])

    def _te0_blocks(self, lin, radius: float, lever: float) -> Te0Slices:
        """The unloaded-TE target's slices in the NLP: per case and position, the active slices of the
        pair centred there (:meth:`_te0_pairs`) that may become its contact within ``radius`` of the
        linearisation (separation lowered by ``2 radius sum_j |J_ij|`` not above the smallest
        separation raised by its own; every active slice without a radius). Arrays ``a`` [mm], ``J``,
        ``Jm`` of the slices; ``blk`` (block of each slice), ``blocks`` (c, n, first, count), ``case``,
        ``psi`` (pair angle over pi/z1) per block, ``keys`` (T, c, n, flat slice) per slice
        (:class:`~gearopt.synthesis.loaded.layout.Te0Slices`)."""
        T = self.torques.size
        out = {k: [] for k in ("a", "J", "Jm", "blk", "case", "psi", "keys")}
        blocks, first = [], 0
        for c, L in enumerate(lin):
            S = L.slices
            K, N, M = S.z.shape
            idx, psi = self._te0_pairs(S)
            reach = 2.0 * radius * np.sum(np.abs(L.J), axis=-1) if np.isfinite(radius) else None
            used = 0
            for n in range(N):
                i = idx[n]
                if i < 0 or not S.active[i, n].any():
                    continue
                m = np.flatnonzero(S.active[i, n])
                if reach is not None:
                    s = (np.max(S.te[i, n, m]) - S.te[i, n, m]) * lever
                    r = reach[i, n, m]
                    m = m[s - r <= np.min(s + r)]
                out["a"].append(L.a[i, n, m])
                out["J"].append(L.J[i, n, m])
                out["Jm"].append(L.Jm[i, n, m])
                out["blk"].append(np.full(m.size, len(blocks)))
                out["keys"].append(np.stack([np.full(m.size, T), np.full(m.size, c), np.full(m.size, n), i * M + m], 1))
                out["case"].append(c)
                out["psi"].append(psi[n])
                blocks.append(Te0Block(c, n, first, m.size))
                first += m.size
                used += 1
            self._te0_enough(used, N, c)
        return Te0Slices(**{k: np.concatenate(v) for k, v in out.items() if k not in ("case", "psi")},
                         case=np.array(out["case"], int), psi=np.array(out["psi"]), blocks=blocks)


    def _harmonic_map(self, blocks, nB):
        """Sparse (T C 2H, nB) map of the blocks' loaded TE to the cosine and sine coefficients of the
        first H mesh harmonics of each (torque, case) (:func:`harmonic_rows`); None for the
        peak-to-peak objective."""
        if self.harmonics is None:
            return None
        H = self.harmonics.size
        C = len(self.cases)
        R = harmonic_rows(self.phi1, self.pair.pinion.z, H)
        rows, cols, vals = [], [], []
        for b, (t, c, n, _, _) in enumerate(blocks):
            base = (t * C + c) * 2 * H
            rows.extend(range(base, base + 2 * H))
            cols.extend([b] * (2 * H))
            vals.extend(R[:, n])
        return _sparse_dm(rows, cols, vals, self.torques.size * C * 2 * H, nB)

    def _pvec(self, rho: float) -> list:
        """The NLP's parameters: pressure limit, edge margin [um], smoothing, penalty weight, the torque
        scales (1) and the misalignment offsets (0)."""
        lay = param_layout(self.torques.size, len(Misalignment.names()))
        return block_vector(lay, dict(p_limit=self.p_limit or 1.0, edge_margin=(self.edge_margin or 0.0) / G_REF,
                                      mu=MU, rho=rho, torque_scale=1.0, mis_offset=0.0)).tolist()


def _sparse_dm(rows, cols, vals, n_rows, n_cols) -> ca.DM:
    return ca.DM.triplet(list(rows), list(cols), ca.DM(np.asarray(vals, float)), n_rows, n_cols)


@dataclass(eq=False)
class LoadedNLP:
    """One linearisation's NLP (:meth:`NLPBuilder._nlp`), its parts by name; its cold-start IPOPT
    solver, :attr:`solver`, is built on first use (a round solved warm, or a trial never solved,
    needs none), as every solver of it from :attr:`derivatives` (:meth:`ipopt`)."""

    problem: dict  #: CasADi's NLP: ``x``, ``p``, ``f``, ``g``
    opts: dict  #: IPOPT's options
    phi1: np.ndarray  #: the NLP's positions [rad]
    #: ``flank``, ``ends``: the slices (indices into the loads ``x``) of the pressure and edge rows
    rows: dict
    gap: ca.Function  #: the gaps of the slices held, ``(z, torque_scale, mis_offset) -> gap`` [um]
    lbg: np.ndarray  #: lower bounds of the constraint rows
    ubg: np.ndarray  #: upper bounds of the constraint rows
    layout: NLPLayout  #: the unknowns, rows and parameters by name
    sizes: dict  #: the layout's block sizes by short name (:meth:`NLPLayout.sizes`)
    blocks: list[Block]  #: one per torque, case and position
    ct: np.ndarray  #: (nB,) torque-case index of each block
    edge: np.ndarray  #: (nx,) tip-edge slices
    ew: np.ndarray  #: (nx,) edge weights at the linearisation, clipped to 0 ... 1
    lever: float  #: ``r_b2 cos(beta_b)`` [mm]
    Wt: np.ndarray  #: (T,) normal load per torque [N]
    ln: np.ndarray  #: (nx,) contact length per slice [mm]
    Rx: np.ndarray  #: (nx,) reduced radius per slice at the linearisation [mm]
    Jk: np.ndarray  #: (nx, P + Q) its curvature's sensitivity (:func:`kappa_lin`)
    theta_k: np.ndarray  #: the linearisation's design [mm]
    keys: np.ndarray  #: (nx, 4) (torque, case, position, flat slice) per slice held
    hmap: ca.DM | None  #: the harmonics map, or None (peak-to-peak objective)
    w_keys: np.ndarray  #: (nw, 4) the same per deflection unknown
    w_part: np.ndarray  #: (nw,) the compliance part of each deflection unknown
    te0: Te0Slices | None  #: the unloaded-TE target's slices, or None
    te0_term: ca.Function  #: the unloaded-TE target's term of the objective, ``z -> te0_term``
    warm: ca.Function | None = None  #: the warm-start IPOPT solver, once built (:meth:`TrustRegion._solve_nlp`)
    _solver: ca.Function | None = field(default=None, repr=False)
    _smoothing: ca.Function | None = field(default=None, repr=False)
    _oracle: ca.Function | None = field(default=None, repr=False)
    _derivatives: dict | None = field(default=None, repr=False)

    @property
    def oracle(self) -> ca.Function:
        """:attr:`problem` as one Function ``(x, p) -> (f, g)`` (built on first use), from which every
        solver of the NLP is built, with its :attr:`derivatives` (the same iterates bit for bit as from
        :attr:`problem` itself)."""
        if self._oracle is None:
            pr = self.problem
            self._oracle = ca.Function("nlp", [pr["x"], pr["p"]], [pr["f"], pr["g"]], ["x", "p"], ["f", "g"])
        return self._oracle

    @property
    def derivatives(self) -> dict:
        """IPOPT's constraint Jacobian and Lagrangian Hessian of :attr:`oracle` as ``nlpsol``'s options
        ``jac_g`` and ``hess_lag`` (:func:`~gearopt.synthesis.loaded.derivatives.ipopt_derivatives`: CasADi's
        own, the same values bit for bit, built in about half the time), built on first use and shared by
        every solver of the NLP."""
        if self._derivatives is None:
            self._derivatives = ipopt_derivatives(self.oracle)
        return self._derivatives

    def ipopt(self, name: str, opts: dict) -> ca.Function:
        """An IPOPT solver of :attr:`oracle` with the options ``opts`` and :attr:`derivatives`."""
        return ca.nlpsol(name, "ipopt", self.oracle, {**opts, **self.derivatives})

    @property
    def solver(self) -> ca.Function:
        """The cold-start IPOPT solver of :attr:`problem` (built on first use, :meth:`ipopt`)."""
        if self._solver is None:
            self._solver = self.ipopt("loaded_microgeometry", self.opts)
        return self._solver

    @property
    def smoothing_solver(self) -> ca.Function:
        """The IPOPT solver of a first round's first stage (:meth:`NLPBuilder._solve_smoothed`): the cold start
        with the monotone barrier (``SMOOTH_STAGE_OPTS``), built on first use (:meth:`ipopt`)."""
        if self._smoothing is None:
            self._smoothing = self.ipopt("loaded_microgeometry_smoothing", {**self.opts, **SMOOTH_STAGE_OPTS})
        return self._smoothing

    @solver.setter
    def solver(self, f: ca.Function) -> None:
        self._solver = f

    @property
    def solver_built(self) -> bool:
        """Whether :attr:`solver` exists (IPOPT is built for an NLP only when it is solved cold)."""
        return self._solver is not None


def kappa_lin(R: np.ndarray, Jk: np.ndarray, P: int, dth: ca.MX | ca.SX | np.ndarray,
              dm: ca.MX | ca.SX | np.ndarray) -> ca.MX | ca.SX | np.ndarray:
    """The Hertz term's relative curvature ``1 / R*`` [1/mm] of every slice, linear in the design step
    ``dth`` [mm] and the misalignment offsets ``dm`` about the linearisation: ``1 / R + Jk (dth, dm)``
    (``R`` (n,) [mm] and ``Jk`` (n, P + 4) of :class:`~gearopt.synthesis.loaded.linearise.Linearisation`),
    kept positive by ``(k + sqrt(k^2 + KAPPA_FLOOR^2)) / 2`` (a relative change of 1e-7 at R* = 10 mm).
    CasADi expressions for symbolic ``dth``, ``dm``; numpy arrays for numbers."""
    if isinstance(dth, (ca.MX, ca.SX)) or isinstance(dm, (ca.MX, ca.SX)):
        k = ca.DM(1.0 / R) + ca.mtimes(ca.DM(Jk[:, :P]), dth) + ca.mtimes(ca.DM(Jk[:, P:]), dm)
        return 0.5 * (k + ca.sqrt(k**2 + KAPPA_FLOOR**2))
    k = 1.0 / R + Jk[:, :P] @ np.asarray(dth, float) + Jk[:, P:] @ np.asarray(dm, float)
    return 0.5 * (k + np.sqrt(k**2 + KAPPA_FLOOR**2))
