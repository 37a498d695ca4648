"""The batch simulator: N rigs at once, a controller at 1 kHz (zero-order hold), RK4 in between.

One call simulates N parameter sets (:class:`~mckibben.plant.params.PlantParams` with scalar or
length-N fields) over the same or per-instance references. The hot loop is one Numba function
(compiled once, cached on disk): instances in blocks of :data:`~mckibben.plant.physics.W` lanes
(structure of arrays, lanes innermost so the compiler vectorizes), blocks spread over every core
on a thread pool (the runner releases the GIL). Each instance is computed by the same arithmetic whatever its block or thread, so
results do not depend on the number of threads. Controllers come in three forms:

- a *kernel spec* ``(kernel, istate0, iparams, fstate0, fparams)`` — a Numba ``@njit`` function
  and per-instance state/parameter rows (``docs/controller.md``; the firmware core's mirror
  :func:`mckibben.control.core.core_spec` gives one): the fast path;
- a plain Python callable ``f(t, adc, enc, p_ref_pa) -> (inlet, bleed)``: the slow path, for
  prototyping (every control period calls back into Python);
- no controller: an open-loop schedule of inlet/bleed PWM counts.

Timing: the controller samples the sensors at the start of each control period ``ts``, its
command is held for the period, and the plant is integrated with ``substeps`` RK4 steps of
``ts/substeps`` (default 1 ms and 10: 10 kHz). That step is an accuracy choice, tested: on the
reference closed loop the pressure stays within 1 kPa of a run with ten times finer steps.
"""

from __future__ import annotations

import math
import threading
import types
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from mckibben import _jit
from mckibben import hardware as HW
from mckibben._jit import kernel as compiled  # the one decorator (`kernel` here names a controller kernel)
from mckibben.errors import ArgumentTypeError, InputError, UnreachableError, check_array, check_instance, check_int, check_real
from mckibben.limits import SECONDS_PER_SAMPLE, check_budget
from mckibben.results import TimeResponse
from mckibben.models import laws as LW
from mckibben.models.laws._base import evaluate_points
from mckibben.plant import _runner
from mckibben.plant import params as PP
from mckibben.plant import packing as PK
from mckibben.plant import physics as ph
from mckibben.plant.physics import NS, W
from mckibben.plant._runner import FLAG_ABOVE_SUPPLY, FLAG_END_STOP, FLAG_NONFINITE  # noqa: F401 (public here)

#: The reference left the rig's physical range [0, 1 MPa] somewhere: the controller's supervisor
#: held it in [0, p_max], so the run followed another reference than the one given.
FLAG_REFERENCE_OUTSIDE = 8

#: The recorded series of a :class:`SimResult`, in the simulator's order; ``simulate(record=...)`` picks some.
SERIES = ("pressure", "pressure_measured", "length", "force", "air_mass", "temperature", "inlet", "bleed", "faults",
          "adc", "encoder")
_OUT_KEYS = ("out_p", "out_pm", "out_l", "out_f", "out_m", "out_t", "out_in", "out_bl", "out_fault", "out_adc", "out_enc")
_SERIES_SET = frozenset(SERIES)
_INT_SERIES = frozenset(("inlet", "bleed", "faults", "adc", "encoder"))

_C = PK.Col
C_L0, C_KP, C_LF, C_KS, C_LFREE = (int(c) for c in (_C.nominal_length, _C.passive_stiffness, _C.load_force,
                                                   _C.spring_rate, _C.spring_free_length))


@dataclass(frozen=True, repr=False, eq=False)
class SimResult(TimeResponse):
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
        Pressure reference given to the controller, (N, n), read-only (the given reference broadcast). [Pa]
    flags : numpy.ndarray
        Per instance: 1 non-finite state, 2 chamber above supply, 4 an end stop reached, 8 the
        reference outside [0, 1 MPa] (held in range by the supervisor). [-]
    istate, fstate : numpy.ndarray
        The controllers' state at the end of the run (kernel path), (N, ·). [-]
    temperature : numpy.ndarray
        Gas temperature in the chamber, (N, n). [K]
    recorded : tuple of str
        The series of :data:`SERIES` this run recorded (``simulate(record=...)``); reading another
        raises ``AttributeError`` naming it.
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
    temperature: np.ndarray | None = None
    recorded: tuple = SERIES

    SIGNALS = ("pressure", "pressure_measured", "length", "force", "inlet", "bleed", "faults", "reference")

    def __getattribute__(self, name):
        if name in _SERIES_SET and name not in object.__getattribute__(self, "recorded"):
            raise AttributeError(f"SimResult.{name}: not recorded (this run was simulated with record="
                                 f"{object.__getattribute__(self, 'recorded')!r})")
        return object.__getattribute__(self, name)

    def __repr__(self) -> str:
        n, k = self.reference.shape
        return (f"SimResult({n} instances x {k} periods, recorded: {', '.join(self.recorded)}; "
                f"flagged: {int(np.count_nonzero(self.flags))})")

    @cached_property
    def command(self) -> np.ndarray:
        """Signed valve command, inlet − bleed, computed once (callers index it per instance); read-only. [PWM counts]"""
        u = self.inlet.astype(float) - self.bleed.astype(float)
        u.flags.writeable = False
        return u

    def to_pandas(self, i: int = 0):
        """Instance ``i`` as a DataFrame with unit-suffixed columns."""
        return self.frame(i)


def _runner_of(kernel):
    """The compiled runner module bound to a controller kernel (:mod:`mckibben.plant._runner`, generated once)."""
    if kernel is None:
        return _runner
    if not (isinstance(kernel, numba.core.registry.CPUDispatcher) or numba.config.DISABLE_JIT and callable(kernel)):
        raise InputError(f"controller kernel: a Numba @njit function, not a {type(kernel).__name__}")
    return _jit.module_for(_runner, "controller_kernel", kernel)


def _run(runner, use_kernel, *args):
    """Every block, spread over ``numba.get_num_threads()`` threads in contiguous shares.

    Each instance is computed by the same code whatever its share, so the results do not depend
    on the number of threads. (Threads over a ``nogil`` function rather than ``prange``: the
    runner's blocks are independent and a thread pool needs no parallel compilation.)
    """
    n = args[5].shape[0]
    nb = (n + W - 1) // W
    threads = max(1, min(numba.get_num_threads(), nb))
    if threads == 1:
        runner.run_blocks(use_kernel, 0, nb, *args)
        return
    edges = [nb * k // threads for k in range(threads + 1)]
    with ThreadPoolExecutor(threads) as pool:
        futures = [pool.submit(runner.run_blocks, use_kernel, edges[k], edges[k + 1], *args) for k in range(threads)]
        for f in futures:
            f.result()



@compiled(error_model="numpy", inline="always")
def _balance(law, prm, th, w, i, pg, length):
    """Muscle pull less load pull of instance i at a length (the integrator's forces, no friction). [N]"""
    f = ph.law_value(law, pg, length, th, i, w)
    f = 0.0 if f != f else f
    stretch = length - prm[i, C_L0]
    fm = (f if f > 0.0 else 0.0) + prm[i, C_KP] * (stretch if stretch > 0.0 else 0.0)
    return fm - (prm[i, C_LF] - prm[i, C_KS] * (length - prm[i, C_LFREE]))


@compiled(error_model="numpy")
def _bracket_balance(law, prm, th, w, pg, a, b, status):
    """Narrow each instance's bracket [a, b] onto the root of :func:`_balance`, in place; ``status`` as
    :func:`static_equilibrium`'s (0 between the stops, 1 straight stop, 2 locking stop).

    The balance rises with length (``check_force_law`` refuses laws where it would not): its root is
    bracketed on a grid of 64 lengths, nine times over (43 mm / 63⁹ ≈ 3e-18 m: to the last bit).
    """
    for i in range(prm.shape[0]):
        lo = a[i]
        hi = b[i]
        if _balance(law, prm, th, w, i, pg[i], hi) < 0.0:
            status[i] = 1
        elif _balance(law, prm, th, w, i, pg[i], lo) > 0.0:
            status[i] = 2
        for _ in range(9):
            first = 63
            for m in range(64):
                if _balance(law, prm, th, w, i, pg[i], lo + (hi - lo) * (m / 63.0)) > 0.0:
                    first = m
                    break
            first = first if first > 1 else 1
            lo, hi = lo + (hi - lo) * ((first - 1) / 63.0), lo + (hi - lo) * (first / 63.0)
        a[i] = lo
        b[i] = hi


#: Batches up to this many instances bracket their static start through the law's NumPy face
#: (:func:`_bracket_balance_small`) rather than :func:`_bracket_balance`: the same decisions on
#: the same numbers, without compiling a bisection that inlines every law (about 8 s on first use,
#: most of a single-rig command's cold start). Larger batches (sweeps) take the compiled loop,
#: whose early exit from each grid is faster there.
SMALL_BATCH = 256


def _bracket_balance_small(law, prm, th, pg, a, b, status):
    """:func:`_bracket_balance`, vectorized over instances and each grid of 64 lengths, in place.

    Every balance is the compiled law at the same point (its NumPy face,
    :func:`mckibben.models.laws._base.evaluate_kernel`'s loop) followed by the same IEEE operations
    as :func:`_balance` in the same order; the first positive point of a grid is the one the
    compiled loop stops at. So the brackets are the same to the last bit (tested on every law).
    """
    n = prm.shape[0]
    kern = LW.LAWS[LW.LAW_NAMES[law]].kernel
    thf = np.ascontiguousarray(th).ravel()
    l0, kp = prm[:, C_L0][:, None], prm[:, C_KP][:, None]
    lf, ks, lfree = prm[:, C_LF][:, None], prm[:, C_KS][:, None], prm[:, C_LFREE][:, None]

    def balance(length):  # (n, k) lengths -> (n, k) balances, as _balance
        k = length.shape[1]
        f = evaluate_points(kern, np.repeat(pg, k), np.ascontiguousarray(length).ravel(), thf,
                            np.repeat(np.arange(n, dtype=np.int64), k), n).reshape(n, k)
        f = np.where(f != f, 0.0, f)
        stretch = length - l0
        fm = np.where(f > 0.0, f, 0.0) + kp * np.where(stretch > 0.0, stretch, 0.0)
        return fm - (lf - ks * (length - lfree))

    lo, hi = a.copy(), b.copy()
    ends = balance(np.stack([hi, lo], axis=1))
    status[:] = np.where(ends[:, 0] < 0.0, 1, np.where(ends[:, 1] > 0.0, 2, 0))
    frac = np.arange(64) / 63.0
    for _ in range(9):
        pos = balance(lo[:, None] + (hi - lo)[:, None] * frac[None, :]) > 0.0
        first = np.where(pos.any(axis=1), pos.argmax(axis=1), 63)
        first = np.where(first > 1, first, 1)
        lo, hi = lo + (hi - lo) * ((first - 1) / 63.0), lo + (hi - lo) * (first / 63.0)
    a[:] = lo
    b[:] = hi


def static_equilibrium(prm: np.ndarray, law: int, theta: np.ndarray, pressure) -> tuple[np.ndarray, np.ndarray]:
    """Rest length of each instance at a fixed gauge pressure, friction-free: the plant's own statics.

    Solves F_muscle(P, l) = F_load(l) by bisection between the end stops (the same force as the
    integrator: the law's kernel, never pushing, plus the tube's passive stiffness). Where no
    length between the stops balances the load, the muscle rests on a stop, and ``status`` says
    which.

    Parameters
    ----------
    prm : numpy.ndarray
        Packed ``(N, NP)`` parameters.
    law : int
        Law index (:data:`mckibben.models.laws.LAW_NAMES`).
    theta : numpy.ndarray
        ``(NTH, N)`` law parameters.
    pressure : array_like
        Gauge pressure, scalar or (N,). [Pa]

    Returns
    -------
    length : numpy.ndarray
        (N,) rest lengths. [m]
    status : numpy.ndarray
        (N,) 0 balanced between the stops, 1 on the straight-braid stop (the load is more than the
        muscle pulls even straight), 2 on the locking stop (the muscle pulls more than the load even
        fully contracted), 3 blocked (held at the rest length). [-]
    """
    c = PK.Col
    n = prm.shape[0]
    pg = np.array(np.broadcast_to(np.asarray(pressure, dtype=float), (n,)))  # writable: one compiled type
    lo = prm[:, c.l_min].copy()
    hi = prm[:, c.l_max].copy()
    th = np.ascontiguousarray(theta, dtype=float)
    a, b = lo.copy(), hi.copy()
    status = np.zeros(n, dtype=np.int64)
    if n <= SMALL_BATCH:
        _bracket_balance_small(int(law), prm, th, pg, a, b, status)
    else:
        _bracket_balance(int(law), np.ascontiguousarray(prm), th.ravel(), th.shape[1], pg, a, b, status)
    length = np.where(status == 1, hi, np.where(status == 2, lo, 0.5 * (a + b)))
    blocked = prm[:, c.mobile] == 0
    return np.where(blocked, prm[:, c.nominal_length], length), np.where(blocked, 3, status)


def static_length(plant: PP.PlantParams | None = None, pressure=0.0) -> np.ndarray:
    """The length at which each instance's muscle balances its load at a gauge pressure (no friction).

    Parameters
    ----------
    plant : PlantParams, optional
        The rig(s); default the calibrated one.
    pressure : array_like, default 0.0
        Gauge pressure, scalar or (N,). [Pa]

    Returns
    -------
    numpy.ndarray
        (N,) lengths. [m]

    Raises
    ------
    UnreachableError
        Where no length between the braid's end stops balances the load ("no solution"): the
        message names the instance, the pressure, the load and the stop the muscle would rest on.
    """
    prm, law, th, pressure = _static_inputs(plant, pressure)
    return _balanced(prm, law, th, pressure)


def static_branch_lengths(plant: PP.PlantParams | None = None, pressure=0.0) -> tuple[np.ndarray, np.ndarray]:
    """The lengths far along the inflating and deflating branches of the loop: the braid friction's slip, the play.

    Far along a branch the Dahl element is at its slip limit F_c = ``friction_force`` +
    ``friction_per_pa``·P against the motion (``docs/plant.md``): contracting (inflating), the muscle
    pulls the load plus F_c; lengthening (deflating), the load less F_c. A play on the pressure
    (``play_threshold`` r) is at its branch state there: the law sees P − r inflating, P + r
    deflating (:func:`mckibben.models.hysteresis.direction.branch_state`). Each branch's length is the
    plant's static balance (:func:`static_equilibrium`, the same law and tube) with the load and the
    law's pressure so shifted; their difference is the plant's own up/down gap at that pressure and load.

    Parameters
    ----------
    plant : PlantParams, optional
        The rig(s); default the calibrated one.
    pressure : array_like, default 0.0
        Gauge pressure, scalar or (N,). [Pa]

    Returns
    -------
    inflate, deflate : numpy.ndarray
        (N,) lengths on the inflating branch (the longer: the muscle pulls F_c more) and on the
        deflating one. [m]

    Raises
    ------
    UnreachableError
        Where a branch's balance has no length between the end stops, as :func:`static_length`.

    References
    ----------
    Dahl, P. R. (1968), the slip limit; [mpam-characterization] §IV (the measured loop); Kuhnen (2003),
    the play operator.
    """
    prm, law, th, pressure = _static_inputs(plant, pressure)
    c = PK.Col
    pg = np.broadcast_to(np.asarray(pressure, dtype=float), (prm.shape[0],))
    slip = prm[:, c.friction_force] + prm[:, c.friction_per_pa] * np.maximum(pg, 0.0)  # physics._after_step's F_c
    branches = []
    for sign in (1.0, -1.0):
        shifted = prm.copy()
        shifted[:, c.load_force] = prm[:, c.load_force] + sign * slip
        branches.append(_balanced(shifted, law, th, pg - sign * prm[:, c.play_threshold]))  # the play: P ∓ r
    return branches[0], branches[1]


def _static_inputs(plant, pressure):
    """The checked plant, packed, and the checked pressure of :func:`static_length` and its branches."""
    plant = PP.PlantParams() if plant is None else check_instance(plant, "plant", PP.PlantParams, "a PlantParams")
    pressure = check_array(pressure, "pressure", lo=-ph.P_ATM, unit="Pa")  # gauge: down to vacuum
    prm, law, th, _ = plant.prepare()
    if pressure.ndim > 1 or pressure.size not in (1, prm.shape[0]):
        raise InputError(f"pressure: shape {pressure.shape}; want a scalar or ({prm.shape[0]},), one per instance")
    return prm, law, th, pressure


def _balanced(prm, law, th, pressure) -> np.ndarray:
    """:func:`static_equilibrium`'s lengths, or the :class:`UnreachableError` of the first instance on a stop."""
    length, status = static_equilibrium(prm, law, th, pressure)
    bad = np.flatnonzero((status == 1) | (status == 2))
    if bad.size:
        i = bad[0]
        c = PK.Col
        p = float(np.broadcast_to(np.asarray(pressure, dtype=float), (prm.shape[0],))[i])
        stop = "straight-braid" if status[i] == 1 else "locking"
        raise UnreachableError(
            f"no static solution for instance {i} at {p / 1e6:g} MPa under {prm[i, c.load_force]:g} N: no length "
            f"between {prm[i, c.l_min] * 1e3:.1f} and {prm[i, c.l_max] * 1e3:.1f} mm balances the load; the muscle "
            f"rests on its {stop} stop at {length[i] * 1e3:.1f} mm")
    return length


def initial_states(prm: np.ndarray, law: int, theta: np.ndarray, p_init, l_init=None,
                   thermal: str = "energy") -> np.ndarray:
    """``(N, NS)`` states at rest: pressure, gas temperature, shut valves, the static length (or ``l_init``),
    the play's output at the gauge pressure.

    Parameters
    ----------
    prm, law, theta
        As from :meth:`PlantParams.prepare`.
    p_init : array_like
        Gauge pressure, scalar or (N,). [Pa]
    l_init : array_like, optional
        Length, scalar or (N,); default :func:`static_equilibrium`. [m]
    thermal : str, default "energy"
        ``"energy"``: the gas at the wall temperature; ``"polytropic"``: at the temperature its
        compression from the atmosphere gives, T = T_s·(p/p_atm)^((n−1)/n).
    """
    c = PK.Col
    n = prm.shape[0]
    pg = np.broadcast_to(np.asarray(p_init, dtype=float), (n,))
    s0 = np.zeros((n, NS))
    s0[:, ph.S_P] = pg + ph.P_ATM
    s0[:, ph.S_PLAY] = s0[:, ph.S_P] - ph.P_ATM  # the play's output at rest: the gauge pressure (as the kernels see it)
    if thermal == "energy":
        s0[:, ph.S_T] = prm[:, c.temperature]
    else:
        nn = prm[:, c.polytropic_n]
        s0[:, ph.S_T] = prm[:, c.temperature] * (s0[:, ph.S_P] / ph.P_ATM) ** ((nn - 1.0) / nn)
    if l_init is None:
        s0[:, ph.S_LEN] = static_equilibrium(prm, law, theta, pg)[0]
    else:
        s0[:, ph.S_LEN] = np.broadcast_to(np.asarray(l_init, dtype=float), (n,))
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
    ts: float = HW.CONTROL_PERIOD,
    substeps: int = 10,
    initial_pressure=0.0,
    initial_length=None,
    record="all",
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
        Starting muscle length, scalar or (N,), between the braid's end stops; default the static
        equilibrium under the load. [m]
    record : "all" or iterable of str, default "all"
        Which series of :data:`SERIES` to keep, each (N, n): a sweep of many long runs that needs only
        the pressure keeps ``("pressure",)`` and spares writing (and the kernel's zeroing of) the rest,
        11 × 8 bytes per instance and period in all. The others are not recorded: reading one raises.

    Returns
    -------
    SimResult
        The sampled run.
    """
    plant = _check_plant(plant)
    substeps = check_int(substeps, "substeps", lo=1)
    ts = check_real(ts, "ts", lo=0.0, lo_open=True, unit="s")
    duration = check_real(duration, "duration", lo=0.0, lo_open=True, unit="s")
    if n is not None:
        n = check_int(n, "n", lo=1)
    steps = duration / ts
    if not math.isfinite(steps):
        raise InputError(f"duration = {duration!r} s: {duration:g} s / ts = {ts:g} s overflows; far beyond any run")
    if round(steps) < 1 or abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
        raise InputError(f"duration = {duration!r} s: must be a positive whole number of control periods "
                         f"(ts = {ts:g} s)")
    n_steps = int(round(steps))
    spec = controller if isinstance(controller, tuple) else None
    n_ctrl = spec[1].shape[0] if spec is not None else None
    n_inst = n if n is not None else (n_ctrl if n_ctrl is not None else plant.size())
    if plant.size() not in (1, n_inst):
        raise InputError(f"plant parameters describe {plant.size()} instances, the run has {n_inst}")
    recorded = _recorded(record)
    if controller is not None and not isinstance(controller, tuple) and not callable(controller):
        raise ArgumentTypeError(f"controller: {controller!r} is not a kernel spec tuple, a Python callable, or None "
                                "for open loop")
    # the size and time budget (mckibben.limits), before anything is allocated
    check_budget("duration/ts x n (instances) x substeps", float(n_inst) * float(n_steps),
                 bytes_per_sample=8.0 * (len(recorded) + 1),
                 seconds_per_sample=SECONDS_PER_SAMPLE * max(1.0, substeps / 10.0))
    check_int(substeps, "substeps", lo=1, hi=MAX_SUBSTEPS)  # after the budget, which names a huge one with the rest
    prm, law, theta = _prepared(plant, n_inst)
    # any finite reference: the controller's supervisor holds it in [0, p_max] (and is tested doing so)
    ref = _as_rows(check_array(reference, "reference", unit="Pa"), n_inst, n_steps, "reference")
    p_init = _per_instance(check_array(initial_pressure, "initial_pressure", unit="Pa"), n_inst, "initial_pressure")
    if np.any(~(p_init >= 0)) or np.any(p_init > prm[:, PK.Col.supply_pressure]):
        raise InputError("initial_pressure: must be between 0 and the supply pressure")
    if initial_length is not None:
        l_init = _per_instance(check_array(initial_length, "initial_length", unit="m"), n_inst, "initial_length")
        if np.any(~(l_init >= prm[:, PK.Col.l_min])) or np.any(~(l_init <= prm[:, PK.Col.l_max])):
            raise InputError("initial_length: must lie between the braid's end stops, "
                             f"{prm[0, PK.Col.l_min] * 1e3:.1f}..{prm[0, PK.Col.l_max] * 1e3:.1f} mm "
                             "(locking angle and straight braid, eq. 2)")
    else:
        l_init = None
    s0 = initial_states(prm, law, theta, p_init, l_init, plant.thermal)
    sched = np.zeros((1, n_steps, 2), dtype=np.int64)
    if controller is None:
        a = _as_rows(_counts(inlet, "inlet"), n_inst, n_steps, "inlet", np.int64)
        b = _as_rows(_counts(bleed, "bleed"), n_inst, n_steps, "bleed", np.int64)
        if a.min() < 0 or a.max() > 255 or b.min() < 0 or b.max() > 255:
            raise InputError("inlet/bleed: PWM counts must be in 0..255")
        rows = max(a.shape[0], b.shape[0])
        sched = np.empty((rows, n_steps, 2), dtype=np.int64)
        sched[:, :, 0] = a
        sched[:, :, 1] = b
    out = _outputs(n_inst, n_steps, recorded)
    rec = np.array([-1 if name in recorded else 0 for name in SERIES], dtype=np.int64)
    flags = np.zeros(n_inst, dtype=np.int64)
    outside = (ref < 0.0) | (ref > HW.P_MAX_LIMIT)
    if outside.any():  # (rows: one per instance, or one for all)
        flags |= np.where(np.broadcast_to(outside.any(axis=1), (n_inst,)), FLAG_REFERENCE_OUTSIDE, 0)
    common = (sched, prm, theta, law, s0, ref, n_steps, int(substeps), float(ts))
    if spec is not None:
        kernel, i0, ip, f0, fp = spec
        istate, iparams = np.array(i0, dtype=np.int64), np.ascontiguousarray(ip, dtype=np.int64)
        fstate, fparams = np.array(f0, dtype=float), np.ascontiguousarray(fp, dtype=float)
        for name, a in (("istate0", istate), ("iparams", iparams), ("fstate0", fstate), ("fparams", fparams)):
            if a.ndim != 2 or a.shape[0] != n_inst:
                raise InputError(f"controller {name}: shape {a.shape}, want ({n_inst}, ·)")
        _run(_runner_of(kernel), True, istate, iparams, fstate, fparams, *common, *out.values(), flags, rec)
        return _result(n_steps, ts, out, ref, n_inst, flags, recorded, istate, fstate)
    dummy_i = np.zeros((n_inst, 1), dtype=np.int64)
    dummy_f = np.zeros((n_inst, 1))
    if callable(controller):
        _run_python(controller, dummy_i, dummy_f, common, out, flags, rec, n_inst, n_steps, float(ts))
        return _result(n_steps, ts, out, ref, n_inst, flags, recorded)
    if controller is not None:
        raise InputError("controller: a kernel spec tuple, a Python callable, or None for open loop")
    _run(_runner, False, dummy_i, dummy_i, dummy_f, dummy_f, *common, *out.values(), flags, rec)
    return _result(n_steps, ts, out, ref, n_inst, flags, recorded)


#: The most RK4 steps per control period: 1 µs steps at the 1 ms period, far past where the
#: integration has converged (the default 10 is tested against 100); more only costs time. [-]
MAX_SUBSTEPS = 1000


def _check_plant(plant) -> PP.PlantParams:
    """``plant``, or the calibrated rig for None; anything but a :class:`PlantParams` is refused."""
    if plant is None:
        return _default_plant()
    return check_instance(plant, "plant", PP.PlantParams, "a PlantParams")


def _counts(x, name: str) -> np.ndarray:
    """PWM counts: whole numbers 0..255 (a fractional count is refused: the valve takes whole counts)."""
    a = check_array(x, name, unit="counts")
    if a.size and (a.min() < 0 or a.max() > 255):
        raise InputError(f"{name}: PWM counts must be in 0..255")
    if a.size and np.any(a != np.floor(a)):
        raise InputError(f"{name}: {a[a != np.floor(a)].flat[0]:g} is not a whole number of PWM counts (0..255)")
    return a


def _per_instance(a: np.ndarray, n_inst: int, name: str) -> np.ndarray:
    """``a`` as one value per instance: a scalar or an array of ``n_inst`` (else InputError naming it)."""
    if a.ndim > 1 or (a.ndim == 1 and a.shape[0] not in (1, n_inst)):
        raise InputError(f"{name}: shape {a.shape}; give a scalar or one value per instance ({n_inst})")
    return np.broadcast_to(a, (n_inst,))


_DEFAULT: list = []


def _default_plant() -> PP.PlantParams:
    if not _DEFAULT:
        _DEFAULT.append(PP.PlantParams())
    return _DEFAULT[0]


def _prepared(plant: PP.PlantParams, n: int):
    """``plant.prepare(n)``, its force law checked (the check remembers the laws and ranges it passed)."""
    prm = plant.pack(n)
    name, th = plant.law(n)
    th = np.ascontiguousarray(th, dtype=float)
    PK.check_force_law(name, prm, th, plant._law_label())
    return prm, LW.LAW_INDEX[name], th


def _run_python(f, dummy_i, dummy_f, common, out, flags, rec, n_inst, n_steps, ts):
    """Slow path: a Python callable as the controller, called every control period (block by block)."""
    counter = {"k": 0}

    def kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
        k = counter["k"]
        counter["k"] = k + 1
        u_in, u_bl = f((k % n_steps) * ts, adc, enc, p_ref_pa)
        u_in, u_bl = int(u_in), int(u_bl)
        if not (0 <= u_in <= 255 and 0 <= u_bl <= 255):
            raise InputError(f"controller returned ({u_in}, {u_bl}); PWM counts must be in 0..255")
        return u_in, u_bl, 0

    run_block = types.FunctionType(_runner.run_block.py_func.__code__, dict(vars(_runner), controller_kernel=kernel))
    for b0 in range(0, n_inst, W):
        run_block(True, b0, min(W, n_inst - b0), dummy_i, dummy_i, dummy_f, dummy_f, *common, *out.values(), flags, rec)


def _huge_page_switch():
    """NumPy's process-wide switch of its huge-page advice (NumPy 2, then 1.x), or None."""
    import importlib

    for where in ("numpy._core.multiarray", "numpy.core.multiarray"):
        try:
            return getattr(importlib.import_module(where), "_set_madvise_hugepage", None)
        except ImportError:
            continue
    return None


_HUGE_PAGES = _huge_page_switch()
_ADVICE_LOCK = threading.Lock()  # the switch is process-wide: one simulate() at a time flips it


def _outputs(n_inst: int, n_steps: int, recorded: tuple) -> dict:
    """The output arrays, allocated without NumPy's transparent-huge-page advice.

    NumPy advises the kernel to back every large array with 2 MB pages; where the kernel then
    compacts memory to find them (``defrag`` = ``madvise``, the default), first touching 880 MB of
    records (N = 10,000 over 1 s) cost 2.0 s of system time against 0.3 s with ordinary pages
    (``benchmarks/RESULTS.md``). The advice is switched off for these allocations only.
    """
    def allocate():
        return {key: np.empty((n_inst, n_steps if name in recorded else 1),
                              dtype=np.int64 if name in _INT_SERIES else float)
                for key, name in zip(_OUT_KEYS, SERIES)}

    if _HUGE_PAGES is None:
        return allocate()
    with _ADVICE_LOCK:
        before = _HUGE_PAGES(False)
        try:
            return allocate()
        finally:
            _HUGE_PAGES(before)


def _recorded(record) -> tuple:
    """The series ``record`` names, in :data:`SERIES` order (``"all"``: every one)."""
    if isinstance(record, str) and record == "all":
        return SERIES
    if not isinstance(record, (str, list, tuple, set, frozenset)) or not all(isinstance(x, str) for x in record):
        raise ArgumentTypeError(f"record = {record!r}: not a series name or a sequence of names; choose from "
                                f"{', '.join(SERIES)} (or 'all')")
    names = (record,) if isinstance(record, str) else tuple(record)
    if not names:
        raise InputError(f"record: empty; name at least one series of {', '.join(SERIES)} (or 'all')")
    bad = [x for x in names if x not in _SERIES_SET]
    if bad:
        raise InputError(f"record: unknown series {bad[0]!r}; choose from {', '.join(SERIES)} (or 'all')")
    return tuple(x for x in SERIES if x in names)


def _result(n_steps, ts, out, ref, n_inst, flags, recorded, istate=None, fstate=None) -> SimResult:
    return SimResult(
        t=np.arange(n_steps) * ts,
        **{name: out[key] for key, name in zip(_OUT_KEYS, SERIES)},
        # the reference as given (a copy), broadcast read-only: a scalar or (n,) one costs no (N, n) array
        reference=np.broadcast_to(np.array(ref), (n_inst, n_steps)), flags=flags, istate=istate, fstate=fstate,
        recorded=recorded,
    )


class PlantStepper:
    """One rig stepped a control period at a time, for live use (the device emulator).

    :func:`simulate` runs whole experiments; a stepper keeps its state between calls so a
    controller outside the simulator (the firmware core driven over the serial link) can close
    the loop in real time: ``sense()`` the sensors, then ``advance(inlet, bleed)`` one period.
    It runs the simulator's own block code on a block of one lane.

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

    def __init__(self, plant: PP.PlantParams | None = None, ts: float = HW.CONTROL_PERIOD, substeps: int = 10,
                 initial_pressure: float = 0.0):
        plant = _check_plant(plant)
        if plant.size() != 1:
            raise InputError("plant: PlantStepper takes one rig (scalar parameters) only")
        substeps = check_int(substeps, "substeps", lo=1, hi=MAX_SUBSTEPS)
        ts = check_real(ts, "ts", lo=0.0, lo_open=True, hi=1.0, unit="s")
        prm, self.law, theta = _prepared(plant, 1)
        initial_pressure = check_real(initial_pressure, "initial_pressure", lo=0.0,
                                      hi=float(prm[0, PK.Col.supply_pressure]), unit="Pa")
        s0 = initial_states(prm, self.law, theta, float(initial_pressure), None, plant.thermal)
        self.p = prm[0]
        self.bk = np.zeros(ph.BLOCK)
        ph.load_block(0, 1, prm, theta, s0, self.bk)
        self.ts, self.substeps = float(ts), int(substeps)
        self.t = 0.0
        # compile (or load) the integrator and the sensor model now, not in the first real-time period
        ph.advance(1, self.bk.copy(), self.law, self.ts / self.substeps, 0)
        HW.adc_count(0.0, HW.PA_PER_COUNT, 0.0)
        HW.encoder_count(0.0, 0.0, 1.0)
        ph.valve_target(0.0, 1.0, 0.5)
        _runner.gauss(np.zeros(1, dtype=np.uint64), 0)
        self._rng = np.array([np.uint64(int(self.p[PK.Col.seed]) * 2654435761 + 1)], dtype=np.uint64)

    @property
    def pressure(self) -> float:
        """True gauge pressure. [Pa]"""
        return float(self.bk[ph.Z_P] - ph.P_ATM)

    @property
    def length(self) -> float:
        """Muscle length. [m]"""
        return float(self.bk[ph.Z_LEN])

    def sense(self) -> tuple[int, int]:
        """The sensors now: ``(adc, encoder)`` counts, with the configured noise."""
        p = self.p
        meas = self.pressure
        if p[PK.Col.pressure_noise] > 0:
            meas += p[PK.Col.pressure_noise] * _runner.gauss(self._rng, 0)
        adc = int(HW.adc_count(meas, p[PK.Col.pa_per_count], p[PK.Col.adc_zero]))
        enc = int(HW.encoder_count(self.length, p[PK.Col.nominal_length], p[PK.Col.encoder_resolution]))
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
        p = self.p
        self.bk[ph.Y_XIN] = ph.valve_target(float(inlet), p[PK.Col.driver_gain], p[PK.Col.dead_band])
        self.bk[ph.Y_XBL] = ph.valve_target(float(bleed), p[PK.Col.driver_gain], p[PK.Col.dead_band])
        ph.advance(1, self.bk, self.law, self.ts / self.substeps, self.substeps)
        self.t += self.ts


@compiled(error_model="numpy")
def _volumes(bk, n, length, out):
    for j in range(n):
        out[j] = ph.volume(length[j], bk, j)[0]


def chamber_volume(plant: PP.PlantParams | None, length) -> np.ndarray:
    """The chamber's volume at muscle lengths, as the integrator computes it (one rig). [m³]

    Parameters
    ----------
    plant : PlantParams, optional
        One rig; default the calibrated one.
    length : array_like
        Muscle lengths, up to the block width at a time is not required: any shape. [m]
    """
    plant = plant or _default_plant()
    prm, law, theta = _prepared(plant, 1)
    x = np.ascontiguousarray(np.asarray(length, dtype=float)).ravel()
    out = np.empty(x.size)
    prm_w = np.repeat(prm, W, axis=0)
    th_w = np.repeat(theta, W, axis=1)
    bk = np.zeros(ph.BLOCK)
    ph.load_block(0, W, prm_w, th_w, np.zeros((W, NS)), bk)
    for a in range(0, x.size, W):
        seg = x[a:a + W]
        _volumes(bk, seg.size, seg, out[a:a + W])
    return out.reshape(np.shape(length))
