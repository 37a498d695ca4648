"""Closed-loop experiments on the plant: identification, Fig. 13, PID vs sliding mode, robustness.

Every experiment runs the firmware core (:mod:`mckibben.control.core`) on the batch plant
simulator (:mod:`mckibben.plant`) through one seam, :func:`run_closed_loop`. The gains are the
ones of ``docs/control.md``, chosen on the calibrated default plant:

1. identify the plant with an open-loop step of the inlet valve (:func:`identify_plant`), as the
   paper did (§IV.A);
2. the sliding-mode model term uses that τ and G; ε and Ki are ours (:data:`SMC_TUNING`);
3. the PID is lambda-tuned on the same model (:func:`default_pid`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben.control.controllers import FirstOrderModel, design_pid, pid_params, smc_params
from mckibben.control.core import MODE_OPEN_LOOP, CoreParams, core_spec
from mckibben.control.identify import fit_step_response
from mckibben.control.metrics import step_metrics
from mckibben.errors import InputError, unknown_name

#: The paper's Fig. 13 (000_909f662a44080c85.txt, §IV.B): step to 0.55 MPa (80 psi).
PAPER_FIG13 = {
    120.0: {"time_constant_s": 0.06, "overshoot_pct": math.nan},
    150.0: {"time_constant_s": 0.01, "overshoot_pct": 7.0},
}
FIG13_TARGET_PA = 0.55e6


@dataclass(frozen=True)
class LoopRecord:
    """Sampled closed-loop record, one row per instance, one column per control period.

    Parameters
    ----------
    t : numpy.ndarray
        Time of each control period (the sample the controller saw). [s]
    pressure : numpy.ndarray
        True gauge pressure at the samples, (N, n). [Pa]
    reference : numpy.ndarray
        Pressure reference given to the controller, (N, n). [Pa]
    inlet, bleed : numpy.ndarray
        Valve commands, (N, n). [PWM counts]
    faults : numpy.ndarray
        Supervisor fault flags, (N, n). [-]
    length : numpy.ndarray
        Muscle length, (N, n). [m]
    fstate : numpy.ndarray, optional
        The controllers' float state at the end of the run, (N, ·). [-]
    """

    t: np.ndarray
    pressure: np.ndarray
    reference: np.ndarray
    inlet: np.ndarray
    bleed: np.ndarray
    faults: np.ndarray
    length: np.ndarray
    fstate: np.ndarray | None = None

    @property
    def command(self) -> np.ndarray:
        """Signed command, inlet − bleed. [PWM counts]"""
        return self.inlet.astype(float) - self.bleed.astype(float)

    def metrics(self, i: int = 0, t_step: float | None = None) -> dict:
        """:func:`~mckibben.control.metrics.step_metrics` of instance ``i``.

        Parameters
        ----------
        i : int, default 0
            Instance. [-]
        t_step : float, optional
            Time of the step. [s]
        """
        return step_metrics(self.t, self.pressure[i], self.reference[i], self.command[i], t_step=t_step)


#: The backend behind :func:`run_closed_loop`: ``f(spec, reference, duration, plant, ts)``.
_BACKEND = None


def run_closed_loop(spec, reference, duration: float, plant=None, ts: float = 1e-3) -> LoopRecord:
    """Run a controller spec on the batch plant simulator: the one seam to :mod:`mckibben.plant`.

    Parameters
    ----------
    spec : tuple
        ``(kernel, istate0, iparams, fstate0, fparams)`` with N rows. [-]
    reference : array_like
        Pressure reference per control period, shape (n,) or (N, n). [Pa]
    duration : float
        Simulated time. [s]
    plant : optional
        Plant parameters (:func:`plant_batch`); default: the calibrated default plant. [-]
    ts : float, default 1e-3
        Control period. [s]

    Returns
    -------
    LoopRecord
        The sampled record.
    """
    backend = _BACKEND if _BACKEND is not None else _plant_backend
    return backend(spec, reference, duration, plant, ts)


def _plant_backend(spec, reference, duration, plant, ts):
    from mckibben.plant import simulate

    n_inst = np.asarray(spec[1]).shape[0]
    sim = simulate(to_plant_params(plant), duration, controller=spec, reference=reference, ts=ts, n=n_inst)
    pressure = sim.pressure.copy()
    pressure[sim.flags & 1 != 0] = np.nan  # a diverged instance has no metrics, not wrong ones
    return LoopRecord(t=sim.t, pressure=pressure, reference=sim.reference, inlet=sim.inlet, bleed=sim.bleed,
                      faults=sim.faults, length=sim.length, fstate=sim.fstate)


def _steps(duration: float, ts: float = 1e-3) -> tuple[int, np.ndarray]:
    n = int(round(duration / ts))
    return n, np.arange(n) * ts


def identify_plant(plant=None, u1: int = 40, duration: float = 0.8):
    """Identify the plant's first-order model from an open-loop inlet-valve step (§IV.A).

    From rest (both valves closed, atmospheric pressure), the inlet valve steps to ``u1`` PWM
    counts at t = 0 through the core in open-loop mode (its supervisor stays active); a FOPDT
    model is fitted to the pressure. G = Δp/Δu is the secant gain of that step.

    Parameters
    ----------
    plant : optional
        Plant parameters; default the calibrated default plant. [-]
    u1 : int, default 40
        Inlet counts after the step; the default is the plant's calibration step
        (:data:`mckibben.plant.CALIBRATION_PWM`), whose time constant is the paper's 0.09 s. [PWM counts]
    duration : float, default 0.8
        Record length. [s]

    Returns
    -------
    tuple
        ``(StepFit, FirstOrderModel, LoopRecord)``: the fit, the model the controllers use and
        the record it came from.
    """
    if not 1 <= int(u1) <= 255:
        raise InputError(f"identify_plant: u1={u1!r} must be 1..255 counts")
    n, t = _steps(duration)
    spec = core_spec(CoreParams(mode=MODE_OPEN_LOOP, open_loop_inlet=int(u1)))
    rec = run_closed_loop(spec, np.zeros(n), duration, plant)
    u = np.full(n, float(u1))
    fit = fit_step_response(t, rec.pressure[0], u, t_step=0.0, input_step=float(u1))
    return fit, FirstOrderModel.from_fit(fit), rec


#: How far the measured pressure may rise above ``p_max + margin`` on the calibrated plant.
#: The supervisor shuts the inlet while the pressure extrapolated over the valve's closing time
#: (:data:`mckibben.control.core.LEAD_SAMPLES`) passes ``p_max + margin`` and vents above it; the
#: inlet valve's 3 ms lag still lets some air in. Measured with the inlet commanded wide open
#: (open-loop mode and a saturated sliding mode), p_max 0.3–0.8 MPa, supply 0.6–1.0 MPa, valves
#: and volumes ±30 %: at most 55 kPa (at p_max = 0.3 MPa, supply 1 MPa, fast valves, small
#: volume); 12 kPa at p_max = 0.8 MPa. The bound is 60 kPa (``docs/control.md``, Safety; a
#: property test in ``tests/test_control_plant.py``).
SAFETY_TRANSIENT_PA = 60e3

#: Sliding-mode design gains besides β (docs/control.md says how they were chosen).
SMC_TUNING = {"eps": 200e3, "ki": 8.0, "i_max": 1e4}


def smc_core_params(model: FirstOrderModel, beta: float, *, eps: float | None = None, ki: float | None = None,
                    base: CoreParams = CoreParams()) -> CoreParams:
    """Sliding-mode core parameters with the documented tuning (:data:`SMC_TUNING`).

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    beta : float
        Switching gain. [PWM counts]
    eps : float, optional
        Boundary layer; default from :data:`SMC_TUNING`. [Pa]
    ki : float, optional
        Surface integral weight; default from :data:`SMC_TUNING`. [1/s]
    base : CoreParams, optional
        Supervisor and other settings. [-]
    """
    return smc_params(model, beta, SMC_TUNING["eps"] if eps is None else eps,
                      SMC_TUNING["ki"] if ki is None else ki, i_max=SMC_TUNING["i_max"], base=base)


def default_pid(model: FirstOrderModel, closed_loop_tau: float | None = None):
    """The PID the paper found wanting: lambda-tuned on the identified first-order model.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    closed_loop_tau : float, optional
        λ; default τ/3 (three times faster than open loop, a usual aggressive choice). [s]
    """
    lam = model.tau / 3.0 if closed_loop_tau is None else closed_loop_tau
    return design_pid(model, lam)


def step_reference(n: int, t_step_index: int, p0: float, p1: float) -> np.ndarray:
    """A pressure step ``p0 → p1`` at sample ``t_step_index``.

    Parameters
    ----------
    n : int
        Samples. [-]
    t_step_index : int
        Sample of the step. [-]
    p0, p1 : float
        Pressure before and after. [Pa]
    """
    r = np.full(n, float(p0))
    r[t_step_index:] = float(p1)
    return r


def fig13(model: FirstOrderModel, plant=None, betas=(120.0, 150.0), *, eps: float | None = None,
          ki: float | None = None, duration: float = 1.0, t_step: float = 0.1):
    """The paper's Fig. 13 on the plant: sliding mode, step 0 → 0.55 MPa, for each β.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (the law's model term). [-]
    plant : optional
        Plant parameters; default the calibrated default plant. [-]
    betas : sequence of float
        Switching gains. [PWM counts]
    eps : float, optional
        Boundary layer (default ``SMC_TUNING``). [Pa]
    ki : float, optional
        Surface integral weight (default ``SMC_TUNING``). [1/s]
    duration : float, default 1.0
        Record length. [s]
    t_step : float, default 0.1
        Time of the step. [s]

    Returns
    -------
    tuple
        ``(rows, LoopRecord)``: one row per β, ours (step metrics) beside the paper's values.
    """
    n, t = _steps(duration)
    k = int(round(t_step / 1e-3))
    ref = step_reference(n, k, 0.0, FIG13_TARGET_PA)
    params = [smc_core_params(model, b, eps=eps, ki=ki) for b in betas]
    rec = run_closed_loop(core_spec(params), ref, duration, plant)
    rows = []
    for i, b in enumerate(betas):
        m = rec.metrics(i, t_step)
        paper = PAPER_FIG13.get(float(b), {"time_constant_s": math.nan, "overshoot_pct": math.nan})
        rows.append({"beta_counts": float(b), "eps_Pa": params[i].eps, "ki_per_s": params[i].ki,
                     "paper_time_constant_s": paper["time_constant_s"],
                     "paper_overshoot_pct": paper["overshoot_pct"], **m})
    return rows, rec


def step_size_table(model: FirstOrderModel, steps=((0.0, 0.2e6), (0.0, 0.55e6), (0.3e6, 0.7e6), (0.55e6, 0.2e6)),
                    loads=(0.0, 1.5, 3.0), beta: float = 150.0, plant_for_load=None, hold: float = 0.5,
                    duration: float = 0.6):
    """PID (lambda-tuned on the first-order model) against sliding mode over steps and loads.

    Each run holds the starting pressure (the "back pressure") for ``hold`` seconds under the
    same controller, then steps; the metrics are taken from the step on.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model both controllers are designed on. [-]
    steps : sequence of (float, float)
        (from, to) pressures. [Pa]
    loads : sequence of float
        Hanging loads. [N]
    beta : float, default 150.0
        Sliding-mode switching gain. [PWM counts]
    plant_for_load : callable, optional
        ``load -> plant parameters``; default :func:`plant_batch` with that load. [-]
    hold : float, default 0.5
        Time at the starting pressure before the step. [s]
    duration : float, default 0.6
        Time after the step. [s]

    Returns
    -------
    list of dict
        One row per (controller, step, load) with the step metrics.
    """
    plant_for_load = plant_for_load or (lambda load: plant_batch(load_N=load))
    pid = default_pid(model)
    ctrls = {"pid": pid_params(pid), "smc": smc_core_params(model, beta)}
    total = hold + duration
    n, _ = _steps(total)
    k = int(round(hold / 1e-3))
    rows = []
    for load in loads:
        refs, params, labels = [], [], []
        for p0, p1 in steps:
            for name, cp in ctrls.items():
                refs.append(step_reference(n, k, p0, p1))
                params.append(cp)
                labels.append((name, p0, p1))
        rec = run_closed_loop(core_spec(params), np.array(refs), total, plant_for_load(load))
        for i, (name, p0, p1) in enumerate(labels):
            m = rec.metrics(i, hold)
            rows.append({"controller": name, "from_Pa": p0, "to_Pa": p1, "load_N": load, **m})
    return rows


def plant_batch(**kwargs) -> dict:
    """Plant description for :func:`run_closed_loop`, checked; :func:`to_plant_params` builds it.

    Parameters
    ----------
    **kwargs
        ``load_N`` (hanging load) [N], ``supply_Pa`` (supply, gauge) [Pa], and multiplicative
        factors on the calibrated plant (1 = calibrated) [-]: ``valve_gain`` (sonic conductance
        of both valves), ``dead_band``, ``volume`` (the tube lumen at rest), ``dead_volume``,
        ``leak``. Scalars or arrays of N.

    Returns
    -------
    dict
        The keyword arguments, as float arrays.
    """
    allowed = ("load_N", "supply_Pa") + UNCERTAIN_FACTORS
    out = {}
    for key, value in kwargs.items():
        if key not in allowed:
            raise unknown_name("plant factor", key, allowed)
        a = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(a)):
            raise InputError(f"plant {key}: must be finite")
        if key == "load_N" and np.any(a < 0):
            raise InputError(f"plant load_N: {a.min():g} N, a hanging load cannot be negative")
        if key != "load_N" and np.any(a <= 0):
            raise InputError(f"plant {key}: {a.min():g}, must be positive")
        out[key] = a
    return out


def to_plant_params(plant=None):
    """:class:`~mckibben.plant.PlantParams` from a :func:`plant_batch` dict (or pass one through).

    The factors scale the calibrated default plant: ``valve_gain`` both valves' sonic
    conductance, ``dead_band`` the valves' dead band, ``volume`` the lumen (the tube's inner
    diameter by its square root, so the rest lumen volume scales by the factor), ``dead_volume``
    the tubing volume, ``leak`` the leak conductance.

    Parameters
    ----------
    plant : dict or PlantParams or None
        None: the calibrated default plant. [-]

    Returns
    -------
    PlantParams
    """
    from mckibben.plant import PlantParams

    if plant is None:
        return PlantParams()
    if isinstance(plant, PlantParams):
        return plant
    f = plant_batch(**plant)
    base = PlantParams()
    kw = {}
    if "valve_gain" in f:
        kw["valve_conductance"] = base.valve_conductance * f["valve_gain"]
        kw["bleed_conductance"] = base.bleed_conductance * f["valve_gain"]
    if "dead_band" in f:
        kw["dead_band"] = np.minimum(base.dead_band * f["dead_band"], 0.95)
    if "volume" in f:
        kw["inner_diameter"] = base.inner_diameter * np.sqrt(f["volume"])
    if "dead_volume" in f:
        kw["dead_volume"] = base.dead_volume * f["dead_volume"]
    if "leak" in f:
        kw["leak_conductance"] = base.leak_conductance * f["leak"]
    if "supply_Pa" in f:
        kw["supply_pressure"] = f["supply_Pa"]
    if "load_N" in f:
        kw["load_force"] = f["load_N"]
    kw = {k: (float(v) if np.ndim(v) == 0 else v) for k, v in kw.items()}
    return base.replace(**kw) if kw else base


#: Uncertainty of the robustness study: multiplicative ±30 % (uniform) on these plant factors.
UNCERTAIN_FACTORS = ("valve_gain", "dead_band", "volume", "dead_volume", "leak")


def sample_plants(n: int, seed: int = 0, spread: float = 0.3, supply=(0.6e6, 1.0e6), load=(0.0, 3.0)) -> dict:
    """Random plants around the calibrated one (uniform distributions).

    Parameters
    ----------
    n : int
        Number of plants. [-]
    seed : int, default 0
        Random seed. [-]
    spread : float, default 0.3
        Half-width of the multiplicative factors. [-]
    supply : tuple of float, default (0.6e6, 1.0e6)
        Supply pressure range. [Pa]
    load : tuple of float, default (0, 3)
        Hanging load range. [N]

    Returns
    -------
    dict of str to numpy.ndarray
        :func:`plant_batch` keyword arguments, arrays of n.
    """
    if int(n) < 1:
        raise InputError(f"--n: {n!r} must be at least 1")
    rng = np.random.default_rng(seed)
    out = {k: rng.uniform(1 - spread, 1 + spread, n) for k in UNCERTAIN_FACTORS}
    out["supply_Pa"] = rng.uniform(*supply, n)
    out["load_N"] = rng.uniform(*load, n)
    return out


def robustness(model: FirstOrderModel, n: int = 1000, seed: int = 0, beta: float = 150.0,
               target: float = FIG13_TARGET_PA, duration: float = 0.6, t_step: float = 0.05):
    """Monte Carlo over plant uncertainty: PID and sliding mode on the same N random plants.

    Both controllers are designed once, on the model identified on the nominal plant; each
    plant gets both (one batch of 2N instances).

    Parameters
    ----------
    model : FirstOrderModel
        Identified nominal model. [-]
    n : int, default 1000
        Number of plants. [-]
    seed : int, default 0
        Random seed. [-]
    beta : float, default 150.0
        Sliding-mode switching gain. [PWM counts]
    target : float, default 0.55e6
        Step target. [Pa]
    duration : float, default 0.6
        Record length. [s]
    t_step : float, default 0.05
        Time of the step. [s]

    Returns
    -------
    dict
        ``samples`` (the plant factors), ``metrics`` {controller: {metric: array}}, ``summary``
        {controller: {metric: (median, p5, p95)}}.
    """
    samples = sample_plants(n, seed)
    both = {k: np.concatenate([v, v]) for k, v in samples.items()}
    params = [pid_params(default_pid(model))] * n + [smc_core_params(model, beta)] * n
    nn, _ = _steps(duration)
    ref = step_reference(nn, int(round(t_step / 1e-3)), 0.0, target)
    rec = run_closed_loop(core_spec(params), ref, duration, plant_batch(**both))
    keys = ("time_constant_s", "overshoot_pct", "steady_state_error_Pa", "settling_time_s", "valve_effort_counts")
    metrics, summary = {}, {}
    for j, name in enumerate(("pid", "smc")):
        ms = [rec.metrics(j * n + i, t_step) for i in range(n)]
        metrics[name] = {k: np.array([m[k] for m in ms]) for k in keys}
        summary[name] = {k: _pct(metrics[name][k]) for k in keys}
    return {"samples": samples, "metrics": metrics, "summary": summary}


def _pct(x: np.ndarray) -> dict:
    ok = x[np.isfinite(x)]
    if ok.size == 0:
        return {"median": math.nan, "p5": math.nan, "p95": math.nan, "n_undefined": int(x.size)}
    p5, med, p95 = np.percentile(ok, [5, 50, 95])
    return {"median": float(med), "p5": float(p5), "p95": float(p95), "n_undefined": int(x.size - ok.size)}
