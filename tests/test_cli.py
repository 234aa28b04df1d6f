"""The gearopt command line (gearopt.cli) and the all-or-nothing results writer (gearopt.io.results)."""

from __future__ import annotations

import json
import re
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import GOOD_SCENE
from gearopt import cli
from gearopt.cli import main
from gearopt.io.results import MANIFEST, write_results

REPO = Path(__file__).resolve().parents[1]
TESTS = Path(__file__).resolve().parent
BAD_SCENE = GOOD_SCENE.replace("z = 20", "z = 2")


def leftovers(parent: Path) -> list[str]:
    """Temporary directories of the results writer left in ``parent``."""
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def test_run_bad_scene_exits_2_and_writes_nothing(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(BAD_SCENE, "bad.toml")
    out = tmp_path / "out" / "bad"
    assert main(["run", str(scene), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"error: {scene}: [pinion] z = 2 is out of range; valid: z >= 3 teeth." in err
    assert "Traceback" not in err
    assert not out.exists()
    assert not (tmp_path / "out").exists() or leftovers(tmp_path / "out") == []


def test_run_good_scene_writes_results_and_plots(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(GOOD_SCENE)
    out = tmp_path / "results" / "good"
    assert main(["run", str(scene), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    printed = captured.out.split()
    assert printed == [str(out / "results.json"), str(out / "dummy.png"), str(out / "report.html")]
    assert "gearopt: loading" in captured.err and "dummy study running" in captured.err
    data = json.loads((out / "results.json").read_text())
    assert data["units"]["r_a"] == "mm"
    assert data["a_w"] == pytest.approx(60.0)
    assert data["n"] == 4
    meta = data["meta"]
    assert meta["scene"] == str(scene) and meta["study"] == "dummy" and meta["scene_name"] == "dummy spur"
    assert meta["gearopt_version"] and meta["timestamp"] and meta["run_time_s"] >= 0
    assert (out / "dummy.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert leftovers(out.parent) == []


def test_run_quiet_and_no_plots(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(GOOD_SCENE + "[output]\nplots = false\n")
    out = tmp_path / "o"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out.split() == [str(out / "results.json"), str(out / "report.html")]
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "report.html", "results.json"]


def test_run_replaces_previous_output_only_on_success(dummy_study, scene_file, tmp_path, capsys):
    out = tmp_path / "o"
    scene = scene_file(GOOD_SCENE.replace("n = 4", "n = 3"))
    assert main(["run", str(scene), "--out", str(out), "-q"]) == 0
    first = (out / "results.json").read_text()
    assert json.loads(first)["n"] == 3
    # failure while plotting (a bug, not an input error): propagates, the previous results stay untouched
    scene = scene_file(GOOD_SCENE.replace("n = 4", "n = 4\nfail_plots = true"))
    with pytest.raises(RuntimeError, match="on purpose"):
        main(["run", str(scene), "--out", str(out), "-q"])
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "dummy.png", "report.html", "results.json"]
    assert (out / "results.json").read_text() == first
    assert leftovers(tmp_path) == []
    # NaN in the results: a clear error (exit 2, no traceback), nothing written either
    scene = scene_file(GOOD_SCENE.replace("n = 4", "n = 4\nnan = true"))
    capsys.readouterr()
    assert main(["run", str(scene), "--out", str(out), "-q"]) == 2
    assert re.search(r"error: .*non-finite.*angle", capsys.readouterr().err)
    assert (out / "results.json").read_text() == first
    # success replaces the previous output's files
    scene = scene_file(GOOD_SCENE)
    assert main(["run", str(scene), "--out", str(out), "-q"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "dummy.png", "report.html", "results.json"]
    assert json.loads((out / "results.json").read_text())["n"] == 4
    assert leftovers(tmp_path) == []


def test_default_out_dir(dummy_study, scene_file, tmp_path, monkeypatch, capsys):
    scene = scene_file(GOOD_SCENE, "my_scene.toml")
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(scene), "-q"]) == 0
    assert (tmp_path / "out" / "my_scene" / "results.json").is_file()


def test_check(dummy_study, scene_file, tmp_path, capsys):
    good = scene_file(GOOD_SCENE)
    assert main(["check", str(good)]) == 0
    assert "ok:" in capsys.readouterr().out
    bad = scene_file(BAD_SCENE, "bad.toml")
    assert main(["check", str(bad)]) == 2
    assert "[pinion] z = 2" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "scene.toml"]


def test_missing_scene_file(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nope.toml")]) == 2
    assert "no such scene file" in capsys.readouterr().err


def test_studies_lists_sections(dummy_study, capsys):
    assert main(["studies"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^  dummy +dummy study for tests$", out, re.M)
    assert "[dummy]" not in out and "gearopt studies NAME" in out  # compact: no keys
    assert main(["studies", "dummy"]) == 0
    out = capsys.readouterr().out
    assert "dummy: dummy study for tests" in out
    assert "[dummy]" in out and "angle (angle [deg], default 10)" in out
    assert main(["studies", "common"]) == 0
    out = capsys.readouterr().out
    assert "[pair]" in out and "P_n (inverse_length [1/in]" in out
    assert "[pinion.rack]" in out


def test_write_results_requires_units(tmp_path):
    class NoUnits:
        def to_dict(self):
            return {"x": 1.0}

        def save_plots(self, d):
            return []

    with pytest.raises(ValueError, match="units"):
        write_results(tmp_path / "r", NoUnits())
    assert list(tmp_path.iterdir()) == []


def test_write_results_numpy(tmp_path):
    import numpy as np

    class R:
        def to_dict(self):
            return {"units": {"r": "mm"}, "r": np.linspace(0, 1, 3), "n": np.int64(3)}

        def save_plots(self, d):
            return []

    paths = write_results(tmp_path / "r", R(), run_time=0.5)
    data = json.loads(paths[0].read_text())
    assert data["r"] == [0.0, 0.5, 1.0] and data["n"] == 3 and data["meta"]["run_time_s"] == 0.5


def _env(*extra_paths):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *map(str, extra_paths), env.get("PYTHONPATH", "")])
    env["MPLBACKEND"] = "Agg"
    return env


def test_subprocess_bad_scene(scene_file, tmp_path):
    scene = scene_file(GOOD_SCENE.replace("name =", "nmae ="), "bad.toml")
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "gearopt", "run", str(scene), "--out", str(out)],
                       capture_output=True, text=True, cwd=tmp_path, env=_env(), timeout=120)
    assert r.returncode == 2, r.stderr
    assert "error:" in r.stderr and "[scene] nmae" in r.stderr and "Did you mean 'name'" in r.stderr
    assert "Traceback" not in r.stderr
    assert not out.exists()


@pytest.mark.slow
def test_subprocess_good_scene_with_plugin_study(scene_file, tmp_path):
    (tmp_path / "dummy_plugin.py").write_text("from conftest import register_dummy\nregister_dummy()\n")
    scene = scene_file(GOOD_SCENE)
    out = tmp_path / "out"
    env = _env(TESTS, tmp_path)
    env["GEAROPT_STUDY_MODULES"] = "dummy_plugin"
    r = subprocess.run([sys.executable, "-m", "gearopt", "run", str(scene), "--out", str(out)],
                       capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    assert (out / "results.json").is_file() and (out / "dummy.png").is_file()
    assert r.stdout.split() == [str(out / "results.json"), str(out / "dummy.png"), str(out / "report.html")]


# ----------------------------------------------------------------------------------------------
# Progress of long work (gearopt.progress): lines on stderr, none with --quiet
# ----------------------------------------------------------------------------------------------
def test_heartbeat_reports_silence_and_nothing_without_progress():
    import time

    from gearopt.progress import current, heartbeat, reporting

    lines = []
    with heartbeat(lines.append, "solve", every=0.05) as say:
        say("own line")
        time.sleep(0.4)
    n = len(lines)
    time.sleep(0.1)
    assert len(lines) == n  # the thread stopped with the block
    assert lines[0] == "own line" and len(lines) >= 3
    assert all(re.fullmatch(r"solve: \d+ s", x) for x in lines[1:]), lines
    with heartbeat(None, "solve", every=0.01) as say:
        assert say is None
        time.sleep(0.05)
    assert current() is None
    with reporting(lines.append):
        current()("deep")
    assert lines[-1] == "deep" and current() is None


def _fake_fe(monkeypatch, tmp_path):
    """problems/fea_spur.toml with CalculiX and the FE model replaced by fast stand-ins."""
    import time

    import gearopt.fea.calculix as calculix
    import gearopt.fea.model as model
    import gearopt.progress as progress
    import gearopt.studies.fea as fea

    class Res:
        def __init__(self, phi1):
            self.phi1 = phi1

        def to_dict(self):
            return {"phi1": self.phi1}

        def write_vtu(self, path):
            Path(path).write_text("vtu")

    class Model:
        def __init__(self, pair, phi1, opt, tca=None, mis=None):
            import numpy as np

            self.phi1, self.build_time = phi1, 0.01
            self.nodes_pinion = self.nodes_gear = np.zeros((5, 3))
            self.pinion_mesh = self.gear_mesh = type("M", (), {"elements": np.zeros((2, 8))})()

        def run(self):
            time.sleep(0.3)
            return Res(self.phi1)

    real = progress.heartbeat
    monkeypatch.setattr(calculix, "require_ccx", lambda: "ccx")
    monkeypatch.setattr(model, "GearFEModel", Model)
    monkeypatch.setattr(fea, "mesh_section", lambda m: {})
    monkeypatch.setattr(progress, "heartbeat", lambda p, label, every=15.0: real(p, label, every=0.05))
    scene = tmp_path / "fea.toml"
    scene.write_text((REPO / "problems" / "fea_spur.toml").read_text() + "\n[output]\nplots = false\n")
    return scene


def test_fe_positions_report_progress_and_quiet_silences_it(monkeypatch, tmp_path, capsys):
    scene = _fake_fe(monkeypatch, tmp_path)
    assert main(["run", str(scene), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    for i in (1, 2, 3):
        assert re.search(rf"gearopt: fea: position {i}/3 \(phi1 = -?\d+\.\d+ deg\): building the model", err)
        assert f"gearopt: fea: position {i}/3: 10 nodes, 4 elements" in err
        assert re.search(rf"gearopt: fea: position {i}/3: CalculiX running: \d+ s", err)  # the heartbeat
        assert re.search(rf"gearopt: fea: position {i}/3: done in \d+\.\d s", err)
    assert main(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_fe_influence_cache_build_reports_to_the_installed_receiver(monkeypatch, tmp_path):
    """The influence coefficients are built below a study (with the LTCA engine); they report to the
    receiver the CLI installs (gearopt.progress.reporting). CalculiX itself is replaced: it stops the
    build right after the lines before it."""
    import gearopt.fea.influence as influence
    from gearopt import Gear
    from gearopt.fea.mesh import MeshOptions
    from gearopt.geometry.generation import generate
    from gearopt.progress import reporting

    class Stop(Exception):
        pass

    def ccx(*a, **k):
        raise Stop

    monkeypatch.setenv("GEAROPT_CACHE", str(tmp_path))
    monkeypatch.setattr(influence, "run_ccx", ccx)
    tooth = generate(Gear(z=20, m_n=3.0, b=20.0, name="pinion"))
    mesh = MeshOptions(n_face=2, n_half=3, n_flank=4, n_fillet=3, n_rim=2)
    with pytest.raises(Stop):
        influence.influence_grid(tooth, mesh=mesh, use_cache=False)  # no receiver: silent
    lines = []
    with reporting(lines.append), pytest.raises(Stop):
        influence.influence_grid(tooth, mesh=mesh, use_cache=False)
    assert len(lines) == 1, lines
    assert re.fullmatch(r"FE influence coefficients of the pinion: CalculiX, \d+ unit loads on \d+ nodes "
                        r"\(cached afterwards in .+\)", lines[0]), lines
    import gearopt.fea.local as local

    monkeypatch.setattr(local, "section_compression", ccx)
    lines.clear()
    with reporting(lines.append), pytest.raises(Stop):
        local.local_excess(tooth, [tooth.gear.r_p, tooth.gear.r_p + 1.0], use_cache=False)
    assert len(lines) == 1 and re.fullmatch(r"FE local compression of the pinion: CalculiX section 1/2 "
                                            r"\(r = \d+\.\d{3} mm, 0 s so far\)", lines[0]), lines


def test_python_dash_m_gearopt_is_the_cli(monkeypatch, capsys):
    """``python -m gearopt studies`` (gearopt/__main__.py, run in this process) exits as ``gearopt
    studies`` does, with the list of studies."""
    import runpy

    monkeypatch.setattr(sys, "argv", ["gearopt", "studies"])
    with pytest.raises(SystemExit) as e:
        runpy.run_module("gearopt", run_name="__main__", alter_sys=True)
    assert e.value.code == 0
    assert "tca" in capsys.readouterr().out


_BLAS_PROBE = r"""
import ctypes, json, os, sys
import numpy, scipy.linalg, casadi
from gearopt import cli
GETTERS = ("openblas_get_num_threads", "scipy_openblas_get_num_threads", "scipy_openblas_get_num_threads64_")
def counts():
    out = {}
    paths = [l.split(None, 5)[5].strip() for l in open("/proc/self/maps") if "openblas" in l.rsplit("/", 1)[-1]]
    paths.append(os.path.join(os.path.dirname(casadi.__file__), "libcasadi-tp-openblas.so.0"))
    for p in dict.fromkeys(os.path.realpath(p) for p in paths):
        lib = ctypes.CDLL(p)
        for g in GETTERS:
            f = getattr(lib, g, None)
            if f is not None:
                out[os.path.basename(p)] = f()
                break
    return out
before = counts()
cli.main(["studies"])
print("PROBE " + json.dumps([before, counts()]))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or (os.cpu_count() or 1) < 2,
                    reason="OpenBLAS's thread count is set through /proc/self/maps (Linux); one CPU: one thread anyway")
@pytest.mark.parametrize("chosen", [None, "2"])
def test_the_command_sets_casadis_openblas_to_one_thread_unless_the_user_chose(chosen):
    """`gearopt` (cli.main) sets CasADi's OpenBLAS (not loaded yet: numpy imported before it runs) to
    one thread and leaves numpy's and scipy's; with OPENBLAS_NUM_THREADS set it leaves them all."""
    import json
    import subprocess

    env = {k: v for k, v in os.environ.items() if k not in cli.BLAS_THREAD_VARIABLES}
    if chosen is not None:
        env["OPENBLAS_NUM_THREADS"] = chosen
    p = subprocess.run([sys.executable, "-c", _BLAS_PROBE], env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    before, after = json.loads(next(s for s in p.stdout.splitlines() if s.startswith("PROBE "))[6:])
    assert len(after) >= 3 and any("casadi" in k for k in after)  # numpy's, scipy's, CasADi's
    if chosen is None:
        assert min(before.values()) > 1
        assert {k: v for k, v in after.items() if "casadi" not in k} == {k: v for k, v in before.items() if "casadi" not in k}
        assert [v for k, v in after.items() if "casadi" in k] == [1]
    else:
        assert set(before.values()) == set(after.values()) == {int(chosen)}
