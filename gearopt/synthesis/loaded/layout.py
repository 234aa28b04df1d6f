"""Named layout of the loaded micro-geometry NLP (as :class:`gearopt.meshing.layout.ParamLayout` names
the TCA's parameter column): its unknowns, its constraint rows and its parameters are stacked
blocks, each with a name, so no consumer (start point, bounds, predicted values, warm-start
multipliers, sensitivities, tests) knows an offset.

Unknowns (in this order; all scaled, docs/loaded_synthesis.md section 2):

* ``"theta"`` (P) the design [um, or 1e-3/mm for a setting];
* ``"x"`` (nx) the load share of every slice held; ``"y"`` (nx) its gap [um];
* ``"d"`` (nB) the approach of every (torque, case, position) block [um];
* ``"te_hi"``, ``"te_lo"`` (T C) the loaded TE's bounds per (torque, case) [arcsec];
* ``"slack_p"``, ``"slack_e"`` (T C) the pressure and edge-loading slacks;
* ``"w"`` (nw) the deflections of every slice node [um] (the analytical compliance with more than
  ``nlp.DENSE_SLICES_MAX`` slices across the face; else 0: the compliance enters the gaps as dense blocks);
* ``"x0"``, ``"y0"`` (n0), ``"d0"`` (nB0) the unloaded-TE target's loads, gaps and approaches (0
  without a target).

Rows: ``"stiffness"`` (nw, the face coupling of the deflections), ``"gap"`` and ``"complementarity"`` (nx),
``"balance"``, ``"te_hi"``, ``"te_lo"`` (nB), ``"pressure"`` (one per flank slice under a pressure
limit), ``"edge"`` (one per slice of the edge-loading constraint), ``"te0_gap"``,
``"te0_complementarity"`` (n0) and ``"te0_balance"`` (nB0).

Parameters: ``"p_limit"`` [MPa], ``"edge_margin"`` [um], ``"mu"``, ``"rho"``, ``"torque_scale"`` (T)
and ``"mis_offset"`` (one per kind of :class:`~gearopt.meshing.misalignment.Misalignment`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import casadi as ca
import numpy as np

from ...errors import ParameterNameError

#: the unknowns' blocks in the order of the NLP's vector
UNKNOWNS = ("theta", "x", "y", "d", "te_hi", "te_lo", "slack_p", "slack_e", "w", "x0", "y0", "d0")
#: the constraint rows' blocks in the order of the NLP's constraint vector
ROWS = ("stiffness", "gap", "complementarity", "balance", "te_hi", "te_lo", "pressure", "edge", "te0_gap",
        "te0_complementarity", "te0_balance")
#: the parameters' blocks
PARAMS = ("p_limit", "edge_margin", "mu", "rho", "torque_scale", "mis_offset")


class Block(NamedTuple):
    """One (torque, case, position) block of the loaded NLP: its slices are the unknowns
    ``x[first:first + count]`` (and their gaps ``y``), its approach one entry of ``d``."""

    torque: int
    case: int
    position: int
    first: int
    count: int


class Te0Block(NamedTuple):
    """One (case, position) block of the unloaded-TE target: slices ``x0[first:first + count]``."""

    case: int
    position: int
    first: int
    count: int


@dataclass(frozen=True)
class Te0Slices:
    """The unloaded-TE target's slices in the NLP (``NLPBuilder._te0_blocks``): per case and position,
    the active slices of the pair centred there; arrays over those slices unless stated."""

    a: np.ndarray  #: absolute separation [mm]
    J: np.ndarray  #: (n0, P) its derivative in the free amounts
    Jm: np.ndarray  #: (n0, Q) its derivative in the misalignment kinds
    blk: np.ndarray  #: the block (index into ``blocks``) of each slice
    keys: np.ndarray  #: (n0, 4) (T, case, position, flat slice index) of each slice (T: zero load)
    case: np.ndarray  #: (nB0,) the case of each block
    psi: np.ndarray  #: (nB0,) the pair angle of each block over pi / z1
    blocks: list[Te0Block]  #: (case, position, first, count) per block


class BlockLayout:
    """Named consecutive blocks of one stacked vector.

    Parameters
    ----------
    sizes : dict name -> int
        The blocks in order with their lengths (0 allowed: an empty block keeps its name).
    """

    def __init__(self, sizes: dict):
        self._slices: dict[str, slice] = {}
        n = 0
        for name, k in sizes.items():
            k = int(k)
            if k < 0:
                raise ParameterNameError(f"BlockLayout: block {name!r} has a negative size {k}", param=name,
                                         value=k, valid="a size >= 0")
            self._slices[name] = slice(n, n + k)
            n += k
        self.size = n

    @property
    def names(self) -> tuple:
        return tuple(self._slices)

    def __contains__(self, name) -> bool:
        return name in self._slices

    def __getitem__(self, name: str) -> slice:
        """The slice of a block, e.g. ``layout.unknowns["slack_p"]``."""
        try:
            return self._slices[name]
        except KeyError:
            raise ParameterNameError(f"{name!r} is not a block of this layout; known: {', '.join(self._slices)}",
                                     param=name, value=name, valid=f"one of {list(self._slices)}") from None

    def count(self, name: str) -> int:
        """The length of a block."""
        s = self[name]
        return s.stop - s.start

    def take(self, vec: np.ndarray | ca.MX | ca.SX, name: str) -> np.ndarray | ca.MX | ca.SX:
        """The block ``name`` of the stacked vector ``vec`` (a view for numpy)."""
        return vec[self[name]]

    def span(self, first: str, last: str) -> slice:
        """The slice from the start of block ``first`` to the end of block ``last``."""
        return slice(self[first].start, self[last].stop)


@dataclass(frozen=True)
class NLPLayout:
    """The layouts of the NLP's unknowns, constraint rows and parameters (module docstring)."""

    unknowns: BlockLayout
    rows: BlockLayout
    params: BlockLayout

    def sizes(self) -> dict:
        """The sizes by their short names: ``P`` (design), ``nx`` (slices held), ``nB`` (blocks), ``TC``
        (torque-case pairs), ``nw`` (deflections), ``n0``, ``nB0`` (the unloaded-TE target's slices and
        blocks)."""
        u = self.unknowns
        return dict(P=u.count("theta"), nx=u.count("x"), nB=u.count("d"), TC=u.count("te_hi"), nw=u.count("w"),
                    n0=u.count("x0"), nB0=u.count("d0"))


def param_layout(n_torques: int, n_kinds: int) -> BlockLayout:
    """The NLP's parameters: the pressure limit, the edge margin, the smoothing, the penalty weight,
    ``n_torques`` torque scales and ``n_kinds`` misalignment offsets."""
    return BlockLayout(dict(p_limit=1, edge_margin=1, mu=1, rho=1, torque_scale=n_torques, mis_offset=n_kinds))


def nlp_layout(P: int, nx: int, nB: int, TC: int, nw: int, n0: int, nB0: int, n_pressure: int, n_edge: int,
               n_torques: int, n_kinds: int) -> NLPLayout:
    """The layout of an NLP of ``P`` design amounts, ``nx`` slices held in ``nB`` blocks over ``TC``
    torque-case pairs, ``nw`` deflections, ``n0`` / ``nB0`` unloaded-TE slices / blocks and
    ``n_pressure`` / ``n_edge`` inequality rows."""
    unknowns = BlockLayout(dict(theta=P, x=nx, y=nx, d=nB, te_hi=TC, te_lo=TC, slack_p=TC, slack_e=TC, w=nw,
                                x0=n0, y0=n0, d0=nB0))
    rows = BlockLayout(dict(stiffness=nw, gap=nx, complementarity=nx, balance=nB, te_hi=nB, te_lo=nB,
                            pressure=n_pressure, edge=n_edge, te0_gap=n0, te0_complementarity=n0, te0_balance=nB0))
    assert unknowns.names == UNKNOWNS and rows.names == ROWS
    return NLPLayout(unknowns=unknowns, rows=rows, params=param_layout(n_torques, n_kinds))


def block_vector(layout: BlockLayout, parts: dict, fill: float = 0.0) -> np.ndarray:
    """A stacked vector of ``layout`` from ``parts`` (name -> array or scalar), ``fill`` elsewhere."""
    out = np.full(layout.size, fill, float)
    for name, v in parts.items():
        out[layout[name]] = v
    return out
