"""Static muscle models: parameters as frozen dataclasses, evaluation as functions of arrays.

Modules: :mod:`~mckibben.models.kinematic` (eq. 1–2), :mod:`~mckibben.models.mpam` (braid-angle
cubics, length and its inverse), :mod:`~mckibben.models.spring` (F = K(P, Ls)·Ls),
:mod:`~mckibben.models.physical` (Chou–Hannaford, Tondu–Lopez, wall thickness).
"""
