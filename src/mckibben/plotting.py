"""Writing figures: any format Matplotlib writes, atomically, with the user's umask.

Nothing here (nor anywhere in the library) switches Matplotlib's backend: figures show inline in
Jupyter, and a script without a display gets Matplotlib's own non-interactive default.
"""

from __future__ import annotations

import os

from mckibben.atomic import atomic_file, check_output_file

__all__ = ["figure_formats", "check_figure_path", "save_figure"]


def figure_formats() -> tuple[str, ...]:
    """The file suffixes Matplotlib can write (``.png``, ``.pdf``, ``.svg``, ``.eps``, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase  # deferred on purpose: Matplotlib

    return tuple(f".{s}" for s in sorted(FigureCanvasBase.get_supported_filetypes()))


def check_figure_path(path, name: str = "plot") -> str:
    """Refuse, before anything runs, a figure path with no format Matplotlib writes or no folder.

    Parameters
    ----------
    path : str or os.PathLike
        The output file; its suffix picks the format. [-]
    name : str, default "plot"
        The argument's name, for the message. [-]
    """
    return os.fspath(check_output_file(path, name, suffixes=figure_formats()))


def save_figure(fig, path, dpi: int = 120, name: str = "plot") -> None:
    """Save a Matplotlib figure atomically (temporary file in the same folder, then rename).

    The format follows the file's suffix (.png when it has none). A destination that is a folder,
    a FIFO or device, or in a folder that does not exist or takes no new files is an
    :class:`~mckibben.errors.InputError` naming ``name`` (see :mod:`mckibben.atomic`).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure. [-]
    path : str or os.PathLike
        Output file. [-]
    dpi : int, default 120
        Resolution of raster formats. [dots per inch]
    name : str, default "plot"
        The option that named the file, for error messages. [-]
    """
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1] or ".png"
    with atomic_file(path, name) as tmp:
        fig.savefig(tmp, dpi=dpi, format=suffix.lstrip(".").lower())
