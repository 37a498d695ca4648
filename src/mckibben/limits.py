"""Size guards: estimate a job's memory and time from the user's numbers before allocating.

A duration, a cycle count, a number of plants or discs, a reference file's span: each becomes
arrays of instances × samples. :func:`check_budget` estimates the memory and the time of such a
job and refuses it, naming the option and the estimate, when it passes

- :data:`MEMORY_LIMIT` (4 GiB) or :data:`TIME_LIMIT` (10 minutes): the documented limits, which
  ``--force`` lifts;
- the memory the machine has available now (``MemAvailable``): never lifted, since a job past it
  would be killed by the operating system without a message.

The estimates are deliberately on the safe side: :data:`BYTES_PER_SAMPLE` counts every recorded
channel of the batch simulator plus the working copies of the metrics (measured peak: about 120 B
per instance and control period), :data:`SECONDS_PER_SAMPLE` the simulator's cost per instance and
control period measured on the reference machine (about 7 µs, ``benchmarks/RESULTS.md``).
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os

from mckibben.errors import InputError
from mckibben.hardware import P_MAX_LIMIT
import warnings
import numpy as np

#: Memory one instance costs per control period (recorded channels and working copies). [B]
BYTES_PER_SAMPLE = 256
#: Time one instance costs per control period on the batch simulator. [s]
SECONDS_PER_SAMPLE = 10e-6
#: The documented memory limit, lifted by ``--force``. [B]
MEMORY_LIMIT = 4 * 2**30
#: The documented time limit, lifted by ``--force``. [s]
TIME_LIMIT = 600.0


_LIFTED: contextvars.ContextVar[bool] = contextvars.ContextVar("mckibben_limits_lifted", default=False)


@contextlib.contextmanager
def lifted(force: bool = True):
    """Lift :data:`MEMORY_LIMIT` and :data:`TIME_LIMIT` for the library calls inside (``--force``).

    The library applies the documented limits itself (:func:`mckibben.plant.simulate` and every
    experiment built on it); a caller that means to run past them, as the CLI does with
    ``--force``, says so with ``with lifted(): ...``. The machine's available memory still holds.

    Parameters
    ----------
    force : bool, default True
        False leaves the limits as they are (so ``with lifted(force):`` follows a flag). [-]
    """
    token = _LIFTED.set(_LIFTED.get() or bool(force))
    try:
        yield
    finally:
        _LIFTED.reset(token)


def available_memory() -> float:
    """The memory the machine has available now (``MemAvailable`` of ``/proc/meminfo``). [B]

    Falls back to the physical memory, then to infinity where neither can be read.
    """
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def format_bytes(n: float) -> str:
    """``1.5 GiB``-style text for a byte count. [-]"""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{n:.0f} B"
        n /= 1024.0
    return f"{n:.3g} PiB"  # pragma: no cover


def format_seconds(s: float) -> str:
    """``2.8 h``-style text for a duration. [-]"""
    if not math.isfinite(s):
        return "forever"
    if s < 120:
        return f"{s:.3g} s"
    if s < 7200:
        return f"{s / 60:.3g} min"
    if s < 2 * 86400:
        return f"{s / 3600:.3g} h"
    if s < 2 * 365 * 86400:
        return f"{s / 86400:.3g} days"
    return f"{s / (365.25 * 86400):.3g} years"


def check_budget(option: str, samples: float, *, force: bool = False, what: str = "control periods",
                 bytes_per_sample: float = BYTES_PER_SAMPLE, seconds_per_sample: float = SECONDS_PER_SAMPLE,
                 memory_samples: float | None = None) -> tuple[float, float]:
    """Refuse a job whose estimated memory or time is past the limits; return the estimate.

    Parameters
    ----------
    option : str
        The option (or options) whose value sets the size, for the message, e.g. ``"duration"``. [-]
    samples : float
        Instances × control periods (or the unit of work ``what`` names). [-]
    force : bool, default False
        Lift :data:`MEMORY_LIMIT` and :data:`TIME_LIMIT` (the available memory still holds); so
        does an enclosing :func:`lifted`.
    what : str
        The unit of ``samples`` for the message. [-]
    bytes_per_sample, seconds_per_sample : float
        Cost of one sample. [B], [s]
    memory_samples : float, optional
        Samples held in memory at once, when less than ``samples`` (a job done in chunks). [-]

    Returns
    -------
    (float, float)
        Estimated memory [B] and time [s].

    Raises
    ------
    InputError
        Naming ``option``, the size and the estimate, and how to go on.
    """
    samples = float(samples)
    if not math.isfinite(samples) or samples < 0:
        raise InputError(f"{option}: the size asked is not a finite number")
    held = samples if memory_samples is None else float(memory_samples)
    memory = held * bytes_per_sample
    seconds = samples * seconds_per_sample
    count = f"{samples:,.0f}" if samples < 1e15 else f"{samples:.3g}"
    estimate = f"{count} {what}: about {format_bytes(memory)} of memory and {format_seconds(seconds)}"
    avail = available_memory()
    if memory > avail:
        raise InputError(f"{option}: {estimate}, more than the {format_bytes(avail)} this machine has available; "
                         "ask for less")
    if not (force or _LIFTED.get()) and (memory > MEMORY_LIMIT or seconds > TIME_LIMIT):
        raise InputError(f"{option}: {estimate}, past the limit of {format_bytes(MEMORY_LIMIT)} and "
                         f"{format_seconds(TIME_LIMIT)}; ask for less, or give `force` to run it anyway "
                         "(in Python: with mckibben.limits.lifted(): ...)")
    return memory, seconds


# ---------------------------------------------------------------------------------------------
# Pressure limits: one rule for every command (the supervisor's cap, hardware.P_MAX_LIMIT)


class ClampWarning(UserWarning):
    """A request beyond a physical or safety limit was clamped to it (the result says so)."""


def check_p_max(p_max: float, name: str = "p_max") -> float:
    """Check a maximum pressure against the rig's ceiling :data:`mckibben.hardware.P_MAX_LIMIT`.

    Parameters
    ----------
    p_max : float
        The maximum pressure asked for. [Pa]
    name : str
        The option or argument, for the message. [-]

    Returns
    -------
    float
        ``p_max``. [Pa]
    """

    if not (math.isfinite(p_max) and 0 < p_max <= P_MAX_LIMIT):
        raise InputError(f"{name}: {p_max / 1e6:g} MPa is outside (0, {P_MAX_LIMIT / 1e6:g}] MPa, the supervisor's "
                         "ceiling (the transducer's full scale)")
    return float(p_max)


def clamp_pressure(values, p_max: float, name: str):
    """Clamp a pressure request to [0, p_max] as the supervisor will; warn once if it changed.

    The warning is one line naming ``name``; the caller reports the returned flag in its result,
    and scores against the clamped values (what was actually commanded).

    Parameters
    ----------
    values : float or array_like
        Requested pressures. [Pa]
    p_max : float
        The supervisor's maximum. [Pa]
    name : str
        The option or argument, for the warning. [-]

    Returns
    -------
    (numpy.ndarray or float, bool)
        The clamped values and whether any was clamped.
    """


    arr = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: holds a value that is not a finite number")
    out = np.clip(arr, 0.0, p_max)
    clamped = bool(np.any(out != arr))
    if clamped:
        lo, hi = float(arr.min()), float(arr.max())
        warnings.warn(ClampWarning(
            f"{name}: asks for {lo / 1e6:g}..{hi / 1e6:g} MPa; the supervisor holds every reference in "
            f"[0, {p_max / 1e6:g}] MPa (`p_max`), so that is what is commanded and scored (flag "
            "reference_clamped)"), stacklevel=2)
    return (float(out) if np.ndim(values) == 0 else out), clamped


def check_load(load: float, muscle, name: str = "load") -> float:
    """Refuse a hanging load that no pressure the rig can give would lift.

    The blocked force grows about linearly with pressure (Fig. 3 of the miniature-muscle paper);
    past the blocked force at :data:`mckibben.hardware.P_MAX_LIMIT` the muscle would only hang
    stretched against its braid, outside every model's range.

    Parameters
    ----------
    load : float
        The hanging load. [N]
    muscle : MiniatureMuscle
        The muscle (its published blocked force). [-]
    name : str
        The option, for the message. [-]

    Returns
    -------
    float
        ``load``. [N]
    """

    p_ref, f_ref = muscle.blocked_force[0]
    most = f_ref * P_MAX_LIMIT / p_ref
    if not (math.isfinite(load) and load <= most):
        raise InputError(f"{name}: {load:g} N is more than {muscle.name} can lift at any pressure the rig gives "
                         f"(blocked force {f_ref:g} N at {p_ref / 1e6:g} MPa, about {most:.3g} N at "
                         f"{P_MAX_LIMIT / 1e6:g} MPa)")
    return float(load)


#: Largest plausible magnitude of a measured quantity, per dimension (SI). A value past it is a
#: typo or a corrupt file (a unit slip, 1e300), and would break a fit's linear algebra; these are
#: generous bounds for any braided muscle, hydraulic ones included. [SI]
PLAUSIBLE_MAX = {
    "pressure": 100e6,  # [Pa] 100 MPa
    "length": 10.0,  # [m]
    "force": 1e5,  # [N]
    "angle": 2 * math.pi,  # [rad]
    "time": 1e7,  # [s] about 116 days
    "dimensionless": 1e6,  # [-]
}


#: The shortest muscle length a table may hold: no braided muscle is shorter than a millimetre,
#: so a length column below it holds metres (or centimetres) under a millimetre heading. [m]
PLAUSIBLE_MIN_LENGTH = 1e-3


def first_implausible(values, dimension: str):
    """The index of the first value whose magnitude is past :data:`PLAUSIBLE_MAX`, or None.

    Parameters
    ----------
    values : array_like
        Values in SI. [SI]
    dimension : str
        Their dimension, a key of :data:`PLAUSIBLE_MAX`. [-]
    """

    limit = PLAUSIBLE_MAX.get(dimension)
    if limit is None:
        return None
    bad = np.flatnonzero(np.abs(np.asarray(values, dtype=float)) > limit)
    return int(bad[0]) if bad.size else None
