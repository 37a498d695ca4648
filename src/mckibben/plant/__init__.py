"""The dynamic plant: supply, valves, chamber, muscle, load and sensors, simulated in batch.

:func:`simulate` runs N rigs at once (Numba); :class:`PlantParams` holds their parameters (the
calibrated rig of [mpam-characterization] by default); :func:`calibration` checks the default
against the paper. See ``docs/plant.md``.
"""

from mckibben import _lazy
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "CALIBRATION_PWM": "mckibben.plant.calibration",
    "Col": "mckibben.plant.packing",
    "LAW_NAMES": "mckibben.plant.params",
    "LOADS": "mckibben.plant.packing",
    "LinearPlant": "mckibben.plant.linear",
    "Load": "mckibben.plant.packing",
    "PlantParams": "mckibben.plant.params",
    "PlantStepper": "mckibben.plant.simulator",
    "SimResult": "mckibben.plant.simulator",
    "THERMAL": "mckibben.plant.packing",
    "calibrate_force_law": "mckibben.plant.params",
    "calibration": "mckibben.plant.calibration",
    "linearize": "mckibben.plant.linear",
    "open_loop_step": "mckibben.plant.calibration",
    "simulate": "mckibben.plant.simulator",
    "static_branch_lengths": "mckibben.plant.simulator",
    "static_length": "mckibben.plant.simulator",
}

__all__ = [
    "CALIBRATION_PWM", "LAW_NAMES", "LOADS", "PlantParams", "PlantStepper", "SimResult", "calibrate_force_law",
    "calibration", "open_loop_step", "simulate", "static_branch_lengths", "static_length", "Col", "Load", "THERMAL",
    "LinearPlant", "linearize",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.plant.calibration import CALIBRATION_PWM as CALIBRATION_PWM
    from mckibben.plant.packing import Col as Col
    from mckibben.plant.params import LAW_NAMES as LAW_NAMES
    from mckibben.plant.packing import LOADS as LOADS
    from mckibben.plant.linear import LinearPlant as LinearPlant
    from mckibben.plant.packing import Load as Load
    from mckibben.plant.params import PlantParams as PlantParams
    from mckibben.plant.simulator import PlantStepper as PlantStepper
    from mckibben.plant.simulator import SimResult as SimResult
    from mckibben.plant.packing import THERMAL as THERMAL
    from mckibben.plant.params import calibrate_force_law as calibrate_force_law
    from mckibben.plant.calibration import calibration as calibration
    from mckibben.plant.linear import linearize as linearize
    from mckibben.plant.calibration import open_loop_step as open_loop_step
    from mckibben.plant.simulator import simulate as simulate
    from mckibben.plant.simulator import static_branch_lengths as static_branch_lengths
    from mckibben.plant.simulator import static_length as static_length


__getattr__, __dir__ = _lazy.package(__name__, _WHERE, keep_names=True)
