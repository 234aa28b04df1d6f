"""gearopt.types: the type aliases of the annotations. The library imports them only under ``if TYPE_CHECKING:``
(never executed), so a misspelt or removed alias would go unnoticed at run time: every such import must name
an alias the module defines, and the aliases must admit the values their docs promise."""

from __future__ import annotations

import ast
import typing
from pathlib import Path

import casadi as ca
import numpy as np

import gearopt.types as types

PACKAGE = Path(__file__).resolve().parents[1] / "gearopt"


def types_imports(root: Path = PACKAGE) -> list[tuple[str, str]]:
    """(module path, name) of every ``from ..types import name`` / ``from gearopt.types import name`` in the package."""
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module == "types" and node.level > 0
                                                     or node.module == "gearopt.types"):
                found += [(path.relative_to(root.parent).as_posix(), a.name) for a in node.names]
    return found


def test_every_typing_import_names_an_alias_of_gearopt_types():
    """Each name the package imports from gearopt.types is one of its ``__all__`` and exists there."""
    found = types_imports()
    assert len({p for p, _ in found}) >= 5  # the geometry and contact modules annotate with them
    bad = [(p, n) for p, n in found if n not in types.__all__ or not hasattr(types, n)]
    assert not bad, bad


def test_the_aliases_admit_the_values_they_document():
    """``Expr``: a number, a NumPy array or a CasADi SX / MX / DM; ``Param`` also None (the tooth's own p0)."""
    expr = typing.get_args(types.Expr)
    for v in (1.5, np.zeros(3), ca.SX.sym("x"), ca.MX.sym("x"), ca.DM(2.0)):
        assert isinstance(v, expr), type(v)
    assert not isinstance("1.5", expr)
    param = typing.get_args(types.Param)
    assert type(None) in param and {ca.SX, ca.MX, ca.DM} <= set(param)
    assert set(typing.get_args(types.ArrayLike)) <= set(param)  # every array-like value of NumPy's
