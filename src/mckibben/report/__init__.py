"""The characterization report: run every fit on a campaign folder, draw the figures, write HTML.

:func:`~mckibben.report.characterize.characterize` fits; :func:`~mckibben.report.html.write_report`
writes ``index.html``, ``summary.json`` and the PNG figures atomically. ``mckibben reproduce`` runs
both on the bundled (synthetic) campaign or on ``--data DIR``.
"""
