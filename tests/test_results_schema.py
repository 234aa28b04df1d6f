"""Results own their schema: the result objects' ``to_dict()`` against docs/results.md and against
invariants computed here from the dictionaries themselves; the study modules do not import the
scene loader (no io.scene <-> studies import cycle)."""

from __future__ import annotations

import ast
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gearopt.gears import Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment
from gearopt.units import ARCMIN

from results_doc import documented, undocumented

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def crowned():
    g1 = Gear(z=20, m_n=3, b=20, a_pl=2e-3, name="pinion")
    pair = GearPair(g1.with_(rack=replace(g1.rack, a_c=2e-3)), Gear(z=40, m_n=3, b=20, name="gear"))
    return pair, TCA(pair)


def _phi(z1, n=40):
    return np.linspace(-2 * math.pi / z1, 2 * math.pi / z1, n, endpoint=False)


def _check_envelope(case, upper: bool):
    """Independent of the engine: the actual TE is the TE of the driving pair (``upper``: and the
    upper envelope of the pairs' TE), and the transfers lie midway where the driving pair changes."""
    te = np.array([[np.nan if v is None else v for v in row] for row in case["te_arcsec"]])
    env = np.array([np.nan if v is None else v for v in case["te_envelope_arcsec"]])
    has = np.isfinite(env)
    assert has.sum() > len(env) // 2
    if upper:
        assert np.allclose(env[has], np.nanmax(te[:, has], axis=0), rtol=0, atol=1e-9)
    assert np.all(env[has] <= np.nanmax(te[:, has], axis=0) + 1e-9)
    drv = case["driving_pair"]
    assert [k is None for k in drv] == list(~has)
    for i, k in enumerate(drv):
        if k is not None:
            assert te[case["pairs"].index(k), i] == pytest.approx(env[i], abs=1e-9)
    phi = case["phi1"]
    if not case["conjugate"]:
        mids = [0.5 * (phi[i] + phi[i + 1]) for i in range(len(drv) - 1)
                if drv[i] is not None and drv[i + 1] is not None and drv[i] != drv[i + 1]]
        assert case["transfer_phi1"] == pytest.approx(mids, abs=1e-12)
        assert mids, "a crowned drive changes its driving pair within two mesh cycles"
    assert case["peak_to_peak_arcsec"] == pytest.approx(np.nanmax(env) - np.nanmin(env), abs=1e-9)


def test_tca_result_owns_its_dictionary(crowned):
    pair, tca = crowned
    mis = Misalignment(crossing=2 * ARCMIN)
    r = tca.sweep(_phi(pair.pinion.z), mis=mis, pairs=(-1, 0, 1))
    case = r.to_dict("crossed", pair.pinion.z, {"pinion": {"b": 20.0, "r_a": 33.0, "r_form": 28.0}})
    assert undocumented({"cases": [case]}, "tca") == []
    assert case["label"] == "crossed" and case["misalignment"]["crossing_arcmin"] == pytest.approx(2.0, rel=1e-12)
    _check_envelope(case, upper=False)  # the envelope takes only points on the active flanks
    assert case["peak_to_peak_arcsec"] > 1  # profile crowned: a parabolic TE of some arcsec
    # the central pair's path on the gear flank is the transverse radius of its xyz points
    xyz = np.array([[np.nan if v is None else v for v in p] for p in case["gear"]["xyz"]])
    rad = np.array([np.nan if v is None else v for v in case["gear"]["radius"]])
    ok = np.isfinite(rad)
    assert np.allclose(np.hypot(xyz[ok, 0], xyz[ok, 1]), rad[ok], atol=1e-9)
    # harmonics over two whole cycles; without z1 there are none
    assert len(case["harmonics_arcsec"]) == 5
    assert r.to_dict("x")["harmonics_arcsec"] is None


def test_edge_result_owns_its_dictionary(crowned):
    from gearopt.contact.edge import EdgeContact

    pair, tca = crowned
    r = EdgeContact(tca).sweep(_phi(pair.pinion.z, 24), mis=Misalignment(crossing=3 * ARCMIN), pairs=(-1, 0, 1))
    case = r.to_dict("edge", pair.pinion.z, None)
    assert undocumented({"cases": [case]}, "tca") == []
    assert case["edge_analysis"] is True and case["branches"][0] == "surface"
    _check_envelope(case, upper=True)  # te_arcsec: each pair's valid contacts only
    for name, path in case["paths_central_pair"].items():
        assert name in case["branches"]
        # a feature carries the load only where the central pair has contact on it
        for i, load in enumerate(path["carries_load"]):
            if load:
                assert path["gear"]["radius"][i] is not None and case["active_branch"][i] == name


def test_doc_check_finds_undocumented_and_misplaced_keys():
    """The checker itself: an unknown key, a key of another study, a wrong placeholder value."""
    assert undocumented({"study": "tca", "cases": [{"label": "a", "bogus": 1}]}, "tca") == ["cases[].bogus"]
    assert undocumented({"pair": {"a_0": 1.0}}, "tca") == ["pair.a_0"]  # a geometry key
    assert undocumented({"pair": {"a_0": 1.0}}, "geometry") == []
    assert undocumented({"members": {"wheel": {"z": 3}}}, "geometry") == ["members.wheel.z"]
    assert undocumented({"cases": [{"te_branches_central_arcsec": {"gear_nose": []}}]}, "tca") != []
    # the crowning study's before/after cases are read with the tca rows
    assert undocumented({"before": [{"label": "a", "edge_analysis": True}]}, "crowning") == []
    docs = documented()
    assert {"every", "geometry", "planar_tca", "tca", "crowning", "fea", "local"} <= set(docs)


def test_fe_options_dictionary_is_documented():
    from gearopt.fea.model import FEOptions

    d = FEOptions(torque=5e4).to_dict()
    assert undocumented({"options": d}, "fea") == []
    assert d["torque_Nmm"] == 5e4 and set(d["mesh"]) >= {"n_face", "rim_depth"}


# --- the import cycle --------------------------------------------------------------------------
def _imports(path: Path) -> list[tuple[str, bool]]:
    """Modules a file imports, as absolute names, with whether the import sits under
    ``if TYPE_CHECKING`` (typing only, never executed)."""
    tree = ast.parse(path.read_text())
    pkg = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    out = []

    def visit(node, typing_only):
        for child in ast.iter_child_nodes(node):
            t = typing_only or (isinstance(child, ast.If) and getattr(child.test, "id", "") == "TYPE_CHECKING")
            if isinstance(child, ast.ImportFrom):
                base = pkg.split(".")
                mod = ".".join(base[:len(base) - child.level + 1] + ([child.module] if child.module else [])) \
                    if child.level else child.module
                out.append((mod, t))
                out.extend((f"{mod}.{a.name}", t) for a in child.names)
            elif isinstance(child, ast.Import):
                out.extend((a.name, t) for a in child.names)
            visit(child, t)

    visit(tree, False)
    return out


@pytest.mark.parametrize("module", sorted(p.name for p in (ROOT / "gearopt" / "studies").glob("*.py")))
def test_study_modules_do_not_import_the_scene_loader(module):
    """The scene loader imports the studies registry; the studies declare their sections with
    gearopt.io.schema and never import gearopt.io.scene (not even inside functions)."""
    used = [m for m, typing_only in _imports(ROOT / "gearopt" / "studies" / module)
            if not typing_only and (m == "gearopt.io.scene" or m.startswith("gearopt.io.scene."))]
    assert used == [], f"gearopt/studies/{module} imports {used}"


def test_schema_module_imports_neither_loader_nor_studies():
    mods = [m for m, _ in _imports(ROOT / "gearopt" / "io" / "schema.py")]
    assert not [m for m in mods if m.startswith(("gearopt.io.scene", "gearopt.studies"))], mods
    from gearopt.io import scene, schema

    assert scene.Field is schema.Field and scene.Section is schema.Section and scene.Bounds is schema.Bounds
    assert scene.format_field is schema.format_field
