"""No public name is defined twice in ``src/mckibben``, but a registry's hooks (issues 23 and 34).

A reader who meets ``BAUD``, ``derive`` or ``MODES`` in two modules cannot tell whether they are
one fact written twice (which drifts) or two things under one name (which misleads). So every
public module-level name — a function, a class, an assigned name, each name of a tuple
assignment — is defined in one module; every other module imports it (an import names the one
definition, it defines nothing). The walk reads the source (the AST of every module), so a module
no test imports is checked too.

The exceptions are structural, never a list of names:

- **A registry's hooks**, only inside its registry package. A file of a registry package
  (:data:`REGISTRIES`: ``models/laws/<law>.py`` defines ``LAW``, ``control/laws/<name>.py``
  defines ``CONTROLLER``) names what its entry holds with the registry's protocol names: a second
  file has the same names by design. A name is a hook of that file when it *is* the entry, or its
  value is held by the entry (``fit_spec=fit_spec``, ``gains=GAINS``, one level down in a mapping:
  ``grid={"stsmc": GRID}``), or it is the constant of the entry's attribute of the same name
  (``MODE == CONTROLLER.mode``, ``NAME == LAW.name``). The registry's files count as one
  definition: the same name anywhere else is a second.
- **The command line's parts that Typer registers**: a function a Typer app of ``mckibben.cli``
  registers as a command (``step_cmd`` of ``control step`` and of ``rig step``) and an option or
  argument object (``PMAX_OPTION`` of each group, with its own default and help).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
from collections import defaultdict
from pathlib import Path

import typer
import typer.models

import mckibben.cli

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "mckibben"
#: The registry packages: package -> the entry each of its files defines (what the registry discovers).
REGISTRIES = {"mckibben.models.laws": "LAW", "mckibben.control.laws": "CONTROLLER"}


def _module(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


SOURCES = {_module(p): p.read_text(encoding="utf-8") for p in sorted(PACKAGE.rglob("*.py"))}


def _names(target: ast.expr) -> list[str]:
    if isinstance(target, ast.Name):
        return [target.id]
    if isinstance(target, (ast.Tuple, ast.List)):
        return [n for t in target.elts for n in _names(t)]
    if isinstance(target, ast.Starred):
        return _names(target.value)
    return []


def defined(text: str) -> list[str]:
    """The public names a module's source defines at its top level (imports define nothing).

    Parameters
    ----------
    text : str
        A module's source. [-]
    """
    out: list[str] = []
    for node in ast.parse(text).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.append(node.name)
        elif isinstance(node, ast.Assign):
            out += [n for t in node.targets for n in _names(t)]
        elif isinstance(node, ast.AnnAssign):
            out += _names(node.target)
    return [n for n in out if not n.startswith("_")]


def _held(entry) -> tuple[list, dict]:
    """What a registry entry holds: its fields' and properties' values (and one level down), and those by name."""
    by_name = {f.name: getattr(entry, f.name) for f in dataclasses.fields(entry)}
    by_name |= {k: getattr(entry, k) for k, v in vars(type(entry)).items() if isinstance(v, property)}
    values = list(by_name.values())
    for v in list(values):
        if isinstance(v, dict):
            values += list(v.values())
        elif isinstance(v, (tuple, list)):
            values += list(v)
    return values, by_name


def _plain(obj):
    """A compiled kernel's Python function (once Numba is loaded, a kernel file's global is its dispatcher)."""
    return getattr(obj, "py_func", obj)


def _registry_of(module: str) -> str | None:
    """The registry package whose file ``module`` is (a direct, public module of it), or None."""
    package, _, stem = module.rpartition(".")
    return package if package in REGISTRIES and not stem.startswith("_") else None


def _cli_parts() -> set[int]:
    """ids of every command function a Typer app of the command line registers."""
    out, apps = set(), [mckibben.cli.app]
    while apps:
        app = apps.pop()
        out.update(id(c.callback) for c in app.registered_commands)
        apps += [g.typer_instance for g in app.registered_groups]
    return out


CLI_COMMANDS = _cli_parts()


def exemption(module: str, name: str) -> str | None:
    """Why ``module``'s definition of ``name`` may share its name: ``"hook of <package>"``, ``"cli"`` or None.

    Parameters
    ----------
    module, name : str
        A module of the package and a public name its source defines. [-]
    """
    try:
        mod = importlib.import_module(module)
    except ImportError:  # a planted module of the tests below: no exemption
        return None
    if not hasattr(mod, name):
        return None
    value = getattr(mod, name)
    registry = _registry_of(module)
    if registry is not None:
        entry = getattr(mod, REGISTRIES[registry], None)
        if entry is not None:
            values, by_name = _held(entry)
            same = by_name.get(name.lower(), dataclasses.MISSING)
            scalar = isinstance(value, (bool, int, float, str))  # by value only under the attribute's own name
            if (name == REGISTRIES[registry] or (not scalar and any(_plain(value) is _plain(v) for v in values))
                    or (scalar and type(value) is type(same) and value == same)):
                return f"hook of {registry}"
    if module == "mckibben.cli" or module.startswith("mckibben.cli."):
        if isinstance(value, typer.models.ParameterInfo) or id(value) in CLI_COMMANDS:
            return "cli"
    return None


def defined_twice(sources: dict[str, str]) -> dict[str, list[str]]:
    """Public name -> its definitions, where it is defined twice outside the exemptions.

    A registry's hooks count as one definition per registry package (listed as the package);
    the command line's registered parts do not count.

    Parameters
    ----------
    sources : dict of str to str
        Module name -> its source. [-]
    """
    where: dict[str, list[str]] = defaultdict(list)
    for module, text in sorted(sources.items()):
        for name in defined(text):
            why = exemption(module, name)
            if why == "cli":
                continue
            place = why.removeprefix("hook of ") if why else module
            if place not in where[name]:
                where[name].append(place)
    return {name: places for name, places in where.items() if len(places) > 1}


def test_the_walk_sees_the_package():
    """The walk reads every module and recognises each exemption (a broken walk would pass vacuously)."""
    assert len(SOURCES) > 150
    assert "BAUD" in defined(SOURCES["mckibben.hardware"])
    assert "TS_US_MIN" in defined(SOURCES["mckibben.hardware"])  # a name of a tuple assignment
    assert exemption("mckibben.control.laws.stsmc", "MODE") == "hook of mckibben.control.laws"  # MODE == spec.mode
    assert exemption("mckibben.control.laws.stsmc", "GRID") == "hook of mckibben.control.laws"  # in spec.grid
    assert exemption("mckibben.control.laws.pid", "design") == "hook of mckibben.control.laws"
    assert exemption("mckibben.models.laws.hunt_quinn", "NAME") == "hook of mckibben.models.laws"  # == LAW.name
    assert exemption("mckibben.models.laws.spring", "fit_spec") == "hook of mckibben.models.laws"
    assert exemption("mckibben.cli.tool", "PMAX_OPTION") == "cli"
    assert exemption("mckibben.cli.rig", "step_cmd") == "cli"
    # not exempt: the constants a law file keeps for itself, a helper of the command line, the core's derive
    assert exemption("mckibben.models.laws.relative_strain", "RS_FULL_NAMES") is None
    assert exemption("mckibben.cli._common", "option_flags") is None
    assert exemption("mckibben.control.core_params", "derive_core") is None


def test_no_public_name_is_defined_twice():
    assert defined_twice(SOURCES) == {}


def test_the_check_catches_a_planted_duplicate():
    """A name written a second time is reported, wherever it is planted (the test can fail)."""
    planted = dict(SOURCES)
    planted["mckibben.rig.planted"] = "BAUD = 115_200\n"  # a second copy of a hardware fact
    assert defined_twice(planted) == {"BAUD": ["mckibben.hardware", "mckibben.rig.planted"]}


def test_a_hook_name_is_allowed_only_inside_its_registry():
    """A hook's name outside its registry package is a second definition; inside it, a file's own
    constant that its entry does not hold is one too; a helper of the command line is no option."""
    outside = dict(SOURCES)
    outside["mckibben.control.planted"] = "def design(model):\n    pass\n"
    assert defined_twice(outside) == {"design": ["mckibben.control.laws", "mckibben.control.planted"]}
    inside = dict(SOURCES)
    for law in ("relative_strain", "virtual_work"):  # the same fraction written in two law files
        inside[f"mckibben.models.laws.{law}"] += "\nEND_FRACTION = 0.5\n"
    assert defined_twice(inside) == {"END_FRACTION": ["mckibben.models.laws._base", "mckibben.models.laws.relative_strain",
                                                      "mckibben.models.laws.virtual_work"]}
    cli = dict(SOURCES)
    cli["mckibben.cli.planted"] = "def option_flags(command):\n    pass\n"
    assert defined_twice(cli) == {"option_flags": ["mckibben.cli._common", "mckibben.cli.planted"]}
