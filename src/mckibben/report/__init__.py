"""The characterization report: run every fit on a campaign folder, draw the figures, write HTML.

:func:`reproduce` does the whole job (``mckibben reproduce``): :func:`characterize` fits,
:func:`write_report` writes ``index.html``, ``summary.json`` and the PNG figures atomically,
:func:`published_length_tables` evaluates the published sets (Table I, Table II and eq. 3 of
[mpam-characterization]). On the bundled (synthetic) campaign or on any campaign folder.
"""

from mckibben import _lazy
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "characterize": "mckibben.report.characterize",
    "check_report_folder": "mckibben.report.html",
    "published_length_tables": "mckibben.report.reproduction",
    "render_html": "mckibben.report.html",
    "reproduce": "mckibben.report.reproduction",
    "run_report": "mckibben.report.run",
    "summarize": "mckibben.report.html",
    "write_report": "mckibben.report.html",
}

__all__ = ["characterize", "check_report_folder", "published_length_tables", "render_html", "reproduce",
           "run_report", "summarize", "write_report"]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.report.characterize import characterize as characterize
    from mckibben.report.html import check_report_folder as check_report_folder
    from mckibben.report.reproduction import published_length_tables as published_length_tables
    from mckibben.report.html import render_html as render_html
    from mckibben.report.reproduction import reproduce as reproduce
    from mckibben.report.run import run_report as run_report
    from mckibben.report.html import summarize as summarize
    from mckibben.report.html import write_report as write_report


__getattr__, __dir__ = _lazy.package(__name__, _WHERE, keep_names=True)
