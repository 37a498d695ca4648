"""Import time of the quick commands for two source trees, measured alternately (the machine's load hits both).

For each command, ``python -X importtime -m mckibben.cli ARGS`` runs N times per tree, the trees
alternating; the report gives the median and the minimum of the summed top-level import times (as
:mod:`bench_imports` sums them). Use it to compare a branch with main: export each with
``git archive REV src | tar -x -C DIR`` and pass the two ``DIR/src``.

Run: ``python benchmarks/bench_import_compare.py BEFORE_SRC AFTER_SRC [N]`` (default N = 9).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys

COMMANDS = {
    "--version": ["--version"],
    "--help": ["--help"],
    "predict length": ["predict", "length", "--muscle", "mpam97", "--pressure", "0.8MPa", "--load", "0.6N"],
}


def import_seconds(src: str, args: list[str]) -> float:
    env = dict(os.environ, PYTHONPATH=src)
    r = subprocess.run([sys.executable, "-X", "importtime", "-m", "mckibben.cli", *args], capture_output=True,
                       text=True, env=env)
    if r.returncode != 0:
        raise SystemExit(r.stderr[-2000:])
    total = 0
    for line in r.stderr.splitlines():
        if line.startswith("import time:") and "cumulative" not in line:
            _, cumulative, name = line.split("|")
            if not name.startswith("  "):  # depth 0: a top-level import of this process
                total += int(cumulative)
    return total / 1e6


def main() -> None:
    before, after = sys.argv[1], sys.argv[2]
    n = int(sys.argv[3]) if len(sys.argv) > 3 else 9
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; {n} runs per tree\n")
    print("| command | before: median (min) [s] | after: median (min) [s] |")
    print("| --- | --- | --- |")
    for label, args in COMMANDS.items():
        times: dict[str, list[float]] = {before: [], after: []}
        for _ in range(n):
            for src in (before, after):
                times[src].append(import_seconds(src, args))
        cells = [f"{statistics.median(times[s]):.3f} ({min(times[s]):.3f})" for s in (before, after)]
        print(f"| `mckibben {label}` | {cells[0]} | {cells[1]} |", flush=True)


if __name__ == "__main__":
    main()
