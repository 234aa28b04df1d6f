"""Loaded tooth contact analysis (docs/ltca.md): load sharing, loaded TE, contact pressure and mesh
stiffness of a spur or helical drive with its modifications and misalignments.

At each pinion angle the slices of every tooth pair (:mod:`gearopt.ltca.slices`) carry point loads
``F_i >= 0`` along the contact normal; with the compliance matrix ``C`` (:mod:`gearopt.ltca.compliance`)
and the unloaded separations ``s`` the gaps are ``g = s + C F - lam delta`` and the contact conditions
``F >= 0, g >= 0, F g = 0, sum lam F = W`` (W = T / (r_b1 cos(beta_b)); ``lam_i`` each force's own
lever about the pinion axis over ``r_b1 cos(beta_b)``, 1 on an involute flank, less on a tip edge)
are the optimality conditions of the convex QP

    min_F  1/2 F^T C F + s^T F    s.t.  F >= 0,  sum lam F = W,

whose equality multiplier is the loaded approach ``delta`` [mm] (the pinion's rigid advance along the
flank contact normal). The primal-dual active-set method solves it at every position at once
(:func:`~gearopt.ltca.contact_qp.contact_active_set`; qpOASES, CasADi's conic plugin, where that does not settle); the Hertz
part of C depends on the load (Weber's logarithm), so the QP is re-solved with the Hertz approach
linearised at the last loads (a Newton step, tangent by AD) until the loads stop changing (the
nonlinear contact law holds at the solution). Each solution is checked against the contact
conditions (``kkt_error_mm``).

Loaded TE = unloaded TE - delta / (r_b2 cos(beta_b)) [rad] (the gear lags); at zero load
delta = 0 and the loaded TE is the unloaded TE of the slices, which at the point contact equals
the TCA's (the grid of each pair passes through its unloaded point contact).

:class:`LTCA` (here) builds the slices and the contact structure and solves each torque; the contact QP
and its Hertz fixed point are in :mod:`gearopt.ltca.contact_qp`, the results in
:mod:`gearopt.ltca.loaded_result`, the model's range of validity in :mod:`gearopt.ltca.validity`.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING, Any
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from ..contact.hertz import C_PRIME_STEEL
from ..errors import ArgumentError, ConvergenceError, OptionError, check_number, out_of_range
from ..gears import GearPair
from ..meshing.misalignment import Misalignment
from ..meshing.tca import TCA
from ..settings import LTCASettings
from .compliance import Material, ToothCompliance, body_coupling_length, face_matrix_batch, weber_contact
from .contact_qp import (HERTZ_MAX_ITER, QP_METHOD, CompliancePart, ContactQP, ContactStructure,
                         row_median)
from .loaded_result import LoadedResult, LoadedSweep
from .neighbours import NeighbourTerm, cross_blocks
from .slices import SliceSet, SliceSolver
from .validity import check_validity

if TYPE_CHECKING:
    from ..fea.influence import InfluenceGrid
    from ..fea.mesh import MeshOptions

EDGE_RADIUS = 0.05  #: rounding of an unrelieved tip edge [m_n]: the Hertz radius of a tip-edge slice
EDGE_GUESS = 2.0  #: first QP round: tip edges within this many times the ISO-estimated approach
OUTER_MAX = 10  #: QP rounds that add tip-edge slices found closed after a solve
KKT_ADD_TOL = 1e-12  #: a left-out slice whose gap falls below the approach by more than this [mm] is added
F_MIN_SHARE = 1e-3  #: Weber's logarithm uses at least this share of the mean line load


class LTCA(ContactQP):
    """Loaded tooth contact analysis of a gear pair (build once, solve many torques).

    Parameters
    ----------
    pair : GearPair
    settings : gearopt.settings.LTCASettings, optional
        ``side``, ``n_slices``, ``coupling``, ``compliance``, ``curvature``, ``body_coupling``, ``body``,
        ``helical`` as one object; keyword arguments replace its fields. Their defaults and ranges are declared there only.
    side : {"right", "left"}
        Driving flank of the pinion.
    material : Material
        Elastic constants (both members).
    n_slices : int
        Slices across the face (grid spacing b / (n_slices - 1); the face ends are slices too).
    r_int : (float, float), optional
        Inner radii of the pinion and gear bodies [mm] (default: half the root radius, a solid
        gear on its shaft).
    coupling : float, optional
        Coupling length of the teeth's slices across the face [mm] (bending, shear, compression;
        default: half the tooth height of the pinion, (r_a - r_f) / 2).
    body_coupling : float, optional
        Coupling length of the gear bodies' term (Sainsot's foundation) across the face [mm], both
        members (default: each member's :func:`~gearopt.ltca.compliance.body_coupling_length`).
    tca : TCA, optional
        The unloaded TCA (default: point contact with the members' modifications).
    compliance : {"analytical", "fe"}
        Tooth compliance: the analytical thin-slice model, or influence coefficients of each member's
        CalculiX model (:func:`gearopt.fea.influence.influence_grid`, cached on disk; right flank),
        with the same Weber-Banaschek contact term.
    fe_mesh : MeshOptions, optional
        Member mesh of the FE influence coefficients (default: that of ``influence_grid``).
    body : {"full_gear_fit", "sainsot2004"}
        The gear body's term of the analytical compliance (:class:`~gearopt.ltca.compliance.ToothCompliance`):
        Sainsot's form refitted to FE full gears held at their bores (default), or Sainsot, Velex &
        Duverger's 2004 coefficients.
    helical : {"normal", "transverse"}
        A helical member's slice compliance along the normal (per unit face width): the teeth's
        (bending, shear, compression) ``cos(beta_b)`` times the transverse slice's and the body's once
        the transverse term (default; the FE full gears of docs/ltca.md section 7), or both
        ``cos^2(beta_b)`` times it (the projection of the transverse slice, the model before 2026-11-29).
    neighbours : {"auto", "full_gear", "none"}, optional
        The coupling of the pairs in mesh through the gear bodies: a load on one tooth moves the teeth
        ``d`` pitches away by :class:`~gearopt.ltca.neighbours.NeighbourTerm` (fitted to FE full gears held
        at their bores, docs/ltca.md section 7; analytical compliance only), or the pairs are not coupled
        ("none"); "auto" (default): "full_gear" with the analytical compliance, "none" with FE influence
        coefficients (their members' own models). :attr:`neighbours` is the one in use.
    curvature : {"surface", "involute"}
        The flanks' curvature across the contact line in the Hertz term: each modified surface's own
        at the slice's point (by AD; profile crowning, reliefs and their smooth starts raise it), or
        the unmodified involute's ``cos(beta_b) / rho_t`` (for comparison only: it misses the
        reliefs' starts; the loaded micro-geometry optimiser uses the surface's).
    """

    def __init__(self, pair: GearPair, settings: LTCASettings | None = None, *, material: Material | None = None,
                 r_int: float | None = None, tca: TCA | None = None, fe_mesh: MeshOptions | None = None,
                 **options: Any):
        # side, n_slices, coupling, compliance, curvature, body_coupling, body, helical: defaults and checks
        # of LTCASettings
        s = LTCASettings.of(settings, **options)
        side, n_slices, coupling, compliance = s.side, s.n_slices, s.coupling, s.compliance
        curvature, body_coupling = s.curvature, s.body_coupling
        self.settings = s
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {pair!r:.60}: expected a gearopt.gears.GearPair.", param="pair", value=pair,
                                valid="a gearopt.gears.GearPair")
        material = material or Material()
        if not isinstance(material, Material):
            raise ArgumentError(f"material = {material!r:.60}: expected a gearopt.ltca.Material (E, nu).",
                                param="material", value=material, valid="a Material")
        t0 = time.perf_counter()
        self.pair, self.material, self.n_slices = pair, material, int(n_slices)
        self.tca = tca or TCA(pair, side=side)
        self.side = self.tca.side
        self.slicer = SliceSolver(self.tca)
        g1, g2 = pair.pinion, pair.gear
        if r_int is None:
            r_int = (0.5 * g1.r_f, 0.5 * g2.r_f)
        self.r_int = tuple(float(check_number(f"{n}.r_int", v, "inner radius of the gear body [mm]"))
                           for n, v in zip(("pinion", "gear"), r_int))
        tk = dict(body=s.body, helical=s.helical)
        self.teeth = (ToothCompliance(self.tca.pinion.unmodified, material, self.r_int[0], member="pinion", **tk),
                      ToothCompliance(self.tca.gear.unmodified, material, self.r_int[1], member="gear", **tk))
        lam = 0.5 * (g1.r_a - g1.r_f) if coupling is None else coupling
        if not 0.0 <= lam <= 10 * g1.b:
            raise out_of_range("coupling", lam, f"0 <= coupling <= {10 * g1.b:g} mm (10 face widths)", cls=OptionError)
        self.coupling_length = float(lam)
        if body_coupling is None:
            self.body_coupling = tuple(body_coupling_length(t) for t in self.teeth)
        else:
            lb = body_coupling
            if not 0.0 <= lb <= 100 * g1.b:
                raise out_of_range("body_coupling", lb, f"0 <= body_coupling <= {100 * g1.b:g} mm (100 face widths)",
                                   cls=OptionError)
            self.body_coupling = (float(lb), float(lb))
        self.cos_bb = math.cos(g1.beta_b)
        self.compliance = compliance
        self.curvature = curvature
        # the pairs' coupling through the bodies (gearopt.ltca.neighbours): a term of the analytical compliance;
        # FE coefficients are their members' own models (3-tooth sectors), without it
        nb = s.neighbours
        if nb == "auto":
            nb = "full_gear" if compliance == "analytical" else "none"
        if nb == "full_gear" and compliance != "analytical":
            raise out_of_range("neighbours", nb, "'none' with compliance = 'fe' (the coupling through the bodies is a "
                               "term of the analytical compliance)", cls=OptionError)
        self.neighbours = nb
        self.neighbour_terms = (tuple(NeighbourTerm.of(tc, t.unmodified) for tc, t in
                                      zip(self.teeth, (self.tca.pinion, self.tca.gear))) if nb == "full_gear" else None)
        self._influence = None
        self._fe_mesh = fe_mesh
        if compliance == "fe" and self.side != "right":
            raise out_of_range("side", self.side, "'right' with compliance = 'fe' (the FE model loads the right "
                               "flank)", cls=OptionError)
        self._qp: dict = {}
        self.build_time = time.perf_counter() - t0

    @property
    def influence(self) -> tuple[InfluenceGrid, InfluenceGrid] | None:
        """The members' FE influence grids (pinion, gear) with ``compliance = "fe"``, else None.
        Computed (CalculiX, or the disk cache) on first use, i.e. by the first solve: building an
        LTCA validates its inputs and runs nothing (``gearopt check`` writes nothing)."""
        if self.compliance != "fe":
            return None
        if self._influence is None:
            from ..fea.influence import influence_grid

            self._influence = tuple(influence_grid(t.unmodified, self.material.E, self.material.nu,
                                                   mesh=self._fe_mesh, r_form=self.tca.form_radius(m))
                                    for m, t in ((1, self.tca.pinion), (2, self.tca.gear)))
        return self._influence

    @influence.setter
    def influence(self, grids: tuple[InfluenceGrid, InfluenceGrid] | None) -> None:
        """Replace the influence grids (pinion, gear) of an ``"fe"`` engine (e.g. without their
        local excess)."""
        self._influence = None if grids is None else tuple(grids)

    # ------------------------------------------------------------------------------------------
    def default_pairs(self) -> tuple[int, ...]:
        """Tooth pairs that can be in mesh over one mesh cycle around phi1 = 0."""
        m = int(math.floor((self.pair.eps_gamma + 1.0) / 2.0 + 0.3))
        return tuple(range(-m, m + 1))

    def mesh_cycle(self, n: int = 64) -> np.ndarray:
        """``n`` pinion angles over one mesh cycle, ``[-pi/z1, pi/z1)`` [rad]."""
        z1 = self.pair.pinion.z
        return np.linspace(-math.pi / z1, math.pi / z1, int(n), endpoint=False)

    def slices(self, phi1: npt.ArrayLike | None = None, p1: npt.ArrayLike | None = None,
               p2: npt.ArrayLike | None = None, mis: Misalignment | None = None, pairs: Sequence[int] | None = None,
               offsets: tuple[npt.ArrayLike, npt.ArrayLike] | None = None) -> SliceSet:
        """Unloaded slices (the separations) at ``phi1`` [rad] (default: one mesh cycle of 64);
        ``offsets``: pitch deviations of the pairs' teeth (:meth:`SliceSolver.solve`)."""
        phi1 = self.mesh_cycle() if phi1 is None else phi1
        pairs = self.default_pairs() if pairs is None else pairs
        return self.slicer.solve(phi1, p1, p2, mis, pairs, self.n_slices, offsets=offsets)

    @staticmethod
    def validate_torques(torque: float | Sequence[float]) -> np.ndarray:
        """The torque(s) [N m] as an array; :class:`OptionError` naming ``torque`` unless each is a
        finite number > 0 and a list strictly increases."""
        try:
            T = np.atleast_1d(np.asarray(torque, dtype=float))
        except (TypeError, ValueError):
            T = None
        if T is None or T.ndim != 1 or T.size == 0 or isinstance(torque, (str, bytes, bool)):
            raise out_of_range("torque", torque, "a pinion torque [N m] > 0 or a strictly increasing list of them",
                               cls=OptionError)
        for v in T:
            if not (np.isfinite(v) and v > 0):
                raise out_of_range("torque", float(v), "0 < torque < inf [N m] (pinion torque)", cls=OptionError)
        if T.size > 1 and np.any(np.diff(T) <= 0):
            raise out_of_range("torque", T.tolist(), "a strictly increasing list of pinion torques [N m]",
                               cls=OptionError)
        return T

    def structure(self, S: SliceSet) -> ContactStructure:
        """The load-independent parts of the contact problem of the slices ``S``: the tooth and body
        compliance matrices per position and the Hertz data per slice node
        (:class:`ContactStructure`)."""
        g1, g2 = self.pair.pinion, self.pair.gear
        K, N, M = S.z.shape
        cb = self.cos_bb

        def tooth_frame(r, n, zsec, gear):
            # rotate each section's tooth back onto +y (helix: the section z is turned by sigma z tan(beta) / r_p)
            ang = -gear.helix_sign * np.tan(gear.beta) / gear.r_p * zsec if not gear.is_spur else np.zeros_like(zsec)
            c, s = np.cos(ang), np.sin(ang)
            rot = lambda v: np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)  # noqa: E731
            return rot(r), rot(n)

        used = np.isfinite(S.z)
        z1 = np.where(used, S.z, 0.0)
        z2 = np.where(np.isfinite(S.z2), S.z2, z1)
        # each tooth is loaded along the slice force's line of action (at a tip edge the mating flank's
        # normal, not the edge member's own flank normal continued to its tip)
        xy1, n1 = tooth_frame(S.r1, S.n1 if S.nc1 is None else S.nc1, z1, g1)
        xy2, n2 = tooth_frame(S.r2, S.n2 if S.nc2 is None else S.nc2, z2, g2)
        c1 = self.teeth[0].per_width(xy1.reshape(-1, 2), n1.reshape(-1, 2))
        c2 = self.teeth[1].per_width(xy2.reshape(-1, 2), n2.reshape(-1, 2))
        act = S.active

        def filled(c):  # inactive or degenerate nodes: the mean of the active ones (they carry no load)
            c = c.reshape(K, N, M)
            ok = np.where(act & np.isfinite(c) & (c > 0), c, np.nan)
            return np.where(np.isfinite(ok), ok, np.nanmean(ok) if np.isfinite(ok).any() else 1e-4)

        ct = filled(c1.total + c2.total)
        # the tooth (bending, shear, compression of both teeth) and each member's body (Sainsot's term),
        # coupled across the face over their own lengths (compliance.face_matrix_batch)
        parts = [(filled(c1.total - c1.foundation + c2.total - c2.foundation), self.coupling_length),
                 (filled(c1.foundation), self.body_coupling[0]), (filled(c2.foundation), self.body_coupling[1])]
        rad1 = np.hypot(S.r1[..., 0], S.r1[..., 1])
        rad2 = np.hypot(S.r2[..., 0], S.r2[..., 1])
        # bending/shear/foundation matrix of each pair over the used nodes: cos^2(beta_b) D A^-1 D
        # (analytical), or both members' FE influence coefficients at the slices' points
        Cs = np.zeros((N, K * M, K * M))
        if self.influence is not None:
            G1, G2 = self.influence
            for k in range(K):
                for n in range(N):
                    u = np.flatnonzero(used[k, n])
                    idx = k * M + u
                    Cs[n][np.ix_(idx, idx)] = (G1.matrix(rad1[k, n, u], z1[k, n, u])
                                               + G2.matrix(rad2[k, n, u], z2[k, n, u]))
        else:
            # the face coupling on the tooth's own widths (the slices fixed to the tooth), not the contact's
            wt = S.width if S.width_tooth is None else S.width_tooth
            blocks = cb**2 * face_matrix_batch(S.z.reshape(K * N, M), wt.reshape(K * N, M),
                                               [(c.reshape(K * N, M), lam) for c, lam in parts]).reshape(K, N, M, M)
            Cv = Cs.reshape(N, K, M, K, M)
            for k in range(K):
                Cv[:, k, :, k, :] = blocks[k]
            if self.neighbour_terms is not None:
                # the pairs coupled through the bodies (docs/ltca.md section 2, gearopt.ltca.neighbours (N1))
                Cs = cross_blocks(Cs, S.pairs, (np.where(used, S.z, np.nan), np.where(used, z2, np.nan)), wt,
                                  self.neighbour_terms, self.body_coupling, cb)
        # Hertz data per node: reduced radius across the contact line, depths to the centrelines, line
        # length. The curvature of each flank is its own surface's at the point (SliceSet.kappa: profile
        # crowning, reliefs and every modification change it); the involute's cos(beta_b) / rho_t where
        # that is missing, a tip edge's rounding radius on an edge
        k1 = np.sqrt(np.maximum(rad1**2 - g1.r_b**2, 1e-12)) ** -1 * cb
        k2 = np.sqrt(np.maximum(rad2**2 - g2.r_b**2, 1e-12)) ** -1 * cb
        if S.kappa1 is not None and self.curvature == "surface":
            k1 = np.where(np.isfinite(S.kappa1), S.kappa1, k1)
            k2 = np.where(np.isfinite(S.kappa2), S.kappa2, k2)
        if S.edge is not None:
            k1 = np.where(S.edge == 1, 1.0 / (EDGE_RADIUS * g1.m_n), k1)
            k2 = np.where(S.edge == 2, 1.0 / (EDGE_RADIUS * g2.m_n), k2)
        R = 1.0 / np.maximum(k1 + k2, 1e-6)  # (a flat or concave-convex pair beyond: 1 m)
        h1 = c1.h.reshape(K, N, M)
        h2 = c2.h.reshape(K, N, M)
        if self.influence is not None:
            # FE coefficients: the local compression of each member's actual tooth section from FE, Weber's
            # bracket + kappa = ln(2 h e^kappa / b_H) (gearopt.fea.local, docs/ltca.md section 5), on the flank
            # slices; the depth measured in the plane across the contact line, where the local problem is
            # plane strain: the transverse depth h projects to h cos(beta_b) there
            flank = np.ones((K, N, M), bool) if S.edge is None else S.edge == 0
            G1, G2 = self.influence
            h1 = np.where(flank, h1 * cb * np.exp(G1.local_excess(rad1)), h1)
            h2 = np.where(flank, h2 * cb * np.exp(G2.local_excess(rad2)), h2)
        length = S.width / cb
        return ContactStructure(Cs=Cs, parts=tuple(CompliancePart(c, lam) for c, lam in parts),
                                R=np.where(act, R, 1.0), h1=np.where(act, h1, 1.0), h2=np.where(act, h2, 1.0),
                                length=np.where(act, length, 1.0), radius1=rad1, radius2=rad2, ct=ct)

    def solve(self, torque: float | Sequence[float], phi1: npt.ArrayLike | None = None, p1: npt.ArrayLike | None = None,
              p2: npt.ArrayLike | None = None, mis: Misalignment | None = None, pairs: Sequence[int] | None = None,
              slices: SliceSet | None = None, offsets: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
              structure: ContactStructure | None = None) -> LoadedSweep:
        """Loaded TCA at one or several pinion torques.

        Parameters
        ----------
        torque : float or sequence of float
            Pinion torque(s) [N m], each > 0 and finite; a list must be strictly increasing.
        phi1 : array_like, optional
            Pinion angles [rad] (default: one mesh cycle of 64 positions).
        p1, p2, mis, pairs
            As :meth:`TCA.sweep` (default pairs: every pair that can mesh in the cycle).
        slices : SliceSet, optional
            Precomputed unloaded slices (:meth:`slices`) of the same positions and design.
        offsets : (e1, e2), optional
            Angular position deviations of the pinion and gear teeth of each pair [rad] (pitch
            deviations, :meth:`SliceSolver.solve`).
        structure : ContactStructure, optional
            :meth:`structure` of ``slices``, computed already (the loaded micro-geometry optimiser's
            linearisation holds it); only with ``slices``.

        Returns
        -------
        LoadedSweep
        """
        T = self.validate_torques(torque)
        if structure is not None and (slices is None or not isinstance(structure, ContactStructure)):
            raise ArgumentError("structure: LTCA.structure of the slices given as slices= (a ContactStructure), "
                                "and only with slices.", param="structure", value=type(structure).__name__,
                                valid="a ContactStructure of slices=")
        t0 = time.perf_counter()
        S = slices if slices is not None else self.slices(phi1, p1, p2, mis, pairs, offsets)
        t_sep = time.perf_counter() - t0
        st = structure if structure is not None else self.structure(S)
        results = []
        for t in T:  # each torque's first contact set: the previous torque's (a warm start)
            results.append(self._solve_one(float(t), S, st, start=results[-1] if results else None))
        return LoadedSweep(slices=S, results=results, separation_time=t_sep, structure=st,
                           te_zero_rad=S.phi2_ref, ltca=self)

    def _solve_one(self, torque: float, S: SliceSet, st: ContactStructure,
                   start: LoadedResult | None = None) -> LoadedResult:
        t0 = time.perf_counter()
        g1, g2 = self.pair.pinion, self.pair.gear
        cb = self.cos_bb
        K, N, M = S.z.shape
        n = K * M
        W = torque * 1e3 / (g1.r_b * cb)  # normal load [N]
        act = S.active
        te0 = S.te_unloaded  # (N,)
        has = np.isfinite(te0)
        if not has.all():
            bad = S.phi1[~has]
            raise ConvergenceError(f"loaded TCA: no tooth pair in contact at {bad.size} of {N} positions (e.g. phi1 = "
                                   f"{bad[0]:.6g} rad): the positions must lie where the pair meshes.",
                                   param="phi1", value=float(bad[0]))
        lever = g2.r_b * cb
        # each slice's force acts along its own line of action (SliceSet.nc1): the gear turned back by
        # te0 - te closes the slice's gap by that angle times its lever about the gear axis, and the
        # pinion torque is the sum of the forces times their levers about the pinion axis,
        # sum lam_i F_i = W, lam_i = lever1_i / (r_b1 cos(beta_b)) (1 on an involute flank, less on a
        # tip edge); the equality's multiplier delta is the pinion's rigid advance times r_b1 cos(beta_b)
        lev2 = lever if S.lever2 is None else np.where(act & np.isfinite(S.lever2), S.lever2, lever)
        lam = (np.ones(S.z.shape) if S.lever1 is None
               else np.where(act & np.isfinite(S.lever1), S.lever1 / (g1.r_b * cb), 1.0))
        s = np.where(act, (te0[None, :, None] - S.te) * lev2, 0.0)  # (K, N, M) [mm]
        s = np.transpose(s, (1, 0, 2)).reshape(N, n)
        lam = np.transpose(lam, (1, 0, 2)).reshape(N, n)
        A = np.transpose(act, (1, 0, 2)).reshape(N, n)
        f_min = F_MIN_SHARE * W * cb / g1.b
        hz = st.by_position()
        length, R, h1, h2 = hz.length, hz.R, hz.h1, hz.h2
        # Working set: the flank slices and the tip-edge slices near contact; every other active
        # slice is checked after the solve (its gap s + C F must not fall below the approach) and
        # added if it would take load, then the QP is solved again. The result is the QP over all
        # active slices; the working set only keeps far-open tip edges out of the dense QP.
        A_all = A
        edge = (np.zeros(A.shape, bool) if S.edge is None
                else np.transpose(S.edge > 0, (1, 0, 2)).reshape(N, n))
        # first round: the tip edges within twice the approach that ISO 6336-1's c' = 14 N/(mm um)
        # (steel, scaled by E) suggests; the check below makes the result independent of this guess
        guess = EDGE_GUESS * W / (C_PRIME_STEEL * self.material.E / 210000.0 * g1.b)
        A = A_all & (~edge | (s <= guess))
        Cs = st.Cs
        F = None
        # the active-set method's first contact set: the slices loaded at the previous torque (the QP's
        # solution does not depend on it)
        P0 = None if start is None else np.transpose(start.load > 0, (1, 0, 2)).reshape(N, n)
        for _outer in range(OUTER_MAX):
            F, done, change, it = self._fixed_point(A, s, hz, Cs, W, f_min, F0=F, lam=lam, block=M, P0=P0)
            if not done.all():
                raise ConvergenceError(f"loaded TCA at {torque:g} N m: the Hertz fixed point did not settle in "
                                       f"{HERTZ_MAX_ITER} QP solves at {int((~done).sum())} positions (largest load "
                                       f"change {float(np.max(change)):.3g} W).", param="torque", value=torque)
            # s + C F [mm] with the final compliance: no load (no Hertz term) outside the working set
            cH, bH, p0 = weber_contact(F / length, R, h1, h2, self.material, f_min)
            d = s + np.einsum("nij,nj->ni", Cs, F) + np.where(A, cH / length * F, 0.0)
            loaded = A & (F > 1e-9 * W)
            delta = row_median(np.where(loaded, d / lam, np.nan))
            add = A_all & ~A & (d < np.where(np.isfinite(delta), delta, np.inf)[:, None] * lam - KKT_ADD_TOL)
            if not add.any():
                break
            A = A | add
        else:
            raise ConvergenceError(f"loaded TCA at {torque:g} N m: the set of loaded tip edges did not settle in "
                                   f"{OUTER_MAX} QP rounds.", param="torque", value=torque)
        # the contact conditions over every active slice (the gaps d above are those of the full QP)
        err_on = np.where(loaded, np.abs(d - delta[:, None] * lam), 0.0).max(axis=1)
        err_off = np.where(A_all & ~loaded, np.maximum(delta[:, None] * lam - d, 0.0), 0.0).max(axis=1)
        kkt = np.maximum(err_on, err_off)
        sum_err = np.abs((lam * F).sum(axis=1) - W) / W
        if not np.all(np.isfinite(delta)) or np.any(sum_err > 1e-6):
            raise ConvergenceError(f"loaded TCA at {torque:g} N m: the contact QP failed (load balance error "
                                   f"{float(np.nanmax(sum_err)):.3g} W).", param="torque", value=torque)
        back = lambda a: np.transpose(a.reshape(N, K, M), (1, 0, 2))  # noqa: E731
        Fk = back(F)
        te_l = te0 - delta / lever
        pair_load = Fk.sum(axis=2)
        lam_k = back(lam)
        width = np.where(S.width > 0, S.width, np.nan)
        p0_k, bH_k = (np.where(back(A_all), back(v), 0.0) for v in (p0, bH))
        if S.partner_of is not None and (S.partner_of >= 0).any():
            # a partner (a node past the flank boundary, SliceSet.active) carries its share of the contact
            # up to the crossing; the pressure there is the linear interpolation from its neighbour on the
            # flanks, p_i + t (p_o - p_i) at the crossing (t: SliceSet.partner_t), so the peak pressure is
            # continuous as the crossing runs to the neighbour (t -> 0) or onto the partner (t -> 1)
            kk, nn, mm = np.nonzero(S.partner_of >= 0)
            ii, t = S.partner_of[kk, nn, mm], S.partner_t[kk, nn, mm]
            for v in (p0_k, bH_k):
                v[kk, nn, mm] = v[kk, nn, ii] + t * (v[kk, nn, mm] - v[kk, nn, ii])
        result = LoadedResult(
            torque=torque, W=W, phi1=S.phi1, pairs=S.pairs, te_unloaded=te0, te_loaded=te_l, delta=delta,
            load=Fk, line_load=np.where(np.isfinite(S.z), Fk / width, np.nan),
            p0=p0_k, b_H=bH_k, pair_load=pair_load,
            share=(lam_k * Fk).sum(axis=2) / W, stiffness=W / delta / 1e3, kkt_error=kkt, hertz_iterations=it,
            solve_time=time.perf_counter() - t0, face_width=g1.b, stats={"qp_solver": QP_METHOD}, edge=S.edge,
            lever=lam_k * g1.r_b * cb)
        check_validity(result, self.pair, self.material)
        return result
