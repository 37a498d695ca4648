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
from mckibben.fit.isometric import (CV_METHODS, REST_LENGTHS, ModelComparison, _fold_keys, best_of,
                                    compare_isometric, isometric_points)
from mckibben.fit.registry import _data_path, _isometric_table, _synthetic, _table_notes, load_muscle
from mckibben.results import Result, to_jsonable

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["NESTED_MIN_FOLDS", "Candidate", "NestedComparison", "compare_nested", "compare_nested_table"]

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


def _select(table: Table, muscle: MuscleSpec, cv: str, tare: str, models, rails: str, pressure_zero: str,
            options: tuple[str, ...]) -> tuple[dict[str, ModelComparison], list[dict], dict | None, bool]:
    """``compare`` on ``table`` once per rest-length option; every candidate's score; the chosen one."""
    comps = {o: compare_isometric(table, muscle, cv, tare, models, rails, pressure_zero, o) for o in options}
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
    info : dict
        What the table-level call adds to the JSON (file, muscle, synthetic, notes). [-]
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

    call = "mckibben.fit.nested.compare_nested"
    _repr_keys = ("non_nested_best", "nested_rmse_pct_of_peak", "non_nested_rmse_pct_of_peak", "optimism_pct_of_peak")

    @property
    def arguments(self) -> dict:
        """What was compared: data file, scheme, tare and the candidates."""
        return {"source": self.source, "cv": self.cv, "tare": self.tare, "candidates": list(self.candidates)}

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
                            **self.metrics, "selection": self.selection, "nested": self.nested,
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
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        df = self._series().iloc[::-1].reset_index(drop=True)
        if ax is None:
            _, ax = plt.subplots(figsize=(9.0, 1.6 + 0.45 * max(len(df), 3)), layout="constrained")
        y = np.arange(len(df))
        nested = df["nested_rmse_pct_of_peak"].astype(float).to_numpy()
        plain = df["non_nested_rmse_pct_of_peak"].astype(float).to_numpy()
        ax.barh(y + 0.2, plain, 0.38, color="C0", label=f"non-nested best ({self.non_nested['best']})")
        ax.barh(y - 0.2, nested, 0.38, color="C1", label="nested: the fold's own choice")
        for k, (v, who, fl) in enumerate(zip(nested, df["chosen"], df["chosen_flagged"])):
            if who is not None:
                ax.text(0.0 if not np.isfinite(v) else v, y[k] - 0.2, f" {who}{' (flagged)' if fl else ''}",
                        va="center", fontsize="x-small")
        ax.set_yticks(y, [str(h) for h in df["held_out"]])
        ax.set_xlabel("held-out RMSE [% of peak force]")
        m = self.metrics
        ax.set_title(f"{self.cv}, nested: pooled {m['nested_rmse_pct_of_peak']:.2f} % vs non-nested "
                     f"{m['non_nested_rmse_pct_of_peak']:.2f} % (optimism {m['optimism_pct_of_peak']:+.2f} points)",
                     fontsize="medium")
        ax.set_xlim(left=0, right=1.35 * max(float(np.nanmax(np.r_[nested, plain, 0.0])), 1e-9))
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
        return ax.figure


def compare_nested(table: Table, muscle: MuscleSpec, cv: str = "leave-one-length-out", tare: str = "none",
                   models=None, rails: str = "keep", pressure_zero: str = "none",
                   rest_lengths=("nominal",)) -> NestedComparison:
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
    d, _ = isometric_points(table, tare, rails, pressure_zero)
    key, names = _fold_keys(d, cv)  # compare's folds (its labels and names, one function)
    groups = np.unique(key)
    what = {"leave-one-length-out": "held lengths", "leave-one-trial-out": "trials"}.get(cv, "muscles")
    if groups.size < NESTED_MIN_FOLDS:
        raise InputError(f"cv: nested {cv} on {table.path} needs {NESTED_MIN_FOLDS} {what} or more, found "
                         f"{groups.size}: each outer fold's training data are cross-validated again")
    comps, scores, chosen, every_flagged = _select(table, muscle, cv, tare, models, rails, pressure_zero, options)
    if chosen is None:
        raise InputError(f"compare on {table.path}: no candidate could be scored held out, nothing to choose")
    peak = next(iter(comps.values())).peak_force
    by_candidate = {s["candidate"]: {f["held_out"]: f for f in s["folds"]} for s in scores}
    best = chosen["candidate"]
    folds = []
    for g in groups:
        held = names[int(g)]
        test_rows = d.index[key == g]
        keep = ~table.data.index.isin(test_rows)
        extra = table.extra
        inner_table = replace(table, data=table.data[keep], extra=extra[keep] if extra is not None else None)
        note, who, inner_rmse, flagged = "", None, float("nan"), False
        try:
            _, _, pick, flagged = _select(inner_table, muscle, cv, tare, models, rails, pressure_zero, options)
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
    return NestedComparison(cv, candidates, folds, nested, non_nested, scores, peak, str(table.path), tare)


def compare_nested_table(data, muscle: str | None = None, cv: str | None = None, tare: str = "none",
                         rails: str = "keep", pressure_zero: str = "none", select: dict | None = None,
                         columns: dict | None = None, rest_lengths=("nominal",)) -> NestedComparison:
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

    Returns
    -------
    NestedComparison
        Its JSON also gives ``file``, ``kind``, ``muscle``, ``synthetic`` and the reader's notes.
    """
    path: Path = _data_path(data)
    table = _isometric_table(path, select, columns)
    if table is None:
        raise InputError(f"nested: selects among force laws held out on an isometric table; {path} is not one "
                         "(the isotonic comparison picks no best)")
    spec = load_muscle(path, muscle, True, "compare", table)
    check_muscle(table, spec)
    res = compare_nested(table, spec, cv or "leave-one-length-out", tare, None, rails, pressure_zero, rest_lengths)
    res.info = {"file": str(path), "kind": "isometric", "muscle": spec.id, "synthetic": _synthetic(path, spec),
                **_table_notes(table)}
    return res
