"""Bad input, by class: every malformed scene or API call gets one clear GearoptError
that names the key or argument, the value (abbreviated when huge) and the valid range or a hint;
the CLI exits with status 2 without a traceback and writes nothing.
"""

from __future__ import annotations

import math
import re
import numpy as np
import pytest

from gearopt.cli import main
from gearopt.errors import ArgumentError, ConvergenceError, GearoptError, GeometryError, OptionError, ResultsError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.geometry.generation import PARAMS
from gearopt.units import ARCMIN, DEG

# A crowned spur drive 18/37, m 2.5 mm, b 24 mm (point contact), for the tca study.
TCA_SCENE = """\
[scene]
name = "bad_input_tca"
study = "tca"

[pair]
m_n = 2.5

[pinion]
z = 18
b = 24
a_pl = 0.0005
rack = {{ a_c = 0.003 }}

[gear]
z = 37
b = 24

[tca]
positions = 9
{tca}
"""

# A helical pair 23/51, m_n 1.75 mm, for the geometry study (cheap to check).
GEOM_SCENE = """\
[scene]
name = "bad_input_geometry"
study = "geometry"

[pair]
m_n = 1.75
beta = 12
{pair}

[pinion]
z = 23
b = 18
{pinion}

[gear]
z = 51
b = 18
{gear}

[rack]
{rack}
"""


def geom(pair="", pinion="", gear="", rack="", extra=""):
    return GEOM_SCENE.format(pair=pair, pinion=pinion, gear=gear, rack=rack) + extra


def tca(lines=""):
    return TCA_SCENE.format(tca=lines)


def cli(capsys, *args) -> tuple[int, str]:
    capsys.readouterr()
    rc = main(list(args))
    err = capsys.readouterr().err
    return rc, err


def assert_clean_error(rc, err, *needles):
    assert rc == 2, err
    assert "Traceback" not in err and err.startswith("error: "), err
    for n in needles:
        assert re.search(n, err), (n, err)


def check(capsys, scene_file, text, *needles, run=False, tmp_path=None):
    path = scene_file(text)
    if run:
        out = tmp_path / "out" / "r"
        rc, err = cli(capsys, "run", str(path), "--out", str(out), "-q")
        assert_clean_error(rc, err, re.escape(str(path)), *needles)
        assert not out.exists() and not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    else:
        rc, err = cli(capsys, "check", str(path))
        assert_clean_error(rc, err, re.escape(str(path)), *needles)
    return err


# ----------------------------------------------------------------------------------------------
# 1. Tracebacks instead of an error
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("value", ["[" * 3000 + "1" + "]" * 3000, "{ a = " * 1500 + "1" + " }" * 1500])
def test_deeply_nested_values_are_a_scene_error(capsys, scene_file, value):
    err = check(capsys, scene_file, geom(pinion=f"x = {value}"), "nested too deeply")
    assert len(err) < 1000


@pytest.mark.parametrize("lines, key, valid", [
    ('contact = "line"\nz_section = -13', r"\[tca\] z_section = -13", r"z_section\| <= b1 / 2 = 12 mm"),
    ('contact = "line"\nz_section = "0.6 in"', r"\[tca\] z_section = \"0.6 in\"", r"12 mm"),
    ('axial = "26 mm"', r"\[tca\] axial = \"26 mm\"", r"\|axial\| < \(b1 \+ b2\) / 2 = 24 mm"),
    ("axial = -31", r"\[tca\] axial = -31", r"faces do not overlap"),
])
def test_results_that_cannot_be_finite_are_refused_by_check(capsys, scene_file, lines, key, valid):
    text = tca(lines)
    if "line" in lines:
        text = text.replace("a_pl = 0.0005\n", "")
    check(capsys, scene_file, text, key, valid)


@pytest.mark.parametrize("crossing", ['"28 arcmin"', '"0.6 deg"'])
def test_a_case_without_contact_on_the_flanks_is_an_error_not_nan(capsys, scene_file, tmp_path, crossing):
    check(capsys, scene_file, tca(f"crossing = {crossing}"), r"study 'tca' failed", rf"crossing = {crossing}",
          r"off the active flanks", r"edge_contact = true", run=True, tmp_path=tmp_path)


def test_out_that_is_a_file_empty_or_the_working_directory(capsys, scene_file, tmp_path, monkeypatch):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "work").mkdir()
    scene = scene_file(geom(), "scenes/s.toml")
    afile = tmp_path / "results.txt"
    afile.write_text("keep me")
    monkeypatch.chdir(tmp_path / "work")
    for out, needle in ((str(afile), "exists and is not a directory"), ("", "empty"),
                        (str(afile / "sub"), "not a writable directory"), (".", "working directory"),
                        ("..", "working directory"), (str(tmp_path / "scenes"), "contains the scene file"),
                        ("/proc/gearopt-nope", "cannot create")):
        before = sorted(p.name for p in tmp_path.iterdir())
        rc, err = cli(capsys, "run", str(scene), "--out", out, "-q")
        assert_clean_error(rc, err, needle)
        assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert afile.read_text() == "keep me"


def test_writer_refuses_non_finite_results(tmp_path):
    from gearopt.io.results import write_results

    class R:
        def to_dict(self):
            return {"units": {"p": "MPa"}, "p": [1.0, float("inf")]}

        def save_plots(self, d):
            return []

    with pytest.raises(ResultsError, match=r"non-finite.*p\[1\]"):
        write_results(tmp_path / "o", R())
    assert not (tmp_path / "o").exists() and list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------------------------
# 2. Absurd values accepted
# ----------------------------------------------------------------------------------------------
def _crowning_limits(m_n, b, alpha_n=20 * DEG, h_aP=1.0, h_lim=1.0, u_0=0.0):
    """Independent restatement of the rule: crowning may remove at most pi m_n / 8 from each flank."""
    limit = math.pi * m_n / 8
    a_pl = limit / ((b / 2) ** 2 * math.sin(alpha_n))
    reach = max(abs(-h_aP * m_n / math.cos(alpha_n) - u_0), abs(h_lim * m_n / math.cos(alpha_n) - u_0))
    return a_pl, limit / reach**2


@pytest.mark.parametrize("m_n, b", [(1.25, 14.0), (4.0, 45.0), (8.0, 90.0)])
def test_crowning_bounded_by_tooth_thickness(m_n, b):
    a_pl_max, a_c_max = _crowning_limits(m_n, b)
    Gear(19, m_n, b=b, a_pl=0.98 * a_pl_max, rack=BasicRack(a_c=0.98 * a_c_max))  # accepted
    with pytest.raises(GeometryError, match=r"gear\.a_pl = .* a_pl <= ") as e:
        Gear(19, m_n, b=b, a_pl=1.02 * a_pl_max)
    assert f"{a_pl_max:.4g}" in str(e.value)
    with pytest.raises(GeometryError, match=r"gear\.rack\.a_c = .* a_c <= ") as e:
        Gear(19, m_n, b=b, rack=BasicRack(a_c=1.02 * a_c_max))
    assert f"{a_c_max:.4g}" in str(e.value)


@pytest.mark.parametrize("where, line, key", [
    ("pinion", "a_pl = 0.9", r"\[pinion\] a_pl = 0.9 is out of range; valid: a_pl <= "),
    ("pinion", 'a_pl = "12 1/in"', r"\[pinion\] a_pl = \"12 1/in\""),
    ("rack", "a_c = 7", r"\[rack\] a_c = 7 is out of range; valid: a_c <= "),
    ("gear", "rack = { a_c = 0.4 }", r"\[gear.rack\] a_c = 0.4"),
])
def test_absurd_crowning_in_a_scene(capsys, scene_file, where, line, key):
    check(capsys, scene_file, geom(**{where: line}), key, r"pi m_n / 8")


@pytest.mark.parametrize("lines, needle", [
    ("dE = -0.15", r"\[tca\] dE = -0.15 is out of range; valid: dE >= -0\.000[0-9]+ mm.*a_0 = "),
    ('dE = "-0.02 in"', r"\[tca\] dE = \"-0.02 in\" is out of range"),
    ("dE = 4.5", r"\[tca\] dE = 4.5 is out of range.*contact ratio"),
])
def test_centre_distance_change_obeys_the_pair_a_rule(capsys, scene_file, lines, needle):
    check(capsys, scene_file, tca(lines), needle)


def test_centre_distance_change_with_a_given(capsys, scene_file):
    # a = a_0 + 0.1 (a_0 = 68.75 for 18/37, m 2.5): dE = -0.08 is fine, dE = -0.13 jams the teeth
    text = tca("dE = -0.08").replace("m_n = 2.5", "m_n = 2.5\na = 68.85")
    assert main(["check", str(scene_file(text))]) == 0
    check(capsys, scene_file, text.replace("dE = -0.08", "dE = -0.13"), r"\[tca\] dE = -0.13", r"a \+ dE = 68.72")


def test_crowning_study_checks_both_signs_of_dE(capsys, scene_file):
    text = tca("").replace('study = "tca"', 'study = "crowning"').replace("[tca]\npositions = 9\n",
                                                                      '[crowning]\nte_level = "6 arcsec"\ndE = 0.2\n')
    check(capsys, scene_file, text, r"\[crowning\] dE = 0.2 is out of range \(the case -dE = -0.2 mm\)")


def test_operating_check_api():
    pair = GearPair(Gear(23, 2.0, b=20, name="pinion"), Gear(61, 2.0, b=20, name="gear"))
    pair.check_operating(0.0)
    pair.check_operating(0.3)
    with pytest.raises(GeometryError, match=r"dE = -0.01 is out of range"):
        pair.check_operating(-0.01)
    # separation: independent contact ratio at a + dE
    p, g = pair.pinion, pair.gear

    def eps(a):
        aw = math.acos((p.r_b + g.r_b) / a)
        return (math.sqrt(p.r_a**2 - p.r_b**2) + math.sqrt(g.r_a**2 - g.r_b**2) - a * math.sin(aw)) / p.p_bt

    dE_ok = next(d for d in np.arange(3.0, 0.0, -0.01) if eps(pair.a_0 + d) >= 1.0)
    pair.check_operating(dE_ok - 0.01)
    with pytest.raises(GeometryError, match="contact ratio"):
        pair.check_operating(dE_ok + 0.02)


@pytest.mark.parametrize("name, bad", [("out/../../x", "'/'"), ("a\\b", r"'\\\\'"), ("", "empty"),
                                       (".secret", "starts with '.'"), ("run:1", "':'")])
def test_scene_name_cannot_escape_the_output_directory(capsys, scene_file, name, bad):
    text = geom().replace('name = "bad_input_geometry"', f"name = {_q(name)}")
    check(capsys, scene_file, text, r"\[scene\] name = ", bad)


def _q(s):
    return '"' + s.replace("\\", "\\\\") + '"'


# ----------------------------------------------------------------------------------------------
# 3. Wrong parameter blamed
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("section, line, key", [
    ("pair", "P_n = 1e12", r"\[pair\] P_n = 1000000000000.0 \(= 2.54e-11\) is out of range; valid: 0.01 <= m_n"),
    ("pinion", "x = 7e307", r"\[pinion\] x = 7e\+?307 is out of range; valid: x < "),
    ("gear", "x = -4e306\nallow_undercut = true", r"\[gear\] x = -4e\+?306 is out of range; valid: x > "),
    ("gear", "x = 3e306", r"\[gear\] x = 3e\+?306 is out of range; valid: x < "),
])
def test_overflowing_values_blame_themselves(capsys, scene_file, section, line, key):
    text = geom(**{section: line})
    if "P_n" in line:
        text = text.replace("m_n = 1.75\n", "")
    err = check(capsys, scene_file, text, key)
    assert "] k =" not in err


def test_huge_module_blames_m_n(capsys, scene_file):
    text = geom().replace("m_n = 1.75", "m_n = 2e306")
    check(capsys, scene_file, text, r"\[pair\] m_n = 2e\+?306 is out of range; valid: 0.01 <= m_n <= 1000 mm")


@pytest.mark.parametrize("mod, a", [(1.75, 700.0), (0.2, 30.0)])
def test_centre_distance_too_large_names_a_and_m_n(capsys, scene_file, mod, a):
    text = geom(pair=f"a = {a}").replace("m_n = 1.75", f"m_n = {mod}")
    err = check(capsys, scene_file, text, rf"\[pair\] a = {a:g}", r"m_n = ", r"a_0 = [\d.]+ <= a <= [\d.]+ mm")
    assert "eps_gamma = -" in err or "contact ratio" in err
    # the stated a_max is the largest a with eps_gamma >= 1 (independent check)
    a_max = float(re.search(r"<= a <= ([\d.]+) mm", err).group(1))
    assert main(["check", str(scene_file(text.replace(f"a = {a}", f"a = {a_max * (1 - 1e-5)}")))]) == 0


@pytest.mark.parametrize("section, line, key", [
    ("gear", "z = 9000000000", r"\[gear\] z = 9000000000 is out of range; valid: 3 <= z <= 100000"),
    ("pinion", "b = 3e306", r"\[pinion\] b = 3e\+?306 is out of range; valid: 0 < b <= 10 d"),
    ("rack", "u_0 = -2e305", r"\[rack\] u_0 = -2e\+?305 is out of range; valid: \|u_0\| <= "),
    ("rack", "alpha_n = 1e-300", r"alpha_n = 1e-300 deg"),
])
def test_extreme_values_blame_themselves(capsys, scene_file, section, line, key):
    text = geom(**{section: line})
    if section == "gear":
        text = text.replace("z = 51\n", "")
    elif section == "pinion":
        text = text.replace("z = 23\nb = 18", "z = 23")
    check(capsys, scene_file, text, key)


@pytest.mark.parametrize("k1, k2", [(-0.7, -0.2), (-0.1, -0.8)])
def test_short_tips_blame_the_shortened_k(k1, k2):
    def pair(k1, k2):
        return GearPair(Gear(26, 1.5, b=12, k=k1, name="pinion"), Gear(31, 1.5, b=12, k=k2, name="gear"))

    who = "pinion" if k1 < k2 else "gear"
    with pytest.raises(GeometryError, match=rf"{who}\.k = {min(k1, k2)} is out of range; valid: k >= ") as e:
        pair(k1, k2)
    k_min = float(re.search(r"k >= (-?[\d.]+)", str(e.value)).group(1))
    fixed = pair(k_min + 1e-4, k2) if who == "pinion" else pair(k1, k_min + 1e-4)
    assert fixed.eps_gamma == pytest.approx(1.0, abs=2e-3)  # the stated bound is where eps_gamma reaches 1


@pytest.mark.parametrize("where, value, rad", [("rack", "0.4", "0.4 rad"), ("pinion", "rack = { alpha_n = 0.26 }", "")])
def test_pressure_angle_in_radians(capsys, scene_file, where, value, rad):
    line = f"alpha_n = {value}" if where == "rack" else value
    text = geom(**{where: line}).replace("[pair]\nm_n = 1.75", "[pair]\nm_n = 1.75")
    if where == "pinion":  # both members need the same pressure angle: give it to the gear too
        text = text.replace("z = 51\nb = 18", "z = 51\nb = 18\nrack = { alpha_n = 0.26 }")
    err = check(capsys, scene_file, text, r"alpha_n = 0\.\d+: a bare number is read as 0\.\d+ deg", r"rad")
    assert "] x =" not in err


def test_large_gears_find_flank_points_to_rounding():
    """1:400 and larger ratios: the flank point at a radius is found wherever the radius can be
    resolved in double precision (the old absolute 1e-12 mm step test failed at r ~ 1e4 mm)."""
    from gearopt.geometry.generation import generate_by_rack

    for z, m in ((9000, 2.5), (10000, 3.0), (6400, 1.25)):
        g = Gear(z, m, b=20)
        tooth = generate_by_rack(g)
        f = tooth.radius_function("right")
        for r in np.linspace(g.r_p - 0.9 * m, g.r_a - 0.05 * m, 25):
            u = tooth.u_at_radius(r)
            assert abs(float(f(u, 0.0, tooth.p0)[0]) - r) <= 1e-12 * r


def test_errors_while_running_name_the_scene_and_key(capsys, scene_file, tmp_path):
    err = check(capsys, scene_file, tca('crossing = "4 deg"'), r"study 'tca' failed", r"\[tca\]",
                r"crossing = \"4 deg\"", run=True, tmp_path=tmp_path)
    assert "rad" not in err.split(":", 2)[1]


# ----------------------------------------------------------------------------------------------
# 4. Messages
# ----------------------------------------------------------------------------------------------
def _crowning_scene(lines):
    return tca("").replace('study = "tca"', 'study = "crowning"').replace("[tca]\npositions = 9\n",
                                                                      "[crowning]\n" + lines + "\n")


@pytest.mark.parametrize("text, needle", [
    (_crowning_scene("te_level = 14"), r"te_level = 14 is out of range.*Did you mean \"14 arcsec\"\?"),
    (_crowning_scene("te_level = 0.45"), r"Did you mean \"0.45 arcsec\"\?"),
    (_crowning_scene("te_level = \"5 arcsec\"\ncrossing = 5"), r"crossing = 5: .*Did you mean \"5 arcmin\"\?"),
    (tca("crossing = 1.5"), r"\[tca\] crossing = 1.5: a bare number is read as 1.5 deg.*\"1.5 arcmin\""),
    (tca("intersecting = -4"), r"\[tca\] intersecting = -4: .*\"-4 arcmin\""),
    (tca("delta = 4"), r"\[tca\] delta = 4 is out of range.*Did you mean \"4 um\""),
])
def test_unit_slips_get_a_hint(capsys, scene_file, text, needle):
    check(capsys, scene_file, text, needle)


def test_bare_misalignment_refused_above_one_degree_only(capsys, scene_file):
    for line in ("crossing = 0.04", 'crossing = "2.5 deg"', 'intersecting = "-7 arcmin"'):
        rc, err = cli(capsys, "check", str(scene_file(tca(line))))
        assert rc == 0, err
    rc, err = cli(capsys, "check", str(scene_file(tca("crossing = 2.5"))))
    assert_clean_error(rc, err, r"\[tca\] crossing = 2.5: a bare number", r"\"2.5 arcmin\"")


@pytest.mark.parametrize("where, line, needle", [
    ("pair", "h_fP = 1.3", r"\[pair\] h_fP: unknown key\. h_fP belongs in \[rack\]"),
    ("pinion", "beta = 15", r"\[pinion\] beta: unknown key\. beta belongs in \[pair\]"),
    ("gear", "a_c = 0.001", r"\[gear\] a_c: unknown key\. a_c belongs in \[rack\] or \[pinion.rack\] or \[gear.rack\]"),
    ("pair", "module = 2", r"\[pair\] module: unknown key\. Did you mean 'm_n'"),
    ("gear", "teeth = 40", r"\[gear\] teeth: unknown key\. Did you mean 'z'"),
    ("pinion", "pressure_angle = 20", r"Did you mean 'alpha_n'\? It belongs in \[rack\]"),
])
def test_key_in_the_wrong_section_says_where_it_belongs(capsys, scene_file, where, line, needle):
    check(capsys, scene_file, geom(**{where: line}), needle)


def test_key_of_another_study_says_so(capsys, scene_file):
    check(capsys, scene_file, tca("te_level = \"9 arcsec\""),
          r"\[tca\] te_level: unknown key\. te_level belongs in \[crowning\] of study \"crowning\"")


def test_top_level_key_says_where_it_belongs(capsys, scene_file):
    check(capsys, scene_file, "centre_distance = 80\n" + geom(), r"top-level key .* It belongs in \[pair\] \(as a\)")


def test_missing_study_section_lists_its_required_keys(capsys, scene_file):
    text = tca("").replace('study = "tca"', 'study = "crowning"').replace("[tca]\npositions = 9\n", "")
    err = check(capsys, scene_file, text, r"\[crowning\]: missing required section; it needs te_level")
    assert "()" not in err


@pytest.mark.parametrize("where, line, key", [("gear", "b = 19", r"\[gear\] b on line \d+ \(first on line \d+\)"),
                                              ("pair", "beta = 13", r"\[pair\] beta on line")])
def test_duplicate_keys_are_named(capsys, scene_file, where, line, key):
    check(capsys, scene_file, geom(**{where: line}), r"duplicate key " + key)


def test_duplicate_table_is_named(capsys, scene_file):
    check(capsys, scene_file, geom() + "\n[gear]\nx = 0.1\n", r"table \[gear\] is defined twice")


@pytest.mark.parametrize("line", ['k = "' + "7" * 400000 + ' mm"', "x = '" + "q" * 300000 + "'",
                                  "x = [" + ", ".join(["1.5"] * 100000) + "]"])
def test_huge_values_are_abbreviated(capsys, scene_file, line):
    err = check(capsys, scene_file, geom(pinion=line), r"\[pinion\] [kx] = ", r"characters")
    assert len(err) < 1500


@pytest.mark.parametrize("section, line, key", [("pair", "m_n = true", r"\[pair\] m_n = true"),
                                                ("pinion", "b = false", r"\[pinion\] b = false"),
                                                ("gear", "rack = { alpha_n = false }",
                                                 r"\[gear.rack\] alpha_n = false")])
def test_booleans_are_spelled_as_in_toml(capsys, scene_file, section, line, key):
    text = geom(**{section: line})
    if section == "pair":
        text = text.replace("m_n = 1.75\n", "")
    elif section == "pinion":
        text = text.replace("z = 23\nb = 18", "z = 23")
    err = check(capsys, scene_file, text, key)
    assert "True" not in err and "False" not in err


# ----------------------------------------------------------------------------------------------
# 5. API
# ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def crowned_tca():
    from gearopt.meshing.tca import TCA

    pair = GearPair(Gear(18, 2.0, b=16, a_pl=5e-4, rack=BasicRack(a_c=2.5e-3), name="pinion"),
                    Gear(43, 2.0, b=16, name="gear"))
    return TCA(pair)


@pytest.mark.parametrize("kwargs, name", [
    (dict(phi1=[0.0], mis={"crossing": 2 * ARCMIN}), "mis"),
    (dict(phi1=[0.0], mis=(0.0, 1e-3, 0.0, 0.0)), "mis"),
    (dict(phi1=[]), "phi1 is empty"),
    (dict(phi1=np.array([0.01, np.nan, 0.02])), r"phi1\[1\] = nan"),
    (dict(phi1=[0.0, math.inf]), r"phi1\[1\] = inf"),
    (dict(phi1="0.1 rad"), "phi1"),
    (dict(phi1=np.zeros((2, 3))), "phi1: expected a 1-D"),
    (dict(phi1=[0.0], p1=[0.0, 0.0]), rf"p1: expected a vector of {len(PARAMS)}"),
    (dict(phi1=[0.0], p2=np.zeros(len(PARAMS) + 1)), rf"p2: expected a vector of {len(PARAMS)}"),
    (dict(phi1=[0.0], pairs=()), "pairs is empty"),
    (dict(phi1=[0.0], pairs=(0, 0.5)), "pairs contains float 0.5"),
    (dict(phi1=[0.0], pairs=(0, 0)), "every tooth pair may appear once"),
    (dict(phi1=[0.0], pairs=(40,)), "pairs contains 40; valid: -18 < k < 18"),
    (dict(phi1=[0.0], delta="6 um"), "delta = str"),
    (dict(phi1=[0.0], anchor=math.nan), "anchor"),
])
def test_tca_sweep_arguments(crowned_tca, kwargs, name):
    with pytest.raises(ArgumentError, match=name) as e:
        crowned_tca.sweep(**kwargs)
    assert isinstance(e.value, GearoptError)


def test_tca_sweep_delta_out_of_range_is_an_option_error(crowned_tca):
    """delta is a solver option (the elastic approach), not gear data: an OptionError."""
    with pytest.raises(OptionError, match="delta = 0.0 is out of range") as e:
        crowned_tca.sweep([0.0], delta=0.0)
    assert not isinstance(e.value, GeometryError) and isinstance(e.value, ValueError)


@pytest.mark.parametrize("mis, name", [
    (dict(dE=-0.05), r"mis\.dE = -0.05 is out of range; valid: dE >= -0\.000[0-9]+ mm"),
    (dict(axial=17.0), r"mis\.axial = 17.0 is out of range; valid: \|axial\| < \(b1 \+ b2\) / 2 = 16 mm"),
])
def test_tca_sweep_misalignment_ranges(crowned_tca, mis, name):
    from gearopt.meshing.tca import Misalignment

    with pytest.raises(GeometryError, match=name):
        crowned_tca.sweep([0.0], mis=Misalignment(**mis))


@pytest.mark.parametrize("phi", [np.linspace(1.0, 1.1, 4), np.array([-2.5])])
def test_sweep_entirely_outside_the_meshing_cycle_is_an_error(crowned_tca, phi):
    with pytest.raises(ConvergenceError, match=r"no contact at any of the \d+ positions"):
        crowned_tca.sweep(phi, pairs=(0,))
    # partly inside: a result, with NaN (flagged) where there is no contact
    r = crowned_tca.sweep(np.concatenate([[0.0], phi]), pairs=(0,))
    assert np.isfinite(r.te_envelope[0]) and np.isnan(r.te_envelope[1:]).all()


@pytest.mark.parametrize("phi1, needle", [([], "it is empty"), ([0.1, math.nan], r"phi1\[1\] is not finite"),
                                          ("12 deg", "phi1 = str"), (np.ones((2, 2)), "1-D")])
def test_planar_tca_arguments(phi1, needle):
    from gearopt.meshing.planar import PlanarTCA

    with pytest.raises(ArgumentError, match=needle):
        PlanarTCA(31.0, 52.0, 88.0).solve(phi1)


def test_loader_and_writer_argument_types(tmp_path):
    from gearopt.io.results import write_results
    from gearopt.io.scene import load_scene

    with pytest.raises(ArgumentError, match="path = int"):
        load_scene(17)
    with pytest.raises(ArgumentError, match="result = dict"):
        write_results(tmp_path / "o", {"units": {}})
    assert list(tmp_path.iterdir()) == []


def test_edge_contact_arguments(crowned_tca):
    from gearopt.contact.edge import EdgeContact

    with pytest.raises(ArgumentError, match="tca = GearPair"):
        EdgeContact(crowned_tca.pair)
    ec = EdgeContact(crowned_tca)
    with pytest.raises(ArgumentError, match="mis = dict"):
        ec.sweep([0.0], mis={"dE": 0.1})
    with pytest.raises(ArgumentError, match="phi1 is empty"):
        ec.sweep(np.array([]))


def test_constructors_name_wrong_types():
    from gearopt.meshing.tca import TCA
    from gearopt.synthesis.crowning import CrowningOptimizer, CrowningTarget

    with pytest.raises(ArgumentError, match="pair = dict"):
        TCA({"pinion": 1})
    with pytest.raises(ArgumentError, match=r"target\.te_level = str '7 arcsec'.*plain numbers"):
        CrowningTarget(te_level="7 arcsec")
    pair = GearPair(Gear(21, 2.0, b=16, name="pinion"), Gear(47, 2.0, b=16, name="gear"))
    with pytest.raises(ArgumentError, match=r"cases\['tilt'\] = dict.*Misalignment"):
        CrowningOptimizer(pair, CrowningTarget(te_level=6e-5), cases={"tilt": {"crossing": 1e-3}})
    with pytest.raises(ArgumentError, match=r"cases = list"):
        CrowningOptimizer(pair, CrowningTarget(te_level=6e-5), cases=[1e-3])
    from gearopt.meshing.tca import Misalignment
    with pytest.raises(GeometryError, match=r"cases\['in'\]\.dE = -0.2"):
        CrowningOptimizer(pair, CrowningTarget(te_level=6e-5), cases={"in": Misalignment(dE=-0.2)})


@pytest.mark.parametrize("lines, key", [('phi1_start = "47 deg"', r"\[fea\] phi1_start = \"47 deg\""),
                                        ('phi1_start = 0\nphi1_end = -40\nn_positions = 2',
                                         r"\[fea\] phi1_end = -40")])
def test_fe_positions_outside_the_meshing_are_refused_by_check(capsys, scene_file, lines, key):
    text = geom().replace('study = "geometry"', 'study = "fea"').replace("beta = 12\n", "") + "[fea]\n" + lines + "\n"
    check(capsys, scene_file, text, key, r"none of the 3 modelled tooth pairs is in contact")


# ----------------------------------------------------------------------------------------------
# 6. FE garbage
# ----------------------------------------------------------------------------------------------
# The docs/fea.md validation model (20/30 spur, m 3, b 10 mm, 100 N*m): r_b1 = 28.19 mm,
# F_n = 3547 N, measured rotation -6.7e-4 rad, p0 = 1454.7 MPa.
GOOD_FE = dict(phi1=0.0, rotation=-6.7e-4, r_b1=28.19, F_n=3547.0, b=10.0, E=210e3, p_max=1580.9, p0=1454.7)


def test_fe_physics_accepts_the_validated_model():
    from gearopt.fea.references import check_physics

    check_physics(**GOOD_FE)
    # the reference is the case's own Hertz value (the ellipse for a crowned point contact): a mesh
    # error of up to 3x is tolerated, not more
    check_physics(**{**GOOD_FE, "p_max": 2.9 * 1454.7})


@pytest.mark.parametrize("change, needle", [
    (dict(rotation=-8.0e3), "loaded approach along the line of action"),  # ~ -1.65e9 arcsec
    (dict(rotation=0.35), "not an elastic deflection"),
    (dict(rotation=math.nan), "non-finite pinion rotation"),
    (dict(p_max=2.9e5), "peak contact pressure 2.9e\\+05 MPa"),
    (dict(p_max=3.2 * 1454.7), "more than 3 x the Hertz"),
    (dict(p_max=math.inf), "non-finite"),
])
def test_fe_garbage_raises_calculix_error(change, needle):
    from gearopt.fea.calculix import CalculixError
    from gearopt.fea.references import check_physics

    with pytest.raises(CalculixError, match=needle):
        check_physics(**{**GOOD_FE, **change})


def test_inverted_elements_are_refused():
    from gearopt.fea.calculix import CalculixError
    from gearopt.fea.references import check_elements

    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    nodes = np.vstack([cube, cube + [2.0, 0, 0]])
    good = np.array([np.arange(1, 9), np.arange(9, 17)])
    check_elements(nodes, good)
    bad = good.copy()
    bad[1] = bad[1][[4, 5, 6, 7, 0, 1, 2, 3]]  # top and bottom swapped: inside out
    with pytest.raises(CalculixError, match=r"1 inverted element\(s\).*first: element 2"):
        check_elements(nodes, bad)


def test_fe_model_argument_types():
    from gearopt.fea.model import GearFEModel

    pair = GearPair(Gear(20, 3.0, b=10, name="pinion"), Gear(30, 3.0, b=10, name="gear"))
    with pytest.raises(ArgumentError, match="phi1 = str"):
        GearFEModel(pair, "0 deg")
    with pytest.raises(ArgumentError, match="options = dict"):
        GearFEModel(pair, 0.0, options={"torque": 1})
