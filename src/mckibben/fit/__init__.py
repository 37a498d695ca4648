"""Fitting: least squares with standard errors and 95 % intervals, trial statistics, comparison.

See :mod:`mckibben.fit.core` (engines, :class:`FitResult`, bounded multi-start fits with flags,
cluster-robust covariance), :mod:`mckibben.fit.static` (one fit per static model),
:mod:`mckibben.fit.isometric` (force models on isometric tests), :mod:`mckibben.fit.hysteresis`
(Prandtl–Ishlinskii operators on inflate/deflate data), :mod:`mckibben.fit.direction` (a law's
direction-aware form, hysteresis inside the force law, and the held-out up/down gap), :mod:`mckibben.fit.compare`
(every model on the same data), :mod:`mckibben.fit.nested` (compare's choice by nested
cross-validation), :mod:`mckibben.fit.registry` (``fit_table``/``compare_table``:
what ``mckibben fit``/``compare`` run) and :mod:`mckibben.fit.muscle_file` (fitted laws in
muscle files).
"""

import importlib
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules load on first use (PEP 562): importing
#: ``mckibben.fit.registry`` for its model names, as every ``mckibben`` command does at start-up,
#: must not pull in SciPy's optimizers and statistics.
_EXPORTS = {
    "COND_MAX": "core", "FitResult": "core", "bounded_fit": "core", "cluster_covariance": "core",
    "linear_fit": "core", "nonlinear_fit": "core",
    "compare_isometric": "isometric", "fit_isometric": "isometric",
    "PIFit": "hysteresis", "fit_prandtl_ishlinskii": "hysteresis",
    "fit_direction_aware": "direction", "heldout_gap": "direction",
    "compare_table": "registry", "fit_table": "registry",
    "NestedComparison": "nested", "compare_nested": "nested", "compare_nested_table": "nested",
    "NestedGapComparison": "nested", "compare_direction_aware_nested": "nested",
    "compare_direction_aware_nested_table": "nested",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.fit.core import COND_MAX as COND_MAX
    from mckibben.fit.core import FitResult as FitResult
    from mckibben.fit.core import bounded_fit as bounded_fit
    from mckibben.fit.core import cluster_covariance as cluster_covariance
    from mckibben.fit.core import linear_fit as linear_fit
    from mckibben.fit.core import nonlinear_fit as nonlinear_fit
    from mckibben.fit.direction import fit_direction_aware as fit_direction_aware
    from mckibben.fit.direction import heldout_gap as heldout_gap
    from mckibben.fit.hysteresis import PIFit as PIFit
    from mckibben.fit.hysteresis import fit_prandtl_ishlinskii as fit_prandtl_ishlinskii
    from mckibben.fit.isometric import compare_isometric as compare_isometric
    from mckibben.fit.isometric import fit_isometric as fit_isometric
    from mckibben.fit.registry import compare_table as compare_table
    from mckibben.fit.registry import fit_table as fit_table
    from mckibben.fit.nested import NestedComparison as NestedComparison
    from mckibben.fit.nested import compare_nested as compare_nested
    from mckibben.fit.nested import compare_nested_table as compare_nested_table
    from mckibben.fit.nested import NestedGapComparison as NestedGapComparison
    from mckibben.fit.nested import compare_direction_aware_nested as compare_direction_aware_nested
    from mckibben.fit.nested import compare_direction_aware_nested_table as compare_direction_aware_nested_table


def __getattr__(name: str):
    if name not in _EXPORTS:
        try:  # a submodule by attribute (``mckibben.fit.muscle_file``), as an eager package would have bound it
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
        raise AttributeError(f"module 'mckibben.fit' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"mckibben.fit.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
