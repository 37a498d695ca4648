"""The pressure-controller core: the firmware's fixed-point law, bit-exact in Python.

This module mirrors ``firmware/core/controller.c`` operation for operation: ADC scaling, the
supervisor (reference clamp, overpressure vent, latched sensor faults), the sliding-mode law and
the PID of ``docs/controller.md``, and the split of the signed command into inlet and bleed PWM
counts. The tests feed identical sequences to the C core (built for the host, loaded with
ctypes) and to :func:`core_kernel` and require identical outputs at every step, so a simulation
that uses this module runs the controller that runs on the Arduino Mega.

The step is a Numba kernel with the controller-kernel interface of the plant simulator
(``kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa) -> (inlet, bleed,
faults)``); :func:`core_spec` builds the arrays for a batch of instances, :class:`CoreController`
wraps one instance for step-by-step use, and :func:`float_command` is the same law in float64,
the reference the fixed-point arithmetic is measured against (``docs/firmware.md``).

Gains are carried as the integers of the SET_GAIN command (``GAINS``: id, scale, range); the
derived coefficients are computed from them with the integer formulas of the C core.

References
----------
“Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt), section IV, eq. (5)-(12) (sliding mode; signs corrected as in
``docs/controller.md``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, make_dataclass
from typing import Any, NamedTuple

import numpy as np

from mckibben._jit import njit
from mckibben import hardware as HW
from mckibben.errors import InputError, unknown_name
from mckibben.control import registry as R
from mckibben.control.fixed import _TANH, mulq16, tanh_q15, tanh_table  # noqa: F401  (re-exported)
from mckibben.control.fixed import clamp as _clamp
from mckibben.control.fixed import rdiv as _rdiv
from mckibben.control.fixed import wrap32 as _wrap32  # noqa: F401  (re-exported)
from mckibben.control.laws import pid, smc
from mckibben.control.layout import (  # noqa: F401  (the layout's names, re-exported: the core's arrays)
    IP_ADC_MAX, IP_ADC_MIN, IP_ADC_ZERO, IP_ALPHA, IP_BETA_Q8, IP_C_DREF, IP_C_E, IP_C_EPS, IP_C_KD, IP_C_KI,
    IP_C_KIP, IP_C_KP, IP_C_P, IP_C_U0, IP_GAIN0, IP_GS_PA, IP_ISUM_MAX, IP_N_MISSING, IP_N_STUCK, IP_OL_BLEED,
    IP_OL_INLET, IP_P_MAX, IP_P_OVER, IP_PPC_Q8, IP_RESP_U, IP_S_SAT, IP_TS_US, IS_DQ, IS_E_PREV, IS_FIRST,
    IS_HELD_ADC, IS_ISUM, IS_IU, IS_LAST_BLEED, IS_LAST_INLET, IS_LATCHED, IS_MISSING_N, IS_MODE, IS_OVER,
    IS_P_PREV, IS_P_SEEN, IS_PREF_PREV, IS_REFERENCE, IS_STUCK_N, IS_SURFACE)
from mckibben.hardware import ADC_MAX
from mckibben.atomic import atomic_file, check_output_file
from mckibben.atomic import check_input_file
import dataclasses
import json
from pathlib import Path

# --- modes and fault flags (firmware/core/controller.h, docs/protocol.md) ---------------------

MODE_OFF = R.MODE_OFF
MODE_SMC = R.SMC.mode
MODE_PID = R.PID.mode
MODE_OPEN_LOOP = R.MODE_OPEN_LOOP

FAULT_OVERPRESSURE = 0x01
FAULT_ADC_RANGE = 0x02
FAULT_STUCK = 0x04
FAULT_MISSING = 0x08
FAULT_VENT = 0x10

STATUS_OK = 0
STATUS_RANGE = 3
STATUS_GAIN_ID = 4

#: Compiled limit of the maximum pressure [Pa] (full scale of the 0-1 MPa transducer).
P_MAX_LIMIT = HW.P_MAX_LIMIT
TS_US_MIN = HW.TS_US_MIN
TS_US_MAX = HW.TS_US_MAX


class Gain(NamedTuple):
    """One SET_GAIN entry: the value sent is ``round(physical * scale)`` in ``[lo, hi]``."""

    id: int
    name: str
    unit: str
    scale: float
    lo: int
    hi: int
    default: int


#: The gains of SET_GAIN, in id order (the registry's: :data:`mckibben.control.registry.GAINS`).
GAINS: tuple[Gain, ...] = tuple(Gain(g.id, g.name, g.unit, g.scale, g.lo, g.hi, g.default_value) for g in R.GAINS)
GAIN_IDS = {g.name: g.id for g in GAINS}
N_GAINS = len(GAINS)

# --- array layouts (mckibben.control.layout); the extension laws' slots follow the core's ------

#: Lengths of the arrays with every registered extension law's slots (:data:`mckibben.control.registry.LAYOUT`).
N_IPARAMS = R.N_IPARAMS
N_ISTATE = R.N_ISTATE
#: Supervisor 2b: the inlet is shut while p + LEAD_SAMPLES·(p − p_prev) > p_max + margin.
LEAD_SAMPLES = 4
P_NONE = 2_000_000  #: IS_P_PREV before the first step: a falling 'rate', so no cut on the first sample
#: Supervisor 3, the response rule (``docs/controller.md``): a valve counts as open from the
#: supervisor model's lift-off u0_s plus RESP_DU counts; the inlet must raise the pressure while
#: the model's equilibrium for its command (above that margin) is at least 2 p + RESP_P_MIN, the
#: bleed lower it from RESP_P_MIN up.
RESP_DU = 24
RESP_P_MIN = 20_000


@njit(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def _response_expected(st, ip, seen):
    # controller.c response_expected(): must the reading have moved under the last command?
    if ip[IP_GS_PA] == 0:
        return False
    p = st[IS_P_PREV]
    if st[IS_LAST_BLEED] != 0:  # a fall, if the inlet is shut
        return st[IS_LAST_INLET] == 0 and st[IS_LAST_BLEED] >= ip[IP_RESP_U] and p >= RESP_P_MIN
    if st[IS_LAST_INLET] < ip[IP_RESP_U] or p > seen - RESP_P_MIN:
        return False
    # the model's equilibrium above the margin at least twice what holds p
    return (st[IS_LAST_INLET] - ip[IP_RESP_U]) * ip[IP_GS_PA] >= 2 * p + RESP_P_MIN


@njit(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def core_step(st, ip, adc, sample_ok, p_ref_pa, shared):
    """One step of one channel; ``shared`` is the istate that holds the supply estimate.

    ``shared`` is ``st`` itself for a lone controller and channel 0's istate in a bank
    (``mck_bank_step``). See :func:`core_kernel` for the other arguments.
    """
    a_raw = _clamp(adc, 0, 65535)
    p_max = ip[IP_P_MAX]
    if not (p_ref_pa > 0.0):
        pref = 0
    elif p_ref_pa >= p_max:
        pref = p_max
    else:
        pref = int(math.floor(p_ref_pa + 0.5))
    # supervisor 3: sensor faults
    if sample_ok:
        st[IS_MISSING_N] = 0
        if a_raw < ip[IP_ADC_MIN] or a_raw > ip[IP_ADC_MAX]:
            st[IS_LATCHED] |= FAULT_ADC_RANGE
        if a_raw == st[IS_HELD_ADC] and _response_expected(st, ip, shared[IS_P_SEEN]):
            if st[IS_STUCK_N] < 65535:
                st[IS_STUCK_N] += 1
        else:
            st[IS_STUCK_N] = 0
        if ip[IP_N_STUCK] != 0 and st[IS_STUCK_N] >= ip[IP_N_STUCK]:
            st[IS_LATCHED] |= FAULT_STUCK
        st[IS_HELD_ADC] = a_raw
    else:
        if st[IS_MISSING_N] < 65535:
            st[IS_MISSING_N] += 1
        if ip[IP_N_MISSING] != 0 and st[IS_MISSING_N] >= ip[IP_N_MISSING]:
            st[IS_LATCHED] |= FAULT_MISSING
    # ADC scaling
    a = st[IS_HELD_ADC]
    if a > ADC_MAX:
        a = ADC_MAX
    p = ((a - ip[IP_ADC_ZERO]) * ip[IP_PPC_Q8] + 128) >> 8
    if p > shared[IS_P_SEEN]:
        shared[IS_P_SEEN] = p
    # supervisor 1 and 2
    pref = _clamp(pref, 0, p_max)
    if st[IS_OVER] != 0:
        if p < p_max:
            st[IS_OVER] = 0
    elif p > ip[IP_P_OVER]:
        st[IS_OVER] = 1
    cut = p + (p - st[IS_P_PREV]) * LEAD_SAMPLES > ip[IP_P_OVER]
    st[IS_P_PREV] = p
    e = pref - p
    surface = e
    inlet = 0
    bleed = 0
    mode = st[IS_MODE]
    if st[IS_LATCHED] != 0 or st[IS_OVER] != 0:
        bleed = 255
        st[IS_FIRST] = 1
    elif mode == MODE_SMC or mode == MODE_PID or mode > MODE_OPEN_LOOP:
        if st[IS_FIRST] != 0:
            st[IS_FIRST] = 0
            st[IS_PREF_PREV] = pref
            st[IS_E_PREV] = e
        if mode == MODE_SMC:
            st[IS_ISUM] = _clamp(st[IS_ISUM] + e, -ip[IP_ISUM_MAX], ip[IP_ISUM_MAX])
            u, surface = smc.law(ip, p, pref - st[IS_PREF_PREV], e, st[IS_ISUM])
            st[IS_PREF_PREV] = pref
        elif mode == MODE_PID:
            u = pid.law(st, ip, e)
        else:  # the registry's extension laws (modes 4, 5, ...)
            u, surface = R.extension_law(mode, st, ip, p, pref, e)
        u = (u + 128) >> 8
        if u >= 0:
            inlet = 255 if u > 255 else u
        else:
            bleed = 255 if u < -255 else -u
    else:
        st[IS_FIRST] = 1
        if mode == MODE_OPEN_LOOP:
            inlet = ip[IP_OL_INLET]
            bleed = ip[IP_OL_BLEED]
    # supervisor 2b: shut the inlet before the valve's lag carries p past p_max + margin
    if cut:
        inlet = 0
    faults = st[IS_LATCHED] | (FAULT_OVERPRESSURE if st[IS_OVER] != 0 else 0)
    st[IS_LAST_INLET] = inlet
    st[IS_LAST_BLEED] = bleed
    st[IS_SURFACE] = surface
    st[IS_REFERENCE] = pref
    return inlet, bleed, faults


@njit(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def core_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    """One control step of the firmware core (``mck_ctrl_step``), bit-exact.

    Parameters
    ----------
    istate : numpy.ndarray of int64
        This instance's integer state, mutated in place (layout ``IS_*``). [-]
    iparams : numpy.ndarray of int64
        This instance's parameters (:func:`pack_params`). [-]
    fstate : numpy.ndarray of float64
        Unused (the core is integer only); kept for the kernel interface. [-]
    fparams : numpy.ndarray of float64
        Unused; kept for the kernel interface. [-]
    adc : int
        Raw pressure ADC count; saturated to 0..65535 (the C core takes uint16). [count]
    enc : int
        Encoder count; the pressure law does not use it. [count]
    sample_ok : bool
        False when no sample arrived this period. [-]
    p_ref_pa : float
        Pressure reference; rounded to whole Pa as the protocol's i32 (NaN counts as 0). [Pa]

    Returns
    -------
    tuple of int
        Inlet PWM count 0..255, bleed PWM count 0..255, fault flags (``FAULT_*``). [-]
    """
    return core_step(istate, iparams, adc, sample_ok, p_ref_pa, istate)


# --- gains -> coefficients (mirror of derive() in controller.c) -------------------------------


def derive_arrays(gains, ts_us) -> dict[str, np.ndarray]:
    """The derived coefficients of the fixed-point law for many gain sets at once.

    The integer formulas of ``derive()`` in ``firmware/core/controller.c`` in ``int64`` NumPy
    arithmetic (exact: with every gain inside its SET_GAIN range no intermediate exceeds
    2^62, so the values equal the C core's unsigned 64-bit ones).

    Parameters
    ----------
    gains : array_like of int
        Gain values in their SET_GAIN scale (``GAINS``), shape (..., N_GAINS). [-]
    ts_us : array_like of int
        Control period, shape (...). [us]

    Returns
    -------
    dict of str to numpy.ndarray
        Coefficient name -> ``int64`` values of shape (...). [-]
    """
    g = np.asarray(gains, dtype=np.int64)
    ts = np.asarray(ts_us, dtype=np.int64)
    beta, eps, ki, tau, gg, imax = (g[..., k] for k in range(6))
    c = {}
    c["ppc_q8"] = _rdiv(g[..., 11] * 256, 1000)
    c["beta_q8"] = _rdiv(beta * 256, 1000)
    model = gg != 0  # gg == 0: no model term, u = beta tanh(S/eps) alone
    gs = np.where(model, gg, 1)
    c["c_p"] = np.where(model, np.minimum(_rdiv(1000 << 24, gs), 1 << 24), 0)
    c["c_dref"] = np.where(model, np.minimum(_rdiv((tau * 1000) << 24, gs * ts), (1 << 27) - 1), 0)
    c["c_e"] = np.where(model, np.minimum(_rdiv((tau * ki) << 18, gs * 15625), (1 << 25) - 1), 0)
    c["c_u0"] = np.where(model, _rdiv(g[..., 17] * 256, 1000), 0)
    c["c_ki"] = _rdiv((ki * ts) << 15, 1953125)
    c["c_eps"] = (1 << 28) // eps
    c["s_sat"] = 8 * eps
    lim = _rdiv(imax * 1000, ts)
    cap = (1 << 46) // np.maximum(c["c_ki"], 1)
    lim = np.where((c["c_ki"] > 0) & (cap < lim), cap, lim)
    c["isum_max"] = np.minimum(lim, 1 << 30)
    c["c_kp"] = np.minimum(_rdiv(g[..., 6] << 15, 1953125), 1 << 24)
    c["c_kip"] = np.minimum(_rdiv((g[..., 7] * ts) << 17, 30517578125), (1 << 25) - 1)
    c["c_kd"] = np.minimum(_rdiv(g[..., 8] << 14, ts * 15625), (1 << 20) - 1)
    c["alpha"] = _rdiv(ts << 16, g[..., 9] + ts)
    c["gs_pa"] = _rdiv(g[..., 18], 1000)
    c["resp_u"] = _rdiv(g[..., 19], 1000) + RESP_DU
    return {k: np.asarray(v, dtype=np.int64) for k, v in c.items()}


def derive(gains: Sequence[int], ts_us: int) -> dict[str, int]:
    """The derived coefficients of the fixed-point law from the SET_GAIN values.

    Parameters
    ----------
    gains : sequence of int
        The gain values in their SET_GAIN scale (``GAINS``). [-]
    ts_us : int
        Control period. [us]

    Returns
    -------
    dict of str to int
        Coefficient name -> integer value, as ``derive()`` in ``firmware/core/controller.c``
        (:func:`derive_arrays` on one gain set). [-]
    """
    return {k: int(v) for k, v in derive_arrays([int(v) for v in gains], int(ts_us)).items()}


_COEF_INDEX = {
    "ppc_q8": IP_PPC_Q8, "beta_q8": IP_BETA_Q8, "c_p": IP_C_P, "c_dref": IP_C_DREF,
    "c_e": IP_C_E, "c_ki": IP_C_KI, "c_eps": IP_C_EPS, "s_sat": IP_S_SAT,
    "isum_max": IP_ISUM_MAX, "c_kp": IP_C_KP, "c_kip": IP_C_KIP, "c_kd": IP_C_KD,
    "alpha": IP_ALPHA, "c_u0": IP_C_U0, "gs_pa": IP_GS_PA, "resp_u": IP_RESP_U,
}  # fmt: skip


def _fill_coefficients(ip: np.ndarray) -> None:
    """Fill the derived fields of iparams, one instance (N_IPARAMS,) or many (N, N_IPARAMS)."""
    gains = ip[..., IP_GAIN0 : IP_GAIN0 + N_GAINS]
    for name, value in derive_arrays(gains, ip[..., IP_TS_US]).items():
        ip[..., _COEF_INDEX[name]] = value
    # the extension laws' coefficients (their derive(), called at the end of derive() in controller.c)
    for spec in R.EXTENSIONS:
        io = R.LAYOUT[spec.name][1]
        values = spec.derive({g.param: gains[..., g.id] for g in spec.gains}, ip[..., IP_TS_US])
        for j, name in enumerate(spec.coefs):
            ip[..., io + j] = values[name]
    # the supervisor's settings in the step's fields (derive() in controller.c)
    ip[..., IP_P_OVER] = ip[..., IP_P_MAX] + gains[..., GAIN_IDS["margin"]]
    for name, index in (("adc_zero", IP_ADC_ZERO), ("adc_min", IP_ADC_MIN), ("adc_max", IP_ADC_MAX),
                        ("n_stuck", IP_N_STUCK), ("n_missing", IP_N_MISSING)):
        ip[..., index] = gains[..., GAIN_IDS[name]]


# --- physical parameters ----------------------------------------------------------------------


#: The gains' defaults, by CoreParams field: the registry's (:data:`mckibben.control.registry.GAINS`).
_D: dict = {g.param: g.default for g in R.GAINS}
#: The extension laws' gains (registry), fields of CoreParams too; a dataclass built from the
#: registry so that a registered law brings its parameters along.
_ExtensionParams: Any = make_dataclass(
    "_ExtensionParams", [(g.param, type(g.default), field(default=g.default)) for c in R.EXTENSIONS for g in c.gains],
    frozen=True)


@dataclass(frozen=True)
class CoreParams(_ExtensionParams):
    """Physical parameters of the controller core (defaults: the registry's, docs/firmware.md; not tuned).

    Parameters
    ----------
    beta : float
        Sliding-mode switching gain (the paper's 120 and 150). [PWM counts]
    eps : float
        Boundary-layer width of tanh(S/eps). [Pa]
    ki : float
        Integral weight of the sliding surface S = e + Ki I. [1/s]
    tau : float
        Time constant of the identified first-order model. [s]
    g : float
        Static gain of the identified model, pressure per PWM count; 0 switches the model term
        off (u = β·tanh(S/ε) alone, the law as the paper ran it). [Pa/count]
    i_max : float
        Clamp of the sliding-mode integral I. [Pa s]
    kp : float
        PID proportional gain. [counts/Pa]
    ki_pid : float
        PID integral gain. [counts/(Pa s)]
    kd : float
        PID derivative gain. [counts s/Pa]
    tf : float
        PID derivative filter time constant. [s]
    p_max : float
        Maximum pressure; the reference is clamped to [0, p_max]. [Pa]
    margin : float
        Overpressure vent above p_max + margin, until p < p_max. [Pa]
    adc_zero : int
        ADC count at zero gauge pressure. [count]
    pa_per_count : float
        Pressure per ADC count. [Pa/count]
    adc_min, adc_max : int
        Valid ADC range; a reading outside latches a vent. [count]
    n_stuck : int
        Consecutive unchanged readings while the supervisor's valve model predicts a change that
        latch a vent (the response rule, ``docs/controller.md``); 0 = off. [-]
    n_missing : int
        Consecutive missing samples that latch a vent; 0 = off. [-]
    ts : float
        Control period, a whole number of microseconds in [100 us, 10 ms]. [s]
    mode : int
        Initial mode: 0 off, 1 sliding mode, 2 PID, 3 open loop. [-]
    open_loop_inlet, open_loop_bleed : int
        PWM counts used in mode 3. [count]
    u0 : float
        Valve lift-off of the identified model ``ṗ = (G·(u − u0) − p)/τ``: the sliding mode
        sends ``v + u0·sign(v)`` for its command v (not used when g = 0). [PWM counts]
    sup_g : float
        Static gain G_s of the supervisor's valve model ``p = G_s·(u − u0_s)`` (the identified
        model's G, also under the paper's law), rounded to whole Pa per count; 0 switches the
        response rule off. [Pa/count]
    sup_u0 : float
        Lift-off u0_s of the supervisor's valve model. [PWM counts]
    """

    beta: float = _D["beta"]
    eps: float = _D["eps"]
    ki: float = _D["ki"]
    tau: float = _D["tau"]
    g: float = _D["g"]
    i_max: float = _D["i_max"]
    kp: float = _D["kp"]
    ki_pid: float = _D["ki_pid"]
    kd: float = _D["kd"]
    tf: float = _D["tf"]
    p_max: float = float(HW.P_MAX_DEFAULT)
    margin: float = _D["margin"]
    adc_zero: int = _D["adc_zero"]
    pa_per_count: float = _D["pa_per_count"]
    adc_min: int = _D["adc_min"]
    adc_max: int = _D["adc_max"]
    n_stuck: int = _D["n_stuck"]
    n_missing: int = _D["n_missing"]
    ts: float = HW.CONTROL_PERIOD
    mode: int = MODE_SMC
    open_loop_inlet: int = 0
    open_loop_bleed: int = 0
    u0: float = _D["u0"]
    sup_g: float = _D["sup_g"]
    sup_u0: float = _D["sup_u0"]


#: CoreParams field of each gain, in id order.
_PARAM_OF_GAIN = tuple(g.param for g in R.GAINS)


def _extension_docs() -> str:
    """The extension laws' parameters for CoreParams' docstring, from the registry."""
    return "".join(f"    {g.param} : {type(g.default).__name__}\n        {c.name}: {g.doc}. [{g.unit}]\n"
                   for c in R.EXTENSIONS for g in c.gains)


if CoreParams.__doc__ and R.EXTENSIONS:
    CoreParams.__doc__ = CoreParams.__doc__.rstrip() + "\n" + _extension_docs()


def gain_values(params: CoreParams) -> np.ndarray:
    """The SET_GAIN integer values of a parameter set, range-checked.

    Parameters
    ----------
    params : CoreParams
        Physical parameters. [SI]

    Returns
    -------
    numpy.ndarray
        ``N_GAINS`` ``int64`` values in id order (``GAINS``). [-]

    Raises
    ------
    InputError
        A parameter is not finite or outside the range its fixed-point scale can carry.
    """
    return _Columns(_fields_of(params), 1).gains()[0]


def _fields_of(params: CoreParams) -> dict:
    return {f.name: getattr(params, f.name) for f in fields(CoreParams)}


class _Columns:
    """Parameter columns of N instances (scalars or sequences of N), checked in pack_params' order."""

    def __init__(self, values: Mapping[str, object], n: int | None):
        names = [f.name for f in fields(CoreParams)]
        unknown = sorted(set(values) - set(names))
        if unknown:
            raise unknown_name("controller parameter", unknown[0], names)
        defaults = CoreParams()
        self.raw = {name: values.get(name, getattr(defaults, name)) for name in names}
        sizes = {len(v) for v in self.raw.values() if np.ndim(v) == 1}
        if any(np.ndim(v) > 1 for v in self.raw.values()) or len(sizes) > 1:
            raise InputError("controller parameters: scalars or 1-D sequences of one length")
        self.n = int(n) if n is not None else (sizes.pop() if sizes else 1)
        if self.n < 1 or (sizes and sizes != {self.n}):
            raise InputError(f"controller parameters: {sorted(sizes)} instances, {self.n} were asked for")
        self.col = {}
        for name, v in self.raw.items():
            try:
                self.col[name] = np.broadcast_to(np.asarray(v, dtype=float), (self.n,))
            except (TypeError, ValueError):
                raise InputError(f"controller parameter {name}={v!r} is not a number") from None
        self.checks: list[tuple[np.ndarray, object]] = []

    def value(self, name: str, row: int):
        """The parameter as given (scalar or element), for messages."""
        v = self.raw[name]
        if np.ndim(v) == 0:
            return v
        v = v[row]
        return v.item() if isinstance(v, np.generic) else v

    def check(self, bad: np.ndarray, message) -> None:
        self.checks.append((np.asarray(bad, dtype=bool), message))

    def raise_first(self) -> None:
        """Raise for the first instance that fails a check (and its first failing check)."""
        if not self.checks:
            return
        bad = np.stack([b for b, _ in self.checks])
        if bad.any():
            row = int(bad.any(axis=0).argmax())
            k = int(bad[:, row].argmax())
            raise InputError(self.checks[k][1](row))

    def gains(self, check_now: bool = True) -> np.ndarray:
        out = np.zeros((self.n, N_GAINS), dtype=np.int64)
        for gain, name in zip(GAINS, _PARAM_OF_GAIN, strict=True):
            x = self.col[name]
            with np.errstate(invalid="ignore", over="ignore"):
                v = np.rint(x * gain.scale)
                bad = ~np.isfinite(v) | (v < gain.lo) | (v > gain.hi)
            self.check(bad, lambda row, gain=gain, name=name: (
                f"controller parameter {name}={float(self.col[name][row])!r} outside "
                f"[{gain.lo / gain.scale:g}, {gain.hi / gain.scale:g}] {gain.unit}"))
            out[:, gain.id] = np.where(bad, 0, v).astype(np.int64)
        if check_now:
            self.raise_first()
        return out


def pack_batch(params: Mapping[str, object] | None = None, n: int | None = None):
    """Arrays of N controller instances for :func:`core_kernel`, built column by column.

    The same packing as :func:`pack_params` (which is this function on one instance), from
    arrays of physical parameters rather than one :class:`CoreParams` per instance.

    Parameters
    ----------
    params : mapping of str to float or array_like, optional
        :class:`CoreParams` field -> a scalar (shared) or N values; missing fields take the
        defaults. [SI]
    n : int, optional
        Number of instances; default the length of the array values (1 if all are scalars). [-]

    Returns
    -------
    tuple of numpy.ndarray
        ``(istate0[N, N_ISTATE], iparams[N, N_IPARAMS], fstate0[N, 1], fparams[N, 1])``. [-]

    Raises
    ------
    InputError
        A parameter is out of range: the first instance that has one, named with its value.
    """
    cols = _Columns(params or {}, n)
    gains = cols.gains(check_now=False)
    c = cols.col
    with np.errstate(invalid="ignore", over="ignore"):
        ts_us = np.where(np.isfinite(c["ts"]), np.rint(c["ts"] * 1e6), -1.0)
        cols.check((ts_us < TS_US_MIN) | (ts_us > TS_US_MAX) | (np.abs(ts_us - c["ts"] * 1e6) > 1e-6),
                   lambda row: (f"controller parameter ts={cols.value('ts', row)!r} must be a whole number of "
                                f"microseconds in [{TS_US_MIN}, {TS_US_MAX}] us"))
        p_max = np.where(np.isfinite(c["p_max"]), np.rint(c["p_max"]), -1.0)
        cols.check((p_max < 0) | (p_max > P_MAX_LIMIT),
                   lambda row: f"controller parameter p_max={cols.value('p_max', row)!r} outside [0, {P_MAX_LIMIT}] Pa")
        for name, lo, hi in (("mode", 0, max(R.MODES)), ("open_loop_inlet", 0, 255), ("open_loop_bleed", 0, 255)):
            v = c[name]
            cols.check(~np.isfinite(v) | (np.floor(v) != v) | (v < lo) | (v > hi),
                       lambda row, name=name, lo=lo, hi=hi: (f"controller parameter {name}={cols.value(name, row)!r} "
                                                              f"outside the integers {lo}..{hi}"))
    cols.raise_first()
    ip = np.zeros((cols.n, N_IPARAMS), dtype=np.int64)
    ip[:, IP_P_MAX] = p_max
    ip[:, IP_TS_US] = ts_us
    ip[:, IP_OL_INLET] = c["open_loop_inlet"]
    ip[:, IP_OL_BLEED] = c["open_loop_bleed"]
    ip[:, IP_GAIN0 : IP_GAIN0 + N_GAINS] = gains
    _fill_coefficients(ip)
    st = np.zeros((cols.n, N_ISTATE), dtype=np.int64)
    st[:, IS_MODE] = c["mode"]
    st[:, IS_P_PREV] = P_NONE
    st[:, IS_FIRST] = 1
    return st, ip, np.zeros((cols.n, 1)), np.zeros((cols.n, 1))


def pack_params(params: CoreParams) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Arrays of one controller instance for :func:`core_kernel`.

    Parameters
    ----------
    params : CoreParams
        Physical parameters. [SI]

    Returns
    -------
    tuple of numpy.ndarray
        ``(istate0, iparams, fstate0, fparams)``: int64[N_ISTATE], int64[N_IPARAMS],
        float64[1], float64[1]. [-]

    Raises
    ------
    InputError
        A parameter is out of range (named in the message).
    """
    st, ip, fs, fp = pack_batch(_fields_of(params), 1)
    return st[0], ip[0], fs[0], fp[0]


def core_spec(params: CoreParams | Sequence[CoreParams] | Mapping[str, object] = CoreParams(), n: int = 1):
    """Controller spec for the batch simulator: the kernel and per-instance arrays.

    Parameters
    ----------
    params : CoreParams, sequence of CoreParams, or mapping of str to array_like
        One parameter set (repeated ``n`` times), one per instance, or :class:`CoreParams`
        field -> scalar or N values (:func:`pack_batch`; missing fields take the defaults). [SI]
    n : int, default 1
        Number of instances when ``params`` is a single set (or a mapping of scalars). [-]

    Returns
    -------
    tuple
        ``(core_kernel, istate0[N, ·], iparams[N, ·], fstate0[N, 1], fparams[N, 1])``. [-]
    """
    if isinstance(params, CoreParams):
        return (core_kernel,) + pack_batch(_fields_of(params), int(n))
    if isinstance(params, Mapping):
        return (core_kernel,) + pack_batch(params, None if any(np.ndim(v) for v in params.values()) else int(n))
    plist = list(params)
    if not plist:
        raise InputError("core_spec needs at least one parameter set")
    cols = {f.name: [getattr(p, f.name) for p in plist] for f in fields(CoreParams)}
    return (core_kernel,) + pack_batch(cols, len(plist))


class CoreController:
    """One instance of the firmware controller core, stepped from Python.

    The setters mirror the firmware commands and return their ACK status (0 ok, 3 value out of
    range, 4 bad gain id) instead of raising, as the device does.

    Parameters
    ----------
    params : CoreParams, optional
        Physical parameters. [SI]
    """

    def __init__(self, params: CoreParams = CoreParams()):
        self.istate, self.iparams, self.fstate, self.fparams = pack_params(params)

    def step(self, adc: int, sample_ok: bool = True, p_ref_pa: float = 0.0) -> tuple[int, int, int]:
        """One control step.

        Parameters
        ----------
        adc : int
            Raw pressure ADC count. [count]
        sample_ok : bool, default True
            False when no sample arrived this period. [-]
        p_ref_pa : float, default 0.0
            Pressure reference. [Pa]

        Returns
        -------
        tuple of int
            ``(inlet, bleed, faults)``: PWM counts 0..255 and fault flags. [-]
        """
        i, b, f = core_kernel(self.istate, self.iparams, self.fstate, self.fparams,
                              int(adc), 0, bool(sample_ok), float(p_ref_pa))
        return int(i), int(b), int(f)

    @property
    def surface_pa(self) -> int:
        """Sliding surface S (mode 1) or error e (other modes) of the last step. [Pa]"""
        return int(self.istate[IS_SURFACE])

    @property
    def reference_pa(self) -> int:
        """Reference of the last step after the supervisor's clamp. [Pa]"""
        return int(self.istate[IS_REFERENCE])

    @property
    def mode(self) -> int:
        """Current mode. [-]"""
        return int(self.istate[IS_MODE])

    def set_gain(self, gain_id: int, value: int) -> int:
        """SET_GAIN: one gain in its fixed-point scale (``GAINS``); returns the ACK status.

        Parameters
        ----------
        gain_id : int
            Gain id 0..N_GAINS-1. [-]
        value : int
            Value in the gain's SET_GAIN scale. [-]
        """
        if not 0 <= gain_id < N_GAINS:
            return STATUS_GAIN_ID
        g = GAINS[gain_id]
        if not g.lo <= value <= g.hi:
            return STATUS_RANGE
        self.iparams[IP_GAIN0 + gain_id] = value
        _fill_coefficients(self.iparams)
        return STATUS_OK

    def set_mode(self, mode: int) -> int:
        """SET_MODE: resets the law state and clears the latched faults; returns the status.

        Parameters
        ----------
        mode : int
            0 off, 1 sliding mode, 2 PID, 3 open loop. [-]
        """
        if mode not in R.MODES:
            return STATUS_RANGE
        st = self.istate
        st[IS_MODE] = mode
        st[IS_LATCHED] = 0
        st[IS_FIRST] = 1
        for k in (IS_ISUM, IS_IU, IS_DQ, IS_E_PREV, IS_PREF_PREV, IS_STUCK_N, IS_MISSING_N, IS_P_SEEN):
            st[k] = 0
        st[R.CORE_N_ISTATE:] = 0  # the extension laws' state (their reset())
        return STATUS_OK

    def set_max_pressure(self, p_max_pa: int) -> int:
        """SET_MAX_PRESSURE; returns the status.

        Parameters
        ----------
        p_max_pa : int
            Maximum pressure, 0..P_MAX_LIMIT. [Pa]
        """
        if not 0 <= p_max_pa <= P_MAX_LIMIT:
            return STATUS_RANGE
        self.iparams[IP_P_MAX] = p_max_pa
        self.iparams[IP_P_OVER] = p_max_pa + self.iparams[IP_GAIN0 + GAIN_IDS["margin"]]
        return STATUS_OK

    def set_open_loop(self, inlet: int, bleed: int) -> None:
        """SET_OPEN_LOOP: the PWM counts of mode 3.

        Parameters
        ----------
        inlet, bleed : int
            PWM counts 0..255. [count]
        """
        self.iparams[IP_OL_INLET] = int(inlet) & 0xFF
        self.iparams[IP_OL_BLEED] = int(bleed) & 0xFF

    def vent(self) -> None:
        """VENT: latch the vent until the next :meth:`set_mode`."""
        self.istate[IS_LATCHED] |= FAULT_VENT


class CoreBank:
    """N channels of the core stepped together, as ``mck_bank_step`` in the firmware.

    Each channel is a :class:`CoreController` with its own gains and state; in one period
    channel i steps with ``adcs[i]``, ``oks[i]``, ``refs[i]`` in order, and all compare
    with and raise one supply estimate, channel 0's (the shared supply check of the response
    rule, ``docs/controller.md``).

    Parameters
    ----------
    params : sequence of CoreParams
        One parameter set per channel (1..3 on the firmware). [SI]
    """

    def __init__(self, params: Sequence[CoreParams]):
        plist = list(params)
        if not plist:
            raise InputError("CoreBank needs at least one channel")
        self.channels = [CoreController(p) for p in plist]

    def __len__(self) -> int:
        return len(self.channels)

    def __getitem__(self, i: int) -> CoreController:
        return self.channels[i]

    def step(self, adcs, oks, refs) -> list[tuple[int, int, int]]:
        """One period of every channel.

        Parameters
        ----------
        adcs : sequence of int
            Raw ADC count per channel. [count]
        oks : sequence of bool
            Whether each channel's sample arrived. [-]
        refs : sequence of float
            Pressure reference per channel. [Pa]

        Returns
        -------
        list of tuple of int
            ``(inlet, bleed, faults)`` per channel. [-]
        """
        shared = self.channels[0].istate
        out = []
        for c, a, ok, r in zip(self.channels, adcs, oks, refs, strict=True):
            i, b, f = core_step(c.istate, c.iparams, int(a), bool(ok), float(r), shared)
            out.append((int(i), int(b), int(f)))
        return out


# --- float64 reference of the law (accuracy of the fixed point) -------------------------------


def float_command(params: CoreParams, p, p_ref, dp_ref, integral, mode: int = MODE_SMC):
    """The control law in float64, for measuring the fixed-point error.

    Sliding mode: ``v = (p + tau (dp_ref/Ts + Ki e)) / G + beta tanh((e + Ki I)/eps)``,
    ``u = v + u0 sign(v)`` (``u = beta tanh(...)`` alone when G = 0);
    PID (proportional and integral part only): ``u = Kp e + Ki_pid I``; with ``e = p_ref - p``.

    Parameters
    ----------
    params : CoreParams
        Physical parameters. [SI]
    p : array_like
        Measured pressure. [Pa]
    p_ref : array_like
        Reference. [Pa]
    dp_ref : array_like
        Reference increment over one period. [Pa]
    integral : array_like
        Integral of the error I. [Pa s]
    mode : int, default 1
        1 sliding mode, 2 PID. [-]

    Returns
    -------
    numpy.ndarray
        The signed command before rounding and saturation. [PWM counts]

    References
    ----------
    “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt), eq. (5) and (12), signs as corrected in docs/controller.md.
    """
    p, p_ref, dp_ref, integral = (np.asarray(x, dtype=float) for x in (p, p_ref, dp_ref, integral))
    e = p_ref - p
    if mode == MODE_PID:
        return params.kp * e + params.ki_pid * integral
    s = e + params.ki * integral
    switching = params.beta * np.tanh(s / params.eps)
    if params.g == 0:  # no model term
        return switching
    v = (p + params.tau * (dp_ref / params.ts + params.ki * e)) / params.g + switching
    return v + params.u0 * np.sign(v)


def counts_from_command(u) -> tuple[np.ndarray, np.ndarray]:
    """Split a signed command into (inlet, bleed) PWM counts, rounding half up and saturating.

    Parameters
    ----------
    u : array_like
        Signed command. [PWM counts]

    Returns
    -------
    tuple of numpy.ndarray
        Inlet and bleed counts 0..255. [count]
    """
    r = np.floor(np.asarray(u, dtype=float) + 0.5)
    return np.clip(r, 0, 255).astype(np.int64), np.clip(-r, 0, 255).astype(np.int64)


# --- controller designs on disk (``--save-design``, ``rig gains --from``) ---------------------

#: The ``format`` key of a design file.
DESIGN_FORMAT = "mckibben.controller-design"


def save_design(params: CoreParams, path, note: str = "") -> None:
    """Write a controller design as JSON (atomically): every :class:`CoreParams` field, SI.

    The file is what ``mckibben control step --save-design`` writes and ``mckibben rig gains
    --from`` sends to the device: the physical values and, for checking, the SET_GAIN integers
    they become (``gains``).

    Parameters
    ----------
    params : CoreParams
        The design; its values must fit the firmware's ranges (checked). [SI]
    path : str or os.PathLike
        A ``.json`` file. [-]
    note : str, optional
        Free text kept in the file (what it was designed on). [-]
    """


    check_output_file(path, "save_design", (".json",))
    values = gain_values(params)
    doc = {"format": DESIGN_FORMAT, "version": 1, "note": note,
           "params": {f.name: getattr(params, f.name) for f in dataclasses.fields(params)},
           "gains": {g.name: int(values[g.id]) for g in GAINS}}
    with atomic_file(path, "save_design") as tmp:
        tmp.write_text(json.dumps(doc, indent=2) + "\n")


def load_design(path, name: str = "path") -> CoreParams:
    """Read a design written by :func:`save_design`.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file. [-]
    name : str, default "path"
        The caller's argument that gave ``path``, for the messages. [-]

    Returns
    -------
    CoreParams
        The design, range-checked against the firmware's gains.

    Raises
    ------
    InputError
        The file is missing, not JSON, not a design, or names an unknown or out-of-range value.
    """


    p = Path(path)
    if not p.exists():
        raise InputError(f"{name}: {str(p)!r} does not exist")
    check_input_file(p, name, "controller design")  # a folder or a FIFO (which would block the read)
    try:
        doc = json.loads(p.read_text())
    except FileNotFoundError:
        raise InputError(f"{name}: {str(p)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: cannot read {str(p)!r} ({exc})") from None
    except ValueError as exc:
        raise InputError(f"{name}: {str(p)!r} is not JSON ({exc.args[0].split(':')[0]})") from None
    if not isinstance(doc, dict) or doc.get("format") != DESIGN_FORMAT or not isinstance(doc.get("params"), dict):
        raise InputError(f"{name}: {str(p)!r} is not a controller design (no format {DESIGN_FORMAT!r})")
    names = {f.name for f in dataclasses.fields(CoreParams)}
    unknown = sorted(set(doc["params"]) - names)
    if unknown:
        raise InputError(f"{name}: {str(p)!r}: unknown parameter {unknown[0]!r}")
    for k, v in doc["params"].items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"{name}: {str(p)!r}: parameter {k!r} is not a number")
    params = CoreParams(**doc["params"])
    try:
        pack_params(params)
    except InputError as exc:
        raise InputError(f"{name}: {str(p)!r}: {exc}") from None
    return params
