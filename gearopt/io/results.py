"""Writing a study's results: ``results.json`` and plots, all or nothing.

A study's ``run()`` returns a result object with

* ``to_dict() -> dict``: JSON-able data (NumPy scalars/arrays are accepted and converted), with a
  ``"units"`` mapping (quantity -> unit string) so that every number can be read without the source;
* ``save_plots(directory) -> list[str]``: writes its figures into ``directory`` and returns their
  paths (absolute, or relative to ``directory``). If it accepts a ``dpi`` keyword, the scene's
  ``[output] dpi`` is passed.
* optionally ``save_tables(directory) -> list[str]``: writes data tables (CSV) beside
  ``results.json``, whether or not plots are written; same path rules.

:func:`write_results` writes into a temporary sibling of the output directory and moves the files
into place at the end: a previous output is replaced only when everything succeeded, and a failure
leaves no half-written directory behind.

**gearopt never removes a file it did not write.** Every output directory holds a manifest,
:data:`MANIFEST` (``.gearopt-output.json``), listing the files gearopt wrote there. An existing
``--out`` directory is used only when it is empty or a previous gearopt output (it has the
manifest); a directory holding anything else is refused (:func:`check_out_dir`, before the study
runs). Replacing a previous output removes only the files its manifest lists; any other file found
in it (a note added since) is kept where it is, and a new result file that would overwrite such a
file is refused. Other commands that write a results directory call :func:`check_out_dir` before
their work and :func:`write_results` (or :func:`install_output`) at the end.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import inspect
import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from ..errors import ArgumentError, ResultsError, shorten
from ..progress import heartbeat
from ..summary import summarize, summary_dicts, with_pair
from .page import REPORT_FILE, SVGCapture, page_template, report_page
from ..version import __version__
from ..warning_log import WarningLog

if TYPE_CHECKING:  # pragma: no cover
    from .scene import Scene

__all__ = ["write_results", "check_out_dir", "install_output", "output_files", "RESULTS_FILE", "MANIFEST"]

RESULTS_FILE = "results.json"
#: The manifest of an output directory: the files gearopt wrote there (JSON, ``{"files": [...]}``).
MANIFEST = ".gearopt-output.json"


def _jsonable(obj):
    """``json.dumps`` fallback for NumPy and path objects."""
    if hasattr(obj, "tolist"):  # numpy arrays and scalars
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"results: value of type {type(obj).__name__} is not JSON-serialisable: {obj!r}")


def _find_nonfinite(obj, path="") -> str | None:
    """Key path of the first NaN/inf in a nested structure (after NumPy conversion), or None."""
    if hasattr(obj, "tolist") and not isinstance(obj, (str, bytes)):
        obj = obj.tolist()
    if isinstance(obj, float):
        return None if math.isfinite(obj) else (path or "<root>")
    if isinstance(obj, dict):
        for k, v in obj.items():
            p = _find_nonfinite(v, f"{path}.{k}" if path else str(k))
            if p:
                return p
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            p = _find_nonfinite(v, f"{path}[{i}]")
            if p:
                return p
    return None


def output_files(out_dir: str | Path) -> list[str] | None:
    """The files a previous gearopt run wrote into ``out_dir``, from its :data:`MANIFEST`.

    Returns
    -------
    list[str] or None
        Paths relative to ``out_dir`` (``"results.json"``, ``"te.png"``...); ``[]`` for an empty
        directory; ``None`` when ``out_dir`` holds anything but is no gearopt output (no manifest,
        or one that cannot be read).
    """
    out = Path(out_dir)
    man = out / MANIFEST
    if not man.is_file():
        return [] if out.is_dir() and not any(out.iterdir()) else None
    try:
        data = json.loads(man.read_text(encoding="utf-8"))
        files = data["files"]
        if data.get("written_by") != "gearopt" or not isinstance(files, list):
            return None
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
    good = []
    for f in files:  # only plain relative paths inside the directory count as gearopt's
        if isinstance(f, str) and f and not Path(f).is_absolute() and ".." not in Path(f).parts and f != MANIFEST:
            good.append(f)
    return good


def _foreign(out: Path) -> list[str]:
    """Entries of ``out`` other than the manifest (directories with a trailing ``/``), sorted."""
    return sorted(p.name + ("/" if p.is_dir() and not p.is_symlink() else "") for p in out.iterdir()
                  if p.name != MANIFEST)


def _refuse_foreign(out: Path, found: list[str]) -> ResultsError:
    shown = ", ".join(found[:3]) + (f" and {len(found) - 3} more" if len(found) > 3 else "")
    old = ""
    try:  # results of a gearopt from before the manifest: say so, the user may delete them
        if RESULTS_FILE in found and "gearopt_version" in json.loads((out / RESULTS_FILE).read_text())["meta"]:
            old = (f" (its {RESULTS_FILE} is from an earlier gearopt that wrote no {MANIFEST}; if nothing else in it "
                   "is yours, delete the directory)")
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return ResultsError(f"--out {out}: the directory exists and holds files gearopt did not write ({shown}){old}; "
                        f"gearopt writes only into a new or empty directory or a previous gearopt output (one with "
                        f"{MANIFEST}), and never removes a file it did not write. Choose another --out (e.g. "
                        f"out/<scene name>) or empty this directory.",
                        param="--out", value=str(out),
                        valid="a new or empty directory, or a previous gearopt output")


def check_out_dir(out_dir: str | Path, scene_file: str | Path | None = None) -> Path:
    """Check, before anything runs, that ``out_dir`` can become the results directory.

    Refused (:class:`~gearopt.errors.ResultsError`), nothing written: the empty path; an existing file
    or symlink; the working directory, one of its parents or the root, or a directory holding the
    scene file; an existing directory that holds anything and is not a previous gearopt output (no
    :data:`MANIFEST`: the user's own files; see the module docstring); a place where the directory
    cannot be created.

    Parameters
    ----------
    out_dir : str or path
        The output directory (``--out``).
    scene_file : str or path, optional
        The scene file that is run (a directory holding it is refused).

    Returns
    -------
    Path
        ``out_dir`` as a Path.
    """
    if out_dir is not None and not isinstance(out_dir, (str, os.PathLike)):
        raise ArgumentError(f"out_dir = {type(out_dir).__name__} {shorten(repr(out_dir))}: expected a directory path "
                            "(str or pathlib.Path).",
                            param="out_dir", value=out_dir, valid="a directory path (str or pathlib.Path)")
    if out_dir is None or str(out_dir).strip() == "":
        raise ResultsError("--out / out_dir is empty; valid: a directory path such as out/my_scene (it is created; "
                           "a previous gearopt output there is replaced).",
                           param="--out", value=out_dir, valid="a directory path such as out/my_scene")
    out = Path(out_dir)
    full = Path(os.path.abspath(out))
    cwd = Path(os.getcwd())
    if full == Path(full.anchor) or full == cwd or full in cwd.parents:
        raise ResultsError(f"--out {out}: is the working directory, one of its parents or the root; give the results "
                           "a directory of their own (e.g. out/my_scene).",
                           param="--out", value=str(out))
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise ResultsError(f"--out {out}: exists and is not a directory; valid: a new directory or a previous "
                           "gearopt results directory.",
                           param="--out", value=str(out), valid="a new directory or a previous gearopt results directory")
    if scene_file is not None:
        scene_full = Path(os.path.abspath(scene_file))
        if full in scene_full.parents:
            raise ResultsError(f"--out {out}: contains the scene file {scene_file}; gearopt does not write beside "
                               "your own files. Give another output directory (e.g. out/<scene name>).",
                               param="--out", value=str(out))
    if out.is_dir():
        owned = output_files(out)
        found = (_foreign(out) or [MANIFEST]) if owned is None else []
        if found:
            raise _refuse_foreign(out, found)
    base = full.parent
    while not base.exists():
        base = base.parent
    if not base.is_dir() or not os.access(base, os.W_OK | os.X_OK):
        raise ResultsError(f"--out {out}: cannot create it: {base} is not a writable directory.",
                           param="--out", value=str(out))
    try:  # the real test: can a directory be made there (read-only file systems, /proc, ...)?
        os.rmdir(tempfile.mkdtemp(prefix=".gearopt-probe-", dir=base))
    except OSError as e:
        raise ResultsError(f"--out {out}: cannot create it in {base}: {e.strerror or e}.",
                           param="--out", value=str(out)) from None
    return out


def write_results(out_dir: str | Path, result: Any, *, scene: Scene | None = None, run_time: float | None = None,
                  plots: bool | None = None,
                  progress: Callable[[str], None] | None = None,
                  warnings: list[dict[str, str]] | None = None, svg: bool | None = None,
                  plotter: Any = None) -> list[Path]:
    """Write ``results.json``, the tables, the plots and ``report.html`` of ``result`` into ``out_dir``.

    Parameters
    ----------
    out_dir : path
        Output directory: created; or, when it exists, empty or a previous gearopt output, whose
        listed files are replaced on success (module docstring; anything else is refused).
    result
        Object with ``to_dict()`` and ``save_plots(directory)`` (see module docstring).
    scene : Scene, optional
        The scene that was run (its path, name and study go into ``meta``; its
        ``output["plots"]`` decides about plots unless ``plots`` is given).
    run_time : float, optional
        Wall time of the study in s, for ``meta``.
    plots : bool, optional
        Write plots (default: the scene's ``[output] plots``, else True).
    progress : callable(str), optional
        Receives progress lines.
    svg : bool, optional
        Show each light figure in report.html as SVG instead of its PNG (default: the scene's
        ``[output] svg``, else False); each such figure is drawn a second time.
    warnings : list of dict, optional
        The warnings the run raised, ``{"category", "message", "source"}`` each (``gearopt run``
        records them): ``meta.warnings`` of results.json, followed by those shown while the tables
        and plots are written (:class:`~gearopt.warning_log.WarningLog`; ``[]`` when there are none),
        and highlighted in ``report.html``.
    plotter : object, optional
        Draws the plots elsewhere while the tables are written: ``plotter.submit(result, directory,
        kwargs)`` starts ``result.save_plots(directory, **kwargs)`` (False when it cannot),
        ``plotter.wait()`` returns ``(files, warnings)`` (what ``save_plots`` returned, the warnings
        shown meanwhile; None when it could not draw: then they are drawn here) and
        ``plotter.close()`` stops it after an error;
        ``gearopt run`` passes its :class:`gearopt.cli_plots.PlotProcesses`. Not used with ``svg``.

    Returns
    -------
    list[Path]
        The written files in their final place: ``results.json`` first, then the tables, the
        plots and ``report.html`` (:func:`gearopt.io.page.report_page`: the key numbers, the
        warnings, every plot with its caption from the result's ``captions`` mapping, links to the
        other files); the manifest :data:`MANIFEST` is written too, not listed.

    Raises
    ------
    ResultsError
        A non-finite number (NaN, inf) in the results (the schema has ``null`` where a point did not
        converge, never NaN), an output path that cannot hold the results (see
        :func:`check_out_dir`), or a failure to write; nothing is written.
    ValueError
        No ``units`` mapping (a bug of the study).
    """
    out_dir = check_out_dir(out_dir)
    if not (callable(getattr(result, "to_dict", None)) and callable(getattr(result, "save_plots", None))):
        from ..errors import ArgumentError
        raise ArgumentError(f"result = {type(result).__name__}: expected a study result with to_dict() and "
                            "save_plots(directory) (what a study's run() returns).",
                            param="result", value=result, valid="a study result with to_dict() and save_plots(directory)")
    say = progress or (lambda _msg: None)
    if plots is None:
        plots = bool(scene.output.get("plots", True)) if scene is not None else True

    data = result.to_dict()
    if not isinstance(data, dict):
        raise TypeError(f"result.to_dict() must return a dict, got {type(data).__name__}")
    if not isinstance(data.get("units"), dict):
        raise ValueError("result.to_dict() must contain a 'units' mapping (quantity -> unit), e.g. "
                         "{'r_a': 'mm', 'alpha_wt': 'rad'}")
    meta: dict[str, Any] = dict(data.get("meta") or {})
    meta.update({
        "gearopt_version": __version__,
        "scene": str(scene.source) if scene is not None else None,
        "scene_name": scene.name if scene is not None else None,
        "study": scene.study if scene is not None else None,
        "timestamp": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "run_time_s": None if run_time is None else round(float(run_time), 6),
        "warnings": [{"category": str(w.get("category", "Warning")), "message": str(w.get("message", "")),
                      "source": str(w.get("source", ""))} for w in (warnings or [])],
    })
    if scene is not None and getattr(scene, "pair", None) is not None:
        meta["pair"] = _pair_meta(scene)
    data = {**data, "meta": meta}
    data = _with_summary(data, result)
    try:  # allow_nan=False refuses NaN and inf; the walk that names where runs only then
        text = json.dumps(data, indent=2, allow_nan=False, default=_jsonable, ensure_ascii=False) + "\n"
    except ValueError:
        bad = _find_nonfinite(data)
        if bad is None:
            raise
        raise ResultsError(f"results: non-finite number (NaN or inf) at {bad}; results.json is not written (a "
                           "position without contact is null in the arrays; a non-finite scalar means the study "
                           "has no valid result for these inputs).") from None

    parent = out_dir.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=parent)).resolve()
    except OSError as e:
        raise ResultsError(f"cannot create the output directory {out_dir}: {e.strerror or e}.") from None
    pending = False
    want_svg = svg
    try:
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it 0700; give it the usual mode
        written = [RESULTS_FILE]
        # the warnings shown while the tables and plots are written (a plot that leaves a case out)
        # join meta.warnings: results.json is written after them
        drawing = WarningLog()
        svg = None
        if plots:
            say(f"writing plots to {out_dir}")
            kwargs = {}
            if scene is not None and _accepts(result.save_plots, "dpi"):
                kwargs["dpi"] = scene.output.get("dpi", 120)
            # each figure also as SVG for the page where the scene asks for it ([output] svg: a second
            # drawing of every figure)
            if want_svg is None:
                want_svg = bool(scene.output.get("svg", False)) if scene is not None else False
            svg = SVGCapture() if want_svg else None
            # drawn elsewhere (gearopt run: other processes) while the tables are written here
            pending = plotter is not None and svg is None and plotter.submit(result, str(tmp), kwargs)
        if callable(getattr(result, "save_tables", None)):
            with drawing:
                tables = _reported(tmp, result.save_tables(str(tmp)), "save_tables")
        else:
            tables = []
        if plots:
            done = None
            if pending:
                page_template()  # loaded meanwhile
                with heartbeat(progress, "writing plots", every=15.0):
                    done = plotter.wait()
            if done is not None:
                files, shown = done
                drawing.records += [w for w in shown if w not in drawing.records]
            else:
                from ..plot.saving import png_saving
                from ..plot.style import plot_style
                # one style for every study's figures (no offset notation, ...); PNG files compressed
                # for speed
                with drawing, plot_style(), png_saving(), heartbeat(progress, "writing plots", every=15.0), \
                        svg or contextlib.nullcontext():
                    files = result.save_plots(str(tmp), **kwargs)
            written += tables + _reported(tmp, files, "save_plots")
        else:
            written += tables
        if drawing.records:  # shown while the tables and plots were written: they join meta.warnings
            data["meta"]["warnings"] += drawing.records
            text = json.dumps(data, indent=2, allow_nan=False, default=_jsonable, ensure_ascii=False) + "\n"
        (tmp / RESULTS_FILE).write_text(text, encoding="utf-8")
        captions = getattr(result, "captions", None) or {}
        page = report_page(data, written, dict(captions), svg.svgs if svg is not None else None, tmp)
        (tmp / REPORT_FILE).write_text(page, encoding="utf-8")
        written.append(REPORT_FILE)
        install_output(tmp, out_dir)
    except OSError as e:
        if pending:
            plotter.close()
        shutil.rmtree(tmp, ignore_errors=True)
        raise ResultsError(f"cannot write the results to {out_dir}: {e.strerror or e}; nothing was written.") from None
    except BaseException:
        if pending:  # no drawing process writes into tmp any more
            plotter.close()
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [out_dir / w for w in written]


def _pair_meta(scene: Any) -> dict:
    """``meta.pair`` of results.json: the scene's pair (z1, z2, m_n [mm], beta [deg], a [mm]) and the
    driving flank where the study's section gives one; every study's results name their pair."""
    p = scene.pair
    out = {"z1": int(p.pinion.z), "z2": int(p.gear.z), "m_n": float(p.pinion.m_n),
           "beta_deg": math.degrees(p.pinion.beta), "a": float(p.a_w)}
    side = (scene.options.get(scene.study) or {}).get("side") if isinstance(scene.options, dict) else None
    if isinstance(side, str):
        out["side"] = side
    return out


def _with_summary(data: dict, result: Any) -> dict:
    """``data`` with the top-level ``summary`` (docs/results.md, "summary") after ``study`` and
    ``scene``: the result's ``summary()`` (a list of :class:`~gearopt.summary.KeyNumber`), else the
    key numbers :func:`gearopt.summary.summarize` reads from ``data``."""
    fn = getattr(result, "summary", None)
    numbers = with_pair(fn(), data) if callable(fn) else summarize(data)
    head = {k: data[k] for k in ("study", "scene") if k in data}
    return {**head, "summary": summary_dicts(list(numbers)), **{k: v for k, v in data.items() if k not in head}}


def _reported(tmp: Path, paths, who: str) -> list[str]:
    """Paths returned by ``save_plots``/``save_tables``, relative to ``tmp``; each must exist inside it."""
    out = []
    for p in paths or []:
        p = Path(p)
        full = p if p.is_absolute() else tmp / p
        try:
            rel = full.resolve().relative_to(tmp.resolve())
        except ValueError:
            raise ValueError(f"{who} wrote {p} outside the directory it was given") from None
        if not full.exists():
            raise FileNotFoundError(f"{who} reported {p}, which does not exist")
        out.append(str(rel))
    return out


def _accepts(func, name: str) -> bool:
    try:
        return name in inspect.signature(func).parameters
    except (TypeError, ValueError):
        return False


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _files_under(d: Path) -> list[str]:
    return sorted(str(Path(r, f).relative_to(d)) for r, _, fs in os.walk(d) for f in fs)


def _write_manifest(out: Path, files: list[str]) -> None:
    """Write :data:`MANIFEST` of ``out`` listing ``files`` (atomically: a temporary file renamed)."""
    data = {"written_by": "gearopt", "gearopt_version": __version__,
            "note": "gearopt replaces or removes only the files listed here; any other file in this directory is "
                    "left alone.",
            "files": sorted(set(files) - {MANIFEST})}
    tmp = out / f"{MANIFEST}.tmp"
    tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, out / MANIFEST)


def install_output(new: Path, target: Path) -> list[str]:
    """Move the files of the finished directory ``new`` into the output directory ``target``.

    ``target`` is created when absent (``new`` renamed to it). An existing ``target`` must be empty or
    a previous gearopt output (see the module docstring): the files its manifest lists are replaced
    (removed when the new output does not have them), every other file in it is kept, and a new
    file that would overwrite one of those is refused before anything moves. The manifest of
    ``target`` lists the new files at the end. ``new`` is consumed (removed) on success.

    Parameters
    ----------
    new : path
        The complete new output (a temporary directory on the same file system as ``target``).
    target : path
        The output directory.

    Returns
    -------
    list[str]
        The installed files, relative to ``target``.

    Raises
    ------
    ResultsError
        ``target`` holds files gearopt did not write (and is no gearopt output), or a new file would
        overwrite one; ``target`` is unchanged.
    OSError
        Moving failed; the previous output is put back as far as the file system allows.
    """
    new, target = Path(new), Path(target)
    files = _files_under(new)
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise ResultsError(f"--out {target}: exists and is not a directory; not replacing it.",
                           param="--out", value=str(target))
    if not target.exists():
        _write_manifest(new, files)
        os.replace(new, target)
        return files
    owned = output_files(target)
    if owned is None:
        raise _refuse_foreign(target, _foreign(target) or [MANIFEST])
    clash = [f for f in files if (target / f).exists() or (target / f).is_symlink()]
    clash = [f for f in clash if f not in owned]
    if clash:
        raise ResultsError(f"--out {target}: the new results would overwrite {', '.join(clash[:3])}, which gearopt "
                           "did not write; nothing was changed. Move that file or choose another --out.",
                           param="--out", value=str(target))
    inside = target.resolve()
    old = [f for f in owned if ((target / f).is_file() or (target / f).is_symlink())
           and (target / f).parent.resolve().is_relative_to(inside)]  # never through a linked directory
    # both lists in the manifest while the files move: after an interruption every file gearopt wrote is
    # listed, so the next run still recognises this directory and replaces them
    _write_manifest(target, old + files)
    backup = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=target.parent))
    moved_old, moved_new = [], []
    try:
        for f in old:
            (backup / f).parent.mkdir(parents=True, exist_ok=True)
            os.replace(target / f, backup / f)
            moved_old.append(f)
        for f in files:
            (target / f).parent.mkdir(parents=True, exist_ok=True)
            os.replace(new / f, target / f)
            moved_new.append(f)
    except BaseException:
        for f in moved_new:  # undo: the new files back, the previous output in place again
            try:
                os.replace(target / f, new / f)
            except OSError:
                pass
        for f in moved_old:
            try:
                os.replace(backup / f, target / f)
            except OSError:
                pass
        _write_manifest(target, owned)
        shutil.rmtree(backup, ignore_errors=True)
        raise
    _write_manifest(target, files)
    shutil.rmtree(backup, ignore_errors=True)
    for f in old:  # directories that only held previous output files
        d = (target / f).parent
        while d != target and d.is_dir() and not any(d.iterdir()):
            d.rmdir()
            d = d.parent
    shutil.rmtree(new, ignore_errors=True)
    return files
