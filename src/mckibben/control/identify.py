"""Identification of low-order models from an open-loop step response.

The paper identifies the pressure loop of its 100 mm muscle from "a voltage step input to the
driver circuit": first order, τ ≈ 0.09 s, no overshoot (000_909f662a44080c85.txt, §IV.A). We fit

- first order plus dead time (FOPDT): ``y = y0 + K·Δu·(1 − exp(−(t − t_step − θ)/τ))`` for
  ``t ≥ t_step + θ``, else ``y0``;
- optionally second order plus dead time: ``K·Δu·K₂(t − t_step − θ)`` with ``K₂`` the unit step
  response of ``ωn²/(s² + 2ζωn·s + ωn²)`` (any damping ζ > 0);

by nonlinear least squares (:func:`scipy.optimize.curve_fit`) with standard errors from the
covariance scaled by the residual variance, residuals, RMSE and AIC for the comparison. The
standard errors assume independent residuals; a step response's residuals are correlated
(unmodelled dynamics show as structure, not noise), so read them as a lower bound of the
uncertainty — the residuals are returned so their structure can be inspected.

The gain is in output units per input unit (Pa per PWM count for a valve-command step); without
an input column the input step is taken as 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import control
import numpy as np
from scipy import optimize, stats

from mckibben.errors import InputError


def fopdt_response(t, gain: float, tau: float, dead_time: float, y0: float = 0.0, t_step: float = 0.0,
                   input_step: float = 1.0):
    """Step response of a first-order-plus-dead-time model.

    Parameters
    ----------
    t : array_like
        Time. [s]
    gain : float
        Static gain, output per input unit. [output/input]
    tau : float
        Time constant. [s]
    dead_time : float
        Dead time after the step before the output moves. [s]
    y0 : float, default 0.0
        Output before the step. [output]
    t_step : float, default 0.0
        Time of the input step. [s]
    input_step : float, default 1.0
        Size of the input step. [input]

    Returns
    -------
    numpy.ndarray
        Output. [output]

    Examples
    --------
    >>> float(fopdt_response(0.09, gain=2.0, tau=0.09, dead_time=0.0)) == 2.0 * (1 - math.exp(-1))
    True
    """
    s = np.maximum(np.asarray(t, dtype=float) - t_step - dead_time, 0.0)
    return y0 + gain * input_step * -np.expm1(-s / tau)


def sopdt_response(t, gain: float, wn: float, zeta: float, dead_time: float, y0: float = 0.0,
                   t_step: float = 0.0, input_step: float = 1.0):
    """Step response of a second-order-plus-dead-time model ``K·ωn²/(s² + 2ζωn·s + ωn²)·e^(−θs)``.

    Parameters
    ----------
    t : array_like
        Time. [s]
    gain : float
        Static gain, output per input unit. [output/input]
    wn : float
        Natural frequency. [rad/s]
    zeta : float
        Damping ratio, > 0 (under-, critically or over-damped). [-]
    dead_time : float
        Dead time. [s]
    y0 : float, default 0.0
        Output before the step. [output]
    t_step : float, default 0.0
        Time of the input step. [s]
    input_step : float, default 1.0
        Size of the input step. [input]

    Returns
    -------
    numpy.ndarray
        Output. [output]
    """
    s = np.maximum(np.asarray(t, dtype=float) - t_step - dead_time, 0.0)
    z = zeta if abs(zeta - 1.0) > 1e-6 else 1.0 + 1e-6  # the formula is singular at ζ = 1 exactly
    root = np.sqrt(complex(z * z - 1.0))
    p1 = -wn * (z - root)
    p2 = -wn * (z + root)
    with np.errstate(over="ignore", invalid="ignore"):
        unit = 1.0 + (p2 * np.exp(p1 * s) - p1 * np.exp(p2 * s)) / (p1 - p2)
    return y0 + gain * input_step * np.real(unit)


@dataclass(frozen=True)
class StepFit:
    """A low-order model fitted to one step response, with its uncertainty.

    Parameters
    ----------
    order : int
        1 (FOPDT) or 2 (SOPDT). [-]
    params : dict of str to float
        Fitted values: ``gain`` [output/input], ``dead_time_s``, ``y0`` [output] and ``tau_s``
        (order 1) or ``wn_rad_s``, ``zeta`` (order 2). [mixed]
    stderr : dict of str to float
        Standard errors of ``params`` (covariance scaled by the residual variance). [mixed]
    t_step : float
        Time of the input step. [s]
    input_step : float
        Size of the input step (1 when no input column was given). [input]
    t : numpy.ndarray
        Time of the fitted samples. [s]
    residuals : numpy.ndarray
        Measured minus fitted output at ``t``. [output]
    rmse : float
        Root mean square of the residuals. [output]
    r2 : float
        Coefficient of determination. [-]
    aic : float
        Akaike information criterion, n·ln(RSS/n) + 2k (lower is better). [-]
    """

    order: int
    params: dict
    stderr: dict
    t_step: float
    input_step: float
    t: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    rmse: float
    r2: float
    aic: float

    @property
    def gain(self) -> float:
        """Static gain. [output/input]"""
        return self.params["gain"]

    @property
    def tau(self) -> float:
        """First-order time constant; for order 2 the equivalent 2ζ/ωn. [s]"""
        if self.order == 1:
            return self.params["tau_s"]
        return 2.0 * self.params["zeta"] / self.params["wn_rad_s"]

    @property
    def dead_time(self) -> float:
        """Dead time. [s]"""
        return self.params["dead_time_s"]

    def predict(self, t) -> np.ndarray:
        """The fitted response at times ``t``.

        Parameters
        ----------
        t : array_like
            Time. [s]
        """
        p = self.params
        if self.order == 1:
            return fopdt_response(t, p["gain"], p["tau_s"], p["dead_time_s"], p["y0"], self.t_step, self.input_step)
        return sopdt_response(t, p["gain"], p["wn_rad_s"], p["zeta"], p["dead_time_s"], p["y0"], self.t_step,
                              self.input_step)

    def transfer_function(self, pade_order: int = 0) -> control.TransferFunction:
        """The model as a python-control transfer function (input → output deviation).

        Parameters
        ----------
        pade_order : int, default 0
            Order of the Padé approximation of the dead time; 0 leaves the dead time out. [-]
        """
        p = self.params
        if self.order == 1:
            sys = control.tf([p["gain"]], [p["tau_s"], 1.0])
        else:
            wn, z = p["wn_rad_s"], p["zeta"]
            sys = control.tf([p["gain"] * wn * wn], [1.0, 2 * z * wn, wn * wn])
        if pade_order > 0 and p["dead_time_s"] > 0:
            num, den = control.pade(p["dead_time_s"], pade_order)
            sys = sys * control.tf(num, den)
        return sys

    def confidence_intervals(self, level: float = 0.95) -> dict:
        """Symmetric confidence intervals from the standard errors (Student t).

        Parameters
        ----------
        level : float, default 0.95
            Confidence level. [-]
        """
        dof = max(len(self.t) - len(self.params), 1)
        q = stats.t.ppf(0.5 + level / 2.0, dof)
        return {k: (v - q * self.stderr[k], v + q * self.stderr[k]) for k, v in self.params.items()}

    def to_dict(self, output_unit: str = "", input_unit: str = "") -> dict:
        """Plain dict for JSON: values, standard errors and fit statistics.

        Parameters
        ----------
        output_unit : str, default ""
            Unit of the output used as key suffix (``"Pa"`` → ``y0_Pa``, ``rmse_Pa``). [-]
        input_unit : str, default ""
            Unit of the input (``"count"`` → ``gain_Pa_per_count``). [-]
        """
        suffix = f"_{output_unit}" if output_unit else ""
        gain_key = f"gain{suffix}_per_{input_unit}" if input_unit else f"gain{suffix}"
        rename = {"gain": gain_key, "y0": f"y0{suffix}"}
        out = {"order": self.order, "t_step_s": self.t_step, "input_step": self.input_step}
        for k, v in self.params.items():
            out[rename.get(k, k)] = v
            out[f"{rename.get(k, k)}_stderr"] = self.stderr[k]
        out.update({f"rmse{suffix}": self.rmse, "r2": self.r2, "aic": self.aic, "n_samples": int(len(self.t)),
                    f"max_abs_residual{suffix}": float(np.max(np.abs(self.residuals)))})
        return out


def _validate(t, y, u):
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or y.shape != t.shape:
        raise InputError(f"identify: time and output must be 1-D of equal length, got {t.shape} and {y.shape}")
    if t.size < 10:
        raise InputError(f"identify: need at least 10 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
        raise InputError("identify: time or output contains NaN or infinite values")
    if not np.all(np.diff(t) > 0):
        raise InputError("identify: time must be strictly increasing")
    if u is not None:
        u = np.asarray(u, dtype=float)
        if u.shape != t.shape or not np.all(np.isfinite(u)):
            raise InputError("identify: the input column must be finite and as long as the time column")
    return t, y, u


def _locate_step(t, y, u, t_step, input_step):
    if u is not None:
        changes = np.flatnonzero(np.diff(u) != 0)
        if t_step is None:
            if changes.size == 0:
                raise InputError("identify: the input column never changes, there is no step")
            t_step = float(t[changes[0] + 1])
        k = int(np.searchsorted(t, t_step))
        before = u[k - 1] if k > 0 else u[0]
        after = u[min(k, len(u) - 1)]
        if input_step is None:
            input_step = float(after - before)
    else:
        if t_step is None:
            t_step = float(t[0])
        if input_step is None:
            input_step = 1.0
    if input_step == 0:
        raise InputError("identify: the input step is zero")
    if not t[0] <= t_step < t[-5]:
        raise InputError(f"identify: the step at {t_step} s is not inside the record")
    return float(t_step), float(input_step)


def fit_step_response(t, y, u=None, *, order: int = 1, t_step: float | None = None,
                      input_step: float | None = None) -> StepFit:
    """Fit a first- or second-order-plus-dead-time model to one step response.

    Parameters
    ----------
    t : array_like
        Sample times, strictly increasing. [s]
    y : array_like
        Output (e.g. gauge pressure). [output]
    u : array_like, optional
        Input per sample (e.g. signed valve command); the first change is the step. [input]
    order : {1, 2}, default 1
        Model order. [-]
    t_step : float, optional
        Time of the input step (default: the first change of ``u``, else ``t[0]``). [s]
    input_step : float, optional
        Input step size (default: from ``u``, else 1). [input]

    Returns
    -------
    StepFit
        Fitted parameters, standard errors, residuals and fit statistics.

    Raises
    ------
    InputError
        Bad arrays, no step in the input, or no response to fit.
    RuntimeError
        The optimizer failed (carries its message).

    References
    ----------
    000_909f662a44080c85.txt, §IV.A (first-order model from an open-loop step).

    Examples
    --------
    >>> t = np.arange(0, 1, 1e-3)
    >>> y = fopdt_response(t, 2500.0, 0.09, 0.01, t_step=0.1, input_step=200)
    >>> f = fit_step_response(t, y, np.where(t >= 0.1, 200, 0))
    >>> round(f.tau, 3), round(f.gain), round(f.dead_time, 3)
    (0.09, 2500, 0.01)
    """
    if order not in (1, 2):
        raise InputError(f"identify: order={order!r} must be 1 or 2")
    t, y, u = _validate(t, y, u)
    t_step, du = _locate_step(t, y, u, t_step, input_step)
    k0 = int(np.searchsorted(t, t_step))
    y_before = float(np.mean(y[max(0, k0 - 20):k0])) if k0 > 0 else float(y[0])
    n_end = max(3, len(y) // 10)
    y_end = float(np.mean(y[-n_end:]))
    dy = y_end - y_before
    if dy == 0 or not np.any(np.abs(y[k0:] - y_before) > 0.5 * abs(dy)):
        raise InputError("identify: the output does not respond to the step")
    ts = t[k0:] - t_step
    rel = (y[k0:] - y_before) / dy
    t10 = float(ts[np.argmax(rel >= 0.1)])
    t63 = float(ts[np.argmax(rel >= 1 - math.exp(-1))])
    dt = float(np.median(np.diff(t)))
    tau0 = max((t63 - t10) / (1 - 0.105), 2 * dt)
    theta0 = max(t63 - tau0, 0.0)
    k_guess = dy / du
    span = float(t[-1] - t_step)
    kmag = abs(k_guess) * 10 + 1e-12
    if order == 1:
        names = ["gain", "tau_s", "dead_time_s", "y0"]

        def f(tt, k, tau, th, y0):
            return fopdt_response(tt, k, tau, th, y0, t_step, du)

        p0 = [k_guess, tau0, theta0, y_before]
        lo = [-kmag, dt * 1e-3, 0.0, -np.inf]
        hi = [kmag, 10 * span, span, np.inf]
    else:
        names = ["gain", "wn_rad_s", "zeta", "dead_time_s", "y0"]

        def f(tt, k, wn, z, th, y0):
            return sopdt_response(tt, k, wn, z, th, y0, t_step, du)

        p0 = [k_guess, 2.0 / tau0, 1.2, theta0, y_before]
        lo = [-kmag, 1e-3 / span, 0.05, 0.0, -np.inf]
        hi = [kmag, 1e3 / dt, 20.0, span, np.inf]
    p0 = [min(max(v, a + 1e-12 if np.isfinite(a) else v), b - 1e-12 if np.isfinite(b) else v)
          for v, a, b in zip(p0, lo, hi)]
    try:
        popt, pcov = optimize.curve_fit(f, t, y, p0=p0, bounds=(lo, hi), maxfev=20000)
    except (RuntimeError, optimize.OptimizeWarning, ValueError) as exc:
        raise RuntimeError(f"identify: the order-{order} fit failed: {exc}") from exc
    fit = f(t, *popt)
    res = y - fit
    rss = float(np.sum(res**2))
    n = len(y)
    tss = float(np.sum((y - np.mean(y)) ** 2))
    with np.errstate(invalid="ignore"):
        se = np.sqrt(np.clip(np.diag(pcov), 0, None))
    return StepFit(
        order=order,
        params={k: float(v) for k, v in zip(names, popt)},
        stderr={k: float(v) for k, v in zip(names, se)},
        t_step=t_step,
        input_step=du,
        t=t,
        residuals=res,
        rmse=math.sqrt(rss / n),
        r2=1.0 - rss / tss if tss > 0 else math.nan,
        aic=n * math.log(max(rss, 1e-300) / n) + 2 * len(names),
    )


# --- step-response logs --------------------------------------------------------------------------

#: Column names of the valve commands in a step log (as in the rig's telemetry, docs/protocol.md).
INLET_COLUMN, BLEED_COLUMN, COMMAND_COLUMN = "inlet_pwm", "bleed_pwm", "command_pwm"


def read_step_log(path) -> tuple[dict, dict]:
    """Read a step-response log (CSV or Parquet) into SI arrays.

    Columns follow the ``quantity_unit`` convention: a time column ``time_<unit>`` (``time_s``,
    ``time_ms``), a pressure column ``pressure_<unit>`` (``pressure_MPa``, ``pressure_kPa``, …)
    and the valve command either as ``inlet_pwm`` and ``bleed_pwm`` (counts 0..255; the signed
    command is inlet − bleed) or as one signed ``command_pwm``. Other columns are ignored.

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv`` or ``.parquet`` file. [-]

    Returns
    -------
    tuple of dict
        ``({"time_s", "pressure_Pa", "command_pwm"(optional)}, {"path", "columns"})``: arrays in
        SI and where they came from. [s, Pa, counts]

    Raises
    ------
    InputError
        Missing file or column, unknown unit, a non-numeric or missing value (named by
        file:row:column; rows count from 1 after the header), time not increasing.
    """
    import pathlib

    import pandas as pd

    from mckibben.units import split_column, to_si

    from mckibben.atomic import check_input_file

    p = check_input_file(pathlib.Path(path))
    try:
        if p.suffix.lower() == ".parquet":
            df = pd.read_parquet(p)
        elif p.suffix.lower() in (".csv", ".txt"):
            df = pd.read_csv(p, comment="#")
        else:
            raise InputError(f"{p}: unknown log format {p.suffix!r} (use .csv or .parquet)")
    except InputError:
        raise
    except Exception as exc:  # parser errors from pandas/pyarrow: one line, no traceback
        raise InputError(f"{p}: cannot be read as {p.suffix[1:]}: {str(exc).splitlines()[0]}") from exc

    def pick(quantity, dimension):
        found = [c for c in df.columns if split_column(str(c))[0] == quantity and split_column(str(c))[1]]
        if not found:
            raise InputError(f"{p}: no {quantity}_<unit> column (have: {', '.join(map(str, df.columns))})")
        col = str(found[0])
        return col, to_si(numeric(col), split_column(col)[1], dimension, where=f"{p}:{col}")

    def numeric(col):
        v = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise InputError(f"{p}:{bad[0] + 1}:{col}: value {df[col].iloc[bad[0]]!r} is not a finite number")
        return v

    tcol, t = pick("time", "time")
    pcol, pressure = pick("pressure", "pressure")
    if len(t) < 2 or not np.all(np.diff(t) > 0):
        k = int(np.argmax(np.diff(t) <= 0)) + 2 if len(t) >= 2 else 1
        raise InputError(f"{p}:{k}:{tcol}: time must be strictly increasing")
    from mckibben.limits import PLAUSIBLE_MAX, first_implausible

    for values, col, dim, unit in ((t, tcol, "time", "s"), (pressure, pcol, "pressure", "Pa")):
        bad = first_implausible(values, dim)
        if bad is not None:
            raise InputError(f"{p}:{bad + 2}:{col}: {values[bad]:g} {unit} is not a plausible {dim} "
                             f"(more than {PLAUSIBLE_MAX[dim]:g} {unit})")
    data = {"time_s": t, "pressure_Pa": pressure}
    cols = {"time": tcol, "pressure": pcol}
    if INLET_COLUMN in df.columns and BLEED_COLUMN in df.columns:
        data["command_pwm"] = numeric(INLET_COLUMN) - numeric(BLEED_COLUMN)
        cols["command"] = f"{INLET_COLUMN}-{BLEED_COLUMN}"
    elif COMMAND_COLUMN in df.columns:
        data["command_pwm"] = numeric(COMMAND_COLUMN)
        cols["command"] = COMMAND_COLUMN
    return data, {"path": str(p), "columns": cols}


def fit_lift_off(fits, commands) -> dict:
    """The valve's lift-off from steps to different commands: the affine map p = G·(u − u0).

    Each fit's final pressure ``y0 + gain·input_step`` is paired with the command held after its
    step; a straight line through the pairs (exact for two, least squares with standard errors
    for more) gives G and u0 = −intercept/G. The identified model ṗ = (G·(u − u0) − p)/τ then
    holds a pressure p with u0 + p/G counts, where the paper's line through the origin (one step)
    asks p/G_secant (``docs/control.md``).

    Parameters
    ----------
    fits : sequence of StepFit
        Order-1 or order-2 fits of steps from rest (or from any held command). [-]
    commands : sequence of float
        Command held after each step. [PWM counts]

    Returns
    -------
    dict
        ``gain_Pa_per_count`` [Pa/count], ``lift_off_counts`` [counts] and their standard errors
        (``*_stderr``; NaN with two steps: a line through two points has no residual), with the
        data they came from: ``final_pressure_Pa`` and ``commands_pwm``.

    Raises
    ------
    InputError
        Fewer than two steps, steps to the same command, final pressures that do not rise with
        the command, or a lift-off outside [0, smallest command) — the steps do not share one
        line (a saturated valve, or one far above its lift-off where the map bends). A lift-off
        within one count below zero is taken as 0 (no lift-off, to the fits' noise).
    """
    fits = list(fits)
    u = np.asarray(commands, dtype=float)
    if len(fits) < 2 or u.shape != (len(fits),):
        raise InputError(f"lift-off: needs two or more steps with one command each, got {len(fits)} steps "
                         f"and {u.size} commands")
    if np.unique(u).size != u.size:
        raise InputError(f"lift-off: the steps must end at different commands, got {u.tolist()} counts")
    p = np.array([f.params["y0"] + f.gain * f.input_step for f in fits])
    if u.size == 2:
        g = (p[1] - p[0]) / (u[1] - u[0])
        cov = np.full((2, 2), np.nan)
        b = p[0] - g * u[0]
    else:
        (g, b), cov = np.polyfit(u, p, 1, cov=True)
    if not g > 0:
        raise InputError(f"lift-off: the final pressures {np.round(p).tolist()} Pa do not rise with the commands "
                         f"{u.tolist()} counts (a saturated or shut valve?)")
    u0 = -b / g
    if -1.0 <= u0 < 0.0:  # a valve with no lift-off, within the fits' noise
        u0 = 0.0
    if not 0 <= u0 < u.min():
        raise InputError(f"lift-off: the line through the final pressures {np.round(p).tolist()} Pa at "
                         f"{u.tolist()} counts meets zero at {u0:.1f} counts, outside [0, {u.min():g}): use steps "
                         "a few counts apart just above where the pressure starts to rise")
    # u0 = −b/g: first-order propagation of the line's covariance
    jac = np.array([b / g**2, -1.0 / g])
    return {"gain_Pa_per_count": float(g), "lift_off_counts": float(u0),
            "gain_Pa_per_count_stderr": float(np.sqrt(cov[0, 0])),
            "lift_off_counts_stderr": float(np.sqrt(jac @ cov @ jac)),
            "final_pressure_Pa": p.tolist(), "commands_pwm": u.tolist()}
