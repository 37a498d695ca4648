"""``mckibben plant``: the plant's linear model at an operating point (``bode``, ``margins``)."""

from __future__ import annotations

import math

import numpy as np
import typer

from mckibben import hardware as HW
from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.errors import InputError
from mckibben.units import parse_quantity
from mckibben import plant

plant_app = typer.Typer(help="The plant linearized at an operating point, for control design.", no_args_is_help=True)
app.add_typer(plant_app, name="plant")

PRESSURE_OPTION = typer.Option("0.55MPa", "--pressure", help="Operating gauge pressure, e.g. 0.55MPa.")


def _linear(pressure: str):

    p = parse_quantity(pressure, "pressure", "--pressure", allow_zero=False)
    try:
        return plant.linearize(pressure=p)
    except InputError as e:
        raise InputError(f"--pressure: {e}") from None


@plant_app.command("bode")
def bode_cmd(
    pressure: str = PRESSURE_OPTION,
    points: int = typer.Option(13, "--points", help="Frequencies, log-spaced over 0.1–1000 Hz (2..200)."),
    json: bool = JSON_OPTION,
) -> None:
    """Frequency response of inlet command → pressure at the operating point."""
    if not 2 <= points <= 200:
        raise InputError(f"--points: {points} must be in 2..200")
    lin = _linear(pressure)
    f = np.logspace(-1, 3, points)
    resp = lin.ss[0, 0](2j * np.pi * f)
    rows = [{"frequency_Hz": float(fi), "gain_Pa_per_count": float(abs(r)),
             "phase_deg": float(np.degrees(np.angle(r)))} for fi, r in zip(f, resp)]
    if json:
        emit_json({"operating_point": lin.metrics, "response": rows})
        return
    print_table(f"Inlet command → pressure at {lin.pressure_Pa / 1e6:g} MPa (holding command "
                f"{lin.command_counts:.1f} counts)", ["f Hz", "gain Pa/count", "phase deg"],
                [[f"{r['frequency_Hz']:.3g}", f"{r['gain_Pa_per_count']:.4g}", f"{r['phase_deg']:.1f}"] for r in rows])


@plant_app.command("margins")
def margins_cmd(
    kp: float = typer.Option(..., "--kp", help="PID proportional gain, counts/Pa."),
    ki: float = typer.Option(0.0, "--ki", help="PID integral gain, counts/(Pa·s)."),
    kd: float = typer.Option(0.0, "--kd", help="PID derivative gain, counts·s/Pa."),
    tf: float = typer.Option(0.005, "--tf", help="Derivative filter time constant, s."),
    pressure: str = PRESSURE_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Gain and phase margins of a PID on the plant's own linear model at the operating point (sampled at 1 kHz)."""
    import control  # deferred on purpose: python-control (0.8 s)

    for name, v in (("--kp", kp), ("--ki", ki), ("--kd", kd)):
        if not (math.isfinite(v) and v >= 0):
            raise InputError(f"{name}: {v!r} must be a finite gain >= 0")
    if not (math.isfinite(tf) and tf > 0):
        raise InputError(f"--tf: {tf!r} must be a time constant > 0 s")
    if kp == 0 and ki == 0 and kd == 0:
        raise InputError("--kp: all gains are zero; there is no loop")
    lin = _linear(pressure)
    # the loop as the rig runs it: the plant sampled with a zero-order hold at the 1 kHz control
    # period, the PID discretized (Tustin); a continuous loop would hide the hold's phase lag
    s = control.tf("s")
    ts = HW.CONTROL_PERIOD
    pid = control.c2d(kp + ki / s + kd * s / (tf * s + 1), ts, "tustin")
    loop = pid * control.c2d(control.ss2tf(lin.ss[0, 0]), ts, "zoh")
    gm, pm, wcg, wcp = control.margin(loop)
    out = {"operating_point": lin.metrics, "gain_margin": _num(gm), "phase_margin_deg": _num(pm),
           "phase_crossover_Hz": _num(wcg / (2 * np.pi)), "gain_crossover_Hz": _num(wcp / (2 * np.pi))}
    if json:
        emit_json(out)
        return
    print_table(f"PID on the plant linearized at {lin.pressure_Pa / 1e6:g} MPa", ["margin", "value"],
                [["gain margin", _fmt(out["gain_margin"])], ["phase margin", _fmt(out["phase_margin_deg"], " deg")],
                 ["gain crossover", _fmt(out["gain_crossover_Hz"], " Hz")],
                 ["phase crossover", _fmt(out["phase_crossover_Hz"], " Hz")]])


def _num(v):
    v = float(v)
    return v if math.isfinite(v) else None


def _fmt(v, unit=""):
    return "∞" if v is None else f"{v:.4g}{unit}"
