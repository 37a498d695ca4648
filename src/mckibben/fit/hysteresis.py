"""Fitting a Prandtl–Ishlinskii hysteresis operator to inflate/deflate data.

For fixed thresholds the PI operator is linear in its weights and output offset: the output is
``y = y_0 + Z·w`` with ``Z`` the plays' outputs over the input sequence
(:func:`mckibben.models.hysteresis.play_matrix`). The weights are found by linear least squares
with ``w ≥ 0`` (:func:`mckibben.fit.core.linear_fit` with ``nonnegative``: bounded least
squares, :func:`scipy.optimize.lsq_linear`), which keeps the operator monotone and invertible
when ``w_0 > 0``. Standard errors come from the residual variance and the design matrix,
s²·(ZᵀZ)⁻¹ over the weights not held at 0 (cluster-robust across trials with five or more), as
for every other linear fit of the project.

Several runs (trials, or one muscle's held lengths) are fitted together: the plays restart at
each run's first sample from the state the ``start`` argument says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mckibben.errors import InputError, check_array
from mckibben.fit.core import FitResult, linear_fit
from mckibben.models.hysteresis import PrandtlIshlinskii, descended_state, play_matrix
from mckibben.results import FitBase

#: How the plays start at each run's first sample.
STARTS = ("virgin", "descended")
#: Smallest weight of the identity play of a modified PI, before normalization (the inverse's
#: slope 1/w0 stays finite: the operator stays invertible). [-]
W0_FLOOR = 0.05


@dataclass(frozen=True, repr=False)
class PIFit(FitBase):
    """A fitted Prandtl–Ishlinskii operator and its least-squares record (whose words it speaks:
    :class:`~mckibben.results.FitBase`).

    Parameters
    ----------
    model : PrandtlIshlinskii
        The operator, weights with their standard errors. [-]
    fit : FitResult
        Parameters ``offset`` then ``w0 … w(n−1)``, standard errors, residuals, R². [-]
    start : str
        How the plays started at each run (``"virgin"`` or ``"descended"``). [-]
    """

    model: PrandtlIshlinskii
    fit: FitResult
    start: str

    RECORD = "fit"
    call = "mckibben.fit.hysteresis.fit_prandtl_ishlinskii"

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """What was fitted: the data file and how the plays started."""
        return {"source": self.source, "start": self.start}

    @property
    def metrics(self) -> dict:
        """The numbers (:meth:`to_dict`)."""
        return self.to_dict()

    def to_dict(self) -> dict:
        """JSON-ready: the operator's parameters and the fit's statistics."""
        return {"model": self.model.to_dict(), "fit": self.fit.to_dict(), "start": self.start}


def _runs(run, n: int) -> list[slice]:
    if run is None:
        return [slice(0, n)]
    lab = np.asarray(run)
    if lab.shape != (n,):
        raise InputError(f"run: {lab.size} labels for {n} samples")
    edges = np.flatnonzero(lab[1:] != lab[:-1]) + 1
    bounds = np.r_[0, edges, n]
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def pi_design(thresholds, u, *, run=None, start: str = "virgin", input_offset: float = 0.0) -> np.ndarray:
    """The plays' outputs over one or several runs: the weights' design matrix.

    Parameters
    ----------
    thresholds : array_like
        Play thresholds, shape (n,). [input unit]
    u : array_like
        Input samples, runs one after the other, shape (k,). [input unit]
    run : array_like, optional
        Run label per sample; the plays restart where the label changes. [-]
    start : {"virgin", "descended"}, default "virgin"
        Play state at each run's first sample: all zero, or as after a descent from far above
        (:func:`~mckibben.models.hysteresis.descended_state`). [-]
    input_offset : float, default 0.0
        The operator's input offset. [input unit]

    Returns
    -------
    numpy.ndarray
        Shape (k, n). [input unit]
    """
    if start not in STARTS:
        raise InputError(f"start: {start!r} must be one of {', '.join(STARTS)}")
    x = np.asarray(u, dtype=float)
    if x.ndim != 1 or x.size == 0 or not np.all(np.isfinite(x)):
        raise InputError("u: must be a finite, non-empty 1-D array")
    r = np.asarray(thresholds, dtype=float)
    out = np.empty((x.size, r.size))
    for sl in _runs(run, x.size):
        z0 = descended_state(r, float(x[sl][0]), input_offset) if start == "descended" else None
        out[sl], _ = play_matrix(r, x[sl], z0, input_offset)
    return out


def fit_prandtl_ishlinskii(u, y, thresholds, *, run=None, start: str = "virgin", mask=None,
                           input_offset: float = 0.0, input_unit: str = "Pa", output_unit: str = "m",
                           output_knots: int = 0, clusters=None, source: str = "",
                           what: str = "fit prandtl-ishlinskii") -> PIFit:
    """Fit the weights and output offset of a PI operator, thresholds fixed, weights ≥ 0.

    Parameters
    ----------
    u : array_like
        Input samples in time order, runs one after the other (pressure [Pa] or normalized [-]). [input unit]
    y : array_like
        Measured output per sample (contraction [m], force [N]). [output unit]
    thresholds : array_like
        Play thresholds, strictly increasing from 0 (e.g.
        :func:`~mckibben.models.hysteresis.thresholds_uniform`). [input unit]
    run : array_like, optional
        Run label per sample; the plays restart where it changes. [-]
    start : {"virgin", "descended"}, default "virgin"
        Play state at each run's first sample (see :func:`pi_design`). [-]
    mask : array_like of bool, optional
        Samples to fit (the others only drive the plays: a conditioning cycle, saturated ends). [-]
    input_offset : float, default 0.0
        The operator's input offset. [input unit]
    input_unit, output_unit : str
        Units of the input and output, for the result and the parameter names. [-]
    output_knots : int, default 0
        0: the classical PI, y = y_0 + Σ w_i·z_i, regressed on y with w ≥ 0. K ≥ 2: a modified
        PI (Kuhnen 2003) whose inverse output map S⁻¹ is piecewise linear through K knots evenly
        spaced over the fitted outputs (flat beyond them). The weights then sum to 1 (the plays'
        sum is in input units, of slope 1 far from a reversal) and the fit regresses the
        identity play, z_0 = a + Σ_k s_k·ramp_k(y) − Σ_{i≥1} w_i·(z_i − z_0), with slopes
        s_k ≥ 0 (S⁻¹ monotone) and w_i ≥ 0, w_0 = 1 − Σ_{i≥1} w_i: linear in every parameter,
        with bounds. Its residual is in input units. [-]
    clusters : array_like, optional
        Trial label per sample: with five or more trials the covariance is cluster-robust. [-]
    source : str
        Where the data came from, for the record. [-]
    what : str
        The fit's name in error messages. [-]

    Returns
    -------
    PIFit
        ``.model`` (:class:`~mckibben.models.hysteresis.PrandtlIshlinskii` with ``stderr``),
        ``.fit`` (:class:`~mckibben.fit.core.FitResult`).

    Raises
    ------
    InputError
        Mismatched or non-finite inputs, too few points, a design that cannot tell the plays
        apart (thresholds finer than the data), or a fit whose w_0 is 0 (not invertible: flagged).

    References
    ----------
    Kuhnen, K. (2003), European Journal of Control 9(4), 407–418 (identification of the PI
    weights by least squares for fixed thresholds).
    """
    x = check_array(u, "u", finite=False)
    yy = check_array(y, "y", finite=False)
    check_array(thresholds, "thresholds")
    if x.shape != yy.shape or x.ndim != 1:
        raise InputError(f"{what}: u and y must be 1-D of equal length ({x.shape} and {yy.shape})")
    if not np.all(np.isfinite(yy)):
        raise InputError(f"{what}: y contains NaN or infinite values")
    if not math.isfinite(input_offset):
        raise InputError(f"input_offset: {input_offset!r} must be finite")
    r = np.asarray(thresholds, dtype=float)
    if r.ndim != 1 or r.size == 0 or not np.all(np.isfinite(r)) or r[0] != 0 or np.any(np.diff(r) <= 0):
        raise InputError("thresholds: must be finite, start at 0 and increase strictly")
    z = pi_design(r, x, run=run, start=start, input_offset=input_offset)
    m = np.ones(x.size, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    if m.shape != x.shape:
        raise InputError(f"mask: {m.size} flags for {x.size} samples")
    if int(output_knots) != output_knots or output_knots == 1 or not 0 <= output_knots <= 50:
        raise InputError(f"output_knots: {output_knots!r} must be 0 (classical PI) or an integer from 2 to 50")
    n_k = int(output_knots)
    moving = np.ptp(z[m], axis=0) > 0
    if not np.all(moving):
        i = int(np.flatnonzero(~moving)[0])
        raise InputError(f"{what}: the play of threshold {r[i]:.6g} {input_unit} never moves on the fitted samples "
                         f"(input span {np.ptp(x[m]):.6g} {input_unit}); use thresholds below half the span")
    ym, zm = yy[m], z[m]
    n_w = r.size
    rng = (float(x[m].min()), float(x[m].max()))
    if n_k == 0:
        res = linear_fit(np.column_stack([np.ones(ym.size), zm]), ym,
                         [f"offset_{output_unit}"] + [f"w{i}_{output_unit}_per_{input_unit}" for i in range(n_w)],
                         model="prandtl-ishlinskii", response=f"output_{output_unit}", what=what,
                         valid_range={"input": rng}, source=source,
                         clusters=None if clusters is None else np.asarray(clusters)[m],
                         nonnegative=np.r_[False, np.ones(n_w, dtype=bool)])
        weights, se, offset, omap = res.values[1:], res.stderr[1:], float(res.values[0]), None
    else:
        yk = np.linspace(float(ym.min()), float(ym.max()), n_k)
        ramps = np.clip(ym[:, None] - yk[:-1], 0.0, np.diff(yk))
        # Σ w_i = 1 (the plays' sum has the input's unit and slope 1 far from reversals):
        # Σ w_i z_i = z_0 + Σ_{i≥1} w_i (z_i − z_0), so z_0 = a + S⁻¹-ramps − Σ_{i≥1} w_i (z_i − z_0)
        design = np.column_stack([np.ones(ym.size), ramps, -(zm[:, 1:] - zm[:, :1])])
        names = ([f"offset_{input_unit}"] + [f"s{k}_{input_unit}_per_{output_unit}" for k in range(n_k - 1)]
                 + [f"w{i}" for i in range(1, n_w)])
        res = linear_fit(design, zm[:, 0], names, model="modified-prandtl-ishlinskii", response=f"input_{input_unit}",
                         what=what, valid_range={"output": (float(ym.min()), float(ym.max()))}, source=source,
                         clusters=None if clusters is None else np.asarray(clusters)[m],
                         nonnegative=np.r_[False, np.ones(n_k - 1 + n_w - 1, dtype=bool)])
        w_rest = res.values[n_k:]
        weights = np.r_[1.0 - np.sum(w_rest), w_rest]
        cov_w = res.covariance[n_k:, n_k:]
        se = np.r_[np.sqrt(max(float(np.nansum(cov_w)), 0.0)), res.stderr[n_k:]]
        if not weights[0] >= W0_FLOOR:
            # the bound-only optimum breaks w0 ≥ floor (a muscle that sticks like a pure backlash):
            # the constrained optimum (a convex problem with one more linear constraint) has it
            # active, w0 = floor. Eliminate the largest other weight K by Σ w = 1:
            # Σ w_i z_i = f·z_0 + (1 − f)·z_K + Σ_{i≠0,K} w_i (z_i − z_K), bounds only again.
            k_piv = 1 + int(np.argmax(w_rest))
            others = [i for i in range(1, n_w) if i != k_piv]
            base = W0_FLOOR * zm[:, 0] + (1.0 - W0_FLOOR) * zm[:, k_piv]
            design = np.column_stack([np.ones(ym.size), ramps] + [-(zm[:, i] - zm[:, k_piv]) for i in others])
            names_c = names[:n_k] + [f"w{i}" for i in others]
            res = linear_fit(design, base, names_c, model="modified-prandtl-ishlinskii",
                             response=f"input_{input_unit}", what=what,
                             valid_range={"output": (float(ym.min()), float(ym.max()))}, source=source,
                             clusters=None if clusters is None else np.asarray(clusters)[m],
                             nonnegative=np.r_[False, np.ones(n_k - 1 + len(others), dtype=bool)])
            weights = np.zeros(n_w)
            se = np.zeros(n_w)
            weights[0] = W0_FLOOR
            weights[others] = res.values[n_k:]
            se[others] = res.stderr[n_k:]
            weights[k_piv] = 1.0 - W0_FLOOR - float(np.sum(res.values[n_k:]))
            se[k_piv] = np.sqrt(max(float(np.nansum(res.covariance[n_k:, n_k:])), 0.0))
            res = replace(res, flags=res.flags + ("w0_at_floor",))
            if weights[k_piv] < 0:
                raise InputError(f"{what}: no invertible operator with w0 >= {W0_FLOOR:g} fits these data "
                                 "(use fewer plays or smaller thresholds)")
        a, slopes = float(res.values[0]), res.values[1:n_k]
        offset = 0.0
        omap = (yk, a + np.r_[0.0, np.cumsum(slopes * np.diff(yk))])
    model = PrandtlIshlinskii(r, weights, input_offset=float(input_offset), output_offset=offset,
                              input_unit=input_unit, output_unit=output_unit, output_map=omap, stderr=se,
                              valid_range=rng,
                              citation=f"{'modified' if n_k else 'classical'} PI fitted by bounded least squares"
                                       f"{': ' + source if source else ''}")
    return PIFit(model, res, start)
