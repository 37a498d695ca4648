"""A virtual Arduino on a pseudo-terminal: the protocol, the firmware core, the plant, in real time.

The emulator opens a pty pair and behaves like the device at the other end of the serial link:
it runs the controller core (:class:`mckibben.control.core.CoreController`, bit-exact with
``firmware/core``) at 1 kHz on the plant simulator (:class:`mckibben.plant.PlantStepper`),
answers every command with an ACK, and streams telemetry frames. It wakes every few
milliseconds, runs the control periods that are due, and writes their frames, so its average
rate is the device's. For tests it can inject garbage and cut frames into the stream.
"""

from __future__ import annotations

import os
import select
import struct
import threading
import time
import tty

from mckibben.rig import protocol as P


class Emulator:
    """The virtual device. ``start()`` runs it in a thread; ``port`` is the path to open.

    Parameters
    ----------
    plant : PlantParams, optional
        The rig; default the calibrated one.
    controller : CoreParams, optional
        The core's initial parameters (mode, gains, limits).
    ts : float, default 1e-3
        Control period. [s]
    wake : float, default 0.005
        How often the emulator wakes to run the due periods. [s]
    garbage_every : int, default 0
        Insert a burst of garbage after every k-th telemetry frame (0: never). [-]
    cut_every : int, default 0
        Send only the first half of every k-th telemetry frame (0: never); that frame is lost. [-]
    """

    def __init__(self, plant=None, controller=None, ts: float = 1e-3, wake: float = 0.005, garbage_every: int = 0,
                 cut_every: int = 0):
        from mckibben.control.core import CoreController, CoreParams
        from mckibben.plant import PlantStepper

        self.plant = PlantStepper(plant, ts=ts)
        self.ctrl = CoreController(controller or CoreParams(mode=0))
        self.ts, self.wake = ts, wake
        self.garbage_every, self.cut_every = garbage_every, cut_every
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        tty.setraw(self.master)
        self.port = os.ttyname(self.slave)
        self.p_ref = 0.0
        self.streaming, self.decimation = False, 1
        self.tx_seq = 0
        self.steps = 0
        self.sent_telemetry = 0
        self.cut = 0
        self.garbage = 0
        self.rx = P.Parser()
        self._stop = threading.Event()
        self._thread = None

    # -- device behaviour ------------------------------------------------------------------
    def _handle(self, frame) -> None:
        kind = getattr(frame, "kind", None)
        status = 0
        body = getattr(frame, "body", b"")
        c = self.ctrl
        if kind == P.SET_POINT:
            self.p_ref = float(struct.unpack("<i", body)[0])
        elif kind == P.SET_GAIN:
            gid, value = struct.unpack("<Bi", body)
            status = c.set_gain(gid, value)
        elif kind == P.SET_MODE:
            status = c.set_mode(body[0])
        elif kind == P.SET_MAX_PRESSURE:
            status = c.set_max_pressure(struct.unpack("<i", body)[0])
        elif kind == P.VENT:
            c.vent()
        elif kind == P.STREAM:
            if body[1] == 0:
                status = 3
            else:
                self.streaming, self.decimation = bool(body[0]), body[1]
        elif kind == P.SET_OPEN_LOOP:
            c.set_open_loop(body[0], body[1])
        else:
            status = 1
        self._write(P.encode_ack(self._next_seq(), frame.seq, kind if kind is not None else 0, status))

    def _next_seq(self) -> int:
        s = self.tx_seq
        self.tx_seq = (self.tx_seq + 1) & 0xFFFF
        return s

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view and not self._stop.is_set():
            try:
                n = os.write(self.master, view)
                view = view[n:]
            except BlockingIOError:
                time.sleep(0.001)
            except OSError:
                return

    def step(self) -> bytes:
        """Run one control period; return the telemetry packet it streams (or b"")."""
        adc, enc = self.plant.sense()
        inlet, bleed, faults = self.ctrl.step(adc, True, self.p_ref)
        self.plant.advance(inlet, bleed)
        self.steps += 1
        if not self.streaming or self.steps % self.decimation:
            return b""
        t = P.Telemetry(self._next_seq(), int(round(self.steps * self.ts * 1e6)) & 0xFFFFFFFF, adc, enc, inlet, bleed,
                        self.ctrl.mode, faults, self.ctrl.reference_pa, self.ctrl.surface_pa)
        pkt = P.encode_telemetry(t)
        self.sent_telemetry += 1
        if self.cut_every and self.sent_telemetry % self.cut_every == 0:
            self.cut += 1
            pkt = pkt[: len(pkt) // 2]
        if self.garbage_every and self.sent_telemetry % self.garbage_every == 0:
            self.garbage += 1
            pkt += b"\x7f\x13\x88garbage\x01\x02\x00"
        return pkt

    def run(self, duration: float | None = None) -> None:
        """Run in the calling thread until :meth:`stop` (or for ``duration`` seconds).

        Parameters
        ----------
        duration : float, optional
            Wall-clock time to run. [s]
        """
        t0 = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic() - t0
            if duration is not None and now >= duration:
                break
            r, _, _ = select.select([self.master], [], [], 0)
            if r:
                try:
                    data = os.read(self.master, 4096)
                except OSError:
                    data = b""
                for frame in self.rx.feed(data):
                    self._handle(frame)
            due = int(now / self.ts) - self.steps
            out = bytearray()
            for _ in range(max(due, 0)):
                out += self.step()
            if out:
                self._write(bytes(out))
            time.sleep(self.wake)

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
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
