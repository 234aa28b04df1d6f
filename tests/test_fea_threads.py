"""ccx's thread count: the requested threads, at most the CPUs idle now (gearopt.fea.calculix.run_ccx,
idle_cpus_now: the idle share of /proc/stat over a short window)."""

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
    monkeypatch.setattr(calculix, "idle_cpus_now", lambda: idle)
    monkeypatch.setattr(calculix.subprocess, "run", fake_run)
    with pytest.raises(_Stop):
        calculix.run_ccx(None, inp="*HEADING\n", threads=requested)
    assert seen == {"omp": str(expected), "solver": str(expected)}


def _stat(idle: int, busy: int, n_cpus: int) -> str:
    """A /proc/stat whose machine line has ``idle`` idle+iowait ticks and ``busy`` others."""
    cpus = "".join(f"cpu{i} 1 0 1 1 0 0 0 0 0 0\n" for i in range(n_cpus))
    return f"cpu  {busy} 0 0 {idle - 5} 5 0 0 0 0 0\n{cpus}intr 1 2 3\nctxt 99\n"


@pytest.mark.parametrize(("n_cpus", "usable", "idle_ticks", "busy_ticks", "expected"),
                         [(2, 2, 20, 0, 2),    # both cores idle over the window: the other worker is done
                          (2, 2, 10, 10, 1),   # one core busy (the other test worker)
                          (2, 2, 9, 11, 1),    # a little more than one core busy: still one
                          (2, 2, 0, 20, 1),    # all busy: at least one thread
                          (4, 4, 30, 10, 3),
                          (4, 2, 40, 0, 2)])   # at most the CPUs this process may use
def test_idle_cpus_now_is_the_idle_share_of_the_window(monkeypatch, tmp_path, n_cpus, usable, idle_ticks, busy_ticks,
                                                       expected):
    """The CPUs idle over the sampling window, from the machine's tick counters before and after it
    (not the 1-minute load average, which a worker busy until a moment ago keeps at 1 or more)."""
    stat = tmp_path / "stat"
    stat.write_text(_stat(1000, 5000, n_cpus))
    monkeypatch.setattr(calculix, "PROC_STAT", str(stat))
    monkeypatch.setattr(calculix.time, "sleep", lambda s: stat.write_text(_stat(1000 + idle_ticks, 5000 + busy_ticks,
                                                                                n_cpus)))
    monkeypatch.setattr(calculix.os, "sched_getaffinity", lambda pid: set(range(usable)), raising=False)
    monkeypatch.setattr(calculix, "load_average_idle_cpus", lambda: pytest.fail("fell back to the load average"))
    assert calculix.idle_cpus_now() == expected


def test_idle_cpus_now_falls_back_to_the_load_average(monkeypatch, tmp_path):
    """Where /proc/stat cannot be read (not Linux), the 1-minute load average decides."""
    monkeypatch.setattr(calculix, "PROC_STAT", str(tmp_path / "missing"))
    monkeypatch.setattr(calculix, "load_average_idle_cpus", lambda: 3)
    assert calculix.idle_cpus_now() == 3
