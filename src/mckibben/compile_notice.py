"""Whether the first compilation of a process says so on stderr (the ``mckibben`` command turns it on).

A cold kernel cache makes the first command of a machine compile for up to a minute; the
command line prints one line before it does, so that a user knows why it waits (and that it
happens once). Kept apart from the compiled kernels so that switching it on imports nothing:
``mckibben --version`` and ``predict`` never import Numba.
"""

from __future__ import annotations

#: True: the first compilation of a kernel of the package in this process prints one line on stderr.
enabled = False
