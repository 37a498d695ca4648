"""Step-response and tracking metrics, one code for simulation and bench.

:func:`step_metrics` scores a sampled response ``(t, y, reference, commands)`` by the definitions
of python-control's :func:`control.step_info` (rise time 10–90 %, settling time 2 %, overshoot)
and adds what the surgical tool cares about: the 63 % time constant, the steady-state error, the
RMS tracking error and the valve effort (the sum of |PWM| counts over the record: air a
controller wastes). The same function scores a simulated closed loop (``mckibben control step``)
and a recording from the rig (``mckibben rig step``). :func:`step_metrics_batch` is the one
implementation: it scores N runs on one time axis at once (sweeps, Monte Carlo), with
``step_info``'s operations row-wise, and :func:`step_metrics` calls it on one row; a test holds
every row equal to ``control.step_info``'s numbers.

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


def _first_crossings(t: np.ndarray, y: np.ndarray, level: np.ndarray) -> np.ndarray:
    """Per row of ``y`` (N, n): the interpolated time of the first sample at or above ``level[i]``."""
    hit = y >= level[:, None]
    k = hit.argmax(axis=1)
    rows = np.arange(y.shape[0])
    km = np.maximum(k - 1, 0)
    yk, ykm = y[rows, k], y[rows, km]
    tk, tkm = t[k], t[km]
    with np.errstate(divide="ignore", invalid="ignore"):
        inner = tkm + (level - ykm) * (tk - tkm) / (yk - ykm)
    out = np.where((k == 0) | (yk == ykm), tk, inner)
    return np.where(hit.any(axis=1), out, np.nan)


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
    return float(_first_crossings(t, y[None, :], np.array([float(level)]))[0])


def _last_true(mask: np.ndarray) -> np.ndarray:
    """Per row: index of the last True, -1 if none."""
    n = mask.shape[1]
    last = n - 1 - mask[:, ::-1].argmax(axis=1)
    return np.where(mask.any(axis=1), last, -1)


def step_metrics_batch(
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
) -> dict[str, np.ndarray]:
    """Metrics of N sampled step responses on one time axis, all at once (NumPy over rows).

    The definitions are those of :func:`step_metrics` (which calls this function on one row):
    rise time, settling time and overshoot are ``control.step_info``'s, computed row-wise with
    the same floating-point operations, so each row gives the numbers ``control.step_info``
    gives for it (tested against it). A row whose response is not finite everywhere (a run the
    simulator flagged) or whose step size is zero gets NaN for every metric.

    Parameters
    ----------
    t : array_like
        Sample times, strictly increasing, shape (n,). [s]
    y : array_like
        Measured outputs, shape (N, n). [unit]
    reference : float or array_like, optional
        Reference: a constant, (n,) shared by every row, or (N, n). Required unless
        ``final="measured"``. [unit]
    commands : array_like, optional
        Valve commands: (N, n) signed (positive inlet, negative bleed) or (N, n, 2) (inlet,
        bleed) counts. Without it the valve effort is NaN. [PWM counts]
    t_step : float, optional
        Time of the step, common to every row. Default: the first change of the reference (the
        same in every row), else ``t[0]``. [s]
    final : {"reference", "measured"}, default "reference"
        What each response is scored against: the final reference or its last sample. [-]
    unit : str, default "Pa"
        Unit of y, used in the key names (``steady_state_error_Pa``). [-]
    steady_fraction : float, default 0.1
        Trailing fraction of the record averaged for the steady-state value. [-]
    settling_threshold : float, default 0.02
        Half-width of the settling band, as a fraction of the step. [-]

    Returns
    -------
    dict of str to numpy.ndarray
        The keys of :func:`step_metrics`, each an (N,) float array. [s, %, unit, counts]

    Raises
    ------
    InputError
        Arrays of mismatched shape, a time axis that does not increase, a non-finite reference,
        rows whose references step at different times (give ``t_step``), or a step time that
        leaves fewer than 3 samples.
    """
    t = _as_1d("time", t)
    n = t.shape[0]
    if n < 3:
        raise InputError(f"step metrics: need at least 3 samples, got {n}")
    if not np.all(np.diff(t) > 0):
        raise InputError("step metrics: time must be strictly increasing")
    y = np.asarray(y, dtype=float)
    if y.ndim != 2 or y.shape[1] != n:
        raise InputError(f"step metrics: y must have shape (N, {n}), got {y.shape}")
    nrow = y.shape[0]
    if final not in ("reference", "measured"):
        raise InputError(f"step metrics: final={final!r} must be 'reference' or 'measured'")
    if reference is None:
        if final == "reference":
            raise InputError("step metrics: a reference is required unless final='measured'")
        r = None
    else:
        r = np.asarray(reference, dtype=float)
        if r.ndim < 2:
            r = _as_1d("reference", r, n)[None, :]
        elif r.shape != (nrow, n):
            raise InputError(f"step metrics: reference must be a constant, ({n},) or ({nrow}, {n}), got {r.shape}")
        elif not np.all(np.isfinite(r)):
            raise InputError("step metrics: reference contains NaN or infinite values")
    if not 0.0 < steady_fraction <= 1.0:
        raise InputError(f"step metrics: steady_fraction={steady_fraction!r} must be in (0, 1]")

    if t_step is None:
        t_step = float(t[0])
        if r is not None:
            changed = r != r[:, :1]
            first = np.where(changed.any(axis=1), changed.argmax(axis=1), 0)
            if np.any(first != first[0]):
                raise InputError("step metrics: the rows' references step at different times; give t_step")
            t_step = float(t[int(first[0])])
    k0 = int(np.searchsorted(t, t_step, side="left"))
    if k0 >= n - 2:
        raise InputError(f"step metrics: step time {t_step!r} s leaves fewer than 3 samples")
    c = _commands(commands, nrow, n)
    tt = t[k0:] - t_step
    names = {"steady_state_error": f"steady_state_error_{unit}", "rms_error": f"rms_error_{unit}",
             "step_size": f"step_size_{unit}"}
    out: dict[str, np.ndarray] = {}
    for i in range(0, nrow, _ROWS):  # blocks of rows: the temporaries stay in the cache
        rows = slice(i, i + _ROWS)
        part = _score_steps(tt, k0, y[rows], None if r is None else r[rows] if r.shape[0] > 1 else r,
                            None if c is None else c[rows], final, steady_fraction, settling_threshold)
        for key, v in part.items():
            out.setdefault(names.get(key, key), np.empty(nrow))[rows] = v
    return out


#: Rows scored together by :func:`step_metrics_batch` (a 512 × 200 float block is 0.8 MB).
_ROWS = 512


def _score_steps(tt, k0, y, r, c, final, steady_fraction, settling_threshold) -> dict[str, np.ndarray]:
    """The metrics of a block of rows (see :func:`step_metrics_batch`); r is (1 or N, n) or None."""
    nrow = y.shape[0]
    # the value the step starts from: the last sample before it (or the first one)
    base = y[:, k0 - 1] if k0 > 0 else y[:, 0]
    yk = y[:, k0:]
    yy = yk - base[:, None]
    n_ss = max(1, int(round(steady_fraction * yy.shape[1])))
    y_ss = np.mean(yk[:, -n_ss:], axis=1)
    target = np.broadcast_to(r[:, -1], (nrow,)) if final == "reference" else y[:, -1]
    step = target - base
    good = np.all(np.isfinite(y), axis=1) & (step != 0.0)
    nan = np.full(nrow, np.nan)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sgn = np.copysign(1.0, step)
        sy = sgn[:, None] * yy
        abs_step = np.abs(step)
        tc = _first_crossings(tt, sy, ONE_MINUS_INV_E * abs_step)
        # control.step_info (python-control, time-response data with final_output=step): rise
        # time 10-90 %, settling time (first sample after the last one outside the band),
        # overshoot; undefined (NaN) unless the response reaches 90 % of the step.
        reached = np.any(sy >= (0.9 * abs_step)[:, None], axis=1) & good
        s_col = step[:, None]
        sg_col = np.sign(step)[:, None]
        lo = (sg_col * (yy - 0.1 * s_col) >= 0).argmax(axis=1)
        up = (sg_col * (yy - 0.9 * s_col) >= 0).argmax(axis=1)
        rise = tt[up] - tt[lo]
        settled = _last_true(np.abs(yy / s_col - 1) >= settling_threshold) + 1
        m = tt.shape[0]
        settling = np.where(settled < m, tt[np.minimum(settled, m - 1)], np.nan)
        dy_os = np.abs(sy.max(axis=1)) - abs_step
        overshoot = np.where(dy_os > 0, np.abs(100.0 * dy_os / step), 0.0)
        peak = tt[sy.argmax(axis=1)]
        out = {
            "time_constant_s": np.where(good, tc, nan),
            "rise_time_s": np.where(reached, rise, nan),
            "settling_time_s": np.where(reached, settling, nan),
            "overshoot_pct": np.where(reached, overshoot, nan),
            "peak_time_s": np.where(reached, peak, nan),
            "steady_state_error": nan,
            "rms_error": nan,
        }
        if r is not None:
            out["steady_state_error"] = np.where(good, r[:, -1] - y_ss, nan)
            out["rms_error"] = np.where(good, np.sqrt(np.mean((r[:, k0:] - yk) ** 2, axis=1)), nan)
    out["valve_effort_counts"] = np.where(good, _effort(c, nrow, k0), nan)
    out["step_size"] = np.where(good, step, nan)
    return out


def _commands(commands, nrow: int, n: int, what: str = "step metrics") -> np.ndarray | None:
    """The commands as (N, n) or (N, n, 2) floats, checked (None without them)."""
    if commands is None:
        return None
    c = np.asarray(commands, dtype=float)
    if c.shape not in ((nrow, n), (nrow, n, 2)):
        raise InputError(f"{what}: commands must have shape ({nrow}, {n}) or ({nrow}, {n}, 2), got {c.shape}")
    return c


def _effort(c: np.ndarray | None, nrow: int, k0: int) -> np.ndarray:
    """Σ |PWM| per row from sample k0 on (NaN without commands)."""
    if c is None:
        return np.full(nrow, np.nan)
    return np.abs(c[:, k0:]).reshape(nrow, -1).sum(axis=1)


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
    y = _as_1d("y", y, n)
    r = None if reference is None else _as_1d("reference", reference, n)
    c = None
    if commands is not None:
        c = np.asarray(commands, dtype=float)
        if c.ndim == 1:
            c = _as_1d("commands", c, n)
        elif c.ndim != 2 or c.shape[0] != n or c.shape[1] != 2:
            raise InputError(f"step metrics: commands must have shape ({n},) or ({n}, 2), got {c.shape}")
        c = c[None]
    out = step_metrics_batch(t, y[None, :], r, c, t_step=t_step, final=final, unit=unit,
                             steady_fraction=steady_fraction, settling_threshold=settling_threshold)
    if math.isnan(out[f"step_size_{unit}"][0]):
        raise InputError("step metrics: the step size is zero (final value equals the start)")
    return {k: float(v[0]) for k, v in out.items()}


def tracking_metrics_batch(t, y, reference, commands=None, *, unit: str = "Pa") -> dict[str, np.ndarray]:
    """Metrics of N tracking records on one time axis, all at once (NumPy over rows).

    The definitions of :func:`tracking_metrics` (which calls this function on one row). A row
    whose output is not finite everywhere (a run the simulator flagged) gets NaN.

    Parameters
    ----------
    t : array_like
        Sample times, strictly increasing, shape (n,). [s]
    y : array_like
        Measured outputs, shape (N, n). [unit]
    reference : array_like
        Reference, (n,) shared by every row or (N, n). [unit]
    commands : array_like, optional
        (N, n) signed commands or (N, n, 2) (inlet, bleed) counts. [PWM counts]
    unit : str, default "Pa"
        Unit of y, used in the key names. [-]

    Returns
    -------
    dict of str to numpy.ndarray
        The keys of :func:`tracking_metrics`, each an (N,) float array. [unit, counts, s]
    """
    t = _as_1d("time", t)
    n = t.shape[0]
    y = np.asarray(y, dtype=float)
    if y.ndim != 2 or y.shape[1] != n:
        raise InputError(f"tracking metrics: y must have shape (N, {n}), got {y.shape}")
    nrow = y.shape[0]
    r = np.asarray(reference, dtype=float)
    if r.ndim < 2:
        r = _as_1d("reference", r, n)[None, :]
    elif r.shape != (nrow, n) or not np.all(np.isfinite(r)):
        raise InputError(f"tracking metrics: reference must be finite, ({n},) or ({nrow}, {n}), got {r.shape}")
    good = np.all(np.isfinite(y), axis=1)
    nan = np.full(nrow, np.nan)
    with np.errstate(invalid="ignore", over="ignore"):
        e = r - y
        out = {
            f"rms_error_{unit}": np.where(good, np.sqrt(np.mean(e**2, axis=1)), nan),
            f"max_abs_error_{unit}": np.where(good, np.max(np.abs(e), axis=1), nan),
            f"mean_error_{unit}": np.where(good, np.mean(e, axis=1), nan),
            "valve_effort_counts": np.where(good, _effort(_commands(commands, nrow, n, "tracking metrics"), nrow, 0), nan),
            "duration_s": np.where(good, float(t[-1] - t[0]), nan),
        }
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
    c = None if commands is None else np.asarray(commands, dtype=float)[None]
    out = tracking_metrics_batch(t, y[None, :], r, c, unit=unit)
    return {k: float(v[0]) for k, v in out.items()}
