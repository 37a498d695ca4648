"""Fill identification on real fills of a Festo 20 mm muscle (not bundled, not shipped).

Reads ``../shared/data/real/festo20_fill.csv`` beside the repository (eight fills from a 620 kPa
supply; PROVENANCE.md there) and skips cleanly when it is absent. It writes the fills as a lab's
step log (``time_s``, ``pressure_kPa``, ``trial``; no valve column was logged, so each fill starts
at its first sample) into a temporary folder and runs, as a lab would,

    mckibben identify FILLS.csv --order fill --supply 620kPa --json

(the default ``--fill-shape onset``), then prints per trial the supply the fit used (and where
from), the RMS residual, the critical ratio b, the volume growth, its onset, the subsonic index m,
the runs test's z, the flags, and the groups the trials were pooled in. Then, from the library:

- every shape of :data:`mckibben.fit.step.FILL_SHAPES` on every trial: RMS, runs z, AIC;
- held out, within each group of like runs: the shape fitted on trial i predicts trial j with only
  j's time constant and dead time refitted (the valve's opening differs run to run), p0 from j's
  first sample and the supply from j's plateau (median and worst RMS over the pairs; pairs where
  the shape beats ``linear``);
- the noise at each plateau (its last 10 %, a straight line removed: ``plateau_noise_Pa`` and
  ``plateau_noise_lag1`` in identify's JSON) against the lag-1 autocorrelation of the whole
  residual of ``onset`` (``residual_lag1``): white noise at the plateau means the runs test's
  rejection is the shape, not the sensor.

Run: python benchmarks/bench_real_fill.py (about 2 min on the shared 2-core machine).
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from mckibben.cli import main
from mckibben.fit.step import FILL_SHAPES, fill_response, fit_fill, measured_plateau, runs_z

REAL = Path(__file__).resolve().parents[2] / "shared/data/real"
SOURCE = REAL / "festo20_fill.csv"


def _cli(d: pd.DataFrame) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "festo20_fills.csv"
        d[["time_s", "pressure_kPa", "trial"]].to_csv(log, index=False)
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["identify", str(log), "--order", "fill", "--supply", "620kPa", "--json"])
        if code != 0:
            raise SystemExit(f"identify exited {code}: {err.getvalue().strip()}")
    return json.loads(out.getvalue())


def _held_out(fit, t, y) -> float:
    """RMS [Pa] of ``fit``'s shape on another trial (t, y): τ and dead time refitted, p0 and supply measured."""
    from scipy import optimize

    p = fit.params
    plateau = measured_plateau(t, y, float(t[0]), float(y[0]))
    ps = plateau[0] if plateau is not None else p["p_supply_Pa"]

    def res(th):
        return fill_response(t, y[0], ps, th[0], p["b"], th[1], float(t[0]), p["volume_growth"],
                             p.get("growth_onset_Pa"), p.get("subsonic_index", 0.5), p.get("growth_span_Pa")) - y

    r = optimize.least_squares(res, [p["tau_fill_s"], p["dead_time_s"]], bounds=([1e-4, 0.0], [100.0, 1.0]),
                               x_scale=[p["tau_fill_s"], 0.01])
    return float(np.sqrt(np.mean(r.fun ** 2)))


def main_bench() -> int:
    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0
    d = pd.read_csv(SOURCE).rename(columns={"experiment": "trial"})
    res = _cli(d)
    print("mckibben identify festo20_fills.csv --order fill --supply 620kPa  (--fill-shape onset)")
    print(" trial  supply kPa (from)     plateau kPa  rmse kPa      b  growth  onset kPa     m  runs z  flags")
    at_bound = 0
    for tr in res["trials"]:
        m = tr["models"][0]
        plateau = m.get("plateau_Pa")
        at_bound += any(f.startswith("b_at_") for f in m["flags"])
        print(f" {tr['trial']:>5}  {m['p_supply_Pa'] / 1e3:7.1f} ({m.get('supply_source') or 'given':<8})"
              f"  {(plateau or float('nan')) / 1e3:11.1f}  {m['rmse_Pa'] / 1e3:8.2f}  {m['b']:5.3f}"
              f"  {m.get('volume_growth', 0.0):6.2f}  {m.get('growth_onset_Pa', float('nan')) / 1e3:9.1f}"
              f"  {m.get('subsonic_index', 0.5):4.2f}  {m['residual_runs_z']:6.1f}  {', '.join(m['flags']) or 'none'}")
    print(f" b at a bound in {at_bound} of {len(res['trials'])} trials")
    pooled = res["pooled"]["fill"]
    labels = [tr["trial"] for tr in res["trials"]]
    groups = pooled.get("groups") or [dict(pooled, members=list(range(len(labels))))]
    for g in groups:
        who = ", ".join(str(labels[i]) for i in g["members"])
        tau = g.get("tau_fill_s")
        t50 = g.get("half_rise_s")
        print(f" pooled trials {who}: tau_fill "
              + (f"{tau['mean']:.3g} s ± {tau['stderr']:.2g} s" if tau else "(one trial, not pooled)")
              + (f", half-rise {min(t50):.3g}–{max(t50):.3g} s" if t50 else ""))

    # every shape on every trial, from the library
    fills = {}
    for trial, g in d.groupby("trial"):
        g = g.groupby("time_s", as_index=False).mean()  # repeated stamps averaged, as the reader does
        fills[trial] = (g["time_s"].to_numpy(), g["pressure_kPa"].to_numpy() * 1e3)
    fits = {s: {tr: fit_fill(*fills[tr], p_supply=620e3, **kw) for tr in fills} for s, kw in FILL_SHAPES.items()}
    print("\n in-sample, per trial " + " ".join(f"{tr:>14}" for tr in fills))
    for s in FILL_SHAPES:
        print(f" {s:<10} RMS kPa  " + " ".join(f"{fits[s][tr].rmse / 1e3:14.2f}" for tr in fills))
        print(f" {'':<10} runs z   " + " ".join(f"{runs_z(fits[s][tr].residuals):14.1f}" for tr in fills))
        print(f" {'':<10} AIC      " + " ".join(f"{fits[s][tr].aic:14.1f}" for tr in fills))

    like = [[labels[i] for i in g["members"]] for g in groups if len(g["members"]) > 1]
    print("\n held out within groups " + " · ".join(", ".join(map(str, m)) for m in like)
          + ": fitted on i, on j only tau and dead time refitted")
    pairs = [(i, j) for m in like for i in m for j in m if i != j]
    held = {s: np.array([_held_out(fits[s][i], *fills[j]) for i, j in pairs]) for s in FILL_SHAPES}
    for s in FILL_SHAPES:
        wins = int(np.sum(held[s] < held["linear"]))
        print(f" {s:<10} median {np.median(held[s]) / 1e3:5.2f} kPa, worst {held[s].max() / 1e3:5.2f} kPa;"
              f" better than linear on {wins} of {len(pairs)} pairs")

    print("\n noise at the plateau (last 10 %, line removed) against the whole residual of onset (identify's JSON)")
    print(" trial  sd kPa  lag-1 ACF   residual lag-1 ACF")
    for tr in res["trials"]:
        m = tr["models"][0]
        sd, a1 = m["plateau_noise_Pa"], m["plateau_noise_lag1"]
        print(f" {tr['trial']:>5}  " + (f"{sd / 1e3:6.2f}  {a1:9.2f}" if sd is not None else f"{'(not settled)':>17}")
              + f"   {m['residual_lag1']:18.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main_bench())
