"""Quantities a user types, turned into SI.

SI inside everything: pressure in Pa (gauge unless a name says otherwise), length in m, force in
N, angle in rad, time in s. This module is the one edge where other units come in: it parses the
strings of the command line (``0.8MPa``, ``80psi``, ``97mm``, ``60gf``, ``20deg``) and converts the
unit suffixes of file columns (``pressure_MPa``, ``load_g``).

Examples
--------
>>> parse_quantity("0.8MPa", "pressure")
800000.0
>>> round(parse_quantity("80psi", "pressure"))
551581
>>> parse_quantity("97mm", "length")
0.097
"""

from __future__ import annotations

import math
import re

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_real

__all__ = ["G_N", "P_ATM", "SI_UNIT", "UNITS", "parse_quantity", "parse_values", "quantity", "si", "split_column",
           "to_si", "units_of"]

#: Standard gravity [m/s^2] (for gram-force and hanging masses).
G_N = 9.80665
#: Standard atmospheric pressure [Pa]: gauge pressures (the rig's, every table's) + P_ATM = absolute.
P_ATM = 101325.0

#: Unit -> (dimension, factor to SI). Case-sensitive: "mm" is not "Mm".
UNITS: dict[str, tuple[str, float]] = {
    # pressure [Pa]
    "Pa": ("pressure", 1.0),
    "kPa": ("pressure", 1e3),
    "MPa": ("pressure", 1e6),
    "bar": ("pressure", 1e5),
    "mbar": ("pressure", 1e2),
    "psi": ("pressure", 6894.757293168361),
    # length [m]
    "m": ("length", 1.0),
    "cm": ("length", 1e-2),
    "mm": ("length", 1e-3),
    "um": ("length", 1e-6),
    "in": ("length", 0.0254),
    # force [N]
    "N": ("force", 1.0),
    "mN": ("force", 1e-3),
    "kN": ("force", 1e3),
    "gf": ("force", 1e-3 * G_N),
    "kgf": ("force", G_N),
    # mass [kg] (hanging loads are often written as masses)
    "g": ("mass", 1e-3),
    "kg": ("mass", 1.0),
    # angle [rad]
    "rad": ("angle", 1.0),
    "deg": ("angle", math.pi / 180.0),
    # time [s]
    "s": ("time", 1.0),
    "ms": ("time", 1e-3),
    "us": ("time", 1e-6),
    "min": ("time", 60.0),
    # frequency [Hz]
    "Hz": ("frequency", 1.0),
    "kHz": ("frequency", 1e3),
    # bending stiffness [N·m²] (written Nm2, N·m², N*m^2 or Nmm2)
    "Nm2": ("bending_stiffness", 1.0),
    "Nmm2": ("bending_stiffness", 1e-6),
    # dimensionless
    "": ("dimensionless", 1.0),
    "%": ("dimensionless", 1e-2),
}

#: The SI unit of each dimension, used in messages and JSON keys.
SI_UNIT = {
    "pressure": "Pa",
    "length": "m",
    "force": "N",
    "mass": "kg",
    "angle": "rad",
    "time": "s",
    "frequency": "Hz",
    "bending_stiffness": "Nm2",
    "dimensionless": "",
}

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?(?:nan|inf)"
_QUANTITY = re.compile(rf"^\s*(?P<num>{_NUMBER})\s*(?P<unit>[A-Za-z%]*2?)\s*$", re.IGNORECASE)


def units_of(dimension: str) -> list[str]:
    """The unit suffixes accepted for a dimension, e.g. ``units_of("pressure")``.

    Parameters
    ----------
    dimension : str
        A dimension name, e.g. ``"pressure"``. [-]
    """
    return [u for u, (d, _) in UNITS.items() if d == dimension and u]


def to_si(value, unit: str, dimension: str | None = None, *, where: str = "value"):
    """Convert a number or array given in ``unit`` to SI.

    Parameters
    ----------
    value : float or array_like
        The number(s) in ``unit``. [unit]
    unit : str
        A key of :data:`UNITS`, e.g. ``"MPa"``. [-]
    dimension : str, optional
        The dimension the caller expects; a unit of another dimension is an error.
    where : str
        What the value is, for the error message (an argument or file column name).

    Returns
    -------
    float or numpy.ndarray
        The value in SI. [SI]
    """
    if unit not in UNITS:
        hint = f"; use one of {', '.join(units_of(dimension))}" if dimension else ""
        raise InputError(f"{where}: unknown unit {unit!r}{hint}")
    dim, factor = UNITS[unit]
    if dimension is not None and dim != dimension:
        raise InputError(
            f"{where}: unit {unit!r} is a {dim}, but a {dimension} is wanted"
            f" (use one of {', '.join(units_of(dimension))})"
        )
    if isinstance(value, (int, float)):
        return float(value) * factor
    return np.asarray(value, dtype=float) * factor


def parse_quantity(
    text: str,
    dimension: str,
    name: str = "value",
    *,
    allow_negative: bool = False,
    allow_zero: bool = True,
    default_unit: str | None = None,
) -> float:
    """Parse one quantity typed by a user into SI.

    Parameters
    ----------
    text : str
        The text, a number followed by a unit: ``"0.8MPa"``, ``"97 mm"``, ``"60gf"``. [-]
    dimension : str
        The wanted dimension: ``"pressure"``, ``"length"``, ``"force"``, ``"angle"``,
        ``"time"``, ``"frequency"`` or ``"dimensionless"``. A ``"force"`` also accepts a mass
        (``"60g"``), taken as the weight of a hanging mass (times standard gravity).
    name : str
        The argument's name, used in error messages, e.g. ``"pressure"`` (the command line writes it as its flag).
    allow_negative : bool, default False
        Whether a negative value is accepted.
    allow_zero : bool, default True
        Whether zero is accepted.
    default_unit : str, optional
        The unit assumed when the text has none; without it a missing unit is an error.

    Returns
    -------
    float
        The value in SI units of ``dimension``. [SI]

    Raises
    ------
    InputError
        Unknown or missing unit, a unit of another dimension, NaN or infinity, a negative or
        zero value where not allowed. The message names ``name``.
    """
    if not isinstance(text, str):
        text = str(text)
    if dimension == "bending_stiffness":  # N·m², N*m^2, N m2 -> Nm2
        text = re.sub(r"(?<=[A-Za-z])[\s·*.^]+(?=[A-Za-z0-9²])|\^", "", text).replace("²", "2")
    match = _QUANTITY.match(text)
    if match is None:
        raise InputError(f"{name}: cannot read {text!r} as a {dimension} (e.g. {_example(dimension)})")
    number = float(match.group("num"))
    unit = match.group("unit")
    if unit == "" and dimension != "dimensionless":
        if default_unit is None:
            raise InputError(
                f"{name}: {text!r} has no unit; write it with one of {', '.join(units_of(dimension))}"
                f" (e.g. {_example(dimension)})"
            )
        unit = default_unit
    if not math.isfinite(number):
        raise InputError(f"{name}: {text!r} is not a finite number")
    if dimension == "force" and unit in UNITS and UNITS[unit][0] == "mass":
        value = to_si(number, unit, "mass", where=name) * G_N
    else:
        value = to_si(number, unit, dimension, where=name)
    if not math.isfinite(value):  # finite in its unit, past float's range in SI ("1e308MPa")
        raise InputError(f"{name}: {text!r} is past the range of a number in SI ({dimension})")
    if value < 0 and not allow_negative:
        raise InputError(f"{name}: {text!r} is negative; a {dimension} here must be >= 0")
    if value == 0 and not allow_zero:
        raise InputError(f"{name}: {text!r} is zero; a {dimension} here must be > 0")
    return float(value)


def quantity(
    value,
    dimension: str,
    name: str = "value",
    *,
    allow_negative: bool = False,
    allow_zero: bool = True,
) -> float:
    """A quantity given either in SI (a number) or as text with a unit (``"0.8MPa"``).

    For the readers and models that still take either; the experiments take numbers in SI only
    (:func:`si`: ``step_response(target=0.55e6)``), and the command line parses text with
    :func:`parse_quantity`.

    Parameters
    ----------
    value : float or str
        A number, taken in the SI unit of ``dimension``, or text parsed by
        :func:`parse_quantity`. [SI]
    dimension : str
        The wanted dimension (see :func:`parse_quantity`). [-]
    name : str
        The argument's name, for error messages. [-]
    allow_negative : bool, default False
        Whether a negative value is accepted. [-]
    allow_zero : bool, default True
        Whether zero is accepted. [-]

    Returns
    -------
    float
        The value in SI. [SI]

    Examples
    --------
    >>> round(quantity("80psi", "pressure"))
    551581
    >>> quantity(0.097, "length")
    0.097
    """
    if isinstance(value, str):
        return parse_quantity(value, dimension, name, allow_negative=allow_negative, allow_zero=allow_zero)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{name}: {value!r} is neither a number in SI nor text with a unit "
                         f"(e.g. {_example(dimension)})")
    v = float(value)
    if not math.isfinite(v):
        raise InputError(f"{name}: {value!r} is not a finite number")
    if v < 0 and not allow_negative:
        raise InputError(f"{name}: {value!r} is negative; a {dimension} here must be >= 0")
    if v == 0 and not allow_zero:
        raise InputError(f"{name}: {value!r} is zero; a {dimension} here must be > 0")
    return v


def parse_values(
    text: str,
    dimension: str,
    name: str = "value",
    *,
    allow_negative: bool = False,
    allow_zero: bool = True,
) -> np.ndarray:
    """Parse one quantity, a list or a range into an array of SI values.

    Accepted forms: ``"0.8MPa"``; a comma list ``"0.2MPa,0.4MPa,0.6MPa"`` or ``"0.2,0.4,0.6MPa"``
    (bare numbers take the unit of the last item); a range ``START:STOP:COUNT`` such as
    ``"0:0.8MPa:9"`` (nine evenly spaced values, ends included; a bare start takes the unit of
    the stop).

    Parameters
    ----------
    text : str
        What the user typed. [-]
    dimension : str
        The wanted dimension (see :func:`parse_quantity`).
    name : str
        The argument's name for error messages.
    allow_negative, allow_zero : bool
        As in :func:`parse_quantity`.

    Returns
    -------
    numpy.ndarray
        1-D array of values in SI. [SI]
    """
    text = text.strip()
    kw: dict = dict(allow_negative=allow_negative, allow_zero=allow_zero)
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise InputError(f"{name}: a range is START:STOP:COUNT, e.g. 0:0.8MPa:9; got {text!r}")
        start_t, stop_t, count_t = parts
        try:
            count = int(count_t)
        except ValueError:
            raise InputError(f"{name}: the count in {text!r} must be a whole number") from None
        if count < 1 or count > 1_000_000:
            raise InputError(f"{name}: the count in {text!r} must be between 1 and 1000000")
        stop_unit = _unit_of(stop_t)
        stop = parse_quantity(stop_t, dimension, name, **kw)
        start = parse_quantity(start_t, dimension, name, default_unit=stop_unit or None, **kw)
        return np.linspace(start, stop, count)
    items = [t for t in text.split(",")]
    if any(not t.strip() for t in items):
        raise InputError(f"{name}: empty item in list {text!r}")
    last_unit = _unit_of(items[-1]) or None
    return np.array([parse_quantity(t, dimension, name, default_unit=last_unit, **kw) for t in items])


def _unit_of(text: str) -> str:
    match = _QUANTITY.match(text)
    return match.group("unit") if match else ""


def _example(dimension: str) -> str:
    return {
        "pressure": "0.8MPa, 80psi, 5bar",
        "length": "97mm, 9.7cm",
        "force": "0.6N, 60gf",
        "angle": "20deg",
        "time": "0.5s, 20ms",
        "frequency": "1kHz",
        "mass": "60g",
        "bending_stiffness": "2e-4Nm2, 200Nmm2",
        "dimensionless": "0.2",
    }.get(dimension, "1")


def split_column(column: str) -> tuple[str, str]:
    """Split a file column name ``quantity_unit`` into ``(quantity, unit)``.

    ``"pressure_MPa"`` gives ``("pressure", "MPa")``; a name without a known unit suffix, such
    as ``"trial"``, gives the name and an empty unit.

    Parameters
    ----------
    column : str
        A column name such as ``"pressure_MPa"``. [-]
    """
    if "_" in column:
        quantity, unit = column.rsplit("_", 1)
        if unit in UNITS and unit:
            return quantity, unit
    return column, ""


def si(value, dimension: str, name: str, *, allow_negative: bool = False, allow_zero: bool = True) -> float:
    """A library argument that must be a number in SI: the library takes numbers, the CLI parses.

    Text with a unit (``"0.55MPa"``) is refused with the number to pass instead, so a notebook user
    learns the SI value at once; the command line parses its text with :func:`parse_quantity`
    before it calls the library.

    Parameters
    ----------
    value : float
        The argument, in the SI unit of ``dimension``. [SI]
    dimension : str
        Its dimension (a key of :data:`SI_UNIT`). [-]
    name : str
        The argument's Python name, for the message. [-]
    allow_negative, allow_zero : bool
        Whether a negative value, or zero, is accepted. [-]

    Returns
    -------
    float
        ``value``. [SI]

    Raises
    ------
    ArgumentTypeError
        Text, ``None``, a bool or any other non-number.
    InputError
        NaN, infinity, or a negative or zero value where it is not allowed.

    Examples
    --------
    >>> si(0.55e6, "pressure", "target")
    550000.0
    """
    unit = SI_UNIT[dimension]
    if isinstance(value, str):
        try:
            hint = f"; pass {parse_quantity(value, dimension, name, allow_negative=True):.6g} for {value!r}"
        except InputError:
            hint = ""
        raise ArgumentTypeError(f"{name} = {value!r}: the library takes a number in {unit} (SI), not text"
                                f"{hint} (mckibben.units.parse_quantity converts text)")
    v = check_real(value, name, unit=unit)
    if v < 0 and not allow_negative:
        raise InputError(f"{name} = {v:g} {unit}: negative; a {dimension} here must be >= 0")
    if v == 0 and not allow_zero:
        raise InputError(f"{name} = 0 {unit}: a {dimension} here must be > 0")
    return v
