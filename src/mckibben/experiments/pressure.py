"""The pressure-control experiments on the simulated plant, one public call each, returning result objects.

Step (:func:`step_response`), tracking (:func:`track_pressure`), the open-loop identification step
(:func:`open_loop`), the paper's Fig. 13 (:func:`fig13`), PID against sliding mode
(:func:`compare`), Monte Carlo robustness (:func:`robustness`) and hysteresis compensation
(:func:`hysteresis_compensation`) of [mpam-characterization] §IV. Each takes numbers in SI (Pa, N,
s: ``target=0.55e6``) and objects (a :class:`~mckibben.control.references.SineReference`); text with
a unit is refused with the number to pass (:func:`mckibben.units.si`), the command line parses its
flags before it calls.

The building blocks are :mod:`mckibben.control`'s: the identified model and the documented designs
(:mod:`mckibben.control.experiment_setup`), the runs on the batch plant simulator
(:mod:`mckibben.control.runs`), the figures (:mod:`mckibben.control.plots`). This layer sits
above control, tool and rig (DESIGN.md); the results' provenance names the calls here
(``mckibben.experiments.step_response``).

>>> from mckibben.experiments import step_response        # doctest: +SKIP
>>> res = step_response("smc", target=0.55e6, law="paper", beta=150)   # doctest: +SKIP
>>> res.metrics["time_constant_s"], res.to_pandas().columns[:3].tolist()   # doctest: +SKIP
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from mckibben.control import registry as R
from mckibben.control.controllers import FirstOrderModel
from mckibben.control.core_params import CoreParams, core_spec
from mckibben.control.loop import LoopRecord, run_closed_loop, step_reference
from mckibben.control.controllers import SMC_LAWS
from mckibben.control.plant_sampling import plant_batch, sample_plants
from mckibben.control.studies import (CONTROLLER_NAMES, FIG13_TARGET_PA, comparison_entries, fig13_runs, percentiles,
                                      robustness_runs)
from mckibben.control.studies import step_size_table as _step_size_rows
from mckibben.control.tuning import GainTuning
from mckibben.control.hysteresis import PERIOD_MAX, PERIOD_MIN, SWEEP_PERIOD_MAX, SWEEP_PERIOD_MIN, hysteresis_benefit
from mckibben.control.metrics import tracking_metrics
from mckibben.control.plots import plot_compare, plot_fig13, plot_open_loop, plot_record, plot_robustness
from mckibben.control.references import SineReference
from mckibben.control.experiment_setup import (
    TS,
    boundary_layer,
    check_beta,
    check_ki,
    check_periods,
    controller_params,
    default_identification,
    identified_model,
    identify_file_plant,
    muscle_file_plant,
    plant_load,
    pressure_reference,
    rest_pull,
    tuned_controller,
)
from mckibben.errors import ArgumentTypeError, InputError, check_callable, unknown_name
from mckibben.fit.muscle_file import check_direction
from mckibben.hardware import P_MAX_DEFAULT
from mckibben.limits import check_budget, check_p_max, clamp_pressure
from mckibben.plant import CALIBRATION_PWM, PlantParams, open_loop_step
from mckibben.results import Result, TimeResponse, to_jsonable
from mckibben.units import si

__all__ = [
    "COMPARE_LOADS", "COMPARE_STEPS", "CompareResult", "FIG13_REFUSAL", "Fig13Result", "HYSTERESIS_REFUSAL",
    "OpenLoopResult", "ROBUSTNESS_DURATION", "RobustnessResult", "StepResult", "TrackResult", "compare", "fig13",
    "hysteresis_compensation", "open_loop", "robustness", "step_response", "track_pressure",
]


def _model_dict(model: FirstOrderModel) -> dict:
    return {"gain_Pa_per_count": model.gain, "tau_s": model.tau, "dead_time_s": model.dead_time,
            "lift_off_counts": model.lift_off}


def _gains_dict(params: CoreParams, controller: str) -> dict:
    return R.get(controller).describe(params)


def _record_frame(rec: LoopRecord, i: int = 0):
    return rec.frame(i)


@dataclass(frozen=True, repr=False)
class StepResult(Result):
    """A closed-loop pressure step on the simulated plant (:func:`step_response`).

    Attributes
    ----------
    record : LoopRecord
        The sampled run (one instance). [-]
    step_time : float
        Time of the step. [s]
    model : FirstOrderModel
        The identified model the controller was designed on. [-]
    params : CoreParams
        The controller's parameters. [-]
    arguments : dict
        Controller, target [Pa], start [Pa], load [N], p_max [Pa], step time [s]. [-]
    tuning : GainTuning or None
        How the gains were tuned on a muscle file's plant (None: the documented gains). [-]
    """

    record: LoopRecord
    step_time: float
    model: FirstOrderModel
    params: CoreParams
    arguments: dict = field(default_factory=dict)
    tuning: GainTuning | None = None
    call = "mckibben.experiments.step_response"
    _repr_keys = ("time_constant_s", "overshoot_pct", "settling_time_s", "steady_state_error_Pa")

    @property
    def metrics(self) -> dict:
        """Step metrics (:func:`~mckibben.control.metrics.step_metrics`) from the step on. [SI]"""
        return self.record.metrics(0, self.step_time)

    def to_dict(self) -> dict:
        """What ``mckibben control step --json`` prints."""
        a = self.arguments
        return to_jsonable({
            "controller": a["controller"], "target_Pa": a["target_Pa"], "from_Pa": a["from_Pa"],
            "load_N": a["load_N"], "p_max_Pa": a["p_max_Pa"], "requested_target_Pa": a["requested_target_Pa"],
            "requested_from_Pa": a["requested_from_Pa"], "reference_clamped": a["reference_clamped"],
            "step_time_s": self.step_time,
            "model": _model_dict(self.model), "gains": _gains_dict(self.params, a["controller"]),
            "peak_pressure_Pa": float(np.nanmax(self.record.pressure[0])),
            "faults": self.faults, "target_unreachable": self.target_unreachable,
            **({"muscle_file": a["muscle_file"], "direction": a["direction"], "supply_Pa": a["supply_Pa"]}
               if "muscle_file" in a else {}),
            **({"tuning": self.tuning.to_dict()} if self.tuning is not None else {}),
            **self.metrics})

    @property
    def faults(self) -> int:
        """OR of the supervisor's fault flags over the run (0: none). [-]"""
        return int(np.bitwise_or.reduce(self.record.faults[0].astype(np.int64)))

    @property
    def target_unreachable(self) -> bool:
        """Whether the run ended settled below the target with the inlet open (the supply's limit)."""
        return bool(self.record.target_unreachable(0))

    def _series(self):
        return _record_frame(self.record)

    def plot(self, ax=None):
        """Pressure against reference, and the valve command; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes or pair of Axes, optional
            One Axes: the pressure only; two: pressure and command; default a new figure. [-]
        """

        return plot_record(self.record, [self.arguments["controller"]], ax=ax)


def _file_controllers(plant, beta=None) -> dict:
    """The controllers of :func:`compare` and :func:`robustness` (:data:`CONTROLLER_NAMES`), tuned on a muscle
    file's plant: every controller of the registry and variant of its law
    (:func:`~mckibben.control.studies.comparison_entries`); ``beta`` held by the first variant when given."""
    m = identify_file_plant(plant)
    return {name: tuned_controller(controller, m, plant, law=variant or "model",
                                   beta=beta if name == controller else None).params
            for name, controller, variant in comparison_entries()}


def _refuse_muscle_file(function: str, muscle_file, why: str) -> None:
    if muscle_file is not None:
        raise InputError(f"muscle_file {muscle_file}: {function}() {why}")


def _plant_and_controller(controller: str, muscle_file, file_plant: tuple, plant_kw: dict, model, gains: dict,
                          objective: str):
    """The plant a pressure experiment runs on, its design model and its controller.

    A muscle file's plant (:func:`muscle_file_plant` of ``muscle_file`` with ``file_plant`` = (load [N],
    supply [Pa] or None, direction)), its model identified on it and the gains not in ``gains`` tuned
    on it for ``objective`` (:func:`tuned_controller`); else the calibrated plant
    (:func:`plant_batch` of ``plant_kw``) with the documented design (:func:`controller_params`).
    ``model`` replaces the identified model when given; ``gains`` holds ``law``, ``beta``, ``eps``,
    ``ki``, ``lam`` and ``p_max`` [Pa].

    Returns
    -------
    tuple
        ``(plant, model, params, tuning)``; ``tuning`` is None without a muscle file.
    """
    if muscle_file is not None:
        plant = muscle_file_plant(muscle_file, *file_plant)
        m = identify_file_plant(plant) if model is None else model
        tuning = tuned_controller(controller, m, plant, **gains, objective=objective)
        return plant, m, tuning.params, tuning
    plant = plant_batch(**plant_kw)
    m = identified_model() if model is None else model
    return plant, m, controller_params(controller, m, **gains), None


def _no_direction(direction: str, muscle_file) -> None:
    """``--direction`` is the branch of a muscle file's law: refuse it (or a bad value) without one."""

    check_direction(direction)
    if muscle_file is None and direction != "inflate":
        raise InputError(f"direction {direction}: picks the branch of a `muscle_file`'s fitted law; the "
                         "calibrated plant runs both branches through its braid friction")


def _step_args(controller, target, start, load, supply, duration, p_max, force, muscle_file=None):
    """Check a step's numbers, limits first: a refusal comes before any plant is built.

    With a muscle file, its plant's load check replaces the calibrated muscle's (the caller
    builds that plant).
    """
    dur = check_periods(duration, "duration")
    pmax = check_p_max(si(p_max, "pressure", "p_max", allow_zero=False))
    p1 = si(target, "pressure", "target")
    p0 = si(start, "pressure", "start")
    hold = 0.5 if p0 > 0 else 0.05
    check_budget("duration", (hold + dur) / TS, force=force)
    if p0 == p1:
        raise InputError("target: equals `start`, there is no step")
    (p0c, p1c), clamped = clamp_pressure([p0, p1], pmax, "target/start")
    if p0c == p1c:
        raise InputError(f"target: {target!r} and `start` {start!r} are both clamped to {p1c / 1e6:g} MPa "
                         "(`p_max`): there is no step")
    args = {"controller": controller, "target_Pa": float(p1c), "from_Pa": float(p0c),
            "load_N": plant_load(load) if muscle_file is None else si(load, "force", "load"),
            "p_max_Pa": pmax, "duration_s": dur,
            "requested_target_Pa": p1, "requested_from_Pa": p0, "reference_clamped": clamped,
            "step_time_s": hold}
    if supply is not None:
        args["supply_Pa"] = si(supply, "pressure", "supply", allow_zero=False)
    return args


def step_response(controller: str = "smc", target=FIG13_TARGET_PA, *, start=0.0, load=0.6, supply=None,
                  duration=1.0, p_max=P_MAX_DEFAULT, law: str = "model", beta=None, eps=None, ki=None, lam=None,
                  model: FirstOrderModel | None = None, force: bool = False, muscle_file=None,
                  direction: str = "inflate") -> StepResult:
    """A pressure step on the calibrated plant under the firmware's controller.

    The pressure ``start`` is held (0.05 s from rest, 0.5 s from a back pressure), then the
    reference steps to ``target``; a reference outside [0, p_max] is clamped as the supervisor
    would (one warning, ``reference_clamped``), and scored as commanded; Fig. 13 of [mpam-characterization] is this experiment with
    ``law="paper"``, ``beta`` 120 or 150 and ``target`` 0.55 MPa.

    Parameters
    ----------
    controller : {"smc", "pid"}, default "smc"
        The controller (:func:`controller_params`). [-]
    target : float, default 0.55e6
        Pressure after the step (Fig. 13's, :data:`~mckibben.control.studies.FIG13_TARGET_PA`). [Pa]
    start : float, default 0.0
        Pressure held before the step. [Pa]
    load : float, default 0.6
        Hanging load. [N]
    supply : float, optional
        Supply pressure; default the calibrated plant's. [Pa]
    duration : float, default 1.0
        Time after the step. [s]
    p_max : float, default P_MAX_DEFAULT (0.8e6)
        Supervisor's maximum pressure. [Pa]
    law : {"model", "paper"}, default "model"
        Sliding-mode law. [-]
    beta : float, optional
        Switching gain. [PWM counts]
    eps : float, optional
        Boundary layer. [Pa]
    ki : float, optional
        Surface integral weight. [1/s]
    lam : float, optional
        PID closed-loop time constant. [s]
    model : FirstOrderModel, optional
        Design model; default :func:`identified_model`. [-]
    force : bool, default False
        Run past the documented size limits (:mod:`mckibben.limits`). [-]
    muscle_file : str or pathlib.Path, optional
        Run a muscle file's own fitted force law (:func:`muscle_file_plant`) instead of the
        calibrated plant; the design model is identified on that plant and the gains not given
        are tuned on it (:func:`tuned_controller`). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        With ``muscle_file``: the branch of its law. [-]

    Returns
    -------
    StepResult
        ``.metrics`` (time constant, rise, overshoot, settling, errors, effort), ``.to_pandas()``
        (``time_s``, ``reference_Pa``, ``pressure_Pa``, ``inlet_pwm``, ``bleed_pwm``,
        ``command_pwm``, ``length_m``, ``fault_flags``), ``.plot()``.
    """
    _no_direction(direction, muscle_file)
    args = _step_args(controller, target, start, load, supply, duration, p_max, force, muscle_file)
    plant_kw = {"load_N": args["load_N"]}
    if "supply_Pa" in args:
        plant_kw["supply_Pa"] = args["supply_Pa"]
    plant, params_model, params, tuning = _plant_and_controller(
        controller, muscle_file, (load, supply, direction), plant_kw, model,
        dict(law=law, beta=beta, eps=eps, ki=ki, lam=lam, p_max=p_max), "step")
    if muscle_file is not None:
        args.update(muscle_file=str(muscle_file), direction=direction, supply_Pa=float(plant.supply_pressure))
    hold = args["step_time_s"]
    total = hold + args["duration_s"]
    n = int(round(total / TS))
    ref = step_reference(n, int(round(hold / TS)), args["from_Pa"], args["target_Pa"])
    rec = run_closed_loop(core_spec(params), ref, total, plant)
    args.update(law=law if R.get(controller).variants else None)
    return StepResult(rec, hold, params_model, params, args, tuning)


@dataclass(frozen=True, repr=False)
class TrackResult(Result):
    """A pressure trajectory followed on the simulated plant (:func:`track_pressure`).

    Attributes
    ----------
    record : LoopRecord
        The sampled run. [-]
    model : FirstOrderModel
        Design model. [-]
    params : CoreParams
        Controller parameters. [-]
    arguments : dict
        Controller, reference, load [N], p_max [Pa]. [-]
    tuning : GainTuning or None
        How the gains were tuned on a muscle file's plant (None: the documented gains). [-]
    """

    record: LoopRecord
    model: FirstOrderModel
    params: CoreParams
    arguments: dict = field(default_factory=dict)
    tuning: GainTuning | None = None
    call = "mckibben.experiments.track_pressure"

    @property
    def metrics(self) -> dict:
        """RMS and maximum error, valve effort (:func:`~mckibben.control.metrics.tracking_metrics`). [SI]"""
        r = self.record
        return tracking_metrics(r.t, r.pressure[0], r.reference[0], r.command[0])

    def to_dict(self) -> dict:
        """What ``mckibben control track --json`` prints."""
        a = self.arguments
        return to_jsonable({"controller": a["controller"], "load_N": a["load_N"], "p_max_Pa": a["p_max_Pa"],
                            "reference_clamped": a["reference_clamped"],
                            **({"muscle_file": a["muscle_file"], "direction": a["direction"]}
                               if "muscle_file" in a else {}),
                            **({"tuning": self.tuning.to_dict()} if self.tuning is not None else {}),
                            "gains": _gains_dict(self.params, a["controller"]), **self.metrics})

    def _series(self):
        return _record_frame(self.record)

    def plot(self, ax=None):
        """Reference, pressure and command against time; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes or pair of Axes, optional
            Where to draw; default a new figure. [-]
        """

        return plot_record(self.record, [self.arguments["controller"]], ax=ax)


def track_pressure(reference, controller: str = "smc", *, duration=2.0, load=0.6, p_max=P_MAX_DEFAULT,
                   law: str = "model", beta=None, eps=None, ki=None, lam=None, model: FirstOrderModel | None = None,
                   force: bool = False, muscle_file=None, direction: str = "inflate") -> TrackResult:
    """Track a pressure trajectory on the calibrated plant.

    Parameters
    ----------
    reference : SineReference or str or pathlib.Path or array_like
        A sine, a file or samples: see :func:`pressure_reference`. [Pa]
    controller : {"smc", "pid"}, default "smc"
        The controller. [-]
    duration : float, default 2.0
        Length of a sine reference. [s]
    load : float, default 0.6
        Hanging load. [N]
    p_max : float, default P_MAX_DEFAULT (0.8e6)
        Supervisor's maximum pressure. [Pa]
    law : {"model", "paper"}, default "model"
        Sliding-mode law. [-]
    beta : float, optional
        Switching gain. [PWM counts]
    eps : float, optional
        Boundary layer. [Pa]
    ki : float, optional
        Surface integral weight. [1/s]
    lam : float, optional
        PID closed-loop time constant. [s]
    model : FirstOrderModel, optional
        Design model; default :func:`identified_model`. [-]
    force : bool, default False
        Run past the documented size limits (:mod:`mckibben.limits`). [-]
    muscle_file : str or pathlib.Path, optional
        Run a muscle file's own fitted force law (:func:`muscle_file_plant`); the design model is
        identified on that plant and the gains not given are tuned on it (:func:`tuned_controller`). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        With ``muscle_file``: the branch of its law. [-]

    Returns
    -------
    TrackResult
        A reference outside [0, p_max] is clamped as the supervisor would (``reference_clamped``).
    """
    _no_direction(direction, muscle_file)
    pmax = check_p_max(si(p_max, "pressure", "p_max", allow_zero=False))
    f_load = plant_load(load) if muscle_file is None else si(load, "force", "load")
    _, ref = pressure_reference(reference, duration, force=force)
    ref, clamped = clamp_pressure(ref, pmax, "reference")
    plant, m, params, tuning = _plant_and_controller(
        controller, muscle_file, (load, None, direction), {"load_N": f_load}, model,
        dict(law=law, beta=beta, eps=eps, ki=ki, lam=lam, p_max=pmax), "track")
    rec = run_closed_loop(core_spec(params), ref, float(len(ref)) * TS, plant)
    args = {"controller": controller, "reference": _reference_text(reference),
            "load_N": f_load, "p_max_Pa": pmax, "reference_clamped": clamped,
            "law": law if R.get(controller).variants else None}
    if muscle_file is not None:
        args.update(muscle_file=str(muscle_file), direction=direction)
    return TrackResult(rec, m, params, args, tuning)


def _reference_text(reference) -> str:
    """How a result's arguments (a table's provenance) name its reference."""
    if isinstance(reference, SineReference):
        return reference.text
    return str(reference) if isinstance(reference, (str, os.PathLike)) else "array"


#: Why :func:`fig13` and :func:`hysteresis_compensation` (``control fig13|hysteresis``) refuse a muscle file.
FIG13_REFUSAL = ("is the paper's Fig. 13 on its miniature muscle: the β of 120 and 150 counts sit just above that "
                 "rig's holding command and the paper's points are that muscle's; step_response(muscle_file=...) "
                 "tunes the gains for the file's plant (the control step command), compare(muscle_file=...) "
                 "compares the controllers on it")
HYSTERESIS_REFUSAL = ("compensates the hysteresis of the calibrated muscle's braid friction; a muscle file's plant "
                      "runs one branch of its fitted law (`direction`) without friction, so it has no loop to "
                      "compensate")


@dataclass(frozen=True, repr=False)
class Fig13Result(Result):
    """The paper's Fig. 13 on the plant (:func:`fig13`): each (law, β) beside the paper's values.

    Attributes
    ----------
    rows : list of dict
        One per (law, β): step metrics beside ``paper_time_constant_s``, ``paper_overshoot_pct``. [-]
    record : LoopRecord
        The runs, one instance per row. [-]
    model : FirstOrderModel
        Identified model. [-]
    tau_stderr : float
        Standard error of the identified τ. [s]
    arguments : dict
        β values, laws, ε, Ki. [-]
    """

    rows: list
    record: LoopRecord
    model: FirstOrderModel
    tau_stderr: float
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.fig13"

    @property
    def metrics(self) -> dict:
        """Step metrics per case, keyed ``"law@β"`` (e.g. ``"paper@150"``). [SI]"""
        return {f"{r['law']}@{r['beta_counts']:g}": r for r in self.rows}

    def __repr__(self) -> str:
        cases = ", ".join(f"{k}: τ={v['time_constant_s']:.4g} s" for k, v in self.metrics.items())
        return f"Fig13Result({cases})"

    def to_dict(self) -> dict:
        """What ``mckibben control fig13 --json`` prints."""
        return to_jsonable({"model": {**_model_dict(self.model), "tau_s_stderr": self.tau_stderr}, "rows": self.rows})

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        frames = []
        for i, r in enumerate(self.rows):
            df = _record_frame(self.record, i)
            df.insert(0, "beta_counts", r["beta_counts"])
            df.insert(0, "law", r["law"])
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def tau_against_beta(self, betas=None):
        """The paper's law's time constant against β on the plant (τ falls once β exceeds the
        holding command, eq. 11 of [mpam-characterization]).

        Parameters
        ----------
        betas : array_like, optional
            Switching gains; default 110–200 in steps of 2. [PWM counts]

        Returns
        -------
        pandas.DataFrame
            ``beta_counts``, ``time_constant_s``, ``overshoot_pct``.
        """
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        betas = np.arange(110.0, 201.0, 2.0) if betas is None else np.asarray(betas, dtype=float)
        rows, _ = fig13_runs(self.model, betas=betas, laws=("paper",))
        return pd.DataFrame({"beta_counts": [r["beta_counts"] for r in rows],
                             "time_constant_s": [r["time_constant_s"] for r in rows],
                             "overshoot_pct": [r["overshoot_pct"] for r in rows]})

    def plot(self, ax=None):
        """The step responses and τ against β beside the paper's points; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes or pair of Axes, optional
            One Axes: the responses only; two: responses and τ(β); default a new figure with both. [-]
        """

        return plot_fig13(self, ax=ax)


def fig13(betas=(120.0, 150.0), *, laws=SMC_LAWS, eps=None, ki=None, muscle_file=None) -> Fig13Result:
    """The paper's Fig. 13 on the plant: sliding mode, step 0 → 0.55 MPa, each law and β.

    [mpam-characterization] §IV.B measured the ``paper`` law at β = 120 (τ ≈ 0.06 s) and 150
    (τ ≈ 0.01 s, ~7 % overshoot); those values come from
    :data:`mckibben.datasets.paper_points.FIG13`. The ``model`` law at the same β shows what our
    model term changes.

    Parameters
    ----------
    betas : sequence of float, default (120, 150)
        Switching gains. [PWM counts]
    laws : sequence of str, default ("model", "paper")
        Sliding-mode laws. [-]
    eps : float or str, optional
        Boundary layer; default each law's tuning. [Pa]
    ki : float, optional
        Surface integral weight; default each law's tuning. [1/s]
    muscle_file : str or pathlib.Path, optional
        Refused: Fig. 13 is the miniature muscle's (its β sit just above that rig's holding
        command, its points are that muscle's); ``step_response(..., muscle_file=)`` tunes a
        muscle file's controller instead. [-]

    Returns
    -------
    Fig13Result
    """
    _refuse_muscle_file("fig13", muscle_file, FIG13_REFUSAL)
    e = boundary_layer(eps)
    k = check_ki(ki)
    for name, value in (("betas", betas), ("laws", laws)):
        if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list, np.ndarray)) or len(value) == 0:
            raise ArgumentTypeError(f"{name} = {value!r}: want a non-empty sequence (a tuple or list)")
    betas = tuple(check_beta(b, "betas") for b in betas)
    for law in laws:
        if law not in SMC_LAWS:
            raise unknown_name("`laws` entry", law, SMC_LAWS)
    fit, model, _ = default_identification()
    rows, rec = fig13_runs(model, betas=betas, laws=tuple(laws), eps=e, ki=k)
    return Fig13Result(rows, rec, model, float(fit.stderr["tau_s"]),
                       {"betas_counts": list(betas), "laws": list(laws), "eps_Pa": e, "ki_per_s": k})


@dataclass(frozen=True, repr=False)
class CompareResult(Result):
    """PID against both sliding-mode laws over step sizes and loads (:func:`compare`).

    Attributes
    ----------
    rows : list of dict
        One per (controller, step, load) with the step metrics. [-]
    arguments : dict
        β of our law. [-]
    """

    rows: list
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.compare"

    @property
    def metrics(self) -> dict:
        """Per controller: median time constant [s], overshoot [%] and absolute steady-state error [Pa] over the runs."""
        out = {}
        for c in CONTROLLER_NAMES:
            rs = [r for r in self.rows if r["controller"] == c]
            out[c] = {k: float(np.nanmedian([abs(r[k]) if k.startswith("steady") else r[k] for r in rs]))
                      for k in ("time_constant_s", "overshoot_pct", "steady_state_error_Pa")}
        return out

    def __repr__(self) -> str:
        body = ", ".join(f"{c}: τ={v['time_constant_s']:.3g} s" for c, v in self.metrics.items())
        return f"CompareResult({len(self.rows)} runs; median {body})"

    def to_dict(self) -> dict:
        """What ``mckibben control compare --json`` prints."""
        return to_jsonable({"rows": self.rows})

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        return pd.DataFrame(self.rows)

    def plot(self, ax=None):
        """Time constant of each controller for each step and load; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """

        return plot_compare(self, ax=ax)


#: The comparison's steps (0→0.2, 0→0.55, 0.3→0.7 and 0.55→0.2 MPa) as fractions of the 0.8 MPa
#: they are taken under (the rig's maximum, :data:`mckibben.hardware.P_MAX_DEFAULT`); a muscle
#: file's comparison scales them to min(its supply, that maximum).
COMPARE_STEPS = tuple((a / P_MAX_DEFAULT, b / P_MAX_DEFAULT) for a, b in ((0.0, 0.2e6), (0.0, 0.55e6),
                                                                          (0.3e6, 0.7e6), (0.55e6, 0.2e6)))
#: A muscle file's comparison loads, as fractions of what it pulls at rest length and supply
#: (:func:`rest_pull`).
COMPARE_LOADS = (0.0, 0.25, 0.5)


def compare(beta=None, *, muscle_file=None, direction: str = "inflate") -> CompareResult:
    """PID (lambda-tuned on the first-order model) against both sliding-mode laws (§IV.A).

    Steps 0→0.2, 0→0.55, 0.3→0.7 and 0.55→0.2 MPa under 0, 1.5 and 3 N: the paper found the PID's
    performance "varied with different step size and back pressure". With a muscle file, the same
    steps scaled to its top pressure (:data:`COMPARE_STEPS`) under 0, 1/4 and 1/2 of what it pulls
    at rest (:data:`COMPARE_LOADS`), each controller tuned on each loaded plant
    (:func:`tuned_controller`; ``smc_paper`` is the paper's law with β tuned too).

    Parameters
    ----------
    beta : float, optional
        Switching gain of our law (default 50; tuned with a muscle file). [PWM counts]
    muscle_file : str or pathlib.Path, optional
        Compare on a muscle file's plant (:func:`muscle_file_plant`). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        With ``muscle_file``: the branch of its law. [-]

    Returns
    -------
    CompareResult
    """
    _no_direction(direction, muscle_file)
    b = check_beta(beta)
    if muscle_file is None:
        return CompareResult(_step_size_rows(identified_model(), beta=b), {"beta_counts": b})
    plant = muscle_file_plant(muscle_file, 0.0, None, direction)
    top = min(float(plant.supply_pressure), float(P_MAX_DEFAULT))
    most = rest_pull(plant)
    loads = tuple(round(f * most, 1) for f in COMPARE_LOADS)
    plants = {w: muscle_file_plant(muscle_file, w, None, direction) for w in loads}
    rows = _step_size_rows(None, steps=tuple((a * top, c * top) for a, c in COMPARE_STEPS), loads=loads,
                           plant_for_load=plants.__getitem__,
                           controllers_for_load=lambda w, pl: _file_controllers(pl, b))
    return CompareResult(rows, {"beta_counts": b, "muscle_file": str(muscle_file), "direction": direction})


@dataclass(frozen=True, repr=False)
class RobustnessResult(Result):
    """Monte Carlo over plant uncertainty (:func:`robustness`).

    Attributes
    ----------
    samples : dict of str to numpy.ndarray
        The plant factors of each random plant. [-]
    per_plant : dict
        {controller: {metric: array over plants}}. [SI]
    summary : dict
        {controller: {metric: median, p5, p95, n_undefined}}. [SI]
    arguments : dict
        n, seed, β. [-]
    """

    samples: dict
    per_plant: dict
    summary: dict
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.robustness"

    @property
    def metrics(self) -> dict:
        """The summary: per controller and metric, median, 5 % and 95 % and the undefined count."""
        return self.summary

    def __repr__(self) -> str:
        body = ", ".join(f"{c}: τ median {s['time_constant_s']['median']:.3g} s" for c, s in self.summary.items())
        return f"RobustnessResult(n={self.arguments['n']}, seed={self.arguments['seed']}; {body})"

    def to_dict(self) -> dict:
        """What ``mckibben control robustness --json`` prints."""
        return to_jsonable({"n": self.arguments["n"], "seed": self.arguments["seed"], "summary": self.summary})

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        frames = []
        for c in CONTROLLER_NAMES:
            df = pd.DataFrame({"controller": c, "plant": np.arange(self.arguments["n"]), **self.samples,
                               **self.per_plant[c]})
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def plot(self, ax=None):
        """Distributions of time constant, overshoot and steady-state error; return the Figure.

        Parameters
        ----------
        ax : sequence of three matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """

        return plot_robustness(self, ax=ax)


#: Record length of each robustness run. [s]
ROBUSTNESS_DURATION = 0.6


def robustness(n: int = 1000, *, seed: int = 0, beta=None, progress=None, force: bool = False, muscle_file=None,
               direction: str = "inflate") -> RobustnessResult:
    """Monte Carlo over plant uncertainty: PID and both sliding-mode laws on the same n plants.

    ±30 % on valve gain, dead band, volumes and leak, supply 0.6–1.0 MPa, load 0–3 N
    (:func:`~mckibben.control.plant_sampling.sample_plants`); the controllers are designed once on
    the nominal plant's identified model. With a muscle file: the same factors around its plant,
    supply 0.75–1 × its top fitted pressure, load 0–1/2 of what it pulls at rest, step to 0.55/0.8
    of min(supply, 0.8 MPa); the controllers tuned once on the nominal plant (1/4 of that pull)
    (:func:`tuned_controller`).

    Parameters
    ----------
    n : int, default 1000
        Number of random plants. [-]
    seed : int, default 0
        Random seed. [-]
    beta : float, optional
        Switching gain of our law (default 50). [PWM counts]
    progress : callable, optional
        ``progress(done, total)`` after each chunk of plants. [-]
    force : bool, default False
        Run past the documented size limits (:mod:`mckibben.limits`). [-]
    muscle_file : str or pathlib.Path, optional
        Random plants around a muscle file's plant (:func:`muscle_file_plant`). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        With ``muscle_file``: the branch of its law. [-]

    Returns
    -------
    RobustnessResult
    """
    check_callable(progress, "progress")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"n: {n!r} must be at least 1")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**63:
        raise InputError(f"seed: {seed!r} must be in 0..2**63-1")
    k = len(CONTROLLER_NAMES)
    check_budget("n", k * n * ROBUSTNESS_DURATION / TS, force=force,
                 what=f"control periods ({k} controllers × `n` plants × 0.6 s)")
    _no_direction(direction, muscle_file)
    b = check_beta(beta)

    extra: dict = {}
    if muscle_file is None:
        model = identified_model()
        samples = sample_plants(int(n), seed)
    else:
        nominal = muscle_file_plant(muscle_file, 0.0, None, direction)
        top, most = float(nominal.supply_pressure), rest_pull(nominal)
        nominal = muscle_file_plant(muscle_file, 0.25 * most, None, direction)
        model = FirstOrderModel(1.0, 1.0)  # unused: the controllers are tuned on the plant
        samples = sample_plants(int(n), seed, supply=(0.75 * top, top), load=(0.0, 0.5 * most))
        extra = {"base_plant": nominal, "controllers": _file_controllers(nominal, b),
                 "target": float(np.asarray(FIG13_TARGET_PA)) / P_MAX_DEFAULT * min(top, P_MAX_DEFAULT)}
    chunk = max(1, min(int(n), 250))
    per_plant: dict[str, dict[str, np.ndarray]] = {c: {} for c in CONTROLLER_NAMES}
    for lo in range(0, int(n), chunk):
        hi = min(int(n), lo + chunk)
        part = robustness_runs(model, n=hi - lo, seed=seed, beta=b, samples={k: v[lo:hi] for k, v in samples.items()},
                                **extra)
        for c in CONTROLLER_NAMES:
            for k, v in part["metrics"][c].items():
                per_plant[c][k] = np.concatenate([per_plant[c].get(k, np.empty(0)), v])
        if progress is not None:
            progress(hi, int(n))

    summary = {c: {k: percentiles(v) for k, v in per_plant[c].items()} for c in CONTROLLER_NAMES}
    where = {} if muscle_file is None else {"muscle_file": str(muscle_file), "direction": direction,
                                            "target_Pa": extra["target"]}
    return RobustnessResult(samples, per_plant, summary, {"n": int(n), "seed": seed, "beta_counts": b, **where})


@dataclass(frozen=True, repr=False)
class OpenLoopResult(Result, TimeResponse):
    """An open-loop inlet-valve step from rest on the plant (:func:`open_loop`).

    Attributes
    ----------
    time, pressure, length : numpy.ndarray
        Samples [s], gauge pressure [Pa], muscle length [m].
    step_metrics : dict
        Time constant, rise time, overshoot, final pressure. [SI]
    arguments : dict
        Valve [PWM counts], supply [Pa], load [N], duration [s]. [-]
    """

    time: np.ndarray
    pressure: np.ndarray
    length: np.ndarray
    step_metrics: dict
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.open_loop"
    TIME = "time"
    SIGNALS = ("pressure", "length")

    @property
    def metrics(self) -> dict:
        """Time constant (63 %), rise time (10–90 %), overshoot, final pressure and length. [SI]"""
        return {**self.step_metrics, "final_length_m": float(self.length[-1])}

    def to_dict(self) -> dict:
        """What ``mckibben simulate open-loop --json`` prints."""
        a = self.arguments
        extra = {"muscle_file": a["muscle_file"], "direction": a["direction"]} if "muscle_file" in a else {}
        return to_jsonable({"valve_pwm": a["valve_pwm"], "supply_Pa": a["supply_Pa"], "load_N": a["load_N"],
                            "duration_s": a["duration_s"], **extra, **self.metrics})

    def _series(self):
        return self.frame()

    def plot(self, ax=None):
        """The pressure rise with its 63 % time; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """

        return plot_open_loop(self, ax=ax)


def open_loop(valve: int | None = None, *, supply=None, load=0.6, duration=0.5,
              muscle_file=None, direction: str = "inflate") -> OpenLoopResult:
    """An open-loop inlet-valve step from rest (bleed shut): the identification experiment of §IV.A.

    Parameters
    ----------
    valve : int, optional
        Inlet PWM count, 0..255; default the calibration step. [PWM counts]
    supply : float, optional
        Supply pressure (gauge), at most 1 MPa; default the calibrated plant's (0.8e6,
        :class:`~mckibben.plant.PlantParams`), or a muscle file's top fitted pressure. [Pa]
    load : float, default 0.6
        Hanging load. [N]
    duration : float, default 0.5
        Simulated time, whole control periods, at most 60 s. [s]
    muscle_file : str or pathlib.Path, optional
        Run a muscle file's own fitted force law (:func:`muscle_file_plant`). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        With ``muscle_file``: the branch of its law. [-]

    Returns
    -------
    OpenLoopResult
    """

    _no_direction(direction, muscle_file)
    valve = CALIBRATION_PWM if valve is None else valve
    if isinstance(valve, bool) or not isinstance(valve, (int, np.integer)) or not 0 <= valve <= 255:
        raise InputError(f"valve: {valve!r} must be a PWM count in 0..255")
    d = si(duration, "time", "duration", allow_zero=False)
    if d > 60:
        raise InputError(f"duration: {duration!r} is longer than 60 s")
    steps = d / TS
    if abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
        raise InputError(f"duration: {duration!r} must be a whole number of 1 ms control periods")
    extra: dict = {}
    if muscle_file is not None:
        plant = muscle_file_plant(muscle_file, load, supply, direction)
        s, f = float(plant.supply_pressure), float(plant.load_force)
        extra.update(muscle_file=str(muscle_file), direction=direction)
    else:
        s = float(PlantParams().supply_pressure) if supply is None else si(supply, "pressure", "supply",
                                                                           allow_zero=False)
        if s > 1e6:
            raise InputError(f"supply: {supply!r} is above the compressor's 1 MPa")
        f = plant_load(load)
        plant = PlantParams(supply_pressure=s, load_force=f)
    res, m = open_loop_step(plant, valve=int(valve), duration=d)
    return OpenLoopResult(res.t, res.pressure[0], res.length[0], m,
                          {"valve_pwm": int(valve), "supply_Pa": s, "load_N": f, "duration_s": d, **extra})


def hysteresis_compensation(period=4.0, *, sweep_period=None, muscle_file=None):
    """Length tracking with and without hysteresis compensation (inflate/deflate branches, Prandtl–Ishlinskii).

    Identifies the plant (:func:`identified_model`), records a quasi-static pressure triangle,
    fits one cubic per branch and one through both, then tracks a length sinusoid with each
    (:func:`~mckibben.control.hysteresis.hysteresis_benefit`); a second sweep with minor loops
    fits a Prandtl–Ishlinskii operator whose exact inverse gives a third pressure reference
    (summary key ``prandtl_ishlinskii``).

    Parameters
    ----------
    period : float, default 4.0
        Period of the length sinusoid, 1 to 60 s. [s]
    sweep_period : float, optional
        Period of the identification triangle, 1 to 600 s; default 8 × ``period``. [s]
    muscle_file : str or pathlib.Path, optional
        Refused (:data:`HYSTERESIS_REFUSAL`): a muscle file's plant has no friction loop. [-]

    Returns
    -------
    HysteresisBenefit
        ``.summary()``, ``.plot()``.
    """
    _refuse_muscle_file("hysteresis_compensation", muscle_file, HYSTERESIS_REFUSAL)

    per = si(period, "time", "period", allow_zero=False)
    if not PERIOD_MIN <= per <= PERIOD_MAX:
        raise InputError(f"period: {period!r} must be between {PERIOD_MIN:g} s and {PERIOD_MAX:g} s")
    sweep = None
    if sweep_period is not None:
        sweep = si(sweep_period, "time", "sweep_period", allow_zero=False)
        if not SWEEP_PERIOD_MIN <= sweep <= SWEEP_PERIOD_MAX:
            raise InputError(f"sweep_period: {sweep_period!r} must be between {SWEEP_PERIOD_MIN:g} s and "
                             f"{SWEEP_PERIOD_MAX:g} s")
    return hysteresis_benefit(identified_model(), period=per, sweep_period=sweep)
