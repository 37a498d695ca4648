"""The real Festo 10 mm loops in metrics that cannot cancel: RMS and max of the gap error.

``benchmarks/bench_hysteresis.py`` scores its Prandtl–Ishlinskii fits by the loop *width*, the
mean over 100–550 kPa of deflate − inflate force: a signed mean, so a loop that crosses itself
(wider at low pressure one way, at high pressure the other) reads near zero. This script fits the
same operator the same way (its constants and helpers are imported, not copied: 2 plays at 0 and
10 kPa, 8 knots, trials 8–9 fitted, trial 10 held out, rows at the load cell's floor left out) and
scores, at every grid pressure where both branches of trial 10 have data,

- the measured gap g(P) = F_deflate(P) − F_inflate(P);
- the gap error e(P) = predicted gap − measured gap: −g(P) for a static map (no gap), and
  (pred_deflate − pred_inflate) − g(P) for the PI;

pooled over the 24 (muscle, length) pairs: RMS and max |·|, and the median of the per-pair RMS.
Reads ``../shared/data/real/festo10_isometric.csv`` (not bundled); skips when it is absent.

Run: python benchmarks/bench_hysteresis_gap.py
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

from bench_hysteresis import FIT_TRIALS, GRID_KPA, KNOTS, N_PLAYS, RAIL_N, SOURCE, SPAN_PA, TEST_TRIAL, _sequence
from mckibben.fit.hysteresis import fit_prandtl_ishlinskii
from mckibben.models.hysteresis import apply, descended_state, thresholds_uniform


def _branch_gap(p_kpa, value, phase) -> np.ndarray:
    """deflate − inflate of ``value`` at each grid pressure both branches cover. [N]"""
    out = []
    for ph in ("inflate", "deflate"):
        sel = phase == ph
        order = np.argsort(p_kpa[sel])
        out.append((p_kpa[sel][order], value[sel][order]))
    lo = max(out[0][0].min(), out[1][0].min())
    hi = min(out[0][0].max(), out[1][0].max())
    g = GRID_KPA[(GRID_KPA >= lo) & (GRID_KPA <= hi)]
    return np.interp(g, *out[1]) - np.interp(g, *out[0])


def gaps() -> list[dict]:
    """Per (muscle, held length) on the held-out trial: measured gap, PI gap error, mean width."""
    data = pd.read_csv(SOURCE)
    r = thresholds_uniform(N_PLAYS, SPAN_PA)
    rows = []
    for (cut, held), g in data.groupby(["cut_length_cm", "held_length_mm"]):
        seqs = {t: _sequence(g[g.trial == t]) for t in sorted(g.trial.unique())}
        fit_runs = [seqs[t] for t in FIT_TRIALS if t in seqs]
        if TEST_TRIAL not in seqs or not fit_runs:
            continue
        tr = pd.concat(fit_runs)
        u, y = tr.pressure_kPa.to_numpy() * 1e3, tr.force_N.to_numpy()
        res = fit_prandtl_ishlinskii(u, y, r, run=tr.trial.to_numpy(), start="descended", mask=y > RAIL_N,
                                     input_unit="Pa", output_unit="N", source=SOURCE.name, output_knots=KNOTS)
        te = seqs[TEST_TRIAL]
        ut, yt = te.pressure_kPa.to_numpy() * 1e3, te.force_N.to_numpy()
        pred, _ = apply(res.model, ut, descended_state(r, float(ut[0])))
        ok = yt > RAIL_N
        p_k, ph = te.pressure_kPa.to_numpy()[ok], te.phase.to_numpy()[ok]
        measured = _branch_gap(p_k, yt[ok], ph)
        error = _branch_gap(p_k, pred[ok], ph) - measured
        rows.append({"muscle": f"{cut} cm", "held_mm": held, "peak_N": float(np.max(yt)), "measured": measured,
                     "error": error})
    return rows


def main() -> int:
    if not SOURCE.exists():
        print(f"skipped: {SOURCE} is absent (real data are not bundled)")
        return 0
    rows = gaps()
    meas = np.concatenate([r["measured"] for r in rows])
    err = np.concatenate([r["error"] for r in rows])

    def rms(x):
        return float(np.sqrt(np.mean(x**2)))

    print("| muscle | held mm | measured gap RMS / max N | PI gap error RMS / max N | signed mean before / after N |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        m, e = r["measured"], r["error"]
        print(f"| {r['muscle']} | {r['held_mm']:.2f} | {rms(m):.2f} / {np.max(np.abs(m)):.2f} | "
              f"{rms(e):.2f} / {np.max(np.abs(e)):.2f} | {np.mean(m):.2f} / {np.mean(-e):.2f} |")
    print(f"\npooled over {len(rows)} pairs, {meas.size} grid pressures (held-out trial {TEST_TRIAL}):")
    print(f"  static map (no gap):  RMS {rms(meas):.2f} N, max {np.max(np.abs(meas)):.2f} N")
    print(f"  Prandtl–Ishlinskii:   RMS {rms(err):.2f} N, max {np.max(np.abs(err)):.2f} N")
    print(f"  median per-pair RMS:  {np.median([rms(r['measured']) for r in rows]):.2f} N before, "
          f"{np.median([rms(r['error']) for r in rows]):.2f} N after")
    print(f"  (the signed mean the docs used, median |mean gap|: {np.median([abs(np.mean(r['measured'])) for r in rows]):.2f}"
          f" N before, {np.median([abs(np.mean(r['error'])) for r in rows]):.2f} N after)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
