"""Gains tuned on a plant: candidates of a controller's grid simulated on design steps or sines.

:func:`tune_gains` reads the controller's candidate grid and its ``candidates`` function from its
registry entry (:mod:`mckibben.control.laws`), simulates every candidate on the plant's design
steps (:data:`TUNING_STEPS`) or sines (:data:`TUNING_SINES`) and keeps the best that meets
:data:`TUNING_BAR` (:class:`GainTuning`). What a muscle file's plant gets instead of the
calibrated rig's gains (``docs/control.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben.control import registry as R
from mckibben.control.controllers import SMC_LAWS
from mckibben.control.core_params import CoreParams, core_spec
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.loop import time_grid, run_closed_loop, step_reference
from mckibben.control.metrics import step_metrics_batch, tracking_metrics_batch
from mckibben.control.plant_sampling import to_plant_params
from mckibben.errors import unknown_name

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
    n, _ = time_grid(total)
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

    n, t = time_grid(TUNING_SINE_S)
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
