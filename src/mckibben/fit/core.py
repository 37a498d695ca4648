"""Least squares with standard errors, 95 % intervals and the range a fit is valid on.

Two engines, one result type:

- :func:`linear_fit`: ordinary least squares on a design matrix (``numpy.linalg.lstsq`` on
  column-scaled columns; the condition number of the scaled matrix is checked);
- :func:`nonlinear_fit`: :func:`scipy.optimize.least_squares` on scaled parameters; the
  covariance is ``s²·(JᵀJ)⁻¹`` from the Jacobian at the solution, ``s² = SSR/(n − p)``.

Intervals use Student's t with ``n − p`` degrees of freedom (``scipy.stats.t``). Both refuse
fits with too few points and fits whose (scaled) design is ill-conditioned, with one line that
names the fit. A :class:`FitResult` keeps the model function, so it predicts with flags outside
its data range (:mod:`mckibben.models.flags`) and gives confidence bands by the delta method.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mckibben.errors import InputError
from mckibben.models.flags import Flag, outside, split_fit_flags

#: Largest condition number of the column-scaled design (or Jacobian) we accept. Beyond it the
#: data cannot tell the parameters apart: doubles keep ~16 digits, and 1e10 leaves ~6 for the fit.
COND_MAX = 1e10

#: Condition number of the column-scaled Jacobian above which a fit carries the note
#: ``correlated_parameters``: beyond it parameters trade off, so their separate intervals are wide.
#: A note, not a flag: the fit's predictions can still be the best held out (correlation is no doubt
#: about predictions by itself; :data:`UNCONSTRAINED_REL` catches a parameter the data do not see).
COND_FLAG = 1e6

#: A parameter is flagged ``<name>_unconstrained`` when its 95 % interval *with every other parameter
#: held at its fitted value* (half-width t·σ/‖J_k‖, the unscaled sensitivity: the change that raises the
#: sum of squares by t²σ²) is wider than this multiple of its reference magnitude (the bound span when
#: both bounds are finite, else the larger of its value and its starting values). Conditional, so two
#: parameters that only trade off are not flagged; wider than its whole plausible range, so the data
#: cannot tell the parameter's value at all. [-]
UNCONSTRAINED_REL = 1.0

#: A fit is within a bound (``<name>_at_lower_bound``/``_upper_bound``) when its distance to it is at
#: most this fraction of the parameter's reference magnitude (as for :data:`UNCONSTRAINED_REL`), or the
#: optimizer holds it there (its active set). One-sided bounds use the magnitude, not the value: a
#: parameter fitted to 1e-11 above a bound of 0 is at the bound. [-]
AT_BOUND_REL = 1e-3

#: Held-out RMSE above this multiple of the in-sample RMSE flags a compared fit
#: ``heldout_far_above_insample``: it describes the data it saw much better than data it did not.
#: Both are taken on the points of the folds that interpolate (:func:`interpolated_rms`): leaving
#: the extreme held length out is an extrapolation that costs every law, counted apart
#: (``extrapolated_folds``). A law that generalizes loses ~1.5–2× (the real Festo campaigns,
#: benchmarks/RESULTS.md); 3× is beyond that. [-]
HELDOUT_RATIO = 3.0

#: Fewest trials (clusters) for a cluster-robust covariance. With fewer, its variance estimate has
#: too few degrees of freedom to be trusted draw by draw (Cameron & Miller 2015, §VI), and the
#: ordinary covariance is used; the JSON's ``covariance`` says which. [-]
MIN_CLUSTERS = 5


def use_clusters(clusters) -> bool:
    """Whether a fit with these trial labels gets the cluster-robust covariance (≥ :data:`MIN_CLUSTERS`).

    Parameters
    ----------
    clusters : array_like or None
        Trial label per point. [-]
    """
    return clusters is not None and np.unique(clusters).size >= MIN_CLUSTERS


#: R² below which a fit is flagged ``r2_below_0.5``: the model explains less than half the variance.
R2_FLAG = 0.5

#: Which flag marks an input outside the fitted range.
RANGE_FLAGS = {
    "pressure": Flag.PRESSURE_OUT_OF_RANGE,
    "load": Flag.LOAD_OUT_OF_RANGE,
    "length": Flag.LENGTH_OUT_OF_RANGE,
    "contraction": Flag.LENGTH_OUT_OF_RANGE,
    "cos_theta": Flag.LENGTH_OUT_OF_RANGE,
    "force": Flag.FORCE_OUT_OF_RANGE,
    "rest_length": Flag.REST_LENGTH_OUT_OF_RANGE,
}

#: SI unit of each input quantity, for JSON keys of the valid range.
INPUT_UNITS = {"pressure": "Pa", "load": "N", "length": "m", "force": "N", "cos_theta": "", "contraction": "",
               "time": "s", "braid_angle": "rad"}


@dataclass(frozen=True)
class FitResult:
    """A fitted model: parameters, their uncertainty, fit statistics and validity range.

    Attributes
    ----------
    model : str
        The model's name (``"kinematic"``, ``"cubic"``, ...).
    names : tuple of str
        Parameter names, each with its unit suffix (``"k2_m"``, ``"c3_per_MPa3"``).
    values : numpy.ndarray
        Parameter values, in the units the names say. [mixed]
    covariance : numpy.ndarray
        Parameter covariance. [mixed]
    dof : int
        Degrees of freedom n − p. [-]
    n_points : int
        Number of data points used. [-]
    residuals : numpy.ndarray
        Measured − fitted response per point. [response unit]
    response : str
        The fitted quantity with its SI unit, e.g. ``"length_m"``.
    r2 : float
        Coefficient of determination. [-]
    valid_range : dict
        Input quantity -> (min, max) of the data, SI (``{"pressure": (0, 8e5)}``).
    condition_number : float
        Of the column-scaled design or Jacobian. [-]
    condition : dict
        What the data were restricted to, e.g. ``{"load_N": 0.6}``.
    func : callable
        ``func(values, **inputs) -> response`` (SI inputs), used by :meth:`predict`.
    source : str
        The file the data came from.
    flags : tuple of str
        Why the fit's predictions deserve doubt (empty when nothing was found): a bound that
        binds, a parameter the data do not constrain, R² < 0.5, a non-physical value (see
        :func:`fit_flags`). The CLI prints them on stderr and in the JSON.
    notes : tuple of str
        What is worth reporting but casts no doubt on the predictions by itself
        (:data:`mckibben.models.flags.FIT_NOTES`: ``correlated_parameters``, ...).
    t_dof : int, optional
        Degrees of freedom of the intervals' t quantile when they differ from :attr:`dof`
        (cluster-robust covariance: number of clusters − 1). [-]
    covariance_method : str
        ``"ols"`` (s²·(JᵀJ)⁻¹) or ``"cluster-robust (N trials)"``.
    priors : dict
        ``{name: (median, factor)}``: the log-normal priors the fit added to the data
        (:func:`bounded_fit`); empty when the data alone were fitted. [parameter unit, -]
    """

    model: str
    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    dof: int
    n_points: int
    residuals: np.ndarray
    response: str
    r2: float
    valid_range: dict
    condition_number: float
    condition: dict = field(default_factory=dict)
    func: Callable | None = None
    source: str = ""
    flags: tuple = ()
    t_dof: int | None = None
    covariance_method: str = "ols"
    notes: tuple = ()
    priors: dict = field(default_factory=dict)

    @property
    def stderr(self) -> np.ndarray:
        """Standard errors of the parameters. [parameter units]"""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def t_quantile(self) -> float:
        """Student's t quantile for a two-sided 95 % interval with :attr:`dof` degrees of freedom. [-]"""
        from scipy import special  # deferred on purpose: SciPy
        return float(special.stdtrit(self.t_dof if self.t_dof is not None else self.dof, 0.975))  # t quantile, as stats.t.ppf

    @property
    def ci95(self) -> np.ndarray:
        """95 % confidence intervals, shape (p, 2). [parameter units]"""
        half = self.t_quantile * self.stderr
        return np.column_stack([self.values - half, self.values + half])

    @property
    def residual_rms(self) -> float:
        """Root mean square of the residuals. [response unit]"""
        return float(np.sqrt(np.mean(self.residuals**2)))

    @property
    def sigma(self) -> float:
        """Residual standard error sqrt(SSR/dof). [response unit]"""
        return float(np.sqrt(np.sum(self.residuals**2) / max(self.dof, 1)))

    def __getitem__(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    def se(self, name: str) -> float:
        """Standard error of one parameter.

        Parameters
        ----------
        name : str
            Parameter name. [-]
        """
        return float(self.stderr[self.names.index(name)])

    def predict(self, **inputs):
        """Evaluate the fitted model and flag inputs outside the fitted range.

        Parameters
        ----------
        **inputs : array_like
            The model's inputs in SI (e.g. ``pressure=``, ``load=``). [SI]

        Returns
        -------
        value : numpy.ndarray
            The response. [response unit]
        flags : numpy.ndarray
            :class:`~mckibben.models.flags.Flag` mask per element (out of the fitted range).
        """
        value = np.asarray(self.func(self.values, **inputs), dtype=float)
        flags = np.zeros(value.shape, dtype=np.uint16)
        for q, (lo, hi) in self.valid_range.items():
            if q in inputs and q in RANGE_FLAGS:
                flags = flags | np.broadcast_to(outside(np.asarray(inputs[q], dtype=float), lo, hi, RANGE_FLAGS[q]), value.shape)
        return value, flags

    def band(self, **inputs) -> np.ndarray:
        """Half-width of the 95 % confidence band of the fitted curve (delta method).

        Parameters
        ----------
        **inputs : array_like
            The model's inputs in SI. [SI]

        Returns
        -------
        numpy.ndarray
            t·sqrt(gᵀ·C·g), g the gradient of the response in the parameters. [response unit]
        """
        base = np.asarray(self.func(self.values, **inputs), dtype=float)
        grads = []
        for k, v in enumerate(self.values):
            step = 1e-6 * max(abs(v), self.stderr[k], 1e-300)
            up = self.values.copy()
            dn = self.values.copy()
            up[k] += step
            dn[k] -= step
            grads.append((np.asarray(self.func(up, **inputs)) - np.asarray(self.func(dn, **inputs))) / (2 * step))
        g = np.stack([np.broadcast_to(x, base.shape) for x in grads], axis=-1)
        var = np.einsum("...i,ij,...j->...", g, self.covariance, g)
        return self.t_quantile * np.sqrt(np.clip(var, 0.0, None))

    def to_dict(self) -> dict:
        """JSON-ready summary: parameters, standard errors, 95 % intervals, statistics, range."""
        ci = self.ci95
        unit = self.response.split("_", 1)[1] if "_" in self.response else ""
        return {
            "model": self.model,
            "condition": self.condition,
            "response": self.response,
            "parameters": {n: float(v) for n, v in zip(self.names, self.values)},
            "stderr": {n: float(s) for n, s in zip(self.names, self.stderr)},
            "ci95": {n: [float(a), float(b)] for n, (a, b) in zip(self.names, ci)},
            f"residual_rms_{unit}" if unit else "residual_rms": self.residual_rms,
            f"rmse_{unit}" if unit else "rmse": self.residual_rms,
            "r2": self.r2,
            "flags": list(self.flags),
            "notes": list(self.notes),
            "covariance": self.covariance_method,
            "priors": {n: {"median": float(m), "factor": float(fa)} for n, (m, fa) in self.priors.items()},
            "n_points": self.n_points,
            "dof": self.dof,
            "condition_number": self.condition_number,
            "valid_range": {f"{q}_{INPUT_UNITS.get(q, '')}".rstrip("_"): [float(lo), float(hi)]
                            for q, (lo, hi) in self.valid_range.items()},
        }


def _r2(y, resid) -> float:
    ss_tot = float(np.sum((y - np.mean(y)) ** 2))
    return 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else float("nan")


def require_points(n: int, p: int, what: str) -> None:
    """Refuse a fit with fewer than p + 1 points (no residual degree of freedom).

    Parameters
    ----------
    n : int
        Number of points. [-]
    p : int
        Number of parameters. [-]
    what : str
        The fit's name for the message, e.g. ``"fit cubic on a.csv (load 0.6 N)"``.
    """
    if n < p + 1:
        raise InputError(f"{what}: {n} points for {p} parameters; needs at least {p + 1}")


def require_distinct(values, needed: int, quantity: str, what: str, reason: str) -> None:
    """Refuse a fit whose data have too few distinct values of an input.

    Parameters
    ----------
    values : array_like
        The input's values. [SI]
    needed : int
        Distinct values needed. [-]
    quantity : str
        Its name for the message, e.g. ``"pressures"``. [-]
    what : str
        The fit's name for the message.
    reason : str
        Why, e.g. ``"a cubic in pressure"``.
    """
    distinct = np.unique(np.round(np.asarray(values, dtype=float), 12)).size
    if distinct < needed:
        raise InputError(f"{what}: {distinct} distinct {quantity}; {reason} needs at least {needed}")


def _check_condition(matrix: np.ndarray, what: str) -> float:
    norms = np.linalg.norm(matrix, axis=0)
    if np.any(norms == 0):
        raise InputError(f"{what}: ill-conditioned: parameter {int(np.flatnonzero(norms == 0)[0]) + 1} has no effect on the data")
    cond = float(np.linalg.cond(matrix / norms))
    if not np.isfinite(cond) or cond > COND_MAX:
        raise InputError(
            f"{what}: ill-conditioned (condition number {cond:.3g} > {COND_MAX:.0e}): the data do not"
            " determine the parameters; add points that vary the inputs more"
        )
    return cond


def linear_fit(design, y, names, *, model: str, response: str, what: str, valid_range: dict,
               func: Callable | None = None, condition: dict | None = None, source: str = "",
               scale=None, clusters=None, nonnegative=None, cluster_unit: str = "trials") -> FitResult:
    """Ordinary least squares y ≈ X·β with standard errors (optionally some β ≥ 0).

    Parameters
    ----------
    design : array_like
        Design matrix X, shape (n, p), in scaled units (e.g. pressure in MPa). [mixed]
    y : array_like
        Response, shape (n,). [response unit]
    names : sequence of str
        Parameter names with unit suffixes. [-]
    model : str
        Model name. [-]
    response : str
        Response name with SI unit, e.g. ``"length_m"``. [-]
    what : str
        The fit's name for error messages. [-]
    valid_range : dict
        Input -> (min, max), SI. [SI]
    func : callable, optional
        ``func(values, **inputs)``, for :meth:`FitResult.predict`.
    condition : dict, optional
        The condition the data were restricted to.
    source : str
        Data file.
    scale : array_like, optional
        Multiply the fitted β (and its covariance) by this to get the reported values. [-]
    clusters : array_like, optional
        Trial label per row: with five or more trials (:data:`MIN_CLUSTERS`) the covariance is cluster-robust
        (:func:`cluster_covariance`) and the intervals use t with (trials − 1) degrees of freedom.
        [-]
    cluster_unit : str, default "trials"
        What a cluster is, in the covariance's name (``"runs"``: a held length's run of one trial). [-]
    nonnegative : array_like of bool, optional
        Which coefficients are held ≥ 0 (bounded least squares, :func:`scipy.optimize.lsq_linear`
        on the column-scaled design). A coefficient that ends at 0 is held there for the
        covariance (its standard error is NaN) and flagged ``<name>_at_lower_bound``; the others'
        covariance is s²·(X_fᵀX_f)⁻¹ over the free columns, s² = SSR/(n − p). [-]

    Returns
    -------
    FitResult
    """
    x = np.asarray(design, dtype=float)
    y = np.asarray(y, dtype=float)
    n, p = x.shape
    require_points(n, p, what)
    cond = _check_condition(x, what)
    if nonnegative is not None:
        return _nonnegative_fit(x, y, names, np.asarray(nonnegative, dtype=bool), cond, model=model,
                                response=response, valid_range=valid_range, func=func, condition=condition,
                                source=source, scale=scale, clusters=clusters, cluster_unit=cluster_unit)
    norms = np.linalg.norm(x, axis=0)
    beta_s, *_ = np.linalg.lstsq(x / norms, y, rcond=None)
    beta = beta_s / norms
    resid = y - x @ beta
    dof = n - p
    s2 = float(resid @ resid) / dof
    xs = x / norms
    cov_s = s2 * np.linalg.inv(xs.T @ xs)
    cov = cov_s / np.outer(norms, norms)
    t_dof, method = None, "ols"
    if use_clusters(clusters):
        cov = cluster_covariance(x, resid, clusters)
        t_dof = int(np.unique(clusters).size - 1)
        method = f"cluster-robust ({t_dof + 1} {cluster_unit})"
    if scale is not None:
        sc = np.asarray(scale, dtype=float)
        beta = beta * sc
        cov = cov * np.outer(sc, sc)
    r2 = _r2(y, resid)
    flags = ("r2_below_0.5",) if not r2 >= R2_FLAG else ()
    return FitResult(model, tuple(names), beta, cov, dof, n, resid, response, r2, dict(valid_range),
                     cond, dict(condition or {}), func, source, flags, t_dof, method)


def _nonnegative_fit(x, y, names, nonneg, cond, *, model, response, valid_range, func, condition, source, scale,
                     clusters, cluster_unit: str = "trials") -> FitResult:
    """The bounded branch of :func:`linear_fit`: some coefficients ≥ 0, held at 0 for the covariance."""
    from scipy import optimize  # deferred on purpose: SciPy
    n, p = x.shape
    if nonneg.shape != (p,):
        raise InputError(f"nonnegative: {nonneg.size} flags for {p} coefficients")
    norms = np.linalg.norm(x, axis=0)
    xs = x / norms
    lo = np.where(nonneg, 0.0, -np.inf)
    res = optimize.lsq_linear(xs, y, bounds=(lo, np.full(p, np.inf)), method="bvls", tol=1e-14)
    beta = res.x / norms
    at = nonneg & (res.x <= 1e-12 * max(float(np.max(np.abs(res.x))), 1e-300))
    beta[at] = 0.0
    resid = y - x @ beta
    dof = n - p
    free = ~at
    cov = np.full((p, p), np.nan)
    t_dof, method = None, "ols"
    if free.any():
        if use_clusters(clusters):
            cf = cluster_covariance(x[:, free], resid, clusters)
            t_dof = int(np.unique(clusters).size - 1)
            method = f"cluster-robust ({t_dof + 1} {cluster_unit})"
        else:
            s2 = float(resid @ resid) / dof
            xf = xs[:, free]
            cf = s2 * np.linalg.inv(xf.T @ xf) / np.outer(norms[free], norms[free])
        cov[np.ix_(free, free)] = cf
    if scale is not None:
        sc = np.asarray(scale, dtype=float)
        beta = beta * sc
        cov = cov * np.outer(sc, sc)
    r2 = _r2(y, resid)
    flags = tuple(f"{nm}_at_lower_bound" for nm, a in zip(names, at) if a)
    flags += ("r2_below_0.5",) if not r2 >= R2_FLAG else ()
    return FitResult(model, tuple(names), beta, cov, dof, n, resid, response, r2, dict(valid_range),
                     cond, dict(condition or {}), func, source, flags, t_dof, method)


def nonlinear_fit(residual, x0, names, *, model: str, response: str, what: str, valid_range: dict,
                  scale, func: Callable | None = None, condition: dict | None = None, source: str = "",
                  bounds=(-np.inf, np.inf), y=None, n_points=None, clusters=None) -> FitResult:
    """Nonlinear least squares (:func:`scipy.optimize.least_squares`) with standard errors.

    Parameters
    ----------
    residual : callable
        ``residual(theta) -> r`` on scaled parameters θ (each of order 1), r = model − data in
        response units. [response unit]
    x0 : array_like
        Starting scaled parameters. [-]
    names : sequence of str
        Parameter names with unit suffixes. [-]
    model, response, what : str
        As in :func:`linear_fit`.
    valid_range : dict
        Input -> (min, max), SI. [SI]
    scale : array_like
        Physical value = θ·scale. [parameter units]
    func : callable, optional
        ``func(values, **inputs)`` on physical values.
    condition : dict, optional
        The condition the data were restricted to.
    source : str
        Data file.
    bounds : tuple
        Bounds on θ. [-]
    y : array_like, optional
        The measured response, for R². [response unit]
    n_points : int, optional
        Number of points (default: the number of residuals).
    clusters : array_like, optional
        Trial label per residual: with five or more trials (:data:`MIN_CLUSTERS`) the covariance is cluster-robust
        (:func:`cluster_covariance`) and the intervals use t with (trials − 1) degrees of freedom.
        [-]

    Returns
    -------
    FitResult
    """
    from scipy import optimize  # deferred on purpose: SciPy
    x0 = np.asarray(x0, dtype=float)
    r0 = np.asarray(residual(x0))
    n = int(n_points if n_points is not None else r0.size)
    p = x0.size
    require_points(n, p, what)
    if not np.all(np.isfinite(r0)):
        raise InputError(f"{what}: the model cannot be evaluated at the starting point (check the data)")
    res = optimize.least_squares(residual, x0, bounds=bounds, method="trf", x_scale="jac", max_nfev=200 * (p + 1))
    if not res.success or not np.all(np.isfinite(res.fun)):
        raise InputError(f"{what}: the fit did not converge ({res.message})")
    jac = res.jac
    cond = _check_condition(jac, what)
    dof = n - p
    resid = -res.fun  # data − model
    s2 = float(resid @ resid) / dof
    norms = np.linalg.norm(jac, axis=0)
    js = jac / norms
    cov_t = s2 * np.linalg.inv(js.T @ js) / np.outer(norms, norms)
    t_dof, method = None, "ols"
    if use_clusters(clusters):
        cov_t = cluster_covariance(jac, resid, clusters)
        t_dof = int(np.unique(clusters).size - 1)
        method = f"cluster-robust ({t_dof + 1} trials)"
    sc = np.asarray(scale, dtype=float)
    values = res.x * sc
    cov = cov_t * np.outer(sc, sc)
    r2 = _r2(np.asarray(y, dtype=float), resid) if y is not None else float("nan")
    flags = ("r2_below_0.5",) if y is not None and not r2 >= R2_FLAG else ()
    return FitResult(model, tuple(names), values, cov, dof, n, resid, response, r2, dict(valid_range), cond,
                     dict(condition or {}), func, source, flags, t_dof, method)


def data_range(**arrays) -> dict:
    """(min, max) of each named array: the range a fit is valid on.

    Parameters
    ----------
    **arrays : array_like
        Input quantities in SI. [SI]
    """
    return {k: (float(np.min(v)), float(np.max(v))) for k, v in arrays.items()}


#: Largest cluster (points) for the CR2 correction; beyond it CR1's scalar correction is used
#: (CR2 needs an eigendecomposition of an n_g × n_g matrix per cluster). [-]
CR2_MAX_CLUSTER = 600


def cluster_covariance(jac, resid, clusters, p_scale=None, prior_jac=None):
    """Cluster-robust (CR2) covariance of least-squares parameters.

    ``C = (JᵀJ)⁻¹·(Σ_g J_gᵀ·A_g·r_g·r_gᵀ·A_g·J_g)·(JᵀJ)⁻¹`` with A_g = (I − H_gg)^(-1/2), H_gg the
    cluster's block of the hat matrix, summing over the G clusters (trials). Residuals within a
    trial may be correlated in any way (a per-trial offset, a per-trial gain); trials are taken as
    independent. A_g corrects the downward bias of the plain (CR1) sandwich with few clusters;
    clusters larger than :data:`CR2_MAX_CLUSTER` points fall back to CR1,
    c = G/(G − 1)·(n − 1)/(n − p). Intervals then use Student's t with G − 1 degrees of freedom.

    Parameters
    ----------
    jac : array_like
        Jacobian of the model in the parameters, shape (n, p). [response/parameter]
    resid : array_like
        Residuals, shape (n,). [response unit]
    clusters : array_like
        Cluster label per point, shape (n,). [-]
    p_scale : array_like, optional
        Unused placeholder for symmetry with the OLS path. [-]
    prior_jac : array_like, optional
        Rows of priors added to the residuals (:func:`bounded_fit`), shape (m, p), weighted as
        data rows (one standard deviation of the prior = one of the residuals): their information
        enters the bread, JᵀJ + J_pᵀJ_p, and the meat as independent rows of the residuals'
        variance, s²·J_pᵀJ_p; so a direction only the prior sees keeps the prior's variance.
        [response/parameter]

    Returns
    -------
    numpy.ndarray
        Covariance, shape (p, p). [parameter units²]

    References
    ----------
    [cameron2015] Cameron, A. C., Miller, D. L. (2015), A practitioner's guide to cluster-robust inference,
    J. Human Resources 50(2), 317–372. doi:10.3368/jhr.50.2.317 (§VI: few clusters, CR2).
    Bell, R. M., McCaffrey, D. F. (2002), Bias reduction in standard errors for linear regression
    with multi-stage samples, Survey Methodology 28(2), 169–181.
    """
    jac = np.asarray(jac, dtype=float)
    resid = np.asarray(resid, dtype=float)
    n, p = jac.shape
    labels, idx = np.unique(np.asarray(clusters), return_inverse=True)
    g = labels.size
    jp = np.zeros((0, jac.shape[1])) if prior_jac is None else np.asarray(prior_jac, dtype=float)
    norms = np.linalg.norm(np.vstack([jac, jp]), axis=0)
    norms[norms == 0] = 1.0
    js = jac / norms  # column-scaled: parameters of wildly different units stay invertible
    bread = np.linalg.pinv(js.T @ js + (jp / norms).T @ (jp / norms))
    idx = idx.ravel()
    scores = np.zeros((g, p))
    if np.bincount(idx).max() <= CR2_MAX_CLUSTER:
        # CR2 (Bell & McCaffrey 2002): each cluster's residuals scaled by (I − H_gg)^(-1/2), which
        # undoes the shrinkage of residuals by the fit's own leverage; nearly unbiased with few clusters
        for k in range(g):
            sel = idx == k
            jg = js[sel]
            h = jg @ bread @ jg.T
            w, v = np.linalg.eigh(np.eye(h.shape[0]) - h)
            inv_sqrt = (v / np.sqrt(np.clip(w, 1e-12, None))) @ v.T
            scores[k] = jg.T @ (inv_sqrt @ resid[sel])
        c = 1.0
    else:  # very large clusters: CR1's scalar correction
        np.add.at(scores, idx, js * resid[:, None])
        c = g / max(g - 1, 1) * (n - 1) / max(n - p, 1)
    meat = scores.T @ scores
    jps = jp / norms
    meat_prior = (resid @ resid / max(n - p, 1)) * (jps.T @ jps)  # a prior row's residual has the data's variance
    return (bread @ (c * meat + meat_prior) @ bread) / np.outer(norms, norms)


def censor_hinge(r, cens):
    """Model − data with a censored point's consistent side zeroed: max(r, 0) at a floor, min(r, 0) at a ceiling.

    Parameters
    ----------
    r : numpy.ndarray
        Model − data per point. [response unit]
    cens : numpy.ndarray of int or None
        Per point: 0 a reading, −1 at a floor (the response is at most the reading), +1 at a
        ceiling (at least); None: every point a reading. [-]

    Returns
    -------
    numpy.ndarray
        The error a bound leaves: 0 where the model keeps to it. [response unit]
    """
    if cens is None:
        return r
    return np.where(cens < 0, np.maximum(r, 0.0), np.where(cens > 0, np.minimum(r, 0.0), r))


def _tobit(r, cens, s0):
    """The censored likelihood as residuals: ±s₀·√(−2 ln Φ(∓r/s₀)), r = model − bound (floor: −, ceiling: +)."""
    from scipy import special  # deferred on purpose: SciPy
    z = np.where(cens > 0, r, -r) / s0
    return np.where(cens > 0, -1.0, 1.0) * s0 * np.sqrt(np.maximum(-2.0 * special.log_ndtr(z), 0.0))


def _prior_dominates(jac, jac_prior, free, k, sigma, s0) -> bool:
    """Whether the data tell less about parameter k than its prior (profiled over the other free parameters).

    Parameters
    ----------
    jac, jac_prior : numpy.ndarray
        The data's and the priors' Jacobian rows in the physical parameters (the priors' weighted by s0). [-]
    free : numpy.ndarray
        Parameters not held at a bound. [-]
    k : int
        The parameter with a prior. [-]
    sigma, s0 : float
        The residual standard error, and the noise the priors' rows were weighted with. [response unit]
    """
    a, b = jac[:, free] / sigma, jac_prior[:, free] / s0
    norms = np.linalg.norm(np.vstack([a, b]), axis=0)
    norms[norms == 0] = 1.0
    a, b = a / norms, b / norms
    j = int(np.flatnonzero(free).tolist().index(k))
    posterior = float(np.linalg.pinv(a.T @ a + b.T @ b)[j, j])
    prior = 1.0 / max(float(b[:, j] @ b[:, j]), 1e-300)
    return posterior > 0.5 * prior  # the data's information, 1/posterior − 1/prior, below the prior's


def heldout_flags(cv_rmse: float, rmse: float) -> tuple:
    """``("heldout_far_above_insample",)`` when a held-out RMSE exceeds :data:`HELDOUT_RATIO` × the in-sample one.

    Parameters
    ----------
    cv_rmse : float
        Held-out (cross-validated) RMSE. [response unit]
    rmse : float
        In-sample RMSE of the fit on all the data. [response unit]

    Returns
    -------
    tuple of str
    """
    return ("heldout_far_above_insample",) if cv_rmse > HELDOUT_RATIO * rmse else ()


def interpolated_rms(heldout_error, residuals, inside) -> tuple[float, float]:
    """Held-out and in-sample RMS error on the same points: those of the folds that interpolate.

    What :func:`heldout_flags` compares. A fold whose held-out points lie outside the range the
    other folds were fitted on (the longest or shortest held length, a muscle beyond the family's
    rest lengths) measures extrapolation, which every law pays and a comparison reports apart; the
    ratio that says a fit describes the data it saw far better than data it did not is taken where
    it predicts within its range. With no such point (every fold extrapolates), all points.

    Parameters
    ----------
    heldout_error : array_like
        Per point, the held-out prediction minus the measurement (NaN: not predicted). [N]
    residuals : array_like
        Per point, the in-sample residual of the fit on all the data (same order). [N]
    inside : array_like of bool
        Per point, True when its fold predicted within the fitted range. [-]

    Returns
    -------
    (float, float)
        Held-out RMS and in-sample RMS over those points. [N]
    """
    e = np.asarray(heldout_error, dtype=float)
    r = np.asarray(residuals, dtype=float)
    ok = np.isfinite(e) & np.isfinite(r)
    pick = ok & np.asarray(inside, dtype=bool)
    pick = pick if pick.any() else ok
    if not pick.any():
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(e[pick] ** 2))), float(np.sqrt(np.mean(r[pick] ** 2)))


def reference_magnitude(values, lo, hi, starts=()) -> np.ndarray:
    """Each parameter's plausible magnitude: its bound span, else the larger of |value| and |starts|.

    Parameters
    ----------
    values, lo, hi : array_like
        Fitted values and their bounds (``-inf``/``inf`` for none). [parameter units]
    starts : sequence of array_like, optional
        The starting values tried. [parameter units]

    Returns
    -------
    numpy.ndarray
        One magnitude per parameter, > 0. [parameter units]
    """
    values, lo, hi = (np.asarray(x, dtype=float) for x in (values, lo, hi))
    mag = np.abs(values)
    for x0 in starts:
        mag = np.maximum(mag, np.abs(np.asarray(x0, dtype=float)))
    span = hi - lo
    return np.where(np.isfinite(span) & (span > 0), span, np.maximum(mag, 1e-300))


def at_bounds(values, lo, hi, ref, active=None) -> np.ndarray:
    """Which parameters a bound binds: within :data:`AT_BOUND_REL`·ref of it, or held by the optimizer.

    Parameters
    ----------
    values, lo, hi : array_like
        Fitted values and their bounds. [parameter units]
    ref : array_like
        Reference magnitudes (:func:`reference_magnitude`). [parameter units]
    active : array_like, optional
        The optimizer's active set (``scipy.optimize.least_squares``' ``active_mask``: −1 lower, 1 upper). [-]

    Returns
    -------
    numpy.ndarray
        −1 at the lower bound, 1 at the upper, 0 free, per parameter. [-]
    """
    values, lo, hi, ref = (np.asarray(x, dtype=float) for x in (values, lo, hi, ref))
    out = np.zeros(values.size, dtype=int)
    out[np.isfinite(hi) & (hi - values <= AT_BOUND_REL * ref)] = 1
    out[np.isfinite(lo) & (values - lo <= AT_BOUND_REL * ref)] = -1
    if active is not None:
        act = np.asarray(active, dtype=int)
        out = np.where(out == 0, act, out)
    return out


def fit_flags(names, values, lo, hi, r2, condition_number, extra=(), *, ref=None, at=None,
              conditional_halfwidth=None) -> tuple:
    """The doubt flags and notes of a bounded fit (see :attr:`FitResult.flags`, :attr:`FitResult.notes`).

    Parameters
    ----------
    names : sequence of str
        Parameter names. [-]
    values, lo, hi : array_like
        Fitted values and their bounds. [parameter units]
    r2 : float
        Coefficient of determination. [-]
    condition_number : float
        Of the column-scaled Jacobian of the free parameters. [-]
    extra : sequence of str
        Model-specific flags (non-physical values); the ones in
        :data:`mckibben.models.flags.FIT_NOTES` become notes. [-]
    ref : array_like, optional
        Reference magnitudes (default :func:`reference_magnitude` without starts). [parameter units]
    at : array_like, optional
        Bound side per parameter (default :func:`at_bounds`). [-]
    conditional_halfwidth : array_like, optional
        95 % half-width of each parameter with the others held (NaN for parameters at a bound). [parameter units]

    Returns
    -------
    flags, notes : tuple of str
        Flags: ``"<name>_at_lower_bound"``/``"<name>_at_upper_bound"``, ``"<name>_unconstrained"``
        (:data:`UNCONSTRAINED_REL`), ``"r2_below_0.5"`` and the extra flags that doubt predictions.
        Notes: ``"correlated_parameters"`` (:data:`COND_FLAG`) and the extra notes.
    """
    ref = reference_magnitude(values, lo, hi) if ref is None else np.asarray(ref, dtype=float)
    at = at_bounds(values, lo, hi, ref) if at is None else np.asarray(at)
    out = []
    for k, n_ in enumerate(names):
        if at[k] < 0:
            out.append(f"{n_}_at_lower_bound")
        elif at[k] > 0:
            out.append(f"{n_}_at_upper_bound")
        elif conditional_halfwidth is not None and not conditional_halfwidth[k] <= UNCONSTRAINED_REL * ref[k]:
            out.append(f"{n_}_unconstrained")
    if not np.isfinite(r2) or r2 < R2_FLAG:
        out.append("r2_below_0.5")
    flags, notes = split_fit_flags(tuple(out) + tuple(extra))
    if not np.isfinite(condition_number) or condition_number > COND_FLAG:
        notes = ("correlated_parameters",) + notes
    return flags, notes


def bounded_fit(model_fn, y, starts, names, lo, hi, *, model: str, response: str, what: str, valid_range: dict,
                func: Callable, clusters=None, condition: dict | None = None, source: str = "",
                physical_flags: Callable | None = None, cluster_unit: str = "trials",
                priors: dict | None = None, censored=None) -> FitResult:
    """Bounded nonlinear least squares from several starts, with flags and trial-aware intervals.

    Every start is run briefly (:func:`scipy.optimize.least_squares`, trust region reflective,
    each parameter scaled by its bound span or start value), the two lowest are run to
    convergence and the lowest cost wins: the physical models are non-convex (D0 trades against
    the braid angle), so one start is not enough. A
    fit never fails silently: a bound that binds, a parameter the data do not constrain, R² < 0.5
    and the model's own non-physical checks are listed in :attr:`FitResult.flags`; parameters that
    only trade off are a note (:attr:`FitResult.notes`), not a flag. Parameters at a
    bound are held there for the covariance (their standard error is NaN).

    Parameters
    ----------
    model_fn : callable
        ``model_fn(values) -> prediction`` at the data, physical parameter values. [response unit]
    y : array_like
        Measured response. [response unit]
    starts : sequence of array_like
        Starting parameter vectors (physical), each inside the bounds. [parameter units]
    names : sequence of str
        Parameter names with unit suffixes. [-]
    lo, hi : array_like
        Bounds (``-inf``/``inf`` for none). [parameter units]
    model, response, what : str
        As in :func:`linear_fit`.
    valid_range : dict
        Input -> (min, max), SI. [SI]
    func : callable
        ``func(values, **inputs)``, for :meth:`FitResult.predict`.
    clusters : array_like, optional
        Trial label per point: with five or more trials (:data:`MIN_CLUSTERS`) the covariance is cluster-robust
        (:func:`cluster_covariance`), else s²·(JᵀJ)⁻¹. [-]
    condition : dict, optional
        The condition the data were restricted to.
    source : str
        Data file.
    physical_flags : callable, optional
        ``physical_flags(values) -> list of str``: the model's own non-physical checks.
    cluster_unit : str, default "trials"
        What a cluster is, in the covariance's name (``"runs"``: a held length's run of one trial). [-]
    priors : dict, optional
        ``{name: (median, factor)}``: log-normal priors on positive parameters (median [parameter
        unit], one standard deviation a factor ``factor`` [-]). Each adds the row
        s₀·ln(value/median)/ln(factor) to the residuals of the runs to convergence, s₀ the residual
        standard error of the best short run (the data's noise, so the prior weighs as one
        standard deviation of it): the maximum a posteriori fit under Gaussian noise. Its
        information enters the covariance, the conditional intervals and the condition number
        (a parameter the prior holds is constrained), and a parameter about which the data tell
        less than the prior (its data sensitivity ‖J_k‖ below the prior's) carries the note
        ``<name>_from_prior``. ``None``: the data alone.
    censored : array_like of int, optional
        Per point: 0 a reading, −1 a reading at a sensor's floor (the response is at most ``y``),
        +1 at its ceiling (at least ``y``). A censored point's term is the censored (Tobit)
        likelihood, −ln Φ((y − f)/s₀) at the floor, written as the residual
        s₀·√(−2 ln Φ((y − f)/s₀)) (s₀ as for ``priors``; the short runs use its limit s₀ → 0, the
        hinge max(f − y, 0)): a model below the floor costs nothing, one above it what a reading
        would. The residuals reported are data − model with the same hinge (0 where the model
        keeps to the bound). ``None``: every point a reading.

    References
    ----------
    [tobin1958] Tobin, J. (1958), Estimation of relationships for limited dependent variables,
    Econometrica 26(1), 24–36 (the censored likelihood).

    Returns
    -------
    FitResult
    """
    from scipy import optimize  # deferred on purpose: SciPy
    y = np.asarray(y, dtype=float)
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    p = lo.size
    require_points(y.size, p, what)
    best, tried = None, []
    cens = None if censored is None else np.asarray(censored, dtype=int)
    if cens is not None and not cens.any():
        cens = None
    for x0 in starts:
        x0 = np.clip(np.asarray(x0, dtype=float), lo, hi)
        scale = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(x0), 1e-12))
        shift = np.where(np.isfinite(lo), lo, 0.0)

        def resid(th, shift=shift, scale=scale):
            return censor_hinge(np.asarray(model_fn(th * scale + shift), dtype=float) - y, cens)

        th0 = (x0 - shift) / scale
        tlo, thi = (lo - shift) / scale, (hi - shift) / scale
        th0 = np.clip(th0, tlo + 1e-9 * np.isfinite(tlo), thi - 1e-9 * np.isfinite(thi))
        r0 = resid(th0)
        if not np.all(np.isfinite(r0)):
            continue
        # stage 1: a short run from every start; stage 2 below runs the two best to convergence
        res = optimize.least_squares(resid, th0, bounds=(tlo, thi), method="trf", x_scale=1.0,
                                     max_nfev=5 * (p + 1) if len(starts) > 2 else 100 * (p + 1))
        if np.all(np.isfinite(res.fun)):
            tried.append((res.cost, res.x, resid, tlo, thi, shift, scale))
    if not tried:
        raise InputError(f"{what}: the model cannot be evaluated at any starting point (check the data)")
    tried.sort(key=lambda t: t[0])
    n = y.size
    priors = dict(priors or {})
    pk = np.array([names.index(nm) for nm in priors], dtype=int)
    median = np.array([float(priors[nm][0]) for nm in priors])
    width = np.log(np.array([float(priors[nm][1]) for nm in priors]))
    s0 = float(np.sqrt(2.0 * tried[0][0] / max(n - p, 1))) or 1.0  # the data's noise, from the best short run
    for cost, x, resid, tlo, thi, shift, scale in tried[:2]:
        if cens is not None:
            def resid(th, shift=shift, scale=scale):  # noqa: F811 - the censored likelihood's rows
                r = np.asarray(model_fn(th * scale + shift), dtype=float) - y
                return np.where(cens == 0, r, _tobit(r, cens, s0))
        if pk.size:
            def resid(th, data=resid, shift=shift, scale=scale):  # noqa: F811 - the data's rows, then the priors'
                v = th[pk] * scale[pk] + shift[pk]
                return np.concatenate([data(th), s0 * np.log(np.maximum(v, 1e-300) / median) / width])
        res = optimize.least_squares(resid, x, bounds=(tlo, thi), method="trf", x_scale=1.0, max_nfev=100 * (p + 1))
        if np.all(np.isfinite(res.fun)) and (best is None or res.cost < best[0].cost):
            best = (res, shift, scale)
    res, shift, scale = best
    values = res.x * scale + shift
    scores = -np.asarray(res.fun)[:n]  # data - model, as the fit weighed it (the censored likelihood's rows)
    resid = -censor_hinge(np.asarray(model_fn(values), dtype=float) - y, cens) if cens is not None else scores
    jac_prior = res.jac[n:] / scale  # the priors' rows (none without priors)
    ref = reference_magnitude(values, lo, hi, [np.clip(np.asarray(x0, dtype=float), lo, hi) for x0 in starts])
    side = at_bounds(values, lo, hi, ref, res.active_mask)
    at = side != 0
    free = ~at
    jac = res.jac[:n] / scale  # d prediction / d physical value
    cov = np.full((p, p), np.nan)
    cond = float("inf")
    t_dof = None
    method = "ols"
    sigma = float(np.sqrt(resid @ resid / max(n - p, 1)))
    # the fit's information: the data's and the priors' (their rows as data rows of the residuals' σ)
    jaug = np.vstack([jac, jac_prior * sigma / s0])
    if free.any():
        jf = jac[:, free]
        norms = np.linalg.norm(jaug[:, free], axis=0)
        if np.all(norms > 0):
            cond = float(np.linalg.cond(jaug[:, free] / norms))
            labels = np.unique(clusters) if clusters is not None else np.array([0])
            if use_clusters(clusters):
                cf = cluster_covariance(jf, scores, clusters, prior_jac=jaug[n:, free])
                t_dof = int(labels.size - 1)
                method = f"cluster-robust ({labels.size} {cluster_unit})"
            else:
                js = jaug[:, free] / norms
                cf = sigma**2 * np.linalg.pinv(js.T @ js) / np.outer(norms, norms)
            cov[np.ix_(free, free)] = cf
    from scipy import special  # deferred on purpose: SciPy
    tq = float(special.stdtrit(t_dof if t_dof is not None else max(n - p, 1), 0.975))
    with np.errstate(divide="ignore"):
        half = np.where(free, tq * sigma / np.linalg.norm(jaug, axis=0), np.nan)  # unscaled sensitivity
    r2 = _r2(y, resid)
    extra = list(physical_flags(values)) if physical_flags is not None else []
    flags, notes = fit_flags(names, values, lo, hi, r2, cond, extra, ref=ref, at=side, conditional_halfwidth=half)
    held = [f"{names[k]}_from_prior" for k in pk if free[k] and _prior_dominates(jac, jac_prior, free, k, sigma, s0)]
    return FitResult(model, tuple(names), values, cov, n - p, n, resid, response, r2, dict(valid_range), cond,
                     dict(condition or {}), func, source, flags, t_dof, method, notes + tuple(held), priors)
