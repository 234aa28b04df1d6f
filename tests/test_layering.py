"""The import graph of gearopt (docs/architecture.md, "Layers").

Every module of the package is parsed with ``ast``; its imports, at module level and inside
functions (imports under ``if TYPE_CHECKING:`` are typing only and never executed, so they are left
out), give a graph of modules and one of layers. The tests assert:

* no import cycle between modules, and none between layers;
* the layer order of ``LAYERS``: a module imports only from its own layer or the layers below;
* no private name (``_x``) imported from another module;
* only the CLI picks the matplotlib backend (``test_plot_lint.py`` scans the sources for
  ``matplotlib.use(``; here the call is found in the syntax tree, whatever the alias).

Each check is a function of a graph, so the tests also feed it a planted violation and
see it fail.
"""

from __future__ import annotations

import ast
import functools
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "gearopt"

# Layers from the bottom up (docs/architecture.md, "Layers"). A module belongs to the entry that is the
# longest prefix of its dotted name (``gearopt.fea.model`` -> ``gearopt.fea``, ``gearopt.io.scene`` ->
# ``gearopt.io.scene``); it may import from its own layer and any lower one. The top of the library is
# a DAG (plot and io.schema / io.results do not import each other); this list is one order of it.
LAYERS: list[tuple[str, ...]] = [
    # base: no gearopt imports except among themselves
    ("gearopt.errors", "gearopt.units", "gearopt.version", "gearopt.types", "gearopt.report", "gearopt.progress",
     "gearopt.compiled", "gearopt.compile_cache", "gearopt.compile_queue", "gearopt.schema", "gearopt.settings", "gearopt.summary", "gearopt.warning_log",
     "gearopt.forking", "gearopt.graph_cache"),
    ("gearopt.geometry",),       # basic rack, tools, surfaces (envelope, generation), micro-geometry
    ("gearopt.gears",),          # gear data (ISO 21771): a Gear holds its tool and micro-geometry
    ("gearopt.meshing",),        # TCA
    ("gearopt.contact",),        # edge contact, Hertz
    ("gearopt.fea",),            # finite elements (influence grids for the loaded TCA)
    ("gearopt.ltca",),           # loaded TCA
    ("gearopt.synthesis",),      # optimisation of settings and micro-geometry
    ("gearopt.robust",),         # Monte Carlo, sweeps
    ("gearopt.rating",),         # ISO 6336 load capacity (factors from gear data or from ltca results)
    ("gearopt.dynamics",),       # gear dynamics driven by the loaded TCA
    ("gearopt.plot",),           # plots read result dictionaries
    ("gearopt.io.schema",),      # scene schema (fields, sections, tool sections)
    ("gearopt.io.page",),        # report.html renderer (Jinja2)
    ("gearopt.io.results",),     # results.json writer
    ("gearopt.studies",),        # what a scene may ask for: builds, runs, plots
    ("gearopt.io.scene",),       # the scene loader consults the studies registry
    ("gearopt.io",),             # the io package's __init__
    ("gearopt",),                # the package root (re-exports)
    ("gearopt.cli", "gearopt.cli_plots", "gearopt.__main__"),  # the command line
]
TOP = ("gearopt.studies", "gearopt.plot", "gearopt.io", "gearopt.cli")
LIBRARY_BELOW_TOP = ("gearopt.gears", "gearopt.geometry", "gearopt.meshing", "gearopt.contact", "gearopt.fea",
                     "gearopt.ltca", "gearopt.synthesis", "gearopt.robust", "gearopt.rating",
                     "gearopt.dynamics")


@dataclass
class Import:
    importer: str      # module name of the file
    module: str        # module imported from (resolved, absolute)
    names: tuple       # names imported by ``from module import names`` (empty for ``import module``)
    line: int
    in_function: bool = False


@dataclass
class Graph:
    modules: dict[str, Path] = field(default_factory=dict)
    imports: list[Import] = field(default_factory=list)
    backend_calls: list[tuple[str, int]] = field(default_factory=list)


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(node: ast.AST) -> bool:
    test = getattr(node, "test", None)
    return isinstance(node, ast.If) and (getattr(test, "id", None) == "TYPE_CHECKING"
                                         or getattr(test, "attr", None) == "TYPE_CHECKING")


def parse_module(name: str, source: str, is_package: bool, graph: Graph) -> None:
    """Add the imports and ``matplotlib.use`` calls of one module's source to ``graph``."""
    tree = ast.parse(source)
    package = name if is_package else name.rpartition(".")[0]
    mpl_aliases = {"matplotlib"}

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if _is_type_checking(child):
                for sub in child.orelse:   # the ``else`` branch runs
                    visit(ast.Module(body=[sub], type_ignores=[]), in_function)
                continue
            inner = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            if isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")[:len(package.split(".")) - child.level + 1]
                    mod = ".".join(base + ([child.module] if child.module else []))
                else:
                    mod = child.module or ""
                graph.imports.append(Import(name, mod, tuple(a.name for a in child.names), child.lineno, in_function))
            elif isinstance(child, ast.Import):
                for a in child.names:
                    graph.imports.append(Import(name, a.name, (), child.lineno, in_function))
                    if a.name == "matplotlib":
                        mpl_aliases.add(a.asname or "matplotlib")
            elif isinstance(child, ast.Call):
                f = child.func
                if (isinstance(f, ast.Attribute) and f.attr == "use" and isinstance(f.value, ast.Name)
                        and f.value.id in mpl_aliases):
                    graph.backend_calls.append((name, child.lineno))
                elif isinstance(f, ast.Attribute) and f.attr == "switch_backend":  # pyplot.switch_backend
                    graph.backend_calls.append((name, child.lineno))
            visit(child, inner)

    visit(tree, False)


def build_graph(pkg: Path = PKG) -> Graph:
    graph = Graph()
    for path in sorted(pkg.rglob("*.py")):
        name = module_name(path, pkg.parent)
        graph.modules[name] = path
        parse_module(name, path.read_text(encoding="utf-8"), path.name == "__init__.py", graph)
    return graph


def resolve(imp: Import, modules) -> list[tuple[str, str | None]]:
    """The gearopt modules an import reaches, each with the imported name when that name is not
    itself a module (``from .a import b`` reaches module ``a.b`` when b is a submodule)."""
    if not (imp.module == "gearopt" or imp.module.startswith("gearopt.")):
        return []
    if not imp.names:
        return [(imp.module, None)]
    out = []
    for n in imp.names:
        sub = f"{imp.module}.{n}"
        out.append((sub, None) if sub in modules else (imp.module, n))
    return out


def module_edges(graph: Graph) -> dict[str, set[str]]:
    """importer -> modules imported (self-imports dropped; a package's ``__init__`` counts as the
    package module itself)."""
    edges: dict[str, set[str]] = {m: set() for m in graph.modules}
    for imp in graph.imports:
        for target, _ in resolve(imp, graph.modules):
            if target != imp.importer:
                edges[imp.importer].add(target)
    return edges


def layer_of(module: str) -> int:
    best, rank = -1, None
    for i, group in enumerate(LAYERS):
        for prefix in group:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
                best, rank = len(prefix), i
    if rank is None:
        raise AssertionError(f"module {module} has no layer in LAYERS (tests/test_layering.py)")
    return rank


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph, as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def dfs(v: str) -> list[str] | None:
        state[v] = 1
        stack.append(v)
        for w in sorted(edges.get(v, ())):
            if state.get(w) == 1:
                return stack[stack.index(w):] + [w]
            if w not in state:
                found = dfs(w)
                if found:
                    return found
        stack.pop()
        state[v] = 2
        return None

    for v in sorted(edges):
        if v not in state:
            found = dfs(v)
            if found:
                return found
    return None


def unit_of(module: str) -> str:
    """The layer unit a module belongs to: the longest prefix of ``LAYERS`` that names it
    (``gearopt.fea.model`` -> ``gearopt.fea``; ``gearopt.io.scene`` -> ``gearopt.io.scene``: the three
    modules of ``gearopt.io`` sit at different heights, schema < studies < scene)."""
    best = ""
    for group in LAYERS:
        for prefix in group:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > len(best):
                best = prefix
    return best or module


def package_edges(graph: Graph) -> dict[str, set[str]]:
    """The import graph between layer units (packages, and the top-level modules on their own)."""
    out: dict[str, set[str]] = {}
    for a, targets in module_edges(graph).items():
        ua = unit_of(a)
        out.setdefault(ua, set())
        for b in targets:
            ub = unit_of(b)
            # a package's __init__ re-exporting its submodules is the package itself
            if ub != ua and not b.startswith(a + "."):
                out[ua].add(ub)
    return out


def import_cycles(graph: Graph) -> list[list[str]]:
    return [c for c in (find_cycle(module_edges(graph)), find_cycle(package_edges(graph))) if c]


def layer_violations(graph: Graph) -> list[str]:
    bad = []
    for imp in graph.imports:
        for target, _ in resolve(imp, graph.modules):
            if target == imp.importer:
                continue
            # a package's __init__ importing from its own submodules is the package re-exporting them
            if target.startswith(imp.importer + "."):
                continue
            if layer_of(target) > layer_of(imp.importer):
                bad.append(f"{imp.importer}:{imp.line} imports {target} (layer {LAYERS[layer_of(target)][0]} is above "
                           f"{LAYERS[layer_of(imp.importer)][0]})")
    return bad


def top_violations(graph: Graph) -> list[str]:
    """The library below the top never imports studies, plot, io or the CLI; plot never imports
    studies, io or the CLI."""
    bad = []
    rules = [(LIBRARY_BELOW_TOP, TOP), (("gearopt.plot",), ("gearopt.studies", "gearopt.io", "gearopt.cli"))]
    for imp in graph.imports:
        for target, _ in resolve(imp, graph.modules):
            for importers, forbidden in rules:
                if (any(imp.importer == p or imp.importer.startswith(p + ".") for p in importers)
                        and any(target == f or target.startswith(f + ".") for f in forbidden)):
                    bad.append(f"{imp.importer}:{imp.line} imports {target}")
    return bad


def private_imports(graph: Graph) -> list[str]:
    bad = []
    for imp in graph.imports:
        for target, name in resolve(imp, graph.modules):
            if name and name.startswith("_") and not name.startswith("__") and target != imp.importer:
                bad.append(f"{imp.importer}:{imp.line} imports {name} from {target}")
    return bad


def backend_violations(graph: Graph) -> list[str]:
    return [f"{m}:{line}" for m, line in graph.backend_calls if m != "gearopt.cli"]


@pytest.fixture(scope="module")
def graph() -> Graph:
    return build_graph()


# --- the package as it is --------------------------------------------------------------------------
def test_every_module_has_a_layer(graph):
    for m in graph.modules:
        layer_of(m)


def test_no_import_cycle(graph):
    assert import_cycles(graph) == []


def test_layer_order(graph):
    assert layer_violations(graph) == []


def test_library_never_imports_studies_plot_io_cli(graph):
    assert top_violations(graph) == []


def test_no_private_name_imported_across_modules(graph):
    assert private_imports(graph) == []


def test_only_the_cli_picks_the_matplotlib_backend(graph):
    assert backend_violations(graph) == []


def test_the_graph_sees_function_level_imports(graph):
    # the parser must see imports inside functions (the cycles used to hide there)
    assert any(i.in_function for i in graph.imports)


# --- planted violations: each check fails on them -----------------------------------------------------
# Each test adds one module (or imports to an existing one) to the graph of the package as it is and
# asserts that the check reports exactly the planted import.
@functools.lru_cache(maxsize=1)
def _base() -> Graph:
    return build_graph()


def _planted(name: str, source: str, is_package: bool = False) -> Graph:
    b = _base()
    g = Graph(dict(b.modules), list(b.imports), list(b.backend_calls))
    g.modules.setdefault(name, PKG / "planted.py")
    parse_module(name, source, is_package, g)
    return g


def _new(check, planted: Graph) -> list:
    before = check(_base())
    return [v for v in check(planted) if v not in before]


def test_a_planted_cycle_is_found():
    # gears imports geometry.tools (a Gear holds its tool); a function-level import back closes a cycle
    g = _planted("gearopt.geometry.tools", "def f():\n    from ..gears import Gear\n")
    # (the cycle is reported from whichever of its modules the search reaches first)
    assert ["gearopt.gears", "gearopt.geometry.tools", "gearopt.gears"] in import_cycles(g) or \
        ["gearopt.geometry.tools", "gearopt.gears", "gearopt.geometry.tools"] in import_cycles(g)


def test_a_planted_package_cycle_is_found():
    # fea.model -> ltca.compliance, while ltca.engine imports fea.influence: no module cycle, a package one
    g = _planted("gearopt.fea.model", "from ..ltca.compliance import Material\n")
    assert ["gearopt.fea", "gearopt.ltca", "gearopt.fea"] in import_cycles(g) or \
        ["gearopt.ltca", "gearopt.fea", "gearopt.ltca"] in import_cycles(g)


def test_a_typing_only_import_is_not_an_edge():
    g = _planted("gearopt.geometry.generation", "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                 "    from ..gears import Gear\n")
    assert import_cycles(g) == [] and _new(layer_violations, g) == []


def test_a_planted_upward_import_is_refused():
    g = _planted("gearopt.fea.planted", "def f():\n    from ..synthesis.crowning import CrowningOptimizer\n")
    assert _new(layer_violations, g) == ["gearopt.fea.planted:2 imports gearopt.synthesis.crowning (layer "
                                         "gearopt.synthesis is above gearopt.fea)"]


def test_a_planted_import_of_the_root_is_refused():
    # results.json's version comes from gearopt.version, not from the package root
    g = _planted("gearopt.io.results", "def f():\n    from .. import __version__\n")
    assert _new(layer_violations, g) == ["gearopt.io.results:2 imports gearopt (layer gearopt is above "
                                         "gearopt.io.results)"]


def test_a_planted_library_import_of_plot_or_studies_is_refused():
    g = _planted("gearopt.robust.planted", "def f():\n    from ..plot.robust import save_plots\n")
    assert _new(top_violations, g) == ["gearopt.robust.planted:2 imports gearopt.plot.robust"]
    g = _planted("gearopt.plot.planted", "from ..studies.tca import TCAStudy\n")
    assert _new(top_violations, g) == ["gearopt.plot.planted:1 imports gearopt.studies.tca"]


def test_a_planted_private_import_is_refused():
    g = _planted("gearopt.fea.planted", "from .mesh import _hidden\n")
    assert _new(private_imports, g) == ["gearopt.fea.planted:1 imports _hidden from gearopt.fea.mesh"]


def test_a_planted_backend_call_is_refused():
    g = _planted("gearopt.plot.planted", "import matplotlib as mpl\n\ndef f():\n    mpl.use('Agg')\n")
    assert _new(backend_violations, g) == ["gearopt.plot.planted:4"]


def test_a_planted_switch_backend_call_is_refused():
    g = _planted("gearopt.plot.planted", "import matplotlib.pyplot as plt\n\ndef f():\n    plt.switch_backend('Agg')\n")
    assert _new(backend_violations, g) == ["gearopt.plot.planted:4"]
