"""Fill identification on real fills of a Festo 20 mm muscle (not bundled, not shipped).

Reads ``../shared/data/real/festo20_fill.csv`` beside the repository (eight fills from a 620 kPa
supply; PROVENANCE.md there) and skips cleanly when it is absent. It writes the fills as a lab's
step log (``time_s``, ``pressure_kPa``, ``trial``; no valve column was logged, so each fill starts
at its first sample) into a temporary folder and runs, as a lab would,

    mckibben identify FILLS.csv --order fill --supply 620kPa --json

then prints per trial the supply the fit used (and where from), the RMS residual, the critical
ratio b, the volume growth, the runs test's z, the flags, and the groups the trials were pooled in.

Run: python benchmarks/bench_real_fill.py
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

import pandas as pd

from mckibben.cli import main

REAL = Path(__file__).resolve().parents[2] / "shared/data/real"
SOURCE = REAL / "festo20_fill.csv"


def main_bench() -> int:
    if not SOURCE.is_file():
        print(f"skipped: {SOURCE} is absent (real third-party data, not shipped)")
        return 0
    d = pd.read_csv(SOURCE).rename(columns={"experiment": "trial"})
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "festo20_fills.csv"
        d[["time_s", "pressure_kPa", "trial"]].to_csv(log, index=False)
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["identify", str(log), "--order", "fill", "--supply", "620kPa", "--json"])
        if code != 0:
            raise SystemExit(f"identify exited {code}: {err.getvalue().strip()}")
    res = json.loads(out.getvalue())
    print("mckibben identify festo20_fills.csv --order fill --supply 620kPa")
    print(" trial  supply kPa (from)     plateau kPa  rmse kPa      b  growth  runs z  flags")
    at_bound = 0
    for tr in res["trials"]:
        m = tr["models"][0]
        plateau = m.get("plateau_Pa")
        at_bound += any(f.startswith("b_at_") for f in m["flags"])
        print(f" {tr['trial']:>5}  {m['p_supply_Pa'] / 1e3:7.1f} ({m.get('supply_source') or 'given':<8})"
              f"  {(plateau or float('nan')) / 1e3:11.1f}  {m['rmse_Pa'] / 1e3:8.2f}  {m['b']:5.3f}"
              f"  {m.get('volume_growth', 0.0):6.2f}  {m['residual_runs_z']:6.1f}  {', '.join(m['flags']) or 'none'}")
    print(f" b at a bound in {at_bound} of {len(res['trials'])} trials")
    pooled = res["pooled"]["fill"]
    labels = [tr["trial"] for tr in res["trials"]]
    for g in pooled.get("groups") or [dict(pooled, members=list(range(len(labels))))]:
        who = ", ".join(str(labels[i]) for i in g["members"])
        tau = g.get("tau_fill_s")
        t50 = g.get("half_rise_s")
        print(f" pooled trials {who}: tau_fill "
              + (f"{tau['mean']:.3g} s ± {tau['stderr']:.2g} s" if tau else "(one trial, not pooled)")
              + (f", half-rise {min(t50):.3g}–{max(t50):.3g} s" if t50 else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main_bench())
