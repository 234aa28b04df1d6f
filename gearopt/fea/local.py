"""The local (Hertzian) compression of a tooth from its flank to its middle line, from a plane-strain
CalculiX model of the tooth section, for loaded TCA with FE coefficients (docs/ltca.md section 5).

The influence coefficients (:mod:`gearopt.fea.influence`) give the tooth's deflection at the point C
where the load line meets the tooth's middle line; the flattening between the flank and C is added
by Weber & Banaschek's half-space term, per member

    delta_i = 2 f (1 - nu^2) / (pi E) (ln(2 h_i / b_H) - nu / (2 (1 - nu)))

(f load per unit length of contact line, b_H the Hertz half-width, h_i the depth of C). The tooth is
not a half-space: its section is finite and C lies on its middle line. A plane-strain model of the
section under the Hertz strip load measures the compression from the flank to C, and its excess over
Weber's term is, in Weber's bracket, a dimensionless ``kappa`` that depends on the section's shape
and on where along the flank the load acts, not on the load (docs/ltca.md section 5: the excess per
unit line load is the same at 50 and 200 N m, and for 20/40 m 3 and 21/45 m 2.5 sections). Loaded
TCA uses ``ln(2 h e^kappa / b_H)``.

Model per flank position (:func:`section_compression`): the member's three teeth as a slab 1 mm
thick with every axial displacement held (plane strain), its rim held at its bottom arc and both
sector sides as the contact model holds its members, the mesh graded at the load point
(``n_hertz`` elements per Hertz half-width along the flank and as the first layer across the
tooth), and the Hertz pressure ``p0 sqrt(1 - (s / b)^2)`` of half-width ``b = b_rel m_n`` applied as
nodal forces (each flank node takes the exact integral of the pressure over its half segments).
Helical members: the compression happens in the plane across the contact line; its section is taken
as the normal section, i.e. the virtual spur gear of ``z_n = z / (cos^2 beta_b cos beta)`` teeth
(rounded), at the same distance from the reference circle (a transverse slab of a helical tooth is
not a plane-strain problem: docs/ltca.md section 5).

Cached on disk beside the influence coefficients (``influence/local-<key>.npz``).
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import GeometryError, out_of_range
from ..geometry.generation import GeneratedTooth, generate
from ..geometry.tools import RackCutter
from ..progress import current
from .calculix import read_dat, run_ccx
from .cache import cache_dir, save_npz
from .mesh import MeshOptions, ToothMesher, build_member, middle_points

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

LOCAL_VERSION = 1
SLAB = np.array([-0.5, 0.0, 0.5])  #: face layers of the slab [mm] (1 mm thick, plane strain)


def section_tooth(tooth: GeneratedTooth) -> tuple[GeneratedTooth, float]:
    """The tooth whose transverse section is the plane-strain section of ``tooth``, and the radial
    offset [mm] to add to ``tooth``'s radii: ``tooth`` itself for a spur member; for a helical one
    the virtual spur gear of its normal section (``z_n`` rounded, same ``m_n``, ``x``, rack, no
    crowning), its reference circle at the helical member's. A spur member with lengthwise crowning
    (a_pl) is generated without it (the section is at mid face, where it is zero)."""
    g = tooth.gear
    if g.is_spur:  # the slab of 1 mm about mid face: without lengthwise crowning
        return (tooth, 0.0) if g.a_pl == 0.0 else (generate(replace(g, a_pl=0.0, modifications=None)), 0.0)
    zn = g.z / (math.cos(g.beta_b) ** 2 * math.cos(g.beta))
    vg = replace(g, z=max(3, int(round(zn))), beta=0.0, b=1.0, a_pl=0.0, modifications=None, tool=RackCutter(),
                 name=f"{g.name}_virtual_spur")
    return generate(vg), vg.r_p - g.r_p


def section_compression(tooth: GeneratedTooth, radius: float, b_H: float, E: float = 206000.0, nu: float = 0.3,
                        n_hertz: float = 8.0, n_half: int = 24, threads: int = 2) -> dict:
    """Compression from the flank to the middle line under a Hertz strip load, in plane strain.

    Parameters
    ----------
    tooth : GeneratedTooth
        A member whose transverse section is the plane-strain section (spur, or
        :func:`section_tooth` of a helical member).
    radius : float
        Radius of the strip's centre on the flank [mm].
    b_H : float
        Half-width of the Hertz strip [mm].
    E, nu : float
        Young's modulus [MPa], Poisson's ratio.
    n_hertz : float
        Elements per half-width along the flank at the load (and the first layer's thickness across
        the tooth).
    n_half : int
        Elements across half a tooth.

    Returns
    -------
    dict
        ``local`` flank minus C along the load line [mm], ``weber`` Weber's term to the same depth [mm],
        ``kappa`` the excess in Weber's bracket, ``h`` the depth of C [mm], ``f`` the line load [N/mm]
        (the pressure's integral on the flank; the strip is scaled to ``f = 1000 b_H`` N/mm, a
        linear model), ``radius`` of the loaded node [mm], ``elements``, ``ccx_s`` [s].
    """

    g = tooth.gear
    h_c = b_H / n_hertz
    mo = MeshOptions(n_face=2, n_half=n_half, n_flank=10, n_fillet=5, n_rim=4, h_contact=h_c, window=1.5 * b_H)
    mesher = ToothMesher(tooth, mo, z_layers=SLAB)
    u_c = tooth.u_at_radius(radius, 0.0, "right", tooth.p0)
    half = g.s_at(min(max(radius, g.r_b), g.r_a)) / 2
    mm = build_member(mesher, (-1, 0, 1), {0: u_c}, g.name or "member", h_c / half)
    t = [t for t in mm.teeth if t["k"] == 0][0]
    nodes, X = t["nodes"], mm.nodes
    r0, r1 = t["section"].segments["flank"]
    rows = np.arange(r0, r1 + 1)
    mid = 1  # the slab's middle layer (z = 0)
    P = X[nodes[mid, rows, -1], :2]
    ic = int(np.argmin(np.abs(np.hypot(P[:, 0], P[:, 1]) - radius)))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])
    s = arc - arc[ic]
    if s[0] > -1.2 * b_H or s[-1] < 1.2 * b_H:
        raise GeometryError(f"{g.name}: the Hertz strip of half-width {b_H:.4g} mm at radius {radius:.6g} mm does not "
                            "fit on the flank; choose a radius further from the tip and the form circle.",
                            param="radius", value=radius)
    u_row = t["u_rows"][r0 + ic] if np.ndim(t["u_rows"]) == 1 else t["u_rows"][mid][r0 + ic]
    n3 = np.asarray(tooth.surface("right", "flank")(u_row, 0.0, tooth.p0)[1]).ravel()
    nrm = n3 / np.linalg.norm(n3)
    # nodal forces per unit thickness: p0 b (F(x_b) - F(x_a)), F(x) = (x sqrt(1 - x^2) + asin x) / 2
    f = 1000.0 * b_H  # any load: the model is linear (p0 = 2 f / (pi b))
    p0 = 2 * f / (math.pi * b_H)
    edges = np.clip(np.concatenate([[s[0]], 0.5 * (s[1:] + s[:-1]), [s[-1]]]) / b_H, -1.0, 1.0)
    Fi = 0.5 * (edges * np.sqrt(1 - edges**2) + np.arcsin(edges))
    Fn = p0 * b_H * np.diff(Fi)
    wz = np.array([0.25, 0.5, 0.25])  # trapezoid weights of the three layers [mm]
    loads = [(int(nodes[layer, rows[j], -1]), -Fn[j] * wz[layer] * nrm)
             for j in np.flatnonzero(Fn > 0) for layer in range(3)]
    mid_rows = np.arange(0, t["section"].segments["fillet"][1] + 1)
    node_c = int(nodes[mid, rows[ic], -1])
    pair, w, depth = middle_points(X, nodes[mid:mid + 1], np.array([[node_c]]), nrm[None, None, :], mid_rows,
                                    t["section"].n_half)
    fixed = np.unique(np.r_[mm.rim_bottom, mm.rim_sides]) + 1
    lines = ["*NODE, NSET=NALL"] + [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(X)]
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=EALL")
    lines += [f"{i + 1}, " + ", ".join(str(int(n) + 1) for n in e) for i, e in enumerate(mm.elements)]
    lines += ["*NSET, NSET=FIX"] + [", ".join(str(int(v)) for v in fixed[i:i + 16]) for i in range(0, fixed.size, 16)]
    resp = [node_c + 1, int(pair[0, 0]) + 1, int(pair[0, 1]) + 1]
    lines += ["*NSET, NSET=RESP", ", ".join(str(v) for v in resp)]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E:.6e}, {nu:.6f}", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
              "*BOUNDARY", "FIX, 1, 3", "*BOUNDARY", "NALL, 3, 3", "*STEP", "*STATIC", "*CLOAD"]
    for nid, v in loads:
        lines += [f"{nid + 1}, {c + 1}, {v[c]:.12e}" for c in range(2)]
    lines += ["*NODE PRINT, NSET=RESP", "U", "*END STEP"]
    t0 = time.perf_counter()
    run = run_ccx(None, jobname="local", threads=threads, inp="\n".join(lines) + "\n")
    ccx_s = time.perf_counter() - t0
    blk = [b for b in read_dat(run.dat) if b.what.startswith("displacements")][-1]
    U = {int(r[0]): np.array(r[1:4], float) for r in blk.rows}
    u_flank = -U[resp[0]] @ nrm
    u_C = -((1 - w[0]) * U[resp[1]] + w[0] * U[resp[2]]) @ nrm
    h = float(depth[0])
    f_on = float(Fn.sum())
    c0 = 2 * (1 - nu**2) / (math.pi * E)
    bracket = math.log(2 * h / b_H) - nu / (2 * (1 - nu))
    local = float(u_flank - u_C)
    return {"local": local, "weber": c0 * f_on * bracket, "kappa": local / (c0 * f_on) - bracket, "h": h, "f": f_on,
            "radius": float(np.hypot(*P[ic])), "elements": len(mm.elements), "ccx_s": ccx_s}


def _key(tooth: GeneratedTooth, radius, E, nu, b_rel, n_hertz, n_half) -> str:
    # what the section depends on: not the face width, lengthwise crowning or modifications
    # (section_tooth), so the designs of one member share their cache entry
    g = replace(tooth.gear, a_pl=0.0, modifications=None, b=1.0)
    u = tooth.unmodified
    p = [v for n, v in zip(u.param_names, np.round(u.p0, 15).tolist()) if n != "a_pl"]
    d = {"v": LOCAL_VERSION, "gear": repr(g), "p": p, "E": E, "nu": nu,
         "radius": np.round(np.asarray(radius, float), 9).tolist(), "b_rel": b_rel, "n_hertz": n_hertz,
         "n_half": n_half}
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:24]


def local_excess(tooth: GeneratedTooth, radius: ArrayLike, E: float = 206000.0, nu: float = 0.3, b_rel: float = 0.05,
                 n_hertz: float = 8.0, n_half: int = 24, use_cache: bool = True, threads: int = 2) -> np.ndarray:
    """The excess ``kappa`` of the tooth's local compression over Weber's half-space term, in Weber's
    bracket, at flank radii ``radius`` of ``tooth`` (see the module docstring).

    Parameters
    ----------
    tooth : GeneratedTooth
        The member (spur or helical; its face width, lengthwise crowning and modifications are ignored:
        the section is the generated one at mid face, :func:`section_tooth`).
    radius : array_like (n,)
        Transverse radii on the flank [mm]; each is moved inside the flank by 1.5 strip half-widths
        where the strip would reach past the tip or the flank's end (its value there is the nearest
        position's).
    E, nu : float
        Young's modulus [MPa] and Poisson's ratio (``kappa`` depends on ``nu`` and the section's shape).
    b_rel : float
        Half-width of the Hertz strip in modules (0.05: about the pitch point's at a nominal load;
        ``kappa`` changes by 0.02 between 0.03 and 0.08, docs/ltca.md section 5).
    n_hertz, n_half : mesh density (:func:`section_compression`).

    Returns
    -------
    (n,) array of ``kappa`` (dimensionless).
    """

    if not 0.005 <= b_rel <= 0.2:
        raise out_of_range("b_rel", b_rel, "0.005 <= b_rel <= 0.2 (strip half-width in modules)")
    radius = np.atleast_1d(np.asarray(radius, float))
    key = _key(tooth, radius, E, nu, b_rel, n_hertz, n_half)
    path = cache_dir() / f"local-{key}.npz"
    if use_cache and path.exists():
        try:
            return np.load(path)["kappa"]
        except (OSError, KeyError, ValueError):
            pass
    sec, dr = section_tooth(tooth.unmodified)
    g = sec.gear
    b_H = b_rel * g.m_n
    # the strip must fit on the flank: its centre 1.5 b_H of involute arc (s = rho^2 / (2 r_b), rho the
    # roll distance) inside the tip and the form circle
    rho2_lo = max(g.r_form, g.r_b) ** 2 - g.r_b**2
    r_min = math.sqrt(g.r_b**2 + rho2_lo + 3.0 * b_H * g.r_b)
    r_max = math.sqrt(g.r_a**2 - 3.0 * b_H * g.r_b)
    if r_max <= r_min:
        raise GeometryError(f"{g.name}: the flank is shorter than a Hertz strip of half-width {b_H:.4g} mm; "
                            "use a smaller b_rel.", param="b_rel", value=b_rel)
    rv = np.clip(radius + dr, r_min, r_max)
    kappa = np.empty(radius.size)
    done = {}
    say = current()  # the caller's progress (gearopt.progress.reporting); None: silent
    n_runs = len({round(float(r), 9) for r in rv})
    t0 = time.perf_counter()
    for i, r in enumerate(rv):
        k = round(float(r), 9)
        if k not in done:
            if say:
                say(f"FE local compression of the {g.name or 'member'}: CalculiX section {len(done) + 1}/{n_runs} "
                    f"(r = {r:.3f} mm, {time.perf_counter() - t0:.0f} s so far)")
            done[k] = section_compression(sec, float(r), b_H, E, nu, n_hertz, n_half, threads)["kappa"]
        kappa[i] = done[k]
    if use_cache:
        save_npz(path, kappa=kappa, radius=radius)
    return kappa
