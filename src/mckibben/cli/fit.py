"""``mckibben fit DATA --model NAME`` and ``mckibben compare DATA``: fits with uncertainty."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, console, emit_json, print_table
from mckibben.errors import InputError, unknown_name

FIT_MODELS = {
    "kinematic": "eq. 2, l = k1·Ls·cos θ + k2, on braid_angle data (needs the muscle file)",
    "cubic": "one cubic in pressure per load/direction (isotonic, hysteresis, braid_angle, blocked_force)",
    "surface": "one cubic-in-pressure, linear-in-load surface of the length (isotonic)",
    "force-contraction": "one cubic of load vs contraction per pressure, Fig. 5 (isotonic; muscle file)",
    "spring": "Lu(P) and K(P, Ls) per direction and pressure range (force_length or isotonic)",
    "chou-hannaford": "length under load, fitted strand length and D0 (isotonic; muscle file)",
    "tondu-lopez": "length under load, fitted k and r0 (isotonic; muscle file)",
    "first-order": "p0, p_final, tau of pressure step responses (step_response)",
}
NEEDS_MUSCLE = {"kinematic", "force-contraction", "chou-hannaford", "tondu-lopez"}


def load_muscle(data: Path, muscle: str | None, required: bool, what: str):
    """The muscle file given with --muscle, else ``muscle.toml`` beside the data (or None)."""
    from mckibben.data import find_muscle_file, read_muscle

    path = Path(muscle) if muscle else find_muscle_file(data)
    if path is None:
        if required:
            raise InputError(f"{what}: needs a muscle file; give --muscle FILE.toml or put muscle.toml beside {data}")
        return None
    return read_muscle(path)


def _synthetic(data: Path, spec) -> bool:
    from mckibben.datasets.campaign import is_synthetic

    folder = data if data.is_dir() else data.parent
    return bool(spec is not None and spec.synthetic) or is_synthetic(folder) or is_synthetic(folder.parent)


def run_fit(data: Path, model: str, muscle: str | None = None, kind: str | None = None,
            split_pressure: float | None = None) -> dict:
    """Run one fit command; return the JSON-ready result (also used by the tests)."""
    from mckibben.data import check_muscle, read_table
    from mckibben.fit import static

    if model not in FIT_MODELS:
        raise unknown_name("model", model, FIT_MODELS)
    table = read_table(data, kind)
    spec = load_muscle(data, muscle, model in NEEDS_MUSCLE, f"fit {model}")
    if spec is not None:
        check_muscle(table, spec)
    extra: dict = {}
    if model == "kinematic":
        fits = [static.fit_kinematic(table, spec)]
    elif model == "cubic":
        fits = list(static.fit_cubics(table).values())
    elif model == "surface":
        fits = [static.fit_surface(table)]
    elif model == "force-contraction":
        fits = list(static.fit_force_contraction(table, spec).values())
    elif model == "spring":
        sf = static.fit_spring(table, split_pressure=split_pressure,
                               nominal_length=spec.nominal_length if spec else None)
        fits = [sf.result]
        extra = {"split_pressure_Pa": sf.model.split_pressure, "blocks": [list(b) for b in sf.blocks],
                 "terms_P_Ls_exponents": [list(t) for t in sf.model.terms]}
    elif model == "chou-hannaford":
        fits = [static.fit_chou_hannaford(table, spec)]
    elif model == "tondu-lopez":
        fits = [static.fit_tondu_lopez(table, spec)]
    else:
        fits = list(static.fit_first_order(table).values())
    out = {"file": str(data), "kind": table.kind, "model": model, "muscle": spec.id if spec else None,
           "synthetic": _synthetic(data, spec), **extra, "fits": [f.to_dict() for f in fits]}
    if len(fits) == 1:
        out.update({k: v for k, v in fits[0].to_dict().items() if k not in ("model",)})
    return out


@app.command("fit")
def fit_cmd(
    data: Path = typer.Argument(..., help="Experiment table (.csv or .parquet)."),
    model: str = typer.Option(..., "--model", help=f"One of: {', '.join(FIT_MODELS)}."),
    muscle: str = typer.Option(None, "--muscle", help="Muscle file (TOML); default muscle.toml beside DATA."),
    kind: str = typer.Option(None, "--kind", help="Experiment kind, if neither the file name nor its columns tell."),
    split_pressure: str = typer.Option(None, "--split-pressure", help="spring: low/high range split (default: median pressure)."),
    json: bool = JSON_OPTION,
) -> None:
    """Fit a static model to one experiment table: parameters, standard errors, 95 % intervals."""
    from mckibben.units import parse_quantity

    split = parse_quantity(split_pressure, "pressure", "--split-pressure") if split_pressure else None
    out = run_fit(data, model, muscle, kind, split)
    if json:
        emit_json(out)
        return
    if out["synthetic"]:
        console.print("[bold yellow]SYNTHETIC data[/] (generated, not measured)")
    for f in out["fits"]:
        cond = ", ".join(f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}" for k, v in f["condition"].items())
        rows = [[n, f"{v:.6g}", f"{f['stderr'][n]:.3g}", f"[{f['ci95'][n][0]:.6g}, {f['ci95'][n][1]:.6g}]"]
                for n, v in f["parameters"].items()]
        print_table(f"{model} fit of {out['file']}" + (f" ({cond})" if cond else ""),
                    [" parameter", "value", "std. error", "95 % interval"], rows)
        rms_key = next(k for k in f if k.startswith("residual_rms"))
        rng = ", ".join(f"{k} {lo:.4g}..{hi:.4g}" for k, (lo, hi) in f["valid_range"].items())
        console.print(f"  {rms_key} {f[rms_key]:.4g}, R² {f['r2']:.5f}, n {f['n_points']}, valid on {rng}")


@app.command("compare")
def compare_cmd(
    data: Path = typer.Argument(..., help="An isotonic table, or a muscle folder holding isotonic.csv (and braid_angle.csv)."),
    muscle: str = typer.Option(None, "--muscle", help="Muscle file (TOML); default muscle.toml beside DATA."),
    json: bool = JSON_OPTION,
) -> None:
    """Fit every applicable model to the same isotonic data; RMSE, max relative error, CV error, 20 % rule."""
    out = run_compare(data, muscle)
    if json:
        emit_json(out)
        return
    if out["synthetic"]:
        console.print("[bold yellow]SYNTHETIC data[/] (generated, not measured)")
    rows = [[s["model"], str(s["n_parameters"]), _mm(s["rmse_m"]), _pct(s["max_rel_error"]), _pct(s["within_20pct"]),
             _mm(s["cv_rmse_m"]), _pct(s["cv_within_20pct"]), s["note"][:60]] for s in out["models"]]
    print_table(f"Length under load vs pressure, {out['n_points']} points of {out['file']} (P > 0); CV: {out['cv_method']}",
                [" model", "params", "RMSE mm", "max rel. err. ε %", "within 20 % ε", "CV RMSE mm", "CV within 20 %", " note"],
                rows)


def _mm(v):
    return "—" if v is None or not np.isfinite(v) else f"{v * 1e3:.3f}"


def _pct(v):
    return "—" if v is None or not np.isfinite(v) else f"{v * 100:.1f}"


def run_compare(data: Path, muscle: str | None = None) -> dict:
    """Run the comparison; return the JSON-ready result."""
    from mckibben.data import check_muscle, read_table
    from mckibben.fit.compare import compare_models

    data = Path(data)
    folder = data if data.is_dir() else data.parent
    iso_path = folder / "isotonic.csv" if data.is_dir() else data
    if data.is_dir() and not iso_path.is_file():
        raise InputError(f"compare: {data} holds no isotonic.csv")
    table = read_table(iso_path)
    spec = load_muscle(iso_path, muscle, True, "compare")
    check_muscle(table, spec)
    braid = None
    braid_path = folder / "braid_angle.csv"
    if braid_path.is_file():
        b = read_table(braid_path)
        if {"pressure", "load"} <= set(b.data.columns):
            check_muscle(b, spec)
            braid = b
    res = compare_models(table, spec, braid)
    return {"file": str(iso_path), "muscle": spec.id, "synthetic": _synthetic(iso_path, spec),
            "quantity": "length under load at a pressure (rows with P > 0); relative errors on contraction",
            "n_points": res["n_points"], "cv_method": res["cv_method"],
            "models": [s.to_dict() for s in res["scores"]]}
