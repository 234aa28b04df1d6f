"""The loaded optimiser's work outside IPOPT (issue 43): a derived graph's library keyed by its
construction (:func:`gearopt.compiled.keyed_by`) and the loaded TCA reusing a contact structure
computed already (``LTCA.solve(structure=)``)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from gearopt import compile_cache, compiled
from gearopt.errors import ArgumentError
from gearopt.gears import Gear, GearPair
from gearopt.ltca.engine import LTCA


def _base(a: float) -> ca.Function:
    x = ca.SX.sym("x", 2)
    return ca.Function("outside_base", [x], [ca.sin(a * x[0]) * x[1]])


def _derived(base: ca.Function) -> ca.Function:
    x = ca.SX.sym("x", 2)
    return ca.Function("outside_derived", [x], [ca.jacobian(base(x), x)])


@pytest.mark.skipif(not compiled.available(), reason="no C compiler")
def test_a_derived_library_is_keyed_by_its_bases_and_tag_without_serialising_it(tmp_path, monkeypatch):
    """The key names the bases' libraries and the tag (a change of either: another library), looking
    the derived library up never serialises its own graph, and it is found without building it."""
    monkeypatch.setenv("GEAROPT_CACHE_DIR", str(tmp_path))
    b1, b2 = _base(1.5), _base(2.5)
    f = compiled.keyed_by(_derived(b1), [b1], "construction A")
    serialised = []
    orig = compiled.cache_key

    def spy(g):
        serialised.append(g.name())
        return orig(g)

    monkeypatch.setattr(compile_cache, "cache_key", spy)
    path = compiled.library_path(f)
    assert "outside_derived" not in serialised  # the base's key only (memoised per Function)
    assert path.name.startswith("outside_derived-") and path.parent == tmp_path
    same = compiled.keyed_by(_derived(b1), [b1], "construction A")
    assert compiled.library_path(same) == path
    assert compiled.library_path(compiled.keyed_by(_derived(b1), [b1], "construction B")) != path
    assert compiled.library_path(compiled.keyed_by(_derived(b2), [b2], "construction A")) != path
    # an empty tag (a source that cannot be read): keyed by the graph as before
    plain = compiled.keyed_by(_derived(b1), [b1], "")
    assert compiled.library_path(plain) == tmp_path / f"outside_derived-{orig(plain)[:24]}.so"
    # the compiled library of the derived graph gives its numbers
    g = compiled.compile_function(f)
    x = np.array([0.3, -1.2])
    assert np.allclose(np.asarray(g(x)), np.asarray(_derived(b1)(x)), rtol=1e-14, atol=0.0)
    # found by its name, bases and tag before the derived graph is built; not under another tag
    h = compiled.keyed_library("outside_derived", [b1], "construction A")
    assert h is not None and np.array_equal(np.asarray(h(x)), np.asarray(g(x)))
    assert compiled.keyed_library("outside_derived", [b1], "construction B") is None


@pytest.fixture(scope="module")
def spur_ltca():
    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0), Gear(z=40, m_n=3.0, b=20.0))
    L = LTCA(pair, n_slices=7)
    return L, L.slices(L.mesh_cycle(6))


def test_loaded_tca_with_the_structure_given_is_the_same_and_checks_it(spur_ltca):
    """``solve(slices=S, structure=LTCA.structure(S))`` gives the loaded TCA of ``solve(slices=S)`` bit for
    bit; a structure without slices, or that is not a ContactStructure, is refused naming ``structure``."""
    L, S = spur_ltca
    a = L.solve([50.0, 150.0], slices=S)
    b = L.solve([50.0, 150.0], slices=S, structure=L.structure(S))
    for ra, rb in zip(a.results, b.results):
        assert np.array_equal(ra.load, rb.load) and np.array_equal(ra.te_loaded, rb.te_loaded)
    with pytest.raises(ArgumentError) as e:
        L.solve(50.0, phi1=L.mesh_cycle(6), structure=L.structure(S))
    assert e.value.param == "structure"
    with pytest.raises(ArgumentError) as e:
        L.solve(50.0, slices=S, structure={"Cs": None})
    assert e.value.param == "structure"


def test_designs_at_the_same_positions_share_the_first_guesses(monkeypatch):
    """The slices' first guesses (the unmodified drive's conjugate sections) depend on the positions and
    the tool shifts x only: a second design at the same positions solves none, and its slices are bit
    for bit those of a solver that never saw the first design; another x solves them again."""
    from gearopt.contact import edge_guesses
    from gearopt.geometry.microgeometry import Microgeometry

    pair = GearPair(Gear(z=20, m_n=3.0, b=20.0, modifications=Microgeometry(C_alpha=0.005, C_beta=0.01)),
                    Gear(z=40, m_n=3.0, b=20.0))
    phi = LTCA(pair, n_slices=7).mesh_cycle(4)
    names = LTCA(pair, n_slices=7).tca.pinion.param_names
    solved = []
    orig = edge_guesses.conjugate_sections
    monkeypatch.setattr(edge_guesses, "conjugate_sections", lambda *a: solved.append(1) or orig(*a))
    L = LTCA(pair, n_slices=7)
    p1a = L.tca.pinion.p0.copy()
    p1b = p1a.copy()
    p1b[names.index("iso.C_alpha")] = 0.012
    p1b[names.index("iso.C_beta")] = 0.004
    L.slices(phi, p1a)
    Sb = L.slices(phi, p1b)
    assert len(solved) == 1
    fresh = LTCA(pair, n_slices=7).slices(phi, p1b)
    assert len(solved) == 2
    for name in ("te", "width", "r1", "n1", "lever1", "kappa1", "active"):
        assert np.array_equal(getattr(Sb, name), getattr(fresh, name), equal_nan=name != "active")
    p1c = p1b.copy()
    p1c[names.index("x")] = 0.05
    L.slices(phi, p1c)
    assert len(solved) == 3
