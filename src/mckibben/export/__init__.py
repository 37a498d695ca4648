"""Bridges out of mckibben: the plant as an FMU (:func:`export_fmu`) for Simulink, Modelica, FMPy, and
calibrated muscles on MuJoCo tendons (:mod:`mckibben.export.mujoco`, imported on its own: it loads Numba)."""

from mckibben import _lazy
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


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
