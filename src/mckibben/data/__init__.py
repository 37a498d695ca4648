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
    "MuscleSpec": "mckibben.data.io",
    "QUANTITIES": "mckibben.data.schema",
    "SCHEMAS": "mckibben.data.schema",
    "Schema": "mckibben.data.schema",
    "TARES": "mckibben.data.io",
    "Table": "mckibben.data.io",
    "apply_tare": "mckibben.data.io",
    "check_muscle": "mckibben.data.io",
    "detect_kind": "mckibben.data.io",
    "find_muscle_file": "mckibben.data.io",
    "known_columns": "mckibben.data.schema",
    "muscle_of_table": "mckibben.data.io",
    "read_muscle": "mckibben.data.io",
    "read_table": "mckibben.data.io",
}

__all__ = ["KINDS", "QUANTITIES", "SCHEMAS", "TARES", "MuscleSpec", "Schema", "Table", "apply_tare", "check_muscle", "detect_kind",
           "find_muscle_file", "known_columns", "muscle_of_table", "read_muscle", "read_table"]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.data.schema import KINDS as KINDS
    from mckibben.data.io import MuscleSpec as MuscleSpec
    from mckibben.data.schema import QUANTITIES as QUANTITIES
    from mckibben.data.schema import SCHEMAS as SCHEMAS
    from mckibben.data.schema import Schema as Schema
    from mckibben.data.io import TARES as TARES
    from mckibben.data.io import Table as Table
    from mckibben.data.io import apply_tare as apply_tare
    from mckibben.data.io import check_muscle as check_muscle
    from mckibben.data.io import detect_kind as detect_kind
    from mckibben.data.io import find_muscle_file as find_muscle_file
    from mckibben.data.io import muscle_of_table as muscle_of_table
    from mckibben.data.schema import known_columns as known_columns
    from mckibben.data.io import read_muscle as read_muscle
    from mckibben.data.io import read_table as read_table


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
