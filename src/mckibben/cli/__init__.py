"""The ``mckibben`` command.

``main()`` runs the Typer app and turns every :class:`~mckibben.errors.InputError` (and every
usage error of the parser) into one line on stderr and exit status 2, with no traceback.
Sub-commands live in sibling modules, each adding itself to :data:`app`.
"""

from __future__ import annotations

import contextlib
import errno
import importlib
import inspect
import os
import pkgutil
import shlex
import signal
import sys
import threading
import traceback
import warnings

import click
import numpy as np
import typer

try:  # Typer >= 0.20 vendors its own copy of Click
    from typer._click import exceptions as _tclick
except ImportError:  # pragma: no cover - older Typer uses Click itself
    _tclick = click.exceptions

_USAGE_ERRORS = (click.UsageError, _tclick.UsageError)
_NO_ARGS = tuple({click.exceptions.NoArgsIsHelpError, getattr(_tclick, "NoArgsIsHelpError", click.exceptions.NoArgsIsHelpError)})
_EXITS = (click.exceptions.Exit, typer.Exit)
_ABORTS = (click.Abort, typer.Abort)

from mckibben import __version__, compile_notice, results  # noqa: E402  (after the Click/Typer compatibility shims)
from mckibben.cli._common import command_of, flag_names, in_flags  # noqa: E402
from mckibben.errors import InputError  # noqa: E402

app = typer.Typer(
    name="mckibben",
    help="Braided pneumatic artificial muscles: characterize, fit, predict, simulate, control, deploy.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=True,
    rich_markup_mode=None,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _print_version(value: bool) -> None:
    if value:
        sys.stdout.write(f"mckibben {__version__}\n")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", "-V", is_eager=True, callback=_print_version,
                                 help="Print the version and exit."),
    debug: bool = typer.Option(False, "--debug", help="On an internal error, print the traceback (allowed anywhere "
                                                      "on the command line; or MCKIBBEN_DEBUG=1)."),
) -> None:
    """Braided pneumatic artificial muscles: characterize, fit, predict, simulate, control, deploy."""



def _register_commands() -> None:
    """Import every sibling module: each adds its commands to :data:`app` on import."""

    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")


_register_commands()

#: Words that end with a period inside a sentence: Click's first-sentence rule would cut the
#: command list's help there ("The paper's Fig."). [-]
_ABBREVIATIONS = ("Fig.", "Figs.", "eq.", "Eq.", "e.g.", "i.e.", "Ref.", "No.", "vs.", "cf.")


def short_help(doc: str | None) -> str | None:
    """The first sentence of a command's docstring, for the command list, not cut at an abbreviation.

    Parameters
    ----------
    doc : str or None
        The docstring. [-]
    """
    if not doc:
        return None
    words = inspect.cleandoc(doc).split("\n\n")[0].split()
    out = []
    for w in words:
        out.append(w)
        if w.endswith(".") and w not in _ABBREVIATIONS and not (len(w) <= 3 and w[:-1].isdigit()):
            break
    return " ".join(out).rstrip(".")


def _set_short_helps(typer_app) -> None:
    """Give every command without one a short help by :func:`short_help` (sub-apps too)."""
    for info in typer_app.registered_commands:
        if info.short_help is None and info.callback is not None:
            info.short_help = short_help(info.help or info.callback.__doc__)
    for group in typer_app.registered_groups:
        _set_short_helps(group.typer_instance)


_set_short_helps(app)


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); return the exit status.

    The one error boundary of the command line: a user's mistake (bad value, bad file, an output
    path that cannot be written, more memory than the machine has) is one line on stderr and exit
    status 2; anything else is an internal error: one line asking for a report, exit status 1, and
    the traceback only with ``--debug`` (anywhere on the line) or ``MCKIBBEN_DEBUG=1``. Warnings are
    one line each, after a successful run. SIGTERM and SIGHUP unwind like Ctrl-C, so no temporary
    file is left behind.
    """
    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args or os.environ.get("MCKIBBEN_DEBUG", "") not in ("", "0")
    args = [a for a in args if a != "--debug"]
    # the command line, for the provenance of what the command writes (absolute paths as bare names:
    # a file written here must not carry the layout of this machine)
    outer, results.COMMAND = results.COMMAND, shlex.join(["mckibben"] + [os.path.basename(a) if os.path.isabs(a)
                                                                         else a for a in args])
    with _signals_unwind(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        if not debug:
            np_err = np.seterr(all="ignore")
        try:
            code = _run(args, debug)
        finally:
            results.COMMAND = outer
            if not debug:
                np.seterr(**np_err)
    if code == 0 or debug:
        _print_warnings(caught)
    return _exit(code)


def _empty_value(args: list[str]) -> str | None:
    """The option given an empty value (``--plot ""`` or ``--plot=``), if any: it would silently
    mean "the default" to code that tests the value for truth."""
    for i, a in enumerate(args):
        if a.startswith("--") and a.endswith("=") and len(a) > 3:
            return a[:-1]
        if a == "" and i > 0 and args[i - 1].startswith("--") and "=" not in args[i - 1] and args[i - 1] != "--":
            return args[i - 1]
    return None


def _run(args: list[str], debug: bool) -> int:
    empty = _empty_value(args)
    if empty is not None:
        return _fail(f"{empty}: an empty value; give one, or leave the option out for its default", 2)
    try:
        result = app(args=args, prog_name="mckibben", standalone_mode=False)
    except InputError as exc:  # the library names Python arguments: say the flags the user typed
        return _fail(in_flags(str(exc), flag_names(command_of(app, args))), 2)
    except _NO_ARGS as exc:
        sys.stdout.write(exc.ctx.get_help() + "\n" if exc.ctx is not None else "")
        return 0
    except _USAGE_ERRORS as exc:
        where = f"{exc.ctx.command_path}: " if exc.ctx is not None else ""
        return _fail(f"{where}{exc.format_message()}", 2)
    except _EXITS as exc:
        return exc.exit_code
    except (_ABORTS + (KeyboardInterrupt,)) as exc:
        return _fail(_signal_name(exc), 130 if not isinstance(exc, _Terminated) else 128 + exc.signum)
    except BrokenPipeError:
        return 0
    except MemoryError as exc:
        detail = f" ({exc})" if str(exc) else ""
        return _fail(f"not enough memory for the size asked{detail}; ask for a smaller size", 2, debug)
    except OSError as exc:
        if getattr(exc, "filename", None) is None and exc.errno not in _USER_ERRNOS:
            return _internal(exc, debug)
        what = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        return _fail(f"{what}{exc.strerror or exc}", 2, debug)
    except RecursionError as exc:
        return _internal(exc, debug)
    except Exception as exc:  # noqa: BLE001 - the boundary: nothing leaves as a bare traceback
        return _internal(exc, debug)
    return result if isinstance(result, int) else 0


#: OS errors that come from the user's paths or machine even without a file name.
_USER_ERRNOS = {errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOSPC, errno.EDQUOT, errno.ENOENT, errno.EISDIR,
                errno.ENOTDIR, errno.EEXIST, errno.ENAMETOOLONG, errno.ELOOP, errno.EXDEV, errno.EBUSY}


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


#: The one prefix of every error line the command line prints (a user's mistake, exit status 2).
ERROR_PREFIX = "error: "


def _fail(message: str, code: int, debug: bool = False) -> int:
    """Print ``error: MESSAGE`` (:data:`ERROR_PREFIX`, the one place it is written) as one line; return ``code``."""
    if debug:
        traceback.print_exc(file=sys.stderr)
    sys.stderr.write(_one_line(ERROR_PREFIX + message) + "\n")
    return code


def _internal(exc: BaseException, debug: bool) -> int:
    if debug:
        traceback.print_exc(file=sys.stderr)
    hint = "" if debug else " (rerun with --debug for the traceback)"
    sys.stderr.write(_one_line(f"internal error: {type(exc).__name__}: {exc}; please report it with the command "
                               f"line{hint}") + "\n")
    return 1


class _Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised in the main thread so that ``finally`` blocks clean up."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _signal_name(exc: BaseException) -> str:
    if isinstance(exc, _Terminated):
        return f"terminated by {signal.Signals(exc.signum).name}"
    return "interrupted"


@contextlib.contextmanager
def _signals_unwind():
    """Turn SIGTERM and SIGHUP into an exception for the duration of a command (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    def handler(signum, frame):
        raise _Terminated(signum)

    old = {}
    for sig in (signal.SIGTERM, signal.SIGHUP):
        try:
            old[sig] = signal.signal(sig, handler)
        except (ValueError, OSError):
            pass
    try:
        yield
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)


def _print_warnings(caught) -> None:
    seen = set()
    for w in caught:
        line = _one_line(f"warning: {w.message}")
        if line not in seen:
            seen.add(line)
            sys.stderr.write(line + "\n")


def _exit(code: int) -> int:
    sys.stdout.flush()
    return code


def run() -> None:
    """The console script: ``sys.exit(main())``, saying on stderr when kernels are compiled for the first time."""
    compile_notice.enabled = True
    sys.exit(main())
