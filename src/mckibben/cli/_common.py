"""Shared pieces of the command line: output (table or one JSON object) and errors.

Every command takes ``--json``: then it prints a single JSON object on stdout, numbers in SI with
unit-suffixed keys (``length_m``, ``pressure_Pa``). Bad input raises
:class:`~mckibben.errors.InputError`; :func:`mckibben.cli.main` prints its one line on stderr
and exits with status 2.

The library's messages name its Python arguments (``beta = 300: ...``, ``p_max: ...``, another
argument in backquotes: ``equals `start```); :func:`in_flags` turns them into the flags of the
command that ran (``--beta``, ``--p-max``, ``--from``), read from the command's own options, so
the one table of names is the commands' signatures.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from mckibben.errors import InputError
from mckibben.results import to_jsonable
from mckibben.units import parse_quantity
from mckibben import fit

console = Console(soft_wrap=True)
err_console = Console(stderr=True, soft_wrap=True)

JSON_OPTION = typer.Option(False, "--json", help="Print one JSON object on stdout (SI units).")
#: ``--direction`` of every command that takes ``--muscle-file``; check it with :func:`check_direction`.
DIRECTION_OPTION = typer.Option("inflate", "--direction", help="--muscle-file: the fitted law's inflate or deflate "
                                                                "branch (a spring law's hysteresis; the other laws "
                                                                "have one).")


#: ``--select`` and ``--columns`` of every command that reads a lab's table (the reader's ``select``, ``columns``).
SELECT_OPTION = typer.Option(None, "--select", metavar="COLUMN=VALUE",
                             help="Read only the rows whose COLUMN holds VALUE (repeatable): one muscle or "
                                  "condition of a table holding several, e.g. --select cut_length_cm=10.")
COLUMNS_OPTION = typer.Option(None, "--columns", metavar="OLD=NEW",
                              help="Read the file's column OLD as the schema's NEW (repeatable), e.g. "
                                   "--columns phase=direction.")


def choices(values) -> str:
    """An option's metavar listing its choices, ``[none|lowest|column]``, instead of ``<str>`` in ``--help``.

    Parameters
    ----------
    values : iterable of str
        The option's choices (the library's tuple of them: one list). [-]
    """
    return "[" + "|".join(values) + "]"


def parse_pairs(values: list[str] | None, flag: str, example: str) -> dict[str, str] | None:
    """``["a=1", "b=2"]`` of a repeatable ``NAME=VALUE`` flag as a dict (None if not given).

    Parameters
    ----------
    values : list of str or None
        What the user typed, one item per use of the flag. [-]
    flag : str
        The flag, for the message (``--select``). [-]
    example : str
        A right value, for the message. [-]
    """
    if not values:
        return None
    out: dict[str, str] = {}
    for item in values:
        key, eq, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not eq or not key or not value:
            raise InputError(f"{flag}: {item!r} is not NAME=VALUE; give e.g. {flag} {example}")
        if key in out:
            raise InputError(f"{flag}: {key} is given twice ({key}={out[key]}, {item}); keep one")
        out[key] = value
    return out


def print_notes(notes) -> None:
    """A table reader's notes, one ``note:`` line each on stderr, with the flags that act on them."""
    for note in notes or ():
        err_console.print(f"note: {in_flags(note, {'columns': '--columns', 'select': '--select'})}",
                          markup=False, highlight=False)


def _looks_like_file(value: str) -> bool:
    """Whether a ``--muscle`` value is a file (a ``.toml`` name or a file that exists), not a set's name."""
    return value.strip().lower().endswith(".toml") or Path(value).is_file()


def _published_set(ctx: typer.Context, value: str | None) -> str | None:
    """``--muscle``'s callback: a published set's name; a file gets the hint of ``--muscle-file``."""
    if value is not None and _looks_like_file(value):
        takes_file = any("--muscle-file" in p.opts for p in ctx.command.params)
        hint = (f"give a muscle file with --muscle-file {value}" if takes_file else
                "this command runs the published sets only (a command that runs a muscle file lists --muscle-file "
                "in its --help)")
        raise InputError(f"--muscle: {value!r} is a file; --muscle names a published parameter set "
                         f"(mckibben params list); {hint}")
    return value


def muscle_option(default: str | None, help: str):
    """``--muscle NAME``, a published parameter set, the same in every command (a file is refused with a hint)."""
    return typer.Option(default, "--muscle", metavar="NAME", help=help, callback=_published_set)


#: ``--muscle-file FILE`` of fit and compare (the Python argument is the library's ``muscle``).
MUSCLE_FILE_ARG_OPTION = typer.Option(None, "--muscle-file", metavar="FILE",
                                      help="Muscle file (TOML); default muscle.toml beside DATA, else the rest length "
                                           "the table gives (one muscle).")
#: The old spelling of ``--muscle-file`` in fit and compare, kept with a deprecation note.
OLD_MUSCLE_FILE_OPTION = typer.Option(None, "--muscle", metavar="FILE",
                                      help="Deprecated spelling of --muscle-file here (--muscle names a published set "
                                           "in every other command).")


def muscle_file_of(muscle_file: str | None, old: str | None, command: str) -> str | None:
    """The muscle file of a command that took it as ``--muscle`` before ``--muscle-file``.

    ``--muscle FILE`` still works, with one deprecation warning on stderr; a published set's name
    there, or both flags at once, is refused (one line, exit 2).

    Parameters
    ----------
    muscle_file : str or None
        ``--muscle-file``. [-]
    old : str or None
        ``--muscle`` (the old spelling). [-]
    command : str
        The command, for the messages (``fit``). [-]
    """
    if old is None:
        return muscle_file
    if muscle_file is not None:
        raise InputError(f"--muscle: given with --muscle-file; in {command} --muscle is the old spelling of "
                         "--muscle-file: keep --muscle-file")
    if not _looks_like_file(old):
        raise InputError(f"--muscle: {command} reads a muscle file (TOML), not a published parameter set; give "
                         f"--muscle-file FILE.toml ({old!r} is not a .toml file)")
    err_console.print(f"warning: {command} --muscle FILE is deprecated: use --muscle-file {old} (--muscle names a "
                      "published parameter set in every command)", markup=False, highlight=False)
    return old


def check_direction(direction: str) -> str:
    """``--direction``, checked: ``inflate`` or ``deflate`` (else one line, exit 2).

    The value only; :func:`mckibben.fit.muscle_file.check_direction` (the one check) also refuses
    ``deflate`` for a file whose law has one branch, given the law.
    """

    return fit.muscle_file.check_direction(direction)


def command_of(app, args: list[str]):
    """The (sub)command a command line runs: ``["control", "step", ...]`` -> the ``control step`` command."""
    command = typer.main.get_command(app)
    for arg in args:
        sub = getattr(command, "commands", {}).get(arg)
        if sub is not None:
            command = sub
        elif not arg.startswith("-"):
            break
    return command


def flag_names(command) -> dict[str, str]:
    """Python argument name -> how the command takes it (``start`` -> ``--from``; an argument: ``FILE``)."""
    flags = {}
    for param in getattr(command, "params", ()):
        longs = [o for o in param.opts if o.startswith("--")]
        if longs:
            flags[param.name] = longs[0]
        elif getattr(param, "param_type_name", "") == "argument":
            flags[param.name] = param.name.upper()
    return flags


_LEADING = re.compile(r"^([A-Za-z_]\w*(?:/[A-Za-z_]\w*)*)(?=[ :=]|$)")
_QUOTED = re.compile(r"`([A-Za-z_]\w*)`")


def in_flags(message: str, flags: dict[str, str]) -> str:
    """A library message with the Python arguments it names written as the command's flags.

    The argument a message starts with (``p_max: ...``, ``target/start: ...``) and any argument
    in backquotes (```start```) become the flags of ``flags`` (from :func:`flag_names`); a name
    the command does not take is left as written.
    """
    def leading(m: re.Match) -> str:
        names = m.group(1).split("/")
        return "/".join(flags[n] for n in names) if all(n in flags for n in names) else m.group(0)

    message = _LEADING.sub(leading, message, count=1)
    return _QUOTED.sub(lambda m: flags.get(m.group(1), m.group(0)), message)


class FlagValue(float):
    """A flag's quantity in SI that prints (``repr``) as the user typed it.

    The library takes numbers and quotes the argument it refuses with ``{value!r}``; given a
    :class:`FlagValue`, that quote is the flag's text (``--supply: '2MPa' is above the
    compressor's 1 MPa``), while every computation, ``str``, ``format`` and JSON see the number.
    """

    text: str

    def __new__(cls, value: float, text: str):
        obj = super().__new__(cls, value)
        obj.text = text
        return obj

    def __repr__(self) -> str:
        return repr(self.text)


def parse_flag(text: str | None, dimension: str, name: str, **kw) -> FlagValue | None:
    """A flag's text in SI (None stays None), for the library argument ``name``.

    Parameters
    ----------
    text : str or None
        What the user typed. [-]
    dimension : str
        Its dimension (:func:`mckibben.units.parse_quantity`). [-]
    name : str
        The library's Python argument it goes to: a refusal names it, and :func:`in_flags` writes
        it as the flag. [-]
    **kw
        ``allow_negative``, ``allow_zero`` of :func:`~mckibben.units.parse_quantity`. [-]
    """
    return None if text is None else FlagValue(parse_quantity(text, dimension, name, **kw), text)


def emit_json(obj: dict) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n")
    sys.stdout.flush()


def print_table(title: str, columns: list[str], rows: list[list[Any]]) -> None:
    """Print a table of rows (values are formatted with ``str`` unless already strings).

    On a terminal, a Rich table; otherwise (piped, redirected) plain aligned text, never cut to
    the terminal's width.
    """
    cells = [[v if isinstance(v, str) else _fmt(v) for v in row] for row in rows]
    if not console.is_terminal:
        columns_env = os.environ.get("COLUMNS", "")
        sys.stdout.write(plain_table(title, columns, cells, int(columns_env) if columns_env.isdigit() else None))
        sys.stdout.flush()
        return
    table = Table(title=title, title_justify="left")
    for col in columns:
        table.add_column(col, justify="right" if col[:1] != " " else "left", overflow="fold")
    for row in cells:
        table.add_row(*row)
    console.print(table, soft_wrap=False)  # the table fits the terminal: long cells wrap


def plain_table(title: str, columns: list[str], cells: list[list[str]], width: int | None = None) -> str:
    """The table as plain text: a title line, a header, one line per row, columns aligned.

    Parameters
    ----------
    title, columns, cells
        As :func:`print_table` (a column whose name starts with a space is left-aligned). [-]
    width : int, optional
        Fit the lines in this many characters by wrapping the widest column's cells onto
        continuation lines (``$COLUMNS`` when piped; default: never wrapped, a line per row). [-]
    """
    head = [c.strip() for c in columns]
    widths = [max([len(h)] + [len(r[i]) for r in cells if i < len(r)]) for i, h in enumerate(head)]
    left = [c[:1] == " " for c in columns]
    if width is not None and sum(widths) + 2 * (len(widths) - 1) > width and widths:
        wide = max(range(len(widths)), key=widths.__getitem__)
        widths[wide] = max(len(head[wide]), 12, width - (sum(widths) - widths[wide]) - 2 * (len(widths) - 1))

    def line(values):
        return "  ".join(v.ljust(w) if lft else v.rjust(w) for v, w, lft in zip(values, widths, left)).rstrip()

    def lines(values):
        parts = [textwrap.wrap(v, w, break_long_words=True) or [""] if len(v) > w else [v]
                 for v, w in zip(values, widths)]
        return [line([p[k] if k < len(p) else "" for p in parts]) for k in range(max(len(p) for p in parts))]

    return "\n".join([title, line(head), *[x for r in cells for x in lines(r)]]) + "\n"


def _fmt(value: Any) -> str:
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            return "—"
        return f"{value:.4g}"
    return str(value)


def fail(message: str) -> None:
    """Raise the error the CLI reports as one line with exit status 2."""
    raise InputError(message)
