"""``mckibben examples list|copy``: the example files shipped in the package."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.examples import list_examples
from mckibben.examples import copy_example

examples_app = typer.Typer(help="Example files shipped with mckibben: list them, copy one to edit.",
                           no_args_is_help=True)
app.add_typer(examples_app, name="examples")


@examples_app.command("list")
def list_cmd(json: bool = JSON_OPTION) -> None:
    """The bundled examples and what each is."""

    found = list_examples()
    if json:
        emit_json({"examples": found})
        return
    print_table("Examples (mckibben examples copy NAME [DEST])", [" name", " what"], [[k, v] for k, v in found.items()])


@examples_app.command("copy")
def copy_cmd(
    name: str = typer.Argument(..., help="An example's name, e.g. sweep.toml."),
    dest: str = typer.Argument(".", help="Folder (default: the current one) or file name of the copy."),
    json: bool = JSON_OPTION,
) -> None:
    """Copy an example out of the package (an existing file is never overwritten)."""

    path = copy_example(name, dest)
    if json:
        emit_json({"copied": str(path)})
        return
    print(f"wrote {path}")
