"""The controller core's parameters: :class:`CoreParams`, the SET_GAIN values, and their packing.

:class:`CoreParams` (SI, its fields built from the registry's gains), the SET_GAIN integers of a
parameter set (:data:`GAINS`, :func:`gain_values`), the coefficients the C core derives from them
(:func:`derive_arrays`, the integer formulas of ``derive()`` in ``controller.c``), the packing of
one or many parameter sets into the core's arrays (:func:`pack_params`, :func:`pack_batch`,
:func:`core_spec`, the plant simulator's kernel spec), and the law in float64
(:func:`float_command`), the reference the fixed point is measured against.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, make_dataclass
from typing import Any

import numpy as np

from mckibben import hardware as HW
from mckibben.errors import InputError, unknown_name
from mckibben.control import registry as R
# the gains of SET_GAIN in id order, their ids, and the arrays' lengths with every extension law's slots: the registry's
from mckibben.control.laws import GAIN_IDS
from mckibben.control.registry import ALL_GAINS as GAINS  # the SET_GAIN table (core.GAINS)
from mckibben.control.registry import N_GAINS, N_IPARAMS, N_ISTATE
from mckibben.control.fixed import rdiv as _rdiv
from mckibben.control.layout import (
    IP_ADC_MAX, IP_ADC_MIN, IP_ADC_ZERO, IP_ALPHA, IP_BETA_Q8, IP_C_DREF, IP_C_E, IP_C_EPS, IP_C_KD, IP_C_KI,
    IP_C_KIP, IP_C_KP, IP_C_P, IP_C_U0, IP_GAIN0, IP_GS_PA, IP_ISUM_MAX, IP_N_MISSING, IP_N_STUCK, IP_OL_BLEED,
    IP_OL_INLET, IP_P_MAX, IP_P_OVER, IP_PPC_Q8, IP_RESP_U, IP_S_SAT, IP_TS_US, IS_FIRST,
    IS_MODE, IS_P_PREV)
from mckibben.control.step import MODE_PID, MODE_SMC, P_NONE, RESP_DU, core_kernel
from mckibben.hardware import P_MAX_LIMIT, TS_US_MAX, TS_US_MIN


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


def derive_core(gains: Sequence[int], ts_us: int) -> dict[str, int]:
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


def fill_coefficients(ip: np.ndarray) -> None:
    """Fill the derived fields of iparams, one instance (N_IPARAMS,) or many (N, N_IPARAMS), as ``derive()`` does.

    Parameters
    ----------
    ip : numpy.ndarray of int64
        iparams with the raw SET_GAIN values at ``IP_GAIN0 + id``; changed in place. [-]
    """
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


#: The gains' defaults, by CoreParams field: the registry's (:data:`mckibben.control.registry.ALL_GAINS`).
_D: dict = {g.param: g.default for g in R.ALL_GAINS}
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
_PARAM_OF_GAIN = tuple(g.param for g in R.ALL_GAINS)


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
        for name, lo, hi in (("mode", 0, max(R.MODE_IDS)), ("open_loop_inlet", 0, 255), ("open_loop_bleed", 0, 255)):
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
    fill_coefficients(ip)
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
    [mpam-characterization], eq. (5) and (12), signs as corrected in docs/controller.md.
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
