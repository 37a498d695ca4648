"""The shape of the public API: exports, a CLI that only parses, calls and prints, and no cycles upward.

The command line is a thin shell over the library (DESIGN.md, "Library first"): no ``cli/``
module may import another module's private names or reach into the simulator and the controller
core itself; ``report/`` sits below the CLI and never imports it.
"""

from __future__ import annotations

import ast
import importlib
import pathlib

import pytest

import mckibben

SRC = pathlib.Path(mckibben.__file__).parent
CLI_FILES = sorted((SRC / "cli").glob("*.py"))

#: What running an experiment looks like: the CLI calls a library function that does it.
EXPERIMENT_CALLS = {"run_closed_loop", "simulate", "core_spec", "step_reference", "smc_core_params", "pid_params",
                    "sample_plants", "simulate_tracking", "tip_reference", "fit_step_response", "step_metrics",
                    "tracking_metrics", "open_loop_step", "fit_kinematic", "fit_cubics", "fit_surface", "fit_spring",
                    "fit_chou_hannaford", "fit_tondu_lopez", "fit_first_order", "compare_models", "fit_lift_off",
                    "characterize", "write_report"}


def _imports(path: pathlib.Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                yield node.module, alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, None


@pytest.mark.parametrize("path", CLI_FILES, ids=lambda p: p.name)
def test_cli_modules_use_only_public_library_names(path):
    for module, name in _imports(path):
        if not module.startswith("mckibben") or module.startswith("mckibben.cli"):
            continue
        parts = module.split(".")
        assert not any(p.startswith("_") for p in parts), f"{path.name} imports private module {module}"
        private = name is not None and name.startswith("_") and not name.startswith("__")
        assert not private, f"{path.name} imports private {module}.{name}"


@pytest.mark.parametrize("path", CLI_FILES, ids=lambda p: p.name)
def test_cli_modules_hold_no_experiment(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    called = {n.func.id if isinstance(n.func, ast.Name) else n.func.attr
              for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, (ast.Name, ast.Attribute))}
    assert not called & EXPERIMENT_CALLS, f"{path.name} runs {sorted(called & EXPERIMENT_CALLS)} itself"
    assert "use" not in {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and
                         isinstance(n.value, ast.Name) and n.value.id == "matplotlib"}


def test_library_never_switches_the_matplotlib_backend():
    for path in SRC.rglob("*.py"):
        assert "matplotlib.use(" not in path.read_text(encoding="utf-8"), path


def test_report_does_not_import_the_cli():
    for path in (SRC / "report").glob("*.py"):
        for module, _ in _imports(path):
            assert not module.startswith("mckibben.cli"), f"{path.name} imports {module}"


@pytest.mark.parametrize("package", ["mckibben", "mckibben.models", "mckibben.control", "mckibben.rig",
                                     "mckibben.report", "mckibben.tool", "mckibben.sweep", "mckibben.results",
                                     "mckibben.units"])
def test_public_names_are_exported_and_exist(package):
    mod = importlib.import_module(package)
    names = getattr(mod, "__all__", None)
    assert names, f"{package} exports nothing"
    for name in names:
        assert getattr(mod, name) is not None, f"{package}.{name}"
