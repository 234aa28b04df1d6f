"""Automatic hexahedral mesh of gear teeth from the tooth surface equations (Litvin section 9.5,
docs/theory.md section 12.1).

One tooth of a member is the volume bounded by both flanks, both fillets, the root circle arcs to
the middle of the neighbouring spaces, the radial lines there, a rim arc at ``r_rim = r_f - rim_depth``
and the two face ends. Auxiliary intermediate surfaces split it into six sub-volumes (Litvin
Fig. 9.5.1):

* the tooth's middle surface (halfway, in angle, between the two flanks) separates the left and the
  right half;
* the surface through the flank/fillet junction lines and the surface through the fillet ends on the
  root circle split each half into an upper part (flank), a middle part (fillet and root arc) and a
  lower part (rim).

Each sub-volume is a structured block of ``rows x columns x layers`` hexahedra: rows run along the
profile (``n_flank``/graded contact rows, ``n_fillet``, ``n_rim``), columns across the half tooth
(``n_half``, graded towards the surface), layers along the face (``n_face``). In each transverse
section the side chain (flank, fillet, root arc, radial line) is sampled by calling the surface
Functions of :class:`~gearopt.geometry.generation.GeneratedTooth`, so every node on a flank or a
fillet is a true surface point; interior nodes are interpolated linearly in polar coordinates
between the side point and the point of the middle line on the same row (so the tip and rim
boundaries are exact circular arcs). Neighbouring teeth share the nodes of the radial lines.

Along the profile the rows of a loaded flank are graded towards the contact point given by the TCA:
the element size is ``h_c`` within ``window`` of the contact point and grows linearly with the
distance (``growth`` per unit length) up to the far size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import GeometryError, OptionError, out_of_range
from ..geometry.frames import rot_z_points
from ..geometry.generation import GeneratedTooth
from ..settings import MeshOptions  # noqa: F401 - the option set of the mesh, declared in gearopt.settings

if TYPE_CHECKING:
    from collections.abc import Sequence
    from ..types import ArrayLike, Param

#: How a member mesh is held (:meth:`MemberMesh.held`): "sector" (rim bottom and sector sides, the contact
#: model's members) or "bore" (the rim's bottom arc only: with every tooth meshed, a gear held at its bore).
SUPPORTS = ("sector", "bore")

#: C3D8 faces (ccx / Abaqus numbering S1..S6) as node positions 0..7 of the element.
HEX_FACES = {1: (0, 1, 2, 3), 2: (4, 7, 6, 5), 3: (0, 4, 5, 1), 4: (1, 5, 6, 2), 5: (2, 6, 7, 3), 6: (3, 7, 4, 0)}


@dataclass
class ToothSection:
    """Structured node grid of one tooth: ``xyz`` (layers, rows, cols, 3) in the member frame, the
    surface coordinates of the side nodes and the row ranges of each segment."""

    xyz: np.ndarray
    q: dict  # side -> (rows,) surface coordinate (u on flank rows, phi on fillet rows, nan elsewhere)
    segments: dict  # segment name -> (first row, last row) (node rows, inclusive)
    n_half: int


def graded_params(s: np.ndarray, n_uniform: int, s_c: float | None, h_c: float, window: float,
                   growth: float) -> np.ndarray:
    """Node positions along [s[0], s[-1]] (arc length): uniform with ``n_uniform`` elements, or
    graded towards ``s_c`` with the size function h(s) = min(h_far, h_c + growth (|s - s_c| - window)+)."""
    L = s[-1] - s[0]
    if s_c is None or h_c <= 0:
        return np.linspace(s[0], s[-1], n_uniform + 1)
    h_far = max(L / n_uniform, h_c)
    grid = np.linspace(s[0], s[-1], 4001)
    h = np.minimum(h_far, h_c + growth * np.maximum(0.0, np.abs(grid - s_c) - window))
    dens = np.concatenate([[0.0], np.cumsum(0.5 * (1 / h[1:] + 1 / h[:-1]) * np.diff(grid))])
    n = max(n_uniform, int(math.ceil(dens[-1])))
    return np.interp(np.linspace(0, dens[-1], n + 1), dens, grid)


def _column_weights(n_half: int, first: float) -> np.ndarray:
    """Weights 0 (middle line) .. 1 (surface) of the columns, the surface layer ``first`` thick
    (fraction of the half width), geometric growth towards the middle; uniform if first >= 1/n."""
    if first <= 0 or first >= 1.0 / n_half:
        t = np.linspace(0, 1, n_half + 1)
    else:
        lo, hi = 1.0, 10.0
        for _ in range(200):  # ratio g with first (g^n - 1)/(g - 1) = 1
            g = 0.5 * (lo + hi)
            tot = first * (g**n_half - 1) / (g - 1)
            lo, hi = (g, hi) if tot < 1 else (lo, g)
        steps = first * g ** np.arange(n_half)
        t = np.concatenate([[0.0], np.cumsum(steps)])
        t /= t[-1]
    return 1.0 - t[::-1]  # from the middle (0) to the surface (1)


class ToothMesher:
    """Sections of one member's teeth (see the module docstring).

    Parameters
    ----------
    tooth : GeneratedTooth
        Surfaces of the member.
    options : MeshOptions
    p : array (len(tooth.param_names),), optional
        Surface parameter vector (default: the gear as built).
    z_layers : array, optional
        Axial positions of the face layers [mm], ascending from -b/2 to b/2 (default: ``n_face``
        uniform elements).
    r_rim : float, optional
        Radius of the rim's bottom arc [mm] instead of ``r_f - rim_depth m_n`` (e.g. a bore deeper than
        the ``fea.rim_depth`` range: the full gear of :func:`gearopt.fea.influence.line_load_compliance`);
        ``0.15 r_f < r_rim < r_f``.
    """

    def __init__(self, tooth: GeneratedTooth, options: MeshOptions, p: Param = None,
                 z_layers: ArrayLike | None = None, r_rim: float | None = None) -> None:
        self.tooth, self.opt = tooth, options
        self.p = tooth.p0 if p is None else np.asarray(p, float)
        g = tooth.gear
        self.gear = g
        self.r_a, self.r_f = g.r_a, tooth.r_root
        if r_rim is not None:
            if not (isinstance(r_rim, (int, float)) and 0.15 * self.r_f < r_rim < self.r_f):
                raise out_of_range("r_rim", r_rim, f"{0.15 * self.r_f:.6g} < r_rim < {self.r_f:.6g} mm (above 0.15 r_f, "
                                   "below the root circle)", cls=OptionError)
            self.r_rim = float(r_rim)
        else:
            self.r_rim = self.r_f - options.rim_depth * g.m_n
        if self.r_rim <= 0.15 * self.r_f:
            raise GeometryError(f"{g.name}: rim_depth = {options.rim_depth} m_n leaves no hub (r_rim = "
                                f"{self.r_rim:.4g} mm); use a smaller fea.rim_depth.", param="fea.rim_depth",
                                value=options.rim_depth)
        self.u_f, self.phi_max = tooth.junction(self.p)
        self.z = (np.linspace(-g.b / 2, g.b / 2, options.n_face + 1) if z_layers is None
                  else np.asarray(z_layers, float))
        self.pitch_angle = 2 * math.pi / g.z
        self._maps = {}

    def _eval(self, side, seg, q, z):
        key = (side, seg, len(q))
        if key not in self._maps:
            self._maps[key] = self.tooth.surface(side, seg).map(len(q))
        r = self._maps[key](np.asarray(q, float), z, np.tile(self.p[:, None], len(q)))[0]
        return np.asarray(r).T

    def flank_arclength(self, side: str, z: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """(u samples, arc length samples) of the flank from the tip to the fillet junction."""
        u_tip = self.tooth.u_at_radius(self.r_a, z, side, self.p)
        u = np.linspace(u_tip, self.u_f, 801)
        r = self._eval(side, "flank", u, z)
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(r, axis=0), axis=1))])
        return u, s

    def profile_rows(self, contact_u: float, first_layer: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Flank parameters u (tip -> junction) of the node rows and the phi values of the fillet rows.

        ``contact_u``: flank parameter of the contact point on this tooth (None: uniform rows), or
        one per face layer (an inclined contact line: each layer graded at its own contact point;
        then ``u_rows`` is (layers, rows)). The number of rows is the same in every layer."""
        o = self.opt
        u, s = self.flank_arclength("right", 0.0)
        phi_rows = np.linspace(0.0, self.phi_max, o.n_fillet + 1)
        if contact_u is not None and np.ndim(contact_u) == 1:
            cu = np.asarray(contact_u, float)
            if cu.size != len(self.z):
                raise ValueError(f"contact_u: one value per face layer ({len(self.z)}), got {cu.size}")
            sc = np.interp(cu, u[::-1], s[::-1]) if u[0] > u[-1] else np.interp(cu, u, s)
            rows = [graded_params(s, o.n_flank, float(c), o.h_contact, o.window, o.growth) for c in sc]
            n = max(len(r) for r in rows)
            rows = [r if len(r) == n else np.interp(np.linspace(0, 1, n), np.linspace(0, 1, len(r)), r) for r in rows]
            out = np.array([np.interp(r, s, u) for r in rows])
            out[:, 0], out[:, -1] = u[0], u[-1]
            return out, phi_rows
        s_c = None if contact_u is None else float(np.interp(contact_u, u, s))
        sn = graded_params(s, o.n_flank, s_c, o.h_contact, o.window, o.growth)
        u_rows = np.interp(sn, s, u)
        u_rows[0], u_rows[-1] = u[0], u[-1]
        return u_rows, phi_rows

    def section(self, u_rows: ArrayLike, phi_rows: ArrayLike, col_first: float = 0.0) -> ToothSection:
        """Node grid of tooth 0 (centred on +y at the middle section) for every face layer."""
        o, g = self.opt, self.gear
        nz = len(self.z)
        nh = o.n_half
        w = _column_weights(nh, col_first)
        rows_xyz = {"right": [], "left": []}
        for z in self.z:
            for side in ("right", "left"):
                # u_tip depends on z for a crowned / helical flank: rescale the tip row only.
                u_tip = self.tooth.u_at_radius(self.r_a, z, side, self.p)
                us = (u_rows[list(self.z).index(z)] if np.ndim(u_rows) == 2 else u_rows).copy()
                us[0] = u_tip
                fl = self._eval(side, "flank", us, z)
                fi = self._eval(side, "fillet", phi_rows[1:], z)
                rows_xyz[side].append(np.vstack([fl, fi]))
        n_fl, n_fi = np.shape(u_rows)[-1], len(phi_rows) - 1
        seg_fl = (0, n_fl - 1)
        seg_fi = (n_fl - 1, n_fl - 1 + n_fi)
        # Root arc and radial line (the same for every tooth and both sides: shared nodes).
        grid = []
        half_pitch = self.pitch_angle / 2

        def polar(k):
            R, Lf = rows_xyz["right"][k], rows_xyz["left"][k]
            th_R = np.arctan2(R[:, 0], R[:, 1])  # angle from +y towards +x
            th_L = np.arctan2(Lf[:, 0], Lf[:, 1])
            mid = 0.5 * (th_R[n_fl // 2] + th_L[n_fl // 2])  # middle line of this section
            return R, Lf, th_R, th_L, np.hypot(R[:, 0], R[:, 1]), np.hypot(Lf[:, 0], Lf[:, 1]), mid

        # nodes on the root arc: chosen in the middle section, the same in every layer
        _, _, th_R, _, rad_R, _, mid = polar(nz // 2)
        arc0 = rad_R[-1] * (mid + half_pitch - th_R[-1])
        n_arc = 0 if arc0 < 1e-6 * g.m_n else min(2, max(1, int(round(o.n_rim * arc0 / (self.r_f - self.r_rim)))))
        for k, z in enumerate(self.z):
            R, Lf, th_R, th_L, rad_R, rad_L, mid = polar(k)
            # the root circle of this section: where its fillets end (deeper at the face ends of a
            # plunged, longitudinally crowned member)
            r_root = 0.5 * (rad_R[-1] + rad_L[-1])
            # root arc from the fillet end to the middle of the space, then down the radial line
            arc_len = r_root * (mid + half_pitch - th_R[-1])
            thR_arc = np.linspace(th_R[-1], mid + half_pitch, n_arc + 1)[1:]
            thL_arc = np.linspace(th_L[-1], mid - half_pitch, n_arc + 1)[1:]
            r_rad = np.linspace(r_root, self.r_rim, o.n_rim + 1)[1:]
            th_side_R = np.concatenate([th_R, thR_arc, np.full(o.n_rim, mid + half_pitch)])
            th_side_L = np.concatenate([th_L, thL_arc, np.full(o.n_rim, mid - half_pitch)])
            r_side_R = np.concatenate([rad_R, np.full(n_arc, r_root), r_rad])
            r_side_L = np.concatenate([rad_L, np.full(n_arc, r_root), r_rad])
            # middle line: the rows' mean radius on flank and fillet, then linearly (by the side chain's
            # length) down to the rim
            r_mid_top = 0.5 * (r_side_R[: n_fl + n_fi] + r_side_L[: n_fl + n_fi])
            lens = np.concatenate([[0.0], np.full(n_arc, max(arc_len, 0.0) / max(n_arc, 1)),
                                   np.diff(-r_rad, prepend=-r_root)])
            cum = np.cumsum(lens)
            r_mid_bot = r_root - (r_root - self.r_rim) * cum[1:] / cum[-1]
            r_mid = np.concatenate([r_mid_top, r_mid_bot])
            nr = len(r_mid)
            sec = np.empty((nr, 2 * nh + 1, 3))
            for j in range(2 * nh + 1):
                if j >= nh:
                    ww, th_s, r_s = w[j - nh], th_side_R, r_side_R
                else:
                    ww, th_s, r_s = w[nh - j], th_side_L, r_side_L
                th = mid + ww * (th_s - mid)
                rr = r_mid + ww * (r_s - r_mid)
                sec[:, j, 0] = rr * np.sin(th)
                sec[:, j, 1] = rr * np.cos(th)
                sec[:, j, 2] = z
            # exact surface points on the side columns (the polar form reproduces them to rounding)
            sec[: n_fl + n_fi, -1, :] = R
            sec[: n_fl + n_fi, 0, :] = Lf
            grid.append(sec)
        xyz = np.stack(grid)
        nr = xyz.shape[1]
        q = {"flank": np.asarray(u_rows, float), "fillet": np.asarray(phi_rows, float)}
        segments = {"flank": seg_fl, "fillet": seg_fi, "root": (seg_fi[1], seg_fi[1] + n_arc),
                    "rim": (seg_fi[1] + n_arc, nr - 1)}
        if nz != xyz.shape[0]:  # pragma: no cover - defensive
            raise RuntimeError("layer count mismatch")
        return ToothSection(xyz=xyz, q=q, segments=segments, n_half=nh)


_rotz = rot_z_points  # points (..., 3) about z (gearopt.geometry.frames)


@dataclass
class MemberMesh:
    """Nodes and hexahedra of several teeth of one member, in the member's own frame.

    ``nodes`` (N, 3); ``elements`` (E, 8) 0-based node indices (C3D8 order); per tooth ``teeth[k]``
    a dict with the tooth index, its rotation, the node index grid (layers, rows, cols) and the
    element index grid (layers, rows, cols); ``rim_nodes`` (bottom arc and both sector sides).
    """

    name: str
    nodes: np.ndarray
    elements: np.ndarray
    teeth: list
    rim_bottom: np.ndarray
    rim_sides: np.ndarray
    r_rim: float
    meta: dict = field(default_factory=dict)

    def held(self, support: str = "sector") -> np.ndarray:
        """0-based indices of the nodes held fixed for ``support``.

        Parameters
        ----------
        support : {"sector", "bore"}
            ``"sector"``: the rim's bottom arc and both sector sides (the contact model's members,
            docs/fea.md); ``"bore"``: the rim's bottom arc only, the sides free. A mesh of every tooth
            of the member (:attr:`full_ring`) is a gear held at its bore ``r_rim`` with ``"bore"``;
            it has no sides, and ``"sector"`` is refused for it.

        Returns
        -------
        ndarray of int
            Sorted node indices.
        """
        if support not in SUPPORTS:
            raise out_of_range("support", support, " or ".join(repr(s) for s in SUPPORTS), cls=OptionError)
        if support == "bore":
            return np.unique(self.rim_bottom)
        if self.full_ring:
            raise OptionError(f"support = 'sector': the mesh of {self.name} is a full ring (every tooth, the seam "
                              "merged) and has no sector sides; use support = 'bore'.", param="support",
                              value=support, valid="'bore' for a full ring")
        return np.unique(np.r_[self.rim_bottom, self.rim_sides])

    @property
    def full_ring(self) -> bool:
        """Whether the mesh holds every tooth of the member, the last tooth's radial line merged with the
        first's (a closed ring, no sector sides)."""
        return bool(self.meta.get("full_ring", False))


def build_member(mesher: ToothMesher, tooth_ids: Sequence[int], contact_u: dict, name: str,
                 col_first: float) -> MemberMesh:
    """Mesh the teeth ``tooth_ids`` (tooth k rotated by ``k * 2 pi / z`` counter-clockwise) of a member.

    ``contact_u[k]``: flank parameter of the contact point on tooth k (graded rows), or absent."""
    pts, elems, teeth = [], [], []
    offset = 0
    for k in tooth_ids:
        u_rows, phi_rows = mesher.profile_rows(contact_u.get(k))
        sec = mesher.section(u_rows, phi_rows, col_first if k in contact_u else 0.0)
        X = _rotz(sec.xyz, k * mesher.pitch_angle)
        nl, nr, nc, _ = X.shape
        idx = offset + np.arange(nl * nr * nc).reshape(nl, nr, nc)
        pts.append(X.reshape(-1, 3))
        offset += nl * nr * nc
        L, R, C = np.meshgrid(np.arange(nl - 1), np.arange(nr - 1), np.arange(nc - 1), indexing="ij")
        L, R, C = L.ravel(), R.ravel(), C.ravel()
        e = np.stack([idx[L, R, C], idx[L, R, C + 1], idx[L, R + 1, C + 1], idx[L, R + 1, C],
                      idx[L + 1, R, C], idx[L + 1, R, C + 1], idx[L + 1, R + 1, C + 1], idx[L + 1, R + 1, C]], axis=1)
        e_first = sum(len(x) for x in elems)
        elems.append(e)
        teeth.append({"k": k, "angle": k * mesher.pitch_angle, "nodes": idx, "section": sec,
                      "elements": e_first + np.arange(len(e)).reshape(nl - 1, nr - 1, nc - 1),
                      "u_rows": u_rows, "phi_rows": phi_rows})
    P = np.vstack(pts)
    E = np.vstack(elems)
    # merge the shared radial-line nodes of neighbouring teeth
    from scipy.spatial import cKDTree

    tol = 1e-7 * max(1.0, mesher.r_a)
    pairs = cKDTree(P).query_pairs(tol, output_type="ndarray")
    keep = np.arange(len(P))
    if len(pairs):
        pairs = np.sort(pairs, axis=1)
        for a, b in pairs[np.argsort(pairs[:, 1])]:
            keep[b] = keep[a]
        for i in range(len(keep)):  # resolve chains
            while keep[keep[i]] != keep[i]:
                keep[i] = keep[keep[i]]
    uniq, inv = np.unique(keep, return_inverse=True)
    P = P[uniq]
    E = inv[E]
    for t in teeth:
        t["nodes"] = inv[t["nodes"]]
    # orientation: positive Jacobian at the element centre
    vol = hex_volume_sign(P, E)
    if np.sum(vol < 0) > np.sum(vol > 0):  # the node order of the grid turns the other way: flip all
        E = E[:, [3, 2, 1, 0, 7, 6, 5, 4]]
        vol = -vol
    if np.any(vol <= 0):
        bad = np.flatnonzero(vol <= 0)
        raise GeometryError(f"{name}: {bad.size} of {len(E)} elements of the tooth mesh are inverted (first at "
                            f"{np.round(P[E[bad[0]]].mean(axis=0), 3).tolist()} mm); change the element counts "
                            "(fea.n_half, fea.n_rim) or the grading.")
    bottom = np.unique(np.concatenate([t["nodes"][:, -1, :].ravel() for t in teeth]))
    # sector sides: the radial lines of the rim segment on both ends of the sector (tooth k is turned
    # counter-clockwise by k pitches, so the first tooth's right column and the last tooth's left one)
    first, last = teeth[0], teeth[-1]
    rs = first["section"].segments["rim"][0]
    sides = np.unique(np.concatenate([first["nodes"][:, rs:, -1].ravel(), last["nodes"][:, rs:, 0].ravel()]))
    # every tooth of the member: the first tooth's right radial line is the last one's left (merged above)
    ring = len(set(int(k) % mesher.gear.z for k in tooth_ids)) == mesher.gear.z
    return MemberMesh(name=name, nodes=P, elements=E, teeth=teeth, rim_bottom=bottom, rim_sides=sides,
                      r_rim=mesher.r_rim, meta={"r_f": mesher.r_f, "r_a": mesher.r_a, "z": mesher.z, "full_ring": ring})


def hex_volume_sign(P: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Jacobian determinant at the centre of each hexahedron (sign = orientation)."""
    X = P[E]  # (n, 8, 3)
    d_xi = (-X[:, 0] + X[:, 1] + X[:, 2] - X[:, 3] - X[:, 4] + X[:, 5] + X[:, 6] - X[:, 7]) / 8
    d_eta = (-X[:, 0] - X[:, 1] + X[:, 2] + X[:, 3] - X[:, 4] - X[:, 5] + X[:, 6] + X[:, 7]) / 8
    d_zeta = (-X[:, 0] - X[:, 1] - X[:, 2] - X[:, 3] + X[:, 4] + X[:, 5] + X[:, 6] + X[:, 7]) / 8
    return np.einsum("ij,ij->i", np.cross(d_xi, d_eta), d_zeta)


_hex_volume_sign = hex_volume_sign  # (old private name)


def hex_min_jacobian(P: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Smallest Jacobian determinant over the 8 corners of each hexahedron (quality check)."""
    X = P[E]
    corners = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                        [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
    out = np.full(len(E), np.inf)
    for xi, eta, ze in corners:
        dN = _dshape(xi, eta, ze)  # (8, 3)
        J = np.einsum("nka,kb->nab", X, dN)
        out = np.minimum(out, np.linalg.det(J))
    return out


def _dshape(xi, eta, ze):
    s = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                  [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
    d = np.empty((8, 3))
    d[:, 0] = s[:, 0] * (1 + s[:, 1] * eta) * (1 + s[:, 2] * ze) / 8
    d[:, 1] = s[:, 1] * (1 + s[:, 0] * xi) * (1 + s[:, 2] * ze) / 8
    d[:, 2] = s[:, 2] * (1 + s[:, 0] * xi) * (1 + s[:, 1] * eta) / 8
    return d


def shape(xi: ArrayLike, eta: ArrayLike, ze: ArrayLike) -> np.ndarray:
    """Trilinear shape functions of the 8-node hexahedron at natural coordinates (8,)."""
    s = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                  [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
    return (1 + s[:, 0] * xi) * (1 + s[:, 1] * eta) * (1 + s[:, 2] * ze) / 8


#: Natural coordinates of the 2x2x2 Gauss points of C3D8 in ccx's order.
GAUSS_C3D8 = np.array([[xi, eta, ze] for ze in (-1, 1) for eta in (-1, 1) for xi in (-1, 1)], float) / math.sqrt(3)


def face_of(elem_nodes: np.ndarray, quad: set) -> int:
    """Face number (1..6) of a hexahedron whose nodes include the 4 nodes ``quad``."""
    for f, loc in HEX_FACES.items():
        if {int(elem_nodes[i]) for i in loc} == quad:
            return f
    raise ValueError("face not found")


def middle_points(X: np.ndarray, nodes: np.ndarray, load: np.ndarray, normals: np.ndarray,
                  mid_rows: Sequence[int] | np.ndarray, nh: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each load node, the two middle-line nodes (same layer) between which its load line crosses
    the middle line, the interpolation weight and the distance to the crossing [mm]:
    ``(pairs (n, 2), w (n,), depth (n,))`` (flattened like ``load``)."""
    pairs, w, depth = [], [], []
    for i in range(load.shape[0]):
        for layer in range(load.shape[1]):
            P = X[nodes[layer, mid_rows, nh], :2]
            x0 = X[load[i, layer], :2]
            d = -normals[i, layer, :2]
            d = d / np.linalg.norm(d)
            hit = None
            for q in range(len(P) - 1):
                e = P[q + 1] - P[q]
                A = np.column_stack([d, -e])
                if abs(np.linalg.det(A)) < 1e-14:
                    continue
                s_, t_ = np.linalg.solve(A, P[q] - x0)
                if s_ > 0 and -1e-9 <= t_ <= 1 + 1e-9 and (hit is None or s_ < hit[2]):
                    hit = (q, min(max(t_, 0.0), 1.0), s_)
            if hit is None:
                raise GeometryError(f"influence_grid: the load line of flank row {i}, face layer {layer} does not "
                                    "meet the tooth's middle line above the fillet end; the member mesh is not a "
                                    "tooth (check the gear data).", param="mesh", value=None)
            q, t_, s_ = hit
            pairs.append((nodes[layer, mid_rows[q], nh], nodes[layer, mid_rows[q + 1], nh]))
            w.append(t_)
            depth.append(s_)
    return np.array(pairs, int), np.array(w, float), np.array(depth, float)
