"""Pressure control: identification, PID and sliding mode, the firmware's core, experiments.

The experiments of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt) §IV on the simulated plant, one call each, returning
result objects (``.metrics``, ``.to_pandas()``, ``.plot(ax=None)``):

>>> import mckibben.control as mc                                  # doctest: +SKIP
>>> mc.step_response("smc", target="0.55MPa", law="paper", beta=150)   # doctest: +SKIP
>>> mc.fig13().plot()                                               # doctest: +SKIP

Building blocks: :func:`identify_plant` (FOPDT fit and the valves' lift-off, §IV.A),
:func:`design_pid`, :func:`smc_params`, :func:`controller_params`, :func:`step_metrics` (and :func:`step_metrics_batch` for N runs),
:func:`run_closed_loop`. Modules: :mod:`~mckibben.control.core` (the controller core shared
with the firmware), :mod:`~mckibben.control.identify`, :mod:`~mckibben.control.metrics`,
:mod:`~mckibben.control.hysteresis`, :mod:`~mckibben.control.length`.
"""

from mckibben.control.controllers import FirstOrderModel, PIDDesign, design_pid, pid_params, smc_params
from mckibben.control.core import CoreParams
from mckibben.control.experiments import LAWS, identify_plant, run_closed_loop
from mckibben.control.identify import fit_step_response, read_step_log
from mckibben.control.metrics import step_metrics, step_metrics_batch, tracking_metrics, tracking_metrics_batch
from mckibben.control.plots import (
    plot_compare,
    plot_fig13,
    plot_hysteresis,
    plot_open_loop,
    plot_record,
    plot_robustness,
    plot_step_fit,
)
from mckibben.control.simulation import (
    CONTROLLERS,
    CompareResult,
    Fig13Result,
    OpenLoopResult,
    RobustnessResult,
    StepResult,
    TrackResult,
    compare,
    controller_params,
    fig13,
    hysteresis_compensation,
    identified_model,
    open_loop,
    pressure_reference,
    robustness,
    step_response,
    track,
    tuned_controller,
)

__all__ = [
    "CONTROLLERS", "LAWS", "CompareResult", "CoreParams", "Fig13Result", "FirstOrderModel", "OpenLoopResult",
    "PIDDesign", "RobustnessResult", "StepResult", "TrackResult", "compare", "controller_params", "design_pid",
    "fig13", "fit_step_response", "hysteresis_compensation", "identified_model", "identify_plant", "open_loop", "pid_params",
    "plot_compare", "plot_fig13", "plot_hysteresis", "plot_open_loop", "plot_record", "plot_robustness", "plot_step_fit",
    "pressure_reference", "read_step_log", "robustness", "run_closed_loop", "smc_params", "step_metrics",
    "step_metrics_batch", "step_response", "track",
    "tracking_metrics", "tracking_metrics_batch", "tuned_controller",
]
