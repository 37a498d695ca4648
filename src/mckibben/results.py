"""What every experiment returns: a result object with one shape across the library.

Each public experiment (a closed-loop step, Fig. 13, a robustness study, a tracking run, a fit)
returns a subclass of :class:`Result`, following python-control's response objects and lmfit's
``ModelResult``:

``.metrics``
    A dict of scalar results, SI units, keys suffixed with their unit (``time_constant_s``,
    ``overshoot_pct``, ``steady_state_error_Pa``).
``.to_pandas()``
    The time series (or table) behind the metrics, columns named ``quantity_unit``
    (``time_s``, ``pressure_Pa``, ``inlet_pwm``), provenance in ``DataFrame.attrs``.
``.plot(ax=None)``
    Draws on ``ax`` (a new figure when None) and returns the :class:`~matplotlib.figure.Figure`;
    it never switches Matplotlib's backend, so figures show inline in Jupyter.
``.to_dict()``
    Everything ``--json`` prints: JSON-ready values, SI units.
``.to_file(path)``
    The ``to_pandas()`` table as CSV or Parquet (by suffix); Parquet files carry the provenance
    in their schema metadata (key ``mckibben``).
``repr``
    The class name, what was run and the headline metrics, on one line.

Sampled signals live in one type, :class:`TimeResponse` (python-control's ``TimeResponseData`` in
spirit): the simulator's, the closed loop's, the device's, the tool's and the MuJoCo runs' records
all give ``time`` [s], ``n_samples``, ``n_instances``, ``signal(name, i)`` and ``frame(i)``, whose
columns follow :data:`SIGNAL_COLUMNS`; the results' ``to_pandas`` are built from those frames.
"""

from __future__ import annotations

import json
import math
import os
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, unknown_name
from mckibben import __version__
from mckibben.atomic import check_input_file, check_output_file
from mckibben.atomic import atomic_file
import numpy as _np
import sys
import functools


__all__ = ["Result", "TimeResponse", "SIGNAL_COLUMNS", "to_jsonable", "write_table", "read_provenance",
           "SERIES_SUFFIXES"]

#: The file formats of :meth:`Result.to_file` and ``--out``.
SERIES_SUFFIXES = (".csv", ".parquet")


def to_jsonable(obj: Any) -> Any:
    """Turn NumPy scalars and arrays, tuples and dicts into JSON values; NaN and infinities become None.

    Parameters
    ----------
    obj : object
        A value, possibly nested. [-]
    """
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        value = float(obj)
        return value if math.isfinite(value) else None
    return obj


def provenance(call: str, arguments: dict | None = None) -> dict:
    """Where a table came from: the library call, its arguments, the version and the time.

    Parameters
    ----------
    call : str
        The public function that produced it, e.g. ``"mckibben.experiments.step_response"``. [-]
    arguments : dict, optional
        Its arguments, SI. [-]
    """

    prov = {"call": call, "arguments": to_jsonable(arguments or {}), "mckibben_version": __version__,
            "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    if COMMAND:
        prov["command"] = COMMAND
    return prov


#: The command line that runs this process's work (``mckibben control step ...``), set by the CLI;
#: empty in a notebook or script, whose call and arguments the provenance names instead.
COMMAND = ""


def provenance_sidecar(path) -> str:
    """The file beside a CSV table that holds its provenance: ``run.csv`` → ``run.csv.provenance.json``.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file. [-]
    """
    return os.fspath(path) + ".provenance.json"


def check_table_path(path, name: str = "out") -> str:
    """Refuse, before any work, a table path that is not .csv or .parquet or cannot be written.

    Parameters
    ----------
    path : str or os.PathLike
        The output file. [-]
    name : str, default "out"
        The argument's name, for the message. [-]
    """

    return os.fspath(check_output_file(path, name, suffixes=SERIES_SUFFIXES))


def write_table(df, path, meta: dict | None = None, name: str = "out") -> str:
    """Write a table as CSV or Parquet, atomically and with the user's umask.

    Parameters
    ----------
    df : pandas.DataFrame
        The table, columns named ``quantity_unit``. [-]
    path : str or os.PathLike
        ``.csv`` or ``.parquet``. [-]
    meta : dict, optional
        Provenance; default ``df.attrs["provenance"]``. Parquet stores it as JSON under the
        schema metadata key ``mckibben``; a CSV file gets it beside it, as JSON in
        :func:`provenance_sidecar` (a comment line would trip other CSV readers). [-]
    name : str, default "out"
        The argument's name, for error messages. [-]

    Returns
    -------
    str
        The path written.
    """

    if not hasattr(df, "to_csv") or not hasattr(df, "attrs"):
        raise ArgumentTypeError(f"df = {df!r}: not a pandas DataFrame ({type(df).__name__})")
    path = check_table_path(path, name)
    meta = meta if meta is not None else df.attrs.get("provenance", {})
    if path.lower().endswith(".csv"):
        with atomic_file(path, name) as tmp:
            df.to_csv(tmp, index=False)
        if meta:
            with atomic_file(provenance_sidecar(path), name) as tmp:
                with open(tmp, "w", encoding="utf-8") as fh:
                    json.dump(to_jsonable(meta), fh, indent=1, allow_nan=False)
        return path
    with atomic_file(path, name) as tmp:
        import pyarrow as pa  # deferred on purpose: pyarrow
        import pyarrow.parquet as pq  # deferred on purpose: pyarrow

        table = pa.Table.from_pandas(df, preserve_index=False)
        md = dict(table.schema.metadata or {})
        md[b"mckibben"] = json.dumps(to_jsonable(meta), allow_nan=False).encode()
        pq.write_table(table.replace_schema_metadata(md), tmp)
    return path


def read_provenance(path) -> dict:
    """The provenance a :func:`write_table` file carries (empty dict if none).

    Parameters
    ----------
    path : str or os.PathLike
        A Parquet file, or a CSV file (its :func:`provenance_sidecar`). [-]
    """
    path = check_input_file(path, "path")
    if os.fspath(path).lower().endswith(".csv"):
        side = provenance_sidecar(path)
        return json.loads(Path(side).read_text(encoding="utf-8")) if os.path.exists(side) else {}
    import pyarrow.parquet as pq  # deferred on purpose: pyarrow

    md = pq.read_schema(path).metadata or {}
    raw = md.get(b"mckibben")
    return json.loads(raw) if raw else {}


class Result:
    """Base of the library's result objects (see the module's docstring for the conventions).

    Subclasses set :attr:`call` and :attr:`arguments` and implement :meth:`_series`,
    :attr:`metrics` and :meth:`plot`; they may extend :meth:`to_dict`.
    """

    #: The public function that produced the result.
    call: str = ""
    #: Its arguments, SI.
    arguments: dict = {}
    #: Metrics shown by ``repr``; default the first four.
    _repr_keys: tuple[str, ...] = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "plot" in cls.__dict__:
            cls.plot = _checked_plot(cls.__dict__["plot"])

    @property
    def metrics(self) -> dict:
        """Scalar results, SI, unit-suffixed keys."""
        raise NotImplementedError

    def _series(self):
        raise NotImplementedError

    def to_pandas(self):
        """The time series (or table) behind the metrics, ``quantity_unit`` columns.

        Returns
        -------
        pandas.DataFrame
            With ``attrs["provenance"]``: the call, its arguments, the version and the time.
        """
        df = self._series()
        df.attrs["provenance"] = provenance(self.call, self.arguments)
        return df

    def to_dict(self) -> dict:
        """JSON-ready: the arguments and the metrics (what ``--json`` prints)."""
        return to_jsonable({**self.arguments, **self.metrics})

    def to_file(self, path) -> str:
        """Write :meth:`to_pandas` as ``.csv`` or ``.parquet`` (provenance in the Parquet metadata).

        Parameters
        ----------
        path : str or os.PathLike
            Output file. [-]
        """
        return write_table(self.to_pandas(), path)

    def plot(self, ax=None):
        """Draw the result; return the Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """
        raise NotImplementedError

    def _repr_args(self) -> str:
        return ", ".join(f"{k}={_short(v)}" for k, v in self.arguments.items() if not isinstance(v, (dict, list)))

    def __repr__(self) -> str:
        m = self.metrics
        keys = self._repr_keys or tuple(k for k, v in m.items() if not isinstance(v, (dict, list)))[:4]
        shown = ", ".join(f"{k}={_short(m[k])}" for k in keys if k in m)
        args = self._repr_args()
        return f"{type(self).__name__}({args}{'; ' if args and shown else ''}{shown})"


def check_ax(ax, name: str = "ax"):
    """``ax`` if it is None or a Matplotlib Axes; else an :class:`~mckibben.errors.ArgumentTypeError`."""
    if ax is None:
        return None
    from matplotlib.axes import Axes  # deferred: Matplotlib is heavy and only plots need it

    if isinstance(ax, Axes):
        return ax

    if isinstance(ax, (list, tuple, _np.ndarray)) and len(ax) and all(isinstance(a, Axes) for a in _np.ravel(ax)):
        return ax  # a plot that draws on several axes takes them as a sequence
    raise ArgumentTypeError(f"ax = {ax!r}: not a matplotlib Axes ({type(ax).__name__}); give one, or None for a "
                            "new figure")


def shown_once(fig):
    """``fig``, drawn once in Jupyter whether it is the cell's value or not.

    Under Jupyter's inline backend every figure pyplot holds is drawn when the cell ends, and a
    Figure that is the cell's value is drawn again. The figure stays with pyplot (so
    ``r.plot();`` shows it, as any Matplotlib plot does) and is given an ``_ipython_display_``
    that, when the figure is shown as a value, draws it and lets pyplot go of it, so the end of
    the cell does not draw it a second time. Elsewhere nothing changes.
    """

    if fig is None or "matplotlib.pyplot" not in sys.modules:
        return fig
    import matplotlib  # deferred on purpose: Matplotlib

    if "inline" in str(matplotlib.get_backend()).lower():
        fig._ipython_display_ = functools.partial(_display_once, fig)
    return fig


def _display_once(fig) -> None:
    """Draw ``fig`` as a PNG now, and release it from pyplot so the inline backend does not draw it again."""
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib
    from IPython.core.pylabtools import print_figure  # deferred: only inside a Jupyter kernel
    from IPython.display import display  # deferred on purpose: IPython

    display({"image/png": print_figure(fig, "png")}, raw=True)
    plt.close(fig)


def _checked_plot(plot):
    """Wrap a result's ``plot(ax=None, ...)``: ``ax`` checked first, the figure shown once in Jupyter."""

    @functools.wraps(plot)
    def wrapper(self, ax=None, *args, **kwargs):
        check_ax(ax)
        fig = plot(self, ax, *args, **kwargs)
        return shown_once(fig) if ax is None else fig

    return wrapper


def _short(v) -> str:
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.4g}"
    return repr(v)


#: Column of each sampled signal in a time series' table, ``quantity_unit``: the one naming every
#: :class:`TimeResponse` (simulation, closed loop, device, tool tracking) writes with.
SIGNAL_COLUMNS = {
    "reference": "reference_Pa", "pressure": "pressure_Pa", "pressure_measured": "pressure_measured_Pa",
    "inlet": "inlet_pwm", "bleed": "bleed_pwm", "command": "command_pwm", "length": "length_m",
    "force": "force_N", "tension": "tension_N", "faults": "fault_flags", "temperature": "temperature_K", "air_mass": "air_mass_kg",
    "target": "target_m", "achieved": "achieved_m",
}


#: Channel labels of the signals whose channels are not numbered 1, 2, 3: a tip's coordinates. [-]
SIGNAL_CHANNELS = {"target": ("x", "y", "z"), "achieved": ("x", "y", "z")}


class _Time:
    """``record.time``: the sample times as floats, read from the record's :attr:`TimeResponse.TIME`.

    A non-data descriptor, so a record whose time field is itself called ``time`` keeps it (the
    instance's value comes first).
    """

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        return np.asarray(getattr(obj, obj.TIME), dtype=float)


class TimeResponse:
    """The one time-series type: signals sampled on a time vector (python-control's ``TimeResponseData``).

    Every sampled record of the library builds on it: the batch simulator's
    :class:`~mckibben.plant.simulator.SimResult`, the closed loop's
    :class:`~mckibben.control.loop.LoopRecord` (under :class:`StepResult`, :class:`TrackResult`,
    :class:`Fig13Result`), the device's :class:`~mckibben.rig.device.RigStepResult` and the tool's
    :class:`~mckibben.tool.tracking.TrackingResult` (under :class:`ToolTrackResult`). A subclass
    names its time attribute (:attr:`TIME`) and its signals (:attr:`SIGNALS`, attribute names; the
    column of each is :data:`SIGNAL_COLUMNS`'s), and says how a 2-D signal is laid out
    (:attr:`CHANNELS`): one row per instance, ``(N, n)``, or one column per channel, ``(n, k)``.

    It gives them one interface: ``time`` (the sample times [s], whatever the record calls them),
    :attr:`n_samples`, :attr:`n_instances`,
    :meth:`signal` and :meth:`frame` (one instance as a table with ``time_s`` first).
    """

    #: The attribute holding the sample times. [-]
    TIME: str = "t"
    #: The sampled signals, by attribute name, in table order. [-]
    SIGNALS: tuple[str, ...] = ()
    #: True: a 2-D signal is ``(n, k)``, k channels of one run; False: ``(N, n)``, N instances. [-]
    CHANNELS: bool = False
    #: Column of channel ``label`` of a signal (``pressure_1_Pa``). [-]
    CHANNEL_COLUMN: str = "{quantity}_{label}_{unit}"

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.TIME != "time":  # ``record.time`` beside the record's own name for it (``t``)
            cls.time = _Time()  # type: ignore[attr-defined]

    def _times(self) -> np.ndarray:
        """Sample times, (n,): ``record.time``. [s]"""
        return np.asarray(getattr(self, self.TIME), dtype=float)

    @property
    def n_samples(self) -> int:
        """Number of samples n. [-]"""
        return int(self._times().size)

    def recorded_signals(self) -> tuple[str, ...]:
        """The signals this record holds (those of :attr:`SIGNALS` not left out of the run). [-]"""
        held = []
        for name in self.SIGNALS:
            try:
                value = getattr(self, name)
            except AttributeError:  # a simulation run with record=... leaves series out
                continue
            if value is not None:
                held.append(name)
        return tuple(held)

    @property
    def n_instances(self) -> int:
        """Number of instances N (1 for a single run, whatever its channels). [-]"""
        if self.CHANNELS:
            return 1
        for name in self.recorded_signals():
            a = np.asarray(getattr(self, name))
            if a.ndim == 2:
                return int(a.shape[0])
        return 1

    def signal(self, name: str, i: int = 0) -> np.ndarray:
        """One signal of instance ``i``: (n,), or (n, k) for k channels. [its unit: :data:`SIGNAL_COLUMNS`]

        Parameters
        ----------
        name : str
            A signal of :meth:`recorded_signals`. [-]
        i : int, default 0
            The instance (records of one row per instance). [-]
        """
        if name not in self.recorded_signals():
            raise unknown_name(f"signal of {type(self).__name__}", name, self.recorded_signals())
        a = np.asarray(getattr(self, name))
        if a.ndim == 2 and not self.CHANNELS:
            if not -a.shape[0] <= i < a.shape[0]:
                raise InputError(f"i: instance {i} of {a.shape[0]}")
            return a[i]
        return a

    def _channel_labels(self, name: str, k: int) -> tuple[str, ...]:
        """The labels of a signal's k channels: :data:`SIGNAL_CHANNELS`'s, else 1..k. [-]"""
        return SIGNAL_CHANNELS.get(name, tuple(str(j + 1) for j in range(k)))

    def frame(self, i: int = 0):
        """Instance ``i`` as a DataFrame: ``time_s``, then each signal's :data:`SIGNAL_COLUMNS` column.

        A signal of k channels gives k columns, ``<quantity>_<k>_<unit>`` (``pressure_1_Pa``; a
        tip's ``target_x_m``, :data:`SIGNAL_CHANNELS`).

        Parameters
        ----------
        i : int, default 0
            The instance. [-]
        """
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        data: dict[str, Any] = {"time_s": self._times()}
        for name in self.recorded_signals():
            column = SIGNAL_COLUMNS[name]
            a = self.signal(name, i)
            if a.ndim == 2:
                quantity, _, unit = column.rpartition("_")
                labels = self._channel_labels(name, a.shape[1])
                for k in range(a.shape[1]):
                    data[self.CHANNEL_COLUMN.format(quantity=quantity, label=labels[k], unit=unit)] = a[:, k]
            else:
                data[column] = a
        return pd.DataFrame(data)
