"""ccx's thread count: the requested threads, at most the CPUs idle now (gearopt.fea.calculix.run_ccx)."""

from __future__ import annotations

import pytest

from gearopt.fea import calculix


class _Stop(Exception):
    pass


@pytest.mark.parametrize(("requested", "idle", "expected"), [(2, 1, 1), (2, 2, 2), (4, 3, 3), (1, 2, 1)])
def test_ccx_gets_at_most_the_idle_cpus(monkeypatch, requested, idle, expected):
    seen = {}

    def fake_run(args, cwd, env, **kw):
        seen.update(omp=env["OMP_NUM_THREADS"], solver=env["CCX_NPROC_EQUATION_SOLVER"])
        raise _Stop

    monkeypatch.setattr(calculix, "require_ccx", lambda: "ccx")
    monkeypatch.setattr(calculix, "idle_cpus", lambda: idle)
    monkeypatch.setattr(calculix.subprocess, "run", fake_run)
    with pytest.raises(_Stop):
        calculix.run_ccx(None, inp="*HEADING\n", threads=requested)
    assert seen == {"omp": str(expected), "solver": str(expected)}
