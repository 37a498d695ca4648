"""What each command imports: ``python -X importtime`` per command, summed, and the heavy packages it loads.

For each command, a fresh process runs it under ``-X importtime``; the report gives the summed
import time of the top-level imports (self + children, as ``importtime`` prints them) and which of
Numba, python-control, SciPy, pandas, Matplotlib and Dask were imported at all. Import times vary
with the machine's load: compare figures taken in the same run.

Run: ``python benchmarks/bench_imports.py`` (the warm kernel cache is used; run a command once first).
"""

from __future__ import annotations

import os
import subprocess
import sys

HEAVY = ("numba", "control", "scipy", "pandas", "matplotlib", "dask")
COMMANDS = [
    ["--version"],
    ["--help"],
    ["predict", "length", "--muscle", "mpam97", "--pressure", "0.8MPa", "--load", "0.6N"],
    ["predict", "force", "--model", "tondu-lopez", "--pressure", "0.5MPa"],
    ["simulate", "open-loop", "--valve", "117"],
    ["control", "step", "--controller", "smc", "--law", "paper", "--beta", "150", "--target", "0.55MPa"],
    ["control", "fig13"],
    ["tool", "track", "--path", "circle:radius=5mm,period=2s"],
]


def profile(args: list[str]) -> tuple[float, list[str]]:
    r = subprocess.run([sys.executable, "-X", "importtime", "-m", "mckibben.cli", *args], capture_output=True,
                       text=True, env=os.environ)
    total, loaded = 0, set()
    for line in r.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = line.split("|")
        if not name.startswith("  "):  # depth 0: a top-level import of this process
            total += int(cumulative)
        loaded.add(name.strip().split(".")[0])
    return total / 1e6, [h for h in HEAVY if h in loaded]


def main() -> None:
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
    print("| command | imports [s] | heavy packages imported |")
    print("| --- | --- | --- |")
    for args in COMMANDS:
        seconds, heavy = profile(args)
        print(f"| `mckibben {' '.join(args)}` | {seconds:.2f} | {', '.join(heavy) or '–'} |", flush=True)


if __name__ == "__main__":
    main()
