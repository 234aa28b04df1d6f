"""The whole suite's work units under ``make test`` (pytest-xdist ``--dist loadgroup``; conftest.work_unit)
with their cost from the per-test times of a junit report, and the wall time that pytest-xdist's
hand-out of those units (heaviest first, conftest.UNIT_COST) gives on N workers.

    python tests/suite_units.py JUNIT.xml [JUNIT2.xml ...] [--workers 2] [--scale 1.0] [-- PYTEST ARGS]

The junit report: ``pytest --junitxml=FILE`` of a whole-suite run (under load its times are wall times
that overstate CPU; ``--scale`` multiplies them). Prints the units heaviest first as the table for
conftest.UNIT_COST, then the simulated schedule: per worker the units it runs and when it ends.
Tests missing from the report count their unit's median. Collection runs in this process (no test runs)."""

from __future__ import annotations

import argparse
import statistics
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent


class _Units:
    """pytest plugin: the collected items in order with their work unit."""

    def __init__(self):
        self.items: list[tuple[str, str]] = []

    def pytest_collection_finish(self, session):
        work_unit = sys.modules["conftest"].work_unit
        self.items = [(item.nodeid, work_unit(item)) for item in session.items]


def junit_times(paths: list[str]) -> dict[str, float]:
    """nodeid -> time [s] (the last report wins; an xdist_group suffix ``@unit`` is dropped)."""
    times: dict[str, float] = {}
    for path in paths:
        for tc in ET.parse(path).iter("testcase"):
            mod = tc.get("classname", "").split(".")
            # classname "tests.test_x" or "tests.test_x.Class"
            k = next((i for i, m in enumerate(mod) if m.startswith("test_")), len(mod) - 1)
            nodeid = "/".join(mod[:k + 1]) + ".py::" + "::".join(mod[k + 1:] + [tc.get("name", "")])
            times[nodeid.split("@")[0]] = float(tc.get("time", 0.0))
    return times


def simulate(units: list[tuple[str, list[float]]], workers: int) -> list[tuple[float, list[str]]]:
    """pytest-xdist's LoadScopeScheduling on ``workers`` processes: each takes the next unit while it
    has at most 2 tests pending (xdist/scheduler/loadscope.py ``_reschedule``), tests run in order."""
    queue = list(units)
    state = [{"t": 0.0, "pending": [], "units": []} for _ in range(workers)]

    def give(w):
        if queue:
            name, tests = queue.pop(0)
            w["pending"].extend(tests)
            w["units"].append(name)

    for w in state:
        give(w)
    for w in state:
        if len(w["pending"]) <= 2:
            give(w)
    while any(w["pending"] for w in state):
        w = min((w for w in state if w["pending"]), key=lambda w: w["t"] + w["pending"][0])
        w["t"] += w["pending"].pop(0)
        if len(w["pending"]) <= 2:
            give(w)
    return [(w["t"], w["units"]) for w in state]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("junit", nargs="+")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scale", type=float, default=1.0, help="factor on the junit times")
    ap.add_argument("--loadfile", action="store_true",
                    help="also simulate --dist loadfile (a unit per file, most tests first: pytest-xdist's default)")
    a = ap.parse_args(argv)
    plugin = _Units()
    rc = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", str(TESTS), *extra], plugins=[plugin])
    if rc not in (0, 5):
        return int(rc)
    times = junit_times(a.junit)
    per_unit: dict[str, list[tuple[str, float | None]]] = {}
    for nodeid, unit in plugin.items:
        per_unit.setdefault(unit, []).append((nodeid, times.get(nodeid)))
    costs: dict[str, list[float]] = {}
    for unit, tests in per_unit.items():
        known = [t for _, t in tests if t is not None]
        fill = statistics.median(known) if known else 0.0
        costs[unit] = [a.scale * (t if t is not None else fill) for _, t in tests]
    order = sorted(costs, key=lambda u: -sum(costs[u]))
    total = sum(sum(c) for c in costs.values())
    print(f"{len(plugin.items)} tests in {len(costs)} units, {total:.0f} s in all; heaviest first:")
    print("UNIT_COST = {" + ", ".join(f'"{u}": {sum(costs[u]):.0f}' for u in order if sum(costs[u]) >= 5) + "}")
    # the order conftest gives with the table above (units below 5 s keep collection order)
    first = {}
    for i, (_, unit) in enumerate(plugin.items):
        first.setdefault(unit, i)
    listed = {u: sum(costs[u]) for u in order if sum(costs[u]) >= 5}
    handed = sorted(costs, key=lambda u: (-listed.get(u, 0.0), first[u]))
    for k, (end, units) in enumerate(simulate([(u, costs[u]) for u in handed], a.workers)):
        print(f"worker {k}: ends at {end:.0f} s; {len(units)} units, first {units[:6]}")
    if a.loadfile:
        files: dict[str, list[float]] = {}
        by_test = {nodeid: c for unit in per_unit for (nodeid, _), c in zip(per_unit[unit], costs[unit])}
        for nodeid, _ in plugin.items:
            files.setdefault(nodeid.split("::")[0], []).append(by_test[nodeid])
        order = sorted(files, key=lambda f: -len(files[f]))  # stable: xdist's loadscope reorder
        for k, (end, units) in enumerate(simulate([(f, files[f]) for f in order], a.workers)):
            print(f"--dist loadfile, worker {k}: ends at {end:.0f} s; {len(units)} files")
    return 0


if __name__ == "__main__":
    sys.exit(main())
