"""Experiment tables and muscle files: schemas, loaders and validation.

>>> from mckibben.data import SCHEMAS
>>> SCHEMAS["isotonic"].required
('pressure', 'load', 'length')
"""

from mckibben.data.io import (TARES, MuscleSpec, Table, apply_tare, check_muscle, detect_kind, find_muscle_file,
                              read_muscle, read_table)
from mckibben.data.schema import KINDS, QUANTITIES, SCHEMAS, Schema

__all__ = ["KINDS", "QUANTITIES", "SCHEMAS", "TARES", "MuscleSpec", "Schema", "Table", "apply_tare", "check_muscle", "detect_kind",
           "find_muscle_file", "read_muscle", "read_table"]
