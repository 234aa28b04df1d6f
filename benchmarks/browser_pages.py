"""The browser probe of the page tests (tests/page_check.py ``browser_check``): one headless Chromium
started per page (``--dump-dom``, what the tests did before) against the test process's one browser
driven over the DevTools pipe (``shared_browser``, what they do now), on the same report.html pages.

    python benchmarks/browser_pages.py                 # writes the pages of 3 quick scenes first
    python benchmarks/browser_pages.py OUT/*/report.html

Prints, for each way, the pages' wall time and the CPU of this process and of its children (Chromium)
[s], and exits 1 if the two ways' probe results differ on some page (0 when equal; 0 without Chromium,
after saying so: `make bench` runs it).
"""

from __future__ import annotations

import json
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import page_check  # noqa: E402

#: Quick scenes whose pages are probed when none are given (a few seconds each).
SCENES = ("spur_geometry", "problem_9_4_1", "tca_spur_crowned")


def one_start_per_page(path: Path, width: int = 1280, height: int = 900) -> dict:
    """The probe as the tests ran it before: a Chromium of its own for the page, ``--dump-dom``."""
    text = Path(path).read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory() as d:
        probe = Path(d) / Path(path).name
        probe.write_text(text.replace("</body>", page_check._PROBE + "\n</body>"), encoding="utf-8")
        r = page_check._chromium([f"--window-size={width},{height}", "--virtual-time-budget=10000", "--dump-dom",
                                  probe.as_uri()])
    m = re.search(r'<pre id="gearopt-probe">(.*?)</pre>', r.stdout, re.S)
    assert m, f"the probe did not run (chromium exit {r.returncode}): {r.stderr[-800:]}"
    return json.loads(m.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))


def cpu() -> float:
    """User + system CPU [s] of this process and of its waited-for children."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def main(argv: list[str]) -> int:
    if page_check.browser() is None:
        print("Chromium is not installed (make chromium): nothing measured")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        pages = [Path(a) for a in argv]
        if not pages:
            for name in SCENES:
                out = Path(tmp) / name
                subprocess.run([sys.executable, "-m", "gearopt", "run", str(ROOT / "problems" / f"{name}.toml"),
                                "--out", str(out), "--quiet"], check=True)
                pages.append(out / "report.html")
        found = {}
        for label, check in (("one Chromium per page", one_start_per_page),
                             ("one shared Chromium", page_check.browser_check)):
            t, c = time.perf_counter(), cpu()
            found[label] = [check(p) for p in pages]
            if check is page_check.browser_check:
                page_check.shared_browser().close()  # its CPU is counted once it has exited
            print(f"{label:24s} {len(pages)} pages: {time.perf_counter() - t:6.1f} s wall, {cpu() - c:5.1f} s CPU")
        a, b = found.values()
        print("the same probe results on every page" if a == b else "the probe results differ")
        return 0 if a == b else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
