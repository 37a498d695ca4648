"""``mckibben params list|show``: the published parameter sets."""

from __future__ import annotations

import dataclasses

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.datasets import LAW_SETS, MUSCLES, SPRING_MODEL_STRUCTURE, SPRING_MUSCLE_SIZES, get_muscle, parameter_sets
from mckibben.datasets.references import cited, render
from mckibben.errors import unknown_name
from mckibben.models.mpam import MiniatureMuscle

params_app = typer.Typer(help="Published parameter sets, with their citations.", no_args_is_help=True)
app.add_typer(params_app, name="params")

SPRING_SETS = {f"spring-{k}": v for k, v in SPRING_MUSCLE_SIZES.items()}


def muscle_to_dict(m: MiniatureMuscle) -> dict:
    """A miniature muscle's parameters as a JSON-ready dict with SI, unit-suffixed keys."""
    g = m.geometry
    return {
        "name": m.name,
        "kind": "miniature",
        "nominal_length_m": m.nominal_length,
        "strand_length_m": m.strand_length,
        "k1": m.k1,
        "k2_m": m.k2,
        "cos_theta_cubics": [
            {"load_N": load, "coefficients_P3_P2_P1_P0_P_in_MPa": list(c)}
            for load, c in zip(m.braid_map.loads, m.braid_map.coefficients)
        ],
        "pressure_range_Pa": list(m.braid_map.pressure_range),
        "blocked_force": [{"pressure_Pa": p, "force_N": f} for p, f in m.blocked_force],
        "geometry": {
            "outer_diameter_m": g.outer_diameter,
            "tube_inner_diameter_m": g.tube_inner_diameter,
            "tube_outer_diameter_m": g.tube_outer_diameter,
            "strand_diameter_m": g.strand_diameter,
            "braid_angle_rad": g.braid_angle,
        },
        "synthetic": m.synthetic,
        "citation": cited(m.citation)[0].to_dict(),
        "source": render(m.citation),
    }


@params_app.command("list")
def list_cmd(json: bool = JSON_OPTION) -> None:
    """List the parameter sets by name."""
    rows = parameter_sets()
    if json:
        emit_json({"parameter_sets": rows})
        return
    print_table("Parameter sets", ["name", "kind", "source"], [[r["name"], r["kind"], f"{r['citation']['short']} [{r['citation']['key']}]"] for r in rows])
    print("Each work in full (title, authors, venue, year, DOI) under its key in brackets: the References page of the"
          " documentation (docs/references.md); `mckibben params show NAME` gives the tables and equations cited.")


@params_app.command("show")
def show_cmd(name: str = typer.Argument(..., help="A name from `mckibben params list`."), json: bool = JSON_OPTION) -> None:
    """Show one parameter set with its citation."""
    key = name.strip().lower()
    if key in SPRING_SETS:
        text = SPRING_MODEL_STRUCTURE["citation"]
        data = {"name": key, "kind": "spring", **SPRING_SETS[key], "structure": SPRING_MODEL_STRUCTURE,
                "citation": cited(text)[0].to_dict(), "source": render(text)}
        if json:
            emit_json(data)
            return
        print_table(f"{key} (spring model)", ["field", "value"],
                    [[k, str(v)] for k, v in data.items() if k not in ("structure", "citation")])
        print_table("structure", ["field", "value"],
                    [[k, render(v) if k == "citation" else str(v)] for k, v in SPRING_MODEL_STRUCTURE.items()])
        return
    if key in LAW_SETS:
        law, m = LAW_SETS[key]
        fields = {k: v for k, v in m.to_dict().items() if k != "citation"}  # SI, unit-suffixed keys
        if json:
            emit_json({"name": key, "kind": law, **fields, "citation": cited(m.citation)[0].to_dict(),
                       "source": render(m.citation)})
            return
        print_table(f"{key} ({law} law)", ["parameter", "value"],
                    [[k, str(v)] for k, v in fields.items()] + [["citation", render(m.citation)]])
        return
    if key not in MUSCLES:
        raise unknown_name("parameter set", name, list(MUSCLES) + list(SPRING_SETS) + list(LAW_SETS))
    m = get_muscle(key)
    if json:
        emit_json(muscle_to_dict(m))
        return
    rows = [
        ["nominal length L0", f"{m.nominal_length * 1e3:g} mm"],
        ["strand length Ls", f"{m.strand_length * 1e3:g} mm"],
        ["k1", f"{m.k1:g}"],
        ["k2", f"{m.k2 * 1e3:g} mm"],
    ]
    for load, c in zip(m.braid_map.loads, m.braid_map.coefficients):
        rows.append([f"cos θ at {load:g} N (P in MPa)", " ".join(f"{v:+g}" for v in c)])
    rows += [[f"blocked force at {p / 1e6:g} MPa", f"{f:g} N"] for p, f in m.blocked_force]
    g = m.geometry
    rows += [
        ["outer diameter", f"{g.outer_diameter * 1e3:g} mm"],
        ["tube ID / OD", f"{g.tube_inner_diameter * 1e3:g} / {g.tube_outer_diameter * 1e3:g} mm"],
        ["strand diameter", f"{g.strand_diameter * 1e3:g} mm"],
        ["braid angle", f"{np.rad2deg(g.braid_angle):g}°"],
        ["citation", render(m.citation)],
    ]
    print_table(m.name, ["parameter", "value"], rows)


__all__ = ["muscle_to_dict", "dataclasses"]
