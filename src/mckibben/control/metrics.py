"""Step-response and tracking metrics, one code for simulation and bench.

:func:`step_metrics` scores a sampled response ``(t, y, reference, commands)`` with
python-control's :func:`control.step_info` (rise time 10–90 %, settling time 2 %, overshoot) and
adds what the surgical tool cares about: the 63 % time constant, the steady-state error, the RMS
tracking error and the valve effort (the sum of |PWM| counts over the record: air a controller
wastes). The same function scores a simulated closed loop (``mckibben control step``) and a
recording from the rig (``mckibben rig step``).

Keys of the returned dict (SI, unit-suffixed; ``{u}`` is the ``unit`` argument, ``Pa`` by
default):

========================  =====================================================================
``time_constant_s``       time from the step until y first reaches 63.2 % of the way to the
                          final value (linear interpolation between samples; includes dead time)
``rise_time_s``           10 % → 90 % rise time, ``control.step_info``
``settling_time_s``       time after the step when y last leaves the ±2 % band around the
                          final value, ``control.step_info``
``overshoot_pct``         peak beyond the final value, percent of the step, ``control.step_info``
``peak_time_s``           time of the peak, from the step
``steady_state_error_{u}``  reference − mean of y over the last ``steady_fraction`` of the record
``rms_error_{u}``         RMS of reference − y from the step to the end
``valve_effort_counts``   Σ |PWM| over inlet and bleed, every sample from the step to the end
``step_size_{u}``         final value − value at the step
========================  =====================================================================

The final value is the reference (a controlled step is scored against its target, so a
steady-state error shows up as a longer settling time) unless ``final="measured"`` (the last
sample; use it for open-loop identification records, which have no pressure reference).
Undefined metrics (a response that never reaches 90 % has no rise time) are NaN.
"""

from __future__ import annotations

import math

import control
import numpy as np

from mckibben.errors import InputError

#: Fraction of the step that defines the time constant (1 − e⁻¹).
ONE_MINUS_INV_E = 1.0 - math.exp(-1.0)


def _as_1d(name: str, x, n: int | None = None) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 and n is not None:
        a = np.full(n, float(a))
    if a.ndim != 1:
        raise InputError(f"step metrics: {name} must be one-dimensional, got shape {a.shape}")
    if n is not None and a.shape[0] != n:
        raise InputError(f"step metrics: {name} has {a.shape[0]} samples, time has {n}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"step metrics: {name} contains NaN or infinite values")
    return a


def crossing_time(t, y, level: float) -> float:
    """First time a sampled signal reaches ``level`` from below (linear interpolation).

    Parameters
    ----------
    t : array_like
        Sample times, increasing. [s]
    y : array_like
        Signal, rising towards ``level`` (negate both for a falling one). [any]
    level : float
        Level to reach. [same as y]

    Returns
    -------
    float
        Interpolated time of the first sample at or above ``level``; NaN if never reached. [s]

    Examples
    --------
    >>> crossing_time([0.0, 1.0, 2.0], [0.0, 1.0, 2.0], 1.5)
    1.5
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    idx = np.flatnonzero(y >= level)
    if idx.size == 0:
        return math.nan
    k = int(idx[0])
    if k == 0 or y[k] == y[k - 1]:
        return float(t[k])
    return float(t[k - 1] + (level - y[k - 1]) * (t[k] - t[k - 1]) / (y[k] - y[k - 1]))


def step_metrics(
    t,
    y,
    reference=None,
    commands=None,
    *,
    t_step: float | None = None,
    final: str = "reference",
    unit: str = "Pa",
    steady_fraction: float = 0.1,
    settling_threshold: float = 0.02,
) -> dict[str, float]:
    """Metrics of one sampled step response (or tracking record).

    Parameters
    ----------
    t : array_like
        Sample times, strictly increasing. [s]
    y : array_like
        Measured output, e.g. pressure. [unit]
    reference : float or array_like, optional
        Reference, a constant or one value per sample. Required unless ``final="measured"``. [unit]
    commands : array_like, optional
        Valve commands per sample: a 1-D signed command (positive inlet, negative bleed) or an
        ``(n, 2)`` array of (inlet, bleed) counts. Without it the valve effort is NaN. [PWM counts]
    t_step : float, optional
        Time of the step. Default: the first change of an array reference, else ``t[0]``. [s]
    final : {"reference", "measured"}, default "reference"
        What the response is scored against: the final reference or the last sample of y. [-]
    unit : str, default "Pa"
        Unit of y, used in the key names (``steady_state_error_Pa``). [-]
    steady_fraction : float, default 0.1
        Trailing fraction of the record averaged for the steady-state value. [-]
    settling_threshold : float, default 0.02
        Half-width of the settling band, as a fraction of the step. [-]

    Returns
    -------
    dict of str to float
        The metrics listed in the module docstring. [s, %, unit, counts]

    Raises
    ------
    InputError
        Arrays of mismatched length, non-finite values, a time axis that does not increase, no
        step (zero step size), or a missing reference.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 1, 1e-3)
    >>> m = step_metrics(t, 1 - np.exp(-t / 0.1), reference=1.0, unit="")
    >>> round(m["time_constant_s"], 3)
    0.1
    """
    t = _as_1d("time", t)
    n = t.shape[0]
    if n < 3:
        raise InputError(f"step metrics: need at least 3 samples, got {n}")
    if not np.all(np.diff(t) > 0):
        raise InputError("step metrics: time must be strictly increasing")
    y = _as_1d("y", y, n)
    if final not in ("reference", "measured"):
        raise InputError(f"step metrics: final={final!r} must be 'reference' or 'measured'")
    if reference is None:
        if final == "reference":
            raise InputError("step metrics: a reference is required unless final='measured'")
        r = None
    else:
        r = _as_1d("reference", reference, n)
    if not 0.0 < steady_fraction <= 1.0:
        raise InputError(f"step metrics: steady_fraction={steady_fraction!r} must be in (0, 1]")

    if t_step is None:
        if r is not None and np.any(r != r[0]):
            t_step = float(t[int(np.flatnonzero(r != r[0])[0])])
        else:
            t_step = float(t[0])
    k0 = int(np.searchsorted(t, t_step, side="left"))
    if k0 >= n - 2:
        raise InputError(f"step metrics: step time {t_step!r} s leaves fewer than 3 samples")
    # the value the step starts from: the last sample before it (or the first one)
    base = float(y[k0 - 1] if k0 > 0 else y[0])
    tt = t[k0:] - t_step
    yy = y[k0:] - base
    n_ss = max(1, int(round(steady_fraction * yy.shape[0])))
    y_ss = float(np.mean(y[k0:][-n_ss:]))
    target = float(r[-1]) if final == "reference" else float(y[-1])
    step = target - base
    if step == 0.0:
        raise InputError("step metrics: the step size is zero (final value equals the start)")
    sgn = math.copysign(1.0, step)

    out = {
        "time_constant_s": crossing_time(tt, sgn * yy, ONE_MINUS_INV_E * abs(step)),
        "rise_time_s": math.nan,
        "settling_time_s": math.nan,
        "overshoot_pct": math.nan,
        "peak_time_s": math.nan,
    }
    # control.step_info indexes the first 90 % crossing without a guard: only call it when the
    # response gets there (else rise time, settling and overshoot are undefined -> NaN).
    if np.any(sgn * yy >= 0.9 * abs(step)):
        info = control.step_info(yy, timepts=tt, final_output=step,
                                 SettlingTimeThreshold=settling_threshold)
        out["rise_time_s"] = info["RiseTime"]
        out["settling_time_s"] = info["SettlingTime"]
        out["overshoot_pct"] = info["Overshoot"]
        out["peak_time_s"] = float(tt[int(np.argmax(sgn * yy))])
    if r is not None:
        out[f"steady_state_error_{unit}"] = float(r[-1]) - y_ss
        out[f"rms_error_{unit}"] = float(np.sqrt(np.mean((r[k0:] - y[k0:]) ** 2)))
    else:
        out[f"steady_state_error_{unit}"] = math.nan
        out[f"rms_error_{unit}"] = math.nan
    if commands is None:
        out["valve_effort_counts"] = math.nan
    else:
        c = np.asarray(commands, dtype=float)
        if c.ndim == 1:
            c = _as_1d("commands", c, n)
        elif c.ndim != 2 or c.shape[0] != n or c.shape[1] != 2:
            raise InputError(f"step metrics: commands must have shape ({n},) or ({n}, 2), got {c.shape}")
        out["valve_effort_counts"] = float(np.abs(c[k0:]).sum())
    out[f"step_size_{unit}"] = step
    return out


def tracking_metrics(t, y, reference, commands=None, *, unit: str = "Pa") -> dict[str, float]:
    """Metrics of a tracking record: RMS and maximum error, valve effort.

    Parameters
    ----------
    t : array_like
        Sample times, strictly increasing. [s]
    y : array_like
        Measured output. [unit]
    reference : array_like
        Reference per sample. [unit]
    commands : array_like, optional
        Signed command per sample or ``(n, 2)`` (inlet, bleed) counts. [PWM counts]
    unit : str, default "Pa"
        Unit of y, used in the key names. [-]

    Returns
    -------
    dict of str to float
        ``rms_error_{unit}``, ``max_abs_error_{unit}``, ``mean_error_{unit}``,
        ``valve_effort_counts``, ``duration_s``. [unit, counts, s]
    """
    t = _as_1d("time", t)
    n = t.shape[0]
    y = _as_1d("y", y, n)
    r = _as_1d("reference", reference, n)
    e = r - y
    out = {
        f"rms_error_{unit}": float(np.sqrt(np.mean(e**2))),
        f"max_abs_error_{unit}": float(np.max(np.abs(e))),
        f"mean_error_{unit}": float(np.mean(e)),
        "valve_effort_counts": math.nan if commands is None else float(np.abs(np.asarray(commands, float)).sum()),
        "duration_s": float(t[-1] - t[0]),
    }
    return out
