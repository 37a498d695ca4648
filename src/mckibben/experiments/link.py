"""Steer the three-muscle tool through the device link: ``tool track --port`` (an experiment: tool + rig).

The host computes the path's pressure references (:func:`mckibben.tool.tracking.tip_reference`),
sends the three channels' controller design to the device (:meth:`Device.set_gains`, the same
design :func:`mckibben.tool.tracking.simulate_tracking` runs), holds the first references until
the chambers settle, then sends one SET_POINTS frame every
:data:`~mckibben.rig.device.PACED_PERIODS` control periods (paced by the host's clock: the
firmware's measured ceiling, ``docs/firmware.md``) while it records the device's telemetry at that
decimation: the three measured pressures, the references the
device applied, and its faults. The achieved tip is the tool's static equilibrium at the
measured pressures; it is compared with the path's target at the reference the device was
applying (so the error is the pressure loop's, through the link, as in the simulation).
"""

from __future__ import annotations

import sys
import threading
import time

import numpy as np

from mckibben.errors import InputError
from mckibben.hardware import pressure_from_adc
from mckibben.rig import protocol as P
from mckibben.rig.device import PACED_PERIODS, command, connect, end_session
from mckibben.tool.paths import parse_path
from mckibben.tool.tracking import resolve_path, tip_reference
from mckibben.tool.tracking import muscle_plants
from mckibben.rig.device import write_gains
from mckibben.tool.statics import tip_from_pressures
from mckibben.tool.tracking import TRACKING_BETA, TrackingResult, tracking_setup

#: Time the chambers get at the first references before the path starts (device time). [s]
SETTLE_S = 0.5


def _resolve(tool, path, ref=None):

    if isinstance(path, str):
        path = parse_path(path)
    path = resolve_path(path, tool)
    return path, (tip_reference(tool, path) if ref is None else ref)


def tool_plants(tool, path) -> list:
    """The three plants of the tool's muscles on a path, as the emulator should run them.

    Each is the tool's muscle hanging its mean tension along the path, the plants
    :func:`mckibben.tool.tracking.simulate_tracking` simulates.

    Parameters
    ----------
    tool : Tool
        The tool. [-]
    path : TipPath or str
        The path, or its text (``circle:radius=10mm,period=1s``). [-]

    Returns
    -------
    list of PlantParams
        One plant per channel. [-]
    """

    _, ref = _resolve(tool, path)
    return [muscle_plants(tool, float(f)) for f in ref.state.tensions.mean(axis=0)]


def track_over_link(port: str, tool, path, ref=None, *, beta: float | None = None, models: dict | None = None):
    """Follow one tip path with the device's three channels.

    Parameters
    ----------
    port : str
        Serial port of the device or emulator. [-]
    tool : Tool
        The tool. [-]
    path : TipPath or str
        The path, or its text. [-]
    ref : TipReference, optional
        Its references (default :func:`mckibben.tool.tracking.tip_reference` of the path). [-]
    beta : float, optional
        Switching gain; default :data:`mckibben.tool.tracking.TRACKING_BETA`. [PWM counts]
    models : dict, optional
        Identified models by loads, shared with :func:`simulate_tracking`. [-]

    Returns
    -------
    tuple
        ``(TrackingResult, link)``: the run, and the link's counters (frames, missing, corrupt,
        references sent, the device's lag behind the sent references [s]).
    """

    beta = TRACKING_BETA if beta is None else float(beta)
    path, ref = _resolve(tool, path, ref)
    _, params, model, loads = tracking_setup(tool, ref, beta, models)
    link, hello, parser = connect(port)
    if hello.n_channels < 3:
        link.close()
        raise InputError(f"port: {port!r} has {hello.n_channels} channel(s); the tool needs 3")
    try:
        gains = write_gains(link, parser, hello, params, port=port, first_seq=100)
    except BaseException:
        link.close()
        raise
    if not gains.verified:
        link.close()
        raise InputError(f"port: the gains read back from {port!r} differ from those sent")
    refs = np.asarray(ref.pressures, dtype=float)
    n = refs.shape[0]
    sent_at = {}  # rounded reference triple -> index k
    for k in range(n):
        sent_at.setdefault(tuple(int(round(v)) for v in refs[k]), k)
    rows = []

    def on_frame(f):
        if isinstance(f, P.Telemetry):
            rows.append(f)

    seq = 0
    try:
        command(link, parser, [(0, P.set_points(0, refs[0])), (1, P.set_mode(1, P.MODES["smc"])),
                               (2, P.stream(2, True, PACED_PERIODS))], on_frame=on_frame)
        seq = 3
        # hold the first references until the chambers settle (device time)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not (rows and rows[-1].t_us - rows[0].t_us >= SETTLE_S * 1e6):
            for f in parser.feed(link.read(8192)):
                on_frame(f)
        rows.clear()
        # a reader thread parses the telemetry; this thread sends one SET_POINTS per period on
        # the host's clock (a short GIL switch interval, so that parsing does not delay it)
        stop = threading.Event()

        def reader():
            while not stop.is_set():
                data = link.read(4096)
                for f in parser.feed(data):
                    on_frame(f)

        switch = sys.getswitchinterval()
        sys.setswitchinterval(1e-4)
        thread = threading.Thread(target=reader, name="mckibben-track-reader", daemon=True)
        thread.start()
        try:
            t0 = time.monotonic()
            for k in range(PACED_PERIODS, n, PACED_PERIODS):
                now = time.monotonic()
                due = t0 + k * 1e-3
                if due > now:
                    time.sleep(due - now)
                elif now - due > PACED_PERIODS * 1e-3:
                    continue  # late: this reference has passed, send the current one
                link.write(P.set_points(seq, refs[k]))
                seq += 1
            time.sleep(0.1)
        finally:
            stop.set()
            thread.join(timeout=5)
            sys.setswitchinterval(switch)
    finally:
        end_session(link, seq)
        link.close()
    last = (n - 1) // PACED_PERIODS * PACED_PERIODS  # the last reference sent
    idx, pressure, applied, faults, t = [], [], [], 0, []
    for f in rows:
        key = tuple(c.reference_pa for c in f.channels[:3])
        k = sent_at.get(key)
        if k is None:
            continue  # a frame before the path's first reference reached the device
        if idx and idx[-1] == last and k == last:
            break  # the path is over: the device holds its last reference
        idx.append(k)
        t.append(f.t_us * 1e-6)
        pressure.append([pressure_from_adc(c.pressure_adc).item() for c in f.channels[:3]])
        applied.append(key)
        faults |= int(np.bitwise_or.reduce([c.faults for c in f.channels[:3]]))
    if len(idx) < n // 2:
        raise InputError(f"port: only {len(idx)} telemetry frames of the {n}-period path arrived from {port!r}")
    idx = np.asarray(idx)
    pressure = np.asarray(pressure)
    achieved = tip_from_pressures(np.clip(pressure, 0.0, tool.p_max), tool).tip
    t = np.asarray(t)
    result = TrackingResult(t - t[0], ref.target[idx], achieved, refs[idx], pressure, loads, beta, float(model.gain),
                            float(model.tau), faults)
    link_info = {**parser.counters(), "references_sent": seq - 3, "frames_on_path": int(idx.size),
                 "path_periods": n, "references_applied": int(np.unique(idx).size)}
    return result, link_info
