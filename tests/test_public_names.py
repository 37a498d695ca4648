"""No public name is defined twice in the control, experiment and tool layers (issue 23).

A newcomer who reads ``fig13`` or ``track`` in two modules cannot tell which one the command line
runs. The walk reads the source (the AST of every module of ``mckibben.control``,
``mckibben.experiments`` and ``mckibben.tool``), so a module no test imports is checked too.

The one exception is the controller registry's hooks: a controller's file (``control/laws/<name>.py``)
names its law, its coefficients, its float reference and its design with the registry's protocol
names (``law``, ``derive``, ``float_command``, ``design``...), reached through its entry
(``spec.derive``), never imported by name; a second controller's file has the same names by design.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

from mckibben.control import registry as R

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "mckibben"
#: The layers whose public names a user reads side by side.
LAYERS = ("control", "experiments", "tool")
#: The fields of a registry entry that hold a function.
HOOKS = ("law", "design", "candidates", "describe", "derive", "float_law")


def _module(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _registry_hooks() -> set[tuple[str, str]]:
    """(module, name) of every function a registry entry names."""
    out = set()
    for spec in R.CONTROLLERS.values():
        for field in HOOKS:
            func = getattr(spec, field)
            if func is not None:
                out.add((func.__module__, func.__qualname__))
    return out


def public_definitions(sources: dict[str, str]) -> dict[str, list[str]]:
    """Public function and class name -> the modules that define it at module level.

    Parameters
    ----------
    sources : dict of str to str
        Module name -> its source. [-]
    """
    hooks = _registry_hooks()
    found: dict[str, list[str]] = defaultdict(list)
    for module, text in sorted(sources.items()):
        for node in ast.parse(text).body:
            if (isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
                    and not node.name.startswith("_") and (module, node.name) not in hooks):
                found[node.name].append(module)
    return found


SOURCES = {_module(p): p.read_text(encoding="utf-8") for layer in LAYERS for p in (PACKAGE / layer).rglob("*.py")}


def test_the_walk_sees_the_layers():
    """The walk found the experiments (a broken path would make the next test pass vacuously)."""
    found = public_definitions(SOURCES)
    assert found["step_response"] == ["mckibben.experiments.pressure"]
    assert found["track_over_link"] == ["mckibben.experiments.link"]
    assert "make_tool" in found and len(SOURCES) > 15


def test_no_public_name_is_defined_in_two_modules():
    twice = {name: modules for name, modules in public_definitions(SOURCES).items() if len(modules) > 1}
    assert twice == {}


def test_the_rule_catches_a_name_defined_twice():
    """The check fails on two modules that define the same public function (the test can fail)."""
    twice = public_definitions({"mckibben.control.a": "def fig13():\n    pass\n",
                                "mckibben.control.b": "def fig13():\n    pass\ndef _private():\n    pass\n"})
    assert twice["fig13"] == ["mckibben.control.a", "mckibben.control.b"] and "_private" not in twice


def test_a_registry_hook_is_not_a_public_name():
    """A controller module's ``derive`` is the registry's protocol, not a second ``core_params.derive``."""
    modules = ("mckibben.control.core_params", *(c.derive.__module__ for c in R.EXTENSIONS))
    found = public_definitions({m: SOURCES[m] for m in modules})
    assert found["derive"] == ["mckibben.control.core_params"]
