"""Characterize a muscle on the bench with one call: protocol file → tables → fitted muscle file.

A *protocol* (a TOML file, :func:`read_protocol`; ``mckibben examples copy characterize.toml``)
states the hanging loads, the pressure steps (up to the top, then back down; stepped, or ramped at a
rate), the hold time, the settling rule, the number of trials and the safety maximum, and optionally held lengths for
isometric runs on a rig with a load cell. It is checked whole before anything moves; a bad one is
refused with its file, line and reason.

:func:`run_characterization` runs it on a device (the Arduino Mega or an emulator engine) through its
serial link, with the operator (or, unattended, the bench side channel :mod:`mckibben.rig.bench`)
changing the load between runs, records every settled step crash-safely, writes the project's own
tables and fits a muscle file. See ``docs/rig.md``.
"""

from __future__ import annotations

import json
import math
import os
import re
import time
import tomllib
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from mckibben import hardware as HW
from mckibben.atomic import as_path, atomic_file, check_input_file
from mckibben.errors import InputError, unknown_name
from mckibben.hardware import P_MAX_DEFAULT, P_MAX_LIMIT
from mckibben.rig import isometric as ISO
from mckibben.rig import protocol as P
from mckibben.rig.bench import Bench
from mckibben.rig.device import PACED_PERIODS, connect, end_session
from mckibben.results import Result, to_jsonable, write_table
from mckibben.data.muscle_file import read_muscle
from mckibben.data.tables import read_table
from mckibben.fit.compare import TUBE_SUFFIX, compare_models
from mckibben.fit.direction import fit_isotonic_friction
from mckibben.fit.hysteresis import fit_prandtl_ishlinskii
from mckibben.fit.isometric import IsometricFit, fit_isotonic_law
from mckibben.fit.muscle_file import muscle_file_text
from mckibben.models import laws
from mckibben.models.hysteresis import thresholds_uniform
from mckibben.models.hysteresis.direction import FRICTION_FORCE_NAME, FRICTION_NAME
from mckibben.models.muscle import Muscle
from mckibben.models.static import length as static_length
from mckibben.rig import recorder as REC
from mckibben.rig.recorder import _fsync_dir
from mckibben.units import G_N, parse_quantity

__all__ = ["CharacterizeResult", "CharacterizeStopped", "Protocol", "collect_steps", "fit_run", "read_protocol",
           "report_view", "run_characterization", "run_protocol", "static_points", "write_tables"]

#: The sections of a protocol file and the keys each takes.
SECTIONS = {
    "protocol": ("name", "trials", "max_pressure"),
    "isotonic": ("loads", "pressures", "hold", "ramp"),
    "settling": ("window", "tolerance", "timeout"),
    "isometric": ("lengths", "pressures", "hold", "tolerance"),
}
#: A quantity of each dimension, as a protocol file writes it (for the error messages).
EXAMPLE = {"pressure": "0.8MPa", "time": "0.5s", "length": "0.2mm", "force": "61g"}
#: An isometric step's force has settled when the means of its settling window's two halves differ by less
#: than this, unless ``[isometric] tolerance`` says otherwise (a few counts of a 5 N cell). [N]
ISO_TOLERANCE = 0.02
#: Most steps one sweep (up and down) may hold: a protocol is a lab's afternoon, not a typo's week. [-]
MAX_STEPS = 200
#: Fastest set-point ramp a protocol may ask for: the full scale in 10 ms (one telemetry frame of a run,
#: :data:`DECIMATION` control periods), past which a ramp is a step. [Pa/s]
MAX_RAMP_RATE = 100e6
#: Longest ramp between two steps (the hold's limit): a slower rate is a typo, not a protocol. [s]
MAX_RAMP_TIME = 600.0


@dataclass(frozen=True)
class Protocol:
    """A characterization protocol, in SI.

    Attributes
    ----------
    name : str
        What the protocol is (free text). [-]
    loads : tuple of float
        The hanging loads, one isotonic run each, as forces (a mass times standard gravity). [N]
    pressures : tuple of float
        The pressure steps going up (the sweep goes back down the same steps). [Pa]
    hold : float
        Least time at each step before the settling rule is checked. [s]
    window, tolerance, timeout : float
        Settling rule: the length moved less than ``tolerance`` [m] over the last ``window`` [s];
        a step is recorded unsettled after ``timeout`` [s].
    trials : int
        Sweeps per load. [-]
    max_pressure : float
        Safety maximum: no set-point above it. [Pa]
    lengths : tuple of float
        Held lengths of the isometric runs (empty: none). [m]
    iso_pressures : tuple of float
        Pressure steps of the isometric runs (default the isotonic ones). [Pa]
    iso_hold : float
        Least time at each isometric step before its settling rule is checked (default ``hold``). [s]
    iso_tolerance : float
        Isometric settling rule: the force's means over the two halves of the last ``window`` differ by
        less than this (:data:`ISO_TOLERANCE` by default). [N]
    source : str
        The file it was read from. [-]
    ramp : float
        Rate at which the set-point moves from one step to the next, a monotonic approach with no
        overshoot past the step (``0``: stepped, the set-point jumps). [Pa/s]
    """

    name: str
    loads: tuple
    pressures: tuple
    hold: float
    window: float
    tolerance: float
    timeout: float
    trials: int
    max_pressure: float
    lengths: tuple = ()
    iso_pressures: tuple = ()
    source: str = ""
    text: str = field(default="", repr=False)
    ramp: float = 0.0
    iso_hold: float = 0.5
    iso_tolerance: float = ISO_TOLERANCE

    @property
    def sweep(self) -> list[tuple[float, str]]:
        """One sweep's steps: ``(pressure [Pa], "inflate"|"deflate")``, up to the top and back down."""
        up = [(p, "inflate") for p in self.pressures]
        return up + [(p, "deflate") for p in reversed(self.pressures[:-1])]

    def load_steps(self) -> list[tuple[int, int, float]]:
        """Every isotonic run in order: ``(load index, trial (1-based), load [N])``."""
        return [(i, t, f) for i, f in enumerate(self.loads) for t in range(1, self.trials + 1)]


def _key_line(text: str, section: str, key: str | None) -> int:
    """The 1-based line of ``key`` in ``[section]`` of a TOML text (tomllib gives no line for a value's error)."""
    lines = text.splitlines()
    head = re.compile(r"^\s*\[\s*" + re.escape(section) + r"\s*\]")
    start = next((i for i, s in enumerate(lines) if head.match(s)), None)
    if start is None:
        return 1
    if key is None:
        return start + 1
    pat = re.compile(r"^\s*\"?" + re.escape(key) + r"\"?\s*=")
    for i in range(start + 1, len(lines)):
        if re.match(r"^\s*\[", lines[i]):
            break
        if pat.match(lines[i]):
            return i + 1
    return start + 1


def read_protocol(path) -> Protocol:
    """Read and check a protocol file; refuse a bad one before anything moves.

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file (``mckibben examples copy characterize.toml`` gives a commented one). [-]

    Returns
    -------
    Protocol

    Raises
    ------
    InputError
        One line ``FILE:LINE: [section] key: reason`` for the first problem found.
    """
    p = check_input_file(as_path(path, "protocol", "protocol file"), "protocol", "protocol file")
    try:
        text = p.read_bytes().decode("utf-8")
        doc = tomllib.loads(text)
    except UnicodeDecodeError:
        raise InputError(f"{p}: the protocol file is not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: not valid TOML ({exc})") from None
    return _protocol(doc, text, str(p))


def _protocol(doc: dict, text: str, source: str) -> Protocol:
    def fail(section: str, key: str | None, reason: str) -> InputError:
        where = f"[{section}]" + (f" {key}" if key else "")
        return InputError(f"{source}:{_key_line(text, section, key)}: {where}: {reason}")

    for sec, body in doc.items():
        if sec not in SECTIONS:
            raise InputError(f"{source}:{_key_line(text, sec, None)}: {unknown_name('section', sec, SECTIONS)}")
        if not isinstance(body, dict):
            raise InputError(f"{source}:{_key_line(text, sec, None)}: {sec} must be a [{sec}] section")
        for key in body:
            if key not in SECTIONS[sec]:
                raise InputError(f"{source}:{_key_line(text, sec, key)}: [{sec}] "
                                 f"{unknown_name('key', key, SECTIONS[sec])}")
    if "isotonic" not in doc and "isometric" not in doc:
        raise InputError(f"{source}:1: an [isotonic] section (loads, pressures) or an [isometric] one (lengths, "
                         "pressures) is required")

    def quantity(sec: str, key: str, dim: str, default=None, *, zero: bool = True) -> float:
        raw = doc.get(sec, {}).get(key, default)
        if raw is None:
            raise fail(sec, key, "missing")
        if not isinstance(raw, str):
            raise fail(sec, key, f"{raw!r} needs a unit, as text (e.g. \"{EXAMPLE[dim]}\")")
        try:
            return parse_quantity(raw, dim, key, allow_zero=zero)
        except InputError as exc:
            raise fail(sec, key, str(exc)) from None

    def quantities(sec: str, key: str, dim: str, *, zero: bool) -> tuple:
        raw = doc.get(sec, {}).get(key)
        if raw is None:
            raise fail(sec, key, "missing")
        if isinstance(raw, dict):
            extra = set(raw) - {"from", "to", "steps"}
            if extra or not {"from", "to", "steps"} <= set(raw):
                raise fail(sec, key, "a range is { from = \"0MPa\", to = \"0.8MPa\", steps = 9 }")
            n = raw["steps"]
            if not isinstance(n, int) or isinstance(n, bool) or not 2 <= n <= MAX_STEPS:
                raise fail(sec, key, f"steps = {n!r} must be a whole number in 2..{MAX_STEPS}")
            try:
                lo = parse_quantity(str(raw["from"]), dim, f"{key}.from")
                hi = parse_quantity(str(raw["to"]), dim, f"{key}.to")
            except InputError as exc:
                raise fail(sec, key, str(exc)) from None
            values = tuple(float(v) for v in np.linspace(lo, hi, n))
        elif isinstance(raw, list) and raw:
            out = []
            for i, v in enumerate(raw):
                if not isinstance(v, str):
                    raise fail(sec, key, f"item {i + 1} ({v!r}) needs a unit, as text")
                try:
                    out.append(parse_quantity(v, dim, f"{key}[{i + 1}]", allow_zero=True))
                except InputError as exc:
                    raise fail(sec, key, str(exc)) from None
            values = tuple(out)
        else:
            raise fail(sec, key, "a non-empty list of quantities, or a range { from, to, steps }")
        if not zero and min(values) <= 0:
            raise fail(sec, key, "every value must be above zero")
        if any(not math.isfinite(v) or v < 0 for v in values):
            raise fail(sec, key, "every value must be a finite number >= 0")
        return values

    head = doc.get("protocol", {})
    name = head.get("name", "")
    if not isinstance(name, str):
        raise fail("protocol", "name", f"{name!r} must be text")
    trials = head.get("trials", 1)
    if not isinstance(trials, int) or isinstance(trials, bool) or not 1 <= trials <= 20:
        raise fail("protocol", "trials", f"{trials!r} must be a whole number in 1..20")
    p_max = quantity("protocol", "max_pressure", "pressure", f"{P_MAX_DEFAULT / 1e6:g}MPa", zero=False)
    if p_max > P_MAX_LIMIT:
        raise fail("protocol", "max_pressure", f"{p_max / 1e6:g} MPa is above the transducer's full scale "
                                               f"({P_MAX_LIMIT / 1e6:g} MPa)")
    isotonic = "isotonic" in doc  # an isometric-only protocol has none
    loads = quantities("isotonic", "loads", "force", zero=False) if isotonic else ()
    if len(set(loads)) != len(loads):
        raise fail("isotonic", "loads", "a load is listed twice (use trials to repeat a load)")
    pressures = quantities("isotonic", "pressures", "pressure", zero=True) if isotonic else ()
    steps = [("isotonic", pressures)] if isotonic else []
    if "isometric" in doc and "pressures" in doc["isometric"]:
        steps.append(("isometric", quantities("isometric", "pressures", "pressure", zero=True)))
    elif not isotonic:
        raise fail("isometric", "pressures", "missing (an isometric-only protocol has no isotonic ones to take)")
    for sec, ps in steps:
        if any(b <= a for a, b in zip(ps, ps[1:])):
            raise fail(sec, "pressures", "the steps must rise (the sweep comes back down the same steps)")
        if max(ps) > p_max:
            raise fail(sec, "pressures", f"the top step {max(ps) / 1e6:g} MPa is above max_pressure "
                                         f"{p_max / 1e6:g} MPa")
        if len(ps) < 2:
            raise fail(sec, "pressures", "at least two steps")
    hold = quantity("isotonic", "hold", "time", "0.5s")
    if hold > 600:
        raise fail("isotonic", "hold", f"{hold:g} s is longer than 10 minutes")
    ramp = _ramp_rate(doc.get("isotonic", {}).get("ramp"), lambda reason: fail("isotonic", "ramp", reason))
    if ramp and max(pressures) - min(pressures) > MAX_RAMP_TIME * ramp:
        raise fail("isotonic", "ramp", f"{ramp / 1e6:g} MPa/s takes longer than {MAX_RAMP_TIME / 60:g} minutes "
                                       f"from {min(pressures) / 1e6:g} to {max(pressures) / 1e6:g} MPa")
    window = quantity("settling", "window", "time", "0.2s", zero=False)
    tolerance = quantity("settling", "tolerance", "length", "0.2mm", zero=False)
    timeout = quantity("settling", "timeout", "time", "5s", zero=False)
    if timeout < window:
        raise fail("settling", "timeout", f"{timeout:g} s is shorter than the window ({window:g} s)")
    lengths: tuple = ()
    iso_p: tuple = ()
    iso_hold, iso_tol = hold, ISO_TOLERANCE
    if "isometric" in doc:
        lengths = quantities("isometric", "lengths", "length", zero=False)
        if len(set(lengths)) != len(lengths):
            raise fail("isometric", "lengths", "a length is listed twice (use trials to repeat a length)")
        iso_p = steps[-1][1] if steps[-1][0] == "isometric" else pressures
        iso_hold = quantity("isometric", "hold", "time", f"{hold!r}s")
        if iso_hold > 600:
            raise fail("isometric", "hold", f"{iso_hold:g} s is longer than 10 minutes")
        iso_tol = quantity("isometric", "tolerance", "force", f"{ISO_TOLERANCE!r}N", zero=False)
    n = len(loads) * trials * (2 * len(pressures) - 1)
    if n > 20_000:
        raise fail("isotonic", "loads", f"{n} steps in all: more than 20000")
    n_iso = len(lengths) * trials * (2 * len(iso_p) - 1)
    if n_iso > 20_000:
        raise fail("isometric", "lengths", f"{n_iso} steps in all: more than 20000")
    return Protocol(name, loads, pressures, hold, window, tolerance, timeout, trials, p_max, lengths, iso_p,
                    source, text, ramp, iso_hold, iso_tol)


def _ramp_rate(raw, fail) -> float:
    """A protocol's ``ramp``: ``"0.5MPa/s"`` (any pressure unit over s, ms or min) or ``"step"``/absent (0). [Pa/s]"""
    if raw is None or raw == "step":
        return 0.0
    if not isinstance(raw, str) or "/" not in raw:
        raise fail(f"{raw!r} must be a rate of pressure, as text (e.g. \"0.5MPa/s\"), or \"step\"")
    num, _, per = raw.rpartition("/")
    try:
        rate = parse_quantity(num, "pressure", "ramp", allow_zero=False)
        seconds = parse_quantity("1" + per.strip(), "time", "ramp")
    except InputError as exc:
        raise fail(str(exc)) from None
    rate /= seconds
    if rate > MAX_RAMP_RATE:
        raise fail(f"{rate / 1e6:g} MPa/s is faster than {MAX_RAMP_RATE / 1e6:g} MPa/s: that is a step "
                   "(write ramp = \"step\")")
    return rate


# -- the run on the device ------------------------------------------------------------------------

#: Telemetry decimation during a run: one frame every 10 control periods (100 Hz). [-]
DECIMATION = 10
#: A step that ends farther than this from its set-point (and did not move half way there) is a
#: fault: a leak, or a stuck sensor when the reading never changed. [Pa]
REACH_TOLERANCE = 50e3
#: The columns of a step journal part and of ``steps.parquet``.
STEP_COLUMNS = ["load_index", "trial", "step", "load_N", "set_point_Pa", "pressure_Pa", "length_m", "direction",
                "settled", "time_s", "pressure_max_Pa", "force_N", "pressure_min_Pa", "pressure_slip_Pa"]
#: The span of the step's pressure averaged before its extreme is taken as the pressure where the braid
#: slipped (:func:`slip_pressure`): the hung muscle follows the controller's ripple no faster. Chosen on
#: measured runs of the example on both engines (docs/rig.md, benchmarks/RESULTS.md). [s]
SLIP_SMOOTHING = 0.02


class CharacterizeStopped(InputError):
    """The run stopped before the end: a safety stop (a one-line reason) or the operator's Ctrl-C.

    The valves were vented; every load step completed before the stop is kept in the run's journal
    (``--resume`` goes on from there).
    """


class _Session:
    """One connection to the device: commands, telemetry, the safety checks on every frame."""

    def __init__(self, port: str, limit: float):
        self.port, self.limit = port, float(limit)
        self.link, self.hello, self.parser = connect(port)
        self.seq = 0
        self.rows: list = []  # (t [s], p [Pa], encoder, inlet, bleed, faults, adc, force [N] or NaN)
        self.max_pressure = 0.0
        self.has_force = False  # a load cell's force in the telemetry (a later protocol version)
        try:
            for pkt in (P.set_point(self._next(), 0), P.set_max_pressure(self._next(), self.limit, P.ALL),
                        P.set_mode(self._next(), P.MODES["smc"], 0), P.stream(self._next(), True, DECIMATION)):
                self.link.write(pkt)
            self.wait(0.3)
        except BaseException:
            self.close()
            raise

    def _next(self) -> int:
        self.seq = (self.seq + 1) & 0xFFFF
        return self.seq

    def poll(self, prompt: bool = False) -> None:
        """Read what arrived; check every telemetry frame (over-pressure, device faults).

        ``prompt``: return as soon as anything arrived (what is waiting, or the next byte) rather than
        after the link's read timeout, for a caller that answers every frame (:func:`_ramp`).
        """
        size = (self.link.in_waiting or 1) if prompt else 8192
        for f in self.parser.feed(self.link.read(size)):
            if isinstance(f, P.Telemetry):
                force = getattr(f, "force", None)
                self.has_force = force is not None
                p = float(HW.adc_pressure(f.pressure_adc, HW.PA_PER_COUNT, 0.0))
                self.rows.append((f.t_us * 1e-6, p, f.encoder, f.inlet_pwm, f.bleed_pwm, f.faults, f.pressure_adc,
                                  math.nan if force is None else float(force)))
                self.max_pressure = max(self.max_pressure, p)
                if f.faults & ~(1 << P.FAULT_NAMES.index("vent_commanded")):
                    raise self.stop(f"the device reported {', '.join(P.fault_names(f.faults))}")
                if p > self.limit + 2 * HW.PA_PER_COUNT:
                    raise self.stop(f"pressure {p / 1e6:.4f} MPa above the maximum {self.limit / 1e6:g} MPa")

    def wait(self, seconds: float, until=None) -> None:
        """Follow the device's clock for ``seconds`` of telemetry time (or until ``until()``)."""
        end_wall = time.monotonic() + 10.0 + 3.0 * seconds
        t0 = None
        while time.monotonic() < end_wall:
            self.poll()
            if not self.rows:
                continue
            t0 = self.rows[-1][0] if t0 is None else t0
            if self.rows[-1][0] - t0 >= seconds or (until is not None and until()):
                return
        raise self.stop(f"the device stopped streaming telemetry ({len(self.rows)} frames)")

    def set_point(self, pressure: float) -> None:
        if pressure > self.limit:  # the one gate every set-point passes
            raise self.stop(f"set-point {pressure / 1e6:g} MPa above the maximum {self.limit / 1e6:g} MPa")
        self.link.write(P.set_point(self._next(), pressure, 0))

    def stop(self, reason: str) -> CharacterizeStopped:
        self.vent()
        return CharacterizeStopped(f"port {self.port}: stopped: {reason}; valves vented")

    def vent(self) -> None:
        try:
            self.link.write(P.set_point(self._next(), 0, 0))
            self.link.write(P.vent(self._next(), P.ALL))
        except Exception:  # the link may be gone; venting is best effort then
            pass

    def close(self) -> None:
        end_session(self.link, self._next())
        self.link.close()


def _settle(s: _Session, proto: Protocol, length_of, start: int) -> tuple[bool, np.ndarray]:
    """Hold until the length moved less than the tolerance over the window (or the timeout); the window's rows."""
    s.wait(proto.hold)

    def settled() -> bool:
        t_now = s.rows[-1][0]
        w = [r for r in s.rows[start:] if r[0] >= t_now - proto.window]
        if t_now - s.rows[start][0] < proto.hold + proto.window:
            return False
        lengths = length_of(np.array([r[2] for r in w]))
        return float(lengths.max() - lengths.min()) <= proto.tolerance

    t_start = s.rows[start][0]
    ok = settled()
    while not ok and s.rows[-1][0] - t_start < proto.timeout:
        s.wait(proto.window / 2)
        ok = settled()
    t_now = s.rows[-1][0]
    return ok, np.array([r for r in s.rows[start:] if r[0] >= t_now - proto.window], dtype=float)


def _check_reached(s: _Session, target: float, p_before: float, win: np.ndarray, start: int) -> None:
    """Stop on a leak or a stuck sensor: the pressure did not go toward a set-point it should reach."""
    p_now = float(win[:, 1].mean())
    if abs(p_now - target) <= REACH_TOLERANCE or abs(p_now - p_before) >= 0.5 * abs(target - p_before):
        return
    step = np.array(s.rows[start:], dtype=float)
    if np.ptp(step[:, 6]) == 0:
        raise s.stop(f"stuck pressure sensor: it read {p_now / 1e6:.4f} MPa throughout a step to "
                     f"{target / 1e6:g} MPa")
    if target > p_before and step[:, 3].max() > 0:
        raise s.stop(f"leak: the pressure did not rise toward {target / 1e6:g} MPa with the inlet open "
                     f"({p_before / 1e6:.4f} -> {p_now / 1e6:.4f} MPa)")
    raise s.stop(f"the pressure did not follow the set-point {target / 1e6:g} MPa ({p_now / 1e6:.4f} MPa)")


def _ramp(s: _Session, start: float, target: float, rate: float) -> None:
    """Move the set-point from ``start`` to ``target`` at ``rate`` at most: one SET_POINT per telemetry frame.

    During the ramp the device streams a frame every :data:`mckibben.rig.device.PACED_PERIODS`
    control periods (the firmware's measured command ceiling, as ``tool track --port`` streams), and
    each frame gets a set-point ``rate·Δt`` closer to the target, Δt the device time since the last
    one but at most one paced period: so every increment stays small (the controller's reference
    feed-forward is the increment over a period), a host that falls behind the device (a slow machine,
    an unthrottled simulator) makes the ramp slower, never steeper, and the set-point never passes the
    target (nor the session's maximum). The caller sends the target itself at the end.

    Parameters
    ----------
    s : _Session
        The run's connection. [-]
    start, target : float
        The set-points the ramp leaves and reaches. [Pa]
    rate : float
        Its rate, > 0. [Pa/s]
    """
    top = min(target, s.limit)
    dt_max = PACED_PERIODS * HW.CONTROL_PERIOD
    s.link.write(P.stream(s._next(), True, PACED_PERIODS))  # a frame, and a set-point, every paced period
    try:
        s.wait(0.0)
        t_last, p = s.rows[-1][0], start
        while p != top:
            n, deadline = len(s.rows), time.monotonic() + 10.0
            while len(s.rows) == n:  # the next frame
                if time.monotonic() > deadline:
                    raise s.stop(f"the device stopped streaming telemetry ({len(s.rows)} frames)")
                s.poll(prompt=True)
            dp = rate * min(s.rows[-1][0] - t_last, dt_max)
            t_last = s.rows[-1][0]
            p = min(p + dp, top) if top > start else max(p - dp, top)
            s.set_point(p)
    finally:
        s.link.write(P.stream(s._next(), True, DECIMATION))


def _run_sweep(s: _Session, proto: Protocol, length_of, ref_len: float, load_index: int, trial: int, load: float,
               progress, tare: float = math.nan) -> list:
    """One load's sweep, up then down; the rows of its steps (``force_N``: the load cell's mean less ``tare``)."""
    rows = []
    p_before = float(np.mean([r[1] for r in s.rows[-10:]]))
    previous = 0.0  # the sweep starts vented
    for k, (target, direction) in enumerate(proto.sweep):
        start = len(s.rows)
        if proto.ramp:
            _ramp(s, previous, target, proto.ramp)
        s.set_point(target)
        s.wait(0.0)
        previous = target
        ok, win = _settle(s, proto, length_of, start)
        _check_reached(s, target, p_before, win, start)
        lengths = length_of(win[:, 2])
        if lengths.min() <= 0 or lengths.max() > 2 * ref_len:  # the belt ran off the pulley's travel
            raise s.stop(f"length {lengths.min() * 1e3:.2f} mm left the encoder's range")
        p_mean = float(win[:, 1].mean())
        frames = np.array(s.rows[start:], dtype=float)  # every frame of the step: its extremes
        p_step = frames[:, 1]
        rows.append((load_index, trial, k, load, target, p_mean, float(lengths.mean()), direction, bool(ok),
                     float(win[-1, 0]), float(p_step.max()), float(win[:, 7].mean()) - tare, float(p_step.min()),
                     slip_pressure(frames[:, 0], p_step, direction)))
        p_before = p_mean
        if progress is not None:
            progress(1)
    return rows


def _write_part(journal: Path, load_index: int, trial: int, rows: list, meta: dict) -> None:
    """One completed load step, atomically: complete or absent (the recorder's journal discipline)."""
    REC._write_part(journal, "load", load_index, trial, STEP_COLUMNS, rows, meta)


def _done_parts(journal: Path) -> dict:
    """(load index, trial) → path of the completed load steps in a journal."""
    return REC._done_parts(journal, "load")


def run_protocol(port: str, protocol, out, *, unattended: bool = False, resume: bool = False,
                 muscle_file=None, prompt=None, progress=None, bench=None) -> dict:
    """Run a protocol's isotonic load steps on the device; journal each completed one; return the provenance.

    For each load and trial: the load is hung (the operator is asked, or unattended the bench side
    channel changes it), the muscle vented and let settle, then the pressure set-point of the
    device's own controller (closed loop, SET_POINT) goes up the protocol's steps and back down (with
    the protocol's ``ramp``, as a rate-limited ramp from one step to the next, :func:`_ramp`); at
    each step the run holds until the length settles by the protocol's rule and keeps one sample
    (mean pressure and length over the settling window). A completed load step is written to
    ``OUT/steps.journal/`` at once, atomically, so a run killed at any moment keeps every completed
    step, and ``resume=True`` goes on with the others.

    Parameters
    ----------
    port : str
        Serial port of the device (or an emulator's pty, or a link to it). [-]
    protocol : Protocol or str or os.PathLike
        The protocol or its file. [-]
    out : str or os.PathLike
        The run's folder (made if absent; must be empty unless ``resume``). [-]
    unattended : bool, default False
        Change loads through the bench side channel (:mod:`mckibben.rig.bench`) instead of asking. [-]
    resume : bool, default False
        Go on with a run that stopped: skip the completed load steps in ``out``. [-]
    muscle_file : str or os.PathLike, optional
        The muscle under test (recorded in the provenance). [-]
    prompt : callable, optional
        ``prompt(text)`` asks the operator and returns when they confirm (default: ``input``). [-]
    progress : callable, optional
        ``progress(event, **info)``: ``("start", total=, done=)``, ``("load", load=, trial=)``, ``("step",)``. [-]
    bench : Bench, optional
        The bench client (default ``Bench.of_port(port)`` when unattended). [-]

    Returns
    -------
    dict
        The run's provenance (protocol, firmware, port, time, muscle file, limit, steps done).

    Raises
    ------
    CharacterizeStopped
        A safety stop or Ctrl-C (valves vented, completed steps kept).
    """
    proto = protocol if isinstance(protocol, Protocol) else read_protocol(protocol)
    out = Path(out)
    journal = out / "steps.journal"
    if out.exists() and not out.is_dir():
        raise InputError(f"out: {str(out)!r} is a file, not a folder")
    if resume:
        if not journal.is_dir():
            raise InputError(f"resume: {str(out)!r} holds no run to resume (no steps.journal)")
    elif out.is_dir() and any(out.iterdir()):
        raise InputError(f"out: {str(out)!r} is not empty (give `resume` to go on with its run)")
    limit = min(proto.max_pressure, float(P_MAX_DEFAULT))
    meta_file = journal / "run.json"
    if resume and meta_file.is_file():
        old = json.loads(meta_file.read_text())
        if old.get("protocol_text") != proto.text:
            raise InputError(f"resume: the protocol differs from the one {str(out)!r} was started with")
    b = bench if bench is not None else (Bench.of_port(port) if unattended else None)
    ask = prompt if prompt is not None else (lambda text: input(text))
    done = _done_parts(journal) if journal.is_dir() else {}
    held_done = ISO.done_parts(journal) if journal.is_dir() else {}
    todo = [(i, t, f) for i, t, f in proto.load_steps() if (i, t) not in done]
    tell = progress if progress is not None else (lambda *a, **k: None)
    if b is not None:
        b.state()  # the bench answers before anything moves
    s = _Session(port, limit)
    try:
        ISO.check_isometric(proto, port, s.has_force, b, muscle_file)  # no load cell, a length off the travel
        try:
            journal.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"out: cannot write {str(out)!r} ({exc.strerror})") from None
        n_held = len(ISO.held_sweep(proto)) if proto.lengths else 0
        tell("start", total=len(proto.load_steps()) * len(proto.sweep) + len(ISO.held_steps(proto)) * n_held,
             done=len(done) * len(proto.sweep) + len(held_done) * n_held)
        meta = {"protocol": proto.source, "protocol_name": proto.name, "protocol_text": proto.text,
                "port": port, "protocol_version": P.VERSION, "firmware": {
                    "n_channels": s.hello.n_channels, "control_period_us": s.hello.ts_us, "baud": s.hello.baud,
                    "n_gains": s.hello.n_gains, "protocol_version": P.VERSION},
                "muscle_file": None if muscle_file is None else str(muscle_file),
                "max_pressure_Pa": limit, "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "controller": "smc", "unattended": bool(unattended)}
        refs: list[dict] = []
        tares: list[dict] = []
        held_tares: list[dict] = []
        if not meta_file.is_file():
            tmp = journal / ".run.json.tmp"
            tmp.write_text(json.dumps(meta))
            os.replace(tmp, meta_file)
            _fsync_dir(journal)
        ref_len, c0 = None, None
        for load_index, trial, load in todo:
            tell("load", load=load, trial=trial)
            tare = math.nan
            if s.has_force:  # tare the load cell at the start of each run: nothing hanging, the muscle vented
                if b is not None:
                    b.release()
                    b.load(0.0)
                else:
                    ask("take the weight off channel 0 (the load cell is tared at zero force), then Enter "
                        "(Ctrl-C stops safely) ")
                tare = _tare(s, proto)
                tares.append({"load_index": load_index, "trial": trial, "force_offset_N": tare})
            if b is not None:
                b.release()
                b.load(load)
            else:
                ask(f"hang {load / G_N * 1e3:.0f} g ({load:.3g} N) on channel 0 for trial {trial}, then Enter "
                    "(Ctrl-C stops safely) ")
            _vent_and_settle(s, proto)
            if ref_len is None:
                # the encoder counts from where it was zeroed: tie it to a length once per session,
                # as the operator reads the muscle's length off the rule (or the bench reports it)
                ref_len, c0 = _reference(s, b, ask)
                refs.append({"length_m": ref_len, "encoder": c0})
            length_of = (lambda r, c: (lambda cnt: r - (np.asarray(cnt, float) - c) * HW.ENCODER_RESOLUTION))(
                ref_len, c0)
            rows = _run_sweep(s, proto, length_of, ref_len, load_index, trial, load,
                              (lambda n: tell("step")), tare)
            s.set_point(0.0)
            _write_part(journal, load_index, trial, rows, {"max_pressure_Pa": s.max_pressure, "force_offset_N": tare})
        if proto.lengths:  # the isometric runs, after the isotonic ones (mckibben.rig.isometric)
            held_tares = ISO.run_isometric(s, proto, journal, ISO.Tools(_tare, _check_reached, _ramp), b, ask, tell)
    except KeyboardInterrupt:
        s.vent()
        raise CharacterizeStopped(f"port {port}: stopped by the operator; valves vented; "
                                  f"{_kept(journal)} kept in {out} (`resume` goes on)") from None
    except EOFError:  # asked with no one to answer (standard input closed)
        s.vent()
        raise CharacterizeStopped(f"port {port}: stopped: no operator to answer (standard input is closed; on an "
                                  f"emulated bench give `unattended`); valves vented; {_kept(journal)} "
                                  f"kept in {out}") from None
    finally:
        s.close()
    meta["length_references"] = refs
    meta["load_cell_tares"] = tares + held_tares
    meta["finished"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
    meta["peak_pressure_Pa"] = s.max_pressure
    return meta


def _kept(journal: Path) -> str:
    """What a stopped run's journal keeps: its load steps, and its held-length runs when it has any."""
    held = len(ISO.done_parts(journal))
    return f"{len(_done_parts(journal))} load steps" + (f" and {held} held-length runs" if held else "")


#: Gauge pressure below which the muscle counts as vented. [Pa]
VENTED = 5e3


def _vent_and_settle(s: _Session, proto: Protocol) -> None:
    """Set-point 0, wait for the pressure to fall below :data:`VENTED`, then for the length to settle."""
    s.set_point(0.0)
    s.wait(0.0)
    start = len(s.rows)
    s.wait(proto.timeout, until=lambda: s.rows[-1][1] < VENTED)
    if s.rows[-1][1] >= VENTED:
        raise s.stop(f"the pressure stayed at {s.rows[-1][1] / 1e6:.4f} MPa with the set-point at 0")
    _settle(s, proto, lambda c: -np.asarray(c, float) * HW.ENCODER_RESOLUTION, max(start, len(s.rows) - 1))


def _tare(s: _Session, proto: Protocol) -> float:
    """The load cell's zero: its mean reading over the settling window, vented with nothing hanging
    (:meth:`mckibben.rig.device.Device.tare` on the run's own connection). [N]"""
    _vent_and_settle(s, proto)
    t_now = s.rows[-1][0]
    f = np.array([r[7] for r in s.rows if r[0] >= t_now - proto.window], dtype=float)
    return float(np.mean(f))


def _reference(s: _Session, bench, ask) -> tuple[float, float]:
    """A length and the encoder count read at the same moment: the bench's (or the operator's) reading between
    two telemetry frames that show the same count. ``(length [m], count)``."""
    for _ in range(50):
        s.wait(0.02)
        before = s.rows[-1][2]
        length = bench.state().length if bench is not None else _ask_length(ask)
        s.wait(0.02)
        if s.rows[-1][2] == before or bench is None:
            return length, float(s.rows[-1][2])
    raise s.stop("the length never held still long enough to read it")


def _ask_length(ask) -> float:
    """The operator's reading of the muscle's length now (vented), with a unit."""
    while True:
        text = ask("the muscle's length now, vented (e.g. 100.2mm): ")
        try:
            return parse_quantity(str(text).strip(), "length", "length", allow_zero=False)
        except InputError as exc:
            print(f"error: {exc}")


# -- from the journal to tables, and from tables to a muscle file -----------------------------------

#: Plays of the Prandtl-Ishlinskii loop fitted on each load's up/down branches (beside the muscle file's
#: friction, one for every load), and the knots of its output map (a modified PI, Kuhnen 2003: the
#: muscle's contraction saturates with pressure). [-]
N_PLAYS, PI_KNOTS = 3, 3


def collect_steps(out):
    """Every completed load step of a run's journal, in protocol order (one row per settled step).

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder. [-]
    """
    return REC._read_parts(Path(out) / "steps.journal", "load", STEP_COLUMNS, "load_index")


def write_tables(out, steps, meta: dict) -> dict:
    """The run as the project's table kinds, with provenance: ``isotonic.csv`` and ``hysteresis.csv``.

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder. [-]
    steps : pandas.DataFrame
        :func:`collect_steps`. [-]
    meta : dict
        The run's provenance (:func:`run_protocol`). [-]

    Returns
    -------
    dict
        Kind → path written.
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)


    out = Path(out)
    prov = {k: v for k, v in meta.items() if k != "protocol_text"}
    hyst = pd.DataFrame({"pressure_MPa": steps["pressure_Pa"].to_numpy(float) / 1e6,
                         "load_N": steps["load_N"].to_numpy(float),
                         "length_mm": steps["length_m"].to_numpy(float) * 1e3,
                         "direction": steps["direction"].astype(str).to_numpy(),
                         "trial": steps["trial"].to_numpy(int)})
    paths = {"hysteresis": write_table(hyst, out / "hysteresis.csv", {**prov, "kind": "hysteresis"}),
             "isotonic": write_table(hyst.drop(columns=["direction"]), out / "isotonic.csv",
                                     {**prov, "kind": "isotonic"})}
    return paths


def report_view(out, folder) -> Path:
    """A run as a one-muscle campaign folder for the report package: ``muscle.toml``, ``isotonic.csv`` and
    ``hysteresis.csv`` in ``folder``, each step at its set-point pressure, and ``isometric.csv`` as measured
    when the run has isometric runs.

    The report's per-pressure fits (its Fig. 5, force against contraction per pressure) group rows
    by pressure; a measured pressure differs from step to step by a count of the transducer, so the
    view gives each step its set-point, as a lab's sheet lists its nominal pressures, and leaves out
    the set-points where no load moved the muscle (no contraction to fit). The run's own tables keep
    every step at its measured pressure.

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder (with ``muscle.toml``). [-]
    folder : str or os.PathLike
        An existing empty folder to write the view into. [-]

    Returns
    -------
    pathlib.Path
        The muscle folder inside ``folder``. [-]
    """
    import shutil


    out, muscle = Path(out), Path(folder) / "muscle"
    muscle.mkdir()
    shutil.copyfile(out / "muscle.toml", muscle / "muscle.toml")
    if (out / "isometric.csv").is_file():  # the isometric runs, as measured: the report's isometric comparison
        shutil.copyfile(out / "isometric.csv", muscle / "isometric.csv")
    steps = collect_steps(out)
    if not len(steps):  # an isometric-only run
        return muscle
    # set-points where no load has moved the muscle off its vented length carry no contraction to fit
    moved = steps.assign(m=_moving(steps)).groupby("set_point_Pa")["m"].any()
    keep = steps["set_point_Pa"].map(moved).to_numpy(bool)
    for kind in ("isotonic", "hysteresis"):
        df = pd_read_csv(out / f"{kind}.csv")
        df["pressure_MPa"] = steps["set_point_Pa"].to_numpy(float) / 1e6
        write_table(df[keep], muscle / f"{kind}.csv", {"view_of": str(out / f"{kind}.csv"), "pressure": "set-point",
                                                       "rows": "set-points where a load moved the muscle"})
    return muscle


def pd_read_csv(path):
    """A table file as written by :func:`write_tables` (pandas, deferred)."""
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    return pd.read_csv(path)


def _moving(steps) -> np.ndarray:
    """Rows where the muscle has left its vented length (below that the end stop, not the muscle, holds the load)."""
    keep = np.zeros(len(steps), dtype=bool)
    for _, g in steps.groupby(["load_index", "trial"]):
        rest = float(g["length_m"].iloc[0])
        keep[g.index.to_numpy()] = np.abs(g["length_m"].to_numpy(float) - rest) > 1.5 * HW.ENCODER_RESOLUTION
    return keep & (steps["pressure_Pa"].to_numpy(float) > 0)


def static_points(steps, moving, columns):
    """The static length at each step pressure: the mean of the inflating and deflating branches.

    Friction holds the muscle short of its static length on both branches, by about as much on
    each (the plant's Dahl element, a real braid's friction): the branches' mean at one set-point
    is the friction-free length the force laws describe. A set-point visited once (the top of the
    sweep) keeps its one sample. A set-point where a branch has not left the vented length (the end
    stop holds the load there, not the muscle) is left out.

    Parameters
    ----------
    steps : pandas.DataFrame
        :func:`collect_steps`. [-]
    moving : numpy.ndarray of bool
        The steps to use (:func:`_moving`). [-]
    columns : sequence of str
        The isotonic table's columns to give (``pressure``, ``load``, ``length``, ``trial``...). [-]

    Returns
    -------
    pandas.DataFrame
        One row per (load, trial, set-point), SI, indexed from 1 like a read table. [-]
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    s = steps.assign(moving=moving)
    g = s.groupby(["load_index", "trial", "set_point_Pa"], sort=True)
    d = pd.DataFrame({"pressure": g["pressure_Pa"].mean(), "load": g["load_N"].first(), "length": g["length_m"].mean(),
                      "trial": g["trial"].first(), "both": g["moving"].all()})
    d = d[d["both"].to_numpy()].reset_index(drop=True)  # a branch still at rest is held by the stop, not the muscle
    d.index = range(1, len(d) + 1)
    return d[[c for c in columns if c in d.columns]]


def fit_run(out, muscle_file, ramped: bool = False) -> dict:
    """Fit the run's tables: compare every applicable law held out, write the best to ``OUT/muscle.toml``
    with the braid's friction fitted on the up/down branches, and give each load's up/down gap.

    The laws are compared on the branches' mean at each set-point (the friction-free length), each
    with and without the tube's stretch past the rest length (:mod:`mckibben.models.tube`;
    :func:`mckibben.fit.compare.compare_models` with ``tube=True``): the term is kept only when the
    law with it predicts the held-out loads better (the held-out error decides, not the in-sample
    fit or its flags: the term only acts on the points hung past the rest length, and a held-out
    load is the test a lab's next load puts it to). The braid's friction is then fitted with that
    law held, law ∓ A_f·P = load, one A_f, on the loop's width at each set-point both branches
    visited (law(P_u, L_u) − law(P_d, L_d) = A_f·(P_u + P_d);
    :func:`mckibben.fit.direction.fit_isotonic_friction` with ``held`` and ``width``: two stages,
    so the law and its intervals are the static fit's and the file's static length is the one
    compared), each branch point, in a ramped run, at the pressure where its braid last slipped
    (:func:`slip_pressure`); that law, its tube and A_f are written (A_f is left out, and why said,
    when its file does not give the static lengths back as the compared fit did). The friction's
    constant part F_0 is fitted beside and reported, not written, on the branches (``with_constant``)
    and on the widths (``on_width``): on the example's runs the first trades F_0 for A_f (A_f at its
    lower bound), the second gives F_0 six to thirteen times the plant's with A_f's interval reaching
    zero (docs/rig.md). Each load's gap
    is the measured one and the muscle file's (its law with the friction solved for the length on
    each branch at each step's pressure: what ``predict length --branch`` gives), and, beside it,
    a Prandtl–Ishlinskii loop fitted to that load alone.

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder, holding ``isotonic.csv`` and ``hysteresis.csv`` (:func:`write_tables`). [-]
    muscle_file : str or os.PathLike
        The muscle under test (its geometry, for the laws that need it). [-]
    ramped : bool, default False
        Whether the run approached each step by a ramp (the protocol's ``ramp``): then each branch
        point is fitted at the pressure where its braid last slipped (:func:`slip_pressure`); stepped,
        the controller overshoots and the muscle slips partly back, the pressure did not move one
        way, and each point is fitted at the hold's mean pressure. [-]

    Returns
    -------
    dict
        ``comparison`` (every model's held-out scores; ``<law>+tube`` with the tube's term), ``best``
        (the law written), ``muscle_file``, ``parameters``/``stderr``/``valid_range`` (of the law
        written), ``friction`` (``friction_area_m2``, its standard error and interval, or why it was
        not written; ``with_constant``: the friction fitted with its constant part F_0 too,
        ``friction_force_N`` and its interval, reported, not written; ``on_width``: F_0 and A_f fitted on
        the loop's width at each set-point, their intervals, reported, not written), ``hysteresis`` (per load: ``gap_measured_m``, ``gap_model_m`` of the muscle
        file's friction, ``rmse_m`` of its branch lengths, and ``prandtl_ishlinskii``: that load's own
        loop and its gap). SI.
    """
    import dataclasses


    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    out = Path(out)
    spec = read_muscle(muscle_file)
    iso = read_table(out / "isotonic.csv", "isotonic")
    steps = collect_steps(out)
    moving = _moving(steps)
    if np.count_nonzero(moving) < 8:
        raise InputError(f"out: {out}: only {np.count_nonzero(moving)} steps where the muscle moved; too few to fit")
    fit_table = dataclasses.replace(iso, data=static_points(steps, moving, iso.data.columns))
    # every law with and without the tube's stretch: the held-out error decides whether it keeps the term
    cmp = compare_models(fit_table, spec, tube=True)
    scores = [sc.to_dict() for sc in cmp["scores"]]
    candidates = [sc for sc in cmp["scores"] if _law_of_score(sc.name)[0] in laws.fit_laws() and np.isfinite(sc.cv_rmse_m)]
    if not candidates:
        raise InputError(f"out: {out}: no force law could be fitted to the run ({'; '.join(s.note for s in cmp['scores'])})")
    d = fit_table.data
    pts = pd.DataFrame({"held_length": d["length"].to_numpy(float), "pressure": d["pressure"].to_numpy(float),
                        "force": d["load"].to_numpy(float), "direction": "inflate",
                        "trial": d["trial"].to_numpy() if "trial" in d else np.ones(len(d))})
    target = out / "muscle.toml"
    rejected = {}
    tried = []
    best = None
    # best on held-out error first; a law whose muscle file does not give back the lengths it was scored on
    # (the load-cell zero it fits has no meaning without a load cell, and the file's law has none) is passed over;
    # when every one is, the file that gives the lengths back best is written
    for sc in sorted(candidates, key=lambda sc: sc.cv_rmse_m):
        name, tube = _law_of_score(sc.name)
        res = fit_isotonic_law(fit_table, spec, name, tube=tube)
        text = muscle_file_text(dataclasses.replace(spec, path=str(target)), IsometricFit(name, res, spec,
                                                                                          {"method": "none"}, pts))
        pred = _file_lengths(text, out, d["pressure"].to_numpy(float), d["load"].to_numpy(float))
        miss = np.where(np.isfinite(pred), pred - d["length"].to_numpy(float), 0.05)  # unreachable: 5 cm off
        file_rmse = float(np.sqrt(np.mean(miss ** 2)))
        tried.append((file_rmse, sc, res, text))
        if file_rmse <= 1.5 * sc.rmse_m + 2e-4:
            best = sc
            break
        rejected[sc.name] = (f"its muscle file gives the lengths back with RMSE {file_rmse * 1e3:.3g} mm "
                             f"(compared: {sc.rmse_m * 1e3:.3g} mm; flags {', '.join(res.flags) or 'none'})")
    if best is None:
        _, best, res, text = min(tried, key=lambda t: t[0])
        rejected.pop(best.name, None)
    else:
        res, text = tried[-1][2], tried[-1][3]
    name, tube = _law_of_score(best.name)
    # the same law with the braid's friction, law ∓ A_f·P, on both branches of every load (one A_f for all; F_0 = 0):
    # its file gives the static length (the law) and each branch's, and the plant of the file runs the friction
    hyst_table = read_table(out / "hysteresis.csv", "hysteresis")
    branches = dataclasses.replace(hyst_table, data=hyst_table.data[moving])
    friction: dict = {"law": best.name}
    try:
        slip = _slip_pressures(steps)[moving] if ramped else None  # stepped: the hold's mean (see above)
        widths = _set_point_labels(steps)[moving]
        # on the loop's width at each set-point both branches visited (docs/rig.md: on each branch, the rows without
        # a partner, the sweep's top and a branch on its stop, pulled A_f and left the file's loop narrow at 0.6 N)
        fr = fit_isotonic_friction(branches, spec, name, tube=tube, held=res, slip_pressure=slip, width=widths)
    except InputError as exc:
        friction["error"] = str(exc)
    else:
        fr_text = muscle_file_text(dataclasses.replace(spec, path=str(target)),
                                   IsometricFit(name, fr, spec, {"method": "none"}, pts))
        pred = _file_lengths(fr_text, out, d["pressure"].to_numpy(float), d["load"].to_numpy(float))
        miss = np.where(np.isfinite(pred), pred - d["length"].to_numpy(float), 0.05)
        k = fr.names.index(FRICTION_NAME)
        friction.update({"friction_area_m2": float(fr.values[k]), "stderr_m2": float(fr.stderr[k]),
                         "ci95_m2": [float(x) for x in fr.ci95[k]], "rmse_N": float(fr.residual_rms),
                         "flags": list(fr.flags), "static_rmse_m": float(np.sqrt(np.mean(miss ** 2)))})
        # beside it, reported and not written: the friction with its constant part F_0 fitted too (docs/rig.md: on
        # the example the law's own miss trades F_0 for A_f, and the file's gap is the worse for it)
        fc = fit_isotonic_friction(branches, spec, name, tube=tube, held=res, slip_pressure=slip, constant=True)
        c, k = fc.names.index(FRICTION_FORCE_NAME), fc.names.index(FRICTION_NAME)
        friction["with_constant"] = {"friction_force_N": float(fc.values[c]), "stderr_N": float(fc.stderr[c]),
                                     "ci95_N": [float(x) for x in fc.ci95[c]], "friction_area_m2": float(fc.values[k]),
                                     "rmse_N": float(fc.residual_rms),
                                     "flags": [x for x in fc.flags if x.startswith(("friction_", FRICTION_NAME))]}
        # and F_0 with A_f on the loop's width: reported, not written (docs/rig.md: the gap closer still, but F_0 six
        # to thirteen times the plant's and A_f's interval reaching 0: the widths do not tell the two parts apart)
        fw = fit_isotonic_friction(branches, spec, name, tube=tube, held=res, slip_pressure=slip, constant=True,
                                   width=widths)
        c, k = fw.names.index(FRICTION_FORCE_NAME), fw.names.index(FRICTION_NAME)
        friction["on_width"] = {"friction_force_N": float(fw.values[c]), "stderr_N": float(fw.stderr[c]),
                                "ci95_N": [float(x) for x in fw.ci95[c]], "friction_area_m2": float(fw.values[k]),
                                "stderr_m2": float(fw.stderr[k]), "ci95_m2": [float(x) for x in fw.ci95[k]],
                                "rmse_N": float(fw.residual_rms), "n_widths": int(fw.residuals.size),
                                "flags": [x for x in fw.flags if x.startswith(("friction_", FRICTION_NAME))]}
        if friction["static_rmse_m"] <= 1.5 * best.rmse_m + 2e-4:  # its law still gives the lengths back
            res, text = fr, fr_text
        else:
            friction["error"] = (f"not written: its law gives the static lengths back with RMSE "
                                 f"{friction['static_rmse_m'] * 1e3:.3g} mm (compared: {best.rmse_m * 1e3:.3g} mm)")
    with atomic_file(target, "out") as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    saved = target
    written = Muscle.from_spec(read_muscle(saved))
    hyst = {}
    for li, g in steps.groupby("load_index"):
        g = g[moving[g.index.to_numpy()]]  # the branches where the muscle moves (the end stop has no loop)
        p = g["pressure_Pa"].to_numpy(float)
        ell = g["length_m"].to_numpy(float)
        trials, direction = g["trial"].to_numpy(), g["direction"].to_numpy()
        load = float(steps.loc[steps["load_index"] == li, "load_N"].iloc[0])
        if len(g) < 2 * N_PLAYS + PI_KNOTS:
            hyst[str(li)] = {"load_N": load, "error": f"{len(g)} steps where the muscle moved: too few for the loop"}
            continue
        # the muscle file's branches: its law with the friction, solved for the length at each step's pressure
        y_law = np.full(len(g), np.nan)
        for dn in ("inflate", "deflate"):
            sel = direction == dn
            if sel.any():
                y_law[sel] = written.length_for_pressure(p[sel], load, dn).length
        row = {"load_N": load, "gap_measured_m": branch_gap(p, ell, direction),
               "gap_model_m": branch_gap(p, y_law, direction), "model": "friction",
               "rmse_m": float(np.sqrt(np.nanmean((y_law - ell) ** 2)))}
        l_ref = float(ell.max())
        try:  # the per-load Prandtl-Ishlinskii loop, beside: a loop of this load only
            pi = fit_prandtl_ishlinskii(p, l_ref - ell, thresholds_uniform(N_PLAYS, float(np.ptp(p))), run=trials,
                                        start="virgin", input_offset=float(p.min()), output_knots=PI_KNOTS,
                                        input_unit="Pa", output_unit="m", source=str(out / "hysteresis.csv"),
                                        what=f"hysteresis of load {load:.4g} N")
        except InputError as exc:
            row["prandtl_ishlinskii"] = {"error": str(exc)}
        else:
            y_hat = np.concatenate([l_ref - pi.model.apply(p[trials == t])[0] for t in pd.unique(trials)])
            row["prandtl_ishlinskii"] = {"model": pi.model.to_dict(), "reference_length_m": l_ref,
                                         "rmse_m": float(np.sqrt(np.mean((y_hat - ell) ** 2))),
                                         "gap_model_m": branch_gap(p, y_hat, direction)}
        hyst[str(li)] = row
    return {"comparison": scores, "cv_method": cmp["cv_method"], "n_points": int(cmp["n_points"]),
            "best": best.name, "best_cv_rmse_m": float(best.cv_rmse_m), "muscle_file": str(saved),
            "parameters": dict(zip(res.names, (float(v) for v in res.values))),
            "stderr": {n: float(v) for n, v in zip(res.names, res.stderr)},
            "valid_range": {k: [float(a), float(b)] for k, (a, b) in res.valid_range.items()},
            "passed_over": rejected, "friction": friction, "hysteresis": hyst}


def slip_pressure(time, pressure, direction: str) -> float:
    """A step's pressure where its braid last slipped: the extreme of its pressure averaged over :data:`SLIP_SMOOTHING`. [Pa]

    The muscle ends a step where the friction last let it move (:func:`mckibben.fit.direction.fit_isotonic_friction`):
    contracting at the highest pressure an inflating step reached, lengthening at the lowest a deflating one did.
    That holds where each step is approached from one side (a ramped run): a stepped one overshoots and slips
    partly back. The pressure controller ripples about a held set-point faster than the hung muscle follows
    (its mass and the load's, critically damped), so a single frame's extreme over-reaches the slip: the
    extreme is taken of the pressure averaged over the trailing :data:`SLIP_SMOOTHING` of each frame.

    Parameters
    ----------
    time : array_like
        The step's telemetry frames' device time, rising. [s]
    pressure : array_like
        Their gauge pressure. [Pa]
    direction : {"inflate", "deflate"}
        The step's branch. [-]
    """
    t, p = np.asarray(time, dtype=float), np.asarray(pressure, dtype=float)
    if t.shape != p.shape or p.size == 0:
        raise InputError(f"pressure: {p.size} frames for {t.size} times; want one pressure [Pa] per time, at least one")
    if direction not in ("inflate", "deflate"):
        raise InputError(f"direction: {direction!r} must be inflate or deflate")
    total = np.concatenate([[0.0], np.cumsum(p)])
    first = np.searchsorted(t, t - SLIP_SMOOTHING, side="left")  # each frame's trailing window, itself included
    mean = (total[1:] - total[first]) / (np.arange(1, p.size + 1) - first)
    full = t - t[0] >= SLIP_SMOOTHING  # the frames whose window the step fills (all of a shorter step)
    mean = mean[full] if full.any() else mean
    return float(mean.max() if direction == "inflate" else mean.min())


def _set_point_labels(steps) -> np.ndarray:
    """Per step, the label of its set-point (load, trial, commanded pressure): the rows of one loop width. [-]"""
    return steps.groupby(["load_index", "trial", "set_point_Pa"], sort=False).ngroup().to_numpy()


def _slip_pressures(steps) -> np.ndarray:
    """Per step, the recorded :func:`slip_pressure`; a journal recorded before it was kept gives the step's extreme on
    its branch (the highest inflating, the lowest deflating, else the hold's mean). [Pa]"""
    def col(c):
        return steps[c].to_numpy(float) if c in steps else np.full(len(steps), np.nan)

    inflate = steps["direction"].to_numpy() == "inflate"
    old = np.where(inflate, col("pressure_max_Pa"), col("pressure_min_Pa"))
    old = np.where(np.isfinite(old), old, steps["pressure_Pa"].to_numpy(float))
    slip = col("pressure_slip_Pa")
    return np.where(np.isfinite(slip), slip, old)


def _law_of_score(name: str) -> tuple[str, bool]:
    """A comparison's model name as (law, with the tube's stretch) (:data:`mckibben.fit.compare.TUBE_SUFFIX`)."""
    return (name[: -len(TUBE_SUFFIX)], True) if name.endswith(TUBE_SUFFIX) else (name, False)


def _file_lengths(text: str, out: Path, pressure, load) -> np.ndarray:
    """The lengths a muscle file's law gives at (pressure, load) pairs, as ``mckibben predict length`` solves them. [m]"""
    import tempfile


    with tempfile.TemporaryDirectory(prefix=".check-", dir=out) as tmp:
        f = Path(tmp) / "muscle.toml"
        f.write_text(text, encoding="utf-8")
        m = Muscle.from_spec(read_muscle(f))
    out_l = np.full(len(pressure), np.nan)
    for i, (p, w) in enumerate(zip(pressure, load)):
        try:
            out_l[i] = float(static_length(np.array([p]), float(w), m, None).length[0])
        except InputError:
            pass
    return out_l


def branch_gap(pressure, length, direction) -> float:
    """Mean |deflating − inflating| length at the pressures both branches visited (the hysteresis gap). [m]

    Parameters
    ----------
    pressure : array_like
        Step pressures (set-point groups). [Pa]
    length : array_like
        Lengths. [m]
    direction : array_like of str
        ``inflate`` or ``deflate`` per row. [-]
    """
    p = np.round(np.asarray(pressure, float) / 1e4) * 1e4  # steps of the same set-point (10 kPa bins)
    ell = np.asarray(length, float)
    d = np.asarray(direction)
    gaps = []
    for q in np.unique(p):
        up, down = ell[(p == q) & (d == "inflate")], ell[(p == q) & (d == "deflate")]
        if len(up) and len(down):
            gaps.append(abs(float(down.mean()) - float(up.mean())))
    return float(np.mean(gaps)) if gaps else float("nan")


# -- the one public call ----------------------------------------------------------------------------


@dataclass(frozen=True, repr=False)
class CharacterizeResult(Result):
    """A characterization run: its settled steps, its tables, the fitted muscle file.

    Attributes
    ----------
    summary : dict
        JSON-ready: provenance, tables written, steps, peak pressure, the comparison, the best law
        and the muscle file, the hysteresis per load (SI). [-]
    steps : pandas.DataFrame
        One row per settled step (:data:`STEP_COLUMNS`). [-]
    arguments : dict
        Port, protocol, out, unattended, resume, muscle file. [-]
    """

    summary: dict
    steps: object = field(repr=False)
    arguments: dict = field(default_factory=dict)
    call = "mckibben.rig.characterize.run_characterization"

    @property
    def metrics(self) -> dict:
        """Load steps and samples recorded, the peak pressure [Pa], the best law and its held-out RMSE [m]."""
        fit = self.summary.get("fit") or {}
        return {"load_steps": self.summary["load_steps"], "samples": self.summary["samples"],
                "peak_pressure_Pa": self.summary["peak_pressure_Pa"], "best": fit.get("best"),
                "best_cv_rmse_m": fit.get("best_cv_rmse_m")}

    def to_dict(self) -> dict:
        """The summary (what ``--json`` prints)."""
        return to_jsonable(self.summary)

    def _series(self):
        return self.steps

    def plot(self, ax=None):
        """The hysteresis loops: length against pressure per load, inflating and deflating; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        s = self.steps
        for i, (load, g) in enumerate(s.groupby("load_N")):
            for d, mark in (("inflate", "o-"), ("deflate", "s--")):
                h = g[g["direction"] == d]
                ax.plot(h["pressure_Pa"] / 1e6, h["length_m"] * 1e3, mark, color=f"C{i}", ms=3, lw=0.8,
                        label=f"{load:.2g} N {d}")
        ax.set_xlabel("pressure [MPa]")
        ax.set_ylabel("length [mm]")
        ax.legend(fontsize=7)
        return ax.figure


def run_characterization(port: str, protocol, out, *, unattended: bool = False, resume: bool = False, muscle_file=None,
                 prompt=None, progress=None, bench=None) -> CharacterizeResult:
    """Characterize a muscle on the bench: run a protocol, write its tables, fit a muscle file.

    :func:`run_protocol` runs the load steps on the device (crash-safe, resumable); the completed
    steps become ``OUT/isotonic.csv`` and ``OUT/hysteresis.csv`` (the project's table kinds, with
    provenance beside them; :func:`mckibben.data.read_table` and ``mckibben fit`` read them) and
    ``OUT/steps.parquet``; with a muscle file, :func:`fit_run` compares every applicable law held
    out (:func:`mckibben.fit.compare.compare_models`, each with and without the tube's stretch),
    writes the best with the braid's friction fitted on the up/down branches to ``OUT/muscle.toml``
    (for ``mckibben predict length --muscle-file``, ``--branch`` for either branch) and gives each
    load's up/down gap, measured and the file's. ``OUT/summary.json`` holds the summary.

    Parameters
    ----------
    port : str
        Serial port of the device (or an emulated one). [-]
    protocol : Protocol or str or os.PathLike
        The protocol or its file (:func:`read_protocol`). [-]
    out : str or os.PathLike
        The run's folder. [-]
    unattended : bool, default False
        Change loads through the bench side channel instead of asking the operator. [-]
    resume : bool, default False
        Go on with a stopped run in ``out``. [-]
    muscle_file : str or os.PathLike, optional
        The muscle under test; without it the run writes its tables and fits nothing. [-]
    prompt, progress, bench
        As :func:`run_protocol`. [-]

    Returns
    -------
    CharacterizeResult

    Raises
    ------
    InputError
        A bad protocol, muscle file, port or folder, before anything moves.
    CharacterizeStopped
        A safety stop or Ctrl-C during the run (valves vented, completed load steps kept).
    """

    proto = protocol if isinstance(protocol, Protocol) else read_protocol(protocol)
    if muscle_file is not None:
        read_muscle(muscle_file)  # a bad muscle file is refused before anything moves
    meta = run_protocol(port, proto, out, unattended=unattended, resume=resume, muscle_file=muscle_file,
                        prompt=prompt, progress=progress, bench=bench)
    out = Path(out)
    steps = collect_steps(out)
    held = ISO.collect_isometric(out)
    tables = write_tables(out, steps, meta) if len(steps) or not len(held) else {}
    if len(held):
        tables["isometric"] = ISO.write_isometric_table(out, held, meta)
        write_table(held, out / "held_steps.parquet", {k: v for k, v in meta.items() if k != "protocol_text"}, "out")
    write_table(steps, out / "steps.parquet", {k: v for k, v in meta.items() if k != "protocol_text"}, "out")
    expected = len(proto.load_steps())
    peaks = [float(d["pressure_max_Pa"].max()) for d in (steps, held) if len(d)]
    summary = {"out": str(out), "port": port, "protocol": proto.source, "tables": tables,
               "load_steps": int(steps.groupby(["load_index", "trial"]).ngroups),
               "load_steps_expected": expected, "samples": len(steps),
               "held_runs": int(held.groupby(["length_index", "trial"]).ngroups) if len(held) else 0,
               "held_runs_expected": len(ISO.held_steps(proto)), "held_samples": len(held),
               "unsettled": int((~steps["settled"].astype(bool)).sum()) + int((~held["settled"].astype(bool)).sum()),
               "peak_pressure_Pa": max(peaks, default=0.0),
               "max_pressure_Pa": meta["max_pressure_Pa"], "firmware": meta["firmware"],
               "muscle_file_used": None if muscle_file is None else str(muscle_file), "fit": None}
    if muscle_file is not None:
        if len(steps):  # the muscle file comes from the isotonic runs when there are any
            summary["fit"] = fit_run(out, muscle_file, ramped=proto.ramp > 0)
            if len(held):  # and the isometric runs' comparison stands beside it
                summary["fit"]["isometric"] = ISO.compare_run(out, muscle_file)
        elif len(held):
            summary["fit"] = ISO.fit_isometric_only(out, muscle_file)
    tmp = out / ".summary.json.tmp"
    tmp.write_text(json.dumps(to_jsonable(summary), indent=1))
    os.replace(tmp, out / "summary.json")
    return CharacterizeResult(summary, steps, {"port": port, "protocol": proto.source, "out": str(out),
                                               "unattended": unattended, "resume": resume,
                                               "muscle_file": None if muscle_file is None else str(muscle_file)})
