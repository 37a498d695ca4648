"""Pressure controllers: the firmware core with designed gains, and their design.

There is one control law, the firmware's (:mod:`mckibben.control.core`: sliding mode, PID and
the supervisor, fixed point, bit-exact with the C core). This module designs its gains from an
identified model and wraps one instance as an object with explicit state and a
``step(measurement, reference) -> command`` method:

- :func:`design_pid` (:mod:`mckibben.control.laws.pid`): lambda (IMC/SIMC) tuning of a PI(D) on
  the identified first-order model (:class:`FirstOrderModel`), checked with python-control;
- :func:`smc_params`, :func:`pid_params`: the laws' parameters (:mod:`mckibben.control.laws`)
  with the core's defaults as base;
- :class:`SlidingModeController`, :class:`PIDController`: one core instance each;
- :func:`supervised`: wraps a plain Python controller ``f(t, adc, enc, p_ref) -> (inlet, bleed)``
  so that its output goes through the same supervisor (the core in open-loop mode, the callable's
  counts as the open-loop command): no command path bypasses the pressure limit and the vent.

Commands are PWM counts of the Arduino's 8-bit timers: positive drives the inlet valve, negative
the bleed valve (``docs/controller.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from mckibben.control import core
from mckibben.control.bank import CoreController
from mckibben.control.core_params import CoreParams, core_spec
from mckibben.control.step import MODE_OPEN_LOOP, MODE_PID, MODE_SMC
from mckibben.control.first_order import FirstOrderModel
from mckibben.control.laws import pid, smc
from mckibben.control.laws import with_supervisor_model  # noqa: F401  (re-exported)
from mckibben.control.laws.pid import PIDDesign, design_pid
from mckibben.hardware import adc_from_pressure  # noqa: F401  (re-exported: the one sensor model)


# --- design (the controllers' own, control/laws/; here with the core's defaults as base) ----------


def smc_params(model: FirstOrderModel, beta: float, eps: float, ki: float, *, i_max: float = 1e4,
               base: CoreParams = CoreParams()) -> CoreParams:
    """Core parameters of the sliding-mode law: :func:`mckibben.control.laws.smc.from_gains`, base defaulted.

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
        Source of every other parameter; default the core's defaults. [-]

    Returns
    -------
    CoreParams
        With ``mode = MODE_SMC``.

    References
    ----------
    [mpam-characterization], eq. (5), (8), (12); signs corrected in docs/controller.md.
    """
    return smc.from_gains(model, beta, eps, ki, i_max=i_max, base=base)


def pid_params(design: PIDDesign, *, base: CoreParams = CoreParams()) -> CoreParams:
    """Core parameters of the PID mode from a :class:`PIDDesign`: :func:`mckibben.control.laws.pid.from_design`.

    Parameters
    ----------
    design : PIDDesign
        Designed gains. [-]
    base : CoreParams, optional
        Source of every other parameter; default the core's defaults. [-]
    """
    return pid.from_design(design, base=base)


#: The sliding-mode variants (:data:`mckibben.control.laws.smc.VARIANTS`): ``model`` is ours,
#: ``paper`` the law as the paper ran it.
SMC_LAWS = smc.VARIANTS

#: Our sliding-mode design (law ``model``; ``docs/control.md`` says how it was chosen): with the
#: model term carrying the holding command, a small switching gain suffices (the registry's
#: design ``model`` of ``smc``).
SMC_TUNING = dict(smc.DESIGNS["model"])
#: The paper's law (``paper``): β is the paper's (120 or 150; 150 by default, the registry's
#: design ``paper``); ε and Ki are ours, chosen so that the integral brings the β = 120 step to
#: its target within Fig. 13's second.
PAPER_SMC_TUNING = {k: v for k, v in smc.DESIGNS["paper"].items() if k != "beta"}


def smc_core_params(model: FirstOrderModel, beta: float | None = None, *, law: str = "model",
                    eps: float | None = None, ki: float | None = None,
                    base: CoreParams = CoreParams()) -> CoreParams:
    """Sliding-mode core parameters of one variant with its documented design, base defaulted.

    :func:`mckibben.control.laws.smc.variant_params` with the core's defaults as ``base``.

    Parameters
    ----------
    model : FirstOrderModel
        Identified model (used by the ``model`` law only). [-]
    beta : float, optional
        Switching gain; default the law's documented design. [PWM counts]
    law : {"model", "paper"}, default "model"
        Sliding-mode variant (:data:`SMC_LAWS`). [-]
    eps : float, optional
        Boundary layer; default from the law's tuning. [Pa]
    ki : float, optional
        Surface integral weight; default from the law's tuning. [1/s]
    base : CoreParams, optional
        Supervisor and other settings. [-]

    Returns
    -------
    CoreParams
        With ``mode = MODE_SMC``; ``g = 0`` for the ``paper`` law.
    """
    return smc.variant_params(model, beta, law=law, eps=eps, ki=ki, base=base)


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
    "PAPER_SMC_TUNING", "SMC_LAWS", "SMC_TUNING", "smc_core_params",
    "FirstOrderModel", "PIDDesign", "design_pid", "smc_params", "pid_params", "with_supervisor_model",
    "adc_from_pressure",
    "CoreLoopController", "SlidingModeController", "PIDController", "supervised", "core",
]  # fmt: skip
