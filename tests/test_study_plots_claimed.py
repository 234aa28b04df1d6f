"""A study's ``save_plots`` builds no figure whose file another drawing process has claimed
(gearopt.plot.saving.drawn_here; `gearopt run` draws in several processes, gearopt/cli_plots.py)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.figure  # noqa: E402
import pytest  # noqa: E402

from gearopt.io.scene import load_scene  # noqa: E402
from gearopt.plot.saving import drawn_here, png_saving  # noqa: E402

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


@pytest.fixture(scope="module")
def ltca_result():
    return load_scene(PROBLEMS / "ltca_spur.toml").build().run()


def _built(monkeypatch) -> list:
    made = []
    init = matplotlib.figure.Figure.__init__

    def spy(self, *args, **kwargs):
        made.append(self)
        init(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "__init__", spy)
    return made


@pytest.mark.slow
def test_ltca_figures_claimed_elsewhere_are_not_built(ltca_result, tmp_path, monkeypatch):
    claims = tmp_path / "claims"
    claims.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    names = ["ltca_te.png", "ltca_sharing.png", "ltca_pattern.png"]
    with png_saving(claims):  # "another process" took two of the three files
        assert drawn_here(out / names[0]) and drawn_here(out / names[2])
    made = _built(monkeypatch)
    with png_saving(claims):
        files = ltca_result.save_plots(out)
    assert files == names  # every file named, whoever draws it
    assert len(made) == 1  # only ltca_sharing.png was built here
    assert sorted(p.name for p in out.iterdir()) == ["ltca_sharing.png"]
    made.clear()
    assert ltca_result.save_plots(tmp_path) == names and len(made) == 3  # outside png_saving: all drawn
