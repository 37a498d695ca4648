"""Held-out errors of every force model on real isometric measurements (not bundled, not shipped).

Reads ``../shared/data/real/festo10_isometric.csv`` beside the repository by default (Festo 10 mm
muscles cut to six lengths; PROVENANCE.md there says what the rig got wrong) and skips cleanly when
it is absent. It writes the lab's shapes of the data into a temporary folder: one isometric table and a
muscle file of only ``id``, ``nominal_length_mm``, ``outer_diameter_mm`` per muscle, and one family
table (``muscle``, ``rest_length_mm``) with a muscle file of the type; then it runs, as a lab would,

- per muscle: ``mckibben compare ISO.csv --muscle m.toml --cv leave-one-length-out --tare lowest --json``;
- on the family: ``mckibben compare FAMILY.csv --muscle fam.toml --cv leave-one-muscle-out --tare lowest --json``
  and ``--cv leave-one-length-out`` (one muscle's length held out, the other muscles kept),

and prints every model's held-out RMSE as % of the held-out muscle's peak force, its flags (doubt
about its predictions) and notes, the best model per muscle (picked on held-out error among the
unflagged), and any model that is best but carries flags.

With ``--sensors`` it runs instead the sensor and specimen models of issue 33 (item 4): per muscle
``compare … --tare lowest --rails censor`` (a reading at the load cell's floor censored), and on the
family ``compare … --cv leave-one-muscle-out --tare lowest --rest-lengths fitted`` and the same
``fit --model virtual-work`` (each muscle's rest length fitted, with its interval).

With ``--physical [TARE]`` it runs the physical laws of issue 33 (item 3) per muscle, by the
library (``compare_isometric(..., models=[chou-hannaford, wall-corrected, tondu-lopez])``,
leave-one-length-out, ``--tare lowest`` or the TARE given, e.g. ``fitted``): each law's held-out
RMSE as % of peak, the parameters at a bound, its zero, its geometry, and (``fitted``) the spread
of the runs' zeros; ``--physical TARE MODEL,MODEL`` runs those models instead.

With ``--nested`` it runs the issue's bar-1 figures non-nested and nested (issue 33, item 7):
per muscle ``compare ISO.csv … --cv leave-one-length-out --tare lowest --nested`` and on the family
``compare FAMILY.csv … --cv leave-one-muscle-out --tare lowest --nested`` (the laws as candidates),
then ``--rest-lengths nominal,fitted`` (each law with either rest-length option as a candidate):
each outer fold's choice made on the other folds alone (:func:`mckibben.fit.nested.compare_nested`),
and the non-nested best's figure beside it.

With ``--threshold`` it runs virtual-work beside virtual-work with a threshold pressure
(``virtual-work+threshold``, :mod:`mckibben.models.threshold`; issue 33, item 3) by the library
(``compare_isometric(..., models=[...])``, ``--tare lowest``): per muscle leave-one-length-out, and on
the family leave-one-muscle-out and leave-one-length-out; held out % of peak, folds' median and worst,
the fitted threshold, flags.

Run: python benchmarks/bench_real_models.py [--quick | --sensors | --nested | --physical [TARE [MODELS]] | --threshold]
     [--data PATH] [--outer-diameter-mm D]
(--quick: the family only; --data: another campaign in the same format, e.g. a Festo 20 mm one, its
muscles named after the file, ``festo20_isometric.csv`` -> ``festo20-10cm``; --outer-diameter-mm: their
outer diameter, read from such a name when not given; :mod:`real_campaign`.)
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

import real_campaign

from mckibben.cli import main

# The campaign (real_campaign.parse; set from the command line before any bench runs): its file, its
# muscles' outer diameter (the muscle file needs one; no model reads it but the physical laws' bounds;
# Festo DMSP-10: the nominal inner diameter 10 mm, from the file's name) and its name (the ids' prefix).
CAMPAIGN = real_campaign.parse([])[1]
SOURCE = CAMPAIGN.path


def run(*args: str) -> dict:
    """``mckibben ARGS --json`` in-process; the parsed JSON (exit status must be 0)."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(args) + ["--json"])
    if code != 0:
        raise SystemExit(f"mckibben {' '.join(args)} exited {code}: {err.getvalue().strip()}")
    return json.loads(out.getvalue())


def lab_tables(folder: Path) -> tuple[list, Path, Path]:
    """Write per-muscle tables and muscle files, and the family table and its muscle file."""
    d = pd.read_csv(SOURCE)
    d["muscle"] = f"{CAMPAIGN.name}-" + d["cut_length_cm"].astype(str) + "cm"
    d = d.rename(columns={"phase": "direction"})
    cols = ["held_length_mm", "pressure_kPa", "force_N", "direction", "trial", "muscle"]
    per = []
    for m, g in d.groupby("muscle", sort=False):
        iso = folder / f"{m}.csv"
        g[cols].to_csv(iso, index=False)
        toml = folder / f"{m}.toml"
        toml.write_text(f'id = "{m}"\nnominal_length_mm = {g["rest_length_mm"].iloc[0]:g}\n'
                        f"outer_diameter_mm = {CAMPAIGN.outer_diameter_mm:g}\n")
        per.append((m, float(g["rest_length_mm"].iloc[0]), iso, toml))
    fam = folder / "family.csv"
    d[cols + ["rest_length_mm"]].to_csv(fam, index=False)
    fam_toml = folder / f"{CAMPAIGN.name}.toml"
    fam_toml.write_text(f'id = "{CAMPAIGN.name}"\nnominal_length_mm = {d["rest_length_mm"].median():g}\n'
                        f"outer_diameter_mm = {CAMPAIGN.outer_diameter_mm:g}\n")
    return per, fam, fam_toml


def table(out: dict) -> list[str]:
    """One line per model: held-out % of peak (pooled), median and worst fold, flags."""
    lines = []
    for s in sorted(out["models"], key=lambda s: (s["cv_rmse_N"] is None, s["cv_rmse_N"] or 0)):
        if s["cv_rmse_N"] is None:
            lines.append(f"    {s['model']:<16} not fitted: {s['note'][:80]}")
            continue
        lines.append(f"    {s['model']:<16} held out {s['cv_rmse_pct_of_peak']:6.2f} % of peak "
                     f"(folds: median {s['median_fold_pct_of_peak']:5.2f} %, worst {s['worst_fold_pct_of_peak']:5.2f} %)"
                     f"  in-sample {s['rmse_N']:.3g} N  flags: {', '.join(s['flags']) or 'none'}"
                     + (f"  notes: {', '.join(s['notes'])}" if s.get("notes") else ""))
    return lines


def sensors_bench() -> int:
    """The rails censored per muscle; the family's rest lengths fitted."""
    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        per, fam, fam_toml = lab_tables(Path(tmp))
        print("per muscle, leave-one-length-out, --tare lowest: --rails keep -> --rails censor")
        worst = {}
        for m, rest, iso, toml in per:
            line = []
            for rails in ("keep", "censor"):
                out = run("compare", str(iso), "--muscle", str(toml), "--cv", "leave-one-length-out", "--tare", "lowest",
                          "--rails", rails)
                b = next(s for s in out["models"] if s["model"] == out["best"])
                worst.setdefault(rails, []).append(b["cv_rmse_pct_of_peak"])
                line.append(f"{rails}: best {out['best']} {b['cv_rmse_pct_of_peak']:.2f} %")
            print(f"  {m}: rows at the rail {out['tare']['rails']['rows_at_rail']}; " + "; ".join(line))
        for rails, pct in worst.items():
            print(f"  best per muscle, --rails {rails}: median {np.median(pct):.2f} %, worst {np.max(pct):.2f} %")
        for rl in ("nominal", "fitted"):
            out = run("compare", str(fam), "--muscle", str(fam_toml), "--cv", "leave-one-muscle-out", "--tare", "lowest",
                      "--rest-lengths", rl)
            print(f"family, leave-one-muscle-out, --rest-lengths {rl}: best {out['best']}")
            print("\n".join(table(out)))
            fit = run("fit", str(fam), "--model", "virtual-work", "--muscle", str(fam_toml), "--tare", "lowest",
                      "--rest-lengths", rl)["fits"][0]
            shown = {n: (v, fit["ci95"][n]) for n, v in fit["parameters"].items() if n.startswith("rest_shift")
                     or n in ("end_zone_m", "e0")}
            print(f"    fit on all: RMS {fit['rmse_N']:.3f} N, flags {fit['flags'] or 'none'}; "
                  + ", ".join(f"{n} {v:.4g} [{lo:.4g}, {hi:.4g}]" for n, (v, (lo, hi)) in shown.items()))
    return 0


def nested_line(out: dict) -> str:
    """Non-nested and nested figures of one ``compare --nested`` run: pooled, max, median and worst fold."""
    nn, ne = out["non_nested"], out["nested"]
    return (f"non-nested best {nn['best']}: RMSE {nn['rmse_pct_of_peak']:.2f} %, max {nn['max_error_pct_of_peak']:.2f} %, "
            f"folds median {nn['median_fold_pct_of_peak']:.2f} / worst {nn['worst_fold_pct_of_peak']:.2f} %; nested: RMSE "
            f"{ne['rmse_pct_of_peak']:.2f} %, max {ne['max_error_pct_of_peak']:.2f} %, folds median "
            f"{ne['median_fold_pct_of_peak']:.2f} / worst {ne['worst_fold_pct_of_peak']:.2f} %; optimism "
            f"{out['optimism_pct_of_peak']:+.2f} points; choices "
            + ", ".join(f"{k} {v}/{out['n_folds']}" for k, v in out["selection"].items()))


def nested_bench() -> int:
    """The bar-1 figures non-nested and nested: per muscle leave-one-length-out, family leave-one-muscle-out."""
    import time

    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        per, fam, fam_toml = lab_tables(Path(tmp))
        print("per muscle, leave-one-length-out, --tare lowest --nested", flush=True)
        pooled: dict = {"non-nested": [], "nested": []}
        for m, rest, iso, toml in per:
            t0 = time.perf_counter()
            out = run("compare", str(iso), "--muscle", str(toml), "--cv", "leave-one-length-out", "--tare", "lowest",
                      "--nested")
            pooled["non-nested"].append(out["non_nested"]["rmse_pct_of_peak"])
            pooled["nested"].append(out["nested"]["rmse_pct_of_peak"])
            print(f"  {m} (rest {rest:g} mm, {time.perf_counter() - t0:.0f} s): {nested_line(out)}")
            for f in out["folds"]:
                print(f"      held out {f['held_out']:<10} chose {f['chosen']}{' (flagged)' if f['chosen_flagged'] else ''}: "
                      f"{f['rmse_pct_of_peak']:.2f} % (max {f['max_error_pct_of_peak']:.2f} %); non-nested best "
                      f"{f['non_nested_rmse_pct_of_peak']:.2f} %", flush=True)
        for k, v in pooled.items():
            print(f"  per muscle, {k}: median {np.median(v):.2f} %, worst {np.max(v):.2f} % of peak", flush=True)
        for rl in ("nominal", "nominal,fitted"):
            t0 = time.perf_counter()
            out = run("compare", str(fam), "--muscle", str(fam_toml), "--cv", "leave-one-muscle-out", "--tare", "lowest",
                      "--nested", "--rest-lengths", rl)
            print(f"family ({len(per)} muscles), leave-one-muscle-out, --tare lowest --nested --rest-lengths {rl} "
                  f"({time.perf_counter() - t0:.0f} s): {nested_line(out)}")
            for f in out["folds"]:
                print(f"      held out {f['held_out']:<16} chose {f['chosen']}{' (flagged)' if f['chosen_flagged'] else ''}: "
                      f"{f['rmse_pct_of_peak']:.2f} % (max {f['max_error_pct_of_peak']:.2f} %); non-nested best "
                      f"{f['non_nested_rmse_pct_of_peak']:.2f} %", flush=True)
    return 0


PHYSICAL = ("chou-hannaford", "wall-corrected", "tondu-lopez")


def physical_bench(tare: str = "lowest", models=PHYSICAL) -> int:
    """The physical laws (or ``models``) per muscle: held out, parameters at a bound, zero and geometry (issue 33)."""
    from mckibben.data import read_muscle, read_table
    from mckibben.fit.isometric import compare_isometric

    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        per, _, _ = lab_tables(Path(tmp))
        print(f"per muscle, leave-one-length-out, tare {tare}: {', '.join(models)}")
        for m, rest, iso, toml in per:
            c = compare_isometric(read_table(str(iso)), read_muscle(str(toml)), "leave-one-length-out", tare=tare,
                                  models=list(models))
            print(f"  {m} (rest {rest:g} mm)")
            for s in c.scores:
                r = c.fits[s["model"]].result
                vals = {n: float(v) for n, v in zip(r.names, r.values) if not n.startswith("zero_dev_")}
                bound = [f for f in s["flags"] if f.endswith("_bound")]
                other = [f for f in s["flags"] if not f.endswith("_bound")]
                geo = ", ".join(f"{n} {v:.4g}" for n, v in vals.items())
                zeros = ""
                if tare == "fitted":
                    z = np.array([x["zero_N"] for x in c.fits[s["model"]].tare["per_run_N"]])
                    zeros = f"; run zeros {z.min():.1f}..{z.max():.1f} N (sd {z.std():.1f})"
                print(f"    {s['model']:<15} held out {s['cv_rmse_pct_of_peak']:6.2f} % of peak, in-sample "
                      f"{s['rmse_N']:.3g} N; at bound: {', '.join(bound) or 'none'}; other flags: "
                      f"{', '.join(other) or 'none'}; notes: {', '.join(s.get('notes', [])) or 'none'}\n"
                      f"      {geo}{zeros}")
    return 0


THRESHOLD = ("virtual-work", "virtual-work+threshold")


def threshold_bench() -> int:
    """Virtual-work with and without a threshold pressure, per muscle and on the family (issue 33, item 3)."""
    from mckibben.data import read_muscle, read_table
    from mckibben.fit.isometric import compare_isometric

    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0

    def lines(c) -> None:
        for s in c.scores:
            r = c.fits[s["model"]].result
            v = dict(zip(r.names, r.values))
            pth = v.get("threshold_pressure_Pa", float("nan")) / 1e3
            print(f"    {s['model']:<24} held out {s['cv_rmse_pct_of_peak']:5.2f} % of peak (folds: median "
                  f"{s['median_fold_pct_of_peak']:5.2f} %, worst {s['worst_fold_pct_of_peak']:5.2f} %), in-sample "
                  f"{s['rmse_N']:.3g} N, max {s['max_error_pct_of_peak']:.2f} %; P_th {pth:.1f} kPa; zero "
                  f"{v.get('offset_N', 0.0):.1f} N; flags: {', '.join(s['flags']) or 'none'}")

    with tempfile.TemporaryDirectory() as tmp:
        per, fam, fam_toml = lab_tables(Path(tmp))
        print(f"per muscle, leave-one-length-out, tare lowest: {', '.join(THRESHOLD)}")
        for m, rest, iso, toml in per:
            print(f"  {m} (rest {rest:g} mm)")
            lines(compare_isometric(read_table(str(iso)), read_muscle(str(toml)), "leave-one-length-out",
                                    tare="lowest", models=list(THRESHOLD)))
        for cv in ("leave-one-muscle-out", "leave-one-length-out"):
            print(f"family ({len(per)} muscles), {cv}, tare lowest")
            lines(compare_isometric(read_table(str(fam)), read_muscle(str(fam_toml)), cv, tare="lowest",
                                    models=list(THRESHOLD)))
    return 0


def main_bench(quick: bool = False) -> int:
    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        per, fam, fam_toml = lab_tables(Path(tmp))
        best_per_muscle = []
        if not quick:
            print("per muscle, leave-one-length-out, --tare lowest")
            for m, rest, iso, toml in per:
                out = run("compare", str(iso), "--muscle", str(toml), "--cv", "leave-one-length-out", "--tare", "lowest")
                b = next(s for s in out["models"] if s["model"] == out["best"])
                best_per_muscle.append(b["cv_rmse_pct_of_peak"])
                print(f"  {m} (rest {rest:g} mm): best {out['best']} {b['cv_rmse_pct_of_peak']:.2f} % of peak"
                      f"{' FLAGGED ' + ','.join(b['flags']) if b['flags'] else ''}")
                print("\n".join(table(out)))
        for cv in ("leave-one-muscle-out",) + (() if quick else ("leave-one-length-out",)):
            out = run("compare", str(fam), "--muscle", str(fam_toml), "--cv", cv, "--tare", "lowest")
            print(f"family ({len(per)} muscles), {cv}, --tare lowest: best {out['best']}")
            print("\n".join(table(out)))
            b = next(s for s in out["models"] if s["model"] == out["best"])
            for f in b["folds"]:
                print(f"      held out {f['held_out']:<28} {f['rmse_pct_of_peak']:6.2f} % of its peak "
                      f"({f['rmse_N']:.3g} N of {f['peak_force_N']:.4g} N)"
                      f"{'  extrapolated: ' + ', '.join(f['extrapolated']) if f.get('extrapolated') else ''}")
            pct = [f["rmse_pct_of_peak"] for f in b["folds"]]
            print(f"    best model per held-out fold: median {np.median(pct):.2f} %, worst {np.max(pct):.2f} %")
        if best_per_muscle:
            print(f"per muscle best (leave-one-length-out): median {np.median(best_per_muscle):.2f} %, "
                  f"worst {np.max(best_per_muscle):.2f} % of peak")
    return 0


if __name__ == "__main__":
    argv, CAMPAIGN = real_campaign.parse(sys.argv[1:])
    SOURCE = CAMPAIGN.path
    if "--physical" in argv:
        i = argv.index("--physical")
        rest = argv[i + 1:]
        sys.exit(physical_bench(rest[0] if rest else "lowest", tuple(rest[1].split(",")) if len(rest) > 1 else PHYSICAL))
    if "--nested" in argv:
        sys.exit(nested_bench())
    if "--threshold" in argv:
        sys.exit(threshold_bench())
    sys.exit(sensors_bench() if "--sensors" in argv else main_bench("--quick" in argv))
