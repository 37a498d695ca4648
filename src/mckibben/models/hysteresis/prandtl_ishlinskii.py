"""The Prandtl–Ishlinskii (PI) hysteresis operator: play operators, their weighted sum, the exact inverse.

A *play* (backlash) operator of threshold r ≥ 0 maps an input sequence u_k to

    z_k = max(u_k − r, min(u_k + r, z_{k−1})),

so its output follows the input at a distance r and stays put while the input reverses inside
the band (the dead band of a gear, the static friction of the braid on the tube). The classical
PI operator is a weighted sum of plays with thresholds 0 = r_0 < r_1 < … < r_n:

    y_k = y_0 + Σ_i w_i · z_i,k      (z_i the play of threshold r_i applied to u − u_0)

It is rate independent (only the order of the input's values counts, not their timing) and, with
w_0 > 0 and w_i ≥ 0, its output rises with a rising input and falls with a falling one: the
output lags the input, the loop runs counter-clockwise in the (u, y) plane. For a muscle:
contraction (or pulling force) against pressure, where "inflating needs more pressure than
deflating for the same contraction" (§III of [mpam-characterization], its Fig. 6).

Starting from the virgin state (every play at zero) and rising, the output follows the *initial
loading curve* φ(u) = y_0 + Σ_i w_i·max(u − u_0 − r_i, 0), piecewise linear with slope
W_j = w_0 + … + w_j between r_j and r_{j+1}. A PI operator is invertible when every W_j > 0,
and its inverse is again a PI operator, in closed form (Krejčí & Kuhnen 2001, Kuhnen 2003):

    r'_j = φ(r_j) − y_0 = Σ_{i≤j} w_i·(r_j − r_i)                     (thresholds of the inverse)
    w'_0 = 1 / w_0,   w'_j = − w_j / (W_j · W_{j−1})   (j ≥ 1)          (its weights)

with the roles of the offsets swapped (the inverse's input offset is y_0, its output offset
u_0), and, from a state z of the forward plays, the inverse's play states

    z'_j = W_j·z_j + Σ_{i>j} w_i·z_i,

which make the composition exact from any consistent state, not only the virgin one.

Units: a PI operator maps an input in its :attr:`PrandtlIshlinskii.input_unit` (pressure in Pa
for the muscle, or a normalized input [-]) to an output in :attr:`~PrandtlIshlinskii.output_unit`
(contraction or length in m, or force in N). Thresholds have the input's unit, weights the
output's unit per input unit.

**Asymmetric loops, saturation (modified PI).** The classical operator's loading curve has a
non-decreasing slope (w_i ≥ 0), and its loops are point-symmetric. A muscle's contraction against
pressure is S-shaped (a threshold, then the braid's end stop). Kuhnen's *modified* PI operator
puts a static, monotone map S after the plays: y = S(v), v = y_0 + Σ_i w_i·z_i, with S⁻¹ a
superposition of one-sided dead zones, i.e. a continuous, piecewise-linear, non-decreasing map.
We store S⁻¹ by its knots (:attr:`PrandtlIshlinskii.output_map`: outputs y_k and the plays' sums
v_k there; flat beyond the ends, where the muscle saturates). The inverse stays exact:
u = Γ⁻¹[S⁻¹(y)] with Γ⁻¹ the closed form below (:func:`invert`).

Fitting (weights for fixed thresholds, linear least squares with w ≥ 0) lives in
:mod:`mckibben.fit.hysteresis`; this module gives it the design matrix
(:func:`play_matrix`). References: Krejčí, P., Kuhnen, K. (2001), Inverse control of systems
with hysteresis and creep, IEE Proc. Control Theory Appl. 148(3), 185–192,
doi:10.1049/ip-cta:20010375; Kuhnen, K. (2003), Modeling, identification and compensation of
complex hysteretic nonlinearities: a modified Prandtl–Ishlinskii approach, European Journal of
Control 9(4), 407–418; Brokate, M., Sprekels, J. (1996), Hysteresis and Phase Transitions,
Springer, §2.3 (the play and the PI operator).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from mckibben.errors import InputError

#: Where the classical PI operator and its closed-form inverse come from.
PI_CITATION = ("Krejčí & Kuhnen (2001), IEE Proc. Control Theory Appl. 148(3) 185–192 (inverse PI); "
               "Brokate & Sprekels (1996), Hysteresis and Phase Transitions, §2.3 (play, PI operator)")


def _vector(value, name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim != 1 or a.size == 0 or not np.all(np.isfinite(a)):
        raise InputError(f"{name}: must be a finite, non-empty 1-D array")
    return a


def thresholds_uniform(n: int, span: float) -> np.ndarray:
    """Thresholds 0, span/(2n), 2·span/(2n), …: n plays that cover a loop of the input span.

    A play of threshold r changes its output only once the input has reversed by 2r; the
    largest useful threshold is half the input's span.

    Parameters
    ----------
    n : int
        Number of plays, at least 1 (the first, of threshold 0, is the identity). [-]
    span : float
        Input span the loops cover (e.g. p_max − p_min). [input unit]

    Returns
    -------
    numpy.ndarray
        Thresholds, shape (n,). [input unit]
    """
    if int(n) != n or n < 1:
        raise InputError(f"n: {n!r} must be an integer >= 1")
    if not (math.isfinite(span) and span > 0):
        raise InputError(f"span: {span!r} must be finite and > 0")
    return np.arange(int(n)) * (0.5 * span / int(n))


@dataclass(frozen=True, eq=False)
class PrandtlIshlinskii:
    """A classical Prandtl–Ishlinskii operator: y = output_offset + Σ w_i·play_{r_i}[u − input_offset].

    Parameters
    ----------
    thresholds : numpy.ndarray
        Play thresholds, strictly increasing, the first ≥ 0 (0 makes the first play the
        identity). [input unit]
    weights : numpy.ndarray
        Weight of each play. [output unit / input unit]
    input_offset : float, default 0.0
        Input at which the virgin plays sit (0 Pa gauge for a muscle at atmosphere). [input unit]
    output_offset : float, default 0.0
        Output at the virgin state. [output unit]
    input_unit, output_unit : str
        The units, e.g. ``"Pa"`` and ``"m"`` (contraction) or ``"N"`` (force); ``"-"`` for a
        normalized quantity. [-]
    output_map : tuple of numpy.ndarray, optional
        Knots of the inverse output map S⁻¹ (modified PI): outputs y_k [output unit], strictly
        increasing, and the plays' sums v_k there [unit of v = output_offset + Σ w·z],
        non-decreasing; linear between knots, flat beyond. None: the classical operator, y = v.
    stderr : numpy.ndarray, optional
        Standard errors of the weights when fitted (NaN for a weight held at 0). [output unit / input unit]
    valid_range : tuple of float, optional
        Input range the weights were fitted on. [input unit]
    citation : str
        Where the model comes from (and the data it was fitted to). [-]
    """

    thresholds: np.ndarray
    weights: np.ndarray
    input_offset: float = 0.0
    output_offset: float = 0.0
    input_unit: str = "Pa"
    output_unit: str = "m"
    output_map: tuple | None = None
    stderr: np.ndarray | None = None
    valid_range: tuple | None = None
    citation: str = field(default=PI_CITATION)

    def __post_init__(self):
        r = _vector(self.thresholds, "thresholds")
        w = _vector(self.weights, "weights")
        if w.shape != r.shape:
            raise InputError(f"weights: {w.size} weights for {r.size} thresholds")
        if r[0] < 0 or np.any(np.diff(r) <= 0):
            raise InputError("thresholds: must be >= 0 and strictly increasing")
        for name in ("input_offset", "output_offset"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise InputError(f"{name}: {v!r} must be finite")
        if self.output_map is not None:
            yk, vk = (np.asarray(a, dtype=float) for a in self.output_map)
            if (yk.ndim != 1 or yk.shape != vk.shape or yk.size < 2 or not np.all(np.isfinite(yk))
                    or not np.all(np.isfinite(vk)) or np.any(np.diff(yk) <= 0) or np.any(np.diff(vk) < 0)):
                raise InputError("output_map: knots must be two finite 1-D arrays of equal length >= 2, outputs "
                                 "strictly increasing, sums non-decreasing")
            object.__setattr__(self, "output_map", (yk, vk))
        object.__setattr__(self, "thresholds", r)
        object.__setattr__(self, "weights", w)

    @property
    def n(self) -> int:
        """Number of plays. [-]"""
        return int(self.thresholds.size)

    @property
    def slopes(self) -> np.ndarray:
        """W_j = w_0 + … + w_j: slope of the initial loading curve above r_j. [output/input unit]"""
        return np.cumsum(self.weights)

    @property
    def invertible(self) -> bool:
        """True when every slope W_j > 0 (a strictly increasing loading curve). [-]"""
        return bool(np.all(self.slopes > 0))

    def virgin_state(self) -> np.ndarray:
        """Every play at zero (the input at :attr:`input_offset`, never moved). [input unit]"""
        return np.zeros(self.n)

    def apply(self, u, state=None) -> tuple[np.ndarray, np.ndarray]:
        """The output for an input sequence (see :func:`apply`)."""
        return apply(self, u, state)

    def inverse(self) -> PrandtlIshlinskii:
        """The exact inverse operator (see :func:`inverse_operator`)."""
        return inverse_operator(self)

    def loading_curve(self, u) -> np.ndarray:
        """The initial loading curve φ(u) (see :func:`loading_curve`)."""
        return loading_curve(self, u)

    def to_dict(self) -> dict:
        """JSON-ready parameters, units in the keys' values."""
        out = {"model": "prandtl-ishlinskii", "input_unit": self.input_unit, "output_unit": self.output_unit,
               "thresholds": self.thresholds.tolist(), "weights": self.weights.tolist(),
               "input_offset": self.input_offset, "output_offset": self.output_offset, "citation": self.citation}
        if self.output_map is not None:
            out["output_map"] = {"outputs": self.output_map[0].tolist(), "sums": self.output_map[1].tolist()}
        if self.stderr is not None:
            out["weights_stderr"] = [float(s) for s in self.stderr]
        if self.valid_range is not None:
            out["valid_range"] = [float(v) for v in self.valid_range]
        return out


def _state(params: PrandtlIshlinskii, state) -> np.ndarray:
    if state is None:
        return params.virgin_state()
    z = np.asarray(state, dtype=float)
    if z.shape != (params.n,) or not np.all(np.isfinite(z)):
        raise InputError(f"state: must be a finite array of shape ({params.n},) (one value per play)")
    return z.copy()


def descended_state(thresholds, u0: float, input_offset: float = 0.0) -> np.ndarray:
    """Play outputs after the input came down from far above to ``u0``: z_i = u0 − u_0 + r_i.

    The state of a muscle just deflated to ``u0`` (the usual start of an inflate/deflate test):
    on the next rise, play i stays put until the input has risen by 2·r_i.

    Parameters
    ----------
    thresholds : array_like
        Play thresholds, shape (n,). [input unit]
    u0 : float
        The input now. [input unit]
    input_offset : float, default 0.0
        The operator's input offset. [input unit]

    Returns
    -------
    numpy.ndarray
        Play outputs, shape (n,). [input unit]
    """
    r = _vector(thresholds, "thresholds")
    if not (math.isfinite(u0) and math.isfinite(input_offset)):
        raise InputError(f"u0: {u0!r} and input_offset: {input_offset!r} must be finite")
    return (float(u0) - float(input_offset)) + r


def play_matrix(thresholds, u, state=None, input_offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The output of every play over an input sequence: the design matrix of a PI fit.

    Parameters
    ----------
    thresholds : array_like
        Play thresholds, shape (n,). [input unit]
    u : array_like
        Input sequence, shape (k,). [input unit]
    state : array_like, optional
        Play outputs before the first sample (default: all zero, the virgin state). [input unit]
    input_offset : float, default 0.0
        Subtracted from ``u`` before the plays. [input unit]

    Returns
    -------
    z : numpy.ndarray
        Play outputs, shape (k, n). [input unit]
    state : numpy.ndarray
        Play outputs after the last sample, shape (n,). [input unit]
    """
    r = _vector(thresholds, "thresholds")
    x = np.asarray(u, dtype=float)
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise InputError("u: must be a finite 1-D array")
    x = x - float(input_offset)
    z = np.zeros(r.size) if state is None else np.array(state, dtype=float)
    if z.shape != r.shape or not np.all(np.isfinite(z)):
        raise InputError(f"state: must be a finite array of shape ({r.size},) (one value per play)")
    out = np.empty((x.size, r.size))
    lo_r, hi_r = -r, r
    # the plays are independent: one pass in time, vectorized over the plays
    for k, xk in enumerate(x):
        z = np.minimum(np.maximum(z, xk + lo_r), xk + hi_r)
        out[k] = z
    return out, z


def apply(params: PrandtlIshlinskii, u, state=None) -> tuple[np.ndarray, np.ndarray]:
    """A PI operator's output over an input sequence, and the plays' final states.

    Parameters
    ----------
    params : PrandtlIshlinskii
        The operator. [-]
    u : array_like
        Input sequence (pressure [Pa], or a normalized input [-]: :attr:`~PrandtlIshlinskii.input_unit`). [input unit]
    state : array_like, optional
        Play outputs before the first sample, shape (n,); default the virgin state. [input unit]

    Returns
    -------
    y : numpy.ndarray
        Output sequence (contraction or length [m], or force [N]: :attr:`~PrandtlIshlinskii.output_unit`). [output unit]
    state : numpy.ndarray
        Play outputs after the last sample, to continue the sequence. [input unit]
    """
    z0 = _state(params, state)
    z, zf = play_matrix(params.thresholds, u, z0, params.input_offset)
    v = params.output_offset + z @ params.weights
    return (output_map(params, v) if params.output_map is not None else v), zf


def output_map_inverse(params: PrandtlIshlinskii, y) -> np.ndarray:
    """S⁻¹(y): the plays' sum that gives output y (identity for a classical PI).

    Parameters
    ----------
    params : PrandtlIshlinskii
        The operator. [-]
    y : array_like
        Output. [output unit]

    Returns
    -------
    numpy.ndarray
        The plays' weighted sum plus offset, v (flat beyond the knots). [unit of v]
    """
    yy = np.asarray(y, dtype=float)
    if params.output_map is None:
        return yy.copy()
    yk, vk = params.output_map
    return np.interp(yy, yk, vk)


def output_map(params: PrandtlIshlinskii, v) -> np.ndarray:
    """S(v): the output for a plays' sum v (saturating at the end knots).

    Parameters
    ----------
    params : PrandtlIshlinskii
        The operator. [-]
    v : array_like
        The plays' weighted sum plus offset. [unit of v]

    Returns
    -------
    numpy.ndarray
        Output y. [output unit]
    """
    vv = np.asarray(v, dtype=float)
    if params.output_map is None:
        return vv.copy()
    yk, vk = params.output_map
    return np.interp(vv, vk, yk)


def loading_curve(params: PrandtlIshlinskii, u) -> np.ndarray:
    """The initial loading curve: the output from the virgin state along a monotone input.

    φ(u) = y_0 + sign(x)·Σ_i w_i·max(|x| − r_i, 0), x = u − u_0 (odd about the input offset).

    Parameters
    ----------
    params : PrandtlIshlinskii
        The operator. [-]
    u : array_like
        Input values. [input unit]

    Returns
    -------
    numpy.ndarray
        Output. [output unit]
    """
    x = np.asarray(u, dtype=float) - params.input_offset
    a = np.abs(x)[..., None]
    v = params.output_offset + np.sign(x) * (np.clip(a - params.thresholds, 0.0, None) @ params.weights)
    return output_map(params, v) if params.output_map is not None else v


def inverse_operator(params: PrandtlIshlinskii) -> PrandtlIshlinskii:
    """The exact inverse PI operator, in closed form from the initial loading curve.

    r'_j = Σ_{i≤j} w_i·(r_j − r_i), w'_0 = 1/w_0, w'_j = −w_j/(W_j·W_{j−1}) with
    W_j = Σ_{i≤j} w_i; input and output offsets swap, and so do the units. The inverse of the
    inverse is the operator again (to rounding).

    Parameters
    ----------
    params : PrandtlIshlinskii
        An operator whose every slope W_j > 0 (:attr:`~PrandtlIshlinskii.invertible`); its
        first threshold must be 0 (the identity play carries w_0). [-]

    Returns
    -------
    PrandtlIshlinskii
        The inverse: from an output sequence and the matching state (:func:`inverse_state`) it
        gives back the input sequence. [-]

    Raises
    ------
    InputError
        A first threshold > 0 or a slope W_j ≤ 0 (the loading curve is not strictly increasing).

    References
    ----------
    Krejčí, P., Kuhnen, K. (2001), Inverse control of systems with hysteresis and creep, IEE
    Proc. Control Theory Appl. 148(3), 185–192 (the inverse PI operator); Kuhnen, K. (2003),
    European Journal of Control 9(4), 407–418, eq. (12)–(13) (its thresholds and weights).
    """
    if params.output_map is not None:
        raise InputError("params: a modified PI operator (output_map) has no PI inverse; use invert()")
    r, w = params.thresholds, params.weights
    if r[0] != 0.0:
        raise InputError(f"params: the first threshold is {r[0]!r}; the inverse needs a play of threshold 0")
    big_w = np.cumsum(w)
    if not np.all(big_w > 0):
        j = int(np.flatnonzero(big_w <= 0)[0])
        raise InputError(f"params: the loading curve's slope W_{j} = {big_w[j]:.6g} is not > 0; the operator "
                         "is not invertible")
    # r'_j = φ(r_j) − y0 = Σ_{i≤j} w_i (r_j − r_i) = W_j r_j − Σ_{i≤j} w_i r_i
    r_inv = big_w * r - np.cumsum(w * r)
    w_inv = np.empty_like(w)
    w_inv[0] = 1.0 / w[0]
    w_inv[1:] = -w[1:] / (big_w[1:] * big_w[:-1])
    return PrandtlIshlinskii(r_inv, w_inv, input_offset=params.output_offset, output_offset=params.input_offset,
                             input_unit=params.output_unit, output_unit=params.input_unit,
                             citation=f"inverse of: {params.citation}")


def inverse_state(params: PrandtlIshlinskii, state) -> np.ndarray:
    """The inverse operator's play states that match the forward operator's.

    z'_j = W_j·z_j + Σ_{i>j} w_i·z_i: with them, :func:`inverse_operator` continues a sequence the
    forward operator left in ``state`` and inverts it exactly (the virgin state maps to the
    virgin state).

    Parameters
    ----------
    params : PrandtlIshlinskii
        The forward operator. [-]
    state : array_like
        Its play outputs, shape (n,). [input unit]

    Returns
    -------
    numpy.ndarray
        The inverse's play outputs, shape (n,). [output unit]
    """
    z = _state(params, state)
    w = params.weights
    tail = np.cumsum((w * z)[::-1])[::-1]  # Σ_{i≥j} w_i z_i
    after = np.r_[tail[1:], 0.0]            # Σ_{i>j} w_i z_i
    return np.cumsum(w) * z + after


def forward_state(params: PrandtlIshlinskii, inverse_state_) -> np.ndarray:
    """The forward operator's play states from its inverse's (the inverse of :func:`inverse_state`).

    Parameters
    ----------
    params : PrandtlIshlinskii
        The forward operator. [-]
    inverse_state_ : array_like
        The inverse operator's play outputs, shape (n,). [output unit]

    Returns
    -------
    numpy.ndarray
        The forward operator's play outputs, shape (n,). [input unit]
    """
    return inverse_state(inverse_operator(replace(params, output_map=None)), inverse_state_)


def invert(params: PrandtlIshlinskii, y, state=None) -> tuple[np.ndarray, np.ndarray]:
    """The input sequence that makes a PI operator output ``y`` (its exact inverse applied).

    Parameters
    ----------
    params : PrandtlIshlinskii
        The forward operator. [-]
    y : array_like
        Wanted output sequence (e.g. a contraction target [m]). [output unit]
    state : array_like, optional
        The forward operator's play outputs before the first sample; default virgin. [input unit]

    Returns
    -------
    u : numpy.ndarray
        Input sequence (e.g. pressure [Pa]). [input unit]
    state : numpy.ndarray
        The forward operator's play outputs after the last sample. [input unit]
    """
    classical = replace(params, output_map=None)
    inv = inverse_operator(classical)
    z_inv = inverse_state(classical, _state(params, state))
    u, zf_inv = apply(inv, output_map_inverse(params, y), z_inv)
    return u, inverse_state(inv, zf_inv)
