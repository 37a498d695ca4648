"""``mckibben completion SHELL``: print the shell completion script (bash, zsh, fish, powershell)."""

from __future__ import annotations

import sys

import typer

from mckibben.cli import app
from mckibben.errors import unknown_name
from typer.completion import get_completion_script

SHELLS = ("bash", "zsh", "fish", "powershell", "pwsh")


@app.command("completion")
def completion_cmd(shell: str = typer.Argument(..., help="bash, zsh, fish, powershell or pwsh.")) -> None:
    """Print the completion script for SHELL, e.g. ``mckibben completion bash >> ~/.bashrc``
    (or ``eval "$(mckibben completion bash)"``)."""

    if shell not in SHELLS:
        raise unknown_name("shell", shell, SHELLS)
    sys.stdout.write(get_completion_script(prog_name="mckibben", complete_var="_MCKIBBEN_COMPLETE", shell=shell))
    sys.stdout.write("\n")
