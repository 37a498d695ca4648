"""The HTML report of a bench characterization run (``mckibben rig characterize``): the report package's own
report (loops, fits, residuals, comparison), on the run seen as a one-muscle campaign.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from mckibben.report.characterize import characterize as campaign
from mckibben.report.html import write_report
from mckibben.rig.characterize import report_view

__all__ = ["run_report"]


def run_report(out) -> Path:
    """Write ``OUT/report/`` (``index.html``, ``summary.json``, figures) for a finished run with a muscle file.

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder (:func:`mckibben.rig.characterize.run_characterization` with a muscle file). [-]

    Returns
    -------
    pathlib.Path
        The report's ``index.html``. [-]
    """
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix=".report-", dir=out) as tmp:
        report_view(out, tmp)
        folder, _ = write_report(campaign(tmp), out / "report")
    return folder / "index.html"
