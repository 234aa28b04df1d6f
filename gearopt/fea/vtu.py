"""FE results for ParaView: the mesh with displacements, stresses (von Mises) and contact pressure
as a VTK unstructured grid (``.vtu``), written by meshio."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .calculix import CalculixError, Deck, read_frd_block


def fields_from_frd(deck: Deck, frd: str) -> dict:
    """Nodal fields of the last increment in a ccx ``.frd``, in the deck's node order:
    ``displacement`` (N, 3) [mm], ``stress`` (N, 6) [MPa] (xx, yy, zz, xy, yz, zx, extrapolated to
    the nodes by ccx), ``von_mises`` (N,) [MPa], ``contact_pressure`` (N,) [MPa] (0 off the contact
    surfaces)."""
    n = len(deck.nodes)
    out = {}
    for key, block, width in (("displacement", "DISP", 3), ("stress", "STRESS", 6)):
        blk = read_frd_block(frd, block)
        if not blk:
            raise CalculixError(f"the ccx .frd has no {block} block: the deck did not ask for it (*NODE FILE U / "
                                "*EL FILE S) or the run stopped early.")
        a = np.zeros((n, width))
        for nid, vals in blk.items():
            if 1 <= nid <= n:
                a[nid - 1] = vals[:width]
        out[key] = a
    s = out["stress"]
    out["von_mises"] = np.sqrt(0.5 * ((s[:, 0] - s[:, 1]) ** 2 + (s[:, 1] - s[:, 2]) ** 2 + (s[:, 2] - s[:, 0]) ** 2)
                               + 3 * (s[:, 3] ** 2 + s[:, 4] ** 2 + s[:, 5] ** 2))
    p = np.zeros(n)
    blk = read_frd_block(frd, "CONTACT") or {}
    for nid, vals in blk.items():
        if 1 <= nid <= n and len(vals) > 3:
            p[nid - 1] = vals[3]
    out["contact_pressure"] = p
    return out


def write_vtu(deck: Deck, frd: str, path: str | os.PathLike) -> Path:
    """Write the model of ``deck`` with the fields of ``frd`` (:func:`fields_from_frd`) to ``path``
    (``.vtu``) through meshio; atomic (a temporary file renamed into place)."""
    import meshio

    f = fields_from_frd(deck, frd)
    mesh = meshio.Mesh(np.asarray(deck.nodes, float), [("hexahedron", np.asarray(deck.elements, int) - 1)],
                       point_data={"displacement": f["displacement"], "stress": f["stress"],
                                   "von_mises": f["von_mises"], "contact_pressure": f["contact_pressure"]})
    path = Path(path)
    fd, tmp = tempfile.mkstemp(suffix=".vtu", dir=path.parent)
    os.close(fd)
    try:
        meshio.write(tmp, mesh, file_format="vtu")
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path
