"""Design sweeps: a TOML description, chunks of batch simulations run in-process or on Dask,
results as a Parquet dataset, and summaries (best setting, Pareto front, sensitivity).
See ``docs/sweep.md``."""

from mckibben import _lazy
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "Sweep": "mckibben.sweep.spec",
    "best_setting": "mckibben.sweep.summary",
    "load_sweep": "mckibben.sweep.spec",
    "pareto_front": "mckibben.sweep.summary",
    "plot_pareto": "mckibben.sweep.summary",
    "plot_sensitivity": "mckibben.sweep.summary",
    "read_results": "mckibben.sweep.run",
    "run_sweep": "mckibben.sweep.run",
    "sensitivity": "mckibben.sweep.summary",
    "settings_table": "mckibben.sweep.summary",
}

__all__ = ["Sweep", "best_setting", "load_sweep", "pareto_front", "plot_pareto", "plot_sensitivity", "read_results",
           "run_sweep", "sensitivity", "settings_table"]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.sweep.spec import Sweep as Sweep
    from mckibben.sweep.summary import best_setting as best_setting
    from mckibben.sweep.spec import load_sweep as load_sweep
    from mckibben.sweep.summary import pareto_front as pareto_front
    from mckibben.sweep.summary import plot_pareto as plot_pareto
    from mckibben.sweep.summary import plot_sensitivity as plot_sensitivity
    from mckibben.sweep.run import read_results as read_results
    from mckibben.sweep.run import run_sweep as run_sweep
    from mckibben.sweep.summary import sensitivity as sensitivity
    from mckibben.sweep.summary import settings_table as settings_table


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
