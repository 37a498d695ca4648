"""Kernels that stay plain Python until the package loads Numba.

A module whose kernels are also needed by quick commands (``mckibben predict``, ``--help``) marks
them with :func:`kernel` instead of :func:`mckibben._jit.njit` and calls :func:`register` at its
end. Until the package imports Numba (through :mod:`mckibben._jit`, which the simulator and the
controllers import), the marked functions are the plain Python functions they are written as;
from then on each module's marked functions are replaced, in the module, by their compiled
dispatchers, before any compiled code that calls them is compiled. The same source, the same
arithmetic: tests hold the two equal to the bit.

Compiled code reaches a marked kernel through its module (``HW.adc_count``), from inside that
module, or by a name a registered module imported from another (rebound too); a module that is not
registered and imports a marked kernel by name must import :mod:`mckibben._jit` first.

:func:`jit` is the one place a cheap module loads Numba: it imports :mod:`mckibben._jit` on its
first call (a function-level import on purpose, the package's only one of its own modules).
"""

from __future__ import annotations

import sys

#: Names of the modules that hold marked kernels, in registration order.
_MODULES: list[str] = []
#: NumPy faces call their kernels in Python up to this many elements, then compile. [-]
PYTHON_MAX = 64


def kernel(func=None, /, **options):
    """Mark ``func`` as a kernel compiled with Numba's ``options`` once the package loads Numba."""
    def mark(f):
        f.__mckibben_kernel__ = options
        return f

    return mark if func is None else mark(func)


def register(module_name: str) -> None:
    """Declare that ``module_name`` holds marked kernels (call at the end of the module)."""
    if module_name not in _MODULES:
        _MODULES.append(module_name)
    if "mckibben._jit" in sys.modules:
        sys.modules["mckibben._jit"].compile_marked()


def compiled() -> bool:
    """True once the package has loaded Numba (marked kernels are compiled dispatchers)."""
    return "mckibben._jit" in sys.modules


def need_speed(size: int) -> None:
    """Load Numba (compiling every marked kernel) when a NumPy face has more than :data:`PYTHON_MAX` elements."""
    if size > PYTHON_MAX and not compiled():
        jit()


def jit():
    """The module :mod:`mckibben._jit`, imported on the first call: loads Numba, compiles every marked kernel.

    The package's one deferred import of its own: every module stays cheap to import (``mckibben
    --version``, ``predict``), and a caller that needs compiled code (the simulator's batch, a
    large array, the warm-up) calls this instead of importing :mod:`mckibben._jit` itself.

    Returns
    -------
    module
        :mod:`mckibben._jit`.
    """
    from mckibben import _jit  # deferred on purpose: Numba (about 0.5 s to import), only where compiled code runs

    return _jit


def modules() -> list:
    return [sys.modules[name] for name in _MODULES if name in sys.modules]
