"""Units in scenes (gearopt.io.scene, gearopt.units) and in the CLI's listings. One unit rule: a
bare number is mm for every length; a micro-geometry amount (um) is refused without its unit, with
the hint ``"12 um"``; ``gearopt studies`` shows TE levels in arcsec, a compact listing without a name
and the keys of one study with it; ``--out`` shows DIR."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gearopt.cli import main
from gearopt.errors import SceneError
from gearopt.io.scene import load_scene

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
AMOUNTS = ("C_alpha", "f_H_alpha", "C_beta", "f_H_beta", "S_alpha", "C_alpha_a", "C_alpha_f", "C_beta_I", "C_beta_II")


def helical(tmp_path, line: str) -> Path:
    """problems/microgeometry_helical.toml with ``C_beta = "12 um"`` replaced by ``line``."""
    text = (PROBLEMS / "microgeometry_helical.toml").read_text()
    assert 'C_beta = "12 um"' in text
    f = tmp_path / "scene.toml"
    f.write_text(text.replace('C_beta = "12 um"', line))
    return f


def test_bare_amount_is_refused_naming_file_key_value_and_the_fix(tmp_path, capsys):
    f = helical(tmp_path, "C_beta = 12")
    assert main(["check", str(f)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert f'error: {f}: [pinion.modifications] C_beta = 12: a bare number is refused' in err
    assert 'write "12 um" (or "0.012 mm")' in err


@pytest.mark.parametrize("amount", AMOUNTS)
def test_every_amount_key_refuses_a_bare_number(tmp_path, amount):
    start = {"C_alpha_a": 'd_Ca = "59.2 mm"', "C_alpha_f": 'd_Cf = "54 mm"', "C_beta_I": 'b_I = "4 mm"',
             "C_beta_II": 'b_II = "4 mm"'}.get(amount, "")
    text = (PROBLEMS / "microgeometry_helical.toml").read_text()
    i, j = text.index("[pinion.modifications]\n"), text.index("[gear]")
    f = tmp_path / "scene.toml"
    f.write_text(text[:i] + f"[pinion.modifications]\n{amount} = 3\n{start}\n\n" + text[j:])
    with pytest.raises(SceneError) as e:
        load_scene(f)
    msgs = [str(e.value)] + [str(p) for p in getattr(e.value, "problems", [])]
    assert any(f"[pinion.modifications] {amount} = 3: a bare number is refused" in m and 'write "3 um"' in m
               for m in msgs), msgs


@pytest.mark.parametrize("line", ['C_beta = "12"', "C_beta = 12.0", "C_beta = -4"])
def test_other_bare_forms_are_refused(tmp_path, line):
    with pytest.raises(SceneError, match=r"C_beta = .*a bare number is refused"):
        load_scene(helical(tmp_path, line))


def test_amounts_with_their_unit_and_bare_zero(tmp_path):
    um = load_scene(helical(tmp_path, 'C_beta = "12 um"')).pair.pinion.modifications.C_beta
    mm = load_scene(helical(tmp_path, 'C_beta = "0.012 mm"')).pair.pinion.modifications.C_beta
    assert um == pytest.approx(0.012) and mm == pytest.approx(0.012)  # internal unit mm
    assert load_scene(helical(tmp_path, "C_beta = 0")).pair.pinion.modifications.C_beta == 0.0


def test_a_bare_length_is_still_mm(tmp_path):
    f = helical(tmp_path, 'C_beta = "12 um"')
    f.write_text(f.read_text().replace('[pinion]\nz = 21\nb = "30 mm"', "[pinion]\nz = 21\nb = 28"))
    p = load_scene(f).pair.pinion
    assert p.b == 28.0
    assert p.modifications.C_beta == pytest.approx(0.012)


def test_loaded_optimiser_bounds_refuse_bare_amounts(tmp_path):
    text = (PROBLEMS / "microgeometry_loaded.toml").read_text()
    old = 'C_beta = { lo = "0 um", hi = "40 um" }'
    assert old in text
    f = tmp_path / "loaded.toml"
    f.write_text(text.replace(old, "C_beta = { lo = 0, hi = 40 }"))
    with pytest.raises(SceneError) as e:
        load_scene(f)
    msgs = [str(e.value)] + [str(p) for p in getattr(e.value, "problems", [])]
    assert any("C_beta" in m and "hi = 40: a bare number is refused" in m and 'write "40 um"' in m for m in msgs), msgs


def test_every_problem_scene_loads():
    """Every shipped scene writes its amounts with their unit."""
    for f in sorted(PROBLEMS.glob("*.toml")):
        load_scene(f)


def test_studies_shows_te_levels_in_arcsec(capsys):
    assert main(["studies", "crowning"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.strip().startswith("te_level ("))
    assert "0 < te_level <= 600 arcsec" in line and "[arcsec" in line
    assert "0.166667 deg" not in out
    assert main(["studies", "loaded_microgeometry"]) == 0
    out = capsys.readouterr().out
    assert "0 < level <= 600 arcsec" in out
    assert re.search(r"lo \(length \[um, written with its unit", out)


def test_studies_compact_listing_and_one_study(capsys):
    assert main(["studies"]) == 0
    out = capsys.readouterr().out.splitlines()
    studies = [x for x in out if x.startswith("  ")]
    names = [x.split()[0] for x in studies]
    assert {"tca", "crowning", "ltca", "montecarlo", "sweep", "loaded_microgeometry", "fea"} <= set(names)
    assert len(studies) == len(names) == len(set(names))  # one line per study
    assert len(out) < 20
    assert any("gearopt studies NAME" in x for x in out)
    assert main(["studies", "tca"]) == 0
    detail = capsys.readouterr().out
    assert "[tca]" in detail and "positions (int" in detail
    assert main(["studies", "tcaa"]) == 2
    assert "no such study; valid: crowning" in capsys.readouterr().err


def test_out_metavar_is_dir(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    assert "--out DIR" in out and "OUT_TEXT" not in out


def test_a_sub_micron_bare_amount_suggests_mm_first(tmp_path):
    """Bounds of the loaded optimiser used to be bare mm: 0.04 there meant 40 um."""
    text = (PROBLEMS / "microgeometry_loaded.toml").read_text()
    old = 'C_alpha = { lo = "0 um", hi = "40 um" }'
    f = tmp_path / "loaded.toml"
    f.write_text(text.replace(old, "C_alpha = { lo = 0, hi = 0.04 }"))
    with pytest.raises(SceneError) as e:
        load_scene(f)
    msgs = [str(e.value)] + [str(p) for p in getattr(e.value, "problems", [])]
    assert any('hi = 0.04: a bare number is refused' in m and 'write "0.04 mm" (= 40 um) or "0.04 um"' in m
               for m in msgs), msgs
