"""Identification of a step-response log: every trial, every model, pooled; several logs: the lift-off.

:func:`identify_logs` reads logs (:func:`mckibben.data.steplog.read_step_log`), fits each trial
with the low-order models of :mod:`mckibben.fit.step` (first and second order plus dead time,
[mpam-characterization] §IV.A), pools the trials and, given several logs,
fits the valves' lift-off. The reader and the fits moved to ``data`` and ``fit``; their names are
re-exported here.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass, field

import numpy as np

from mckibben.control.core_params import CoreParams, core_spec
from mckibben.control.registry import MODE_OPEN_LOOP
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.loop import time_grid, run_closed_loop
from mckibben.data.steplog import (  # noqa: F401 (re-exported)
    BLEED_COLUMN,
    COMMAND_COLUMN,
    FRACTION_COLUMN,
    INLET_COLUMN,
    TRIAL_COLUMN,
    read_step_log,
    split_trials,
)
from mckibben.errors import InputError, check_real
from mckibben.fit.step import (  # noqa: F401
    B_BOUNDS,
    FILL_SHAPES,
    R2_POOR,
    RUNS_Z,
    ZETA_BOUNDS,
    FillFit,
    StepFit,
    fill_response,
    fit_fill,
    fit_lift_off,
    fit_step_response,
    fopdt_response,
    pooled_step_parameters,
    runs_z,
    sopdt_response,
)
from mckibben.limits import check_budget
from mckibben.plant import CALIBRATION_PWM
from mckibben.results import Result

# --- logs: every trial, every model, pooled; several logs: the lift-off ---------------------------


@dataclass(repr=False)
class LogIdentification(Result):
    """The identification of one step-response log: every requested model on every trial.

    Attributes
    ----------
    path : str
        The log.
    data : dict
        From :func:`read_step_log` (SI arrays).
    meta : dict
        ``path``, ``columns`` and ``notes`` of :func:`read_step_log`.
    trials : dict
        trial -> (that trial's data, list of fits: :class:`StepFit` or :class:`FillFit`).
    """

    path: str
    data: dict = field(repr=False)
    meta: dict = field(repr=False)
    trials: dict = field(repr=False)

    call = "mckibben.control.identify.identify_logs"

    @property
    def arguments(self) -> dict:
        """The log."""
        return {"log": self.path}

    @property
    def input_unit(self) -> str:
        """``count`` (PWM), ``command`` (fraction of full scale) or ``step`` (no input column)."""
        return "count" if "command_pwm" in self.data else "command" if "command" in self.data else "step"

    def _trial_dict(self, data: dict, fits) -> dict:
        out = {"models": [f.to_dict("Pa", self.input_unit) for f in fits]}
        best = min(fits, key=lambda f: f.aic)
        out["best_order"] = best.order
        out["dead_time_s"] = best.dead_time
        if best.order != "fill":
            out[f"gain_Pa_per_{self.input_unit}"] = best.gain
            out["time_constant_s"] = best.tau
        return out

    @property
    def metrics(self) -> dict:
        """One trial: its best model's dead time (and gain, time constant); several: the pooled fits."""
        d = self.to_dict()
        return {k: v for k, v in d.items() if k not in ("log", "columns", "notes", "models", "trials")}

    def to_dict(self) -> dict:
        """JSON-ready: per trial the fits (one trial: at the top level), and ``pooled`` across trials."""
        out = {"log": self.meta["path"], "columns": self.meta["columns"], "notes": self.meta.get("notes", [])}
        if len(self.trials) == 1:
            (d, fits), = self.trials.values()
            out.update(self._trial_dict(d, fits))
            return out
        out["n_trials"] = len(self.trials)
        out["trials"] = [{"trial": tr, **self._trial_dict(d, fits)} for tr, (d, fits) in self.trials.items()]
        n_models = len(next(iter(self.trials.values()))[1])
        out["pooled"] = {str(fs[0].order): pooled_step_parameters(fs)
                         for fs in ([self.trials[tr][1][k] for tr in self.trials] for k in range(n_models))}
        return out

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        frames = []
        for tr, (d, fits) in self.trials.items():
            df = pd.DataFrame({"trial": tr, "time_s": d["time_s"], "pressure_Pa": d["pressure_Pa"]})
            for f in fits:
                df[f"fit_{f.order}_Pa"] = f.predict(d["time_s"])
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def plot(self, ax=None):
        """Pressure of the first trial with every fitted model.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.6))
        d, fits = next(iter(self.trials.values()))
        ax.plot(d["time_s"], d["pressure_Pa"] / 1e6, ".", ms=2, color="0.5", label="measured")
        for f in fits:
            ax.plot(d["time_s"], f.predict(d["time_s"]) / 1e6, label=f"order {f.order}")
        ax.set(xlabel="time [s]", ylabel="pressure [MPa]")
        ax.legend(fontsize="small")
        return ax.figure


@dataclass(repr=False)
class LogsIdentification(Result):
    """The identification of one or several logs, and the valve's lift-off from several.

    Attributes
    ----------
    logs : list of LogIdentification
        One per log.
    lift_off : dict or None
        :func:`fit_lift_off` through the logs' steps (two logs or more).
    """

    logs: list
    lift_off: dict | None = None

    call = "mckibben.control.identify.identify_logs"

    @property
    def arguments(self) -> dict:
        """The logs."""
        return {"logs": [r.path for r in self.logs]}

    @property
    def metrics(self) -> dict:
        """The first log's metrics, and the lift-off when there is one."""
        return {**self.logs[0].metrics, **({"lift_off": self.lift_off} if self.lift_off else {})}

    def to_dict(self) -> dict:
        """JSON-ready: one log's dict, or ``logs`` and ``lift_off``."""
        if self.lift_off is None and len(self.logs) == 1:
            return self.logs[0].to_dict()
        return {"logs": [r.to_dict() for r in self.logs], "lift_off": self.lift_off}

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        return pd.concat([r._series().assign(log=r.path) for r in self.logs], ignore_index=True)

    def plot(self, ax=None):
        """The first log's plot (see :meth:`LogIdentification.plot`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure.
        """
        return self.logs[0].plot(ax)


def identify_logs(logs, orders=(1,), t_step: float | None = None, p_supply: float | None = None,
                  select: dict | None = None, columns: dict | None = None,
                  fill_shape: str = "onset") -> LogsIdentification:
    """Identify step-response logs: every model on every trial, pooled across trials, and the lift-off.

    Parameters
    ----------
    logs : sequence of str or pathlib.Path
        Step-response logs (:func:`read_step_log`). [-]
    orders : sequence, default (1,)
        Models: 1, 2 and/or ``"fill"`` (:func:`fit_fill`). [-]
    t_step : float, optional
        Time of the step (default: the first command change of each trial). [s]
    p_supply : float, optional
        Supply pressure: the bound of the final pressure, the fill model's supply. [Pa]
    select : dict, optional
        Column -> value: read only these rows of each log (:func:`read_step_log`). [-]
    columns : dict, optional
        Each log's column names -> the log's (:func:`read_step_log`). [-]
    fill_shape : str, default "onset"
        The fill model's shape, a name in :data:`~mckibben.fit.step.FILL_SHAPES` (``fixed``,
        ``linear``, ``onset``, ``saturating``). [-]

    Returns
    -------
    LogsIdentification
        With the valve's lift-off (:func:`fit_lift_off`) when two logs or more are given.

    Raises
    ------
    InputError
        A bad log, a fit that cannot converge on it, logs that cannot give a lift-off, or an unknown
        ``fill_shape``.
    """
    if fill_shape not in FILL_SHAPES:
        raise InputError(f"fill_shape: {fill_shape!r} is not a fill shape; use one of {', '.join(FILL_SHAPES)}")
    out = []
    for log in logs:
        data, meta = read_step_log(log, select, columns)
        if len(logs) > 1 and "command_pwm" not in data:
            raise InputError(f"{meta['path']}: the lift-off needs the valve command (inlet_pwm/bleed_pwm or "
                             "command_pwm) in every log")
        if t_step is not None and not float(data["time_s"][0]) < t_step < float(data["time_s"][-1]):
            raise InputError(f"t_step: {t_step:g} s is outside the time of {meta['path']} "
                             f"({data['time_s'][0]:g}..{data['time_s'][-1]:g} s)")
        trials = {}
        try:
            for tr, d in split_trials(data).items():
                u = d.get("command_pwm", d.get("command"))
                fits: list = []
                for o in orders:
                    if o == "fill":
                        fits.append(fit_fill(d["time_s"], d["pressure_Pa"], u, t_step=t_step, p_supply=p_supply,
                                             **FILL_SHAPES[fill_shape]))
                    else:
                        fits.append(fit_step_response(d["time_s"], d["pressure_Pa"], u, order=o, t_step=t_step,
                                                      p_max=p_supply))
                trials[tr] = (d, fits)
        except RuntimeError as exc:  # the data give the fit nothing to converge on: the file's problem
            raise InputError(f"{meta['path']}: {exc}") from None
        out.append(LogIdentification(str(log), data, meta, trials))
    lift = None
    if len(out) > 1:
        if any(len(r.trials) > 1 for r in out):
            raise InputError("identify: the lift-off from several logs needs one trial per log")
        firsts = [next(iter(r.trials.values()))[1][0] for r in out]
        if any(f.order == "fill" for f in firsts):
            raise InputError("identify: the lift-off needs order 1 or 2 fits (`order` 1, 2 or both)")
        held = [float(np.median(r.data["command_pwm"][r.data["time_s"] >= f.t_step])) for r, f in zip(out, firsts)]
        lift = fit_lift_off(firsts, held)
    return LogsIdentification(out, lift)


# --- the simulated plant: two open-loop steps (§IV.A) ------------------------------------------


def identify_plant(plant=None, u1: int | None = None, duration: float = 0.8, du: int = 2):
    """Identify the plant's first-order model, with the valve's lift-off, from two inlet steps.

    From rest (both valves closed, atmospheric pressure) the inlet valve steps to ``u1`` and, in
    a second run, to ``u1 + du`` PWM counts, through the core in open-loop mode (its supervisor
    stays active); a FOPDT model is fitted to each pressure record, as the paper did with one
    voltage step (§IV.A). The ``u1`` step gives τ and θ. The two final pressures p1, p2 give the
    affine static map p = G·(u − u0) through both: G = (p2 − p1)/du, u0 = u1 − p1/G — the
    command below which the valve passes no air. The paper's model through the origin is the
    secant ``p1/u1`` of the first step (the fit's ``gain``); it overstates the command
    that holds a pressure by the whole lift-off (``docs/control.md``).

    Parameters
    ----------
    plant : optional
        Plant parameters; default the calibrated default plant. [-]
    u1 : int, optional
        Inlet counts after the first step; the default is the plant's calibration step
        (:data:`mckibben.plant.CALIBRATION_PWM`), whose time constant is the paper's 0.09 s. [PWM counts]
    duration : float, default 0.8
        Record length. [s]
    du : int, default 2
        Size of the second step above the first. [PWM counts]

    Returns
    -------
    tuple
        ``(StepFit, FirstOrderModel, LoopRecord)``: the fit of the ``u1`` step, the model the
        controllers use (τ and θ of that fit, G and u0 from both steps) and the records.
    """
    if u1 is None:
        u1 = CALIBRATION_PWM
    u1, du = _counts("u1", u1, 1, 254), _counts("du", du, 1, 254)
    if u1 + du > 255:
        raise InputError(f"identify_plant: u1 + du = {u1} + {du} counts, the second step must stay within 255")
    duration = check_real(duration, "duration", lo=0.0, lo_open=True, unit="s")
    check_budget("duration", 2 * duration / 1e-3, force=True)  # before the record's time axis is allocated
    n, t = time_grid(duration)
    steps = (u1, u1 + du)
    spec = core_spec([CoreParams(mode=MODE_OPEN_LOOP, open_loop_inlet=u) for u in steps])
    rec = run_closed_loop(spec, np.zeros(n), duration, plant)
    fits = [fit_step_response(t, rec.pressure[i], np.full(n, float(u)), t_step=0.0, input_step=float(u))
            for i, u in enumerate(steps)]
    lift = fit_lift_off(fits, steps)
    fit = fits[0]
    model = FirstOrderModel(lift["gain_Pa_per_count"], float(fit.tau), float(fit.dead_time), lift["lift_off_counts"])
    return fit, model, rec


def _counts(name: str, value, lo: int, hi: int) -> int:
    """A whole number of PWM counts in [lo, hi], or a one-line InputError naming ``name``."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    try:
        if isinstance(value, bool):
            raise TypeError
        v = operator.index(value)
    except TypeError:
        raise InputError(f"identify_plant: {name}={value!r} must be a whole number of counts in {lo}..{hi}") from None
    if not lo <= v <= hi:
        raise InputError(f"identify_plant: {name}={value!r} must be a whole number of counts in {lo}..{hi}")
    return v
