"""Pressure control: the firmware's controller core (:mod:`mckibben.control.core`) and more."""
