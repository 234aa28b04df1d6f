"""Bad input in the studies (gearopt.studies): measured flanks, relief starts,
loaded TCA, Monte Carlo, sweeps, Dask addresses and ``gearopt check``. One test per class, each at
the scene level (``gearopt.cli.main``, a problems/ scene copied into tmp_path with one key changed)
and through the API. A refusal exits 2 with ``error: ...`` (no traceback) and writes nothing.

Limits stated in the messages are checked against numbers computed here from the gear data
(textbook formulas), not by gearopt's own code.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from gearopt.cli import main
from gearopt.errors import ArgumentError, OptionError
from gearopt.units import ARCMIN, DEG

PROBLEMS = Path(__file__).resolve().parent.parent / "problems"


def variant(tmp_path: Path, name: str, *changes, copy=()) -> Path:
    """problems/<name> written into tmp_path with each (old, new) text change made (old must occur);
    ``copy``: files of problems/ copied beside it."""
    text = (PROBLEMS / name).read_text()
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new, 1)
    for f in copy:
        (tmp_path / f).write_text((PROBLEMS / f).read_text())
    path = tmp_path / name
    path.write_text(text)
    return path


def refused(capsys, argv, *needles) -> str:
    """Run the CLI, assert exit 2 with a one-line-per-problem error (no traceback) matching every
    regex of ``needles``; return stderr."""
    capsys.readouterr()
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.startswith("error: ") and "Traceback" not in err, err
    for n in needles:
        assert re.search(n, err), (n, err)
    return err


def csv_rows(text: str) -> tuple[list[str], int]:
    lines = text.splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("L_y"))
    return lines, head


# --- 1. tracebacks ---------------------------------------------------------------------------------
def test_measured_file_not_text_is_named(tmp_path, capsys):
    """A zip or binary file renamed .csv: an error naming the file, not a UnicodeDecodeError."""
    import zipfile

    from gearopt.geometry.inspection import read_grid_csv

    with zipfile.ZipFile(tmp_path / "zipped.csv", "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("measured_flank_right.csv", (PROBLEMS / "measured_flank_right.csv").read_text())
    (tmp_path / "noise.csv").write_bytes(bytes(range(128, 256)) * 20)  # not UTF-8, no NUL byte
    scene = variant(tmp_path, "measured_flank.toml", ('"measured_flank_right.csv"', '"zipped.csv"'),
                    copy=("measured_flank_left.csv",))
    refused(capsys, ["check", str(scene)], r"\[pinion.measured\] right", "zipped.csv", "not a text file")
    for f in ("zipped.csv", "noise.csv"):
        with pytest.raises(ArgumentError, match=f"{f}: not (a text file|UTF-8 text)"):
            read_grid_csv(tmp_path / f)


def test_scheduler_address_mistyped(tmp_path, capsys):
    """`tpc://...`: an error naming the scheduler and the accepted forms, before any sample runs."""
    from gearopt.robust.execution import connect

    scene = variant(tmp_path, "montecarlo_spur.toml", ("samples = 1000", "samples = 4"))
    out = tmp_path / "out"
    refused(capsys, ["run", str(scene), "--quiet", "--out", str(out), "--scheduler", "tpc://127.0.0.1:8786"],
            "tpc://127.0.0.1:8786", "tcp://HOST:PORT")
    assert not out.exists()
    for bad in ("tpc://127.0.0.1:8786", "tcp://127.0.0.1:87x6", "tcp://127.0.0.1:99999"):
        with pytest.raises(OptionError) as e:
            connect(bad, timeout=0.5)
        assert e.value.param == "scheduler" and "tcp://HOST:PORT" in str(e.value)


def test_sweep_range_end_validated_like_a_fixed_value(tmp_path, capsys):
    """A [sweep.vary] range whose far end makes the flank degenerate: `check` refuses it naming the
    key and the end (a_c, a_pl, crossing), as it refuses the fixed value."""
    from gearopt.io.scene import load_scene
    from gearopt.robust.study import DesignSweep

    cases = [('a_c = { lo = "0.001 1/mm", hi = "0.004 1/mm" }', 'a_c = { lo = "0.001 1/mm", hi = "0.5 1/mm" }',
              r"\[sweep.vary\] a_c = .*0\.5 1/mm.*a_c <= "),
             ('a_pl = { lo = "0.0001 1/mm", hi = "0.0006 1/mm" }', 'a_pl = { lo = "0.0001 1/mm", hi = "0.5 1/mm" }',
              r"\[sweep.vary\] a_pl = .*0\.5 1/mm.*a_pl <= "),
             ('crossing = { lo = "-4 arcmin", hi = "4 arcmin" }', 'crossing = { lo = "-30 deg", hi = "30 deg" }',
              r"\[sweep.vary\] crossing = .*-1800 arcmin \(-30 deg\).*600 arcmin \(10 deg\)")]
    for old, new, needle in cases:
        refused(capsys, ["check", str(variant(tmp_path, "doe_helical.toml", (old, new)))], needle)
    pair = load_scene(PROBLEMS / "doe_helical.toml").pair
    with pytest.raises(OptionError) as e:
        DesignSweep(pair, {"pinion.a_c": (0.001, 0.5)}, design="lhs", samples=4)
    assert e.value.param == "variables.pinion.a_c"
    with pytest.raises(OptionError) as e:
        DesignSweep(pair, {"mis.crossing": (-15 * DEG, 0.0)}, design="lhs", samples=4)
    assert e.value.param == "variables.mis.crossing" and "-900 arcmin" in str(e.value)


def test_sensitivities_of_an_input_constant_over_the_solved_samples():
    """An input that varies over the study but not over the samples with results (the far end of
    its range failed): no LinAlgError, the input is left out of the ranking."""
    from gearopt.robust.study import RobustResult

    rng = np.random.default_rng(1)
    n = 12
    a = np.r_[np.full(8, 1e-3), np.full(4, 0.13)]  # the last four samples have no TE
    b = rng.uniform(-1e-3, 1e-3, n)
    te = np.r_[rng.uniform(1e-5, 2e-5, 8) + b[:8], np.full(4, np.nan)]
    figs = {"te_p2p": te, "harmonics": np.c_[te, te, te], "edge_contact": np.zeros(n, bool),
            "pattern_at_edge": np.zeros(n, bool), "ok": np.r_[np.ones(8, bool), np.zeros(4, bool)],
            "feasible": np.ones(n, bool)}
    r = RobustResult("sweep", "t", {"pinion.a_c": a, "mis.crossing": b}, {}, figs, np.zeros((2, 2)),
                     np.zeros(3), np.zeros(3), {}, {})
    ranked = r.sensitivities()["te_p2p"]
    assert [row["input"] for row in ranked] == ["mis.crossing"]


# --- 2. the wrong key blamed -----------------------------------------------------------------------
def test_measured_deviation_unit_and_outlier_blamed_on_the_file(tmp_path, capsys):
    """'# deviation: mm' over um values, or one 5000 um cell: refused naming the file, its row and
    column and the bound 0.1 m_n = 250 um (m_n = 2.5 mm), not [tca]."""
    from gearopt.geometry.inspection import check_grid_on_flank, read_grid_csv
    from gearopt.io.scene import load_scene

    text = (PROBLEMS / "measured_flank_right.csv").read_text()
    (tmp_path / "in_mm.csv").write_text(text.replace("# deviation: um", "# deviation: mm"))
    lines, head = csv_rows(text)
    row = lines[head + 10].split(",")
    row[5] = "5000"
    lines[head + 10] = ",".join(row)
    (tmp_path / "outlier.csv").write_text("\n".join(lines) + "\n")
    for f, needle in (("in_mm.csv", r"state the wrong unit"), ("outlier.csv", r"row 9 column 5 .* = 5000 um")):
        scene = variant(tmp_path, "measured_flank.toml", ('"measured_flank_right.csv"', f'"{f}"'),
                        copy=("measured_flank_left.csv",))
        err = refused(capsys, ["check", str(scene)], r"\[pinion.measured\] right", f, needle, r"<= 0\.1 m_n = 250 um")
        assert "[tca]" not in err
    pinion = load_scene(PROBLEMS / "measured_flank.toml").pair.pinion
    with pytest.raises(ArgumentError, match=r"outlier.csv: row 9 column 5"):
        check_grid_on_flank(read_grid_csv(tmp_path / "outlier.csv"), pinion)


def test_sweep_a_pl_failure_names_a_pl(tmp_path, capsys):
    """An a_pl range past the plunge limit of this drive (pi m_n / 8 at the face ends: a_pl_max =
    pi m_n / 8 / ((b/2)^2 sin(alpha_n)))."""
    a_max = math.pi * 2.5 / 8 / (15.0**2 * math.sin(20 * DEG))
    err = refused(capsys, ["check", str(variant(tmp_path, "doe_helical.toml",
                                                ('hi = "0.0006 1/mm"', f'hi = "{1.5 * a_max:.6f} 1/mm"')))],
                  r"\[sweep.vary\] a_pl")
    assert f"{a_max:.4g}" in err, err


# --- 3. accepted silently --------------------------------------------------------------------------
def _with_roll_lengths(text: str, f) -> str:
    lines, head = csv_rows(text)
    body = []
    for line in lines[head + 1:]:
        cells = line.split(",")
        cells[0] = repr(f(float(cells[0])))
        body.append(",".join(cells))
    if f(1.0) < f(0.0):
        body = body[::-1]
    return "\n".join(lines[:head + 1] + body) + "\n"


def test_measured_roll_lengths_off_the_flank(tmp_path, capsys):
    """Negative roll lengths (mirrored grid) and a grid below the form circle are refused, naming
    the file, column 0 and the flank's roll-length range."""
    from gearopt.geometry.inspection import check_grid_on_flank, read_grid_csv
    from gearopt.io.scene import load_scene

    text = (PROBLEMS / "measured_flank_right.csv").read_text()
    (tmp_path / "mirrored.csv").write_text(_with_roll_lengths(text, lambda L: -L))
    (tmp_path / "low.csv").write_text(_with_roll_lengths(text, lambda L: 0.05 * L))  # all below L(d_Ff)
    pinion = load_scene(PROBLEMS / "measured_flank.toml").pair.pinion
    L_a = math.sqrt(pinion.r_a**2 - pinion.r_b**2)
    for f, needle in (("mirrored.csv", r"L_y = -15\.5427 mm.*never negative"), ("low.csv", "below the form circle")):
        scene = variant(tmp_path, "measured_flank.toml", ('"measured_flank_right.csv"', f'"{f}"'),
                        copy=("measured_flank_left.csv",))
        refused(capsys, ["check", str(scene)], f, "column 0", needle, f"L_a = {L_a:.6g} mm")
        with pytest.raises(ArgumentError, match=f):
            check_grid_on_flank(read_grid_csv(tmp_path / f), pinion)


def test_relief_start_off_the_flank(tmp_path, capsys):
    """d_Ca below the form circle (d_Ff of the straight rack: the flank end h_aP0 - x below the
    pitch line), a root relief overlapping the tip relief, an L_Ca below the form circle."""
    from gearopt.geometry.microgeometry import Microgeometry
    from gearopt.io.scene import load_scene

    pinion = load_scene(PROBLEMS / "microgeometry_helical.toml").pair.pinion
    # ISO 53 A (h_fP = 1.25, rho_fP = 0.38 m_n): the straight flank ends h = (1.25 - 0.38 (1 - sin 20 deg)) m_n
    # below the datum line (x = 0) and generates the form circle where it crosses the line of action
    m_n, alpha_t = 2.5, math.atan(math.tan(20 * DEG) / math.cos(18 * DEG))
    r_p = 21 * m_n / math.cos(18 * DEG) / 2
    r_b = r_p * math.cos(alpha_t)
    h = (1.25 - 0.38 * (1 - math.sin(20 * DEG))) * m_n
    d_ff = 2 * math.hypot(r_b, r_p * math.sin(alpha_t) - h / math.sin(alpha_t))
    d_bad = (2 * r_b + d_ff) / 2
    refused(capsys, ["check", str(variant(tmp_path, "microgeometry_helical.toml",
                                          ('d_Ca = "59.2 mm"', f'd_Ca = "{d_bad:.3f} mm"')))],
            r"\[pinion.modifications\] d_Ca", f"d_Ff = {d_ff:.6g} mm < d_Ca")
    refused(capsys, ["check", str(variant(tmp_path, "microgeometry_helical.toml",
                                          ('d_Ca = "59.2 mm"', 'd_Ca = "59.2 mm"\nd_Cf = "59.6 mm"\nC_alpha_f = "4 um"')))],
            r"\[pinion.modifications\] d_Cf", "must not overlap")
    with pytest.raises(ArgumentError, match=r"pinion.modifications.L_Ca"):
        pinion.with_(modifications=Microgeometry(C_alpha_a=0.008, L_Ca=0.5))


def test_distribution_parameters_obey_the_fixed_limits(tmp_path, capsys):
    """A crossing sd of 30 deg (mean +- 3 sd far beyond the 10 deg a fixed crossing may have) is
    refused at check; a uniform +-15 arcmin (within 10 deg) is accepted; messages in arcmin/deg."""
    from gearopt.io.scene import load_scene
    from gearopt.robust.sampling import Distribution
    from gearopt.robust.study import MonteCarlo

    scene = variant(tmp_path, "montecarlo_spur.toml",
                    ('crossing = { kind = "normal", mean = "0 arcmin", sd = "1.5 arcmin" }',
                     'crossing = { kind = "normal", mean = "0 arcmin", sd = "30 deg" }'))
    err = refused(capsys, ["check", str(scene)], r"\[montecarlo\] crossing.sd = \"30 deg\"", r"600 arcmin \(10 deg\)")
    assert "0.5235" not in err  # not in radians
    pair = load_scene(PROBLEMS / "montecarlo_spur.toml").pair
    MonteCarlo(pair, 4, misalignment={"crossing": Distribution("uniform", lo=-15 * ARCMIN, hi=15 * ARCMIN)})
    for d, p in ((Distribution("uniform", lo=-11 * DEG, hi=0.0), "lo"), (Distribution("normal", sd=4 * DEG), "sd"),
                 (Distribution("triangular", lo=0.0, mode=0.0, hi=12 * DEG), "hi")):
        with pytest.raises(OptionError) as e:
            MonteCarlo(pair, 4, misalignment={"intersecting": d})
        assert e.value.param == f"misalignment.intersecting.{p}" and "arcmin" in str(e.value)


MC_SMALL = (("samples = 1000", "samples = 6"), ("positions = 64", "positions = 16"))


@pytest.mark.slow
def test_mostly_infeasible_study_warns_and_none_feasible_refused(tmp_path, capsys):
    """Centre-distance tolerance +-2 mm on a 50 um backlash: most samples jam -> a warning on
    stderr and feasible_fraction / warnings in results.json; a fixed dE that jams every sample ->
    refused, nothing written."""
    scene = variant(tmp_path, "montecarlo_spur.toml", *MC_SMALL, ('f_a = "0.02 mm"', 'f_a = "2 mm"'),
                    ('spread = "normal"', 'spread = "uniform"'))
    out = tmp_path / "out"
    capsys.readouterr()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        assert main(["run", str(scene), "--quiet", "--out", str(out)]) == 0
    msgs = [str(x.message) for x in w if "samples" in str(x.message)]
    assert msgs and re.search(r"only \d of 6 samples", msgs[0]), msgs
    res = json.loads((out / "results.json").read_text())
    assert res["statistics"]["feasible_fraction"] < 0.5 and res["warnings"]
    scene = variant(tmp_path, "montecarlo_spur.toml", *MC_SMALL, ('f_a = "0.02 mm"\n', ""),
                    ('positions = 16', 'positions = 16\ndE = {kind = "fixed", value = "-0.3 mm"}'))
    out2 = tmp_path / "out2"
    refused(capsys, ["run", str(scene), "--quiet", "--out", str(out2)], "none of the 6 samples has results")
    assert not out2.exists()


# --- 4. absurd loads -------------------------------------------------------------------------------
def test_ltca_torque_beyond_the_elastic_model(tmp_path, capsys):
    """torque = 1e6 N m on ltca_spur: the Hertz pressure of the line contact (p0 = sqrt(w E* / (pi
    rho)), far above 5000 MPa here) is refused naming the torque and the limit; nothing written. The
    same in the API (LTCA.solve), and a valid torque passes."""
    from gearopt.io.scene import load_scene
    from gearopt.ltca import LTCA

    out = tmp_path / "out"
    scene = variant(tmp_path, "ltca_spur.toml", ("torque = 200.0", "torque = 1e6"))
    refused(capsys, ["run", str(scene), "--quiet", "--out", str(out)], r"\[ltca\] torque", "5000 MPa",
            "linear-elastic")
    assert not out.exists()
    pair = load_scene(PROBLEMS / "ltca_spur.toml").pair
    # the line-contact Hertz pressure at the pitch point with the load on one tooth, b = 20 mm
    W = 2e4 * 1e3 / pair.pinion.r_b
    rho = 1 / (1 / (pair.pinion.r_b * math.tan(pair.alpha_wt)) + 1 / (pair.gear.r_b * math.tan(pair.alpha_wt)))
    E_star = 206000 / (1 - 0.3**2) / 2
    assert math.sqrt(W / 20 * E_star / (math.pi * rho)) > 5000  # 2e4 N m is beyond the limit by Hertz alone
    lt = LTCA(pair, n_slices=5)
    phi = lt.mesh_cycle(16)
    with pytest.raises(OptionError) as e:
        lt.solve(2e4, phi1=phi)
    assert e.value.param == "torque" and e.value.value == 2e4
    r = lt.solve(200.0, phi1=phi).results[0]
    assert np.all(r.stiffness > 0) and r.p_max < 5000


@pytest.mark.slow
def test_montecarlo_torque_beyond_the_elastic_model(tmp_path, capsys):
    """A loaded Monte Carlo with torques up to 1e7 N m: refused by `check` (the Hertz pressure of
    the load over the longest contact line already exceeds the limit); a torque of 5500 N m, below
    that bound but beyond the solved pressure limit, is refused at run time naming the sample and
    its torque (never a negative mesh stiffness); nothing written."""
    from gearopt.io.scene import load_scene
    from gearopt.robust.sampling import Distribution
    from gearopt.robust.study import MonteCarlo

    small = (("samples = 24", "samples = 2"), ("chunk = 8", "chunk = 2"))
    scene = variant(tmp_path, "montecarlo_loaded.toml", *small, ("torque = { kind = \"uniform\", lo = 50, hi = 150 }",
                                                                 "torque = { kind = \"uniform\", lo = 1e6, hi = 1e7 }"))
    refused(capsys, ["check", str(scene)], r"\[montecarlo\] torque.hi = 1(e\+07|0000000\.0) ", "linear-elastic", "5000 MPa")
    pair = load_scene(PROBLEMS / "montecarlo_loaded.toml").pair
    with pytest.raises(OptionError) as e:
        MonteCarlo(pair, 2, iso_grade=6, torque=Distribution("uniform", lo=1e6, hi=1e7, name="torque"))
    assert e.value.param == "torque.hi"
    scene = variant(tmp_path, "montecarlo_loaded.toml", *small, ("torque = { kind = \"uniform\", lo = 50, hi = 150 }",
                                                                 "torque = { kind = \"fixed\", value = 5500 }"))
    out = tmp_path / "out"
    refused(capsys, ["run", str(scene), "--quiet", "--out", str(out)], r"sample 0 \(.*torque = 5500 N m\)",
            "linear-elastic", "5000 MPa")
    assert not out.exists()


# --- 6. check writes nothing -----------------------------------------------------------------------
@pytest.mark.slow
def test_check_writes_nothing(tmp_path, capsys, monkeypatch):
    """`gearopt check` of every scene in problems/ (and of an ltca scene with compliance = "fe")
    starts no CalculiX and writes nothing: not in the cache, not in the working directory."""
    import gearopt.fea.calculix as calculix

    def no_ccx(*a, **k):
        raise AssertionError("gearopt check started CalculiX")

    monkeypatch.setattr(calculix, "require_ccx", no_ccx)
    cache, work = tmp_path / "cache", tmp_path / "work"
    cache.mkdir()
    work.mkdir()
    monkeypatch.setenv("GEAROPT_CACHE", str(cache))
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache / "xdg"))
    monkeypatch.delenv("GEAROPT_CACHE_DIR", raising=False)
    src = tmp_path / "scenes"
    src.mkdir()
    fe = variant(src, "ltca_spur.toml", ("nu = 0.3", 'nu = 0.3\ncompliance = "fe"'))
    for f in PROBLEMS.glob("*.csv"):
        (src / f.name).write_text(f.read_text())
    scenes = sorted(PROBLEMS.glob("*.toml"))
    assert len(scenes) >= 20
    monkeypatch.chdir(work)
    for path in [fe, *scenes]:
        before = {p: p.stat().st_mtime_ns for p in src.iterdir()}
        capsys.readouterr()
        assert main(["check", str(path)]) == 0, capsys.readouterr().err
        assert {p: p.stat().st_mtime_ns for p in src.iterdir()} == before
        assert not any(cache.rglob("*")), (path, list(cache.rglob("*")))
        assert not any(work.iterdir()), (path, list(work.iterdir()))
