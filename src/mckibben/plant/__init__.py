"""The dynamic plant: supply, valves, chamber, muscle, load and sensors, simulated in batch.

:func:`simulate` runs N rigs at once (Numba); :class:`PlantParams` holds their parameters (the
calibrated rig of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt) by default); :func:`calibration` checks the default
against the paper. See ``docs/plant.md``.
"""

from mckibben.plant.calibration import CALIBRATION_PWM, calibration, open_loop_step
from mckibben.plant.params import FORCE_MODELS, LOADS, THERMAL, Col, Load, PlantParams, calibrate_force_law
from mckibben.plant.linear import LinearPlant, linearize
from mckibben.plant.simulator import PlantStepper, SimResult, simulate, static_length

__all__ = [
    "CALIBRATION_PWM", "FORCE_MODELS", "LOADS", "PlantParams", "PlantStepper", "SimResult", "calibrate_force_law",
    "calibration", "open_loop_step", "simulate", "static_length", "Col", "Load", "THERMAL",
    "LinearPlant", "linearize",
]
