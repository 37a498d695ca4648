"""A virtual Arduino on a pseudo-terminal: the protocol, the firmware core, N plants, in real time.

The emulator opens a pty pair and behaves like the device at the other end of the serial link:
it runs the controller core of every channel (:class:`mckibben.control.core.CoreBank`,
bit-exact with ``firmware/core``, shared supply check included) at 1 kHz on one plant per
channel (:class:`mckibben.plant.PlantStepper`), answers every command with an ACK, and streams
telemetry frames. Like the device it is honest about time and the link:

- **Reset on open.** A Mega resets when the host opens its port (DTR). The emulator watches its
  pty: whenever a process opens the port after nobody had it open, the device resets — every
  channel's controller back to its defaults and off, streaming off — and for ``boot_time`` the
  bootloader swallows whatever arrives; then the firmware sends its HELLO frame.
- **A clock that follows wall time.** The control periods that are due run whether or not
  anyone reads. Frames go through a UART model: a 256-byte transmit queue drained at the line
  rate (``baud``/10 bytes per second) into the pty; a frame that does not fit the queue is
  dropped whole and counted (``dropped``), and its sequence number is spent, so a host sees the
  gap, as with the firmware.
- **An incremental encoder.** Channel 0's length is counted from where the muscle was at the
  last reset (the firmware's count starts at 0 there), as on the Mega and in the avr harness.
- **A load cell, when fitted** (``load_cell``): channel 0's muscle tension (the plant's pulling
  force) read through :class:`mckibben.hardware.LoadCell` once per period, streamed in TELEMETRY
  and announced in HELLO, as the firmware built with ``LOAD_CELL_MN`` does.
"""

from __future__ import annotations

import os
import select
import struct
import threading
import time
import socket
import tty

import numpy as np

from mckibben import hardware as HW
from mckibben.plant import physics as ph
from mckibben.rig import protocol as P
from mckibben.control.core import CoreParams
from mckibben.errors import InputError
from mckibben.control.core import CoreBank
from mckibben.plant import PlantStepper
from mckibben.plant import params as PP
from mckibben.plant import physics as PH
from mckibben.rig import bench as B
from mckibben.control.core import IP_GAIN0, N_GAINS

#: The firmware's transmit ring (``TX_SIZE`` in firmware/src/main.c). [bytes]
TX_QUEUE = 256


class Emulator:
    """The virtual device. ``start()`` runs it in a thread; ``port`` is the path to open.

    Parameters
    ----------
    plant : PlantParams or sequence of PlantParams, optional
        The rig of every channel, or one per channel; default the calibrated one.
    controller : CoreParams, optional
        The cores' parameters after a reset (mode, gains, limits); default the firmware's.
    n_channels : int, default 3
        Channels of the device (1..3), as ``MCK_N_CHANNELS`` of the firmware.
    ts : float, default 1e-3
        Control period. [s]
    wake : float, default 0.002
        How often the emulator wakes to run the due periods. [s]
    baud : int, default 1000000
        Line rate of the UART model. [1/s]
    boot_time : float, default 0.3
        How long the bootloader holds after a reset before the firmware runs (a Mega: 1-2 s). [s]
    garbage_every : int, default 0
        Insert a burst of garbage after every k-th telemetry frame (0: never). [-]
    cut_every : int, default 0
        Send only the first half of every k-th telemetry frame (0: never); that frame is lost. [-]
    hold_adc : int, optional
        Channel 0's ADC reads this count whatever the pressure: a stuck sensor. [count]
    load_cell : LoadCell, optional
        A load cell on channel 0's muscle (:class:`mckibben.hardware.LoadCell`); None: none fitted. [-]
    """

    def __init__(self, plant=None, controller=None, n_channels: int = 3, ts: float = 1e-3, wake: float = 0.002,
                 baud: int = 1_000_000, boot_time: float = 0.3, garbage_every: int = 0, cut_every: int = 0,
                 hold_adc: int | None = None, load_cell: HW.LoadCell | None = None):

        if not 1 <= int(n_channels) <= P.MAX_CHANNELS:
            raise InputError(f"Emulator: n_channels {n_channels!r} must be 1..{P.MAX_CHANNELS}")
        self.n = int(n_channels)
        plants = list(plant) if isinstance(plant, (list, tuple)) else [plant] * self.n
        if len(plants) != self.n:
            raise InputError(f"Emulator: {len(plants)} plants for {self.n} channels")
        self._plant_params = plants
        self._controller = controller or CoreParams(mode=0)
        self.ts, self.wake, self.baud, self.boot_time = ts, wake, int(baud), float(boot_time)
        self.garbage_every, self.cut_every = garbage_every, cut_every
        self.hold_adc = None if hold_adc is None else int(hold_adc)
        if load_cell is not None and not isinstance(load_cell, HW.LoadCell):
            raise InputError(f"Emulator: load_cell {load_cell!r} must be a mckibben.hardware.LoadCell or None")
        self.load_cell = load_cell
        self._force_rng = np.random.default_rng(int(getattr(plants[0], "seed", 0) or 0))
        self.master, slave = os.openpty()
        tty.setraw(slave)
        tty.setraw(self.master)
        self.port = os.ttyname(slave)
        os.close(slave)  # the port is "closed" until a host opens it: the pty hangs up meanwhile
        os.set_blocking(self.master, False)
        self.resets = 0
        self.host_present = False  # a process has the port open (a reopen within one wake is not seen)
        self.steps = 0
        self.sent_telemetry = 0
        self.dropped = 0
        self.cut = 0
        self.garbage = 0
        self._stop = threading.Event()
        self._thread = None
        self._lock = threading.Lock()
        self._boot()
        self._bench_open()

    # -- device behaviour ------------------------------------------------------------------
    def _boot(self) -> None:
        """Power-on / reset: plants keep their air, the firmware starts afresh."""

        if not hasattr(self, "plants"):
            self.plants = [PlantStepper(p, ts=self.ts) for p in self._plant_params]
            # compile the kernels now, before the clock starts (a first call inside the loop
            # would stall it for seconds)
            scratch = PlantStepper(self._plant_params[0], ts=self.ts)
            scratch.advance(0, 0)
            CoreBank([self._controller]).step([scratch.sense()[0]], [True], [0.0])
            self._tension(scratch)
        # the pulley's encoder is incremental: the firmware's count starts at 0 on reset, wherever the
        # muscle is (the avr harness, firmware/pil/pil.c mcu_reset, counts the same way)
        pl = self.plants[0]
        self._enc_zero = int(HW.encoder_count(pl.length, pl.p[PP.Col.nominal_length], pl.p[PP.Col.encoder_resolution]))
        self.bank = CoreBank([self._controller] * self.n)
        self.ctrl = self.bank[0]
        self.p_ref = [0.0] * self.n
        self.streaming, self.decimation = False, 1
        self.tx_seq = 0
        self.rx = P.Parser()
        self._queue = bytearray()
        self._booting_until = time.monotonic() + self.boot_time
        self._hello_sent = False
        self._t_dev = 0  # device clock since reset [periods]

    def _handle(self, frame) -> None:
        kind = getattr(frame, "kind", None)
        status, value = 0, 0
        body = getattr(frame, "body", b"")
        ch = body[0] if body else 0
        targets = range(self.n) if ch == P.ALL else [ch]
        if kind in (P.SET_POINT, P.SET_GAIN, P.GET_GAIN, P.SET_OPEN_LOOP) and ch >= self.n:
            status = 3
        elif kind in (P.SET_MODE, P.SET_MAX_PRESSURE, P.VENT) and ch >= self.n and ch != P.ALL:
            status = 3
        elif kind == P.SET_POINT:
            self.p_ref[ch] = float(struct.unpack("<i", body[1:])[0])
        elif kind == P.SET_POINTS:
            if len(body) != 4 * self.n:
                status = 2
            else:
                self.p_ref = [float(v) for v in struct.unpack(f"<{self.n}i", body)]
        elif kind == P.SET_GAIN:
            gid, v = struct.unpack("<Bi", body[1:])
            status = self.bank[ch].set_gain(gid, v)
        elif kind == P.GET_GAIN:
            gid = body[1]
            if gid >= N_GAINS:
                status = 4
            else:
                value = int(self.bank[ch].iparams[IP_GAIN0 + gid])
        elif kind == P.SET_MODE:
            for i in targets:
                status |= self.bank[i].set_mode(body[1])
        elif kind == P.SET_MAX_PRESSURE:
            for i in targets:
                status |= self.bank[i].set_max_pressure(struct.unpack("<i", body[1:])[0])
        elif kind == P.VENT:
            for i in targets:
                self.bank[i].vent()
        elif kind == P.STREAM:
            if body[1] == 0:
                status = 3
            else:
                self.streaming, self.decimation = bool(body[0]), body[1]
        elif kind == P.SET_OPEN_LOOP:
            self.bank[ch].set_open_loop(body[1], body[2])
        else:
            status = 1
        self._send(P.encode_ack(self._next_seq(), frame.seq, kind if kind is not None else 0, status, value))

    def _next_seq(self) -> int:
        s = self.tx_seq
        self.tx_seq = (self.tx_seq + 1) & 0xFFFF
        return s

    def _send(self, pkt: bytes) -> bool:
        """Queue a whole packet or drop it (the firmware's uart_send)."""
        if len(self._queue) + len(pkt) > TX_QUEUE - 1:
            return False
        self._queue += pkt
        return True

    @staticmethod
    def _tension(stepper) -> float:
        """The muscle's pulling force now (the plant's ``outputs``, as the C plant's ``mk_outputs``). [N]"""
        ph.outputs(1, stepper.bk, stepper.law)
        return float(stepper.bk[ph.Y_FORCE])

    def tensions(self) -> list[float]:
        """The channels' true muscle tensions now: what a load cell on the muscle carries. [N]"""
        with self._lock:
            return [self._tension(pl) for pl in self.plants]

    def force_count(self) -> int | None:
        """The load cell's count of channel 0's tension now, with a fresh noise sample; None without one. [count]"""
        cell = self.load_cell
        if cell is None:
            return None
        e = cell.noise * float(self._force_rng.standard_normal()) if cell.noise > 0 else 0.0
        return cell.count(self._tension(self.plants[0]), e)

    def step(self) -> None:
        """Run one control period of every channel; queue the telemetry frame it streams."""
        force_adc = self.force_count()  # sampled at the start of the period, as the firmware's ADC3
        sensed = [pl.sense() for pl in self.plants]
        adcs = [a for a, _ in sensed]
        if self.hold_adc is not None:
            adcs[0] = self.hold_adc
        out = self.bank.step(adcs, [True] * self.n, self.p_ref)
        for pl, (inlet, bleed, _) in zip(self.plants, out, strict=True):
            pl.advance(inlet, bleed)
        self.steps += 1
        self._t_dev += 1
        if not self.streaming or self._t_dev % self.decimation:
            return
        chans = [P.ChannelTelemetry(adcs[i], out[i][0], out[i][1], self.bank[i].mode, out[i][2],
                                    self.bank[i].reference_pa, self.bank[i].surface_pa) for i in range(self.n)]
        t = P.Telemetry.of_channels(self._next_seq(), int(round(self._t_dev * self.ts * 1e6)) & 0xFFFFFFFF,
                                    sensed[0][1] - self._enc_zero, chans, force_adc)
        pkt = P.encode_telemetry(t)
        self.sent_telemetry += 1
        if self.cut_every and self.sent_telemetry % self.cut_every == 0:
            self.cut += 1
            pkt = pkt[: len(pkt) // 2]
        if self.garbage_every and self.sent_telemetry % self.garbage_every == 0:
            self.garbage += 1
            pkt += b"\x7f\x13\x88garbage\x01\x02\x00"
        if not self._send(pkt):
            self.dropped += 1

    def _host_present(self) -> bool:
        """True while some process has the port open (the pty's master does not hang up)."""
        r = select.poll()
        r.register(self.master, select.POLLHUP | select.POLLIN)
        return not any(ev & select.POLLHUP for _, ev in r.poll(0))

    def _drain(self, budget: int) -> int:
        """Move up to ``budget`` queued bytes onto the line; what the pty refuses stays queued."""
        if not self._queue or budget <= 0:
            return 0
        try:
            n = os.write(self.master, bytes(self._queue[:budget]))
        except (BlockingIOError, OSError):
            return 0
        del self._queue[:n]
        return n

    def run(self, duration: float | None = None) -> None:
        """Run in the calling thread until :meth:`stop` (or for ``duration`` seconds).

        Parameters
        ----------
        duration : float, optional
            Wall-clock time to run. [s]
        """
        t0 = time.monotonic()
        # the port was closed when the pty was made: a host that opened it before this thread ran
        # opened it after nobody had it open, and resets the board like any other open
        present = self.host_present
        credit = 0.0
        while not self._stop.is_set():
            now_abs = time.monotonic()
            now = now_abs - t0
            if duration is not None and now >= duration:
                break
            with self._lock:
                was, present = present, self._host_present()
                self.host_present = present
                if present and not was:  # the host opened the port: DTR resets the board
                    self.resets += 1
                    self._boot()
                data = b""
                if present:
                    try:
                        data = os.read(self.master, 4096)
                    except (BlockingIOError, OSError):
                        data = b""
                booting = now_abs < self._booting_until
                if not booting:
                    if not self._hello_sent:
                        self._send(P.encode_hello(self._next_seq(), self.n, int(round(self.ts * 1e6)), self.baud,
                                                  self._n_gains(),
                                                  None if self.load_cell is None else self.load_cell.full_scale))
                        self._hello_sent = True
                frames = [] if booting else self.rx.feed(data)  # the bootloader swallows what came before
                due = int(now / self.ts) - self.steps
                per_period = self.baud / 10.0 * self.ts  # bytes the line carries in one period
                # The commands read at this wake arrived over the periods since the last one: apply
                # them spread over those periods, in order, as the firmware would have met them.
                for frame in frames[:len(frames) - max(due, 0) * len(frames) // max(due, 1)] if due > 0 else frames:
                    self._handle(frame)
                pending = frames[len(frames) - max(due, 0) * len(frames) // max(due, 1):] if due > 0 else []
                if present and self._queue and due <= 0:
                    self._drain(int(per_period))
                for i in range(max(due, 0)):
                    upto = (i + 1) * len(pending) // due
                    for frame in pending[i * len(pending) // due:upto]:
                        self._handle(frame)
                    if booting:  # the board is in its bootloader: valves shut, no telemetry
                        for pl in self.plants:
                            pl.advance(0, 0)
                        self.steps += 1
                    else:
                        self.step()
                    # the UART shifts out one period's worth of the queue, heard or not
                    credit = min(credit + per_period, per_period)
                    if present:
                        credit -= self._drain(int(credit))
                    else:
                        take = min(len(self._queue), int(credit))
                        del self._queue[:take]
                        credit -= take
            time.sleep(self.wake)

    @property
    def device_time(self) -> float:
        """The device's clock: time since its last reset, as its telemetry reports it. [s]"""
        return self._t_dev * self.ts

    @staticmethod
    def _n_gains() -> int:
        return N_GAINS

    def start(self) -> "Emulator":
        """Run in a background thread."""
        self._thread = threading.Thread(target=self.run, name="mckibben-emulator", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the thread and close the pty."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._bench_close()
        try:
            os.close(self.master)
        except OSError:
            pass

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()

    # -- the bench side channel (mckibben.rig.bench) ------------------------------------------
    def _bench_open(self) -> None:
        """Serve the bench socket of this port (:func:`mckibben.rig.bench.bench_path`) in a thread."""
        self.bench = B.bench_path(self.port)
        try:
            self.bench.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
            if self.bench.is_socket():
                self.bench.unlink()  # a socket left by a killed device on a reused pty number
            self._bench_sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self._bench_sock.bind(str(self.bench))
            self._bench_sock.listen(4)
        except OSError:  # no place for the socket: the device runs, without a bench to script
            self.bench = None
            self._bench_sock = None
            return
        self._bench_sock.settimeout(0.1)
        self._bench_thread = threading.Thread(target=self._bench_serve, name="mckibben-bench", daemon=True)
        self._bench_thread.start()

    def _bench_serve(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self._bench_sock.accept()
            except (TimeoutError, socket.timeout):
                continue
            except OSError:
                return
            with conn:
                conn.settimeout(2.0)
                buf = b""
                try:
                    while not self._stop.is_set():
                        chunk = conn.recv(B.MAX_LINE)
                        if not chunk:
                            break
                        buf += chunk
                        while b"\n" in buf:
                            line, buf = buf.split(b"\n", 1)
                            conn.sendall((self.bench_request(line.decode(errors="replace")) + "\n").encode())
                        if len(buf) > B.MAX_LINE:
                            conn.sendall(b"error: line too long\n")
                            break
                except OSError:
                    pass

    def bench_request(self, line: str) -> str:
        """Apply one bench request to channel 0's plant; return the reply line.

        Parameters
        ----------
        line : str
            A request of :mod:`mckibben.rig.bench` (``load F``, ``hold L``, ``release``, ``state``). [-]
        """
        try:
            verb, value = B.parse_request(line)
        except InputError as exc:
            return f"error: {exc}"
        with self._lock:
            pl = self.plants[0]
            row = pl.bk[PH.OFF_P:PH.OFF_P + PH.NP * PH.W:PH.W].copy()  # lane 0's packed parameters
            if verb == "state":
                held = row[PP.Col.mobile] == 0.0
                load = 0.0 if row[PP.Col.load_kind] == PP.Load.spring else row[PP.Col.load_force]
                return f"ok load {float(load)!r} length {pl.length!r} pressure {pl.pressure!r} held {int(held)}"
            if verb == "load":
                row[PP.Col.load_force] = value
            elif verb == "hold":
                lo, hi = row[PP.Col.l_min], row[PP.Col.l_max]
                if not lo <= value <= hi:
                    return f"error: hold {value!r} is outside the muscle's travel {float(lo)!r}..{float(hi)!r} m"
                row[PP.Col.load_kind] = PP.Load.blocked
                pl.bk[PH.Z_LEN] = value
                pl.bk[PH.Z_VEL] = 0.0
            elif verb == "release":
                row[PP.Col.load_kind] = PP.Load.hanging
            prm = row[None, :]
            PP.derive(prm, self._plant_params[0].thermal)  # the one place inv_mass and mobile come from
            pl.bk[PH.OFF_P:PH.OFF_P + PH.NP * PH.W:PH.W] = prm[0]
            pl.p = pl.bk[PH.OFF_P:PH.OFF_P + PH.NP * PH.W:PH.W].copy()
        return "ok"

    def _bench_close(self) -> None:
        sock = getattr(self, "_bench_sock", None)
        if sock is None or self.bench is None:
            return
        sock.close()
        t = getattr(self, "_bench_thread", None)
        if t is not None:
            t.join(timeout=2)
        try:
            if self.bench.is_socket():
                self.bench.unlink()
        except OSError:
            pass
