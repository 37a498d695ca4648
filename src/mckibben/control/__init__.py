"""Pressure control: identification, PID and sliding mode, the firmware's core, experiments.

The experiments of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt) §IV on the simulated plant
(:mod:`mckibben.experiments.pressure`, reachable here by name), one call each, returning
result objects (``.metrics``, ``.to_pandas()``, ``.plot(ax=None)``). Quantities are numbers in SI
(Pa, N, s); a pressure reference is an object (:class:`SineReference`, a file, an array), which
:func:`parse_reference` makes from the command line's text:

>>> import mckibben.control as mc                                  # doctest: +SKIP
>>> mc.step_response("smc", target=0.55e6, law="paper", beta=150)      # doctest: +SKIP
>>> mc.track_pressure(mc.SineReference(0.4e6, 0.1e6, 2.0)).metrics    # doctest: +SKIP
>>> mc.fig13().plot()                                               # doctest: +SKIP

Building blocks: :func:`identify_plant` (FOPDT fit and the valves' lift-off, §IV.A),
:func:`design_pid`, :func:`smc_params`, :func:`controller_params`, :func:`step_metrics` (and :func:`step_metrics_batch` for N runs),
:func:`run_closed_loop`. Modules: :mod:`~mckibben.control.core` (the controller core shared
with the firmware), :mod:`~mckibben.control.identify`, :mod:`~mckibben.control.metrics`,
:mod:`~mckibben.control.hysteresis`, :mod:`~mckibben.control.length`.
"""

from mckibben import _lazy

#: Where each public name lives. The submodules are imported on first use (PEP 562): the control
#: package pulls in python-control and SciPy, and a light module (the controller registry, which
#: the rig, the sweeps and the command line read) must not wait for them. The experiments
#: (``step_response``, ``fig13``...) live in the experiment layer, :mod:`mckibben.experiments.pressure`;
#: they keep their names here (their results' provenance says ``mckibben.control.step_response``),
#: looked up by name on first use: no module of this package imports that layer.
_WHERE = {
    "CONTROLLERS": "mckibben.control.simulation",
    "CompareResult": "mckibben.experiments.pressure",
    "CoreParams": "mckibben.control.core",
    "Fig13Result": "mckibben.experiments.pressure",
    "FirstOrderModel": "mckibben.control.controllers",
    "LAWS": "mckibben.control.experiments",
    "OpenLoopResult": "mckibben.experiments.pressure",
    "PIDDesign": "mckibben.control.controllers",
    "RobustnessResult": "mckibben.experiments.pressure",
    "SineReference": "mckibben.control.references",
    "StepResult": "mckibben.experiments.pressure",
    "TrackResult": "mckibben.experiments.pressure",
    "compare": "mckibben.experiments.pressure",
    "controller_params": "mckibben.control.simulation",
    "design_pid": "mckibben.control.controllers",
    "fig13": "mckibben.experiments.pressure",
    "fit_step_response": "mckibben.fit.step",
    "hysteresis_compensation": "mckibben.experiments.pressure",
    "identified_model": "mckibben.control.simulation",
    "identify_plant": "mckibben.control.experiments",
    "open_loop": "mckibben.experiments.pressure",
    "pid_params": "mckibben.control.controllers",
    "plot_compare": "mckibben.control.plots",
    "plot_fig13": "mckibben.control.plots",
    "plot_hysteresis": "mckibben.control.plots",
    "plot_open_loop": "mckibben.control.plots",
    "plot_record": "mckibben.control.plots",
    "plot_robustness": "mckibben.control.plots",
    "plot_step_fit": "mckibben.control.plots",
    "parse_reference": "mckibben.control.references",
    "pressure_reference": "mckibben.control.simulation",
    "read_step_log": "mckibben.data.steplog",
    "robustness": "mckibben.experiments.pressure",
    "run_closed_loop": "mckibben.control.experiments",
    "smc_params": "mckibben.control.controllers",
    "step_metrics": "mckibben.control.metrics",
    "step_metrics_batch": "mckibben.control.metrics",
    "step_response": "mckibben.experiments.pressure",
    "track_pressure": "mckibben.experiments.pressure",
    "tracking_metrics": "mckibben.control.metrics",
    "tracking_metrics_batch": "mckibben.control.metrics",
    "tuned_controller": "mckibben.control.simulation",
}


__all__ = [
    "CONTROLLERS", "LAWS", "CompareResult", "CoreParams", "Fig13Result", "FirstOrderModel", "OpenLoopResult",
    "PIDDesign", "RobustnessResult", "SineReference", "StepResult", "TrackResult", "compare", "controller_params", "design_pid",
    "fig13", "fit_step_response", "hysteresis_compensation", "identified_model", "identify_plant", "open_loop", "pid_params",
    "plot_compare", "plot_fig13", "plot_hysteresis", "plot_open_loop", "plot_record", "plot_robustness", "plot_step_fit",
    "parse_reference", "pressure_reference", "read_step_log", "robustness", "run_closed_loop", "smc_params", "step_metrics",
    "step_metrics_batch", "step_response", "track_pressure",
    "tracking_metrics", "tracking_metrics_batch", "tuned_controller",
]


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
