"""Type hints on the public API: every public function and method (no leading underscore, in a
public class) of every gearopt module annotates each parameter (``self``/``cls`` excepted) and its
return. The check reads the source (``ast``), so it imports nothing; one test per module, so a
failure names the module and lists its unannotated functions."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent / "gearopt"
MODULES = sorted(p.relative_to(ROOT.parent).with_suffix("").as_posix().replace("/", ".")
                 for p in ROOT.rglob("*.py"))


def _public(name: str) -> bool:
    """A public function or method; ``__init__`` too (its parameters are the constructor's)."""
    return not name.startswith("_") or name == "__init__"


def missing_hints(source: str) -> list[str]:
    """``qualname: what is missing`` of every public function or method of ``source`` whose
    parameters or return lack an annotation (``__init__`` needs no return annotation)."""
    out = []

    def visit(node, prefix: str, in_class: bool):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                if not child.name.startswith("_"):
                    visit(child, f"{prefix}{child.name}.", True)
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if not _public(child.name):
                    continue
                a = child.args
                params = a.posonlyargs + a.args + a.kwonlyargs
                static = any(isinstance(d, ast.Name) and d.id == "staticmethod" for d in child.decorator_list)
                if in_class and not static and params and params[0].arg in ("self", "cls"):
                    params = params[1:]
                params += [p for p in (a.vararg, a.kwarg) if p is not None]
                bad = [p.arg for p in params if p.annotation is None]
                if child.returns is None and child.name != "__init__":
                    bad.append("return")
                if bad:
                    out.append(f"{prefix}{child.name}: {', '.join(bad)}")

    visit(ast.parse(source), "", False)
    return out


def test_the_check_finds_a_missing_hint():
    src = ("def f(a: int, b) -> int: ...\n"
           "def g(a: int) : ...\n"
           "def _h(a): ...\n"
           "class C:\n"
           "    def __init__(self, x): ...\n"
           "    def m(self, y: int) -> None: ...\n"
           "    @staticmethod\n"
           "    def s(self) -> None: ...\n"
           "class _D:\n"
           "    def m(self, y): ...\n")
    assert missing_hints(src) == ["f: b", "g: return", "C.__init__: x", "C.s: self"]


@pytest.mark.parametrize("module", MODULES)
def test_public_functions_are_annotated(module):
    path = ROOT.parent / (module.replace(".", "/") + ".py")
    bad = missing_hints(path.read_text())
    assert not bad, f"{module}: public functions without full type hints:\n  " + "\n  ".join(bad)
