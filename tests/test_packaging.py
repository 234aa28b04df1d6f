"""The package's version has one source, gearopt/version.py: pyproject.toml reads it (setuptools'
dynamic version) instead of stating it again."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_distribution_version_is_gearopt_version():
    pytest.importorskip("setuptools")
    from setuptools.config.pyprojecttoml import read_configuration

    from gearopt.version import __version__

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # setuptools' "[tool.setuptools] is beta"
        raw = read_configuration(ROOT / "pyproject.toml", expand=False)["project"]
        project = read_configuration(ROOT / "pyproject.toml")["project"]
    assert "version" not in raw and "version" in raw["dynamic"]
    assert project["version"] == __version__
