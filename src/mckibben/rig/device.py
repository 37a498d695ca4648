"""The device over its serial link, from Python: ``Device(port).step(target)``.

:class:`Device` opens the port (a real Arduino Mega or ``mckibben rig emulate``'s pty; any URL
pyserial's ``serial_for_url`` takes) at :data:`BAUD` and runs experiments on it; each returns a
result object (:mod:`mckibben.results`). ``mckibben rig step`` is one call of :meth:`Device.step`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from mckibben.control import registry as R
from mckibben.errors import ArgumentTypeError, InputError
from mckibben.hardware import BAUD
from mckibben.hardware import ADC_MAX, P_MAX_DEFAULT, pressure_from_adc
from mckibben.results import Result, TimeResponse
from mckibben.rig import protocol as P
from mckibben.control.core import GAINS, gain_values
from mckibben.control.metrics import step_metrics
from mckibben.results import to_jsonable
from mckibben.units import si
from mckibben.control.core import CoreParams, load_design

__all__ = ["BAUD", "SAFE_MAX_PRESSURE_PA", "Device", "ForceResult", "GainsResult", "RigStepResult", "TareResult",
           "connect", "end_session", "open_port", "write_gains"]

#: How long :func:`connect` waits for the firmware's HELLO after opening the port: a Mega resets
#: on open and its bootloader listens for 1-2 s before the firmware starts. [s]
HELLO_TIMEOUT_S = 4.0
#: The paper's safe limit: no step above it is sent to the device. [Pa]
SAFE_MAX_PRESSURE_PA = float(P_MAX_DEFAULT)
#: How long :meth:`Device.step` waits for the first telemetry frame. [s]
STARTUP_TIMEOUT_S = 10.0
#: Most load-cell samples :meth:`Device.tare` and :meth:`Device.read_force` take (10 s at 1 kHz). [-]
MAX_FORCE_SAMPLES = 10_000
#: Control periods between a streaming host's commands, and the telemetry decimation it asks for
#: beside them: the firmware image's measured ceiling (``docs/firmware.md``, "Command rate"). With
#: three channels in closed loop at 1 kHz, SET_POINTS every 2 ms beside telemetry at decimation 2
#: all arrive and are ACKed; at 1 ms (or at decimation 1) the 16 MHz Mega runs out of cycles.
PACED_PERIODS = 2
#: How long a session's last commands (:func:`end_session`) are given to reach the device before its port is
#: closed: a few of the firmware's 1 ms command polls and the line's time for them. [s]
CLOSE_WAIT = 0.05


def open_port(port: str, timeout: float = 0.02):
    """Open the serial link at :data:`BAUD`; a port that cannot be opened is an :class:`InputError`.

    Parameters
    ----------
    port : str
        Device path or pyserial URL. [-]
    timeout : float, default 0.02
        Read timeout. [s]
    """
    import serial  # deferred on purpose: pyserial (only the rig's commands)

    try:
        return serial.serial_for_url(port, baudrate=BAUD, timeout=timeout)
    except (serial.SerialException, ValueError, OSError) as exc:
        raise InputError(f"port: cannot open {port!r} ({exc})") from None


def connect(port: str, hello_timeout: float | None = None, timeout: float = 0.02):
    """Open the link and wait for the firmware's HELLO frame; return ``(link, hello, parser)``.

    Opening the port of a Mega resets it into its bootloader, which swallows whatever arrives
    for about a second; the firmware announces itself with a HELLO frame once it runs. Bytes
    that arrive before it (a previous session's frames) are discarded, so nothing the caller
    sends is lost and nothing it reads is stale.

    Parameters
    ----------
    port : str
        Device path or pyserial URL. [-]
    hello_timeout : float, optional
        How long to wait for HELLO; default :data:`HELLO_TIMEOUT_S`. [s]
    timeout : float, default 0.02
        Read timeout of the link. [s]

    Raises
    ------
    InputError
        The port cannot be opened, or no HELLO arrives in time (not a mckibben device, or one
        running firmware older than protocol version 2).
    """
    hello_timeout = HELLO_TIMEOUT_S if hello_timeout is None else float(hello_timeout)
    link = open_port(port, timeout)
    parser = P.Parser()
    try:
        link.reset_input_buffer()
        end = time.monotonic() + hello_timeout
        while time.monotonic() < end:
            for f in parser.feed(link.read(4096)):
                if isinstance(f, P.Hello):
                    # a fresh parser: counters start at the hello; it reads force with the device's full scale
                    return link, f, P.Parser(load_cell=f.load_cell)
    except BaseException:
        link.close()
        raise
    link.close()
    raise InputError(f"port: no HELLO frame from {port!r} within {hello_timeout:g} s after opening it; is it a "
                     f"mckibben device running firmware with protocol version {P.VERSION}?")


#: Commands in flight at once: the firmware's receive ring holds 256 bytes and SET_GAIN takes it
#: ~1 ms to compute, while the line brings 100 bytes per ms; and its 256-byte transmit queue
#: drops an ACK that does not fit.
WINDOW = 4


def end_session(link, seq: int) -> None:
    """Leave the device safe at the end of a session that pressurized it: set-points 0, controllers off, vented.

    Sends streaming off, the controller off on every channel, then VENT on every channel (the vent is
    latched until the next SET_MODE, so it is sent last: sent before, the mode change clears it and
    "off" shuts both valves on the air, the muscle stays pressurized), flushes the link and waits
    :data:`CLOSE_WAIT` for the firmware to read them (a port closed at once loses them, and the
    controller goes on holding its last set-point). Best effort: a link already gone is left alone.

    Parameters
    ----------
    link : serial.Serial
        The open link (the caller closes it). [-]
    seq : int
        The first sequence number to use (three are used). [-]
    """
    try:
        seqs = [(seq + k) & 0xFFFF for k in range(3)]
        for pkt in (P.stream(seqs[0], False, 1), P.set_mode(seqs[1], P.MODES["off"], P.ALL), P.vent(seqs[2], P.ALL)):
            link.write(pkt)
        link.flush()
        time.sleep(CLOSE_WAIT)
    except Exception:  # the link may be gone (a device unplugged): nothing more can be sent
        pass


def command(link, parser: P.Parser, packets, timeout: float = 2.0, on_frame=None) -> list:
    """Send commands, at most :data:`WINDOW` unacknowledged at a time; return their ACKs in order.

    Parameters
    ----------
    link : serial.Serial
        The open link. [-]
    parser : Parser
        The link's parser (other frames arriving meanwhile go to ``on_frame``). [-]
    packets : list of (int, bytes)
        ``(seq, packet)`` pairs. [-]
    timeout : float, default 2.0
        How long to wait for each window's ACKs. [s]
    on_frame : callable, optional
        Called with every other frame. [-]
    """
    acks: dict = {}
    for i in range(0, len(packets), WINDOW):
        window = packets[i:i + WINDOW]
        want = {seq for seq, _ in window}
        for _, pkt in window:
            link.write(pkt)
        end = time.monotonic() + timeout
        while want - set(acks) and time.monotonic() < end:
            for f in parser.feed(link.read(4096)):
                if isinstance(f, P.Ack) and f.cmd_seq in want:
                    acks[f.cmd_seq] = f
                elif on_frame is not None:
                    on_frame(f)
        if want - set(acks):
            raise InputError(f"port: the device did not acknowledge {len(want - set(acks))} commands within "
                             f"{timeout:g} s")
    return [acks[seq] for seq, _ in packets]


@dataclass(frozen=True, repr=False)
class GainsResult(Result):
    """Gains sent to the device's channels and read back.

    Attributes
    ----------
    gains : dict
        Gain name -> the SET_GAIN integer sent (``mckibben.control.core.GAINS``). [-]
    read_back : dict
        Channel -> gain name -> the integer the device reports. [-]
    arguments : dict
        Port, channels, design file, p_max [Pa]. [-]
    """

    gains: dict
    read_back: dict
    arguments: dict = field(default_factory=dict)
    call = "mckibben.rig.Device.set_gains"

    @property
    def verified(self) -> bool:
        """Every channel reports exactly the gains sent."""
        return all(rb == self.gains for rb in self.read_back.values())

    @property
    def metrics(self) -> dict:
        """Channels written and whether the read-back matched."""
        return {"channels": len(self.read_back), "gains_per_channel": len(self.gains), "verified": self.verified}

    def to_dict(self) -> dict:
        """JSON-ready: the gains, the read-back per channel, and the verdict."""
        return {**self.arguments, "gains": self.gains, "read_back": {str(k): v for k, v in self.read_back.items()},
                "verified": self.verified}

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        rows = [{"channel": ch, "gain": name, "sent": self.gains[name], "read_back": v}
                for ch, got in self.read_back.items() for name, v in got.items()]
        return pd.DataFrame(rows)

    def plot(self, ax=None):
        """Nothing to draw: raises ``NotImplementedError``."""
        raise NotImplementedError("GainsResult has no plot")


@dataclass(frozen=True, repr=False)
class RigStepResult(Result, TimeResponse):
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
        Port, target [Pa], controller, duration [s], and with a load cell the tare subtracted [N].
    counters : dict
        Frames received and missing. [-]
    force : numpy.ndarray or None
        The load cell's force, tared (:meth:`Device.tare`); None when the device has no load cell. [N]
    """

    time: np.ndarray
    pressure: np.ndarray
    reference: np.ndarray
    command: np.ndarray
    step_time: float
    arguments: dict = field(default_factory=dict)
    counters: dict = field(default_factory=dict)
    force: np.ndarray | None = None
    call = "mckibben.rig.Device.step"
    TIME = "time"
    SIGNALS = ("reference", "pressure", "command", "force")

    @property
    def metrics(self) -> dict:
        """Step metrics (:func:`mckibben.control.metrics.step_metrics`), SI."""

        return step_metrics(self.time, self.pressure, self.reference, self.command, t_step=self.step_time)

    @property
    def final_force(self) -> float | None:
        """Mean tared force over the last 50 ms of the recording; None without a load cell. [N]"""
        if self.force is None or not len(self.force):
            return None
        return float(np.mean(self.force[self.time >= self.time[-1] - 0.05]))

    def to_dict(self) -> dict:
        """The target, controller, metrics and frame counters, JSON-ready; with a load cell the final
        force (``force_N``, tared) and the tare subtracted (``force_offset_N``)."""

        out = {"target_Pa": self.arguments["target_Pa"], "controller": self.arguments["controller"], **self.metrics,
               **self.counters}
        if self.force is not None:
            out.update(force_N=self.final_force, force_offset_N=self.arguments.get("force_offset_N", 0.0))
        return to_jsonable(out)

    def _series(self):
        return self.frame()  # force_N only with a load cell (recorded_signals leaves a None out)

    def plot(self, ax=None):
        """Pressure and set-point against time; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        ax.plot(self.time, self.reference / 1e6, "k--", lw=1, label="set-point")
        ax.plot(self.time, self.pressure / 1e6, label=f"{self.arguments.get('controller', '')} (device)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("pressure [MPa]")
        ax.legend()
        return ax.figure


@dataclass(frozen=True, repr=False)
class ForceResult(Result, TimeResponse):
    """Load-cell readings taken on the device (:meth:`Device.tare`, :meth:`Device.read_force`).

    Attributes
    ----------
    time : numpy.ndarray
        Device time of each telemetry frame. [s]
    force : numpy.ndarray
        The force each frame read, untared (the count times the device's resolution). [N]
    offset : float
        The tare subtracted in :attr:`metrics` (after :meth:`Device.tare`: the mean it measured). [N]
    arguments : dict
        Port, samples, the device's full scale [N]. [-]
    """

    time: np.ndarray
    force: np.ndarray
    offset: float = 0.0
    arguments: dict = field(default_factory=dict)
    call = "mckibben.rig.Device.read_force"
    _repr_keys = ("force_N", "force_std_N", "offset_N", "samples")
    TIME = "time"
    SIGNALS = ("force",)

    @property
    def metrics(self) -> dict:
        """``force_N``: the mean force less the tare; ``force_std_N``: the samples' standard deviation;
        ``offset_N``: the tare; ``resolution_N``: force per count; ``samples``."""
        fs = float(self.arguments.get("full_scale_N", 0.0))
        return {"force_N": float(np.mean(self.force)) - self.offset, "force_std_N": float(np.std(self.force)),
                "offset_N": float(self.offset), "resolution_N": fs / ADC_MAX, "samples": int(len(self.force))}

    def _series(self):
        df = self.frame()  # the readings as read; the table holds them tared
        df["force_N"] -= self.offset
        return df

    def plot(self, ax=None):
        """The tared force against time; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        ax.plot(self.time, self.force - self.offset)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("force [N]")
        return ax.figure


@dataclass(frozen=True, repr=False)
class TareResult(ForceResult):
    """The readings :meth:`Device.tare` averaged; ``offset`` is the tare it keeps (their mean). [N]"""

    call = "mckibben.rig.Device.tare"


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
    ...     res = Device(em.port).step(0.4e6, duration=0.5)
    """

    def __init__(self, port: str):
        if not isinstance(port, str) or not port:
            raise ArgumentTypeError(f"port = {port!r}: want the serial port's path (text), e.g. /dev/ttyACM0")
        self.port = port
        #: The load cell's tare, subtracted from every force this object reports (:meth:`tare`). [N]
        self.force_offset = 0.0

    def _force_samples(self, samples, name: str = "samples") -> tuple[np.ndarray, np.ndarray, float]:
        """``samples`` telemetry frames' device times [s] and forces [N], and the full scale [N]."""
        if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) \
                or not 1 <= int(samples) <= MAX_FORCE_SAMPLES:
            raise InputError(f"{name}: {samples!r} must be a whole number of samples in 1..{MAX_FORCE_SAMPLES}")
        n = int(samples)
        link, hello, parser = connect(self.port)
        t: list = []
        f: list = []
        try:
            if hello.load_cell is None:
                raise InputError(f"port: the device on {self.port!r} has no load cell (its HELLO announces none; "
                                 "build the firmware with LOAD_CELL_MN, docs/firmware.md)")
            link.write(P.stream(0, True, 1))
            deadline = time.monotonic() + STARTUP_TIMEOUT_S + 3.0 * n * 1e-3
            while len(f) < n and time.monotonic() < deadline:
                for fr in parser.feed(link.read(8192)):
                    if isinstance(fr, P.Telemetry) and fr.force is not None and len(f) < n:
                        t.append(fr.t_us * 1e-6)
                        f.append(fr.force)
            link.write(P.stream(1, False, 1))
        finally:
            link.close()
        if len(f) < n:
            raise InputError(f"port: only {len(f)} of {n} load-cell samples arrived from {self.port!r}")
        return np.asarray(t), np.asarray(f), float(hello.load_cell)

    def tare(self, samples: int = 200) -> ForceResult:
        """Zero the load cell: the mean of ``samples`` readings at zero load becomes the offset that
        :meth:`read_force` and :meth:`step` subtract from then on.

        Take it with nothing hanging on the cell and the muscle vented (opening the port resets
        the device: its controllers start off, valves shut).

        Parameters
        ----------
        samples : int, default 200
            Telemetry frames to average (1 kHz), 1..:data:`MAX_FORCE_SAMPLES`. [-]

        Returns
        -------
        TareResult
            The readings; its ``offset`` (``metrics["offset_N"]``) is the new tare, its
            ``force_N`` 0 by construction.

        Raises
        ------
        InputError
            A bad ``samples``, a device without a load cell, or one that stops streaming.
        """
        t, f, fs = self._force_samples(samples)
        self.force_offset = float(np.mean(f))
        return TareResult(t, f, self.force_offset, {"port": self.port, "samples": int(samples), "full_scale_N": fs})

    def read_force(self, samples: int = 50) -> ForceResult:
        """Read the load cell: ``samples`` readings, less the tare (:meth:`tare`).

        Parameters
        ----------
        samples : int, default 50
            Telemetry frames to average (1 kHz), 1..:data:`MAX_FORCE_SAMPLES`. [-]

        Returns
        -------
        ForceResult
            ``metrics["force_N"]`` is the mean tared force. [N]

        Raises
        ------
        InputError
            A bad ``samples``, a device without a load cell, or one that stops streaming.
        """
        t, f, fs = self._force_samples(samples)
        return ForceResult(t, f, self.force_offset, {"port": self.port, "samples": int(samples), "full_scale_N": fs})

    def __repr__(self) -> str:
        return f"Device({self.port!r})"

    def step(self, target=0.55e6, controller: str = "smc", duration=1.0) -> RigStepResult:
        """Run a pressure step on the device: hold 0 Pa for 0.1 s, then ``target``; record it.

        Parameters
        ----------
        target : float, default 0.55e6
            Set-point of the step, at most :data:`SAFE_MAX_PRESSURE_PA`. [Pa]
        controller : str, default "smc"
            The device's pressure controller, a name of the controller registry
            (:data:`mckibben.control.registry.NAMES`: ``"smc"``, ``"pid"`` and the extension laws). [-]
        duration : float, default 1.0
            Recording time after the step, at most 60 s. [s]

        Returns
        -------
        RigStepResult
            The telemetry and its step metrics.
        """

        p = si(target, "pressure", "target", allow_zero=False)
        if p > SAFE_MAX_PRESSURE_PA:
            raise InputError(f"target: {target!r} is above the {SAFE_MAX_PRESSURE_PA / 1e6:g} MPa safe limit")
        if controller not in R.NAMES:
            raise InputError(f"controller: {controller!r} must be one of {', '.join(R.NAMES)}")  # the registry's
        d = si(duration, "time", "duration", allow_zero=False)
        if d > 60:
            raise InputError(f"duration: {duration!r} is longer than 60 s")
        link, _, parser = connect(self.port)
        rows: list = []
        acks: list = []
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
                                     f.inlet_pwm - f.bleed_pwm, f.faults,
                                     np.nan if f.force is None else f.force - self.force_offset))
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
        finally:
            end_session(link, 4)
            link.close()
        bad = [a for a in acks if a.status != 0]
        if bad:
            raise InputError(f"the device refused command type 0x{bad[0].cmd_type:02x} (status {bad[0].status})")
        if len(rows) < 50:
            raise InputError(f"port: only {len(rows)} telemetry frames arrived from {self.port!r}; "
                             "is it a mckibben device?")
        a = np.array(rows, dtype=float)
        if t_step is None:
            raise InputError(f"port: {self.port!r} stopped streaming before the step to {p:g} Pa took effect "
                             f"({len(rows)} frames, {a[-1, 0] - a[0, 0]:.3f} s of device time)")
        faults = int(np.bitwise_or.reduce(a[:, 4].astype(np.int64)))
        args = {"port": self.port, "target_Pa": p, "controller": controller, "duration_s": d}
        force = None if np.isnan(a[:, 5]).any() else a[:, 5]
        if force is not None:
            args["force_offset_N"] = self.force_offset
        return RigStepResult(a[:, 0], a[:, 1], a[:, 2], a[:, 3], float(t_step), args,
                             {"frames": parser.frames, "missing": parser.missing, "faults": faults}, force)

    def set_gains(self, design, channels=None) -> GainsResult:
        """Send a controller design to the device's channels, read every gain back and compare.

        Parameters
        ----------
        design : CoreParams or str or os.PathLike
            The design, or a design file (:func:`mckibben.control.core.save_design`). [-]
        channels : sequence of int, optional
            Channels to write; default every channel the device announces. [-]

        Returns
        -------
        GainsResult
            What was sent and what each channel reports; ``verified`` when they agree.

        Raises
        ------
        InputError
            A bad design, a channel the device does not have, or a refused command.
        """

        params = design if isinstance(design, CoreParams) else load_design(design, "design")
        link, hello, parser = connect(self.port)
        try:
            return write_gains(link, parser, hello, params, channels, self.port)
        finally:
            link.close()


def write_gains(link, parser: P.Parser, hello: P.Hello, params, channels=None, port: str = "",
                first_seq: int = 0) -> GainsResult:
    """:meth:`Device.set_gains` on a link already open (after :func:`connect`).

    Parameters
    ----------
    link : serial.Serial
        The open link. [-]
    parser : Parser
        Its parser. [-]
    hello : Hello
        The device's HELLO. [-]
    params : CoreParams
        The design. [-]
    channels : sequence of int, optional
        Channels to write; default all. [-]
    port : str, optional
        For the result. [-]
    first_seq : int, default 0
        Sequence number of the first command. [-]
    """

    values = gain_values(params)
    chans = list(range(hello.n_channels)) if channels is None else [int(c) for c in channels]
    bad = [c for c in chans if not 0 <= c < hello.n_channels]
    if bad:
        raise InputError(f"channel: {bad[0]} is not a channel of the device (0..{hello.n_channels - 1})")
    seq = first_seq
    packets = []
    for c in chans:
        for g in GAINS:
            packets.append((seq, P.set_gain(seq, g.id, int(values[g.id]), c)))
            seq += 1
        packets.append((seq, P.set_max_pressure(seq, params.p_max, c)))
        seq += 1
    acks = command(link, parser, packets)
    refused = [a for a in acks if a.status != 0]
    if refused:
        raise InputError(f"the device refused command type 0x{refused[0].cmd_type:02x} (status {refused[0].status})")
    reads = []
    for c in chans:
        for g in GAINS:
            reads.append((seq, P.get_gain(seq, g.id, c)))
            seq += 1
    acks = command(link, parser, reads)
    read_back: dict = {}
    k = 0
    for c in chans:
        read_back[c] = {}
        for g in GAINS:
            read_back[c][g.name] = int(acks[k].value)
            k += 1
    return GainsResult({g.name: int(values[g.id]) for g in GAINS}, read_back,
                       {"port": port, "channels": chans, "p_max_Pa": float(params.p_max)})
