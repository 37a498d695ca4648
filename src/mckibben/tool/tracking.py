"""Tip tracking: a path → pressure references (IK + static inverse) → three controlled muscles.

The reference half (this module's :func:`tip_reference`) needs only the tool: each sample of the
path goes through the inverse kinematics, the load model and each muscle's inverse static model,
giving three pressure references. The simulation half runs three plant instances, one per
muscle, each with its own pressure controller, on those references (:func:`simulate_tracking`),
and takes the pressures the plant achieves back through the tool's forward static equilibrium
to the achieved tip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.control import registry as R
from mckibben.errors import UnreachableError
from mckibben.results import TimeResponse
from mckibben.tool.geometry import Tool
from mckibben.tool.paths import TipPath
from mckibben.tool.statics import ToolState, explain_unreachable, pressures_for_tip, tip_from_pressures
from mckibben.tool.kinematics import Arc
from mckibben.control.runs import identify_plant
from mckibben.models.law_statics import LawMuscle
from mckibben.plant import PlantParams
from mckibben.control.runs import smc_core_params
from mckibben.control.experiment_setup import identify_file_plant
from mckibben.control.core import core_spec
from mckibben.plant import simulate


def straight_height(tool: Tool, fraction: float = 0.5) -> float:
    """Height of the straight tool's tip with ``fraction·p_max`` in all three muscles.

    Parameters
    ----------
    tool : Tool
        The tool.
    fraction : float, default 0.5
        Fraction of p_max. [-]

    Returns
    -------
    float
        Tip height z (= arc length, the tool is straight). [m]
    """
    p = fraction * tool.p_max
    return float(tip_from_pressures(np.array([p, p, p]), tool).tip[2])


def resolve_path(path: TipPath, tool: Tool) -> TipPath:
    """The path with its plane height set (default :func:`straight_height` at p_max/2).

    Parameters
    ----------
    path : TipPath
        The parsed path.
    tool : Tool
        The tool it is for.
    """
    return path if path.z is not None else path.with_z(straight_height(tool))


@dataclass(frozen=True)
class TipReference:
    """Target tip positions along a path and the pressures that hold them (static inverse).

    Attributes
    ----------
    time : numpy.ndarray
        Sample times. [s]
    target : numpy.ndarray
        Target tip positions, shape (n, 3). [m]
    state : ToolState
        Lengths, tensions, pressures (shape (n, 3)) and flags at every sample.
    """

    time: np.ndarray
    target: np.ndarray
    state: ToolState

    @property
    def pressures(self) -> np.ndarray:
        """Pressure references of muscles 1, 2, 3, shape (n, 3). [Pa]"""
        return self.state.pressures


def tip_reference(tool: Tool, path: TipPath, ts: float = 1e-3) -> TipReference:
    """Pressure references for a tip path, sampled every ``ts``.

    Parameters
    ----------
    tool : Tool
        The tool.
    path : TipPath
        The path (its ``z`` resolved with :func:`resolve_path` if unset).
    ts : float, default 1e-3
        Sample period (the controllers' period). [s]

    Returns
    -------
    TipReference
        Times, targets and the static inverse at each sample.

    Raises
    ------
    UnreachableError
        When any point of the path is unreachable: names the first such time, the target and the
        limiting muscle(s).
    """
    path = resolve_path(path, tool)
    n = int(round(path.duration / ts))
    t = np.arange(n) * ts
    target = path.position(t)
    per_loop = path.period / ts
    if abs(per_loop - round(per_loop)) < 1e-9 * per_loop and round(per_loop) < n:
        # the path repeats every round(per_loop) samples: solve one loop and tile it (same numbers)
        m = int(round(per_loop))
        one = pressures_for_tip(target[:m], tool)
        state = _tile_state(one, -(-n // m), n)
    else:
        state = pressures_for_tip(target, tool)
    bad = np.flatnonzero(~state.reachable)
    if bad.size:
        i = int(bad[0])
        x, y, z = target[i] * 1e3
        raise UnreachableError(
            f"path: the tip target ({x:.2f}, {y:.2f}, {z:.2f}) mm at t = {t[i]:.3f} s is unreachable:"
            f" {explain_unreachable(state, tool, i)}"
        )
    return TipReference(t, target, state)


def _tile_state(state: ToolState, reps: int, n: int) -> ToolState:
    """Repeat a ToolState along its first axis ``reps`` times and keep ``n`` samples."""

    def tile(a):
        a = np.asarray(a)
        return np.concatenate([a] * reps, axis=0)[:n]

    arc = Arc(tile(state.arc.arc_length), tile(state.arc.theta_x), tile(state.arc.theta_y))
    return ToolState(arc, tile(state.tip), tile(state.rotation), tile(state.lengths), tile(state.tensions),
                     tile(state.pressures), tile(state.flags), tile(state.converged))


def tip_errors(target, achieved) -> dict:
    """RMS and maximum distance between target and achieved tip positions.

    Parameters
    ----------
    target : array_like
        Target tips, shape (n, 3). [m]
    achieved : array_like
        Achieved tips, shape (n, 3). [m]

    Returns
    -------
    dict
        ``rms_error_m`` and ``max_error_m``.
    """
    d = np.linalg.norm(np.asarray(achieved, float) - np.asarray(target, float), axis=-1)
    return {"rms_error_m": float(np.sqrt(np.mean(d * d))), "max_error_m": float(d.max())}


@dataclass(frozen=True)
class TrackingResult(TimeResponse):
    """One simulated tracking run: three muscles, target vs achieved tip.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times, (n,). [s]
    target : numpy.ndarray
        Target tip, (n, 3). [m]
    achieved : numpy.ndarray
        Achieved tip: the tool's static equilibrium at the simulated chamber pressures, (n, 3). [m]
    reference : numpy.ndarray
        Pressure references, (n, 3). [Pa]
    pressure : numpy.ndarray
        Simulated chamber pressures, (n, 3). [Pa]
    loads : numpy.ndarray
        Hanging load each plant instance carried (the muscle's mean tension on the path), (3,). [N]
    beta : float
        Sliding-mode switching gain of the three controllers. [PWM counts]
    model_gain, model_tau : float
        Identified first-order model the controllers use. [Pa/count], [s]
    faults : int
        OR of every controller fault flag over the run (0: none). [-]
    """

    time: np.ndarray
    target: np.ndarray
    achieved: np.ndarray
    reference: np.ndarray
    pressure: np.ndarray
    loads: np.ndarray
    beta: float
    model_gain: float
    model_tau: float
    faults: int

    TIME = "time"
    SIGNALS = ("target", "achieved", "reference", "pressure")
    CHANNELS = True

    def summary(self) -> dict:
        """Errors and settings as a JSON-ready dict (SI, unit-suffixed keys)."""
        err = tip_errors(self.target, self.achieved)
        p_err = self.pressure - self.reference
        return {
            **err,
            "pressure_rms_error_Pa": float(np.sqrt(np.mean(p_err**2))),
            "pressure_max_error_Pa": float(np.max(np.abs(p_err))),
            "plant_loads_N": self.loads.tolist(),
            "beta_counts": self.beta,
            "model_gain_Pa_per_count": self.model_gain,
            "model_tau_s": self.model_tau,
            "controller_faults": self.faults,
        }


#: Switching gain of the tracking controllers (law ``model``): the step design's
#: (:data:`mckibben.control.controllers.SMC_TUNING`); with the model term carrying the holding
#: command (valve lift-off included) the switching term only covers the model's error.
TRACKING_BETA = R.SMC.designs["model"]["beta"]
#: Boundary layer [Pa] and surface integral weight [1/s] of the tracking controllers: narrower
#: than the step tuning of :data:`mckibben.control.controllers.SMC_TUNING` (100 kPa, 5 1/s),
#: which trades holding accuracy for a clean step; tracking a moving reference wants the
#: pressure held to ~1 kPa. Narrower still chatters: β/ε is the loop's gain near the surface
#: (20 kPa: 2.6 kPa RMS pressure error on a 2 Hz circle, 0.9 mm of tip error; 50 kPa: 0.9 kPa,
#: 0.2 mm).
TRACKING_SMC = {"eps": 50e3, "ki": 5.0}


def identify_muscle_plant(plant_params, pwm: int | None = None):
    """The first-order model of one muscle's plant, with the valves' lift-off, from two open-loop
    inlet steps (§IV.A; :func:`mckibben.control.identify.identify_plant`).

    Parameters
    ----------
    plant_params : PlantParams
        One plant instance. [-]
    pwm : int, optional
        Inlet PWM count of the first step; default the plant's calibration step. [counts]

    Returns
    -------
    FirstOrderModel
        Gain [Pa/count], time constant [s], dead time [s] and lift-off [counts].
    """

    return identify_plant(plant_params, u1=pwm)[1]


def muscle_plants(tool: Tool, load_force):
    """The plant of the tool's muscle hanging loads: one instance per load.

    A miniature muscle runs the plant's calibrated law (:meth:`PlantParams.for_muscle`); a muscle
    file's runs its own fitted law on a rig sized for it (:meth:`PlantParams.from_muscle_file`,
    the same branch as the tool's statics).

    Parameters
    ----------
    tool : Tool
        The tool. [-]
    load_force : float or array_like
        Hanging load of each instance. [N]

    Returns
    -------
    PlantParams
    """

    m = tool.muscle
    if isinstance(m, LawMuscle):
        return PlantParams.from_muscle_file(m.source, m.direction, load_force=load_force)
    return PlantParams.for_muscle(m, load_force=load_force)


def tracking_setup(tool: Tool, ref: TipReference, beta: float = TRACKING_BETA, cache: dict | None = None):
    """The three muscles' plants, their controllers' parameters and model for one run.

    Each muscle's plant is the tool's muscle (:func:`muscle_plants`) hanging that
    muscle's mean tension along the path; the controllers' model is identified on the plant with
    the mean of the three loads (one open-loop step; a muscle file's plant over
    :data:`mckibben.control.experiment_setup.FILE_IDENTIFICATION_S`, as ``control step --muscle-file``),
    the same for the three channels, and their supervisor takes it too.

    Parameters
    ----------
    tool : Tool
        The tool.
    ref : TipReference
        The run's references.
    beta : float, default TRACKING_BETA
        Switching gain. [PWM counts]
    cache : dict, optional
        Identified models by loads, reused across calls. [-]

    Returns
    -------
    tuple
        ``(plants, params, model, loads)``: a :class:`PlantParams` of three instances, the
        :class:`CoreParams` of the three controllers, the :class:`FirstOrderModel`, the loads [N].
    """

    cache = {} if cache is None else cache
    loads = ref.state.tensions.mean(axis=0)
    plants = muscle_plants(tool, loads)
    key = tuple(np.round(loads, 12))
    if key not in cache:
        one = muscle_plants(tool, float(loads.mean()))
        if isinstance(tool.muscle, LawMuscle):  # a large muscle settles in seconds: the control commands' record

            cache[key] = identify_file_plant(one)
        else:
            cache[key] = identify_muscle_plant(one)
    model = cache[key]
    params = smc_core_params(model, beta, **TRACKING_SMC)
    params = type(params)(**{**params.__dict__, "p_max": tool.p_max})
    return plants, params, model, loads


def simulate_tracking(tool: Tool, runs, *, beta: float = TRACKING_BETA) -> list[TrackingResult]:
    """Follow each run's pressure references with three plant instances and their controllers.

    Each muscle is one instance of the batch plant (:func:`mckibben.plant.simulate`) with the
    tool's muscle (:func:`muscle_plants`: the plant's calibrated force law, or a muscle file's own), hanging the
    muscle's mean tension along the path, and its own
    sliding-mode pressure controller (the firmware core, :func:`mckibben.control.core.core_spec`)
    whose model term is identified on that plant by an open-loop step. The run starts at the
    path's first reference pressures. The achieved tip is the tool's static equilibrium at the
    simulated chamber pressures (quasi-static tool mechanics).

    Parameters
    ----------
    tool : Tool
        The tool.
    runs : list of (TipPath, TipReference)
        Paths and their references (:func:`tip_reference`).
    beta : float, default 50
        Switching gain of the three controllers. [PWM counts]

    Returns
    -------
    list of TrackingResult
        One per run.
    """

    results = []
    models = {}
    for path, ref in runs:
        plants, params, model, loads = tracking_setup(tool, ref, beta, models)
        sim = simulate(plants, ref.time.size * 1e-3, controller=core_spec(params, 3), reference=ref.pressures.T,
                       initial_pressure=ref.pressures[0])
        pressure = sim.pressure.T
        achieved = tip_from_pressures(np.clip(pressure, 0.0, tool.p_max), tool).tip
        results.append(TrackingResult(ref.time, ref.target, achieved, ref.pressures, pressure, loads, float(beta),
                                      float(model.gain), float(model.tau), int(np.bitwise_or.reduce(sim.faults.ravel()))))
    return results


def plot_tracking(runs, results, tool: Tool, ax=None):
    """Figure: target vs achieved tip path (top view) per speed, tip error over time, error vs speed.

    Parameters
    ----------
    runs : list of (TipPath, TipReference)
        The runs.
    results : list of TrackingResult
        Their simulations.
    tool : Tool
        The tool (for the title).
    ax : sequence of three matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    k = len(results)
    if ax is None:
        fig, axes = plt.subplots(1, 3, figsize=(15, 5))
    else:
        axes = list(ax)
        fig = axes[0].figure
    ax = axes[0]
    colors = plt.cm.viridis(np.linspace(0, 0.85, k))
    for (p, _), r, c in zip(runs, results, colors):
        ax.plot(r.achieved[:, 0] * 1e3, r.achieved[:, 1] * 1e3, color=c, lw=1.2,
                label=f"T = {p.period:g} s ({p.mean_speed * 1e3:.0f} mm/s)")
    ax.plot(results[0].target[:, 0] * 1e3, results[0].target[:, 1] * 1e3, "r--", lw=1.5, label="target", zorder=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("tip path, top view: target vs achieved")
    ax.legend(fontsize=8)
    ax = axes[1]
    for (p, _), r, c in zip(runs, results, colors):
        err = np.linalg.norm(r.achieved - r.target, axis=1)
        ax.plot(r.time / p.period, err * 1e3, color=c, lw=1, label=f"T = {p.period:g} s")
    ax.set_xlabel("time / period [-]")
    ax.set_ylabel("tip error [mm]")
    ax.set_title("tip error over the run")
    ax.legend(fontsize=8)
    ax = axes[2]
    speeds = np.array([p.mean_speed for p, _ in runs]) * 1e3
    rms = np.array([r.summary()["rms_error_m"] for r in results]) * 1e3
    mx = np.array([r.summary()["max_error_m"] for r in results]) * 1e3
    order = np.argsort(speeds)
    ax.plot(speeds[order], rms[order], "o-", label="RMS")
    ax.plot(speeds[order], mx[order], "s-", label="max")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("mean tip speed [mm/s]")
    ax.set_ylabel("tip error [mm]")
    ax.set_title("tip error vs speed")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    p0 = runs[0][0]
    fig.suptitle(f"Tracking a {p0.kind} ({p0.size * 1e3:g} mm, z = {p0.z * 1e3:.1f} mm) with three simulated"
                 f" {tool.muscle.name} muscles, sliding mode β = {results[0].beta:g}", fontsize=10)
    if ax is None:
        fig.tight_layout()
    return fig
