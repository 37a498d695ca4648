"""``mckibben identify LOG``: fit first/second-order-plus-dead-time models to a step-response log."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import (COLUMNS_OPTION, JSON_OPTION, SELECT_OPTION, console, emit_json, err_console,
                                  parse_pairs, print_table)
from mckibben.errors import InputError
from mckibben.units import parse_quantity
from mckibben.plotting import check_figure_path
from mckibben.cli._output import write_plot
from mckibben.plotting import save_figure
from mckibben.results import provenance
from mckibben import control


@app.command("identify")
def identify_cmd(
    logs: list[str] = typer.Argument(..., help="Step-response log(s) (.csv or .parquet): time_<unit>, pressure_<unit>, "
                                               "inlet_pwm/bleed_pwm, command_pwm or command (fraction), optional "
                                               "trial. Two or more steps to different commands also give the "
                                               "valve's lift-off."),
    order: str = typer.Option("1", "--order", metavar="[1|2|both|fill|all]", help="Model: 1, 2, both, fill (orifice into a volume) or all."),
    t_step: str = typer.Option(None, "--t-step", help="Time of the step, e.g. 0.1s (default: first command change)."),
    supply: str = typer.Option(None, "--supply", help="Nominal supply pressure, e.g. 620kPa: bounds the final "
                                                      "pressure of orders 1 and 2; the fill model estimates its "
                                                      "supply from the measured plateau and uses this one only "
                                                      "when the fill does not settle."),
    fill_shape: str = typer.Option("onset", "--fill-shape", metavar="[fixed|linear|onset|saturating]",
                                   help="The fill model's volume and flow: fixed (a fixed volume), linear (growing "
                                        "from the start), onset (held to an onset pressure, then growing; the "
                                        "valve's subsonic index fitted) or saturating (onset, growth that "
                                        "saturates)."),
    plot: str = typer.Option(None, "--plot", help="Write a PNG of data, fit and residuals (the first log)."),
    select: list[str] = SELECT_OPTION,
    columns: list[str] = COLUMNS_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Identify gain, time constant and dead time (with standard errors) from an open-loop step, one fit per
    trial and pooled across trials; from steps to several commands, the valve's lift-off u0 too."""

    orders = {"1": (1,), "2": (2,), "both": (1, 2), "fill": ("fill",), "all": (1, 2, "fill")}.get(order)
    if orders is None:
        raise InputError(f"--order: {order!r} must be 1, 2, both, fill or all")
    ts = parse_quantity(t_step, "time", "--t-step") if t_step is not None else None
    p_supply = parse_quantity(supply, "pressure", "--supply", allow_zero=False) if supply is not None else None
    if plot is not None:
        check_figure_path(plot)
    if fill_shape not in control.identify.FILL_SHAPES:
        raise InputError(f"--fill-shape: {fill_shape!r} must be one of {', '.join(control.identify.FILL_SHAPES)}")
    res = control.identify.identify_logs(logs, orders, ts, p_supply, parse_pairs(select, "--select", "experiment=3"),
                                         parse_pairs(columns, "--columns", "experiment=trial"), fill_shape)
    results = [(log, r.data, r.meta, r.trials) for log, r in zip(logs, res.logs)]
    lift = res.lift_off
    if plot is not None:
        trial_data, fits = next(iter(results[0][3].values()))
        _plot(plot, trial_data, fits)
    outs = [r.to_dict() for r in res.logs]
    flagged = [f"{o['log']}" + (f" trial {t['trial']}" if len(o.get("trials", [])) > 1 else "")
               + f" order {m['order']} ({', '.join(m['flags'])})"
               for o in outs for t in (o.get("trials") or [o]) for m in t["models"] if m["flags"]]
    if flagged:
        err_console.print(f"warning: identify: flagged: {'; '.join(flagged)}", markup=False, highlight=False)
    if json:
        emit_json(outs[0] if lift is None else {"logs": outs, "lift_off": lift})
        return
    for (log, data, meta, per_trial), o in zip(results, outs):
        for note in meta.get("notes", []):
            console.print(f"{log}: note: {note}")
        for tr, (trial_data, fits) in per_trial.items():
            rows = []
            for f in fits:
                for k, v in f.params.items():
                    rows.append([f"order {f.order}", k, v, f.se(k)])
                if f.order == "fill":
                    rows.append(["order fill", "shape", f.shape, ""])
                    src = f.supply.get("source")
                    rows.append(["order fill", "supply from", {"plateau": "the measured plateau",
                                                               "fitted": "the fit (no plateau)",
                                                               "nominal": "--supply (no plateau)"}.get(src, src), ""])
                    if f.supply.get("nominal_Pa") is not None and src != "nominal":
                        rows.append(["order fill", "--supply (nominal) Pa", f.supply["nominal_Pa"], ""])
                rows.append([f"order {f.order}", "rmse Pa", f.rmse, ""])
                rows.append([f"order {f.order}", "AIC", f.aic, ""])
                rows.append([f"order {f.order}", "flags", ", ".join(f.flags) or "none", ""])
            label = f" trial {tr}" if len(per_trial) > 1 else ""
            print_table(f"{log}{label}: step at {fits[0].t_step:.4g} s ({_input_label(trial_data)})",
                        ["model", "parameter", "value", "std. error"], rows)
        if "pooled" in o:
            labels = [t["trial"] for t in o["trials"]]
            for k, pooled in o["pooled"].items():
                groups = pooled.get("groups") or [dict(pooled, members=list(range(len(labels))))]
                for g in groups:
                    who = ", ".join(str(labels[i]) for i in g["members"])
                    apart = (f" (group {groups.index(g) + 1} of {len(groups)}: half-rise "
                             f"{min(g['half_rise_s']):.3g}–{max(g['half_rise_s']):.3g} s; runs that differ are "
                             "not pooled)") if len(groups) > 1 else ""
                    rows = [[f"order {k}", name, v["mean"], v["stderr"], f"[{v['ci95'][0]:.4g}, {v['ci95'][1]:.4g}]"]
                            for name, v in g.items() if isinstance(v, dict)]
                    if rows:
                        print_table(f"{log}: order {k} pooled over trials {who}{apart} (mean, standard error "
                                    "across trials)", ["model", "parameter", "mean", "std. error", "95 % interval"],
                                    rows)
                    else:
                        console.print(f"{log}: order {k}: trial {who} differs from the others{apart}: reported "
                                      "alone, not pooled", markup=False, highlight=False)
    if lift is not None:
        print_table("lift-off: p = G·(u − u0) through the final pressures",
                    ["parameter", "value", "std. error"],
                    [["G Pa/count", lift["gain_Pa_per_count"], lift["gain_Pa_per_count_stderr"]],
                     ["u0 counts", lift["lift_off_counts"], lift["lift_off_counts_stderr"]]])


def _input_label(data: dict) -> str:
    if "command_pwm" in data:
        return "input in PWM counts"
    if "command" in data:
        return "input as a fraction of full scale"
    return "no input column: unit step"


def _plot(path: str, data: dict, fits) -> None:

    write_plot(control.plot_step_fit(data["time_s"], data["pressure_Pa"], fits), path, 120)


def save_png(fig, path: str) -> None:
    """Write a figure atomically (:func:`mckibben.plotting.save_figure`): nothing half-written."""

    save_figure(fig, path, dpi=120, provenance=provenance("mckibben.control.identify"))
