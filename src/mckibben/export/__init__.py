"""Bridges out of mckibben: the plant as an FMU (:func:`export_fmu`) for Simulink, Modelica, FMPy, and
calibrated muscles on MuJoCo tendons (:mod:`mckibben.export.mujoco`, imported on its own: it loads Numba)."""

import importlib
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "export_fmu": "mckibben.export.fmu",
}

__all__ = ["export_fmu"]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.export.fmu import export_fmu as export_fmu


def __getattr__(name: str):
    # table-driven (see _WHERE): the submodule and its heavy third-party packages load on first use
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
        globals()[name] = value
        return value
    try:  # a submodule by attribute (``mckibben.plant.params``), as an eager package would have bound it
        return importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
