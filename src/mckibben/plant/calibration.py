"""Calibration of the default plant against [mpam-characterization].

Three published numbers: the open-loop response of the 100 mm muscle to a valve-voltage step is
first order with τ ≈ 0.09 s and no overshoot (§IV.A); the 97 mm muscle's blocked force at
0.8 MPa is 4.2 N (§III.A); under 0.6 N at 0.8 MPa it is 78.1 mm long (eq. 2+3, Tables I–II).
"""

from __future__ import annotations

import numpy as np

from mckibben.errors import check_int
from mckibben.plant import params as PP
from mckibben.plant.simulator import simulate, static_length

#: PWM count of the open-loop calibration step: a voltage step to 2.29 V of 5 V, five counts above
#: the valves' lift-off (112 counts, ``docs/plant.md``), whose steady pressure (≈ 0.5 MPa, where
#: the inflow through the barely open inlet balances the leak) lies inside the operating range, as
#: the paper's identification step must have (its size is not printed). Larger steps fill faster
#: and end nearer the supply pressure.
CALIBRATION_PWM = 117


def open_loop_step(plant: PP.PlantParams | None = None, valve: int = CALIBRATION_PWM, duration: float = 0.5,
                   ts: float = 1e-3, substeps: int = 10):
    """An open-loop inlet-valve step from rest and its metrics.

    Parameters
    ----------
    plant : PlantParams, optional
        The rig; default the calibrated one.
    valve : int, default CALIBRATION_PWM
        Inlet PWM count of the step (bleed shut). [counts]
    duration : float, default 0.5
        Simulated time. [s]
    ts : float, default 1e-3
        Sample (control) period. [s]
    substeps : int, default 10
        RK4 steps per sample. [-]

    Returns
    -------
    result : SimResult
        The run (one instance).
    metrics : dict
        ``time_constant_s`` (63 % of the final rise), ``rise_time_s`` (10–90 %),
        ``overshoot_pct``, ``final_pressure_Pa``, ``settling_time_s`` (2 %).
    """
    valve = check_int(valve, "valve", lo=0, hi=255)
    res = simulate(plant, duration, inlet=valve, ts=ts, substeps=substeps, n=1)
    t, y = res.t, res.pressure[0]
    final = float(np.mean(y[-max(1, len(y) // 20):]))
    y0 = float(y[0])
    rise = final - y0
    if rise <= 0:
        return res, {"time_constant_s": None, "rise_time_s": None, "overshoot_pct": 0.0,
                     "final_pressure_Pa": final, "settling_time_s": None}
    k63 = int(np.argmax(y >= y0 + 0.632 * rise))
    # linear interpolation between samples for the 63 % crossing
    tau = float(t[k63 - 1] + (y0 + 0.632 * rise - y[k63 - 1]) / (y[k63] - y[k63 - 1]) * (t[k63] - t[k63 - 1]))
    rise_time, overshoot, settling_time = step_info(y - y0, t, rise)
    return res, {
        "time_constant_s": tau,
        "rise_time_s": rise_time,
        "overshoot_pct": overshoot,
        "settling_time_s": settling_time,
        "final_pressure_Pa": final,
    }


def step_info(y: np.ndarray, t: np.ndarray, final: float) -> tuple[float, float, float]:
    """Rise time (10–90 %), overshoot and 2 % settling time of a sampled step response of a positive final value.

    The definitions and arithmetic of python-control's ``step_info`` for time-response data
    (``RiseTimeLimits=(0.1, 0.9)``, ``SettlingTimeThreshold=0.02``), written out so that an
    open-loop run does not import python-control (0.8 s); ``tests/test_plant.py`` holds the two
    equal on random responses.

    Parameters
    ----------
    y : numpy.ndarray
        The response, starting from 0. [any unit]
    t : numpy.ndarray
        Sample times. [s]
    final : float
        The final value, > 0. [unit of y]

    Returns
    -------
    (float, float, float)
        Rise time [s], overshoot [%] (0 when none), settling time [s] (NaN if never settled).
    """
    y, t = np.asarray(y, dtype=float), np.asarray(t, dtype=float)
    lower = np.nonzero(y - 0.1 * final >= 0)[0][0]
    upper = np.nonzero(y - 0.9 * final >= 0)[0][0]
    rise_time = t[upper] - t[lower]
    outside = np.nonzero(np.abs(y / final - 1) >= 0.02)[0]
    settled = 0 if outside.size == 0 else outside[-1] + 1
    settling_time = t[settled] if settled < len(t) else np.nan
    dy_os = np.abs(y.max()) - np.abs(final)
    overshoot = np.abs(100.0 * dy_os / final) if dy_os > 0 else 0
    return float(rise_time), float(overshoot), float(settling_time)


def calibration(plant: PP.PlantParams | None = None) -> dict:
    """Check the plant against the paper's three numbers.

    Parameters
    ----------
    plant : PlantParams, optional
        The rig; default the calibrated one.

    Returns
    -------
    dict
        The open-loop step metrics; ``blocked_force_N`` (a blocked end inflated to 0.8 MPa) and
        ``length_m`` and ``contraction`` (0.6 N hanging, inflated to 0.8 MPa: friction holds it
        slightly longer than ``static_length_m``, the friction-free balance); the paper's values;
        the ``checks`` and ``pass``.
    """
    plant = plant or PP.PlantParams()
    _, step = open_loop_step(plant)
    # The rig's own experiments, dynamically: the inlet opened fully on a sealed muscle (no
    # leak) fed at 0.8 MPa, the end blocked (load cell) or carrying 0.6 N, until it settles.
    sealed = plant.replace(leak_conductance=0.0, supply_pressure=0.8e6)
    blocked_run = simulate(sealed.replace(load_kind="blocked"), 0.6, inlet=255, n=1)
    hanging_run = simulate(sealed.replace(load_kind="hanging", load_force=0.6), 0.6, inlet=255, n=1)
    blocked = float(blocked_run.force[0, -1])
    length = float(hanging_run.length[0, -1])
    static = float(static_length(sealed.replace(load_force=0.6), 0.8e6)[0])
    checks = {
        "time_constant": 0.08 <= (step["time_constant_s"] or 0) <= 0.10,
        "no_overshoot": step["overshoot_pct"] < 1.0,
        "blocked_force": abs(blocked - 4.2) <= 0.42,
        "length": abs(length - 78.1e-3) <= 7.81e-3,
    }
    return {
        **step,
        "step_pwm": CALIBRATION_PWM,
        "blocked_force_N": blocked,
        "paper_blocked_force_N": 4.2,
        "length_m": length,
        "paper_length_m": 78.1e-3,
        "contraction": 1.0 - length / float(plant.nominal_length),
        "blocked_pressure_Pa": float(blocked_run.pressure[0, -1]),
        "static_length_m": static,
        "paper_time_constant_s": 0.09,
        "checks": checks,
        "pass": all(checks.values()),
    }
