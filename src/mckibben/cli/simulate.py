"""``mckibben simulate open-loop|calibrate``: the plant simulator from the command line."""

from __future__ import annotations

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import DIRECTION_OPTION, JSON_OPTION, emit_json, parse_flag, print_table
from mckibben.cli._output import DPI_OPTION, OUT_OPTION, check_outputs, metric_row, plot_option, write_plot
from mckibben import experiments
from mckibben import plant

simulate_app = typer.Typer(help="Simulate the rig: valves, chamber, muscle, load, sensors.", no_args_is_help=True)
app.add_typer(simulate_app, name="simulate")


@simulate_app.command("open-loop")
def open_loop_cmd(
    valve: int = typer.Option(None, "--valve", help="Inlet PWM step, 0..255 counts (bleed shut); default the "
                                                    "calibration step (117 counts; the valves lift off at 112)."),
    duration: str = typer.Option("0.5s", "--duration", help="Simulated time, e.g. 0.5s."),
    supply: str = typer.Option(None, "--supply", help="Supply pressure (gauge), ≤ 1 MPa (default 0.8MPa; with "
                                                      "--muscle-file the top of its fitted pressures)."),
    load: str = typer.Option("0.6N", "--load", help="Hanging load."),
    muscle_file: str = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law "
                                                                "(mckibben fit … --save): simulate that muscle."),
    direction: str = DIRECTION_OPTION,
    plot: str = plot_option("a figure of the response"),
    dpi: int = DPI_OPTION,
    out: str = OUT_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """An open-loop inlet-valve step from rest: time constant, rise time, final pressure."""

    check_outputs(plot, dpi, out)
    res = experiments.open_loop(valve, supply=parse_flag(supply, "pressure", "supply", allow_zero=False),
                            load=parse_flag(load, "force", "load"),
                            duration=parse_flag(duration, "time", "duration", allow_zero=False),
                            muscle_file=muscle_file, direction=direction)
    d = res.to_dict()
    if plot:
        write_plot(res.plot(), plot, dpi, res)
        d["plot"] = plot
    if out:
        res.to_file(out)
    if json:
        emit_json(d)
        return
    m = res.metrics
    print_table(f"Open-loop step, inlet PWM {d['valve_pwm']}", [" metric", "value"],
                [metric_row(k, m[k]) for k in ("time_constant_s", "rise_time_s", "overshoot_pct", "final_pressure_Pa",
                                               "final_length_m")])


@simulate_app.command("calibrate")
def calibrate_cmd(json: bool = JSON_OPTION) -> None:
    """Check the default plant against the paper: τ ≈ 0.09 s, 4.2 N blocked, 78.1 mm under 0.6 N."""

    c = plant.calibration()
    if json:
        emit_json(c)
        return
    ok = lambda b: "ok" if b else "FAIL"  # noqa: E731
    ch = c["checks"]
    print_table(
        "Default plant vs [mpam-characterization]",
        ["quantity", "paper", "plant", "accepted", "check"],
        [["open-loop time constant", "≈ 0.09 s", f"{c['time_constant_s']:.4f} s", "0.08–0.10 s", ok(ch["time_constant"])],
         ["open-loop overshoot", "none", f"{c['overshoot_pct']:.2f} %", "< 1 %", ok(ch["no_overshoot"])],
         ["blocked force, 97 mm, 0.8 MPa", "4.2 N", f"{c['blocked_force_N']:.3f} N", "± 10 %", ok(ch["blocked_force"])],
         ["length, 0.6 N, 0.8 MPa", "78.1 mm", f"{c['length_m'] * 1e3:.2f} mm", "± 10 %", ok(ch["length"])]],
    )
    if not c["pass"]:
        raise typer.Exit(1)


__all__ = ["np"]
