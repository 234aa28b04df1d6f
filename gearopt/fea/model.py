"""Finite element model of a gear drive at one position of the meshing cycle (Litvin section 9.5),
solved with CalculiX: the mesh of both members placed as the TCA places them, the contact sets and the
input deck. The analytic references it is checked against (Hertz, ISO 6336-3) are in
:mod:`gearopt.fea.references`, the result read from the ccx output in :mod:`gearopt.fea.result`.

:class:`GearFEModel` takes a :class:`~gearopt.gears.GearPair` and a pinion angle ``phi1`` (the TCA
convention of :mod:`gearopt.meshing.tca`): the TCA gives the gear angle ``phi2`` with the flanks in
contact and the contact points of each tooth pair; ``teeth`` teeth of each member (mates of each
other) are meshed (:mod:`gearopt.fea.mesh`) and placed in the fixed frame S_f exactly as the TCA
places the surfaces:

    pinion: r_f = Rz(-phi1 + theta1) r_1          gear: r_f = (0, a, 0) + Rz(phi2) Rz(pi + theta2) r_2

A misalignment of the gear (``mis``: centre distance change, crossing and intersecting angles, axial
displacement) places the gear as the TCA does (:meth:`~gearopt.meshing.misalignment.Misalignment.gear_to_fixed`:
the axis turned by ``intersecting`` about x_f, then by ``crossing`` about y_f, the centre moved to
``(0, a + dE, axial)``); the gear is held at its rim in that position, so the pinion's rotation about
its own axis stays the one free degree of freedom.

Pinion tooth k (turned by ``k 2 pi / z1`` in its frame) meshes with gear tooth ``-k``.

Boundary conditions: the gear rim (bottom arc and both sector sides) is fixed; the pinion rim nodes
form a rigid body tied to a reference node on the pinion axis whose rotation about z is the only
free DOF. Step 1 prescribes a rotation in the driving direction that closes the contact (the estimated
loaded approach, :meth:`GearFEModel.approach_estimate`); step 2 releases it (``*BOUNDARY, OP=NEW``) and
applies the torque as a moment on the rotation node (docs/theory.md section 12.3, rule 1); step 3 repeats
the load with the contact faces paired again at the loaded state (docs/fea.md "Solver cost"). Contact:
element-face surfaces on the driving flanks, the gear master and the pinion slave, surface-to-surface
penalty contact with a LINEAR pressure-overclosure slope of ``penalty`` x E (50 E by default, docs/theory.md
section 12.3, rule 2), no ADJUST (rule 3), no friction.

Elements are 8-node hexahedra C3D8 (full integration). C3D8I (incompatible modes) was measured to
cost ~3.4x the equations for no gain in this contact/root-stress problem (docs/theory.md section 12.2), so it is not
offered by default (``element_type`` may still name it).

The torque is in N*mm internally (the scene takes N*m).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import casadi as ca
import numpy as np

from ..errors import ArgumentError, GearoptError, GeometryError, check_number, option_error
from ..gears import GearPair
from ..geometry.frames import rot_z_points
from ..meshing.misalignment import Misalignment
from ..meshing.tca import TCA
from ..settings import FEOptions
from .calculix import Deck, run_ccx
from .mesh import MemberMesh, ToothMesher, build_member, face_of, graded_params
from .references import MESH_STIFFNESS, Hertz, HertzPoint, check_elements, hertz_line, hertz_point
from .result import FEResult

_rotz = rot_z_points  # points (n, 3) about z (gearopt.geometry.frames)


def _face_layers(b: float, n_face: int, z_c: float, h: float, window: float, growth: float) -> np.ndarray:
    """Face layers [mm] graded towards ``z_c`` (size ``h`` within ``window``, growing by ``growth``
    per mm beyond, at most the uniform size ``b / n_face``), one layer on ``z_c``."""
    z_c = float(np.clip(z_c, -b / 2, b / 2))
    lo = graded_params(np.array([0.0, z_c + b / 2]), max(1, round(n_face * (z_c + b / 2) / b)), z_c + b / 2, h,
                        window, growth) - b / 2 if z_c > -b / 2 + 1e-9 else np.array([-b / 2])
    hi = graded_params(np.array([0.0, b / 2 - z_c]), max(1, round(n_face * (b / 2 - z_c) / b)), 0.0, h,
                        window, growth) + z_c if z_c < b / 2 - 1e-9 else np.array([b / 2])
    out = np.concatenate([lo[:-1], [z_c], hi[1:]]) if lo.size > 1 and hi.size > 1 else np.concatenate([lo, hi])
    return np.unique(np.round(out, 12))


def _with_breaks(z, breaks, keep=None) -> np.ndarray:
    """Face layers ``z`` [mm] (increasing, ends included) with a layer on every ``breaks`` value: the
    nearest interior layer moves there when it is within 0.3 of its element's length (no sliver),
    unless it is ``keep`` (the ellipse centre's layer); otherwise a layer is inserted."""
    z = np.array(z, float)
    for e in sorted(breaks):
        if np.min(np.abs(z - e)) < 1e-9:
            continue
        j = int(np.searchsorted(z, e))
        lo, hi = z[j - 1], z[j]
        near = j - 1 if e - lo <= hi - e else j
        movable = 0 < near < len(z) - 1 and (keep is None or abs(z[near] - keep) > 1e-9)
        if movable and abs(z[near] - e) < 0.3 * (hi - lo):
            z[near] = e
        else:
            z = np.insert(z, j, e)
    return z


def model_tca(pair: GearPair, mis: Misalignment | None = None) -> TCA:
    """The TCA that places the FE model's members: right flank driving, line contact for unmodified,
    aligned (or only dE/axially displaced) members, point contact for a crowned pinion or gear or an
    angular misalignment."""
    crowned = any(g.a_pl != 0 or g.rack.a_c != 0 for g in (pair.pinion, pair.gear))
    angular = mis is not None and any(getattr(mis, k) != 0 for k in Misalignment.names("angle"))
    return TCA(pair, side="right", contact="point" if crowned or angular else "line")


class GearFEModel:
    """FE model of ``pair`` at the pinion angle ``phi1`` [rad] (see the module docstring).

    Parameters
    ----------
    pair : GearPair
    phi1 : float
        Pinion angle (TCA convention: 0 = tooth 0's driving flank at the pitch point).
    options : FEOptions
    tca : TCA, optional
        A compiled TCA of the pair (right flank driving); built if omitted (line contact for
        unmodified, aligned members, point contact for a crowned pinion or a misaligned drive).
    mis : Misalignment, optional
        Misalignment of the gear (mm, rad); default aligned. Checked as the TCA checks it (a centre
        distance that jams or separates the teeth, faces that do not overlap: an error naming the key).
    """

    def __init__(self, pair: GearPair, phi1: float, options: FEOptions | None = None, tca: TCA | None = None,
                 mis: Misalignment | None = None) -> None:
        t0 = time.perf_counter()
        if not isinstance(pair, GearPair):
            raise ArgumentError(f"pair = {type(pair).__name__}: expected a gearopt.gears.GearPair.",
                                param="pair", value=pair, valid="a gearopt.gears.GearPair")
        if options is not None and not isinstance(options, FEOptions):
            raise ArgumentError(f"options = {type(options).__name__}: expected an FEOptions.",
                                param="options", value=options, valid="an FEOptions")
        if mis is not None and not isinstance(mis, Misalignment):
            raise ArgumentError(f"mis = {type(mis).__name__}: expected a gearopt.meshing.misalignment.Misalignment.",
                                param="mis", value=mis, valid="a Misalignment")
        self.pair, self.phi1 = pair, check_number("phi1", phi1, "a finite pinion angle [rad]")
        self.opt = options or FEOptions()
        self.mis = mis or Misalignment()
        self.mis.check(pair, "mis")
        misaligned = bool(np.any(self.mis.vector() != 0))
        if tca is None:
            tca = model_tca(pair, self.mis)
        if tca.side != "right":
            raise option_error("tca.side", tca.side, "'right' (the FE model drives on the pinion's right flank)")
        self.tca = tca
        o = self.opt
        g1, g2 = pair.pinion, pair.gear
        n = o.teeth
        self.tooth_ids = list(range(-(n // 2), n - n // 2))
        res = tca.sweep(np.array([self.phi1]), pairs=self.tooth_ids, mis=self.mis if misaligned else None)
        on = res.on_surface[:, 0]
        if not on.any():
            why = "choose phi1 within the meshing cycle"
            if misaligned:
                why += (f", or a smaller misalignment ({self.mis.label()}): under it the contact may leave the "
                        "flanks (edge contact at a face end or a tip, which the FE model does not place); crowning "
                        "the pinion keeps the contact on the flanks")
            raise GeometryError(f"FE model at phi1 = {self.phi1:.6g} rad: no tooth pair of the {n} modelled is in "
                                f"contact on the active flanks (TCA); {why}.", param="phi1", value=self.phi1)
        self.phi2 = float(np.nanmax(np.where(on, res.phi2[:, 0], np.nan)))
        gap = (self.phi2 - res.phi2[:, 0]) * pair.gear.r_b  # separation of each pair along the line of action
        # pairs that the load can close: within twice the estimated loaded approach (ISO 6336-1 c'), at
        # least 5 um; their contact zones are graded (a coarse faceted flank would keep them open)
        reach = max(5e-3, 2.0 * o.torque / g1.r_b / (MESH_STIFFNESS * min(g1.b, g2.b)))
        self.loaded = [k for k, o_, gp in zip(self.tooth_ids, on, gap) if o_ and gp < reach]
        if not (g1.is_spur and g2.is_spur):  # inclined contact lines: a pair may touch off the middle section
            self.loaded = sorted(self.loaded + self._helical_reach(reach))
        self.contact = {k: {"u1": float(res.u1[i, 0]), "u2": float(res.u2[i, 0]), "z1": float(res.z1[i, 0]),
                            "z2": float(res.z2[i, 0]),
                            "radius1": float(res.radius1[i, 0]), "radius2": float(res.radius2[i, 0]),
                            "gap": float(gap[i]), "on_surface": bool(on[i])}
                        for i, k in enumerate(self.tooth_ids)}
        self.tca_result = res
        # Hertz reference for the full load on one pair (also sets the contact grading)
        F_n = o.torque / g1.r_b
        self.F_n = F_n
        b_eff = min(g1.b, g2.b)
        self.hertz: dict[int, Hertz] = {}
        cb = math.cos(g1.beta_b)
        point = tca.contact_type == "point"
        for i, k in enumerate(self.tooth_ids):
            if k not in self.loaded or not on[i]:  # the Hertz references: pairs touching in the middle section
                continue
            c = self.contact[k]
            if point and np.isfinite(res.ellipse_a[i, 0]) and np.isfinite(res.ellipse_b[i, 0]):
                # point contact: the Hertz ellipse of the whole normal load on this pair
                lam = (2 * res.delta / res.ellipse_a[i, 0] ** 2, 2 * res.delta / res.ellipse_b[i, 0] ** 2)
                self.hertz[k] = hertz_point(F_n / cb, lam, o.E, o.nu)
                continue
            # line contact in the normal section: load per contact-line length F_bt / b, radii rho_t / cos(beta_b)
            rho1 = math.sqrt(max(c["radius1"] ** 2 - g1.r_b**2, 1e-12)) / cb
            rho2 = math.sqrt(max(c["radius2"] ** 2 - g2.r_b**2, 1e-12)) / cb
            self.hertz[k] = hertz_line(F_n / b_eff, rho1, rho2, o.E, o.nu)
        b_H = min(h.b for h in self.hertz.values())
        mo = o.mesh
        if o.n_hertz > 0 and mo.h_contact == 0:
            mo = replace(mo, h_contact=b_H / o.n_hertz, window=mo.window or 1.5 * b_H)
        # point contact: face layers graded towards the ellipse centre (n_ellipse elements per major semi-axis)
        z_layers = None
        ell = [(self.contact[k]["z1"], self.contact[k]["z2"], h.a) for k, h in self.hertz.items()
               if isinstance(h, HertzPoint)] if o.n_ellipse > 0 else []
        if ell:
            z_c1, z_c2, a_e = min(ell, key=lambda t: abs(t[0]))  # the ellipse centre in each member's frame
            z_layers = {m: _face_layers(g.b, mo.n_face, z_c, a_e / o.n_ellipse, a_e, mo.growth) for m, g, z_c in
                        (("pinion", g1, z_c1), ("gear", g2, z_c2))}
        self.mesh_options = mo
        self.b_H = b_H
        # meshes (member frames), then placement in S_f
        self.pin_tooth = tca.pinion
        self.gear_tooth = tca.gear
        z_layers = dict(z_layers or {})
        # the mate's face ends inside a member's face (unequal face widths, an axial displacement) are
        # layers of that member: the contact ends there, and a layer across it would smear the end of
        # the pattern and its edge pressure over an element (gear frame: z - axial)
        ax = self.mis.axial
        for name, g, ends, keep in (("pinion", g1, (ax - g2.b / 2, ax + g2.b / 2), z_c1 if ell else None),
                                    ("gear", g2, (-g1.b / 2 - ax, g1.b / 2 - ax), z_c2 if ell else None)):
            inner = [e for e in ends if abs(e) < g.b / 2 - 1e-6]
            if inner:
                base = z_layers.get(name)
                z_layers[name] = _with_breaks(np.linspace(-g.b / 2, g.b / 2, mo.n_face + 1) if base is None else base,
                                              inner, keep)
        m1 = ToothMesher(self.pin_tooth, mo, z_layers=z_layers.get("pinion"))
        m2 = ToothMesher(self.gear_tooth, mo, z_layers=z_layers.get("gear"))
        cu1 = {k: self.contact[k]["u1"] for k in self.loaded}
        cu2 = {-k: self.contact[k]["u2"] for k in self.loaded}
        if not (g1.is_spur and g2.is_spur):
            # helical: the contact line is inclined across the face; grade each face layer at its own
            # contact point (the conjugate contact of the aligned, unmodified drive in that section)
            for k in self.loaded:
                lay = self._layer_contact(m1, m2, k)
                if lay is not None:
                    cu1[k], cu2[-k] = lay
        # a pair the load can close but with no contact point to grade at (none in the middle section nor
        # in two face layers): uniform rows on its flanks
        cu1 = {k: v for k, v in cu1.items() if np.all(np.isfinite(v))}
        cu2 = {k: v for k, v in cu2.items() if np.all(np.isfinite(v))}
        first1 = self._first_layer(g1, [self.contact[k]["radius1"] for k in self.loaded], mo)
        first2 = self._first_layer(g2, [self.contact[k]["radius2"] for k in self.loaded], mo)
        self.pinion_mesh = build_member(m1, self.tooth_ids, cu1, "pinion", first1)
        self.gear_mesh = build_member(m2, sorted(-k for k in self.tooth_ids), cu2, "gear", first2)
        self.nodes_pinion = _rotz(self.pinion_mesh.nodes, -self.phi1 + tca.theta1)
        self.nodes_gear = self.place_gear(self.gear_mesh.nodes)
        self.build_time = time.perf_counter() - t0

    def place_gear(self, X: np.ndarray) -> np.ndarray:
        """Points ``X`` (n, 3) of the gear's own frame [mm] placed in the fixed frame S_f at the model's
        gear angle, as the TCA places the gear surface: ``Rz(phi2) Rz(pi + theta2)``, then the
        misalignment (:meth:`Misalignment.gear_to_fixed`)."""
        Xa = _rotz(_rotz(np.asarray(X, float).reshape(-1, 3), math.pi + self.tca.theta2), self.phi2)
        m = self.mis.as_dict()
        R = np.column_stack([np.asarray(Misalignment.gear_to_fixed(m, ca.DM(e), 0.0, False), float).ravel()
                             for e in np.eye(3)])
        return Xa @ R.T + np.array([0.0, self.pair.a_w + self.mis.dE, self.mis.axial])

    def _section_contacts(self, k: int, zs):
        """The line contact of pair k of the aligned, unmodified teeth in the pinion sections ``zs``
        [mm]: (u1, u2, z2, phi2, radius1, radius2) arrays (phi2 with the pair's shift, as the TCA's),
        or None if a section has none."""
        tca, pair = self.tca, self.pair
        if getattr(self, "_lt", None) is None:
            self._lt = TCA(pair, side="right", pinion=tca.pinion.unmodified, gear=tca.gear.unmodified, contact="line")
        lt = self._lt
        lay = tca.layout
        flat1, flat2 = np.zeros(len(tca.pinion.unmodified.param_names)), np.zeros(len(tca.gear.unmodified.param_names))
        flat1[lay.p_index("pinion", "x")] = tca.pinion.p0[lay.p_index("pinion", "x")]
        flat2[lay.p_index("gear", "x")] = tca.gear.p0[lay.p_index("gear", "x")]
        phi = self.phi1 - 2 * math.pi * k / pair.pinion.z
        S1, S2 = tca.pinion.unmodified.surface("right", "flank"), tca.gear.unmodified.surface("right", "flank")
        rows = []
        w = None
        for z in zs:
            try:
                w = lt.solve_point(phi, w, flat1, flat2, None, float(z))
            except GearoptError:
                rows.append((np.nan,) * 6)  # no contact in this section (e.g. below a base circle)
                w = None
                continue
            r1 = np.asarray(S1(w[0], float(z), flat1)[0]).ravel()
            r2 = np.asarray(S2(w[1], w[2], flat2)[0]).ravel()
            rows.append((w[0], w[1], w[2], w[3] / lt.scale2 + 2 * math.pi * k / pair.gear.z, np.hypot(r1[0], r1[1]),
                         np.hypot(r2[0], r2[1])))
        out = tuple(np.array(c, float) for c in zip(*rows))
        return out if np.isfinite(out[0]).any() else None

    def _layer_contact(self, m1: ToothMesher, m2: ToothMesher, k: int):
        """Contact parameters (u1 per pinion layer, u2 per gear layer) of pair k: the line contact of
        the aligned, unmodified teeth in each pinion section (None if a section has none)."""
        sol = self._section_contacts(k, m1.z)
        if sol is None:
            return None
        u1, u2, z2 = sol[:3]
        ok = np.isfinite(u1) & np.isfinite(u2) & np.isfinite(z2)
        if ok.sum() < 2:
            return None
        # sections without a contact (the line runs below a base circle there): the nearest section's
        order = np.argsort(z2[ok])
        return np.interp(m1.z, m1.z[ok], u1[ok]), np.interp(m2.z, z2[ok][order], u2[ok][order])

    def _helical_reach(self, reach: float) -> list:
        """Helical pairs not touching in the middle section whose contact line lies on both active
        flanks in some section within ``reach`` [mm] of closing (they carry load)."""
        pair, tca = self.pair, self.tca
        g1, g2 = pair.pinion, pair.gear
        zs = np.linspace(-g1.b / 2, g1.b / 2, 9)
        f1, f2 = tca.form_radius(1), tca.form_radius(2)
        out = []
        for k in self.tooth_ids:
            if k in self.loaded:
                continue
            sol = self._section_contacts(k, zs)
            if sol is None:
                continue
            _, _, z2, phi2, rad1, rad2 = sol
            with np.errstate(invalid="ignore"):
                on = (rad1 >= f1) & (rad1 <= g1.r_a) & (rad2 >= f2) & (rad2 <= g2.r_a) & (np.abs(z2) <= g2.b / 2)
            on &= np.isfinite(phi2)
            if on.any() and float(np.min((self.phi2 - phi2[on]) * g2.r_b)) < reach:
                out.append(k)
        return out

    @staticmethod
    def _first_layer(g, radii, mo) -> float:
        if mo.h_contact <= 0 or not radii:
            return 0.0
        half = min(g.s_at(min(max(r, g.r_b), g.r_a)) / 2 for r in radii if math.isfinite(r))
        return mo.h_contact / half

    # ------------------------------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return len(self.pinion_mesh.elements) + len(self.gear_mesh.elements)

    @property
    def n_nodes(self) -> int:
        return len(self.pinion_mesh.nodes) + len(self.gear_mesh.nodes)

    def _flank_faces(self, mesh: MemberMesh, k: int, eoff: int, noff: int):
        """(element id, face) of the right flank of tooth k (1-based ids)."""
        t = next(t for t in mesh.teeth if t["k"] == k)
        r0, r1 = t["section"].segments["flank"]
        out = []
        nodes = t["nodes"]
        for L in range(nodes.shape[0] - 1):
            for R in range(r0, r1):
                e = int(t["elements"][L, R, -1])
                quad = {int(nodes[L, R, -1]), int(nodes[L, R + 1, -1]), int(nodes[L + 1, R, -1]),
                        int(nodes[L + 1, R + 1, -1])}
                out.append((e + 1 + eoff, face_of(mesh.elements[e], quad)))
        return out

    def _fillet_elements(self, mesh: MemberMesh, eoff: int, cols: int = 2):
        ids = []
        for t in mesh.teeth:
            a, b = t["section"].segments["fillet"][0], t["section"].segments["root"][1]
            ids.append(t["elements"][:, a:b, -cols:].ravel())
        return np.concatenate(ids) + 1 + eoff

    def approach_estimate(self) -> float:
        """Estimated loaded approach of the members along the line of action [mm], the step-1 rotation's
        measure (``close_fraction`` of it, docs/fea.md "Solver cost").

        The loaded pairs as springs of the ISO 6336-1 single-pair stiffness ``c' b`` in parallel (c'
        :data:`MESH_STIFFNESS` scaled with E, b the common face width), each taking load once the approach
        exceeds its unloaded separation ``g_k`` (the TCA's, ``contact[k]["gap"]``):
        ``sum_k c' b max(0, delta - g_k) = F_n``. The FE models are stiffer or softer than ISO's c': the
        converged approach is 0.92 (one pair) and 1.12-1.15 (two pairs) of the estimate on
        problems/fea_crowned.toml, 0.72 and 0.85 on problems/fea_spur.toml. It sets ccx's iterations; the
        results depend on it little (step 3 pairs the faces again at the loaded state): 0.8 instead of 1.0
        of it moves the rotation by 4e-7 to 2.5e-5 and the peak pressure mid face by 5e-6 to 1.2e-3
        (relative; docs/fea.md "Solver cost").
        """
        g1, g2 = self.pair.pinion, self.pair.gear
        cb = MESH_STIFFNESS * self.opt.E / 210e3 * min(g1.b, g2.b)
        gaps = sorted(g for g in (self.contact[k]["gap"] for k in self.loaded) if math.isfinite(g) and g >= 0)
        gaps = gaps or [0.0]
        for n in range(len(gaps), 1, -1):  # the pairs that close: the n smallest separations
            delta = (self.F_n / cb + sum(gaps[:n])) / n
            if delta >= gaps[n - 1]:
                return delta
        return self.F_n / cb + gaps[0]

    def deck(self) -> Deck:
        o = self.opt
        n1 = len(self.nodes_pinion)
        e1 = len(self.pinion_mesh.elements)
        nodes = np.vstack([self.nodes_pinion, self.nodes_gear])
        elems = np.vstack([self.pinion_mesh.elements + 1, self.gear_mesh.elements + 1 + n1])
        ref, rot = len(nodes) + 1, len(nodes) + 2
        pm, gm = self.pinion_mesh, self.gear_mesh
        nsets = {"PRIM": np.unique(np.r_[pm.rim_bottom, pm.rim_sides]) + 1,
                 "GFIX": np.unique(np.r_[gm.rim_bottom, gm.rim_sides]) + 1 + n1}
        surfaces, pairs = {}, []
        for k in self.tooth_ids:
            surfaces[f"SP{k + 10}"] = self._flank_faces(pm, k, 0, 0)
            surfaces[f"SG{k + 10}"] = self._flank_faces(gm, -k, e1, n1)
            pairs.append((f"SP{k + 10}", f"SG{k + 10}"))
        self._pfil = self._fillet_elements(pm, 0)
        self._gfil = self._fillet_elements(gm, e1)
        elsets = {"PFIL": self._pfil, "GFIL": self._gfil}
        g1 = self.pair.pinion
        close = -o.close_fraction * self.approach_estimate() / g1.r_b  # clockwise: the pinion's driving direction
        check_elements(nodes, elems)
        return Deck(nodes=nodes, elements=elems, nsets=nsets, elsets=elsets, surfaces=surfaces, contact_pairs=pairs,
                    ref_node=ref, rot_node=rot, rigid_nset="PRIM", fixed_nset="GFIX", E=o.E, nu=o.nu,
                    penalty=o.penalty * o.E, close_rotation=close, moment=-o.torque, print_elsets=["PFIL", "GFIL"],
                    element_type=o.element_type)

    def run(self) -> FEResult:
        """Write the deck, run ccx, read and check the results (:class:`CalculixError` when the
        reaction misses T / r_b1 by more than 1 % or no contact pressure is positive)."""
        deck = self.deck()
        run = run_ccx(deck, threads=self.opt.threads, timeout=self.opt.timeout, keep_dir=self.opt.keep_dir)
        return FEResult.from_run(self, deck, run)
