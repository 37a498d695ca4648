"""Writing figures: atomically, so a failed or interrupted save leaves nothing half-written."""

from __future__ import annotations

import os

from mckibben.atomic import atomic_file


def save_figure(fig, path, dpi: int = 120, name: str = "--plot") -> None:
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
    name : str, default "--plot"
        The option that named the file, for error messages. [-]
    """
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1] or ".png"
    with atomic_file(path, name) as tmp:
        fig.savefig(tmp, dpi=dpi, format=suffix.lstrip(".").lower())
