"""The identified first-order model of a pressure plant, ``ṗ = (G·(u − u0) − p)/τ`` (plus a dead time).

What identification (:func:`mckibben.control.identify_plant`) returns and every controller
design (:mod:`mckibben.control.laws`) reads. It sits below the controllers and the core so that
a controller file can take it without importing what is built on the registry.

References
----------
[mpam-characterization], §IV.A (the first-order model of a voltage step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from mckibben.errors import InputError

if TYPE_CHECKING:  # python-control costs ~0.8 s at import: imported where an LTI object is built
    import control


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
