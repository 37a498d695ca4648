"""Characterize a muscle on the bench with one call: protocol file → tables → fitted muscle file.

A *protocol* (a TOML file, :func:`read_protocol`; ``mckibben examples copy characterize.toml``)
states the hanging loads, the pressure steps (up to the top, then back down), the hold time, the
settling rule, the number of trials and the safety maximum, and optionally held lengths for
isometric runs on a rig with a load cell. It is checked whole before anything moves; a bad one is
refused with its file, line and reason.

:func:`characterize` runs it on a device (the Arduino Mega or an emulator engine) through its
serial link, with the operator (or, unattended, the bench side channel :mod:`mckibben.rig.bench`)
changing the load between runs, records every settled step crash-safely, writes the project's own
tables and fits a muscle file. See ``docs/rig.md``.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field

import numpy as np

from mckibben.atomic import as_path, check_input_file
from mckibben.errors import InputError, unknown_name
from mckibben.hardware import P_MAX_DEFAULT, P_MAX_LIMIT
from mckibben.units import parse_quantity

__all__ = ["Protocol", "read_protocol"]

#: The sections of a protocol file and the keys each takes.
SECTIONS = {
    "protocol": ("name", "trials", "max_pressure"),
    "isotonic": ("loads", "pressures", "hold"),
    "settling": ("window", "tolerance", "timeout"),
    "isometric": ("lengths", "pressures", "hold"),
}
#: A quantity of each dimension, as a protocol file writes it (for the error messages).
EXAMPLE = {"pressure": "0.8MPa", "time": "0.5s", "length": "0.2mm", "force": "61g"}
#: Most steps one sweep (up and down) may hold: a protocol is a lab's afternoon, not a typo's week. [-]
MAX_STEPS = 200


@dataclass(frozen=True)
class Protocol:
    """A characterization protocol, in SI.

    Attributes
    ----------
    name : str
        What the protocol is (free text). [-]
    loads : tuple of float
        The hanging loads, one isotonic run each, as forces (a mass times standard gravity). [N]
    pressures : tuple of float
        The pressure steps going up (the sweep goes back down the same steps). [Pa]
    hold : float
        Least time at each step before the settling rule is checked. [s]
    window, tolerance, timeout : float
        Settling rule: the length moved less than ``tolerance`` [m] over the last ``window`` [s];
        a step is recorded unsettled after ``timeout`` [s].
    trials : int
        Sweeps per load. [-]
    max_pressure : float
        Safety maximum: no set-point above it. [Pa]
    lengths : tuple of float
        Held lengths of the isometric runs (empty: none). [m]
    iso_pressures : tuple of float
        Pressure steps of the isometric runs (default the isotonic ones). [Pa]
    source : str
        The file it was read from. [-]
    """

    name: str
    loads: tuple
    pressures: tuple
    hold: float
    window: float
    tolerance: float
    timeout: float
    trials: int
    max_pressure: float
    lengths: tuple = ()
    iso_pressures: tuple = ()
    source: str = ""
    text: str = field(default="", repr=False)

    @property
    def sweep(self) -> list[tuple[float, str]]:
        """One sweep's steps: ``(pressure [Pa], "inflate"|"deflate")``, up to the top and back down."""
        up = [(p, "inflate") for p in self.pressures]
        return up + [(p, "deflate") for p in reversed(self.pressures[:-1])]

    def load_steps(self) -> list[tuple[int, int, float]]:
        """Every isotonic run in order: ``(load index, trial (1-based), load [N])``."""
        return [(i, t, f) for i, f in enumerate(self.loads) for t in range(1, self.trials + 1)]


def _key_line(text: str, section: str, key: str | None) -> int:
    """The 1-based line of ``key`` in ``[section]`` of a TOML text (tomllib gives no line for a value's error)."""
    lines = text.splitlines()
    head = re.compile(r"^\s*\[\s*" + re.escape(section) + r"\s*\]")
    start = next((i for i, s in enumerate(lines) if head.match(s)), None)
    if start is None:
        return 1
    if key is None:
        return start + 1
    pat = re.compile(r"^\s*\"?" + re.escape(key) + r"\"?\s*=")
    for i in range(start + 1, len(lines)):
        if re.match(r"^\s*\[", lines[i]):
            break
        if pat.match(lines[i]):
            return i + 1
    return start + 1


def read_protocol(path) -> Protocol:
    """Read and check a protocol file; refuse a bad one before anything moves.

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file (``mckibben examples copy characterize.toml`` gives a commented one). [-]

    Returns
    -------
    Protocol

    Raises
    ------
    InputError
        One line ``FILE:LINE: [section] key: reason`` for the first problem found.
    """
    p = check_input_file(as_path(path, "protocol", "protocol file"), "protocol", "protocol file")
    try:
        text = p.read_bytes().decode("utf-8")
        doc = tomllib.loads(text)
    except UnicodeDecodeError:
        raise InputError(f"{p}: the protocol file is not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: not valid TOML ({exc})") from None
    return _protocol(doc, text, str(p))


def _protocol(doc: dict, text: str, source: str) -> Protocol:
    def fail(section: str, key: str | None, reason: str) -> InputError:
        where = f"[{section}]" + (f" {key}" if key else "")
        return InputError(f"{source}:{_key_line(text, section, key)}: {where}: {reason}")

    for sec, body in doc.items():
        if sec not in SECTIONS:
            raise InputError(f"{source}:{_key_line(text, sec, None)}: {unknown_name('section', sec, SECTIONS)}")
        if not isinstance(body, dict):
            raise InputError(f"{source}:{_key_line(text, sec, None)}: {sec} must be a [{sec}] section")
        for key in body:
            if key not in SECTIONS[sec]:
                raise InputError(f"{source}:{_key_line(text, sec, key)}: [{sec}] "
                                 f"{unknown_name('key', key, SECTIONS[sec])}")
    if "isotonic" not in doc:
        raise InputError(f"{source}:1: an [isotonic] section (loads, pressures) is required")

    def quantity(sec: str, key: str, dim: str, default=None, *, zero: bool = True) -> float:
        raw = doc.get(sec, {}).get(key, default)
        if raw is None:
            raise fail(sec, key, "missing")
        if not isinstance(raw, str):
            raise fail(sec, key, f"{raw!r} needs a unit, as text (e.g. \"{EXAMPLE[dim]}\")")
        try:
            return parse_quantity(raw, dim, key, allow_zero=zero)
        except InputError as exc:
            raise fail(sec, key, str(exc)) from None

    def quantities(sec: str, key: str, dim: str, *, zero: bool) -> tuple:
        raw = doc.get(sec, {}).get(key)
        if raw is None:
            raise fail(sec, key, "missing")
        if isinstance(raw, dict):
            extra = set(raw) - {"from", "to", "steps"}
            if extra or not {"from", "to", "steps"} <= set(raw):
                raise fail(sec, key, "a range is { from = \"0MPa\", to = \"0.8MPa\", steps = 9 }")
            n = raw["steps"]
            if not isinstance(n, int) or isinstance(n, bool) or not 2 <= n <= MAX_STEPS:
                raise fail(sec, key, f"steps = {n!r} must be a whole number in 2..{MAX_STEPS}")
            try:
                lo = parse_quantity(str(raw["from"]), dim, f"{key}.from")
                hi = parse_quantity(str(raw["to"]), dim, f"{key}.to")
            except InputError as exc:
                raise fail(sec, key, str(exc)) from None
            values = tuple(float(v) for v in np.linspace(lo, hi, n))
        elif isinstance(raw, list) and raw:
            out = []
            for i, v in enumerate(raw):
                if not isinstance(v, str):
                    raise fail(sec, key, f"item {i + 1} ({v!r}) needs a unit, as text")
                try:
                    out.append(parse_quantity(v, dim, f"{key}[{i + 1}]", allow_zero=True))
                except InputError as exc:
                    raise fail(sec, key, str(exc)) from None
            values = tuple(out)
        else:
            raise fail(sec, key, "a non-empty list of quantities, or a range { from, to, steps }")
        if not zero and min(values) <= 0:
            raise fail(sec, key, "every value must be above zero")
        if any(not math.isfinite(v) or v < 0 for v in values):
            raise fail(sec, key, "every value must be a finite number >= 0")
        return values

    head = doc.get("protocol", {})
    name = head.get("name", "")
    if not isinstance(name, str):
        raise fail("protocol", "name", f"{name!r} must be text")
    trials = head.get("trials", 1)
    if not isinstance(trials, int) or isinstance(trials, bool) or not 1 <= trials <= 20:
        raise fail("protocol", "trials", f"{trials!r} must be a whole number in 1..20")
    p_max = quantity("protocol", "max_pressure", "pressure", f"{P_MAX_DEFAULT / 1e6:g}MPa", zero=False)
    if p_max > P_MAX_LIMIT:
        raise fail("protocol", "max_pressure", f"{p_max / 1e6:g} MPa is above the transducer's full scale "
                                               f"({P_MAX_LIMIT / 1e6:g} MPa)")
    loads = quantities("isotonic", "loads", "force", zero=False)
    if len(set(loads)) != len(loads):
        raise fail("isotonic", "loads", "a load is listed twice (use trials to repeat a load)")
    pressures = quantities("isotonic", "pressures", "pressure", zero=True)
    for sec, ps in (("isotonic", pressures),):
        if any(b <= a for a, b in zip(ps, ps[1:])):
            raise fail(sec, "pressures", "the steps must rise (the sweep comes back down the same steps)")
        if max(ps) > p_max:
            raise fail(sec, "pressures", f"the top step {max(ps) / 1e6:g} MPa is above max_pressure "
                                         f"{p_max / 1e6:g} MPa")
    if len(pressures) < 2:
        raise fail("isotonic", "pressures", "at least two steps")
    hold = quantity("isotonic", "hold", "time", "0.5s")
    if hold > 600:
        raise fail("isotonic", "hold", f"{hold:g} s is longer than 10 minutes")
    window = quantity("settling", "window", "time", "0.2s", zero=False)
    tolerance = quantity("settling", "tolerance", "length", "0.2mm", zero=False)
    timeout = quantity("settling", "timeout", "time", "5s", zero=False)
    if timeout < window:
        raise fail("settling", "timeout", f"{timeout:g} s is shorter than the window ({window:g} s)")
    lengths: tuple = ()
    iso_p: tuple = ()
    if "isometric" in doc:
        lengths = quantities("isometric", "lengths", "length", zero=False)
        iso_p = quantities("isometric", "pressures", "pressure", zero=True) if "pressures" in doc["isometric"] \
            else pressures
        if max(iso_p) > p_max:
            raise fail("isometric", "pressures", f"the top step {max(iso_p) / 1e6:g} MPa is above max_pressure")
    n = len(loads) * trials * (2 * len(pressures) - 1)
    if n > 20_000:
        raise fail("isotonic", "loads", f"{n} steps in all: more than 20000")
    return Protocol(name, loads, pressures, hold, window, tolerance, timeout, trials, p_max, lengths, iso_p,
                    source, text)
