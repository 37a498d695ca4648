"""``mckibben export fmu``: the plant as an FMU for Simulink, OpenModelica, Dymola, FMPy (docs/fmu.md)."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import DIRECTION_OPTION, JSON_OPTION, emit_json

export_app = typer.Typer(help="Export a calibrated muscle's plant for other simulators.", no_args_is_help=True)
app.add_typer(export_app, name="export")


@export_app.command("fmu")
def fmu_cmd(
    muscle: str = typer.Option(None, "--muscle", help="Published parameter set (mpam97, mpam117, mpam143; default "
                                                      "mpam97 unless --muscle-file)."),
    muscle_file: str = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law "
                                                                "(mckibben fit … --save)."),
    out: str = typer.Option(..., "--out", help="The FMU to write, e.g. m.fmu."),
    fmi: int = typer.Option(3, "--fmi", help="FMI version: 3 (FMI 3.0) or 2 (FMI 2.0)."),
    load: str = typer.Option(None, "--load", help="Hanging load, the FMU's load_force start value (default 0.6N)."),
    supply: str = typer.Option(None, "--supply", help="Supply pressure, the supply_pressure start value (default "
                                                      "0.8MPa; with --muscle-file the top of its fitted pressures)."),
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Write the plant (valve commands in; pressure, length, force out) as a co-simulation FMU."""
    from mckibben.export import export_fmu

    path = export_fmu(muscle, muscle_file, out, fmi, load=load, supply=supply, direction=direction)
    if json:
        emit_json({"fmu": str(path), "fmi_version": f"{fmi}.0", "interface": "co-simulation",
                   "source": muscle_file or muscle or "mpam97"})
        return
    typer.echo(f"wrote {path} (FMI {fmi}.0 co-simulation; inputs inlet, bleed; outputs pressure, length, force)")
