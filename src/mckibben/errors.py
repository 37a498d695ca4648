"""Exceptions raised for bad input.

Every error a user can cause is an :class:`InputError`: one line that names what was wrong and
where (file:row:column, argument name, fit). It subclasses :class:`ValueError` so callers can
catch it plainly; the CLI turns it into a single line on stderr and exit status 2.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class InputError(ValueError):
    """Bad input from a user: a value, a file, an argument. The message is one line."""


class UnreachableError(InputError):
    """A target (length, pressure, tip position) that the muscle or tool cannot reach."""


def unknown_name(kind: str, name: str, choices: Iterable[str]) -> InputError:
    """Build the error for an unknown name, suggesting the closest valid ones.

    Parameters
    ----------
    kind : str
        What was named, e.g. ``"muscle"`` or ``"model"``. [-]
    name : str
        The name the user gave. [-]
    choices : iterable of str
        The valid names. [-]
    """
    choices = sorted(choices)
    close = difflib.get_close_matches(name, choices, n=3)
    hint = f" Did you mean {', '.join(close)}?" if close else ""
    return InputError(f"unknown {kind} {name!r}.{hint} Provide one of: {', '.join(choices)}")
