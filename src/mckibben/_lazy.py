"""Packages whose public names and submodules load on first use (PEP 562), in one place.

Every command module imports the packages it uses at module level (DESIGN.md: the import graph is
visible), and ``mckibben --version``/``--help`` import every command module. So a package's
``__init__`` only names where each public name lives; :func:`package` gives it the module-level
``__getattr__`` and ``__dir__`` that import the submodule (and its heavy third-party packages:
Numba, SciPy, pandas...) when a name of it is first used.
"""

from __future__ import annotations

import importlib
import sys
import types


def package(name: str, where: dict[str, str] | None = None, *, keep_names: bool = False):
    """The ``__getattr__`` and ``__dir__`` of the lazy package ``name``.

    Parameters
    ----------
    name : str
        The package (its ``__name__``). [-]
    where : dict, optional
        Public name -> the module that defines it; the value is bound on the package at first use.
        Any other attribute is tried as a submodule (``mckibben.plant.params``), as an eager package
        would have bound it. [-]
    keep_names : bool, default False
        A public name of ``where`` that is also a submodule's name (``plant.calibration``) stays the
        function when the submodule loads: the import system's binding of the module on the package
        is refused (the module stays in ``sys.modules``), as the eager package rebound it. [-]

    Returns
    -------
    (callable, callable)
        ``__getattr__`` and ``__dir__`` for the package's namespace. [-]
    """
    module = sys.modules[name]
    where = dict(where or {})

    def __getattr__(attr: str):
        if attr in where:
            value = getattr(importlib.import_module(where[attr]), attr)
            module.__dict__[attr] = value
            return value
        try:
            return importlib.import_module(f"{name}.{attr}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{name}.{attr}":
                raise
        raise AttributeError(f"module {name!r} has no attribute {attr!r}")

    def __dir__():
        return sorted(set(vars(module)) | set(where))

    if keep_names:
        module.__class__ = type("LazyPackage", (_KeepNames,), {"_names": frozenset(where)})
    return __getattr__, __dir__


class _KeepNames(types.ModuleType):
    """A package where a public function keeps its name when a submodule of that name is imported."""

    _names: frozenset = frozenset()

    def __setattr__(self, attr, value):
        if attr in self._names and isinstance(value, types.ModuleType):
            return
        super().__setattr__(attr, value)
