"""Writing figures: any format Matplotlib writes, atomically, with the user's umask.

Nothing here (nor anywhere in the library) switches Matplotlib's backend: figures show inline in
Jupyter, and a script without a display gets Matplotlib's own non-interactive default.
"""

from __future__ import annotations

import os

from mckibben.atomic import atomic_file, check_output_file
from mckibben.results import to_jsonable

__all__ = ["figure_formats", "check_figure_path", "save_figure", "figure_metadata"]


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


def figure_metadata(fmt: str, provenance: dict) -> dict | None:
    """The provenance as the metadata a figure format can hold (Matplotlib's ``savefig(metadata=)``).

    PNG keeps text chunks (the whole provenance as JSON under ``Description``), PDF its document
    information (``Subject``), SVG its Dublin Core fields (``Description``); PostScript takes a
    creator and a title. Formats with no place for text (JPEG, TIFF, raw) get ``None``.

    Parameters
    ----------
    fmt : str
        The format, e.g. ``"png"``. [-]
    provenance : dict
        From :func:`mckibben.results.provenance` (call, arguments, version, UTC time, inputs). [-]

    Returns
    -------
    dict or None
        ``savefig``'s ``metadata``. [-]
    """
    import json
    from datetime import datetime

    text = json.dumps(to_jsonable(provenance), sort_keys=True, allow_nan=False)
    creator = f"mckibben {provenance.get('mckibben_version', '')}".strip()
    title = str(provenance.get("command") or provenance.get("call") or "")
    when = provenance.get("created_utc")
    fmt = fmt.lower()
    if fmt == "png":
        return {"Software": creator, "Title": title, "Creation Time": when, "Description": text}
    if fmt == "pdf":
        date = datetime.fromisoformat(when) if when else None
        return {"Creator": creator, "Title": title, "Subject": text, "CreationDate": date}
    if fmt in ("svg", "svgz"):
        return {"Creator": creator, "Title": title, "Date": when, "Description": text}
    if fmt in ("ps", "eps"):
        return {"Creator": creator, "Title": title}
    return None


def save_figure(fig, path, dpi: int = 120, name: str = "plot", provenance: dict | None = None) -> None:
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
    provenance : dict, optional
        Where the figure came from (:func:`mckibben.results.provenance`), written into the file's
        metadata where its format has a place for it (:func:`figure_metadata`). [-]
    """
    path = os.fspath(path)
    fmt = (os.path.splitext(path)[1] or ".png").lstrip(".").lower()
    meta = figure_metadata(fmt, provenance) if provenance else None
    with atomic_file(path, name) as tmp:
        fig.savefig(tmp, dpi=dpi, format=fmt, **({"metadata": meta} if meta else {}))
