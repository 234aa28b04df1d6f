"""Linearisation of the separations in the design (docs/loaded_synthesis.md section 2): the exact
slices of a design and the sensitivities of every slice's separation to the design and the
misalignments (the implicit function theorem on the slice equations, by AD), per case
(:class:`Linearisation`; :class:`Lineariser`, a part of
:class:`~gearopt.synthesis.loaded.LoadedMicroOptimizer`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import numpy.typing as npt

from ... import compiled, compile_queue
from ...graph_cache import eliminated
from ...ltca.engine import ContactStructure
from ...ltca.slices import SliceSet
from ...meshing.misalignment import Misalignment

#: linearisations kept per optimiser and its copies (:meth:`Lineariser.linearise`): a case each of the
#: last two designs of the loop
LIN_KEPT = 4


@dataclass(frozen=True)
class Linearisation:
    """The slices of one design in one misalignment case and their separations' sensitivities
    (:meth:`Lineariser.linearise`); arrays (K, N, M): pairs x positions x slices, zero at inactive slices.

    Attributes
    ----------
    slices : SliceSet
        The exact slices of the design (:meth:`gearopt.ltca.engine.LTCA.slices`).
    structure : ContactStructure
        Their compliance and Hertz data (:meth:`gearopt.ltca.engine.LTCA.structure`).
    a : (K, N, M) array
        Absolute separation of every slice [mm] (``-te r_b2 cos(beta_b)``).
    J : (K, N, M, P) array
        Its derivative in each free amount [mm/mm, or mm per 1/mm for a setting].
    Jm : (K, N, M, Q) array
        Its derivative in each misalignment kind of ``Misalignment.names()`` [mm/rad or mm/mm].
    Jr : (K, N, M, 2, P + Q) array
        Derivatives of the slice point's radius on the pinion and on the gear [mm per unit] (moves a
        flank slice in the tip band, :func:`~gearopt.synthesis.loaded.edges.edge_weight_lin`).
    lam : (K, N, M) array
        Each slice's lever about the pinion axis over ``r_b1 cos(beta_b)`` (1 on an involute flank).
    da : (K, N, M) array
        The separation's correction for the slice's own levers [mm] (zero on an involute flank).
    mis : Misalignment
        The case.
    Jk : (K, N, M, P + Q) array
        Derivatives of the Hertz term's relative curvature ``1 / R*`` (``kappa1 + kappa2``) [1/mm per
        unit] in each free amount and misalignment kind (zero where held: tip edges, unknown curvature).
    """

    slices: SliceSet = field(repr=False)
    structure: ContactStructure = field(repr=False)
    a: np.ndarray = field(repr=False)
    J: np.ndarray = field(repr=False)
    Jm: np.ndarray = field(repr=False)
    Jr: np.ndarray = field(repr=False)
    lam: np.ndarray = field(repr=False)
    da: np.ndarray = field(repr=False)
    mis: Misalignment
    Jk: np.ndarray = field(repr=False)


@dataclass(frozen=True)
class SliceTangent:
    """A slice's equations ``G(w, prm) = 0`` (kind 0: flank, 1/2: a tip edge) with the derivative of their
    solution in the optimiser's parameter columns (the implicit function theorem, CasADi AD)."""

    w: ca.SX  #: the slice's unknowns (4) [mm]
    prm: ca.SX  #: the TCA's parameter column (``tca.layout``)
    dw: ca.SX  #: dw/d(columns) (4, columns) [mm per unit]
    idx: list  #: the rows of ``prm`` that are the optimiser's columns

    def total(self, v: ca.SX) -> ca.SX:
        """The total derivative of ``v(w, prm)`` along the solution of the slice equations in the
        columns: ``dv/dprm + dv/dw dw/dprm``."""
        return ca.mtimes(ca.jacobian(v, self.w), self.dw) + ca.jacobian(v, self.prm)[:, self.idx]


class Lineariser:
    """The linearisation of the slices' separations at a design, per case."""

    def slice_tangent(self, kind: int) -> SliceTangent:
        """The equations of a slice of ``kind`` (0: flank, 1/2: the pinion's / gear's tip edge) and their
        solution's derivative in the optimiser's parameter columns (:class:`SliceTangent`), built once
        per kind (the separations' sensitivities and the held data's point tangents share it)."""
        memo = self.__dict__.setdefault("_tangents", {})
        if kind not in memo:
            G = self.slice_residual(kind)
            w = ca.SX.sym("w", 4)
            prm = ca.SX.sym("prm", self.tca.layout.size)
            F = G(w, prm)
            idx = self._prm_index
            memo[kind] = SliceTangent(w, prm, -ca.solve(ca.jacobian(F, w), ca.jacobian(F, prm)[:, idx]), idx)
        return memo[kind]

    def slice_residual(self, kind: int) -> ca.Function:
        """The slice equations ``G(w, prm)`` of a slice of ``kind`` (0: flank, 1/2: the pinion's / gear's
        tip edge; :class:`~gearopt.ltca.slices.SliceSolver`)."""
        slicer = self.ltca.slicer
        return slicer.G if kind == 0 else slicer.edge_branch[kind].G

    def keyed_by_construction(self, f: ca.Function, kind: int, *code: object) -> ca.Function:
        """``f``, built from the slice equations of ``kind`` and the slices' geometry by the code
        ``code`` (functions, classes) with this optimiser's parameter columns, keyed in the disk
        cache of compiled libraries by that (:func:`gearopt.compiled.keyed_by`): looking its library
        up serialises no derived graph (0.2-0.3 s each, as long as running them interpreted)."""
        return compiled.keyed_by(f, *self._construction(kind, code))

    def _construction(self, kind: int, code: tuple) -> tuple[list, str]:
        """The bases and tag of :meth:`keyed_by_construction` (:func:`gearopt.compiled.keyed_by`)."""
        tag = compiled.source_tag(Lineariser.slice_tangent, Lineariser.slice_residual, SliceTangent, *code)
        return ([self.slice_residual(kind), self.ltca.slicer.geometry],
                tag and f"{tag}/{kind}/{self._prm_index}/{self.pair.gear.r_p!r}")

    def cached_construction(self, name: str, kind: int, *code: object) -> compiled.ColumnMap | None:
        """The compiled library of the Function ``name`` that :meth:`keyed_by_construction` keys, on
        columns, if it is in the disk cache (with ``jit``), else None: then the graph is not built."""
        if not self.jit:
            return None
        g = compiled.keyed_library(name, *self._construction(kind, code))
        return None if g is None else compiled.ColumnMap(g, lambda m: compiled.map_columns(g, m), compiled=True)

    # -- linearisation --------------------------------------------------------------------------
    def _sensitivity(self, kind: int) -> ca.Function:
        """d(r_p2 phi2)/d(theta, misalignment) of a slice (kind 0: flank, 1/2: a tip edge), implicit
        function theorem; with the total derivatives of the slice point's radius on the pinion (``dr1``)
        and on the gear (``dr2``) [mm per unit], which move a flank slice in the tip band
        (:func:`edge_weight`; zero on a tip edge, whose weight is 1), and of the relative curvature
        across the contact line ``kappa1 + kappa2`` (``dk`` [1/mm per unit], ``SliceSet.kappa1/2``, the
        Hertz term's ``1 / R*``: the surface's own curvature changes with the amounts, and the point
        moves along the profile; zero on a tip edge, whose Hertz radius is held)."""
        if kind not in self._sens:
            slicer = self.ltca.slicer
            t = self.slice_tangent(kind)
            w, prm = t.w, t.prm
            outs = [t.dw[3, :].T]
            if kind == 0:
                geo = slicer.geometry(w, prm)
                names = slicer.geometry.name_out()
                r1, r2 = geo[0], geo[2]
                kap = geo[names.index("kappa1")] + geo[names.index("kappa2")]
                for v in (ca.sqrt(r1[0] ** 2 + r1[1] ** 2), ca.sqrt(r2[0] ** 2 + r2[1] ** 2), kap):
                    outs.append(t.total(v).T)  # along the solution of the slice equations
            else:
                outs += [ca.DM.zeros(len(t.idx))] * 3
            # common subexpressions eliminated (the same numbers bit for bit; kind 0: 168,000 -> 95,000
            # instructions, interpreted 1.8x faster until its library lands, docs/benchmarks.md "The
            # slice geometry's common subexpressions")
            self._sens[kind] = self.keyed_by_construction(
                eliminated(ca.Function(f"ltca_dphi2_{kind}", [w, prm], outs, ["w", "prm"],
                                       ["dw3", "dr1", "dr2", "dk"])),
                kind, Lineariser._sensitivity)
        return self._sens[kind]

    def sensitivity_columns(self, kind: int, n: int) -> compiled.ColumnMap:
        """:meth:`_sensitivity` of slice kind ``kind`` on ``n`` columns: with ``jit``, the compiled library
        from the disk cache (:func:`gearopt.compiled.mapped`, ``jit="auto"``: on a cache miss it compiles in
        the background while these columns run interpreted, and a later call picks it up); the AD graph
        interpreted took most of a linearisation (4 s of the 7 of problems/microgeometry_loaded.toml)."""
        cm = self._sens_maps.get(kind)
        if cm is not None and cm.compiled:
            return cm
        if cm is None and kind not in self._sens:
            # the library in the cache: the AD graph is not built (0.26 s)
            cm = self.cached_construction(f"ltca_dphi2_{kind}", kind, Lineariser._sensitivity)
            if cm is not None:
                self._sens_maps[kind] = cm
                return cm
        f = self._sensitivity(kind)
        if cm is None or (not cm.compiled and self.jit and compiled.cached_function(f) is not None):
            cm = self._sens_maps[kind] = compiled.mapped(f, n, jit="auto" if self.jit else False)
        return cm

    def separation_gradients(self, kind: int, wv: np.ndarray, prm: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The separations' sensitivities of slices of kind ``kind`` at the slice unknowns ``wv``
        (4, n) and parameter columns ``prm`` (:meth:`sensitivity_columns`), one row per column:
        ``J`` (n, nq) [mm per unit] (the gear's rotation times ``-r_b2 cos(beta_b)``), ``Jr`` (n, 2, nq)
        (the point's radius on the pinion and the gear), ``Jk`` (n, nq) (the relative curvature)."""
        lever = self.pair.gear.r_b * self.ltca.cos_bb
        dw3, dr1, dr2, dk = (np.asarray(v).T for v in self.sensitivity_columns(kind, wv.shape[1])(wv, prm))
        return dw3 / self.pair.gear.r_p * (-lever), np.stack([dr1, dr2], axis=1), dk

    def linearise(self, theta: npt.ArrayLike) -> list[Linearisation]:
        """Slices, compliance and the separations' sensitivities of the design ``theta`` [mm]: one
        :class:`Linearisation` per case. A case linearised already at the same design and positions (by
        this optimiser or a copy: a Pareto point's first round is the last point's final design, the KKT
        sensitivities that of the loop's last round) is that linearisation (:meth:`_remembered`)."""
        p1, p2 = self.params(theta)
        out = []
        for mis in self.cases:
            case = (p1.tobytes(), p2.tobytes(), tuple(float(getattr(mis, k)) for k in Misalignment.names()),
                    tuple(self._prm_index), bool(self.jit))
            key = (case, np.asarray(self.phi1, float).tobytes())
            hit = self._remembered(key)
            if hit is not None:
                out.append(hit[0])
                continue
            # the same design and case on another grid (a refined grid's first round: the last pass's final
            # design): its sensitivities of the slices this grid shares
            near = next((v[2] for k, v in reversed(self._lin_memo.items()) if k[0] == case and v[0] is self.ltca), None)
            L, raw = self._linearise_case(p1, p2, mis, near)
            self._remember(key, L, raw)
            out.append(L)
        return out

    def _remembered(self, key: tuple) -> tuple | None:
        """The linearisation of ``key`` (design, case, columns, ``jit``; positions) made by this loaded TCA
        and its raw gradients (:meth:`_remember`), if kept."""
        hit = self._lin_memo.get(key)
        return hit[1:] if hit is not None and hit[0] is self.ltca else None

    def _remember(self, key: tuple, L: Linearisation, raw: tuple) -> None:
        """Keep ``L`` and ``raw`` (its slices and per-slice gradients ``(J, Jr, Jk)`` as
        :meth:`separation_gradients` gave them; the newest :data:`LIN_KEPT`) when its numbers are those
        every later linearisation of ``key`` gives: no library compiles in the background, and the
        sensitivities ran compiled (or ``jit`` is off); else a later one may run the library and differ at
        round-off."""
        if compile_queue.pending or (self.jit and not all(m.compiled for m in self._sens_maps.values())):
            return
        memo = self._lin_memo
        memo.pop(key, None)
        memo[key] = (self.ltca, L, raw)
        while len(memo) > LIN_KEPT:
            memo.pop(next(iter(memo)))

    def exact_sweeps(self, lin: list[Linearisation]) -> list:
        """The loaded TCA at every torque of each linearisation's slices (:meth:`gearopt.ltca.engine.LTCA.solve`
        on its slices and structure), solved once per :class:`Linearisation` kept by :meth:`linearise`."""
        out = []
        for L in lin:
            memo = self._lin_sweeps
            key = (id(L), np.asarray(self.torques, float).tobytes())
            hit = memo.get(key)
            if hit is not None and hit[0] is L:
                out.append(hit[1])
                continue
            sw = self.ltca.solve(self.torques, slices=L.slices, structure=L.structure)
            if any(v[1] is L for v in self._lin_memo.values()):  # (only a kept one is met again)
                memo[key] = (L, sw)
                while len(memo) > LIN_KEPT:
                    memo.pop(next(iter(memo)))
            out.append(sw)
        return out

    def _linearise_case(self, p1: np.ndarray, p2: np.ndarray, mis: Misalignment, near: tuple | None = None
                        ) -> tuple[Linearisation, tuple]:
        """:meth:`linearise` of one case (the members' parameter vectors ``p1``, ``p2``), and its raw
        gradients (:meth:`_remember`). ``near``: the raw gradients of this design and case on another grid,
        taken for every slice whose position (its angle), pair, node, kind and unknowns are the same bit
        for bit (:meth:`separation_gradients` is a function of the slice's unknowns and column alone)."""
        lever = self.pair.gear.r_b * self.ltca.cos_bb
        z1 = self.pair.pinion.z
        S = self.ltca.slices(self.phi1, p1, p2, mis)
        st = self.ltca.structure(S)
        K, N, M = S.z.shape
        J = np.zeros((K, N, M, len(self._prm_index)))
        Jr = np.zeros((K, N, M, 2, len(self._prm_index)))
        Jk = np.zeros((K, N, M, len(self._prm_index)))
        phis = (S.phi1[None, :] - 2 * math.pi * np.array(S.pairs)[:, None] / z1)
        kinds = np.zeros((K, N, M), int) if S.edge is None else S.edge
        for kind in (0, 1, 2):
            sel = S.active & (kinds == kind)
            if not sel.any():
                continue
            kk, nn, mm = np.nonzero(sel)
            if near is not None:  # the slices the other grid solved alike: their gradients
                got = _same_slices(near[0], S, kind, (kk, nn, mm))
                if got is not None:
                    hit, at = got
                    src = (kk[hit], at, mm[hit])
                    dst = (kk[hit], nn[hit], mm[hit])
                    J[dst], Jr[dst], Jk[dst] = near[1][src], near[2][src], near[3][src]
                    kk, nn, mm = kk[~hit], nn[~hit], mm[~hit]
                    if not kk.size:
                        continue
            prm = self.tca.prm(phis[kk, nn], p1, p2, mis)
            prm[self.tca.layout.index("z_section"), :] = S.z[kk, nn, mm]
            J[kk, nn, mm], Jr[kk, nn, mm], Jk[kk, nn, mm] = self.separation_gradients(kind, S.w[kk, nn, mm].T, prm)
        raw = (S, J.copy(), Jr, Jk)
        if S.partner_of is not None:
            # a partner slice's separation is interpolated to the crossing (SliceSet.partner_t), and
            # so is its sensitivity (the crossing's own motion with the design is left out); its Hertz
            # radius is its own, and so is Jk (the NLP bounds its own pressure, the loaded TCA reports
            # the one interpolated to the crossing, which lies between its and its neighbour's)
            kk, nn, mm = np.nonzero(S.partner_of >= 0)
            ii, tt = S.partner_of[kk, nn, mm], S.partner_t[kk, nn, mm][:, None]
            J[kk, nn, mm] = J[kk, nn, ii] + tt * (J[kk, nn, mm] - J[kk, nn, ii])
        # each slice on its own levers (LTCA._solve_one, docs/ltca.md section 3): the gap is
        # (te0 - te) L2 + C F - lam delta, lam = L1 / (r_b1 cos(beta_b)); with the absolute separation
        # a = -te r_b2 cos(beta_b) and the block's approach d = delta - te0 r_b2 cos(beta_b)
        # (TE = -d / (r_b2 cos(beta_b))) it is a + da + C F - lam d, da = -(te - te0) (L2 - r_b2 cos(beta_b))
        # - te0 (lam - 1) r_b2 cos(beta_b): zero on an involute flank, on a tip edge held at its value
        # at the linearisation (J, the derivative of a, is the flank lever's)
        lam, lev2 = self._levers(S)
        te0 = S.te_unloaded[None, :, None]
        te0 = np.where(np.isfinite(te0), te0, 0.0)
        da = np.where(S.active, -(S.te - te0) * (lev2 - lever) - te0 * (lam - 1.0) * lever, 0.0)
        a = np.where(S.active, -S.te * lever, 0.0)
        P = len(self.free)
        # the Hertz term's relative curvature 1 / R* of the default loaded TCA (each flank's own, LTCA
        # .structure) where the slice's curvature is known, its sensitivity there (else held)
        if S.kappa1 is not None:
            Jk = np.where((np.isfinite(S.kappa1) & np.isfinite(S.kappa2) & S.active)[..., None], Jk, 0.0)
        else:
            Jk = np.zeros_like(Jk)  # (the raw gradients kept as they are)
        return Linearisation(slices=S, structure=st, a=a, J=J[..., :P], Jm=J[..., P:], Jr=Jr, mis=mis,
                             lam=lam, da=da, Jk=Jk), raw

    def _levers(self, S) -> tuple[np.ndarray, np.ndarray]:
        """Per slice (K, N, M): ``lam`` = its lever about the pinion axis over ``r_b1 cos(beta_b)`` and its
        lever about the gear axis [mm] (``SliceSet.lever1/2``; the involute's where missing)."""
        cb = self.ltca.cos_bb
        lever = self.pair.gear.r_b * cb
        ok = S.active
        lam = (np.ones(S.z.shape) if S.lever1 is None
               else np.where(ok & np.isfinite(S.lever1), S.lever1 / (self.pair.pinion.r_b * cb), 1.0))
        lev2 = (np.full(S.z.shape, lever) if S.lever2 is None
                else np.where(ok & np.isfinite(S.lever2), S.lever2, lever))
        return lam, lev2

    # -- the NLP --------------------------------------------------------------------------------
    def _keep(self, lin, sweeps, radius: float) -> list:
        """Per case (T, K, N, M): the active slices the NLP holds at each torque. A slice is left out
        when it stays open for every design within ``radius`` of the linearisation: its separation,
        lowered by the most the design can change it there (``sum_j |J_ij| radius``, twice over), still
        exceeds 1.5 times the largest loaded approach of its case and torque plus the edge margin. The
        trust-region loop evaluates every trial design exactly, so a slice that would close anyway shows
        as a model miss there."""
        out = []
        margin = self.edge_margin or 0.0
        for L, sw in zip(lin, sweeps):
            S = L.slices
            reach = (2.0 * radius * np.sum(np.abs(L.J), axis=-1) if np.isfinite(radius)
                     else np.full(S.z.shape, np.inf))  # no radius: every active slice stays
            keep = []
            for r in sw.results:
                s = (r.te_unloaded[None, :, None] - S.te) * self._levers(S)[1]
                bound = 1.5 * float(np.nanmax(r.delta)) + margin
                with np.errstate(invalid="ignore"):
                    keep.append(S.active & ~(s - reach > bound))
            out.append(np.array(keep))
        return out


def _same_slices(Sp: SliceSet, S: SliceSet, kind: int, idx: tuple) -> tuple[np.ndarray, np.ndarray] | None:
    """Which of the active slices ``idx = (kk, nn, mm)`` of kind ``kind`` of ``S`` the slices ``Sp`` of the same
    design and case on another grid hold alike: the same pair, position angle, node and section, active, of
    that kind, with the same unknowns, bit for bit. Returns the mask over ``idx`` and those slices'
    positions in ``Sp``; None when the grids share no slice layout."""
    if Sp.pairs != S.pairs or Sp.z.shape[2] != S.z.shape[2]:
        return None
    kk, nn, mm = idx
    o = np.argsort(Sp.phi1, kind="stable")
    at = o[np.minimum(np.searchsorted(Sp.phi1[o], S.phi1), Sp.phi1.size - 1)]
    pos = np.where(Sp.phi1[at] == S.phi1, at, -1)[nn]
    hit = pos >= 0
    q = np.where(hit, pos, 0)
    kinds = np.zeros(Sp.z.shape, int) if Sp.edge is None else Sp.edge
    with np.errstate(invalid="ignore"):
        hit &= (Sp.active[kk, q, mm] & (kinds[kk, q, mm] == kind) & (Sp.z[kk, q, mm] == S.z[kk, nn, mm])
                & np.all(Sp.w[kk, q, mm] == S.w[kk, nn, mm], axis=1))
    return hit, q[hit]
