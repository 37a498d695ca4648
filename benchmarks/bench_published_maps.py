"""Every force model on the published force maps of Martens & Boblan (2017), against the paper's own error.

The maps (``benchmarks/data/martens2017/``, read its README: source, transcription, what could and
could not be checked) are the measured isometric force maps of a Festo DMSP-20-300 (Table A1) and a
DMSP-10-250 (Table A2) of M. Martens, I. Boblan, Actuators 6(4), 33 (2017),
doi:10.3390/act6040033. Their model reaches a maximum error below 2.35 % (20 mm) and 4.4 % (10 mm) of
the peak force (abstract); issue 33's bar asks the best *accepted* (unflagged) model of mckibben to
reach that in-sample.

For each map it runs, as a lab would, ``mckibben compare MAP.csv --muscle-file M.toml --cv
leave-one-length-out --json`` (the library call :func:`mckibben.fit.compare_table`), once with the
table's zeros kept as readings (``--rails keep``) and once with them censored (``--rails censor``: a
zero in the map is where the held muscle is slack, the law's force there is at most 0). It prints per
model the in-sample and held-out RMS and maximum error in % of the peak, the ratio of held-out to
in-sample RMSE on the folds that interpolate (``heldout_far_above_insample`` above 3), the flags, the best accepted
model (the comparison's ``best``: lowest held-out error among the unflagged) and its in-sample
maximum error beside the paper's; then the rows that carry the largest errors of the best accepted
model and of the model with the lowest in-sample maximum error (``fit --model``, the same options).

Run: python benchmarks/bench_published_maps.py [--rows N]   (N largest errors listed, default 5)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mckibben.fit import compare_table, fit_table

DATA = Path(__file__).resolve().parent / "data" / "martens2017"
#: map, muscle file, the paper's own maximum error in % of peak (Martens & Boblan 2017, abstract)
MAPS = (("DMSP-20-300 (Table A1)", DATA / "dmsp20_isometric.csv", DATA / "dmsp20.toml", 2.35),
        ("DMSP-10-250 (Table A2)", DATA / "dmsp10_isometric.csv", DATA / "dmsp10.toml", 4.4))
RAILS = ("keep", "censor")


def pct(x) -> str:
    return "    -" if x is None else f"{float(x):5.2f}"


def ratio(m: dict) -> str:
    """Held-out over in-sample RMSE on the interpolating folds' points (what ``heldout_far_above_insample`` reads)."""
    cv, fit = m.get("cv_rmse_interpolated_N"), m.get("rmse_interpolated_N")
    return "    -" if cv is None or not fit else f"{cv / fit:5.2f}"


def worst_rows(data: Path, muscle: Path, model: str, rails: str, n: int) -> list[str]:
    """The n rows with the largest |measured − fitted| of one model fitted to all rows."""
    fit = fit_table(data, model, muscle=str(muscle), rails=rails)
    d = fit.fits[0]._series()  # the fitted points, the model's force and the residual (IsometricFit)
    peak = float(np.max(np.abs(d["force_N"])))
    d = d.assign(err=d["residual_N"].abs()).sort_values("err", ascending=False).head(n)
    out = [f"    {model}: largest errors (held length, pressure, measured, fitted, error % of peak)"]
    for _, r in d.iterrows():
        out.append(f"      {r['held_length_m'] * 1e3:6.1f} mm {r['pressure_Pa'] / 1e3:7.2f} kPa "
                   f"{r['force_N']:8.1f} N {r['force_fit_N']:8.1f} N {100 * r['residual_N'] / peak:+6.2f} %")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=5)
    args = ap.parse_args(argv)
    for name, data, muscle, paper in MAPS:
        for rails in RAILS:
            res = compare_table(data, muscle=str(muscle), cv="leave-one-length-out", rails=rails).to_dict()
            print(f"\n{name}, rails {rails}: peak {res['peak_force_N']:.1f} N; the paper's model: max {paper} %")
            print(f"  {'model':16s} {'RMS in':>6s} {'max in':>6s} {'RMS out':>7s} {'max out':>7s} {'ratio':>5s}  flags")
            for m in res["models"]:
                print(f"  {m['model']:16s} {pct(m.get('rmse_N') and 100 * m['rmse_N'] / res['peak_force_N'])} "
                      f"{pct(m['max_error_pct_of_peak'])}  {pct(m['cv_rmse_pct_of_peak'])}   "
                      f"{pct(m['cv_max_error_pct_of_peak'])} {ratio(m)}  {', '.join(m['flags']) or 'none'}"
                      + (f"  [notes: {', '.join(m['notes'])}]" if m.get("notes") else ""))
            by = {m["model"]: m for m in res["models"]}
            best = res.get("best")
            scored = [m for m in res["models"] if m["max_error_pct_of_peak"] is not None]
            tightest = min(scored, key=lambda m: m["max_error_pct_of_peak"])["model"]
            if best is None or res.get("best_flagged"):
                print(f"  best accepted: none (best {best}, flagged)")
            else:
                mx = by[best]["max_error_pct_of_peak"]
                print(f"  best accepted: {best}, in-sample max {mx:.2f} % vs the paper's {paper} %: "
                      f"{'MET' if mx <= paper else 'NOT met'}")
            print(f"  lowest in-sample max: {tightest} {by[tightest]['max_error_pct_of_peak']:.2f} % "
                  f"(flags: {', '.join(by[tightest]['flags']) or 'none'})")
            if args.rows > 0:
                for model in dict.fromkeys(x for x in (best, tightest) if x):
                    print("\n".join(worst_rows(data, muscle, model, rails, args.rows)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
