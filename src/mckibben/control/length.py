"""Length (contraction) control: static feed-forward, hysteresis compensation, outer loop.

A target length becomes a target pressure through the inverse static model (eq. 2 + 3 of
[mpam-characterization] inverted, :func:`mckibben.models.mpam.pressure_for_length`: "a static
feed-forward term in the closed loop control of the MPAM", §III). The pressure loop (the core's
sliding mode or PID) runs inside. Two refinements:

- **hysteresis compensation**: the muscle needs more pressure inflating than deflating for the
  same contraction (§III). :func:`fit_hysteresis_branches` fits one cubic per branch, pressure as
  a function of length, to a quasi-static inflate/deflate sweep; :func:`length_feedforward`
  then picks the branch by the direction the target moves (length falling = inflating) and
  keeps the last branch while the target holds still;
- **Prandtl–Ishlinskii compensation**: :func:`fit_pi_hysteresis` fits a (modified)
  Prandtl–Ishlinskii operator from pressure to contraction
  (:mod:`mckibben.models.hysteresis`, :mod:`mckibben.fit.hysteresis`) and
  :meth:`PIHysteresis.pressure` inverts it exactly: the pressure for a length target follows
  from the target's whole history through the operator's memory, direction-aware without
  switching branches (a reversal inside the loop moves the pressure through the loop's
  interior, as the muscle does);
- **outer loop on the encoder**: :func:`length_loop_kernel` wraps the core kernel (so the
  supervisor stays below it) with a PI correction of the pressure reference from the length
  error measured by the encoder, on top of the feed-forward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben._jit import kernel
from mckibben.control.core_params import N_ISTATE
from mckibben.control.step import core_kernel
from mckibben.errors import InputError
from mckibben.fit.hysteresis import PIFit, fit_prandtl_ishlinskii
from mckibben.hardware import ENCODER_RESOLUTION
from mckibben.models.hysteresis import PrandtlIshlinskii, apply, invert, thresholds_uniform
from mckibben.datasets import get_muscle
from mckibben.models.mpam import pressure_for_length, require_reachable
from mckibben.control.core_params import pack_params

#: Encoder resolution of the paper's rig (:data:`mckibben.hardware.ENCODER_RESOLUTION`).
ENCODER_M_PER_COUNT = ENCODER_RESOLUTION


@dataclass(frozen=True)
class HysteresisBranches:
    """Pressure as a cubic of length on the inflating and on the deflating branch.

    Parameters
    ----------
    inflate : numpy.ndarray
        Polynomial coefficients (``numpy.polyval`` order) of pressure [Pa] in length [m] on the
        inflating branch. [Pa/m^k]
    deflate : numpy.ndarray
        The same on the deflating branch. [Pa/m^k]
    length_range : tuple of float
        Lengths the sweep covered; evaluation outside is clipped to it. [m]
    rmse_inflate, rmse_deflate : float
        Fit residuals of each branch. [Pa]
    """

    inflate: np.ndarray
    deflate: np.ndarray
    length_range: tuple
    rmse_inflate: float
    rmse_deflate: float

    def pressure(self, length, inflating) -> np.ndarray:
        """Pressure that holds ``length`` on the given branch.

        Parameters
        ----------
        length : array_like
            Target length. [m]
        inflating : array_like of bool
            True for the inflating branch. [-]
        """
        ell = np.clip(np.asarray(length, dtype=float), *self.length_range)
        return np.where(inflating, np.polyval(self.inflate, ell), np.polyval(self.deflate, ell))

    def width(self, length) -> np.ndarray:
        """Hysteresis width, inflating minus deflating pressure at a length.

        Parameters
        ----------
        length : array_like
            Length. [m]
        """
        return self.pressure(length, True) - self.pressure(length, False)


def fit_hysteresis_branches(pressure, length, inflating, degree: int = 3) -> HysteresisBranches:
    """Fit pressure as a polynomial of length on each branch of a quasi-static sweep.

    The paper fits a cubic to each branch of contraction against pressure (§III, "hysteresis");
    we fit the inverse directly (pressure against length), the map the feed-forward needs.

    Parameters
    ----------
    pressure : array_like
        Measured pressure of the sweep. [Pa]
    length : array_like
        Measured length. [m]
    inflating : array_like of bool
        True where the pressure was rising. [-]
    degree : int, default 3
        Polynomial degree. [-]

    Returns
    -------
    HysteresisBranches
        The two fitted branches.

    References
    ----------
    [mpam-characterization], §III (cubic fit of each hysteresis branch).
    """
    p = np.asarray(pressure, dtype=float)
    ell = np.asarray(length, dtype=float)
    up = np.asarray(inflating, dtype=bool)
    if not (p.shape == ell.shape == up.shape) or p.ndim != 1:
        raise InputError("fit_hysteresis_branches: pressure, length and inflating must be 1-D of equal length")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(ell))):
        raise InputError("fit_hysteresis_branches: pressure or length contains NaN or infinite values")
    coefs, rmses = [], []
    for mask, name in ((up, "inflating"), (~up, "deflating")):
        if np.count_nonzero(mask) < 3 * (degree + 1):
            raise InputError(f"fit_hysteresis_branches: too few {name} samples ({np.count_nonzero(mask)})")
        c = np.polyfit(ell[mask], p[mask], degree)
        coefs.append(c)
        rmses.append(float(np.sqrt(np.mean((np.polyval(c, ell[mask]) - p[mask]) ** 2))))
    return HysteresisBranches(coefs[0], coefs[1], (float(ell.min()), float(ell.max())), rmses[0], rmses[1])


@dataclass(frozen=True)
class PIHysteresis:
    """A muscle's pressure-to-contraction hysteresis as a Prandtl–Ishlinskii operator.

    Contraction is ``reference_length − length``; the operator's input is the gauge pressure.

    Parameters
    ----------
    model : PrandtlIshlinskii
        Pressure [Pa] to contraction [m] (a modified PI when its ``output_map`` is set). [-]
    reference_length : float
        Length at zero contraction of the operator's output. [m]
    length_range : tuple of float
        Lengths the fit covered; targets outside are clipped to it. [m]
    fit : PIFit
        The fit record (weights' standard errors, residuals). [-]
    """

    model: PrandtlIshlinskii
    reference_length: float
    length_range: tuple
    fit: PIFit

    @property
    def rmse(self) -> float:
        """Fit residual: contraction [m] for a classical PI, pressure [Pa] for a modified one."""
        return self.fit.fit.residual_rms

    def pressure(self, length_ref, state=None) -> tuple[np.ndarray, np.ndarray]:
        """The pressure sequence that holds a length sequence (the exact inverse operator).

        Parameters
        ----------
        length_ref : array_like
            Target length per sample. [m]
        state : array_like, optional
            The operator's play states before the first sample; default virgin (the muscle
            at zero gauge pressure, never inflated). [Pa]

        Returns
        -------
        pressure : numpy.ndarray
            Pressure per sample. [Pa]
        state : numpy.ndarray
            Play states after the last sample. [Pa]
        """
        ell = np.clip(np.asarray(length_ref, dtype=float), *self.length_range)
        return invert(self.model, self.reference_length - ell, state)

    def length(self, pressure, state=None) -> tuple[np.ndarray, np.ndarray]:
        """The length the operator predicts for a pressure sequence.

        Parameters
        ----------
        pressure : array_like
            Pressure per sample. [Pa]
        state : array_like, optional
            Play states before the first sample; default virgin. [Pa]

        Returns
        -------
        length : numpy.ndarray
            Length per sample. [m]
        state : numpy.ndarray
            Play states after the last sample. [Pa]
        """
        c, z = apply(self.model, pressure, state)
        return self.reference_length - c, z

    def summary(self) -> dict:
        """JSON-ready: the operator, its fit residual and range."""
        return {"model": self.model.to_dict(), "reference_length_m": self.reference_length,
                "length_range_m": list(self.length_range),
                f"rmse_{'Pa' if self.model.output_map is not None else 'm'}": self.rmse, "r2": self.fit.fit.r2,
                "flags": list(self.fit.fit.flags)}


def fit_pi_hysteresis(pressure, length, *, mask=None, reference_length: float | None = None, n_plays: int = 6,
                      output_knots: int = 8) -> PIHysteresis:
    """Fit a Prandtl–Ishlinskii operator, pressure to contraction, on a recorded pressure sweep.

    The plays run over the whole record from the virgin state (the record must start at zero
    gauge pressure or from a state that the first samples wash out); the fit uses the samples
    of ``mask`` (leave out the saturated ends, where length is not a function of pressure).
    The sweep should reverse inside the fitted range (minor loops): a single major loop
    determines only the loop's width, not how the muscle turns round.

    Parameters
    ----------
    pressure : array_like
        Measured pressure per sample, in time order. [Pa]
    length : array_like
        Measured length per sample. [m]
    mask : array_like of bool, optional
        Samples to fit; default all. [-]
    reference_length : float, optional
        Length of zero contraction; default the longest length recorded. [m]
    n_plays : int, default 6
        Number of plays, thresholds evenly spaced up to half the fitted samples' pressure span. [-]
    output_knots : int, default 8
        Knots of the modified PI's monotone output map (0: the classical PI; the map follows the
        S-shaped contraction of a muscle). [-]

    Returns
    -------
    PIHysteresis
        The operator, its fit and range.

    References
    ----------
    Kuhnen, K. (2003), European Journal of Control 9(4), 407–418 (modified PI operator);
    Krejčí & Kuhnen (2001), IEE Proc. Control Theory Appl. 148(3), 185–192 (its inverse).
    """
    p = np.asarray(pressure, dtype=float)
    ell = np.asarray(length, dtype=float)
    if not (p.shape == ell.shape) or p.ndim != 1:
        raise InputError("fit_pi_hysteresis: pressure and length must be 1-D of equal length")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(ell))):
        raise InputError("fit_pi_hysteresis: pressure or length contains NaN or infinite values")
    m = np.ones(p.size, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    if m.shape != p.shape or np.count_nonzero(m) < 10 * (n_plays + output_knots):
        raise InputError(f"mask: too few samples to fit ({np.count_nonzero(m)})")
    l_ref = float(ell.max()) if reference_length is None else float(reference_length)
    if not math.isfinite(l_ref):
        raise InputError(f"reference_length: {reference_length!r} must be finite")
    r = thresholds_uniform(n_plays, float(np.ptp(p[m])))
    res = fit_prandtl_ishlinskii(p, l_ref - ell, r, mask=m, output_knots=output_knots, input_unit="Pa",
                                 output_unit="m", what="fit_pi_hysteresis")
    return PIHysteresis(res.model, l_ref, (float(ell[m].min()), float(ell[m].max())), res)


def inflating_direction(length_ref) -> np.ndarray:
    """Which branch each sample of a length reference is on: True while the length falls.

    A sample where the reference holds still keeps the previous direction; the first samples
    before any motion count as inflating (the muscle starts from low pressure).

    Parameters
    ----------
    length_ref : array_like
        Length reference per sample. [m]

    Returns
    -------
    numpy.ndarray of bool
        True on the inflating branch. [-]
    """
    ell = np.asarray(length_ref, dtype=float)
    d = np.diff(ell, prepend=ell[:1])
    out = np.empty(ell.shape, dtype=bool)
    last = True
    for i, di in enumerate(d):
        if di < 0:
            last = True
        elif di > 0:
            last = False
        out[i] = last
    return out


def length_feedforward(length_ref, *, muscle=None, load: float = 0.6, p_max: float = 0.8e6,
                       branches: HysteresisBranches | None = None, pi: PIHysteresis | None = None) -> np.ndarray:
    """Pressure reference for a length reference: the static inverse, optionally per branch.

    Parameters
    ----------
    length_ref : array_like
        Target length per sample. [m]
    muscle : MiniatureMuscle, optional
        Static model for the inverse without ``branches`` (default ``mpam97``). [-]
    load : float, default 0.6
        Hanging load. [N]
    p_max : float, default 0.8e6
        Pressure limit; targets beyond reach become an error. [Pa]
    branches : HysteresisBranches, optional
        Fitted inflate/deflate branches: hysteresis compensation. [-]
    pi : PIHysteresis, optional
        A fitted Prandtl–Ishlinskii operator: compensation through its exact inverse, from the
        virgin state at the first sample (exclusive with ``branches``). [-]

    Returns
    -------
    numpy.ndarray
        Pressure reference, clipped to [0, p_max]. [Pa]

    Raises
    ------
    UnreachableError
        A target no pressure in [0, p_max] reaches (static inverse only).

    References
    ----------
    [mpam-characterization], eq. (2) and (3) inverted (§III: the model as a static feed-forward).
    """
    ell = np.asarray(length_ref, dtype=float)
    if ell.ndim != 1 or not np.all(np.isfinite(ell)):
        raise InputError("length reference must be a finite 1-D array")
    if branches is not None and pi is not None:
        raise InputError("pi: give either branches or pi, not both")
    if pi is not None:
        return np.clip(pi.pressure(ell)[0], 0.0, p_max)
    if branches is not None:
        return np.clip(branches.pressure(ell, inflating_direction(ell)), 0.0, p_max)

    m = get_muscle("mpam97") if muscle is None else muscle
    uniq, inv = np.unique(ell, return_inverse=True)
    r = pressure_for_length(m, uniq, load, p_max)
    require_reachable(r, m, p_max)
    return np.clip(r.pressure[inv], 0.0, p_max)


# --- outer loop on the encoder, as a kernel of the batch simulator -------------------------------

#: fparams layout of :func:`length_loop_kernel` (after it, the length reference per step).
FP_KP, FP_KI, FP_L0, FP_M_PER_COUNT, FP_CORR_MAX, FP_REF0 = 0, 1, 2, 3, 4, 5
#: fstate layout: integral of the length error [m s], the last correction [Pa].
FS_INT, FS_CORR = 0, 1
#: istate: the core's state, then the step index.
IS_STEP = N_ISTATE


@kernel
def length_loop_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    """Feed-forward pressure plus a PI on the encoder's length error, then the core.

    ``p_ref_pa`` carries the feed-forward pressure of this step; the length target of step k is
    ``fparams[FP_REF0 + k]``. The measured length is ``L0 − enc·m_per_count``. The correction
    ``Kp·(l − l_ref) + Ki·∫(l − l_ref)`` (a muscle too long needs more pressure) is clamped to
    ±corr_max (anti-windup: the integral stops growing while clamped), added to the
    feed-forward, and the sum goes to :func:`~mckibben.control.core.core_kernel` as its
    reference: the supervisor clamps it and vents on faults as for any other reference.

    Parameters
    ----------
    istate : numpy.ndarray of int64
        The core's state, then the step index. [-]
    iparams : numpy.ndarray of int64
        The core's parameters. [-]
    fstate : numpy.ndarray of float64
        Integral of the length error and last correction. [m s, Pa]
    fparams : numpy.ndarray of float64
        Kp [Pa/m], Ki [Pa/(m s)], L0 [m], encoder [m/count], corr_max [Pa], then the length
        target per step [m]. [-]
    adc : int
        Pressure ADC count. [count]
    enc : int
        Encoder count (contraction positive). [count]
    sample_ok : bool
        False when no sample arrived. [-]
    p_ref_pa : float
        Feed-forward pressure of this step. [Pa]

    Returns
    -------
    tuple of int
        Inlet, bleed PWM counts and the fault flags, from the core. [-]
    """
    k = istate[IS_STEP]
    n_ref = fparams.shape[0] - FP_REF0
    kk = k if k < n_ref else n_ref - 1
    l_ref = fparams[FP_REF0 + kk]
    istate[IS_STEP] = k + 1
    ts = iparams[1] * 1e-6
    length = fparams[FP_L0] - enc * fparams[FP_M_PER_COUNT]
    err = length - l_ref
    cmax = fparams[FP_CORR_MAX]
    integ = fstate[FS_INT] + err * ts
    corr = fparams[FP_KP] * err + fparams[FP_KI] * integ
    if corr > cmax:
        corr = cmax
    elif corr < -cmax:
        corr = -cmax
    else:
        fstate[FS_INT] = integ
    fstate[FS_CORR] = corr
    return core_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa + corr)


def length_loop_spec(core_params, length_ref, *, kp: float, ki: float, rest_length: float,
                     corr_max: float = 0.1e6, m_per_count: float = ENCODER_M_PER_COUNT, n: int = 1):
    """Controller spec of :func:`length_loop_kernel` for the batch simulator.

    Parameters
    ----------
    core_params : CoreParams
        The inner pressure loop (sliding mode or PID) and supervisor. [-]
    length_ref : array_like
        Length target per control step. [m]
    kp : float
        Proportional gain of the outer loop. [Pa/m]
    ki : float
        Integral gain of the outer loop. [Pa/(m s)]
    rest_length : float
        Length at encoder count 0. [m]
    corr_max : float, default 0.1e6
        Clamp of the outer loop's pressure correction. [Pa]
    m_per_count : float, default 0.17e-3
        Encoder resolution. [m/count]
    n : int, default 1
        Number of instances. [-]

    Returns
    -------
    tuple
        ``(length_loop_kernel, istate0, iparams, fstate0, fparams)`` with N rows. [-]
    """

    ref = np.asarray(length_ref, dtype=float)
    if ref.ndim != 1 or ref.size == 0 or not np.all(np.isfinite(ref)):
        raise InputError("length_loop_spec: length_ref must be a finite, non-empty 1-D array")
    for name, v in (("kp", kp), ("ki", ki), ("corr_max", corr_max), ("rest_length", rest_length)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"length_loop_spec: {name}={v!r} must be finite and >= 0")
    st, ip, _, _ = pack_params(core_params)
    ist = np.zeros((n, N_ISTATE + 1), dtype=np.int64)
    ist[:, :N_ISTATE] = st
    fp = np.concatenate([[kp, ki, rest_length, m_per_count, corr_max], ref])
    return (length_loop_kernel, ist, np.tile(ip, (n, 1)), np.zeros((n, 2)), np.tile(fp, (n, 1)))
