"""Bad input at the limits of the gear data: pointed and short tips, tip diameters, thickness
allowances, face widths and crowning margins beyond the tooth, unit slips of angles, and the API
entry points' argument checks. Values differ from tests/test_bad_input.py's. Limits stated in
messages are checked against independent formulas (scipy root finding on the textbook
tooth-thickness equation), not against gearopt's own code.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy.optimize import brentq

from gearopt.cli import main
from gearopt.errors import ArgumentError, GearoptError, GeometryError, OptionError
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.meshing.tca import TCA, Misalignment
from gearopt.units import ARCMIN

SPUR = """\
[scene]
name = "audit"
study = "{study}"

[pair]
m_n = "{m} mm"
{pair}

[pinion]
z = {z1}
b = "{b} mm"
{pinion}

[gear]
z = {z2}
b = "{b} mm"
{gear}
{extra}
"""


def scene(study="geometry", m=2.25, z1=19, z2=44, b=16, pair="", pinion="", gear="", extra=""):
    return SPUR.format(study=study, m=m, z1=z1, z2=z2, b=b, pair=pair, pinion=pinion, gear=gear, extra=extra)


def run_check(capsys, scene_file, text):
    path = scene_file(text)
    capsys.readouterr()
    rc = main(["check", str(path)])
    err = capsys.readouterr().err
    return rc, err


def refused(capsys, scene_file, text, *needles):
    rc, err = run_check(capsys, scene_file, text)
    assert rc == 2 and err.startswith("error: ") and "Traceback" not in err, err
    for n in needles:
        assert re.search(n, err), (n, err)
    return err


def accepted(capsys, scene_file, text):
    rc, err = run_check(capsys, scene_file, text)
    assert rc == 0, err


def _inv(a):
    return math.tan(a) - a


def tip_thickness(z, m, x, k, alpha=math.radians(20), h_aP=1.0):
    """Independent textbook tip thickness of a spur gear (Litvin eq. 10.2.x; ISO 21771):
    s_a = d_a (s / d + inv alpha - inv alpha_a), s = m (pi / 2 + 2 x tan alpha)."""
    d = m * z
    d_a = d + 2 * m * (h_aP + x + k)
    d_b = d * math.cos(alpha)
    s = m * (math.pi / 2 + 2 * x * math.tan(alpha))
    alpha_a = math.acos(d_b / d_a)
    return d_a * (s / d + _inv(alpha) - _inv(alpha_a))


def _number_after(text, pattern):
    m = re.search(pattern, text)
    assert m, (pattern, text)
    return float(m.group(1))


# --- wrong parameter blamed: a lengthened tip that is pointed is k's (or d_a's) fault --------------
@pytest.mark.parametrize("z, x, k", [(23, 0.2, 3.0), (31, -0.1, 1.4), (14, 0.45, 0.9)])
def test_pointed_lengthened_tip_blames_k_with_its_limit(z, x, k):
    with pytest.raises(GeometryError) as e:
        Gear(z=z, m_n=2.0, x=x, k=k, b=15.0, name="gear", allow_undercut=True)
    msg = str(e.value)
    assert msg.startswith("gear.k = "), msg
    k_max = _number_after(msg, r"k < (-?[\d.]+) for x")
    k_oracle = brentq(lambda kk: tip_thickness(z, 2.0, x, kk), -0.5, k)
    assert k_max == pytest.approx(k_oracle, abs=2e-4)


def test_tip_diameter_out_of_range_names_d_a_as_written(capsys, scene_file):
    z, m, x = 19, 2.25, 0.25
    err = refused(capsys, scene_file, scene(pinion=f'x = {x}\nd_a = "70 mm"'), r"\[pinion\] d_a = \"70 mm\"",
                  r"d_a < ")
    assert "[pinion] x" not in err and "[pinion] k" not in err
    d_max = _number_after(err, r"d_a < ([\d.]+) mm")
    k_oracle = brentq(lambda kk: tip_thickness(z, m, x, kk), -0.5, 5)
    assert d_max == pytest.approx(m * z + 2 * m * (1 + x + k_oracle), abs=2e-3)
    err = refused(capsys, scene_file, scene(gear='d_a = "0.09 m"'), r"\[gear\] d_a = \"0.09 m\"", r"d_a > ")
    # the root circle: d_f = d - 2 m (h_fP - x), h_fP = 1.25 (ISO 53 A)
    assert _number_after(err, r"d_a > ([\d.]+) mm") == pytest.approx(2.25 * 44 - 2 * 2.25 * 1.25, rel=1e-5)


# --- absurd values accepted ----------------------------------------------------------------------
@pytest.mark.parametrize("key, value", [("A_sne", '"-6 mm"'), ("A_sni", '"-25 mm"'), ("A_sne", '"4.5 mm"')])
def test_absurd_thickness_allowance_is_refused_by_name(capsys, scene_file, key, value):
    extra = 'A_sne = "5 mm"\n' if key == "A_sni" and value.startswith('"-') is False else ""
    err = refused(capsys, scene_file, scene(gear=extra + f"{key} = {value}"), rf"\[gear\] {key} = ",
                  r"pi m_n / 2")
    assert "[gear] x" not in err
    # realistic DIN 3967 allowances still pass
    accepted(capsys, scene_file, scene(pinion='A_sne = "-0.12 mm"\nA_sni = "-0.19 mm"', pair='a = "71.3 mm"'))


def test_face_width_far_below_the_module_is_refused(capsys, scene_file):
    refused(capsys, scene_file, scene(pinion="", gear="").replace('b = "16 mm"', 'b = "3 um"', 1),
            r"\[pinion\] b = \"3 um\"", r"b >= 0.1 m_n")
    with pytest.raises(GeometryError, match=r"pinion\.b = .*b >= 0\.1 m_n"):
        Gear(z=30, m_n=4.0, b=1e-7, name="pinion")
    Gear(z=30, m_n=4.0, b=2.0, name="pinion")  # b = m_n / 2: thin, but a tooth


def test_crowning_margins_leaving_no_room_are_refused_at_check(capsys, scene_file):
    crown = '[crowning]\nte_level = "6 arcsec"\ncrossing = "2 arcmin"\n{}'
    refused(capsys, scene_file, scene("crowning", b=9, extra=crown.format('edge_margin = "4.6 mm"')),
            r"\[crowning\] edge_margin = \"4.6 mm\"", r"4\.5 mm")
    # flank height of the 19-tooth pinion: tip minus form radius, well below 2 x 3.5 mm
    refused(capsys, scene_file, scene("crowning", extra=crown.format('tip_margin = "3.5 mm"')),
            r"\[crowning\] tip_margin = \"3.5 mm\"", r"tip_margin <")


def test_fea_young_modulus_in_gpa_gets_a_hint(capsys, scene_file):
    fea = "[fea]\nE = {}\n"
    refused(capsys, scene_file, scene("fea", extra=fea.format("206")), r"\[fea\] E = 206", r"206000 MPa")
    refused(capsys, scene_file, scene("fea", extra=fea.format("2.1e11")), r"\[fea\] E = ", r"210000 MPa")


# --- unit slips ------------------------------------------------------------------------------------
def test_bare_misalignment_angle_in_tca_cases_is_a_unit_slip(capsys, scene_file):
    crowned = 'a_pl = "0.0004 1/mm"\nrack = { a_c = "0.002 1/mm" }'
    cases = '[tca]\npositions = 9\n[[tca.cases]]\nlabel = "x"\nintersecting = {}\n'
    refused(capsys, scene_file, scene("tca", pinion=crowned, extra=cases.format("-6")),
            r"\[tca\.cases\]\[0\] intersecting = -6", r"-6 arcmin")
    accepted(capsys, scene_file, scene("tca", pinion=crowned, extra=cases.format('"-6 arcmin"')))


def test_bare_helix_angle_in_radians_is_a_unit_slip(capsys, scene_file):
    refused(capsys, scene_file, scene(pair="beta = 0.21"), r"\[pair\] beta = 0.21", r"0.21 rad")
    accepted(capsys, scene_file, scene(pair='beta = "0.21 rad"'))
    accepted(capsys, scene_file, scene(pair="beta = 0"))
    accepted(capsys, scene_file, scene(pair="beta = 13"))


# --- API -----------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def crowned_tca():
    rack = BasicRack.iso53("A", a_c=0.0025)
    pair = GearPair(pinion=Gear(z=17, m_n=2.75, b=18.0, a_pl=3e-4, rack=rack, x=0.1, name="pinion"),
                    gear=Gear(z=39, m_n=2.75, b=18.0, name="gear"))
    return TCA(pair)


@pytest.mark.parametrize("kwargs, needle", [
    (dict(phi1=float("nan")), r"phi1"), (dict(phi1="0.02"), r"phi1"), (dict(phi1=0.01, w0=[0.0, 1.0, 2.0]), r"w0"),
    (dict(phi1=0.01, mis={"crossing": 1e-3}), r"mis"), (dict(phi1=0.01, p1=[0.1, 0.0]), r"p1"),
])
def test_solve_point_names_the_argument(crowned_tca, kwargs, needle):
    with pytest.raises(ArgumentError, match=needle):
        crowned_tca.solve_point(**kwargs)


def test_sweep_refuses_strings_for_angles(crowned_tca):
    with pytest.raises(ArgumentError, match="phi1"):
        crowned_tca.sweep(["0.01", "0.02"])


def test_involute_functions_check_their_domain():
    from gearopt.geometry.involute import inv, inv_inverse

    for bad in ("0.3", float("nan"), 1.9, [0.1, -2.0]):
        with pytest.raises(ArgumentError):
            inv(bad)
    for bad in ("x", float("inf"), 3e16, -5e20):
        with pytest.raises(ArgumentError):
            inv_inverse(bad)
    a = float(inv_inverse(2e3))
    assert math.tan(a) - a == pytest.approx(2e3, rel=1e-12)
    for theta in (7e9, 4e14):  # below the limit alpha is the double nearest pi/2 - 1/(theta + pi/2)
        # (cot eps + eps = theta + pi/2 with eps = pi/2 - alpha; eps^3 terms are below 1e-29 here)
        a = float(inv_inverse(theta))
        assert a < math.pi / 2 and abs(a - (math.pi / 2 - 1 / (theta + math.pi / 2))) <= 2 * math.ulp(math.pi / 2)


def test_api_entry_points_name_wrong_arguments(tmp_path):
    from gearopt.geometry.generation import generate_by_hob, generate_by_rack
    from gearopt.io.results import write_results
    from gearopt.studies.planar_tca import PlanarTCAStudy
    from gearopt.units import deg

    with pytest.raises(ArgumentError, match="gear"):
        generate_by_rack("pinion")
    g = Gear(z=25, m_n=1.5, b=10.0, name="gear")
    with pytest.raises(ArgumentError, match="hob"):
        generate_by_hob(g, hob={"N_h": 1})
    with pytest.raises(ArgumentError, match="out_dir"):
        write_results(7, object())
    with pytest.raises(ArgumentError, match="unknown field.*h_ap"):
        BasicRack.iso53("B", h_ap=1.1)
    with pytest.raises(ArgumentError, match="phi1"):
        PlanarTCAStudy(30.0, 50.0, 90.0, ["a", "b"])
    with pytest.raises(ArgumentError, match="value_deg"):
        deg("20")
    with pytest.raises(ArgumentError, match="allow_undercut"):
        Gear(z=25, m_n=1.5, b=10.0, allow_undercut="false")
    assert Gear(z=np.int32(25), m_n=1.5, b=10.0).z == 25  # numpy integers are integers


def test_tca_study_checks_its_arguments():
    from gearopt.studies.tca import TCAStudy
    from gearopt.synthesis.local import LocalTarget, local_synthesis

    rack = BasicRack.iso53("A", a_c=0.002)
    pair = GearPair(pinion=Gear(z=21, m_n=2.0, b=14.0, a_pl=5e-4, rack=rack, name="pinion"),
                    gear=Gear(z=47, m_n=2.0, b=14.0, name="gear"))
    for kwargs, needle in [(dict(positions=4), "positions"), (dict(positions="81"), "positions"),
                           (dict(delta=-0.004), "delta"), (dict(misalignment={"dE": 0.01}), "misalignment"),
                           (dict(edge_contact="no"), "edge_contact"), (dict(z_section=9.0, contact="line"), "z_section"),
                           (dict(misalignment=Misalignment(dE=-0.2)), r"misalignment\.dE"),
                           (dict(cases={"far": Misalignment(axial=14.5)}), r"cases\['far'\]\.axial")]:
        with pytest.raises(GearoptError, match=needle):
            TCAStudy(pair, **kwargs)
    with pytest.raises(ArgumentError, match="mprime21"):
        LocalTarget(mprime21="-0.002", major_axis=5.0)
    with pytest.raises(GeometryError, match="major_axis"):
        local_synthesis(pair, LocalTarget(mprime21=-0.003, major_axis=40.0))


def test_crowning_optimizer_refuses_margins_beyond_the_tooth():
    from gearopt.synthesis.crowning import CrowningOptimizer, CrowningTarget

    pair = GearPair(pinion=Gear(z=22, m_n=2.0, b=7.0, name="pinion"), gear=Gear(z=45, m_n=2.0, b=9.0, name="gear"))
    cases = {"x": Misalignment(crossing=2 * ARCMIN)}
    with pytest.raises(GeometryError, match=r"edge_margin.*3\.5 mm"):
        CrowningOptimizer(pair, CrowningTarget(te_level=3e-5, edge_margin=3.6), cases=cases)
    with pytest.raises(GeometryError, match=r"tip_margin"):
        CrowningOptimizer(pair, CrowningTarget(te_level=3e-5, tip_margin=2.5), cases=cases)


def test_hob_diameter_beyond_any_lead_angle_is_refused(capsys, scene_file):
    from gearopt.geometry.generation import Hob

    hob = 'tool = {{kind = "hob", z = 2, d_p0 = {}}}'
    err = refused(capsys, scene_file, scene(pinion=hob.format('"3 m"')), r"\[pinion\] tool.d_p0 = \"3 m\"",
                  r"lead angle")
    # lead angle 0.1 deg: d_p0 = N_h m_n / sin(0.1 deg); 30 deg: N_h m_n / sin(30 deg)
    assert _number_after(err, r"d_p0 <= ([\d.]+) mm") == pytest.approx(2 * 2.25 / math.sin(math.radians(0.1)),
                                                                        rel=1e-5)
    err = refused(capsys, scene_file, scene(gear=hob.format('"6 mm"')), r"\[gear\] tool.d_p0 = \"6 mm\"",
                  r"lead angle")
    assert _number_after(err, r"([\d.]+) <= d_p0") == pytest.approx(2 * 2.25 / 0.5, rel=1e-5)
    accepted(capsys, scene_file, scene(pinion=hob.format('"90 mm"'), gear=hob.format('"9.1 mm"')))
    with pytest.raises(GeometryError, match="d_p0"):
        Hob(N_h=1, d_p0=4e5).lead_angle(4.0)


def test_bare_planar_starting_angle_in_radians_is_a_unit_slip(capsys, scene_file):
    planar = "[planar_tca]\nalpha_guess = {}\n"
    refused(capsys, scene_file, scene("planar_tca", extra=planar.format("0.4")), r"alpha_guess = 0.4", r"0.4 rad")
    accepted(capsys, scene_file, scene("planar_tca", extra=planar.format("24")))


def test_toml_dates_are_spelled_as_in_toml(capsys, scene_file):
    err = refused(capsys, scene_file, scene(pinion="x = 2024-02-29T08:30:00"), r"\[pinion\] x = 2024-02-29T08:30:00:",
                  r"got a date-time")
    assert "datetime" not in err
    refused(capsys, scene_file, scene(extra="[geometry]\npoints = 07:45:00\n"), r"points = 07:45:00:", r"a time of day")


def test_scene_with_a_byte_order_mark_is_read(capsys, scene_file):
    path = scene_file("")
    path.write_bytes(b"\xef\xbb\xbf" + scene().encode("utf-8"))
    capsys.readouterr()
    assert main(["check", str(path)]) == 0, capsys.readouterr().err


def test_run_error_in_a_case_shows_the_cases_as_written(capsys, scene_file, tmp_path):
    crowned = 'a_pl = "0.0004 1/mm"\nrack = { a_c = "0.002 1/mm" }'
    cases = '[tca]\npositions = 9\n[[tca.cases]]\nlabel = "tilted"\nintersecting = "45 arcmin"\n'
    path = scene_file(scene("tca", pinion=crowned, extra=cases))
    out = tmp_path / "res"
    capsys.readouterr()
    rc = main(["run", str(path), "--out", str(out), "-q"])
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err and not out.exists(), err
    assert 'cases[0] = {label = "tilted", intersecting = "45 arcmin"}' in err, err


def test_line_contact_with_angular_misalignment_is_refused_at_check(capsys, scene_file):
    # conjugate spur pinion, crossed axes: the flanks cross in every section, no line contact exists
    refused(capsys, scene_file, scene("tca", extra='[tca]\ncontact = "line"\npositions = 9\ncrossing = "4 arcmin"\n'),
            r"\[tca\] crossing = \"4 arcmin\" is not allowed with contact = \"line\"")
    cases = '[tca]\ncontact = "line"\npositions = 9\n[[tca.cases]]\ndE = "0.03 mm"\n[[tca.cases]]\nintersecting = "-1.5 arcmin"\n'
    refused(capsys, scene_file, scene("tca", pair='a = "71.3 mm"', extra=cases),
            r"\[tca\.cases\]\[1\] intersecting = \"-1.5 arcmin\"")
    # a centre-distance change keeps line contact; edge contact handles the crossed axes
    accepted(capsys, scene_file, scene("tca", pair='a = "71.3 mm"', extra=cases.split("[[tca.cases]]\nint")[0]))
    accepted(capsys, scene_file, scene("tca", extra='[tca]\ncontact = "line"\nedge_contact = true\npositions = 9\n'
                                                    'crossing = "4 arcmin"\n'))


def test_fea_positions_that_would_repeat_or_ignore_an_angle(capsys, scene_file):
    fea = "[fea]\nphi1_start = \"{}\"\nphi1_end = \"{}\"\nn_positions = {}\n"
    refused(capsys, scene_file, scene("fea", b=8, extra=fea.format("1.5 deg", "1.5 deg", 4)), r"\[fea\] n_positions = 4")
    refused(capsys, scene_file, scene("fea", b=8, extra=fea.format("-3 deg", "4 deg", 1)),
            r"\[fea\] phi1_end = \"4 deg\" is not used with n_positions = 1")


def test_crowning_optimizer_with_no_cases_is_refused():
    from gearopt.synthesis.crowning import CrowningOptimizer, CrowningTarget

    pair = GearPair(pinion=Gear(z=24, m_n=2.5, b=15.0, name="pinion"), gear=Gear(z=37, m_n=2.5, b=15.0, name="gear"))
    with pytest.raises(OptionError, match="cases"):  # an option of the optimizer, not gear data
        CrowningOptimizer(pair, CrowningTarget(te_level=4e-5), cases={})
