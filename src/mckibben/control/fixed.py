"""Integer building blocks of the controller core, bit-exact mirrors of ``firmware/core/controller.c``.

Every law of the core (:mod:`mckibben.control.core`, :mod:`mckibben.control.registry`) computes
with these: ``mulq16`` (``mck_mulq16``: floor(x·c/2^16) wrapped to int32), the tanh table and
its interpolation (``mck_tanh_q15``), the clamp, and the rounding division of the gain-setting
code (``rdiv``). They are Numba kernels so that the laws inline them.
"""

from __future__ import annotations

import numpy as np

from mckibben._kernels import kernel, register

def tanh_table() -> np.ndarray:
    """The tanh table of the fixed-point law: ``round(tanh(i/16) * 2^15)``, i = 0..128.

    Returns
    -------
    numpy.ndarray
        129 ``int64`` values; entry i is tanh at x = i/16 in Q15. [-]
    """
    return np.rint(np.tanh(np.arange(129) / 16.0) * 32768.0).astype(np.int64)


_TANH = tanh_table()



@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def wrap32(v):
    """v wrapped to int32 (two's complement), as a C cast. [-]"""
    return ((v + 2147483648) & 0xFFFFFFFF) - 2147483648


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def mulq16(x, c):
    """floor(x c / 2^16) wrapped to int32, as ``mck_mulq16`` (c >= 0). [-]"""
    return wrap32((x * c) >> 16)


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def tanh_q15(x_q12):
    """tanh of x (Q12, 0 <= x < 8) in Q15 by linear interpolation in the table. [-]"""
    i = x_q12 >> 8
    f = x_q12 & 0xFF
    a = _TANH[i]
    b = _TANH[i + 1]
    return a + (((b - a) * f) >> 8)


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def clamp(v, lo, hi):
    """v clamped to [lo, hi] (``clamp32``). [-]"""
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


#: Clamp of each Q8 term before the sum (65536 counts): ``TERM_LIM`` of controller.c.
TERM_LIM = 1 << 24

def rdiv(n, d):
    """floor((n + floor(d/2)) / d): ``rdiv`` of controller.c, on NumPy int64 arrays or ints. [-]"""
    return (n + d // 2) // d


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
