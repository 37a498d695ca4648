"""``mckibben rig record|recover|step|emulate``: the serial link to the device (or its emulator)."""

from __future__ import annotations

import sys
import time

import typer

from mckibben.cli import app
from mckibben import experiments
from mckibben.cli._common import JSON_OPTION, emit_json, err_console, parse_flag, print_table
from mckibben.cli._output import metric_row
from mckibben.atomic import check_output_file
from mckibben.control import registry as R
from mckibben.errors import InputError
from mckibben.units import parse_quantity
from mckibben import hardware as HW
from mckibben import data as data_pkg
from mckibben import rig
from mckibben import report as report_pkg
from mckibben import control
from mckibben.cli import tool as T
import collections
import threading
import os

rig_app = typer.Typer(help="The rig over its serial link: record, step, emulate.", no_args_is_help=True)
app.add_typer(rig_app, name="rig")


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
    """Record telemetry (every channel); a kill -9 loses at most the last 0.2 s (see docs/rig.md)."""
    from rich.live import Live  # deferred on purpose: Rich's live display

    d = _duration(duration)
    if not 1 <= decimation <= 255:
        raise InputError(f"--decimation: {decimation} must be in 1..255")
    l0 = parse_quantity(nominal_length, "length", "--nominal-length", allow_zero=False)
    rec_out = check_output_file(out, "--out", (".parquet",))

    link, hello, _ = rig.device.connect(port)  # the device resets on open: nothing older than this run is kept
    try:
        rec = rig.Recorder(rec_out, meta={"port": port, "baud": rig.BAUD, "n_channels": hello.n_channels,
                                          "load_cell_N": hello.load_cell},
                           nominal_length=l0, parser=rig.protocol.Parser(load_cell=hello.load_cell))
    except BaseException:
        link.close()
        raise
    link.write(rig.protocol.stream(0, True, decimation))
    t0 = time.monotonic()
    show = not json and sys.stderr.isatty()

    def view():
        c = rec.parser.counters()
        dt = max(time.monotonic() - t0, 1e-9)
        p = rec.last.pressure_adc * rec.pa_per_count / 1e6 if rec.last else float("nan")
        return (f"{c['frames'] / dt:7.0f} frames/s   missing {c['missing']}   corrupt {c['corrupt']}   "
                f"pressure {p:.3f} MPa   {dt:5.1f}/{d:g} s")

    # A reader thread drains the port while the journal is written: the serial driver buffers
    # only ~4 KB (70 ms of three-channel telemetry at 1 kHz), less than a journal part may take.

    chunks = collections.deque()
    stop = threading.Event()

    def reader():
        while not stop.is_set():
            data = link.read(8192)
            if data:
                chunks.append(data)

    thread = threading.Thread(target=reader, name="mckibben-record-reader", daemon=True)
    thread.start()
    try:
        with Live(view(), console=err_console, refresh_per_second=4, transient=True) if show else _Null() as live:
            while time.monotonic() - t0 < d:
                data = b"".join(chunks.popleft() for _ in range(len(chunks)))
                rec.feed(data)
                if not data:
                    time.sleep(0.005)
                if show:
                    live.update(view())
        stop.set()
        thread.join(timeout=5)
        rec.feed(b"".join(chunks))
        link.write(rig.protocol.stream(1, False, 1))
    finally:
        stop.set()
        thread.join(timeout=5)
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

    check_output_file(out, "--out", (".parquet",))
    df = rig.recover(journal, out)
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
    controller: str = typer.Option("smc", "--controller", help=" or ".join(R.NAMES) + "."),
    duration: str = typer.Option("1s", "--duration", help="Recording time after the step."),
    json: bool = JSON_OPTION,
) -> None:
    """Run a pressure step on the device and print the step metrics."""

    res = rig.Device(port).step(parse_flag(target, "pressure", "target", allow_zero=False), controller=controller,
                                duration=parse_flag(duration, "time", "duration", allow_zero=False))
    _warn_faults(res.counters.get("faults", 0))
    if json:
        emit_json(res.to_dict())
        return
    p = res.arguments["target_Pa"]
    print_table(f"Step to {p / 1e6:g} MPa ({controller})", [" metric", "value"],
                [metric_row(k, v) for k, v in res.metrics.items()])


def _warn_faults(faults: int) -> None:
    """The device's faults on stderr, whatever the output format."""

    if faults:
        err_console.print(f"warning: the device reported faults: {', '.join(rig.protocol.fault_names(faults))} (flags {faults})",
                          markup=False, highlight=False)


@rig_app.command("gains")
def gains_cmd(
    port: str = typer.Option(..., "--port", help="Serial port of the device or emulator."),
    source: str = typer.Option(..., "--from", help="Controller design (JSON) written by control step --save-design "
                                                   "or mckibben.control.core.save_design."),
    channel: str = typer.Option("all", "--channel", help="Channel to write (0, 1, 2) or all."),
    json: bool = JSON_OPTION,
) -> None:
    """Send a controller design's gains to the device, read them back and verify them."""

    params = control.core.load_design(source, "source")  # bad files fail before the port is touched
    if channel == "all":
        chans = None
    elif channel.isdigit():
        chans = [int(channel)]
    else:
        raise InputError(f"--channel: {channel!r} must be a channel number or all")
    res = rig.Device(port).set_gains(params, chans)
    if not res.verified:
        raise InputError(f"--port: the gains read back from {port!r} differ from those sent")
    if json:
        emit_json({**res.to_dict(), "from": source})
        return
    print_table(f"Gains from {source} on {port}", ["channel", "gains", "verified"],
                [[str(c), str(len(v)), "yes"] for c, v in res.read_back.items()])


@rig_app.command("emulate")
def emulate_cmd(
    duration: str = typer.Option(None, "--duration", help="Stop after this long (default: until Ctrl-C)."),
    link: str = typer.Option(None, "--link", help="Also make a symbolic link to the port at this path."),
    channels: int = typer.Option(3, "--channels", help="Pressure channels of the emulated device (1..3)."),
    boot_time: str = typer.Option("0.3s", "--boot-time", help="Bootloader time after each reset (a Mega: 1-2 s)."),
    tool_path: str = typer.Option(None, "--tool-path", help="Emulate the default tool's three muscles, each hanging "
                                                           "its mean tension on this tip path (as tool track "
                                                           "--port steers it), e.g. circle:radius=10mm,period=1s."),
    engine: str = typer.Option("python", "--engine", help="python: the firmware core's Python mirror; avr: the "
                                                           "firmware image itself in simavr (libsimavr)."),
    supply: str = typer.Option(None, "--supply", help="Supply pressure of every channel (default 0.8MPa; up to "
                                                      "1MPa, above the safe maximum, to prove the supervisor)."),
    load_cell: str = typer.Option(None, "--load-cell", help="Fit a load cell of this full scale on channel 0's "
                                                            "muscle (e.g. 5N, the paper rig's; docs/firmware.md)."),
    load_cell_offset: str = typer.Option(None, "--load-cell-offset", help="The load cell amplifier's zero offset, "
                                                                          "as a force (default 0N)."),
    load_cell_noise: str = typer.Option(None, "--load-cell-noise", help="The load cell's noise, standard deviation "
                                                                        "(default 0N)."),
    json: bool = JSON_OPTION,
) -> None:
    """A virtual device on a pseudo-terminal (the firmware core, or its image in simavr) on N plants, in real time;
    it resets when opened."""

    d = _duration(duration) if duration else None
    if not 1 <= channels <= 3:
        raise InputError(f"--channels: {channels} must be 1, 2 or 3")
    if engine not in rig.engines.ENGINES:
        raise InputError(f"--engine: {engine!r} must be one of {', '.join(rig.engines.ENGINES)}")
    sup = parse_flag(supply, "pressure", "supply", allow_zero=False) if supply is not None else None
    cell = None
    if load_cell is None and (load_cell_offset is not None or load_cell_noise is not None):
        raise InputError("--load-cell-offset/--load-cell-noise: give the load cell's full scale with --load-cell")
    if load_cell is not None:
        cell = HW.LoadCell(parse_flag(load_cell, "force", "load_cell", allow_zero=False),
                            parse_flag(load_cell_offset or "0N", "force", "load_cell_offset", allow_negative=True),
                            parse_flag(load_cell_noise or "0N", "force", "load_cell_noise"))
    boot = parse_quantity(boot_time, "time", "--boot-time")
    if boot > 10:
        raise InputError(f"--boot-time: {boot_time!r} is longer than 10 s")
    plants = None
    if tool_path is not None:
        if channels != 3:
            raise InputError("--tool-path: the tool has three muscles; leave --channels at 3")
        tool = T.build_tool(*(o.default for o in (T.MUSCLE_OPTION, T.PITCH_OPTION, T.DISCS_OPTION, T.PRELOAD_OPTION,
                                                  T.KB_OPTION, T.KA_OPTION, T.PMAX_OPTION)))  # tool track's defaults
        plants = experiments.link.tool_plants(tool, tool_path)
    em = rig.engines.start_device(engine, plant=plants, n_channels=channels, boot_time=boot, supply=sup,
                                  load_cell=cell)
    made = False
    try:  # from here on, a Ctrl-C or a SIGTERM at any point stops the device and removes its link
        if link:
            try:
                if os.path.islink(link):
                    os.unlink(link)
                os.symlink(em.port, link)
                made = True
            except OSError as exc:
                raise InputError(f"--link: cannot create {link!r} ({exc.strerror})") from None
        if json:
            emit_json({"port": em.port, "link": link, "baud": rig.BAUD, "channels": channels, "engine": engine,
                       "load_cell_N": None if cell is None else cell.full_scale,
                       "bench": None if em.bench is None else str(em.bench)})
        else:
            err_console.print(f"emulated device ({engine} engine) on {em.port}" + (f" (link {link})" if link else "") + "; Ctrl-C stops")
        em.run(d)
    except KeyboardInterrupt:
        pass
    finally:
        em.stop()
        if made and os.path.islink(link):
            os.unlink(link)


@rig_app.command("bench")
def bench_cmd(
    port: str = typer.Option(..., "--port", help="Serial port of the emulated device (or a link to it)."),
    request: str = typer.Argument(..., help="load, hold, release or state."),
    value: str = typer.Argument(None, help="load: a weight (61g, 0.6N); hold: a length (92mm)."),
    json: bool = JSON_OPTION,
) -> None:
    """Change the simulated bench of an emulated device: hang a load, hold a length, release; or show it."""
    if request in ("load", "hold"):
        if value is None:
            raise InputError(f"{request}: give a {'weight (61g, 0.6N)' if request == 'load' else 'length (92mm)'}")
        v = parse_quantity(value, "force" if request == "load" else "length", request, allow_zero=request == "load")
        line = f"{request} {v!r}"
    elif request in ("release", "state"):
        if value is not None:
            raise InputError(f"{request}: takes no value (got {value!r})")
        line = request
    else:
        raise InputError(f"request: {request!r} must be one of load, hold, release, state")
    b = rig.Bench.of_port(port)
    if request == "state":
        st = b.state()
        out = {"load_N": st.load, "length_m": st.length, "pressure_Pa": st.pressure, "held": st.held}
    else:
        b.request(line)
        out = {"request": line, "reply": "ok"}
    if json:
        emit_json(out)
        return
    print_table(f"Bench of {port}", list(out), [[str(v) for v in out.values()]])


@rig_app.command("characterize")
def characterize_cmd(
    port: str = typer.Option(..., "--port", help="Serial port of the device or emulator (e.g. /dev/ttyACM0)."),
    protocol: str = typer.Option(..., "--protocol", help="Protocol file (TOML): mckibben examples copy "
                                                         "characterize.toml."),
    out: str = typer.Option(..., "--out", help="Folder of the run: tables, muscle.toml, report/ (empty or new, "
                                               "or a stopped run's with --resume)."),
    unattended: bool = typer.Option(False, "--unattended", help="Change the loads through the emulated bench's "
                                                                "side channel instead of asking the operator."),
    resume: bool = typer.Option(False, "--resume", help="Go on with a stopped run in --out: its completed load "
                                                        "steps are kept, the others run."),
    muscle_file: str = typer.Option(None, "--muscle-file", help="The muscle under test (TOML); with it the run "
                                                                "fits every law and writes OUT/muscle.toml."),
    json: bool = JSON_OPTION,
) -> None:
    """Run a characterization protocol on the bench: load steps, pressure up and down, tables, fitted muscle file."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn  # deferred: Rich's progress

    proto = rig.read_protocol(protocol)  # a bad protocol or muscle file is refused before the port is touched
    if muscle_file is not None:
        data_pkg.read_muscle(muscle_file)
    show = not json and sys.stderr.isatty()
    bar = Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total} steps"),
                   TimeRemainingColumn(), console=err_console, transient=True, disable=not show)
    task = bar.add_task("characterize", total=1)

    def progress(event, **info):
        if event == "start":
            bar.update(task, total=info["total"], completed=info["done"])
        elif event == "load":
            bar.update(task, description=f"load {info['load'] / 9.80665 * 1e3:.0f} g, trial {info['trial']}")
        elif event == "length":
            bar.update(task, description=f"held at {info['length'] * 1e3:.1f} mm, trial {info['trial']}")
        else:
            bar.advance(task)

    def prompt(text: str) -> str:
        bar.stop()
        try:
            return err_console.input(text)
        finally:
            bar.start()

    with bar:
        res = rig.run_characterization(port, proto, out, unattended=unattended, resume=resume, muscle_file=muscle_file,
                             prompt=prompt, progress=progress)
    summary = res.to_dict()
    report = None
    if muscle_file is not None:
        try:
            report = str(report_pkg.run_report(res.summary["out"]))
        except InputError as exc:  # the run, its tables and muscle file stand without the report
            summary["report_error"] = str(exc)
            err_console.print(f"warning: no HTML report: {exc}", markup=False, highlight=False)
    summary["report"] = report
    if json:
        emit_json(summary)
        return
    m = res.metrics
    rows = []
    if summary["load_steps_expected"]:  # an isometric-only protocol has no load steps to count
        rows += [["load steps", f"{summary['load_steps']} of {summary['load_steps_expected']}"],
                 ["samples", str(m["samples"])]]
    if summary["held_runs_expected"]:
        rows.append(["held-length runs", f"{summary['held_runs']} of {summary['held_runs_expected']} "
                                         f"({summary['held_samples']} samples)"])
    rows += [["peak pressure", f"{m['peak_pressure_Pa'] / 1e6:.4f} MPa"], *[[k, v] for k, v in summary["tables"].items()]]
    iso_fit = (summary["fit"] or {}).get("isometric")
    if iso_fit:
        rows.append(["isometric: best law (held out)", f"{iso_fit['best']}"])
    if summary["fit"] and summary["fit"].get("source") == "isometric":
        f = summary["fit"]
        rows += [["muscle file (from the isometric runs)", f["muscle_file"]], ["report", str(report)]]
    elif summary["fit"]:
        f = summary["fit"]
        fr = f.get("friction") or {}
        rows += [["best law (held out)", f"{f['best']} ({f['best_cv_rmse_m'] * 1e3:.3f} mm)"],
                 ["friction A_f", f"{fr['friction_area_m2'] * 1e6:.4g} mm² (N/MPa)" if "friction_area_m2" in fr
                  and "error" not in fr else fr.get("error", "not fitted")],
                 ["muscle file", f["muscle_file"]], ["report", str(report)]]
    print_table(f"Characterization on {port}", [" what", "value"], rows)
