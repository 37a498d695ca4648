"""``mckibben simulate open-loop|calibrate``: the plant simulator from the command line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.errors import InputError
from mckibben.units import parse_quantity

simulate_app = typer.Typer(help="Simulate the rig: valves, chamber, muscle, load, sensors.", no_args_is_help=True)
app.add_typer(simulate_app, name="simulate")


def _check_plot_path(plot: str | None) -> Path | None:
    if plot is None:
        return None
    from mckibben.atomic import check_output_file

    return check_output_file(plot, "--plot", (".png", ".pdf", ".svg"))


def _save_plot(path: Path, t, pressure, title: str, metrics: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=120)
    ax.plot(t, pressure / 1e6, lw=1.5, label="chamber pressure (simulated)")
    tau = metrics.get("time_constant_s")
    if tau:
        ax.axvline(tau, color="0.5", ls="--", lw=1, label=f"63 % at {tau * 1e3:.0f} ms")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("gauge pressure [MPa]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    from mckibben.plotting import save_figure

    try:
        save_figure(fig, path)
    finally:
        plt.close(fig)


@simulate_app.command("open-loop")
def open_loop_cmd(
    valve: int = typer.Option(None, "--valve", help="Inlet PWM step, 0..255 counts (bleed shut); default the "
                                                    "calibration step (117 counts; the valves lift off at 112)."),
    duration: str = typer.Option("0.5s", "--duration", help="Simulated time, e.g. 0.5s."),
    supply: str = typer.Option("0.8MPa", "--supply", help="Supply pressure (gauge), ≤ 1 MPa."),
    load: str = typer.Option("0.6N", "--load", help="Hanging load."),
    plot: str = typer.Option(None, "--plot", help="Save a figure of the response (.png/.pdf/.svg)."),
    json: bool = JSON_OPTION,
) -> None:
    """An open-loop inlet-valve step from rest: time constant, rise time, final pressure."""
    from mckibben.plant import CALIBRATION_PWM, PlantParams, open_loop_step

    valve = CALIBRATION_PWM if valve is None else valve
    if not 0 <= valve <= 255:
        raise InputError(f"--valve: {valve} must be a PWM count in 0..255")
    d = parse_quantity(duration, "time", "--duration", allow_zero=False)
    steps = d / 1e-3
    if abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
        raise InputError(f"--duration: {duration!r} must be a whole number of 1 ms control periods")
    if d > 60:
        raise InputError(f"--duration: {duration!r} is longer than 60 s")
    s = parse_quantity(supply, "pressure", "--supply", allow_zero=False)
    if s > 1e6:
        raise InputError(f"--supply: {supply!r} is above the compressor's 1 MPa")
    from mckibben.datasets import get_muscle
    from mckibben.limits import check_load

    f = check_load(parse_quantity(load, "force", "--load"), get_muscle(PlantParams().muscle_name))
    path = _check_plot_path(plot)
    res, m = open_loop_step(PlantParams(supply_pressure=s, load_force=f), valve=valve, duration=d)
    out = {"valve_pwm": valve, "supply_Pa": s, "load_N": f, "duration_s": d, **m,
           "final_length_m": float(res.length[0, -1])}
    if path is not None:
        _save_plot(path, res.t, res.pressure[0], f"open-loop step, inlet PWM {valve}, supply {s / 1e6:g} MPa", m)
        out["plot"] = str(path)
    if json:
        emit_json(out)
        return
    fmt = lambda v, k=1.0, u="": "—" if v is None else f"{v * k:.4g}{u}"  # noqa: E731
    print_table(
        f"Open-loop step, inlet PWM {valve}",
        ["metric", "value"],
        [["time constant (63 %)", fmt(m["time_constant_s"], 1e3, " ms")],
         ["rise time (10–90 %)", fmt(m["rise_time_s"], 1e3, " ms")],
         ["overshoot", fmt(m["overshoot_pct"], 1, " %")],
         ["final pressure", fmt(m["final_pressure_Pa"], 1e-6, " MPa")],
         ["final length", fmt(out["final_length_m"], 1e3, " mm")]],
    )


@simulate_app.command("calibrate")
def calibrate_cmd(json: bool = JSON_OPTION) -> None:
    """Check the default plant against the paper: τ ≈ 0.09 s, 4.2 N blocked, 78.1 mm under 0.6 N."""
    from mckibben.plant import calibration

    c = calibration()
    if json:
        emit_json(c)
        return
    ok = lambda b: "ok" if b else "FAIL"  # noqa: E731
    ch = c["checks"]
    print_table(
        "Default plant vs 000_909f662a44080c85.txt",
        ["quantity", "paper", "plant", "accepted", "check"],
        [["open-loop time constant", "≈ 0.09 s", f"{c['time_constant_s']:.4f} s", "0.08–0.10 s", ok(ch["time_constant"])],
         ["open-loop overshoot", "none", f"{c['overshoot_pct']:.2f} %", "< 1 %", ok(ch["no_overshoot"])],
         ["blocked force, 97 mm, 0.8 MPa", "4.2 N", f"{c['blocked_force_N']:.3f} N", "± 10 %", ok(ch["blocked_force"])],
         ["length, 0.6 N, 0.8 MPa", "78.1 mm", f"{c['length_m'] * 1e3:.2f} mm", "± 10 %", ok(ch["length"])]],
    )
    if not c["pass"]:
        raise typer.Exit(1)


__all__ = ["np"]
