"""``mckibben rig record|recover|step|emulate``: the serial link to the device (or its emulator)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, err_console, print_table
from mckibben.atomic import check_output_file
from mckibben.errors import InputError
from mckibben.units import parse_quantity

rig_app = typer.Typer(help="The rig over its serial link: record, step, emulate.", no_args_is_help=True)
app.add_typer(rig_app, name="rig")

from mckibben.rig.device import BAUD, open_port as _open


def _duration(text: str, name: str = "--duration", limit: float = 24 * 3600) -> float:
    d = parse_quantity(text, "time", name, allow_zero=False)
    if d > limit:
        raise InputError(f"{name}: {text!r} is longer than {limit:g} s")
    return d


@rig_app.command("record")
def record_cmd(
    port: str = typer.Option(..., "--port", help="Serial port of the device or emulator (e.g. /dev/ttyACM0)."),
    out: str = typer.Option(..., "--out", help="Parquet file to write (a journal OUT.journal/ is kept meanwhile)."),
    duration: str = typer.Option("10s", "--duration", help="How long to record."),
    decimation: int = typer.Option(1, "--decimation", help="Stream every k-th control step (1 = 1 kHz)."),
    nominal_length: str = typer.Option("97mm", "--nominal-length", help="Muscle rest length, for length_m."),
    json: bool = JSON_OPTION,
) -> None:
    """Record telemetry; a kill -9 loses at most the last quarter second (see docs/rig.md)."""
    from rich.live import Live

    from mckibben.rig import protocol as P
    from mckibben.rig.recorder import Recorder

    d = _duration(duration)
    if not 1 <= decimation <= 255:
        raise InputError(f"--decimation: {decimation} must be in 1..255")
    l0 = parse_quantity(nominal_length, "length", "--nominal-length", allow_zero=False)
    rec_out = check_output_file(out, "--out", (".parquet",))
    link = _open(port)
    rec = Recorder(rec_out, meta={"port": port, "baud": BAUD}, nominal_length=l0)
    link.write(P.stream(0, True, decimation))
    t0 = time.monotonic()
    show = not json and sys.stderr.isatty()

    def view():
        c = rec.parser.counters()
        dt = max(time.monotonic() - t0, 1e-9)
        p = rec.last.pressure_adc * rec.pa_per_count / 1e6 if rec.last else float("nan")
        return (f"{c['frames'] / dt:7.0f} frames/s   missing {c['missing']}   corrupt {c['corrupt']}   "
                f"pressure {p:.3f} MPa   {dt:5.1f}/{d:g} s")

    try:
        with Live(view(), console=err_console, refresh_per_second=4, transient=True) if show else _Null() as live:
            while time.monotonic() - t0 < d:
                rec.feed(link.read(8192))
                if show:
                    live.update(view())
        link.write(P.stream(1, False, 1))
    finally:
        link.close()
    df = rec.close()
    c = rec.parser.counters()
    result = {"out": str(rec_out), "frames": c["frames"], "telemetry_rows": len(df), "missing": c["missing"],
              "corrupt": c["corrupt"], "bad_version": c["bad_version"], "duration_s": d}
    if json:
        emit_json(result)
        return
    print_table("Recording", list(result), [[str(v) for v in result.values()]])


class _Null:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


@rig_app.command("recover")
def recover_cmd(
    journal: str = typer.Argument(..., help="A journal folder left by a killed recorder (OUT.journal)."),
    out: str = typer.Option(..., "--out", help="Parquet file to write."),
    json: bool = JSON_OPTION,
) -> None:
    """Join a recorder's journal into one Parquet file."""
    from mckibben.rig.recorder import recover

    check_output_file(out, "--out", (".parquet",))
    df = recover(journal, out)
    result = {"out": out, "telemetry_rows": len(df),
              "time_s": [float(df["time_s"].min()), float(df["time_s"].max())] if len(df) else None}
    if json:
        emit_json(result)
        return
    print_table("Recovered", ["out", "rows"], [[out, str(len(df))]])


@rig_app.command("step")
def step_cmd(
    port: str = typer.Option(..., "--port", help="Serial port of the device or emulator."),
    target: str = typer.Option("0.55MPa", "--target", help="Pressure set-point of the step."),
    controller: str = typer.Option("smc", "--controller", help="smc or pid."),
    duration: str = typer.Option("1s", "--duration", help="Recording time after the step."),
    json: bool = JSON_OPTION,
) -> None:
    """Run a pressure step on the device and print the step metrics."""
    from mckibben.rig import Device

    res = Device(port).step(target, controller=controller, duration=duration)
    if json:
        emit_json(res.to_dict())
        return
    p = res.arguments["target_Pa"]
    print_table(f"Step to {p / 1e6:g} MPa ({controller})", ["metric", "value"],
                [[k, f"{v:.4g}"] for k, v in res.metrics.items()])


@rig_app.command("emulate")
def emulate_cmd(
    duration: str = typer.Option(None, "--duration", help="Stop after this long (default: until Ctrl-C)."),
    link: str = typer.Option(None, "--link", help="Also make a symbolic link to the port at this path."),
    json: bool = JSON_OPTION,
) -> None:
    """A virtual device on a pseudo-terminal: the firmware core on the plant simulator, in real time."""
    import os

    from mckibben.rig.emulator import Emulator

    d = _duration(duration) if duration else None
    em = Emulator()
    if link:
        try:
            if os.path.islink(link):
                os.unlink(link)
            os.symlink(em.port, link)
        except OSError as exc:
            em.stop()
            raise InputError(f"--link: cannot create {link!r} ({exc.strerror})") from None
    if json:
        emit_json({"port": em.port, "link": link, "baud": BAUD})
    else:
        err_console.print(f"emulated device on {em.port}" + (f" (link {link})" if link else "") + "; Ctrl-C stops")
    try:
        em.run(d)
    except KeyboardInterrupt:
        pass
    finally:
        em.stop()
        if link and os.path.islink(link):
            os.unlink(link)
