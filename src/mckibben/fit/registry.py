"""The fit registry: every ``mckibben fit`` model and ``mckibben compare`` as library calls.

:func:`fit_table` fits one model to one experiment table (any kind it applies to) and returns a
:class:`TableFit`; :func:`compare_table` fits every applicable model to the same data and scores
it on held-out data (:class:`TableComparison`). Both find the muscle file beside the data when
none is given, and say whether the data are synthetic. Their ``to_dict()`` is what ``--json``
prints.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_real, unknown_name
from mckibben.models import laws
from mckibben.results import FitBase, Result
from mckibben.data import find_muscle_file, muscle_of_table, read_muscle
from mckibben.datasets.campaign import is_synthetic
from mckibben.data import check_muscle, read_table
from mckibben.fit import static
from mckibben.fit.isometric import ALL_MODELS, fit_isometric, fit_isotonic_law
from mckibben.fit.muscle_file import save_muscle_file
from mckibben.fit.isometric import compare_isometric
from mckibben.fit.compare import compare_models
from mckibben.results import to_jsonable
from mckibben.fit.isometric import IsometricFit
from mckibben.fit.direction import DirectionAwareFit, compare_direction_aware, fit_direction_aware
from mckibben.fit.names import FIT_MODELS, NEEDS_MUSCLE  # noqa: F401  (re-exported)



def load_muscle(data: Path, muscle: str | None, required: bool, what: str, table=None, models=()):
    """The muscle file given with --muscle, else ``muscle.toml`` beside the data, else the muscle the
    table itself describes (:func:`mckibben.data.muscle_file.muscle_of_table`), or None. A muscle-file key
    missing names the laws of ``models`` that need it (:attr:`mckibben.models.laws.Law.needs`)."""

    path = Path(muscle) if muscle else find_muscle_file(data)
    if path is None and table is not None:
        spec = muscle_of_table(table)
        if spec is not None:
            return spec
    if path is None:
        if required:
            raise InputError(f"{what}: needs a muscle file; give `muscle` FILE.toml or put muscle.toml beside {data}")
        return None
    return read_muscle(path, _needed_by(models))


def _needed_by(models) -> dict:
    """Muscle-file field -> the registered laws among ``models`` that need it (for its message)."""
    named = [laws.LAWS[n] for n in (laws.ALIASES.get(m, m) for m in models) if n in laws.LAWS]
    fields = {q for law in named for q in law.needs}
    return {q: " and ".join(law.name for law in named if q in law.needs) for q in fields}


def _synthetic(data: Path, spec) -> bool:

    folder = data if data.is_dir() else data.parent
    return bool(spec is not None and spec.synthetic) or is_synthetic(folder) or is_synthetic(folder.parent)


def _run_fit(data: Path, model: str, muscle: str | None = None, kind: str | None = None,
             split_pressure: float | None = None, tare: str = "none", save: str | None = None,
             rest_length: float | None = None, rails: str = "keep", pressure_zero: str = "none",
             select: dict | None = None, columns: dict | None = None,
             direction_aware: str | None = None, rest_lengths: str = "nominal",
             min_samples: int = 0, drift: bool = False) -> tuple[dict, list]:
    """One fit: the JSON-ready dict and the fit objects."""

    if model not in FIT_MODELS and model not in laws.ALIASES:  # an old law name is read (deprecated)
        raise unknown_name("model", model, FIT_MODELS)
    table = read_table(data, kind, select, columns)
    isometric = table.kind == "isometric"
    spec = load_muscle(data, muscle, model in NEEDS_MUSCLE or isometric, f"fit {model}", table, (model,))
    if spec is not None:
        check_muscle(table, spec)
    if tare != "none" and not isometric:
        raise InputError(f"tare: applies to isometric tables; {data} is a {table.kind} table")
    if (rails != "keep" or pressure_zero != "none") and not isometric:
        raise InputError(f"rails/`pressure_zero`: apply to isometric tables; {data} is a {table.kind} table")
    if drift and direction_aware is None:
        raise InputError("drift: the run-drift nuisance is fitted with a direction-aware form; give `direction_aware`")
    if min_samples != 0 and not isometric:
        raise InputError(f"min_samples: selects the binned points of an isometric table; {data} is a {table.kind} table")
    if save is not None and not isometric:
        raise InputError(f"save: writes a force law fitted to an isometric table; {data} is a {table.kind} table")
    if save is not None and spec.outer_diameter is None:  # a table's rest length stood for the muscle file
        raise InputError(f"save: a muscle file of the {model} force law needs the muscle's outer diameter (its "
                         f"chamber), which {spec.path or data} does not give; give `muscle` FILE.toml with "
                         f"outer_diameter_mm")
    if rest_lengths != "nominal" and save is not None:
        raise InputError("save: writes a family law at recorded rest lengths; fit with rest_lengths 'nominal' to save")
    if rest_length is not None and save is None:
        raise InputError("rest_length: sets the rest length of the muscle a family law's file describes; give `save`")
    law = laws.LAWS.get(laws.ALIASES.get(model, model))
    own = law.own_fit if law is not None and not isometric else None  # the law's own procedure (Law.own_fit)
    if split_pressure is not None:
        check_real(split_pressure, "split_pressure", lo=0.0, unit="Pa")
        if own is None or not own.split_pressure:
            splitters = {n: lw.own_fit.tables for n, lw in laws.own_fit_laws().items() if lw.own_fit.split_pressure}
            kinds = sorted({k.replace("_", "-") for t in splitters.values() for k in t}, reverse=True)
            raise InputError(f"split_pressure: splits the data of the {' or '.join(splitters)} model on an "
                             f"{' or '.join(kinds)} table; fit {model} on a {table.kind} table has no split")
    if rest_length is not None:
        check_real(rest_length, "rest_length", lo=0.0, lo_open=True, unit="m")
    extra: dict = {}
    if direction_aware is not None:  # a law with hysteresis inside it (mckibben.fit.direction)
        if not isometric:
            raise InputError(f"direction_aware: fits a law to inflate and deflate rows of an isometric table; {data} is "
                             f"a {table.kind} table")
        fit = fit_direction_aware(table, spec, model, direction_aware, tare, rails, pressure_zero,
                                  min_samples=min_samples, drift=drift)
        out = {"file": str(data), "kind": table.kind, "model": model, "muscle": spec.id,
               "synthetic": _synthetic(data, spec), **_table_notes(table), "tare": fit.tare, "fits": [fit.to_dict()]}
        _update_keeping_table_notes(out, fit.to_dict())
        if save is not None:  # the law with its operator (save_muscle_file)
            out["saved"] = str(save_muscle_file(save, spec, fit, rest_length))
        return out, [fit]
    if isometric:
        if model not in ALL_MODELS and model not in laws.ALIASES:
            raise InputError(f"fit {model}: not a force model for an isometric table; use one of {', '.join(ALL_MODELS)}")
        fit = fit_isometric(table, spec, model, tare, rails, pressure_zero, rest_lengths=rest_lengths,
                            min_samples=min_samples)
        out = {"file": str(data), "kind": table.kind, "model": model, "muscle": spec.id,
               "synthetic": _synthetic(data, spec), **_table_notes(table), "tare": fit.tare, "fits": [fit.to_dict()]}
        _update_keeping_table_notes(out, fit.to_dict())
        if save is not None:
            out["saved"] = str(save_muscle_file(save, spec, fit, rest_length))
        return out, [fit]
    if model == "kinematic":
        fits = [static.fit_kinematic(table, spec)]
    elif model == "cubic":
        fits = list(static.fit_cubics(table).values())
    elif model == "surface":
        fits = [static.fit_surface(table)]
    elif model == "force-contraction":
        fits = list(static.fit_force_contraction(table, spec).values())
    elif own is not None and law is not None:  # the law's own procedure (it checks the table kind)
        if split_pressure is not None:
            p = table.data["pressure"].to_numpy()
            if not float(p.min()) <= split_pressure < float(p.max()):
                raise InputError(f"split_pressure: {split_pressure / 1e6:g} MPa is outside the pressures of {data} "
                                 f"({p.min() / 1e6:g}..{p.max() / 1e6:g} MPa): one range would get no point")
        fits, extra = static.OWN_FITS[law.name](table, spec, split_pressure)
    elif model in laws.fit_laws() or model in laws.ALIASES:  # every registered law: through its force
        fits = [fit_isotonic_law(table, spec, model)]
    else:
        fits = list(static.fit_first_order(table).values())
    out = {"file": str(data), "kind": table.kind, "model": model, "muscle": spec.id if spec else None,
           "synthetic": _synthetic(data, spec), **_table_notes(table), **extra, "fits": [f.to_dict() for f in fits]}
    if len(fits) == 1:
        _update_keeping_table_notes(out, fits[0].to_dict())
    else:
        out["flags"] = sorted({fl for f in fits for fl in f.flags})
    return out, fits


def _update_keeping_table_notes(out: dict, fit: dict) -> None:
    """Lift one fit's fields to the top of ``out``; its ``notes`` (what the fit could not tell, e.g.
    ``correlated_parameters``) follow the table reader's notes (columns kept aside) instead of
    replacing them."""
    notes = list(out.get("notes", [])) + list(fit.get("notes", []))
    out.update({k: v for k, v in fit.items() if k not in ("model", "notes")})
    if notes:
        out["notes"] = notes


def _table_notes(table) -> dict:
    """What a result says of how its table was read: ``selected`` rows and ``notes`` (columns kept aside)."""
    return {**({"selected": dict(table.selected)} if table.selected else {}),
            **({"notes": list(table.notes)} if table.notes else {})}


def _isometric_table(data: Path, select: dict | None = None, columns: dict | None = None):
    """The table if DATA is an isometric table file, else None (a folder or another kind)."""

    data = Path(data)
    if data.is_dir():
        return None
    table = read_table(data, None, select, columns)
    return table if table.kind == "isometric" else None


def _compare_isometric(table, data: Path, muscle: str | None, cv: str, tare: str, rails: str = "keep",
                       pressure_zero: str = "none", direction_aware: str | None = None,
                       rest_lengths: str = "nominal", min_samples: int = 0, drift: bool = False) -> dict:
    """Compare every force model on an isometric table; return the JSON-ready result."""

    spec = load_muscle(data, muscle, True, "compare", table)
    check_muscle(table, spec)
    res = compare_isometric(table, spec, cv, tare, rails=rails, pressure_zero=pressure_zero,
                            rest_lengths=rest_lengths, min_samples=min_samples)
    out = {"file": str(data), "kind": "isometric", "muscle": spec.id, "synthetic": _synthetic(data, spec),
           **_table_notes(table), "quantity": "force at held lengths and pressures (all rows)", **res.to_dict()}
    if direction_aware is not None:  # each law beside its direction-aware form (mckibben.fit.direction)
        out["direction_aware"] = compare_direction_aware(table, spec, structure=direction_aware, tare=tare,
                                                         rails=rails, pressure_zero=pressure_zero,
                                                         min_samples=min_samples, drift=drift)
    return out


#: Distinct pressures (above 0) an isotonic table needs for `compare`: a cubic in pressure and a
#: check of its fit (as :func:`mckibben.fit.static.fit_cubics` requires), plus one left out by CV.
COMPARE_MIN_PRESSURES = 6


def _compare_isotonic(data: Path, muscle: str | None = None, select: dict | None = None,
                      columns: dict | None = None) -> dict:
    """Run the comparison; return the JSON-ready result."""

    data = Path(data)
    folder = data if data.is_dir() else data.parent
    iso_path = folder / "isotonic.csv" if data.is_dir() else data
    if data.is_dir() and not iso_path.is_file():
        raise InputError(f"compare: {data} holds no isotonic.csv")
    table = read_table(iso_path, None, select, columns)
    spec = load_muscle(iso_path, muscle, True, "compare")
    check_muscle(table, spec)
    braid = None
    braid_path = folder / "braid_angle.csv"
    if braid_path.is_file():
        b = read_table(braid_path)
        if {"pressure", "load"} <= set(b.data.columns):
            check_muscle(b, spec)
            braid = b
    pressures = table.data["pressure"].to_numpy()
    distinct = np.unique(np.round(pressures[pressures > 0], 3)).size
    if distinct < COMPARE_MIN_PRESSURES:
        raise InputError(f"compare: {iso_path} has {distinct} distinct pressures above 0; comparing the models "
                         f"(cubics in pressure, cross-validated) needs at least {COMPARE_MIN_PRESSURES}")
    res = compare_models(table, spec, braid)
    return {"file": str(iso_path), "muscle": spec.id, "synthetic": _synthetic(iso_path, spec), **_table_notes(table),
            "quantity": "length under load at a pressure (rows with P > 0); relative errors on contraction",
            "n_points": res["n_points"], "cv_method": res["cv_method"],
            "models": [s.to_dict() for s in res["scores"]]}


@dataclass(repr=False)
class TableFit(FitBase):
    """One model fitted to one experiment table (:func:`fit_table`).

    A fit-family member (:class:`~mckibben.results.FitBase`): its words are its fits' joined, in
    order; a model fitted per load or per pressure (several fits) names each parameter
    ``<name> (<condition>)`` and its :meth:`to_pandas` has a ``condition`` column.

    Attributes
    ----------
    summary : dict
        What ``mckibben fit --json`` prints: file, kind, model, muscle, synthetic, the fits'
        parameters, standard errors, intervals, statistics and flags.
    fits : list
        The fit objects (:class:`~mckibben.fit.core.FitResult`,
        :class:`~mckibben.fit.isometric.IsometricFit` or
        :class:`~mckibben.fit.direction.DirectionAwareFit`).
    """

    summary: dict
    fits: list = field(default_factory=list)

    call = "mckibben.fit.registry.fit_table"

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """The data file and the model."""
        return {"file": self.summary["file"], "model": self.summary["model"]}

    @staticmethod
    def _condition(fit) -> str:
        cond = getattr(fit, "condition", None) or {}
        return ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in cond.items())

    @property
    def names(self) -> tuple:
        """The fits' parameter names; ``<name> (<condition>)`` when there are several fits. [-]"""
        if len(self.fits) == 1:
            return tuple(self.fits[0].names)
        return tuple(f"{n} ({self._condition(f)})" for f in self.fits for n in f.names)

    @property
    def units(self) -> tuple:
        """Each parameter's unit (its fit's). [-]"""
        return tuple(u for f in self.fits for u in f.units)

    def _joined(self, word: str) -> np.ndarray:
        parts = [np.asarray(getattr(f, word), dtype=float) for f in self.fits]
        return np.concatenate(parts) if parts else np.zeros(0)

    @property
    def values(self) -> np.ndarray:
        """Parameter values, the fits' in order. [parameter units]"""
        return self._joined("values")

    @property
    def stderr(self) -> np.ndarray:
        """Standard errors, the fits' in order. [parameter units]"""
        return self._joined("stderr")

    @property
    def ci95(self) -> np.ndarray:
        """95 % intervals, shape (p, 2): each fit's own (its t quantile). [parameter units]"""
        parts = [np.asarray(f.ci95, dtype=float).reshape(-1, 2) for f in self.fits]
        return np.vstack(parts) if parts else np.zeros((0, 2))

    @property
    def residuals(self) -> np.ndarray:
        """Measured − fitted per point, the fits' in order. [response unit]"""
        return self._joined("residuals")

    @property
    def n_points(self) -> int:
        """Points fitted, all fits. [-]"""
        return int(sum(f.n_points for f in self.fits))

    @property
    def dof(self) -> int:
        """Residual degrees of freedom, all fits. [-]"""
        return int(sum(f.dof for f in self.fits))

    @property
    def r2(self) -> float:
        """R² of a single fit (NaN for several: each has its own, in :attr:`summary`). [-]"""
        return float(self.fits[0].r2) if len(self.fits) == 1 else float("nan")

    @property
    def aic(self) -> float:
        """The fits' AIC summed (independent fits: their log-likelihoods add). [-]"""
        return float(sum(f.aic for f in self.fits)) if self.fits else float("nan")

    @property
    def flags(self) -> tuple:
        """The fit's flags (all fits' for a per-load or per-pressure model)."""
        return tuple(self.summary.get("flags", []))

    @property
    def notes(self) -> tuple:
        """The table reader's and the fits' notes. [-]"""
        return tuple(self.summary.get("notes", []))

    @property
    def source(self) -> str:
        """The table file. [-]"""
        return str(self.summary["file"])

    @property
    def metrics(self) -> dict:
        """R², RMS residual, number of points and flags (of a single fit; else the flags)."""
        keys = [k for k in self.summary if k.startswith(("rmse", "residual_rms"))] + ["r2", "n_points", "flags"]
        return {k: self.summary[k] for k in keys if k in self.summary}

    def to_dict(self) -> dict:
        """JSON-ready (what ``--json`` prints)."""

        return to_jsonable(self.summary)

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        frames = [f._series().assign(condition=self._condition(f)) for f in self.fits]
        df = pd.concat(frames, ignore_index=True) if frames else super()._series()
        return df[["condition"] + [c for c in df.columns if c != "condition"]] if frames else df

    def plot(self, ax=None):
        """An isometric fit's force curves (:meth:`IsometricFit.plot`); else the residuals per point.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib


        if self.fits and isinstance(self.fits[0], (IsometricFit, DirectionAwareFit)):
            return self.fits[0].plot(ax)
        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.5))
        for f in self.fits:
            ax.plot(f.residuals, ".", ms=3, label=str(f.condition) if f.condition else None)
        ax.set(xlabel="point", ylabel=f"residual [{self.fits[0].response}]" if self.fits else "residual")
        return ax.figure


def _data_path(data) -> Path:
    """``data`` as a path: the fits read a table file, whose name, folder and muscle file they report."""
    if isinstance(data, (str, os.PathLike)) and str(data):
        return Path(data)
    hint = ("; write it to a file first (DataFrame.to_csv) with quantity_unit column names"
            if type(data).__name__ == "DataFrame" else "")
    raise ArgumentTypeError(f"data = {type(data).__name__ if data is not None else None}: not a table file path "
                            f"(str or os.PathLike to a .csv or .parquet){hint}")


def fit_table(data, model: str, muscle: str | None = None, kind: str | None = None,
              split_pressure: float | None = None, tare: str = "none", save: str | None = None,
              rest_length: float | None = None, rails: str = "keep", pressure_zero: str = "none",
              select: dict | None = None, columns: dict | None = None,
              direction_aware: str | None = None, rest_lengths: str = "nominal", min_samples: int = 0,
              drift: bool = False) -> TableFit:
    """Fit one model to one experiment table: parameters, standard errors, 95 % intervals, flags.

    Parameters
    ----------
    data : str or pathlib.Path
        The table (.csv or .parquet). [-]
    model : str
        A key of :data:`FIT_MODELS`. [-]
    muscle : str, optional
        Muscle file (TOML); default ``muscle.toml`` beside the data. [-]
    kind : str, optional
        Experiment kind, if neither the file name nor its columns tell. [-]
    split_pressure : float, optional
        Spring model: the low/high range split (default: the median pressure). [Pa]
    tare : {"none", "lowest", "column"}, default "none"
        Isometric tables: :func:`mckibben.data.preprocessing.apply_tare`. [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Isometric tables: rows at a sensor's rail (:func:`mckibben.fit.isometric.isometric_points`). [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        Isometric tables: the pressure transducer's zero (:func:`mckibben.data.preprocessing.apply_pressure_zero`). [-]
    rest_length : float, optional
        With ``save`` and a family law: the rest length of the muscle the saved file describes
        (default the muscle file's nominal length). [m]
    save : str, optional
        Isometric tables: write a muscle file with the fitted force law here; with
        ``direction_aware``, the law and its operator (:func:`mckibben.fit.muscle_file.save_muscle_file`). [-]
    select : dict, optional
        Column -> value: fit only the rows holding these values, e.g. one muscle of a table of
        several (:func:`mckibben.data.read_table`). [-]
    columns : dict, optional
        The file's column names -> the schema's, e.g. ``{"phase": "direction"}``. [-]
    direction_aware : {"play", "friction"}, optional
        Isometric tables: fit the law's direction-aware form of this structure
        (:func:`mckibben.fit.direction.fit_direction_aware`); None: the plain law. [-]

    rest_lengths : {"nominal", "fitted"}, default "nominal"
        Isometric family tables: each muscle's rest length as recorded or fitted
        (:func:`mckibben.fit.isometric.fit_points`); not with ``save``. [-]
    min_samples : int, default 0
        Isometric tables binned from a stepped protocol: points of fewer readings than this (the
        column ``n_samples``) are a step passing through, left out of the fit
        (:func:`mckibben.fit.isometric.transition_rows`); 0 keeps every point. [-]
    drift : bool, default False
        With ``direction_aware``: fit the run-drift nuisance too
        (:func:`mckibben.fit.direction.fit_direction_aware`). [-]

    Returns
    -------
    TableFit
        With no muscle file, a table giving one muscle's rest length stands for it
        (:func:`mckibben.data.muscle_file.muscle_of_table`).
    """
    out, fits = _run_fit(_data_path(data), model, muscle, kind, split_pressure, tare, save, rest_length, rails,
                         pressure_zero, select, columns, direction_aware, rest_lengths, min_samples, drift)
    return TableFit(out, fits)


@dataclass(repr=False)
class TableComparison(Result):
    """Every applicable model on the same data, scored on held-out data (:func:`compare_table`).

    Attributes
    ----------
    summary : dict
        What ``mckibben compare --json`` prints.
    """

    summary: dict

    call = "mckibben.fit.registry.compare_table"

    @property
    def arguments(self) -> dict:
        """The data file."""
        return {"file": self.summary["file"]}

    @property
    def metrics(self) -> dict:
        """The best model on held-out data (isometric), the number of points (isotonic)."""
        return {k: self.summary[k] for k in ("best", "cv", "cv_method", "peak_force_N", "n_points") if k in self.summary}

    def to_dict(self) -> dict:
        """JSON-ready (what ``--json`` prints)."""

        return to_jsonable(self.summary)

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        return pd.DataFrame(self.summary["models"])

    def plot(self, ax=None):
        """Held-out error per model (bar chart).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw; default a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.5))
        df = self._series()
        key = "cv_rmse_pct_of_peak" if "cv_rmse_pct_of_peak" in df else "cv_rmse_m"
        ax.bar(df["model"], df[key].astype(float))
        ax.set_ylabel(key)
        ax.tick_params(axis="x", labelrotation=20)
        return ax.figure


def compare_table(data, muscle: str | None = None, cv: str | None = None, tare: str = "none", rails: str = "keep",
                  pressure_zero: str = "none", select: dict | None = None,
                  columns: dict | None = None, direction_aware: str | None = None,
                  rest_lengths: str = "nominal", min_samples: int = 0, drift: bool = False) -> TableComparison:
    """Fit every applicable model to the same data and score it on held-out data.

    An isometric table: every force model, folds by held length (default) or trial
    (:func:`mckibben.fit.isometric.compare_isometric`). An isotonic table or a muscle folder
    holding ``isotonic.csv`` (and ``braid_angle.csv``): the length models
    (:func:`mckibben.fit.compare.compare_models`).

    Parameters
    ----------
    data : str or pathlib.Path
        A table or a muscle folder. [-]
    muscle : str, optional
        Muscle file; default ``muscle.toml`` beside the data. [-]
    cv : {"leave-one-length-out", "leave-one-trial-out"}, optional
        Isometric tables only. [-]
    tare : {"none", "lowest", "column"}, default "none"
        Isometric tables only. [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Isometric tables: rows at a sensor's rail. [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        Isometric tables: the pressure transducer's zero. [-]
    select : dict, optional
        Column -> value: compare on the rows holding these values (one muscle of several). [-]
    columns : dict, optional
        The file's column names -> the schema's, e.g. ``{"phase": "direction"}``. [-]
    direction_aware : {"play", "friction"}, optional
        Isometric tables: also score each law beside its direction-aware form of this structure,
        each trial held out in turn, by the up/down gap (RMS and max of the gap error; key
        ``direction_aware``, :func:`mckibben.fit.direction.compare_direction_aware`). [-]
    rest_lengths : {"nominal", "fitted"}, default "nominal"
        Isometric family tables: each muscle's rest length as recorded or fitted
        (:func:`mckibben.fit.isometric.fit_points`). [-]
    min_samples : int, default 0
        Isometric tables: points of fewer readings than this (the column ``n_samples``) are left
        out of every fit and of the up/down gap (:func:`mckibben.fit.isometric.transition_rows`). [-]
    drift : bool, default False
        With ``direction_aware``: the direction-aware forms carry the run-drift nuisance, fitted on
        the training trials (:func:`mckibben.fit.direction.heldout_gap`). [-]

    Returns
    -------
    TableComparison
    """
    data = _data_path(data)
    if drift and direction_aware is None:
        raise InputError("drift: the run-drift nuisance is fitted with a direction-aware form; give `direction_aware`")
    iso = _isometric_table(data, select, columns)
    if iso is not None:
        return TableComparison(_compare_isometric(iso, data, muscle, cv or "leave-one-length-out", tare, rails,
                                                  pressure_zero, direction_aware, rest_lengths, min_samples, drift))
    if direction_aware is not None:
        raise InputError("direction_aware: scores laws on the inflate and deflate rows of an isometric table")
    if min_samples != 0:
        raise InputError("min_samples: selects the binned points of an isometric table; the isotonic comparison "
                         "takes every point")
    if cv is not None or tare != "none" or rails != "keep" or pressure_zero != "none" or rest_lengths != "nominal":
        raise InputError("cv/`tare`: apply to isometric tables; the isotonic comparison chooses its own folds")
    return TableComparison(_compare_isotonic(data, muscle, select, columns))
