"""The ``mckibben`` command.

``main()`` runs the Typer app and turns every :class:`~mckibben.errors.InputError` (and every
usage error of the parser) into one line on stderr and exit status 2, with no traceback.
Sub-commands live in sibling modules, each adding itself to :data:`app`.
"""

from __future__ import annotations

import sys

import click
import typer

try:  # Typer >= 0.20 vendors its own copy of Click
    from typer._click import exceptions as _tclick
except ImportError:  # pragma: no cover - older Typer uses Click itself
    _tclick = click.exceptions

_USAGE_ERRORS = (click.UsageError, _tclick.UsageError)
_NO_ARGS = tuple({click.exceptions.NoArgsIsHelpError, getattr(_tclick, "NoArgsIsHelpError", click.exceptions.NoArgsIsHelpError)})
_EXITS = (click.exceptions.Exit, typer.Exit)
_ABORTS = (click.Abort, typer.Abort)

from mckibben.errors import InputError

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
        from mckibben import __version__

        sys.stdout.write(f"mckibben {__version__}\n")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", "-V", is_eager=True, callback=_print_version,
                                 help="Print the version and exit."),
) -> None:
    """Braided pneumatic artificial muscles: characterize, fit, predict, simulate, control, deploy."""



def _register_commands() -> None:
    """Import every sibling module: each adds its commands to :data:`app` on import."""
    import importlib
    import pkgutil

    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")


_register_commands()


def main(argv: list[str] | None = None) -> int:
    """Run the command line with ``argv`` (default ``sys.argv[1:]``); return the exit status."""
    args = sys.argv[1:] if argv is None else argv
    try:
        result = app(args=args, prog_name="mckibben", standalone_mode=False)
    except InputError as exc:
        sys.stderr.write(f"error: {exc}\n")
        return _exit(2)
    except _NO_ARGS as exc:
        sys.stdout.write(exc.ctx.get_help() + "\n" if exc.ctx is not None else "")
        return _exit(0)
    except _USAGE_ERRORS as exc:
        where = f" ({exc.ctx.command_path})" if exc.ctx is not None else ""
        sys.stderr.write(f"error{where}: {exc.format_message()}\n")
        return _exit(2)
    except _EXITS as exc:
        return _exit(exc.exit_code)
    except _ABORTS:
        sys.stderr.write("error: aborted\n")
        return _exit(130)
    except BrokenPipeError:
        return _exit(0)
    return _exit(result if isinstance(result, int) else 0)


def _exit(code: int) -> int:
    sys.stdout.flush()
    return code


def run() -> None:
    """The console script: ``sys.exit(main())``."""
    sys.exit(main())
