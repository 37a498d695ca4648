"""Experiments above control, tool and rig (DESIGN.md): the layer that may use all three.

:mod:`~mckibben.experiments.link`: the three-muscle tool steered through the device link
(``mckibben tool track --port``; :func:`~mckibben.experiments.link.track_over_link`). It was
``mckibben.rig.track``; it moved here because it uses the tool, which the rig may not import.
"""

from mckibben import _lazy


__getattr__, __dir__ = _lazy.package(__name__, None)
