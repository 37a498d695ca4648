"""Nested cross-validation of ``compare``'s choice: the error of the model it would pick, honestly held out.

``mckibben compare`` scores every candidate on the same folds and picks ``best``, the smallest
held-out error among the fits that carry no flag (:func:`mckibben.fit.isometric.best_of`). That
choice is made on the very folds whose errors are reported, so the best's held-out error is the
minimum of several noisy estimates: optimistic, the more so the more candidates there are and the
closer they score (Varma & Simon (2006) [varma2006]; Cawley & Talbot (2010) [cawley2010]).

:func:`compare_nested` takes the choice out of the held-out data. For each *outer* fold (a held
length, a trial or a muscle, the folds of ``compare``'s ``cv``) the whole selection runs again on
the other folds only: the outer training rows, read as a table of their own (their sensor
corrections found on them), are compared by :func:`~mckibben.fit.isometric.compare_isometric`
with the same candidates, the same ``cv`` on the inner folds, and the same ``best`` rule. The
chosen candidate, refitted on the outer training data, predicts the outer fold; that fit and its
score are the fold's entry in the comparison on all the data (``compare``'s own fold loop: the same
fit of the same rows, so a candidate's outer score is one number however it was chosen). So the
nested and the non-nested figures differ only in *which* candidate scores each fold. The outer
score keeps compare's sensor corrections, found on the whole table (a pressure zero ``"lowest"``,
a rail); the selection finds its own on the outer training rows (with ``rails="exclude"``, a
held-out fold's rows at the rail stay in those rows and are excluded there again).

**Candidates.** One data structure, :class:`Candidate`: each model ``compare`` scores
(:data:`~mckibben.fit.isometric.FAMILY_MODELS` on a family table, else
:data:`~mckibben.fit.isometric.ALL_MODELS`, or ``models``) under each of the given rest-length
options (a family's rest lengths as recorded, or fitted per muscle). A choice between options is a
choice made on the data, and the nested figure pays for it. The tare is not a candidate: it
changes the force the models are scored against (raw or tared), so two tares' errors are not
errors of one target (benchmarks/RESULTS.md, "The zero of each run, fitted").

**Measures** (all held out, none can cancel): per outer fold the RMS and the largest |error|, in N
and as % of the held-out muscle's peak |force| (the table's peak for one muscle), as ``compare``'s
folds give them; pooled, the RMS over every held-out point (the folds' mean squares weighted by
their points) and the largest |error|, as % of the table's peak; the median and the worst fold.
The same pooling for the non-nested best (its own folds), and the *optimism*: nested minus
non-nested, in points of % of peak (positive: the non-nested figure flattered the choice).

**The direction-aware form** (:func:`compare_direction_aware_nested`, ``compare --direction-aware
--nested``): the same idea on the up/down gap, each trial held out. Candidates are
:class:`GapCandidate` (law × structure × run drift); the fold loop is
:func:`~mckibben.fit.direction.heldout_gap`'s at both levels (outer: every trial of the table;
inner: every outer training trial, on those trials alone), the score its gap error RMS pooled over
every held-out run (never a signed mean), the choice ``best``'s rule on it.

References
----------
Varma & Simon (2006) [varma2006]: nested cross-validation against the optimism of the chosen
model's cross-validated error. Cawley & Talbot (2010) [cawley2010]: selection bias in
performance evaluation.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mckibben.data import check_muscle
from mckibben.data.muscle_file import MuscleSpec
from mckibben.data.tables import Table
from mckibben.errors import InputError, check_instance, unknown_name
from mckibben.fit.direction import HeldoutGap, _no_fitted_tare, gap_laws, gap_scores, heldout_gap
from mckibben.fit.isometric import (CV_METHODS, REST_LENGTHS, ModelComparison, _fold_keys, best_of,
                                    compare_isometric, isometric_points, transition_rows)
from mckibben.models.hysteresis.direction import DEFAULT_STRUCTURE, STRUCTURES
from mckibben.fit.registry import _data_path, _isometric_table, _synthetic, _table_notes, load_muscle
from mckibben.results import Result, to_jsonable

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["GAP_DRIFTS", "NESTED_MIN_FOLDS", "Candidate", "GapCandidate", "NestedComparison",
           "NestedGapComparison", "compare_direction_aware_nested", "compare_direction_aware_nested_table",
           "compare_nested", "compare_nested_table"]

#: Outer folds a nested comparison needs: each outer training set keeps two folds or more for
#: its own (inner) cross-validation. [-]
NESTED_MIN_FOLDS = 3


@dataclass(frozen=True)
class Candidate:
    """One thing ``compare`` can choose: a model and the options it is fitted with.

    Attributes
    ----------
    model : str
        A force model (a key of :data:`~mckibben.fit.isometric.ALL_MODELS`). [-]
    rest_lengths : {"nominal", "fitted"}
        A family's rest lengths as recorded or fitted per muscle
        (:func:`~mckibben.fit.isometric.fit_points`). [-]
    """

    model: str
    rest_lengths: str = "nominal"

    @property
    def name(self) -> str:
        """The model's name, with the option when it is not the default."""
        return self.model if self.rest_lengths == "nominal" else f"{self.model} (rest lengths fitted)"


def _options(rest_lengths) -> tuple[str, ...]:
    opts = (rest_lengths,) if isinstance(rest_lengths, str) else tuple(rest_lengths)
    if not opts:
        raise InputError(f"rest_lengths: give one option or more of {', '.join(REST_LENGTHS)}")
    for o in opts:
        if o not in REST_LENGTHS:
            raise unknown_name("rest_lengths", str(o), REST_LENGTHS)
    if len(set(opts)) != len(opts):
        raise InputError(f"rest_lengths: {', '.join(opts)} names an option twice")
    return opts


def _rows(table: Table, keep) -> Table:
    """The table on the rows ``keep`` marks (boolean, aligned with ``table.data``), its kept-aside columns too."""
    extra = table.extra
    return replace(table, data=table.data[keep], extra=extra[keep] if extra is not None else None)


def _select(table: Table, muscle: MuscleSpec, cv: str, tare: str, models, rails: str, pressure_zero: str,
            options: tuple[str, ...], min_samples: int = 0
            ) -> tuple[dict[str, ModelComparison], list[dict], dict | None, bool]:
    """``compare`` on ``table`` once per rest-length option; every candidate's score; the chosen one."""
    comps = {o: compare_isometric(table, muscle, cv, tare, models, rails, pressure_zero, o, min_samples)
             for o in options}
    scores = [{**s, "candidate": Candidate(s["model"], o).name, "rest_lengths": o}
              for o, c in comps.items() for s in c.scores]
    chosen, every_flagged = best_of(scores)
    return comps, scores, chosen, every_flagged


def _pooled(folds: list[dict], peak: float) -> dict:
    """RMS over every held-out point (folds weighted by their points), the largest |error|, the folds' spread."""
    ok = [f for f in folds if f.get("rmse_N") is not None and np.isfinite(f["rmse_N"])]
    if not ok:
        nan = float("nan")
        return {"rmse_N": nan, "rmse_pct_of_peak": nan, "max_error_N": nan, "max_error_pct_of_peak": nan,
                "median_fold_pct_of_peak": nan, "worst_fold_pct_of_peak": nan, "folds_scored": 0}
    n = np.array([f["n_points"] for f in ok], dtype=float)
    rms = float(np.sqrt(np.sum(n * np.array([f["rmse_N"] for f in ok]) ** 2) / np.sum(n)))
    mx = float(max(f["max_error_N"] for f in ok))
    pct = [f["rmse_pct_of_peak"] for f in ok]
    return {"rmse_N": rms, "rmse_pct_of_peak": rms / peak * 100.0, "max_error_N": mx,
            "max_error_pct_of_peak": mx / peak * 100.0, "median_fold_pct_of_peak": float(np.median(pct)),
            "worst_fold_pct_of_peak": float(np.max(pct)), "folds_scored": len(ok)}


@dataclass(repr=False)
class NestedComparison(Result):
    """``compare``'s choice held out: the nested and the non-nested error of the chosen model.

    Attributes
    ----------
    cv : str
        The cross-validation scheme of both levels (a key of :data:`~mckibben.fit.isometric.CV_METHODS`).
    candidates : list of str
        The candidates' names (:class:`Candidate`), in the order compared.
    folds : list of dict
        Per outer fold: ``held_out``, ``chosen`` (the candidate the inner selection picked),
        ``chosen_flagged`` (every inner candidate flagged), ``inner_cv_rmse_N`` (the chosen one's
        error on the inner folds: what the selection believed), ``rmse_N``, ``rmse_pct_of_peak``,
        ``max_error_N``, ``max_error_pct_of_peak`` (the chosen candidate refitted on the outer
        training data, on the outer fold), ``non_nested_rmse_N`` and ``non_nested_rmse_pct_of_peak``
        and ``non_nested_max_error_N`` (the non-nested best on the same fold), ``peak_force_N``, ``n_points`` and ``note``.
    nested : dict
        Pooled over the outer folds (:func:`compare_nested`, "Measures"). [N, %]
    non_nested : dict
        The same for the non-nested best, with ``best`` and ``best_flagged``. [N, %]
    comparison : list of dict
        Every candidate's scores on all the data (``compare``'s, with ``candidate``). [-]
    peak_force : float
        Largest |force| of the table. [N]
    source : str
        The data file. [-]
    tare : str
        The load cell's tare. [-]
    info : dict
        What the table-level call adds to the JSON (file, muscle, synthetic, notes). [-]
    min_samples : int
        The settled points' threshold of readings (0: every point). [-]
    """

    cv: str
    candidates: list
    folds: list
    nested: dict
    non_nested: dict
    comparison: list = field(repr=False)
    peak_force: float
    source: str = ""
    tare: str = "none"
    info: dict = field(default_factory=dict)
    min_samples: int = 0

    call = "mckibben.fit.nested.compare_nested"
    _repr_keys = ("non_nested_best", "nested_rmse_pct_of_peak", "non_nested_rmse_pct_of_peak", "optimism_pct_of_peak")

    @property
    def arguments(self) -> dict:
        """What was compared: data file, scheme, tare, the candidates and the settled points' threshold."""
        return {"source": self.source, "cv": self.cv, "tare": self.tare, "candidates": list(self.candidates),
                "min_samples": self.min_samples}

    @property
    def selection(self) -> dict:
        """Candidate -> number of outer folds that chose it (selection stability). [-]"""
        out: dict = {}
        for f in self.folds:
            out[f["chosen"]] = out.get(f["chosen"], 0) + 1
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    @property
    def metrics(self) -> dict:
        """Nested and non-nested pooled RMS, max and worst/median fold as % of peak; the optimism; the choices."""
        nn, ne = self.non_nested, self.nested
        same = sum(f["chosen"] == nn["best"] for f in self.folds)
        return {"non_nested_best": nn["best"], "non_nested_rmse_pct_of_peak": nn["rmse_pct_of_peak"],
                "nested_rmse_pct_of_peak": ne["rmse_pct_of_peak"],
                "optimism_pct_of_peak": ne["rmse_pct_of_peak"] - nn["rmse_pct_of_peak"],
                "non_nested_max_error_pct_of_peak": nn["max_error_pct_of_peak"],
                "nested_max_error_pct_of_peak": ne["max_error_pct_of_peak"],
                "non_nested_median_fold_pct_of_peak": nn["median_fold_pct_of_peak"],
                "nested_median_fold_pct_of_peak": ne["median_fold_pct_of_peak"],
                "non_nested_worst_fold_pct_of_peak": nn["worst_fold_pct_of_peak"],
                "nested_worst_fold_pct_of_peak": ne["worst_fold_pct_of_peak"],
                "worst_fold_optimism_pct_of_peak": ne["worst_fold_pct_of_peak"] - nn["worst_fold_pct_of_peak"],
                "n_folds": len(self.folds), "folds_choosing_non_nested_best": same,
                "peak_force_N": self.peak_force}

    def to_dict(self) -> dict:
        """JSON-ready (what ``compare --nested --json`` prints)."""
        return to_jsonable({**self.info, "cv": self.cv, "tare": self.tare, "candidates": list(self.candidates),
                            "min_samples": self.min_samples, **self.metrics, "selection": self.selection, "nested": self.nested,
                            "non_nested": self.non_nested, "folds": self.folds, "models": self.comparison})

    def _series(self) -> pd.DataFrame:
        """One row per outer fold (``quantity_unit`` columns)."""
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        keys = ("held_out", "chosen", "chosen_flagged", "inner_cv_rmse_N", "rmse_N", "rmse_pct_of_peak", "max_error_N",
                "max_error_pct_of_peak", "non_nested_rmse_N", "non_nested_rmse_pct_of_peak", "peak_force_N",
                "n_points", "note")
        df = pd.DataFrame([{k: f.get(k) for k in keys} for f in self.folds], columns=list(keys))
        return df.rename(columns={"rmse_N": "nested_rmse_N", "rmse_pct_of_peak": "nested_rmse_pct_of_peak",
                                  "max_error_N": "nested_max_error_N",
                                  "max_error_pct_of_peak": "nested_max_error_pct_of_peak"})

    def plot(self, ax=None):
        """Per outer fold, the nested and the non-nested held-out RMSE as % of peak, each fold's choice named.

        One row per outer fold (names on the vertical axis): the chosen candidate's error (nested,
        refitted on the outer training data) beside the non-nested best's on the same fold, the
        chosen candidate written at the bar's end (marked ``flagged`` when every inner candidate
        was), the pooled figures and the optimism in the title.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
        """
        series = self._series()
        ax, df = _paired_bars(ax, series, "nested_rmse_pct_of_peak", "non_nested_rmse_pct_of_peak",
                              self.non_nested["best"], [str(h) for h in series["held_out"]][::-1])
        ax.set_xlabel("held-out RMSE [% of peak force]")
        m = self.metrics
        ax.set_title(f"{self.cv}, nested: pooled {m['nested_rmse_pct_of_peak']:.2f} % vs non-nested "
                     f"{m['non_nested_rmse_pct_of_peak']:.2f} % (optimism {m['optimism_pct_of_peak']:+.2f} points)",
                     fontsize="medium")
        return _finish(ax, df, "nested_rmse_pct_of_peak", "non_nested_rmse_pct_of_peak", 0.0)


def _paired_bars(ax, series, nested_col: str, plain_col: str, best: str, labels: list[str]):
    """Both nested figures' bars: per outer fold (one row each, the first at the top) the non-nested
    best's error above the fold's own choice's, the choice written at its bar's end (``flagged``
    when every inner candidate was). Returns the axes and the rows in drawing order."""
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    df = series.iloc[::-1].reset_index(drop=True)
    if ax is None:
        _, ax = plt.subplots(figsize=(9.0, 1.6 + 0.45 * max(len(df), 3)), layout="constrained")
    y = np.arange(len(df))
    nested = df[nested_col].astype(float).to_numpy()
    ax.barh(y + 0.2, df[plain_col].astype(float).to_numpy(), 0.38, color="C0", label=f"non-nested best ({best})")
    ax.barh(y - 0.2, nested, 0.38, color="C1", label="nested: the fold's own choice")
    for k, (v, who, fl) in enumerate(zip(nested, df["chosen"], df["chosen_flagged"])):
        if who is not None:
            ax.text(0.0 if not np.isfinite(v) else v, y[k] - 0.2, f" {who}{' (flagged)' if fl else ''}",
                    va="center", fontsize="x-small")
    ax.set_yticks(y, labels)
    return ax, df


def _finish(ax, df, nested_col: str, plain_col: str, floor: float):
    """The x range (room for the choices' names right of the longest bar, ``floor`` always shown) and the legend."""
    top = np.nanmax(np.r_[df[nested_col].astype(float), df[plain_col].astype(float), floor])
    ax.set_xlim(left=0, right=1.35 * max(float(top), 1e-9))
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return ax.figure


def compare_nested(table: Table, muscle: MuscleSpec, cv: str = "leave-one-length-out", tare: str = "none",
                   models=None, rails: str = "keep", pressure_zero: str = "none",
                   rest_lengths=("nominal",), min_samples: int = 0) -> NestedComparison:
    """``compare``'s choice by nested cross-validation: each outer fold's error of the model chosen without it.

    See the module notes. The outer folds are ``compare``'s folds of ``cv`` on the whole table
    (:func:`~mckibben.fit.isometric.compare_isometric`); for each, the selection (every candidate,
    the inner folds of the same ``cv`` on the outer training rows, ``best``'s rule
    :func:`~mckibben.fit.isometric.best_of`) runs on the outer training rows alone, and the chosen
    candidate's fit on those rows is scored on the held-out fold. Cost: about (K + 1)·K fits per
    candidate for K outer folds, against K + 1 for ``compare``.

    Parameters
    ----------
    table : Table
        An ``isometric`` table. [-]
    muscle : MuscleSpec
        The muscle file (for a family: the type's). [-]
    cv : {"leave-one-length-out", "leave-one-trial-out", "leave-one-muscle-out"}, default "leave-one-length-out"
        The folds of both levels; the table needs :data:`NESTED_MIN_FOLDS` of them or more. [-]
    tare : {"none", "lowest", "column", "fitted"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_tare`. [-]
    models : sequence of str, optional
        The models (default ``compare``'s: the family laws on a family table, else every model). [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Rows at a sensor's rail (:func:`~mckibben.fit.isometric.isometric_points`). [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        The pressure transducer's zero. [-]
    rest_lengths : str or sequence of str, default ("nominal",)
        The rest-length options each model is a candidate with (``("nominal", "fitted")``: both,
        a family table only). [-]
    min_samples : int, default 0
        Points binned from fewer readings than this (a column ``n_samples``: a pressure step
        passing through, not a hold; :func:`~mckibben.fit.isometric.transition_rows`) are left out
        of every fit and every score, at both levels; a fixed input of the selection, not a
        candidate. 0: every point. [-]

    Returns
    -------
    NestedComparison

    References
    ----------
    Varma & Simon (2006) [varma2006]; Cawley & Talbot (2010) [cawley2010].
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    options = _options(rest_lengths)
    if cv not in CV_METHODS:
        raise unknown_name("`cv` scheme", cv, CV_METHODS)
    d, _ = isometric_points(table, tare, rails, pressure_zero, min_samples)
    key, names = _fold_keys(d, cv)  # compare's folds (its labels and names, one function)
    groups = np.unique(key)
    what = {"leave-one-length-out": "held lengths", "leave-one-trial-out": "trials"}.get(cv, "muscles")
    if groups.size < NESTED_MIN_FOLDS:
        raise InputError(f"cv: nested {cv} on {table.path} needs {NESTED_MIN_FOLDS} {what} or more, found "
                         f"{groups.size}: each outer fold's training data are cross-validated again")
    comps, scores, chosen, every_flagged = _select(table, muscle, cv, tare, models, rails, pressure_zero, options,
                                                   min_samples)
    if chosen is None:
        raise InputError(f"compare on {table.path}: no candidate could be scored held out, nothing to choose")
    peak = next(iter(comps.values())).peak_force
    by_candidate = {s["candidate"]: {f["held_out"]: f for f in s["folds"]} for s in scores}
    best = chosen["candidate"]
    folds = []
    for g in groups:
        held = names[int(g)]
        test_rows = d.index[key == g]
        inner_table = _rows(table, ~table.data.index.isin(test_rows))
        note, who, inner_rmse, flagged = "", None, float("nan"), False
        try:
            _, _, pick, flagged = _select(inner_table, muscle, cv, tare, models, rails, pressure_zero, options,
                                          min_samples)
        except InputError as exc:
            pick, note = None, f"selection on the other folds failed: {exc}"
        if pick is not None:
            who, inner_rmse = pick["candidate"], pick["cv_rmse_N"]
        elif not note:
            note = "no candidate could be scored on the other folds"
        mine = by_candidate.get(who, {}).get(held) if who is not None else None
        ref = by_candidate[best].get(held)
        if who is not None and mine is None:
            note = f"{who} could not be fitted without {held}"
        nan = float("nan")
        folds.append({"held_out": held, "chosen": who, "chosen_flagged": bool(flagged), "inner_cv_rmse_N": inner_rmse,
                      "rmse_N": mine["rmse_N"] if mine else nan,
                      "rmse_pct_of_peak": mine["rmse_pct_of_peak"] if mine else nan,
                      "max_error_N": mine["max_error_N"] if mine else nan,
                      "max_error_pct_of_peak": mine["max_error_pct_of_peak"] if mine else nan,
                      "non_nested_rmse_N": ref["rmse_N"] if ref else nan,
                      "non_nested_rmse_pct_of_peak": ref["rmse_pct_of_peak"] if ref else nan,
                      "non_nested_max_error_N": ref["max_error_N"] if ref else nan,
                      "peak_force_N": (mine or ref or {}).get("peak_force_N", nan),
                      "n_points": int(np.sum(key == g)), "note": note})
    nested = _pooled(folds, peak)
    non_nested = {"best": best, "best_flagged": every_flagged,
                  **_pooled([{**f, "rmse_N": f["non_nested_rmse_N"], "rmse_pct_of_peak": f["non_nested_rmse_pct_of_peak"],
                              "max_error_N": f["non_nested_max_error_N"]} for f in folds], peak)}
    candidates = list(dict.fromkeys(s["candidate"] for s in scores))
    return NestedComparison(cv, candidates, folds, nested, non_nested, scores, peak, str(table.path), tare,
                            min_samples=int(min_samples))


def _isometric_file(data, muscle, select, columns, not_isometric: str):
    """A table file and its muscle for a nested comparison: (path, table, spec); ``not_isometric``
    (with ``{path}``) is the error when the file is no isometric table."""
    path: Path = _data_path(data)
    table = _isometric_table(path, select, columns)
    if table is None:
        raise InputError(not_isometric.format(path=path))
    spec = load_muscle(path, muscle, True, "compare", table)
    check_muscle(table, spec)
    return path, table, spec


def _file_info(path: Path, table: Table, spec: MuscleSpec) -> dict:
    """What a nested comparison's JSON says of its file: ``file``, ``kind``, ``muscle``, ``synthetic``, the reader's notes."""
    return {"file": str(path), "kind": "isometric", "muscle": spec.id, "synthetic": _synthetic(path, spec),
            **_table_notes(table)}


def compare_nested_table(data, muscle: str | None = None, cv: str | None = None, tare: str = "none",
                         rails: str = "keep", pressure_zero: str = "none", select: dict | None = None,
                         columns: dict | None = None, rest_lengths=("nominal",),
                         min_samples: int = 0) -> NestedComparison:
    """``mckibben compare DATA --nested``: :func:`compare_nested` on an isometric table file.

    Parameters
    ----------
    data : str or pathlib.Path
        An isometric table (.csv or .parquet). [-]
    muscle : str, optional
        Muscle file; default ``muscle.toml`` beside the data, else the muscle the table describes. [-]
    cv : {"leave-one-length-out", "leave-one-trial-out", "leave-one-muscle-out"}, optional
        Default ``leave-one-length-out``. [-]
    tare : {"none", "lowest", "column", "fitted"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_tare`. [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Rows at a sensor's rail. [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        The pressure transducer's zero. [-]
    select : dict, optional
        Column -> value: compare on the rows holding these values. [-]
    columns : dict, optional
        The file's column names -> the schema's. [-]
    rest_lengths : str or sequence of str, default ("nominal",)
        The rest-length options each model is a candidate with. [-]
    min_samples : int, default 0
        The settled points only, for fit and score alike (:func:`compare_nested`). [-]

    Returns
    -------
    NestedComparison
        Its JSON also gives ``file``, ``kind``, ``muscle``, ``synthetic`` and the reader's notes.
    """
    path, table, spec = _isometric_file(data, muscle, select, columns, "nested: selects among force laws held out on "
                                        "an isometric table; {path} is not one (the isotonic comparison picks no best)")
    res = compare_nested(table, spec, cv or "leave-one-length-out", tare, None, rails, pressure_zero, rest_lengths,
                         min_samples)
    res.info = _file_info(path, table, spec)
    return res


# --- the direction-aware form, chosen by nested leave-one-trial-out on the up/down gap -------------------------

#: The drift options a nested direction-aware selection tries by default: without and with the
#: run-drift nuisance (:data:`mckibben.fit.direction.DRIFT_NAME`). [-]
GAP_DRIFTS = (False, True)


@dataclass(frozen=True)
class GapCandidate:
    """One direction-aware form the gap selection can choose: a law, its operator, the run drift or not.

    Attributes
    ----------
    model : str
        A registered force law with a fit spec. [-]
    structure : {"play", "friction"}
        The operator (:data:`~mckibben.models.hysteresis.direction.STRUCTURES`). [-]
    drift : bool
        Whether the run-drift nuisance is fitted with it (:func:`~mckibben.fit.direction.fit_direction_aware`). [-]
    """

    model: str
    structure: str = DEFAULT_STRUCTURE
    drift: bool = False

    @property
    def name(self) -> str:
        """``law (structure[, drift])``."""
        return f"{self.model} ({self.structure}{', drift' if self.drift else ''})"


def _gap_candidates(models, structures, drifts) -> list[GapCandidate]:
    """law × structure × drift, each option checked and named in its error."""
    models = (models,) if isinstance(models, str) else tuple(models)
    structures = (structures,) if isinstance(structures, str) else tuple(structures)
    drifts = (drifts,) if isinstance(drifts, bool) else tuple(drifts)
    for what, opts in (("models", models), ("structures", structures), ("drifts", drifts)):
        if not opts:
            raise InputError(f"{what}: give one option or more")
        if len(set(opts)) != len(opts):
            raise InputError(f"{what}: {', '.join(map(str, opts))} names an option twice")
    for st in structures:
        if st not in STRUCTURES:
            raise unknown_name("structures", str(st), STRUCTURES)
    for dr in drifts:
        if not isinstance(dr, (bool, np.bool_)):
            raise InputError(f"drifts: {dr!r} is not True or False (the run-drift nuisance fitted or not)")
    return [GapCandidate(m, st, bool(dr)) for m in models for st in structures for dr in drifts]


def _trial_gap(rows: list[dict]) -> dict:
    """:func:`~mckibben.fit.direction.gap_scores` of the direction-aware form on these held-out runs, pooled."""
    if not rows:
        return gap_scores([], [])
    return gap_scores(np.concatenate([r["measured_N"] for r in rows]),
                      np.concatenate([r["direction_aware_N"] for r in rows]))


def _gap_select(table: Table, muscle: MuscleSpec, candidates: list[GapCandidate], tare: str, rails: str,
                pressure_zero: str, grid, min_samples: int, cache: dict) -> tuple[list[dict], dict[str, HeldoutGap]]:
    """Every candidate's held-out gap, each trial of ``table`` held out in turn (:func:`heldout_gap`): one
    score per candidate (``gap_error_rms_N`` pooled over every held-out run, ``flags`` of its fits, ``note``)
    and its :class:`~mckibben.fit.direction.HeldoutGap`. ``cache``: the fits shared by the outer and inner
    selections (an inner fold on one trial recurs in two outer folds)."""
    scores, gaps = [], {}
    for c in candidates:
        row = {"candidate": c.name, "model": c.model, "structure": c.structure, "drift": c.drift}
        try:
            h = heldout_gap(table, muscle, c.model, c.structure, tare=tare, rails=rails, pressure_zero=pressure_zero,
                            grid=grid, min_samples=min_samples, drift=c.drift, cache=cache)
        except InputError as exc:
            scores.append({**row, "gap_error_rms_N": float("nan"), "measured_gap_rms_N": float("nan"),
                           "n_pressures": 0, "flags": [], "note": f"not fitted: {exc}"})
            continue
        m = h.metrics
        gaps[c.name] = h
        scores.append({**row, "gap_error_rms_N": m["direction_aware_gap_error_rms_N"],
                       "measured_gap_rms_N": m["measured_gap_rms_N"], "n_pressures": m["n_pressures"],
                       "flags": sorted({fl for f in h.fits for fl in f.result.flags}), "note": ""})
    return scores, gaps


def _gap_best(scores: list[dict]) -> tuple[dict | None, bool]:
    """``best``'s rule (:func:`~mckibben.fit.isometric.best_of`) on the held-out gap error RMS."""
    pick, every_flagged = best_of([{**s, "cv_rmse_N": s["gap_error_rms_N"]} for s in scores])
    return (None if pick is None else next(s for s in scores if s["candidate"] == pick["candidate"])), every_flagged


@dataclass(repr=False)
class NestedGapComparison(Result):
    """The direction-aware form chosen by nested leave-one-trial-out on the up/down gap, and its held-out gap.

    Attributes
    ----------
    candidates : list of str
        The candidates' names (:class:`GapCandidate`), in the order tried.
    folds : list of dict
        Per held-out trial (outer fold): ``held_out`` (the trial), ``inner_folds`` (trials the
        selection held out in turn: the outer training trials), ``chosen``, ``chosen_flagged``
        (every inner candidate flagged), ``inner_gap_error_rms_N`` (the chosen one's on the inner
        folds: what the selection believed), ``inner`` (every candidate's inner score:
        ``gap_error_rms_N``, ``n_pressures``, ``flags``), ``measured_gap_rms_N``,
        ``gap_error_rms_N``, ``gap_error_max_N``, ``gap_error_ratio`` (the chosen candidate fitted
        on the outer training trials, on the held-out trial), ``non_nested_gap_error_rms_N``,
        ``non_nested_gap_error_max_N``, ``non_nested_gap_error_ratio`` (the non-nested best on the
        same trial), ``optimism`` (nested − non-nested ratio), ``n_pressures``, ``note``. [N, -]
    nested, non_nested : dict
        Pooled over every held-out run of every outer fold (:func:`~mckibben.fit.direction.gap_scores`;
        ``non_nested`` with ``best`` and ``best_flagged``). [N, -]
    comparison : list of dict
        Every candidate on all the trials (each held out in turn): ``candidate``, ``model``,
        ``structure``, ``drift``, ``gap_error_rms_N``, ``measured_gap_rms_N``, ``n_pressures``,
        ``flags``, ``note``, and ``by_trial`` (its ratio per held-out trial). [N, -]
    heldout : dict
        Candidate name -> its :class:`~mckibben.fit.direction.HeldoutGap` on all the trials (the
        runs the outer scores pool; not in the JSON). [-]
    min_samples : int
        The settled points' threshold (a fixed input of the selection). [-]
    source, tare : str
        The data file and the load cell's tare. [-]
    info : dict
        What the table-level call adds to the JSON (file, muscle, synthetic, notes). [-]
    """

    candidates: list
    folds: list
    nested: dict
    non_nested: dict
    comparison: list = field(repr=False)
    heldout: dict = field(repr=False, default_factory=dict)
    min_samples: int = 0
    source: str = ""
    tare: str = "none"
    info: dict = field(default_factory=dict)

    call = "mckibben.fit.nested.compare_direction_aware_nested"
    _repr_keys = ("non_nested_best", "nested_gap_error_ratio", "non_nested_gap_error_ratio", "optimism")

    @property
    def arguments(self) -> dict:
        """What was compared: data file, tare, the candidates and the settled points' threshold."""
        return {"source": self.source, "cv": "leave-one-trial-out", "tare": self.tare,
                "candidates": list(self.candidates), "min_samples": self.min_samples}

    @property
    def selection(self) -> dict:
        """Candidate -> number of outer folds that chose it (selection stability). [-]"""
        out: dict = {}
        for f in self.folds:
            out[f["chosen"]] = out.get(f["chosen"], 0) + 1
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    @property
    def metrics(self) -> dict:
        """Pooled nested and non-nested gap error RMS and ratio (error RMS / measured gap RMS), the optimism,
        the largest per-trial ratio of each, the folds that meet a ratio of 0.5. [N, -]"""
        ne, nn = self.nested, self.non_nested
        per = [f["gap_error_ratio"] for f in self.folds]
        per_nn = [f["non_nested_gap_error_ratio"] for f in self.folds]
        return {"non_nested_best": nn["best"], "measured_gap_rms_N": ne["measured_gap_rms_N"],
                "nested_gap_error_rms_N": ne["gap_error_rms_N"], "nested_gap_error_max_N": ne["gap_error_max_N"],
                "nested_gap_error_ratio": ne["gap_error_ratio"],
                "non_nested_gap_error_rms_N": nn["gap_error_rms_N"], "non_nested_gap_error_max_N": nn["gap_error_max_N"],
                "non_nested_gap_error_ratio": nn["gap_error_ratio"],
                "optimism": ne["gap_error_ratio"] - nn["gap_error_ratio"],
                "nested_worst_fold_ratio": float(np.nanmax(per)) if per else float("nan"),
                "non_nested_worst_fold_ratio": float(np.nanmax(per_nn)) if per_nn else float("nan"),
                "folds_at_most_half": int(sum(bool(r <= 0.5) for r in per)), "n_folds": len(self.folds),
                "folds_choosing_non_nested_best": sum(f["chosen"] == nn["best"] for f in self.folds)}

    def to_dict(self) -> dict:
        """JSON-ready (what ``compare --direction-aware --nested --json`` prints)."""
        return to_jsonable({**self.info, **self.arguments, **self.metrics, "selection": self.selection,
                            "nested": self.nested, "non_nested": self.non_nested, "folds": self.folds,
                            "models": self.comparison})

    def _series(self) -> pd.DataFrame:
        """One row per held-out trial (``quantity_unit`` columns)."""
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        keys = ("held_out", "chosen", "chosen_flagged", "inner_gap_error_rms_N", "measured_gap_rms_N",
                "gap_error_rms_N", "gap_error_max_N", "gap_error_ratio", "non_nested_gap_error_rms_N",
                "non_nested_gap_error_ratio", "optimism", "n_pressures", "note")
        df = pd.DataFrame([{k: f.get(k) for k in keys} for f in self.folds], columns=list(keys))
        return df.rename(columns={"gap_error_rms_N": "nested_gap_error_rms_N", "gap_error_max_N": "nested_gap_error_max_N",
                                  "gap_error_ratio": "nested_gap_error_ratio"})

    def plot(self, ax=None):
        """Per held-out trial, the nested and the non-nested gap error ratio, a line at 0.5, each fold's choice named.

        One row per held-out trial: the gap error RMS over the measured gap's RMS of the
        candidate chosen on the other trials alone (nested), beside the non-nested best's on the
        same trial; the chosen candidate written at the bar's end (``flagged`` when every inner
        candidate was); a line at 0.5 (the error half the measured gap); the pooled figures in the title.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
        """
        series = self._series()
        ax, df = _paired_bars(ax, series, "nested_gap_error_ratio", "non_nested_gap_error_ratio",
                              self.non_nested["best"], [f"trial {h}" for h in series["held_out"]][::-1])
        ax.axvline(0.5, color="k", lw=0.8, ls="--", label="0.5: half the measured gap")
        ax.set_xlabel("held-out gap error RMS / measured gap RMS [-]")
        m = self.metrics
        ax.set_title(f"direction-aware form chosen by nested leave-one-trial-out\npooled {m['nested_gap_error_ratio']:.2f}"
                     f" vs non-nested {m['non_nested_gap_error_ratio']:.2f} (optimism {m['optimism']:+.2f})",
                     fontsize="medium")
        return _finish(ax, df, "nested_gap_error_ratio", "non_nested_gap_error_ratio", 0.5)


def compare_direction_aware_nested(table: Table, muscle: MuscleSpec, models=None, structures=STRUCTURES,
                                   drifts=GAP_DRIFTS, tare: str = "none", rails: str = "exclude",
                                   pressure_zero: str = "none", grid=None, min_samples: int = 0) -> NestedGapComparison:
    """The direction-aware form (law × structure × drift) chosen by nested leave-one-trial-out on the up/down gap.

    Outer fold: one trial held out. On the other trials alone, every candidate's held-out gap
    (:func:`~mckibben.fit.direction.heldout_gap`, each of those trials held out in turn: the inner
    leave-one-trial-out; with 3 trials, 2 inner folds of one training trial each) is scored by
    the gap error RMS pooled over every inner held-out run (every muscle and held length of the
    table, each grid pressure one value: the metric that cannot cancel), and ``best``'s rule
    (:func:`~mckibben.fit.isometric.best_of`: the smallest among the candidates whose fits carry no
    flag) picks one. The chosen candidate fitted on all the outer training trials scores the
    held-out trial: that fit is the one :func:`~mckibben.fit.direction.heldout_gap` makes on the
    whole table for that trial (the same fit of the same rows), so the nested and the non-nested
    figures differ only in *which* candidate scores each trial. The non-nested best is the same
    rule applied to the scores on all the trials, the choice made on the very trials it is scored
    on (Varma & Simon (2006) [varma2006]; Cawley & Talbot (2010) [cawley2010]).

    Cost: per candidate, K outer fits and K·(K − 1) inner fits on K − 2 trials, for K trials.

    Parameters
    ----------
    table : Table
        An ``isometric`` table with inflate and deflate rows and :data:`NESTED_MIN_FOLDS` trials or more.
    muscle : MuscleSpec
        The muscle file. [-]
    models : str or sequence of str, optional
        The laws tried (registered laws with a fit spec; a family law on a family table); default
        every such law (:func:`~mckibben.fit.direction.gap_laws`, as the non-nested comparison).
        Each costs its structures × drifts candidates: name a few on a large campaign. [-]
    structures : str or sequence of str, default every structure ("play", "friction")
        The operators tried (:data:`~mckibben.models.hysteresis.direction.STRUCTURES`). [-]
    drifts : bool or sequence of bool, default :data:`GAP_DRIFTS` (without and with)
        The run-drift nuisance fitted or not (:func:`~mckibben.fit.direction.fit_direction_aware`). [-]
    tare, rails, pressure_zero : str
        As :func:`~mckibben.fit.direction.heldout_gap` (``tare`` none, lowest or column; ``rails``
        exclude or keep). [-]
    grid : array_like, optional
        The gap's pressures (:func:`~mckibben.fit.direction.loop_gap`); default every 10 kPa both
        branches cover. [Pa]
    min_samples : int, default 0
        Points binned from fewer readings are left out of every fit and gap, at both levels, and
        kept in each run's history: a fixed input of the selection, not a candidate (a threshold
        changes the points scored, so two thresholds' errors are not errors of one target). [-]

    Returns
    -------
    NestedGapComparison

    References
    ----------
    Varma & Simon (2006) [varma2006]; Cawley & Talbot (2010) [cawley2010].
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    _no_fitted_tare(tare)
    transition_rows(table, min_samples)  # a bad threshold or a missing column: one error, not one note per candidate
    d, _ = isometric_points(table, tare, "keep", pressure_zero, min_samples)
    candidates = _gap_candidates(gap_laws(d) if models is None else models, structures, drifts)
    trials = np.unique(d["trial"].to_numpy()) if "trial" in d else np.zeros(0)
    if trials.size < NESTED_MIN_FOLDS:
        raise InputError(f"table: nested leave-one-trial-out on {table.path} needs {NESTED_MIN_FOLDS} trials or more, "
                         f"found {trials.size}: each held-out trial's training trials are cross-validated again")
    cache: dict = {}  # fits on the same points, made once across the outer and inner folds
    scores, gaps = _gap_select(table, muscle, candidates, tare, rails, pressure_zero, grid, min_samples, cache)
    best, every_flagged = _gap_best(scores)
    if best is None:
        notes = "; ".join(s["note"] for s in scores if s["note"])
        raise InputError(f"compare on {table.path}: no direction-aware candidate could be scored held out ({notes})")
    by_trial: dict[str, dict] = {}  # candidate -> held-out trial -> its held-out runs
    for name, h in gaps.items():
        for r in h.rows:
            by_trial.setdefault(name, {}).setdefault(r["trial"], []).append(r)
    for s in scores:
        s["by_trial"] = {str(t): _trial_gap(rows)["gap_error_ratio"] for t, rows in by_trial.get(s["candidate"], {}).items()}
    folds, nested_rows, plain_rows = [], [], []
    for t in trials:
        held = t.item() if hasattr(t, "item") else t
        inner_table = _rows(table, (table.data["trial"] != t).to_numpy())
        note, pick, flagged, inner = "", None, False, []
        try:
            inner, _ = _gap_select(inner_table, muscle, candidates, tare, rails, pressure_zero, grid, min_samples,
                                   cache)
            pick, flagged = _gap_best(inner)
        except InputError as exc:
            note = f"selection on the other trials failed: {exc}"
        if pick is None and not note:
            note = "no candidate could be scored on the other trials: " + "; ".join(s["note"] for s in inner if s["note"])
        who = pick["candidate"] if pick else None
        mine = by_trial.get(who, {}).get(held, []) if who else []
        ref = by_trial[best["candidate"]].get(held, [])
        if who is not None and not mine:
            note = f"{who} could not be fitted without trial {held}"
        sm, sr = _trial_gap(mine), _trial_gap(ref)
        nested_rows += mine
        plain_rows += ref
        folds.append({"held_out": held, "inner_folds": [x.item() if hasattr(x, "item") else x for x in trials if x != t],
                      "chosen": who, "chosen_flagged": bool(flagged),
                      "inner_gap_error_rms_N": pick["gap_error_rms_N"] if pick else float("nan"),
                      "inner": {s["candidate"]: {"gap_error_rms_N": s["gap_error_rms_N"], "n_pressures": s["n_pressures"],
                                                 "flags": s["flags"]} for s in inner},
                      "measured_gap_rms_N": sr["measured_gap_rms_N"] if ref else sm["measured_gap_rms_N"],
                      "gap_error_rms_N": sm["gap_error_rms_N"], "gap_error_max_N": sm["gap_error_max_N"],
                      "gap_error_ratio": sm["gap_error_ratio"],
                      "non_nested_gap_error_rms_N": sr["gap_error_rms_N"], "non_nested_gap_error_max_N": sr["gap_error_max_N"],
                      "non_nested_gap_error_ratio": sr["gap_error_ratio"],
                      "optimism": sm["gap_error_ratio"] - sr["gap_error_ratio"],
                      "n_pressures": max(sm["n_pressures"], sr["n_pressures"]), "note": note})
    nested = _trial_gap(nested_rows)
    non_nested = {"best": best["candidate"], "best_flagged": every_flagged, **_trial_gap(plain_rows)}
    return NestedGapComparison([c.name for c in candidates], folds, nested, non_nested, scores, gaps,
                               int(min_samples), str(table.path), tare)


def compare_direction_aware_nested_table(data, muscle: str | None = None, tare: str = "none", rails: str = "exclude",
                                         pressure_zero: str = "none", select: dict | None = None,
                                         columns: dict | None = None, models=None, structures=STRUCTURES,
                                         drifts=GAP_DRIFTS, min_samples: int = 0) -> NestedGapComparison:
    """``mckibben compare DATA --direction-aware --nested``: :func:`compare_direction_aware_nested` on a table file.

    Parameters
    ----------
    data : str or pathlib.Path
        An isometric table (.csv or .parquet) with inflate and deflate rows and three trials or more. [-]
    muscle : str, optional
        Muscle file; default ``muscle.toml`` beside the data, else the muscle the table describes. [-]
    tare : {"none", "lowest", "column"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_tare`. [-]
    rails : {"exclude", "keep"}, default "exclude"
        Rows at a sensor's rail (left out of fits and gaps, kept in the history). [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        The pressure transducer's zero. [-]
    select : dict, optional
        Column -> value: compare on the rows holding these values. [-]
    columns : dict, optional
        The file's column names -> the schema's. [-]
    models, structures, drifts
        The candidates, as :func:`compare_direction_aware_nested`. [-]
    min_samples : int, default 0
        The settled points only (:func:`compare_direction_aware_nested`). [-]

    Returns
    -------
    NestedGapComparison
        Its JSON also gives ``file``, ``kind``, ``muscle``, ``synthetic`` and the reader's notes.
    """
    path, table, spec = _isometric_file(data, muscle, select, columns, "direction_aware: scores laws on the inflate "
                                        "and deflate rows of an isometric table; {path} is not one")
    res = compare_direction_aware_nested(table, spec, models, structures, drifts, tare, rails, pressure_zero,
                                         min_samples=min_samples)
    res.info = _file_info(path, table, spec)
    return res
