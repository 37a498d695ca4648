"""The closed loop on the plant: one seam from the controller core to the batch simulator.

:func:`run_closed_loop` runs a controller spec (:func:`mckibben.control.core.core_spec`) on the
batch plant simulator (:mod:`mckibben.plant`) and returns a :class:`LoopRecord`;
:func:`step_reference` makes the step references of the runs; :data:`SAFETY_TRANSIENT_PA` is how
far the supervisor lets the pressure pass ``p_max + margin`` on the calibrated plant.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from mckibben.control.metrics import step_metrics
from mckibben.control.plant_sampling import to_plant_params
from mckibben.limits import check_budget
from mckibben.plant import simulate
from mckibben.results import TimeResponse


@dataclass(frozen=True)
class LoopRecord(TimeResponse):
    """Sampled closed-loop record, one row per instance, one column per control period.

    Parameters
    ----------
    t : numpy.ndarray
        Time of each control period (the sample the controller saw). [s]
    pressure : numpy.ndarray
        True gauge pressure at the samples, (N, n). [Pa]
    reference : numpy.ndarray
        Pressure reference given to the controller, (N, n). [Pa]
    inlet, bleed : numpy.ndarray
        Valve commands, (N, n). [PWM counts]
    faults : numpy.ndarray
        Supervisor fault flags, (N, n). [-]
    length : numpy.ndarray
        Muscle length, (N, n). [m]
    fstate : numpy.ndarray, optional
        The controllers' float state at the end of the run, (N, ·). [-]
    """

    t: np.ndarray
    pressure: np.ndarray
    reference: np.ndarray
    inlet: np.ndarray
    bleed: np.ndarray
    faults: np.ndarray
    length: np.ndarray
    fstate: np.ndarray | None = None

    SIGNALS = ("reference", "pressure", "inlet", "bleed", "command", "length", "faults")

    @cached_property
    def command(self) -> np.ndarray:
        """Signed command, inlet − bleed, computed once (metrics index it per instance); read-only. [PWM counts]"""
        u = self.inlet.astype(float) - self.bleed.astype(float)
        u.flags.writeable = False
        return u

    def metrics(self, i: int = 0, t_step: float | None = None) -> dict:
        """:func:`~mckibben.control.metrics.step_metrics` of instance ``i``.

        Parameters
        ----------
        i : int, default 0
            Instance. [-]
        t_step : float, optional
            Time of the step. [s]
        """
        return step_metrics(self.t, self.pressure[i], self.reference[i], self.command[i], t_step=t_step)

    def target_unreachable(self, i: int = 0, window: float = 0.1) -> bool:
        """Whether instance ``i`` ends settled below its reference with the inlet driving up.

        The supply (or the valve at full command) is then the limit: the chamber is where it can
        be, which is not a fault (the supervisor's response rule agrees, ``docs/controller.md``).

        Parameters
        ----------
        i : int, default 0
            Instance. [-]
        window : float, default 0.1
            The final stretch examined. [s]
        """
        k = max(int(round(window / (self.t[1] - self.t[0]))), 2) if self.t.size > 1 else 1
        p, r = self.pressure[i, -k:], self.reference[i, -k:]
        if not (np.all(np.isfinite(p)) and r.size):
            return False
        short = float(np.mean(r - p))
        settled = float(np.ptp(p)) < max(5e3, 0.01 * float(np.mean(r)))
        return bool(short > max(10e3, 0.02 * float(np.mean(r))) and settled and np.mean(self.inlet[i, -k:]) > 0)


#: The backend behind :func:`run_closed_loop`: ``f(spec, reference, duration, plant, ts)``.
_BACKEND = None


def run_closed_loop(spec, reference, duration: float, plant=None, ts: float = 1e-3) -> LoopRecord:
    """Run a controller spec on the batch plant simulator: the one seam to :mod:`mckibben.plant`.

    Parameters
    ----------
    spec : tuple
        ``(kernel, istate0, iparams, fstate0, fparams)`` with N rows. [-]
    reference : array_like
        Pressure reference per control period, shape (n,) or (N, n). [Pa]
    duration : float
        Simulated time. [s]
    plant : optional
        Plant parameters (:func:`plant_batch`); default: the calibrated default plant. [-]
    ts : float, default 1e-3
        Control period. [s]

    Returns
    -------
    LoopRecord
        The sampled record.
    """

    n_inst = np.asarray(spec[1]).shape[0]
    # the documented limits are the command line's (--force); here only what cannot fit at all
    check_budget("duration", n_inst * max(float(duration) / ts, 0.0), force=True)
    backend = _BACKEND if _BACKEND is not None else _plant_backend
    return backend(spec, reference, duration, plant, ts)


def _plant_backend(spec, reference, duration, plant, ts):

    n_inst = np.asarray(spec[1]).shape[0]
    sim = simulate(to_plant_params(plant), duration, controller=spec, reference=reference, ts=ts, n=n_inst)
    pressure = sim.pressure.copy()
    pressure[sim.flags & 1 != 0] = np.nan  # a diverged instance has no metrics, not wrong ones
    return LoopRecord(t=sim.t, pressure=pressure, reference=sim.reference, inlet=sim.inlet, bleed=sim.bleed,
                      faults=sim.faults, length=sim.length, fstate=sim.fstate)


def time_grid(duration: float, ts: float = 1e-3) -> tuple[int, np.ndarray]:
    """The control periods of a run: their number and their times.

    Parameters
    ----------
    duration : float
        Length of the run. [s]
    ts : float, default 1e-3
        Control period. [s]

    Returns
    -------
    (int, numpy.ndarray)
        Number of periods [-] and the time of each [s].
    """
    n = int(round(duration / ts))
    return n, np.arange(n) * ts


#: How far the measured pressure may rise above ``p_max + margin`` on the calibrated plant.
#: The supervisor shuts the inlet and opens the bleed while the pressure extrapolated over the
#: valve's closing time (:data:`mckibben.control.core.LEAD_SAMPLES`) passes ``p_max``, caps the
#: inlet at ``(p_max - p) >> HEADROOM_SHIFT`` counts below it, and vents above ``p_max + margin``;
#: the inlet valve's 3 ms lag still lets some air in. Measured with the inlet commanded wide open
#: (open-loop mode and both sliding-mode laws at β = 255), p_max 0.3–0.8 MPa, supply 0.6–1.0 MPa,
#: valves and volumes ±30 %: at most 47 kPa (67 kPa above p_max, at p_max = 0.4 MPa, supply 1 MPa,
#: valves 1.3×, small volumes); at p_max = 0.8 MPa the pressure stays below p_max on every such
#: plant. The bound is 50 kPa (``docs/control.md``, Safety; a property test in
#: ``tests/test_control_plant.py``).
SAFETY_TRANSIENT_PA = 50e3

def step_reference(n: int, t_step_index: int, p0: float, p1: float) -> np.ndarray:
    """A pressure step ``p0 → p1`` at sample ``t_step_index``.

    Parameters
    ----------
    n : int
        Samples. [-]
    t_step_index : int
        Sample of the step. [-]
    p0, p1 : float
        Pressure before and after. [Pa]
    """
    r = np.full(n, float(p0))
    r[t_step_index:] = float(p1)
    return r
