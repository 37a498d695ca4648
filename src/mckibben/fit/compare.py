"""Model comparison on the same data: every applicable model predicts the same lengths.

What is compared
----------------
On an isotonic table (length under hanging loads vs pressure) every model predicts the **length
under load at a pressure**, l(P, F), at every row with P > 0 (the physical models have no
stiffness at zero pressure, so zero-pressure rows are left out for all models alike):

- ``paper (eq. 2+3)``: the paper's pipeline, k1, k2 (eq. 2) and one cos θ cubic per load (eq. 3)
  fitted on the braid-angle photographs beside the isotonic table, loads in between interpolated
  linearly (:mod:`mckibben.models.mpam`). Fitted on other data, so every isotonic point is held out
  and its cross-validated error is its plain error. Only when a ``braid_angle`` table with
  pressure and load is beside the data.
- ``cubic per load``: the paper's way on the lengths themselves, one cubic in P per load,
  linear in load between loads.
- ``surface``: one cubic-in-P, linear-in-load surface (:func:`~mckibben.fit.static.fit_surface`).
- every registered law with a fit spec (:func:`mckibben.models.laws.fit_laws`: the spring model of
  [wickramatunge2010], the physical laws, the family laws, any law added), fitted through its
  force, F(P, L) = load (:func:`~mckibben.fit.isometric.fit_isotonic_law`), and solved for the
  length (:func:`~mckibben.fit.isometric.law_length`).
- ``gaussian process``: a data-driven regressor (scikit-learn, RBF + white noise kernel on scaled
  inputs, fitted to the trial means), as [wickramatunge2010] suggests a universal approximator. Its kernel's
  hyperparameters (4 numbers) are optimized once on all the data and kept in the cross-validation
  folds (a refit per fold takes seconds and moves them little); the GP itself is refitted per fold.

Measures
--------
- ``rmse_m``: root mean square length error of the model fitted on all the data. [m]
- ``max_rel_error``: the largest relative error of the **contraction** ε = 1 − l/L0,
  |ε̂ − ε|/|ε|, over points with |ε| ≥ 0.02 (a relative error of a contraction near zero means
  nothing). The length's own relative error would hide everything: 1 mm is 1 % of 100 mm. [-]
- ``within_20pct``: share of those points whose contraction is predicted within 20 % of the
  measured value — the paper's accuracy claim for eq. 2+3 (abstract). [-]
- ``cv_rmse_m`` and ``cv_within_20pct``: the same, cross-validated: leave one load out when the
  data have three loads or more (a load never seen is predicted from the others), else 5-fold on
  shuffled rows (seed 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np

from mckibben.data.muscle_file import MuscleSpec
from mckibben.data.tables import Table
from mckibben.errors import InputError
from mckibben.fit.static import (
    fit_cubics,
    fit_kinematic,
    fit_surface,
    fitted_muscle,
)
from mckibben.fit.isometric import fit_isotonic_law, law_length
from mckibben.models import laws
from mckibben.models.mpam import BraidAngleMap, predict_length

#: Contractions smaller than this are left out of the relative measures. [-]
MIN_CONTRACTION = 0.02
#: The paper's accuracy claim: within 20 % of the measured value (abstract). [-]
PAPER_TOLERANCE = 0.20


def _subtable(table: Table, mask) -> Table:
    return Table(table.kind, table.path, table.data[np.asarray(mask)], table.columns)


def _cubic_per_load(train: Table):
    fits = fit_cubics(train)
    keys = sorted(k[0] for k in fits)
    if len(keys) < 2:
        raise InputError(f"compare on {train.path}: cubic per load needs two loads or more to predict between them")
    bmap = BraidAngleMap(tuple(float(k) for k in keys), tuple(tuple(fits[(k, None)].values) for k in keys))

    def predict(p, f):
        c = bmap.coefficients_at(f)
        x = np.asarray(p) / 1e6
        return ((c[..., 0] * x + c[..., 1]) * x + c[..., 2]) * x + c[..., 3]

    return predict, 4 * len(keys)


def _surface(train: Table):
    res = fit_surface(train)
    return (lambda p, f: res.predict(pressure=p, load=f)[0]), len(res.values)


def _by_force(name, muscle, lo, hi):
    # the bracket: a fifth of the measured range beyond each end (the law must cross the load there)
    pad = 0.2 * (hi - lo) + 1e-3 * hi

    def make(train: Table):
        res = fit_isotonic_law(train, muscle, name)
        return (lambda p, f: law_length(res, p, f, lo - pad, hi + pad)), len(res.values)

    return make


def _gaussian_process(train: Table, kernel=None, optimize=True):
    from sklearn.gaussian_process import GaussianProcessRegressor  # deferred on purpose: scikit-learn
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel  # deferred on purpose: scikit-learn

    # on the trial means per (pressure, load): the GP's cost grows as n³, and the means carry the
    # same information about the surface
    d = train.data.assign(pk=np.round(train.data["pressure"] / 1e3), fk=np.round(train.data["load"], 9))
    d = d.groupby(["pk", "fk"], sort=True).agg(pressure=("pressure", "mean"), load=("load", "mean"),
                                               length=("length", "mean")).reset_index()
    x = np.column_stack([d["pressure"] / 1e6, d["load"]])
    y = d["length"].to_numpy()
    mu, sd = float(np.mean(y)), float(np.std(y)) or 1.0
    if kernel is None:
        kernel = ConstantKernel(1.0, (1e-2, 1e2)) * RBF([0.5, 1.0], (1e-2, 1e2)) + WhiteKernel(1e-2, (1e-6, 1.0))
    gp = GaussianProcessRegressor(kernel, normalize_y=False, random_state=0, n_restarts_optimizer=0,
                                  optimizer="fmin_l_bfgs_b" if optimize else None)
    gp.fit(x, (y - mu) / sd)

    def predict(p, f):
        q = np.column_stack([np.ravel(p) / 1e6, np.broadcast_to(f, np.shape(p)).ravel()])
        return gp.predict(q) * sd + mu

    predict.kernel_ = gp.kernel_  # the cross-validation folds reuse these hyperparameters
    return predict, int(gp.kernel_.n_dims)


@dataclass
class ModelScore:
    """One model's scores on the comparison data (see the module notes for each measure)."""

    name: str
    n_parameters: int
    rmse_m: float
    max_rel_error: float
    within_20pct: float
    cv_rmse_m: float
    cv_within_20pct: float
    cv_method: str
    note: str = ""
    predictions: np.ndarray = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """JSON-ready dict (SI, unit-suffixed keys)."""
        return {"model": self.name, "n_parameters": self.n_parameters, "rmse_m": self.rmse_m,
                "max_rel_error": self.max_rel_error, "within_20pct": self.within_20pct,
                "cv_rmse_m": self.cv_rmse_m, "cv_within_20pct": self.cv_within_20pct,
                "cv_method": self.cv_method, "note": self.note}


def _scores(pred, meas, l0):
    ok = np.isfinite(pred)
    rmse = float(np.sqrt(np.mean((pred[ok] - meas[ok]) ** 2))) if ok.any() else float("nan")
    eps, eps_hat = 1 - meas / l0, 1 - pred / l0
    rel_sel = np.abs(eps) >= MIN_CONTRACTION
    rel = np.abs(eps_hat - eps)[rel_sel] / np.abs(eps)[rel_sel]
    rel = np.where(np.isfinite(rel), rel, np.inf)
    return rmse, (float(np.max(rel)) if rel.size else float("nan")), (float(np.mean(rel <= PAPER_TOLERANCE)) if rel.size else float("nan"))


def compare_models(table: Table, muscle: MuscleSpec, braid: Table | None = None) -> dict:
    """Fit every applicable model to an isotonic table and score their length predictions.

    Parameters
    ----------
    table : Table
        An ``isotonic`` table.
    muscle : MuscleSpec
        The muscle file (nominal length for the contraction; geometry for the physical models).
    braid : Table, optional
        A ``braid_angle`` table with pressure and load, for the paper's pipeline (eq. 2 + 3).

    Returns
    -------
    dict
        ``scores`` (list of :class:`ModelScore`), ``n_points``, ``cv_method``, ``pressure_Pa``,
        ``load_N``, ``length_m`` (the compared points).
    """
    if table.kind != "isotonic":
        raise InputError(f"compare: needs an isotonic table (length under loads vs pressure); {table.path} is a {table.kind} table")
    data = _subtable(table, table.data["pressure"].to_numpy() > 0)
    d = data.data
    p, f, ell = d["pressure"].to_numpy(), d["load"].to_numpy(), d["length"].to_numpy()
    loads = np.unique(np.round(f, 9))
    if len(loads) >= 3:
        cv_method = "leave one load out"
        folds = [np.isclose(f, load, rtol=0, atol=1e-9) for load in loads]
    else:
        cv_method = "5-fold"
        order = np.random.default_rng(0).permutation(len(d))
        folds = [np.isin(np.arange(len(d)), chunk) for chunk in np.array_split(order, 5)]

    makers = {
        "cubic per load": _cubic_per_load,
        "surface": _surface,
        # every registered law with a fit spec, fitted through its force (fit_isotonic_law)
        **{name: _by_force(name, muscle, float(np.min(ell)), float(np.max(ell))) for name in laws.fit_laws()},
        "gaussian process": _gaussian_process,
    }
    scores = []
    if braid is not None:
        kin = fit_kinematic(braid, muscle)
        m = fitted_muscle(muscle, kin, fit_cubics(braid))
        pred = predict_length(m, p, f).length
        rmse, mx, w20 = _scores(pred, ell, muscle.nominal_length)
        scores.append(ModelScore("paper (eq. 2+3)", 2 + 4 * len(m.braid_map.loads), rmse, mx, w20, rmse, w20,
                                 "fitted on the braid photographs", f"k1, k2 and cos θ cubics from {braid.path}", pred))
    for name, make in makers.items():
        try:
            predict, npar = make(data)
            if hasattr(predict, "kernel_"):
                make = partial(make, kernel=predict.kernel_, optimize=False)
            pred = np.asarray(predict(p, f), dtype=float)
            rmse, mx, w20 = _scores(pred, ell, muscle.nominal_length)
            cv_pred = np.full(len(d), np.nan)
            note = ""
            for test in folds:
                try:
                    fp, _ = make(_subtable(data, ~test))
                    cv_pred[test] = fp(p[test], f[test])
                except InputError as exc:
                    note = f"a fold could not be fitted: {exc}"
            cv_rmse, _, cv_w20 = _scores(cv_pred, ell, muscle.nominal_length)
            unpredicted = int(np.sum(~np.isfinite(pred)))
            if unpredicted:
                note = (note + "; " if note else "") + f"{unpredicted} points unreachable for the model"
            scores.append(ModelScore(name, npar, rmse, mx, w20, cv_rmse, cv_w20, cv_method, note, pred))
        except InputError as exc:
            scores.append(ModelScore(name, 0, np.nan, np.nan, np.nan, np.nan, np.nan, cv_method, f"not fitted: {exc}"))
    return {"scores": scores, "n_points": len(d), "cv_method": cv_method, "pressure_Pa": p, "load_N": f, "length_m": ell}
