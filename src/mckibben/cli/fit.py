"""``mckibben fit DATA --model NAME`` and ``mckibben compare DATA``: fits with uncertainty."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, console, emit_json, err_console, print_table
from mckibben.errors import InputError, unknown_name

FIT_MODELS = {
    "kinematic": "eq. 2, l = k1·Ls·cos θ + k2, on braid_angle data (needs the muscle file)",
    "cubic": "one cubic in pressure per load/direction (isotonic, hysteresis, braid_angle, blocked_force)",
    "surface": "one cubic-in-pressure, linear-in-load surface of the length (isotonic)",
    "force-contraction": "one cubic of load vs contraction per pressure, Fig. 5 (isotonic; muscle file)",
    "spring": "Lu(P) and K(P, Ls) per direction and pressure range (force_length, isotonic or isometric)",
    "chou-hannaford": "fitted braid geometry: length under load (isotonic) or force(P, L) (isometric); muscle file",
    "wall-chou-hannaford": "Chou-Hannaford with the tube wall: force(P, L) (isometric; muscle file)",
    "tondu-lopez": "fitted k and r0 (and alpha0 if unknown): isotonic or isometric; muscle file",
    "first-order": "p0, p_final, tau of pressure step responses (step_response)",
}
NEEDS_MUSCLE = {"kinematic", "force-contraction", "chou-hannaford", "wall-chou-hannaford", "tondu-lopez"}


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
            split_pressure: float | None = None, tare: str = "none", save: str | None = None) -> dict:
    """Run one fit command; return the JSON-ready result (also used by the tests)."""
    from mckibben.data import check_muscle, read_table
    from mckibben.fit import static

    if model not in FIT_MODELS:
        raise unknown_name("model", model, FIT_MODELS)
    table = read_table(data, kind)
    isometric = table.kind == "isometric"
    spec = load_muscle(data, muscle, model in NEEDS_MUSCLE or isometric, f"fit {model}")
    if spec is not None:
        check_muscle(table, spec)
    if tare != "none" and not isometric:
        raise InputError(f"--tare: applies to isometric tables; {data} is a {table.kind} table")
    if save is not None and not isometric:
        raise InputError(f"--save: writes a force law fitted to an isometric table; {data} is a {table.kind} table")
    extra: dict = {}
    if isometric:
        from mckibben.fit.isometric import FORCE_MODELS, fit_isometric

        if model not in FORCE_MODELS:
            raise InputError(f"fit {model}: not a force model for an isometric table; use one of {', '.join(FORCE_MODELS)}")
        fit = fit_isometric(table, spec, model, tare)
        out = {"file": str(data), "kind": table.kind, "model": model, "muscle": spec.id,
               "synthetic": _synthetic(data, spec), "tare": fit.tare, "fits": [fit.to_dict()]}
        out.update({k: v for k, v in fit.to_dict().items() if k not in ("model",)})
        if save is not None:
            from mckibben.fit.muscle_file import save_muscle_file

            out["saved"] = str(save_muscle_file(save, spec, fit))
        return out
    if model == "kinematic":
        fits = [static.fit_kinematic(table, spec)]
    elif model == "cubic":
        fits = list(static.fit_cubics(table).values())
    elif model == "surface":
        fits = [static.fit_surface(table)]
    elif model == "force-contraction":
        fits = list(static.fit_force_contraction(table, spec).values())
    elif model == "spring":
        if split_pressure is not None:
            p = table.data["pressure"].to_numpy()
            if not float(p.min()) <= split_pressure < float(p.max()):
                raise InputError(f"--split-pressure: {split_pressure / 1e6:g} MPa is outside the pressures of {data} "
                                 f"({p.min() / 1e6:g}..{p.max() / 1e6:g} MPa): one range would get no point")
        sf = static.fit_spring(table, split_pressure=split_pressure,
                               nominal_length=spec.nominal_length if spec else None)
        fits = [sf.result]
        extra = {"split_pressure_Pa": sf.model.split_pressure, "blocks": [list(b) for b in sf.blocks],
                 "terms_P_Ls_exponents": [list(t) for t in sf.model.terms]}
    elif model == "chou-hannaford":
        fits = [static.fit_chou_hannaford(table, spec)]
    elif model == "tondu-lopez":
        fits = [static.fit_tondu_lopez(table, spec)]
    elif model == "wall-chou-hannaford":
        raise InputError(f"fit wall-chou-hannaford: needs an isometric table; {data} is a {table.kind} table")
    else:
        fits = list(static.fit_first_order(table).values())
    out = {"file": str(data), "kind": table.kind, "model": model, "muscle": spec.id if spec else None,
           "synthetic": _synthetic(data, spec), **extra, "fits": [f.to_dict() for f in fits]}
    if len(fits) == 1:
        out.update({k: v for k, v in fits[0].to_dict().items() if k not in ("model",)})
    else:
        out["flags"] = sorted({fl for f in fits for fl in f.flags})
    return out


def warn_flags(what: str, flags) -> None:
    """One warning line on stderr when a fit carries flags (the JSON keeps them too)."""
    if flags:
        err_console.print(f"warning: {what}: flagged: {', '.join(flags)}", markup=False, highlight=False)


@app.command("fit")
def fit_cmd(
    data: Path = typer.Argument(..., help="Experiment table (.csv or .parquet)."),
    model: str = typer.Option(..., "--model", help=f"One of: {', '.join(FIT_MODELS)}."),
    muscle: str = typer.Option(None, "--muscle", help="Muscle file (TOML); default muscle.toml beside DATA."),
    kind: str = typer.Option(None, "--kind", help="Experiment kind, if neither the file name nor its columns tell."),
    split_pressure: str = typer.Option(None, "--split-pressure", help="spring: low/high range split (default: median pressure)."),
    tare: str = typer.Option("none", "--tare", help="isometric: none (default), lowest (each run's force at its "
                                                    "lowest pressure) or column (a tare_N column)."),
    save: str = typer.Option(None, "--save", help="isometric: write a muscle file (TOML) with this fitted force law."),
    json: bool = JSON_OPTION,
) -> None:
    """Fit a static model to one experiment table: parameters, standard errors, 95 % intervals, flags."""
    from mckibben.units import parse_quantity

    split = parse_quantity(split_pressure, "pressure", "--split-pressure") if split_pressure else None
    out = run_fit(data, model, muscle, kind, split, tare, save)
    warn_flags(f"fit {model} on {data}", out.get("flags", []))
    if json:
        emit_json(out)
        return
    if out.get("tare", {}).get("method", "none") != "none":
        t = out["tare"]
        vals = [r["tare_N"] for r in t.get("per_run_N", [])] or t.get("tare_N_range", [])
        console.print(f"tare ({t['method']}): {len(t.get('per_run_N', []))} runs, "
                      f"{min(vals):.3g} to {max(vals):.3g} N subtracted" if vals else f"tare ({t['method']})")
    if out.get("saved"):
        console.print(f"wrote muscle file {out['saved']} with the fitted {model} force law")
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
        console.print(f"  covariance: {f.get('covariance', 'ols')}; flags: {', '.join(f.get('flags', [])) or 'none'}")


@app.command("compare")
def compare_cmd(
    data: Path = typer.Argument(..., help="An isometric or isotonic table, or a muscle folder holding isotonic.csv "
                                          "(and braid_angle.csv)."),
    muscle: str = typer.Option(None, "--muscle", help="Muscle file (TOML); default muscle.toml beside DATA."),
    cv: str = typer.Option(None, "--cv", help="isometric: leave-one-length-out (default) or leave-one-trial-out."),
    tare: str = typer.Option("none", "--tare", help="isometric: none (default), lowest or column (see docs/data.md)."),
    json: bool = JSON_OPTION,
) -> None:
    """Fit every applicable model to the same data and score it on held-out data (the best is picked there)."""
    iso = _isometric_table(data)
    if iso is not None:
        out = run_compare_isometric(iso, data, muscle, cv or "leave-one-length-out", tare)
        flagged = [f"{s['model']} ({', '.join(s['flags'])})" for s in out["models"] if s["flags"]]
        warn_flags(f"compare on {data}", flagged)
        if json:
            emit_json(out)
            return
        if out["synthetic"]:
            console.print("[bold yellow]SYNTHETIC data[/] (generated, not measured)")
        rows = [[s["model"], str(s["n_parameters"]), _g(s["rmse_N"]), _g(s["r2"], ".4f"), _g(s["cv_rmse_N"]),
                 _g(s["cv_rmse_pct_of_peak"], ".2f"), ", ".join(s["flags"]) or "none"]
                for s in sorted(out["models"], key=lambda s: (s["cv_rmse_N"] is None, s["cv_rmse_N"] or 0))]
        print_table(f"Force(P, L) models on {out['file']}, held out: {out['cv']} (peak {out['peak_force_N']:.4g} N)",
                    [" model", "params", "RMSE N", "R²", "CV RMSE N", "CV % of peak", " flags"], rows)
        console.print(f"best on held-out error: {out['best']}")
        return
    if cv is not None or tare != "none":
        raise InputError("--cv/--tare: apply to isometric tables; the isotonic comparison chooses its own folds")
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


def _g(v, fmt=".4g"):
    return "—" if v is None or not np.isfinite(v) else format(v, fmt)


def _isometric_table(data: Path):
    """The table if DATA is an isometric table file, else None (a folder or another kind)."""
    from mckibben.data import read_table

    data = Path(data)
    if data.is_dir():
        return None
    table = read_table(data)
    return table if table.kind == "isometric" else None


def run_compare_isometric(table, data: Path, muscle: str | None, cv: str, tare: str) -> dict:
    """Compare every force model on an isometric table; return the JSON-ready result."""
    from mckibben.data import check_muscle
    from mckibben.fit.isometric import compare_isometric

    spec = load_muscle(data, muscle, True, "compare")
    check_muscle(table, spec)
    res = compare_isometric(table, spec, cv, tare)
    return {"file": str(data), "kind": "isometric", "muscle": spec.id, "synthetic": _synthetic(data, spec),
            "quantity": "force at held lengths and pressures (all rows)", **res.to_dict()}


def _mm(v):
    return "—" if v is None or not np.isfinite(v) else f"{v * 1e3:.3f}"


def _pct(v):
    return "—" if v is None or not np.isfinite(v) else f"{v * 100:.1f}"


#: Distinct pressures (above 0) an isotonic table needs for `compare`: a cubic in pressure and a
#: check of its fit (as :func:`mckibben.fit.static.fit_cubics` requires), plus one left out by CV.
COMPARE_MIN_PRESSURES = 6


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
    pressures = table.data["pressure"].to_numpy()
    distinct = np.unique(np.round(pressures[pressures > 0], 3)).size
    if distinct < COMPARE_MIN_PRESSURES:
        raise InputError(f"compare: {iso_path} has {distinct} distinct pressures above 0; comparing the models "
                         f"(cubics in pressure, cross-validated) needs at least {COMPARE_MIN_PRESSURES}")
    res = compare_models(table, spec, braid)
    return {"file": str(iso_path), "muscle": spec.id, "synthetic": _synthetic(iso_path, spec),
            "quantity": "length under load at a pressure (rows with P > 0); relative errors on contraction",
            "n_points": res["n_points"], "cv_method": res["cv_method"],
            "models": [s.to_dict() for s in res["scores"]]}
