"""The runs of the paper's comparisons: Fig. 13, step sizes and loads, and the robustness study.

:func:`fig13_runs` (the sliding-mode steps of Fig. 13, :data:`PAPER_FIG13`), :func:`step_size_table`
(every compared controller over steps and loads) and :func:`robustness_runs` (Monte Carlo over
plant uncertainty). The compared controllers are every entry of the registry and every variant of
its law (:func:`comparison_entries`, :data:`CONTROLLER_NAMES`), each with its documented design
(:func:`comparison_controllers`). The experiments (:mod:`mckibben.experiments`) wrap these runs
in results.
"""

from __future__ import annotations

import math

import numpy as np

from mckibben.control import registry as R
from mckibben.control.controllers import SMC_LAWS, smc_core_params
from mckibben.control.core_params import CoreParams, core_spec
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.laws import with_supervisor_model
from mckibben.control.loop import time_grid, run_closed_loop, step_reference
from mckibben.control.metrics import step_metrics_batch
from mckibben.control.plant_sampling import plant_batch, sample_plants, to_plant_params
from mckibben.datasets.paper_points import FIG13 as _FIG13
from mckibben.errors import InputError
from mckibben.limits import check_budget

#: The paper's Fig. 13 (:data:`mckibben.datasets.paper_points.FIG13`): β -> time constant, overshoot.
PAPER_FIG13 = _FIG13["points"]
#: Fig. 13's step target, 0.55 MPa (80 psi). [Pa]
FIG13_TARGET_PA = _FIG13["target_Pa"]


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
    n, t = time_grid(duration)
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
    n, _ = time_grid(total)
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
    nn, _ = time_grid(duration)
    ref = step_reference(nn, int(round(t_step / 1e-3)), 0.0, target)
    plant = plant_batch(**every) if base_plant is None else to_plant_params(plant_batch(**every), base_plant)
    rec = run_closed_loop(core_spec(params), ref, duration, plant)
    keys = ("time_constant_s", "overshoot_pct", "steady_state_error_Pa", "settling_time_s", "valve_effort_counts")
    scored = step_metrics_batch(rec.t, rec.pressure, rec.reference, rec.command, t_step=t_step)  # every run at once
    metrics, summary = {}, {}
    for j, name in enumerate(CONTROLLER_NAMES):
        metrics[name] = {key: scored[key][j * n:(j + 1) * n].copy() for key in keys}
        summary[name] = {key: percentiles(metrics[name][key]) for key in keys}
    return {"samples": samples, "metrics": metrics, "summary": summary}


def percentiles(x: np.ndarray) -> dict:
    """Median, 5th and 95th percentile of the finite values, and how many were not.

    Parameters
    ----------
    x : numpy.ndarray
        One metric over the runs. [its unit]

    Returns
    -------
    dict
        ``median``, ``p5``, ``p95`` [its unit] and ``n_undefined`` [-].
    """
    ok = x[np.isfinite(x)]
    if ok.size == 0:
        return {"median": math.nan, "p5": math.nan, "p95": math.nan, "n_undefined": int(x.size)}
    p5, med, p95 = np.percentile(ok, [5, 50, 95])
    return {"median": float(med), "p5": float(p5), "p95": float(p95), "n_undefined": int(x.size - ok.size)}
