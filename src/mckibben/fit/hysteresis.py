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
from dataclasses import dataclass

import numpy as np

from mckibben.errors import InputError
from mckibben.fit.core import FitResult, linear_fit
from mckibben.models.hysteresis import PrandtlIshlinskii, apply, descended_state, play_matrix

#: How the plays start at each run's first sample.
STARTS = ("virgin", "descended")


@dataclass(frozen=True)
class PIFit:
    """A fitted Prandtl–Ishlinskii operator and its least-squares record.

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
                           output_degree: int = 1, clusters=None, source: str = "",
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
    output_degree : int, default 1
        1: the classical PI. d ≥ 2: a modified PI with the inverse output map
        S⁻¹(y) = y + Σ_{k=2..d} g_k·yᵏ, fitted with the weights by regressing y on
        [1, plays, −y², …, −y^d] (Kuhnen's identification of the modified PI, linear in all
        parameters; y on both sides, so low-noise outputs only). [-]
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
    x = np.asarray(u, dtype=float)
    yy = np.asarray(y, dtype=float)
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
    if int(output_degree) != output_degree or not 1 <= output_degree <= 5:
        raise InputError(f"output_degree: {output_degree!r} must be an integer from 1 to 5")
    deg = int(output_degree)
    moving = np.ptp(z[m], axis=0) > 0
    if not np.all(moving):
        i = int(np.flatnonzero(~moving)[0])
        raise InputError(f"{what}: the play of threshold {r[i]:.6g} {input_unit} never moves on the fitted samples "
                         f"(input span {np.ptp(x[m]):.6g} {input_unit}); use thresholds below half the span")
    ym = yy[m]
    design = np.column_stack([np.ones(int(m.sum())), z[m]] + [-(ym**k) for k in range(2, deg + 1)])
    unit_w = f"{output_unit}_per_{input_unit}"
    names = ([f"offset_{output_unit}"] + [f"w{i}_{unit_w}" for i in range(r.size)]
             + [f"g{k}_per_{output_unit}{k - 1}" for k in range(2, deg + 1)])
    nonneg = np.r_[False, np.ones(r.size, dtype=bool), np.zeros(deg - 1, dtype=bool)]
    cl = None if clusters is None else np.asarray(clusters)[m]
    n_w = r.size

    def func(values, **inputs):
        pi = PrandtlIshlinskii(r, values[1:1 + n_w], input_offset=input_offset, output_offset=float(values[0]),
                               output_poly=tuple(values[1 + n_w:]))
        return apply(pi, inputs["input"])[0]

    res = linear_fit(design, yy[m], names, model="prandtl-ishlinskii", response=f"output_{output_unit}", what=what,
                     valid_range={"input": (float(x[m].min()), float(x[m].max()))}, func=func, source=source,
                     clusters=cl, nonnegative=nonneg)
    w = res.values[1:1 + n_w]
    se = res.stderr[1:1 + n_w]
    model = PrandtlIshlinskii(r, w, input_offset=float(input_offset), output_offset=float(res.values[0]),
                              input_unit=input_unit, output_unit=output_unit,
                              output_poly=tuple(float(g) for g in res.values[1 + n_w:]), stderr=se,
                              valid_range=(float(x[m].min()), float(x[m].max())),
                              citation=f"classical PI fitted by bounded least squares{': ' + source if source else ''}")
    return PIFit(model, res, start)
