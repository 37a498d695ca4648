"""``python -m mckibben.cli``: the same as the ``mckibben`` command."""

from mckibben.cli import run

run()
