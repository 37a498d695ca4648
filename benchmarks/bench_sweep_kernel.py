"""Benchmark: the 100,000-plant sweep's simulations alone against the C loop (issue 21, item 5).

The sweep of ``bench_sweep.py`` (the paper's sliding-mode law at four β × 25,000 random plants, a
step to 0.55 MPa for 0.2 s, chunks of 2,000), with every chunk's design rows and controller packing
done beforehand, so that only :func:`mckibben.plant.simulate` is timed: closed loop as the sweep
runs it, then open loop replaying each chunk's recorded valve commands (the plant physics without
the controller core's mirror). The C SoA+SIMD+OpenMP loop of ``bench_plant.py`` (same
instance-substeps) runs right after each pass. What is left between the simulator and the whole
``mckibben sweep run`` (``bench_cli.py``) is the process start, Parquet and the chunks' Python.

Run: ``python benchmarks/bench_sweep_kernel.py [--passes 2] [--samples 25000] [--no-c]`` (about a minute on 2
cores, warm cache; ``--no-c`` skips the C loop, to compare source trees put first on ``PYTHONPATH``).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_plant import build_c, run_c  # noqa: E402
from bench_sweep import TEMPLATE  # noqa: E402

import mckibben.sweep.run as R  # noqa: E402
from mckibben.plant import simulate  # noqa: E402
from mckibben.sweep import load_sweep  # noqa: E402

RECORD = ("pressure", "inlet", "bleed")  # what the sweep records


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--passes", type=int, default=2)
    ap.add_argument("--samples", type=int, default=25_000, help="plants per beta (four betas)")
    ap.add_argument("--no-c", action="store_true", help="skip the C loop")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        toml = Path(d) / "sweep.toml"
        toml.write_text(TEMPLATE.format(samples=args.samples))
        sweep = load_sweep(toml)
        scenario = sweep.scenario
        steps = int(round(scenario["duration"] / 1e-3))
        ref = R._reference(scenario, steps)
        chunks = [sweep.chunk(k) for k in range(sweep.n_chunks)]
        prepared = [(R._plants(rows), R._controllers(rows, "smc"), len(rows)) for rows in chunks]
        plants, ctrl, n = prepared[0]  # load (or compile) both runners before timing
        r = simulate(plants, steps * 1e-3, controller=ctrl, reference=ref, n=n, record=RECORD)
        simulate(plants, steps * 1e-3, inlet=r.inlet, bleed=r.bleed, n=n, record=("pressure",))
        exes = None if args.no_c else build_c(Path(d))
        print(f"{sweep.n_runs:,} plants, {steps} periods x 10 RK4 substeps")
        print("| pass | closed loop [s wall / CPU s] | open loop [s wall / CPU s] | C loop [s] | closed / C |")
        print("| --- | --- | --- | --- | --- |")
        for k in range(args.passes):
            w, c, cmds = time.perf_counter(), time.process_time(), []
            for plants, ctrl, n in prepared:
                r = simulate(plants, steps * 1e-3, controller=ctrl, reference=ref, n=n, record=RECORD)
                cmds.append((r.inlet, r.bleed))
            closed = (time.perf_counter() - w, time.process_time() - c)
            w, c = time.perf_counter(), time.process_time()
            for (plants, _, n), (a, b) in zip(prepared, cmds):
                simulate(plants, steps * 1e-3, inlet=a, bleed=b, n=n, record=("pressure",))
            opened = (time.perf_counter() - w, time.process_time() - c)
            cw = float("nan") if exes is None else run_c(exes["exact"], "simd", sweep.n_runs, steps)[0]
            print(f"| {k + 1} | {closed[0]:.2f} / {closed[1]:.2f} | {opened[0]:.2f} / {opened[1]:.2f} | {cw:.2f} "
                  f"| {closed[0] / cw:.2f}x |", flush=True)


if __name__ == "__main__":
    main()
