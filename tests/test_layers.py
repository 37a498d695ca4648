"""DESIGN.md's layer rule and "imports tell the truth", checked on the import graph of ``src/mckibben``.

The graph is built from the source (the AST of every module: its module-level imports and the
imports inside its functions), not from what happens to be loaded, so an import on a path no test
runs is checked too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "mckibben"

#: Modules every layer may import; they import only each other (errors, units, hardware facts,
#: size limits, files written atomically, the result base class, the kernel machinery).
BASE = {"mckibben", "errors", "files", "compile_notice", "_kernels", "_jit", "_lazy", "units", "hardware", "limits", "atomic",
        "results", "plotting"}

#: Layer of each package (DESIGN.md's picture, top to bottom): a module may import a lower layer,
#: never a higher one nor another package of its own layer (siblings: ``fit`` and ``plant``;
#: ``rig``, ``tool`` and ``export``).
LAYER = {
    "data": 1,
    "models": 2,
    "datasets": 3,
    "fit": 4, "plant": 4,
    "control": 5,
    "rig": 6, "export": 6,
    # the tool's MuJoCo engine drives the endoscope's muscles through the bridge (export.mujoco)
    "tool": 7,
    "experiments": 8,
    "sweep": 9, "report": 9, "doctor": 9, "examples": 9,
    "cli": 10,
}

#: The package's deferred imports of its own modules: (importing module, imported module) -> why.
DEFERRED_OWN = {
    ("mckibben._kernels", "mckibben._jit"): "loads Numba: the one place a cheap module reaches compiled code",
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


KNOWN = {_module_name(p) for p in PACKAGE.rglob("*.py")}


def _targets(module: str, node: ast.Import | ast.ImportFrom, is_package: bool, known=None) -> list[str]:
    """The modules an import statement names (``from a import b``: ``a.b`` if it is a module, else ``a``)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    base = node.module or ""
    if node.level:
        pkg = module.split(".") if is_package else module.split(".")[:-1]
        pkg = pkg[: len(pkg) - (node.level - 1)]
        base = ".".join(pkg + ([base] if base else []))
    known = KNOWN if known is None else known
    return sorted({f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names})


#: Every module of the package, parsed once: (name, is a package's __init__, syntax tree).
TREES = [(_module_name(path), path.name == "__init__.py", ast.parse(path.read_text(encoding="utf-8")))
         for path in sorted(PACKAGE.rglob("*.py"))]


def _imports() -> list[tuple[str, str, bool, int]]:
    """Every import of the package's own modules: (importer, imported, inside a function, line)."""
    known = KNOWN
    out = []
    for module, is_package, tree in TREES:
        in_function = set()
        for fn in ast.walk(tree):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                in_function.update(id(n) for n in ast.walk(fn) if isinstance(n, (ast.Import, ast.ImportFrom)))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            for target in _targets(module, node, is_package):
                if target in known and target != module:
                    out.append((module, target, id(node) in in_function, node.lineno))
    return out


def _layer(module: str) -> tuple[str, int | None]:
    """The module's package (``models``, ``errors``...) and its layer (None for a base module)."""
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else "mckibben"
    if top in BASE:
        return top, None
    assert top in LAYER, f"{module}: a package with no layer in this test's table (DESIGN.md): add it"
    return top, LAYER[top]


IMPORTS = _imports()


def test_the_graph_is_not_empty():
    """The walk found the package (a broken path would make every other test pass vacuously)."""
    assert len(IMPORTS) > 300
    assert ("mckibben.plant.params", "mckibben.models.muscle", False) in {(a, b, f) for a, b, f, _ in IMPORTS}


def test_no_function_level_import_of_the_packages_own_modules():
    """Imports of mckibben.* are at module level, so the graph is visible (DESIGN.md), but the documented deferral."""
    hidden = [f"{a}:{line} imports {b} inside a function" for a, b, inside, line in IMPORTS
              if inside and (a, b) not in DEFERRED_OWN]
    assert hidden == []


def _crossing(a: str, b: str) -> str | None:
    """Why module ``a`` may not reach module ``b`` (DESIGN.md's layer rule), or None if it may."""
    (pa, la), (pb, lb) = _layer(a), _layer(b)
    if pa == pb:
        return None
    if la is None and lb is not None:
        return f"a base module reaches the {pb} layer"
    if la is not None and lb is not None and lb >= la:
        return f"{pa} (layer {la}) may not reach {pb} (layer {lb})"
    return None


def test_every_import_goes_down_the_layers():
    bad = [f"{a}:{line} -> {b}: {why}" for a, b, _, line in IMPORTS if (why := _crossing(a, b))]
    assert bad == []


@pytest.mark.parametrize("importer, imported", [("mckibben.rig", "mckibben.tool"), ("mckibben.plant", "mckibben.fit"),
                                                ("mckibben.data", "mckibben.models"),
                                                ("mckibben.models", "mckibben.plant"),
                                                ("mckibben.control", "mckibben.rig")])
def test_the_crossings_design_md_names_are_absent(importer, imported):
    found = [(a, b) for a, b, _, _ in IMPORTS if (a == importer or a.startswith(importer + "."))
             and (b == imported or b.startswith(imported + "."))]
    assert found == []


def test_the_rule_catches_a_crossing():
    """The check itself fails on a module that imports upwards (the test can fail)."""
    assert _layer("mckibben.rig.device")[1] < _layer("mckibben.experiments.link")[1]
    assert _layer("mckibben.plant.params")[1] == _layer("mckibben.fit.core")[1]  # siblings: refused by ``>=``
    tree = ast.parse("def f():\n    from mckibben.tool import tracking\n")
    node = tree.body[0].body[0]
    assert _targets("mckibben.rig.device", node, False) == ["mckibben.tool.tracking"]
    bad = [(a, b) for a, b in [("mckibben.rig.device", "mckibben.tool.tracking")] if _crossing(a, b)]
    assert bad  # the rule refuses it


def test_the_deferred_import_is_the_documented_one():
    """The one deferral of the package's own code loads Numba and says so where it is written."""
    text = (PACKAGE / "_kernels.py").read_text(encoding="utf-8")
    line = next(x for x in text.splitlines() if "from mckibben import _jit" in x)
    assert "deferred" in line and "Numba" in line


def _named_modules() -> list[tuple[str, str, int]]:
    """Modules named in strings that the package resolves by name: the lazy maps of its packages
    (``_WHERE``: PEP 562) and ``"module:function"`` references (the controller registry's hooks).
    An exact string constant that is a known module, or a known module and ``:attribute``."""
    out = []
    for module, _, tree in TREES:
        if module == "mckibben":  # the top-level facade: it names the entry points of every layer by design
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                target = node.value.split(":", 1)[0]
                if target in KNOWN and target != module:
                    out.append((module, target, node.lineno))
    return out


NAMED = _named_modules()


def test_names_resolved_at_run_time_go_down_the_layers_too():
    """A lazy map or a registry hook that names a higher layer is an upward import made at first use
    (e.g. ``mckibben.control.step_response`` resolving to the experiment layer): refused like one."""
    assert any(a == "mckibben.control" and b == "mckibben.control.core" for a, b, _ in NAMED)  # the walk sees maps
    bad = [f"{a}:{line} names {b}: {why}" for a, b, line in NAMED if (why := _crossing(a, b))]
    assert bad == []


def test_no_controller_is_named_by_a_string():
    """The controller registry holds function objects: no ``"module:qualname"`` string in control/."""
    named = [(a, b, line) for a, b, line in NAMED if a.startswith("mckibben.control.") and a != "mckibben.control"]
    assert named == []


def _cycles(edges: set[tuple[str, str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    graph: dict[str, list[str]] = {}
    for a, b in edges:
        graph.setdefault(a, []).append(b)
        graph.setdefault(b, [])
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle_in_control():
    """No circle among the control package's modules, counting every import (``TYPE_CHECKING`` ones too):
    the controllers (``control/laws``) sit below the core and the registry that are built from them."""
    edges = {(a, b) for a, b, _, _ in IMPORTS if a.startswith("mckibben.control") and b.startswith("mckibben.control")}
    assert ("mckibben.control.step", "mckibben.control.laws.smc") in edges  # the walk sees the control package
    assert _cycles(edges) == []


def test_the_circle_check_finds_a_circle():
    """The check fails on the circle the registry once had (controllers -> core -> registry -> stsmc -> controllers)."""
    old = {("c.controllers", "c.core"), ("c.core", "c.registry"), ("c.registry", "c.stsmc"), ("c.stsmc", "c.controllers"),
           ("c.runs", "c.core")}
    assert _cycles(old) == [["c.controllers", "c.core", "c.registry", "c.stsmc"]]



def test_no_import_circle_in_the_package():
    """No circle anywhere in ``src/mckibben`` but through the one documented deferral (:data:`DEFERRED_OWN`)."""
    edges = {(a, b) for a, b, _, _ in IMPORTS if (a, b) not in DEFERRED_OWN}
    assert _cycles(edges) == []


def _defined(tree: ast.Module) -> list[str]:
    """The public names a module defines at its top level: functions, classes and assigned names
    (an import, ``from x import name``, defines nothing: it names the one definition)."""
    out = []
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.append(node.name)
        elif isinstance(node, ast.Assign):
            out += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out.append(node.target.id)
    return [n for n in out if not n.startswith("_")]


def _defined_twice(trees) -> dict[str, list[str]]:
    where: dict[str, list[str]] = {}
    for module, _, tree in trees:
        for name in _defined(tree):
            where.setdefault(name, []).append(module)
    return {name: mods for name, mods in where.items() if len(mods) > 1}


#: Packages whose grab-bags were split (issue 34): each public name is defined in one of their modules,
#: and the old homes (``data.io``, ``plant.params``) import what moved.
SPLIT = ("mckibben.data", "mckibben.plant")


@pytest.mark.parametrize("package", SPLIT)
def test_no_public_name_is_defined_twice_in_the_split_packages(package):
    trees = [t for t in TREES if t[0] == package or t[0].startswith(package + ".")]
    assert len(trees) >= 5  # the walk sees the package's modules
    assert _defined_twice(trees) == {}


def test_the_old_homes_still_import_what_moved():
    """``mckibben.data.io`` and ``mckibben.plant.params`` define none of the moved names and still give each."""
    import mckibben.data.io as io
    import mckibben.plant.params as params

    for old, names in ((io, io.__all__), (params, ("Col", "NP", "derive", "validate", "check_force_law", "Load", "G"))):
        for name in names:
            value = getattr(old, name)
            home = getattr(value, "__module__", None)
            if home is not None and callable(value):
                assert home != old.__name__, f"{old.__name__}.{name} is defined there, not imported"
    tree = next(t for m, _, t in TREES if m == "mckibben.data.io")
    assert _defined(tree) == []  # io.py defines nothing public


def test_the_twice_check_finds_a_name_defined_twice():
    a = ast.parse("def read_table(path):\n    pass\nfrom x import Table\n")
    b = ast.parse("read_table = None\nTable = 1\n")
    assert _defined_twice([("p.a", False, a), ("p.b", False, b)]) == {"read_table": ["p.a", "p.b"]}
