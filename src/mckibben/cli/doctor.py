"""``mckibben doctor``: compile every kernel once, and say what this machine has."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, console, emit_json, print_table
from mckibben.cli._output import progress_bar
from mckibben import doctor


@app.command("doctor")
def doctor_cmd(
    warm: bool = typer.Option(True, "--warm/--no-warm", help="Compile (or load) every kernel the commands use, "
                                                             "once, with a progress bar."),
    scheduler: str = typer.Option(None, "--scheduler", help="Also check that a Dask scheduler answers at this "
                                                            "address (tcp://host:port)."),
    json: bool = JSON_OPTION,
) -> None:
    """Warm the kernel cache and check the optional parts (AVR toolchain, simulator, programmer, Dask)."""

    with progress_bar("compiling kernels", json or not warm) as bar:
        task = bar.add_task("warm", total=None)

        def progress(done: int, total: int, name: str) -> None:
            bar.update(task, completed=done, total=total, description=name)

        report, warmed = doctor.diagnose(scheduler, warm_up=warm, progress=progress)
    if json:
        emit_json({**report.to_dict(), "warm": None if warmed is None else warmed.to_dict(), "ok": report.ok})
    else:
        rows = [["version", report.version], ["kernel cache", report.cache_dir or f"none: {report.cache_problem}"],
                ["cache size", f"{report.cache_bytes / 1e6:.1f} MB"], ["numba / llvmlite",
                                                                        f"{report.numba} / {report.llvmlite}"],
                ["threads used / cores", f"{report.threads} / {report.cores}"]]
        if warmed is not None:
            rows.append(["warm-up", f"{len(warmed.steps)} experiments, {warmed.compiled} kernels compiled "
                                    f"({sum(s['seconds'] for s in warmed.steps):.1f} s)"])
        for name, t in {**report.tools, **report.packages}.items():
            rows.append([name, t["found"] or f"missing ({t['for']}): {t['install']}"])
        if report.scheduler is not None:
            s = report.scheduler
            rows.append([f"scheduler {s['address']}", "answers" if s["reachable"] else f"no answer: {s['detail']}"])
        print_table("mckibben doctor", ["what", "here"], rows)
    if not report.ok:
        if not json:
            console.print("[bold]doctor: see the lines above[/bold]", highlight=False)
        raise typer.Exit(1)
