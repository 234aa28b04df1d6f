"""The result of one FE position: :class:`FEResult`, read from the ccx output of a
:class:`~gearopt.fea.model.GearFEModel` (gear reaction, pinion rotation and loaded TE, contact pressure
profiles and the pattern across the face, pair forces, fillet stresses against the analytic references),
checked (:func:`~gearopt.fea.references.check_physics`) and JSON-able."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import GeometryError
from .calculix import CalculixError, Deck, last_block, read_contact_statistics, read_dat, read_frd_block
from .mesh import GAUSS_C3D8, shape
from .references import check_physics, penalty_layer_estimate, root_stress_estimate
from .vtu import write_vtu

if TYPE_CHECKING:
    from pathlib import Path
    from .calculix import CcxRun
    from .model import GearFEModel


def _principal_vm(S):
    """Max principal and von Mises stress of rows (sxx, syy, szz, sxy, sxz, syz)."""
    T = np.empty((len(S), 3, 3))
    T[:, 0, 0], T[:, 1, 1], T[:, 2, 2] = S[:, 0], S[:, 1], S[:, 2]
    T[:, 0, 1] = T[:, 1, 0] = S[:, 3]
    T[:, 0, 2] = T[:, 2, 0] = S[:, 4]
    T[:, 1, 2] = T[:, 2, 1] = S[:, 5]
    ev = np.linalg.eigvalsh(T)
    vm = np.sqrt(0.5 * ((S[:, 0] - S[:, 1]) ** 2 + (S[:, 1] - S[:, 2]) ** 2 + (S[:, 2] - S[:, 0]) ** 2)
                 + 3 * (S[:, 3] ** 2 + S[:, 4] ** 2 + S[:, 5] ** 2))
    return ev[:, 2], vm


@dataclass
class FEResult:
    """Results of one FE position (JSON-able via :meth:`to_dict`)."""

    phi1: float
    phi2: float
    data: dict

    @classmethod
    def from_run(cls, model: GearFEModel, deck: Deck, run: CcxRun) -> "FEResult":
        blocks = read_dat(run.dat)
        o = model.opt
        g1, g2 = model.pair.pinion, model.pair.gear
        nodes = deck.nodes
        rf = last_block(blocks, "total force", "GFIX") or last_block(blocks, "forces", "GFIX")
        if rf is None or not rf.rows:
            raise CalculixError("ccx output has no reaction forces of the fixed gear rim (GFIX): the run did not "
                                "reach the load step.")
        R = np.array(rf.rows[-1][-3:], float)
        F_n = model.F_n
        if not np.all(np.isfinite(R)):
            raise CalculixError(f"ccx reports a non-finite reaction force {R.tolist()} at phi1 = {model.phi1:.6g} rad: "
                                "the solution diverged; the result is not valid.")
        rel = abs(np.linalg.norm(R[:2]) - F_n) / F_n
        rot = last_block(blocks, "displacements", "NROT")
        rotation = float(rot.rows[-1][-1]) if rot and rot.rows else float("nan")
        cs = last_block(blocks, "contact stress")
        if cs is None or not cs.rows:
            raise CalculixError(f"ccx reports no contact stress at phi1 = {model.phi1:.6g} rad: the flanks did not "
                                "come into contact (open gap); nothing to report.")
        C = np.array([r for r in cs.rows if len(r) >= 4], float)
        press = C[:, -3]
        if not np.any(press > 0):
            raise CalculixError(f"no positive contact pressure at phi1 = {model.phi1:.6g} rad (max {press.max():.4g} "
                                "MPa): the contact is open; the result is not valid.")
        if rel > 0.01:
            raise CalculixError(f"gear reaction |R| = {np.linalg.norm(R[:2]):.6g} N differs from T / r_b1 = {F_n:.6g} N "
                                f"by {100 * rel:.3g} % (> 1 %): the load did not pass through the contact; the result "
                                "is not valid (see docs/theory.md section 12.3, rule 1).")
        elems = deck.elements
        profiles, p_mid_max = cls._contact_profiles(model, run.frd)
        # stresses at integration points of the fillet elements
        roots = {}
        for member, es, tooth, place in (("pinion", "PFIL", model.pin_tooth, (0.0, model.phi1)),
                                         ("gear", "GFIL", model.gear_tooth, None)):
            blk = last_block(blocks, "stresses", es)
            if blk is None or not blk.rows:
                raise CalculixError(f"ccx output has no stresses for the {member} fillet elements ({es}).")
            S = np.array(blk.rows, float)
            if not np.all(np.isfinite(S)):
                raise CalculixError(f"ccx reports non-finite stresses in the {member} fillet elements ({es}) at phi1 = "
                                    f"{model.phi1:.6g} rad: the solution diverged; the result is not valid.")
            e = S[:, 0].astype(int) - 1
            ip = S[:, 1].astype(int) - 1
            N = np.array([shape(*GAUSS_C3D8[i]) for i in ip])
            X = np.einsum("ni,nij->nj", N, nodes[elems[e] - 1])
            s1, vm = _principal_vm(S[:, 2:8])
            if member == "pinion":
                rad = np.hypot(X[:, 0], X[:, 1])
            else:
                rad = np.hypot(X[:, 0], X[:, 1] - model.pair.a_w)
            mid = np.abs(X[:, 2]) <= 0.25 * min(g1.b, g2.b)
            i_mid = int(np.argmax(np.where(mid, s1, -np.inf)))
            roots[member] = {"max_principal": float(s1.max()), "max_principal_mid": float(s1[i_mid]),
                             "radius_at_max_mid": float(rad[i_mid]), "z_at_max_mid": float(X[i_mid, 2]),
                             "max_von_mises": float(vm.max()), "n_points": int(len(s1))}
        # the pair nearest the pitch point: its Hertz reference and the FE pressure at mid face
        k0 = min(model.hertz, key=lambda k: abs(model.contact[k]["radius1"] - g1.r_p))
        hz = model.hertz[k0]
        p_max_mid = p_mid_max.get(k0, float("nan"))
        # ISO / Lewis estimates of the root stress for the whole load on the loaded pair (single contact)
        est = {}
        for member, tooth, radius in (("pinion", model.pin_tooth, model.contact[k0]["radius1"]),
                                      ("gear", model.gear_tooth, model.contact[k0]["radius2"])):
            try:
                est[member] = root_stress_estimate(tooth, radius, F_n, min(g1.b, g2.b))
            except GeometryError as e:  # helical: no estimate
                est[member] = {"error": str(e)}
        # the pressure in the section through the contact against its Hertz reference (the overall peak
        # also holds the stress singularities where a contact line meets a tip edge or a face end)
        check_physics(phi1=model.phi1, rotation=rotation, r_b1=g1.r_b, F_n=F_n, b=min(g1.b, g2.b), E=o.E,
                      p_max=p_max_mid if math.isfinite(p_max_mid) else float(press.max()), p0=hz.p0)
        # normal contact force of each tooth pair (load sharing), from the contact statistics per pair
        stats = read_contact_statistics(run.dat)
        fn = {k: -float(stats.get(f"SP{k + 10}", {}).get("normal_force", 0.0)) for k in model.tooth_ids}
        pair_force = {str(k): (v if math.isfinite(v) and v > 0 else 0.0) for k, v in fn.items()}
        tot = sum(pair_force.values())
        # the contact pattern across the face, its level set by the pair's contact force
        pattern = cls._line_loads(model, run.frd)
        for k, pat in pattern.items():
            f = pair_force.get(k, 0.0)
            pat["nodal_over_force"] = pat["force"] / f if f > 0 else None
            if f > 0 and pat["force"] > 0:
                pat["q"] = [q * f / pat["force"] for q in pat["q"]]
            pat["force"] = f
        te_arcsec = rotation * (g1.z / g2.z) * 206264.806  # gear lag equivalent of the pinion's extra rotation
        data = {
            "phi1": model.phi1, "phi2": model.phi2, "loaded_pairs": model.loaded,
            "single_pair_contact": len(model.loaded) == 1,
            "contact_points": {str(k): {n: (x if not isinstance(x, float) or math.isfinite(x) else None)
                                        for n, x in v.items()} for k, v in model.contact.items()},
            "n_elements": model.n_elements, "n_nodes": model.n_nodes, "element_type": o.element_type,
            "reaction": {"gear_rim_force": R.tolist(), "magnitude": float(np.linalg.norm(R[:2])),
                         "T_over_rb1": F_n, "rel_error": float(rel)},
            "pair_force_N": pair_force, "pair_share": {k: (v / tot if tot > 0 else None) for k, v in pair_force.items()},
            "pinion_rotation_rad": rotation,
            "loaded_te_arcsec": float(te_arcsec),
            "contact": {"p_max": float(press.max()), "p_max_mid": p_max_mid,
                        "hertz_p0": hz.p0, "hertz_b": hz.b, "R_star": hz.R_star, "hertz_kind": hz.kind,
                        "hertz_a": hz.a if hz.a is not None and math.isfinite(hz.a) else None,
                        "ratio_mid_to_hertz": p_max_mid / hz.p0, "hertz_pair": k0,
                        **penalty_layer_estimate(p_max_mid, hz, o),
                        "profiles": profiles, "pattern": pattern,
                        "n_points": int(len(press)), "n_positive": int((press > 0).sum())},
            "root": roots, "root_estimate": est,
            "timing": {"build_s": model.build_time, "ccx_s": run.seconds},
        }
        for member in ("pinion", "gear"):
            e_ = est[member]
            if "sigma_iso" in e_:
                data["root"][member]["ratio_to_iso"] = roots[member]["max_principal_mid"] / e_["sigma_iso"]
                data["root"][member]["ratio_to_lewis"] = roots[member]["max_principal_mid"] / e_["sigma_lewis"]
        data = _jsonable(data)
        out = cls(phi1=model.phi1, phi2=model.phi2, data=data)
        out.deck, out.frd = deck, run.frd  # for write_vtu (not part of the results dictionary)
        return out

    def write_vtu(self, path: str | os.PathLike) -> Path:
        """The mesh with displacements, stresses and contact pressure as ``.vtu`` (ParaView),
        :func:`gearopt.fea.vtu.write_vtu`."""
        return write_vtu(self.deck, self.frd, path)

    @staticmethod
    def _contact_profiles(model, frd: str):
        """Nodal contact pressure (CPRESS of the .frd) along the pinion's driving flank of each tooth in
        the middle section z = 0: ``{tooth: {"s", "radius", "p"}}`` with ``s`` the arc length [mm]
        along the profile from the TCA contact point (positive towards the tip), and the maximum per tooth."""
        blk = read_frd_block(frd, "CONTACT")
        if blk is None:
            raise CalculixError("ccx wrote no nodal contact output (CONTACT block of the .frd).")
        out, pmax = {}, {}
        pm = model.pinion_mesh
        for t in pm.teeth:
            k = t["k"]
            r0, r1 = t["section"].segments["flank"]
            c = model.contact.get(k)
            zl = pm.nodes[t["nodes"][:, r0, -1]][:, 2]  # the face layers
            z_ref = c["z1"] if (c is not None and k in model.loaded) else 0.0
            layer = int(np.argmin(np.abs(zl - z_ref)))  # the section through the contact (mid face: line contact)
            ids = t["nodes"][layer, r0:r1 + 1, -1]
            X = pm.nodes[ids]
            p = np.array([blk.get(int(i) + 1, [0, 0, 0, 0])[3] for i in ids])
            arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(X, axis=0), axis=1))])
            u_rows = t["u_rows"] if np.ndim(t["u_rows"]) == 1 else t["u_rows"][layer]
            ok = k in model.loaded and np.all(np.diff(u_rows) > 0)
            s0 = float(np.interp(c["u1"], u_rows, arc)) if ok else 0.0
            out[str(k)] = {"s": (s0 - arc).tolist(), "radius": np.hypot(X[:, 0], X[:, 1]).tolist(), "p": p.tolist()}
            pmax[k] = float(p.max())
        return out, pmax

    @staticmethod
    def _line_loads(model, frd: str) -> dict:
        """The contact pattern of each loaded pair across the face, from the nodal contact pressure on
        the whole driving flank of its pinion tooth: ``{tooth: {"z", "q", "force", "z_centroid",
        "p_max", "z_at_p_max"}}``. The pressure is integrated over each flank quadrilateral of the mesh
        (its area times the mean of its four nodal pressures); ``q`` [N/mm] is the normal load per mm of
        face between two face layers (``z_layers``) at their mid ``z`` [mm] (pinion frame = S_f z), ``force`` [N]
        their sum and ``z_centroid`` [mm] the force-weighted centre of the pattern. (The nodal
        pressures of ccx integrate to more than the pair's contact force, 10 % on the default mesh of a
        spur pair: :meth:`from_run` scales ``q`` to the contact force and reports the ratio.)"""
        blk = read_frd_block(frd, "CONTACT")
        pm = model.pinion_mesh
        out = {}
        for t in pm.teeth:
            k = t["k"]
            if k not in model.loaded:
                continue
            r0, r1 = t["section"].segments["flank"]
            ids = t["nodes"][:, r0:r1 + 1, -1]  # (layers, rows)
            X = pm.nodes[ids]
            p = np.array([[blk.get(int(i) + 1, [0, 0, 0, 0])[3] for i in row] for row in ids])
            # quadrilateral (L, R): corners (L, R), (L, R+1), (L+1, R+1), (L+1, R); area from its diagonals
            d1 = X[1:, 1:] - X[:-1, :-1]
            d2 = X[1:, :-1] - X[:-1, 1:]
            area = 0.5 * np.linalg.norm(np.cross(d1, d2), axis=-1)
            pq = 0.25 * (p[:-1, :-1] + p[:-1, 1:] + p[1:, :-1] + p[1:, 1:])
            F = area * pq
            zq = 0.25 * (X[:-1, :-1, 2] + X[:-1, 1:, 2] + X[1:, :-1, 2] + X[1:, 1:, 2])
            zl = X[:, :, 2].mean(axis=1)
            tot = float(F.sum())
            i, j = np.unravel_index(int(np.argmax(p)), p.shape)
            out[str(k)] = {"z": (0.5 * (zl[1:] + zl[:-1])).tolist(), "z_layers": zl.tolist(),
                           "q": (F.sum(axis=1) / np.diff(zl)).tolist(),
                           "force": tot, "z_centroid": float((F * zq).sum() / tot) if tot > 0 else None,
                           "p_max": float(p.max()), "z_at_p_max": float(X[i, j, 2])}
        return out

    def to_dict(self) -> dict:
        return self.data


def _jsonable(v):
    """Plain Python floats/ints/lists (NumPy scalars converted, non-finite floats as None)."""
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v
