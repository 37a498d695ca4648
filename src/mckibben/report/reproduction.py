"""The whole characterization report in one call, and the published sets' length tables.

:func:`reproduce` does the whole job (``mckibben reproduce``): :func:`characterize` fits,
:func:`write_report` writes ``index.html``, ``summary.json`` and the PNG figures atomically,
:func:`published_length_tables` evaluates the published sets (Table I, Table II and eq. 3 of
[mpam-characterization]). On the bundled (synthetic) campaign or on any campaign folder.
"""

from __future__ import annotations

from collections.abc import Callable
import os

import numpy as np

from mckibben.errors import ArgumentTypeError, check_callable
from mckibben.report.characterize import characterize
from mckibben.report.html import check_report_folder, write_report
from mckibben.datasets import MUSCLES
from mckibben.models.flags import flag_names
from mckibben.models.mpam import predict_length
from mckibben.datasets.campaign import campaign_muscle_dirs
from mckibben.report.figures import ALL_FIGURES

__all__ = ["published_length_tables", "reproduce"]


def published_length_tables() -> dict:
    """Predicted length of every published muscle and load at 0, 0.1, ..., 0.8 MPa (eq. 2 and 3).

    Returns
    -------
    dict
        ``"mpam97@0.6N"`` → pressures [Pa], lengths [m], contractions [-], cos θ [-] and flags.
    """

    pressures = np.linspace(0.0, 0.8e6, 9)
    tables = {}
    for name, m in MUSCLES.items():
        for load in m.braid_map.loads:
            r = predict_length(m, pressures, load)
            tables[f"{name}@{load:g}N"] = {
                "muscle": name,
                "load_N": load,
                "pressure_Pa": pressures.tolist(),
                "length_m": r.length.tolist(),
                "contraction": r.contraction.tolist(),
                "cos_theta": r.cos_theta.tolist(),
                "flags": [flag_names(x) for x in r.flags],
            }
    return tables


def reproduce(out="mckibben-report", *, data=None, progress: Callable[[str, int, int], None] | None = None):
    """Characterize a campaign and write its HTML report: every fit, the comparison, the figures.

    Parameters
    ----------
    out : str or os.PathLike, default "mckibben-report"
        Report folder (replaced only if it holds a report written before). [-]
    data : str or os.PathLike, optional
        Campaign folder (one sub-folder per muscle); default the bundled synthetic campaign. [-]
    progress : callable, optional
        ``progress(message, done, total)`` after each step. [-]

    Returns
    -------
    (pathlib.Path, dict, dict)
        The report folder, its summary and :func:`published_length_tables`.
    """

    check_callable(progress, "progress")  # before the run, not found after it
    if not isinstance(out, (str, os.PathLike)) or (data is not None and not isinstance(data, (str, os.PathLike))):
        bad, name = (out, "out") if not isinstance(out, (str, os.PathLike)) else (data, "data")
        raise ArgumentTypeError(f"{name} = {bad!r}: not a folder path (str or os.PathLike)")
    check_report_folder(out)
    tables = published_length_tables()
    # per muscle: fits and comparison; the isometric comparisons; the figures
    total = 2 * len(campaign_muscle_dirs(data)) + len(ALL_FIGURES) + 1
    done = [0]

    def step(msg: str) -> None:
        done[0] += 1
        if progress is not None:
            progress(msg, done[0], max(total, done[0]))

    char = characterize(data, progress=step)
    folder, summary = write_report(char, out, progress=step)
    return folder, summary, tables
