"""The building blocks of the closed-loop experiments: the identified model, the documented designs, the plants.

:func:`identified_model` (the calibrated plant identified as the paper did, §IV.A of
[mpam-characterization], :func:`~mckibben.control.identify.identify_plant`),
:func:`controller_params` (a controller with the documented tuning, ``docs/control.md``),
:func:`tuned_controller` (gains tuned on a plant), :func:`muscle_file_plant` (a muscle file's own
plant), :func:`pressure_reference` (a reference sampled at the control period) and the checks of
the gains the experiments share. The experiments themselves (:func:`step_response`,
:func:`fig13`, ...) are in :mod:`mckibben.experiments.pressure`, above control, tool and rig.

Every function takes numbers in SI (Pa, N, s) and objects
(:class:`~mckibben.control.references.SineReference`); text with a unit is refused with the number
to pass (:func:`mckibben.units.si`).
"""

from __future__ import annotations

import math
import os
from functools import lru_cache

import numpy as np

from mckibben.control import registry as R
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.laws import with_supervisor_model
from mckibben.control.core_params import CoreParams
from mckibben.control.controllers import SMC_LAWS
from mckibben.control.identify import identify_plant
from mckibben.control.tuning import tune_gains
from mckibben.control.references import SineReference, refuse_text
from mckibben.data.muscle_file import read_muscle
from mckibben.data.steplog import read_step_log
from mckibben.datasets import get_muscle
from mckibben.errors import ArgumentTypeError, InputError, unknown_name
from mckibben.fit.muscle_file import check_direction, muscle_force_law
from mckibben.hardware import P_MAX_DEFAULT, P_MAX_LIMIT
from mckibben.limits import check_budget, check_load, check_p_max
from mckibben.models import laws as LW
from mckibben.plant import PlantParams
from mckibben.units import si

__all__ = [
    "CONTROLLERS", "FILE_IDENTIFICATION_S", "TS", "boundary_layer", "check_beta", "check_ki", "check_periods",
    "controller_params", "default_identification", "identified_model", "identify_file_plant", "muscle_file_plant",
    "plant_load", "pressure_reference", "rest_pull", "tuned_controller",
]

#: Controllers the firmware core runs (:data:`mckibben.control.registry.NAMES`).
CONTROLLERS = R.NAMES
#: Control period of the core and of every record. [s]
TS = 1e-3


@lru_cache(maxsize=1)
def default_identification():
    """:func:`~mckibben.control.identify.identify_plant` on the calibrated plant, once per process.

    Returns
    -------
    tuple
        ``(StepFit, FirstOrderModel, LoopRecord)``.
    """
    return identify_plant()


def identified_model() -> FirstOrderModel:
    """The first-order model (with the valves' lift-off) identified on the calibrated plant.

    Two open-loop inlet steps, as the paper did with one voltage step (§IV.A of
    [mpam-characterization]); computed once per process.

    Returns
    -------
    FirstOrderModel
        Gain [Pa/count], time constant [s], dead time [s], lift-off [PWM counts].
    """
    return default_identification()[1]


def _counts_or_rate(value, name: str) -> float:
    """A gain given as a number (PWM counts, 1/s): text is refused, as every quantity of the library."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ArgumentTypeError(f"{name}: {value!r} is not a number")
    return float(value)


def check_beta(beta, name: str = "beta") -> float | None:
    """A sliding-mode switching gain β, 0..255 (None stays None: the design's).

    Parameters
    ----------
    beta : float or None
        The gain. [PWM counts]
    name : str, default "beta"
        The argument's name, for the message. [-]
    """
    if beta is None:
        return None
    b = _counts_or_rate(beta, name)
    if not (math.isfinite(b) and 0 <= b <= 255):
        raise InputError(f"{name}: {beta!r} must be in 0..255 PWM counts")
    return b


def check_ki(ki) -> float | None:
    """A sliding-surface integral weight, at least 0 (None stays None: the design's).

    Parameters
    ----------
    ki : float or None
        The weight. [1/s]
    """
    if ki is None:
        return None
    k = _counts_or_rate(ki, "ki")
    if not (math.isfinite(k) and k >= 0):
        raise InputError(f"ki: {ki!r} must be >= 0 (1/s)")
    return k


def check_periods(value, name: str) -> float:
    """A positive time that is a whole number of 1 ms control periods.

    Parameters
    ----------
    value : float
        The time. [s]
    name : str
        The argument, for messages. [-]
    """
    d = si(value, "time", name, allow_zero=False)
    steps = d / TS
    if not math.isfinite(steps):  # (1e306 s: past any budget, and no whole number of periods)
        raise InputError(f"{name}: {value!r} is longer than any run can be")
    if steps >= 1 and abs(steps - round(steps)) > 1e-6 * steps:
        raise InputError(f"{name}: {value!r} must be a whole number of 1 ms control periods")
    if steps < 1 - 1e-9:
        raise InputError(f"{name}: {value!r} is shorter than one 1 ms control period")
    return d


def controller_params(controller: str = "smc", model: FirstOrderModel | None = None, *, law: str = "model",
                      beta=None, eps=None, ki=None, lam=None, p_max=P_MAX_DEFAULT) -> CoreParams:
    """The firmware core's parameters for a controller with the documented tuning.

    Parameters
    ----------
    controller : {"smc", "pid"}, default "smc"
        Sliding mode (eq. 9–12, §IV.A of [mpam-characterization]) or the lambda-tuned PID the
        paper found wanting. [-]
    model : FirstOrderModel, optional
        Model the controller is designed on; default :func:`identified_model`. [-]
    law : {"model", "paper"}, default "model"
        Sliding-mode law: ours (model term with the valves' lift-off) or the paper's
        β·tanh(S/ε) alone. [-]
    beta : float, optional
        Switching gain; default 50 (``model``) or 150 (``paper``). [PWM counts]
    eps : float, optional
        Boundary layer; default the law's tuning. [Pa]
    ki : float, optional
        Surface integral weight; default the law's tuning. [1/s]
    lam : float, optional
        PID closed-loop time constant; default τ/3. [s]
    p_max : float, default P_MAX_DEFAULT (0.8e6)
        Supervisor's maximum pressure. [Pa]

    Returns
    -------
    CoreParams
    """
    if controller not in CONTROLLERS:
        raise unknown_name("controller", controller, CONTROLLERS)
    if law not in SMC_LAWS:
        raise unknown_name("`law`", law, SMC_LAWS)
    b, k = check_beta(beta), check_ki(ki)
    e = boundary_layer(eps)
    lm = si(lam, "time", "lam", allow_zero=False) if lam is not None else None
    model = identified_model() if model is None else model
    # the supervisor's valve model (G, lift-off) comes from the identification too
    base = with_supervisor_model(CoreParams(p_max=check_p_max(si(p_max, "pressure", "p_max", allow_zero=False))),
                                 model)
    return R.get(controller).design(model, base, law=law, beta=b, eps=e, ki=k, lam=lm)


def boundary_layer(eps) -> float | None:
    """The sliding-mode boundary layer ε, checked to lie in 1 Pa .. :data:`~mckibben.hardware.P_MAX_LIMIT`.

    Parameters
    ----------
    eps : float or None
        The boundary layer; None for the default. [Pa]
    """
    if eps is None:
        return None

    e = si(eps, "pressure", "eps", allow_zero=False)
    if not 1.0 <= e <= P_MAX_LIMIT:
        raise InputError(f"eps: {eps!r} must be between 1 Pa and {P_MAX_LIMIT / 1e6:g} MPa (the supervisor's "
                         "ceiling)")
    return e


def plant_load(load) -> float:
    """The hanging load of the calibrated plant's muscle, checked against what it can lift.

    Parameters
    ----------
    load : float
        The load. [N]
    """

    return check_load(si(load, "force", "load"), get_muscle(PlantParams().muscle_name))


def muscle_file_plant(path, load=0.6, supply=None, direction: str = "inflate"):
    """The plant of a muscle file's own fitted force law (:meth:`PlantParams.from_muscle_file`), loaded.

    Parameters
    ----------
    path : str or pathlib.Path
        A muscle file with a ``[force_model]`` table (``mckibben fit … --save``). [-]
    load : float, default 0.6
        Hanging load: at most the law's force at the rest length and the supply (a heavier load
        would stretch the muscle past the lengths it was fitted on). Its mass moves with the
        muscle (and is critically damped, ``docs/plant.md``). [N]
    supply : float, optional
        Supply pressure (gauge); default the top of the fitted pressure range. [Pa]
    direction : {"inflate", "deflate"}, default "inflate"
        The branch of the law (:func:`~mckibben.fit.muscle_file.check_direction`: a spring fit
        has two, the other laws one). [-]

    Returns
    -------
    PlantParams

    Raises
    ------
    InputError
        One line starting ``muscle_file`` and naming the file (missing, no force law, a law the
        plant cannot run) or ``load``/``supply``/``direction``.
    """

    f = si(load, "force", "load")
    check_direction(direction)
    kw = {}
    if supply is not None:
        kw["supply_pressure"] = si(supply, "pressure", "supply", allow_zero=False)
        if kw["supply_pressure"] > 1e6:
            raise InputError(f"supply: {supply!r} is above the compressor's 1 MPa")
    try:
        spec = read_muscle(path)
        law = muscle_force_law(spec)
    except InputError as exc:
        raise InputError(f"muscle_file {path}: {exc}") from None
    check_direction(direction, law)
    if math.isfinite(f) and f >= 0:
        kw["load_force"] = f  # its mass moves with the muscle: the plant damps it
    try:
        plant = PlantParams.from_muscle_file(spec, direction, **kw)
    except InputError as exc:
        raise InputError(f"muscle_file {path}: {exc}") from None
    most = rest_pull(plant)
    if not (math.isfinite(f) and 0 <= f <= most):
        raise InputError(f"load: {f:g} N is more than the muscle of {path} pulls at its rest length at "
                         f"{float(np.asarray(plant.supply_pressure)) / 1e6:g} MPa ({most:.4g} N, its fitted law)")
    return plant


def rest_pull(plant) -> float:
    """What a plant's muscle pulls at its rest length and supply pressure: the heaviest load it lifts. [N]

    Parameters
    ----------
    plant : PlantParams
        One rig. [-]
    """

    name, th = plant.law(1)
    return float(np.maximum(LW.evaluate(name, plant.supply_pressure, plant.nominal_length, th[:, 0]), 0.0))


#: Record length of a muscle file plant's identification: a large muscle under a load takes
#: seconds to settle, and the two steps' final pressures give the static gain and lift-off. [s]
FILE_IDENTIFICATION_S = 2.0


def identify_file_plant(plant) -> FirstOrderModel:
    """The first-order model of a muscle file's plant: :func:`~mckibben.control.identify.identify_plant`
    over :data:`FILE_IDENTIFICATION_S`.

    Parameters
    ----------
    plant : PlantParams
        One rig. [-]

    Returns
    -------
    FirstOrderModel
        Gain [Pa/count], time constant [s], dead time [s], lift-off [PWM counts].
    """

    return identify_plant(plant, duration=FILE_IDENTIFICATION_S)[1]


def tuned_controller(controller: str, model: FirstOrderModel, plant, *, law: str = "model", beta=None, eps=None,
                     ki=None, lam=None, p_max=P_MAX_DEFAULT, objective: str = "step"):
    """A controller whose free gains are tuned on a plant (:func:`~mckibben.control.tuning.tune_gains`).

    What a muscle file's plant gets instead of the calibrated rig's gains (``docs/control.md``,
    "Gains for a muscle file's plant"): the model term and the supervisor's valve model come from
    ``model``; β, ε, Ki (sliding mode) or λ and the design τ (PID) are chosen by simulating
    design steps on ``plant``. A gain given here is held, the others are tuned.

    Parameters
    ----------
    controller : {"smc", "pid"}
        The controller. [-]
    model : FirstOrderModel
        The model identified on ``plant``. [-]
    plant : PlantParams
        The plant (one rig). [-]
    law : {"model", "paper"}, default "model"
        Sliding-mode law. [-]
    beta : float, optional
        Switching gain to hold. [PWM counts]
    eps : float, optional
        Boundary layer to hold. [Pa]
    ki : float, optional
        Surface integral weight to hold. [1/s]
    lam : float, optional
        PID closed-loop time constant to hold. [s]
    p_max : float, default P_MAX_DEFAULT (0.8e6)
        Supervisor's maximum pressure (the design steps stay below it). [Pa]
    objective : {"step", "track"}, default "step"
        Tune on design steps (:func:`step_response`) or design sines (:func:`track_pressure`). [-]

    Returns
    -------
    GainTuning
        ``.params`` (the core's parameters), ``.gains``, ``.steps``, ``.met``.
    """

    if controller not in CONTROLLERS:
        raise unknown_name("controller", controller, CONTROLLERS)
    if law not in SMC_LAWS:
        raise unknown_name("`law`", law, SMC_LAWS)
    b, k, e = check_beta(beta), check_ki(ki), boundary_layer(eps)
    lm = si(lam, "time", "lam", allow_zero=False) if lam is not None else None
    base = with_supervisor_model(CoreParams(p_max=check_p_max(si(p_max, "pressure", "p_max", allow_zero=False))),
                                 model)
    return tune_gains(plant, model, controller, law=law, base=base, beta=b, eps=e, ki=k, lam=lm, objective=objective)


def pressure_reference(reference, duration=2.0, *, force: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A pressure reference sampled at the control period.

    Parameters
    ----------
    reference : SineReference or str or pathlib.Path or array_like
        A :class:`~mckibben.control.references.SineReference` (at most 500 Hz, what a 1 kHz
        controller can follow), the path of a CSV/Parquet file with ``time_<unit>`` and
        ``pressure_<unit>`` columns (resampled), or one pressure per control period. The command
        line's text (``sine:0.4MPa,0.2MPa,2Hz``) is read by
        :func:`~mckibben.control.references.parse_reference`. [Pa]
    duration : float, default 2.0
        Length of a sine reference. [s]
    force : bool, default False
        Go past the documented size limits (:mod:`mckibben.limits`). [-]

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Times [s] and pressures [Pa].
    """
    refuse_text(reference)
    if isinstance(reference, SineReference):
        d = check_periods(duration, "duration")
        check_budget("duration", d / TS, force=force)
        if reference.frequency > 500:
            raise InputError(f"reference frequency: {reference.frequency:g} Hz is above the 500 Hz a 1 kHz "
                             "controller can follow")
        t = np.arange(int(round(d / TS))) * TS
        return t, reference.sample(t)
    if not isinstance(reference, (str, os.PathLike)):
        p = np.asarray(reference, dtype=float)
        if p.ndim != 1 or p.size < 10 or not np.all(np.isfinite(p)):
            raise InputError("reference: an array reference must be 1-D, finite, at least 10 samples")
        check_budget("reference", p.size, force=force, what="control periods (one per sample of the array)")
        return np.arange(p.size) * TS, p

    data, _ = read_step_log(reference)
    t0 = data["time_s"] - data["time_s"][0]
    check_budget(f"reference {reference}", float(t0[-1]) / TS, force=force, what="control periods (the file's span)")
    t = np.arange(int(t0[-1] / TS) + 1) * TS
    if t.size < 10:
        raise InputError(f"reference: {str(reference)!r} is shorter than 10 ms")
    return t, np.interp(t, t0, data["pressure_Pa"])
