"""``mckibben reproduce``: the main job, run on the bundled data."""

from __future__ import annotations

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, print_table
from mckibben.datasets import MUSCLES
from mckibben.models.flags import flag_names
from mckibben.models.mpam import predict_length


@app.command("reproduce")
def reproduce_cmd(json: bool = JSON_OPTION) -> None:
    """Reproduce the published models: Tables I and II and the predicted lengths."""
    pressures = np.linspace(0.0, 0.8e6, 9)
    tables = {}
    for name, m in MUSCLES.items():
        for load in m.braid_map.loads:
            r = predict_length(m, pressures, load)
            tables[f"{name}@{load:g}N"] = {
                "muscle": name,
                "load_N": load,
                "pressure_Pa": pressures.tolist(),
                "length_m": r.length.tolist(),
                "contraction": r.contraction.tolist(),
                "cos_theta": r.cos_theta.tolist(),
                "flags": [flag_names(x) for x in r.flags],
            }
    if json:
        emit_json({"length_tables": tables})
        return
    print_table(
        "Table I (000_909f662a44080c85.txt): l = k1·Ls·cos θ + k2",
        ["muscle", "L0 mm", "Ls mm", "k1", "k2 mm", "blocked force N @ 0.8 MPa"],
        [[n, f"{m.nominal_length * 1e3:g}", f"{m.strand_length * 1e3:g}", f"{m.k1:g}", f"{m.k2 * 1e3:g}", f"{m.blocked_force[0][1]:g}"] for n, m in MUSCLES.items()],
    )
    print_table(
        "Table II and eq. 3: cos θ = c3·P³ + c2·P² + c1·P + c0 (P in MPa)",
        ["muscle", "load N", "c3", "c2", "c1", "c0"],
        [[n, f"{load:g}", *[f"{v:+g}" for v in c]] for n, m in MUSCLES.items() for load, c in zip(m.braid_map.loads, m.braid_map.coefficients)],
    )
    for key, t in tables.items():
        print_table(
            f"Predicted length, {t['muscle']} under {t['load_N']:g} N",
            ["pressure MPa", "length mm", "contraction %", "cos θ", "flags"],
            [[f"{p / 1e6:.1f}", f"{l_ * 1e3:.2f}", f"{c * 100:.1f}", f"{ct:.4f}", ", ".join(f) or "ok"]
             for p, l_, c, ct, f in zip(t["pressure_Pa"], t["length_m"], t["contraction"], t["cos_theta"], t["flags"])],
        )
