"""The speed figures quoted in README.md and docs/*.md are the generated ones (issue 43: every figure
regenerates from one benchmark command, ``python benchmarks/figures.py``, which writes docs/figures.md and
rewrites the docs' marked blocks ``<!-- figure: KEY -->VALUE<!-- /figure -->``). A block edited by hand, or
naming a figure the generated file does not have, fails here. Nothing is timed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures.md"
DOCS = [ROOT / "README.md", ROOT / "problems" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"<!-- figure: ([^ ]+?)( range| met)? -->(.*?)<!-- /figure -->")
ROW = re.compile(r"^\| `([^`]+)` \| ([^|]+?) \| [^|]*? \| ([^|]+?) - ([^|]+?) \| (\d+) \| ([^|]*?) \|", re.M)


def table() -> dict[str, tuple[str, str, str, str]]:
    """docs/figures.md: ``{key: (value, min, max, target column)}`` as written."""
    return {m.group(1): m.group(2, 3, 4, 6) for m in ROW.finditer(FIGURES.read_text())}


def blocks() -> list[tuple[str, str, str, str]]:
    """Every marked block: (file, key, form: '', ' range' or ' met', content)."""
    return [(str(p.relative_to(ROOT)), m.group(1), m.group(2) or "", m.group(3)) for p in DOCS
            for m in BLOCK.finditer(p.read_text())]


def test_generated_file_has_figures_with_their_spread():
    t = table()
    assert len(t) >= 10, "docs/figures.md lists the figures of README/docs (python benchmarks/figures.py)"
    text = FIGURES.read_text()
    assert "Machine: " in text and "load average" in text
    for key, (v, lo, hi, target) in t.items():
        assert float(lo) <= float(v) <= float(hi), f"{key}: the median {v} outside its range {lo} - {hi}"
        if target:  # "<= 5: met": the verdict is the value's
            op, lim, verdict = re.fullmatch(r"(<=|>=) ([0-9.]+): (met|not met)", target).groups()
            ok = float(v) <= float(lim) if op == "<=" else float(v) >= float(lim)
            assert verdict == ("met" if ok else "not met"), f"{key}: {v} against {target}"


@pytest.mark.parametrize("doc", [str(p.relative_to(ROOT)) for p in DOCS])
def test_every_block_holds_the_generated_value(doc):
    t = table()
    for name, key, rng, content in blocks():
        if name != doc:
            continue
        assert key in t, f"{doc}: a block names {key!r}, which docs/figures.md does not have"
        v, lo, hi, target = t[key]
        want = {"": v, " range": f"{v} ({lo}-{hi})", " met": target.partition(": ")[2]}[rng]
        assert content == want, (f"{doc}: block {key!r} holds {content!r}, docs/figures.md gives {want!r} "
                                 "(edit neither by hand: python benchmarks/figures.py)")


def test_the_docs_quote_the_issue_43_figures():
    quoted = {key for _, key, _, _ in blocks()}
    for key in ("tca.sweep_64x3_us", "tca.sweep_64x3_vs_fsolve", "ltca.crowned_s", "loaded.warm_s", "loaded.cold_s",
                "run.demo_s", "run.crowning_s"):
        assert key in quoted, f"no doc quotes {key} through a marked block"
