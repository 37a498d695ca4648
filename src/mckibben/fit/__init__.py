"""Fitting: least squares with standard errors and 95 % intervals, trial statistics, comparison.

See :mod:`mckibben.fit.core` (engines, :class:`FitResult`, bounded multi-start fits with flags,
cluster-robust covariance), :mod:`mckibben.fit.static` (one fit per static model),
:mod:`mckibben.fit.isometric` (force models on isometric tests), :mod:`mckibben.fit.compare`
(every model on the same data), :mod:`mckibben.fit.registry` (``fit_table``/``compare_table``:
what ``mckibben fit``/``compare`` run) and :mod:`mckibben.fit.muscle_file` (fitted laws in
muscle files).
"""

from mckibben.fit.core import COND_MAX, FitResult, bounded_fit, cluster_covariance, linear_fit, nonlinear_fit
from mckibben.fit.isometric import compare_isometric, fit_isometric
from mckibben.fit.registry import compare_table, fit_table

__all__ = ["COND_MAX", "FitResult", "bounded_fit", "cluster_covariance", "compare_isometric", "compare_table",
           "fit_isometric", "fit_table", "linear_fit", "nonlinear_fit"]
