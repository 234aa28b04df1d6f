"""The FE study's options as option sets of gearopt.settings (issue 40): FEOptions and MeshOptions
declare each option once; the API, the ``[fea]`` scene section and the docs take it from there (the
generic checks of every option are in tests/test_settings.py, which lists fea as converted)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from gearopt.errors import OptionError, SceneError
from gearopt.fea.mesh import MeshOptions
from gearopt.fea.model import FEOptions

ROOT = Path(__file__).resolve().parents[1]


def test_the_fea_api_classes_are_the_option_sets():
    from gearopt import settings

    assert FEOptions is settings.FEOptions and MeshOptions is settings.MeshOptions
    assert issubclass(FEOptions, settings.Settings) and issubclass(MeshOptions, settings.Settings)


def test_the_keyword_api_keeps_working_and_normalises():
    import numpy as np

    o = FEOptions(torque=100e3, n_hertz=2, mesh=MeshOptions(n_face=np.int64(2), n_half=4, n_flank=6, n_fillet=4,
                                                            n_rim=3))
    assert o.to_dict() == {"torque_Nmm": 100e3, "E": 210e3, "nu": 0.3, "teeth": 3, "n_hertz": 2.0, "n_ellipse": 2.0,
                           "penalty_times_E": 50.0, "element_type": "C3D8",
                           "mesh": {"n_face": 2, "n_half": 4, "n_flank": 6, "n_fillet": 4, "n_rim": 3,
                                    "rim_depth": 1.5}}
    assert type(o.mesh.n_face) is int and type(o.n_hertz) is float
    kept = dataclasses.replace(o, keep_dir="/tmp/x")  # as FEStudy.run keeps each position's files
    assert kept.keep_dir == "/tmp/x" and kept.mesh == o.mesh
    graded = dataclasses.replace(o.mesh, h_contact=0.05, window=0.3)  # as GearFEModel grades the contact
    assert (graded.h_contact, graded.window, graded.n_face) == (0.05, 0.3, 2)


def test_an_odd_face_count_is_refused_naming_the_even_range():
    with pytest.raises(OptionError, match=r"fea\.n_face = 3 is out of range; valid: an even integer, "
                                          r"2 <= n_face <= 200") as e:
        MeshOptions(n_face=3)
    assert e.value.param == "fea.n_face"


def test_a_modulus_in_gpa_gets_the_hint_through_the_api_as_in_a_scene():
    """E = 210 (GPa written for MPa): the API used to take any E > 0; it now states the range of the
    scene key with the same unit hint."""
    with pytest.raises(OptionError, match=r"fea\.E = 210 is out of range; valid: 500 <= E <= 1\.2e\+06 MPa, the "
                                          r"Young's moduli of gear materials \(E is in MPa: 210 GPa is 210000 MPa\)"):
        FEOptions(E=210)
    from gearopt.studies import studies

    field = next(f for f in studies()["fea"].sections[0].fields if f.name == "E")
    with pytest.raises(SceneError, match=r"210 GPa is 210000 MPa"):
        field.convert(210.0, "[fea] E")


def test_mesh_must_be_mesh_options():
    with pytest.raises(OptionError, match=r"fea\.mesh = .* valid: a gearopt\.fea\.mesh\.MeshOptions") as e:
        FEOptions(mesh={"n_face": 2})
    assert e.value.param == "fea.mesh"


def test_the_scene_torque_is_the_api_torque_in_n_m():
    from gearopt.studies import studies

    field = next(f for f in studies()["fea"].sections[0].fields if f.name == "torque")
    assert field.default * 1e3 == FEOptions().torque
    field.convert(1e6, "[fea] torque")
    with pytest.raises(SceneError, match=r"0 < torque <= 1e\+06"):
        field.convert(2e6, "[fea] torque")
    FEOptions(torque=1e9)
    with pytest.raises(OptionError, match=r"fea\.torque = 2000000000\.0 is out of range; valid: 0 < torque <= 1e\+09 N\*mm"):
        FEOptions(torque=2e9)


def test_a_scene_without_fea_keys_builds_the_api_defaults(tmp_path):
    """One default per option: the scene section's defaults load as FEOptions() (torque 100 N*m)."""
    from gearopt.io.scene import load_scene
    from gearopt.studies import get_study

    text = (ROOT / "problems/fea_spur.toml").read_text()
    text = text.split("[fea]")[0]
    path = tmp_path / "s.toml"
    path.write_text(text)
    study = get_study("fea").build(load_scene(path))
    assert study.options == FEOptions()
    assert study.phi1s == [0.0]


def test_a_scene_refuses_an_odd_face_count_naming_the_key(tmp_path):
    from gearopt.io.scene import load_scene
    from gearopt.studies import get_study

    text = re.sub(r"(?m)^n_face = 2$", "n_face = 3", (ROOT / "problems/fea_spur.toml").read_text())
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(SceneError, match=r"\[fea\] n_face = 3 is out of range; valid: an even integer") as e:
        get_study("fea").build(load_scene(path))
    assert e.value.param == "[fea] n_face"
