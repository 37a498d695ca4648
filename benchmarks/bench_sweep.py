"""Benchmark: simulations per second of a 100,000-plant step sweep, in-process and on a local
two-worker Dask cluster (issue 9).

The sweep: the paper's sliding-mode law at four β (120–180 counts) × 25,000 random plants each
(supply 0.6–1.0 MPa, load 0–3 N, dead band ±30 %, valve conductance ±30 %), a step to 0.55 MPa
simulated for 0.2 s (200 control periods, RK4 at 10 kHz), step metrics kept; chunks of 2,000.

The in-process run also reports its CPU time (all threads) and how it splits between the
simulator (``mckibben.plant.simulate``, timed around each chunk's call) and the rest (design rows,
controller packing, metrics, Parquet): the split is less affected by a shared machine's load than
the wall clock, and the load average is printed with it.

Run: ``python benchmarks/bench_sweep.py [--runs 100000]`` (a few minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import mckibben.sweep.run as sweep_run
from mckibben.sweep import load_sweep, read_results, run_sweep

TEMPLATE = """
[sweep]
seed = 2026
samples = {samples}
chunk_size = 2000
[scenario]
kind = "step"
target = "0.55MPa"
duration = "0.2s"
[plant]
supply_pressure = {{ uniform = ["0.6MPa", "1.0MPa"] }}
load_force = {{ uniform = ["0N", "3N"] }}
dead_band = {{ uniform = [0.44, 0.82] }}
valve_conductance = {{ uniform = [1.4e-10, 2.6e-10] }}
[controller]
kind = "smc"
g = 0
beta = {{ grid = [120, 135, 150, 180] }}
[metrics]
keep = ["time_constant_s", "overshoot_pct", "steady_state_error_Pa", "valve_effort_counts"]
"""


class _Timed:
    """``mckibben.plant.simulate`` with its wall-clock and CPU time summed, as the sweep calls it
    (``mckibben.sweep.run.simulate``). With two chunks in flight the process's CPU time during a call
    includes the other chunk's Python, so the split of CPU time is approximate."""

    def __init__(self, simulate):
        self.simulate, self.wall, self.cpu = simulate, 0.0, 0.0

    def __call__(self, *args, **kwargs):
        w, c = time.perf_counter(), time.process_time()
        try:
            return self.simulate(*args, **kwargs)
        finally:
            self.wall += time.perf_counter() - w
            self.cpu += time.process_time() - c


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=100_000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        toml = Path(d) / "bench.toml"
        toml.write_text(TEMPLATE.format(samples=args.runs // 4))
        sweep = load_sweep(toml)
        # warm the compile cache outside the timing
        warm = Path(d) / "warm.toml"
        warm.write_text(TEMPLATE.format(samples=1))
        run_sweep(load_sweep(warm), Path(d) / "warm")
        rows = []
        for label, kw in (("in-process", {}), ("local cluster, 2 workers", {"workers": 2})):
            timed = _Timed(sweep_run.simulate)
            if not kw:
                sweep_run.simulate = timed  # the name the sweep calls (imported at its module level)
            load = os.getloadavg()[0]
            t, c = time.perf_counter(), time.process_time()
            try:
                stats = run_sweep(sweep, Path(d) / label.split(",")[0].replace(" ", "-"), **kw)
            finally:
                sweep_run.simulate = timed.simulate
            sec, cpu = time.perf_counter() - t, time.process_time() - c
            rows.append((label, stats["computed_runs"], sec, stats["computed_runs"] / sec))
            if not kw:
                split = (sec, cpu, timed.wall, timed.cpu, load, os.getloadavg()[0])
        a = read_results(Path(d) / "in-process")
        b = read_results(Path(d) / "local-cluster")
        same = a.equals(b)
    print(f"{'where':<26} | {'runs':>7} | {'seconds':>8} | {'sims/s':>7}")
    for label, runs, sec, rate in rows:
        print(f"{label:<26} | {runs:>7} | {sec:>8.1f} | {rate:>7.0f}")
    print(f"results identical in-process and on the cluster: {same}")
    sec, cpu, sim_wall, sim_cpu, load0, load1 = split
    print(f"in-process: wall {sec:.1f} s = simulate() {sim_wall:.1f} s + the rest {sec - sim_wall:.1f} s; "
          f"CPU {cpu:.1f} s = simulate() {sim_cpu:.1f} s + the rest {cpu - sim_cpu:.1f} s "
          f"(load average {load0:.2f} before, {load1:.2f} after)")


if __name__ == "__main__":
    main()
