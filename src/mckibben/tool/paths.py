"""Tip trajectories for tracking: a circle or a figure-eight, written as a one-line spec.

Syntax (units required on every value; keys in any order)::

    circle:radius=5mm,period=2s[,z=110mm][,cx=0mm][,cy=0mm][,cycles=2]
    figure8:size=5mm,period=2s[,z=110mm][,cx=0mm][,cy=0mm][,cycles=2]

- ``circle``: x = cx + R·cos(2πt/T), y = cy + R·sin(2πt/T), z constant; starts at (cx + R, cy).
- ``figure8`` (lemniscate of Gerono): x = cx + a·sin(2πt/T), y = cy + (a/2)·sin(4πt/T),
  z constant; one lobe each side of the centre, starts at the centre.
- ``z`` defaults to the tool's straight height at half the maximum pressure on all three muscles
  (the middle of its axial stroke); ``cx``, ``cy`` to 0 (the tool axis); ``cycles`` to 2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_real
from mckibben.limits import PLAUSIBLE_MAX
from mckibben.units import parse_quantity

_KEYS = {
    "circle": {"radius": "length", "period": "time", "z": "length", "cx": "length", "cy": "length", "cycles": "dimensionless"},
    "figure8": {"size": "length", "period": "time", "z": "length", "cx": "length", "cy": "length", "cycles": "dimensionless"},
}
_REQUIRED = {"circle": ("radius", "period"), "figure8": ("size", "period")}
#: Largest size, centre offset or height of a path: far past any tool's reach (each run checks its
#: tool's own reach). [m]
MAX_PATH_SIZE = 10.0


@dataclass(frozen=True)
class TipPath:
    """A closed tip trajectory in a plane z = const.

    Attributes
    ----------
    kind : str
        ``"circle"`` or ``"figure8"``.
    size : float
        Circle radius R, or figure-eight half-width a. [m]
    period : float
        Time for one loop, T. [s]
    z : float or None
        Height of the plane; ``None`` until resolved against a tool (:meth:`with_z`). [m]
    cx, cy : float
        Centre of the path. [m]
    cycles : float
        Loops to run. [-]
    text : str
        The one-line text it was read from (:func:`parse_path`), for provenance; empty if built
        by hand. [-]

    Every field is checked when the path is made: a kind of ``circle`` or ``figure8``, a size
    and a period > 0, finite coordinates (a plane height > 0), cycles > 0.
    """

    kind: str
    size: float
    period: float
    z: float | None = None
    cx: float = 0.0
    cy: float = 0.0
    cycles: float = 2.0
    text: str = field(default="", compare=False)

    def __post_init__(self):
        if not isinstance(self.kind, str) or self.kind not in _KEYS:
            raise InputError(f"kind = {self.kind!r}: not a path kind; use circle or figure8")
        check_real(self.size, "size", lo=0.0, lo_open=True, hi=MAX_PATH_SIZE, unit="m")
        check_real(self.period, "period", lo=0.0, lo_open=True, hi=PLAUSIBLE_MAX["time"], unit="s")
        if self.z is not None:
            check_real(self.z, "z", lo=0.0, lo_open=True, hi=MAX_PATH_SIZE, unit="m")
        check_real(self.cx, "cx", lo=-MAX_PATH_SIZE, hi=MAX_PATH_SIZE, unit="m")
        check_real(self.cy, "cy", lo=-MAX_PATH_SIZE, hi=MAX_PATH_SIZE, unit="m")
        check_real(self.cycles, "cycles", lo=0.0, lo_open=True, unit="-")
        if not isinstance(self.text, str):
            raise ArgumentTypeError(f"text = {self.text!r}: not text ({type(self.text).__name__})")

    @property
    def duration(self) -> float:
        """Total time, ``cycles × period``. [s]"""
        return self.cycles * self.period

    @property
    def length(self) -> float:
        """Length of one loop (the figure-eight's by quadrature). [m]"""
        if self.kind == "circle":
            return 2.0 * math.pi * self.size
        t = np.linspace(0.0, self.period, 20001)
        p = self.position(t, z=0.0)
        return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))

    @property
    def mean_speed(self) -> float:
        """Mean tip speed along the path, loop length / period. [m/s]"""
        return self.length / self.period

    def with_z(self, z: float) -> TipPath:
        """The same path with its plane height set.

        Parameters
        ----------
        z : float
            Height of the plane. [m]
        """
        return TipPath(self.kind, self.size, self.period, z, self.cx, self.cy, self.cycles, self.text)

    def with_period(self, period: float) -> TipPath:
        """The same path run at another period (speed).

        Parameters
        ----------
        period : float
            Time for one loop. [s]
        """
        if not period > 0:
            raise InputError(f"period: {period!r} must be > 0 s")
        return TipPath(self.kind, self.size, period, self.z, self.cx, self.cy, self.cycles, self.text)

    def position(self, t, z: float | None = None) -> np.ndarray:
        """Target tip position at times ``t``.

        Parameters
        ----------
        t : array_like
            Time from the start. [s]
        z : float, optional
            Plane height overriding :attr:`z`. [m]

        Returns
        -------
        numpy.ndarray
            (x, y, z) on the last axis. [m]
        """
        z = self.z if z is None else z
        if z is None:
            raise InputError("path: the plane height z is not set (give z=... or resolve it against the tool)")
        w = 2.0 * math.pi * np.asarray(t, dtype=float) / self.period
        if self.kind == "circle":
            x, y = self.cx + self.size * np.cos(w), self.cy + self.size * np.sin(w)
        else:
            x, y = self.cx + self.size * np.sin(w), self.cy + 0.5 * self.size * np.sin(2.0 * w)
        return np.stack([x, y, np.full_like(w, z)], axis=-1)


def parse_path(spec: str, name: str = "path") -> TipPath:
    """Parse a path spec such as ``circle:radius=5mm,period=2s`` (see the module docstring).

    Parameters
    ----------
    spec : str
        The spec. [-]
    name : str, default "path"
        The argument's name for error messages. [-]

    Returns
    -------
    TipPath
        The path (``z`` is ``None`` unless the spec gives it).

    Raises
    ------
    InputError
        Unknown kind or key, a missing required key, a repeated key, a value without a unit or
        of the wrong dimension, a zero size or period, a non-positive cycle count.

    Examples
    --------
    >>> p = parse_path("circle:radius=5mm,period=2s")
    >>> p.kind, p.size, p.period, p.cycles
    ('circle', 0.005, 2.0, 2.0)
    """
    if not isinstance(spec, str) or ":" not in spec:
        raise InputError(f"{name}: {spec!r} is not a path; write e.g. circle:radius=5mm,period=2s or figure8:size=5mm,period=2s")
    kind, _, body = spec.partition(":")
    kind = kind.strip().lower()
    if kind not in _KEYS:
        raise InputError(f"{name}: unknown path kind {kind!r}; use circle or figure8")
    values: dict[str, float] = {}
    for item in body.split(","):
        key, eq, text = item.partition("=")
        key = key.strip().lower()
        if not eq or not key:
            raise InputError(f"{name}: {item.strip()!r} in {spec!r} is not key=value")
        if key not in _KEYS[kind]:
            raise InputError(f"{name}: unknown key {key!r} for {kind}; use {', '.join(_KEYS[kind])}")
        if key in values:
            raise InputError(f"{name}: key {key!r} given twice in {spec!r}")
        dim = _KEYS[kind][key]
        negative_ok = key in ("cx", "cy")
        values[key] = parse_quantity(text, dim, f"{name} {key}", allow_negative=negative_ok,
                                     allow_zero=key not in ("radius", "size", "period", "z", "cycles"))
    missing = [k for k in _REQUIRED[kind] if k not in values]
    if missing:
        raise InputError(f"{name}: {kind} needs {', '.join(missing)} (e.g. {kind}:{_REQUIRED[kind][0]}=5mm,period=2s)")
    try:
        return _made(kind, values, spec)
    except InputError as exc:  # a field of the path: name the argument it came from
        raise type(exc)(f"{name}: {exc}") from None


def _made(kind: str, values: dict, spec: str) -> TipPath:
    return TipPath(
        kind=kind,
        size=values.get("radius", values.get("size")),
        period=values["period"],
        z=values.get("z"),
        cx=values.get("cx", 0.0),
        cy=values.get("cy", 0.0),
        cycles=values.get("cycles", 2.0),
        text=spec,
    )
