"""The device over its serial link, from Python: ``Device(port).step(target)``.

:class:`Device` opens the port (a real Arduino Mega or ``mckibben rig emulate``'s pty; any URL
pyserial's ``serial_for_url`` takes) at :data:`BAUD` and runs experiments on it; each returns a
result object (:mod:`mckibben.results`). ``mckibben rig step`` is one call of :meth:`Device.step`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from mckibben.errors import InputError
from mckibben.hardware import P_MAX_DEFAULT, pressure_from_adc
from mckibben.results import Result
from mckibben.rig import protocol as P

__all__ = ["BAUD", "SAFE_MAX_PRESSURE_PA", "Device", "RigStepResult", "open_port"]

#: Baud rate of the serial link (``docs/protocol.md``).
BAUD = 500000
#: The paper's safe limit: no step above it is sent to the device. [Pa]
SAFE_MAX_PRESSURE_PA = float(P_MAX_DEFAULT)
#: How long :meth:`Device.step` waits for the first telemetry frame. [s]
STARTUP_TIMEOUT_S = 10.0
#: The device's controllers by name (:data:`mckibben.rig.protocol.MODES`).
CONTROLLERS = ("smc", "pid")


def open_port(port: str, timeout: float = 0.02):
    """Open the serial link at :data:`BAUD`; a port that cannot be opened is an :class:`InputError`.

    Parameters
    ----------
    port : str
        Device path or pyserial URL. [-]
    timeout : float, default 0.02
        Read timeout. [s]
    """
    import serial

    try:
        return serial.serial_for_url(port, baudrate=BAUD, timeout=timeout)
    except (serial.SerialException, ValueError, OSError) as exc:
        raise InputError(f"--port: cannot open {port!r} ({exc})") from None


@dataclass(frozen=True, repr=False)
class RigStepResult(Result):
    """A pressure step measured on the device.

    Attributes
    ----------
    time : numpy.ndarray
        Device time of each telemetry frame. [s]
    pressure : numpy.ndarray
        Measured pressure (ADC counts scaled to the sensor's range). [Pa]
    reference : numpy.ndarray
        The controller's set-point. [Pa]
    command : numpy.ndarray
        Inlet − bleed. [PWM counts]
    step_time : float
        Time of the step. [s]
    arguments : dict
        Port, target [Pa], controller, duration [s].
    counters : dict
        Frames received and missing. [-]
    """

    time: np.ndarray
    pressure: np.ndarray
    reference: np.ndarray
    command: np.ndarray
    step_time: float
    arguments: dict = field(default_factory=dict)
    counters: dict = field(default_factory=dict)
    call = "mckibben.rig.Device.step"

    @property
    def metrics(self) -> dict:
        """Step metrics (:func:`mckibben.control.metrics.step_metrics`), SI."""
        from mckibben.control.metrics import step_metrics

        return step_metrics(self.time, self.pressure, self.reference, self.command, t_step=self.step_time)

    def to_dict(self) -> dict:
        """The target, controller, metrics and frame counters, JSON-ready."""
        from mckibben.results import to_jsonable

        return to_jsonable({"target_Pa": self.arguments["target_Pa"], "controller": self.arguments["controller"],
                            **self.metrics, **self.counters})

    def _series(self):
        import pandas as pd

        return pd.DataFrame({"time_s": self.time, "reference_Pa": self.reference, "pressure_Pa": self.pressure,
                             "command_pwm": self.command})

    def plot(self, ax=None):
        """Pressure and set-point against time; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        ax.plot(self.time, self.reference / 1e6, "k--", lw=1, label="set-point")
        ax.plot(self.time, self.pressure / 1e6, label=f"{self.arguments.get('controller', '')} (device)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("pressure [MPa]")
        ax.legend()
        return ax.figure


class Device:
    """The rig's controller over a serial link.

    Parameters
    ----------
    port : str
        Serial port of the device or emulator (e.g. ``/dev/ttyACM0``). [-]

    Examples
    --------
    >>> from mckibben.rig import Device, Emulator   # doctest: +SKIP
    >>> with Emulator() as em:                       # doctest: +SKIP
    ...     res = Device(em.port).step("0.4MPa", duration=0.5)
    """

    def __init__(self, port: str):
        self.port = port

    def __repr__(self) -> str:
        return f"Device({self.port!r})"

    def step(self, target="0.55MPa", controller: str = "smc", duration=1.0) -> RigStepResult:
        """Run a pressure step on the device: hold 0 Pa for 0.1 s, then ``target``; record it.

        Parameters
        ----------
        target : float or str, default "0.55MPa"
            Set-point of the step, at most :data:`SAFE_MAX_PRESSURE_PA`. [Pa]
        controller : {"smc", "pid"}, default "smc"
            The device's pressure controller. [-]
        duration : float or str, default 1.0
            Recording time after the step, at most 60 s. [s]

        Returns
        -------
        RigStepResult
            The telemetry and its step metrics.
        """
        from mckibben.units import quantity

        p = quantity(target, "pressure", "--target", allow_zero=False)
        if p > SAFE_MAX_PRESSURE_PA:
            raise InputError(f"--target: {target!r} is above the 0.8 MPa safe limit")
        if controller not in CONTROLLERS:
            raise InputError(f"--controller: {controller!r} must be smc or pid")
        d = quantity(duration, "time", "--duration", allow_zero=False)
        if d > 60:
            raise InputError(f"--duration: {duration!r} is longer than 60 s")
        link = open_port(self.port)
        parser = P.Parser()
        rows = []
        acks = []
        try:
            for pkt in (P.set_point(0, 0), P.set_mode(1, P.MODES[controller]), P.stream(2, True, 1)):
                link.write(pkt)
            # The hold and the recording follow the device's clock (telemetry time), not the
            # host's: a busy host, or a device that takes a moment to start, must not cut the
            # step short. The wall clock only bounds a device that stops streaming.
            deadline = time.monotonic() + STARTUP_TIMEOUT_S + 3.0 * (d + 0.1)
            sent = False
            t_step = None  # device time of the first frame that reports the new set-point
            while time.monotonic() < deadline:
                for f in parser.feed(link.read(8192)):
                    if isinstance(f, P.Telemetry):
                        rows.append((f.t_us * 1e-6, pressure_from_adc(f.pressure_adc).item(), f.reference_pa,
                                     f.inlet_pwm - f.bleed_pwm))
                        if t_step is None and sent and f.reference_pa > 0:
                            t_step = rows[-1][0]
                    elif isinstance(f, P.Ack):
                        acks.append(f)
                if not rows:
                    continue
                if not sent and rows[-1][0] - rows[0][0] >= 0.1:
                    link.write(P.set_point(3, p))
                    sent = True
                elif t_step is not None and rows[-1][0] - t_step >= d:
                    break
            link.write(P.stream(4, False, 1))
            link.write(P.set_mode(5, 0))
        finally:
            link.close()
        bad = [a for a in acks if a.status != 0]
        if bad:
            raise InputError(f"the device refused command type 0x{bad[0].cmd_type:02x} (status {bad[0].status})")
        if len(rows) < 50:
            raise InputError(f"--port: only {len(rows)} telemetry frames arrived from {self.port!r}; "
                             "is it a mckibben device?")
        a = np.array(rows, dtype=float)
        if t_step is None:
            raise InputError(f"--port: {self.port!r} stopped streaming before the step to {p:g} Pa took effect "
                             f"({len(rows)} frames, {a[-1, 0] - a[0, 0]:.3f} s of device time)")
        return RigStepResult(a[:, 0], a[:, 1], a[:, 2], a[:, 3], float(t_step),
                             {"port": self.port, "target_Pa": p, "controller": controller, "duration_s": d},
                             {"frames": parser.frames, "missing": parser.missing})
