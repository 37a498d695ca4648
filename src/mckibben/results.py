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

Fitted models are one family, :class:`FitBase` (lmfit's ``ModelResult`` in spirit): the
least-squares record :class:`~mckibben.fit.core.FitResult`, the step and fill fits, the spring
model's, the hysteresis operator's, the force laws' and the table fit all give ``names``,
``values``, ``stderr``, ``ci95``, ``params``, ``flags``, ``notes``, ``n_points``,
``residual_rms``, ``aic`` and ``source``; their ``to_pandas`` is the parameter table.
"""

from __future__ import annotations

import json
import math
import os
from datetime import datetime, timezone
from pathlib import Path
from collections.abc import Callable
from typing import Any, Generic, TypeVar

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


#: Unit tokens a parameter name may end with (``dead_time_s``, ``a30_N_per_MPa3``, ``wn_rad_s``):
#: :attr:`FitBase.units` reads a parameter's unit from the first of them in its name. [-]
UNIT_TOKENS = frozenset({"m", "m2", "m3", "mm", "N", "Pa", "MPa", "kPa", "s", "rad", "deg", "kg", "K", "J", "W",
                         "count", "pwm", "per"})


def unit_of_name(name: str) -> str:
    """The unit suffix of a parameter name: ``"a30_N_per_MPa3"`` → ``"N_per_MPa3"``, ``"zeta"`` → ``""``.

    Parameters
    ----------
    name : str
        A parameter name, ``quantity_unit`` (the quantity's first word is never read as a unit). [-]
    """
    words = str(name).split("_")
    for i in range(1, len(words)):
        if words[i] in UNIT_TOKENS:
            return "_".join(words[i:])
    return ""


_T = TypeVar("_T")


class _Word(Generic[_T]):
    """One word of :class:`FitBase`'s vocabulary, computed unless the fit holds it itself.

    A non-data descriptor (as :class:`_Time`): a fit that stores the word as a field (a dataclass's
    ``names``, ``flags``) keeps its own value. Read on the class it raises AttributeError, so a
    dataclass field of the same name is a plain field, not one whose default is this descriptor.
    """

    def __init__(self, func: Callable[[Any], _T]) -> None:
        self.func = func
        self.__doc__ = func.__doc__
        self.name = func.__name__

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, obj, owner=None) -> _T:
        if obj is None:
            raise AttributeError(f"{getattr(owner, '__name__', owner)}.{self.name}: a word of a fit instance")
        return self.func(obj)


class FitBase(Result):
    """Base of every fitted model: one vocabulary for a fit's parameters (lmfit's ``ModelResult`` in spirit).

    A fit gives, whatever it fitted (a force law, a step response, a hysteresis operator):

    ``names``
        Parameter names, ``quantity_unit`` (``"k2_m"``, ``"tau_s"``). [-]
    ``values``, ``stderr``
        Values and standard errors, arrays in the order of ``names`` (NaN: a parameter held at a
        bound). [parameter units]
    ``ci95``
        95 % intervals, shape (p, 2): ``values ∓ t_quantile·stderr``, Student's t with ``dof``
        degrees of freedom. [parameter units]
    ``params``
        ``{name: value}``; ``fit[name]`` is one value, ``fit.se(name)`` its standard error.
    ``units``
        Each parameter's unit, read from its name (:func:`unit_of_name`). [-]
    ``residuals``, ``n_points``, ``dof``, ``residual_rms``, ``r2``
        Measured − fitted per point, their count, n − p, their root mean square and the
        coefficient of determination. [response unit]
    ``aic``
        Akaike's criterion of a least-squares fit, n·ln(RSS/n) + 2p (NaN where the fit is no
        plain least squares: priors, censored points). [-]
    ``flags``, ``notes``
        Why its predictions deserve doubt; what is worth reporting without doubting them.
    ``source``
        The data file fitted (empty when arrays were given).

    and :attr:`metrics`, :meth:`to_pandas` (the parameter table: ``name``, ``value``, ``stderr``,
    ``ci95_low``, ``ci95_high``, ``unit``), :meth:`to_dict`, :meth:`to_file` and :meth:`plot`
    (the residuals, unless a fit draws more).

    A subclass gives ``names``, ``values``, ``stderr`` and ``residuals`` (fields or properties),
    or wraps a least-squares record (a :class:`~mckibben.fit.core.FitResult`) in the attribute
    named by :attr:`RECORD`, whose words it then speaks. Any word it holds itself comes first.
    """

    #: The attribute holding the least-squares record this fit wraps (``"result"``); empty: none. [-]
    RECORD: str = ""

    def _record(self):
        if not self.RECORD:
            raise NotImplementedError(f"{type(self).__name__}: give names, values, stderr and residuals, or RECORD")
        return getattr(self, self.RECORD)

    @_Word
    def names(self) -> tuple:
        """Parameter names, ``quantity_unit``. [-]"""
        return tuple(self._record().names)

    @_Word
    def values(self) -> np.ndarray:
        """Parameter values, in the order of :attr:`names`. [parameter units]"""
        return np.asarray(self._record().values, dtype=float)

    @_Word
    def stderr(self) -> np.ndarray:
        """Standard errors of the parameters (NaN: held at a bound). [parameter units]"""
        return np.asarray(self._record().stderr, dtype=float)

    @_Word
    def residuals(self) -> np.ndarray:
        """Measured − fitted response per point. [response unit]"""
        return np.asarray(self._record().residuals, dtype=float)

    @_Word
    def flags(self) -> tuple:
        """Why the fit's predictions deserve doubt (empty: nothing found). [-]"""
        return tuple(self._record().flags) if self.RECORD else ()

    @_Word
    def notes(self) -> tuple:
        """What is worth reporting but casts no doubt on the predictions by itself. [-]"""
        return tuple(self._record().notes) if self.RECORD else ()

    @_Word
    def source(self) -> str:
        """The data file fitted (empty when arrays were given). [-]"""
        return str(self._record().source) if self.RECORD else ""

    @_Word
    def n_points(self) -> int:
        """Number of points fitted. [-]"""
        return int(self._record().n_points) if self.RECORD else int(np.size(self.residuals))

    @_Word
    def dof(self) -> int:
        """Residual degrees of freedom n − p. [-]"""
        return int(self._record().dof) if self.RECORD else self.n_points - len(self.names)

    @_Word
    def t_quantile(self) -> float:
        """Student's t quantile of a two-sided 95 % interval with :attr:`dof` degrees of freedom. [-]"""
        if self.RECORD:
            return float(self._record().t_quantile)
        from scipy import special  # deferred on purpose: SciPy
        return float(special.stdtrit(max(self.dof, 1), 0.975))  # t quantile, as stats.t.ppf

    @_Word
    def ci95(self) -> np.ndarray:
        """95 % confidence intervals, shape (p, 2). [parameter units]"""
        if self.RECORD:
            return np.asarray(self._record().ci95, dtype=float)
        half = self.t_quantile * self.stderr
        return np.column_stack([self.values - half, self.values + half])

    @_Word
    def r2(self) -> float:
        """Coefficient of determination (NaN when unknown). [-]"""
        return float(self._record().r2) if self.RECORD else float("nan")

    @_Word
    def aic(self) -> float:
        """Akaike information criterion n·ln(RSS/n) + 2p (lower is better; NaN where undefined). [-]"""
        if self.RECORD:
            return float(self._record().aic)
        return least_squares_aic(self.residuals, len(self.names))

    @property
    def params(self) -> dict:
        """``{name: value}``. [parameter units]"""
        return {n: float(v) for n, v in zip(self.names, self.values)}

    @property
    def units(self) -> tuple:
        """Each parameter's unit, from its name (:func:`unit_of_name`). [-]"""
        return tuple(unit_of_name(n) for n in self.names)

    @property
    def residual_rms(self) -> float:
        """Root mean square of the residuals. [response unit]"""
        r = np.asarray(self.residuals, dtype=float)
        return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")

    def __getitem__(self, name: str) -> float:
        return float(self.values[self._index(name)])

    def _index(self, name: str) -> int:
        if name not in self.names:
            raise unknown_name(f"parameter of {type(self).__name__}", name, self.names)
        return list(self.names).index(name)

    def se(self, name: str) -> float:
        """Standard error of one parameter.

        Parameters
        ----------
        name : str
            Parameter name (one of :attr:`names`). [-]
        """
        return float(self.stderr[self._index(name)])

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """What was fitted: the data file."""
        return {"source": self.source}

    @property
    def metrics(self) -> dict:
        """``residual_rms``, ``r2``, ``aic``, ``n_points`` and ``flags`` (the record's, unit-suffixed, for a wrapper)."""
        if self.RECORD:
            return dict(self._record().metrics)
        return {"residual_rms": self.residual_rms, "r2": self.r2, "aic": self.aic, "n_points": self.n_points,
                "flags": list(self.flags)}

    def _series(self):
        """The parameter table: name, value, stderr, 95 % interval and unit per parameter."""
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        ci = np.asarray(self.ci95, dtype=float).reshape(-1, 2)
        return pd.DataFrame({"name": list(self.names), "value": np.asarray(self.values, dtype=float),
                             "stderr": np.asarray(self.stderr, dtype=float), "ci95_low": ci[:, 0],
                             "ci95_high": ci[:, 1], "unit": list(self.units)})

    def to_pandas(self):
        """The parameter table: ``name``, ``value``, ``stderr``, ``ci95_low``, ``ci95_high``, ``unit``.

        Returns
        -------
        pandas.DataFrame
            One row per parameter, with ``attrs["provenance"]``.
        """
        return super().to_pandas()

    def to_dict(self) -> dict:
        """JSON-ready: parameters, standard errors, 95 % intervals, statistics, flags and notes."""
        return to_jsonable({"parameters": self.params, "stderr": dict(zip(self.names, self.stderr)),
                            "ci95": dict(zip(self.names, np.asarray(self.ci95).tolist())), **self.metrics,
                            "notes": list(self.notes), "source": self.source})

    def plot(self, ax=None):
        """The residuals against the point's index, their RMS in the title.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
        r = np.asarray(self.residuals, dtype=float)
        ax.plot(np.arange(r.size), r, ".", ms=3)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set(xlabel="point", ylabel="measured − fitted",
               title=f"{type(self).__name__}: residual RMS {self.residual_rms:.4g}")
        return ax.figure


def least_squares_aic(residuals, k: int) -> float:
    """Akaike's criterion of a least-squares fit under Gaussian noise: n·ln(RSS/n) + 2k.

    Parameters
    ----------
    residuals : array_like
        Measured − fitted per point. [response unit]
    k : int
        Number of fitted parameters. [-]

    References
    ----------
    [akaike1974] Akaike, H. (1974), A new look at the statistical model identification, IEEE Trans.
    Automatic Control AC-19, 716–723; −2·ln L of Gaussian noise at its fitted variance is n·ln(RSS/n)
    up to a constant.
    """
    r = np.asarray(residuals, dtype=float)
    n = r.size
    if n == 0:
        return float("nan")
    return float(n * math.log(max(float(r @ r), 1e-300) / n) + 2 * k)
