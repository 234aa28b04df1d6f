"""Named layout of the symbolic inputs of the TCA graph (``prm``).

The TCA's Functions take one parameter column ``prm``: the pinion angle, both members' surface
parameter vectors, the misalignments and the line-contact section. :class:`ParamLayout` names every
entry and builds, slices, packs and unpacks ``prm`` by name, so no consumer (edge contact,
synthesis, studies, tests) knows an index. Names:

* ``"phi1"`` [rad]; ``"z_section"`` [mm];
* ``"pinion.<p>"``, ``"gear.<p>"``: each member's surface parameters ``GeneratedTooth.param_names``
  (the generation settings :data:`~gearopt.geometry.generation.PARAMS`, then any flank-modification
  parameters); the whole vectors are the groups ``"pinion"`` and ``"gear"``;
* ``"mis.<kind>"``: every field of :class:`~gearopt.meshing.misalignment.Misalignment`; group ``"mis"``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError, ParameterNameError
from .curvature import Sym
from .misalignment import Misalignment

if TYPE_CHECKING:
    from ..geometry.generation import GeneratedTooth


class ParamLayout:
    """name -> slice of the TCA parameter column ``prm``.

    Parameters
    ----------
    pinion_names, gear_names : sequence of str
        Names of each member's surface parameter vector p (``GeneratedTooth.param_names``).
    """

    MEMBERS = ("pinion", "gear")

    def __init__(self, pinion_names: Sequence[str], gear_names: Sequence[str]):
        self.groups: dict[str, slice] = {}
        self._index: dict[str, int] = {}
        self.names: list[str] = []

        def add(group, entries):
            start = len(self.names)
            for e in entries:
                name = e if group is None else f"{group}.{e}"
                if name in self._index:
                    raise ParameterNameError(f"ParamLayout: duplicate parameter name {name!r}", param=name,
                                             valid="names that appear once")
                self._index[name] = len(self.names)
                self.names.append(name)
            if group is not None:
                self.groups[group] = slice(start, len(self.names))

        add(None, ["phi1"])
        add("pinion", tuple(pinion_names))
        add("gear", tuple(gear_names))
        add("mis", Misalignment.names())
        add(None, ["z_section"])
        self.names = tuple(self.names)
        self.member_names = {"pinion": tuple(pinion_names), "gear": tuple(gear_names)}

    @classmethod
    def for_teeth(cls, pinion: GeneratedTooth, gear: GeneratedTooth) -> ParamLayout:
        """The layout of a TCA of two :class:`~gearopt.geometry.generation.GeneratedTooth`."""
        return cls(pinion.param_names, gear.param_names)

    @property
    def size(self) -> int:
        return len(self.names)

    def __len__(self) -> int:
        return self.size

    def __contains__(self, name) -> bool:
        return name in self._index or name in self.groups

    def index(self, name: str) -> int:
        """Row of a single entry, e.g. ``"pinion.a_c"``, ``"mis.crossing"``."""
        try:
            return self._index[name]
        except KeyError:
            raise ParameterNameError(f"{name!r} is not a TCA parameter; known: {', '.join(self.names)}",
                                     param=name, valid=", ".join(self.names)) from None

    def slice(self, name: str) -> slice:
        """Rows of an entry or of a group (``"pinion"``, ``"gear"``, ``"mis"``)."""
        if name in self.groups:
            return self.groups[name]
        i = self.index(name)
        return slice(i, i + 1)

    def indices(self, names: Sequence[str]) -> list[int]:
        """Rows of several single entries, in the given order."""
        return [self.index(n) for n in names]

    def p_index(self, member: str, name: str) -> int:
        """Position of surface parameter ``name`` inside member ``member``'s vector p."""
        return self.member_names[member].index(name)

    # --- numbers ------------------------------------------------------------------------------
    def pack(self, phi1: npt.ArrayLike, values: dict | None = None) -> np.ndarray:
        """Numeric parameter matrix (size, N) for the positions ``phi1`` (N,) [rad].

        ``values`` maps names (entries or groups) to numbers (or vectors for groups), applied in
        order; entries not given are 0, so give every surface parameter (the groups "pinion" and
        "gear" take whole vectors p). A :class:`Misalignment` may be given as ``"mis"``.
        """
        phi1 = np.atleast_1d(np.asarray(phi1, dtype=float))
        col = np.zeros(self.size)
        for name, v in (values or {}).items():
            if name == "phi1":
                raise ParameterNameError("pack: phi1 is the first argument (one column per position)", param="phi1",
                                         valid="the positions as pack's first argument")
            if isinstance(v, Misalignment):
                v = v.vector()
            sl = self.slice(name)
            v = np.asarray(v, float).ravel()
            if v.size != sl.stop - sl.start:
                raise ArgumentError(f"pack: {name!r} takes {sl.stop - sl.start} numbers, got {v.size}", param=name,
                                    value=v.size, valid=f"{sl.stop - sl.start} numbers")
            col[sl] = v
        out = np.tile(col[:, None], phi1.size)
        out[self.index("phi1")] = phi1
        return out

    def unpack(self, prm: npt.ArrayLike) -> dict[str, float | np.ndarray]:
        """``{name: value}`` of every single entry of one column (or ``{name: row}`` of a matrix)."""
        prm = np.asarray(prm, float)
        return {n: prm[i] for i, n in enumerate(self.names)}

    def misalignment(self, prm: npt.ArrayLike) -> Misalignment:
        """The :class:`Misalignment` of one numeric column."""
        col = np.asarray(prm, float).ravel()
        return Misalignment(**{k: float(col[self.index(f"mis.{k}")]) for k in Misalignment.names()})

    # --- symbols ------------------------------------------------------------------------------
    def symbols(self, sym: type[ca.SX] | type[ca.MX] = ca.SX) -> dict[str, Sym]:
        """Fresh symbols of every group and single entry outside a group: ``{"phi1", "pinion",
        "gear", "mis", "z_section"}`` (vectors for the groups)."""
        return {"phi1": sym.sym("phi1"), "pinion": sym.sym("p1", self._len("pinion")),
                "gear": sym.sym("p2", self._len("gear")), "mis": sym.sym("mis", self._len("mis")),
                "z_section": sym.sym("z_section")}

    def _len(self, group):
        sl = self.groups[group]
        return sl.stop - sl.start

    def build(self, pieces: dict) -> Sym:
        """The column ``prm`` (vertcat) from named pieces: groups (``"pinion"``, ``"gear"``, ``"mis"``)
        or single entries (``"mis.crossing"``...); every entry must be given exactly once. The
        pieces may be SX, MX, DM or numbers."""
        parts, covered = [], np.zeros(self.size, int)
        for name, v in pieces.items():
            sl = self.slice(name)
            n = sl.stop - sl.start
            size = v.shape[0] if hasattr(v, "shape") and len(v.shape) else (len(v) if hasattr(v, "__len__") else 1)
            if size != n:
                raise ArgumentError(f"build: {name!r} takes {n} rows, got {size}", param=name, value=size,
                                    valid=f"{n} rows")
            covered[sl] += 1
            parts.append((sl.start, v))
        bad = [self.names[i] for i in np.flatnonzero(covered != 1)]
        if bad:
            raise ParameterNameError(f"build: every entry must be given exactly once: {', '.join(bad)}",
                                     param=bad[0], valid="every entry exactly once")
        return ca.vertcat(*(v for _, v in sorted(parts, key=lambda t: t[0])))

    def named(self, prm: Sym | np.ndarray) -> dict:
        """Named pieces of a symbolic (or numeric) column: groups as vectors, each single entry by
        name, and ``"mis_map"``: ``{kind: value}`` for :meth:`Misalignment.gear_to_fixed`."""
        out = {g: prm[sl] for g, sl in self.groups.items()}
        out.update({n: prm[i] for i, n in enumerate(self.names)})
        out["mis_map"] = {k: prm[self.index(f"mis.{k}")] for k in Misalignment.names()}
        return out

    def __repr__(self) -> str:
        return f"ParamLayout({', '.join(self.names)})"
