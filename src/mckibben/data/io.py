"""The old home of the table and muscle-file readers, kept so that ``mckibben.data.io`` imports still work.

The names are defined in the modules that hold them; import them from there (or from
:mod:`mckibben.data`):

- :mod:`mckibben.data.tables`: :class:`~mckibben.data.tables.Table`, :func:`~mckibben.data.tables.read_table`,
  :func:`~mckibben.data.tables.detect_kind` (reading a table, checking it against its schema, SI);
- :mod:`mckibben.data.setpoints`: :func:`~mckibben.data.setpoints.set_point_groups` (the set points
  behind measured loads and pressures);
- :mod:`mckibben.data.preprocessing`: :func:`~mckibben.data.preprocessing.apply_tare`,
  :func:`~mckibben.data.preprocessing.apply_pressure_zero`, :func:`~mckibben.data.preprocessing.find_rails`;
- :mod:`mckibben.data.muscle_file`: :class:`~mckibben.data.muscle_file.MuscleSpec`,
  :func:`~mckibben.data.muscle_file.read_muscle`, :func:`~mckibben.data.muscle_file.muscle_file_text_of`,
  :func:`~mckibben.data.muscle_file.check_muscle`, :func:`~mckibben.data.muscle_file.muscle_of_table`,
  :func:`~mckibben.data.muscle_file.find_muscle_file`.
"""

from __future__ import annotations

from mckibben.data.muscle_file import MUSCLE_KEYS, MUSCLE_MAX_SIZE, MuscleSpec, check_muscle, find_muscle_file
from mckibben.data.muscle_file import muscle_file_text_of, muscle_of_table, read_muscle
from mckibben.data.preprocessing import PRESSURE_ZEROS, RAIL_MIN_ROWS, RAIL_POLICIES, TARES
from mckibben.data.preprocessing import apply_pressure_zero, apply_tare, find_rails
from mckibben.data.setpoints import GROUP_GAP, set_point_groups
from mckibben.data.tables import NUMERIC_SUFFIXES, PRESSURE_ZERO_TOL, SUGGEST_CUTOFF, Table, detect_kind, read_table

__all__ = ["GROUP_GAP", "MUSCLE_KEYS", "MUSCLE_MAX_SIZE", "NUMERIC_SUFFIXES", "PRESSURE_ZEROS", "PRESSURE_ZERO_TOL",
           "RAIL_MIN_ROWS", "RAIL_POLICIES", "SUGGEST_CUTOFF", "TARES", "MuscleSpec", "Table", "apply_pressure_zero",
           "apply_tare", "check_muscle", "detect_kind", "find_muscle_file", "find_rails", "muscle_file_text_of",
           "muscle_of_table", "read_muscle", "read_table", "set_point_groups"]
