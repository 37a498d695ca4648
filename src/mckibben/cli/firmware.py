"""``mckibben firmware build|flash|sketch``: the Mega's firmware from the installed package (docs/firmware.md)."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, parse_flag, print_table
from mckibben.rig import firmware as FW

firmware_app = typer.Typer(help="The Arduino Mega firmware: build the image, flash it, write the Arduino sketch.",
                           no_args_is_help=True)
app.add_typer(firmware_app, name="firmware")

CHANNELS_OPTION = typer.Option(3, "--channels", help="Pressure channels of the image (1..3).")
LOAD_CELL_OPTION = typer.Option(None, "--load-cell", help="Full scale of a load cell on A3 (e.g. 5N; "
                                                          "docs/firmware.md, 'Load cell'); default none.")


@firmware_app.command("build")
def build_cmd(
    n_channels: int = CHANNELS_OPTION,
    out: str = typer.Option("firmware-build", "--out", help="Folder for mckibben.elf and mckibben.hex."),
    load_cell: str = LOAD_CELL_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Build the ATmega2560 image (avr-gcc) from the firmware sources shipped in the package."""
    image = FW.build(n_channels, out, load_cell=parse_flag(load_cell, "force", "load_cell", allow_zero=False))
    if json:
        emit_json(image.to_dict())
        return
    print_table("Firmware image", ["file", "path"], [["elf", str(image.elf)], ["hex", str(image.hex)]])


@firmware_app.command("flash")
def flash_cmd(
    port: str = typer.Option(..., "--port", help="The Mega's serial port, e.g. /dev/ttyACM0."),
    n_channels: int = CHANNELS_OPTION,
    dry_run: bool = typer.Option(False, "--dry-run", help="Build, and print the avrdude command without running it."),
    load_cell: str = LOAD_CELL_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Build the image and flash it through the Mega's bootloader with avrdude."""
    res = FW.flash(port, n_channels, dry_run=dry_run,
                   load_cell=parse_flag(load_cell, "force", "load_cell", allow_zero=False))
    if json:
        emit_json(res.to_dict())
        return
    print(res.to_dict()["command"] if dry_run else f"flashed {port} ({res.image.n_channels} channels)")


@firmware_app.command("sketch")
def sketch_cmd(
    out: str = typer.Option(..., "--out", help="An existing folder; the sketch folder mckibben/ is written into it."),
    json: bool = JSON_OPTION,
) -> None:
    """Write the Arduino IDE sketch folder (board: Arduino Mega 2560) with the firmware's sources."""
    folder = FW.sketch(out)
    if json:
        emit_json({"sketch": str(folder)})
        return
    print(folder)
