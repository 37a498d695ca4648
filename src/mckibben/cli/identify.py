"""``mckibben identify LOG``: fit first/second-order-plus-dead-time models to a step-response log."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.errors import InputError


@app.command("identify")
def identify_cmd(
    logs: list[str] = typer.Argument(..., help="Step-response log(s) (.csv or .parquet): time_<unit>, pressure_<unit>, "
                                               "inlet_pwm/bleed_pwm or command_pwm. Two or more steps to different "
                                               "commands also give the valve's lift-off."),
    order: str = typer.Option("1", "--order", help="Model order: 1, 2 or both."),
    t_step: str = typer.Option(None, "--t-step", help="Time of the step, e.g. 0.1s (default: first command change)."),
    plot: str = typer.Option(None, "--plot", help="Write a PNG of data, fit and residuals (the first log)."),
    json: bool = JSON_OPTION,
) -> None:
    """Identify gain, time constant and dead time (with standard errors) from an open-loop step;
    from steps to several commands, the valve's lift-off u0 of ṗ = (G·(u − u0) − p)/τ too."""
    from mckibben.control.identify import fit_lift_off, fit_step_response, read_step_log
    from mckibben.units import parse_quantity

    orders = {"1": (1,), "2": (2,), "both": (1, 2)}.get(order)
    if orders is None:
        raise InputError(f"--order: {order!r} must be 1, 2 or both")
    ts = parse_quantity(t_step, "time", "--t-step") if t_step is not None else None
    if plot is not None:
        from mckibben.atomic import check_output_file

        check_output_file(plot, "--plot", (".png",))
    results = []
    for log in logs:
        data, meta = read_step_log(log)
        if len(logs) > 1 and "command_pwm" not in data:
            raise InputError(f"{meta['path']}: the lift-off needs the valve command (inlet_pwm/bleed_pwm or "
                             "command_pwm) in every log")
        try:
            fits = [fit_step_response(data["time_s"], data["pressure_Pa"], data.get("command_pwm"), order=o,
                                      t_step=ts) for o in orders]
        except RuntimeError as exc:  # the data give the fit nothing to converge on: the file's problem
            raise InputError(f"{meta['path']}: {exc}") from None
        results.append((log, data, meta, fits))
    lift = None
    if len(results) > 1:
        lift = fit_lift_off([r[3][0] for r in results], [_held_command(r[1], r[3][0].t_step) for r in results])
    if plot is not None:
        _plot(plot, results[0][1], results[0][3])
    outs = [_log_result(data, meta, fits) for _, data, meta, fits in results]
    if json:
        emit_json(outs[0] if lift is None else {"logs": outs, "lift_off": lift})
        return
    for (log, data, _, fits) in results:
        rows = []
        for f in fits:
            for k, v in f.params.items():
                rows.append([f"order {f.order}", k, v, f.stderr[k]])
            rows.append([f"order {f.order}", "rmse Pa", f.rmse, ""])
            rows.append([f"order {f.order}", "AIC", f.aic, ""])
        print_table(f"{log}: step at {fits[0].t_step:.4g} s, input step {fits[0].input_step:g} "
                    f"({'PWM counts' if 'command_pwm' in data else 'no input column: unit step'})",
                    ["model", "parameter", "value", "std. error"], rows)
    if lift is not None:
        print_table("lift-off: p = G·(u − u0) through the final pressures",
                    ["parameter", "value", "std. error"],
                    [["G Pa/count", lift["gain_Pa_per_count"], lift["gain_Pa_per_count_stderr"]],
                     ["u0 counts", lift["lift_off_counts"], lift["lift_off_counts_stderr"]]])


def _held_command(data: dict, t_step: float) -> float:
    """The command held after the step: the median from the step on. [PWM counts]"""
    import numpy as np

    after = data["time_s"] >= t_step
    return float(np.median(data["command_pwm"][after]))


def _log_result(data: dict, meta: dict, fits) -> dict:
    input_unit = "count" if "command_pwm" in data else "step"
    out = {"log": meta["path"], "columns": meta["columns"],
           "models": [f.to_dict("Pa", input_unit) for f in fits]}
    best = min(fits, key=lambda f: f.aic)
    out["best_order"] = best.order
    out[f"gain_Pa_per_{input_unit}"] = best.gain
    out["time_constant_s"] = best.tau
    out["dead_time_s"] = best.dead_time
    return out


def _plot(path: str, data: dict, fits) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = data["time_s"]
    fig, (ax, axr) = plt.subplots(2, 1, sharex=True, figsize=(7, 5), gridspec_kw={"height_ratios": [3, 1]})
    ax.plot(t, data["pressure_Pa"] / 1e6, ".", ms=2, color="0.5", label="measured")
    for f in fits:
        ax.plot(t, f.predict(t) / 1e6, label=f"order {f.order}: τ = {f.tau * 1e3:.1f} ms, "
                                              f"θ = {f.dead_time * 1e3:.1f} ms")
        axr.plot(t, f.residuals / 1e3, lw=0.8, label=f"order {f.order}")
    ax.set_ylabel("pressure [MPa]")
    ax.legend()
    axr.set_ylabel("residual [kPa]")
    axr.set_xlabel("time [s]")
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)


def save_png(fig, path: str) -> None:
    """Write a figure atomically (:func:`mckibben.plotting.save_figure`): nothing half-written."""
    from mckibben.plotting import save_figure

    save_figure(fig, path, dpi=120)
