"""``mckibben reproduce``: the whole characterization, on the bundled data or ``--data DIR``.

Prints the published Tables I and II (and the predicted lengths), fits every model to every
muscle of the campaign, and writes an HTML report with PNG figures (default ``./mckibben-report/``;
written into a temporary folder and renamed into place, so a failure leaves nothing half-written).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, console, emit_json, err_console, print_table
from mckibben.datasets import MUSCLES
from mckibben.datasets.references import render
from mckibben import report


def _print_published(tables: dict) -> None:
    print_table(
        render("Table I ([mpam-characterization]): l = k1·Ls·cos θ + k2"),
        ["muscle", "L0 mm", "Ls mm", "k1", "k2 mm", "blocked force N @ 0.8 MPa"],
        [[n, f"{m.nominal_length * 1e3:g}", f"{m.strand_length * 1e3:g}", f"{m.k1:g}", f"{m.k2 * 1e3:g}", f"{m.blocked_force[0][1]:g}"] for n, m in MUSCLES.items()],
    )
    print_table(
        "Table II and eq. 3: cos θ = c3·P³ + c2·P² + c1·P + c0 (P in MPa)",
        ["muscle", "load N", "c3", "c2", "c1", "c0"],
        [[n, f"{load:g}", *[f"{v:+g}" for v in c]] for n, m in MUSCLES.items() for load, c in zip(m.braid_map.loads, m.braid_map.coefficients)],
    )
    for t in tables.values():
        print_table(
            f"Predicted length, {t['muscle']} under {t['load_N']:g} N",
            ["pressure MPa", "length mm", "contraction %", "cos θ", "flags"],
            [[f"{p / 1e6:.1f}", f"{l_ * 1e3:.2f}", f"{c * 100:.1f}", f"{ct:.4f}", ", ".join(f) or "ok"]
             for p, l_, c, ct, f in zip(t["pressure_Pa"], t["length_m"], t["contraction"], t["cos_theta"], t["flags"])],
        )


@app.command("reproduce")
def reproduce_cmd(
    out: Path = typer.Option(Path("mckibben-report"), "--out", help="Report folder (default ./mckibben-report)."),
    data: Path = typer.Option(None, "--data", help="Campaign folder (one sub-folder per muscle); default: the bundled synthetic campaign."),
    json: bool = JSON_OPTION,
) -> None:
    """Characterize the campaign: fit every model, compare them, write the HTML report with figures."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn  # deferred on purpose: Rich's progress display (about 30 ms to import)


    with Progress(TextColumn("{task.description:<40}"), BarColumn(), TimeElapsedColumn(), console=err_console,
                  transient=True, disable=json or not err_console.is_terminal) as bar:
        task = bar.add_task("reading data", total=None)

        def step(msg: str, done: int, total: int) -> None:
            bar.update(task, description=msg, completed=done, total=total)

        folder, summary, tables = report.reproduce(out, data=data, progress=step)
    if json:
        emit_json({"out": str(folder), "report_html": str(folder / "index.html"), **summary, "length_tables": tables})
        return
    _print_published(tables)
    if summary["synthetic"]:
        console.print("[bold red]SYNTHETIC DATA[/]: the bundled example campaign is generated, not measured.")
    print_table("Fitted Table I (± one standard error) beside the published values",
                [" muscle", "k1", "published", "k2 mm", "published"],
                [[r["muscle"], f"{r['k1']:.3f} ± {r['k1_stderr']:.3f}", _g(r["k1_published"]),
                  f"{r['k2_m'] * 1e3:.2f} ± {r['k2_stderr_m'] * 1e3:.2f}", _g(r["k2_published_m"], 1e3)]
                 for r in summary["table_I"]])
    rows = []
    for muscle, c in summary["comparison"].items():
        best = min((m for m in c["models"] if np.isfinite(m["cv_rmse_m"] or np.nan)), key=lambda m: m["cv_rmse_m"])
        paper = next((m for m in c["models"] if m["model"].startswith("paper")), None)
        rows.append([muscle, best["model"], f"{best['cv_rmse_m'] * 1e3:.3f}",
                     f"{paper['within_20pct'] * 100:.1f}" if paper else "—"])
    print_table("Model comparison (length under load; details in the report)",
                [" muscle", " best model (CV RMSE)", "CV RMSE mm", "paper eq. 2+3 within 20 % [%]"], rows)
    for c in summary.get("isometric", []):
        print_table(f"Isometric {c['muscle']}: force(P, L) models, held out {c['cv']} (peak {c['peak_force_N']:.4g} N)",
                    [" model", "RMSE N", "CV RMSE N", "CV % of peak", " flags"],
                    [[m["model"] + (" (best)" if m["model"] == c["best"] else ""), _g(m["rmse_N"]),
                      _g(m["cv_rmse_N"]), f"{m['cv_rmse_pct_of_peak']:.2f}" if m["cv_rmse_pct_of_peak"] is not None
                      else "—", ", ".join(m["flags"]) or "none"]
                     for m in sorted(c["models"], key=lambda m: (m["cv_rmse_N"] is None, m["cv_rmse_N"] or 0))])
    console.print(f"Report: {folder / 'index.html'}")


def _g(v, scale=1.0):
    return "—" if v is None else f"{v * scale:.4g}"
