"""Shared test helpers."""

from __future__ import annotations

import io
import json
import os
import signal
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass

import pytest

# the suite's processes compile without the background warm-up (the compile-cache tests, which
# give their subprocesses a clean environment, run it as a user's command does)
os.environ.setdefault("MCKIBBEN_BACKGROUND_WARM", "0")

# a suite started in the background inherits SIGINT ignored (a shell does that to `&` jobs) and
# would pass the ignore on to the commands its tests interrupt with SIGINT; a Python handler here
# is reset to the default in every child instead
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

from mckibben.cli import main  # noqa: E402


@dataclass
class CliResult:
    code: int
    out: str
    err: str

    def json(self):
        return json.loads(self.out)


def run_cli(*args: str) -> CliResult:
    """Run ``mckibben ARGS`` in-process and capture exit status, stdout and stderr."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        code = main(list(args))
    return CliResult(code, out.getvalue(), err.getvalue())


@pytest.fixture
def cli():
    return run_cli
