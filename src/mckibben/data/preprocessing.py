"""What is done to a validated table before a fit: the load cell's tare, the pressure transducer's
zero, and the rows at a sensor's rail.

Each function takes a :class:`~mckibben.data.tables.Table` and returns the corrected table with a
report (a dict the CLI prints); each is off by default.
"""

from __future__ import annotations

import numpy as np

from mckibben.data.setpoints import set_point_groups
from mckibben.data.tables import Table
from mckibben.errors import InputError, check_instance, unknown_name


#: Tare methods of :func:`apply_tare` (``"fitted"``: each run's zero is fitted with the force law,
#: :func:`mckibben.fit.isometric.fit_points`; the table is left as read).
TARES = ("none", "lowest", "column", "fitted")
#: Pressure-zero methods of :func:`apply_pressure_zero`.
PRESSURE_ZEROS = ("none", "lowest", "column")
#: What to do with rows at a sensor's rail (:func:`find_rails`): keep them as readings, exclude
#: them, or censor them (a reading at a floor says "force ≤ floor": :func:`mckibben.fit.core.bounded_fit`).
RAIL_POLICIES = ("keep", "exclude", "censor")
#: A column's extreme value repeated on at least this many rows is a rail (a load cell that cannot
#: read below a floor, a saturated transducer): a reading that many times exactly at the extreme is
#: the converter's limit, not the quantity. [-]
RAIL_MIN_ROWS = 5


def find_rails(table: Table, columns=("force", "pressure")) -> tuple[np.ndarray, dict]:
    """Rows stuck at a sensor's rail: a column's lowest or highest value, repeated exactly.

    A load cell that cannot read below a floor returns the same lowest count for every row where
    the muscle is slack (the real data's Festo rig reads −8.735 N on dozens of rows); a saturated
    transducer returns its top count. Such a reading says only "at most" (or "at least") that
    value. The rule: the column's minimum (maximum) found on :data:`RAIL_MIN_ROWS` rows or more
    (a gauge pressure of 0, a vented chamber, is not a rail).

    Parameters
    ----------
    table : Table
        A validated table. [-]
    columns : sequence of str
        Quantities to check (those the table has). [-]

    Returns
    -------
    at_rail : numpy.ndarray of bool
        Per row: at a rail of any checked column. [-]
    report : dict
        Per rail: ``column``, ``side`` (``low``/``high``), ``value`` (SI) and ``rows``. [-]
    """
    d = table.data
    mask = np.zeros(len(d), dtype=bool)
    rails = []
    for c in columns:
        if c not in d:
            continue
        v = d[c].to_numpy(dtype=float)
        for side, x in (("low", np.min(v)), ("high", np.max(v))):
            if c == "pressure" and side == "low" and x <= 0:
                continue  # gauge zero: a vented chamber, read as it is
            at = v == x
            if at.sum() >= RAIL_MIN_ROWS:
                mask |= at
                rails.append({"column": c, "side": side, "value": float(x), "rows": int(at.sum())})
    return mask, {"rails": rails, "rows_at_rail": int(mask.sum())}


def apply_pressure_zero(table: Table, method: str = "none") -> tuple[Table, dict]:
    """Subtract the pressure transducer's zero offset from the pressure column (off by default).

    A gauge transducer often reads a few kPa at atmosphere (``PROVENANCE.md`` of the real data).

    - ``"lowest"``: the offset is estimated as the table's lowest pressure reading, i.e. the rig's
      lowest step is taken to be atmosphere (true when each run starts vented; an upper bound of
      the offset otherwise — say so when reporting);
    - ``"column"``: the table's ``pressure_zero`` column (the transducer's reading at atmosphere,
      per row) is subtracted.

    Pressures below zero after the correction are set to zero.

    Parameters
    ----------
    table : Table
        A table with a pressure column. [-]
    method : {"none", "lowest", "column", "fitted"}, default "none"
        How to find the offset. [-]

    Returns
    -------
    table : Table
        The corrected table (the same table for ``"none"``).
    report : dict
        ``method`` and ``pressure_zero_Pa`` (the offset, or its range for a column). [-]
    """
    if method not in PRESSURE_ZEROS:
        raise unknown_name("pressure zero", method, PRESSURE_ZEROS)
    if method == "none":
        return table, {"method": "none"}
    d = table.data.copy()
    if method == "column":
        if "pressure_zero" not in d:
            raise InputError(f"{table.path}: pressure zero 'column' needs a pressure_zero_<unit> column (e.g. pressure_zero_kPa)")
        zero = d["pressure_zero"].to_numpy(dtype=float)
        report = {"method": method, "pressure_zero_Pa": [float(zero.min()), float(zero.max())]}
    else:
        zero = np.full(len(d), float(d["pressure"].min()))
        report = {"method": method, "pressure_zero_Pa": float(zero[0])}
    d["pressure"] = np.maximum(d["pressure"].to_numpy(dtype=float) - zero, 0.0)
    return Table(table.kind, table.path, d, table.columns), report


def apply_tare(table: Table, method: str = "none") -> tuple[Table, dict]:
    """Subtract the load cell's zero from an isometric table's force (off by default).

    A load cell that was not zeroed reads a few newtons at zero pressure (pre-tension at rest
    length, or a negative reading on a slack muscle; ``/work/shared/notes/lab-data.md``). Two ways
    to remove it:

    - ``"lowest"``: per run (held length set point and trial), the mean force at the run's lowest pressure
      (inflate and deflate rows alike, within 1 % of the run's pressure span or 2 kPa) is
      subtracted, so every run starts at zero force. This also
      removes real pre-tension at rest length: use it when the models should see force due to
      pressure only.
    - ``"column"``: the table's ``tare`` column (a tare run's reading) is subtracted row by row.
    - ``"fitted"``: nothing is subtracted here (pre-tension is kept as force); each run's zero is
      a parameter of the fit, with its interval (:func:`mckibben.fit.isometric.fit_points`).

    Parameters
    ----------
    table : Table
        An ``isometric`` table.
    method : {"none", "lowest", "column"}, default "none"
        How to tare. [-]

    Returns
    -------
    table : Table
        The table with the force tared (the same table for ``"none"`` and ``"fitted"``).
    report : dict
        ``method`` and, when used, ``per_run_N``: a list of ``{held_length_m, trial, tare_N}``
        (``"lowest"``) or ``tare_N_range`` (``"column"``). Printed by the CLI when a tare is used.
    """
    check_instance(table, "table", Table, "a Table (read_table)")
    if method not in TARES:
        raise unknown_name("tare method", method, TARES)
    if table.kind != "isometric":
        raise InputError(f"tare: applies to isometric tables; {table.path} is a {table.kind} table")
    d = table.data.copy()
    report: dict = {"method": method}
    if method in ("none", "fitted"):
        if "tare" in d:
            report["note"] = "the tare column was not subtracted (use tare 'column')"
        return table, report
    if method == "column":
        if "tare" not in d:
            raise InputError(f"{table.path}: tare 'column' needs a tare_<unit> column (e.g. tare_N)")
        d["force"] = d["force"] - d["tare"]
        report["tare_N_range"] = [float(d["tare"].min()), float(d["tare"].max())]
    else:
        runs = []
        groups, lengths = set_point_groups(d["held_length"].to_numpy(), decimals=6)
        # a family table's runs are per muscle too
        who = d["muscle"].astype(str).to_numpy() if "muscle" in d else np.full(len(d), "")
        for (k, trial, m), grp in d.groupby([groups, d["trial"].to_numpy(), who], sort=True):
            ell = lengths[k]
            p = grp["pressure"].to_numpy()
            # the rows at the run's lowest pressure set point: within 1 % of the run's span (2 kPa at least)
            near = p <= p.min() + max(0.01 * float(np.ptp(p)), 2e3)
            zero = float(grp["force"].to_numpy()[near].mean())
            d.loc[grp.index, "force"] = grp["force"] - zero
            runs.append({"held_length_m": float(ell), "trial": int(trial), "tare_N": zero, **({"muscle": m} if m else {})})
        report["per_run_N"] = runs
    return Table(table.kind, table.path, d, table.columns), report
