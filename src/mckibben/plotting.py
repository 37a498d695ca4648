"""Writing figures: atomically, so a failed or interrupted save leaves nothing half-written."""

from __future__ import annotations

import os
import tempfile

from mckibben.errors import InputError
from mckibben.files import apply_umask


def save_figure(fig, path, dpi: int = 120) -> None:
    """Save a Matplotlib figure atomically (temporary file in the same folder, then rename).

    The format follows the file's suffix (.png when it has none).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure. [-]
    path : str or os.PathLike
        Output file. [-]
    dpi : int, default 120
        Resolution of raster formats. [dots per inch]
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise InputError(f"--plot: folder {folder!r} does not exist")
    suffix = os.path.splitext(path)[1] or ".png"
    fd, tmp = tempfile.mkstemp(suffix=suffix, dir=folder)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=dpi, format=suffix.lstrip(".").lower())
        apply_umask(tmp, directory=False)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
