"""Low-order models fitted to an open-loop step response: first order, second order, the fill.

The paper identifies the pressure loop of its 100 mm muscle from "a voltage step input to the
driver circuit": first order, τ ≈ 0.09 s, no overshoot ([mpam-characterization], §IV.A). We fit

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

Also the fill model of a chamber through a valve (:func:`fit_fill`), the runs test of the
residuals (:func:`runs_z`), the pooling of per-trial fits and the valves' lift-off across
logs. Moved here from :mod:`mckibben.control.identify` (which identifies logs with them and
re-exports the names it had) to stand beside the other fits.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from mckibben.errors import InputError
from mckibben.results import FitBase
from mckibben.units import P_ATM

if TYPE_CHECKING:  # python-control costs ~0.8 s at import: imported where an LTI object is built
    import control


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


@dataclass(frozen=True, repr=False, kw_only=True)
class ResponseFit(FitBase):
    """What the fits of one response in time share (:class:`StepFit`, :class:`FillFit`): a member
    of the fit family (:class:`~mckibben.results.FitBase`).

    Parameters
    ----------
    names : tuple of str
        Parameter names, ``quantity_unit``. [-]
    values : numpy.ndarray
        Fitted values, in the order of ``names`` (:attr:`params` maps them). [mixed]
    stderr : numpy.ndarray
        Their standard errors (covariance scaled by the residual variance). [mixed]
    t_step : float
        Time of the input step. [s]
    t : numpy.ndarray
        Time of the fitted samples. [s]
    residuals : numpy.ndarray
        Measured minus fitted output at ``t``. [output]
    rmse : float
        Root mean square of the residuals (:attr:`residual_rms`). [output]
    r2 : float
        Coefficient of determination. [-]
    aic : float
        Akaike information criterion, n·ln(RSS/n) + 2k, k the parameters fitted (lower is better). [-]
    flags : tuple of str
        Why the fit deserves doubt (empty: nothing found): ``<param>_at_lower_bound`` /
        ``_at_upper_bound`` (a dead time of 0 is a value, not a bound), ``poor_fit_r2``
        (R² < :data:`R2_POOR`), ``residual_runs`` (residual signs in runs: the model's shape is
        wrong, :func:`runs_z`).
    source : str, default ""
        The log fitted (empty when arrays were given). [-]
    """

    names: tuple
    values: np.ndarray = field(repr=False)
    stderr: np.ndarray = field(repr=False)
    t_step: float
    t: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    rmse: float
    r2: float
    aic: float
    flags: tuple = ()
    source: str = ""

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """What was fitted: the model's order, the step's time and the log."""
        return {"order": getattr(self, "order", ""), "t_step_s": self.t_step, "source": self.source}

    @property
    def metrics(self) -> dict:
        """``rmse``, ``r2``, ``aic``, ``n_points`` and ``flags``."""
        return {"rmse": self.rmse, "r2": self.r2, "aic": self.aic, "n_points": self.n_points, "flags": list(self.flags)}

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
        raise NotImplementedError

    def confidence_intervals(self, level: float = 0.95) -> dict:
        """Symmetric confidence intervals from the standard errors (Student t, n − p degrees of freedom).

        Parameters
        ----------
        level : float, default 0.95
            Confidence level. [-]
        """
        from scipy import special  # deferred on purpose: SciPy
        q = special.stdtrit(max(self.dof, 1), 0.5 + level / 2.0)  # Student's t quantile (scipy.stats.t.ppf's own)
        return {k: (v - q * s, v + q * s) for (k, v), s in zip(self.params.items(), self.stderr)}

    def plot(self, ax=None):
        """The measured response and the fitted model against time.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
        fitted = self.predict(self.t)
        ax.plot(self.t, fitted + self.residuals, ".", ms=2, alpha=0.6, label="measured")
        ax.plot(self.t, fitted, "-", lw=1.2, label=f"fitted ({self.arguments['order']})")
        ax.axvline(self.t_step, color="k", lw=0.6, ls=":")
        ax.set(xlabel="time [s]", ylabel="output", title=f"{type(self).__name__}: RMS {self.rmse:.4g}, R² {self.r2:.4f}")
        ax.legend(fontsize="small")
        return ax.figure

    def _common_dict(self) -> dict:
        """What both fits' JSON holds after their parameters: statistics and flags."""
        return {"aic": self.aic, "n_samples": int(len(self.t)), "residual_runs_z": runs_z(self.residuals),
                "flags": list(self.flags)}


def _named(values: dict, errors: dict) -> dict:
    """``ResponseFit``'s fields from ``{name: value}`` and ``{name: stderr}`` (the same names)."""
    names = tuple(values)
    return {"names": names, "values": np.array([values[k] for k in names], dtype=float),
            "stderr": np.array([errors[k] for k in names], dtype=float)}


@dataclass(frozen=True, repr=False, kw_only=True)
class StepFit(ResponseFit):
    """A low-order model fitted to one step response, with its uncertainty (:class:`ResponseFit`'s fields).

    Parameters
    ----------
    order : int
        1 (FOPDT) or 2 (SOPDT). [-]
    input_step : float
        Size of the input step (1 when no input column was given). [input]

    The parameters (:attr:`params`, :attr:`stderr`): ``gain`` [output/input], ``dead_time_s``,
    ``y0`` [output], ``tau_s`` (order 1) or ``wn_rad_s``, ``zeta`` (order 2), and ``p_final``
    [output].
    """

    order: int
    input_step: float

    call = "mckibben.fit.step.fit_step_response"

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
        import control  # deferred: python-control costs ~0.8 s at import (only LTI objects need it)

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
        for (k, v), se in zip(self.params.items(), self.stderr):
            out[rename.get(k, k)] = v
            out[f"{rename.get(k, k)}_stderr"] = float(se)
        out.update({f"rmse{suffix}": self.rmse, "r2": self.r2,
                    f"max_abs_residual{suffix}": float(np.max(np.abs(self.residuals))), **self._common_dict()})
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
                      input_step: float | None = None, p_max: float | None = None) -> StepFit:
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
    p_max : float, optional
        Upper bound of the final output p∞ of a rising step, e.g. the supply pressure: a fill
        cannot end above its supply. Reaching it is flagged ``p_final_at_supply``. [output]

    Returns
    -------
    StepFit
        Fitted parameters (``gain``, ``p_final`` = y0 + gain·Δu, ...), standard errors,
        residuals, fit statistics and flags.

    Raises
    ------
    InputError
        Bad arrays, no step in the input, or no response to fit.
    RuntimeError
        The optimizer failed (carries its message).

    References
    ----------
    [mpam-characterization], §IV.A (first-order model from an open-loop step).

    Examples
    --------
    >>> t = np.arange(0, 1, 1e-3)
    >>> y = fopdt_response(t, 2500.0, 0.09, 0.01, t_step=0.1, input_step=200)
    >>> f = fit_step_response(t, y, np.where(t >= 0.1, 200, 0))
    >>> round(f.tau, 3), round(f.gain), round(f.dead_time, 3)
    (0.09, 2500, 0.01)
    """
    from scipy import optimize  # deferred on purpose: SciPy
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
    span = float(t[-1] - t_step)
    pmag = abs(dy) * 10 + abs(y_before) + 1e-12
    pf_lo, pf_hi = y_before - pmag, y_before + pmag
    if p_max is not None:
        if dy > 0 and not p_max > y_before:
            raise InputError(f"identify: the supply {p_max:g} is not above the pressure before the step ({y_before:g})")
        pf_hi = min(pf_hi, p_max) if dy > 0 else pf_hi
    y_end = min(y_end, pf_hi - 1e-9 * abs(pf_hi))
    if order == 1:
        names = ["p_final", "tau_s", "dead_time_s", "y0"]

        def f(tt, pf, tau, th, y0):
            return fopdt_response(tt, (pf - y0) / du, tau, th, y0, t_step, du)

        p0 = [y_end, tau0, theta0, y_before]
        lo = [pf_lo, dt * 1e-3, 0.0, -np.inf]
        hi = [pf_hi, 10 * span, span, np.inf]
    else:
        names = ["p_final", "wn_rad_s", "zeta", "dead_time_s", "y0"]

        def f(tt, pf, wn, z, th, y0):
            return sopdt_response(tt, (pf - y0) / du, wn, z, th, y0, t_step, du)

        p0 = [y_end, 2.0 / tau0, 1.2, theta0, y_before]
        lo = [pf_lo, 1e-3 / span, ZETA_BOUNDS[0], 0.0, -np.inf]
        hi = [pf_hi, 1e3 / dt, ZETA_BOUNDS[1], span, np.inf]
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
    r2 = 1.0 - rss / tss if tss > 0 else math.nan
    flags = _bound_flags(names, popt, lo, hi, skip=("dead_time_s", "y0"), lower_ok=("dead_time_s",))
    if p_max is not None and pf_hi - popt[0] <= 1e-3 * abs(dy):
        flags = tuple(fl for fl in flags if not fl.startswith("p_final")) + ("p_final_at_supply",)
    flags += _shape_flags(res, r2)
    with np.errstate(invalid="ignore"):
        se = np.sqrt(np.clip(np.diag(pcov), 0, None))
    values = {k: float(v) for k, v in zip(names, popt)}
    errors = {k: float(v) for k, v in zip(names, se)}
    # the gain from the final value: K = (p∞ − y0)/Δu, its error by the delta method
    values["gain"] = (values["p_final"] - values["y0"]) / du
    i_pf, i_y0 = 0, names.index("y0")
    with np.errstate(invalid="ignore"):
        errors["gain"] = float(np.sqrt(max(pcov[i_pf, i_pf] + pcov[i_y0, i_y0] - 2 * pcov[i_pf, i_y0], 0.0)) / abs(du))
    order_keys = ["gain"] + [k for k in names if k != "p_final"] + ["p_final"]
    return StepFit(
        order=order,
        **_named({k: values[k] for k in order_keys}, {k: errors[k] for k in order_keys}),
        t_step=t_step,
        input_step=du,
        t=t,
        residuals=res,
        rmse=math.sqrt(rss / n),
        r2=r2,
        aic=n * math.log(max(rss, 1e-300) / n) + 2 * len(names),
        flags=flags,
    )


#: Bounds of the damping ratio of the order-2 fit. [-]
ZETA_BOUNDS = (0.05, 20.0)
#: R² below which a step-response fit is flagged ``poor_fit_r2``: a pressure step logged by a
#: transducer of ~1 % noise explains > 99 % of its variance when the model's shape is right. [-]
R2_POOR = 0.99
#: Runs-test z below which residuals are flagged ``residual_runs``: fewer sign changes than
#: chance by 3 standard deviations (p ≈ 0.001) means structure, i.e. the wrong shape. [-]
RUNS_Z = -3.0


def runs_z(residuals) -> float:
    """Wald–Wolfowitz runs test of the residuals' signs: z of the number of runs.

    Independent residuals give z ≈ N(0, 1); a model of the wrong shape leaves long runs of one
    sign (z ≪ 0). Zero residuals are left out.

    Parameters
    ----------
    residuals : array_like
        Residuals in time order. [output]

    Returns
    -------
    float
        z-score (NaN with fewer than 10 non-zero residuals or one sign only). [-]

    References
    ----------
    Wald, A., Wolfowitz, J. (1940), On a test whether two samples are from the same population,
    Ann. Math. Stat. 11(2), 147–162.
    """
    r = np.asarray(residuals, dtype=float)
    s = np.sign(r[r != 0])
    n1, n2 = int(np.sum(s > 0)), int(np.sum(s < 0))
    n = n1 + n2
    if n < 10 or n1 == 0 or n2 == 0:
        return math.nan
    runs = 1 + int(np.sum(s[1:] != s[:-1]))
    mu = 2.0 * n1 * n2 / n + 1.0
    var = (mu - 1.0) * (mu - 2.0) / (n - 1.0)
    return float((runs - mu) / math.sqrt(var)) if var > 0 else math.nan


def _bound_flags(names, values, lo, hi, skip=(), lower_ok=(), upper_ok=()) -> tuple:
    """``<name>_at_lower_bound`` / ``_upper_bound`` within 0.1 % of a bound; ``skip`` names neither
    (unless also in ``lower_ok``: then only the upper is tested), ``lower_ok`` / ``upper_ok`` one side."""
    out = []
    for n_, v, a, b in zip(names, values, lo, hi):
        if n_ in skip and n_ not in lower_ok:
            continue
        # within 0.1 % of the bound (relative to the bound itself: some bounds span decades)
        span = (b - a) if np.isfinite(a) and np.isfinite(b) else np.inf
        if np.isfinite(a) and v - a <= 1e-3 * min(span, max(abs(a), 1e-12)) and n_ not in lower_ok:
            out.append(f"{n_}_at_lower_bound")
        elif np.isfinite(b) and b - v <= 1e-3 * min(span, max(abs(b), 1e-12)) and n_ not in skip + upper_ok:
            out.append(f"{n_}_at_upper_bound")
    return tuple(out)


def _shape_flags(res, r2) -> tuple:
    out = []
    if not r2 >= R2_POOR:
        out.append("poor_fit_r2")
    z = runs_z(res)
    if np.isfinite(z) and z < RUNS_Z:
        out.append("residual_runs")
    return tuple(out)


def fill_response(t, p0, p_supply, tau_fill, b, dead_time, t_step=0.0, volume_growth=0.0, growth_onset=None,
                  subsonic_index=0.5, growth_span=None):
    """Pressure of a muscle filled from a supply through an orifice: the volume grows as it fills.

    With the ISO 6358 flow of the orifice, isothermal air and a volume V = V0·(1 + γ·S(r)) of the
    absolute pressure ratio r = p/p_s, d(p·V)/dt = R·T·ṁ gives

        dr/dt = φ(r) / (τ_fill·h(r)),   h = d(r·V/V0)/dr = V/V0 + r·V'/V0,

    φ = 1 while choked (r ≤ b) and φ = (1 − x²)^m above, x = (r − b)/(1 − b), m the subsonic index
    ([iso6358]; 0.5, the ellipse of its 1989 edition, by default). The growth S is 0 up to the
    onset ratio r_on and rises to 1 at the supply: linearly, S = u with u = (r − r_on)/(1 − r_on)
    (the default; r_on = r0 without an onset: the volume grows from V0 at the start to V0·(1 + γ) at
    the supply, linearly in the pressure), or saturating, S = (1 − e^(−u/κ))/(1 − e^(−1/κ)) with κ
    the growth span over (p_s − p_on) (a muscle that reaches its full contraction: its volume stops
    growing). Separable: the time to reach r is τ·∫h/φ dr, choked τ·[r·V/V0] exactly and, above b,
    τ·(1 − b)·∫h/(1 − x²)^m dx, with y = 1 − x the integrand h·y^(1 − m)/(2 − y)^m per d(−ln y),
    smooth, summed by trapezoids on x even to 0.9 and ln y even down to y = 1e−13 (m ≥ 1 never
    reaches the supply: a flow falling linearly with the pressure difference approaches it
    exponentially), the onset a node with h on each side of it. The times at 4097 ratios below b
    and 8193 above are inverted by interpolation; γ = 0 with m = 0.5 is inverted exactly (a
    straight ramp bending into the supply along a sine). An onset above p0 is a muscle that keeps
    its volume until its pressure overcomes the bladder and braid (the Festo 20 mm fills keep it to
    ~85–130 kPa: benchmarks/RESULTS.md).

    Parameters
    ----------
    t : array_like
        Time. [s]
    p0 : float
        Gauge pressure before the step. [Pa]
    p_supply : float
        Supply gauge pressure. [Pa]
    tau_fill : float
        Time to fill the starting volume V0 from vacuum to the supply at the choked rate, p_s/ṗ_choked. [s]
    b : float
        Critical pressure ratio of the orifice, 0 < b < 1. [-]
    dead_time : float
        Delay from the step to the flow. [s]
    t_step : float, default 0.0
        Time of the valve step. [s]
    volume_growth : float, default 0.0
        γ ≥ 0, relative growth of the volume from the start to the supply pressure. [-]
    growth_onset : float, optional
        Gauge pressure at which the volume starts to grow; None (or ≤ ``p0``): from the start. [Pa]
    subsonic_index : float, default 0.5
        m > 0, the exponent of the subsonic flow function ([iso6358]); 0.5 is the ellipse. [-]
    growth_span : float, optional
        Pressure above the onset over which the growth e-folds (κ·(p_s − p_on)); None: linear growth. [Pa]

    Returns
    -------
    numpy.ndarray
        Gauge pressure. [Pa]

    References
    ----------
    [iso6358] (sonic conductance C, critical ratio b, the subsonic index m and the flow function
    φ); the chamber's d(p·V)/dt = R·T·ṁ (NOTES.md, "Higher marks"); notes/lab-data.md (fills are
    S-shaped or ramp-then-exponential).
    """

    ps = p_supply + P_ATM
    r0 = (p0 + P_ATM) / ps
    s = np.maximum(np.asarray(t, dtype=float) - t_step - dead_time, 0.0)
    if r0 >= 1.0:
        return np.full(s.shape, p_supply, dtype=float)
    x0 = min(max((r0 - b) / (1.0 - b), 0.0), 1.0 - 1e-13)
    if volume_growth == 0 and subsonic_index == 0.5:  # a fixed volume: the ramp and the sine, inverted exactly
        t1 = tau_fill * max(b - r0, 0.0)
        arg = np.minimum(math.asin(x0) + np.maximum(s - t1, 0.0) / (tau_fill * (1.0 - b)), np.pi / 2)
        r = np.where(s < t1, r0 + s / tau_fill, b + (1.0 - b) * np.sin(arg))
        return r * ps - P_ATM
    r_on = r0 if growth_onset is None else min(max((growth_onset + P_ATM) / ps, r0), 1.0 - 1e-9)
    kappa = None if growth_span is None else max(growth_span / ps / (1.0 - r_on), 1e-6)

    def rv_h(r, above):
        """r·V/V0 and h = d(r·V/V0)/dr at ratios r, on the growing side of the onset where ``above``."""
        u = np.maximum(r - r_on, 0.0) / (1.0 - r_on)
        if kappa is None:
            grow, slope = u, np.ones_like(u)
        else:
            den = -math.expm1(-1.0 / kappa)
            grow, slope = -np.expm1(-u / kappa) / den, np.exp(-u / kappa) / (kappa * den)
        v = 1.0 + volume_growth * np.where(above, grow, 0.0)
        return r * v, v + r * volume_growth * np.where(above, slope, 0.0) / (1.0 - r_on)

    rb = max(r0, b)
    rc = np.linspace(r0, rb, 4097)
    if r0 < r_on < rb:
        rc = np.sort(np.append(rc, r_on))
    rv, _ = rv_h(rc, rc > r_on)
    t_choked = tau_fill * (rv - rv[0])  # ∫h dr = [r·V/V0], exact
    # x even to 0.9, then ln(1 − x) even down to 1e−13, where the flow vanishes
    xm = max(x0, 0.9)
    y = np.concatenate([1.0 - np.linspace(x0, xm, 4097),
                        np.exp(np.linspace(math.log(1.0 - xm), math.log(1e-13), 4097))[1:]])
    x_on = (r_on - b) / (1.0 - b)
    if x0 < x_on < 1.0 - 1e-13:
        y = np.sort(np.append(y, 1.0 - x_on))[::-1]
    ln_y = np.log(y)
    rs = b + (1.0 - b) * (1.0 - y)
    w = y ** (1.0 - subsonic_index) / (2.0 - y) ** subsonic_index
    above = 0.5 * (rs[1:] + rs[:-1]) > r_on  # each segment's side of the onset, at both its ends
    _, h_left = rv_h(rs[:-1], above)
    _, h_right = rv_h(rs[1:], above)
    d_sub = (1.0 - b) * 0.5 * (h_left * w[:-1] + h_right * w[1:]) * -np.diff(ln_y)
    since = np.concatenate([t_choked, t_choked[-1] + tau_fill * np.cumsum(d_sub)])
    r = np.interp(s, since, np.concatenate([rc, rs[1:]]), right=1.0)
    return r * ps - P_ATM


@dataclass(frozen=True, repr=False, kw_only=True)
class FillFit(ResponseFit):
    """The orifice fill of a growing volume fitted to a rising step (see :func:`fill_response`).

    :class:`ResponseFit`'s fields, the parameters (:attr:`params`, :attr:`stderr`) ``p0_Pa``,
    ``tau_fill_s``, ``b``, ``dead_time_s``, ``volume_growth``, ``growth_onset_Pa``,
    ``growth_span_Pa`` and ``subsonic_index`` (each of these three only when it was fitted),
    ``p_supply_Pa`` (its error is 0 when the supply was taken as given), residuals in Pa, and:

    Parameters
    ----------
    order : str, default "fill"
        The model's name, where :class:`StepFit` has its order. [-]
    supply : dict
        Where the supply came from: ``source`` (``"plateau"``: estimated within the measured
        plateau; ``"fitted"``: estimated above the highest sample, the fill did not settle;
        ``"nominal"``: the given supply, the fill did not settle), ``plateau_Pa`` (median of the
        plateau, or None), ``nominal_Pa`` (the given supply, or None). [Pa]
    shape : str, default "linear"
        The name of the shape fitted in :data:`FILL_SHAPES` (``"custom"`` for another set of options). [-]
    """

    order: str = "fill"
    supply: dict = field(default_factory=dict)
    shape: str = "linear"

    call = "mckibben.fit.step.fit_fill"

    def predict(self, t) -> np.ndarray:
        """The fitted fill at times ``t``.

        Parameters
        ----------
        t : array_like
            Time. [s]
        """
        p = self.params
        return fill_response(t, p["p0_Pa"], p["p_supply_Pa"], p["tau_fill_s"], p["b"], p["dead_time_s"], self.t_step,
                             p.get("volume_growth", 0.0), p.get("growth_onset_Pa"), p.get("subsonic_index", 0.5),
                             p.get("growth_span_Pa"))

    def to_dict(self, output_unit: str = "Pa", input_unit: str = "") -> dict:
        """Plain dict for JSON: the parameters and their errors, the supply's source, the fit's
        statistics, and beside the runs test's z what reads it (:func:`plateau_noise`):
        ``plateau_noise_Pa`` and ``plateau_noise_lag1`` (None when the fill has not settled) and
        ``residual_lag1``, the residuals' lag-1 autocorrelation.

        Parameters
        ----------
        output_unit : str, default "Pa"
            Unused (the fill model is in Pa). [-]
        input_unit : str, default ""
            Unused. [-]
        """
        out = {"order": "fill", "fill_shape": self.shape, "t_step_s": self.t_step}
        for (k, v), se in zip(self.params.items(), self.stderr):
            out[k] = v
            out[f"{k}_stderr"] = float(se)
        out.update({"supply_source": self.supply.get("source"), "plateau_Pa": self.supply.get("plateau_Pa"),
                    "p_supply_nominal_Pa": self.supply.get("nominal_Pa")})
        noise = plateau_noise(self.t, self.predict(self.t) + self.residuals, self.t_step, self.params["p0_Pa"])
        out.update({"plateau_noise_Pa": noise[0] if noise else None, "plateau_noise_lag1": noise[1] if noise else None,
                    "residual_lag1": lag1_autocorrelation(self.residuals)})
        out.update({"rmse_Pa": self.rmse, "r2": self.r2, **self._common_dict()})
        return out


#: Bounds of the fill model's critical pressure ratio (ISO 6358 valves: ~0.1–0.6). [-]
B_BOUNDS = (0.01, 0.99)
#: Bounds of the fill model's volume growth γ from the start to the supply: 0 is a fixed volume; a
#: braided muscle's volume grows a few times over its stroke (its diameter ~1.5–2× at full
#: contraction), so 20 is far beyond it and a fit there says the shape is wrong. [-]
VOLUME_GROWTH_BOUNDS = (0.0, 20.0)
#: The fill model's growth onset is fitted from the start to this fraction of the way to the highest
#: sample: an onset beyond it leaves too few samples of growth to tell it from the supply's approach. [-]
ONSET_MAX = 0.9
#: Bounds of the fill model's subsonic index m ([iso6358]): 0.5 is the ellipse of an orifice;
#: a flow that falls linearly with the pressure difference near the supply (a laminar path: tubing,
#: a regulator's seat) is m ≈ 1; the Festo 20 mm fills give 0.6–1.2. A fit at either bound says the
#: shape is wrong. [-]
SUBSONIC_INDEX_BOUNDS = (0.2, 2.0)
#: Bounds of the fill model's growth span, in rises of the fill: a hundredth of the rise is a step
#: in the volume (flagged); five rises is a growth no fill can tell from linear (no flag). [-]
SPAN_BOUNDS = (0.01, 5.0)
#: The fill model's shapes by name: :func:`fit_fill`'s options for each. ``onset`` is what
#: ``mckibben identify --order fill`` fits by default: on the Festo 20 mm fills it predicts a held-out
#: trial's shape better than ``linear`` (median RMS 4.5 against 6.2 kPa, 17 of 22 pairs) and as well
#: as ``saturating`` (4.4 kPa), which fits better in-sample with one parameter more
#: (benchmarks/RESULTS.md, "Fill identification on real fills"). [-]
FILL_SHAPES = {
    "fixed": {"volume_growth": False},  # a fixed volume, the ellipse
    "linear": {},  # a volume growing linearly from the start, the ellipse
    "onset": {"growth_onset": True, "subsonic_index": True},  # held to an onset, then linear; m fitted
    "saturating": {"growth_onset": True, "growth_span": True, "subsonic_index": True},  # ... saturating
}
#: The plateau is the last this fraction of the samples after the step. [-]
PLATEAU_FRACTION = 0.1
#: A fill has settled when its plateau drifts (median of its second half minus its first) by at
#: most this fraction of the rise; its supply is then estimated within the plateau's range. The
#: Festo 20 mm fills drift at most 0.2 % at their end; a fill stopped at 80 % of its rise drifts ~2 %. [-]
SETTLED_SPREAD = 0.01


def _plateau_tail(t, y, t_step: float) -> tuple[np.ndarray, np.ndarray]:
    """The samples after the step and its plateau: their last :data:`PLATEAU_FRACTION` (at least 5). [Pa]"""
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    after = y[t >= t_step]
    return after, after[-max(int(round(PLATEAU_FRACTION * after.size)), 5):]


def measured_plateau(t, y, t_step: float, p0: float) -> tuple[float, float, float] | None:
    """The pressure a fill settled at: median and range of its last :data:`PLATEAU_FRACTION` of samples (at least 5).

    Parameters
    ----------
    t : array_like
        Sample times. [s]
    y : array_like
        Gauge pressure. [Pa]
    t_step : float
        Time of the step. [s]
    p0 : float
        Pressure before the step. [Pa]

    Returns
    -------
    tuple of float or None
        ``(median, low, high)`` of the plateau [Pa], or None when the fill has not settled
        (:data:`SETTLED_SPREAD`) or the plateau has fewer than 5 samples.
    """
    after, tail = _plateau_tail(t, y, t_step)
    if tail.size < 5 or after.size < 2 * tail.size:
        return None
    med = float(np.median(tail))
    rise = med - p0
    half = tail.size // 2
    drift = abs(float(np.median(tail[half:]) - np.median(tail[:half])))
    if not rise > 0 or drift > SETTLED_SPREAD * rise:
        return None
    return med, float(np.min(tail)), float(np.max(tail))


def lag1_autocorrelation(x) -> float:
    """Lag-1 autocorrelation of a series about its mean: ≈ 0 for white noise, → 1 for a smooth one.

    Parameters
    ----------
    x : array_like
        Values in time order. [any]

    Returns
    -------
    float
        Σ(x_k·x_(k+1))/Σx_k² of the centred series (NaN with fewer than 3 values or none varying). [-]
    """
    x = np.asarray(x, dtype=float)
    x = x - np.mean(x) if x.size else x
    den = float(np.sum(x * x))
    return float(np.sum(x[1:] * x[:-1]) / den) if x.size >= 3 and den > 0 else math.nan


def plateau_noise(t, y, t_step: float, p0: float) -> tuple[float, float] | None:
    """The sensor's noise where a fill has settled: its plateau (:func:`measured_plateau`'s samples)
    with a straight line removed.

    What the runs test of a fill's residuals needs to be read: white noise here (lag-1
    autocorrelation near 0) and long runs in the residuals mean the model's shape, not the
    sensor's filtering; correlated noise here would make a runs test on every sample reject any
    model.

    Parameters
    ----------
    t : array_like
        Sample times. [s]
    y : array_like
        Gauge pressure. [Pa]
    t_step : float
        Time of the step. [s]
    p0 : float
        Pressure before the step. [Pa]

    Returns
    -------
    tuple of float or None
        ``(standard deviation [Pa], lag-1 autocorrelation [-])``, or None when the fill has not
        settled or its plateau has fewer than 8 samples.
    """
    if measured_plateau(t, y, t_step, p0) is None:
        return None
    _, tail = _plateau_tail(t, y, t_step)
    if tail.size < 8:
        return None
    k = np.arange(tail.size, dtype=float)
    x = tail - np.polyval(np.polyfit(k, tail, 1), k)
    return float(np.std(x)), lag1_autocorrelation(x)


def fit_fill(t, y, u=None, *, t_step: float | None = None, p_supply: float | None = None,
             volume_growth: bool = True, growth_onset: bool = False, growth_span: bool = False,
             subsonic_index: bool = False) -> FillFit:
    """Fit the orifice fill of a growing volume (:func:`fill_response`) to a rising pressure step.

    **Shape.** By default the volume grows linearly from the start and the flow is the ellipse
    (``linear`` in :data:`FILL_SHAPES`); the options fit a fixed volume, an onset of the growth, a
    growth that saturates and the valve's subsonic index m ([iso6358]). :data:`FILL_SHAPES` names
    the combinations; ``identify`` fits ``onset`` by default.

    **Supply.** When the fill settles (:func:`measured_plateau`) the supply is estimated within
    the range of the measured plateau, whatever the nominal ``p_supply`` says (a regulator set to
    620 kPa delivers 624–646 kPa on the Festo 20 mm fills, and a fixed-volume fit pinned at 620 kPa
    has up to 2.3× the RMS of one with its supply free); the nominal is reported beside it. When the fill does not settle, the data bound
    the supply only from below: it is the given ``p_supply`` (``supply_source`` ``"nominal"``), or
    fitted above the highest sample.

    Parameters
    ----------
    t : array_like
        Sample times, strictly increasing. [s]
    y : array_like
        Gauge pressure. [Pa]
    u : array_like, optional
        Valve command per sample; its first change is the step. [input]
    t_step : float, optional
        Time of the step (default: from ``u``, else ``t[0]``). [s]
    p_supply : float, optional
        Nominal supply gauge pressure (see above). [Pa]
    volume_growth : bool, default True
        Fit the volume's growth γ (else a fixed volume, γ = 0). [-]
    growth_onset : bool, default False
        Fit the pressure at which the volume starts to grow (``growth_onset_Pa``, :func:`fill_response`;
        else it grows from the start). Needs ``volume_growth``. Its lower bound, the start, is a
        value (no flag); its upper bound, 90 % of the way to the highest sample, is flagged. [-]
    growth_span : bool, default False
        Fit the pressure span over which the growth saturates (``growth_span_Pa``,
        :func:`fill_response`; else it is linear). Needs ``volume_growth``. Its upper bound, five
        rises, is a growth indistinguishable from linear (no flag); its lower bound is flagged. [-]
    subsonic_index : bool, default False
        Fit the orifice's subsonic index m (``subsonic_index``, :func:`fill_response`, within
        :data:`SUBSONIC_INDEX_BOUNDS`; else m = 0.5, the ellipse). [-]

    Returns
    -------
    FillFit
    """
    from scipy import optimize  # deferred on purpose: SciPy
    t, y, u = _validate(t, y, u)
    t_step, _ = _locate_step(t, y, u, t_step, None)
    k0 = int(np.searchsorted(t, t_step))
    p0 = float(np.mean(y[max(0, k0 - 20):k0])) if k0 > 0 else float(y[0])
    if not np.max(y) > p0:
        raise InputError("identify: the fill model needs a rising step")
    ymax = float(np.max(y))
    span = float(t[-1] - t_step)
    dt = float(np.median(np.diff(t)))
    plateau = measured_plateau(t, y, t_step, p0)
    if plateau is not None:
        source, (ps_lo, ps_hi) = "plateau", (plateau[1], max(plateau[2], plateau[1] * (1 + 1e-9) + 1e-9))
    elif p_supply is not None:
        source = "nominal"
    else:
        source, (ps_lo, ps_hi) = "fitted", (ymax, 3.0 * ymax + 1e6)
    fit_ps = source != "nominal"
    if (growth_onset or growth_span) and not volume_growth:
        raise InputError("fit_fill: growth_onset and growth_span need volume_growth (a fixed volume does not grow)")
    rise = max(abs(ymax - p0), 1.0)
    # name, bounds, scale; the start values per multistart below
    spec = [("p0_Pa", p0 - rise, p0 + rise, rise), ("tau_fill_s", dt * 1e-2, 100 * span, span),
            ("b", *B_BOUNDS, 1.0), ("dead_time_s", 0.0, span, span)]
    if volume_growth:
        spec.append(("volume_growth", *VOLUME_GROWTH_BOUNDS, 1.0))
    if growth_onset:
        spec.append(("growth_onset_Pa", p0, p0 + ONSET_MAX * (ymax - p0), rise))
    if growth_span:
        spec.append(("growth_span_Pa", SPAN_BOUNDS[0] * rise, SPAN_BOUNDS[1] * rise, rise))
    if subsonic_index:
        spec.append(("subsonic_index", *SUBSONIC_INDEX_BOUNDS, 1.0))
    if fit_ps:
        spec.append(("p_supply_Pa", ps_lo, ps_hi, max(ymax, 1.0)))
    names = [n_ for n_, *_ in spec]
    col = {n_: i for i, n_ in enumerate(names)}
    lo = [x[1] for x in spec]
    hi = [x[2] for x in spec]
    scale = np.array([x[3] for x in spec])

    def model(v):
        ps = v[col["p_supply_Pa"]] if fit_ps else max(float(p_supply), ymax)  # type: ignore[arg-type]
        return fill_response(t, v[0], ps, v[1], v[2], v[3], t_step, v[4] if volume_growth else 0.0,
                             v[col["growth_onset_Pa"]] if growth_onset else None,
                             v[col["subsonic_index"]] if subsonic_index else 0.5,
                             v[col["growth_span_Pa"]] if growth_span else None)

    lo_a, hi_a = np.array(lo), np.array(hi)
    ps0 = plateau[0] if plateau is not None else (1.05 * ymax if p_supply is None else p_supply)
    # several starts: b; a volume that grows from the start (γ 0 or 2) or holds to an onset (a
    # fraction of the rise), linearly or saturating over a tenth of the rise; the ellipse, or a flow
    # that falls linearly with the pressure difference
    extra = growth_onset or growth_span or subsonic_index
    starts = itertools.product((0.3, 0.7) if extra else (0.2, 0.5, 0.8),
                               (0.1, 0.2) if growth_onset else (0.0,),
                               (1.5,) if (growth_onset or growth_span) else (0.0, 2.0) if volume_growth else (0.0,),
                               (0.1, 1.0) if growth_span else (0.0,),
                               (1.0,) if subsonic_index else (0.5,))
    best = None
    for b0, f0, g0, k0, m0 in starts:
        x0 = np.array([p0, max(span / 3, 2 * dt), b0, 0.0] + ([g0] if volume_growth else [])
                      + ([p0 + f0 * (ymax - p0)] if growth_onset else []) + ([k0 * rise] if growth_span else [])
                      + ([m0] if subsonic_index else []) + ([ps0] if fit_ps else []))
        x0 = np.clip(x0, lo_a + 1e-9 * scale, hi_a - 1e-9 * scale)
        r = optimize.least_squares(lambda th: model(th * scale) - y, x0 / scale, bounds=(lo_a / scale, hi_a / scale),
                                   method="trf", max_nfev=2000)
        if best is None or r.cost < best.cost:
            best = r
    v = best.x * scale
    res = -best.fun
    n, k = len(y), len(names)
    rss = float(res @ res)
    jac = best.jac / scale
    norms = np.linalg.norm(jac, axis=0)
    norms[norms == 0] = 1.0
    cov = rss / max(n - k, 1) * np.linalg.pinv((jac / norms).T @ (jac / norms)) / np.outer(norms, norms)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    tss = float(np.sum((y - np.mean(y)) ** 2))
    r2 = 1.0 - rss / tss if tss > 0 else math.nan
    # the supply's bounds are the plateau's noise band: the supply at either edge is no doubt
    flags = _bound_flags(names, v, lo, hi, skip=("p0_Pa", "p_supply_Pa"), upper_ok=("growth_span_Pa",),
                         lower_ok=("dead_time_s", "volume_growth", "growth_onset_Pa", "p_supply_Pa")) + _shape_flags(res, r2)
    params = {nm: float(x) for nm, x in zip(names, v)}
    errors = {nm: float(e) for nm, e in zip(names, se)}
    if not volume_growth:
        params["volume_growth"], errors["volume_growth"] = 0.0, 0.0
    if not fit_ps:
        params["p_supply_Pa"], errors["p_supply_Pa"] = max(float(p_supply), ymax), 0.0  # type: ignore[arg-type]
    supply = {"source": source, "plateau_Pa": plateau[0] if plateau is not None else None,
              "nominal_Pa": float(p_supply) if p_supply is not None else None}
    given = {k: v_ for k, v_ in (("volume_growth", volume_growth), ("growth_onset", growth_onset),
                                 ("growth_span", growth_span), ("subsonic_index", subsonic_index)) if v_ != (k == "volume_growth")}
    shape = next((k for k, kw in FILL_SHAPES.items() if kw == given), "custom")
    return FillFit(shape=shape, **_named(params, errors), t_step=t_step, t=t, residuals=res, rmse=math.sqrt(rss / n), r2=r2,
                   aic=n * math.log(max(rss, 1e-300) / n) + 2 * k, flags=flags, supply=supply)


#: Trials whose half-rise times (:func:`half_rise_time`) differ by more than this factor, with no
#: trial between them, are different runs (another supply, valve or muscle state): they are reported
#: as separate groups, never pooled. The Festo 20 mm fills come in groups of t50 ≈ 1.1–1.2 s,
#: 0.29–0.41 s and 0.03 s (a run that jumps to 460 kPa in 60 ms); within a group t50 varies by
#: < 1.45× (benchmarks/bench_real_fill.py). [-]
GROUP_RATIO = 1.5


def half_rise_time(fit) -> float:
    """Time from the step until the measured response first covers half its rise.

    Measured, not modelled: a run whose shape the model misses (a jump to 460 kPa in 60 ms) keeps
    its own half-rise time. The samples are the fit's prediction plus its residuals; the rise is
    from the median of the last 20 samples before the step (or the first sample when the log starts
    at the step) to the median of the last :data:`PLATEAU_FRACTION` of samples.

    Parameters
    ----------
    fit : StepFit or FillFit
        A fitted step or fill (its ``predict``, ``t``, ``residuals`` and ``t_step``). [-]

    Returns
    -------
    float
        t50. [s]
    """
    t = np.asarray(fit.t, dtype=float)
    y = np.asarray(fit.predict(t), dtype=float) + np.asarray(fit.residuals, dtype=float)
    after = t >= fit.t_step
    start = float(np.median(y[~after][-20:])) if (~after).any() else float(y[after][0])
    t, y = t[after], y[after]
    end = float(np.median(y[-max(int(round(PLATEAU_FRACTION * y.size)), 1):]))
    above = (y - (start + 0.5 * (end - start))) * np.sign(end - start) >= 0
    return float(t[int(np.argmax(above))] - fit.t_step) if above.any() else float(t[-1] - fit.t_step)


def split_runs(fits) -> list[list[int]]:
    """Group trials whose half-rise times agree (gaps above :data:`GROUP_RATIO` split them).

    Parameters
    ----------
    fits : sequence of StepFit or FillFit
        One fit per trial. [-]

    Returns
    -------
    list of list of int
        Positions of the trials in ``fits``, one list per group, the fastest group first.
    """
    t50 = np.array([half_rise_time(f) for f in fits])
    order = np.argsort(t50, kind="stable")
    groups = [[int(order[0])]] if order.size else []
    for a, b in zip(order[:-1], order[1:]):
        if t50[b] > GROUP_RATIO * max(t50[a], 1e-300):
            groups.append([])
        groups[-1].append(int(b))
    return [sorted(g) for g in groups]


def _pool(fits) -> dict:
    from scipy import special  # deferred on purpose: SciPy
    n = len(fits)
    out: dict = {"n_trials": n}
    if n < 2:
        return out
    q = float(special.stdtrit(n - 1, 0.975))  # Student's t quantile (scipy.stats.t.ppf's own)
    for k in fits[0].params:
        if k in ("p_final", "p_supply_Pa"):  # set by each trial's command or supply, not a property to pool
            continue
        v = np.array([f.params[k] for f in fits])
        m, se = float(np.mean(v)), float(np.std(v, ddof=1) / math.sqrt(n))
        out[k] = {"mean": m, "stderr": se, "ci95": [m - q * se, m + q * se]}
    return out


def pooled_step_parameters(fits) -> dict:
    """Mean of each parameter over trials with its standard error across trials (sd/√n), per group of like runs.

    Each trial is one independent realization of the step; the spread between trials is the
    honest uncertainty of a parameter (it includes what each fit's own error leaves out: the
    residuals of one step are correlated). 95 % intervals use t with n − 1 degrees of freedom.
    Trials are first tested for being the same run (:func:`split_runs`: half-rise times within
    :data:`GROUP_RATIO`): runs that differ are pooled apart, each group with its members, and
    nothing is pooled across groups.

    Parameters
    ----------
    fits : sequence of StepFit or FillFit
        One fit per trial, same order. [-]

    Returns
    -------
    dict
        One group: ``n_trials``, ``n_groups`` = 1 and per parameter ``mean``, ``stderr``, ``ci95``.
        Several: ``n_trials``, ``n_groups`` and ``groups``, a list (fastest first) of
        ``{"members": positions in fits, "half_rise_s": [...], "n_trials": ..., <parameter>: {...}}``.
        [parameter units]
    """
    fits = list(fits)
    groups = split_runs(fits) if len(fits) >= 2 else [list(range(len(fits)))]
    if len(groups) <= 1:
        return {**_pool(fits), "n_groups": 1}
    return {"n_trials": len(fits), "n_groups": len(groups),
            "groups": [{"members": g, "half_rise_s": [half_rise_time(fits[i]) for i in g],
                        **_pool([fits[i] for i in g])} for g in groups]}


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
