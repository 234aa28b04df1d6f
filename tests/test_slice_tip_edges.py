"""LTCA slices' tip-edge solves (gearopt.ltca.slices.SliceSolver._tip_edges): interpreted or compiled, the
columns beyond a tip are solved alone, not padded to a fixed chunk, with the same slices bit for bit."""

from __future__ import annotations

import dataclasses

import numpy as np

import gearopt.ltca.slices as slices
from gearopt.compiled import ColumnMap
from gearopt.gears import Gear, GearPair
from gearopt.geometry.microgeometry import Microgeometry
from gearopt.ltca.engine import LTCA
from gearopt.meshing.solver import Branch
from gearopt.meshing.tca import TCA


def _slices():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_beta=0.010)),
                    Gear(z=40, m_n=3.0, b=20.0))
    L = LTCA(pair, tca=TCA(pair, jit=False), n_slices=5)
    return L.slices(L.mesh_cycle(8))


def test_tip_edge_solves_take_their_columns_alone_with_the_same_slices(monkeypatch):
    """Interpreted, and with the map flagged compiled too (the flag the solves were once padded by):
    each tip-edge solve gets as many columns as lie beyond that tip (fewer than EDGE_CHUNK here),
    never a chunk padded to EDGE_CHUNK; the slices equal, bit for bit, those of solves padded to the
    chunk (copies of the first column, the padding the compiled path once took)."""
    sizes = []
    real_outputs = ColumnMap.outputs

    def spy(self, *args):
        if self.column.name().startswith("ltca_tip"):
            sizes.append(np.asarray(args[0]).shape[1])
        return real_outputs(self, *args)

    monkeypatch.setattr(ColumnMap, "outputs", spy)
    S = _slices()
    assert S.edge is not None and (S.edge > 0).any()  # tip edges in contact
    assert sizes and all(0 < n < slices.EDGE_CHUNK for n in sizes)
    real_mapped = Branch.mapped

    def flagged(self, n, n_total=None, extra=False):
        cm = real_mapped(self, n, n_total, extra)
        if self.name.startswith("ltca_tip"):
            cm.compiled = True  # (the map stays the interpreted one)
        return cm

    monkeypatch.setattr(Branch, "mapped", flagged)
    sizes.clear()
    flag = _slices()
    assert sizes and all(0 < n < slices.EDGE_CHUNK for n in sizes)
    # the reference: every tip-edge call padded to EDGE_CHUNK columns, the padding cut off after
    monkeypatch.setattr(Branch, "mapped", real_mapped)

    def padded(self, *args):
        if not self.column.name().startswith("ltca_tip"):
            return real_outputs(self, *args)
        n = np.asarray(args[0]).shape[1]
        sel = np.concatenate([np.arange(n), np.zeros(slices.EDGE_CHUNK - n, int)])
        sizes.append(sel.size)
        return [np.asarray(o)[:, :n] for o in real_outputs(self, *(np.asarray(a)[:, sel] for a in args))]

    monkeypatch.setattr(ColumnMap, "outputs", padded)
    sizes.clear()
    ref = _slices()
    assert sizes and all(n == slices.EDGE_CHUNK for n in sizes)
    for other in (S, flag):
        for f in dataclasses.fields(other):
            a, b = getattr(other, f.name), getattr(ref, f.name)
            if isinstance(a, np.ndarray):
                assert np.array_equal(a, b, equal_nan=True), f.name
            elif f.name == "stats":  # the solver's counts equal; its time does not
                assert {k: v for k, v in a.items() if k != "time_s"} == {k: v for k, v in b.items() if k != "time_s"}
            else:
                assert a == b, f.name
