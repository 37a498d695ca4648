"""Pressure controllers: the firmware core with designed gains, and their design.

There is one control law, the firmware's (:mod:`mckibben.control.core`: sliding mode, PID and
the supervisor, fixed point, bit-exact with the C core). This module designs its gains from an
identified model and wraps one instance as an object with explicit state and a
``step(measurement, reference) -> command`` method:

- :func:`design_pid`: lambda (IMC/SIMC) tuning of a PI(D) on the identified first-order model,
  checked with python-control (margins, predicted closed-loop step);
- :func:`smc_params`: the sliding-mode gains, the model term (τ, G) from identification;
- :class:`SlidingModeController`, :class:`PIDController`: one core instance each;
- :func:`supervised`: wraps a plain Python controller ``f(t, adc, enc, p_ref) -> (inlet, bleed)``
  so that its output goes through the same supervisor (the core in open-loop mode, the callable's
  counts as the open-loop command): no command path bypasses the pressure limit and the vent.

Commands are PWM counts of the Arduino's 8-bit timers: positive drives the inlet valve, negative
the bleed valve (``docs/controller.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from mckibben.control import core
from mckibben.control.core import MODE_OPEN_LOOP, MODE_PID, MODE_SMC, CoreController, CoreParams, core_spec
from mckibben.errors import InputError
from mckibben.hardware import adc_from_pressure  # noqa: F401  (re-exported: the one sensor model)
from mckibben.control.metrics import ONE_MINUS_INV_E, crossing_time

if TYPE_CHECKING:  # python-control costs ~0.8 s at import: imported where an LTI object is built
    import control


# --- design --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FirstOrderModel:
    """The identified model ``ṗ = (G·(u − u0) − p)/τ`` (plus an optional dead time θ).

    u0 is the command below which the valve passes no air (its lift-off); 0 gives the paper's
    first-order model through the origin (§IV.A).

    Parameters
    ----------
    gain : float
        Static gain G, pressure per PWM count above the lift-off. [Pa/count]
    tau : float
        Time constant. [s]
    dead_time : float, default 0.0
        Dead time. [s]
    lift_off : float, default 0.0
        u0, the valve's lift-off. [PWM counts]
    """

    gain: float
    tau: float
    dead_time: float = 0.0
    lift_off: float = 0.0

    @classmethod
    def from_fit(cls, fit) -> FirstOrderModel:
        """From a :class:`~mckibben.fit.step.StepFit` (order 1 or 2).

        Parameters
        ----------
        fit : StepFit
            Fitted step response with gain in Pa per count. [-]
        """
        return cls(float(fit.gain), float(fit.tau), float(fit.dead_time))

    def through_origin(self, pressure: float) -> FirstOrderModel:
        """The paper's model through the origin (no lift-off), with the secant gain at a pressure.

        ``G_s = p/(u0 + p/G)``: the gain of the straight line from rest to the command that
        holds ``pressure``; equal to this model there, wrong away from it (§IV.A's PID).

        Parameters
        ----------
        pressure : float
            Operating point. [Pa]

        Returns
        -------
        FirstOrderModel
            Gain G_s [Pa/count], the same τ [s] and θ [s], no lift-off.
        """
        if not (math.isfinite(pressure) and pressure > 0):
            raise InputError(f"through_origin: pressure={pressure!r} must be a finite pressure > 0 Pa")
        gain = pressure / (self.lift_off + pressure / self.gain)
        if not (math.isfinite(gain) and gain > 0):
            raise InputError(f"through_origin: no line through the origin meets {self!r} at {pressure:g} Pa")
        return FirstOrderModel(float(gain), self.tau, self.dead_time)

    def transfer_function(self, pade_order: int = 2) -> control.TransferFunction:
        """``G/(τs + 1)`` times a Padé approximation of the dead time.

        Parameters
        ----------
        pade_order : int, default 2
            Padé order (0: no dead time). [-]
        """
        import control  # deferred: python-control costs ~0.8 s at import (only LTI objects need it)

        sys = control.tf([self.gain], [self.tau, 1.0])
        # a dead time that is zero to round-off (a fit's 1e-26 s) would put Padé poles at 1e26/s
        if pade_order > 0 and self.dead_time > 1e-9 * self.tau:
            sys = sys * control.tf(*control.pade(self.dead_time, pade_order))
        return sys


@dataclass(frozen=True)
class PIDDesign:
    """A PID designed on a first-order model, with python-control's verdict on it.

    Parameters
    ----------
    kp : float
        Proportional gain. [counts/Pa]
    ki : float
        Integral gain. [counts/(Pa s)]
    kd : float
        Derivative gain. [counts s/Pa]
    tf : float
        Derivative filter time constant. [s]
    closed_loop_tau : float
        The λ the design aimed at (closed-loop time constant on the model). [s]
    gain_margin : float
        Gain margin of the loop on the model (inf if unbounded). [-]
    phase_margin_deg : float
        Phase margin of the loop on the model. [deg]
    predicted : dict
        ``control.step_info`` of the closed loop on the model (linear, no saturation). [s, %]
    """

    kp: float
    ki: float
    kd: float
    tf: float
    closed_loop_tau: float
    gain_margin: float
    phase_margin_deg: float
    predicted: dict


def design_pid(model: FirstOrderModel, closed_loop_tau: float, *, derivative: bool = False,
               ts: float = 1e-3, verdict: bool = True) -> PIDDesign:
    """Lambda (IMC / SIMC) tuning of a PI or PID on a first-order-plus-dead-time model.

    ``Kp = τ/(G(λ + θ))``, ``Ti = min(τ, 4(λ + θ))``, ``Ki = Kp/Ti``; with ``derivative`` a
    derivative cancelling half the dead time, ``Td = θ/2``, filtered with ``Tf = max(Td/10, Ts)``.
    python-control then checks the design: stability margins of the loop (dead time as a
    second-order Padé approximation) and the closed-loop step (``control.step_info``) on the
    linear model. Valve saturation and dead band are not in the model: that is exactly why a
    PID tuned this way degrades with step size and back pressure on the real plant (§IV.A).

    Parameters
    ----------
    model : FirstOrderModel
        Identified model, gain in Pa per PWM count. [-]
    closed_loop_tau : float
        Desired closed-loop time constant λ. [s]
    derivative : bool, default False
        Add the derivative term. [-]
    ts : float, default 1e-3
        Control period (lower bound of the filter time constant). [s]
    verdict : bool, default True
        Compute python-control's margins and predicted step (False: NaN and an empty dict, for
        screening many candidates). [-]

    Returns
    -------
    PIDDesign
        Gains in PWM counts per Pa and the verdict.

    References
    ----------
    S. Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
    J. Process Control 13 (2003) 291–309, eq. (20)–(21) (SIMC).
    """
    if not (model.gain > 0 and model.tau > 0 and model.dead_time >= 0):
        raise InputError(f"design_pid: the model needs gain > 0 and tau > 0, got {model!r}")
    if not closed_loop_tau > 0:
        raise InputError(f"design_pid: closed_loop_tau={closed_loop_tau!r} must be > 0 s")
    lam, theta = float(closed_loop_tau), model.dead_time
    kp = model.tau / (model.gain * (lam + theta))
    ti = min(model.tau, 4.0 * (lam + theta))
    ki = kp / ti
    td = theta / 2.0 if derivative else 0.0
    kd = kp * td
    tf = max(td / 10.0, ts)
    if not verdict:
        return PIDDesign(kp, ki, kd, tf, lam, math.nan, math.nan, {})
    import control  # deferred: python-control costs ~0.8 s at import (only LTI objects need it)

    s = control.tf("s")
    c = kp + ki / s + kd * s / (tf * s + 1)
    loop = c * model.transfer_function(2)
    gm, pm, _, _ = control.margin(loop)
    cl = control.feedback(loop, 1)
    tgrid = np.linspace(0, 10 * (lam + theta + model.tau), 4000)
    info = control.step_info(cl, timepts=tgrid)
    predicted = {"time_constant_s": _tf_time_constant(cl, tgrid), "rise_time_s": info["RiseTime"],
                 "settling_time_s": info["SettlingTime"], "overshoot_pct": info["Overshoot"]}
    return PIDDesign(kp, ki, kd, tf, lam, float(gm), float(pm), predicted)


def _tf_time_constant(sys, tgrid) -> float:
    import control  # deferred: python-control costs ~0.8 s at import (only LTI objects need it)


    t, y = control.step_response(sys, tgrid)
    return crossing_time(t, y / sys.dcgain(), ONE_MINUS_INV_E)


def smc_params(model: FirstOrderModel, beta: float, eps: float, ki: float, *, i_max: float = 1e4,
               base: CoreParams = CoreParams()) -> CoreParams:
    """Core parameters of the sliding-mode law from an identified model and the design gains.

    The model term of the law (``docs/controller.md``) uses τ, G and the lift-off u0 of the
    identified first-order model; β, ε and Ki are the design's. The PID gains and supervisor settings are
    taken from ``base``.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (G in Pa per PWM count, τ). [-]
    beta : float
        Switching gain. [PWM counts]
    eps : float
        Boundary-layer width. [Pa]
    ki : float
        Integral weight of the surface. [1/s]
    i_max : float, default 1e4
        Clamp of the error integral. [Pa s]
    base : CoreParams, optional
        Source of every other parameter. [-]

    Returns
    -------
    CoreParams
        With ``mode = MODE_SMC``.

    References
    ----------
    [mpam-characterization], eq. (5), (8), (12); signs corrected in docs/controller.md.
    """
    if model.gain > 0:
        base = with_supervisor_model(base, model)
    return replace(base, beta=float(beta), eps=float(eps), ki=float(ki), tau=float(model.tau),
                   g=float(model.gain), u0=float(model.lift_off), i_max=float(i_max), mode=MODE_SMC)


def with_supervisor_model(base: CoreParams, model: FirstOrderModel) -> CoreParams:
    """``base`` with the supervisor's valve model set from an identified model.

    The response rule of the stuck-sensor check (``docs/controller.md``, supervisor 3) predicts
    from ``p = G_s·(u − u0_s)`` whether the reading must move; it takes G and the lift-off of
    the identification whatever law runs (the paper's law included).

    Parameters
    ----------
    base : CoreParams
        Core parameters. [-]
    model : FirstOrderModel
        Identified model (G in Pa per PWM count, lift-off in counts). [-]

    Returns
    -------
    CoreParams
        With ``sup_g = G`` and ``sup_u0 = u0``.
    """
    return replace(base, sup_g=float(model.gain), sup_u0=float(model.lift_off))


def pid_params(design: PIDDesign, *, base: CoreParams = CoreParams()) -> CoreParams:
    """Core parameters of the PID mode from a :class:`PIDDesign`.

    Parameters
    ----------
    design : PIDDesign
        Designed gains. [-]
    base : CoreParams, optional
        Source of every other parameter. [-]
    """
    return replace(base, kp=design.kp, ki_pid=design.ki, kd=design.kd, tf=design.tf, mode=MODE_PID)


# --- controller objects -------------------------------------------------------------------------


class CoreLoopController:
    """One instance of the firmware core run from Python, in pressure units.

    ``step(measurement, reference)`` quantizes the measured pressure as the 10-bit ADC does,
    runs one core step (supervisor and law) and returns the signed command in PWM counts
    (inlet positive, bleed negative). The state is the core's (``self.core.istate``);
    :meth:`spec` gives the same controller to the batch simulator.

    Parameters
    ----------
    params : CoreParams
        Core parameters (mode chosen by the subclass). [-]
    """

    mode = MODE_SMC

    def __init__(self, params: CoreParams):
        self.params = replace(params, mode=self.mode)
        self.core = CoreController(self.params)
        self.faults = 0
        self.inlet = 0
        self.bleed = 0

    def reset(self) -> None:
        """Back to the initial state (integrals, filters and latched faults cleared)."""
        self.core = CoreController(self.params)
        self.faults = self.inlet = self.bleed = 0

    def step(self, measurement: float, reference: float, sample_ok: bool = True) -> int:
        """One control period.

        Parameters
        ----------
        measurement : float
            Measured gauge pressure. [Pa]
        reference : float
            Pressure reference (the supervisor clamps it to [0, p_max]). [Pa]
        sample_ok : bool, default True
            False when no sample arrived this period. [-]

        Returns
        -------
        int
            Signed command: inlet counts if ≥ 0, minus bleed counts if < 0. [PWM counts]
        """
        adc = adc_from_pressure(measurement, self.params.adc_zero, self.params.pa_per_count)
        self.inlet, self.bleed, self.faults = self.core.step(adc, sample_ok, reference)
        return self.inlet - self.bleed

    @property
    def surface(self) -> int:
        """Sliding surface S (SMC) or error e (PID) of the last step. [Pa]"""
        return self.core.surface_pa

    def spec(self, n: int = 1):
        """Controller spec for the batch simulator (``core_spec``).

        Parameters
        ----------
        n : int, default 1
            Number of identical instances. [-]
        """
        return core_spec(self.params, n)


class SlidingModeController(CoreLoopController):
    """The sliding-mode law of the core (mode 1). See :func:`smc_params` for the gains.

    Parameters
    ----------
    params : CoreParams
        Core parameters; the mode is set to sliding mode. [-]
    """

    mode = MODE_SMC


class PIDController(CoreLoopController):
    """The PID of the core (mode 2). See :func:`design_pid` for the gains.

    Parameters
    ----------
    params : CoreParams
        Core parameters; the mode is set to PID. [-]
    """

    mode = MODE_PID


def supervised(func: Callable, params: CoreParams = CoreParams()) -> Callable:
    """Put the core's supervisor below a plain Python controller.

    The returned callable has the simulator's slow-path signature ``g(t, adc, enc, p_ref) ->
    (inlet, bleed)``. Each call clamps ``p_ref`` to ``[0, p_max]``, asks ``func`` for its counts,
    then runs one core step in open-loop mode with those counts: the core's supervisor (ADC range
    and stuck-sensor faults, overpressure vent) decides what reaches the valves. ``g.faults``
    holds the last fault flags.

    Parameters
    ----------
    func : callable
        ``func(t, adc, enc, p_ref) -> (inlet, bleed)``, counts 0..255 (clipped). [s, count, count,
        Pa] -> [count]
    params : CoreParams, optional
        Supervisor settings (p_max, margin, ADC range, n_stuck, n_missing). [-]

    Returns
    -------
    callable
        The supervised controller.
    """
    ctl = CoreController(replace(params, mode=MODE_OPEN_LOOP))
    p_max = float(params.p_max)

    def g(t, adc, enc, p_ref, sample_ok=True):
        pr = min(max(float(p_ref), 0.0), p_max) if math.isfinite(float(p_ref)) else 0.0
        inlet, bleed = func(t, adc, enc, pr)
        ctl.set_open_loop(int(np.clip(inlet, 0, 255)), int(np.clip(bleed, 0, 255)))
        i, b, f = ctl.step(int(adc), bool(sample_ok), pr)
        g.faults = f
        return i, b

    g.faults = 0
    g.core = ctl
    return g


__all__ = [
    "FirstOrderModel", "PIDDesign", "design_pid", "smc_params", "pid_params", "with_supervisor_model",
    "adc_from_pressure",
    "CoreLoopController", "SlidingModeController", "PIDController", "supervised", "core",
]  # fmt: skip
