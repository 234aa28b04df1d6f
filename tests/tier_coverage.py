"""Which gearopt modules the fast test tier (``pytest -m "not slow"``, what ``make check`` runs) exercises.

Runs the fast tier under coverage.py (one data file per xdist worker, combined afterwards) and lists, for
every ``gearopt/**/*.py``, the share of its statements executed and whether any line inside one of its
functions ran (a module only imported has run its ``def`` lines, not their bodies). Exits 1 when a
module's functions never ran, so that a new module without a fast test shows up here.

Usage (needs coverage.py, which the test extra installs)::

    python tests/tier_coverage.py            # the fast tier on 2 workers
    python tests/tier_coverage.py -- -k tca  # extra pytest arguments after --

docs/testing.md gives the last measurement.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "gearopt"

#: A pytest plugin loaded by every xdist worker: starts coverage at configure, saves a parallel data file.
PLUGIN = '''
import coverage, os
_cov = None
def pytest_configure(config):
    global _cov
    _cov = coverage.Coverage(data_file=os.environ["TIER_COVERAGE_FILE"], data_suffix=True,
                             source=[os.environ["TIER_COVERAGE_SOURCE"]])
    _cov.start()
def pytest_unconfigure(config):
    if _cov is not None:
        _cov.stop()
        _cov.save()
'''


def function_body_lines(path: Path) -> set[int]:
    """Line numbers of the statements inside the functions (and methods) of a module."""
    lines: set[int] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for stmt in node.body:
                lines.update(range(stmt.lineno, (stmt.end_lineno or stmt.lineno) + 1))
    return lines


def main(argv: list[str]) -> int:
    import coverage

    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "tier_coverage_plugin.py").write_text(PLUGIN)
        data = Path(tmp) / ".coverage"
        env = dict(os.environ, TIER_COVERAGE_FILE=str(data), TIER_COVERAGE_SOURCE=str(PACKAGE),
                   PYTHONPATH=os.pathsep.join([tmp, str(ROOT), os.environ.get("PYTHONPATH", "")]))
        cmd = [sys.executable, "-m", "pytest", "-q", "-m", "not slow", "-n", "2", "--dist", "loadfile",
               "-p", "tier_coverage_plugin", "-p", "no:cacheprovider", *extra]
        print("$", " ".join(cmd), flush=True)
        rc = subprocess.call(cmd, cwd=ROOT, env=env)
        cov = coverage.Coverage(data_file=str(data))
        cov.combine([tmp])
        measured = cov.get_data()
        rows, missing = [], []
        for path in sorted(PACKAGE.rglob("*.py")):
            executed = set(measured.lines(str(path)) or ())
            statements = cov.analysis2(str(path))[1]
            body = function_body_lines(path)
            ran = bool(executed & body) or (not body and bool(executed))
            share = len(executed & set(statements)) / max(len(statements), 1)
            rows.append((path.relative_to(ROOT).as_posix(), share, ran))
            if not ran:
                missing.append(rows[-1][0])
    width = max(len(r[0]) for r in rows)
    print(f"\n{'module':<{width}}  statements run  functions run")
    for name, share, ran in rows:
        print(f"{name:<{width}}  {100 * share:13.0f} %  {'yes' if ran else 'NO'}")
    total = sum(r[1] for r in rows) / len(rows)
    print(f"\n{len(rows)} modules, mean statement coverage {100 * total:.0f} %; "
          f"{len(missing)} module(s) whose functions never ran in the fast tier" + (":" if missing else "."))
    for m in missing:
        print("  ", m)
    return 1 if (missing or rc not in (0,)) else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
