"""``mckibben predict length|pressure|force``: evaluate the static models from the command line."""

from __future__ import annotations

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.datasets import get_muscle
from mckibben.models.flags import flag_names
from mckibben.models.mpam import predict_length, pressure_for_length
from mckibben.units import parse_quantity, parse_values

predict_app = typer.Typer(help="Predict length, pressure or force from a static model.", no_args_is_help=True)
app.add_typer(predict_app, name="predict")

MUSCLE_OPTION = typer.Option("mpam97", "--muscle", help="Parameter set (see `mckibben params list`).")
LOAD_OPTION = typer.Option("0.6N", "--load", help="Hanging load, e.g. 0.6N, 60gf, 2.1N.")
PMAX_OPTION = typer.Option("0.8MPa", "--p-max", help="Highest pressure allowed.")


def _rows_or_scalars(records: dict, scalar: bool) -> dict:
    if scalar:
        return {k: (v[0] if isinstance(v, list) else v) for k, v in records.items()}
    return records


@predict_app.command("length")
def length_cmd(
    muscle: str = MUSCLE_OPTION,
    pressure: str = typer.Option(..., "--pressure", help="Pressure, list or range: 0.8MPa, 0.2,0.4MPa, 0:0.8MPa:9."),
    load: str = LOAD_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Length and contraction at a pressure under a hanging load (eq. 2 + 3)."""
    m = get_muscle(muscle)
    p = parse_values(pressure, "pressure", "--pressure")
    f = parse_quantity(load, "force", "--load")
    r = predict_length(m, p, f)
    flags = [flag_names(x) for x in r.flags]
    if json:
        out = {
            "muscle": m.name,
            "load_N": f,
            "pressure_Pa": r.pressure.tolist(),
            "length_m": r.length.tolist(),
            "contraction": r.contraction.tolist(),
            "cos_theta": r.cos_theta.tolist(),
            "flags": flags,
        }
        scalar = len(p) == 1 and "," not in pressure and ":" not in pressure
        emit_json(_rows_or_scalars(out, scalar))
        return
    rows = [
        [f"{pp / 1e6:.4g}", f"{ll * 1e3:.2f}", f"{cc * 100:.1f}", f"{ct:.4f}", ", ".join(fl) or "ok"]
        for pp, ll, cc, ct, fl in zip(r.pressure, r.length, r.contraction, r.cos_theta, flags)
    ]
    print_table(f"{m.name} under {f:g} N", ["pressure MPa", "length mm", "contraction %", "cos θ", "flags"], rows)


@predict_app.command("pressure")
def pressure_cmd(
    muscle: str = MUSCLE_OPTION,
    length: str = typer.Option(..., "--length", help="Target length, list or range: 85mm, 80,85,90mm."),
    load: str = LOAD_OPTION,
    p_max: str = PMAX_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """The pressure that holds a target length under a load (the inverse of eq. 2 + 3)."""
    m = get_muscle(muscle)
    lengths = parse_values(length, "length", "--length", allow_zero=False)
    f = parse_quantity(load, "force", "--load")
    pmax = parse_quantity(p_max, "pressure", "--p-max", allow_zero=False)
    r = pressure_for_length(m, lengths, f, pmax)
    flags = [flag_names(x) for x in r.flags]
    if json:
        out = {
            "muscle": m.name,
            "load_N": f,
            "p_max_Pa": pmax,
            "length_m": r.length.tolist(),
            "pressure_Pa": r.pressure.tolist(),
            "contraction": r.contraction.tolist(),
            "cos_theta": r.cos_theta.tolist(),
            "flags": flags,
        }
        scalar = len(lengths) == 1 and "," not in length and ":" not in length
        emit_json(_rows_or_scalars(out, scalar))
        return
    rows = [
        [f"{ll * 1e3:.2f}", "unreachable" if not np.isfinite(pp) else f"{pp / 1e6:.4f}", f"{cc * 100:.1f}", ", ".join(fl) or "ok"]
        for ll, pp, cc, fl in zip(r.length, r.pressure, r.contraction, flags)
    ]
    print_table(f"{m.name} under {f:g} N, p ≤ {pmax / 1e6:g} MPa", ["length mm", "pressure MPa", "contraction %", "flags"], rows)
