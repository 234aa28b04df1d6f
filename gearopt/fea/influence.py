"""Influence coefficients of a member's teeth from its CalculiX model, for loaded TCA (docs/ltca.md).

One member (``teeth`` teeth, rim of ``rim_depth`` modules held at its bottom arc and both sector
sides, as the contact model holds its members; or at its bottom arc only, ``support = "bore"``) is meshed by the FE mesher (section 9.5). A unit
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

from ..errors import ArgumentError, GeometryError, OptionError, out_of_range
from ..progress import current, heartbeat
from ..geometry.generation import GeneratedTooth
from .calculix import CalculixError, read_dat, run_ccx
from .cache import cache_dir, save_npz  # noqa: F401  (cache_dir: re-exported)
from .local import local_excess
from .mesh import SUPPORTS, MeshOptions, ToothMesher, build_member, middle_points

if TYPE_CHECKING:
    from collections.abc import Sequence

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
    neighbours : dict or None
        ``{d: (nr, nz, nr, nz) array}``: the displacement of tooth ``d`` (``d`` pitches from the loaded
        tooth, in the member's tooth numbering) along its own flank normal at the response point of its
        grid point i per unit normal force at the loaded tooth's grid point j [mm/N] (not symmetric;
        :func:`influence_grid`'s ``neighbours``), or None.
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
    neighbours: dict | None = None

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


def _key(tooth: GeneratedTooth, E: float, nu: float, mesh: MeshOptions, teeth: int, r_form, support: str = "sector",
         what: str = "grid") -> str:
    g = tooth.gear
    d = {"v": CACHE_VERSION, "gear": repr(g), "p": np.round(tooth.p0, 15).tolist(), "names": list(tooth.param_names),
         "E": E, "nu": nu, "mesh": repr(mesh), "teeth": teeth, "r_form": None if r_form is None else round(r_form, 9)}
    if support != "sector" or what != "grid":  # (the default grid's key as before: the cached grids stay valid)
        d.update(support=support, what=what)
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:24]



def _flank_loads(tooth: GeneratedTooth, t: dict, X: np.ndarray, rows: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The load nodes of the flank ``rows`` of the member's tooth ``t`` in every face layer, (nr, nz),
    and the flank's outward unit normals there, (nr, nz, 3), from the surface itself (the tip row at
    the tip circle)."""
    nodes = t["nodes"]
    L = nodes.shape[0]
    r0 = t["section"].segments["flank"][0]
    load = np.array([[nodes[layer, r, -1] for layer in range(L)] for r in rows])
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
    return load, normals


def check_neighbours(neighbours: Sequence[int], ids: tuple[int, ...]) -> tuple[int, ...]:
    """``neighbours``, the teeth (pitches from the loaded tooth 0) whose response is read, checked against
    the model's teeth ``ids``: distinct nonzero integers among them."""
    try:
        d = tuple(int(v) for v in neighbours)
        ok = all(float(v) == int(v) for v in neighbours)
    except (TypeError, ValueError):
        d, ok = (), False
    if not ok or len(set(d)) != len(d) or any(v == 0 or v not in ids for v in d):
        raise out_of_range("neighbours", neighbours, f"distinct nonzero tooth offsets among {min(ids)} ... {max(ids)} "
                           "(the member model's teeth)", cls=OptionError)
    return d


def _neighbour_points(mm, mesher: ToothMesher, ids: tuple[int, ...], X: np.ndarray, rows: list[int],
                      normals: np.ndarray, mid_rows: np.ndarray, nh: int) -> dict:
    """Per tooth ``d`` of ``ids``: its load-line crossings with its middle line for the loaded tooth's flank
    grid turned by ``d`` pitches, ``(pairs, weights, normals (n, 3))`` as :func:`middle_points`."""
    teeth = {t["k"]: t for t in mm.teeth}
    L = teeth[0]["nodes"].shape[0]
    out = {}
    for d in ids:
        nd = teeth[d]["nodes"]
        a = d * mesher.pitch_angle
        c, s_ = np.cos(a), np.sin(a)
        nrm = normals.copy()
        nrm[..., 0] = c * normals[..., 0] - s_ * normals[..., 1]
        nrm[..., 1] = s_ * normals[..., 0] + c * normals[..., 1]
        load_d = np.array([[nd[layer, r, -1] for layer in range(L)] for r in rows])
        pairs, w, _ = middle_points(X, nd, load_d, nrm, mid_rows, nh)
        out[d] = (pairs, w, nrm.reshape(-1, 3))
    return out


def _deck_head(title: str, X: np.ndarray, elements: np.ndarray, element: str, fixed: np.ndarray,
               ridx: np.ndarray, E: float, nu: float) -> list[str]:
    """The CalculiX deck's lines before its steps: nodes, elements of type ``element``, the held
    node set FIX and the response node set RESP (``fixed``, ``ridx``: 1-based node numbers), the
    material and the boundary."""
    lines = [f"** gearopt: {title}", "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(X)]
    lines.append(f"*ELEMENT, TYPE={element}, ELSET=EALL")
    lines += [f"{i + 1}, " + ", ".join(str(int(n) + 1) for n in e) for i, e in enumerate(elements)]
    lines += ["*NSET, NSET=FIX"] + [", ".join(str(int(v)) for v in fixed[i:i + 16]) for i in range(0, fixed.size, 16)]
    lines += ["*NSET, NSET=RESP"] + [", ".join(str(int(v)) for v in ridx[i:i + 16]) for i in range(0, ridx.size, 16)]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E:.6e}, {nu:.6f}", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
              "*BOUNDARY", "FIX, 1, 3"]
    return lines


def _run_deck(lines: list[str], jobname: str, who: str, n_cases: int, ridx: np.ndarray, resp_pair: np.ndarray,
              resp_w: np.ndarray, threads: int, say, label: str) -> tuple[list[np.ndarray], float]:
    """Run the deck ``lines`` (``n_cases`` load steps, each printing the displacements of the node set
    RESP, ``ridx``) and return per step the displacement of every response point, interpolated
    between its node pair ``resp_pair`` with weights ``resp_w`` ((M, 3) arrays), and CalculiX's wall
    time [s]."""
    t0 = time.perf_counter()
    with heartbeat(say, f"{label}: CalculiX running", every=15.0):
        run = run_ccx(None, jobname=jobname, threads=threads, inp="\n".join(lines) + "\n")
    ccx_s = time.perf_counter() - t0
    blocks = [b for b in read_dat(run.dat) if b.what.startswith("displacements") and (b.set or "").upper() == "RESP"]
    if len(blocks) != n_cases:
        raise CalculixError(f"{who}: ccx wrote {len(blocks)} displacement blocks for {n_cases} load cases.")
    pos = {int(v): i for i, v in enumerate(ridx)}
    ia = np.array([pos[int(v) + 1] for v in resp_pair[:, 0]])
    ib = np.array([pos[int(v) + 1] for v in resp_pair[:, 1]])
    out = []
    for b in blocks:
        Um = np.zeros((ridx.size, 3))
        for row in b.rows:
            Um[pos[int(row[0])]] = row[1:4]
        out.append((1.0 - resp_w)[:, None] * Um[ia] + resp_w[:, None] * Um[ib])
    return out, ccx_s


def influence_grid(tooth: GeneratedTooth, E: float = 206000.0, nu: float = 0.3, mesh: MeshOptions | None = None,
                   teeth: int = 3, side: str = "right", r_form: float | None = None, use_cache: bool = True,
                   threads: int = 2, local: bool = True, support: str = "sector",
                   neighbours: Sequence[int] = ()) -> InfluenceGrid:
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
    support : {"sector", "bore"}
        How the member is held (:meth:`gearopt.fea.mesh.MemberMesh.held`): ``"sector"`` (default) the
        rim's bottom arc and both sector sides, as the contact model's members; ``"bore"`` the bottom
        arc only (with ``teeth`` = the member's tooth count: a full gear held at its bore ``r_f -
        rim_depth m_n``).
    neighbours : sequence of int
        Teeth (pitches from the loaded tooth, in the member's numbering) whose response to each load is
        read as well, at the points of their own grids (``InfluenceGrid.neighbours``): the coupling of
        neighbouring teeth through the rim or body (docs/ltca.md section 7). Default none.

    Returns
    -------
    InfluenceGrid
    """
    if side != "right":
        raise out_of_range("side", side, "'right' (the FE model loads the right flank)")
    mesh = mesh or MeshOptions(n_face=6, n_half=6, n_flank=8, n_fillet=5, n_rim=4)
    check_teeth(teeth, tooth.gear.z)
    if support not in SUPPORTS:
        raise out_of_range("support", support, " or ".join(repr(v) for v in SUPPORTS), cls=OptionError)
    ids = tuple(range(-(teeth // 2), teeth - teeth // 2))
    nbs = check_neighbours(neighbours, ids)
    key = _key(tooth, E, nu, mesh, teeth, r_form, support,
               what="grid" if not nbs else "grid:neighbours " + ",".join(str(d) for d in nbs))
    path = cache_dir() / f"{key}.npz"
    if use_cache and path.exists():
        try:
            d = np.load(path)
            out = InfluenceGrid(radius=d["radius"], z=d["z"], G=d["G"], asymmetry=float(d["asymmetry"]),
                                ccx_s=float(d["ccx_s"]), cached=True, key=key, depth=d["depth"],
                                neighbours={v: d[f"N{v:+d}"] for v in nbs} or None)
        except (OSError, KeyError, ValueError):
            out = None  # a damaged file: compute again
        if out is not None:
            return _with_local(out, tooth, E, nu, use_cache, threads) if local else out
    m = ToothMesher(tooth, mesh)
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
    load, normals = _flank_loads(tooth, t, X, rows)
    mid_rows = np.arange(0, t["section"].segments["fillet"][1] + 1)  # the middle line, tip to fillet end
    # held like the contact model's members (docs/fea.md): the rim's bottom arc and both sector sides
    # response point of each load: where the load line meets the tooth's middle line in its layer
    # (Weber's depth h is measured to there; the middle node of the same row lies off the load line, and
    # the bending slope between the two points is of the order of the whole local term)
    resp_pair, resp_w, depth = middle_points(X, nodes, load, normals, mid_rows, nh)
    n_own = resp_w.size
    nb = _neighbour_points(mm, m, nbs, X, rows, normals, mid_rows, nh)
    resp_pair = np.concatenate([resp_pair] + [nb[v][0] for v in nbs])
    resp_w = np.concatenate([resp_w] + [nb[v][1] for v in nbs])
    fixed = mm.held(support) + 1
    ridx = np.unique(resp_pair) + 1  # the response nodes, 1-based
    lines = _deck_head("influence coefficients of a tooth flank (unit normal loads)", X, mm.elements, "C3D8",
                       fixed, ridx, E, nu)
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
    n = flat_load.size
    responses, ccx_s = _run_deck(lines, "influence", "influence_grid", n, ridx, resp_pair, resp_w, threads, say, label)
    if say:
        say(f"{label}: done in {ccx_s:.1f} s")
    G = np.zeros((n, n))
    Gn = {v: np.zeros((n, n)) for v in nbs}
    for j, U in enumerate(responses):
        G[:, j] = -np.einsum("ij,ij->i", U[:n_own], flat_n)  # displacement into the tooth along the normal
        for q, v in enumerate(nbs):  # tooth v's own normal
            Gn[v][:, j] = -np.einsum("ij,ij->i", U[n_own * (q + 1):n_own * (q + 2)], nb[v][2])
    if not np.all(np.isfinite(G)) or np.any(np.diag(G) <= 0):
        raise CalculixError("influence_grid: non-finite or non-positive self-compliance in the ccx results.")
    asym = float(np.max(np.abs(G - G.T)) / np.max(np.abs(G)))
    G = 0.5 * (G + G.T)
    radius = np.array([np.hypot(*X[load[i, L // 2], :2]) for i in range(len(rows))])
    z = X[load[0], 2]
    order = np.argsort(radius)
    nr, nz = len(rows), L
    G4 = G.reshape(nr, nz, nr, nz)[order][:, :, order]
    N4 = {v: g.reshape(nr, nz, nr, nz)[order][:, :, order] for v, g in Gn.items()}
    out = InfluenceGrid(radius=radius[order], z=z, G=G4, asymmetry=asym, ccx_s=ccx_s, cached=False, key=key,
                        depth=depth.reshape(nr, nz)[order], neighbours=N4 or None)
    if use_cache:
        save_npz(path, radius=out.radius, z=out.z, G=out.G, asymmetry=asym, ccx_s=ccx_s, depth=out.depth,
                 **{f"N{v:+d}": g for v, g in N4.items()})
    return _with_local(out, tooth, E, nu, use_cache, threads) if local else out


def _with_local(grid: InfluenceGrid, tooth, E, nu, use_cache, threads) -> InfluenceGrid:
    return replace(grid, kappa=local_excess(tooth, grid.radius, E, nu, use_cache=use_cache, threads=threads))


def check_teeth(teeth: int, z: int) -> int:
    """``teeth``, the teeth of a member model, checked: an integer 1 <= teeth <= z (z: every tooth, a full
    ring)."""
    if isinstance(teeth, bool) or not isinstance(teeth, (int, np.integer)):
        raise ArgumentError(f"teeth = {teeth!r:.40}: expected an integer number of teeth.", param="teeth",
                            value=teeth, valid=f"an integer, 1 <= teeth <= {z}")
    if not 1 <= teeth <= z:
        raise out_of_range("teeth", teeth, f"1 <= teeth <= {z} (the member's tooth count: a full ring)",
                           cls=OptionError)
    return int(teeth)


#: Element types of :func:`line_load_compliance` (those of ``FEOptions.element_type``).
ELEMENTS = ("C3D8", "C3D8I")


@dataclass(frozen=True)
class LineLoadCompliance:
    """A member's normal compliance per unit face width under line loads uniform over the face
    (:func:`line_load_compliance`).

    Attributes
    ----------
    radius : (nr,) radii of the loaded flank rows, ascending [mm].
    C : (nr, nr) normal displacement at the response point of row i in the middle face layer per unit
        line load [N/mm] uniform over the face on row j [mm^2/N] (``C[i, i]``: the row's own compliance
        per unit face width, the quantity of the analytical model's per-width terms).
    support : how the member was held; teeth : its teeth; full_ring : every tooth (a closed ring).
    ccx_s : CalculiX time [s]; cached : read from the cache; key : the cache key.
    neighbours : ``{d: (nr, nr) array}``, tooth ``d``'s displacement along its own normal at its row i's
        response point per unit line load on the loaded tooth's row j [mm^2/N] (:func:`line_load_compliance`'s
        ``neighbours``), or None.
    """

    radius: np.ndarray
    C: np.ndarray
    support: str
    teeth: int
    full_ring: bool
    ccx_s: float
    cached: bool
    key: str
    neighbours: dict | None = None

    def at(self, radius: ArrayLike) -> np.ndarray:
        """The own compliance ``C[i, i]`` at flank radii ``radius`` [mm] (linear between rows, constant
        beyond) [mm^2/N]."""
        return np.interp(np.asarray(radius, float), self.radius, np.diag(self.C))


def line_load_compliance(tooth: GeneratedTooth, E: float = 206000.0, nu: float = 0.3, mesh: MeshOptions | None = None,
                         teeth: int = 3, support: str = "sector", r_form: float | None = None,
                         rows: ArrayLike | None = None, r_bore: float | None = None, element: str = "C3D8",
                         use_cache: bool = True, threads: int = 2, neighbours: Sequence[int] = ()) -> LineLoadCompliance:
    """The central tooth's compliance per unit face width under a line load uniform over the face, per
    flank row (one CalculiX load case a loaded row, not one per grid point as :func:`influence_grid`).

    The member is meshed and held as in :func:`influence_grid`; the load of row j is a normal line load
    of 1 N/mm along the row (nodal forces with the face layers' tributary widths, each along its node's
    flank normal); the response at row i is the displacement along row i's normal at the point where
    its load line meets the tooth's middle line, in the middle face layer. With ``teeth`` equal to the
    member's tooth count and ``support = "bore"`` the model is a full gear held at its bore, the body
    of the analytical model's Sainsot term (docs/ltca.md section 7).

    Parameters
    ----------
    tooth : GeneratedTooth
    E, nu : float
        Young's modulus [MPa] and Poisson's ratio.
    mesh : MeshOptions
        Element counts (``n_face`` layers; default: ``n_face = 4``, ``n_half = 4``, ``n_flank = 8``,
        ``n_fillet = 4``, ``n_rim = 8``, ``rim_depth`` 1.5 m_n).
    teeth : int
        Teeth of the model, 1 <= teeth <= z (the central one loaded; z: the full ring, seam merged).
    support : {"sector", "bore"}
        :meth:`gearopt.fea.mesh.MemberMesh.held`.
    r_form : float, optional
        Lowest radius of the rows [mm] (default: the flank's end).
    rows : array of int, optional
        Indices of the loaded rows among those above ``r_form`` (ascending radius; default: all). The
        responses are taken at every row.
    r_bore : float, optional
        Radius of the rim's bottom arc [mm] (the bore of a full gear) instead of ``r_f - rim_depth m_n``
        (:class:`gearopt.fea.mesh.ToothMesher`'s ``r_rim``).
    element : {"C3D8", "C3D8I"}
        CalculiX element type (C3D8I: incompatible modes, without the full-integration hexahedron's shear
        locking in bending; ``FEOptions.element_type``'s choices).
    use_cache : bool
        Read and write the on-disk cache (:func:`gearopt.fea.cache.cache_dir`).
    threads : int
        CalculiX threads.
    neighbours : sequence of int
        Teeth (pitches from the loaded tooth, in the member's numbering) whose response at their own rows
        is read as well (``LineLoadCompliance.neighbours``; docs/ltca.md section 7). Default none.

    Returns
    -------
    LineLoadCompliance
        ``C`` has a column for each loaded row (the others NaN).
    """
    mesh = mesh or MeshOptions(n_face=4, n_half=4, n_flank=8, n_fillet=4, n_rim=8)
    teeth = check_teeth(teeth, tooth.gear.z)
    if support not in SUPPORTS:
        raise out_of_range("support", support, " or ".join(repr(v) for v in SUPPORTS), cls=OptionError)
    if element not in ELEMENTS:
        raise out_of_range("element", element, " or ".join(repr(v) for v in ELEMENTS), cls=OptionError)
    m = ToothMesher(tooth, mesh, r_rim=r_bore)
    ids = tuple(range(-(teeth // 2), teeth - teeth // 2))
    nbs = check_neighbours(neighbours, ids)
    mm = build_member(m, ids, {}, tooth.gear.name or "member", 0.0)
    fixed = mm.held(support) + 1  # (checks support against a full ring)
    t = [t for t in mm.teeth if t["k"] == 0][0]
    nodes = t["nodes"]
    r0, r1 = t["section"].segments["flank"]
    nh = t["section"].n_half
    X = mm.nodes
    L = nodes.shape[0]
    all_rows = [r for r in range(r0, r1 + 1) if r_form is None
                or np.hypot(*X[nodes[L // 2, r, -1], :2]) >= r_form - 1e-9]
    if len(all_rows) < 2:
        raise GeometryError(f"line_load_compliance: fewer than 2 flank rows above r_form = {r_form:.6g} mm; refine "
                            "n_flank.", param="mesh.n_flank", value=mesh.n_flank)
    radius = np.array([np.hypot(*X[nodes[L // 2, r, -1], :2]) for r in all_rows])
    order = np.argsort(radius)  # ascending radius
    nr = len(all_rows)
    loaded = np.arange(nr) if rows is None else np.asarray(rows, int).ravel()
    if loaded.size == 0 or np.any((loaded < 0) | (loaded >= nr)) or np.unique(loaded).size != loaded.size:
        raise out_of_range("rows", np.asarray(rows).tolist(), f"distinct row indices 0 <= i < {nr}",
                           cls=ArgumentError)
    key = _key(tooth, E, nu, mesh, teeth, r_form, support, what=f"line:r_rim {m.r_rim:.9g}:" + ",".join(str(int(i)) for i in loaded)
               + ("" if element == "C3D8" else f":{element}")
               + ("" if not nbs else ":neighbours " + ",".join(str(d) for d in nbs)))
    path = cache_dir() / f"{key}.npz"
    if use_cache and path.exists():
        try:
            d = np.load(path)
            return LineLoadCompliance(radius=d["radius"], C=d["C"], support=support, teeth=teeth,
                                      full_ring=mm.full_ring, ccx_s=float(d["ccx_s"]), cached=True, key=key,
                                      neighbours={v: d[f"N{v:+d}"] for v in nbs} or None)
        except (OSError, KeyError, ValueError):
            pass  # a damaged file: compute again
    load, normals = _flank_loads(tooth, t, X, all_rows)
    mid_rows = np.arange(0, t["section"].segments["fillet"][1] + 1)
    resp_pair, resp_w, _ = middle_points(X, nodes, load, normals, mid_rows, nh)
    resp_pair = resp_pair.reshape(nr, L, 2)[:, L // 2]
    resp_w = resp_w.reshape(nr, L)[:, L // 2]
    n_mid = normals[:, L // 2]
    nb = _neighbour_points(mm, m, nbs, X, all_rows, normals, mid_rows, nh)
    resp_pair = np.concatenate([resp_pair] + [nb[v][0].reshape(nr, L, 2)[:, L // 2] for v in nbs])
    resp_w = np.concatenate([resp_w] + [nb[v][1].reshape(nr, L)[:, L // 2] for v in nbs])
    zl = X[load[0], 2]
    trib = np.zeros(L)  # tributary face widths of the layers (trapezoidal rule) [mm]
    trib[:-1] += 0.5 * np.diff(zl)
    trib[1:] += 0.5 * np.diff(zl)
    ridx = np.unique(resp_pair) + 1  # the response nodes, 1-based
    lines = _deck_head("a tooth's compliance under uniform line loads (unit N/mm per row)", X, mm.elements, element,
                       fixed, ridx, E, nu)
    for j in order[loaded]:  # the j-th row by ascending radius
        lines += ["*STEP", "*STATIC", "*CLOAD, OP=NEW"]
        for layer in range(L):
            f = -normals[j, layer] * trib[layer]  # into the tooth
            lines += [f"{load[j, layer] + 1}, {c + 1}, {f[c]:.12e}" for c in range(3)]
        lines += ["*NODE PRINT, NSET=RESP", "U", "*END STEP"]
    say = current()
    label = f"FE line-load compliance of the {tooth.gear.name or 'member'} ({teeth} teeth, support {support!r})"
    if say:
        say(f"{label}: CalculiX, {loaded.size} load cases on {len(X)} nodes")
    responses, ccx_s = _run_deck(lines, "lineload", "line_load_compliance", loaded.size, ridx, resp_pair, resp_w,
                                 threads, say, label)
    C = np.full((nr, nr), np.nan)
    Cn = {v: np.full((nr, nr), np.nan) for v in nbs}
    inv = np.empty(nr, int)
    inv[order] = np.arange(nr)
    for jj, U in zip(loaded, responses):
        C[inv, jj] = -np.einsum("ij,ij->i", U[:nr], n_mid)  # rows of U by mesh row; into ascending radius
        for q, v in enumerate(nbs):  # tooth v's own normal
            Cn[v][inv, jj] = -np.einsum("ij,ij->i", U[nr * (q + 1):nr * (q + 2)], nb[v][2].reshape(nr, L, 3)[:, L // 2])
    if not np.all(np.isfinite(C[:, loaded])) or np.any(np.diag(C)[loaded] <= 0):
        raise CalculixError("line_load_compliance: non-finite or non-positive self-compliance in the ccx results.")
    out = LineLoadCompliance(radius=radius[order], C=C, support=support, teeth=teeth, full_ring=mm.full_ring,
                             ccx_s=ccx_s, cached=False, key=key, neighbours=Cn or None)
    if use_cache:
        save_npz(path, radius=out.radius, C=C, ccx_s=ccx_s, **{f"N{v:+d}": c for v, c in Cn.items()})
    return out
