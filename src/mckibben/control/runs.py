"""Closed-loop runs on the plant, the building blocks of the experiments: identification, tuning,
the runs of Fig. 13, PID vs sliding mode and robustness.

The experiments themselves (one public call each, returning a result) are
:mod:`mckibben.experiments`; this module gives them their runs. Every run goes through the
firmware core (:mod:`mckibben.control.core`) on the batch plant simulator (:mod:`mckibben.plant`)
through one seam, :func:`run_closed_loop`. The gains are the
ones of ``docs/control.md``, chosen on the calibrated default plant:

1. identify the plant with two open-loop steps of the inlet valve (:func:`identify_plant`): τ and
   θ as the paper did (§IV.A), and the valves' lift-off u0 with the gain above it;
2. two sliding-mode laws (:data:`SMC_LAWS`): ``model`` (ours; its model term uses τ, G and u0;
   :data:`SMC_TUNING`) and ``paper`` (β·tanh(S/ε) alone, as the paper ran it;
   :data:`PAPER_SMC_TUNING`);
3. the PID is lambda-tuned on the paper's line through the origin at 0.55 MPa (:func:`default_pid`).
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mckibben.control.first_order import FirstOrderModel
from mckibben.control.laws import smc, with_supervisor_model
from mckibben.control.laws.pid import default_pid  # noqa: F401  (re-exported: the PID the paper found wanting)
from mckibben.control import registry as R
from mckibben.control.core import MODE_OPEN_LOOP, CoreParams, core_spec
from mckibben.fit.step import fit_lift_off, fit_step_response
from mckibben.control.metrics import step_metrics, step_metrics_batch
from mckibben.datasets.paper_points import FIG13 as _FIG13
from mckibben.errors import InputError, check_real, unknown_name
from mckibben.limits import check_budget
from mckibben.plant import simulate
from mckibben.plant import CALIBRATION_PWM
from mckibben.control.metrics import tracking_metrics_batch
from mckibben.plant import PlantParams

#: The paper's Fig. 13 (:data:`mckibben.datasets.paper_points.FIG13`): β -> time constant, overshoot.
PAPER_FIG13 = _FIG13["points"]
#: Fig. 13's step target, 0.55 MPa (80 psi). [Pa]
FIG13_TARGET_PA = _FIG13["target_Pa"]


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

    @cached_property
    def command(self) -> np.ndarray:
        """Signed command, inlet − bleed, computed once (metrics index it per instance); read-only. [PWM counts]"""
        u = self.inlet.astype(float) - self.bleed.astype(float)
        u.flags.writeable = False
        return u

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

    def target_unreachable(self, i: int = 0, window: float = 0.1) -> bool:
        """Whether instance ``i`` ends settled below its reference with the inlet driving up.

        The supply (or the valve at full command) is then the limit: the chamber is where it can
        be, which is not a fault (the supervisor's response rule agrees, ``docs/controller.md``).

        Parameters
        ----------
        i : int, default 0
            Instance. [-]
        window : float, default 0.1
            The final stretch examined. [s]
        """
        k = max(int(round(window / (self.t[1] - self.t[0]))), 2) if self.t.size > 1 else 1
        p, r = self.pressure[i, -k:], self.reference[i, -k:]
        if not (np.all(np.isfinite(p)) and r.size):
            return False
        short = float(np.mean(r - p))
        settled = float(np.ptp(p)) < max(5e3, 0.01 * float(np.mean(r)))
        return bool(short > max(10e3, 0.02 * float(np.mean(r))) and settled and np.mean(self.inlet[i, -k:]) > 0)


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

    n_inst = np.asarray(spec[1]).shape[0]
    # the documented limits are the command line's (--force); here only what cannot fit at all
    check_budget("duration", n_inst * max(float(duration) / ts, 0.0), force=True)
    backend = _BACKEND if _BACKEND is not None else _plant_backend
    return backend(spec, reference, duration, plant, ts)


def _plant_backend(spec, reference, duration, plant, ts):

    n_inst = np.asarray(spec[1]).shape[0]
    sim = simulate(to_plant_params(plant), duration, controller=spec, reference=reference, ts=ts, n=n_inst)
    pressure = sim.pressure.copy()
    pressure[sim.flags & 1 != 0] = np.nan  # a diverged instance has no metrics, not wrong ones
    return LoopRecord(t=sim.t, pressure=pressure, reference=sim.reference, inlet=sim.inlet, bleed=sim.bleed,
                      faults=sim.faults, length=sim.length, fstate=sim.fstate)


def _steps(duration: float, ts: float = 1e-3) -> tuple[int, np.ndarray]:
    n = int(round(duration / ts))
    return n, np.arange(n) * ts


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
    n, t = _steps(duration)
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


#: How far the measured pressure may rise above ``p_max + margin`` on the calibrated plant.
#: The supervisor shuts the inlet while the pressure extrapolated over the valve's closing time
#: (:data:`mckibben.control.core.LEAD_SAMPLES`) passes ``p_max + margin`` and vents above it; the
#: inlet valve's 3 ms lag still lets some air in. Measured with the inlet commanded wide open
#: (open-loop mode and both sliding-mode laws at β = 255), p_max 0.3–0.8 MPa, supply 0.6–1.0 MPa,
#: valves and volumes ±30 %: at most 79 kPa (at p_max = 0.3 MPa, supply 1 MPa, valves 1.3×,
#: small dead volume); 47 kPa at p_max = 0.5 MPa, 15 kPa at 0.8 MPa. The bound is 90 kPa
#: (``docs/control.md``, Safety; a property test in ``tests/test_control_plant.py``).
SAFETY_TRANSIENT_PA = 90e3

#: The sliding-mode variants (:data:`mckibben.control.laws.smc.VARIANTS`): ``model`` is ours,
#: ``paper`` the law as the paper ran it.
SMC_LAWS = smc.VARIANTS

#: Our sliding-mode design (law ``model``; ``docs/control.md`` says how it was chosen): with the
#: model term carrying the holding command, a small switching gain suffices (the registry's
#: design ``model`` of ``smc``).
SMC_TUNING = dict(smc.DESIGNS["model"])
#: The paper's law (``paper``): β is the paper's (120 or 150; 150 by default, the registry's
#: design ``paper``); ε and Ki are ours, chosen so that the integral brings the β = 120 step to
#: its target within Fig. 13's second.
PAPER_SMC_TUNING = {k: v for k, v in smc.DESIGNS["paper"].items() if k != "beta"}


def smc_core_params(model: FirstOrderModel, beta: float | None = None, *, law: str = "model",
                    eps: float | None = None, ki: float | None = None,
                    base: CoreParams = CoreParams()) -> CoreParams:
    """Sliding-mode core parameters of one variant with its documented design, base defaulted.

    :func:`mckibben.control.laws.smc.variant_params` with the core's defaults as ``base``.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (used by the ``model`` law only). [-]
    beta : float, optional
        Switching gain; default the law's documented design. [PWM counts]
    law : {"model", "paper"}, default "model"
        Sliding-mode variant (:data:`SMC_LAWS`). [-]
    eps : float, optional
        Boundary layer; default from the law's tuning. [Pa]
    ki : float, optional
        Surface integral weight; default from the law's tuning. [1/s]
    base : CoreParams, optional
        Supervisor and other settings. [-]

    Returns
    -------
    CoreParams
        With ``mode = MODE_SMC``; ``g = 0`` for the ``paper`` law.
    """
    return smc.variant_params(model, beta, law=law, eps=eps, ki=ki, base=base)


#: Design steps of a plant tuned by :func:`tune_gains`, as fractions of its top pressure
#: min(supply, p_max): three rises from rest and one fall from a held back pressure.
TUNING_STEPS = ((0.0, 0.25), (0.0, 0.5), (0.0, 0.75), (0.75, 0.25))
#: What a tuned design must meet on every design step: overshoot [%], steady-state error
#: [fraction of the step] and settling (±2 %) within the record.
TUNING_BAR = {"overshoot_pct": 10.0, "steady_state_error": 0.02}
#: The candidate gains :func:`tune_gains` tries (a value given by the caller replaces its list):
#: sliding mode, law ``model`` (β [counts], ε [Pa], Ki [1/s] and the model term's τ as fractions
#: of the identified one); law ``paper`` (no model term); the PID's design τ (fractions of the
#: identified one) and λ (multiples of that τ). The design τ goes down to the fast phase of a
#: muscle file's plant (the chamber at the braid's straight stop fills in milliseconds), which a
#: first-order fit of the whole step puts at the slow phase (tenths of a second).
TUNING_CANDIDATES = {name: dict(grid) for c in R.CONTROLLERS.values() for name, grid in c.grid.items()}


@dataclass(frozen=True)
class GainTuning:
    """Gains chosen for one plant by :func:`tune_gains`, with what they did on the design steps.

    Attributes
    ----------
    controller : str
        ``"smc"`` or ``"pid"``. [-]
    law : str or None
        The sliding-mode law (None for the PID). [-]
    gains : dict
        The chosen free gains: ``beta_counts``, ``eps_Pa``, ``ki_per_s`` or ``lambda_s``. [SI]
    params : CoreParams
        The core's parameters with those gains. [-]
    steps : list of dict
        Per design step: ``from_Pa``, ``to_Pa`` and the step metrics of the chosen gains. [SI]
    met : bool
        Whether the chosen gains meet :data:`TUNING_BAR` on every design step. [-]
    candidates : int
        Number of candidate gain sets simulated. [-]
    """

    controller: str
    law: str | None
    gains: dict
    params: CoreParams
    steps: list
    met: bool
    candidates: int

    def to_dict(self) -> dict:
        """The tuning as JSON-ready numbers (the design steps' or sines' main metrics)."""
        if self.steps and "reference" in self.steps[0]:
            return {"method": "simulated design sines on the plant", "objective": "track",
                    "candidates": self.candidates, **self.gains, "references": self.steps}
        keys = ("overshoot_pct", "settling_time_s", "steady_state_error_Pa")
        return {"method": "simulated design steps on the plant", "objective": "step", "bar_met": self.met,
                "candidates": self.candidates, **self.gains, "overshoot_max_pct": TUNING_BAR["overshoot_pct"],
                "steps": [{"from_Pa": s["from_Pa"], "to_Pa": s["to_Pa"], **{k: s[k] for k in keys}} for s in self.steps]}


def tune_gains(plant, model: FirstOrderModel, controller: str = "smc", *, law: str = "model",
               base: CoreParams = CoreParams(), beta: float | None = None, eps: float | None = None,
               ki: float | None = None, lam: float | None = None, hold: float = 0.3,
               duration: float = 1.0, objective: str = "step") -> GainTuning:
    """Choose a controller's free gains for one plant: the fastest that meets :data:`TUNING_BAR`.

    With ``objective="track"`` the candidates follow the design sines :data:`TUNING_SINES`
    instead, and the smallest worst RMS error (after :data:`TUNING_SETTLE_S`) wins: gains that
    step without overshoot (a small model term, whose τ·ṗ_ref kick a step makes an impulse) follow
    a sine late, and gains that follow a sine kick a step.

    The model term (sliding mode, law ``model``) and the PID's line through the origin still come
    from the identified ``model``; what a first-order model cannot set on a plant whose dynamics
    change along a step (a muscle file's plant: the chamber at the braid's straight stop fills in
    milliseconds, then grows severalfold as the muscle contracts) is chosen by simulation: every
    candidate of :data:`TUNING_CANDIDATES` runs the design steps :data:`TUNING_STEPS` on the plant
    in one batch, and the candidate with the shortest worst settling time among those meeting the
    bar on every step wins; if none does, the one nearest to it (fewest steps missing it, then
    the smallest sum of the ratios of each metric to its bar beyond 1), with ``met`` False.

    Parameters
    ----------
    plant : PlantParams or dict
        The plant (one rig; :func:`run_closed_loop`). [-]
    model : FirstOrderModel
        The model identified on it (:func:`identify_plant`). [-]
    controller : {"smc", "pid"}, default "smc"
        The controller. [-]
    law : {"model", "paper"}, default "model"
        Sliding-mode law. [-]
    base : CoreParams, optional
        Supervisor settings (p_max, the supervisor's valve model). [-]
    beta, eps, ki : float, optional
        Sliding-mode gains to hold fixed instead of tuning. [PWM counts, Pa, 1/s]
    lam : float, optional
        PID closed-loop time constant to hold fixed. [s]
    hold : float, default 0.3
        Time at the back pressure before a step. [s]
    duration : float, default 1.0
        Time after the step; a step settles within it. [s]
    objective : {"step", "track"}, default "step"
        Design steps against the bar, or design sines by RMS error. [-]

    Returns
    -------
    GainTuning
    """
    spec = R.get(controller)
    if law not in SMC_LAWS:
        raise unknown_name("sliding-mode law", law, SMC_LAWS)
    law_of = law if spec.variants else None
    top = min(float(to_plant_params(plant).supply_pressure), float(base.p_max))
    grid = TUNING_CANDIDATES[law if spec.variants else next(iter(spec.grid))]
    cands, params = spec.candidates(model, base, top, grid, law=law, beta=beta, eps=eps, ki=ki, lam=lam)
    if objective == "track":
        return _tune_tracking(plant, controller, law_of, cands, params, top)
    if objective != "step":
        raise unknown_name("tuning objective", objective, ("step", "track"))
    total = hold + duration
    n, _ = _steps(total)
    k = int(round(hold / 1e-3))
    steps = [(a * top, b * top) for a, b in TUNING_STEPS]
    refs = np.array([step_reference(n, k, p0, p1) for _ in params for p0, p1 in steps])
    rec = run_closed_loop(core_spec([p for p in params for _ in steps]), refs, total, plant)
    every = step_metrics_batch(rec.t, rec.pressure, rec.reference, rec.command, t_step=hold)
    best, best_key = 0, None
    table = []
    for i in range(len(params)):
        rows = [{"from_Pa": p0, "to_Pa": p1, **{k: float(v[i * len(steps) + j]) for k, v in every.items()}}
                for j, (p0, p1) in enumerate(steps)]
        table.append(rows)
        short = [_shortfall(r, duration) for r in rows]
        settle = max(r["settling_time_s"] if math.isfinite(r["settling_time_s"]) else duration for r in rows)
        key = (sum(x > 1.0 for x in short), sum(max(x - 1.0, 0.0) for x in short), settle)
        if best_key is None or key < best_key:
            best, best_key = i, key
    return GainTuning(controller, law_of, cands[best], params[best], table[best], best_key[0] == 0, len(params))


#: Design references of a tuning for tracking: sines about ½ of the top pressure, ¼ of it in
#: amplitude, at 0.5 and 2 Hz (fractions of the top, fractions of the top, Hz).
TUNING_SINES = ((0.5, 0.25, 0.5), (0.5, 0.25, 2.0))
#: Length of a design sine, and the start left out of its score (the rise to the sine). [s]
TUNING_SINE_S, TUNING_SETTLE_S = 2.5, 0.5


def _tune_tracking(plant, controller, law, cands, params, top) -> GainTuning:
    """The candidate with the smallest worst RMS error on :data:`TUNING_SINES` (after the rise)."""

    n, t = _steps(TUNING_SINE_S)
    refs = [m * top + a * top * np.sin(2 * np.pi * f * t) for m, a, f in TUNING_SINES]
    rec = run_closed_loop(core_spec([p for p in params for _ in refs]), np.array([r for _ in params for r in refs]),
                          TUNING_SINE_S, plant)
    k = int(round(TUNING_SETTLE_S / 1e-3))
    every = tracking_metrics_batch(rec.t[k:], rec.pressure[:, k:], rec.reference[:, k:], rec.command[:, k:])
    rms = np.nan_to_num(every["rms_error_Pa"].reshape(len(params), len(refs)), nan=np.inf)
    best = int(np.argmin(rms.max(axis=1)))
    rows = [{"reference": f"sine:{m * top / 1e6:.4g}MPa,{a * top / 1e6:.4g}MPa,{f:g}Hz",
             "rms_error_Pa": float(every["rms_error_Pa"][best * len(refs) + j]),
             "max_abs_error_Pa": float(every["max_abs_error_Pa"][best * len(refs) + j])}
            for j, (m, a, f) in enumerate(TUNING_SINES)]
    return GainTuning(controller, law, cands[best], params[best], rows, True, len(params))


def _shortfall(m: dict, duration: float) -> float:
    """How far one design step is from :data:`TUNING_BAR`: the largest ratio of a metric to its bar
    (overshoot, steady-state error per step size, settling time per record; 2 if it never settles)."""
    over = m["overshoot_pct"] / TUNING_BAR["overshoot_pct"] if math.isfinite(m["overshoot_pct"]) else 2.0
    err = abs(m["steady_state_error_Pa"]) / abs(m["to_Pa"] - m["from_Pa"]) / TUNING_BAR["steady_state_error"]
    settle = m["settling_time_s"] / duration if math.isfinite(m["settling_time_s"]) else 2.0
    return max(over, err if math.isfinite(err) else 2.0, settle)


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


def fig13_runs(model: FirstOrderModel, plant=None, betas=(120.0, 150.0), *, laws=SMC_LAWS, eps: float | None = None,
          ki: float | None = None, duration: float = 1.0, t_step: float = 0.1):
    """The paper's Fig. 13 on the plant: sliding mode, step 0 → 0.55 MPa, for each law and β.

    The ``paper`` law is what the paper measured; the ``model`` law at the same β shows what the
    model term changes.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (the ``model`` law's model term). [-]
    plant : optional
        Plant parameters; default the calibrated default plant. [-]
    betas : sequence of float
        Switching gains. [PWM counts]
    laws : sequence of str, default ("model", "paper")
        Sliding-mode laws (:data:`SMC_LAWS`). [-]
    eps : float, optional
        Boundary layer (default: each law's tuning). [Pa]
    ki : float, optional
        Surface integral weight (default: each law's tuning). [1/s]
    duration : float, default 1.0
        Record length. [s]
    t_step : float, default 0.1
        Time of the step. [s]

    Returns
    -------
    tuple
        ``(rows, LoopRecord)``: one row per (law, β), ours (step metrics) beside the paper's
        values, in the order ``laws`` × ``betas``.
    """
    n, t = _steps(duration)
    k = int(round(t_step / 1e-3))
    ref = step_reference(n, k, 0.0, FIG13_TARGET_PA)
    cases = [(law, float(b)) for law in laws for b in betas]
    params = [smc_core_params(model, b, law=law, eps=eps, ki=ki) for law, b in cases]
    rec = run_closed_loop(core_spec(params), ref, duration, plant)
    rows = []
    for i, (law, b) in enumerate(cases):
        m = rec.metrics(i, t_step)
        paper = PAPER_FIG13.get(b, {"time_constant_s": math.nan, "overshoot_pct": math.nan})
        rows.append({"law": law, "beta_counts": b, "eps_Pa": params[i].eps, "ki_per_s": params[i].ki,
                     "paper_time_constant_s": paper["time_constant_s"],
                     "paper_overshoot_pct": paper["overshoot_pct"], **m})
    return rows, rec


def step_size_table(model: FirstOrderModel | None, steps=((0.0, 0.2e6), (0.0, 0.55e6), (0.3e6, 0.7e6), (0.55e6, 0.2e6)),
                    loads=(0.0, 1.5, 3.0), beta: float | None = None, plant_for_load=None, hold: float = 0.5,
                    duration: float = 0.6, controllers_for_load=None):
    """PID (lambda-tuned on the first-order model) against both sliding-mode laws over steps and loads.

    Each run holds the starting pressure (the "back pressure") for ``hold`` seconds under the
    same controller, then steps; the metrics are taken from the step on. Controllers: ``pid``,
    ``smc`` (law ``model``, :data:`SMC_TUNING`), ``smc_paper`` (law ``paper``, β = 150) and each
    extension law of the registry (:func:`comparison_controllers`).

    Parameters
    ----------
    model : FirstOrderModel or None
        Identified model the controllers are designed on (None with ``controllers_for_load``). [-]
    steps : sequence of (float, float)
        (from, to) pressures. [Pa]
    loads : sequence of float
        Hanging loads. [N]
    beta : float, optional
        Switching gain of the ``smc`` law (default :data:`SMC_TUNING`). [PWM counts]
    plant_for_load : callable, optional
        ``load -> plant parameters``; default :func:`plant_batch` with that load. [-]
    hold : float, default 0.5
        Time at the starting pressure before the step. [s]
    duration : float, default 0.6
        Time after the step. [s]
    controllers_for_load : callable, optional
        ``(load, plant) -> {name: CoreParams}`` for :data:`CONTROLLER_NAMES`; default the
        documented design on ``model`` for every load. [-]

    Returns
    -------
    list of dict
        One row per (controller, step, load) with the step metrics.
    """
    plant_for_load = plant_for_load or (lambda load: plant_batch(load_N=load))
    if controllers_for_load is None:
        if model is None:
            raise InputError("step_size_table: give a model or controllers_for_load")
        fixed = comparison_controllers(model, beta)
        controllers_for_load = lambda load, plant: fixed  # noqa: E731
    total = hold + duration
    n, _ = _steps(total)
    k = int(round(hold / 1e-3))
    rows = []
    for load in loads:
        plant = plant_for_load(load)
        ctrls = controllers_for_load(load, plant)
        refs, params, labels = [], [], []
        for p0, p1 in steps:
            for name, cp in ctrls.items():
                refs.append(step_reference(n, k, p0, p1))
                params.append(cp)
                labels.append((name, p0, p1))
        rec = run_closed_loop(core_spec(params), np.array(refs), total, plant)
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


def to_plant_params(plant=None, base=None):
    """:class:`~mckibben.plant.PlantParams` from a :func:`plant_batch` dict (or pass one through).

    The factors scale the calibrated default plant: ``valve_gain`` both valves' sonic
    conductance, ``dead_band`` the valves' dead band, ``volume`` the lumen (the tube's inner
    diameter by its square root, so the rest lumen volume scales by the factor), ``dead_volume``
    the tubing volume, ``leak`` the leak conductance.

    Parameters
    ----------
    plant : dict or PlantParams or None
        None: the calibrated default plant. [-]
    base : PlantParams, optional
        The plant the factors scale; default the calibrated one. [-]

    Returns
    -------
    PlantParams
    """

    if plant is None:
        return PlantParams() if base is None else base
    if isinstance(plant, PlantParams):
        return plant
    f = plant_batch(**plant)
    base = PlantParams() if base is None else base
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
        raise InputError(f"n: {n!r} must be at least 1")
    rng = np.random.default_rng(seed)
    out = {k: rng.uniform(1 - spread, 1 + spread, n) for k in UNCERTAIN_FACTORS}
    out["supply_Pa"] = rng.uniform(*supply, n)
    out["load_N"] = rng.uniform(*load, n)
    return out


def comparison_entries() -> tuple[tuple[str, str, str | None], ...]:
    """Every compared controller, from the registry: ``(row name, controller, variant)``.

    One row per controller of :data:`mckibben.control.registry.CONTROLLERS` and per variant of
    its law: the first variant under the controller's name (``smc``), the others under
    ``<name>_<variant>`` (``smc_paper``). A registered controller is compared without a change
    here.

    Returns
    -------
    tuple of (str, str, str or None)
        In mode order. [-]
    """
    out = []
    for spec in R.CONTROLLERS.values():
        for i, variant in enumerate(spec.variants or (None,)):
            out.append((spec.name if i == 0 else f"{spec.name}_{variant}", spec.name, variant))
    return tuple(out)


#: The controllers of :func:`robustness_runs`, :func:`step_size_table` and the comparisons, by row
#: name (:func:`comparison_entries`): ``smc``, ``smc_paper``, ``pid``, then every extension law.
CONTROLLER_NAMES = tuple(name for name, _, _ in comparison_entries())


def comparison_controllers(model: FirstOrderModel, beta: float | None = None) -> dict:
    """The controllers of the comparisons (:data:`CONTROLLER_NAMES`), designed on an identified model.

    Each controller of the registry with its documented design (each variant of its law); ``beta``
    replaces the switching gain of a law's first variant (``smc``: our law), the paper's law keeps
    its β = 150.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model. [-]
    beta : float, optional
        Switching gain of the ``smc`` law (default :data:`SMC_TUNING`). [PWM counts]

    Returns
    -------
    dict
        ``{name: CoreParams}``, in :data:`CONTROLLER_NAMES` order.
    """
    base = with_supervisor_model(CoreParams(), model)
    return {name: R.get(controller).design(model, base, law=variant, beta=beta if name == controller else None)
            for name, controller, variant in comparison_entries()}


def robustness_runs(model: FirstOrderModel, n: int = 1000, seed: int = 0, beta: float | None = None,
               target: float = FIG13_TARGET_PA, duration: float = 0.6, t_step: float = 0.05, samples=None,
               base_plant=None, controllers=None):
    """Monte Carlo over plant uncertainty: PID and both sliding-mode laws on the same N plants.

    The controllers are designed once, on the model identified on the nominal plant; each plant
    gets every one (one batch of k·N instances): ``pid``, ``smc`` (law ``model``), ``smc_paper``
    (law ``paper``, β = 150) and each extension law of the registry (:func:`comparison_controllers`).

    Parameters
    ----------
    model : FirstOrderModel
        Identified nominal model. [-]
    n : int, default 1000
        Number of plants. [-]
    seed : int, default 0
        Random seed. [-]
    beta : float, optional
        Switching gain of the ``smc`` law (default :data:`SMC_TUNING`). [PWM counts]
    target : float, default 0.55e6
        Step target. [Pa]
    duration : float, default 0.6
        Record length. [s]
    t_step : float, default 0.05
        Time of the step. [s]
    samples : dict, optional
        The n plants (:func:`sample_plants`); default drawn from ``seed``. [-]
    base_plant : PlantParams, optional
        The nominal plant the factors scale; default the calibrated one. [-]
    controllers : dict, optional
        ``{name: CoreParams}`` for :data:`CONTROLLER_NAMES`; default the documented design on
        ``model``. [-]

    Returns
    -------
    dict
        ``samples`` (the plant factors), ``metrics`` {controller: {metric: array}}, ``summary``
        {controller: {metric: (median, p5, p95)}}. A plant a controller never brings to 63 %
        of the step has a NaN time constant, counted in ``n_undefined``.
    """
    if isinstance(n, bool) or int(n) != n or n < 1:
        raise InputError(f"n: {n!r} must be a whole number of plants >= 1")
    if isinstance(seed, bool) or int(seed) != seed or not 0 <= seed < 2**63:
        raise InputError(f"seed: {seed!r} must be a whole number in 0..2**63-1")

    check_budget("n", len(CONTROLLER_NAMES) * n * duration / 1e-3, force=True)
    samples = sample_plants(n, seed) if samples is None else samples
    k = len(CONTROLLER_NAMES)
    every = {key: np.concatenate([v] * k) for key, v in samples.items()}
    if controllers is None:
        controllers = comparison_controllers(model, beta)
    params = [controllers[name] for name in CONTROLLER_NAMES for _ in range(n)]
    nn, _ = _steps(duration)
    ref = step_reference(nn, int(round(t_step / 1e-3)), 0.0, target)
    plant = plant_batch(**every) if base_plant is None else to_plant_params(plant_batch(**every), base_plant)
    rec = run_closed_loop(core_spec(params), ref, duration, plant)
    keys = ("time_constant_s", "overshoot_pct", "steady_state_error_Pa", "settling_time_s", "valve_effort_counts")
    scored = step_metrics_batch(rec.t, rec.pressure, rec.reference, rec.command, t_step=t_step)  # every run at once
    metrics, summary = {}, {}
    for j, name in enumerate(CONTROLLER_NAMES):
        metrics[name] = {key: scored[key][j * n:(j + 1) * n].copy() for key in keys}
        summary[name] = {key: _pct(metrics[name][key]) for key in keys}
    return {"samples": samples, "metrics": metrics, "summary": summary}


def _pct(x: np.ndarray) -> dict:
    ok = x[np.isfinite(x)]
    if ok.size == 0:
        return {"median": math.nan, "p5": math.nan, "p95": math.nan, "n_undefined": int(x.size)}
    p5, med, p95 = np.percentile(ok, [5, 50, 95])
    return {"median": float(med), "p5": float(p5), "p95": float(p95), "n_undefined": int(x.size - ok.size)}
