"""Exceptions raised for bad input.

Every error a user can cause is an :class:`InputError`: one line that names what was wrong and
where (file:row:column, argument name, fit). It subclasses :class:`ValueError` so callers can
catch it plainly; the CLI turns it into a single line on stderr and exit status 2.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class InputError(ValueError):
    """Bad input from a user: a value, a file, an argument. The message is one line."""


class UnreachableError(InputError):
    """A target (length, pressure, tip position) that the muscle or tool cannot reach."""


def unknown_name(kind: str, name: str, choices: Iterable[str]) -> InputError:
    """Build the error for an unknown name, suggesting the closest valid ones.

    Parameters
    ----------
    kind : str
        What was named, e.g. ``"muscle"`` or ``"model"``. [-]
    name : str
        The name the user gave. [-]
    choices : iterable of str
        The valid names. [-]
    """
    choices = sorted(choices)
    if not isinstance(name, str):  # None, a number: a type error, not a misspelling (difflib takes text only)
        return ArgumentTypeError(f"{kind} = {name!r}: not a name ({_type_name(name)}); give one of: {', '.join(choices)}")
    close = difflib.get_close_matches(name, choices, n=3)
    hint = f" Did you mean {', '.join(close)}?" if close else ""
    return InputError(f"unknown {kind} {name!r}.{hint} Provide one of: {', '.join(choices)}")


class ArgumentTypeError(InputError, TypeError):
    """An argument of the wrong type (``None``, a bool, text, an object) where a number or a
    particular object is required. Both an :class:`InputError` (a ``ValueError``, what the CLI
    reports as one line) and a ``TypeError``, so callers may catch either."""


# ---------------------------------------------------------------------------------------------
# The validation boundary of the public API: every public function checks its arguments with
# these before it allocates anything; each message names the Python argument (the CLI maps it to
# its flag).


def _is_number(value) -> bool:
    import numbers

    return isinstance(value, numbers.Real) and not isinstance(value, bool) and not _is_bool_scalar(value)


def _is_bool_scalar(value) -> bool:
    import numpy as np

    return isinstance(value, (bool, np.bool_))


def check_real(value, name: str, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False,
               hi_open: bool = False, unit: str = "") -> float:
    """A real number, finite and within ``[lo, hi]`` (open ends with ``lo_open``/``hi_open``).

    Parameters
    ----------
    value : float
        The argument. [SI]
    name : str
        The argument's Python name, for the message. [-]
    lo, hi : float, optional
        Bounds. [SI]
    lo_open, hi_open : bool, default False
        Whether a bound itself is excluded. [-]
    unit : str
        The SI unit, for the message. [-]

    Returns
    -------
    float
        ``value``. [SI]

    Raises
    ------
    ArgumentTypeError
        ``None``, a bool, text or any other non-number.
    InputError
        NaN, infinity, or a value outside the bounds.
    """
    import math

    if not _is_number(value):
        raise ArgumentTypeError(f"{name} = {value!r}: not a number ({_type_name(value)}); give a real number"
                                + (f" in {unit}" if unit else ""))
    v = float(value)
    if not math.isfinite(v):
        raise InputError(f"{name} = {value!r}: not a finite number")
    below = lo is not None and (v <= lo if lo_open else v < lo)
    above = hi is not None and (v >= hi if hi_open else v > hi)
    if below or above:
        raise InputError(f"{name} = {v:g}{' ' + unit if unit else ''}: outside {_interval(lo, hi, lo_open, hi_open)}")
    return v


def check_int(value, name: str, *, lo: int | None = None, hi: int | None = None) -> int:
    """A whole number (an ``int`` or NumPy integer, not a bool) within ``[lo, hi]``.

    Parameters
    ----------
    value : int
        The argument. [-]
    name : str
        The argument's Python name, for the message. [-]
    lo, hi : int, optional
        Inclusive bounds. [-]

    Returns
    -------
    int
        ``value``. [-]
    """
    import numbers

    if isinstance(value, bool) or _is_bool_scalar(value) or not isinstance(value, numbers.Integral):
        raise ArgumentTypeError(f"{name} = {value!r}: not a whole number ({_type_name(value)})")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise InputError(f"{name} = {v}: outside {_interval(lo, hi, False, False)}")
    return v


def check_array(value, name: str, *, lo: float | None = None, hi: float | None = None, ndim: int | None = None,
                size: int | None = None, unit: str = "", finite: bool = True):
    """A real array (or scalar) of finite values within ``[lo, hi]``, as ``float`` NumPy array.

    Parameters
    ----------
    value : array_like
        The argument. [SI]
    name : str
        The argument's Python name, for the message. [-]
    lo, hi : float, optional
        Inclusive bounds. [SI]
    ndim : int, optional
        The required number of dimensions. [-]
    size : int, optional
        The largest number of elements accepted (checked before converting). [-]
    unit : str
        The SI unit, for the message. [-]
    finite : bool, default True
        Refuse NaN and infinities; False lets them through (a low-level formula whose NaN in
        gives NaN out) and checks only the type, shape, size and bounds of the finite values. [-]

    Returns
    -------
    numpy.ndarray
        ``value`` as floats (a new array only where a conversion was needed). [SI]
    """
    import numpy as np

    if value is None or isinstance(value, (str, bytes, dict, set)) or _is_bool_scalar(value):
        raise ArgumentTypeError(f"{name} = {value!r}: not a number or an array of numbers ({_type_name(value)})")
    try:
        raw = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged lists
        raise ArgumentTypeError(f"{name}: not an array of numbers ({' '.join(str(exc).split())[:80]})") from None
    if raw.dtype == bool or raw.dtype.kind not in "iuf":
        raise ArgumentTypeError(f"{name}: an array of {raw.dtype} values; give real numbers"
                                + (f" in {unit}" if unit else ""))
    if size is not None and raw.size > size:
        raise InputError(f"{name}: {raw.size:,} values, more than the {size:,} accepted")
    if ndim is not None and raw.ndim != ndim:
        raise InputError(f"{name}: shape {raw.shape}, want {ndim} dimension{'s' if ndim != 1 else ''}")
    a = raw.astype(float, copy=False)
    if finite and not np.all(np.isfinite(a)):
        raise InputError(f"{name}: holds a value that is not a finite number")
    v = a if finite else a[np.isfinite(a)]
    if v.size and ((lo is not None and v.min() < lo) or (hi is not None and v.max() > hi)):
        bad = v.min() if lo is not None and v.min() < lo else v.max()
        raise InputError(f"{name}: {bad:g}{' ' + unit if unit else ''} is outside {_interval(lo, hi, False, False)}")
    return a


def check_callable(value, name: str, *, optional: bool = True):
    """A callable (or ``None`` when ``optional``): checked before a run, not found after it."""
    if (value is None and optional) or callable(value):
        return value
    raise ArgumentTypeError(f"{name} = {show_value(value)}: not callable ({_type_name(value)}); give a function"
                            + (" or None" if optional else ""))


def check_instance(value, name: str, cls, what: str, *, optional: bool = False):
    """``value`` if it is a ``cls`` (or ``None`` when ``optional``); else an :class:`ArgumentTypeError`."""
    if (value is None and optional) or isinstance(value, cls):
        return value
    raise ArgumentTypeError(f"{name} = {show_value(value)}: not {what} ({_type_name(value)})")


def show_value(value) -> str:
    """``repr(value)`` on one short line (a DataFrame's repr spans many: its type stands in)."""
    r = repr(value)
    return r if "\n" not in r and len(r) <= 80 else f"<{type(value).__name__}>"


def _type_name(value) -> str:
    return "None" if value is None else type(value).__name__


def _interval(lo, hi, lo_open, hi_open) -> str:
    left = "(" if lo_open or lo is None else "["
    right = ")" if hi_open or hi is None else "]"
    a = "-inf" if lo is None else f"{lo:g}"
    b = "inf" if hi is None else f"{hi:g}"
    return f"{left}{a}, {b}{right}"
