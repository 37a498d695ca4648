"""``mckibben fit DATA --model NAME`` and ``mckibben compare DATA``: fits with uncertainty."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import (COLUMNS_OPTION, JSON_OPTION, MUSCLE_FILE_ARG_OPTION, OLD_MUSCLE_FILE_OPTION,
                                  SELECT_OPTION, choices, console, emit_json, err_console, muscle_file_of,
                                  parse_pairs, print_notes, print_table)
from mckibben.data.preprocessing import PRESSURE_ZEROS, RAIL_POLICIES, TARES
from mckibben.data.schema import KINDS
from mckibben.fit.isometric import CV_METHODS, REST_LENGTHS
from mckibben.cli._output import DPI_OPTION, check_outputs, plot_option, write_plot
from mckibben.fit.names import FIT_MODELS
from mckibben.models.hysteresis.direction import DEFAULT_STRUCTURE, STRUCTURES
from mckibben.errors import InputError
from mckibben.units import parse_quantity
from mckibben import fit


MIN_SAMPLES_HELP = ("isometric, a table binned from a stepped protocol: leave out points of fewer readings than N "
                    "(its n_samples column: a step passing through, not a hold; see docs/data.md). Default 0: every point.")

RUN_DRIFT_HELP = ("with --direction-aware: fit a run-drift nuisance too, force x (1 + c.s), s the place along each "
                  "run (the rubber relaxing, the load cell creeping); the muscle's predictions leave it out "
                  "(see docs/hysteresis.md). compare --nested: each form with and without it is a candidate.")
STRUCTURE_HELP = ("with --direction-aware: the operator, play (the law fed through a play on the pressure; default, "
                  "chosen on held-out evidence) or friction (law plus a friction proportional to pressure: the form "
                  "the plant also runs). compare --nested: a comma list, each a candidate. See docs/hysteresis.md.")
STRUCTURE_OPTION = typer.Option(DEFAULT_STRUCTURE, "--structure", metavar=choices(STRUCTURES), help=STRUCTURE_HELP)


def _structure(direction_aware: bool, structure: str) -> str | None:
    """The direction-aware structure a command asked for (None without --direction-aware)."""
    if not direction_aware:
        if structure != DEFAULT_STRUCTURE:
            raise InputError(f"--structure: {structure!r} needs --direction-aware (the operator of a direction-aware law)")
        return None
    if structure not in STRUCTURES:
        raise InputError(f"--structure: {structure!r} is not one of {', '.join(STRUCTURES)}")
    return structure


def warn_flags(what: str, flags) -> None:
    """One warning line on stderr when a fit carries flags (the JSON keeps them too)."""
    if flags:
        err_console.print(f"warning: {what}: flagged: {', '.join(flags)}", markup=False, highlight=False)


@app.command("fit")
def fit_cmd(
    data: Path = typer.Argument(..., help="Experiment table (.csv or .parquet)."),
    model: str = typer.Option(..., "--model", metavar="MODEL", help=f"One of: {', '.join(FIT_MODELS)}."),
    muscle: str = MUSCLE_FILE_ARG_OPTION,
    old_muscle: str = OLD_MUSCLE_FILE_OPTION,
    kind: str = typer.Option(None, "--kind", metavar=choices(KINDS), help="Experiment kind, if neither the file name nor its columns tell."),
    split_pressure: str = typer.Option(None, "--split-pressure", help="spring: low/high range split (default: median pressure)."),
    tare: str = typer.Option("none", "--tare", metavar=choices(TARES), help="isometric: none (default), lowest (each run's force at its "
                                                    "lowest pressure), column (a tare_N column) or fitted (each "
                                                    "run's zero fitted with the law, with its interval)."),
    save: str = typer.Option(None, "--save", help="isometric: write a muscle file (TOML) with this fitted force law "
                                                 "(with --direction-aware, the law and its play: predict ... --branch)."),
    rails: str = typer.Option("keep", "--rails", metavar=choices(RAIL_POLICIES), help="isometric: rows at a sensor's rail (a load-cell floor): keep "
                                                      "(default, counted), exclude, or censor (a reading at a floor "
                                                      "says only force <= floor)."),
    pressure_zero: str = typer.Option("none", "--pressure-zero", metavar=choices(PRESSURE_ZEROS), help="isometric: the pressure transducer's zero: none "
                                                                      "(default), lowest or column (pressure_zero_kPa)."),
    rest_length: str = typer.Option(None, "--rest-length", help="with --save and a family law: the rest length of the "
                                                                "muscle the file describes (default: the muscle file's)."),
    rest_lengths: str = typer.Option("nominal", "--rest-lengths", metavar=choices(REST_LENGTHS),
                                     help="isometric family: each muscle's rest length as recorded (nominal, default) "
                                          "or fitted with its interval (see docs/fit.md)."),
    select: list[str] = SELECT_OPTION,
    columns: list[str] = COLUMNS_OPTION,
    direction_aware: bool = typer.Option(False, "--direction-aware", help="isometric: fit the law's direction-aware "
                                         "form (hysteresis inside the law: --structure), law and operator jointly."),
    structure: str = STRUCTURE_OPTION,
    min_samples: int = typer.Option(0, "--min-samples", metavar="N", help=MIN_SAMPLES_HELP),
    drift: bool = typer.Option(False, "--run-drift", help=RUN_DRIFT_HELP),
    plot: str = plot_option("the fit: force curves over the data (isometric; measured and modelled loops with "
                            "--direction-aware), else the residuals"),
    dpi: int = DPI_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Fit a static model to one experiment table: parameters, standard errors, 95 % intervals, flags."""
    check_outputs(plot, dpi)
    muscle = muscle_file_of(muscle, old_muscle, "fit")
    split = parse_quantity(split_pressure, "pressure", "--split-pressure") if split_pressure else None

    rest = parse_quantity(rest_length, "length", "--rest-length", allow_zero=False) if rest_length else None
    picked = parse_pairs(select, "--select", "cut_length_cm=10")
    names = parse_pairs(columns, "--columns", "phase=direction")
    op = _structure(direction_aware, structure)
    res = fit.fit_table(data, model, muscle, kind, split, tare, save, rest, rails, pressure_zero, picked, names,
                        op, rest_lengths, min_samples, drift)
    out = res.summary
    print_notes(out.get("notes"))
    if plot:
        write_plot(res.plot(), plot, dpi, res)
    _sensor_warnings(f"fit {model} on {data}", out.get("tare", {}))
    warn_flags(f"fit {model} on {data}", out.get("flags", []))
    if json:
        emit_json(out)
        return
    if out.get("tare", {}).get("method", "none") != "none":
        t = out["tare"]
        if t["method"] == "fitted":  # each run's zero fitted with the law, nothing subtracted
            z = [r["zero_N"] for r in t.get("per_run_N", [])]
            console.print(f"tare (fitted): {len(z)} runs, zeros {min(z):.3g} to {max(z):.3g} N fitted (intervals in "
                          "--json)" if z else "tare (fitted)")
        else:
            vals = [r["tare_N"] for r in t.get("per_run_N", [])] or t.get("tare_N_range", [])
            console.print(f"tare ({t['method']}): {len(t.get('per_run_N', []))} runs, "
                          f"{min(vals):.3g} to {max(vals):.3g} N subtracted" if vals else f"tare ({t['method']})")
    if out.get("saved"):
        console.print(f"wrote muscle file {out['saved']} with the fitted {model} force law"
                      + (f" and its {op} operator (predict ... --branch inflate|deflate)" if op else ""))
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
    muscle: str = MUSCLE_FILE_ARG_OPTION,
    old_muscle: str = OLD_MUSCLE_FILE_OPTION,
    cv: str = typer.Option(None, "--cv", metavar=choices(CV_METHODS), help="isometric: leave-one-length-out (default), leave-one-trial-out or, on a "
                                              "family table (muscle and rest_length columns), leave-one-muscle-out."),
    tare: str = typer.Option("none", "--tare", metavar=choices(TARES), help="isometric: none (default), lowest, column or fitted (see docs/data.md)."),
    rails: str = typer.Option("keep", "--rails", metavar=choices(RAIL_POLICIES), help="isometric: rows at a sensor's rail: keep (default), exclude or censor "
                                                      "(a reading at a floor says only force <= floor)."),
    pressure_zero: str = typer.Option("none", "--pressure-zero", metavar=choices(PRESSURE_ZEROS), help="isometric: the pressure transducer's zero: "
                                                                      "none (default), lowest or column."),
    rest_lengths: str = typer.Option("nominal", "--rest-lengths", metavar=choices(REST_LENGTHS),
                                     help="isometric family: each muscle's rest length as recorded (nominal, default) "
                                          "or fitted with its interval (see docs/fit.md)."),
    select: list[str] = SELECT_OPTION,
    columns: list[str] = COLUMNS_OPTION,
    direction_aware: bool = typer.Option(False, "--direction-aware", help="isometric: also score each law beside its "
                                         "direction-aware form, each trial held out, by the up/down gap."),
    structure: str = STRUCTURE_OPTION,
    min_samples: int = typer.Option(0, "--min-samples", metavar="N", help=MIN_SAMPLES_HELP),
    drift: bool = typer.Option(False, "--run-drift", help=RUN_DRIFT_HELP),
    nested: bool = typer.Option(False, "--nested", help="isometric: nested cross-validation: each fold's error of "
                                "the model chosen on the other folds alone (the non-nested best's error is "
                                "optimistic; see docs/fit.md). With --rest-lengths nominal,fitted both are candidates; "
                                "with --direction-aware, each trial held out, the direction-aware form (--laws x "
                                "--structure play,friction x --run-drift off,on) chosen on the other trials by the "
                                "up/down gap (see docs/hysteresis.md)."),
    models: str = typer.Option(None, "--laws", metavar="LAW,LAW", help="with --direction-aware --nested: the laws "
                               "tried (default every law with a fit; each adds its structures x drifts candidates)."),
    plot: str = plot_option("the held-out error of every model (--nested: each fold's, nested and not)"),
    dpi: int = DPI_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Fit every applicable model to the same data and score it on held-out data (the best is picked there)."""
    check_outputs(plot, dpi)
    muscle = muscle_file_of(muscle, old_muscle, "compare")
    if models is not None and not (nested and direction_aware):
        raise InputError("--laws: the candidates of --direction-aware --nested; without both, compare scores every law")
    if nested and direction_aware:
        _compare_nested_direction_aware(data, muscle, cv, tare, rails, pressure_zero, rest_lengths, select, columns,
                                        models, structure, drift, min_samples, plot, dpi, json)
        return
    op = _structure(direction_aware, structure)
    if nested:
        if drift:
            raise InputError("--run-drift: a nuisance of the direction-aware forms; give --direction-aware")
        _compare_nested(data, muscle, cv, tare, rails, pressure_zero, rest_lengths, select, columns, min_samples,
                        plot, dpi, json)
        return
    res = fit.compare_table(data, muscle, cv, tare, rails, pressure_zero,
                            parse_pairs(select, "--select", "cut_length_cm=10"),
                            parse_pairs(columns, "--columns", "phase=direction"),
                            op, rest_lengths, min_samples, drift)
    out = res.summary
    print_notes(out.get("notes"))
    if plot:
        write_plot(res.plot(), plot, dpi, res)
    _sensor_warnings(f"compare on {data}", out.get("tare", {}))
    if out.get("kind") == "isometric":
        flagged = [f"{s['model']} ({', '.join(s['flags'])})" for s in out["models"] if s["flags"]]
        warn_flags(f"compare on {data}", flagged)
        if json:
            emit_json(out)
            return
        if out["synthetic"]:
            console.print("[bold yellow]SYNTHETIC data[/] (generated, not measured)")
        rows = [[s["model"], str(s["n_parameters"]), _g(s["rmse_N"]), _g(s["r2"], ".4f"), _g(s["cv_rmse_N"]),
                 _g(s["cv_rmse_pct_of_peak"], ".2f"), f"{s.get('extrapolated_folds', 0)}/{len(s.get('folds', []))}",
                 ", ".join(s["flags"]) or "none"]
                for s in sorted(out["models"], key=lambda s: (s["cv_rmse_N"] is None, s["cv_rmse_N"] or 0))]
        print_table(f"Force(P, L) models on {out['file']}, held out: {out['cv']} (peak {out['peak_force_N']:.4g} N)",
                    [" model", "params", "RMSE N", "R²", "CV RMSE N", "CV % of peak", "extrapolated folds",
                     " flags"], rows)
        console.print(f"best on held-out error: {out['best']}")
        if "direction_aware" in out:
            rows = [[s["model"], _g(s.get("measured_gap_rms_N")),
                     f"{_g(s.get('plain_gap_error_rms_N'))} / {_g(s.get('plain_gap_error_max_N'))}",
                     f"{_g(s.get('direction_aware_gap_error_rms_N'))} / {_g(s.get('direction_aware_gap_error_max_N'))}",
                     s["note"][:60] or ", ".join(s.get("flags", [])) or "none"] for s in out["direction_aware"]]
            print_table(f"Up/down gap, each trial held out ({op} structure)",
                        [" law", "measured gap RMS N", "plain error RMS / max N", "direction-aware error RMS / max N",
                         " flags or note"], rows)
        return
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


def _compare_nested(data, muscle, cv, tare, rails, pressure_zero, rest_lengths, select, columns, min_samples,
                    plot, dpi, json) -> None:
    """``compare --nested``: parse, call :func:`mckibben.fit.nested.compare_nested_table`, print."""
    res = fit.compare_nested_table(data, muscle, cv, tare, rails, pressure_zero,
                                   parse_pairs(select, "--select", "cut_length_cm=10"),
                                   parse_pairs(columns, "--columns", "phase=direction"),
                                   tuple(x.strip() for x in rest_lengths.split(",")), min_samples)
    out = res.to_dict()
    print_notes(out.get("notes"))
    if plot:
        write_plot(res.plot(), plot, dpi, res)
    if json:
        emit_json(out)
        return
    if out["synthetic"]:
        console.print("[bold yellow]SYNTHETIC data[/] (generated, not measured)")
    rows = [[str(f["held_out"]), f"{f['chosen'] or '—'}{' (flagged)' if f['chosen_flagged'] else ''}",
             _g(f["rmse_pct_of_peak"], ".2f"), _g(f["max_error_pct_of_peak"], ".2f"),
             _g(f["non_nested_rmse_pct_of_peak"], ".2f"), f["note"][:50]] for f in out["folds"]]
    print_table(f"Nested {out['cv']} on {out['file']} (peak {out['peak_force_N']:.4g} N): each fold predicted by the "
                "model chosen without it", [" held out", " chosen", "RMSE % of peak", "max % of peak",
                                            f"non-nested best ({out['non_nested_best']}) RMSE %", " note"], rows)
    ne, nn = out["nested"], out["non_nested"]
    for what, m in (("nested", ne), (f"non-nested ({out['non_nested_best']})", nn)):
        console.print(f"{what}: RMSE {_g(m['rmse_pct_of_peak'], '.2f')} % of peak, max {_g(m['max_error_pct_of_peak'], '.2f')} %, "
                      f"folds median {_g(m['median_fold_pct_of_peak'], '.2f')} % / worst {_g(m['worst_fold_pct_of_peak'], '.2f')} %")
    choices = ", ".join(f"{k} {v}/{out['n_folds']}" for k, v in out["selection"].items())
    console.print(f"optimism of the non-nested figure: {_g(out['optimism_pct_of_peak'], '+.2f')} points of % of peak; "
                  f"choices: {choices}")


def _compare_nested_direction_aware(data, muscle, cv, tare, rails, pressure_zero, rest_lengths, select, columns,
                                    models, structure, drift, min_samples, plot, dpi, json) -> None:
    """``compare --direction-aware --nested``: parse, call
    :func:`mckibben.fit.nested.compare_direction_aware_nested_table`, print."""
    if cv is not None and cv != "leave-one-trial-out":
        raise InputError(f"--cv: {cv} with --direction-aware --nested; the up/down gap is scored each trial held out "
                         "(leave-one-trial-out, the default here)")
    if rest_lengths != "nominal":
        raise InputError(f"--rest-lengths: {rest_lengths} with --direction-aware; the direction-aware forms are fitted "
                         "at the recorded rest lengths (nominal)")
    structures = tuple(x.strip() for x in structure.split(","))
    for st in structures:
        if st not in STRUCTURES:
            raise InputError(f"--structure: {st!r} is not one of {', '.join(STRUCTURES)} (a comma list with --nested)")
    laws = None if models is None else tuple(x.strip() for x in models.split(","))
    res = fit.compare_direction_aware_nested_table(data, muscle, tare, rails, pressure_zero,
                                                   parse_pairs(select, "--select", "cut_length_cm=10"),
                                                   parse_pairs(columns, "--columns", "phase=direction"), laws,
                                                   structures, (False, True) if drift else (False,), min_samples)
    out = res.to_dict()
    print_notes(out.get("notes"))
    if plot:
        write_plot(res.plot(), plot, dpi, res)
    if json:
        emit_json(out)
        return
    if out["synthetic"]:
        console.print("[bold yellow]SYNTHETIC data[/] (generated, not measured)")
    rows = [[str(f["held_out"]), f"{f['chosen'] or '—'}{' (flagged)' if f['chosen_flagged'] else ''}",
             _g(f["measured_gap_rms_N"]), _g(f["gap_error_rms_N"]), _g(f["gap_error_ratio"], ".2f"),
             _g(f["non_nested_gap_error_ratio"], ".2f"), f["note"][:50]] for f in out["folds"]]
    print_table(f"Nested leave-one-trial-out on {out['file']}: each trial's up/down gap predicted by the direction-aware "
                "form chosen without it", [" held-out trial", " chosen", "measured gap RMS N", "gap error RMS N",
                                           "ratio", f"non-nested best ({out['non_nested_best']}) ratio", " note"], rows)
    console.print(f"pooled gap error / measured gap RMS: nested {_g(out['nested_gap_error_ratio'], '.2f')}, non-nested "
                  f"{_g(out['non_nested_gap_error_ratio'], '.2f')} (optimism {_g(out['optimism'], '+.2f')}); "
                  f"held-out trials at or below 0.5: {out['folds_at_most_half']}/{out['n_folds']}")
    choices = ", ".join(f"{k} {v}/{out['n_folds']}" for k, v in out["selection"].items())
    console.print(f"choices: {choices}")


def _sensor_warnings(what: str, report: dict) -> None:
    """One warning line on stderr for rows at a sensor's rail and for tares read at the rail."""
    rails = report.get("rails", {})
    if rails.get("rows_at_rail"):
        where = ", ".join(f"{r['column']} {r['side']} {r['value']:g}" for r in rails["rails"])
        done = ("excluded" if rails.get("excluded") else "censored (a reading at a floor: force <= floor)"
                if rails.get("censored") else "kept (--rails exclude to drop them, --rails censor to censor them)")
        tare = "; tares read at the rail: the load cell's zero is unknown there" if "tare_at_rail" in report.get(
            "flags", []) else ""
        err_console.print(f"warning: {what}: {rails['rows_at_rail']} rows at a sensor's rail ({where}), {done}{tare}",
                          markup=False, highlight=False)


def _g(v, fmt=".4g"):
    return "—" if v is None or not np.isfinite(v) else format(v, fmt)


def _mm(v):
    return "—" if v is None or not np.isfinite(v) else f"{v * 1e3:.3f}"


def _pct(v):
    return "—" if v is None or not np.isfinite(v) else f"{v * 100:.1f}"


