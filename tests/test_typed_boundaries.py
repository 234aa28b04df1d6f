"""Typed data across module boundaries (issue 40): the loaded TCA's contact structure, the FE model's
Hertz references and a tooth's slice compliances are frozen dataclasses read by name, and no module
imports another module's private names."""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from gearopt.fea.model import FEOptions, GearFEModel
from gearopt.fea.references import HertzLine, HertzPoint, hertz_line, hertz_point
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.ltca.compliance import Material, ToothCompliance, face_matrix_batch
from gearopt.ltca.contact_qp import CompliancePart, ContactStructure, HertzNodes
from gearopt.ltca.engine import LTCA
from gearopt.meshing.solver import BranchSolution
from gearopt.meshing.sweep_args import SweepArgs, check_sweep_args

ROOT = Path(__file__).resolve().parent.parent / "gearopt"
MODULES = sorted(p.relative_to(ROOT.parent).with_suffix("").as_posix().replace("/", ".") for p in ROOT.rglob("*.py"))


def spur() -> GearPair:
    return GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))


@pytest.fixture(scope="module")
def structure():
    L = LTCA(spur(), n_slices=7)
    S = L.slices(L.mesh_cycle(4))
    return L, S, L.structure(S)


def test_contact_structure_fields_by_name(structure):
    """LTCA.structure: a frozen ContactStructure whose fields have the slices' shapes; the tooth and
    body matrices ``Cs`` are the sum of the parts' face matrices times cos^2(beta_b) (docs/ltca.md
    section 2), built here again from the named parts."""
    L, S, st = structure
    assert isinstance(st, ContactStructure)
    with pytest.raises(dataclasses.FrozenInstanceError):
        st.R = None
    K, N, M = S.z.shape
    for name in ("ct", "length", "R", "h1", "h2", "radius1", "radius2"):
        assert getattr(st, name).shape == (K, N, M), name
    assert st.Cs.shape == (N, K * M, K * M)
    assert [type(p) for p in st.parts] == [CompliancePart] * 3
    assert [p.coupling_length for p in st.parts] == [L.coupling_length, *L.body_coupling]
    used = np.isfinite(S.z)
    assert np.all(st.length[S.active] > 0) and np.all(st.R[S.active] > 0)
    # the contact length of a spur slice is its width
    np.testing.assert_allclose(st.length[S.active], S.width[S.active], rtol=1e-12)
    wt = S.width if S.width_tooth is None else S.width_tooth
    blocks = face_matrix_batch(S.z.reshape(K * N, M), wt.reshape(K * N, M),
                               [(p.compliance.reshape(K * N, M), p.coupling_length) for p in st.parts])
    blocks = blocks.reshape(K, N, M, M)
    for k in range(K):
        for n in range(N):
            u = np.flatnonzero(used[k, n])
            np.testing.assert_allclose(st.Cs[n][np.ix_(k * M + u, k * M + u)], blocks[k, n][np.ix_(u, u)],
                                       rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(sum(p.compliance for p in st.parts), st.ct, rtol=1e-12)


def test_contact_structure_by_position_orders_nodes_as_the_compliance(structure):
    """by_position: (N, K M) rows, node k M + m of position n is (k, n, m), the order of ``Cs``."""
    _, S, st = structure
    K, N, M = S.z.shape
    hz = st.by_position()
    assert isinstance(hz, HertzNodes)
    for name in ("length", "R", "h1", "h2"):
        flat, full = getattr(hz, name), getattr(st, name)
        assert flat.shape == (N, K * M)
        for k, n, m in ((0, 0, 0), (K - 1, N - 1, M - 1), (K // 2, 1, M // 2)):
            assert flat[n, k * M + m] == full[k, n, m]
    assert st.hertz.R is st.R


def test_sweep_keeps_the_structure(structure):
    L, S, _ = structure
    sw = L.solve(100.0, slices=S)
    assert isinstance(sw.structure, ContactStructure)
    assert sw.to_dict(20)["pattern"]["pinion"]["radius"] == [float(v) for v in
                                                             sw.structure.radius1[np.isfinite(S.z)
                                                                                  & (sw.results[0].load > 0)]]


def test_slice_compliance_by_name():
    from gearopt.geometry.generation import generate

    t = generate(Gear(z=20, m_n=3.0, b=20.0))
    tc = ToothCompliance(t, Material(), r_int=0.5 * t.gear.r_f)
    u = t.u_at_radius(t.gear.r_p)
    p, n, _ = t.point("right", "flank", u)
    c = tc.per_width(np.array([p[:2]]), np.array([n[:2]]))
    assert dataclasses.is_dataclass(c)
    assert c.total[0] == pytest.approx(c.bending[0] + c.shear[0] + c.compression[0] + c.foundation[0], rel=1e-14)
    assert c.h[0] > 0 and c.eta_F[0] > 0


def test_hertz_references_are_typed():
    """hertz_line / hertz_point: HertzLine / HertzPoint; a line contact has no major semi-axis."""
    line = hertz_line(354.7, 10.26, 15.39, 210e3, 0.3)
    assert isinstance(line, HertzLine) and line.kind == "line" and line.a is None
    assert (line.rho1, line.rho2) == (10.26, 15.39)
    assert line.R_star == pytest.approx(1 / (1 / 10.26 + 1 / 15.39), rel=1e-14)
    pt = hertz_point(1000.0, (0.05, 0.2), 210e3, 0.3)
    assert isinstance(pt, HertzPoint) and pt.kind == "ellipse" and pt.a > pt.b > 0
    assert pt.R_star == pytest.approx(1 / 0.25, rel=1e-14)
    with pytest.raises(dataclasses.FrozenInstanceError):
        pt.p0 = 0.0


@pytest.mark.parametrize("pinion, kind", [(Gear(z=20, m_n=3, b=20), HertzLine),
                                          (Gear(z=20, m_n=3, b=20, a_pl=2e-3, rack=BasicRack.iso53("A", a_c=2e-3)),
                                           HertzPoint)])
def test_fe_model_hertz_reference_kind(pinion, kind):
    """GearFEModel.hertz: a HertzLine per pair of a line contact (spur), a HertzPoint of a crowned
    pinion's point contact (no CalculiX run)."""
    m = GearFEModel(GearPair(pinion, Gear(z=40, m_n=3, b=20)), 0.0, FEOptions(torque=100e3))
    assert m.hertz and all(isinstance(h, kind) for h in m.hertz.values())
    h = next(iter(m.hertz.values()))
    if kind is HertzLine:
        c = m.contact[next(iter(m.hertz))]
        assert h.rho1 == pytest.approx(math.sqrt(c["radius1"] ** 2 - m.pair.pinion.r_b ** 2), rel=1e-12)
    assert m.b_H == min(v.b for v in m.hertz.values())


def test_sweep_args_and_branch_solution_by_name():
    from gearopt.meshing.tca import TCA

    tca = TCA(GearPair(Gear(z=20, m_n=3.0, b=20.0, a_pl=4e-4, rack=BasicRack.iso53("A", a_c=2e-3)),
                       Gear(z=40, m_n=3.0, b=20.0)))
    a = check_sweep_args(tca, [0.0, 0.01], pairs=(0,))
    assert isinstance(a, SweepArgs) and a.pairs == (0,) and a.phi1.shape == (2,)
    np.testing.assert_array_equal(a.p1, tca.pinion.p0)
    prm = tca.prm(a.phi1, a.p1, a.p2, a.mis)
    W0 = np.repeat(np.asarray(tca.guess())[:, None], 2, axis=1)
    sol = tca.branch.solve(W0, prm, [np.arange(2)])
    assert isinstance(sol, BranchSolution) and sol.ok.all() and sol.W.shape == W0.shape
    assert np.all(sol.res <= tca.tol) and sol.stats["n_fast"] == 2


def private_imports(source: str, module: str) -> list[str]:
    """``from X import _name`` (or ``import X._y``) of another module's private name in ``source``
    (module ``module``); relative imports resolved."""
    out = []
    pkg = module.rsplit(".", 1)[0]  # the package of a module, or of an __init__
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = pkg.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            if base == module:
                continue
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    out.append(f"{base}.{a.name}")
    return out


def test_the_private_import_check_finds_one():
    src = "from ..meshing.tca import _shape_matrix, eigh2_sym\nfrom .hertz import _x\nfrom . import y\n"
    assert private_imports(src, "gearopt.ltca.slices") == ["gearopt.meshing.tca._shape_matrix",
                                                           "gearopt.ltca.hertz._x"]


@pytest.mark.parametrize("module", MODULES)
def test_no_private_name_imported_across_modules(module):
    path = ROOT.parent / (module.replace(".", "/") + ".py")
    bad = private_imports(path.read_text(), module)
    assert not bad, f"{module} imports private names of other modules: {', '.join(bad)}"


def test_weber_contact_by_name():
    """weber_contact: a WeberContact whose b_H and p0 are Hertz's line contact (hertz_line)."""
    from gearopt.ltca.compliance import WeberContact, weber_contact

    m = Material(E=210000.0, nu=0.3)
    w = weber_contact(np.array([350.0]), 8.0 * 15.0 / 23.0, 3.0, 4.0, m, 1.0)
    assert isinstance(w, WeberContact) and w.compliance[0] > 0
    ref = hertz_line(350.0, 8.0, 15.0, m.E, m.nu)
    assert w.b_H[0] == pytest.approx(ref.b, rel=1e-12) and w.p0[0] == pytest.approx(ref.p0, rel=1e-12)
