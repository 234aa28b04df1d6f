"""The scenes of problems/ as tests see them: their pytest parameters (markers by study and cost), the
checks every scene run must pass, and the physics checks of the loaded micro-geometry and FE scenes.
The test_problems*.py files each take a group of scenes (by study), so that pytest-xdist spreads them;
conftest.scene_run runs each scene once per test process."""

from __future__ import annotations

import math
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from gearopt.cli import main
from gearopt.errors import SceneError
from gearopt.io.scene import load_scene

from results_doc import undocumented

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
SCENES = sorted(p for p in PROBLEMS.glob("*.toml"))
#: pytest markers of the scene runs: IPOPT (crowning study), CalculiX (fea study)
STUDY_MARKS = {"crowning": [pytest.mark.ipopt], "fea": [pytest.mark.calculix], "loaded_microgeometry": [pytest.mark.ipopt]}
#: every scene run takes more than 2 s (the CLI, its results and plots), the gear-data scenes included
FAST_STUDIES: set[str] = set()


def study(scene: Path) -> str:
    return tomllib.loads(scene.read_text())["scene"]["study"]


def edge_contact(scene: Path) -> bool:
    return bool(tomllib.loads(scene.read_text()).get("tca", {}).get("edge_contact", False))


def scene_param(scene: Path):
    marks = list(STUDY_MARKS.get(study(scene), []))
    if study(scene) not in FAST_STUDIES:
        marks.append(pytest.mark.slow)
    return pytest.param(scene, marks=marks, id=scene.stem)


def check_scene_run(scene: Path, scene_run) -> None:
    """What every scene run must give: exit 0, results with units, every key documented in
    docs/results.md, plots above 10 kB with no mechanical fault (tests/plot_lint.py), and the
    study's own scalars where a check below knows them."""
    if study(scene) == "fea" and shutil.which("ccx") is None:
        pytest.skip("CalculiX (ccx) is not installed: the FE scene cannot run (make test installs it as root)")
    run = scene_run(scene.stem)
    assert run.status == 0
    res, out = run.results, run.out
    assert res["units"], "results must state units"
    # every key is documented in docs/results.md (rows of "every study" and of this study)
    assert undocumented(res, res["study"]) == [], "keys missing in docs/results.md"
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs, "plots must be written"
    for p in out.glob("*.png"):
        assert p.stat().st_size > 10_000
    if res["study"] == "loaded_microgeometry":
        _loaded_microgeometry_scalars(res, out)
    if res["scene"] == "fea_crowned":
        _fea_crowned_scalars(res)
    # what can be checked mechanically in every plot (tests/plot_lint.py): no offset text, every
    # legend entry drawn, nothing cut at the image's edge, no overlaps, no legend over the data where avoidable
    assert run.plot_problems == [], "plot problems:\n" + "\n".join(run.plot_problems)


def _fea_crowned_scalars(res):
    """The crowned spur pinion under a 3 arcmin crossing (problems/fea_crowned.toml): one pair at the
    pitch point, two at +-5.4 deg; the reaction is T / r_b1; every loaded pair's pattern integrates to
    its contact force and its centre lies off mid face on the side the crossing moves the TCA contact
    to (z1 < 0), by more than a millimetre at the pitch point."""
    assert res["options"]["misalignment"]["crossing_arcmin"] == pytest.approx(3.0)
    assert [len(p["loaded_pairs"]) for p in res["positions"]] == [2, 1, 2]
    for p in res["positions"]:
        assert p["reaction"]["rel_error"] < 0.01
        for k in p["loaded_pairs"]:
            pat = p["contact"]["pattern"][str(k)]
            q, zl = np.array(pat["q"]), np.array(pat["z_layers"])
            assert zl[0] == pytest.approx(-10.0) and zl[-1] == pytest.approx(10.0)  # the whole face
            assert np.sum(q * np.diff(zl)) == pytest.approx(p["pair_force_N"][str(k)], rel=1e-6)
            assert pat["z_centroid"] < -0.5 and p["contact_points"][str(k)]["z1"] < 0
    assert res["positions"][1]["contact"]["pattern"]["0"]["z_centroid"] < -1.0


def _loaded_microgeometry_scalars(res, out):
    """The micro-geometry optimisation under load (problems/microgeometry_loaded.toml): the start design
    loads its tip edges at every torque and case; the optimum loads none (verification grid, exact
    loaded TCA), agrees with the exact loaded TCA within 0.01 arcsec, lowers the objective by a third,
    keeps the pressure limit, and stays within its bounds."""
    d = res["design"]
    assert d["error"]["te_pp"] < 0.01
    assert d["after"]["objective_arcsec"] < d["before"]["objective_arcsec"]
    if res["scene"] == "microgeometry_loaded":
        assert min(min(r) for r in d["before"]["edge_share"]) > 0.2
        assert max(max(r) for r in d["after"]["edge_share"]) < 1e-4
        assert d["after"]["objective_arcsec"] < 0.67 * d["before"]["objective_arcsec"]
        assert max(max(r) for r in d["after"]["p_max_MPa"]) <= res["options"]["p_limit_MPa"] * 1.001
        # the derivatives are taken at the design (a converged optimum: the NLP's optimum is the design)
        assert d["sensitivities"]["model_step_um"] < 0.1 and d["sensitivities"]["at_design"]
    sens = d["sensitivities"]
    assert sens["at_design"] == (sens["model_step_um"] <= 1.0)
    # the active set is read cleanly from IPOPT's central path (no degenerate constraint: unique derivatives)
    assert sens["degenerate"] == 0 and sens["active"] >= 1
    assert all(math.isfinite(v) for v in sens["objective_arcsec_per_Nm"]) and len(sens["objective_arcsec_per_Nm"]) == \
        len(res["torques_Nm"])
    for k, v in d["theta_um"].items():
        lo, hi = res["options"]["free"][k]
        assert lo - 1e-6 <= v <= hi + 1e-6
    assert (out / "loaded_microgeometry.csv").read_text().count("\n") == 1 + len(res["cases"]) * len(res["torques_Nm"])
    if "pareto" in res:
        _pareto_scalars(res, out)
    if res["options"]["unloaded_te"] is not None:
        _unloaded_te_scalars(res, out)


def _unloaded_te_scalars(res, out):
    """The unloaded parabolic-TE target (problems/microgeometry_te_target.toml): the NLP's misfit is the
    exact slices'; each case's misfit recomputed here from the written unloaded TE (numpy least squares
    of the parabola plus a line) is the reported one; the term of the objective is the weighted sum
    of the smoothed misfits; the mirror-image cases (crossing +-2') have the same unloaded TE."""
    d, u = res["design"], res["design"]["unloaded_te"]
    assert d["error"]["te0_rms"] < 1e-4
    lvl = res["options"]["unloaded_te"]["level_arcsec"]
    W = np.sum(np.array(res["options"]["weights"]), axis=0)
    for key in ("before", "after"):
        rms = []
        for c, case in enumerate(u["cases"]):
            e = case[key]
            psi, te = np.array(e["psi"]), np.array(e["te_arcsec"])
            assert psi.size >= 0.9 * res["options"]["verify_positions"] and np.all(np.abs(psi) <= 1.0)
            V = np.stack([np.ones_like(psi), psi], axis=1)
            coef, *_ = np.linalg.lstsq(V, te + lvl * psi**2, rcond=None)
            rms.append(float(np.sqrt(np.mean((te + lvl * psi**2 - V @ coef) ** 2))))
            assert e["rms_arcsec"] == pytest.approx(rms[-1], abs=1e-9)
            assert d[key]["te0_rms_arcsec"][c] == pytest.approx(rms[-1], abs=1e-9)
        weight = res["options"]["unloaded_te"]["weight"]
        assert d[key]["te0_term_arcsec"] == pytest.approx(weight * float(np.sum(W * np.sqrt(np.array(rms) ** 2 + 1e-6))),
                                                          rel=1e-9)
        names = [c["name"] for c in u["cases"]]
        assert rms[names.index("crossing +2'")] == pytest.approx(rms[names.index("crossing -2'")], abs=1e-6)
    assert (out / "loaded_micro_unloaded_te.png").stat().st_size > 10_000


def _pareto_scalars(res, out):
    """The Pareto front (problems/microgeometry_pareto.toml): the optimum without a limit is the
    scene's design; every point meets its limit on the verification grid; the loaded TE rises as
    the limit tightens, by more than an arcsec over the front; the CSV has a row per point; the
    design's sensitivities are those of the NLP it solves (a tighter limit's, when the front keeps
    that limit's design: LoadedMicroStudy), whose optimum lies at the design."""
    assert res["design"]["sensitivities"]["at_design"], res["design"]["sensitivities"]["model_step_um"]
    pts = res["pareto"]["points"]
    assert pts[0]["p_limit_MPa"] is None
    assert pts[0]["objective_arcsec"] == res["design"]["after"]["objective_arcsec"]
    ok = [p for p in pts if p["feasible"]]
    assert len(ok) >= 3
    for p in ok[1:]:
        assert p["p_max_MPa"] <= p["p_limit_MPa"] * 1.001
    te = [p["objective_arcsec"] for p in ok]
    assert all(b >= a - 1e-6 for a, b in zip(te, te[1:])) and te[-1] > te[0] + 1.0
    assert (out / "loaded_micro_pareto.csv").read_text().count("\n") == 1 + len(pts)
    assert (out / "loaded_micro_pareto.png").stat().st_size > 10_000


def bad_scene(tmp_path, scene: str, edit) -> tuple[list, str]:
    """Write ``problems/<scene>.toml`` with ``edit = (old, new)`` applied; check that building it raises
    SceneError and that ``gearopt run`` fails writing nothing. Returns the error's params (its own and
    its problems') and its message."""
    text = (PROBLEMS / f"{scene}.toml").read_text()
    assert edit[0] in text
    f = tmp_path / "bad.toml"
    f.write_text(text.replace(edit[0], edit[1], 1))
    with pytest.raises(SceneError) as e:
        load_scene(f).build()
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--quiet"]) != 0
    assert not out.exists()
    return [e.value.param] + [getattr(p, "param", None) for p in getattr(e.value, "problems", [])], str(e.value)
