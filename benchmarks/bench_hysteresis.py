"""What a Prandtl–Ishlinskii operator removes: the simulated miniature muscle and real Festo muscles.

1. **Simulator** (the seed paper's 1.2 mm muscle, its Fig. 6 loop from the plant's Dahl friction):
   ``hysteresis_benefit`` at a 4 s tracking period (``mckibben control hysteresis --period 4s
   --json``): RMS / max length error of the single cubic, the inflate/deflate branches and the
   inverse PI operator.
2. **Real data** (``../shared/data/real/festo10_isometric.csv``, not bundled; skipped when absent):
   force against pressure at a held length, inflate then deflate, three trials per (muscle,
   length). Per (muscle, length) a modified PI operator (pressure [Pa] → force [N], 2 plays at 0
   and 10 kPa, weights ≥ 0, a monotone output map of 8 knots) is fitted on every trial but the
   last (8 and 9) and scored on the last (10), held out (other configurations: benchmarks/RESULTS.md).
   Loop width = mean over a pressure grid of (deflate − inflate) force, on the held-out trial:
   *before* on the measured force (the width any static map leaves), *after* on the residual
   force − PI prediction. Samples at the load cell's floor (the campaign's lowest force when it is
   a rail, :func:`real_campaign.rail_floor`: −8.735 N, slack muscle) are left out of fit and width.

Run: python benchmarks/bench_hysteresis.py [--real-only] [--data PATH] [--outer-diameter-mm D]
(--data: another campaign in the same format, e.g. a Festo 20 mm one; --outer-diameter-mm: its
muscles' outer diameter, read from a name like ``festo20_isometric.csv`` when not given.)
"""

from __future__ import annotations

import sys

import numpy as np
import pandas as pd

import real_campaign

from mckibben.fit.hysteresis import fit_prandtl_ishlinskii
from mckibben.models.hysteresis import apply, descended_state, thresholds_uniform

N_PLAYS, SPAN_PA, KNOTS = 2, 40e3, 8
GRID_KPA = np.arange(100.0, 560.0, 10.0)
# The campaign and what is read from it, set by use() (main; bench_hysteresis_gap.py reads them here).
CAMPAIGN = real_campaign.parse([])[1]
SOURCE = CAMPAIGN.path
RAIL_N = -np.inf  # the load cell's floor + 0.01 N: rows at or below are at the rail (PROVENANCE.md,
# RESULTS.md "sensor realities"); -inf: the campaign has no rail, every row kept
FIT_TRIALS: tuple[int, ...] = ()
TEST_TRIAL = -1


def use(campaign: real_campaign.Campaign) -> None:
    """Set the module's campaign, its rail and its trials (the file must exist)."""
    global CAMPAIGN, SOURCE, RAIL_N, FIT_TRIALS, TEST_TRIAL
    CAMPAIGN, SOURCE = campaign, campaign.path
    floor = real_campaign.rail_floor(campaign.path)
    RAIL_N = -np.inf if floor is None else floor + 0.01
    FIT_TRIALS, TEST_TRIAL = real_campaign.trials(pd.read_csv(campaign.path))


def _sequence(run: pd.DataFrame) -> pd.DataFrame:
    """One trial in time order: inflate bins rising, then deflate bins falling."""
    up = run[run.phase == "inflate"].sort_values("pressure_kPa")
    dn = run[run.phase == "deflate"].sort_values("pressure_kPa", ascending=False)
    return pd.concat([up, dn])


def _width(p_kpa, value, phase) -> float:
    """Mean over the grid of deflate − inflate, where both branches have data above the floor. [N]"""
    out = []
    for ph in ("inflate", "deflate"):
        sel = phase == ph
        order = np.argsort(p_kpa[sel])
        out.append((p_kpa[sel][order], value[sel][order]))
    lo = max(out[0][0].min(), out[1][0].min())
    hi = min(out[0][0].max(), out[1][0].max())
    g = GRID_KPA[(GRID_KPA >= lo) & (GRID_KPA <= hi)]
    if g.size == 0:
        return float("nan")
    return float(np.mean(np.interp(g, *out[1]) - np.interp(g, *out[0])))


def real_data() -> list[dict]:
    """Per (muscle, held length): the PI fit, held-out RMSE, loop width before/after."""
    data = pd.read_csv(SOURCE)
    rows = []
    r = thresholds_uniform(N_PLAYS, SPAN_PA)
    for (cut, held), g in data.groupby(["cut_length_cm", "held_length_mm"]):
        seqs = {t: _sequence(g[g.trial == t]) for t in sorted(g.trial.unique())}
        fit_runs = [seqs[t] for t in FIT_TRIALS if t in seqs]
        if TEST_TRIAL not in seqs or not fit_runs:
            continue
        tr = pd.concat(fit_runs)
        u = tr.pressure_kPa.to_numpy() * 1e3
        y = tr.force_N.to_numpy()
        mask = y > RAIL_N
        res = fit_prandtl_ishlinskii(u, y, r, run=tr.trial.to_numpy(), start="descended", mask=mask,
                                     input_unit="Pa", output_unit="N", source=SOURCE.name, output_knots=KNOTS)
        te = seqs[TEST_TRIAL]
        ut = te.pressure_kPa.to_numpy() * 1e3
        yt = te.force_N.to_numpy()
        pred, _ = apply(res.model, ut, descended_state(r, float(ut[0])))
        ok = yt > RAIL_N
        ph = te.phase.to_numpy()
        p_k = te.pressure_kPa.to_numpy()
        # a static map (one cubic through both branches of the fitting trials) for comparison
        cub = np.polyfit(u[mask], y[mask], 3)
        static = np.polyval(cub, ut)
        peak = float(np.max(yt))
        rows.append({
            "muscle": f"{cut} cm", "held_mm": held, "peak_N": peak,
            "width_before_N": _width(p_k[ok], yt[ok], ph[ok]),
            "width_after_N": _width(p_k[ok], (yt - pred)[ok], ph[ok]),
            "rmse_static_N": float(np.sqrt(np.mean((yt - static)[ok] ** 2))),
            "rmse_pi_N": float(np.sqrt(np.mean((yt - pred)[ok] ** 2))),
            "fit_rmse_N": res.fit.residual_rms, "w0_over_se": float(res.model.weights[0] / res.model.stderr[0])
            if np.isfinite(res.model.stderr[0]) and res.model.stderr[0] > 0 else float("nan"),
            "flags": ",".join(res.fit.flags),
        })
    return rows


def simulator() -> dict:
    """The seed paper's miniature on the plant simulator: the three feed-forwards' errors."""
    from mckibben.experiments import hysteresis_compensation

    return hysteresis_compensation(4.0).summary()


def main(argv: list[str]) -> int:
    argv, campaign = real_campaign.parse(argv)
    if "--real-only" not in argv:
        s = simulator()
        pi = s["prandtl_ishlinskii"]
        print("simulator (period 4 s, sweep 32 s): RMS / max length error, mm")
        print(f"| single cubic | {s['single_cubic']['rms_error_m'] * 1e3:.2f} | {s['single_cubic']['max_error_m'] * 1e3:.2f} |")
        print(f"| branches | {s['branches']['rms_error_m'] * 1e3:.2f} | {s['branches']['max_error_m'] * 1e3:.2f} |")
        print(f"| Prandtl–Ishlinskii inverse | {pi['rms_error_m'] * 1e3:.2f} | {pi['max_error_m'] * 1e3:.2f} |")
        print(f"PI fit residual {pi['fit_rmse_Pa'] / 1e3:.1f} kPa, weights {np.round(pi['weights'], 3).tolist()}")
    if not campaign.path.exists():
        print(f"skipped: {campaign.path} is absent (real data are not bundled)")
        return 0
    use(campaign)
    rows = real_data()
    print("\n| muscle | held mm | peak N | loop width before N | after N | held-out RMSE static N | PI N |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['muscle']} | {r['held_mm']:.2f} | {r['peak_N']:.1f} | {r['width_before_N']:.2f} | "
              f"{r['width_after_N']:.2f} | {r['rmse_static_N']:.2f} | {r['rmse_pi_N']:.2f} |")
    wb = np.array([r["width_before_N"] for r in rows])
    wa = np.array([r["width_after_N"] for r in rows])
    rs = np.array([r["rmse_static_N"] for r in rows])
    rp = np.array([r["rmse_pi_N"] for r in rows])
    print(f"\nmedian |width| before {np.nanmedian(np.abs(wb)):.2f} N, after {np.nanmedian(np.abs(wa)):.2f} N; "
          f"median held-out RMSE static {np.median(rs):.2f} N, PI {np.median(rp):.2f} N; "
          f"{len(rows)} (muscle, length) pairs")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
