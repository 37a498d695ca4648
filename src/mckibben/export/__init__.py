"""Bridges out of mckibben: the plant as an FMU (:func:`export_fmu`) for Simulink, Modelica, FMPy, and
calibrated muscles on MuJoCo tendons (:mod:`mckibben.export.mujoco`, imported on its own: it loads Numba)."""

from mckibben.export.fmu import export_fmu

__all__ = ["export_fmu"]
