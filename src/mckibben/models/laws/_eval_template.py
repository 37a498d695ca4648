"""The element-wise loop of a force law's NumPy face, a template bound to one law kernel at a time.

:func:`mckibben.models.laws._base.evaluate_kernel` evaluates a law's kernel over arrays. A compiled
loop taking the kernel as an *argument* cannot be cached (``mckibben._jit``); so, as for the
simulator's runner, :func:`mckibben._jit.module_for` makes one module of this source per law, with
the ``# kernel-import`` line replaced by an import of that law's kernel (bound to the global ``law_kernel``).

Its functions are marked (:func:`mckibben._kernels.kernel`), not compiled at import, so that
:mod:`~mckibben.models.laws._base` can import this template at module level without loading Numba;
they compile when Numba is loaded (here and in every module generated from this source, which
registers itself in turn).
"""

from __future__ import annotations

import math

from mckibben._kernels import kernel as _marked
from mckibben._kernels import register


@_marked(error_model="numpy")
def placeholder(pressure, length, th, o, w):
    """The template's own kernel (never evaluated: every law is bound by a generated module). [N]"""
    return math.nan


law_kernel = placeholder  # kernel-import


@_marked(error_model="numpy")
def eval_loop(p, length, th, col, w, out):
    """``out[i] = law_kernel(p[i], length[i], th, col[i], w)``: the law at each point. [N]"""
    for i in range(p.size):
        out[i] = law_kernel(p[i], length[i], th, col[i], w)


register(__name__)
