"""Step-response logs (CSV or Parquet): read into SI arrays, split into trials.

A log has a time column, a pressure column and the valve command (``inlet_pwm``/``bleed_pwm``,
``command_pwm`` or a fraction ``command``), optionally a ``trial`` column: see
:func:`read_step_log`. The fits are in :mod:`mckibben.fit.step`, the identification of logs in
:mod:`mckibben.control.identify` (which re-exports these names).
"""

from __future__ import annotations

import numpy as np

from mckibben.atomic import as_path, check_input_file
from mckibben.data.tables import _select_rows
from mckibben.errors import ArgumentTypeError, InputError
from mckibben.limits import PLAUSIBLE_MAX, first_implausible
from mckibben.units import split_column, to_si

# --- step-response logs --------------------------------------------------------------------------

#: Column names of the valve commands in a step log (as in the rig's telemetry, docs/protocol.md).
INLET_COLUMN, BLEED_COLUMN, COMMAND_COLUMN = "inlet_pwm", "bleed_pwm", "command_pwm"
#: A valve command as a fraction of full scale (the project's step_response tables) and the trial.
FRACTION_COLUMN, TRIAL_COLUMN = "command", "trial"


def read_step_log(path, select: dict | None = None, columns: dict | None = None) -> tuple[dict, dict]:
    """Read a step-response log (CSV or Parquet) into SI arrays.

    Columns follow the ``quantity_unit`` convention: a time column ``time_<unit>`` (``time_s``,
    ``time_ms``), a pressure column ``pressure_<unit>`` (``pressure_MPa``, ``pressure_kPa``, …)
    and the valve command either as ``inlet_pwm`` and ``bleed_pwm`` (counts 0..255; the signed
    command is inlet − bleed), as one signed ``command_pwm``, or as ``command`` (a fraction of
    full scale, the project's ``step_response`` tables). A ``trial`` column splits the log into
    trials (time restarts per trial; :func:`split_trials`). Samples sharing a time stamp (a
    millisecond clock at a high rate) are averaged, and ``notes`` says so. Other columns are
    ignored.

    Parameters
    ----------
    path : str or pathlib.Path
        ``.csv`` or ``.parquet`` file. [-]
    select : dict, optional
        Column -> value: only the rows holding every value are read, e.g. one experiment of a log
        holding several (``{"experiment": 3}``); as :func:`mckibben.data.read_table`. Rows keep
        their numbers in the file. [-]
    columns : dict, optional
        The file's column name -> the log's, e.g. ``{"experiment": "trial"}`` or
        ``{"P_kPa": "pressure_kPa"}``. [-]

    Returns
    -------
    tuple of dict
        ``({"time_s", "pressure_Pa", "command_pwm" or "command", "trial" (optional)},
        {"path", "columns", "notes"})``: arrays in SI and where they came from. [s, Pa, counts or -]

    Raises
    ------
    InputError
        Missing file or column, unknown unit, a non-numeric or missing value (named by
        file:row:column; rows count from 1 after the header), time not increasing.
    """

    import pandas as pd  # deferred on purpose: pandas (0.25 s)



    p = check_input_file(as_path(path, "path"))
    try:
        if p.suffix.lower() == ".parquet":
            df = pd.read_parquet(p)
        elif p.suffix.lower() in (".csv", ".txt"):
            df = pd.read_csv(p, comment="#")
        else:
            raise InputError(f"{p}: unknown log format {p.suffix!r} (use .csv or .parquet)")
    except InputError:
        raise
    except Exception as exc:  # parser errors from pandas/pyarrow: one line, no traceback
        raise InputError(f"{p}: cannot be read as {p.suffix[1:]}: {str(exc).splitlines()[0]}") from exc

    df.columns = [str(c).strip() for c in df.columns]
    if columns is not None:
        if not isinstance(columns, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                                    for k, v in columns.items()):
            raise ArgumentTypeError(f"columns = {columns!r}: not a mapping of the file's column names to the log's "
                                    f"({type(columns).__name__}); give e.g. {{'experiment': 'trial'}}")
        for old, new in columns.items():
            if old not in df.columns:
                raise InputError(f"columns: {old}={new}: {p} has no column {old!r}; its columns are "
                                 f"{', '.join(df.columns)}")
            if new in df.columns and new not in columns:
                raise InputError(f"columns: {old}={new}: {p} already has a column {new!r}; keep one")
    renamed = dict(columns or {})
    keep = _select_rows(str(p), df, select, renamed)
    df = df.rename(columns=renamed)[keep]
    rows = df.index.to_numpy() + 1  # 1-based rows of the file, kept through a selection

    def pick(quantity, dimension):
        found = [c for c in df.columns if split_column(str(c))[0] == quantity and split_column(str(c))[1]]
        if not found:
            raise InputError(f"{p}: no {quantity}_<unit> column (have: {', '.join(map(str, df.columns))})")
        col = str(found[0])
        return col, to_si(numeric(col), split_column(col)[1], dimension, where=f"{p}:{col}")

    def numeric(col):
        v = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise InputError(f"{p}:{rows[bad[0]]}:{col}: value {df[col].iloc[bad[0]]!r} is not a finite number")
        return v

    tcol, t = pick("time", "time")
    pcol, pressure = pick("pressure", "pressure")

    for values, col, dim, unit in ((t, tcol, "time", "s"), (pressure, pcol, "pressure", "Pa")):
        bad = first_implausible(values, dim)
        if bad is not None:
            raise InputError(f"{p}:{rows[bad] + 1}:{col}: {values[bad]:g} {unit} is not a plausible {dim} "
                             f"(more than {PLAUSIBLE_MAX[dim]:g} {unit})")
    data = {"time_s": t, "pressure_Pa": pressure}
    cols = {"time": tcol, "pressure": pcol}
    if INLET_COLUMN in df.columns and BLEED_COLUMN in df.columns:
        data["command_pwm"] = numeric(INLET_COLUMN) - numeric(BLEED_COLUMN)
        cols["command"] = f"{INLET_COLUMN}-{BLEED_COLUMN}"
    elif COMMAND_COLUMN in df.columns:
        data["command_pwm"] = numeric(COMMAND_COLUMN)
        cols["command"] = COMMAND_COLUMN
    elif FRACTION_COLUMN in df.columns:
        data["command"] = numeric(FRACTION_COLUMN)
        cols["command"] = FRACTION_COLUMN
    if TRIAL_COLUMN in df.columns:
        trial = numeric(TRIAL_COLUMN)
        frac = np.flatnonzero(trial != np.round(trial))
        if frac.size:
            raise InputError(f"{p}:{rows[frac[0]]}:{TRIAL_COLUMN}: {trial[frac[0]]:g} is not a whole number")
        data["trial"] = trial.astype(int)
        cols["trial"] = TRIAL_COLUMN
    notes = []
    trials = data["trial"] if "trial" in data else np.ones(len(t), int)
    for tr in np.unique(trials):
        idx = np.flatnonzero(trials == tr)
        if idx.size < 2:
            continue
        back = np.flatnonzero(np.diff(t[idx]) < 0)
        if back.size or not np.all(np.diff(idx) == 1):
            k = int(rows[idx[back[0] + 1]]) if back.size else int(rows[idx[np.flatnonzero(np.diff(idx) != 1)[0] + 1]])
            raise InputError(f"{p}:{k}:{tcol}: time goes back within trial {tr} (or the trial's rows are not"
                             " together); time must increase within each trial")
    # repeated time stamps (millisecond clocks): average the samples that share one
    key = np.column_stack([trials, t])
    uniq, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    if np.any(counts > 1):
        inv = inv.ravel()
        order = np.argsort(uniq[:, 0] * 0 + np.arange(len(uniq)))  # np.unique sorts by (trial, time)
        merged = {}
        for name, v in data.items():
            acc = np.zeros(len(uniq))
            np.add.at(acc, inv, v.astype(float))
            merged[name] = acc / counts
        merged["trial"] = uniq[:, 0].astype(int) if "trial" in data else None
        if merged["trial"] is None:
            del merged["trial"]
        data = {k: (v[order].astype(int) if k == "trial" else v[order]) for k, v in merged.items()}
        notes.append(f"{int(np.sum(counts > 1))} repeated time stamps: their {int(np.sum(counts[counts > 1]))}"
                     " samples were averaged")
    if len(data["time_s"]) < 2:
        raise InputError(f"{p}:{tcol}: needs at least two time stamps")
    return data, {"path": str(p), "columns": cols, "notes": notes, **({"selected": dict(select)} if select else {})}


def split_trials(data: dict) -> dict:
    """The log's samples per trial (one trial, 1, when the log has no ``trial`` column).

    Parameters
    ----------
    data : dict
        From :func:`read_step_log`.

    Returns
    -------
    dict
        trial -> the same dict restricted to that trial's samples (without ``trial``).
    """
    if "trial" not in data:
        return {1: data}
    out = {}
    for tr in np.unique(data["trial"]):
        sel = data["trial"] == tr
        out[int(tr)] = {k: v[sel] for k, v in data.items() if k != "trial"}
    return out
