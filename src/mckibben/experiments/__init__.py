"""Experiments above control, tool and rig (DESIGN.md): the layer that may use all three.

:mod:`~mckibben.experiments.pressure`: the pressure-control experiments on the simulated plant
(:func:`step_response`, :func:`track_pressure`, :func:`open_loop`, :func:`fig13`, :func:`compare`,
:func:`robustness`, :func:`hysteresis_compensation`), one call each returning a result object.
:mod:`~mckibben.experiments.tool`: the three-muscle tool's tip following a path in simulation
(:func:`track_tip`, ``mckibben tool track``).
:mod:`~mckibben.experiments.link`: the three-muscle tool steered through the device link
(``mckibben tool track --port``; :func:`~mckibben.experiments.link.track_over_link`). It was
``mckibben.rig.track``; it moved here because it uses the tool, which the rig may not import.
:mod:`~mckibben.experiments.mujoco`: a hanging mass and any model with muscles on its tendons, in
MuJoCo (:func:`hanging_mass`, :func:`run_model`; ``mckibben mujoco hang|run``), on the bridge of
:mod:`mckibben.export.mujoco` (``mujoco`` is an optional dependency).
"""

from mckibben import _lazy


#: Where each public name lives; the submodules load on first use (PEP 562).
_WHERE = {name: "mckibben.experiments.pressure" for name in (
    "CompareResult", "Fig13Result", "OpenLoopResult", "RobustnessResult", "StepResult", "TrackResult", "compare",
    "fig13", "hysteresis_compensation", "open_loop", "robustness", "step_response", "track_pressure")}
_WHERE.update({"HangingMassResult": "mckibben.experiments.mujoco", "MuscleRunResult": "mckibben.experiments.mujoco",
               "hanging_mass": "mckibben.experiments.mujoco", "run_model": "mckibben.experiments.mujoco"})
_WHERE.update({"track_over_link": "mckibben.experiments.link",
               "ToolTrackResult": "mckibben.experiments.tool", "track_tip": "mckibben.experiments.tool"})

__all__ = sorted(_WHERE)

__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
