"""Experiment tables and muscle files: schemas, loaders and validation.

>>> from mckibben.data import SCHEMAS
>>> SCHEMAS["isotonic"].required
('pressure', 'load', 'length')
"""

from mckibben import _lazy
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "KINDS": "mckibben.data.schema",
    "MuscleSpec": "mckibben.data.muscle_file",
    "QUANTITIES": "mckibben.data.schema",
    "SCHEMAS": "mckibben.data.schema",
    "Schema": "mckibben.data.schema",
    "TARES": "mckibben.data.preprocessing",
    "Table": "mckibben.data.tables",
    "apply_tare": "mckibben.data.preprocessing",
    "check_muscle": "mckibben.data.muscle_file",
    "detect_kind": "mckibben.data.tables",
    "find_muscle_file": "mckibben.data.muscle_file",
    "known_columns": "mckibben.data.schema",
    "muscle_of_table": "mckibben.data.muscle_file",
    "read_muscle": "mckibben.data.muscle_file",
    "read_table": "mckibben.data.tables",
}

__all__ = ["KINDS", "QUANTITIES", "SCHEMAS", "TARES", "MuscleSpec", "Schema", "Table", "apply_tare", "check_muscle", "detect_kind",
           "find_muscle_file", "known_columns", "muscle_of_table", "read_muscle", "read_table"]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.data.schema import KINDS as KINDS
    from mckibben.data.muscle_file import MuscleSpec as MuscleSpec
    from mckibben.data.schema import QUANTITIES as QUANTITIES
    from mckibben.data.schema import SCHEMAS as SCHEMAS
    from mckibben.data.schema import Schema as Schema
    from mckibben.data.preprocessing import TARES as TARES
    from mckibben.data.tables import Table as Table
    from mckibben.data.preprocessing import apply_tare as apply_tare
    from mckibben.data.muscle_file import check_muscle as check_muscle
    from mckibben.data.tables import detect_kind as detect_kind
    from mckibben.data.muscle_file import find_muscle_file as find_muscle_file
    from mckibben.data.muscle_file import muscle_of_table as muscle_of_table
    from mckibben.data.schema import known_columns as known_columns
    from mckibben.data.muscle_file import read_muscle as read_muscle
    from mckibben.data.tables import read_table as read_table


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
