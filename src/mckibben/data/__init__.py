"""Experiment tables and muscle files: schemas, loaders and validation.

>>> from mckibben.data import SCHEMAS
>>> SCHEMAS["isotonic"].required
('pressure', 'load', 'length')
"""

from mckibben.data.io import MuscleSpec, Table, check_muscle, detect_kind, find_muscle_file, read_muscle, read_table
from mckibben.data.schema import KINDS, QUANTITIES, SCHEMAS, Schema

__all__ = ["KINDS", "QUANTITIES", "SCHEMAS", "MuscleSpec", "Schema", "Table", "check_muscle", "detect_kind",
           "find_muscle_file", "read_muscle", "read_table"]
