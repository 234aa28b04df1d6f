"""CasADi graphs built once from other Functions: kept in the process and, serialised, on disk.

Common-subexpression elimination (``{"cse": True}``) of an SX graph costs far more than building it:
a TCA branch's residual-and-Jacobian graph (7,300 instructions after elimination) takes about 0.2 s,
its serialised form 10 ms to read back. A graph that a fixed construction builds from given
Functions (:class:`gearopt.meshing.solver.Branch`: the Newton step's Jacobian and the checks at the
solved point, from the residual and the checks) is therefore looked up by what it is built from:
the SHA-256 of the CasADi version, the graph's name, a tag naming the construction (its source:
:func:`gearopt.compiled.source_tag`) and the serialised bases. The Function found is the one the
construction gives, bit for bit (a serialised Function reads back to the same instructions and
constants; it is always the one read back, built here or not, so that what embeds it serialises,
and so keys its compiled library, the same in every process).

Where: in this process (the newest :data:`KEPT`), then ``graphs/`` in
:func:`gearopt.compiled.cache_root` (zlib-compressed, 50-300 kB a graph), written with an atomic
rename; nothing is written within :func:`gearopt.compiled.no_background` (``gearopt check``).
"""

from __future__ import annotations

import hashlib
import os
import zlib
from collections.abc import Callable, Sequence

import casadi as ca

from .compile_cache import cache_root, serial_digest, write_cache_file

KEPT = 32  #: graphs kept in this process (newest last)
_graphs: dict[str, ca.Function] = {}
_counts = {"built": 0, "memo": 0, "disk": 0}


def counts() -> dict:
    """Graphs this process built (``built``), found in the process (``memo``) and read from disk (``disk``)."""
    return dict(_counts)


def digest(f: ca.Function) -> str | None:
    """SHA-256 of ``f``'s serialisation (once per Function object, shared with its library key:
    :func:`gearopt.compile_cache.serial_digest`; None when CasADi cannot serialise it)."""
    try:
        return serial_digest(f)
    except Exception:  # noqa: BLE001 - a Function CasADi cannot serialise: its derived graphs are built each time
        return None


def graph_path(key: str) -> os.PathLike:
    """Where the graph of ``key`` (:func:`built_once`) lives on disk."""
    return cache_root() / "graphs" / f"{key[:40]}.casadi.z"


def built_once(name: str, bases: Sequence[ca.Function], tag: str, build: Callable[[], ca.Function]) -> ca.Function:
    """The Function ``name`` that ``build()`` makes from ``bases`` by the construction ``tag`` names
    (it must change whenever the construction does, e.g. :func:`gearopt.compiled.source_tag` of the
    code that builds it): from this process's memo, else from the disk cache, else built (and
    written to the cache unless :func:`gearopt.compiled.writes_nothing`). An empty ``tag`` or a base
    CasADi cannot serialise: built every time."""
    parts = [digest(b) for b in bases]
    if not tag or any(p is None for p in parts):
        _counts["built"] += 1
        return build()
    h = hashlib.sha256()
    for part in [ca.__version__, name, tag, *parts]:
        h.update(part.encode() + b"\0")
    key = h.hexdigest()
    f = _graphs.pop(key, None)
    if f is not None:
        _counts["memo"] += 1
    else:
        path = graph_path(key)
        try:
            f = ca.Function.deserialize(zlib.decompress(path.read_bytes()).decode())
        except (OSError, RuntimeError, zlib.error, UnicodeDecodeError):
            f = None
        if f is not None and f.name() == name:
            _counts["disk"] += 1
        else:
            text = build().serialize()
            _counts["built"] += 1
            # the Function read back, here too: a Function that embeds it (a rootfinder, a column)
            # then serialises the same whether it was built or read, so its compiled library has one
            # key (CasADi's serialisation of an embedded Function that was read back differs from
            # that of the one built, their generated C code being the same)
            f = ca.Function.deserialize(text)
            write_cache_file(path, zlib.compress(text.encode(), 1))
    _graphs[key] = f
    while len(_graphs) > KEPT:
        _graphs.pop(next(iter(_graphs)))
    return f


def eliminated(f: ca.Function) -> ca.Function:
    """The SX Function ``f`` (same name, inputs and outputs) with its common subexpressions
    eliminated (CasADi's ``cse``: operations of the same kind on the same operands computed once),
    so it evaluates the same numbers bit for bit in fewer instructions."""
    ins = [ca.SX.sym(f.name_in(i), f.sparsity_in(i)) for i in range(f.n_in())]
    return ca.Function(f.name(), ins, f.call(ins), f.name_in(), f.name_out(), {"cse": True})
