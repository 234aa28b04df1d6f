"""The documented schema of results.json (docs/results.md), read from the tables of that page, and
the check that a results dictionary uses only documented keys. Independent of gearopt's code: it
reads the Markdown page and walks plain dictionaries (see the "How the tables are read" paragraph of
docs/results.md for the grammar)."""

from __future__ import annotations

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "results.md"

#: What a placeholder of docs/results.md stands for (one dictionary key).
_FEATURE = r"surface|(?:pinion|gear)_(?:tip|limit|face[+-]|corner[+-])|pinion_tip/gear_face[+-]|pinion_face[+-]/gear_tip|pinion_tip/gear_tip"
PLACEHOLDERS = {
    "<member>": r"pinion|gear",
    "<side>": r"right|left",
    "<member>_modifications": r"(?:pinion|gear)_modifications",
    "<feature>": _FEATURE,
    "<k>": r"-?\d+",
    "<variable>": r"a_c|a_pl|mis\.\w+",  # a crowning setting or a misalignment kind
    "<kind>_mm": r"\w+_mm",  # a misalignment kind of unit length
    "<kind>_arcmin": r"\w+_arcmin",  # a misalignment kind of unit angle
    "<case>": r".+",
    "<quantity>": r".+",
    "<input>": r"(?:mis|pinion|gear)\.[\w.]+|torque",  # a sampled input or design variable
    "<stat>": r"n|mean|sd|min|max|p\d+",
}
#: Sections of the crowning study that hold tca cases: checked against the tca study's ``cases[]``.
ALIASES = {("crowning", "before[]"): ("tca", "cases[]"), ("crowning", "after[]"): ("tca", "cases[]"),
           # each case of the loaded micro-geometry study is an ltca result (its top-level keys)
           ("loaded_microgeometry", "before[]"): ("ltca", None), ("loaded_microgeometry", "after[]"): ("ltca", None)}


def _split(token: str) -> list[str]:
    """``cases[].misalignment.dE_mm`` -> ``["cases[]", "misalignment", "dE_mm"]``."""
    return [p for p in token.split(".") if p]


def documented(doc: Path = DOC) -> dict[str, list[tuple[str, ...]]]:
    """Documented key paths per section: ``{"every": [...], "tca": [...], ...}``; each path a tuple of
    names (``"cases[]"``: an entry of the list ``cases``; placeholders kept as written)."""
    out: dict[str, list[tuple[str, ...]]] = {}
    scope = None
    for line in doc.read_text(encoding="utf-8").splitlines():
        h = re.match(r"^## (\w+)", line)
        if h:
            scope = h.group(1)
            out.setdefault(scope, [])
            continue
        if scope is None or not line.startswith("| `"):
            continue
        cell = line.split("|")[1]
        tokens = re.findall(r"`([^`]+)`", cell)
        first = _split(tokens[0])
        out[scope].append(tuple(first))
        for t in tokens[1:]:
            rel = _split(t)
            out[scope].append(tuple(first[:len(first) - len(rel)] + rel))
    return out


def _name_ok(pattern: str, name: str) -> bool:
    if pattern.endswith("[]") != name.endswith("[]"):
        return False
    p, n = pattern.removesuffix("[]"), name.removesuffix("[]")
    if p in PLACEHOLDERS:
        return re.fullmatch(PLACEHOLDERS[p], n) is not None
    return p == n


def _matches(pattern: tuple, path: tuple, prefix: bool = False) -> bool:
    if len(pattern) < len(path) or (len(pattern) > len(path) and not prefix):  # prefix: path is an ancestor
        return False
    return all(_name_ok(p, n) for p, n in zip(pattern, path))


def leaf_paths(d, path=()):
    """Every leaf of a results dictionary as ``(path, value)``: values that are not dictionaries and
    not lists of dictionaries (lists of dictionaries add ``[]`` to their name, their entries are
    walked)."""
    if isinstance(d, dict):
        if not d and path:
            yield path, d
        for k, v in d.items():
            if isinstance(v, list) and any(isinstance(x, dict) for x in v):
                for x in v:
                    yield from leaf_paths(x, path + (f"{k}[]",))
            elif isinstance(v, dict):
                yield from leaf_paths(v, path + (str(k),))
            else:
                yield path + (str(k),), v
    elif path:
        yield path, d


def undocumented(results: dict, study: str, doc: Path = DOC) -> list[str]:
    """Key paths of ``results`` (a study's results.json) that no row of docs/results.md documents
    (rows of ``## every study`` and of the study's own section)."""
    docs = documented(doc)
    bad = []
    for path, value in leaf_paths(results):
        scope, p = study, path
        for (st, head), (st2, head2) in ALIASES.items():
            if st == study and path and path[0] == head:
                scope, p = st2, ((head2,) if head2 else ()) + path[1:]
        rows = docs.get("every", []) + docs.get(scope, [])
        empty = isinstance(value, (dict, list)) and not value  # an empty container: documented by its contents
        # an empty list may be a list of entries (no transfers: ``transfers[]``) or of numbers
        alt = p[:-1] + (p[-1] + "[]",) if isinstance(value, list) and not value else p
        if not any(_matches(r, p) or (empty and (_matches(r, p, prefix=True) or _matches(r, alt, prefix=True)))
                   for r in rows):
            bad.append(".".join(path))
    return sorted(set(bad))
