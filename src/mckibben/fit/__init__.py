"""Fitting: least squares with standard errors and 95 % intervals, trial statistics, comparison.

See :mod:`mckibben.fit.core` (engines and :class:`FitResult`), :mod:`mckibben.fit.static` (one
fit per static model) and :mod:`mckibben.fit.compare` (every model on the same data).
"""

from mckibben.fit.core import COND_MAX, FitResult, linear_fit, nonlinear_fit

__all__ = ["COND_MAX", "FitResult", "linear_fit", "nonlinear_fit"]
