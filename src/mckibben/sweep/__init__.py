"""Design sweeps: a TOML description, chunks of batch simulations run in-process or on Dask,
results as a Parquet dataset, and summaries (best setting, Pareto front, sensitivity).
See ``docs/sweep.md``."""

from mckibben.sweep.run import read_results, run_sweep
from mckibben.sweep.spec import Sweep, load_sweep
from mckibben.sweep.summary import (
    best_setting,
    pareto_front,
    plot_pareto,
    plot_sensitivity,
    sensitivity,
    settings_table,
)

__all__ = ["Sweep", "best_setting", "load_sweep", "pareto_front", "plot_pareto", "plot_sensitivity", "read_results",
           "run_sweep", "sensitivity", "settings_table"]
