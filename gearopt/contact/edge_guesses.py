"""First guesses of edge contact: the conjugate contact of the aligned, unmodified drive in several
pinion sections at each angle (:func:`conjugate_sections`, also the loaded TCA slices' first guesses),
moved onto each edge (slid onto a face end, along the profile onto a tip circle, onto the end of a
folded flank), with the flank evaluators they need. :class:`EdgeFirstGuesses` is a part of
:class:`gearopt.contact.edge.EdgeContact`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from ..compiled import ColumnMap, mapped
from ..errors import ConvergenceError
from ..meshing.misalignment import Misalignment
from .edge_kinds import EDGES, edge_kind, exact_key

if TYPE_CHECKING:
    from ..meshing.tca import TCA
    from ..types import ArrayLike, Param


class EdgeFirstGuesses:
    """The first guesses of :class:`~gearopt.contact.edge.EdgeContact` (a mixin: it uses its ``tca``,
    ``edges``, ``members``, ``teeth``, the limit curves ``_limit_u``, the line-contact TCA
    ``_line_tca``, the memo ``_memo`` / ``_remember`` and the evaluators ``_colmaps``)."""

    _SECTIONS = (-0.5, -0.25, 0.0, 0.25, 0.5)  #: pinion sections of the first guesses [b1]

    def _first_guesses(self, uphi, p1, p2) -> dict:
        """{edge name: list of (5, M) first guesses} at the pair-0 angles ``uphi``
        (:meth:`_guesses` from :meth:`_sections`): they depend on the angles and the settings only,
        not on the misalignment, so they are memoised per exact (uphi, p1, p2) and the cases of a
        study solve them once. Callers must not write into the arrays."""
        key = ("guesses", exact_key(uphi), exact_key(p1), exact_key(p2))
        hit = self._memo.get(key)
        if hit is None:
            hit = self._remember(key, self._guesses(self._sections(uphi, p1, p2), p1, p2))
        return hit

    def _sections(self, uphi, p1, p2) -> dict:
        """Conjugate contact of the aligned drive with the crowning removed in the pinion sections
        z = s b1 (s in _SECTIONS) at each angle of ``uphi``: {s: (5, M) full unknowns, NaN where
        none} (:func:`conjugate_sections`)."""
        b1 = self.members[1].b
        secs = conjugate_sections(self.tca, self._line_tca(), uphi, p1, p2, [s * b1 for s in self._SECTIONS])
        return {s: secs[s * b1] for s in self._SECTIONS if s * b1 in secs}

    def _columns(self, what: str, member: int) -> ColumnMap:
        """A flank evaluator of ``member`` on any number of columns, built once per EdgeContact
        (:class:`gearopt.compiled.ColumnMap`: maps of a few fixed sizes, numpy in and out; the
        compiled library when it is in the disk cache, as the branches' solves): ``"radius"``
        (u, z, p) -> (transverse radius [mm], d radius / du) of the driving flank, ``"point"``
        (u, z, p) -> the flank point r [mm] (the surface's first output only)."""
        key = (what, member)
        cm = self._colmaps.get(key)
        if cm is None:
            tooth, side = self.teeth[member], self.tca.side
            if what == "radius":
                f = tooth.radius_function(side)
            else:
                s = tooth.surface(side, "flank")
                u, z, p = ca.SX.sym("u"), ca.SX.sym("z"), ca.SX.sym("p", s.size1_in(2))
                f = ca.Function(f"flank_point{member}", [u, z, p], [s(u, z, p)[0]], ["u", "z", "p"], ["r"])
            cm = self._colmaps[key] = mapped(f, 1, self.tca.jit)
        return cm

    def _u_at(self, member, radius, z, p):
        """Vectorised flank parameter u at transverse ``radius`` and axial ``z`` (Newton; NaN where
        it fails)."""
        tooth = self.teeth[member]
        z = np.asarray(z, float)
        n = z.size
        f = self._columns("radius", member)
        u = np.full(n, float(tooth.extras.get("q_pitch", 0.0)))
        P = np.tile(np.asarray(p, float)[:, None], n)
        zz = np.where(np.isfinite(z), z, 0.0)[None, :]
        for _ in range(40):
            rad, d = (v.ravel() for v in f(u[None, :], zz, P))
            with np.errstate(invalid="ignore", divide="ignore"):
                step = np.where(d < 0, (rad - radius) / d, np.nan)
            u = u - step
            if np.all(~np.isfinite(step) | (np.abs(step) < 1e-12)):
                break
        return np.where(np.isfinite(z) & np.isfinite(u), u, np.nan)

    def _guesses(self, sections, p1, p2) -> dict:
        """First guesses {edge name: list of (5, M)} from the conjugate section solutions
        ``sections`` ({s: (5, M)}): the section points moved onto each edge (slid along the face
        width onto a face end, along the profile onto the tip circle, or the contact line
        interpolated to where it crosses a tip circle). The points put on a member's tip circle
        are solved together (:meth:`_u_at` once per member: a point's u depends on its own z only)."""
        secs = [sections[s] for s in self._SECTIONS if s in sections]
        if not secs:
            return {name: [] for name in self.edges}
        prm_of = {1: p1, 2: p2}
        tips: dict[int, list] = {1: [], 2: []}  # points whose u_m is put on member m's tip circle

        def on_face(Qs, m, sg):  # slide the conjugate point along the face width onto the face end m
            q0 = Qs.copy()
            shift = sg * self.members[m].b / 2 - q0[1 if m == 1 else 3]
            q0[1] += shift
            q0[3] += shift
            return q0

        def on_tip(q0, m):  # q0's u_m onto member m's tip circle (in place, below: it reads z_m only)
            tips[m].append(q0)
            return q0

        # The conjugate contact line interpolated to where it crosses member m's tip circle.
        S_all = np.hstack(secs)
        M = secs[0].shape[1]
        crossing = {}
        for m in (1, 2):
            rads = self._radius(m, S_all, prm_of[m]).reshape(len(secs), M) - self.members[m].r_a
            out = np.full((5, M), np.nan)
            for j in range(len(secs) - 1):
                f0, f1 = rads[j], rads[j + 1]
                br = np.isfinite(f0) & np.isfinite(f1) & (np.sign(f0) != np.sign(f1)) & ~np.isfinite(out[0])
                with np.errstate(invalid="ignore", divide="ignore"):
                    t = np.where(br, f0 / (f0 - f1), np.nan)
                out = np.where(br, secs[j] + t * (secs[j + 1] - secs[j]), out)
            crossing[m] = out
        # the crossings on the tip circles (the tip edges' first guesses, and slid onto a face end
        # for the tip/face crossings, once they are solved)
        tipx = {m: on_tip(crossing[m].copy(), m) for m in (1, 2)}
        slide = []  # (name, face member, face sign, tip member): on_face of a solved tip crossing

        out = {}
        for name in self.edges:
            member, kind, sign = edge_kind(name)
            if kind == "limit":  # the conjugate section points moved onto the flank's end u = U(z)
                iu, iz = (0, 1) if member == 1 else (2, 3)
                U = self._limit_u[member]
                guesses = []
                for S in secs:
                    q0 = S.copy()
                    zz = np.where(np.isfinite(q0[iz]), q0[iz], 0.0)
                    q0[iu] = np.asarray(U.map(zz.size)(zz[None, :])).ravel()
                    guesses.append(q0)
                out[name] = guesses
            elif kind == "face":
                out[name] = [on_face(secs[0 if sign < 0 else -1], member, sign)]
            elif kind == "corner":
                out[name] = [on_tip(on_face(secs[0 if sign < 0 else -1], member, sign), member)]
            elif kind == "tip":
                out[name] = [tipx[member]] + [on_tip(S.copy(), member) for S in secs]
            else:  # edge on edge
                (m1, k1, s1), (m2, k2, s2) = (EDGES[e] for e in sign)
                if k1 == "tip" and k2 == "tip":  # each tip crossing onto both tip circles
                    out[name] = [on_tip(on_tip(crossing[1].copy(), 1), 2), on_tip(on_tip(crossing[2].copy(), 2), 1)]
                else:
                    face_m, face_s, tip_m = (m2, s2, m1) if k2 == "face" else (m1, s1, m2)
                    out[name] = [on_tip(on_face(secs[0 if face_s < 0 else -1], face_m, face_s), tip_m)]
                    slide.append((name, face_m, face_s, tip_m))
        for m in (1, 2):
            if tips[m]:
                iu, iz = (0, 1) if m == 1 else (2, 3)
                z = np.concatenate([q[iz] for q in tips[m]])
                u = self._u_at(m, self.members[m].r_a, z, prm_of[m])
                n = 0
                for q in tips[m]:
                    q[iu] = u[n:n + q.shape[1]]
                    n += q.shape[1]
        for name, face_m, face_s, tip_m in slide:
            out[name].append(on_face(tipx[tip_m], face_m, face_s))
        return out

    def _radius(self, member, Q, prm=None):
        """Transverse radius of the contact point on ``member`` for the columns of Q (NaN-safe)."""
        tooth = self.teeth[member]
        iu, iz = (0, 1) if member == 1 else (2, 3)
        p = tooth.p0 if prm is None else prm
        good = np.isfinite(Q[iu]) & np.isfinite(Q[iz])
        out = np.full(Q.shape[1], np.nan)
        if good.any():
            n = int(good.sum())
            r = self._columns("point", member)(Q[iu][good][None, :], Q[iz][good][None, :],
                                               np.tile(np.asarray(p, float)[:, None], n))
            out[good] = np.hypot(r[0], r[1])
        return out


def conjugate_sections(tca: TCA, line_tca: TCA, phis: ArrayLike, p1: Param, p2: Param, z_sections: ArrayLike) -> dict:
    """Conjugate contact of the aligned drive of ``tca`` with its crowning and flank modifications
    removed (``line_tca``: a line-contact TCA of the unmodified teeth; only the tool shifts x of
    ``p1``, ``p2`` kept) in the pinion sections ``z_sections`` [mm] at the angles ``phis`` [rad]:
    {z: (5, M) full unknowns (u1, z1, u2, z2, r_p2 phi2), NaN where none}. Each column is solved by
    itself (Newton from the linear prediction around phi1 = 0, which depends on that angle only); a
    section without a solution at phi1 = 0 is left out. First guesses of edge contact and of the
    loaded-TCA slices."""
    lay = tca.layout
    n1, n2 = (len(t.unmodified.param_names) for t in (tca.pinion, tca.gear))  # generation settings only
    flat1, flat2 = np.zeros(n1), np.zeros(n2)
    flat1[lay.p_index("pinion", "x")] = p1[lay.p_index("pinion", "x")]
    flat2[lay.p_index("gear", "x")] = p2[lay.p_index("gear", "x")]
    phis = np.asarray(phis, float)
    aligned = Misalignment()
    found, W0s, prms = [], [], []
    for zs in z_sections:
        try:
            w_a = line_tca.solve_point(0.0, None, flat1, flat2, aligned, zs)
        except ConvergenceError:
            continue
        found.append(zs)
        prms.append(line_tca.prm(phis, flat1, flat2, aligned, zs))
        W0s.append(line_tca.branch.predict(w_a, line_tca.prm([0.0], flat1, flat2, aligned, zs)[:, 0], phis))
    if not found:
        return {}
    # every section's columns in one mapped solve and one w_full map (each column solved by itself)
    n = phis.size * len(found)
    W, res, _, _ = (np.asarray(v) for v in line_tca.branch.mapped(n, phis.size * len(z_sections))(
        np.hstack(W0s), np.hstack(prms)))
    res = res.ravel()
    Wf = np.asarray(line_tca.w_full.map(n)(W, np.repeat(np.asarray(found, float), phis.size)[None, :]))
    Wf[:, ~(np.isfinite(res) & (res <= 1e-8))] = np.nan
    return {zs: Wf[:, j * phis.size:(j + 1) * phis.size] for j, zs in enumerate(found)}
