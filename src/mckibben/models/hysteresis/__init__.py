"""Hysteresis operator models and their exact inverses.

One file per model family: :mod:`~mckibben.models.hysteresis.prandtl_ishlinskii` (the classical
Prandtl–Ishlinskii operator of play operators, its closed-form inverse, the design matrix its fit
uses); :mod:`~mckibben.models.hysteresis.direction` (a force law's direction-aware form: the law fed
through a play on the pressure, or plus a friction term proportional to pressure). Fitting lives in :mod:`mckibben.fit.hysteresis`; compensation for length control in
:mod:`mckibben.control.length`. The other hysteresis models of the project stay where they act and
are documented alternatives (docs/hysteresis.md): the plant's Dahl friction (the simulated
muscle's loop), the spring law's two coefficient sets, and the per-branch cubics of
:func:`mckibben.control.length.fit_hysteresis_branches`.
"""

from mckibben.models.hysteresis.prandtl_ishlinskii import (
    PI_CITATION,
    PrandtlIshlinskii,
    apply,
    descended_state,
    forward_state,
    inverse,
    inverse_state,
    invert,
    loading_curve,
    output_map,
    output_map_inverse,
    play_matrix,
    thresholds_uniform,
)

__all__ = ["PI_CITATION", "PrandtlIshlinskii", "apply", "descended_state", "forward_state", "inverse", "inverse_state", "invert",
           "loading_curve", "output_map", "output_map_inverse", "play_matrix", "thresholds_uniform"]
