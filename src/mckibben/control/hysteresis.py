"""Measured benefit of hysteresis compensation for length control, on the plant simulator.

The muscle needs more pressure inflating than deflating for the same contraction (§III of
[mpam-characterization]; in :mod:`mckibben.plant` a Dahl friction element on the braid gives
this rate-independent hysteresis). :func:`hysteresis_benefit` measures what the per-branch
feed-forward of :mod:`mckibben.control.length` buys over a single static map:

1. **identification sweep**: a slow triangle pressure reference ``p_low → p_high → p_low``
   (by default 8 times slower than the tracking, see :data:`SWEEP_PERIOD_FACTOR`) under the
   sliding-mode pressure loop; one triangle conditions the friction state, the second
   is recorded. The inflate and deflate branches (pressure as a cubic of length,
   :func:`~mckibben.control.length.fit_hysteresis_branches`) and one cubic through all points of
   both branches (the map without compensation) are fitted on the samples whose length lies
   inside the sweep's length range shrunk by :data:`FIT_MARGIN` at each end: at both ends the
   length saturates (rest length, full contraction) and pressure is not a function of length;
2. **tracking**: a slow sinusoidal length target inside that range becomes a pressure reference
   through (i) the single cubic and (ii) the branches, picked by
   :func:`~mckibben.control.length.inflating_direction`; both run as one batch of the pressure
   loop (no encoder outer loop), so the whole length error is the feed-forward's;
3. the RMS and maximum length error after the first cycle of each, and their ratios;
4. **Prandtl–Ishlinskii variant** (``pi=True``, new keys only): a second sweep at the same
   rate with minor loops inside the range (:data:`PI_TURNS`: reversals inside the loop are what
   identifies how the muscle turns round), a modified PI operator fitted to it
   (:func:`~mckibben.control.length.fit_pi_hysteresis`), and the same tracking with the
   pressure reference from its exact inverse (:meth:`~mckibben.control.length.PIHysteresis.pressure`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial

from mckibben.control.length import (
    HysteresisBranches,
    PIHysteresis,
    fit_hysteresis_branches,
    fit_pi_hysteresis,
    inflating_direction,
)
from mckibben.errors import InputError
from mckibben.control.core_params import core_spec
from mckibben.control.controllers import smc_core_params
from mckibben.control.loop import run_closed_loop
from mckibben.control.plots import plot_hysteresis
from mckibben.results import Result, to_jsonable

#: Fraction of the sweep's length span left out at each end of the branch fits (saturation).
FIT_MARGIN = 0.1
#: Default amplitude of the length target as a fraction of the fitted length span. [-]
AMPLITUDE_FRACTION = 0.4
#: Bounds of the tracking period: slower than the pressure loop by far, and a bounded run time. [s]
PERIOD_MIN, PERIOD_MAX = 1.0, 60.0
#: Bounds of the sweep period. [s]
SWEEP_PERIOD_MIN, SWEEP_PERIOD_MAX = 1.0, 600.0
#: Default sweep period as a multiple of the tracking period. A sweep as fast as the tracking
#: is not quasi-static: the length crosses the steep part of the loop fast, viscous damping
#: widens the loop (88 kPa at 4 s against 37 kPa at 64 s on the calibrated plant) and the
#: branches over-compensate (docs/hysteresis.md). [-]
SWEEP_PERIOD_FACTOR = 8.0
#: Pressure held before the sweep and the tracking run start moving. [s]
HOLD_S = 0.5

METHODS = ("single_cubic", "branches")
#: Turning points of the Prandtl–Ishlinskii identification sweep, as fractions of
#: [p_low, p_high]: one major loop (the first rise conditions the plays and is not fitted), then
#: minor loops of shrinking size around the middle of the range. [-]
PI_TURNS = (0.0, 1.0, 0.0, 0.85, 0.35, 0.8, 0.4, 0.75, 0.45, 0.7, 0.5, 0.65, 0.55, 1.0, 0.0)
#: Plays and knots of the output map of the fitted (modified) operator. [-]
PI_PLAYS, PI_OUTPUT_KNOTS = 6, 8


@dataclass(frozen=True, repr=False)
class HysteresisBenefit(Result):
    """Result of :func:`hysteresis_benefit`: sweep, fits, tracking records and errors.

    Parameters
    ----------
    period : float
        Period of the length sinusoid. [s]
    sweep_period : float
        Period of the identification triangle. [s]
    cycles : int
        Cycles of the length sinusoid; errors are taken after the first. [-]
    mean, amplitude : float
        Centre and amplitude of the length sinusoid. [m]
    sweep_pressure, sweep_length : numpy.ndarray
        Measured pressure [Pa] and length [m] of the recorded sweep triangle.
    sweep_inflating : numpy.ndarray of bool
        True where the sweep's reference rose. [-]
    fit_mask : numpy.ndarray of bool
        Sweep samples the fits used. [-]
    branches : HysteresisBranches
        Inflate/deflate fits, pressure [Pa] of length [m].
    single : numpy.polynomial.Polynomial
        One cubic through both branches, pressure [Pa] of length [m].
    rmse_single : float
        Fit residual of the single cubic. [Pa]
    t : numpy.ndarray
        Time of the tracking run, from the start of the sinusoid. [s]
    length_ref : numpy.ndarray
        Length target. [m]
    length : numpy.ndarray
        Measured length, (2, n): single cubic, then branches. [m]
    pressure_ref : numpy.ndarray
        Pressure references, (2, n). [Pa]
    rms_error, max_error : numpy.ndarray
        RMS and maximum absolute length error after the first cycle, per method. [m]
    pi : PIHysteresis, optional
        The Prandtl–Ishlinskii operator fitted on its own sweep (None with ``pi=False``). [-]
    pi_sweep_pressure, pi_sweep_length : numpy.ndarray, optional
        Its sweep with minor loops: measured pressure [Pa] and length [m].
    pi_fit_mask : numpy.ndarray of bool, optional
        Samples of that sweep the fit used. [-]
    pi_length, pi_pressure_ref : numpy.ndarray, optional
        Tracking with the inverse operator's pressure: length [m] and reference [Pa].
    pi_rms_error, pi_max_error : float
        Its RMS and maximum length error after the first cycle (NaN without). [m]
    pi_error : str
        Why the operator could not be fitted on this plant (empty when it was). [-]
    """

    period: float
    sweep_period: float
    cycles: int
    mean: float
    amplitude: float
    sweep_pressure: np.ndarray
    sweep_length: np.ndarray
    sweep_inflating: np.ndarray
    fit_mask: np.ndarray
    branches: HysteresisBranches
    single: Polynomial
    rmse_single: float
    t: np.ndarray
    length_ref: np.ndarray
    length: np.ndarray
    pressure_ref: np.ndarray
    rms_error: np.ndarray
    max_error: np.ndarray
    pi: PIHysteresis | None = None
    pi_sweep_pressure: np.ndarray | None = None
    pi_sweep_length: np.ndarray | None = None
    pi_fit_mask: np.ndarray | None = None
    pi_length: np.ndarray | None = None
    pi_pressure_ref: np.ndarray | None = None
    pi_rms_error: float = math.nan
    pi_max_error: float = math.nan
    pi_error: str = ""
    call = "mckibben.experiments.hysteresis_compensation"
    _repr_keys = ("rms_ratio", "max_ratio")

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """Tracking and sweep periods [s], and the tracked length's mean and amplitude [m]."""
        return {"period_s": self.period, "sweep_period_s": self.sweep_period, "length_mean_m": self.mean,
                "length_amplitude_m": self.amplitude}

    def to_dict(self) -> dict:
        """What ``mckibben control hysteresis --json`` prints: :meth:`summary`."""
        return to_jsonable(self.summary())

    def _series(self):
        """The length-tracking runs: target, and each method's pressure reference and length."""
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        data = {"time_s": self.t, "length_reference_m": self.length_ref}
        for i, name in enumerate(METHODS):
            data[f"{name}_pressure_reference_Pa"] = self.pressure_ref[i]
            data[f"{name}_length_m"] = self.length[i]
        if self.pi_length is not None and self.pi_pressure_ref is not None:
            data["prandtl_ishlinskii_pressure_reference_Pa"] = self.pi_pressure_ref
            data["prandtl_ishlinskii_length_m"] = self.pi_length
        return pd.DataFrame(data)

    @property
    def rms_ratio(self) -> float:
        """RMS length error with branches over without. [-]"""
        return float(self.rms_error[1] / self.rms_error[0])

    @property
    def max_ratio(self) -> float:
        """Maximum length error with branches over without. [-]"""
        return float(self.max_error[1] / self.max_error[0])

    @property
    def metrics(self) -> dict:
        """The numbers (:meth:`summary`), SI with unit-suffixed keys."""
        return self.summary()

    def plot(self, ax=None):
        """The sweep with both branch fits, and the tracking errors; return the Figure.

        Parameters
        ----------
        ax : pair of matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """

        return plot_hysteresis(self, ax=ax)

    def summary(self) -> dict:
        """The numbers, SI with unit-suffixed keys (what ``--json`` prints)."""
        return {
            "period_s": self.period,
            "sweep_period_s": self.sweep_period,
            "cycles": self.cycles,
            "length_mean_m": self.mean,
            "length_amplitude_m": self.amplitude,
            "fit_length_range_m": list(self.branches.length_range),
            "fit_rmse_Pa": {"inflating": self.branches.rmse_inflate, "deflating": self.branches.rmse_deflate,
                            "single_cubic": self.rmse_single},
            "hysteresis_width_at_mean_Pa": float(self.branches.width(self.mean)),
            **{name: {"rms_error_m": float(self.rms_error[i]), "max_error_m": float(self.max_error[i])}
               for i, name in enumerate(METHODS)},
            "rms_ratio": self.rms_ratio,
            "max_ratio": self.max_ratio,
            **({"prandtl_ishlinskii": {"error": self.pi_error}} if self.pi_error else {}),
            **({} if self.pi is None else {"prandtl_ishlinskii": {
                "rms_error_m": self.pi_rms_error, "max_error_m": self.pi_max_error,
                "rms_ratio_to_single": float(self.pi_rms_error / self.rms_error[0]),
                "max_ratio_to_single": float(self.pi_max_error / self.max_error[0]),
                "rms_ratio_to_branches": float(self.pi_rms_error / self.rms_error[1]),
                "fit_rmse_Pa": self.pi.rmse, "n_plays": self.pi.model.n, "output_knots": PI_OUTPUT_KNOTS,
                "sweep_turns_fraction": list(PI_TURNS),
                "weights": self.pi.model.weights.tolist(),
                "weights_stderr": [float(v) for v in self.pi.model.stderr]
                if self.pi.model.stderr is not None else None,
                "thresholds_Pa": self.pi.model.thresholds.tolist()}}),
        }


def _triangle(n: int, p_low: float, p_high: float) -> np.ndarray:
    phase = np.arange(n) / n
    return p_low + (p_high - p_low) * np.where(phase < 0.5, 2 * phase, 2 - 2 * phase)


def _turns(turns, n_per_unit: int, p_low: float, p_high: float) -> np.ndarray:
    """A piecewise-linear pressure reference through turning points (fractions of the range)."""
    f = np.asarray(turns, dtype=float)
    segs = [np.linspace(a, b, max(int(round(abs(b - a) * n_per_unit)), 1), endpoint=False)
            for a, b in zip(f[:-1], f[1:])]
    return p_low + (p_high - p_low) * np.concatenate(segs + [f[-1:]])


def hysteresis_benefit(model, *, period: float = 4.0, amplitude: float | None = None, mean: float | None = None,
                       cycles: int = 2, plant=None, sweep_period: float | None = None, p_low: float = 0.1e6,
                       p_high: float = 0.7e6, beta: float | None = None, ts: float = 1e-3,
                       pi: bool = True) -> HysteresisBenefit:
    """Length tracking error with and without hysteresis compensation, on the plant.

    Parameters
    ----------
    model : FirstOrderModel
        Identified pressure model (:func:`~mckibben.control.identify.identify_plant`), the
        sliding mode's model term. [-]
    period : float, default 4.0
        Period of the length sinusoid, 1 to 60 s. [s]
    amplitude : float, optional
        Amplitude of the length sinusoid; default :data:`AMPLITUDE_FRACTION` of the fitted
        length span. [m]
    mean : float, optional
        Centre of the length sinusoid; default the centre of the fitted length range. [m]
    cycles : int, default 2
        Cycles of the length sinusoid, at least 2; the first (start-up) is not scored. [-]
    plant : optional
        Plant parameters (:func:`~mckibben.control.plant_sampling.plant_batch`); default the
        calibrated plant. [-]
    sweep_period : float, optional
        Period of the identification triangle, 1 to 600 s; default
        :data:`SWEEP_PERIOD_FACTOR` × ``period`` (quasi-static). [s]
    p_low, p_high : float, default 0.1e6, 0.7e6
        Pressure range of the identification sweep. [Pa]
    beta : float, optional
        Switching gain of the pressure loop (our sliding-mode law); default the step design's
        (:data:`mckibben.control.controllers.SMC_TUNING`). [PWM counts]
    ts : float, default 1e-3
        Control period. [s]
    pi : bool, default True
        Also fit and track with the Prandtl–Ishlinskii operator (its own sweep and tracking
        run; the other results do not change). [-]

    Returns
    -------
    HysteresisBenefit
        Sweep, fits, tracking records, RMS and maximum length errors.

    Raises
    ------
    InputError
        A period outside [1, 60] s or sweep period outside [1, 600] s, fewer than 2 cycles, a
        bad sweep range, or a length target outside the fitted range.

    References
    ----------
    [mpam-characterization], §III (hysteresis: one cubic per branch).
    """

    if not (math.isfinite(period) and PERIOD_MIN <= period <= PERIOD_MAX):
        raise InputError(f"period: {period!r} s must be between {PERIOD_MIN:g} and {PERIOD_MAX:g} s")
    sweep_period = SWEEP_PERIOD_FACTOR * period if sweep_period is None else float(sweep_period)
    if not (math.isfinite(sweep_period) and SWEEP_PERIOD_MIN <= sweep_period <= SWEEP_PERIOD_MAX):
        raise InputError(f"sweep_period: {sweep_period!r} s must be between {SWEEP_PERIOD_MIN:g} and "
                         f"{SWEEP_PERIOD_MAX:g} s")
    if int(cycles) != cycles or cycles < 2:
        raise InputError(f"cycles: {cycles!r} must be an integer >= 2 (the first cycle is not scored)")
    if not (math.isfinite(p_low) and math.isfinite(p_high) and 0 <= p_low < p_high):
        raise InputError(f"sweep range: p_low={p_low!r} Pa, p_high={p_high!r} Pa must satisfy 0 <= p_low < p_high")
    cycles = int(cycles)
    params = smc_core_params(model, beta)
    n_hold = int(round(HOLD_S / ts))
    n_per = int(round(period / ts))
    n_sw = int(round(sweep_period / ts))

    # (a) identification sweep: hold, one conditioning triangle, one recorded triangle
    tri = _triangle(n_sw, p_low, p_high)
    ref = np.r_[np.full(n_hold, p_low), tri, tri]
    rec = run_closed_loop(core_spec(params), ref, ref.size * ts, plant, ts)
    sl = slice(n_hold + n_sw, None)
    p_sw, l_sw = rec.pressure[0, sl], rec.length[0, sl]
    up_sw = np.arange(n_sw) < n_sw // 2
    if not (np.all(np.isfinite(p_sw)) and np.all(np.isfinite(l_sw))):
        raise InputError("identification sweep diverged on this plant")
    lo, hi = float(l_sw.min()), float(l_sw.max())
    span = hi - lo
    mask = (l_sw >= lo + FIT_MARGIN * span) & (l_sw <= hi - FIT_MARGIN * span)
    branches = fit_hysteresis_branches(p_sw[mask], l_sw[mask], up_sw[mask])
    single = Polynomial.fit(l_sw[mask], p_sw[mask], 3)
    rmse_single = float(np.sqrt(np.mean((single(l_sw[mask]) - p_sw[mask]) ** 2)))

    # (b) tracking a length sinusoid, starting at its longest (lowest pressure), falling first
    f_lo, f_hi = branches.length_range
    mean = 0.5 * (f_lo + f_hi) if mean is None else float(mean)
    amplitude = AMPLITUDE_FRACTION * (f_hi - f_lo) if amplitude is None else float(amplitude)
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise InputError(f"amplitude: {amplitude!r} m must be > 0")
    if not (math.isfinite(mean) and f_lo <= mean - amplitude and mean + amplitude <= f_hi):
        raise InputError(f"length target {mean * 1e3:g} ± {amplitude * 1e3:g} mm leaves the fitted range "
                         f"{f_lo * 1e3:.2f}–{f_hi * 1e3:.2f} mm")
    n = cycles * n_per
    t = np.arange(n) * ts
    l_ref = mean + amplitude * np.cos(2 * np.pi * t / period)
    l_full = np.r_[np.full(n_hold, l_ref[0]), l_ref]
    p_single = np.clip(single(l_full), 0.0, None)
    p_branch = np.clip(branches.pressure(l_full, inflating_direction(l_full)), 0.0, None)
    refs = np.vstack([p_single, p_branch])
    trk = run_closed_loop(core_spec([params, params]), refs, l_full.size * ts, plant, ts)
    length = trk.length[:, n_hold:]

    # (c) errors after the first cycle
    err = length[:, n_per:] - l_ref[n_per:]
    rms = np.sqrt(np.mean(err ** 2, axis=1))
    mx = np.max(np.abs(err), axis=1)
    def _benefit(**more) -> HysteresisBenefit:
        return HysteresisBenefit(**more, period=float(period), sweep_period=sweep_period, cycles=cycles, mean=mean,
                                 amplitude=amplitude, sweep_pressure=p_sw, sweep_length=l_sw,
                                 sweep_inflating=up_sw, fit_mask=mask, branches=branches, single=single,
                                 rmse_single=rmse_single, t=t, length_ref=l_ref, length=length,
                                 pressure_ref=refs[:, n_hold:], rms_error=rms, max_error=mx)

    extra: dict = {}
    if pi:
        # (d) Prandtl–Ishlinskii: a sweep with minor loops at the main sweep's rate, fitted
        # from zero pressure (virgin plays), the first rise left out; then the same tracking
        ref_pi = np.r_[np.zeros(n_hold), _turns(PI_TURNS, n_sw // 2, p_low, p_high)]
        rec_pi = run_closed_loop(core_spec(params), ref_pi, ref_pi.size * ts, plant, ts)
        p_pi, l_pi = rec_pi.pressure[0], rec_pi.length[0]
        if not (np.all(np.isfinite(p_pi)) and np.all(np.isfinite(l_pi))):
            raise InputError("Prandtl–Ishlinskii sweep diverged on this plant")
        first_peak = int(np.argmax(ref_pi >= p_high))
        m_pi = (l_pi >= lo + FIT_MARGIN * span) & (l_pi <= hi - FIT_MARGIN * span) & (np.arange(p_pi.size) >= first_peak)
        try:
            op = fit_pi_hysteresis(p_pi, l_pi, mask=m_pi, reference_length=hi, n_plays=PI_PLAYS,
                                   output_knots=PI_OUTPUT_KNOTS)
        except InputError as exc:  # the PI variant is an addition: report why it is missing, keep the rest
            return _benefit(pi_error=str(exc), pi_sweep_pressure=p_pi, pi_sweep_length=l_pi, pi_fit_mask=m_pi)
        p_op = np.clip(op.pressure(l_full)[0], 0.0, None)
        trk_pi = run_closed_loop(core_spec(params), p_op, l_full.size * ts, plant, ts)
        err_pi = trk_pi.length[0, n_hold:][n_per:] - l_ref[n_per:]
        extra = {"pi": op, "pi_sweep_pressure": p_pi, "pi_sweep_length": l_pi, "pi_fit_mask": m_pi,
                 "pi_length": trk_pi.length[0, n_hold:], "pi_pressure_ref": p_op[n_hold:],
                 "pi_rms_error": float(np.sqrt(np.mean(err_pi ** 2))), "pi_max_error": float(np.max(np.abs(err_pi)))}
    return _benefit(**extra)
