"""``mckibben sweep run|summarize``: design sweeps, local or on a Dask cluster."""

from __future__ import annotations

import re
import sys
import time

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, err_console, print_table
from mckibben.errors import InputError
from mckibben.limits import SECONDS_PER_SAMPLE, check_budget, lifted
from mckibben.atomic import check_output_dir
from mckibben import sweep as sweep_lib

sweep_app = typer.Typer(help="Parameter sweeps on the batch simulator, in-process or on Dask.", no_args_is_help=True)
app.add_typer(sweep_app, name="sweep")

_SCHEDULER = re.compile(r"^tcp://[A-Za-z0-9_.\-\[\]:]+:\d{1,5}$")


@sweep_app.command("run")
def run_cmd(
    file: str = typer.Argument(..., help="The sweep description (TOML)."),
    out: str = typer.Option(..., "--out", help="Results folder (chunks already there are kept: a rerun resumes)."),
    workers: int = typer.Option(None, "--workers", help="Run on a local Dask cluster with N worker processes."),
    scheduler: str = typer.Option(None, "--scheduler", help="Run on an existing Dask scheduler, tcp://HOST:PORT."),
    force: bool = typer.Option(False, "--force", help="Run past the documented size limits (mckibben.limits)."),
    json: bool = JSON_OPTION,
) -> None:
    """Run a sweep; chunks already written are skipped (resume)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn  # deferred on purpose: Rich's progress display (about 30 ms to import)



    if workers is not None and scheduler is not None:
        raise InputError("--workers and --scheduler: give one, not both")
    if workers is not None and not 1 <= workers <= 256:
        raise InputError(f"--workers: {workers} must be between 1 and 256")
    if scheduler is not None and not _SCHEDULER.match(scheduler):
        raise InputError(f"--scheduler: {scheduler!r} must look like tcp://HOST:PORT")
    sweep = sweep_lib.load_sweep(file)

    # memory: one chunk per worker at a time; time: the wall time, shared by the workers
    steps = round(sweep.scenario["duration"] / 1e-3)
    check_budget(f"{file} (samples × grid × duration, chunk_size)", sweep.n_runs * steps, force=force,
                 memory_samples=min(sweep.chunk_size, sweep.n_runs) * steps * (workers or 1),
                 seconds_per_sample=SECONDS_PER_SAMPLE / (workers or 1))
    t0 = time.perf_counter()
    show = not json and sys.stderr.isatty()
    progress = Progress(TextColumn("sweep"), BarColumn(), TextColumn("{task.completed}/{task.total} runs"),
                        TextColumn("{task.fields[rate]:.0f} sims/s"), TimeRemainingColumn(), console=err_console,
                        disable=not show)
    with progress:
        task = progress.add_task("sweep", total=sweep.n_runs, rate=0.0)
        first = {}

        def update(done, total):
            first.setdefault("done", done)
            dt = time.perf_counter() - t0
            rate = (done - first["done"]) / dt if dt > 0 else 0.0
            progress.update(task, completed=done, rate=rate)

        with lifted(force):  # the library applies the same limits; --force lifts them there too
            stats = sweep_lib.run_sweep(sweep, out, workers=workers, scheduler=scheduler, progress=update)
    stats.update(out=str(out), sweep_sha256=sweep.sha256, seed=sweep.seed)
    if json:
        emit_json(stats)
        return
    print_table("Sweep", ["runs", "chunks", "computed", "skipped (resumed)", "seconds", "results"],
                [[stats["runs"], stats["chunks"], stats["computed"], stats["skipped"], f"{stats['seconds']:.1f}", str(out)]])


@sweep_app.command("summarize")
def summarize_cmd(
    results: str = typer.Argument(..., help="A results folder written by `mckibben sweep run`."),
    objective: str = typer.Option("time_constant_s", "--objective", help="Metric to minimise (median over plants)."),
    constraint: str = typer.Option("overshoot_pct<=10", "--constraint", help="METRIC<=VALUE the quantile must meet."),
    quantile: float = typer.Option(0.95, "--quantile", help="Fraction of plants that must meet the constraint."),
    folder: str = typer.Option(None, "--plots", help="Folder for pareto.png and sensitivity.png."),
    json: bool = JSON_OPTION,
) -> None:
    """Best setting under a constraint, Pareto front, sensitivities, figures."""

    if folder:
        check_output_dir(folder, "--plots")
    table = sweep_lib.read_results(results)
    best = sweep_lib.best_setting(table, objective, constraint, quantile)
    s = sweep_lib.settings_table(table, quantile)
    qn = int(round(quantile * 100))
    objs = [c for c in ("time_constant_s_median", "valve_effort_counts_median", f"overshoot_pct_q{qn}") if c in s]
    front = sweep_lib.pareto_front(s, objs) if objs else s.iloc[:0]
    sens = sweep_lib.sensitivity(table)
    paths = sweep_lib.summary.figures(table, folder, quantile) if folder else []
    if json:
        emit_json({"runs": len(table), "settings": len(s), "objective": objective, "constraint": constraint,
                   "quantile": quantile, "best": best, "pareto_front": front.to_dict("records"),
                   "sensitivity": {p: sens.loc[p].to_dict() for p in sens.index}, "figures": paths})
        return
    if best is None:
        err_console.print(f"no setting meets {constraint} in {qn} % of plants")
    else:
        print_table(f"Best setting: lowest median {objective} with {constraint} in {qn} % of plants",
                    ["field", "value"], [[k, v if isinstance(v, str) else f"{v:.4g}"] for k, v in best.items()])
    grid = [c for c in front.columns if c.startswith(("plant.", "controller."))]
    shown = front[grid + objs]
    print_table("Pareto front (settings no other beats on every objective)",
                [c.split(".")[-1] for c in shown.columns],
                [[f"{v:.4g}" if isinstance(v, float) else str(v) for v in r] for r in shown.itertuples(index=False)])
    print_table("Sensitivity (Spearman)", ["parameter", *sens.columns],
                [[p, *[f"{v:+.2f}" for v in sens.loc[p]]] for p in sens.index])
