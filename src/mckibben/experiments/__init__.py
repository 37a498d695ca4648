"""Experiments above control, tool and rig (DESIGN.md): the layer that may use all three.

:mod:`~mckibben.experiments.link`: the three-muscle tool steered through the device link
(``mckibben tool track --port``; :func:`~mckibben.experiments.link.track_over_link`). It was
``mckibben.rig.track``; it moved here because it uses the tool, which the rig may not import.
"""

import importlib


def __getattr__(name: str):
    # the package is cheap to import (every command module imports it); a submodule loads on first use
    try:
        return importlib.import_module(f"{__name__}.{name}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
