"""Experiments in MuJoCo with the calibrated muscles of :mod:`mckibben.export.mujoco` on its tendons.

:func:`hanging_mass`: a weight hanging from one muscle, its pressure held by a registry controller,
the settled length against ``mckibben predict length`` (``mckibben mujoco hang``).
:func:`run_model`: any MuJoCo model with muscles on some of its tendons, under valve counts or a
controller (``mckibben mujoco run``). Each returns a :class:`~mckibben.results.Result` whose record
is a :class:`~mckibben.results.TimeResponse`.

The bridge itself (the muscle bank, the model loader, the plants and the hanging-mass MJCF) stays
in :mod:`mckibben.export.mujoco`; these moved here from it, as the experiments of the other
packages did, so every public experiment lives in :mod:`mckibben.experiments`.

References
----------
MuJoCo documentation, "Computation"; [mpam-characterization], eq. (2)–(3), §III–IV.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from mckibben import control
from mckibben import hardware as HW
from mckibben.errors import ArgumentTypeError, InputError, check_real
from mckibben.export.mujoco import MuscleBank, _mujoco, hanging_mass_mjcf, load_model, muscle_plant
from mckibben.datasets import get_muscle
from mckibben.models import laws as LW
from mckibben.models.laws.braid_map import LAW as BRAID_MAP
from mckibben.models.mpam import MiniatureMuscle, predict_length
from mckibben.plant.simulator import static_equilibrium
from mckibben.results import Result, TimeResponse
from mckibben.units import si

__all__ = ["HangingMassResult", "MuscleRunResult", "hanging_mass", "run_model"]


@dataclass(frozen=True, eq=False)
class HangingMassResult(Result, TimeResponse):
    """A mass hanging from one muscle in MuJoCo, its pressure held by a controller: the static length.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times (every control period). [s]
    pressure, length, tension : numpy.ndarray
        Chamber gauge pressure [Pa], muscle length [m] and tension [N] at each sample.
    muscle : str
        The muscle's name. [-]
    load : float
        Hanging weight. [N]
    reference : float
        Pressure reference. [Pa]
    predicted_length : float
        ``mckibben predict length`` at the held pressure and the load (eq. 2+3). [m]
    plant_length : float
        The plant's own static length at the held pressure (its force law, no friction). [m]
    arguments : dict
        The call's arguments, SI. [-]
    """

    time: np.ndarray
    pressure: np.ndarray
    length: np.ndarray
    tension: np.ndarray
    muscle: str
    load: float
    reference: float
    predicted_length: float
    plant_length: float
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.mujoco.hanging_mass"
    TIME = "time"
    SIGNALS = ("pressure", "length", "tension")

    @property
    def metrics(self) -> dict:
        """Static length and pressure (mean of the last 10 % of the run) against the static predictions."""
        tail = self.time >= 0.9 * self.time[-1]
        length = float(np.mean(self.length[tail]))
        return {"static_length_m": length, "held_pressure_Pa": float(np.mean(self.pressure[tail])),
                "predicted_length_m": self.predicted_length,
                "length_error_vs_predict_pct": 100.0 * (length / self.predicted_length - 1.0),
                "plant_static_length_m": self.plant_length,
                "length_error_vs_plant_pct": 100.0 * (length / self.plant_length - 1.0),
                "tension_N": float(np.mean(self.tension[tail]))}

    def _series(self):
        return self.frame()

    def plot(self, ax=None):
        """Length against the predicted static length, and pressure, over time.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw the length; default a new figure (pressure on a twin axis). [-]
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(self.time, self.length * 1e3, label="MuJoCo length")
        ax.axhline(self.predicted_length * 1e3, color="k", ls="--", lw=1, label="predict length (eq. 2+3)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("length [mm]")
        ax2 = ax.twinx()
        ax2.plot(self.time, self.pressure / 1e6, color="C1", lw=1, label="pressure")
        ax2.set_ylabel("pressure [MPa]")
        ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"{self.muscle} holding {self.load:g} N in MuJoCo")
        return ax.figure


def hanging_mass(muscle="mpam97", pressure=0.4e6, load=0.6, *, force_model: str | None = None,
                 controller="smc", duration=1.5, timestep=1e-4, friction: bool = True) -> HangingMassResult:
    """A mass hanging from one muscle in MuJoCo, the pressure held by a registry controller.

    The muscle starts at its rest length and its chamber at ``pressure``; the controller holds
    the pressure while the load settles; the result compares the settled length with
    :func:`mckibben.models.mpam.predict_length` (``mckibben predict length``) and with the
    plant's own static length at the held pressure.

    Parameters
    ----------
    muscle : str or MiniatureMuscle, default "mpam97"
        A published set. [-]
    pressure : float, default 0.4e6
        Pressure reference (gauge). [Pa]
    load : float, default 0.6
        Hanging weight. [N]
    force_model : str, optional
        ``"calibrated"`` (default) or ``"empirical"`` (:func:`muscle_plant`). [-]
    controller : str, default "smc"
        A controller of the registry. [-]
    duration : float, default 1.5
        Simulated time. [s]
    timestep : float, default 1e-4
        MuJoCo's step (the plant's own RK4 step), at most the control period. [s]
    friction : bool, default True
        The braid's friction (the plant's Dahl element, ``docs/plant.md``); False turns it off,
        leaving the frictionless statics that predict length and the plant's static length solve. [-]

    Returns
    -------
    HangingMassResult
    """
    mujoco = _mujoco()
    m_obj = get_muscle(muscle) if isinstance(muscle, str) else muscle
    if not isinstance(m_obj, MiniatureMuscle):
        raise ArgumentTypeError("muscle: a published set (mpam97, mpam117, mpam143): predict length needs its eq. 2+3")
    pressure = si(pressure, "pressure", "pressure", allow_zero=False)
    load = si(load, "force", "load", allow_zero=False)
    duration = si(duration, "time", "duration", allow_zero=False)
    timestep = check_real(si(timestep, "time", "timestep", allow_zero=False), "timestep",
                          hi=HW.CONTROL_PERIOD, unit="s")
    plant = muscle_plant(m_obj, force_model, **({} if friction else {"friction_force": 0.0, "friction_per_pa": 0.0}))
    model = load_model(hanging_mass_mjcf(plant, load, timestep))
    data = mujoco.MjData(model)
    name, th = plant.law(1)  # the law the plant resolved its force model to
    # the braid-angle maps pull less when stretched below ~0.25 MPa: checked over the held pressures only
    floor = 0.9 * pressure if name == BRAID_MAP.name else 0.0
    # the supervisor's p_max at the transducer's full scale: its headroom cap holds a chamber some tens
    # of kPa below p_max (docs/controller.md, 2b), and this rig holds `pressure`, the calibration
    # point 0.8 MPa included (the 0.8 MPa supply bounds the chamber)
    ctrl = (control.experiment_setup.controller_params(controller, p_max=HW.P_MAX_LIMIT)
            if isinstance(controller, str) else controller)
    bank = MuscleBank(model, ["muscle"], plant, controller=ctrl, initial_pressure=pressure, pressure_floor=floor)
    n = int(round(duration / timestep))
    every = bank.steps_per_period
    t, p, ln, f = [], [], [], []
    for k in range(n):
        bank.step(data, reference=pressure if k == 0 else None)
        if k % every == every - 1:
            t.append(bank.t)
            p.append(bank.pressure[0])
            ln.append(bank.length(data)[0])
            f.append(bank.tension[0])
    p_arr = np.array(p)
    tail = np.array(t) >= 0.9 * t[-1]
    held = float(np.mean(p_arr[tail]))
    predicted = float(predict_length(m_obj, held, load).length)
    prm = plant.replace(load_force=load).pack(1)
    plant_len = float(static_equilibrium(prm, LW.LAW_INDEX[name], th, held)[0][0])
    return HangingMassResult(np.array(t), p_arr, np.array(ln), np.array(f), m_obj.name, float(load), float(pressure),
                             predicted, plant_len,
                             {"muscle": m_obj.name, "pressure_Pa": pressure, "load_N": load,
                              "force_model": force_model or "calibrated", "controller": controller,
                              "duration_s": duration, "timestep_s": timestep, "friction": bool(friction)})


# --- any model: its muscles under valve counts or a controller ----------------------------------------


@dataclass(frozen=True, eq=False)
class MuscleRunResult(Result, TimeResponse):
    """A MuJoCo model run with muscles on some of its tendons (:func:`run_model`).

    Attributes
    ----------
    time : numpy.ndarray
        Sample times (every control period), (n,). [s]
    pressure, length, tension : numpy.ndarray
        Each muscle's gauge pressure [Pa], length [m] and tension [N], (n, M).
    tendons : tuple of str
        The muscles' tendons. [-]
    end_stop : numpy.ndarray
        Per muscle: whether it reached an end stop of its braid. [-]
    faults : numpy.ndarray
        Per muscle: OR of the controller's fault flags (0 without a controller). [-]
    arguments : dict
        The call's arguments, SI. [-]
    """

    time: np.ndarray
    pressure: np.ndarray
    length: np.ndarray
    tension: np.ndarray
    tendons: tuple
    end_stop: np.ndarray
    faults: np.ndarray
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.mujoco.run_model"
    TIME = "time"
    SIGNALS = ("pressure", "length", "tension")
    CHANNELS = True
    CHANNEL_COLUMN = "{label}_{quantity}_{unit}"

    @property
    def metrics(self) -> dict:
        """Each muscle's final pressure, length and tension, its end-stop flag and faults (lists, tendon order)."""
        return {"tendons": list(self.tendons), "final_pressure_Pa": self.pressure[-1].tolist(),
                "final_length_m": self.length[-1].tolist(), "final_tension_N": self.tension[-1].tolist(),
                "end_stop": self.end_stop.tolist(), "controller_faults": self.faults.tolist()}

    def _channel_labels(self, name: str, k: int) -> tuple[str, ...]:
        return tuple(self.tendons)

    def _series(self):
        return self.frame()

    def plot(self, ax=None):
        """Each muscle's pressure and length over time.

        Parameters
        ----------
        ax : sequence of two matplotlib.axes.Axes, optional
            Where to draw pressure and length; default a new figure. [-]
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
        else:
            axes = list(ax)
        for i, name in enumerate(self.tendons):
            axes[0].plot(self.time, self.pressure[:, i] / 1e6, label=name)
            axes[1].plot(self.time, self.length[:, i] * 1e3, label=name)
        axes[0].set_ylabel("pressure [MPa]")
        axes[1].set_ylabel("muscle length [mm]")
        axes[1].set_xlabel("time [s]")
        axes[0].legend(fontsize=8)
        return axes[0].figure


def run_model(model, tendons, muscle="mpam97", *, reference=None, inlet=None, bleed=0, controller="smc",
              duration=1.0, initial_pressure=0.0, offset=0.0, force_model: str | None = None) -> MuscleRunResult:
    """Run a MuJoCo model with muscles on some of its tendons: a pressure reference held, or valve counts.

    Parameters
    ----------
    model : str, os.PathLike or mujoco.MjModel
        An MJCF file (or text, or a compiled model) whose tendons carry ``<general tendon="T"
        gear="-1"/>`` actuators (:class:`MuscleBank`). [-]
    tendons : str or sequence of str
        The muscles' tendons (text: comma-separated). [-]
    muscle : str, muscle or PlantParams, default "mpam97"
        For every tendon (:func:`muscle_plant`); a ``.toml`` path is a fitted muscle file. [-]
    reference : float or sequence, optional
        Pressure held by ``controller``, one or one per muscle (``0.5e6``, ``[0.3e6, 0.5e6]``). [Pa]
    inlet, bleed : int or sequence, optional
        Without ``reference``: valve PWM counts held over the run, one or one per muscle. [counts]
    controller : str, default "smc"
        The registry's controller for ``reference`` (``smc``, ``pid``). [-]
    duration : float, default 1.0
        Simulated time. [s]
    initial_pressure : float or sequence, default 0.0
        Each chamber's gauge pressure at the start. [Pa]
    offset : float or sequence, default 0.0
        Tendon length that is not muscle, one or one per muscle. [m]
    force_model : str, optional
        A published set's law: ``"calibrated"`` or ``"empirical"`` (:func:`muscle_plant`). [-]

    Returns
    -------
    MuscleRunResult
        Sampled every control period (1 ms).
    """
    mujoco = _mujoco()
    names = [t.strip() for t in tendons.split(",")] if isinstance(tendons, str) else list(tendons)
    duration = si(duration, "time", "duration", allow_zero=False)
    if (reference is None) == (inlet is None):
        raise InputError("reference/inlet: give either a pressure reference or valve counts, not both or neither")

    def values(x, dimension, name):
        if isinstance(x, str):
            si(x, dimension, name)  # text: refused with the number to pass
        return np.array([si(v, dimension, name) for v in np.ravel(x)])

    p0 = values(initial_pressure, "pressure", "initial_pressure")
    off = values(offset, "length", "offset")
    ctrl = controller if reference is not None else None
    bank = MuscleBank(model, names, muscle, force_model=force_model, controller=ctrl,
                      initial_pressure=p0 if p0.size > 1 else float(p0[0]), offset=off if off.size > 1 else float(off[0]))
    m = bank.model
    data = mujoco.MjData(m)
    n_periods = int(round(duration / bank.ts))
    if n_periods < 1:
        raise InputError(f"duration: {duration:g} s is shorter than one control period ({bank.ts:g} s)")
    if reference is not None:
        ref = values(reference, "pressure", "reference")
        first = {"reference": ref if ref.size > 1 else float(ref[0])}
    else:
        first = {"inlet": _count_list(inlet, "inlet"), "bleed": _count_list(bleed, "bleed")}
    mujoco.mj_forward(m, data)
    t, p, ln, f = [], [], [], []
    for k in range(n_periods):
        t.append(bank.t)
        p.append(bank.pressure)
        ln.append(bank.length(data))
        f.append(bank.tension)
        for s in range(bank.steps_per_period):
            bank.step(data, **(first if k == 0 and s == 0 else {}))
    return MuscleRunResult(np.array(t), np.array(p), np.array(ln), np.array(f), tuple(names), bank.end_stop.copy(),
                           bank.faults.copy(),
                           {"model": _model_label(model),
                            "tendons": names, "muscle": str(muscle), "duration_s": duration,
                            "controller": ctrl, "force_model": force_model or "calibrated"})


def _count_list(value, name: str) -> np.ndarray:
    """PWM counts from a number or a sequence (checked 0..255 by the bank)."""
    if isinstance(value, str):
        raise ArgumentTypeError(f"{name} = {value!r}: the library takes PWM counts as numbers, one or one per muscle, "
                                "not text")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: {value!r} is not a PWM count 0..255 (or one per muscle)") from None


def _model_label(model) -> str:
    if isinstance(model, (str, os.PathLike)) and not os.fspath(model).lstrip().startswith("<"):
        return os.fspath(model)
    return "MJCF text" if isinstance(model, str) else type(model).__name__
