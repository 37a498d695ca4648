"""``mckibben export fmu``: the plant as an FMU for Simulink, OpenModelica, Dymola, FMPy (docs/fmu.md)."""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import DIRECTION_OPTION, JSON_OPTION, emit_json, muscle_option, parse_flag
from mckibben.errors import InputError
from mckibben import control
from mckibben import export

export_app = typer.Typer(help="Export a calibrated muscle's plant for other simulators.", no_args_is_help=True)
app.add_typer(export_app, name="export")


@export_app.command("fmu")
def fmu_cmd(
    muscle: str = muscle_option(None, "Published parameter set (mpam97, mpam117, mpam143; default mpam97 unless "
                                      "--muscle-file)."),
    muscle_file: str = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law "
                                                                "(mckibben fit … --save)."),
    out: str = typer.Option(..., "--out", help="The FMU to write, e.g. m.fmu."),
    fmi: int = typer.Option(3, "--fmi", help="FMI version: 3 (FMI 3.0) or 2 (FMI 2.0)."),
    load: str = typer.Option(None, "--load", help="Hanging load, the FMU's load_force start value (default 0.6N; with "
                                                  "--muscle-file a quarter of what it pulls at rest)."),
    supply: str = typer.Option(None, "--supply", help="Supply pressure, the supply_pressure start value (default "
                                                      "0.8MPa; with --muscle-file the top of its fitted pressures)."),
    direction: str = DIRECTION_OPTION,
    controller: str = typer.Option(None, "--controller", help="Close the loop inside the FMU with the firmware's "
                                                              "own C core at 1 kHz: smc or pid (input: the "
                                                              "pressure reference)."),
    law: str = typer.Option("model", "--law", help="--controller smc: model (our law) or paper (beta tanh(S/eps))."),
    beta: float = typer.Option(None, "--beta", help="--controller smc: switching gain, PWM counts."),
    design: str = typer.Option(None, "--design", help="--controller: a design file's gains (written by "
                                                      "mckibben control step … --save-design)."),
    json: bool = JSON_OPTION,
) -> None:
    """Write the plant (valve commands in; pressure, length, force out) as a co-simulation FMU."""

    ctrl: object = controller
    if design is not None:
        if controller is None:
            raise InputError("--design: give --controller smc or pid with it")
        if controller not in export.fmu.CONTROLLERS:
            raise InputError(f"--controller: {controller!r}; choose {' or '.join(export.fmu.CONTROLLERS)}")
        ctrl = control.core.load_design(design, "design")
        if ctrl.mode != export.fmu.controller_mode(controller):
            raise InputError(f"--design {design}: its mode is {ctrl.mode}, not --controller {controller}")
    path = export.export_fmu(muscle, muscle_file, out, fmi, ctrl,
                             load=parse_flag(load, "force", "load"),
                             supply=parse_flag(supply, "pressure", "supply", allow_zero=False),
                             direction=direction, law=law, beta=beta)
    closed = controller is not None
    if json:
        emit_json({"fmu": str(path), "fmi_version": f"{fmi}.0", "interface": "co-simulation",
                   "source": muscle_file or muscle or "mpam97", "controller": controller})
        return
    io = ("input reference; outputs pressure, length, force, inlet, bleed, faults" if closed
          else "inputs inlet, bleed; outputs pressure, length, force")
    typer.echo(f"wrote {path} (FMI {fmi}.0 co-simulation; {io})")
