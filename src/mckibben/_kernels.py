"""The package's one decorator for compiled functions, :func:`kernel`, and the kernels that stay plain Python until the package loads Numba.

Every compiled function of the package is written as a plain Python function decorated with
:func:`kernel` (Numba's ``njit`` options as keywords; caching is decided by :mod:`mckibben._jit`).
What the decorator returns depends only on whether Numba is loaded yet:

- Numba loaded (:mod:`mckibben._jit` imported): the compiled dispatcher
  (:class:`mckibben._jit.Kernel`), cached on disk. A module that runs compiled code as soon as it
  is imported (the simulator, the controllers' runners) imports the decorator from
  :mod:`mckibben._jit` (``from mckibben._jit import kernel``, the same function re-exported), which
  loads Numba first.
- Numba not loaded: the function itself, marked. A module whose kernels are also needed by quick
  commands (``mckibben predict``, ``--help``) imports the decorator from here and calls
  :func:`register` at its end. Until the package imports Numba (through :mod:`mckibben._jit`, which
  the simulator and the controllers import), the marked functions are the plain Python functions
  they are written as; from then on each module's marked functions are replaced, in the module, by
  their compiled dispatchers, before any compiled code that calls them is compiled. The same
  source, the same arithmetic: tests hold the two equal to the bit.

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
    """Compile ``func`` with Numba's ``options``: now if Numba is loaded, else once the package loads it.

    Use as ``@kernel`` or ``@kernel(error_model="numpy", inline="always", ...)``; the options are
    Numba's ``njit`` options, except ``cache``, which :mod:`mckibben._jit` decides (a per-user
    folder, or in memory when none can be written). ``fastmath`` is ``False`` unless given.

    Parameters
    ----------
    func : function, optional
        The plain Python function. [-]
    **options
        Numba's ``njit`` options. [-]

    Returns
    -------
    mckibben._jit.Kernel or function
        The compiled dispatcher when Numba is loaded; otherwise ``func`` itself, marked, which
        :func:`register` replaces by its dispatcher in its module once Numba is loaded.
    """
    if "cache" in options:
        raise TypeError("mckibben._kernels.kernel decides caching itself; do not pass cache=")

    def make(f):
        if _COMPILER:  # Numba is loaded: the dispatcher now
            return _COMPILER[0](f, options)
        f.__mckibben_kernel__ = options
        return f

    return make if func is None else make(func)


#: ``[compile(func, options)]`` once :mod:`mckibben._jit` has loaded Numba (:func:`use_compiler`).
_COMPILER: list = []


def use_compiler(compile_function) -> None:
    """From now on :func:`kernel` compiles at once with ``compile_function(func, options)`` (:mod:`mckibben._jit` calls it)."""
    _COMPILER[:] = [compile_function]


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
