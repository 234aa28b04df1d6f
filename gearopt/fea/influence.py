"""Influence coefficients of a member's teeth from its CalculiX model, for loaded TCA (docs/ltca.md).

One member (``teeth`` teeth, rim of ``rim_depth`` modules held at its bottom arc and both sector
sides, as the contact model holds its members) is meshed by the FE mesher (section 9.5). A unit
normal force is applied, one load case (``*STEP``) each, at every node of a grid on the driving flank
of the central tooth (its flank rows within the active profile, every face layer). The response at
grid point i is the displacement along the flank normal at the point where the load line of i (the
flank normal through it) meets the tooth's middle line in the same layer, interpolated between the
two middle-line nodes there. This is the deflection of the tooth (bending, shear, body) without the
local flattening between the flank and that point, which loaded TCA adds analytically (Weber &
Banaschek, measured to the centreline along the same line). The middle node of the same row lies
about 0.8 mm further up the tooth (20/40 spur pinion, pitch point); taking the response there made the
loaded approach 10 % larger, through the tooth's bending slope over that distance. The matrix is
symmetrised (Maxwell), and its asymmetry is reported.

Coefficients are cached on disk per geometry (a hash of the gear data, the generated tooth's
parameters, the material, the grid and the mesh), so a new process reuses them. The cache directory
is ``influence/`` in ``$GEAROPT_CACHE`` (else ``$XDG_CACHE_HOME/gearopt`` or ``~/.cache/gearopt``);
files are written atomically.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import GeometryError, out_of_range
from ..progress import current, heartbeat
from ..geometry.generation import GeneratedTooth
from .calculix import CalculixError, read_dat, run_ccx
from .cache import cache_dir, save_npz  # noqa: F401  (cache_dir: re-exported)
from .local import local_excess
from .mesh import MeshOptions, ToothMesher, build_member, middle_points

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

CACHE_VERSION = 4


@dataclass(frozen=True)
class InfluenceGrid:
    """Normal compliance of one member's tooth between points of its flank grid.

    Attributes
    ----------
    radius : (nr,) radii of the grid rows, ascending [mm]; z : (nz,) face positions [mm].
    G : (nr, nz, nr, nz) displacement along the normal at (radius_i, z_i) per unit normal force at
        (radius_j, z_j) [mm/N] (symmetric).
    asymmetry : largest |G - G^T| / max G before symmetrising; ccx_s : CalculiX time [s];
    cached : read from the cache; key : the cache key.
    depth : (nr, nz) distance from each grid point along its load line to the response point on the
        tooth's middle line [mm] (Weber's depth ``h``).
    kappa : (nr,) the excess of the tooth's local compression over Weber's half-space term at the grid
        rows, in Weber's bracket (:func:`gearopt.fea.local.local_excess`), or None.
    """

    radius: np.ndarray
    z: np.ndarray
    G: np.ndarray
    asymmetry: float
    ccx_s: float
    cached: bool
    key: str
    depth: np.ndarray | None = None
    kappa: np.ndarray | None = None

    def local_excess(self, radius: ArrayLike) -> np.ndarray:
        """``kappa`` at flank radii ``radius`` [mm] (linear between the grid rows, constant beyond;
        zeros without it)."""
        r = np.asarray(radius, float)
        if self.kappa is None:
            return np.zeros(r.shape)
        return np.interp(r, self.radius, self.kappa)

    def matrix(self, radius: ArrayLike, z: ArrayLike) -> np.ndarray:
        """Compliance matrix [mm/N] between points ``(radius[i], z[i])`` of the flank (multilinear
        interpolation on the grid; points beyond it are clamped onto its edge)."""
        from scipy.interpolate import RegularGridInterpolator

        r = np.clip(np.asarray(radius, float), self.radius[0], self.radius[-1])
        zz = np.clip(np.asarray(z, float), self.z[0], self.z[-1])
        f = RegularGridInterpolator((self.radius, self.z, self.radius, self.z), self.G)
        n = r.size
        pts = np.stack([np.repeat(r, n), np.repeat(zz, n), np.tile(r, n), np.tile(zz, n)], axis=1)
        C = f(pts).reshape(n, n)
        return 0.5 * (C + C.T)


def _key(tooth: GeneratedTooth, E: float, nu: float, mesh: MeshOptions, teeth: int, r_form) -> str:
    g = tooth.gear
    d = {"v": CACHE_VERSION, "gear": repr(g), "p": np.round(tooth.p0, 15).tolist(), "names": list(tooth.param_names),
         "E": E, "nu": nu, "mesh": repr(mesh), "teeth": teeth, "r_form": None if r_form is None else round(r_form, 9)}
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:24]


def influence_grid(tooth: GeneratedTooth, E: float = 206000.0, nu: float = 0.3, mesh: MeshOptions | None = None,
                   teeth: int = 3, side: str = "right", r_form: float | None = None, use_cache: bool = True,
                   threads: int = 2, local: bool = True) -> InfluenceGrid:
    """Influence coefficients of ``tooth``'s driving flank (see the module docstring).

    Parameters
    ----------
    tooth : GeneratedTooth
    E, nu : float
        Young's modulus [MPa] and Poisson's ratio.
    mesh : MeshOptions
        Element counts of the member mesh; its flank rows (``n_flank``) and face layers (``n_face``)
        are the load grid (default: ``n_flank = 8``, ``n_face = 6``; ``n_half = 6``, ``n_fillet = 5``,
        ``n_rim = 4`` as the contact model's default mesh).
    teeth : int
        Teeth of the member in the model (the central one loaded).
    r_form : float, optional
        Lowest radius of the grid [mm] (default: the flank's end).
    use_cache : bool
        Read and write the on-disk cache.
    local : bool
        Also compute the local-compression excess ``kappa`` at the grid rows
        (:func:`gearopt.fea.local.local_excess`, cached on its own).

    Returns
    -------
    InfluenceGrid
    """
    if side != "right":
        raise out_of_range("side", side, "'right' (the FE model loads the right flank)")
    mesh = mesh or MeshOptions(n_face=6, n_half=6, n_flank=8, n_fillet=5, n_rim=4)
    key = _key(tooth, E, nu, mesh, teeth, r_form)
    path = cache_dir() / f"{key}.npz"
    if use_cache and path.exists():
        try:
            d = np.load(path)
            out = InfluenceGrid(radius=d["radius"], z=d["z"], G=d["G"], asymmetry=float(d["asymmetry"]),
                                ccx_s=float(d["ccx_s"]), cached=True, key=key, depth=d["depth"])
        except (OSError, KeyError, ValueError):
            out = None  # a damaged file: compute again
        if out is not None:
            return _with_local(out, tooth, E, nu, use_cache, threads) if local else out
    m = ToothMesher(tooth, mesh)
    ids = tuple(range(-(teeth // 2), teeth - teeth // 2))
    mm = build_member(m, ids, {}, tooth.gear.name or "member", 0.0)
    t = [t for t in mm.teeth if t["k"] == 0][0]
    nodes = t["nodes"]  # (layers, rows, cols)
    r0, r1 = t["section"].segments["flank"]
    nh = t["section"].n_half
    X = mm.nodes
    rows = [r for r in range(r0, r1 + 1) if r_form is None
            or np.hypot(*X[nodes[nodes.shape[0] // 2, r, -1], :2]) >= r_form - 1e-9]
    if len(rows) < 2:
        raise GeometryError(f"influence_grid: fewer than 2 flank rows above r_form = {r_form:.6g} mm; refine n_flank.",
                            param="mesh.n_flank", value=mesh.n_flank)
    L = nodes.shape[0]
    load = np.array([[nodes[layer, r, -1] for layer in range(L)] for r in rows])  # (nr, nz)
    mid_rows = np.arange(0, t["section"].segments["fillet"][1] + 1)  # the middle line, tip to fillet end
    # outward unit normals of the flank at the load nodes, from the surface itself
    surf = tooth.surface("right", "flank")
    u_rows = t["u_rows"]
    normals = np.zeros(load.shape + (3,))
    for i, r in enumerate(rows):
        for layer in range(L):
            zl = X[load[i, layer], 2]
            uu = u_rows[r] if np.ndim(u_rows) == 1 else u_rows[layer][r]
            if r == r0:
                uu = tooth.u_at_radius(tooth.gear.r_a, zl, "right", tooth.p0)
            normals[i, layer] = np.asarray(surf(uu, zl, tooth.p0)[1]).ravel()
    # held like the contact model's members (docs/fea.md): the rim's bottom arc and both sector sides
    # response point of each load: where the load line meets the tooth's middle line in its layer
    # (Weber's depth h is measured to there; the middle node of the same row lies off the load line, and
    # the bending slope between the two points is of the order of the whole local term)
    resp_pair, resp_w, depth = middle_points(X, nodes, load, normals, mid_rows, nh)
    fixed = np.unique(np.r_[mm.rim_bottom, mm.rim_sides]) + 1
    lines = ["** gearopt: influence coefficients of a tooth flank (unit normal loads)", "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(X)]
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=EALL")
    lines += [f"{i + 1}, " + ", ".join(str(int(n) + 1) for n in e) for i, e in enumerate(mm.elements)]
    lines += ["*NSET, NSET=FIX"] + [", ".join(str(int(v)) for v in fixed[i:i + 16]) for i in range(0, fixed.size, 16)]
    ridx = np.unique(resp_pair) + 1
    lines += ["*NSET, NSET=RESP"] + [", ".join(str(int(v)) for v in ridx[i:i + 16]) for i in range(0, ridx.size, 16)]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E:.6e}, {nu:.6f}", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
              "*BOUNDARY", "FIX, 1, 3"]
    flat_load = load.ravel()
    flat_n = normals.reshape(-1, 3)
    for j, (nid, nv) in enumerate(zip(flat_load, flat_n)):
        f = -nv  # a unit force into the tooth
        lines += ["*STEP", "*STATIC", "*CLOAD, OP=NEW"] + [f"{nid + 1}, {c + 1}, {f[c]:.12e}" for c in range(3)]
        lines += ["*NODE PRINT, NSET=RESP", "U", "*END STEP"]
    say = current()  # the caller's progress (gearopt.progress.reporting); None: silent
    label = f"FE influence coefficients of the {tooth.gear.name or 'member'}"
    if say:
        say(f"{label}: CalculiX, {flat_load.size} unit loads on {len(X)} nodes (cached afterwards in {cache_dir()})")
    t0 = time.perf_counter()
    with heartbeat(say, f"{label}: CalculiX running", every=15.0):
        run = run_ccx(None, jobname="influence", threads=threads, inp="\n".join(lines) + "\n")
    ccx_s = time.perf_counter() - t0
    if say:
        say(f"{label}: done in {ccx_s:.1f} s")
    blocks = [b for b in read_dat(run.dat) if b.what.startswith("displacements") and (b.set or "").upper() == "RESP"]
    n = flat_load.size
    if len(blocks) != n:
        raise CalculixError(f"influence_grid: ccx wrote {len(blocks)} displacement blocks for {n} load cases.")
    pos = {int(v): i for i, v in enumerate(ridx)}
    ia = np.array([pos[int(v) + 1] for v in resp_pair[:, 0]])
    ib = np.array([pos[int(v) + 1] for v in resp_pair[:, 1]])
    G = np.zeros((n, n))
    for j, b in enumerate(blocks):
        Um = np.zeros((ridx.size, 3))
        for row in b.rows:
            Um[pos[int(row[0])]] = row[1:4]
        U = (1.0 - resp_w)[:, None] * Um[ia] + resp_w[:, None] * Um[ib]
        G[:, j] = -np.einsum("ij,ij->i", U, flat_n)  # displacement into the tooth along the normal
    if not np.all(np.isfinite(G)) or np.any(np.diag(G) <= 0):
        raise CalculixError("influence_grid: non-finite or non-positive self-compliance in the ccx results.")
    asym = float(np.max(np.abs(G - G.T)) / np.max(np.abs(G)))
    G = 0.5 * (G + G.T)
    radius = np.array([np.hypot(*X[load[i, L // 2], :2]) for i in range(len(rows))])
    z = X[load[0], 2]
    order = np.argsort(radius)
    nr, nz = len(rows), L
    G4 = G.reshape(nr, nz, nr, nz)[order][:, :, order]
    out = InfluenceGrid(radius=radius[order], z=z, G=G4, asymmetry=asym, ccx_s=ccx_s, cached=False, key=key,
                        depth=depth.reshape(nr, nz)[order])
    if use_cache:
        save_npz(path, radius=out.radius, z=out.z, G=out.G, asymmetry=asym, ccx_s=ccx_s, depth=out.depth)
    return _with_local(out, tooth, E, nu, use_cache, threads) if local else out


def _with_local(grid: InfluenceGrid, tooth, E, nu, use_cache, threads) -> InfluenceGrid:
    return replace(grid, kappa=local_excess(tooth, grid.radius, E, nu, use_cache=use_cache, threads=threads))
