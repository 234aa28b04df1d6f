"""Writing a study's results: ``results.json`` and plots, all or nothing.

A study's ``run()`` returns a result object with

* ``to_dict() -> dict``: JSON-able data (NumPy scalars/arrays are accepted and converted), with a
  ``"units"`` mapping (quantity -> unit string) so that every number can be read without the source;
* ``save_plots(directory) -> list[str]``: writes its figures into ``directory`` and returns their
  paths (absolute, or relative to ``directory``). If it accepts a ``dpi`` keyword, the scene's
  ``[output] dpi`` is passed.
* optionally ``save_tables(directory) -> list[str]``: writes data tables (CSV) beside
  ``results.json``, whether or not plots are written; same path rules.

:func:`write_results` writes into a temporary sibling of the output directory and renames it into
place at the end: an existing output directory is replaced only when everything succeeded, and a
failure leaves no half-written directory behind.
"""

from __future__ import annotations

import datetime as _dt
import inspect
import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..errors import ArgumentError, ResultsError, shorten

__all__ = ["write_results", "check_out_dir", "RESULTS_FILE"]

RESULTS_FILE = "results.json"


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


def check_out_dir(out_dir, scene_file=None) -> Path:
    """Check, before anything runs, that ``out_dir`` can become the results directory.

    Refused (:class:`~gearopt.errors.ResultsError`): the empty path; an existing file or symlink;
    the working directory, one of its parents or the root, or a directory holding the scene file
    (the output directory is replaced as a whole); a place where the directory cannot be created.

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
        raise ResultsError("--out / out_dir is empty; valid: a directory path such as out/my_scene (it is created, "
                           "or replaced as a whole).",
                           param="--out", value=out_dir, valid="a directory path such as out/my_scene")
    out = Path(out_dir)
    full = Path(os.path.abspath(out))
    cwd = Path(os.getcwd())
    if full == Path(full.anchor) or full == cwd or full in cwd.parents:
        raise ResultsError(f"--out {out}: is the working directory, one of its parents or the root; results replace "
                           "the output directory as a whole, so give a directory of its own (e.g. out/my_scene).",
                           param="--out", value=str(out))
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise ResultsError(f"--out {out}: exists and is not a directory; valid: a new directory or a previous "
                           "gearopt results directory.",
                           param="--out", value=str(out), valid="a new directory or a previous gearopt results directory")
    if scene_file is not None:
        scene_full = Path(os.path.abspath(scene_file))
        if full in scene_full.parents:
            raise ResultsError(f"--out {out}: contains the scene file {scene_file}; replacing it would delete the scene. "
                               "Give another output directory.",
                               param="--out", value=str(out))
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


def write_results(out_dir, result, *, scene=None, run_time: float | None = None, plots: bool | None = None,
                  progress=None) -> list[Path]:
    """Write ``results.json`` (and the plots) of ``result`` into ``out_dir``.

    Parameters
    ----------
    out_dir : path
        Output directory; created, or replaced as a whole if it exists.
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

    Returns
    -------
    list[Path]
        The written files in their final place: ``results.json`` first, then the plots.

    Raises
    ------
    ResultsError
        A non-finite number (NaN, inf) in the results (the schema has ``null`` where a point did not
        converge, never NaN), an output path that cannot hold the results (see
        :func:`check_out_dir`), or a failure to write; nothing is written.
    ValueError
        No ``units`` mapping (a bug of the study).
    """
    from .. import __version__

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
    })
    data = {**data, "meta": meta}
    bad = _find_nonfinite(data)
    if bad is not None:
        raise ResultsError(f"results: non-finite number (NaN or inf) at {bad}; results.json is not written (a "
                           "position without contact is null in the arrays; a non-finite scalar means the study "
                           "has no valid result for these inputs).")
    text = json.dumps(data, indent=2, allow_nan=False, default=_jsonable, ensure_ascii=False) + "\n"

    parent = out_dir.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=parent)).resolve()
    except OSError as e:
        raise ResultsError(f"cannot create the output directory {out_dir}: {e.strerror or e}.") from None
    try:
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes it 0700; give it the usual mode
        (tmp / RESULTS_FILE).write_text(text, encoding="utf-8")
        written = [RESULTS_FILE]
        if callable(getattr(result, "save_tables", None)):
            written += _reported(tmp, result.save_tables(str(tmp)), "save_tables")
        if plots:
            say(f"writing plots to {out_dir}")
            kwargs = {}
            if scene is not None and _accepts(result.save_plots, "dpi"):
                kwargs["dpi"] = scene.output.get("dpi", 120)
            from ..plot.style import plot_style
            with plot_style():  # one style for every study's figures (no offset notation, ...)
                written += _reported(tmp, result.save_plots(str(tmp), **kwargs), "save_plots")
        _replace_dir(tmp, out_dir)
    except OSError as e:
        shutil.rmtree(tmp, ignore_errors=True)
        raise ResultsError(f"cannot write the results to {out_dir}: {e.strerror or e}; nothing was written.") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return [out_dir / w for w in written]


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


def _replace_dir(new: Path, target: Path) -> None:
    """Move directory ``new`` to ``target``, replacing an existing ``target`` only at the end."""
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise FileExistsError(f"{target} exists and is not a directory; not replacing it")
    if not target.exists():
        os.replace(new, target)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{target.name}.old-", dir=target.parent))
    os.rmdir(old)
    os.replace(target, old)
    try:
        os.replace(new, target)
    except BaseException:
        os.replace(old, target)  # put the previous results back
        raise
    shutil.rmtree(old, ignore_errors=True)
