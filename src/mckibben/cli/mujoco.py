"""``mckibben mujoco``: calibrated muscles on MuJoCo tendons (docs/mujoco.md; the ``mujoco`` extra)."""

from __future__ import annotations

import typer

from mckibben import experiments
from mckibben.cli import app
from mckibben.results import check_table_path
from mckibben.cli._common import JSON_OPTION, emit_json, err_console, muscle_option, parse_flag
from mckibben.errors import InputError
from mckibben.units import parse_values

mujoco_app = typer.Typer(help="Calibrated muscles on the tendons of MuJoCo models (the mujoco extra).",
                         no_args_is_help=True)
app.add_typer(mujoco_app, name="mujoco")

MUSCLE = typer.Option("mpam97", "--muscle", metavar="NAME", help="Published parameter set (mpam97, mpam117, "
                                                                 "mpam143); a muscle file here is deprecated: use "
                                                                 "--muscle-file.")
MUSCLE_FILE = typer.Option(None, "--muscle-file", metavar="FILE", help="A muscle file with a fitted force law "
                                                                       "(mckibben fit … --save); replaces --muscle.")
FORCE_MODEL = typer.Option(None, "--force-model", help="A published set's law: calibrated (default) or empirical "
                                                       "(eq. 2+3, the statics of predict length).")


@mujoco_app.command("hang")
def hang_cmd(
    muscle: str = muscle_option("mpam97", "Published parameter set (mpam97, mpam117, mpam143)."),
    pressure: str = typer.Option("0.4MPa", "--pressure", help="Pressure the sliding-mode controller holds."),
    load: str = typer.Option("0.6N", "--load", help="Hanging load."),
    force_model: str = FORCE_MODEL,
    duration: str = typer.Option("1.5s", "--duration", help="Simulated time."),
    no_friction: bool = typer.Option(False, "--no-friction", help="Turn the braid's friction off (the frictionless "
                                                                  "statics of predict length)."),
    json: bool = JSON_OPTION,
) -> None:
    """A mass hanging from one muscle in MuJoCo: its static length against predict length."""

    res = experiments.mujoco.hanging_mass(muscle, parse_flag(pressure, "pressure", "pressure", allow_zero=False),
                                     parse_flag(load, "force", "load", allow_zero=False), force_model=force_model,
                                     duration=parse_flag(duration, "time", "duration", allow_zero=False),
                                     friction=not no_friction)
    if json:
        emit_json(res.to_dict())
        return
    m = res.metrics
    typer.echo(f"{res.muscle} under {res.load:g} N at {m['held_pressure_Pa'] / 1e6:.4f} MPa: "
               f"{m['static_length_m'] * 1e3:.3f} mm in MuJoCo, {m['predicted_length_m'] * 1e3:.3f} mm predicted "
               f"({m['length_error_vs_predict_pct']:+.2f} %), {m['plant_static_length_m'] * 1e3:.3f} mm the plant's "
               f"static length ({m['length_error_vs_plant_pct']:+.2f} %)")


def _counts(text: str, name: str) -> list[float]:
    """PWM counts from the command line: one, or one per muscle, comma-separated."""
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"{name}: {text!r} is not a PWM count 0..255 (or one per muscle, comma-separated)") from None


@mujoco_app.command("run")
def run_cmd(
    model: str = typer.Argument(..., help="An MJCF file whose muscle tendons carry <general tendon=\"T\" gear=\"-1\"/>."),
    tendon: str = typer.Option(..., "--tendon", help="The muscles' tendons, comma-separated."),
    muscle: str = MUSCLE,
    muscle_file: str = MUSCLE_FILE,
    reference: str = typer.Option(None, "--reference", help="Pressure the controllers hold, one or one per muscle "
                                                            "(0.5MPa or 0.3,0.5MPa)."),
    inlet: str = typer.Option(None, "--inlet", help="Instead of --reference: inlet PWM counts held (0..255), one or "
                                                    "one per muscle."),
    bleed: str = typer.Option("0", "--bleed", help="With --inlet: bleed PWM counts held."),
    controller: str = typer.Option("smc", "--controller", help="With --reference: smc or pid."),
    duration: str = typer.Option("1s", "--duration", help="Simulated time."),
    initial_pressure: str = typer.Option("0MPa", "--initial-pressure", help="Chamber pressure at the start."),
    offset: str = typer.Option("0mm", "--offset", help="Tendon length that is not muscle, one or one per muscle."),
    force_model: str = FORCE_MODEL,
    out: str = typer.Option(None, "--out", help="Write the time series: .csv or .parquet."),
    json: bool = JSON_OPTION,
) -> None:
    """Run an MJCF model with calibrated muscles on its tendons; print each muscle's final state."""

    if out:
        check_table_path(out)
    if muscle_file is not None:
        muscle = muscle_file
    elif muscle.strip().lower().endswith(".toml"):
        err_console.print(f"warning: mujoco run --muscle FILE is deprecated: use --muscle-file {muscle} (--muscle "
                          "names a published parameter set in every command)", markup=False, highlight=False)
    res = experiments.mujoco.run_model(
        model, tendon, muscle, reference=None if reference is None else parse_values(reference, "pressure", "reference"),
        inlet=None if inlet is None else _counts(inlet, "inlet"), bleed=_counts(bleed, "bleed"), controller=controller,
        duration=parse_flag(duration, "time", "duration", allow_zero=False),
        initial_pressure=parse_values(initial_pressure, "pressure", "initial_pressure"),
        offset=parse_values(offset, "length", "offset"), force_model=force_model)
    if out:
        res.to_file(out)
    if json:
        emit_json(res.to_dict())
        return
    m = res.metrics
    for i, name in enumerate(m["tendons"]):
        typer.echo(f"{name}: {m['final_pressure_Pa'][i] / 1e6:.4f} MPa, {m['final_length_m'][i] * 1e3:.3f} mm, "
                   f"{m['final_tension_N'][i]:.4g} N{' (end stop reached)' if m['end_stop'][i] else ''}")
