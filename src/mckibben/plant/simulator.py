"""The batch simulator: N rigs at once, a controller at 1 kHz (zero-order hold), RK4 in between.

One call simulates N parameter sets (:class:`~mckibben.plant.params.PlantParams` with scalar or
length-N fields) over the same or per-instance references. The hot loop is one Numba function
(compiled once, cached on disk). Controllers come in three forms:

- a *kernel spec* ``(kernel, istate0, iparams, fstate0, fparams)`` — a Numba ``@njit`` function
  and per-instance state/parameter rows (``docs/controller.md``; the firmware core's mirror
  :func:`mckibben.control.core.core_spec` gives one): the fast path;
- a plain Python callable ``f(t, adc, enc, p_ref_pa) -> (inlet, bleed)``: the slow path, for
  prototyping (every control period calls back into Python);
- no controller: an open-loop schedule of inlet/bleed PWM counts.

Timing: the controller samples the sensors at the start of each control period ``ts``, its
command is held for the period, and the plant is integrated with ``substeps`` RK4 steps of
``ts/substeps`` (default 1 ms and 10: 10 kHz).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from mckibben import hardware as HW
from mckibben.errors import InputError
from mckibben.plant import params as PP
from mckibben.plant import physics as ph

FLAG_NONFINITE = 1  #: the state became NaN or infinite (simulation of that instance stopped)
FLAG_ABOVE_SUPPLY = 2  #: the chamber rose above the supply pressure by more than 1 kPa


@dataclass(frozen=True)
class SimResult:
    """Sampled result of a batch simulation (row i is instance i, column k control period k).

    Attributes
    ----------
    t : numpy.ndarray
        Sample times, (n,). [s]
    pressure : numpy.ndarray
        True gauge pressure in the chamber at each sample, (N, n). [Pa]
    pressure_measured : numpy.ndarray
        Pressure as the controller saw it (ADC count scaled), (N, n). [Pa]
    length : numpy.ndarray
        Muscle length, (N, n). [m]
    force : numpy.ndarray
        Muscle pulling force, (N, n). [N]
    air_mass : numpy.ndarray
        Air in the chamber, (N, n). [kg]
    inlet, bleed : numpy.ndarray
        Valve commands applied during each period, (N, n). [PWM counts]
    faults : numpy.ndarray
        Controller fault flags, (N, n). [-]
    adc, encoder : numpy.ndarray
        Raw sensor readings, (N, n). [counts]
    reference : numpy.ndarray
        Pressure reference given to the controller, (N, n). [Pa]
    flags : numpy.ndarray
        Per instance: 1 non-finite state, 2 chamber above supply. [-]
    istate, fstate : numpy.ndarray
        The controllers' state at the end of the run (kernel path), (N, ·). [-]
    """

    t: np.ndarray
    pressure: np.ndarray
    pressure_measured: np.ndarray
    length: np.ndarray
    force: np.ndarray
    air_mass: np.ndarray
    inlet: np.ndarray
    bleed: np.ndarray
    faults: np.ndarray
    adc: np.ndarray
    encoder: np.ndarray
    reference: np.ndarray
    flags: np.ndarray
    istate: np.ndarray | None = None
    fstate: np.ndarray | None = None

    @cached_property
    def command(self) -> np.ndarray:
        """Signed valve command, inlet − bleed, computed once (callers index it per instance); read-only. [PWM counts]"""
        u = self.inlet.astype(float) - self.bleed.astype(float)
        u.flags.writeable = False
        return u

    def to_pandas(self, i: int = 0):
        """Instance ``i`` as a DataFrame with unit-suffixed columns."""
        import pandas as pd

        return pd.DataFrame({
            "time_s": self.t, "pressure_Pa": self.pressure[i], "pressure_measured_Pa": self.pressure_measured[i],
            "length_m": self.length[i], "force_N": self.force[i], "inlet_pwm": self.inlet[i],
            "bleed_pwm": self.bleed[i], "faults": self.faults[i], "reference_Pa": self.reference[i],
        })


@njit(cache=True)
def _splitmix(state):
    z = (state + np.uint64(0x9E3779B97F4A7C15)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    out = z
    out = ((out ^ (out >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    out = ((out ^ (out >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    out = out ^ (out >> np.uint64(31))
    return z, out


@njit(cache=True)
def _gauss(rng):
    """Standard normal deviate from a per-instance splitmix64 stream (Box–Muller)."""
    rng[0], a = _splitmix(rng[0])
    rng[0], b = _splitmix(rng[0])
    u1 = ((a >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740993.0)
    u2 = (b >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


@njit(cache=True)
def _run(kernel, istate, iparams, fstate, fparams, use_kernel, schedule, prm, s0, ref, n_steps, substeps, ts,
         out_p, out_pm, out_l, out_f, out_m, out_in, out_bl, out_fault, out_adc, out_enc, flags):
    n_inst = prm.shape[0]
    dt = ts / substeps
    k1 = np.empty(ph.NS)
    k2 = np.empty(ph.NS)
    k3 = np.empty(ph.NS)
    k4 = np.empty(ph.NS)
    tmp = np.empty(ph.NS)
    rng = np.zeros(1, dtype=np.uint64)
    per_instance_ref = ref.shape[0] > 1
    per_instance_sched = schedule.shape[0] > 1
    for i in range(n_inst):
        p = prm[i]
        s = s0[i].copy()
        rng[0] = np.uint64(int(p[PP.I_SEED]) & 0x7FFFFFFFFFFFFFFF) * np.uint64(2654435761) + np.uint64(i + 1)
        noise = p[PP.I_PRESSURE_NOISE]
        for k in range(n_steps):
            pg = ph.gauge_pressure(s[ph.S_MASS], s[ph.S_LEN], p)
            length = s[ph.S_LEN]
            meas = pg
            if noise > 0.0:
                meas += noise * _gauss(rng)
            adc = HW.adc_count(meas, p[PP.I_PA_PER_COUNT], p[PP.I_ADC_ZERO])
            enc = HW.encoder_count(length, p[PP.I_NOMINAL_LENGTH], p[PP.I_ENCODER_RESOLUTION])
            r = ref[i if per_instance_ref else 0, k]
            if use_kernel:
                u_in, u_bl, fault = kernel(istate[i], iparams[i], fstate[i], fparams[i], adc, enc, True, r)
            else:
                row = i if per_instance_sched else 0
                u_in = schedule[row, k, 0]
                u_bl = schedule[row, k, 1]
                fault = 0
            out_p[i, k] = pg
            out_pm[i, k] = HW.adc_pressure(adc, p[PP.I_PA_PER_COUNT], p[PP.I_ADC_ZERO])
            out_l[i, k] = length
            out_f[i, k] = ph.muscle_force(pg, length, p)
            out_m[i, k] = s[ph.S_MASS]
            out_in[i, k] = u_in
            out_bl[i, k] = u_bl
            out_fault[i, k] = fault
            out_adc[i, k] = adc
            out_enc[i, k] = enc
            xin_t = ph.valve_target(u_in, p)
            xbl_t = ph.valve_target(u_bl, p)
            for _ in range(substeps):
                ph.rk4_step(s, p, xin_t, xbl_t, dt, k1, k2, k3, k4, tmp)
            finite = True
            for j in range(ph.NS):
                if not math.isfinite(s[j]):
                    finite = False
            if not finite:
                flags[i] |= 1
                for kk in range(k + 1, n_steps):
                    out_p[i, kk] = np.nan
                    out_pm[i, kk] = np.nan
                    out_l[i, kk] = np.nan
                    out_f[i, kk] = np.nan
                    out_m[i, kk] = np.nan
                break
            if pg > p[PP.I_SUPPLY_PRESSURE] + 1e3:
                flags[i] |= 2


@njit(cache=True)
def _no_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    return 0, 0, 0


@njit(cache=True)
def _initial_states(prm, p_init):
    n = prm.shape[0]
    s0 = np.zeros((n, ph.NS))
    for i in range(n):
        p = prm[i]
        pg = p_init[i]
        length = ph.static_length(pg, p)
        s0[i, ph.S_LEN] = length
        s0[i, ph.S_MASS] = ph.mass_for_pressure(pg, length, p)
    return s0


def _as_rows(x, n_inst: int, n_steps: int, name: str, dtype=float) -> np.ndarray:
    a = np.asarray(x, dtype=dtype)
    if a.ndim == 0:
        return np.full((1, n_steps), a, dtype=dtype)
    if a.ndim == 1:
        if a.shape[0] != n_steps:
            raise InputError(f"{name}: {a.shape[0]} samples, the run has {n_steps} control periods")
        return a[None, :]
    if a.ndim == 2 and a.shape[1] == n_steps and a.shape[0] in (1, n_inst):
        return a
    raise InputError(f"{name}: shape {a.shape}; want (n,) or (N, n) with N = {n_inst}, n = {n_steps}")


def simulate(
    plant: PP.PlantParams | None = None,
    duration: float = 1.0,
    *,
    controller=None,
    reference=0.0,
    inlet=0,
    bleed=0,
    n: int | None = None,
    ts: float = 1e-3,
    substeps: int = 10,
    initial_pressure=0.0,
    initial_length=None,
) -> SimResult:
    """Simulate N rigs, open loop or under a controller.

    Parameters
    ----------
    plant : PlantParams, optional
        Parameters, scalars or arrays of N; default the calibrated paper rig (97 mm muscle).
    duration : float, default 1.0
        Simulated time; a whole number of control periods. [s]
    controller : tuple or callable, optional
        A kernel spec ``(kernel, istate0, iparams, fstate0, fparams)`` (rows for N instances; copied,
        the final state is returned), or a Python callable ``f(t, adc, enc, p_ref_pa) ->
        (inlet, bleed)`` (slow path). None: open loop on ``inlet``/``bleed``.
    reference : float or array_like, default 0.0
        Pressure reference per control period, scalar, (n,) or (N, n). [Pa]
    inlet, bleed : int or array_like, default 0
        Open-loop PWM counts (0–255) per control period, scalar, (n,) or (N, n). [counts]
    n : int, optional
        Number of instances when every parameter is a scalar. [-]
    ts : float, default 1e-3
        Control period. [s]
    substeps : int, default 10
        RK4 steps per control period. [-]
    initial_pressure : float or array_like, default 0.0
        Starting gauge pressure, scalar or (N,). [Pa]
    initial_length : float or array_like, optional
        Starting muscle length, scalar or (N,); default the static equilibrium under the load. [m]

    Returns
    -------
    SimResult
        The sampled run.
    """
    plant = plant or PP.PlantParams()
    if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
        raise InputError(f"substeps = {substeps!r}: a whole number >= 1 of plant steps per control period")
    if not (ts > 0 and math.isfinite(ts)):
        raise InputError(f"ts = {ts!r}: the control period must be a positive number of seconds")
    steps = duration / ts
    if not (duration > 0 and math.isfinite(duration)) or abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
        raise InputError(f"duration = {duration!r} s: must be a positive whole number of control periods ({ts:g} s)")
    n_steps = int(round(steps))
    spec = controller if isinstance(controller, tuple) else None
    n_ctrl = spec[1].shape[0] if spec is not None else None
    n_inst = n if n is not None else (n_ctrl if n_ctrl is not None else plant.size())
    if plant.size() not in (1, n_inst):
        raise InputError(f"plant parameters describe {plant.size()} instances, the run has {n_inst}")
    prm = plant.pack(n_inst)
    ref = _as_rows(reference, n_inst, n_steps, "reference")
    p_init = np.broadcast_to(np.asarray(initial_pressure, dtype=float), (n_inst,)).copy()
    if np.any(p_init < 0) or np.any(p_init > prm[:, PP.I_SUPPLY_PRESSURE]):
        raise InputError("initial_pressure: must be between 0 and the supply pressure")
    if initial_length is None:
        s0 = _initial_states(prm, p_init)
    else:
        l_init = np.broadcast_to(np.asarray(initial_length, dtype=float), (n_inst,))
        lmax = prm[:, PP.I_K1] * prm[:, PP.I_STRAND_LENGTH] + prm[:, PP.I_K2]
        if np.any(~(l_init > 0)) or np.any(l_init >= lmax):
            raise InputError("initial_length: must be > 0 and shorter than the straightened braid")
        s0 = np.zeros((n_inst, ph.NS))
        s0[:, ph.S_LEN] = l_init
        s0[:, ph.S_MASS] = [ph.mass_for_pressure(pg, ln, row) for pg, ln, row in zip(p_init, l_init, prm)]
    sched = np.zeros((1, n_steps, 2), dtype=np.int64)
    if controller is None:
        a = _as_rows(inlet, n_inst, n_steps, "inlet", np.int64)
        b = _as_rows(bleed, n_inst, n_steps, "bleed", np.int64)
        if a.min() < 0 or a.max() > 255 or b.min() < 0 or b.max() > 255:
            raise InputError("inlet/bleed: PWM counts must be in 0..255")
        rows = max(a.shape[0], b.shape[0])
        sched = np.empty((rows, n_steps, 2), dtype=np.int64)
        sched[:, :, 0] = a
        sched[:, :, 1] = b
    out = dict(
        out_p=np.empty((n_inst, n_steps)), out_pm=np.empty((n_inst, n_steps)), out_l=np.empty((n_inst, n_steps)),
        out_f=np.empty((n_inst, n_steps)), out_m=np.empty((n_inst, n_steps)),
        out_in=np.empty((n_inst, n_steps), dtype=np.int64), out_bl=np.empty((n_inst, n_steps), dtype=np.int64),
        out_fault=np.empty((n_inst, n_steps), dtype=np.int64), out_adc=np.empty((n_inst, n_steps), dtype=np.int64),
        out_enc=np.empty((n_inst, n_steps), dtype=np.int64),
    )
    flags = np.zeros(n_inst, dtype=np.int64)
    dummy_i = np.zeros((n_inst, 1), dtype=np.int64)
    dummy_f = np.zeros((n_inst, 1))
    if spec is not None:
        kernel, i0, ip, f0, fp = spec
        istate, iparams = np.array(i0, dtype=np.int64), np.ascontiguousarray(ip, dtype=np.int64)
        fstate, fparams = np.array(f0, dtype=float), np.ascontiguousarray(fp, dtype=float)
        for name, a in (("istate0", istate), ("iparams", iparams), ("fstate0", fstate), ("fparams", fparams)):
            if a.ndim != 2 or a.shape[0] != n_inst:
                raise InputError(f"controller {name}: shape {a.shape}, want ({n_inst}, ·)")
        _run_cached(kernel, istate, iparams, fstate, fparams, True, sched, prm, s0, ref, n_steps, int(substeps),
                    float(ts), *out.values(), flags)
        return _result(n_steps, ts, out, ref, n_inst, flags, istate, fstate)
    if callable(controller):
        _run_python(controller, sched, prm, s0, ref, n_steps, int(substeps), float(ts), out, flags)
        return _result(n_steps, ts, out, ref, n_inst, flags)
    if controller is not None:
        raise InputError("controller: a kernel spec tuple, a Python callable, or None for open loop")
    _run_cached(_no_kernel, dummy_i, dummy_i, dummy_f, dummy_f, False, sched, prm, s0, ref, n_steps, int(substeps),
                float(ts), *out.values(), flags)
    return _result(n_steps, ts, out, ref, n_inst, flags)


def _run_cached(*args):
    """Call :func:`_run`, retrying once if Numba fails to *save* the new overload to its cache.

    Numba's on-disk cache cannot re-pickle its index once it holds the type of a kernel compiled
    by another process ("underlying object has vanished"). The failure is in saving, after the
    overload was compiled and registered, and before the run started: the retry runs in memory.
    """
    try:
        _run(*args)
    except ReferenceError:
        _run(*args)


def _run_python(f, sched, prm, s0, ref, n_steps, substeps, ts, out, flags):
    """Slow path: a Python callable as the controller, called every control period."""
    n_inst = prm.shape[0]
    counter = {"k": 0}

    def kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
        k = counter["k"]
        counter["k"] = k + 1
        u_in, u_bl = f((k % n_steps) * ts, adc, enc, p_ref_pa)
        u_in, u_bl = int(u_in), int(u_bl)
        if not (0 <= u_in <= 255 and 0 <= u_bl <= 255):
            raise InputError(f"controller returned ({u_in}, {u_bl}); PWM counts must be in 0..255")
        return u_in, u_bl, 0

    dummy_i = np.zeros((n_inst, 1), dtype=np.int64)
    dummy_f = np.zeros((n_inst, 1))
    _run.py_func(kernel, dummy_i, dummy_i, dummy_f, dummy_f, True, sched, prm, s0, ref, n_steps, substeps, ts,
                 *out.values(), flags)


def _result(n_steps, ts, out, ref, n_inst, flags, istate=None, fstate=None) -> SimResult:
    return SimResult(
        t=np.arange(n_steps) * ts,
        pressure=out["out_p"], pressure_measured=out["out_pm"], length=out["out_l"], force=out["out_f"],
        air_mass=out["out_m"], inlet=out["out_in"], bleed=out["out_bl"], faults=out["out_fault"],
        adc=out["out_adc"], encoder=out["out_enc"],
        reference=np.broadcast_to(ref, (n_inst, n_steps)).copy(), flags=flags, istate=istate, fstate=fstate,
    )


@njit(cache=True)
def _advance(s, p, inlet, bleed, dt, substeps, k1, k2, k3, k4, tmp):
    xin_t = ph.valve_target(inlet, p)
    xbl_t = ph.valve_target(bleed, p)
    for _ in range(substeps):
        ph.rk4_step(s, p, xin_t, xbl_t, dt, k1, k2, k3, k4, tmp)


class PlantStepper:
    """One rig stepped a control period at a time, for live use (the device emulator).

    :func:`simulate` runs whole experiments; a stepper keeps its state between calls so a
    controller outside the simulator (the firmware core driven over the serial link) can close
    the loop in real time: ``sense()`` the sensors, then ``advance(inlet, bleed)`` one period.

    Parameters
    ----------
    plant : PlantParams, optional
        One rig (scalar fields); default the calibrated rig.
    ts : float, default 1e-3
        Control period. [s]
    substeps : int, default 10
        RK4 steps per period. [-]
    initial_pressure : float, default 0.0
        Starting gauge pressure. [Pa]
    """

    def __init__(self, plant: PP.PlantParams | None = None, ts: float = 1e-3, substeps: int = 10,
                 initial_pressure: float = 0.0):
        plant = plant or PP.PlantParams()
        if plant.size() != 1:
            raise InputError("PlantStepper: one rig (scalar parameters) only")
        if not (isinstance(substeps, (int, np.integer)) and substeps >= 1) or not ts > 0:
            raise InputError("PlantStepper: ts > 0 and a whole number of substeps >= 1")
        self.p = plant.pack(1)[0]
        self.s = _initial_states(self.p[None, :], np.array([float(initial_pressure)]))[0].copy()
        self.ts, self.substeps = float(ts), int(substeps)
        self.t = 0.0
        self._work = tuple(np.empty(ph.NS) for _ in range(5))
        self._rng = np.array([np.uint64(int(self.p[PP.I_SEED]) * 2654435761 + 1)], dtype=np.uint64)

    @property
    def pressure(self) -> float:
        """True gauge pressure. [Pa]"""
        return float(ph.gauge_pressure(self.s[ph.S_MASS], self.s[ph.S_LEN], self.p))

    @property
    def length(self) -> float:
        """Muscle length. [m]"""
        return float(self.s[ph.S_LEN])

    def sense(self) -> tuple[int, int]:
        """The sensors now: ``(adc, encoder)`` counts, with the configured noise."""
        p = self.p
        meas = self.pressure
        if p[PP.I_PRESSURE_NOISE] > 0:
            meas += p[PP.I_PRESSURE_NOISE] * _gauss(self._rng)
        adc = int(HW.adc_count(meas, p[PP.I_PA_PER_COUNT], p[PP.I_ADC_ZERO]))
        enc = int(HW.encoder_count(self.length, p[PP.I_NOMINAL_LENGTH], p[PP.I_ENCODER_RESOLUTION]))
        return adc, enc

    def advance(self, inlet: int, bleed: int) -> None:
        """Hold the valve commands for one control period.

        Parameters
        ----------
        inlet, bleed : int
            PWM counts 0..255. [counts]
        """
        if not (0 <= inlet <= 255 and 0 <= bleed <= 255):
            raise InputError(f"PlantStepper.advance: PWM counts must be in 0..255, got ({inlet}, {bleed})")
        _advance(self.s, self.p, float(inlet), float(bleed), self.ts / self.substeps, self.substeps, *self._work)
        self.t += self.ts
