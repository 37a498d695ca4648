"""Static muscle models: parameters as frozen dataclasses, evaluation as functions of arrays.

One calling convention for every family (:mod:`~mckibben.models.static`):
``length(pressure, load, muscle, model=...)``, ``pressure(length, load, muscle, model=...)`` and
``force(pressure, length, muscle, model=...)`` return a :class:`StaticResult` for any registered law
with a published parameter set (:func:`force_laws`), or a muscle file's law.

Modules: :mod:`~mckibben.models.kinematic` (eq. 1–2), :mod:`~mckibben.models.mpam` (braid-angle
cubics, length and its inverse), :mod:`~mckibben.models.spring` (F = K(P, Ls)·Ls),
:mod:`~mckibben.models.physical` (Chou–Hannaford, Tondu–Lopez, wall thickness),
:mod:`~mckibben.models.hysteresis` (the Prandtl–Ishlinskii operator and its exact inverse).
"""

from mckibben.models.flags import Flag, flag_names
from mckibben.models.kinematic import braid_from_length, length_from_braid
from mckibben.models.mpam import (
    BraidAngleMap,
    ForcePrediction,
    LengthPrediction,
    MiniatureGeometry,
    MiniatureMuscle,
    braid_cos_theta,
    force_from_length,
    predict_length,
    pressure_for_length,
)
from mckibben.models.physical import (
    BraidGeometry,
    chou_hannaford_force,
    length_under_load,
    miniature_geometry,
    tondu_lopez_contraction,
    tondu_lopez_force,
    wall_corrected_force,
)
from mckibben.models.spring import SpringModel, spring_force, spring_length, stiffness, unstretched_length
from mckibben.models.static import StaticResult, force, force_laws, length, pressure

__all__ = [
    "StaticResult", "force", "force_laws", "length", "pressure",
    "BraidAngleMap", "BraidGeometry", "Flag", "ForcePrediction", "LengthPrediction", "MiniatureGeometry",
    "MiniatureMuscle", "SpringModel", "braid_cos_theta", "braid_from_length", "chou_hannaford_force", "flag_names",
    "force_from_length", "length_from_braid", "length_under_load", "miniature_geometry", "predict_length",
    "pressure_for_length", "spring_force", "spring_length", "stiffness", "tondu_lopez_contraction",
    "tondu_lopez_force", "unstretched_length", "wall_corrected_force",
]
