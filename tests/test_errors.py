"""Structured errors (gearopt.errors): every GearoptError carries ``param``, ``value`` and
``valid``; the scene loader maps errors to ``[section] key`` from those fields; line contact in the
point-contact TCA is a LineContactError (edge contact switches on the class, not the words);
solver and study options raise OptionError, not GeometryError.

The expected fields are read off the documented valid ranges (gearopt.gears, the TCA docs), not off
the code's output; the corpora of tests/test_bad_input*.py are checked by the autouse fixture in
conftest.py with the independent message reader of tests/error_fields.py.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import gearopt
from error_fields import check_fields, recording
from gearopt.errors import (ArgumentError, CalculixError, ConvergenceError, GearoptError, GeometryError,
                            LineContactError, OptionError, SceneError, SynthesisError, check_number, out_of_range)
from gearopt.gears import BasicRack, Gear, GearPair
from gearopt.units import ARCMIN, DEG


def _spur(z1=19, z2=41, m=2.25, b=16.0, a_pl=0.0, a_c=0.0):
    rack = BasicRack.iso53("A", a_c=a_c) if a_c else BasicRack.iso53("A")
    return GearPair(pinion=Gear(z=z1, m_n=m, b=b, a_pl=a_pl, rack=rack, name="pinion"),
                    gear=Gear(z=z2, m_n=m, b=b, name="gear"))


@pytest.fixture(scope="module")
def crowned():
    return _spur(a_pl=4e-4, a_c=0.002)


@pytest.fixture(scope="module")
def crowned_tca(crowned):
    from gearopt.meshing.tca import TCA

    return TCA(crowned)


# ------------------------------------------------------------------------------------------------
# 1. The fields, against the documented valid ranges
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make, cls, param, value, valid", [
    (lambda: Gear(z=2, m_n=2.0, b=10.0, name="pinion"), GeometryError, "pinion.z", 2, "z >= 3 teeth"),
    (lambda: Gear(z=30, m_n=2.0, b=10.0, a_pl=-1e-3, name="gear"), GeometryError, "gear.a_pl", -1e-3,
     "a_pl >= 0 [1/mm] (0 = no longitudinal crowning)"),
    (lambda: Gear(z=30, m_n=2.0, b=10.0, beta=50 * DEG, name="wheel"), GeometryError, "wheel.beta", "50 deg",
     "0 <= beta < 45 deg"),
    (lambda: BasicRack(alpha_n=47 * DEG), GeometryError, "rack.alpha_n", "47 deg", "0 < alpha_n < 45 deg"),
    (lambda: BasicRack(h_aP=-0.2), GeometryError, "rack.h_aP", -0.2, "h_aP > 0 (in modules)"),
    (lambda: Gear(z=30, m_n=2.0, b=10.0, A_sne=math.nan, name="pinion"), GeometryError, "pinion.A_sne", math.nan,
     "a finite number"),
    (lambda: __import__("gearopt.meshing.tca", fromlist=["Misalignment"]).Misalignment(crossing=math.inf),
     GeometryError, "misalignment.crossing", math.inf, "a finite number"),
    (lambda: __import__("gearopt.meshing.tca", fromlist=["Misalignment"]).Misalignment(intersecting=700 * ARCMIN),
     GeometryError, "misalignment.intersecting", "700 arcmin", "|angle| <= 600 arcmin (10 deg)"),
    (lambda: check_number("target.te_level", "8 arcsec"), ArgumentError, "target.te_level", "8 arcsec",
     "a finite number"),
    (lambda: gearopt.units.deg("20 deg"), ArgumentError, "value_deg", "20 deg", "a number in deg"),
])
def test_fields_name_parameter_value_and_range(make, cls, param, value, valid):
    with pytest.raises(cls) as ei:
        make()
    e = ei.value
    assert e.param == param
    assert e.valid == valid
    if isinstance(value, float) and math.isnan(value):
        assert math.isnan(e.value)
    else:
        assert e.value == value
    assert not check_fields(e), check_fields(e)
    assert str(e).startswith(f"{param} = ")


def test_pair_error_fields_name_the_centre_distance():
    p, g = Gear(z=21, m_n=3.0, b=20.0, name="pinion"), Gear(z=40, m_n=3.0, b=20.0, name="gear")
    r_bsum = p.r_b + g.r_b
    with pytest.raises(GeometryError) as ei:
        GearPair(pinion=p, gear=g, a=0.9 * r_bsum)
    assert ei.value.param == "pair.a" and ei.value.value == pytest.approx(0.9 * r_bsum)
    assert f"{r_bsum:.6g}" in ei.value.valid and not check_fields(ei.value)


def test_errors_without_a_parameter_have_none():
    e = ConvergenceError("no contact point")
    assert (e.param, e.value, e.valid, e.detail) == (None, None, None, None)
    e = out_of_range("x", 1.5, "x < 1", "Lower it.")
    assert (e.param, e.value, e.valid) == ("x", 1.5, "x < 1")
    assert str(e) == f"x = 1.5 {e.detail}" and e.detail == "is out of range; valid: x < 1. Lower it."


def test_fields_survive_pickling():
    import pickle

    e = pickle.loads(pickle.dumps(out_of_range("pinion.z", 2, "z >= 3 teeth")))
    assert type(e) is GeometryError and (e.param, e.value, e.valid) == ("pinion.z", 2, "z >= 3 teeth")


def test_synthesis_and_calculix_errors_live_in_errors_py():
    from gearopt.fea import CalculixError as fea_ce
    from gearopt.fea.calculix import CalculixError as calculix_ce
    from gearopt.synthesis import SynthesisError as syn_se
    from gearopt.synthesis.crowning import SynthesisError as crowning_se

    assert SynthesisError.__module__ == CalculixError.__module__ == "gearopt.errors"
    assert syn_se is crowning_se is SynthesisError and fea_ce is calculix_ce is CalculixError
    assert issubclass(SynthesisError, ConvergenceError) and issubclass(CalculixError, RuntimeError)
    assert issubclass(LineContactError, ConvergenceError)


# ------------------------------------------------------------------------------------------------
# 2. Solver and study options are OptionErrors, not geometry errors
# ------------------------------------------------------------------------------------------------
def _tca(pair, **kw):
    from gearopt.meshing.tca import TCA

    return TCA(pair, **kw)


def _fe(**kw):
    from gearopt.fea.model import FEOptions

    return FEOptions(**kw)


def _mesh(**kw):
    from gearopt.fea.mesh import MeshOptions

    return MeshOptions(**kw)


@pytest.mark.parametrize("call, param, value", [
    (lambda pair: _tca(pair, solver="bogus"), "solver", "bogus"),
    (lambda pair: _tca(pair, contact="surface"), "contact", "surface"),
    (lambda pair: _tca(pair, side="up"), "side", "up"),
    (lambda pair: _tca(pair, jit="yes"), "jit", "yes"),
    (lambda pair: _tca(pair, tol=-1e-9), "tol", -1e-9),
    (lambda pair: _tca(pair, tol=0.5), "tol", 0.5),
    (lambda pair: __import__("gearopt.studies.tca", fromlist=["TCAStudy"]).TCAStudy(pair, positions=4),
     "positions", 4),
    (lambda pair: __import__("gearopt.studies.tca", fromlist=["TCAStudy"]).TCAStudy(pair, delta=1.0), "delta", 1.0),
    (lambda pair: __import__("gearopt.studies.tca", fromlist=["TCAStudy"]).TCAStudy(pair, z_section=9.0),
     "z_section", 9.0),
    (lambda pair: _fe(teeth=9), "fea.teeth", 9),
    (lambda pair: _fe(element_type="C3D20"), "fea.element_type", "C3D20"),
    (lambda pair: _mesh(n_face=3), "fea.n_face", 3),
    (lambda pair: __import__("gearopt.meshing.planar", fromlist=["PlanarTCA"]).PlanarTCA(30.0, 40.0, 100.0).solve(
        [0.1], method="bisect"), "method", "bisect"),
])
def test_solver_options_raise_option_error(call, param, value):
    pair = _spur(b=16.0)
    with pytest.raises(OptionError) as ei:
        call(pair)
    e = ei.value
    assert not isinstance(e, GeometryError), "a solver option is not a geometry error"
    assert isinstance(e, ValueError) and isinstance(e, GearoptError)
    assert (e.param, e.value) == (param, value) and e.valid and not check_fields(e)


def test_optimizer_options_raise_option_error(crowned):
    from gearopt.synthesis.crowning import CrowningOptimizer, CrowningTarget

    for kw, param in (({"positions": 3}, "positions"), ({"tol": 1.0}, "tol"), ({"cases": {}}, "cases"),
                      ({"bounds": {"a_c": (0.01, 0.001)}}, "bounds['a_c']"), ({"side": "both"}, "side")):
        with pytest.raises(OptionError) as ei:
            CrowningOptimizer(crowned, CrowningTarget(te_level=6e-5), **kw)
        assert ei.value.param == param and not isinstance(ei.value, GeometryError)


def test_edge_contact_edges_option(crowned_tca):
    from gearopt.contact.edge import EdgeContact

    with pytest.raises(OptionError) as ei:
        EdgeContact(crowned_tca, edges=("pinion_tip", "rim"))
    assert ei.value.param == "edges" and ei.value.value == "rim"


def test_sweep_delta_is_an_option(crowned_tca, crowned):
    with pytest.raises(OptionError) as ei:
        crowned_tca.sweep([0.0], delta=0.2 * crowned.pinion.m_n)
    assert ei.value.param == "delta" and not isinstance(ei.value, GeometryError)


def test_geometry_stays_geometry_error():
    """Actual gear data keep their class: ``except GeometryError`` still catches them."""
    with pytest.raises(GeometryError) as ei:
        Gear(z=30, m_n=2.0, b=10.0, x=-40.0, name="gear")
    assert not isinstance(ei.value, OptionError) and ei.value.param == "gear.x"


# ------------------------------------------------------------------------------------------------
# 3. The scene loader maps deep errors to [section] key from the fields
# ------------------------------------------------------------------------------------------------
SCENE = """\
[scene]
name = "errors"
study = "{study}"

[pair]
m_n = {m}

[pinion]
z = {z1}
b = 16
{pinion}

[gear]
z = 41
b = 16

[rack]
{rack}

{extra}
"""


def _scene(study="geometry", m=2.25, z1=19, pinion="", rack="", extra=""):
    return SCENE.format(study=study, m=m, z1=z1, pinion=pinion, rack=rack, extra=extra)


def _load_error(scene_file, text, build=True) -> SceneError:
    from gearopt.cli import _in_scene
    from gearopt.io.scene import load_scene

    path = scene_file(text)
    with pytest.raises(SceneError) as ei:
        scene = load_scene(path)
        if build:
            with _in_scene(scene):
                scene.build()
    assert str(ei.value).startswith(str(path))
    return ei.value


@pytest.mark.parametrize("text, param, head, valid", [
    (_scene(z1=2), "[pinion] z", "[pinion] z = 2 is out of range", "z >= 3 teeth"),
    (_scene(rack='alpha_n = "50 deg"'), "[rack] alpha_n", '[rack] alpha_n = "50 deg" is out of range',
     "0 < alpha_n < 45 deg"),
    (_scene(pinion='rack = { h_aP = -0.5 }'), "[pinion.rack] h_aP", "[pinion.rack] h_aP = -0.5 is out of range",
     "h_aP > 0 (in modules)"),
    (_scene(pinion='a_pl = "-0.001 1/mm"'), "[pinion] a_pl", '[pinion] a_pl = "-0.001 1/mm" (= -0.001) is out of range',
     "a_pl >= 0 [1/mm] (0 = no longitudinal crowning)"),
])
def test_gear_errors_are_reported_at_their_key(scene_file, text, param, head, valid):
    e = _load_error(scene_file, text, build=False)
    assert e.param == param and e.valid == valid, (e.param, e.valid, str(e))
    assert head in str(e), str(e)
    assert not check_fields(e)


def test_study_option_error_is_reported_at_its_key(scene_file):
    # [tca] delta passes the scene's own range (<= 0.1 mm) but not the study's 0.1 m_n = 0.06 mm
    text = _scene("tca", m=0.6, pinion='a_pl = 0.0005\nrack = { a_c = 0.003 }', extra="[tca]\ndelta = 0.09\n")
    with recording() as seen:
        e = _load_error(scene_file, text)
    deep = [x for x in seen if isinstance(x, OptionError)]
    assert deep and deep[0].param == "delta"
    assert e.param == "[tca] delta" and e.value == "0.09"
    assert "[tca] delta = 0.09 is out of range; valid: 0 < delta <= 0.1 m_n = 0.06 mm" in str(e), str(e)


def test_tool_error_is_reported_at_its_key(scene_file):
    # the pinion's hob, checked against the gear (lead angle): pinion.tool.d_p0 -> [pinion] tool.d_p0,
    # with the value as written and the valid range computed for this module
    e = _load_error(scene_file, _scene(pinion='tool = {kind = "hob", d_p0 = "4 m"}'))
    assert e.param == "[pinion] tool.d_p0" and e.value == '"4 m"'
    assert e.valid.startswith("4.5 <= d_p0 <= ")  # asin(N_h m_n / d_p0) = 30 deg: d_p0 = 2 m_n = 4.5 mm
    assert re.search(r'\[pinion\] tool.d_p0 = "4 m" \(= 4000.0\) is out of range; valid: 4.5 <= d_p0 <= ', str(e)), str(e)


def test_run_time_error_is_reported_at_its_key(scene_file):
    """A TCA error raised while the study runs, naming mis.crossing, is stated for [tca] crossing
    with the value as written (deg), not the internal name and radians."""
    from gearopt.io.scene import load_scene

    scene = load_scene(scene_file(_scene("tca", pinion='a_pl = 0.0005\nrack = { a_c = 0.003 }',
                                         extra='[tca]\ncrossing = "3 deg"\n')))
    err = out_of_range("mis.crossing", 3 * DEG, "|crossing| <= 2 deg", cls=GeometryError)
    e = scene.run_error(err)
    assert e.param == "[tca] crossing" and e.value == '"3 deg"' and e.valid == "|crossing| <= 2 deg"
    assert '[tca] crossing = "3 deg" is out of range; valid: |crossing| <= 2 deg.' in str(e)
    assert "mis.crossing" not in str(e) and f"{3 * DEG}" not in str(e)
    # an error about no one key keeps its words and gets no param
    e = scene.run_error(ConvergenceError("TCA at phi1 = 0.1 rad: no contact point"))
    assert e.param is None and str(e).endswith("TCA at phi1 = 0.1 rad: no contact point")


def test_mapping_uses_fields_not_words(scene_file):
    """An error whose message does not start with its parameter is still mapped by its param."""
    from gearopt.io.scene import load_scene

    scene = load_scene(scene_file(_scene("tca", pinion='a_pl = 0.0005\nrack = { a_c = 0.003 }',
                                         extra='[tca]\npositions = 17\n')))
    err = OptionError("too few positions for this drive", param="positions", value=17, valid="positions >= 33",
                      detail="is too few for this drive; valid: positions >= 33.")
    e = scene.study_error("tca", err)
    assert e.param == "[tca] positions"
    assert str(e) == f"{scene.source}: [tca] positions = 17 is too few for this drive; valid: positions >= 33."


def test_no_message_parsing_left_in_gearopt():
    """No error is recognised by its words: no ``in str(e)``, no regex on an error message."""
    root = Path(gearopt.__file__).parent
    bad = []
    for f in root.rglob("*.py"):
        text = f.read_text(encoding="utf-8")
        for pat in (r"in str\((e|err|exc)\)", r"re\.\w+\([^)]*str\((e|err|exc)\)",
                    r"str\((e|err|exc)\)\.(split|replace|startswith|endswith)", r"\"line contact\" in"):
            for m in re.finditer(pat, text):
                bad.append(f"{f.relative_to(root)}: {m.group(0)}")
    assert not bad, bad


# ------------------------------------------------------------------------------------------------
# 4. Line contact: a class, not a phrase
# ------------------------------------------------------------------------------------------------
def test_point_contact_on_conjugate_flanks_raises_line_contact_error():
    tca = _tca(_spur(z1=23, z2=37, m=2.0, b=14.0))
    with pytest.raises(LineContactError) as ei:
        tca.solve_point(0.0)
    assert ei.value.param == "contact" and ei.value.value == "point"
    with pytest.raises(LineContactError):
        tca.sweep(np.linspace(-0.05, 0.05, 3))


def test_edge_contact_switches_to_line_contact_on_the_class(monkeypatch):
    """EdgeContact solves the line contact of a conjugate drive when the TCA raises
    LineContactError, whatever its words; another ConvergenceError that merely mentions line
    contact is not taken for one."""
    from gearopt.contact.edge import EdgeContact
    from gearopt.meshing.tca import TCA

    pair = _spur(z1=23, z2=37, m=2.0, b=14.0)
    phi = np.linspace(-0.05, 0.05, 3)
    tca = TCA(pair)
    real = tca.solve_point

    def reworded(*a, **kw):
        try:
            return real(*a, **kw)
        except LineContactError as e:
            raise LineContactError("singular tangency equations (reworded)", param=e.param, value=e.value) from None

    monkeypatch.setattr(tca, "solve_point", reworded)  # this point-contact TCA only
    r = EdgeContact(tca, edges=("pinion_tip",)).sweep(phi, pairs=(0,))
    assert r.stats.get("surface_mode") == "line contact (mid section)", r.stats
    assert np.abs(r.te_envelope).max() < 1e-9  # the conjugate drive: zero TE

    tca2 = TCA(pair)

    def other(*a, **kw):
        raise ConvergenceError("TCA: the point-contact equations are singular: the flanks are in line contact")

    monkeypatch.setattr(tca2, "solve_point", other)
    # not taken for line contact: no surface contact, and the aligned drive has no edge contact either
    with pytest.raises(ConvergenceError, match="no contact at any"):
        EdgeContact(tca2, edges=("pinion_tip",)).sweep(phi, pairs=(0,))
