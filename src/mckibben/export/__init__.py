"""Bridges out of mckibben: the plant as an FMU (:func:`export_fmu`) for Simulink, Modelica, FMPy."""

from mckibben.export.fmu import export_fmu

__all__ = ["export_fmu"]
