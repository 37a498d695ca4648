"""Figures of the control experiments: public ``plot_*`` functions that draw on ``ax`` (or a new figure).

None of them switches Matplotlib's backend or writes a file: they return the Figure, which shows
inline in Jupyter; ``Figure.savefig`` (or :func:`mckibben.plotting.save_figure`, atomic) writes
any format Matplotlib knows. The paper's points come from :mod:`mckibben.datasets.paper_points`.
"""

from __future__ import annotations

import numpy as np

from mckibben.control import registry as R
from mckibben.datasets.paper_points import FIG13

__all__ = ["plot_step_fit", "plot_record", "plot_fig13", "plot_robustness", "plot_compare", "plot_open_loop", "plot_hysteresis"]


def _axes(ax, n: int, **subplots):
    """``n`` axes: the ones given, or a new figure's."""
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    if ax is None:
        fig, axes = plt.subplots(*((n, 1) if subplots.pop("vertical", False) else (1, n)), **subplots)
        return fig, list(np.atleast_1d(axes))
    axes = list(np.atleast_1d(ax))
    return axes[0].figure, axes


def plot_record(record, labels, ax=None):
    """Pressure against the reference (top) and the signed valve command (bottom).

    Parameters
    ----------
    record : LoopRecord
        A closed-loop record (:func:`mckibben.control.loop.run_closed_loop`). [-]
    labels : sequence of str
        One label per instance to draw. [-]
    ax : matplotlib.axes.Axes or pair of Axes, optional
        One Axes: the pressure only; two: pressure and command; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5), gridspec_kw={"height_ratios": [3, 1.3]})
    else:
        fig, axes = _axes(ax, 1)
    axp = axes[0]
    axp.plot(record.t, record.reference[0] / 1e6, "k--", lw=1, label="reference")
    for i, lab in enumerate(labels):
        axp.plot(record.t, record.pressure[i] / 1e6, label=lab)
        if len(axes) > 1:
            axes[1].plot(record.t, record.command[i], lw=0.8, label=lab)
    axp.set_ylabel("pressure [MPa]")
    axp.legend()
    if len(axes) > 1:
        axes[1].set_ylabel("inlet − bleed [PWM]")
        axes[1].set_xlabel("time [s]")
    else:
        axp.set_xlabel("time [s]")
    if ax is None:
        fig.tight_layout()
    return fig


def plot_fig13(result, ax=None, tau_vs_beta=None):
    """Fig. 13 of [mpam-characterization] on the plant: step responses, and τ against β beside
    the paper's points (:data:`mckibben.datasets.paper_points.FIG13`).

    Parameters
    ----------
    result : Fig13Result
        From :func:`mckibben.experiments.fig13`. [-]
    ax : matplotlib.axes.Axes or pair of Axes, optional
        One Axes: the responses only; two: responses and τ(β); default a new figure with both. [-]
    tau_vs_beta : pandas.DataFrame, optional
        τ against β (:meth:`Fig13Result.tau_against_beta`); computed when needed. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = _axes(ax, 2, figsize=(11, 4.5))
    axr = axes[0]
    rec = result.record
    axr.plot(rec.t, rec.reference[0] / 1e6, "k--", lw=1, label="reference")
    for i, r in enumerate(result.rows):
        axr.plot(rec.t, rec.pressure[i] / 1e6, ls="-" if r["law"] == "paper" else ":",
                 label=f"{r['law']} law, β = {r['beta_counts']:g}")
    axr.set_xlim(0.08, 0.4)
    axr.set_xlabel("time [s]")
    axr.set_ylabel("pressure [MPa]")
    axr.legend(fontsize=8)
    axr.set_title(f"step to {FIG13['target_Pa'] / 1e6:g} MPa")
    if len(axes) > 1:
        axb = axes[1]
        sweep = result.tau_against_beta() if tau_vs_beta is None else tau_vs_beta
        axb.semilogy(sweep["beta_counts"], sweep["time_constant_s"] * 1e3, "o-", ms=3,
                     label="paper's law on the plant")
        betas = sorted(FIG13["points"])
        axb.semilogy(betas, [FIG13["points"][b]["time_constant_s"] * 1e3 for b in betas], "k*", ms=12,
                     label=f"paper ({FIG13['source'].split(',', 1)[1].strip()})")
        axb.set_xlabel("β [PWM counts]")
        axb.set_ylabel("time constant [ms]")
        axb.set_title("τ against β: β must exceed the holding command (eq. 11)")
        axb.legend(fontsize=8)
    if ax is None:
        fig.tight_layout()
    return fig


_ROBUST_PANELS = (("time_constant_s", 1e3, "time constant [ms]"), ("overshoot_pct", 1.0, "overshoot [%]"),
                  ("steady_state_error_Pa", 1e-3, "steady-state error [kPa]"))
_CONTROLLER_LABELS = {**{c.name: c.label for c in R.CONTROLLERS.values()},
                      "smc_paper": f"SMC, paper's\nlaw, β = {R.SMC.designs['paper']['beta']:g}"}


def plot_robustness(result, ax=None):
    """Box plots (whiskers 5–95 %) of time constant, overshoot and steady-state error per controller.

    Parameters
    ----------
    result : RobustnessResult
        From :func:`mckibben.experiments.robustness`. [-]
    ax : sequence of three matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = _axes(ax, 3, figsize=(11, 3.8))
    names = list(result.per_plant)
    for a, (k, scale, lab) in zip(axes, _ROBUST_PANELS):
        data = [result.per_plant[c][k] * scale for c in names]
        data = [d[np.isfinite(d)] for d in data]
        a.boxplot(data, whis=(5, 95), showfliers=True, flierprops={"markersize": 2})
        a.set_xticks(range(1, len(names) + 1), [_CONTROLLER_LABELS.get(c, c) for c in names])
        a.set_ylabel(lab)
    if ax is None:
        fig.suptitle(f"{result.arguments['n']} random plants (whiskers 5–95 %)")
        fig.tight_layout()
    return fig


def plot_compare(result, ax=None):
    """Time constant of each controller for each step and load (§IV.A's "varied with step size and
    back pressure").

    Parameters
    ----------
    result : CompareResult
        From :func:`mckibben.experiments.compare`. [-]
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (a,) = _axes(ax, 1, figsize=(9, 4))
    cases = []
    for r in result.rows:
        key = (r["from_Pa"], r["to_Pa"], r["load_N"])
        if key not in cases:
            cases.append(key)
    x = np.arange(len(cases))
    for j, c in enumerate(dict.fromkeys(r["controller"] for r in result.rows)):
        tau = [next(r["time_constant_s"] for r in result.rows if r["controller"] == c
                    and (r["from_Pa"], r["to_Pa"], r["load_N"]) == k) for k in cases]
        a.semilogy(x + (j - 1) * 0.15, np.asarray(tau) * 1e3, "o", label=c)
    a.set_xticks(x, [f"{p0 / 1e6:g}→{p1 / 1e6:g} MPa\n{f:g} N" for p0, p1, f in cases], fontsize=7)
    a.set_ylabel("time constant [ms]")
    a.legend(fontsize=8)
    if ax is None:
        fig.tight_layout()
    return fig


def plot_open_loop(result, ax=None):
    """The open-loop pressure rise and its 63 % time.

    Parameters
    ----------
    result : OpenLoopResult
        From :func:`mckibben.experiments.open_loop`. [-]
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (a,) = _axes(ax, 1, figsize=(6, 3.6))
    a.plot(result.time, result.pressure / 1e6, lw=1.5, label="chamber pressure (simulated)")
    tau = result.metrics.get("time_constant_s")
    if tau is not None and np.isfinite(tau):
        a.axvline(tau, color="0.5", ls="--", lw=1, label=f"63 % at {tau * 1e3:.0f} ms")
    a.set_xlabel("time [s]")
    a.set_ylabel("gauge pressure [MPa]")
    args = result.arguments
    a.set_title(f"open-loop step, inlet PWM {args['valve_pwm']}, supply {args['supply_Pa'] / 1e6:g} MPa",
                fontsize=10)
    a.grid(alpha=0.3)
    a.legend(loc="lower right", fontsize=8)
    if ax is None:
        fig.tight_layout()
    return fig


def plot_hysteresis(result, ax=None):
    """The identification sweep with both branch fits, and the length-tracking errors.

    Parameters
    ----------
    result : HysteresisBenefit
        From :func:`mckibben.control.hysteresis.hysteresis_benefit`. [-]
    ax : pair of matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (a, axe) = _axes(ax, 2, figsize=(11, 4.5))
    res = result
    up = res.sweep_inflating
    a.plot(res.sweep_pressure[up] / 1e6, res.sweep_length[up] * 1e3, ".", ms=1.5, color="C3",
           label="sweep, inflating")
    a.plot(res.sweep_pressure[~up] / 1e6, res.sweep_length[~up] * 1e3, ".", ms=1.5, color="C0",
           label="sweep, deflating")
    ell = np.linspace(*res.branches.length_range, 200)
    a.plot(res.branches.pressure(ell, True) / 1e6, ell * 1e3, "-", color="darkred", lw=1.5, label="inflating fit")
    a.plot(res.branches.pressure(ell, False) / 1e6, ell * 1e3, "-", color="navy", lw=1.5, label="deflating fit")
    a.plot(res.single(ell) / 1e6, ell * 1e3, "k--", lw=1, label="single cubic")
    a.set_xlabel("pressure [MPa]")
    a.set_ylabel("length [mm]")
    a.set_title(f"identification sweep ({res.sweep_period:g} s)")
    a.legend(fontsize=8)
    for i, lab in enumerate(("single cubic", "branches")):
        axe.plot(res.t, (res.length[i] - res.length_ref) * 1e3, label=f"{lab}: RMS {res.rms_error[i] * 1e3:.2f} mm")
    axe.axvspan(0, res.period, color="0.9", label="first cycle (not scored)")
    axe.axhline(0, color="k", lw=0.5)
    axe.set_xlabel("time [s]")
    axe.set_ylabel("length − target [mm]")
    axe.set_title(f"tracking {res.mean * 1e3:.1f} ± {res.amplitude * 1e3:.1f} mm, period {res.period:g} s")
    axe.legend(fontsize=8)
    if ax is None:
        fig.tight_layout()
    return fig


def plot_step_fit(time, pressure, fits, ax=None):
    """A measured step response with its FOPDT/SOPDT fits (top) and their residuals (bottom).

    Parameters
    ----------
    time : array_like
        Sample times. [s]
    pressure : array_like
        Measured pressure. [Pa]
    fits : sequence of StepFit
        From :func:`mckibben.fit.step.fit_step_response`. [-]
    ax : pair of matplotlib.axes.Axes, optional
        Where to draw; default a new figure. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    t = np.asarray(time, dtype=float)
    if ax is None:
        fig, (a, axr) = plt.subplots(2, 1, sharex=True, figsize=(7, 5), gridspec_kw={"height_ratios": [3, 1]})
    else:
        fig, (a, axr) = _axes(ax, 2)
    a.plot(t, np.asarray(pressure, dtype=float) / 1e6, ".", ms=2, color="0.5", label="measured")
    for f in fits:
        what = f"fill: b = {f.params['b']:.2f}" if f.order == "fill" else f"order {f.order}: τ = {f.tau * 1e3:.1f} ms"
        a.plot(t, f.predict(t) / 1e6, label=f"{what}, θ = {f.dead_time * 1e3:.1f} ms")
        axr.plot(t, f.residuals / 1e3, lw=0.8, label=f"order {f.order}")
    a.set_ylabel("pressure [MPa]")
    a.legend()
    axr.set_ylabel("residual [kPa]")
    axr.set_xlabel("time [s]")
    if ax is None:
        fig.tight_layout()
    return fig
