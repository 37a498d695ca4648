"""Documentation meta-tests: doctested examples run, and every public argument is documented."""

import doctest
import importlib
import inspect
import pkgutil
import re

import pytest

import mckibben

MODEL_MODULES = ["mckibben.units", "mckibben.models.kinematic", "mckibben.models.mpam", "mckibben.models.physical",
                 "mckibben.models.spring", "mckibben.models.static"]


@pytest.mark.parametrize("name", MODEL_MODULES)
def test_doctests(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0  # a module listed here has examples, and they ran


def _public_functions():
    for info in pkgutil.walk_packages(mckibben.__path__, "mckibben."):
        if ".cli" in info.name or info.name.split(".")[-1].startswith("_"):
            continue
        if not info.name.startswith(("mckibben.models", "mckibben.units")):
            continue
        module = importlib.import_module(info.name)
        for fname, func in inspect.getmembers(module, inspect.isfunction):
            if func.__module__ == module.__name__ and not fname.startswith("_"):
                yield f"{info.name}.{fname}", func


@pytest.mark.parametrize("qualname, func", list(_public_functions()), ids=lambda x: x if isinstance(x, str) else "")
def test_every_public_argument_is_documented_with_a_unit(qualname, func):
    doc = inspect.getdoc(func) or ""
    assert doc, f"{qualname} has no docstring"
    params = [p for p in inspect.signature(func).parameters if p not in ("self", "cls")]
    if not params:
        return
    section = doc.split("Parameters\n----------", 1)
    assert len(section) == 2, f"{qualname}: no numpydoc Parameters section"
    for p in params:
        assert re.search(rf"^{p}\b|, {p}\b|^{p},", section[1], re.M), f"{qualname}: argument {p!r} is undocumented"


def test_data_md_tables_are_generated_from_the_schema():
    from pathlib import Path

    from mckibben.data.schema import schema_markdown

    text = (Path(__file__).parents[1] / "docs" / "data.md").read_text(encoding="utf-8")
    assert schema_markdown() in text


def test_fit_md_law_table_is_generated_from_the_registry():
    from pathlib import Path

    from mckibben.models.laws import law_table_markdown

    text = (Path(__file__).parents[1] / "docs" / "fit.md").read_text(encoding="utf-8")
    assert law_table_markdown() in text
