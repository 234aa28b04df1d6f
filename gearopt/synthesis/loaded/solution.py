"""The NLP's start point, bounds and own values at a solution, and the carrying of an earlier NLP's
multipliers to a new one (warm start) (:class:`NLPSolution`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from ...meshing.misalignment import Misalignment
from ...units import RAD_TO_ARCSEC
from ...ltca.compliance import face_matrix_batch
from ...contact.hertz import hertz_peak_pressure
from .constants import G_REF, MU
from .layout import block_vector
from .nlp import kappa_lin
from .verify import parabola_fit


class NLPSolution:
    """Start point, bounds and predicted values of the NLP; multipliers carried between NLPs."""

    def _start(self, nlp, lin, theta_k, sw):
        """Initial point: the exact loaded TCA of the linearisation's design (its loads, deflections and
        approach), with the smoothed complementarity x y = MU made to hold."""
        U = nlp.layout.unknowns
        nx, nB, TC, nw = (U.count(k) for k in ("x", "d", "te_hi", "w"))
        x0 = np.zeros(nx)
        d0 = np.zeros(nB)
        w0 = np.zeros(nw)
        lever = nlp.lever
        CF = {}
        # each compliance part's deflections (analytical compliance: the NLP's deflection unknowns,
        # LTCA.structure's parts, each coupled across the face over its own length)
        cb2 = self.ltca.cos_bb**2
        Cp = {}
        if nlp.w_part.size:
            for c, L in enumerate(lin):
                S = L.slices
                K, N, M = S.z.shape
                wt = S.width if S.width_tooth is None else S.width_tooth
                Cp[c] = [cb2 * face_matrix_batch(S.z.reshape(K * N, M), wt.reshape(K * N, M),
                                                 [(p.compliance.reshape(K * N, M), p.coupling_length)]).reshape(K, N, M, M)
                         for p in L.structure.parts]
        for b, (t, c, n, first, cnt) in enumerate(nlp.blocks):
            S = lin[c].slices
            K, N, M = S.z.shape
            r = sw[c].results[t]
            A = nlp.keys[first:first + cnt, 3]
            Ff = np.transpose(r.load, (1, 0, 2)).reshape(N, K * M)[n]
            x0[first:first + cnt] = Ff[A] / r.W
            CF[(t, c, n)] = Ff
            # delta' = delta - te0 lever (absolute separations a = -te lever)
            d0[b] = (r.delta[n] - r.te_unloaded[n] * lever) / G_REF
        for j, ((t, c, n, i), part) in enumerate(zip(nlp.w_keys, nlp.w_part)):
            M = lin[c].slices.z.shape[2]
            k, m = divmod(int(i), M)
            w0[j] = Cp[c][part][k, n, m] @ CF[(t, c, n)][k * M:(k + 1) * M] / G_REF
        te = -d0 * G_REF / lever * RAD_TO_ARCSEC
        u0 = np.full(TC, -np.inf)
        v0 = np.full(TC, np.inf)
        np.maximum.at(u0, nlp.ct, te)
        np.minimum.at(v0, nlp.ct, te)
        parts = dict(theta=np.asarray(theta_k) * 1e3, x=x0, y=1.0, d=d0, te_hi=u0, te_lo=v0, w=w0)
        if nlp.te0 is not None:
            parts.update(zip(("x0", "y0", "d0"), self._te0_start(nlp.te0, lever)))
        z0 = block_vector(U, parts)
        gap = np.asarray(nlp.gap(z0, np.ones(self.torques.size), np.zeros(len(Misalignment.names())))).ravel()
        loaded = x0 > 1e3 * MU
        y0 = np.where(loaded, MU / np.maximum(x0, 1e-300), np.maximum(gap, 1e-3))
        x0 = np.where(loaded, x0, MU / y0)
        z0[U["x"]] = x0
        z0[U["y"]] = y0
        # slacks that make the start feasible for the pressure and edge constraints
        counts = [b.count for b in nlp.blocks]
        ct_x = np.repeat(nlp.ct, counts)
        s_p = np.zeros(TC)
        s_e = np.zeros(TC)
        if self.p_limit is not None:
            W = nlp.Wt[np.repeat([b.torque for b in nlp.blocks], counts)]
            p2 = np.where(nlp.edge, 0.0, x0 * W * self.material.E_star / (math.pi * nlp.Rx * nlp.ln))
            np.maximum.at(s_p, ct_x, p2 / self.p_limit**2 - 1.0)
        if self.edge_margin is not None:
            np.maximum.at(s_e, ct_x, nlp.ew * x0 - MU * G_REF / self.edge_margin)
        z0[U["slack_p"]] = s_p * 1.01 + 1e-6
        z0[U["slack_e"]] = s_e * 1.01 + 1e-6
        return z0

    def _te0_start(self, te0, lever) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Start of the unloaded-TE target's unknowns ``(x0, y0, d0)`` at the linearisation's design: each
        block's smallest separation carries the load, every other slice x = MU / y."""
        aa = te0.a / G_REF
        n0, nB0 = aa.size, len(te0.blocks)
        x0, y0, d0 = np.zeros(n0), np.zeros(n0), np.zeros(nB0)
        for b, (_, _, first, cnt) in enumerate(te0.blocks):
            s = slice(first, first + cnt)
            y = aa[s] - np.min(aa[s])
            j = int(np.argmin(aa[s]))
            x = MU / np.maximum(y, 1e-3)
            x[j] = 1.0 - (np.sum(x) - x[j])
            d0[b] = np.min(aa[s]) - MU / x[j]
            y = aa[s] - d0[b]
            x = np.where(np.arange(cnt) == j, x[j], MU / y)
            x0[s], y0[s] = x, y
        return x0, y0, d0

    def _bounds(self, nlp):
        """The unknowns' bounds: the design's own (scaled), slacks >= 0, everything else free."""
        U = nlp.layout.unknowns
        lbx = block_vector(U, dict(theta=self.lo * 1e3, slack_p=0.0, slack_e=0.0), fill=-np.inf)
        ubx = block_vector(U, dict(theta=self.hi * 1e3), fill=np.inf)
        return lbx, ubx

    def _predicted(self, nlp, z):
        U = nlp.layout.unknowns
        TC = U.count("te_hi")
        x = U.take(z, "x")
        d = U.take(z, "d")
        te = -d * G_REF / nlp.lever * RAD_TO_ARCSEC
        hi = np.full(TC, -np.inf)
        lo = np.full(TC, np.inf)
        np.maximum.at(hi, nlp.ct, te)
        np.minimum.at(lo, nlp.ct, te)
        T, C = self.torques.size, len(self.cases)
        pp = (hi - lo).reshape(T, C)
        # flank pressure of the NLP's loads
        counts = [b.count for b in nlp.blocks]
        W = nlp.Wt[np.repeat([b.torque for b in nlp.blocks], counts)]
        f = np.maximum(x, 0.0) * W / nlp.ln
        Jk = nlp.Jk
        P = Jk.shape[1] - len(Misalignment.names())
        kap = kappa_lin(nlp.Rx, Jk, P, U.take(z, "theta") * 1e-3 - nlp.theta_k, np.zeros(Jk.shape[1] - P))
        p0 = np.where(nlp.edge, 0.0, hertz_peak_pressure(f, 1.0 / kap, self.material.E_star))
        pm = np.full(TC, 0.0)
        blk_ct = np.repeat(nlp.ct, counts)
        np.maximum.at(pm, blk_ct, p0)
        obj = float(np.sum(self.weights * pp))
        if nlp.hmap is not None:
            H = self.harmonics.size
            ab = np.asarray(ca.mtimes(nlp.hmap, ca.DM(te))).ravel().reshape(T, C, H, 2)
            obj = float(np.sum(self.weights[..., None] * np.hypot(ab[..., 0], ab[..., 1]) * self.harmonics))
        out = {"te_pp": pp, "p_max": pm.reshape(T, C), "objective": obj,
               "slack_p": U.take(z, "slack_p").reshape(T, C), "slack_e": U.take(z, "slack_e").reshape(T, C)}
        if nlp.te0 is not None:  # the NLP's unloaded TE, its misfit by least squares (as in the NLP)
            t0 = nlp.te0
            te = -U.take(z, "d0") * G_REF / nlp.lever * RAD_TO_ARCSEC
            rms = np.array([parabola_fit(t0.psi[t0.case == c], te[t0.case == c],
                                          self.te_level * RAD_TO_ARCSEC)[0] for c in range(C)])
            out.update(te0_rms=rms, te0_term=self._te0_term(rms), te0=te)
        return out

    def _multipliers(self, prev, nlp):
        """The multipliers of an earlier NLP's solution ``prev = (nlp, solution)`` carried to ``nlp``,
        row by row: a row of a slice, a block or a torque-case keeps its multiplier where the earlier
        NLP had the same row (the same torque, case, position and slice; a position matched by its
        angle, so a refined grid's rows find theirs), else 0. ``None`` when the new grid does not hold
        every position of the earlier one."""
        pn, r = prev
        # each earlier position by its place on the new grid (a refined grid holds the earlier one)
        at = np.searchsorted(nlp.phi1, pn.phi1)
        if np.any(at >= nlp.phi1.size) or not np.array_equal(nlp.phi1[np.minimum(at, nlp.phi1.size - 1)], pn.phi1):
            return None
        lg, lx = (np.asarray(r[k]).ravel() for k in ("lam_g", "lam_x"))

        def code(k, n):  # (torque, case, position, slice) -> one key, the position on the new grid
            k = np.asarray(k, np.int64).reshape(-1, 4)
            pos = at[k[:, 2]] if n is pn else k[:, 2]
            return ((k[:, 0] * 1000 + k[:, 1]) * 100000 + pos) * 1000000 + k[:, 3]

        def rows(n):  # the keys of every constraint row, by the rows' block (:data:`.layout.ROWS`)
            kx = code(n.keys, n)
            kb = code([(b.torque, b.case, b.position, 0) for b in n.blocks], n)
            out = dict(stiffness=code(n.w_keys, n) * 4 + n.w_part, gap=kx, complementarity=kx, balance=kb, te_hi=kb,
                       te_lo=kb, pressure=kx[n.rows["flank"]], edge=kx[n.rows["ends"]])
            if n.te0 is not None:  # the unloaded-TE target's rows (torque index T: zero load)
                k0 = code(n.te0.keys, n)
                out.update(te0_gap=k0, te0_complementarity=k0,
                           te0_balance=code([(self.torques.size, c, m, 0) for c, m, _, _ in n.te0.blocks], n))
            return out

        def carry(kp, vp, kn):
            out = np.zeros(kn.size)
            if kp.size and kn.size:
                o = np.argsort(kp)
                j = np.minimum(np.searchsorted(kp[o], kn), kp.size - 1)
                hit = kp[o][j] == kn
                out[hit] = vp[o[j[hit]]]
            return out

        lay, lay_p = nlp.layout, pn.layout
        old, new = rows(pn), rows(nlp)
        parts = [carry(old[k], lay_p.rows.take(lg, k), new[k]) if k in new else np.zeros(0) for k in lay.rows.names]
        # (the design's bounds: none, the new design is the centre of its trust region; the slacks' bounds
        # keep theirs)
        lam_x = block_vector(lay.unknowns, {k: lay_p.unknowns.take(lx, k) for k in ("slack_p", "slack_e")})
        return lam_x, np.concatenate(parts)
