"""The on-disk cache of the FE influence coefficients and local excesses (:mod:`gearopt.fea.influence`,
:mod:`gearopt.fea.local`): its directory and the atomic write of its .npz files."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..compiled import cache_root

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


def cache_dir() -> Path:
    """Directory of the influence-coefficient cache: ``influence/`` in gearopt's cache root
    (:func:`gearopt.compiled.cache_root`: ``$GEAROPT_CACHE``, else ``$XDG_CACHE_HOME/gearopt``, else
    ``~/.cache/gearopt``)."""
    return cache_root() / "influence"


def save_npz(path: Path, **arrays: ArrayLike) -> None:
    """Write ``arrays`` to ``path`` (.npz) atomically (a temporary file in the same directory, renamed)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=".npz", dir=path.parent)
    os.close(fd)
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
