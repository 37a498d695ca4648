"""Experiment tables (CSV, Parquet): read, check against their schema, convert to SI, plot.

:func:`read_table` returns a :class:`Table`. Every problem is an :class:`~mckibben.errors.InputError`
with one line that names the file, the row and the column and what is wrong. Rows are counted as
**1-based data rows**: row 1 is the first row after the header, in CSV and Parquet alike. For a CSV
the file line is given too, ``row 4 (line 5)``, because the header is line 1. The first problem
found (lowest row, then leftmost column) is reported. The schemas themselves are in
:mod:`mckibben.data.schema`; what is done to a table after reading it (tare, pressure zero, rails)
in :mod:`mckibben.data.preprocessing`.
"""

from __future__ import annotations

import difflib
from typing import TYPE_CHECKING

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mckibben.data.schema import BARE_COLUMNS, KINDS, QUANTITIES, SCHEMAS, known_columns
from mckibben.data.setpoints import set_point_groups
from mckibben.atomic import as_path, check_input_file
from mckibben.errors import ArgumentTypeError
from mckibben.errors import InputError
from mckibben.units import G_N, UNITS, to_si, units_of
from mckibben.errors import unknown_name
from mckibben.limits import PLAUSIBLE_MAX, PLAUSIBLE_MIN_LENGTH, first_implausible
from mckibben.units import SI_UNIT
from mckibben.results import check_ax, shown_once

if TYPE_CHECKING:
    import pandas as pd


def _pd():
    """pandas, imported on first use: it costs about 0.25 s, and a simulation that reads no table needs none."""
    import pandas  # deferred: pandas (0.25 s) only where a table is read

    return pandas

NUMERIC_SUFFIXES = (".csv", ".parquet", ".pq")

#: In an isometric table, pressures below zero by at most this fraction of the largest pressure
#: (and at least 1 kPa) are a transducer's zero offset and read as 0; below that they are refused. [-]
PRESSURE_ZERO_TOL = 0.01


@dataclass(frozen=True)
class Table:
    """One validated experiment table, in SI.

    Attributes
    ----------
    kind : str
        Experiment kind (a key of :data:`mckibben.data.schema.SCHEMAS`).
    path : str
        The file as the user named it (used in messages).
    data : pandas.DataFrame
        One column per quantity, SI (``pressure`` [Pa], ``load`` [N], ``length`` [m], ``force`` [N],
        ``braid_angle`` [rad], ``time`` [s], ``command`` [-]), ``trial`` (int, 1 if absent),
        ``direction`` and ``muscle`` (str). The index is the 1-based data row.
    columns : dict
        Quantity -> the column name in the file (e.g. ``{"pressure": "pressure_psi"}``).
    extra : pandas.DataFrame or None
        The columns the schema does not know, kept aside as read (text), on the rows of ``data``.
    notes : tuple of str
        One line per thing the reader did that the user should know (columns kept aside).
    selected : dict
        The ``select`` the rows were picked with (column -> value; empty: every row).
    """

    kind: str
    path: str
    data: pd.DataFrame
    columns: dict = field(default_factory=dict)
    extra: pd.DataFrame | None = None
    notes: tuple[str, ...] = ()
    selected: dict = field(default_factory=dict)

    @property
    def is_csv(self) -> bool:
        """Whether the file is a CSV (its messages give file lines too)."""
        return self.path.lower().endswith(".csv")

    def where(self, row: int | None = None, quantity: str | None = None) -> str:
        """The location prefix of a message: ``file: row R (line R+1), column C``.

        Parameters
        ----------
        row : int, optional
            1-based data row. [-]
        quantity : str, optional
            Quantity name; the file's column name is printed. [-]
        """
        return _where(self.path, row, self.columns.get(quantity, quantity) if quantity else None, self.is_csv)

    def __len__(self) -> int:
        return len(self.data)

    def plot(self, ax=None):
        """Draw the table as its kind is read (what against what, one line per group); return the Figure.

        ``isotonic`` and ``hysteresis``: length against pressure, one line per load (and
        direction); ``blocked_force``: force against pressure; ``braid_angle``: braid angle
        against length; ``force_length``: force against length per pressure and direction;
        ``isometric``: force against pressure per held length and direction; ``step_response``:
        pressure against time. Each trial is its own line. Axes in the lab's units (kPa, mm, N,
        deg, s); the figure shows once in Jupyter, as a result's ``.plot()``.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]

        Returns
        -------
        matplotlib.figure.Figure
        """
        check_ax(ax)
        if isinstance(ax, (list, tuple, np.ndarray)):
            raise InputError(f"ax: a table draws on one Axes, not {len(ax)}")
        x, y, groups = _TABLE_PLOTS[self.kind]
        new = ax is None
        if new:
            import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

            fig, ax = plt.subplots(figsize=(6.0, 4.0))
        else:
            fig = ax.figure
        df = self.data
        keys = [g for g in groups if g in df.columns and df[g].nunique() > 1]
        split = "trial" in df.columns and df["trial"].nunique() > 1
        parts = df.groupby(keys, sort=True) if keys else [((), df)]
        for k, (key, part) in enumerate(parts):  # one colour per group, one line per trial
            key = key if isinstance(key, tuple) else (key,)
            label = ", ".join(_group_label(c, v) for c, v in zip(keys, key)) or None
            for t, (_, run) in enumerate(part.groupby("trial", sort=True) if split else [(None, part)]):
                ax.plot(run[x] * _PLOT_SCALE[x][0], run[y] * _PLOT_SCALE[y][0], marker=".", color=f"C{k % 10}",
                        label=label if t == 0 else None)
        ax.set_xlabel(f"{x.replace('_', ' ')} [{_PLOT_SCALE[x][1]}]")
        ax.set_ylabel(f"{y.replace('_', ' ')} [{_PLOT_SCALE[y][1]}]")
        ax.set_title(f"{Path(self.path).name} ({self.kind}{', one line per trial' if split else ''})")
        if keys and len(parts) <= 12:
            ax.legend(fontsize="small")
        ax.grid(True, alpha=0.3)
        return shown_once(fig) if new else fig


#: What :meth:`Table.plot` draws for each kind: (x, y, the columns that split it into lines).
_TABLE_PLOTS = {
    "blocked_force": ("pressure", "force", ()),
    "isotonic": ("pressure", "length", ("load",)),
    "hysteresis": ("pressure", "length", ("load", "direction")),
    "braid_angle": ("length", "braid_angle", ()),
    "force_length": ("length", "force", ("pressure", "direction")),
    "isometric": ("pressure", "force", ("held_length", "direction")),
    "step_response": ("time", "pressure", ()),
}
#: SI quantity -> (factor, unit) of a plot's axis (units at the edges).
_PLOT_SCALE = {"pressure": (1e-3, "kPa"), "length": (1e3, "mm"), "held_length": (1e3, "mm"), "force": (1.0, "N"),
               "load": (1.0, "N"), "braid_angle": (180.0 / math.pi, "deg"), "time": (1.0, "s")}


def _group_label(column: str, value) -> str:
    if column in _PLOT_SCALE and isinstance(value, (int, float, np.number)):
        factor, unit = _PLOT_SCALE[column]
        return f"{column.replace('_', ' ')} {float(value) * factor:.4g} {unit}"
    return f"{column} {value}"


def _where(path: str, row: int | None, column: str | None, is_csv: bool) -> str:
    out = path
    if row is not None:
        out += f": row {row}" + (f" (line {row + 1})" if is_csv else "")
    if column is not None:
        out += (", " if row is not None else ": ") + f"column {column}"
    return out


#: How close (difflib ratio) an unknown column's name must be to a known one of the same quantity
#: to be suggested: a typo (``presure`` -> ``pressure``, 0.93; ``tral`` -> ``trial``, 0.89), not
#: another quantity of the same dimension (``cut_length`` -> ``rest_length``, 0.76). [-]
SUGGEST_CUTOFF = 0.8


def _suggestion(name: str, values=None) -> str | None:
    """The known column an unknown one probably means, or None: only a name of the same quantity.

    A ``quantity_unit`` name with a unit is matched against the quantities of that unit's
    dimension; a bare name against the bare columns; a column whose every value is a branch of a
    loop (``inflate``/``deflate``, ``elongation``/``contraction``) means ``direction``, whatever
    its name (a lab's ``phase``).
    """
    quantity, _, unit = name.rpartition("_")
    if unit in UNITS and quantity:
        dim = UNITS[unit][0]
        same = [q for q in QUANTITIES if QUANTITIES[q][0] == dim or (q == "load" and dim == "mass")]
        close = difflib.get_close_matches(quantity, same, n=1, cutoff=SUGGEST_CUTOFF)
        return f"{close[0]}_{unit}" if close else None
    if values is not None:
        text = set(np.char.lower(np.asarray(values, dtype=str)))
        text.discard("")
        if text and any(text <= set(s.directions) for s in SCHEMAS.values() if s.directions):
            return "direction"
    bare = list(BARE_COLUMNS) + [q for q in QUANTITIES if QUANTITIES[q][0] == "dimensionless"]
    close = difflib.get_close_matches(name, bare, n=1, cutoff=SUGGEST_CUTOFF)
    return close[0] if close else None


def _parse_columns(path: str, names: list[str]) -> tuple[dict[str, tuple[str, str, str]], list[str]]:
    """Map each known file column to (quantity, unit, original name); list the unknown ones.

    Unknown names (not a quantity of the schema) are returned apart, to be kept aside; a known
    quantity with a bad unit, a quantity given twice, or a header that is one column (another
    delimiter) raise.
    """
    out: dict[str, tuple[str, str, str]] = {}
    unknown: list[str] = []
    for name in names:
        if name in BARE_COLUMNS:
            quantity, unit = name, ""
        elif name in QUANTITIES:
            dim = QUANTITIES[name][0]
            if dim == "dimensionless":
                quantity, unit = name, ""
            else:
                raise InputError(f"{path}: column {name}: no unit; name it {name}_<unit>, e.g. {name}_{units_of(dim)[0] if dim != 'force' else 'N'}")
        else:
            quantity, _, unit = name.rpartition("_")
            if quantity not in QUANTITIES:
                sep = next((c for c in (";", "\t", "|") if c in name), None)
                if sep is not None:  # one column holding every header: another delimiter
                    raise InputError(f"{path}: the header is one column, {name!r}: the file looks separated by "
                                     f"{'tabs' if sep == chr(9) else repr(sep)}; mckibben reads comma-separated CSV "
                                     "(with a decimal point): save it again with commas")
                unknown.append(name)
                continue
            dim = QUANTITIES[quantity][0]
            ok_units = units_of(dim) + (units_of("mass") if quantity == "load" else [])
            if unit not in UNITS or not unit:
                raise InputError(f"{path}: column {name}: unknown unit {unit!r} for {quantity}; use one of {', '.join(ok_units)}")
            if unit not in ok_units:
                raise InputError(f"{path}: column {name}: unit {unit!r} is a {UNITS[unit][0]}, not a {dim}; use one of {', '.join(ok_units)}")
        if quantity in out:
            raise InputError(f"{path}: columns {out[quantity][2]} and {name} both give {quantity}; keep one")
        out[quantity] = (quantity, unit, name)
    return out, unknown


def _unknown_text(name: str, values=None) -> str:
    """``phase (its values are a loop's branches: map it with `columns` phase=direction)``: a name and its hint."""
    near = _suggestion(name, values)
    if near is None:
        return name
    if near == "direction" and values is not None and _suggestion(name) != "direction":
        return f"{name} (its values are a loop's branches: map it with `columns` {name}=direction)"
    return f"{name} (did you mean {near}?)"


def _unknown_note(path: str, frame, unknown: list[str]) -> str:
    """The one-line note for the columns kept aside, with the known columns (from the schema)."""
    parts = [_unknown_text(c, frame[c].astype(str).str.strip().to_numpy()) for c in unknown]
    what = f"column {parts[0]} is" if len(parts) == 1 else f"columns {', '.join(parts)} are"
    return f"{path}: {what} unknown: kept aside, not read; known columns are {', '.join(known_columns())}"


def _rename_columns(path: str, frame, columns) -> dict[str, str]:
    """Check ``columns`` (file name -> schema name) against a file's header; return it as a dict."""
    if columns is None:
        return {}
    if not isinstance(columns, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in columns.items()):
        raise ArgumentTypeError(f"columns = {columns!r}: not a mapping of the file's column names to the schema's "
                                f"({type(columns).__name__}); give e.g. {{'phase': 'direction'}}")
    header = list(frame.columns)
    for old, new in columns.items():
        if old not in header:
            raise InputError(f"columns: {old}={new}: {path} has no column {old!r}; its columns are {', '.join(header)}")
        known, unknown = _parse_columns(path, [new])
        if unknown:
            near = _suggestion(new)
            raise InputError(f"columns: {old}={new}: {new!r} is not a column mckibben reads"
                             + (f" (did you mean {near}?)" if near else "")
                             + f"; known columns are {', '.join(known_columns())}")
        if new in header and new not in columns:
            raise InputError(f"columns: {old}={new}: {path} already has a column {new!r}; keep one")
    targets = list(columns.values())
    twice = next((t for t in targets if targets.count(t) > 1), None)
    if twice is not None:
        raise InputError(f"columns: two columns are mapped to {twice!r}; keep one")
    return dict(columns)


def _select_rows(path: str, frame, select, renamed: dict[str, str]) -> np.ndarray:
    """The rows of a raw frame that ``select`` (column -> value) picks; one line when none does."""
    keep = np.ones(len(frame), dtype=bool)
    if select is None:
        return keep
    if not isinstance(select, dict) or not all(isinstance(k, str) for k in select):
        raise ArgumentTypeError(f"select = {select!r}: not a mapping of column names to values "
                                f"({type(select).__name__}); give e.g. {{'cut_length_cm': 10}}")
    back = {new: old for old, new in renamed.items()}
    for col, value in select.items():
        src = back.get(col, col)
        if src not in frame.columns:
            raise InputError(f"select: {col}={value}: {path} has no column {col!r}; its columns are "
                             f"{', '.join(frame.columns)}")
        raw = frame[src]
        text = raw.astype(str).str.strip()
        numbers = _pd().to_numeric(text, errors="coerce").to_numpy(dtype=float)
        try:
            target = float(value)
        except (TypeError, ValueError):
            target = math.nan
        if math.isfinite(target) and np.isfinite(numbers).all():
            hit = np.isclose(numbers, target, rtol=1e-9, atol=0.0)
        else:
            hit = (text == str(value).strip()).to_numpy()
        if not hit.any():
            values = list(dict.fromkeys(text.tolist()))
            shown = ", ".join(values[:12]) + (", ..." if len(values) > 12 else "")
            raise InputError(f"select: {col}={value}: no row of {path} has {col} = {value}; its values are {shown}")
        keep &= hit
    if not keep.any():
        raise InputError(f"select: {', '.join(f'{c}={v}' for c, v in select.items())}: no row of {path} has all of "
                         "these values together")
    return keep


def detect_kind(quantities) -> str | None:
    """The experiment kind whose required columns are all present (the most specific one).

    Parameters
    ----------
    quantities : iterable of str
        The quantities (and bare columns) a table has. [-]

    Returns
    -------
    str or None
        The kind, or None if no kind's required columns are all present.
    """
    if isinstance(quantities, (str, bytes)) or not hasattr(quantities, "__iter__"):
        raise ArgumentTypeError(f"quantities = {quantities!r}: not a collection of column names "
                                f"({type(quantities).__name__})")
    present = set(quantities)
    fits = [s for s in SCHEMAS.values() if set(s.required) <= present]
    if not fits:
        return None
    # the kind that explains most of the columns, then the most specific (most required)
    fits.sort(key=lambda s: (len(present - set(s.allowed)), -len(s.required)))
    return fits[0].kind


def _read_frame(path: Path, name: str) -> tuple[pd.DataFrame, bool]:
    suffix = path.suffix.lower()
    if suffix not in NUMERIC_SUFFIXES:
        raise InputError(f"{name}: unknown file type {path.suffix!r}; use .csv or .parquet")
    check_input_file(path, None)
    if suffix == ".csv":
        try:
            df = _pd().read_csv(path, dtype=str, keep_default_na=False, skip_blank_lines=False, skipinitialspace=True)
        except _pd().errors.EmptyDataError:
            raise InputError(f"{name}: the file is empty; it needs a header line and data rows") from None
        except (_pd().errors.ParserError, UnicodeDecodeError) as exc:
            raise InputError(f"{name}: cannot read as CSV: {' '.join(str(exc).split())}") from None
        return df, True
    try:
        df = _pd().read_parquet(path)
    except Exception as exc:  # pyarrow raises several types for a bad file
        raise InputError(f"{name}: cannot read as Parquet: {' '.join(str(exc).split())}") from None
    return df.reset_index(drop=True), False


def read_table(path, kind: str | None = None, select: dict | None = None, columns: dict | None = None) -> Table:
    """Read one experiment table (CSV or Parquet), validate it and convert it to SI.

    Tables as labs keep them: a column the schema does not know (a lab's ``n_samples``,
    ``cut_length_cm``) is kept aside in :attr:`Table.extra` with a one-line note in
    :attr:`Table.notes`, not refused; ``columns`` maps a lab's names to the schema's
    (``{"phase": "direction"}``); ``select`` picks one muscle or condition from a table holding
    several (``{"cut_length_cm": 10}``). Rows keep their numbers in the file.

    Parameters
    ----------
    path : str or pathlib.Path
        The file. Its kind is ``kind`` if given, else the file's stem if that names a kind
        (``isotonic.csv``), else detected from its columns.
    kind : str, optional
        Force the experiment kind (a key of :data:`~mckibben.data.schema.SCHEMAS`).
    select : dict, optional
        Column -> value: only the rows holding every value are read (numbers compared as numbers,
        in the file's unit, else text). A column is named as in the file, or by its new name in
        ``columns``. [-]
    columns : dict, optional
        The file's column name -> a name of the schema (:func:`~mckibben.data.schema.known_columns`,
        with a unit where it has one: ``{"P_kPa": "pressure_kPa"}``). [-]

    Returns
    -------
    Table
        The validated table in SI.

    Raises
    ------
    InputError
        One line naming the file, row and column and what is wrong: a missing column, unknown
        unit, text in a numeric cell, a missing value, NaN or infinity, a negative pressure
        or load, a direction that is not one of the kind's, time not increasing within a trial,
        several muscles in one table without a ``select``; or naming ``select``/``columns`` when
        one of theirs is not in the file or picks no row.
    """
    p = as_path(path, "path")
    if kind is not None and not isinstance(kind, str):
        raise ArgumentTypeError(f"kind = {kind!r}: not an experiment kind ({type(kind).__name__}); give one of "
                                f"{', '.join(KINDS)}, or None to detect it")
    name = str(path)
    df, is_csv = _read_frame(p, name)
    df.columns = [str(c).strip() for c in df.columns]
    renamed = _rename_columns(name, df, columns)
    keep = _select_rows(name, df, select, renamed)
    df = df.rename(columns=renamed)
    selected = set() if select is None else {renamed.get(c, c) for c in select}
    file_rows = np.flatnonzero(keep) + 1  # 1-based rows of the file, kept through a selection
    df = df[keep]
    cols, unknown = _parse_columns(name, list(df.columns))
    aside = [c for c in unknown if c not in selected]
    notes = (_unknown_note(name, df, aside),) if aside else ()
    if kind is not None and kind not in SCHEMAS:
        raise unknown_name("experiment kind", kind, KINDS)
    if kind is None and p.stem in SCHEMAS:
        kind = p.stem
    if kind is None:
        kind = detect_kind(cols)
        explains = [sc for sc in SCHEMAS.values() if set(cols) <= set(sc.allowed)]
        # the kind a table missing a required column was meant to be: the one whose columns hold all of the
        # table's, then whose branches a direction column's values are (inflate/deflate or elongation/contraction),
        # then with most of its required columns there
        branches = set(df[cols["direction"][2]].astype(str).str.strip().str.lower()) if "direction" in cols else set()

        def closest(sc):
            return (set(cols) <= set(sc.allowed), bool(branches) and branches <= set(sc.directions),
                    len(set(sc.required) & set(cols)))

        if explains and kind is not None and not set(cols) <= set(SCHEMAS[kind].allowed):
            # the columns name one kind (e.g. held_length: isometric) that misses a required one
            kind = max(explains, key=closest).kind
        if kind is None:
            best = max(SCHEMAS.values(), key=closest)
            missing = [q for q in best.required if q not in cols]
            raise InputError(
                f"{name}: missing column {_example_column(missing[0])}: no experiment kind matches the columns"
                f" (closest: {best.kind}, which needs {', '.join(best.required)}){_meant(missing[0], df, aside)}"
            )
    schema = SCHEMAS[kind]
    for q in schema.required:
        if q not in cols:
            raise InputError(f"{name}: missing column {_example_column(q)}; a {kind} table needs "
                             f"{', '.join(schema.required)}{_meant(q, df, aside)}")
    filled = [(q, value, why) for q, value, why in schema.defaults if q not in cols]
    for q, value, _ in filled:
        meant = _meant(q, df, aside)
        if meant:  # a lab's own name for the column (phase): refused rather than read as the default
            raise InputError(f"{name}: missing column {_example_column(q)} (without it every row would be read as "
                             f"{value}){meant}")
    for q, (_, _, col) in cols.items():
        if q not in schema.allowed:
            raise InputError(
                f"{name}: column {col} is not part of the {kind} schema (required: {', '.join(schema.required)};"
                f" optional: {', '.join(schema.optional)})"
            )
    if len(df) == 0:
        raise InputError(f"{name}: no data rows")

    rows = file_rows
    errors: list[tuple[int, int, str]] = []  # (row, column position, message)
    out: dict[str, np.ndarray] = {}
    order = list(df.columns)
    for q, (_, unit, col) in cols.items():
        pos = order.index(col)
        raw = df[col]
        where = lambda r: _where(name, int(r), col, is_csv)  # noqa: E731
        if q in QUANTITIES:
            values, bad = _numbers(raw)
            for i, text in bad:
                errors.append((rows[i - 1], pos, f"{where(rows[i - 1])}: {text}"))
            dim, no_negative, _ = QUANTITIES[q]
            if no_negative and q == "pressure" and kind == "isometric" and unit:
                # an unzeroed transducer reads slightly below zero at zero pressure: within
                # PRESSURE_ZERO_TOL of the largest reading that is a zero offset, read as 0
                si = to_si(np.nan_to_num(values, nan=0.0), unit, dim)
                tol = max(PRESSURE_ZERO_TOL * float(np.max(si, initial=0.0)), 1e3)
                small = (si < 0) & (si >= -tol)
                values = np.where(small, 0.0, values)
            if no_negative:
                neg = np.flatnonzero(np.nan_to_num(values, nan=0.0) < 0)
                if neg.size:
                    r = rows[neg[0]]
                    errors.append((r, pos, f"{where(r)}: {_g(values[neg[0]])} is negative; a {QUANTITIES[q][2].split(' (')[0]} must be >= 0"))
            if q == "load" and UNITS[unit][0] == "mass":
                out[q] = to_si(values, unit, "mass") * G_N
            else:
                out[q] = to_si(values, unit, dim) if unit else values
        elif q == "trial":
            values, bad = _numbers(raw)
            for i, text in bad:
                errors.append((rows[i - 1], pos, f"{where(rows[i - 1])}: {text}"))
            frac = np.flatnonzero(np.isfinite(values) & (values != np.round(values)))
            if frac.size:
                r = rows[frac[0]]
                errors.append((r, pos, f"{where(r)}: {_g(values[frac[0]])} is not a whole number (trials are counted 1, 2, ...)"))
            out[q] = np.nan_to_num(values, nan=1.0).astype(int)
        else:  # direction, muscle: text
            text = raw.astype(str).str.strip().to_numpy()
            empty = np.flatnonzero((text == "") | (text == "nan") | (text == "None"))
            if empty.size:
                r = rows[empty[0]]
                errors.append((r, pos, f"{where(r)}: value is missing"))
            if q == "direction":
                lowered = np.char.lower(text.astype(str))
                wrong = np.flatnonzero(~np.isin(lowered, schema.directions) & (text != ""))
                if wrong.size:
                    r = rows[wrong[0]]
                    errors.append((r, pos, f"{where(r)}: {text[wrong[0]]!r} is not a direction; use {' or '.join(schema.directions)}"))
                text = lowered
            out[q] = text
    if errors:
        errors.sort(key=lambda e: (e[0], e[1]))
        raise InputError(errors[0][2])
    data = _pd().DataFrame(out, index=_pd().Index(rows, name="row"))
    for q, value, why in filled:
        data[q] = value
        notes += (f"{name}: no {q} column: every row read as {value} ({why})",)
    if "trial" not in data:
        data["trial"] = 1
    if "time" in data:
        col = cols["time"][2]
        for _, grp in data.groupby("trial", sort=False):
            t = grp["time"].to_numpy()
            back = np.flatnonzero(np.diff(t) <= 0)
            if back.size:
                r = int(grp.index[back[0] + 1])
                prev = int(grp.index[back[0]])
                raise InputError(
                    f"{_where(name, r, col, is_csv)}: time {_g(t[back[0] + 1])} does not increase"
                    f" (row {prev} has {_g(t[back[0]])}); time must increase within each trial"
                )
    _check_plausible(data, cols, name, is_csv)
    extra = _pd().DataFrame({c: df[c].to_numpy() for c in aside}, index=data.index)
    table = Table(kind, name, data, {q: c[2] for q, c in cols.items()}, extra, notes,
                  {} if select is None else dict(select))
    if kind == "isometric":
        _check_isometric(table)
    return table


def _meant(quantity: str, frame, aside: list[str]) -> str:
    """``; the unknown column presure_MPa (did you mean pressure_MPa?) may be it`` for a missing quantity, or ''."""
    for c in aside:
        near = _suggestion(c, frame[c].astype(str).str.strip().to_numpy())
        if near is not None and (near == quantity or near.rpartition("_")[0] == quantity):
            return f"; the unknown column {_unknown_text(c, frame[c].astype(str).str.strip().to_numpy())} may be it"
    return ""


def _check_plausible(data: pd.DataFrame, cols: dict, name: str, is_csv: bool) -> None:
    """Refuse a magnitude no braided muscle produces (:data:`mckibben.limits.PLAUSIBLE_MAX`), or a length
    below :data:`mckibben.limits.PLAUSIBLE_MIN_LENGTH` (metres under a millimetre heading)."""

    for q, (_, _, col) in cols.items():
        if q not in QUANTITIES:
            continue
        dim = QUANTITIES[q][0]
        v = data[q].to_numpy(dtype=float)
        i = first_implausible(v, dim)
        if i is not None:
            r = int(data.index[i])
            raise InputError(f"{_where(name, r, col, is_csv)}: {_g(data[q].iloc[i])} {SI_UNIT[dim]} is not a plausible "
                             f"{QUANTITIES[q][2].split(' (')[0]} (more than {PLAUSIBLE_MAX[dim]:g} {SI_UNIT[dim]})")
        if dim == "length":
            short = np.flatnonzero(np.isfinite(v) & (v < PLAUSIBLE_MIN_LENGTH))
            if short.size:
                r = int(data.index[short[0]])
                raise InputError(f"{_where(name, r, col, is_csv)}: {_g(v[short[0]] * 1e3)} mm is not a plausible "
                                 f"{QUANTITIES[q][2].split(' (')[0]} (below {PLAUSIBLE_MIN_LENGTH * 1e3:g} mm); "
                                 f"the column {col} holds metres? (97 mm is 97 in a _mm column, 0.097 in a _m one)")


def _several_muscles(table: Table) -> str:
    """The message for a table of several rest lengths and no ``muscle`` column: which column names them.

    The column named is the first kept-aside one holding one value per rest length (a lab's
    ``cut_length_cm``), else the rest-length column itself.
    """
    d = table.data
    rest = d["rest_length"].to_numpy()
    column = table.columns["rest_length"]
    per_unit = to_si(1.0, column.rpartition("_")[2], "length")  # the file's unit: select reads it
    values = [f"{v / per_unit:g}" for v in np.unique(rest)]
    for c in ([] if table.extra is None else list(table.extra.columns)):
        pairs = _pd().DataFrame({"c": table.extra[c].astype(str).to_numpy(), "r": rest})
        if pairs["c"].nunique() == len(values) and len(pairs.drop_duplicates()) == len(values):
            column, values = c, list(dict.fromkeys(pairs["c"]))
            break
    shown = ", ".join(values[:8]) + (", ..." if len(values) > 8 else "")
    return (f"{table.path}: column {column} holds {len(values)} muscles ({shown}), each with its own rest length; "
            f"pick one with `select` {column}={values[0]}, or fit them as a family with a muscle column"
            + (f" (`columns` {column}=muscle)" if column != table.columns["rest_length"] else ""))


def _check_isometric(table: Table) -> None:
    """An isometric table spans two held lengths or more and two pressures or more per run."""
    d = table.data
    if "rest_length" in d:  # a family table: one rest length per muscle
        if "muscle" not in d and np.unique(d["rest_length"].to_numpy()).size > 1:
            raise InputError(_several_muscles(table))
    if "rest_length" in d and "muscle" in d:
        spread = d.groupby(d["muscle"].astype(str))["rest_length"].agg(lambda x: float(np.ptp(x.to_numpy())))
        bad = spread[spread > 1e-9]
        if len(bad):
            r = int(d.index[(d["muscle"].astype(str) == bad.index[0]).to_numpy()][0])
            raise InputError(f"{table.where(r, 'rest_length')}: muscle {bad.index[0]!r} has more than one rest length")
    groups, lengths = set_point_groups(d["held_length"].to_numpy(), decimals=6)
    if lengths.size < 2:
        raise InputError(
            f"{table.where(None, 'held_length')}: only one held length ({lengths[0] * 1e3:g} mm); an isometric table"
            " needs two or more to fit force(P, L) (one length at rest is a blocked_force table)"
        )
    for (k, trial), grp in d.groupby([groups, d["trial"].to_numpy()], sort=True):
        ell = lengths[k]
        if np.unique(np.round(grp["pressure"].to_numpy(), 3)).size < 2:
            r = int(grp.index[0])
            raise InputError(
                f"{table.where(r, 'pressure')}: the run at held length {ell * 1e3:g} mm, trial {trial} has one"
                f" pressure ({grp['pressure'].iloc[0] / 1e3:g} kPa); an isometric run steps the pressure up and down"
            )


def _numbers(raw: pd.Series) -> tuple[np.ndarray, list[tuple[int, str]]]:
    """Convert a column to float; list (1-based row, problem) for cells that are not finite numbers."""
    if _pd().api.types.is_numeric_dtype(raw) and not _pd().api.types.is_bool_dtype(raw):
        values = raw.to_numpy(dtype=float)
        text = None
    else:
        text = raw.astype(str).str.strip()
        values = _pd().to_numeric(text.where(text != "", None), errors="coerce").to_numpy(dtype=float)
    bad = []
    idx = np.flatnonzero(~np.isfinite(values))
    for i in idx[:1]:  # the first one is enough: one message per problem
        if text is None:
            v = values[i]
            bad.append((i + 1, "value is missing (NaN)" if math.isnan(v) else f"{_g(v)} is not a finite number"))
            continue
        cell = text.iloc[i]
        if cell == "" or cell.lower() in ("none", "null"):
            bad.append((i + 1, "value is missing"))
            continue
        try:
            v = float(cell)
        except ValueError:
            bad.append((i + 1, f"{cell!r} is not a number"))
            continue
        bad.append((i + 1, "value is missing (NaN)" if math.isnan(v) else f"{cell!r} is not a finite number"))
    return values, bad


def _g(v: float) -> str:
    return f"{float(v):g}"


def _example_column(quantity: str) -> str:
    if quantity in BARE_COLUMNS:
        return quantity
    dim = QUANTITIES[quantity][0]
    example = {"pressure": "MPa", "force": "N", "length": "mm", "angle": "deg", "time": "s"}.get(dim, "")
    return f"{quantity}_<unit> (e.g. {quantity}_{example})" if example else quantity


