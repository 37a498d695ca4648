"""Where the closed-loop runs live: an index of the modules the old ``runs`` was split into.

This module defines nothing. It keeps ``mckibben.control.runs.<name>`` importable for the names
the command line, the tool and the experiments read; new code imports from the module that holds
the name:

- :mod:`mckibben.control.loop`: :func:`run_closed_loop` (the one seam to the plant simulator),
  :class:`LoopRecord`, :func:`step_reference`, :data:`SAFETY_TRANSIENT_PA`;
- :mod:`mckibben.control.identify`: :func:`identify_plant` (two open-loop steps, §IV.A);
- :mod:`mckibben.control.controllers`: the sliding mode's variants (:data:`SMC_LAWS`), their
  documented designs and :func:`smc_core_params`; the PID's is :func:`default_pid`
  (:mod:`mckibben.control.laws.pid`);
- :mod:`mckibben.control.tuning`: :func:`tune_gains` and its design steps, sines and bar;
- :mod:`mckibben.control.studies`: :func:`fig13_runs`, :func:`step_size_table`,
  :func:`robustness_runs` and the compared controllers (:func:`comparison_entries`);
- :mod:`mckibben.control.plant_sampling`: :func:`plant_batch`, :func:`to_plant_params`,
  :func:`sample_plants`.
"""

from __future__ import annotations

from mckibben.control.controllers import PAPER_SMC_TUNING, SMC_LAWS, SMC_TUNING, smc_core_params
from mckibben.control.identify import identify_plant
from mckibben.control.laws.pid import default_pid
from mckibben.control.loop import SAFETY_TRANSIENT_PA, LoopRecord, run_closed_loop, step_reference, time_grid
from mckibben.control.plant_sampling import UNCERTAIN_FACTORS, plant_batch, sample_plants, to_plant_params
from mckibben.control.studies import (CONTROLLER_NAMES, FIG13_TARGET_PA, PAPER_FIG13, comparison_controllers,
                                      comparison_entries, fig13_runs, robustness_runs, step_size_table)
from mckibben.control.tuning import (TUNING_BAR, TUNING_CANDIDATES, TUNING_SINES, TUNING_STEPS, GainTuning,
                                     tune_gains)

__all__ = [
    "CONTROLLER_NAMES", "FIG13_TARGET_PA", "GainTuning", "LoopRecord", "PAPER_FIG13", "PAPER_SMC_TUNING",
    "SAFETY_TRANSIENT_PA", "SMC_LAWS", "SMC_TUNING", "TUNING_BAR", "TUNING_CANDIDATES", "TUNING_SINES",
    "TUNING_STEPS", "UNCERTAIN_FACTORS", "comparison_controllers", "comparison_entries", "default_pid",
    "fig13_runs", "identify_plant", "plant_batch", "robustness_runs", "run_closed_loop", "sample_plants",
    "smc_core_params", "step_reference", "step_size_table", "time_grid", "to_plant_params", "tune_gains",
]
