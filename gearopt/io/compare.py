"""``gearopt compare``: several designs of the same gear pair side by side.

Each design is a result directory of an earlier ``gearopt run`` (``results.json`` and the manifest
:data:`~gearopt.io.results.MANIFEST`) or a scene file, which is run first into a subdirectory of
the comparison. :func:`compare` checks that the designs can be compared, then writes into the
output directory (the rules of :mod:`gearopt.io.results`: a new or empty directory or a previous
gearopt output, everything written into a temporary sibling and moved into place at the end):

* ``key_numbers.csv``: one row per key number of the designs' ``summary`` (docs/results.md), one
  column per design, the difference of every further design to the first and the better design
  (by the row's ``better``); a number a design does not have is ``n/a``, never 0;
* ``compare_*.png``: the designs overlaid on the same axes and scales
  (:func:`gearopt.plot.compare.figures.save_figures`);
* ``comparison.json``: the designs (label, source, study, pair), the table and the figures with
  their captions;
* ``report.html``: the table first, then the figures with their captions;
* ``<label>/``: the run of each scene given.

Designs that cannot be compared are refused before anything runs or is written
(:func:`check_comparable`): a different ratio z2/z1, different tooth numbers or normal module (the
pinion angle and the flank maps would not correspond), a different driving flank; an argument that
is neither a result directory nor a scene; a ``results.json`` of another gearopt schema.
"""

from __future__ import annotations

import csv
import datetime as _dt
import json
import math
import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from ..errors import GeometryError, OptionError, ResultsError
from ..summary import KeyNumber, summary_from_results
from ..version import __version__
from .results import RESULTS_FILE, check_out_dir, install_output

if TYPE_CHECKING:  # pragma: no cover
    from collections.abc import Sequence

    from .scene import Scene

__all__ = ["Design", "KeyRow", "compare", "load_design", "read_results", "pair_identity", "check_comparable",
           "key_numbers", "design_numbers", "write_key_numbers_csv", "NA", "KEY_NUMBERS_FILE", "COMPARISON_FILE"]

NA = "n/a"  #: a key number a design does not have
KEY_NUMBERS_FILE = "key_numbers.csv"
COMPARISON_FILE = "comparison.json"
#: the pair quantities that must agree, in the order they are checked
_IDENTITY = ("ratio", "z", "m_n", "side")


@dataclass
class Design:
    """One design of a comparison.

    Attributes
    ----------
    label : str
        Its name in the figures and the table.
    source : Path
        The argument as given: a result directory or a scene file.
    results : dict
        Its ``results.json`` (empty until a scene has run).
    directory : Path or None
        The result directory (None for a scene not run yet).
    scene : Scene or None
        The loaded scene (scene arguments).
    identity : dict
        ``z1``, ``z2``, ``m_n`` [mm], ``side`` (driving flank of the pinion) and ``ratio`` (z2 / z1),
        each None where unknown (:func:`pair_identity`).
    samples : dict
        The columns of the design's samples table (Monte Carlo, sweep), else empty.
    """

    label: str
    source: Path
    results: dict = field(default_factory=dict)
    directory: Path | None = None
    scene: Scene | None = None
    identity: dict = field(default_factory=dict)
    samples: dict = field(default_factory=dict)

    @property
    def study(self) -> str | None:
        """The study of the results, else of the scene."""
        return self.results.get("study") or (self.scene.study if self.scene is not None else None)


@dataclass
class KeyRow:
    """One row of the key-numbers table: a quantity over the designs.

    Attributes
    ----------
    key, label, unit, group : str
        As in the designs' ``summary`` (those of the first design that has the quantity).
    better : str or None
        ``"lower"`` or ``"higher"`` when a smaller / larger value is better, else None.
    values : list
        One per design, in the order of the designs; None where the design does not have it (or has
        it without a value: ``present``).
    differences : list
        Per design: its value minus the first design's (numbers only; None where either is not a
        number, and for the first design).
    best : list[int]
        The indices of the designs with the better value (ties all), empty when ``better`` is None
        or fewer than two designs have a number.
    present : list[bool]
        Per design: it has the quantity (its value may still be None: no value, e.g. the harmonics
        of a TE without whole mesh cycles).
    """

    key: str
    label: str
    unit: str
    group: str
    better: str | None
    values: list
    differences: list
    best: list[int]
    present: list[bool] = field(default_factory=list)


def _num(v: Any) -> float | None:
    """``v`` as a finite float when it is a number (not a bool), else None."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _better(text: Any) -> str | None:
    t = str(text or "").strip().lower()
    if t in ("lower", "low", "min", "smaller", "less", "-"):
        return "lower"
    if t in ("higher", "high", "max", "larger", "more", "+"):
        return "higher"
    return None


def read_results(directory: str | Path) -> dict:
    """The ``results.json`` of a result directory, checked to be one this gearopt reads.

    Raises
    ------
    ResultsError
        The file cannot be read or is no JSON object, it lacks ``study``, ``units`` or
        ``meta.gearopt_version`` (not a gearopt results file), or it was written by a gearopt of
        another schema (another major version, or for 0.x another minor version) or for an unknown
        study.
    """
    d = Path(directory)
    f = d / RESULTS_FILE
    try:
        data = json.loads(f.read_text(encoding="utf-8"))
    except OSError as e:
        raise ResultsError(f"{f}: cannot read it: {e.strerror or e}.", param="DESIGN", value=str(d)) from None
    except ValueError as e:
        raise ResultsError(f"{f}: not a JSON file ({e}); expected the results.json of a gearopt run.",
                           param="DESIGN", value=str(d), valid="a gearopt result directory") from None
    meta = data.get("meta") if isinstance(data, dict) else None
    if not isinstance(data, dict) or not isinstance(data.get("study"), str) or not isinstance(data.get("units"), dict) \
            or not isinstance(meta, dict) or not isinstance(meta.get("gearopt_version"), str):
        raise ResultsError(f"{f}: not a gearopt results file (it needs the keys study, units and "
                           "meta.gearopt_version; docs/results.md).", param="DESIGN", value=str(d),
                           valid="a gearopt result directory")
    theirs, ours = _schema(meta["gearopt_version"]), _schema(__version__)
    if theirs != ours:
        raise ResultsError(f"{f}: written by gearopt {meta['gearopt_version']}, whose results.json schema is not this "
                           f"gearopt's ({__version__}: it reads results of gearopt {'.'.join(ours)}.x). Run the scene "
                           "again with this gearopt (or give the scene instead of the directory).",
                           param="DESIGN", value=str(d), valid=f"results of gearopt {'.'.join(ours)}.x")
    from ..studies import studies

    if data["study"] not in studies():
        raise ResultsError(f"{f}: study {data['study']!r} is not a study of this gearopt (valid: "
                           f"{', '.join(sorted(studies()))}).", param="DESIGN", value=str(d),
                           valid=", ".join(sorted(studies())))
    return data


def _schema(version: str) -> tuple[str, ...]:
    """The part of a version that fixes the results schema: major, and minor for 0.x."""
    parts = (version.split("+")[0].split(".") + ["0", "0"])[:2]
    return tuple(parts) if parts[0] == "0" else (parts[0],)


def _scene_side(scene: Scene) -> str | None:
    for sec in (scene.options or {}).values():
        if isinstance(sec, dict) and isinstance(sec.get("side"), str):
            return sec["side"]
    return None


def pair_identity(results: dict | None = None, scene: Scene | None = None) -> dict:
    """What fixes the gear pair of a design: ``z1``, ``z2``, ``m_n`` [mm], ``side`` (the driving
    flank of the pinion) and ``ratio`` (z2 / z1); None where unknown.

    Read from the results (``pair`` of the tca, ltca and fea studies; ``members`` of the geometry
    study; ``options.side``; the geometry rows of ``summary``), else from the scene (its pair and
    the study section's ``side``).
    """
    ident: dict[str, Any] = {"z1": None, "z2": None, "m_n": None, "side": None, "ratio": None}
    r = results or {}
    pair = r.get("pair") if isinstance(r.get("pair"), dict) else {}
    members = r.get("members") if isinstance(r.get("members"), dict) else {}
    opts = r.get("options") if isinstance(r.get("options"), dict) else {}
    summ = {n.key: n.value for n in _summary(r)}
    ident["z1"] = pair.get("z1", (members.get("pinion") or {}).get("z", summ.get("z1")))
    ident["z2"] = pair.get("z2", (members.get("gear") or {}).get("z", summ.get("z2")))
    ident["m_n"] = pair.get("m_n", (members.get("pinion") or {}).get("m_n", summ.get("m_n_mm")))
    side = pair.get("side", opts.get("side", summ.get("side")))
    ident["side"] = side if isinstance(side, str) else None
    if scene is not None:
        p, g = scene.pair.pinion, scene.pair.gear
        for k, v in (("z1", p.z), ("z2", g.z), ("m_n", p.m_n), ("side", _scene_side(scene))):
            if ident[k] is None:
                ident[k] = v
    if ident["z1"] and ident["z2"]:
        ident["ratio"] = ident["z2"] / ident["z1"]
    elif _num(pair.get("ratio")) is not None:
        ident["ratio"] = float(pair["ratio"])
    elif isinstance(r.get("input"), dict) and _num(r["input"].get("r_b1")):  # planar TCA: base radii
        ident["ratio"] = float(r["input"]["r_b2"]) / float(r["input"]["r_b1"])
    return ident


def _why_not(a: dict, b: dict) -> str | None:
    """Why two pair identities cannot be compared, or None."""
    ra, rb = a.get("ratio"), b.get("ratio")
    if ra is not None and rb is not None and abs(ra - rb) > 1e-9 * max(abs(ra), 1.0):
        za = f"{a['z2']}/{a['z1']} = " if a.get("z1") else ""
        zb = f"{b['z2']}/{b['z1']} = " if b.get("z1") else ""
        return (f"different ratios z2/z1 ({za}{ra:.6g} and {zb}{rb:.6g}): their pinion angles and mesh cycles do not "
                "correspond")
    if None not in (a.get("z1"), b.get("z1"), a.get("z2"), b.get("z2")) and (a["z1"], a["z2"]) != (b["z1"], b["z2"]):
        return (f"different tooth numbers ({a['z1']}/{a['z2']} and {b['z1']}/{b['z2']}): the mesh cycles "
                f"(360/z1 = {360 / a['z1']:.4g} and {360 / b['z1']:.4g} deg) differ, the TE against the pinion angle "
                "cannot be overlaid")
    if a.get("m_n") is not None and b.get("m_n") is not None and abs(a["m_n"] - b["m_n"]) > 1e-9:
        return (f"different normal modules ({a['m_n']:.6g} mm and {b['m_n']:.6g} mm): the flanks are of another size, "
                "their flank maps and pressures do not correspond")
    if a.get("side") and b.get("side") and a["side"] != b["side"]:
        return (f"different driving flanks of the pinion ({a['side']} and {b['side']}): the contact lies on other "
                "flanks, in another sense of rotation")
    return None


def check_comparable(designs: Sequence[Design]) -> None:
    """Refuse designs that cannot be compared, naming the two designs and why.

    Every design is checked against the first design that states each pair quantity.

    Raises
    ------
    GeometryError
        Different ratio z2/z1, tooth numbers, normal module or driving flank (:func:`pair_identity`).
    """
    for i, b in enumerate(designs):
        for a in designs[:i]:
            why = _why_not(a.identity, b.identity)
            if why:
                raise GeometryError(f"gearopt compare: designs {a.label!r} ({a.source}) and {b.label!r} ({b.source}) "
                                    f"are not comparable: {why}. Compare designs of the same gear pair.",
                                    param="DESIGN", value=[str(a.source), str(b.source)],
                                    valid="designs of the same pair: same z1, z2, m_n and driving flank")


def _samples(directory: Path, results: dict) -> dict:
    """The columns of a Monte Carlo / sweep design's samples table (empty cells NaN); {} without one."""
    name = results.get("samples_csv")
    f = directory / name if isinstance(name, str) else None
    if f is None or not f.is_file():
        return {}
    import numpy as np

    with f.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    cols: dict[str, Any] = {}
    for k in (rows[0].keys() if rows else []):
        vals = []
        for row in rows:
            try:
                vals.append(float(row[k]))
            except (TypeError, ValueError):
                vals.append(float("nan"))
        cols[k] = np.array(vals, float)
    return cols


def load_design(argument: str | Path, label: str | None = None) -> Design:
    """A design from a command-line argument: a result directory (read and checked,
    :func:`read_results`) or a scene file (loaded and validated, not run).

    Raises
    ------
    OptionError
        The argument does not exist, or is neither a directory with ``results.json`` nor a ``.toml``
        scene file.
    ResultsError
        Its ``results.json`` is not one this gearopt reads.
    SceneError
        The scene is malformed.
    """
    p = Path(argument)
    valid = "a result directory of gearopt run (with results.json) or a scene file (.toml)"
    if p.is_dir():
        if not (p / RESULTS_FILE).is_file():
            what = "an earlier comparison (compare its designs' directories inside it)" \
                if (p / COMPARISON_FILE).is_file() else "no gearopt result directory"
            raise OptionError(f"gearopt compare: {p}: a directory without {RESULTS_FILE}: {what}; expected {valid}.",
                              param="DESIGN", value=str(p), valid=valid)
        res = read_results(p)
        d = Design(label or str(res.get("scene") or p.name), p, res, p)
        d.identity = pair_identity(res, _scene_of(res))
        d.samples = _samples(p, res)
        return d
    if p.is_file() and p.suffix.lower() == ".toml":
        from .scene import load_scene

        scene = load_scene(p)
        d = Design(label or scene.name, p, {}, None, scene)
        d.identity = pair_identity(None, scene)
        return d
    if not p.exists():
        raise OptionError(f"gearopt compare: {p}: no such file or directory; expected {valid}.",
                          param="DESIGN", value=str(p), valid=valid)
    raise OptionError(f"gearopt compare: {p}: neither a result directory nor a scene file; expected {valid}.",
                      param="DESIGN", value=str(p), valid=valid)


def _scene_of(results: dict) -> Scene | None:
    """The scene a result names (``meta.scene``) when its pair is not in the results and the file
    still loads; None otherwise (the pair then stays partly unknown)."""
    ident = pair_identity(results)
    if all(ident[k] is not None for k in ("z1", "z2", "m_n", "side")):
        return None
    src = (results.get("meta") or {}).get("scene")
    if not isinstance(src, str) or not Path(src).is_file():
        return None
    from ..errors import GearoptError
    from .scene import load_scene

    try:
        return load_scene(src)
    except GearoptError:
        return None


def _summary(results: dict) -> list[KeyNumber]:
    """The key numbers of a results dict (its ``summary``, else computed), [] when it has none."""
    if not results:
        return []
    try:
        return summary_from_results(results)
    except (KeyError, TypeError, ValueError, IndexError):  # a results.json without the arrays summarize() reads
        return []


def _case_names(results: dict) -> dict[str, str]:
    """Per case label of a design (``[[tca.cases]]`` names, ``misaligned``...), the name of its
    misalignment (:func:`gearopt.plot.compare.common.case_name`), so that the cases of two designs with the
    same misalignment share their key numbers whatever their labels."""
    from ..plot.compare.common import case_name
    from ..plot.compare.unloaded import te_cases

    out = {}
    for c in te_cases(results):
        lab = c.get("label")
        if isinstance(lab, str) and "misalignment" in c:
            out[lab] = case_name(c["misalignment"])
    if results.get("study") == "ltca" and isinstance(results.get("misalignment"), dict):
        out["unloaded"] = case_name(results["misalignment"])  # te_pp_arcsec[unloaded]: the unloaded TE of its case
    return out


def design_numbers(design: Design) -> list[KeyNumber]:
    """A design's key numbers, the cases named by their misalignment (``te_pp_arcsec[misaligned]``
    of a tca run with a 3' crossing becomes ``te_pp_arcsec[crossing +3 arcmin]``); of an optimisation
    (crowning, loaded_microgeometry) the optimum's numbers only (its ``before.*`` keys, the start
    design, are left out)."""
    names = _case_names(design.results)
    out = []
    for n in _summary(design.results):
        if n.key.startswith("before."):  # the start design of an optimisation: the optimum is compared
            continue
        m = re.fullmatch(r"(.*)\[(.*)\]", n.key)
        if m and m.group(2) in names and names[m.group(2)] != m.group(2):
            case, new = m.group(2), names[m.group(2)]
            label = n.label[: -len(case)] + new if n.label.endswith(case) else f"{n.label} ({new})"
            n = KeyNumber(f"{m.group(1)}[{new}]", label, n.value, n.unit, n.better, n.group)
        out.append(n)
    return out


def key_numbers(designs: Sequence[Design]) -> list[KeyRow]:
    """The key-numbers table of the designs: every quantity of their summaries (:func:`design_numbers`;
    grouped as :data:`gearopt.summary.GROUPS`; within a group the quantities every design has first,
    each part in the order of first appearance), one value per design (None: the design does not
    have it).

    The difference is each design's value minus the first design's; ``best`` marks the design(s)
    with the lower or higher value as the row's ``better`` says, among at least two numbers that
    are not all equal to 4 significant digits (relative :data:`SAME_RELATIVE`: a K_Halpha of 1.00004
    against 1.00006 marks neither).
    """
    from ..summary import GROUPS

    per = [{n.key: n for n in design_numbers(d)} for d in designs]
    order: dict[str, KeyNumber] = {}
    for numbers in per:
        for key, n in numbers.items():
            order.setdefault(key, n)
    # by group; within a group the quantities every design has first (the comparison proper)
    shared = {k for k in order if all(k in numbers for numbers in per)}
    heads = sorted(order.values(), key=lambda n: (GROUPS.index(n.group) if n.group in GROUPS else len(GROUPS),
                                                  n.key not in shared))
    rows = []
    for head in heads:
        values = [numbers[head.key].value if head.key in numbers else None for numbers in per]
        first = _num(values[0])
        diffs = [None] + [None if first is None or _num(v) is None else _num(v) - first for v in values[1:]]
        better = _better(head.better)
        nums = [(i, _num(v)) for i, v in enumerate(values) if _num(v) is not None]
        best = []
        if better and len(nums) >= 2:
            target = (min if better == "lower" else max)(v for _, v in nums)
            best = [i for i, v in nums if _same(v, target)]
            if len(best) == len(nums):  # all equal as the table shows them: none is better
                best = []
        rows.append(KeyRow(head.key, head.label, head.unit, head.group, better, values, diffs, best,
                           [head.key in numbers for numbers in per]))
    return rows


#: relative difference below which two key numbers are the same: half a unit of the 4th significant digit
#: the page shows (a better value that the table cannot show is none)
SAME_RELATIVE = 5e-5


def _same(a: float, b: float) -> bool:
    """``a`` and ``b`` agree to the page's 4 significant digits (:data:`SAME_RELATIVE`)."""
    return abs(a - b) <= SAME_RELATIVE * max(abs(a), abs(b))


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    if isinstance(v, (list, tuple)):
        return " ".join(_cell(x) for x in v)
    return str(v)


def write_key_numbers_csv(rows: Sequence[KeyRow], labels: Sequence[str], path: str | Path) -> Path:
    """Write the key-numbers table as CSV: ``group, key, quantity, unit, better``, one column per
    design (its value; ``n/a`` where the design does not have the quantity, an empty cell where it
    has it without a value), then ``<label> - <first label>`` per further design (empty where either
    is not a number) and ``best`` (the labels of the better designs, ``;``-separated). Numbers at
    full precision."""
    path = Path(path)
    head = ["group", "key", "quantity", "unit", "better", *labels,
            *[f"{lab} - {labels[0]}" for lab in labels[1:]], "best"]
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        for r in rows:
            vals = [_cell(v) if ok else NA for v, ok in zip(r.values, r.present or [True] * len(r.values))]
            w.writerow([r.group, r.key, r.label, r.unit, r.better or "", *vals,
                        *["" if v is None else _cell(v) for v in r.differences[1:]], ";".join(labels[i] for i in r.best)])
    return path


def _unique_labels(designs: Sequence[Design], labels: Sequence[str] | None) -> None:
    if labels is not None:
        if len(labels) != len(designs) or any(not str(lab).strip() for lab in labels):
            raise OptionError(f"--labels {','.join(labels)}: {len(labels)} labels for {len(designs)} designs; give one "
                              "non-empty label per design, comma-separated, in the order of the designs.",
                              param="--labels", value=",".join(labels), valid=f"{len(designs)} non-empty labels")
        if len(set(labels)) != len(labels):
            raise OptionError(f"--labels {','.join(labels)}: a label is given twice; every design needs its own.",
                              param="--labels", value=",".join(labels), valid="distinct labels")
        for d, lab in zip(designs, labels):
            d.label = str(lab).strip()
        return
    # default labels (scene names) given twice: the directory or file name added, else the position
    base = [d.label for d in designs]
    for d, b in zip(designs, base):
        if base.count(b) > 1 and d.source.name != b:
            d.label = f"{b} ({d.source.name})"
    now = [d.label for d in designs]
    for i, (d, b) in enumerate(zip(designs, base)):
        if now.count(d.label) > 1:
            d.label = f"{b} (#{i + 1})"


def _slug(label: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", label).strip("._") or "design"


def _check_places(out: Path, designs: Sequence[Design]) -> None:
    """The output directory must not be, hold or lie inside a design's directory or scene."""
    full = Path(os.path.abspath(out))
    for d in designs:
        src = Path(os.path.abspath(d.source))
        if full == src or full in src.parents or src in full.parents:
            raise ResultsError(f"--out {out}: {'is' if full == src else 'holds' if full in src.parents else 'lies inside'}"
                               f" the design {d.source}; the comparison would replace or mix with it. Choose another "
                               "--out (e.g. out/compare).", param="--out", value=str(out),
                               valid="a directory apart from the designs")


def compare(arguments: Sequence[str | Path], out: str | Path, labels: Sequence[str] | None = None,
            run_scene: Callable[[Path, Path], None] | None = None,
            progress: Callable[[str], None] | None = None, dpi: int = 120) -> list[Path]:
    """Compare designs and write the comparison into ``out`` (module docstring).

    Parameters
    ----------
    arguments : sequence of paths
        At least two: result directories of ``gearopt run`` or scene files (run first).
    out : path
        The output directory (the rules of :func:`gearopt.io.results.check_out_dir`).
    labels : sequence of str, optional
        One label per design (default: the scene names, made unique).
    run_scene : callable(scene file, directory), optional
        Runs a scene into a new directory (the CLI passes ``gearopt run``); default: build and run
        the study here and :func:`~gearopt.io.results.write_results`.
    progress : callable(str), optional
        Receives progress lines.
    dpi : int
        Resolution of the figures.

    Returns
    -------
    list[Path]
        The files written at their final place: the table, the figures, ``comparison.json``, the
        page (the scene runs' files are in their subdirectories, not listed).

    Raises
    ------
    OptionError
        Fewer than two designs, an argument that is neither a result directory nor a scene, wrong
        ``labels``.
    ResultsError
        A results.json of another schema; an output directory that cannot hold the comparison.
    GeometryError
        Designs that cannot be compared (:func:`check_comparable`).
    SceneError
        A malformed scene. Nothing is written on any refusal.
    """
    say = progress or (lambda _msg: None)
    if len(arguments) < 2:
        raise OptionError(f"gearopt compare: {len(arguments)} design(s) given; give at least two result directories or "
                          "scene files.", param="DESIGN", value=[str(a) for a in arguments], valid="two or more designs")
    out = check_out_dir(out)
    designs = [load_design(a) for a in arguments]
    _unique_labels(designs, labels)
    _check_places(out, designs)
    check_comparable(designs)
    parent = Path(os.path.abspath(out)).parent
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=parent)).resolve()
    try:
        used: set[str] = set()
        for d in designs:
            if d.scene is None:
                continue
            sub = _slug(d.label)
            while sub in used:
                sub += "_"
            used.add(sub)
            say(f"running {d.source} ({d.label}) into {out / sub}")
            (run_scene or _run_here)(d.source, tmp / sub)
            d.directory = tmp / sub
            d.results = read_results(d.directory)
            d.identity = pair_identity(d.results, d.scene)
            d.samples = _samples(d.directory, d.results)
        check_comparable(designs)
        for d in designs:
            for note in _unchecked(d):
                say(f"{d.label}: {note}")
        say(f"comparing {', '.join(d.label for d in designs)}")
        written = _write(designs, tmp, out, dpi)
        os.chmod(tmp, 0o777 & ~_umask())
        install_output(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [out / w for w in written]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _run_here(scene_file: Path, directory: Path) -> None:
    """Run a scene's study in this process and write its results into ``directory``."""
    import time

    from .results import write_results
    from .scene import load_scene

    scene = load_scene(scene_file)
    study = scene.build()
    t0 = time.perf_counter()
    result = study.run()
    write_results(directory, result, scene=scene, run_time=time.perf_counter() - t0)


def comparison_dict(designs: Sequence[Design], rows: Sequence[KeyRow], figures: Sequence[tuple[str, str]],
                    out: Path, warnings: Sequence[dict[str, str]] = ()) -> dict:
    """The content of ``comparison.json`` (and of the page): designs, key numbers, figures.

    ``key_numbers[].values`` holds a label only when that design has the quantity (an absent label:
    the design does not have it, never 0); ``differences`` each further design's value minus the
    first design's where both are numbers; ``meta.warnings`` the warnings raised while the figures
    were drawn (``warnings``: ``{"category", "message", "source"}`` each, as results.json's)."""
    labels = [d.label for d in designs]
    full = Path(os.path.abspath(out))

    def place(d: Design) -> str:
        """The design's result directory relative to the comparison (links of the page)."""
        if d.scene is not None and d.directory is not None:
            return d.directory.name
        return os.path.relpath(os.path.abspath(d.source), full)

    return {
        "kind": "comparison",
        "designs": [{"label": d.label, "source": str(d.source), "study": d.study,
                     "scene": d.results.get("scene"), "pair": d.identity, "directory": place(d),
                     "ran_here": d.scene is not None,
                     "has_report": d.directory is not None and (d.directory / "report.html").is_file(),
                     "gearopt_version": (d.results.get("meta") or {}).get("gearopt_version"),
                     "timestamp": (d.results.get("meta") or {}).get("timestamp"),
                     "warnings": _warnings(d.results) + _unchecked(d)} for d in designs],
        "key_numbers": [{"key": r.key, "label": r.label, "unit": r.unit, "group": r.group, "better": r.better,
                         "values": {lab: v for lab, v, ok in zip(labels, r.values, r.present) if ok},
                         "differences": {lab: v for lab, v in zip(labels[1:], r.differences[1:]) if v is not None},
                         "best": [labels[i] for i in r.best]} for r in rows],
        "figures": [{"file": f, "caption": c} for f, c in figures],
        "meta": {"gearopt_version": __version__,
                 "timestamp": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                 "warnings": [dict(w) for w in warnings]},
    }


def _unchecked(d: Design) -> list[str]:
    """A note when the design's pair could not be checked (neither its results nor a scene state it)."""
    missing = [k for k in ("z1", "z2", "m_n") if d.identity.get(k) is None]
    if not missing:
        return []
    return [f"its {', '.join(missing)} are not in its results and its scene ({d.results.get('meta', {}).get('scene')}) "
            "was not found: whether it is the same pair as the others was not checked."]


def _warnings(results: dict) -> list[str]:
    """A design's warnings: those its run recorded (``meta.warnings``) and the result's own (``warnings``)."""
    out = []
    for w in (results.get("meta") or {}).get("warnings") or []:
        out.append(f"{w.get('category', 'Warning')}: {w.get('message', '')}" if isinstance(w, dict) else str(w))
    out += [str(w) for w in results.get("warnings") or [] if all(str(w) not in o for o in out)]
    return out


def _write(designs: Sequence[Design], tmp: Path, out: Path, dpi: int) -> list[str]:
    from ..plot.compare.figures import save_figures
    from ..plot.style import plot_style
    from ..warning_log import WarningLog
    from .page import SVGCapture

    labels = [d.label for d in designs]
    rows = key_numbers(designs)
    write_key_numbers_csv(rows, labels, tmp / KEY_NUMBERS_FILE)
    drawing = WarningLog()  # a figure that leaves a design or a case out says so by a warning
    with drawing, plot_style(), SVGCapture() as capture:  # light figures also as SVG for the page
        figures = save_figures({d.label: d.results for d in designs}, tmp,
                               samples={d.label: d.samples for d in designs if d.samples}, dpi=dpi)
    data = comparison_dict(designs, rows, figures, out, drawing.records)
    (tmp / COMPARISON_FILE).write_text(json.dumps(data, indent=1, ensure_ascii=False, default=_jsonable) + "\n",
                                       encoding="utf-8")
    written = [KEY_NUMBERS_FILE, *[f for f, _ in figures], COMPARISON_FILE]
    written.append(write_page(data, tmp, capture.svgs))
    return written


def _jsonable(obj: Any) -> Any:
    if hasattr(obj, "tolist"):
        return obj.tolist()
    return str(obj)


def write_page(data: dict, directory: Path, svgs: dict[str, bytes] | None = None) -> str:
    """Write ``report.html`` of a comparison (``data``: :func:`comparison_dict`) into ``directory``
    (:func:`gearopt.io.page.render_page`): the key-numbers table first (one column per design, the
    better value marked, ``n/a`` where a design does not have the quantity, the differences to the
    first design), the designs, their warnings, then every figure inline with its caption; links to
    the table, comparison.json and each design's own page. A figure goes in as SVG when ``svgs``
    (:class:`gearopt.io.page.SVGCapture`) holds a light enough rendering of it, else as PNG.
    Returns the file name."""
    from ..summary import format_value
    from .page import REPORT_FILE, Cell, Table, figure_from_file, render_page

    designs = data["designs"]
    labels = [d["label"] for d in designs]
    first = labels[0]
    rows: list[Any] = []
    group = None
    for r in data["key_numbers"]:
        if r["group"] != group:
            group = r["group"]
            rows.append(group)
        cells: list[Any] = [r["label"], r["unit"], Cell(r["better"] or "", "" if r["better"] else "absent")]
        for lab in labels:
            if lab not in r["values"]:
                cells.append(Cell(NA, "absent", title=f"{lab} does not have this quantity"))
            else:
                v = r["values"][lab]
                cells.append(Cell(format_value(v), "better" if lab in r["best"] else "", title=repr(v)))
        for lab in labels[1:]:
            dv = r["differences"].get(lab)
            cells.append(Cell("" if dv is None else ("0" if abs(dv) < 1e-9 else f"{dv:+.4g}"), title=repr(dv)))
        rows.append(cells)
    ncol = 3 + len(labels)
    table = Table("Key numbers", ["quantity", "unit", "better", *labels, *[f"{lab} \u2212 {first}" for lab in labels[1:]]],
                  rows, note=f"4 significant digits (full values in {KEY_NUMBERS_FILE}); bold green: the better design "
                             f"of a row; {NA}: the design does not have the quantity; differences to {first}.",
                  numeric=tuple(range(3, ncol + len(labels) - 1)))

    def pair_text(p: dict) -> str:
        z = f"{p['z1']}/{p['z2']}" if p.get("z1") else "\u2014"
        m = "\u2014" if p.get("m_n") is None else f"{format_value(float(p['m_n']))} mm"
        return f"z {z}, m_n {m}, driving flank {p.get('side') or chr(0x2014)}"

    design_rows = [[d["label"], d["study"] or "", d["scene"] or "", pair_text(d["pair"]),
                    f"{d['source']} (run here into {d['directory']}/)" if d["ran_here"] else d["source"],
                    str(d["gearopt_version"] or ""), str(d["timestamp"] or "").replace("T", " ").replace("+00:00", "")]
                   for d in designs]
    tables = [table, Table("Designs", ["label", "study", "scene", "pair", "source", "gearopt", "date (UTC)"],
                           design_rows)]
    warnings = [f"{d['label']}: {w}" for d in designs for w in d["warnings"]]
    warnings += [f"comparison figures: {w['category']}: {w['message']} ({w['source']})"
                 for w in data["meta"].get("warnings") or []]
    figures = [figure_from_file(Path(directory) / f["file"], f["caption"], (svgs or {}).get(f["file"]))
               for f in data["figures"]]
    links = [(KEY_NUMBERS_FILE, f"{KEY_NUMBERS_FILE}: the key numbers at full precision"),
             (COMPARISON_FILE, f"{COMPARISON_FILE}: designs, key numbers, figures")]
    for d in designs:  # the runs made here (inside this directory; a design elsewhere is named in "Designs")
        if d["ran_here"] and d["has_report"]:
            links.append((f"{d['directory']}/{REPORT_FILE}", f"{d['label']}: its own report"))
        if d["ran_here"]:
            links.append((f"{d['directory']}/{RESULTS_FILE}", f"{d['label']}: results.json"))
    studies = sorted({d["study"] or "" for d in designs})
    header = {"designs": ", ".join(labels), "studies": ", ".join(studies),
              "date (UTC)": data["meta"]["timestamp"].replace("T", " ").replace("+00:00", ""),
              "gearopt": data["meta"]["gearopt_version"]}
    intro = ("The same gear pair in several designs, overlaid on the same axes and scales: one colour per design "
             f"({first} first, drawn thicker), one line style per misalignment case.")
    if any(f["file"].startswith("compare_rating") for f in data["figures"]):
        intro += (" In the ISO 6336 rating figures the line style is the member (solid pinion, dashed gear) or the "
                  "method of the load factor (solid gearopt's loaded TCA, dashed ISO 6336-1).")
    if not data["figures"]:
        intro += " The designs have no plotted quantity in common (only the key numbers are compared)."
    text = render_page(f"Comparison: {' vs '.join(labels)}", header, tables, warnings, figures, links, intro=intro)
    (Path(directory) / REPORT_FILE).write_text(text, encoding="utf-8")
    return REPORT_FILE
