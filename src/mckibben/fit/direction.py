"""Direction-aware laws fitted to isometric data, and the up/down gap they predict held out.

:func:`fit_direction_aware` fits a registered law's direction-aware form
(:mod:`mckibben.models.hysteresis.direction`: the law fed through a play operator on the pressure,
or the law plus a friction term proportional to pressure) jointly: the law's parameters (its own
fit spec, read, never copied) and the operator's (the play's threshold r, and the friction
area A_f), one operator shared by every held length and muscle of the table.

**The pressure history.** An isometric table holds binned points, not a time series: each run
(one held length of one trial, of one muscle) is rebuilt in the order the protocol applied it,
its ``inflate`` rows by rising pressure, then its ``deflate`` rows by falling pressure, from the
state of a muscle just deflated to its first pressure (the play's output P₀ + r). Only this
order counts: the operator is rate independent.

**Metrics that cannot cancel.** The up/down gap of a run, g(P) = F_deflate(P) − F_inflate(P), at
every grid pressure both of its branches cover (:func:`loop_gap`, linear interpolation along each
branch), measured and predicted; the *gap error* is predicted − measured, and it is scored by its
RMS and its maximum |·| (:func:`gap_scores`), never by a signed mean (which a loop that crosses
itself cancels). A static law predicts no gap: its gap error is −g.

:func:`heldout_gap` fits the plain law (:func:`mckibben.fit.isometric.fit_points`) and its
direction-aware form on every trial but one and scores the gap of the held-out trial, each trial
held out in turn.

**Settled points and the run's drift.** ``min_samples`` leaves a stepped protocol's steps (points
binned from few readings, :func:`mckibben.fit.isometric.transition_rows`) out of the residuals and
the gap while they stay in the history; ``drift=True`` fits a nuisance force × (1 + c·s) along each
run's order (:func:`run_position`, :data:`DRIFT_NAME`), which the muscle's predictions leave out.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from mckibben.data.muscle_file import MuscleSpec
from mckibben.data.tables import Table
from mckibben.errors import InputError, check_instance, unknown_name
from mckibben.fit.core import FitResult, bounded_fit, data_range
from mckibben.fit.isometric import (BOUNDS_NOTE, SURFACE, _runs, fit_points, is_family, isometric_points, model_name,
                                   transition_rows)
from mckibben.models import laws
from mckibben.models.law_statics import rising_root
from mckibben.models.hysteresis.direction import (DEFAULT_STRUCTURE, DIRECTIONS, FRICTION_FORCE_NAME, FRICTION_NAME,
                                                  STRUCTURES, branch_force, branch_state, direction_aware_force,
                                                  play_pressure)
from mckibben.models.tube import TUBE_MAX_STRAIN, TUBE_NAME, with_tube
from mckibben.results import FitBase, Result, provenance, to_jsonable

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["DEFAULT_STRUCTURE", "DRIFT_NAME", "GAP_STEP_PA", "THRESHOLD_MAX_FRACTION", "FRICTION_MAX", "DirectionAwareFit",
           "HeldoutGap", "compare_direction_aware", "fit_direction_aware", "fit_isotonic_friction", "gap_scores",
           "heldout_gap", "loop_gap", "run_order", "run_position"]

#: The play's threshold is bounded by this fraction of the largest pressure of the data. [-]
THRESHOLD_MAX_FRACTION = 0.25
#: The smallest play threshold, as a fraction of the largest pressure (a play of 0 is no play). [-]
THRESHOLD_MIN_FRACTION = 1e-3
#: The friction area's upper bound, as a share of the data's peak force over peak pressure
#: (A_f·P at most this share of the largest force at the largest pressure). [-]
FRICTION_MAX = 0.5
#: The default grid step of the gap (:func:`loop_gap`). [Pa]
GAP_STEP_PA = 10e3
#: The run-drift nuisance's name among a fit's parameters (``drift=True``): the share of its force a
#: run gains from its first point to its last (:func:`run_position`), negative for a force that
#: relaxes. [-]
DRIFT_NAME = "run_drift_ratio"
#: The run drift's bound, either sign: half the force over a run is no drift any more. [-]
DRIFT_MAX = 0.5


def run_order(d: pd.DataFrame) -> tuple[np.ndarray, list[slice]]:
    """The protocol's order of an isometric table's points: per run, inflate rising, then deflate falling.

    Parameters
    ----------
    d : pandas.DataFrame
        ``held_length`` [m], ``pressure`` [Pa], ``direction``, ``trial`` (and ``muscle`` of a family).

    Returns
    -------
    order : numpy.ndarray
        Positional indices of ``d`` in that order. [-]
    runs : list of slice
        Each run's span in the ordered points. [-]
    """
    label = _runs(d)
    p = d["pressure"].to_numpy(dtype=float)
    up = (d["direction"].to_numpy() == "inflate")
    # one key per row: run, then inflate before deflate, then pressure rising (inflate) / falling (deflate)
    order = np.lexsort((np.where(up, p, -p), ~up, label))
    bounds = np.flatnonzero(np.diff(label[order])) + 1
    edges = np.concatenate([[0], bounds, [label.size]])
    return order, [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def run_position(n: int, runs: list[slice]) -> np.ndarray:
    """Each point's place along its run's history: 0 at the run's first point, 1 at its last.

    The clock of the run-drift nuisance (``drift=True`` of :func:`fit_direction_aware`): a binned
    table has no time, only the protocol's order (:func:`run_order`), so the drift is linear in
    that order.

    Parameters
    ----------
    n : int
        Number of ordered points. [-]
    runs : list of slice
        Each run's span (:func:`run_order`). [-]

    Returns
    -------
    numpy.ndarray
        Position in [0, 1] per point (0 for a run of one point). [-]
    """
    s = np.zeros(n)
    for r in runs:
        k = r.stop - r.start
        if k > 1:
            s[r] = np.linspace(0.0, 1.0, k)
    return s


def _drift(values, names) -> tuple[np.ndarray, float]:
    """The law's and operator's values, and the run drift (0 without one). [SI], [-]"""
    v = np.asarray(values, dtype=float)
    if DRIFT_NAME in names:
        return v[:-1], float(v[-1])
    return v, 0.0


def _play_runs(p: np.ndarray, runs: list[slice], r: float) -> np.ndarray:
    z = np.empty_like(p)
    for s in runs:
        z[s] = play_pressure(p[s], r)[0]
    return z


def loop_gap(pressure, force, direction, grid=None, step: float = GAP_STEP_PA) -> tuple[np.ndarray, np.ndarray]:
    """A run's up/down gap, deflate − inflate force, where both branches have data.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure of the run's points. [Pa]
    force : array_like
        Force at each point (measured or predicted). [N]
    direction : array_like of str
        ``"inflate"`` or ``"deflate"`` per point. [-]
    grid : array_like, optional
        Pressures to compare at; those outside the range both branches cover are dropped.
        Default: every ``step`` inside that range. [Pa]
    step : float, default :data:`GAP_STEP_PA`
        The default grid's step. [Pa]

    Returns
    -------
    pressure : numpy.ndarray
        The grid pressures used. [Pa]
    gap : numpy.ndarray
        F_deflate − F_inflate there (each branch interpolated linearly in pressure); empty when a
        branch is missing or the branches do not overlap. [N]
    """
    p = np.asarray(pressure, dtype=float)
    f = np.asarray(force, dtype=float)
    dn = np.asarray(direction)
    branches = []
    for name in ("inflate", "deflate"):
        sel = (dn == name) & np.isfinite(f)
        if sel.sum() < 2:
            return np.zeros(0), np.zeros(0)
        o = np.argsort(p[sel])
        branches.append((p[sel][o], f[sel][o]))
    lo = max(branches[0][0][0], branches[1][0][0])
    hi = min(branches[0][0][-1], branches[1][0][-1])
    if grid is None:
        if not np.isfinite(step) or step <= 0:
            raise InputError(f"step: {step!r} must be a pressure > 0 [Pa]")
        g = np.arange(np.ceil(lo / step) * step, hi + 1e-9, step) if hi > lo else np.zeros(0)
    else:
        g = np.asarray(grid, dtype=float)
        g = g[(g >= lo) & (g <= hi)]
    return g, np.interp(g, *branches[1]) - np.interp(g, *branches[0])


def gap_scores(measured, predicted) -> dict:
    """RMS and maximum |·| of the measured gap and of the gap error (predicted − measured).

    Parameters
    ----------
    measured : array_like
        Measured gap at each compared pressure (pooled over runs). [N]
    predicted : array_like
        Predicted gap at the same pressures (0 for a static law). [N]

    Returns
    -------
    dict
        ``measured_gap_rms_N``, ``measured_gap_max_N``, ``gap_error_rms_N``, ``gap_error_max_N``,
        ``gap_error_ratio`` (error RMS / measured RMS), ``n_pressures``. Squares and absolute
        values only: an error of either sign counts.
    """
    m = np.asarray(measured, dtype=float).ravel()
    e = np.asarray(predicted, dtype=float).ravel() - m
    if m.size == 0:
        nan = float("nan")
        return {"measured_gap_rms_N": nan, "measured_gap_max_N": nan, "gap_error_rms_N": nan, "gap_error_max_N": nan,
                "gap_error_ratio": nan, "n_pressures": 0}
    mr, er = float(np.sqrt(np.mean(m**2))), float(np.sqrt(np.mean(e**2)))
    return {"measured_gap_rms_N": mr, "measured_gap_max_N": float(np.max(np.abs(m))), "gap_error_rms_N": er,
            "gap_error_max_N": float(np.max(np.abs(e))), "gap_error_ratio": er / mr if mr > 0 else float("nan"),
            "n_pressures": int(m.size)}


@dataclass(repr=False)
class DirectionAwareFit(FitBase):
    """A law's direction-aware form fitted to an isometric table (:func:`fit_direction_aware`); a
    fit-family member speaking its :attr:`result`'s words (``to_pandas()`` is the parameter table,
    :meth:`points` the points).

    Attributes
    ----------
    model : str
        The law's registry name. [-]
    structure : str
        ``"play"`` or ``"friction"`` (:data:`~mckibben.models.hysteresis.direction.STRUCTURES`). [-]
    result : FitResult
        The law's parameters followed by the operator's (``play_threshold_Pa``, and
        ``friction_area_m2``), standard errors, flags; ``result.predict(pressure=, length=,
        direction=)`` evaluates a branch far from a reversal (:meth:`predict_branch`).
    muscle : MuscleSpec
        The muscle file the fit used.
    tare : dict
        The sensor report (:func:`mckibben.fit.isometric.isometric_points`).
    data : pandas.DataFrame
        The points in the protocol's order (:func:`run_order`), with ``fitted`` (False: a row at a
        rail or a step of fewer than ``min_samples`` readings, in the history but not in the
        residuals) and ``force_model`` [N] (with the run drift, when fitted).
    runs : list of slice
        Each run's span in :attr:`data`.
    law_force : callable
        The law's NumPy face with the load cell's zero (its fit spec's ``force``).
    """

    model: str
    structure: str
    result: FitResult
    muscle: MuscleSpec
    tare: dict
    data: pd.DataFrame = field(repr=False)
    runs: list = field(repr=False)
    law_force: Callable = field(repr=False)

    RECORD = "result"
    call = "mckibben.fit.direction.fit_direction_aware"
    _repr_keys = ("rmse_N", "play_threshold_Pa", "friction_area_m2", "flags")

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """What was fitted: law, structure, data file, muscle and tare."""
        return {"model": self.model, "structure": self.structure, "source": self.result.source,
                "muscle": self.muscle.id, "tare": self.tare.get("method", "none")}

    def _force(self, values, pressure, length, z, direction, rest_length=None):
        v, _ = _drift(values, self.result.names)  # the drift is the test's, not the muscle's: never predicted
        return direction_aware_force(self.law_force, self.structure, v, pressure, length, z, direction=direction,
                                     rest_length=rest_length)

    @property
    def operator(self) -> dict:
        """The operator's fitted values: ``play_threshold_Pa`` [Pa] (and ``friction_area_m2`` [m²]);
        ``run_drift_ratio`` [-] when the fit had the run-drift nuisance."""
        names = STRUCTURES[self.structure][0] + ((DRIFT_NAME,) if DRIFT_NAME in self.result.names else ())
        return {n: self.result[n] for n in names}

    @property
    def metrics(self) -> dict:
        """``rmse_N``, ``r2``, ``n_points``, the operator's values and ``flags``."""
        return {"rmse_N": self.result.residual_rms, "r2": self.result.r2, "n_points": self.result.n_points,
                **self.operator, "flags": list(self.result.flags)}

    def predict(self, pressure, length, state: float | None = None, rest_length=None) -> tuple[np.ndarray, float]:
        """Force along one pressure sequence at one length, and the play's final state.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure in the order applied, shape (k,). [Pa]
        length : float or array_like
            Held length (broadcast). [m]
        state : float, optional
            The play's output before the first sample (the last call's state, to continue); default
            a muscle just deflated to ``pressure[0]``. [Pa]
        rest_length : float, optional
            A family law's rest length of the muscle. [m]

        Returns
        -------
        force : numpy.ndarray
            [N]
        state : float
            The play's output after the last sample. [Pa]
        """
        p = np.asarray(pressure, dtype=float).ravel()
        if p.size == 0 or not np.all(np.isfinite(p)):
            raise InputError("pressure: must be a non-empty finite sequence [Pa]")
        z, zf = play_pressure(p, self.result["play_threshold_Pa"], state)
        ell = np.broadcast_to(np.asarray(length, dtype=float), p.shape)
        rest = None if rest_length is None else np.broadcast_to(np.asarray(rest_length, dtype=float), p.shape)
        # the direction the pressure last moved, for a law with a branch per direction (a repeated value
        # keeps it); the first sample deflates only when it drags the play down from the given state
        r = self.result["play_threshold_Pa"]
        before = np.inf if state is not None and p[0] < state - r else p[0]
        step = np.sign(np.diff(np.concatenate([[before], p])))
        idx = np.maximum.accumulate(np.where(step != 0, np.arange(p.size), 0))
        dirn = np.where(step[idx] < 0, "deflate", "inflate")
        return self._force(self.result.values, p, ell, z, dirn, rest), zf

    def predict_branch(self, pressure, length, direction="inflate", rest_length=None):
        """Force on a branch far from a reversal (the play at P ∓ r), with out-of-range flags.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        length : array_like
            Held length. [m]
        direction : str or array_like, default "inflate"
            ``"inflate"`` or ``"deflate"``. [-]
        rest_length : array_like, optional
            A family law's rest length. [m]

        Returns
        -------
        force : numpy.ndarray
            [N]
        flags : numpy.ndarray
            :class:`~mckibben.models.flags.Flag` masks.
        """
        extra = {} if rest_length is None else {"rest_length": rest_length}
        return self.result.predict(pressure=pressure, length=length, direction=direction, **extra)

    def pressure(self, force, length, direction="inflate", rest_length=None) -> np.ndarray:
        """The pressure that pulls a force on a branch: the direction-aware form's inverse, for compensation.

        Inflating, a muscle needs more pressure for the same force than deflating (by 2r on a
        ``"play"`` form): a feed-forward picks the branch by the direction the pressure moves.
        Solved by :func:`mckibben.models.law_statics.rising_root` in pressure over the fitted range.

        Parameters
        ----------
        force : array_like
            The force wanted. [N]
        length : array_like
            Held length (broadcast). [m]
        direction : {"inflate", "deflate"}, default "inflate"
            The branch. [-]
        rest_length : float, optional
            A family law's rest length. [m]

        Returns
        -------
        numpy.ndarray
            Gauge pressure; NaN where the fitted range does not reach the force. [Pa]
        """
        if direction not in DIRECTIONS:
            raise InputError(f"direction: {direction!r} is not one of {', '.join(DIRECTIONS)}")
        lo, hi = self.result.valid_range["pressure"]
        extra = {} if rest_length is None else {"rest_length": rest_length}

        def pull(ell, p):  # rising_root scans its second argument: here the pressure
            return self.result.func(self.result.values, pressure=p, length=ell, direction=direction, **extra)

        ell, f = np.broadcast_arrays(np.asarray(length, dtype=float), np.asarray(force, dtype=float))
        p, state = rising_root(pull, ell, f, lo, hi)
        return np.where(state == 0, p, np.nan)

    def to_dict(self) -> dict:
        """JSON-ready: the fit's parameters, errors, flags, structure and tare."""
        return to_jsonable({**self.result.to_dict(), "direction_aware": {"structure": self.structure, **self.operator},
                            "tare": self.tare, "bounds": BOUNDS_NOTE})

    def points(self) -> pd.DataFrame:
        """The points in the protocol's order, whether each was fitted, and the model's force.

        Returns
        -------
        pandas.DataFrame
            ``held_length_m``, ``pressure_Pa``, ``force_N``, ``direction``, ``trial``, ``fitted``,
            ``force_model_N``; provenance in ``attrs``.
        """
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        d = self.data.reset_index(drop=True)
        df = pd.DataFrame({"held_length_m": d["held_length"], "pressure_Pa": d["pressure"], "force_N": d["force"],
                           "direction": d["direction"], "trial": d["trial"], "fitted": d["fitted"],
                           "force_model_N": d["force_model"]})
        df.attrs["provenance"] = provenance(self.call, self.arguments)
        return df

    def plot(self, ax=None):
        """Measured and modelled loops: force against pressure per held length, along each run's history.

        One colour per held length; markers are the measured points (o inflate, v deflate), lines
        the direction-aware model along the same pressure sequence (the modelled loop).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(6.5, 4.2))
        d = self.data.reset_index(drop=True)
        lengths = np.unique(np.round(d["held_length"].to_numpy(dtype=float), 6))
        colors = plt.get_cmap("viridis")(np.linspace(0, 0.85, max(lengths.size, 1)))
        labelled = set()
        first_trial = d["trial"].iloc[0] if len(d) else None
        for s in self.runs:
            run = d.iloc[s]
            if run["trial"].iloc[0] != first_trial:
                continue  # one trial's loops: several trials on one axes hide each other
            k = int(np.argmin(np.abs(lengths - float(run["held_length"].iloc[0]))))
            col = colors[k]
            for dn, mk in (("inflate", "o"), ("deflate", "v")):
                sel = (run["direction"] == dn).to_numpy() & run["fitted"].to_numpy()
                ax.plot(run["pressure"][sel] / 1e3, run["force"][sel], mk, ms=3, color=col, alpha=0.6)
            lab = f"{lengths[k] * 1e3:g} mm" if k not in labelled else None
            labelled.add(k)
            ax.plot(run["pressure"] / 1e3, run["force_model"], "-", lw=1, color=col, label=lab)
        op = f"r = {self.operator['play_threshold_Pa'] / 1e3:.3g} kPa" + (
            f", A_f = {self.operator['friction_area_m2'] * 1e6:.3g} mm²" if "friction_area_m2" in self.operator else "") + (
            f", run drift {self.operator[DRIFT_NAME]:+.1%}" if DRIFT_NAME in self.operator else "")
        ax.set_xlabel("pressure [kPa]")
        ax.set_ylabel("force [N]")
        ax.set_title(f"{self.model} ({self.structure}: {op}), trial {first_trial}\n"
                     "markers measured (o inflate, v deflate), lines modelled", fontsize="small")
        if labelled:
            ax.legend(title="held length", fontsize="small")
        ax.figure.tight_layout()
        return ax.figure


def _law_spec(model: str, muscle: MuscleSpec, fmax: float, d: pd.DataFrame):
    """The law's own fit spec on these points (read, never copied)."""
    data = {"pressure": d["pressure"].to_numpy(dtype=float), "held_length": d["held_length"].to_numpy(dtype=float),
            "force": d["force"].to_numpy(dtype=float), "direction": d["direction"].to_numpy(),
            "rest_length": _rest(d, muscle)}
    return laws.LAWS[model].fit_spec(muscle, fmax, data)


def _rest(d, muscle: MuscleSpec) -> np.ndarray:
    return d["rest_length"].to_numpy(dtype=float) if "rest_length" in d else np.full(len(d), muscle.nominal_length)


def _law_name(model: str) -> str:
    name = model_name(model)
    if name == SURFACE or name not in laws.LAWS:
        raise InputError(f"model: {model!r} is not a registered force law; the direction-aware form takes one of "
                         f"{', '.join(laws.fit_laws())}")
    return name


def _no_fitted_tare(tare: str) -> None:
    """A direction-aware fit has one load-cell zero: ``tare="fitted"`` (a zero per run) is refused by name."""
    if tare == "fitted":
        raise InputError("tare: 'fitted' (a zero per run) applies to the plain laws' fit and compare; a direction-aware"
                         " fit takes none, lowest or column")


def _points(table: Table, tare: str, rails: str, pressure_zero: str, trials=None, min_samples: int = 0):
    """All points (the history) and which of them enter the residuals and the gap (rails and transitions excluded)."""
    _no_fitted_tare(tare)
    d, report = isometric_points(table, tare, "keep", pressure_zero)
    fitted = np.ones(len(d), dtype=bool)
    if rails not in ("keep", "exclude"):
        isometric_points(table, tare, rails, pressure_zero)  # its error names the policy
    if rails == "exclude" or min_samples:
        kept, sel_report = isometric_points(table, tare, rails, pressure_zero, min_samples)
        fitted = d.index.isin(kept.index)
        report = {**report, **{k: sel_report[k] for k in ("rails", "transitions") if k in sel_report}}
    if trials is not None:
        sel = np.isin(d["trial"].to_numpy(), np.asarray(list(trials)))
        if not sel.any():
            raise InputError(f"trials: none of {sorted(trials)} is in {table.path} "
                             f"(trials {sorted(np.unique(d['trial']).tolist())})")
        d, fitted = d[sel], fitted[sel]
    return d.assign(fitted=fitted), report


def _fit_points(d: pd.DataFrame, muscle: MuscleSpec, model: str, structure: str, source: str, drift: bool = False):
    """The joint fit on ordered points: (FitResult, ordered DataFrame with the model's force, runs)."""
    order, runs = run_order(d)
    d = d.iloc[order].reset_index(drop=True)
    fitted = d["fitted"].to_numpy(dtype=bool)
    p = d["pressure"].to_numpy(dtype=float)
    ell = d["held_length"].to_numpy(dtype=float)
    f = d["force"].to_numpy(dtype=float)
    dirn = d["direction"].to_numpy()
    rest = _rest(d, muscle)
    what = f"fit {model} (direction-aware, {structure}) on {source}"
    if is_family(d) and not laws.LAWS[model].family:
        raise InputError(f"{what}: the table holds {d['muscle'].astype(str).nunique()} muscles; {model} is fitted on "
                         f"one muscle (a family law: {', '.join(laws.fit_laws(family=True))})")
    if not np.any(dirn[fitted] == "inflate") or not np.any(dirn[fitted] == "deflate"):
        raise InputError(f"{what}: needs both inflate and deflate rows (the direction column); a loop has two branches")
    fmax = float(np.max(np.abs(f[fitted]))) or 1.0
    spec = _law_spec(model, muscle, fmax, d[fitted])
    nth = len(spec.names)
    pmax = float(np.max(p))
    if not pmax > 0:
        raise InputError(f"{what}: no pressure above zero")
    op_names = STRUCTURES[structure][0]
    area = fmax / pmax  # [m²]: the scale of the friction area
    lo = np.r_[spec.lo, THRESHOLD_MIN_FRACTION * pmax, [0.0] * (len(op_names) - 1)]
    hi = np.r_[spec.hi, THRESHOLD_MAX_FRACTION * pmax, [FRICTION_MAX * area] * (len(op_names) - 1)]
    starts = [np.r_[s, r0 * pmax, [0.02 * area] * (len(op_names) - 1)] for s in spec.starts for r0 in (0.01, 0.04)]
    names = tuple(spec.names) + op_names
    if drift:  # the run-drift nuisance, one for every run, either sign
        names += (DRIFT_NAME,)
        lo, hi = np.r_[lo, -DRIFT_MAX], np.r_[hi, DRIFT_MAX]
        starts = [np.r_[x0, 0.0] for x0 in starts]
    pos = run_position(len(d), runs)

    def along(values, z):
        v, c = _drift(values, names)
        return direction_aware_force(spec.force, structure, v, p, ell, z, direction=dirn, rest_length=rest) * (
            1.0 + c * pos)

    def model_fn(v):
        return along(v, _play_runs(p, runs, float(v[nth])))[fitted]

    def func(values, pressure, length, direction="inflate", rest_length=None):
        v, _ = _drift(values, names)  # a branch of the muscle: the test's drift is not in it
        z = branch_state(pressure, direction, float(v[nth]))
        return direction_aware_force(spec.force, structure, v, pressure, length, z, direction=direction,
                                     rest_length=rest_length)

    physical = (lambda v: spec.physical(v[:nth])) if spec.physical is not None else None
    vr = data_range(pressure=p[fitted], length=ell[fitted])
    res = bounded_fit(model_fn, f[fitted], starts, names, lo, hi, model=model,
                      response="force_N", what=what, valid_range=vr, func=func, clusters=_runs(d[fitted]),
                      source=source, physical_flags=physical, cluster_unit="runs")
    d["force_model"] = along(res.values, _play_runs(p, runs, res["play_threshold_Pa"]))
    return res, d, runs, spec.force


def fit_direction_aware(table: Table, muscle: MuscleSpec, model: str, structure: str = DEFAULT_STRUCTURE,
                        tare: str = "none", rails: str = "exclude", pressure_zero: str = "none",
                        trials=None, min_samples: int = 0, drift: bool = False) -> DirectionAwareFit:
    """Fit a law's direction-aware form (law and operator jointly) to an isometric table.

    Parameters
    ----------
    table : Table
        An ``isometric`` table with ``inflate`` and ``deflate`` rows (a family table for a family law).
    muscle : MuscleSpec
        The muscle file (nominal length, outer diameter; the law's bounds read it).
    model : str
        A registered law with a fit spec (:func:`mckibben.models.laws.fit_laws`). [-]
    structure : {"play", "friction"}, default :data:`DEFAULT_STRUCTURE`
        :data:`~mckibben.models.hysteresis.direction.STRUCTURES`. [-]
    tare : {"none", "lowest", "column"}, default "none"
        :func:`mckibben.data.preprocessing.apply_tare`. [-]
    rails : {"keep", "exclude"}, default "exclude"
        Rows at a sensor's rail: excluded from the residuals (default; they stay in the pressure
        history) or kept. [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        :func:`mckibben.data.preprocessing.apply_pressure_zero`. [-]
    trials : sequence, optional
        Fit only these trials (the others held out). [-]
    min_samples : int, default 0
        Points binned from fewer readings than this (a column ``n_samples``) are a pressure step
        passing through, not a hold (:func:`mckibben.fit.isometric.transition_rows`): excluded from
        the residuals, kept in the pressure history (the play needs the order); 0 fits every point. [-]
    drift : bool, default False
        Fit the run-drift nuisance too: force × (1 + c·s), s the point's place along its run's
        history (:func:`run_position`, 0 at the run's first point, 1 at its last), c
        (``run_drift_ratio``, within ± :data:`DRIFT_MAX`) one for every run of the table, either
        sign. A force that relaxes over a run in proportion to itself (the rubber's stress
        relaxation at a held length, a load cell's creep under load) makes a gap of its own,
        negative where the deflating pass comes long after the inflating one (low pressure). The
        drift belongs to the test, not the muscle: the fit's branches, :meth:`DirectionAwareFit.predict`
        and the inverse leave it out; the bounds and the ``run_drift_ratio_unconstrained`` flag of
        :func:`mckibben.fit.core.bounded_fit` say when the data do not pin it. [-]

    Returns
    -------
    DirectionAwareFit

    References
    ----------
    :mod:`mckibben.models.hysteresis.direction` (Tondu & Lopez 2000 for the friction form; Kuhnen
    2003 for the play); the intervals are cluster-robust by run, as :func:`mckibben.fit.isometric.fit_isometric`.
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    name = _law_name(model)
    if structure not in STRUCTURES:
        raise unknown_name("structure", structure, STRUCTURES)
    d, report = _points(table, tare, rails, pressure_zero, trials, min_samples)
    res, d, runs, force = _fit_points(d, muscle, name, structure, str(table.path), drift)
    return DirectionAwareFit(name, structure, res, muscle, report, d, runs, force)


@dataclass(repr=False)
class HeldoutGap(Result):
    """The up/down gap of held-out trials: measured, a plain law's and its direction-aware form's.

    Attributes
    ----------
    model, structure : str
        The law and the direction-aware structure. [-]
    rows : list of dict
        One per held-out run: ``trial``, ``held_length_m`` (and ``muscle``), ``pressure_Pa`` (the
        grid), ``measured_N``, ``plain_N``, ``direction_aware_N`` (predicted gaps), and the
        held-out force errors ``force_error_plain_N``, ``force_error_direction_aware_N`` (per point).
    fits : list of DirectionAwareFit
        The direction-aware fit of each fold (the last is drawn by :meth:`plot`).
    """

    model: str
    structure: str
    rows: list = field(repr=False)
    fits: list = field(repr=False, default_factory=list)

    call = "mckibben.fit.direction.heldout_gap"
    _repr_keys = ("measured_gap_rms_N", "plain_gap_error_rms_N", "direction_aware_gap_error_rms_N")

    @property
    def arguments(self) -> dict:
        """The law, structure and the held-out trials."""
        return {"model": self.model, "structure": self.structure,
                "held_out_trials": sorted({r["trial"] for r in self.rows})}

    @property
    def metrics(self) -> dict:
        """Pooled over the held-out runs: measured gap RMS/max, each model's gap error RMS/max and ratio, force RMSE."""
        if not self.rows:
            meas, plain, da = np.zeros(0), np.zeros(0), np.zeros(0)
            fp, fd = np.zeros(0), np.zeros(0)
        else:
            meas = np.concatenate([r["measured_N"] for r in self.rows])
            plain = np.concatenate([r["plain_N"] for r in self.rows])
            da = np.concatenate([r["direction_aware_N"] for r in self.rows])
            fp = np.concatenate([r["force_error_plain_N"] for r in self.rows])
            fd = np.concatenate([r["force_error_direction_aware_N"] for r in self.rows])
        sp, sd = gap_scores(meas, plain), gap_scores(meas, da)

        def rmse(x):
            return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")

        return {"measured_gap_rms_N": sp["measured_gap_rms_N"], "measured_gap_max_N": sp["measured_gap_max_N"],
                "plain_gap_error_rms_N": sp["gap_error_rms_N"], "plain_gap_error_max_N": sp["gap_error_max_N"],
                "direction_aware_gap_error_rms_N": sd["gap_error_rms_N"],
                "direction_aware_gap_error_max_N": sd["gap_error_max_N"],
                "direction_aware_gap_error_ratio": sd["gap_error_ratio"], "n_pressures": sp["n_pressures"],
                "n_runs": len(self.rows), "heldout_rmse_plain_N": rmse(fp), "heldout_rmse_direction_aware_N": rmse(fd)}

    def _series(self) -> pd.DataFrame:
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        parts = [pd.DataFrame({"trial": r["trial"], "held_length_m": r["held_length_m"], "muscle": r.get("muscle", ""),
                               "pressure_Pa": r["pressure_Pa"], "measured_gap_N": r["measured_N"],
                               "plain_gap_N": r["plain_N"], "direction_aware_gap_N": r["direction_aware_N"]})
                 for r in self.rows]
        return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()

    def plot(self, ax=None):
        """Predicted against measured gap at every held-out pressure (the diagonal is a perfect model).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if ax is None:
            _, ax = plt.subplots(figsize=(4.5, 4.2))
        df = self._series()
        m = self.metrics
        ax.plot(df["measured_gap_N"], df["plain_gap_N"], ".", ms=3, alpha=0.5,
                label=f"plain (error RMS {m['plain_gap_error_rms_N']:.2f} N)")
        ax.plot(df["measured_gap_N"], df["direction_aware_gap_N"], ".", ms=3, alpha=0.5,
                label=f"{self.structure} (error RMS {m['direction_aware_gap_error_rms_N']:.2f} N)")
        lim = [float(np.nanmin(df.iloc[:, 4:].to_numpy())), float(np.nanmax(df.iloc[:, 4:].to_numpy()))] if len(df) else [0, 1]
        ax.plot(lim, lim, "k-", lw=0.8)
        ax.set_xlabel("measured gap, deflate − inflate [N]")
        ax.set_ylabel("predicted gap [N]")
        ax.set_title(f"{self.model}: held-out up/down gap", fontsize="small")
        ax.legend(fontsize="small")
        ax.figure.tight_layout()
        return ax.figure


def _plain_force(res: FitResult, d: pd.DataFrame, muscle: MuscleSpec) -> np.ndarray:
    extra = {"rest_length": d["rest_length"].to_numpy(dtype=float)} if "rest_length" in d else {}
    return np.asarray(res.func(res.values, pressure=d["pressure"].to_numpy(dtype=float),
                               length=d["held_length"].to_numpy(dtype=float), direction=d["direction"].to_numpy(),
                               **extra), dtype=float)


def heldout_gap(table: Table, muscle: MuscleSpec, model: str, structure: str = DEFAULT_STRUCTURE,
                test_trials=None, tare: str = "none", rails: str = "exclude", pressure_zero: str = "none",
                grid=None, min_samples: int = 0, drift: bool = False, cache: dict | None = None) -> HeldoutGap:
    """Each trial held out in turn: the measured up/down gap and the gap a plain and a direction-aware law predict.

    For each held-out trial, the plain law (:func:`mckibben.fit.isometric.fit_points`) and its
    direction-aware form (:func:`fit_direction_aware`) are fitted on the other trials; both predict
    every point of the held-out trial (the direction-aware form along each run's history, from a
    muscle just deflated), and each run's gap (:func:`loop_gap`, on the rows not at a rail) is
    compared with the measured one.

    Parameters
    ----------
    table : Table
        An ``isometric`` table with two trials or more.
    muscle : MuscleSpec
        The muscle file.
    model : str
        A registered law with a fit spec. [-]
    structure : {"play", "friction"}, default :data:`DEFAULT_STRUCTURE`
        The direction-aware structure. [-]
    test_trials : sequence, optional
        The trials to hold out (each in turn); default every trial. [-]
    tare, rails, pressure_zero : str
        As :func:`fit_direction_aware`. [-]
    grid : array_like, optional
        The gap's pressures (:func:`loop_gap`); default every 10 kPa both branches cover. [Pa]
    min_samples : int, default 0
        As :func:`fit_direction_aware`: points from fewer readings are left out of both fits and
        of the measured and predicted gaps, and kept in each run's history. [-]
    drift : bool, default False
        As :func:`fit_direction_aware`: the drift fitted on the other trials, applied along each
        held-out run's own order (a prediction: the held-out trial gives it no value). [-]
    cache : dict, optional
        Fits to reuse, keyed by the law, the structure, the drift and the training points' content:
        pass one dict to several calls that fit on the same points (a nested comparison's inner
        folds fit each single trial twice) and each fit is made once. The results are those of
        fitting again. [-]

    Returns
    -------
    HeldoutGap
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    check_instance(cache, "cache", dict, "a dict (shared by the calls whose fits it keeps)", optional=True)
    name = _law_name(model)
    if structure not in STRUCTURES:
        raise unknown_name("structure", structure, STRUCTURES)
    d_all, _ = _points(table, tare, rails, pressure_zero, min_samples=min_samples)
    trials = np.unique(d_all["trial"].to_numpy())
    if trials.size < 2:
        raise InputError(f"heldout_gap on {table.path}: needs two trials or more (one to fit, one held out); "
                         f"it has {trials.size}")
    tests = trials if test_trials is None else np.asarray(list(test_trials))
    missing = [t for t in tests if t not in trials]
    if missing:
        raise InputError(f"test_trials: {missing} not in {table.path} (trials {trials.tolist()})")
    rows, fits = [], []
    for t in tests:
        train = d_all[d_all["trial"] != t]
        test = d_all[d_all["trial"] == t]
        plain, res, force = _train_fits(train, muscle, name, structure, str(table.path), drift, cache)
        fit = DirectionAwareFit(name, structure, res, muscle, {}, *_fit_frame(res, test, force, structure), force)
        fits.append(fit)
        td = fit.data
        fp = _plain_force(plain, td, muscle)
        for s in fit.runs:
            run = td.iloc[s]
            ok = run["fitted"].to_numpy()
            pr, dn = run["pressure"].to_numpy(dtype=float)[ok], run["direction"].to_numpy()[ok]
            g, meas = loop_gap(pr, run["force"].to_numpy(dtype=float)[ok], dn, grid)
            _, gp = loop_gap(pr, fp[s][ok], dn, g if g.size else None)
            _, gd = loop_gap(pr, run["force_model"].to_numpy(dtype=float)[ok], dn, g if g.size else None)
            if g.size == 0:
                continue
            row = {"trial": t.item() if hasattr(t, "item") else t, "held_length_m": float(run["held_length"].iloc[0]),
                   "pressure_Pa": g, "measured_N": meas, "plain_N": gp, "direction_aware_N": gd,
                   "force_error_plain_N": (fp[s] - run["force"].to_numpy(dtype=float))[ok],
                   "force_error_direction_aware_N": (run["force_model"] - run["force"]).to_numpy(dtype=float)[ok]}
            if "muscle" in run:
                row["muscle"] = str(run["muscle"].iloc[0])
            rows.append(row)
    return HeldoutGap(name, structure, rows, fits)


def _train_fits(train: pd.DataFrame, muscle: MuscleSpec, name: str, structure: str, source: str, drift: bool,
                cache: dict | None):
    """The plain law and its direction-aware form fitted on ``train``: (plain FitResult, FitResult, the law's force),
    taken from ``cache`` when the same law, structure and drift were fitted on the same points."""
    key = None
    if cache is not None:
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        content = pd.util.hash_pandas_object(train, index=False).to_numpy().tobytes()
        key = (name, structure, bool(drift), repr(muscle), source, tuple(train.columns), content)
        if key in cache:
            return cache[key]
    plain = fit_points(train[train["fitted"]].drop(columns="fitted"), muscle, name, source=source)
    res, _, _, force = _fit_points(train, muscle, name, structure, source, drift)
    if key is not None:
        cache[key] = (plain, res, force)
    return plain, res, force


def _fit_frame(res: FitResult, d: pd.DataFrame, law_force, structure: str):
    """Held-out points in the protocol's order with the fitted model's force along their history."""
    order, runs = run_order(d)
    d = d.iloc[order].reset_index(drop=True)
    p = d["pressure"].to_numpy(dtype=float)
    z = _play_runs(p, runs, res["play_threshold_Pa"])
    rest = d["rest_length"].to_numpy(dtype=float) if "rest_length" in d else None
    v, c = _drift(res.values, res.names)  # the fitted drift, on the held-out run's own order (no value of its own)
    d["force_model"] = direction_aware_force(law_force, structure, v, p, d["held_length"].to_numpy(dtype=float), z,
                                             direction=d["direction"].to_numpy(), rest_length=rest) * (
        1.0 + c * run_position(len(d), runs))
    return d, runs


def gap_laws(d: pd.DataFrame) -> list[str]:
    """The laws a direction-aware comparison tries when none are named: every registered law with a
    fit, the family laws on a family table (:func:`mckibben.models.laws.fit_laws`).

    Parameters
    ----------
    d : pandas.DataFrame
        The table's points (:func:`~mckibben.fit.isometric.isometric_points`). [-]
    """
    return list(laws.fit_laws(family=True) if is_family(d) else laws.fit_laws())


def compare_direction_aware(table: Table, muscle: MuscleSpec, models=None, structure: str = DEFAULT_STRUCTURE,
                            tare: str = "none", rails: str = "exclude", pressure_zero: str = "none",
                            grid=None, min_samples: int = 0, drift: bool = False) -> list[dict]:
    """Each law beside its direction-aware form, on held-out trials: what ``compare --direction-aware`` adds.

    Parameters
    ----------
    table : Table
        An ``isometric`` table with inflate and deflate rows and two trials or more.
    muscle : MuscleSpec
        The muscle file.
    models : sequence of str, optional
        Laws to score; default every law with a fit spec that applies (the family laws on a family
        table). [-]
    structure : {"play", "friction"}, default :data:`DEFAULT_STRUCTURE`
        The direction-aware structure. [-]
    tare, rails, pressure_zero : str
        As :func:`fit_direction_aware`. [-]
    grid : array_like, optional
        The gap's pressures (:func:`loop_gap`). [Pa]
    min_samples : int, default 0
        As :func:`heldout_gap`. [-]
    drift : bool, default False
        As :func:`heldout_gap`. [-]

    Returns
    -------
    list of dict
        Per law: ``model``, ``structure``, ``cv`` (``"leave-one-trial-out"``), the pooled
        :attr:`HeldoutGap.metrics` (measured gap RMS/max; plain and direction-aware gap error RMS/max;
        held-out force RMSE of both), the operator's values per fold (``play_threshold_Pa``; and
        ``run_drift_ratio`` with ``drift``), and ``note`` (why a law could not be scored).
    """
    _no_fitted_tare(tare)
    transition_rows(table, min_samples)  # a bad threshold or a missing column: one error, not one note per law
    if models is None:
        models = gap_laws(isometric_points(table, tare, "keep", pressure_zero)[0])
    out = []
    for model in models:
        row: dict = {"model": model, "structure": structure, "cv": "leave-one-trial-out"}
        try:
            h = heldout_gap(table, muscle, model, structure, tare=tare, rails=rails, pressure_zero=pressure_zero,
                            grid=grid, min_samples=min_samples, drift=drift)
        except InputError as exc:
            out.append({**row, "note": f"not fitted: {exc}"})
            continue
        drifts = {DRIFT_NAME: [f.result[DRIFT_NAME] for f in h.fits]} if drift else {}
        out.append({**row, **h.metrics, "play_threshold_Pa": [f.result["play_threshold_Pa"] for f in h.fits], **drifts,
                    "flags": sorted({fl for f in h.fits for fl in f.result.flags}), "note": ""})
    return out


def fit_isotonic_friction(table: Table, muscle: MuscleSpec, model: str, *, tube: bool = False,
                          start=None, held: FitResult | None = None, slip_pressure=None,
                          constant: bool = False, width=None) -> FitResult:
    """A law's ``"friction"`` form fitted to the up/down branches of isotonic sweeps: law ∓ (F_0 + A_f·P) = load.

    Each point (P, load, L, direction) of a hysteresis table (an isotonic sweep's rows with their
    branch) is a muscle far along a branch of its loop: the pressure has moved one way since the
    last step and the braid slipped, so its friction is at its limit, against the motion. Inflating
    (contracting) the muscle pulls the load plus the friction, deflating the load less it:
    F_law(P, L) − (F_0 + A_f·P) = load on the inflating branch, F_law(P, L) + (F_0 + A_f·P) = load on
    the deflating one (:func:`mckibben.models.hysteresis.direction.branch_force`, the ``"friction"``
    structure at its branch state; a Dahl element's slip limit, a constant (Coulomb) part F_0 and a
    part proportional to pressure). The law's parameters (its own fit spec, read, never copied; the
    law's inflate branch for every point: the friction, not a second branch of the law, makes the
    loop), the tube's stiffness with ``tube`` (:mod:`mckibben.models.tube`) and A_f (with ``constant``
    F_0 too), one each for every load, are fitted jointly; or, given ``held`` (the same law fitted to
    the branches' mean, the friction-free length), the law is held there and the friction alone is
    fitted on the branches (two stages: the law keeps its fit and its intervals, the friction gets its
    own). F_0 is told from A_f·P by the pressures' spread only: where the data do not tell them apart
    (F_0's 95 % interval reaches zero) it is flagged ``friction_force_N_unconstrained``, and a law
    that misses the branches' force by more than the friction trades one for the other (measured on
    ``mckibben rig characterize``'s example: ``docs/rig.md``), so F_0 is fitted only when asked.

    **Where the braid slipped.** A branch's point sits where the friction last slipped, at the
    pressure of that moment, not at the mean pressure of the hold: a pressure controller's ripple
    at a held set-point (or its overshoot) contracts an inflating muscle at each peak, and the
    friction then holds it there while the pressure falls back by less than the friction's width
    (the Dahl element, ``docs/plant.md``); likewise a deflating muscle at each trough. So the
    loop measured at the mean pressure is narrower than the braid's by about twice the ripple's
    reach. ``slip_pressure`` gives that pressure per point (the highest of the step on an
    inflating one, the lowest on a deflating one: ``mckibben rig characterize`` records both), and
    the branch's force is evaluated there.

    **On the loop's width.** Given ``held`` and ``width`` (per row, the label of its set-point: one
    load, one trial, one commanded pressure), the friction is fitted on the difference of the two
    branch equations at each set-point both branches visited instead of on each branch:
    F_law(P_u, L_u) − F_law(P_d, L_d) = 2·F_0 + A_f·(P_u + P_d) (P_u, L_u and P_d, L_d the
    inflating and deflating points' slip pressures and lengths, the rows of one branch averaged).
    The held law's systematic miss, nearly the same on both branches at nearby (P, L), cancels
    there, so it no longer trades F_0 for A_f (measured on ``mckibben rig characterize``'s example:
    ``docs/rig.md``). The residuals are then the widths' misses [N], one per set-point.

    Parameters
    ----------
    table : Table
        A ``hysteresis`` table (pressure, load, length, direction, trial), both branches; the rows where
        the muscle hangs on an end stop left out by the caller. [-]
    muscle : MuscleSpec
        The muscle file (nominal length, outer diameter; the law's bounds read it). [-]
    model : str
        A registered law with a fit spec (:func:`mckibben.models.laws.fit_laws`). [-]
    tube : bool, default False
        Fit the tube's stretch past the rest length with the law. [-]
    start : array_like, optional
        A start for the law's parameters (and the tube's, with ``tube``), e.g. a static fit's values
        (:func:`mckibben.fit.isometric.fit_isotonic_law`); default the law's own starts. Ignored
        with ``held``. [SI]
    held : FitResult, optional
        The law (with its tube's stiffness, with ``tube``) already fitted to the friction-free
        lengths (:func:`mckibben.fit.isometric.fit_isotonic_law` on the branches' mean): its values
        are held, and only A_f is fitted. The result carries the law's values, standard errors and
        valid range as ``held`` has them, and A_f's own. Default: law and A_f fitted jointly. [-]
    slip_pressure : array_like, optional
        Per row, the gauge pressure at which the braid last slipped (see above); default the
        table's pressure. [Pa]
    constant : bool, default False
        Fit the friction's constant part F_0 beside A_f·P; default A_f alone (F_0 = 0). [-]
    width : array_like, optional
        Per row, a label of its set-point (rows of one load, one trial and one commanded pressure
        share it); with ``held``, the friction is fitted on the loop's width at each label that has
        both branches (see above); default on each branch point. [-]

    Returns
    -------
    FitResult
        The law's parameters (the tube's stiffness with ``tube``), then (with ``constant``)
        ``friction_force_N`` F_0 [N], and ``friction_area_m2`` A_f [m²];
        ``result.predict(pressure=, length=, direction=)`` gives the branch's force (``direction``
        "inflate" or "deflate"). Residuals in force [N].

    References
    ----------
    Tondu & Lopez (2000), their friction force proportional to pressure (the form); Dahl (1968)
    for the slip limit and its constant part (the plant's braid friction, ``docs/plant.md``).
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    name = _law_name(model)
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    if table.kind != "hysteresis" or "direction" not in table.data:
        raise InputError(f"fit {name} (friction) on {table.path}: needs a hysteresis table (pressure, load, length, "
                         f"direction); it is a {table.kind} table")
    t = table.data
    d = pd.DataFrame({"held_length": t["length"].to_numpy(dtype=float), "pressure": t["pressure"].to_numpy(dtype=float),
                      "force": t["load"].to_numpy(dtype=float), "direction": t["direction"].to_numpy(dtype=object),
                      "trial": t["trial"].to_numpy() if "trial" in t else np.ones(len(t))})
    dirn = d["direction"].to_numpy()
    bad = ~np.isin(dirn, list(DIRECTIONS))
    if bad.any():
        raise InputError(f"{table.path}: direction {dirn[bad][0]!r} is not one of {', '.join(DIRECTIONS)}")
    what = f"fit {name} (friction, isotonic branches) on {table.path}"
    if not np.any(dirn == "inflate") or not np.any(dirn == "deflate"):
        raise InputError(f"{what}: needs both inflate and deflate rows; a loop has two branches")
    p = d["pressure"].to_numpy(dtype=float)
    if slip_pressure is not None:
        p = np.asarray(slip_pressure, dtype=float).ravel()
        if p.size != len(d) or not np.all(np.isfinite(p)):
            raise InputError(f"slip_pressure: {p.size} values, {np.count_nonzero(~np.isfinite(p))} not finite; "
                             f"want one finite pressure [Pa] per row of {table.path} ({len(d)})")
    ell = d["held_length"].to_numpy(dtype=float)
    f = d["force"].to_numpy(dtype=float)
    pmax = float(np.max(p))
    if not pmax > 0:
        raise InputError(f"{what}: no pressure above zero")
    fmax = float(np.max(np.abs(f))) or 1.0
    spec = _law_spec(name, muscle, fmax, d)
    law_force, names, lo, hi, starts = spec.force, tuple(spec.names), spec.lo, spec.hi, list(spec.starts)
    if tube:
        k_max = fmax / (TUBE_MAX_STRAIN * muscle.nominal_length)
        law_force = with_tube(spec.force, muscle.nominal_length)
        names, lo, hi = names + (TUBE_NAME,), np.r_[lo, 0.0], np.r_[hi, k_max]
        starts = [np.r_[x0, 0.05 * k_max] for x0 in starts]
    n_law = len(names)
    if width is not None and held is None:
        raise InputError("width: fitting the friction on the loop's width needs the law held (held=, the law fitted "
                         "to the branches' mean)")
    if held is not None:
        return _fit_friction_held(held, law_force, names, p, ell, f, dirn, d["trial"].to_numpy(), fmax, pmax,
                                  constant, what=what, model=name, source=str(table.path), width=width)
    if start is not None:
        x0 = np.clip(np.asarray(start, dtype=float).ravel()[:n_law], lo, hi)
        if x0.size != n_law:
            raise InputError(f"start: {x0.size} values, the law has {n_law}")
        starts = [x0]
    terms, f_lo, f_hi, f_starts = _friction_terms(fmax, pmax, constant)
    lo, hi = np.r_[lo, f_lo], np.r_[hi, f_hi]
    starts = [np.r_[x0, s0] for x0 in starts for s0 in f_starts]
    names = names + terms
    func = _friction_func(law_force, len(terms))

    physical = (lambda v: spec.physical(v[:len(spec.names)])) if spec.physical is not None else None
    res = bounded_fit(lambda v: func(v, p, ell, dirn), f, starts, names, lo, hi, model=name, response="force_N",
                      what=what, valid_range=data_range(pressure=p, length=ell), func=func,
                      clusters=d["trial"].to_numpy(), source=str(table.path), physical_flags=physical,
                      priors=spec.priors)
    return _flag_friction_force(res)


def _friction_terms(fmax: float, pmax: float, constant: bool) -> tuple[tuple, np.ndarray, np.ndarray, list]:
    """The friction's terms as a fit names them ((F_0 [N],) A_f [m²]), their bounds and starts: each at most
    :data:`FRICTION_MAX` of the peak load (A_f·P at the peak pressure), from small starts."""
    area = fmax / pmax  # [m²]: the scale of the friction area
    if not constant:
        return (FRICTION_NAME,), np.zeros(1), np.r_[FRICTION_MAX * area], [np.r_[a0 * area] for a0 in (0.02, 0.1)]
    starts = [np.r_[c0 * fmax, a0 * area] for c0 in (0.005, 0.05) for a0 in (0.02, 0.1)]
    return ((FRICTION_FORCE_NAME, FRICTION_NAME), np.zeros(2), np.r_[FRICTION_MAX * fmax, FRICTION_MAX * area],
            starts)


def _friction_func(law_force, n_terms: int):
    """``func(values, pressure, length, direction)``: the law's values, then the friction's ``n_terms`` ((F_0,) A_f),
    far along each point's branch (:func:`~mckibben.models.hysteresis.direction.branch_force`)."""
    def func(values, pressure, length, direction="inflate", rest_length=None):
        v = np.asarray(values, dtype=float)
        f0 = v[-2] if n_terms == 2 else 0.0
        return branch_force(law_force, v[:-n_terms], v[-1], pressure, length, direction, friction_force=f0,
                            direction="inflate", rest_length=rest_length)
    return func


def _flag_friction_force(res: FitResult) -> FitResult:
    """With F_0 fitted, flag each friction term ``<name>_unconstrained`` (F_0's, A_f's) when its 95 % interval
    reaches zero (the data do not tell that part of the friction from none), unless a bound flag already says so;
    a fit without F_0 as it is."""
    if FRICTION_FORCE_NAME not in res.names:
        return res
    flags = res.flags
    for name in (FRICTION_FORCE_NAME, FRICTION_NAME):
        lo95 = float(res.ci95[res.names.index(name)][0])
        if not (any(fl.startswith(name) for fl in flags) or (np.isfinite(lo95) and lo95 > 0)):
            flags = flags + (f"{name}_unconstrained",)
    return replace(res, flags=flags)


def _width_pairs(width, dirn: np.ndarray, trials: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The loop's width at each set-point label that has both branches, as a matrix W (one row per such label:
    +1/n over its inflating rows, −1/n over its deflating ones), and each row's trial: W·(branch force − load) is
    each width's miss. [-]"""
    lab = np.asarray(width, dtype=object).ravel()
    if lab.size != dirn.size:
        raise InputError(f"width: {lab.size} labels; want one set-point label per row ({dirn.size})")
    _, inv = np.unique(lab.astype(str), return_inverse=True)
    rows, clusters = [], []
    for g in range(int(inv.max()) + 1):
        up, down = (inv == g) & (dirn == "inflate"), (inv == g) & (dirn == "deflate")
        if up.any() and down.any():
            rows.append(up / up.sum() - down / down.sum())
            clusters.append(trials[up][0])
    return (np.array(rows, dtype=float).reshape(-1, dirn.size), np.array(clusters))


def _fit_friction_held(held: FitResult, law_force, names, p, ell, f, dirn, trials, fmax: float, pmax: float,
                       constant: bool, *, what: str, model: str, source: str, width=None) -> FitResult:
    """The friction alone on the branches (or, with ``width``, on the loop's width at each set-point), the law held
    at ``held``'s values: :func:`fit_isotonic_friction`'s second stage.

    ``fmax``, ``pmax`` are the data's peak load [N] and pressure [Pa] (the friction's scales); the rest as there.
    """
    check_instance(held, "held", FitResult, "a FitResult (mckibben.fit.isometric.fit_isotonic_law)")
    if tuple(held.names) != tuple(names):
        raise InputError(f"held: its parameters {', '.join(held.names)} are not the law's {', '.join(names)} "
                         f"(fit the same law{' with the tube' if TUBE_NAME in names else ''} first)")
    law = np.asarray(held.values, dtype=float)

    terms, f_lo, f_hi, f_starts = _friction_terms(fmax, pmax, constant)
    func = _friction_func(law_force, len(terms))
    if width is None:
        fr = _flag_friction_force(bounded_fit(lambda v: func(np.r_[law, v], p, ell, dirn), f, f_starts, terms,
                                              f_lo, f_hi, model=model, response="force_N", what=f"{what}, the law held",
                                              valid_range=data_range(pressure=p, length=ell), func=func,
                                              clusters=trials, source=source))
    else:
        w, clusters = _width_pairs(width, dirn, trials)
        if len(w) <= len(terms):
            raise InputError(f"width: {len(w)} set-points with both branches; the loop's width needs more than "
                             f"{len(terms)} to fit {', '.join(terms)}")
        # each width's miss, W·(branch force − load): the same branch form as above, differenced per set-point
        fr = _flag_friction_force(bounded_fit(lambda v: w @ (func(np.r_[law, v], p, ell, dirn) - f), np.zeros(len(w)),
                                              f_starts, terms, f_lo, f_hi, model=model, response="force_N",
                                              what=f"{what}, the law held, on the loop's width",
                                              valid_range=data_range(pressure=p, length=ell), func=func,
                                              clusters=clusters, source=source))
        # every width's target is 0 (the same load on both branches): R² has nothing to explain, its flag no meaning
        fr = replace(fr, flags=tuple(x for x in fr.flags if not x.startswith("r2_")))
    n, k = len(law), len(terms)
    cov = np.zeros((n + k, n + k))
    cov[:n, :n] = held.covariance
    cov[n:, n:] = fr.covariance
    return replace(fr, names=tuple(names) + terms, values=np.r_[law, fr.values], covariance=cov,
                   valid_range=dict(held.valid_range), flags=tuple(dict.fromkeys((*held.flags, *fr.flags))),
                   notes=tuple(dict.fromkeys((*held.notes, *fr.notes))), priors=dict(held.priors))
