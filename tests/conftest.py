"""Shared test helpers."""

from __future__ import annotations

import io
import json
import os
import re
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


def names_argument(message: str, name: str) -> bool:
    """True where ``message`` names the argument ``name`` as a word, or its flag form with hyphens.

    A substring test would let a one-letter name such as ``n`` or ``ax`` pass on almost any message.
    """
    return any(re.search(rf"(?<![A-Za-z0-9_]){re.escape(form)}(?![A-Za-z0-9_])", message)
               for form in {name, name.replace("_", "-")})


def refusals_in_subprocess(setup: str, cases: dict, memory_limit: int | None = None, timeout: float = 120) -> dict:
    """Evaluate each case's Python expression in one fresh interpreter, for calls that could eat the
    machine's memory or hang if a size guard failed.

    ``setup`` is the code that imports what the expressions use; ``memory_limit`` [bytes] caps the
    interpreter's address space. Returns case -> the :class:`~mckibben.errors.InputError`'s
    message, ``"ran"`` if the call returned, or ``"crash <exception type>"``.
    """
    import subprocess
    import sys
    import textwrap

    limit = ("import resource\n"
             f"resource.setrlimit(resource.RLIMIT_AS, ({memory_limit}, {memory_limit}))\n") if memory_limit else ""
    code = limit + textwrap.dedent(setup) + textwrap.dedent("""
        import json, sys
        from mckibben.errors import InputError
        out = {}
        for key, expr in json.loads(sys.argv[1]).items():
            try:
                eval(expr)
                out[key] = "ran"
            except InputError as exc:
                out[key] = str(exc)
            except BaseException as exc:
                out[key] = "crash " + type(exc).__name__
        print(json.dumps(out))
    """)
    run = subprocess.run([sys.executable, "-c", code, json.dumps(cases)], capture_output=True, text=True,
                         timeout=timeout, env={**os.environ, "MCKIBBEN_NO_COMPILE_NOTICE": "1"})
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def _avr_engine_missing() -> str | None:
    from mckibben.rig.engines import avr

    return avr.available()


#: The device engines every device test runs against: the Python emulator and the firmware image in
#: simavr (skipped only where libsimavr, avr-gcc or make is missing).
DEVICE_ENGINES = ["python", "avr"]


@pytest.fixture(params=DEVICE_ENGINES)
def engine(request) -> str:
    """The device engine of a device test: ``python`` or ``avr`` (skipped, with the reason, without the tools)."""
    if request.param == "avr":
        why = _avr_engine_missing()
        if why is not None:
            pytest.skip(why)
    return request.param


def start_device(engine: str, **kw):
    """A device of ``engine`` behind a pty, running (a context manager): :func:`mckibben.rig.engines.start_device`."""
    from mckibben.rig.engines import start_device as start

    return start(engine, **kw)
