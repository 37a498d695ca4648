"""What a designer wants from a sweep: the best setting under a constraint, a Pareto front,
and the sensitivity of each metric to each parameter.

A *setting* is one grid point (the values a designer chooses: gains, supply, muscle); the random
draws at each grid point are the plants it must cope with, so settings are judged on quantiles
over those draws.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import re

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_instance, check_real, unknown_name
from mckibben.plotting import save_figure
from mckibben.results import check_ax, provenance
from mckibben.sweep.spec import METRICS
from mckibben.atomic import check_output_dir

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pandas as pd

_CONSTRAINT = re.compile(r"^\s*([a-zA-Z_]+)\s*(<=|>=|<|>)\s*([-+0-9.eE]+)\s*$")


def _check_table(table, name: str = "table", need: tuple = ()) -> None:
    """``table`` a DataFrame of sweep results (:func:`~mckibben.sweep.run.read_results`) with ``need`` columns."""
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    check_instance(table, name, pd.DataFrame, "a DataFrame of sweep results (read_results)")
    missing = [c for c in need if c not in table.columns]
    if missing:
        raise InputError(f"{name}: no column {', '.join(map(repr, missing))}; is it a sweep's results (read_results)?")


def _check_quantile(quantile) -> float:
    return check_real(quantile, "quantile", lo=0.0, hi=1.0, lo_open=True, hi_open=True)


def parameter_columns(table: pd.DataFrame) -> list[str]:
    """The swept parameters (plant.* and controller.* columns that vary).

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    """
    _check_table(table)
    cols = [c for c in table.columns if c.startswith(("plant.", "controller."))]
    return [c for c in cols if table[c].nunique() > 1]


def metric_columns(table: pd.DataFrame) -> list[str]:
    """The metric columns of a results table.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    """
    _check_table(table)
    return [m for m in METRICS if m in table.columns]


def settings_table(table: pd.DataFrame, quantile: float = 0.95) -> pd.DataFrame:
    """Per grid point: its parameter values, and the median and ``quantile`` of every metric.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    quantile : float, default 0.95
        The upper quantile reported beside the median. [-]
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    quantile = _check_quantile(quantile)
    _check_table(table, need=("grid_id",))
    grid_cols = [c for c in parameter_columns(table) if table.groupby("grid_id")[c].nunique().max() == 1]
    metrics = metric_columns(table)
    g = table.groupby("grid_id")
    out = g[grid_cols].first() if grid_cols else pd.DataFrame(index=g.size().index)
    out["plants"] = g.size()
    for m in metrics:
        out[f"{m}_median"] = g[m].median()
        out[f"{m}_q{int(round(quantile * 100))}"] = g[m].quantile(quantile)
    return out.reset_index()


def best_setting(table: pd.DataFrame, objective: str = "time_constant_s", constraint: str = "overshoot_pct<=10",
                 quantile: float = 0.95) -> dict | None:
    """The setting with the lowest median ``objective`` whose ``quantile`` meets the constraint.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    objective : str
        Metric to minimise (its median over the plants). [-]
    constraint : str
        ``METRIC<=VALUE`` (or ``<``, ``>=``, ``>``) that the metric's ``quantile`` must satisfy. [-]
    quantile : float, default 0.95
        "in 95 % of plants". [-]
    """
    quantile = _check_quantile(quantile)  # the arguments first, then the table they apply to
    if not isinstance(objective, str):
        raise ArgumentTypeError(f"objective: a metric name (text), not {type(objective).__name__}")
    if not isinstance(constraint, str):
        raise ArgumentTypeError(f"constraint: text like overshoot_pct<=10, not {type(constraint).__name__}")
    m = _CONSTRAINT.match(constraint)
    if not m:
        raise InputError(f"constraint: {constraint!r} must look like overshoot_pct<=10")
    if objective not in METRICS:
        raise unknown_name("objective metric", objective, METRICS)
    _check_table(table, need=("grid_id",))
    metrics = metric_columns(table)
    if objective not in metrics:
        raise unknown_name("objective metric", objective, metrics)
    name, op, value = m.group(1), m.group(2), float(m.group(3))
    if name not in metrics:
        raise unknown_name("constraint metric", name, metrics)
    s = settings_table(table, quantile)
    q = s[f"{name}_q{int(round(quantile * 100))}"]
    ok = {"<=": q <= value, "<": q < value, ">=": q >= value, ">": q > value}[op]
    feasible = s[ok & s[f"{objective}_median"].notna()]
    if feasible.empty:
        return None
    return feasible.sort_values(f"{objective}_median").iloc[0].to_dict()


def pareto_front(settings: pd.DataFrame, objectives: list[str]) -> pd.DataFrame:
    """The settings no other setting beats in every objective (all minimised).

    Parameters
    ----------
    settings : pandas.DataFrame
        From :func:`settings_table`.
    objectives : list of str
        Columns of ``settings`` to minimise. [-]
    """
    _check_table(settings, "settings")
    if isinstance(objectives, str) or not isinstance(objectives, (list, tuple)) or not objectives:
        raise ArgumentTypeError(f"objectives: a non-empty list of column names, not {objectives!r}")
    for o in objectives:
        if o not in settings.columns:
            raise unknown_name("objectives column", o, [str(c) for c in settings.columns])
    v = settings[objectives].to_numpy(dtype=float)
    keep = np.ones(len(v), dtype=bool)
    for i in range(len(v)):
        if not np.all(np.isfinite(v[i])):
            keep[i] = False
            continue
        dominated = np.all(v <= v[i], axis=1) & np.any(v < v[i], axis=1)
        keep[i] = not dominated.any()
    return settings[keep]


def sensitivity(table: pd.DataFrame) -> pd.DataFrame:
    """Spearman rank correlation of every metric with every swept parameter.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    from scipy.stats import spearmanr  # deferred on purpose: SciPy
    params = [c for c in parameter_columns(table) if pd.api.types.is_numeric_dtype(table[c])]
    metrics = metric_columns(table)
    out = pd.DataFrame(index=params, columns=metrics, dtype=float)
    for p in params:
        for m in metrics:
            ok = table[[p, m]].dropna()
            if len(ok) > 2 and ok[m].nunique() > 1:
                out.loc[p, m] = spearmanr(ok[p], ok[m]).statistic
    return out


def plot_pareto(table: pd.DataFrame, quantile: float = 0.95, ax=None):
    """Settings: median time constant against median valve effort, coloured by the overshoot
    quantile, with the Pareto front; return the Figure (None when the metrics are missing).

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    quantile : float, default 0.95
        Quantile used for the overshoot colour. [-]
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    check_ax(ax)
    s = settings_table(table, quantile)
    qn = int(round(quantile * 100))
    if not {"time_constant_s_median", "valve_effort_counts_median"} <= set(s.columns):
        return None
    if ax is None:
        fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=120)
    fig = ax.figure
    color = s.get(f"overshoot_pct_q{qn}", pd.Series(np.zeros(len(s))))
    sc = ax.scatter(s["time_constant_s_median"] * 1e3, s["valve_effort_counts_median"], c=color, cmap="viridis", s=36)
    objs = ["time_constant_s_median", "valve_effort_counts_median"] + ([f"overshoot_pct_q{qn}"] if f"overshoot_pct_q{qn}" in s else [])
    front = pareto_front(s, objs).sort_values("time_constant_s_median")
    ax.plot(front["time_constant_s_median"] * 1e3, front["valve_effort_counts_median"], "r-o", mfc="none", ms=9,
            label="Pareto front")
    fig.colorbar(sc, ax=ax, label=f"overshoot, {qn}th percentile of plants [%]")
    ax.set_xlabel("time constant, median over plants [ms]")
    ax.set_ylabel("valve effort Σ|PWM|, median [counts]")
    ax.set_title("Settings: speed vs air used vs overshoot", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_sensitivity(table: pd.DataFrame, ax=None):
    """Spearman rank correlation of each metric with each swept parameter, as a heat map; return
    the Figure (None when nothing varies).

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]
    """
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    check_ax(ax)
    sens = sensitivity(table)
    if sens.empty:
        return None
    if ax is None:
        fig, ax = plt.subplots(figsize=(1.6 + 1.3 * len(sens.columns), 1.2 + 0.5 * len(sens.index)), dpi=120)
    fig = ax.figure
    im = ax.imshow(sens.to_numpy(dtype=float), cmap="coolwarm", vmin=-1, vmax=1)
    ax.set_xticks(range(len(sens.columns)), [c.replace("_", " ") for c in sens.columns], rotation=30, ha="right", fontsize=8)
    ax.set_yticks(range(len(sens.index)), sens.index, fontsize=8)
    for (i, j), v in np.ndenumerate(sens.to_numpy(dtype=float)):
        if np.isfinite(v):
            ax.text(j, i, f"{v:+.2f}", ha="center", va="center", fontsize=7)
    fig.colorbar(im, ax=ax, label="Spearman rank correlation")
    ax.set_title("Sensitivity of each metric to each parameter", fontsize=10)
    fig.tight_layout()
    return fig


def figures(table: pd.DataFrame, folder, quantile: float = 0.95) -> list[str]:
    """Pareto scatter and sensitivity heatmap as PNGs in ``folder``; returns their paths.

    Parameters
    ----------
    table : pandas.DataFrame
        Sweep results.
    folder : str or Path
        Where to write.
    quantile : float, default 0.95
        Quantile used for the overshoot colour. [-]
    """
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib


    folder = check_output_dir(folder, "folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"folder: cannot create folder {str(folder)!r} ({exc.strerror})") from None
    paths = []
    for name, fig in (("pareto.png", plot_pareto(table, quantile)), ("sensitivity.png", plot_sensitivity(table))):
        if fig is None:
            continue
        p = folder / name
        try:
            save_figure(fig, p, name="folder", provenance=provenance("mckibben.sweep.figures", {"quantile": quantile}))
        finally:
            plt.close(fig)
        paths.append(str(p))
    return paths
