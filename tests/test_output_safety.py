"""gearopt never removes a file it did not write: ``--out`` refuses a directory of the user's own
files, replaces only the files a previous gearopt output lists in its manifest, and leaves the
previous output as it was when a run fails (gearopt.io.results)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from conftest import GOOD_SCENE
from gearopt.cli import main
from gearopt.errors import ResultsError
from gearopt.io.results import MANIFEST, check_out_dir, install_output, output_files, write_results


def tree(d: Path) -> dict[str, bytes]:
    """Every file under ``d`` (relative path -> content)."""
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def hidden_leftovers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith(".") and p.name != MANIFEST)


def run(capsys, *args) -> tuple[int, str]:
    capsys.readouterr()
    rc = main(["run", *map(str, args), "-q"])
    return rc, capsys.readouterr().err


def test_user_file_in_out_is_refused_and_nothing_is_written(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(GOOD_SCENE)
    out = tmp_path / "results"
    out.mkdir()
    (out / "notes.txt").write_text("my notes")
    rc, err = run(capsys, scene, "--out", out)
    assert rc == 2 and "Traceback" not in err
    assert re.search(r"error: --out .*results: the directory exists and holds files gearopt did not write "
                     r"\(notes\.txt\)", err)
    assert "Choose another --out" in err and "empty this directory" in err
    assert tree(out) == {"notes.txt": b"my notes"}
    assert hidden_leftovers(tmp_path) == []


def test_user_subdirectory_and_hidden_file_are_refused(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(GOOD_SCENE)
    out = tmp_path / "o"
    (out / "data").mkdir(parents=True)
    (out / "data" / "x.csv").write_text("1,2")
    (out / ".keep").write_text("")
    rc, err = run(capsys, scene, "--out", out)
    assert rc == 2 and ".keep" in err and "data/" in err
    assert tree(out) == {".keep": b"", "data/x.csv": b"1,2"}


def test_empty_directory_is_used(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(GOOD_SCENE)
    out = tmp_path / "o"
    out.mkdir()
    assert run(capsys, scene, "--out", out)[0] == 0
    assert sorted(tree(out)) == [MANIFEST, "dummy.png", "report.html", "results.json"]
    assert sorted(json.loads((out / MANIFEST).read_text())["files"]) == ["dummy.png", "report.html", "results.json"]


def test_previous_output_is_replaced_and_a_note_added_later_is_kept(dummy_study, scene_file, tmp_path, capsys):
    out = tmp_path / "o"
    assert run(capsys, scene_file(GOOD_SCENE), "--out", out)[0] == 0
    (out / "notes.txt").write_text("looked at it, fine")
    assert run(capsys, scene_file(GOOD_SCENE + "[output]\nplots = false\n"), "--out", out)[0] == 0
    files = tree(out)
    # the plot of the first run is gone (gearopt wrote it), the user's note is not
    assert sorted(files) == [MANIFEST, "notes.txt", "report.html", "results.json"]
    assert files["notes.txt"] == b"looked at it, fine"
    assert json.loads(files[MANIFEST])["files"] == ["report.html", "results.json"]
    assert hidden_leftovers(tmp_path) == []


def test_failure_mid_run_leaves_the_previous_output_intact(dummy_study, scene_file, tmp_path, capsys):
    out = tmp_path / "o"
    assert run(capsys, scene_file(GOOD_SCENE), "--out", out)[0] == 0
    (out / "notes.txt").write_text("mine")
    before = tree(out)
    scene = scene_file(GOOD_SCENE.replace("n = 4", "n = 4\nfail_plots = true"))
    with pytest.raises(RuntimeError, match="on purpose"):
        main(["run", str(scene), "--out", str(out), "-q"])
    assert tree(out) == before
    assert run(capsys, scene_file(GOOD_SCENE.replace("n = 4", "n = 4\nnan = true")), "--out", out)[0] == 2
    assert tree(out) == before
    assert hidden_leftovers(tmp_path) == []


def test_measured_csv_of_the_scene_inside_out_survives(dummy_study, scene_file, tmp_path, capsys):
    scene = scene_file(GOOD_SCENE)
    out = tmp_path / "o"
    out.mkdir()
    csv = out / "measured_flank_right.csv"
    csv.write_text("# profile: L_y mm\n0,1\n")
    rc, err = run(capsys, scene, "--out", out)
    assert rc == 2 and "measured_flank_right.csv" in err
    assert tree(out) == {"measured_flank_right.csv": b"# profile: L_y mm\n0,1\n"}


def test_out_equal_to_the_scene_directory(dummy_study, scene_file, tmp_path, capsys):
    (tmp_path / "scenes").mkdir()
    scene = scene_file(GOOD_SCENE, "scenes/s.toml")
    (tmp_path / "scenes" / "measured.csv").write_text("1")
    before = tree(tmp_path / "scenes")
    rc, err = run(capsys, scene, "--out", tmp_path / "scenes")
    assert rc == 2 and "contains the scene file" in err
    assert tree(tmp_path / "scenes") == before
    assert hidden_leftovers(tmp_path) == []


def test_new_file_would_overwrite_a_user_file(tmp_path):
    """A note the user saved under the name of a result file in a previous output: refused, kept."""

    class R:
        def __init__(self, plot):
            self.plot = plot

        def to_dict(self):
            return {"units": {}, "x": 1.0}

        def save_plots(self, d):
            if self.plot:
                (Path(d) / "te.png").write_bytes(b"png")
                return ["te.png"]
            return []

    out = tmp_path / "o"
    write_results(out, R(False))
    (out / "te.png").write_text("my own picture")
    before = tree(out)
    with pytest.raises(ResultsError, match=r"would overwrite te\.png, which gearopt did not write"):
        write_results(out, R(True))
    assert tree(out) == before
    assert hidden_leftovers(tmp_path) == []


def test_manifest_api(tmp_path):
    d = tmp_path / "d"
    assert output_files(d) is None  # absent
    d.mkdir()
    assert output_files(d) == []  # empty
    (d / "a.txt").write_text("x")
    assert output_files(d) is None  # the user's
    with pytest.raises(ResultsError, match=r"a\.txt"):
        check_out_dir(d)
    # a manifest that is not gearopt's or lists paths outside the directory claims nothing outside
    (d / MANIFEST).write_text(json.dumps({"written_by": "gearopt", "files": ["../x", "/etc/passwd", "a.txt"]}))
    assert output_files(d) == ["a.txt"]
    (d / MANIFEST).write_text("not json")
    assert output_files(d) is None
    with pytest.raises(ResultsError, match="did not write"):
        check_out_dir(d)
    # install_output into a new place: renamed, manifest written
    new = tmp_path / "new"
    (new / "sub").mkdir(parents=True)
    (new / "sub" / "f.csv").write_text("1")
    assert install_output(new, tmp_path / "t") == ["sub/f.csv"]
    assert json.loads((tmp_path / "t" / MANIFEST).read_text())["files"] == ["sub/f.csv"]
    assert not new.exists()


def test_output_of_an_earlier_gearopt_without_manifest_is_refused_with_a_hint(dummy_study, scene_file, tmp_path,
                                                                              capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "results.json").write_text('{"meta": {"gearopt_version": "0.0.9"}, "units": {}}')
    (out / "te.png").write_bytes(b"png")
    before = tree(out)
    rc, err = run(capsys, scene_file(GOOD_SCENE), "--out", out)
    assert rc == 2 and "from an earlier gearopt that wrote no .gearopt-output.json" in err
    assert tree(out) == before
