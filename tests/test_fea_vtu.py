"""gearopt.fea.vtu without CalculiX: the nodal fields of a hand-written ``.frd`` (ccx's fixed-width
result format) on a one-element deck, von Mises against its closed forms (uniaxial stress: sigma;
pure shear: sqrt(3) tau), and the ``.vtu`` read back by meshio with the same arrays."""

from __future__ import annotations

import numpy as np
import pytest

from gearopt.fea.calculix import CalculixError, Deck
from gearopt.fea.vtu import fields_from_frd, write_vtu


def deck() -> Deck:
    """A unit cube C3D8 (nodes 1-8)."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    return Deck(nodes=nodes, elements=np.arange(1, 9)[None, :], nsets={}, elsets={}, surfaces={}, contact_pairs=[],
                ref_node=9, rot_node=10, rigid_nset="RIM", fixed_nset="FIX", E=210e3, nu=0.3, penalty=1e6,
                close_rotation=1e-6, moment=1e5)


def block(name: str, rows: dict[int, list[float]]) -> str:
    """One ccx result block: `` -4`` header, `` -1`` records (node id in 10 chars, values in 12), `` -3`` end."""
    lines = [f" -4  {name:<8}    {len(next(iter(rows.values())))}    1"]
    lines += [" -1" + f"{nid:10d}" + "".join(f"{v:12.5E}" for v in vals) for nid, vals in rows.items()]
    return "\n".join(lines + [" -3"])


def frd(stress: dict[int, list[float]], pressure: dict[int, float] | None = None) -> str:
    disp = {n: [1e-3 * n, -2e-3 * n, 0.5e-3] for n in range(1, 9)}
    parts = [block("DISP", disp), block("STRESS", stress)]
    if pressure:
        parts.append(block("CONTACT", {n: [0.0, 0.0, 0.0, p] for n, p in pressure.items()}))
    return "\n".join(parts) + "\n"


def test_von_mises_is_the_closed_form_for_uniaxial_stress_and_pure_shear():
    s, tau = 250.0, 80.0
    stress = {n: [s, 0, 0, 0, 0, 0] for n in range(1, 5)} | {n: [0, 0, 0, tau, 0, 0] for n in range(5, 9)}
    f = fields_from_frd(deck(), frd(stress, {3: 1234.5}))
    assert f["von_mises"][:4] == pytest.approx(s, rel=1e-5)
    assert f["von_mises"][4:] == pytest.approx(np.sqrt(3.0) * tau, rel=1e-5)
    assert f["displacement"][6] == pytest.approx([7e-3, -14e-3, 0.5e-3], rel=1e-5)
    assert f["contact_pressure"][2] == pytest.approx(1234.5, rel=1e-5)
    assert np.count_nonzero(f["contact_pressure"]) == 1  # 0 off the contact surfaces


def test_a_frd_without_stresses_is_refused_naming_the_block():
    with pytest.raises(CalculixError, match="STRESS"):
        fields_from_frd(deck(), block("DISP", {1: [0.0, 0.0, 0.0]}) + "\n")


def test_the_vtu_holds_the_mesh_and_the_fields(tmp_path):
    meshio = pytest.importorskip("meshio")
    stress = {n: [10.0 * n, 0, 0, 0, 0, 0] for n in range(1, 9)}
    text = frd(stress, {5: 99.0})
    path = write_vtu(deck(), text, tmp_path / "model.vtu")
    assert path == tmp_path / "model.vtu" and sorted(p.name for p in tmp_path.iterdir()) == ["model.vtu"]
    m = meshio.read(path)
    assert np.allclose(m.points, deck().nodes)
    assert m.cells[0].type == "hexahedron" and np.array_equal(m.cells[0].data, np.arange(8)[None, :])
    ref = fields_from_frd(deck(), text)
    for k in ("displacement", "stress", "von_mises", "contact_pressure"):
        assert np.allclose(m.point_data[k], ref[k], rtol=1e-12, atol=0), k
    assert m.point_data["von_mises"] == pytest.approx(10.0 * np.arange(1, 9), rel=1e-5)
