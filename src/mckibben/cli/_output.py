"""Options and writers shared by the commands that draw figures or write time series."""

from __future__ import annotations

import math

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


#: Labels of the metrics whose name alone does not say what they measure (the rest: the key's words).
METRIC_LABELS = {"time_constant": "time constant (63 %)", "rise_time": "rise time (10–90 %)",
                 "settling_time": "settling time (±2 %)"}
#: A metric key's unit suffix -> (factor from SI, the unit printed): the text output's units, one place.
METRIC_UNITS = {"_s": (1e3, "ms"), "_m": (1e3, "mm"), "_N": (1.0, "N"), "_pct": (1.0, "%"),
                "_counts": (1.0, "counts"), "_rad": (180.0 / math.pi, "deg")}


def metric_row(key: str, value) -> list[str]:
    """``["time constant (63 %)", "91.2 ms"]`` from ``("time_constant_s", 0.0912)``: a metric with its unit.

    The same label and unit in every command's text output (``simulate``, ``control step``,
    ``control track``, ``rig step``); pressures in kPa below 0.1 MPa (errors), else MPa.

    Parameters
    ----------
    key : str
        The metric's JSON key, unit-suffixed (``rise_time_s``, ``steady_state_error_Pa``). [-]
    value : float, str or None
        Its value in SI. [SI]
    """
    if key.endswith("_Pa"):
        stem = key[:-3]
        scale, unit = ((1e-3, "kPa") if isinstance(value, (int, float)) and abs(value) < 1e5 else (1e-6, "MPa"))
    else:
        suffix = next((s for s in METRIC_UNITS if key.endswith(s)), None)
        stem = key[: -len(suffix)] if suffix else key
        scale, unit = METRIC_UNITS[suffix] if suffix else (1.0, "")
    label = METRIC_LABELS.get(stem, stem.replace("_", " "))
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return [label, "—" if value is None else str(value)]
    if not math.isfinite(value):
        return [label, "—"]
    return [label, f"{value * scale:.4g}" + (f" {unit}" if unit else "")]
