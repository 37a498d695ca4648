"""Every force model on the published force maps of Martens & Boblan (2017), against the paper's own error.

The maps (``benchmarks/data/martens2017/``, read its README: source, transcription, what could and
could not be checked) are the measured isometric force maps of a Festo DMSP-20-300 (Table A1) and a
DMSP-10-250 (Table A2) of M. Martens, I. Boblan, Actuators 6(4), 33 (2017),
doi:10.3390/act6040033. Their model reaches a maximum error below 2.35 % (20 mm) and 4.4 % (10 mm) of
the peak force (abstract); issue 33's bar asks the best *accepted* (unflagged) model of mckibben to
reach that in-sample.

For each map it runs, as a lab would, ``mckibben compare MAP.csv --muscle-file M.toml --cv
leave-one-length-out --json`` (its library call on one muscle's map,
:func:`mckibben.fit.isometric.compare_isometric`), once with the table's zeros kept as readings (``--rails keep``) and once with them censored (``--rails censor``: a
zero in the map is where the held muscle is slack, the law's force there is at most 0). It prints per
model the in-sample and held-out RMS and maximum error in % of the peak, the ratio of held-out to
in-sample RMSE on the folds that interpolate (``heldout_far_above_insample`` above 3), the flags, the best accepted
model (the comparison's ``best``: lowest held-out error among the unflagged) and its in-sample
maximum error beside the paper's; then the rows that carry the largest errors of the best accepted
model and of the model with the lowest in-sample maximum error (the comparison's fit of that model on
all rows).

With ``--threshold`` every law without a threshold of its own is also scored with a threshold
pressure fitted with it, ``<law>+threshold`` (:mod:`mckibben.models.threshold`, issue 33 item 3:
is the −37 N zero that virtual-work buys on the censored 10 mm map a threshold pressure?); the
columns add the fitted load-cell zero and threshold.

Run: python benchmarks/bench_published_maps.py [--rows N] [--threshold]   (N largest errors listed, default 5)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mckibben.data import read_muscle, read_table
from mckibben.fit.isometric import ModelComparison, compare_isometric

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


def worst_rows(comparison: ModelComparison, model: str, n: int) -> list[str]:
    """The n rows with the largest |measured − fitted| of one model fitted to all rows."""
    d = comparison.fits[model].points()  # the fitted points, the model's force and the residual (IsometricFit)
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
    ap.add_argument("--threshold", action="store_true", help="also score <law>+threshold")
    args = ap.parse_args(argv)
    w = 26 if args.threshold else 16
    for name, data, muscle, paper in MAPS:
        for rails in RAILS:
            c = compare_isometric(read_table(str(data)), read_muscle(str(muscle)), "leave-one-length-out", rails=rails,
                                  threshold=args.threshold)
            res = c.to_dict()
            print(f"\n{name}, rails {rails}: peak {res['peak_force_N']:.1f} N; the paper's model: max {paper} %")
            print(f"  {'model':{w}s} {'RMS in':>6s} {'max in':>6s} {'RMS out':>7s} {'max out':>7s} {'ratio':>5s}"
                  + (f" {'zero N':>6s} {'P_th kPa':>8s}" if args.threshold else "") + "  flags")
            for m in res["models"]:
                extra = ""
                if args.threshold and m["model"] in c.fits:
                    v = dict(zip(c.fits[m["model"]].result.names, c.fits[m["model"]].result.values))
                    extra = (f" {v.get('offset_N', 0.0):6.1f} "
                             f"{v['threshold_pressure_Pa'] / 1e3 if 'threshold_pressure_Pa' in v else float('nan'):8.1f}")
                print(f"  {m['model']:{w}s} {pct(m.get('rmse_N') and 100 * m['rmse_N'] / res['peak_force_N'])} "
                      f"{pct(m['max_error_pct_of_peak'])}  {pct(m['cv_rmse_pct_of_peak'])}   "
                      f"{pct(m['cv_max_error_pct_of_peak'])} {ratio(m)}{extra}  {', '.join(m['flags']) or 'none'}"
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
                    print("\n".join(worst_rows(c, model, args.rows)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
