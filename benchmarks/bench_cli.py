"""Benchmark of what a user waits for: whole commands, each a fresh process (issue 21).

For each command: the wall time of a first run after the kernel cache is wiped (it compiles), and
of later runs (the cache is warm: the best of ``--repeat``), beside the yardstick
``python -c "import numpy, scipy.optimize, pandas"`` timed in the same run, and the ratio to it.
Then ``mckibben sweep run`` of the 100,000-plant step sweep beside the C loop of the same physics
(``plant_loop.c``, structure of arrays, SIMD, OpenMP on every core: ``bench_plant.py`` builds it)
for the same number of instance-substeps.

The cache is a folder of its own (``MCKIBBEN_CACHE_DIR``), so the user's cache is not touched.

Run: ``python benchmarks/bench_cli.py [--repeat 3] [--no-cold] [--no-sweep]`` (a few minutes).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

YARDSTICK = [sys.executable, "-c", "import numpy, scipy.optimize, pandas"]
MCK = [sys.executable, "-m", "mckibben.cli"]
COMMANDS = [
    ("mckibben --version", [*MCK, "--version"]),
    ("mckibben predict length --muscle mpam97 --pressure 0.8MPa --load 0.6N",
     [*MCK, "predict", "length", "--muscle", "mpam97", "--pressure", "0.8MPa", "--load", "0.6N"]),
    ("mckibben predict force --model tondu-lopez --pressure 0.5MPa",
     [*MCK, "predict", "force", "--model", "tondu-lopez", "--pressure", "0.5MPa"]),
    ("mckibben simulate open-loop --valve 117", [*MCK, "simulate", "open-loop", "--valve", "117"]),
    ("mckibben control step --controller smc --law paper --beta 150 --target 0.55MPa",
     [*MCK, "control", "step", "--controller", "smc", "--law", "paper", "--beta", "150", "--target", "0.55MPa"]),
    ("mckibben control fig13", [*MCK, "control", "fig13"]),
    ("mckibben tool track --path circle:radius=5mm,period=2s",
     [*MCK, "tool", "track", "--path", "circle:radius=5mm,period=2s"]),
    ("python -c 'mckibben.step_response()'",
     [sys.executable, "-c", "import mckibben; mckibben.step_response('smc', law='paper', beta=150)"]),
]



def wall(cmd, env, cwd=None) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, env=env, cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="warm runs per command (the best is reported)")
    ap.add_argument("--no-cold", action="store_true", help="skip the first runs after a cache wipe")
    ap.add_argument("--no-sweep", action="store_true", help="skip the 100,000-plant sweep")
    ap.add_argument("--runs", type=int, default=100_000, help="plants in the sweep")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-cli-"))
    env = dict(os.environ, MCKIBBEN_CACHE_DIR=str(tmp / "cache"))
    try:
        print(f"load average at start: {load()}; {os.cpu_count()} CPUs")
        wall(YARDSTICK, env)
        yard = min(wall(YARDSTICK, env) for _ in range(args.repeat))
        print(f"yardstick `python -c \"import numpy, scipy.optimize, pandas\"`: {yard:.2f} s\n")
        print("| command | first run, cold cache [s] | later run [s] | later / yardstick |")
        print("| --- | --- | --- | --- |")
        for label, cmd in COMMANDS:
            cold = float("nan")
            if not args.no_cold:
                shutil.rmtree(tmp / "cache", ignore_errors=True)
                cold = wall(cmd, env)
            warm = min(wall(cmd, env) for _ in range(args.repeat))
            print(f"| `{label}` | {cold:.2f} | {warm:.2f} | {warm / yard:.2f}x |", flush=True)
        if args.no_sweep:
            return
        samples = args.runs // 4
        sys.path.insert(0, str(HERE))
        from bench_sweep import TEMPLATE  # the same sweep as the in-process benchmark
        from bench_plant import SUB, build_c, run_c  # the C loop and its build

        (tmp / "sweep.toml").write_text(TEMPLATE.format(samples=samples))
        wall([*MCK, "doctor", "--json"], env)  # a warm cache, as for the commands above
        sweep_times = []
        for _ in range(2):
            shutil.rmtree(tmp / "out", ignore_errors=True)
            sweep_times.append(wall([*MCK, "sweep", "run", "sweep.toml", "--out", "out", "--json"], env, cwd=tmp))
        exes = build_c(tmp)
        steps = 200
        c_best = min(run_c(exes["exact"], "simd", samples * 4, steps)[0] for _ in range(2))
        print(f"\n`mckibben sweep run` of {samples * 4:,} plants, 0.2 s each ({steps} periods x {SUB} RK4 substeps), "
              f"whole command: {min(sweep_times):.2f} s (runs: {', '.join(f'{t:.2f}' for t in sweep_times)})")
        print(f"C SoA+SIMD+OpenMP loop, same instance-substeps, exact IEEE: {c_best:.2f} s; "
              f"ratio {min(sweep_times) / c_best:.2f}x")
        print(f"load average at end: {load()}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
