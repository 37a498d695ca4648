"""Options and writers shared by the commands that draw figures or write time series."""

from __future__ import annotations

import typer

from mckibben.errors import InputError
from mckibben.plotting import check_figure_path, save_figure
from mckibben.results import check_table_path, provenance
from mckibben.cli._common import err_console
import sys

DPI_OPTION = typer.Option(120, "--dpi", help="Resolution of raster figures (PNG, JPEG...), dots per inch.")
OUT_OPTION = typer.Option(None, "--out", help="Write the time series: .csv or .parquet (SI, unit-suffixed "
                                               "columns; Parquet carries the provenance).")


def plot_option(what: str):
    """A ``--plot FILE`` option; any format Matplotlib writes (by suffix)."""
    return typer.Option(None, "--plot", help=f"Write {what} (.png, .pdf, .svg, ... any Matplotlib format).")


def check_outputs(plot: str | None = None, dpi: int | None = None, out: str | None = None) -> None:
    """Refuse bad --plot, --dpi and --out before anything runs."""
    if plot is not None:
        check_figure_path(plot)
    if dpi is not None and not 10 <= dpi <= 2400:
        raise InputError(f"--dpi: {dpi} must be between 10 and 2400")
    if out is not None:
        check_table_path(out)


def write_plot(fig, path: str, dpi: int, result=None) -> None:
    """Save the figure atomically, with the provenance of ``result`` (or of the command) in its metadata, and close it."""
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

    call = getattr(result, "call", None)  # a Result; some figures come from other objects
    prov = provenance(call, getattr(result, "arguments", {})) if call else provenance("mckibben.cli")
    try:
        save_figure(fig, path, dpi=dpi, provenance=prov)
    finally:
        plt.close(fig)


def progress_bar(label: str, json: bool):
    """A Rich progress bar on stderr, shown only on a terminal (and never with --json)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn  # deferred on purpose: Rich's progress display (about 30 ms to import)



    return Progress(TextColumn(label), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                    TimeElapsedColumn(), TimeRemainingColumn(), console=err_console, transient=True,
                    disable=json or not sys.stderr.isatty())
