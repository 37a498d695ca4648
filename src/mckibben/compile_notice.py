"""Whether the first compilation of a process says so on stderr (the ``mckibben`` command turns it on).

A cold kernel cache makes the first command of a machine compile for up to a minute; the
command line prints one line before it does, so that a user knows why it waits (and that it
happens once). A Jupyter (IPython) kernel says so too, once per kernel, with one dot per kernel
compiled as progress: a notebook's first simulating cell otherwise waits with no word. Kept apart
from the compiled kernels so that switching it on imports nothing: ``mckibben --version`` and
``predict`` never import Numba.
"""

from __future__ import annotations

import sys

#: True: the first compilation of a kernel of the package in this process prints one line on stderr.
enabled = False


def in_notebook() -> bool:
    """Whether this process is a Jupyter (IPython) kernel: its cells show stderr, and it compiles silently otherwise."""
    return "ipykernel" in sys.modules


def shown() -> bool:
    """Whether this process says when it compiles: the ``mckibben`` command, or a Jupyter kernel."""
    return enabled or in_notebook()
