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

__all__ = ["write_results", "RESULTS_FILE"]

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
    ValueError
        A non-finite number (NaN, inf) in the results, or no ``units`` mapping; nothing is written.
    """
    from .. import __version__

    out_dir = Path(out_dir)
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
        raise ValueError(f"results: non-finite number (NaN or inf) at {bad}; results.json is not written.")
    text = json.dumps(data, indent=2, allow_nan=False, default=_jsonable, ensure_ascii=False) + "\n"

    parent = out_dir.parent
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=parent)).resolve()
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
            written += _reported(tmp, result.save_plots(str(tmp), **kwargs), "save_plots")
        _replace_dir(tmp, out_dir)
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
