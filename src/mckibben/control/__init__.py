"""Pressure control: the controller registry, identification, PID and sliding mode, the firmware's core.

The experiments of [mpam-characterization] §IV on the simulated plant (step, tracking, Fig. 13,
compare, robustness...) live in the layer above, :mod:`mckibben.experiments`, one call each,
returning result objects. Quantities are numbers in SI (Pa, N, s); a pressure reference is an
object (:class:`SineReference`, a file, an array), which :func:`parse_reference` makes from the
command line's text:

>>> import mckibben.control as mc, mckibben.experiments as mx          # doctest: +SKIP
>>> mx.step_response("smc", target=0.55e6, law="paper", beta=150)      # doctest: +SKIP
>>> mx.track_pressure(mc.SineReference(0.4e6, 0.1e6, 2.0)).metrics     # doctest: +SKIP

Building blocks: :func:`identify_plant` (FOPDT fit and the valves' lift-off, §IV.A),
:func:`design_pid`, :func:`smc_params`, :func:`controller_params`, :func:`step_metrics` (and :func:`step_metrics_batch` for N runs),
:func:`run_closed_loop`. Modules, each named for what it holds: :mod:`~mckibben.control.laws`
(the controllers, one file each, and the one table of their mode and gain ids),
:mod:`~mckibben.control.registry` (the tables built from them), the firmware's core
(:mod:`~mckibben.control.layout`, :mod:`~mckibben.control.step`,
:mod:`~mckibben.control.core_params`, :mod:`~mckibben.control.bank`,
:mod:`~mckibben.control.design_file`), :mod:`~mckibben.control.identify`,
:mod:`~mckibben.control.loop`, :mod:`~mckibben.control.tuning`, :mod:`~mckibben.control.studies`,
:mod:`~mckibben.control.plant_sampling`, :mod:`~mckibben.control.experiment_setup`,
:mod:`~mckibben.control.metrics`, :mod:`~mckibben.control.hysteresis`,
:mod:`~mckibben.control.length` (``docs/control.md`` has the table).
"""

from mckibben import _lazy

#: Where each public name lives. The submodules are imported on first use (PEP 562): the control
#: package pulls in python-control and SciPy, and a light module (the controller registry, which
#: the rig, the sweeps and the command line read) must not wait for them. Every name is of this
#: package or below it: the experiments are the layer above's (:mod:`mckibben.experiments`).
_WHERE = {
    "CONTROLLERS": "mckibben.control.registry",
    "CoreParams": "mckibben.control.core",
    "FirstOrderModel": "mckibben.control.first_order",
    "PIDDesign": "mckibben.control.laws.pid",
    "SMC_LAWS": "mckibben.control.controllers",
    "SineReference": "mckibben.control.references",
    "controller_params": "mckibben.control.experiment_setup",
    "design_pid": "mckibben.control.laws.pid",
    "fit_step_response": "mckibben.fit.step",
    "identified_model": "mckibben.control.experiment_setup",
    "identify_plant": "mckibben.control.identify",
    "pid_params": "mckibben.control.controllers",
    "plot_compare": "mckibben.control.plots",
    "plot_fig13": "mckibben.control.plots",
    "plot_hysteresis": "mckibben.control.plots",
    "plot_open_loop": "mckibben.control.plots",
    "plot_record": "mckibben.control.plots",
    "plot_robustness": "mckibben.control.plots",
    "plot_step_fit": "mckibben.control.plots",
    "parse_reference": "mckibben.control.references",
    "pressure_reference": "mckibben.control.experiment_setup",
    "read_step_log": "mckibben.data.steplog",
    "run_closed_loop": "mckibben.control.loop",
    "smc_params": "mckibben.control.controllers",
    "step_metrics": "mckibben.control.metrics",
    "step_metrics_batch": "mckibben.control.metrics",
    "tracking_metrics": "mckibben.control.metrics",
    "tracking_metrics_batch": "mckibben.control.metrics",
    "tuned_controller": "mckibben.control.experiment_setup",
}


__all__ = [
    "CONTROLLERS", "CoreParams", "FirstOrderModel", "SMC_LAWS",
    "PIDDesign", "SineReference", "controller_params", "design_pid",
    "fit_step_response", "identified_model", "identify_plant", "pid_params",
    "plot_compare", "plot_fig13", "plot_hysteresis", "plot_open_loop", "plot_record", "plot_robustness", "plot_step_fit",
    "parse_reference", "pressure_reference", "read_step_log", "run_closed_loop", "smc_params", "step_metrics",
    "step_metrics_batch",
    "tracking_metrics", "tracking_metrics_batch", "tuned_controller",
]


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
