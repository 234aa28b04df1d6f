"""The TCA of many samples in one mapped call (the engine of the robust-design studies).

A sample is one drive as built: both members' surface parameter vectors (design settings, ISO
modification amounts and their manufacturing deviations), a misalignment, and the angular position
deviations of the teeth in mesh (pitch deviations). :class:`TCAKernel` solves one mesh cycle of
every sample of a chunk at once: the anchors of all samples in one mapped solve, the implicit-
function predictions, then all positions x pairs x samples in one mapped solve (compiled C from
the disk cache, :mod:`gearopt.compiled`), continuation within each sample's pair only, and the
per-sample figures:

* ``te_p2p`` [rad]: peak-to-peak of the TE envelope over the cycle (surface contacts on the active
  flanks);
* ``harmonics`` [rad]: amplitudes of the envelope's mesh orders 1..H (DFT over the cycle; NaN when a
  position has no surface contact);
* ``edge_contact``: at some position the highest tangency of the extended surfaces lies off the
  active flank (beyond the face, the tip or the form circle) or no surface contact exists: the real
  contact there is on an edge (Litvin 9.6), which this sweep does not solve;
* ``pattern_at_edge``: a contact ellipse (elastic approach ``delta``) on the active flank reaches
  past a face end or the tip: the bearing contact is truncated;
* the contact pattern on the pinion flank (every pair's contact ellipses over the cycle: the teeth
  are alike): its extent in face position and radius,
  and a count grid (cells of face position x radius) that the studies add up into the
  probability of each flank point being in the pattern.

Pitch deviations are exact rigid-body offsets: pinion tooth k ahead by ``e1`` [rad] is solved at
``phi1 + e1``; gear tooth k ahead by ``e2`` [rad] adds ``e2`` to its gear angle. A chunk's result
depends only on its own samples (no state crosses samples), so any executor gives the same numbers.
"""

from __future__ import annotations

import copy
import math
from typing import TYPE_CHECKING, Sequence

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from ..compiled import MIN_COLUMNS, available, compile_function, mapped
from ..errors import GearoptError, OptionError
from ..meshing.solver import DELTA_DEFAULT

if TYPE_CHECKING:  # pragma: no cover
    from ..gears import GearPair
    from ..ltca.compliance import Material
    from ..ltca.engine import LTCA
    from ..meshing.tca import TCA

#: iterations of the line-search Newton of the continuation (the TCA's: 100)
SAFE_ITER = 20
#: face-position x radius cells of the pattern count grid
PATTERN_GRID = (48, 32)
#: least number of points along each ellipse's major axis marked in the grid (more: two per cell)
PATTERN_POINTS = 9


def _pattern_function(tca, delta: float) -> ca.Function:
    """(w, prm) -> (radius1, radius2, z_lo, r_lo, z_hi, r_hi, a) [mm]: contact radii on both flanks
    and the ends of the contact ellipse's major axis on the pinion flank (face position, radius)
    with its semi-axis ``a`` for the elastic approach ``delta`` (docs/theory.md section 8)."""
    nw, npr = tca.contact.size1_in(0), tca.contact.size1_in(1)
    w, p = ca.SX.sym("w", nw), ca.SX.sym("p", npr)
    c = tca.contact(w=w, prm=p)
    M = c["K1"] + c["K2"]
    a, b, d = M[0, 0], 0.5 * (M[0, 1] + M[1, 0]), M[1, 1]
    lam = 0.5 * (a + d) - ca.sqrt(0.25 * (a - d) ** 2 + b ** 2)  # smaller eigenvalue: the major axis
    th = 0.5 * ca.atan2(2 * b, a - d)  # direction of the larger one; the major axis is normal to it
    v = ca.vertcat(-ca.sin(th), ca.cos(th))
    semi = ca.sqrt(2 * delta / ca.fmax(lam, 1e-12))
    d1 = ca.mtimes(c["E1"], v)
    r1, r2 = c["r1"], c["r2"]
    lo, hi = r1 - semi * d1, r1 + semi * d1
    rad = lambda q: ca.sqrt(q[0] ** 2 + q[1] ** 2)  # noqa: E731
    out = ca.vertcat(rad(r1), rad(r2), lo[2], rad(lo), hi[2], rad(hi), semi)
    return ca.Function("tca_pattern", [w, p], [out], ["w", "prm"], ["pattern"])


class TCAKernel:
    """One mesh cycle of unloaded TCA for many samples at once; picklable (its CasADi Functions
    serialise), so the studies build it once and ship it to every worker.

    Parameters
    ----------
    tca : gearopt.meshing.tca.TCA
        The drive's TCA (point contact), built with every parameter the samples vary.
    positions : int
        Positions per mesh cycle (evenly spaced, one cycle centred on the pitch point).
    pairs : tuple of int
        Tooth pairs analysed (pinion teeth; 0 is the central pair).
    delta : float
        Elastic approach of the contact ellipse [mm].
    harmonics : int
        Mesh orders reported.
    jit : {"auto", True, False}
        Compiled engine: "auto" compiles when ``n_total`` columns >= MIN_COLUMNS and a compiler
        works. Decided here once, so every chunk runs the same code.
    n_total : int
        Columns of the whole study (samples x positions x pairs).
    pattern_rows : tuple (r_lo, r_hi)
        Radius range of the pattern grid [mm] (default: the pinion's form radius to its tip).
    """

    def __init__(self, tca: TCA, positions: int = 64, pairs: Sequence[int] = (-1, 0, 1), delta: float = DELTA_DEFAULT,
                 harmonics: int = 3, jit: bool | str = "auto", n_total: int | None = None,
                 pattern_rows: int | None = None) -> None:
        if tca.contact_type != "point":
            raise OptionError("the robust-design studies need point contact (a crowned pinion): contact = "
                              f"{tca.contact_type!r}; crown the pinion (a_c, a_pl or ISO C_alpha / C_beta).",
                              param="contact", value=tca.contact_type, valid="'point'")
        if 0 not in pairs:
            raise OptionError(f"pairs = {pairs!r} must include the central pair 0.", param="pairs", value=pairs,
                              valid="pairs including 0")
        pair = tca.pair
        self.layout = tca.layout
        self.positions, self.pairs, self.delta, self.n_harm = int(positions), tuple(pairs), float(delta), int(harmonics)
        z1, z2 = pair.pinion.z, pair.gear.z
        self.z1, self.z2, self.ratio, self.scale2 = z1, z2, z1 / z2, tca.scale2
        self.b1, self.b2 = pair.pinion.b, pair.gear.b
        self.r_a1, self.r_a2 = pair.pinion.r_a, pair.gear.r_a
        self.phi = np.linspace(-math.pi / z1, math.pi / z1, self.positions, endpoint=False)
        self.p1_0, self.p2_0 = np.asarray(tca.pinion.p0, float), np.asarray(tca.gear.p0, float)
        self.guess = np.asarray(tca.guess(), float)
        n_total = n_total if n_total is not None else MIN_COLUMNS
        self.jit = bool(jit) if not isinstance(jit, str) else (n_total >= MIN_COLUMNS and available())
        self.branch = copy.copy(tca.branch)
        self.branch._maps = {}
        self.branch.jit = self.jit
        # The line-search Newton that rescues columns from their solved neighbours stops after
        # SAFE_ITER iterations here (the TCA's allows 100): it runs interpreted, and a column it
        # cannot rescue in SAFE_ITER (a pair far out of mesh) costs ~0.1 s at 100.
        self.branch.rf_safe = ca.rootfinder("tca_newton_mc", "newton", tca.branch.G, {
            "error_on_fail": False, "abstol": 1e-13, "abstolStep": 1e-16, "max_iter": SAFE_ITER, "line_search": True,
            "show_eval_warnings": False})
        self.pattern = _pattern_function(tca, self.delta)
        self.s_grid = np.linspace(0.0, 1.0, 9)  # z^2 / (b/2)^2 of the flank-limit tables
        self.ulim_0 = self.limit_tables(tca, self.p1_0[None, :], self.p2_0[None, :])[0]
        r_lo = tca.form_radius(1) if pattern_rows is None else pattern_rows[0]
        r_hi = self.r_a1 if pattern_rows is None else pattern_rows[1]
        self.grid_z = np.linspace(-self.b1 / 2, self.b1 / 2, PATTERN_GRID[0] + 1)
        self.grid_r = np.linspace(r_lo, r_hi, PATTERN_GRID[1] + 1)

    # -- on the parent side ---------------------------------------------------------------------
    def limit_tables(self, tca: TCA, P1: np.ndarray, P2: np.ndarray) -> np.ndarray:
        """(n, 2, 9) flank-limit tables u_lim(z^2) of both members for each row of P1, P2 (the
        generated flank's end, :meth:`TCA.limit_table`), computed once per distinct vector. An error
        of a row's table (a degenerate flank) is raised with the row as its ``sample`` attribute."""
        out = np.empty((len(P1), 2, self.s_grid.size))
        seen: dict = {}
        for i, (p1, p2) in enumerate(zip(np.asarray(P1, float), np.asarray(P2, float))):
            for m, p in ((0, p1), (1, p2)):
                key = (m, p.tobytes())
                if key not in seen:
                    try:
                        s, u = tca.limit_table(m + 1, p)
                    except GearoptError as e:
                        e.sample = i  # the first row whose flank is degenerate (the studies name it)
                        raise
                    b = self.b1 if m == 0 else self.b2
                    seen[key] = np.interp(self.s_grid * (b / 2) ** 2, s, u) if s.size > 1 else np.full(9, u[0])
                out[i, m] = seen[key]
        return out

    def prepare(self) -> "TCAKernel":
        """Compile (or load from the disk cache) the column Functions in this process, so that
        workers on this machine only load them."""
        if self.jit:
            compile_function(self.branch.one)
            compile_function(self.pattern)
        return self

    @property
    def n_per_sample(self) -> int:
        """Columns solved per sample (positions x pairs)."""
        return self.positions * len(self.pairs)

    # -- anywhere -------------------------------------------------------------------------------
    def evaluate(self, chunk: dict) -> dict:
        """Solve and reduce the samples of ``chunk``.

        Parameters
        ----------
        chunk : dict
            ``p1`` (n, n_p1), ``p2`` (n, n_p2) surface parameter vectors; ``mis`` (n, 4)
            misalignment vectors (``Misalignment.names()`` order, mm / rad); optional ``e1``,
            ``e2`` (n, K) angular position deviations of the pinion / gear teeth of each pair
            [rad]; optional ``ulim`` (n, 2, 9) flank-limit tables (default: the nominal design's);
            optional ``skip`` (n,) bool: samples not to report (e.g. a misalignment that jams the
            teeth): their figures are empty and they count nowhere.

        Returns
        -------
        dict
            Per sample (n,): ``te_p2p`` [rad], ``harmonics`` (n, H) [rad], ``edge_contact``,
            ``pattern_at_edge``, ``ok`` (anchor solved, or its search left the face: then edge
            contact and no TE), ``n_failed`` (columns not converged),
            ``pattern_z`` / ``pattern_r`` (n, 2) extents [mm] (NaN without contact), ``envelope``
            (n, positions) the TE envelope [rad] (its zero: phi2 = 0 of pair 0's solution frame, a
            constant per sample; NaN where no surface contact); and the chunk's ``pattern_count``
            (rows radius, cols face) of samples covering each cell.
        """
        P1, P2, MIS = (np.atleast_2d(np.asarray(chunk[k], float)) for k in ("p1", "p2", "mis"))
        n, K, P = P1.shape[0], len(self.pairs), self.positions
        e1 = np.zeros((n, K)) if chunk.get("e1") is None else np.asarray(chunk["e1"], float)
        e2 = np.zeros((n, K)) if chunk.get("e2") is None else np.asarray(chunk["e2"], float)
        ulim = np.broadcast_to(self.ulim_0, (n, 2, 9)) if chunk.get("ulim") is None else np.asarray(chunk["ulim"])
        lay, br = self.layout, self.branch
        k0 = self.pairs.index(0)

        def prm_of(phis, rows):
            out = np.zeros((lay.size, phis.size))
            out[lay.index("phi1")] = phis
            out[lay.groups["pinion"]] = P1[rows].T
            out[lay.groups["gear"]] = P2[rows].T
            out[lay.groups["mis"]] = MIS[rows].T
            return out

        # anchors: pair 0 at body angle 0 of every sample, from the nominal pitch-point guess
        phi_a = e1[:, k0]
        prm_a = prm_of(phi_a, np.arange(n))
        W_a, res, n1n2, reg = (np.asarray(v) for v in br.mapped(n, n * self.n_per_sample)(
            np.tile(self.guess[:, None], (1, n)), prm_a))
        ok_a = np.asarray(br.accept(res.ravel(), n1n2.ravel(), reg.ravel()), bool)
        skip = np.zeros(n, bool) if chunk.get("skip") is None else np.asarray(chunk["skip"], bool)
        off = np.zeros(n, bool)
        W_a = W_a.copy()
        if not (ok_a | skip).all():  # line-search Newton from the guess where Newton failed
            bad = np.flatnonzero(~ok_a & ~skip)
            Wr, rr, dr, gr = self._safe(bad, prm_a)
            good = np.asarray(br.accept(rr, dr, gr), bool)
            W_a[:, bad[good]] = Wr[:, good]
            ok_a[bad[good]] = True
            # the search ran off the face: no surface contact at the pitch position, the contact is on an edge
            with np.errstate(invalid="ignore"):
                off[bad] = ~good & np.isfinite(Wr[1]) & ((np.abs(Wr[1]) > self.b1 / 2) | (np.abs(Wr[3]) > self.b2 / 2))
        ok_a &= ~skip
        dW = np.asarray(br.dw.map(n)(W_a, prm_a))
        # all columns: sample-major, then pair, then position
        phis = (self.phi[None, None, :] - 2 * math.pi * np.asarray(self.pairs)[None, :, None] / self.z1
                + e1[:, :, None])  # (n, K, P)
        rows = np.repeat(np.arange(n), K * P)
        prm = prm_of(phis.ravel(), rows)
        W0 = W_a[:, rows] + dW[:, rows] * (phis.ravel() - phi_a[rows])[None, :]
        W0[:, ~ok_a[rows]] = self.guess[:, None]
        groups = [np.arange(g * P, (g + 1) * P) for g in range(n * K) if ok_a[g // K]]
        W, res, n1n2, reg, ok, _ = br.solve(W0, prm, groups)
        ok &= ok_a[rows]
        pat = np.asarray(mapped(self.pattern, prm.shape[1], self.jit)(np.where(ok, W, W0), prm))
        out = self._reduce(W, ok, pat, e2, ulim, ok_a)
        out["edge_contact"] |= off  # anchors that left the face: edge contact, no TE
        out["ok"] |= off
        return out

    def _safe(self, cols, prm_a):
        """Line-search Newton from the guess at the anchor columns ``cols``."""
        br = self.branch
        m = max(8, 1 << int(cols.size - 1).bit_length())
        pad = np.concatenate([cols, np.full(m - cols.size, cols[0])])
        W, r, d, g = (np.asarray(v) for v in br._safe_mapped(m)(np.tile(self.guess[:, None], (1, m)), prm_a[:, pad]))
        return W[:, :cols.size], r.ravel()[:cols.size], d.ravel()[:cols.size], g.ravel()[:cols.size]

    def _reduce(self, W, ok, pat, e2, ulim, ok_a) -> dict:
        n, K, P = ok.size // (len(self.pairs) * self.positions), len(self.pairs), self.positions
        shp = lambda a: np.asarray(a).reshape(n, K, P)  # noqa: E731
        ok3 = shp(ok)
        u1, z1, u2, z2 = (shp(W[i]) for i in range(4))
        phi2 = shp(W[4] / self.scale2) + (2 * math.pi * np.asarray(self.pairs) / self.z2)[None, :, None] + e2[:, :, None]
        te = phi2 - self.ratio * self.phi[None, None, :]
        rad1, rad2 = shp(pat[0]), shp(pat[1])
        eps = 1e-9

        def u_lim(m, z, b):
            s = np.clip(np.where(np.isfinite(z), z, 0.0) ** 2 / (b / 2) ** 2, 0.0, 1.0)
            idx = np.clip((s * 8).astype(int), 0, 7)
            t = s * 8 - idx
            tab = ulim[:, m, :][:, None, None, :]
            lo = np.take_along_axis(np.broadcast_to(tab, (n, K, P, 9)), idx[..., None], axis=3)[..., 0]
            hi = np.take_along_axis(np.broadcast_to(tab, (n, K, P, 9)), idx[..., None] + 1, axis=3)[..., 0]
            return lo + t * (hi - lo)

        with np.errstate(invalid="ignore"):
            on = (ok3 & (np.abs(z1) <= self.b1 / 2 + eps) & (np.abs(z2) <= self.b2 / 2 + eps)
                  & (rad1 <= self.r_a1 + eps) & (rad2 <= self.r_a2 + eps)
                  & (u1 <= u_lim(0, z1, self.b1) + 1e-8) & (u2 <= u_lim(1, z2, self.b2) + 1e-8))
        te_on = np.where(on, te, -np.inf)
        env = te_on.max(axis=1)  # (n, P)
        has = np.isfinite(env)
        te_any = np.where(ok3, te, -np.inf)
        drv = te_any.argmax(axis=1)
        drv_on = np.take_along_axis(on, drv[:, None, :], axis=1)[:, 0, :]
        edge = (~has | ~drv_on).any(axis=1) & ok_a
        envn = np.where(has, env, np.nan)
        with np.errstate(invalid="ignore"), np.errstate(all="ignore"):
            p2p = np.where(has.any(axis=1), np.nanmax(np.where(has, env, -np.inf), axis=1)
                           - np.nanmin(np.where(has, env, np.inf), axis=1), np.nan)
        spec = np.fft.rfft(np.where(has, env, 0.0), axis=1) * 2 / P
        harm = np.abs(spec[:, 1:self.n_harm + 1])
        harm[~has.all(axis=1)] = np.nan
        # the pattern on the pinion flank: every pair's contacts (the teeth are alike) over the cycle
        zlo, rlo, zhi, rhi = (shp(pat[i]) for i in (2, 3, 4, 5))
        at_edge = (on & ((np.maximum(np.abs(zlo), np.abs(zhi)) > self.b1 / 2) | (np.maximum(rlo, rhi) > self.r_a1))
                   ).any(axis=(1, 2))
        zs = np.stack([zlo, z1, zhi])
        rs = np.stack([rlo, rad1, rhi])
        mask = np.broadcast_to(on, zs.shape)
        with np.errstate(invalid="ignore"):
            pz = np.stack([np.where(mask, zs, np.inf).min(axis=(0, 2, 3)),
                           np.where(mask, zs, -np.inf).max(axis=(0, 2, 3))], 1)
            pr = np.stack([np.where(mask, rs, np.inf).min(axis=(0, 2, 3)),
                           np.where(mask, rs, -np.inf).max(axis=(0, 2, 3))], 1)
        none = ~on.any(axis=(1, 2))
        pz[none], pr[none] = np.nan, np.nan
        pz = np.clip(pz, -self.b1 / 2, self.b1 / 2)
        pr = np.clip(pr, self.grid_r[0], self.r_a1)
        count = self._count(on.reshape(n, K * P), *(a.reshape(n, K * P) for a in (zlo, rlo, zhi, rhi)))
        return {"te_p2p": p2p, "harmonics": harm, "edge_contact": edge, "pattern_at_edge": at_edge, "ok": ok_a.copy(),
                "n_failed": (~ok3).sum(axis=(1, 2)), "pattern_z": pz, "pattern_r": pr, "pattern_count": count,
                "envelope": envn}

    def _count(self, c_on, zlo, rlo, zhi, rhi) -> np.ndarray:
        """Samples whose pattern (the major axes of their contact ellipses) covers each cell: each
        axis marked at points two per cell along it."""
        nz, nr = PATTERN_GRID
        n = c_on.shape[0]
        s_idx, c_idx = np.nonzero(c_on & np.isfinite(zlo) & np.isfinite(rlo) & np.isfinite(zhi) & np.isfinite(rhi))
        mark = np.zeros((n, nr * nz), bool)
        if s_idx.size:
            dz, dr = (self.grid_z[-1] - self.grid_z[0]) / nz, (self.grid_r[-1] - self.grid_r[0]) / nr
            z0, r0 = zlo[s_idx, c_idx], rlo[s_idx, c_idx]
            dzs, drs = zhi[s_idx, c_idx] - z0, rhi[s_idx, c_idx] - r0
            span = np.abs(dzs) / dz + np.abs(drs) / dr
            pts = int(min(max(PATTERN_POINTS, 2 * span.max() + 2), 4 * (nz + nr)))
            t = np.linspace(0.0, 1.0, pts)[None, :]
            iz = np.floor((z0[:, None] + dzs[:, None] * t - self.grid_z[0]) / dz).astype(np.int64)
            ir = np.floor((r0[:, None] + drs[:, None] * t - self.grid_r[0]) / dr).astype(np.int64)
            m = (iz >= 0) & (iz < nz) & (ir >= 0) & (ir < nr)
            mark[np.broadcast_to(s_idx[:, None], iz.shape)[m], (ir * nz + iz)[m]] = True
        return mark.sum(axis=0).reshape(nr, nz)


class LTCAKernel:
    """Loaded TCA of each sample at its own torque over one mesh cycle (:class:`~gearopt.ltca.LTCA`
    with the analytical compliance): loaded TE peak-to-peak and first harmonic, peak Hertz pressure
    of the flank contact, largest tip-edge load share and mean mesh stiffness.

    Picklable as a recipe (the pair, the side, the options): each process builds its LTCA once, on
    its first chunk (the loaded engine's Functions are built from the gear data; about 1 s), and
    keeps it for every later chunk.

    Parameters
    ----------
    pair : GearPair
    phi : ndarray (N,)
        Pinion angles of the cycle [rad] (the unloaded kernel's).
    pairs : tuple of int
    deviation_mod : bool
        Build the pinion with the study's relative deviation modification (``dev``) so that the
        parameter vectors of the chunks fit.
    side : str
    n_slices : int
    material : Material, optional
    """

    def __init__(self, pair: GearPair, phi: ArrayLike, pairs: Sequence[int] = (-1, 0, 1), deviation_mod: bool = False,
                 side: str = "right", n_slices: int = 21, material: Material | None = None, n_harm: int = 3) -> None:
        self.pair, self.phi, self.pairs = pair, np.asarray(phi, float), tuple(pairs)
        self.deviation_mod, self.side, self.n_slices, self.material = deviation_mod, side, int(n_slices), material
        self.n_harm = int(n_harm)
        self._ltca = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_ltca"] = None
        return state

    def engine(self) -> LTCA:
        """The LTCA of this process (built on first use)."""
        if self._ltca is None:
            from ..geometry.microgeometry import modified_tooth
            from ..ltca import LTCA
            from ..meshing.tca import TCA
            pinion = modified_tooth(self.pair, "pinion")
            if self.deviation_mod:
                from .deviation import deviation_modification
                pinion = pinion.with_modification(deviation_modification(self.pair)[0])
            tca = TCA(self.pair, side=self.side, pinion=pinion, contact="point")
            self._ltca = LTCA(self.pair, side=self.side, material=self.material, n_slices=self.n_slices, tca=tca)
        return self._ltca

    def evaluate(self, chunk: dict) -> dict:
        """Per sample of ``chunk`` (keys of :meth:`TCAKernel.evaluate` plus ``torque`` (n,) [N m]):
        ``loaded_te_p2p`` [rad], ``loaded_harmonics`` (n, H) [rad], ``p_max`` [MPa],
        ``edge_share_max``, ``stiffness_mean`` [N/um], ``loaded_ok``. A sample whose loaded solve
        fails (no contact on the flanks, a solver failure) has empty figures and ``loaded_ok``
        False."""
        from ..errors import ConvergenceError, GeometryError
        from ..meshing.misalignment import Misalignment

        P1, P2, MIS = (np.atleast_2d(np.asarray(chunk[k], float)) for k in ("p1", "p2", "mis"))
        n, K = P1.shape[0], len(self.pairs)
        e1 = np.zeros((n, K)) if chunk.get("e1") is None else np.asarray(chunk["e1"], float)
        e2 = np.zeros((n, K)) if chunk.get("e2") is None else np.asarray(chunk["e2"], float)
        skip = np.zeros(n, bool) if chunk.get("skip") is None else np.asarray(chunk["skip"], bool)
        T = np.asarray(chunk["torque"], float)
        out = {"loaded_te_p2p": np.full(n, np.nan), "loaded_harmonics": np.full((n, self.n_harm), np.nan),
               "p_max": np.full(n, np.nan), "edge_share_max": np.full(n, np.nan),
               "stiffness_mean": np.full(n, np.nan), "loaded_ok": np.zeros(n, bool)}
        lt = self.engine()
        for i in range(n):
            if skip[i]:
                continue
            try:
                sw = lt.solve(float(T[i]), phi1=self.phi, p1=P1[i], p2=P2[i], mis=Misalignment(*MIS[i]),
                              pairs=self.pairs, offsets=(e1[i], e2[i]))
            except (ConvergenceError, GeometryError):
                continue
            except OptionError as e:  # beyond the model's range of validity (ltca.validity.check_validity)
                e.sample = int(chunk.get("first", 0)) + i  # the study names the sample and its inputs
                raise
            r = sw.results[0]
            te = np.asarray(r.te_loaded, float)
            if not np.all(np.isfinite(te)):
                continue
            out["loaded_te_p2p"][i] = te.max() - te.min()
            out["loaded_harmonics"][i] = np.abs(np.fft.rfft(te) * 2 / te.size)[1:self.n_harm + 1]
            out["p_max"][i] = r.p_max
            out["edge_share_max"][i] = float(np.max(r.edge_share))
            out["stiffness_mean"][i] = float(np.mean(r.stiffness))
            out["loaded_ok"][i] = True
        return out
