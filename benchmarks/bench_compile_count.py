"""Diagnostic of a cold command's compilations: how many times each kernel is compiled (issue 34).

Numba compiles a kernel once per signature; a constant argument passed from one kernel to another
(``clamp(x, -TERM_LIM, TERM_LIM)``) is typed as an integer *literal*, so each distinct constant is
a signature of its own and the callee is compiled again for it (on purpose only for the plant's
``rhs``: one copy per Runge-Kutta stage, which LLVM vectorizes). For each command this runs the
command in a fresh process with an empty cache folder (``MCKIBBEN_CACHE_DIR``) and the background
warm-up off (so this process compiles everything), then prints, per kernel compiled more than once,
the number of overloads and how many of them have a literal argument type, and the totals.

Run: ``python benchmarks/bench_compile_count.py [--all]`` (``--all`` lists every kernel; about
10-20 s per command).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

COMMANDS = [
    ["control", "step", "--controller", "smc", "--law", "paper", "--beta", "150", "--target", "0.55MPa"],
    ["simulate", "open-loop", "--valve", "117"],
]

# Runs one command in this process, then reports every dispatcher's overloads as JSON on stderr's last line.
RUN = """
import io, json, sys, contextlib
from numba.core import types as T
from mckibben.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    status = main(sys.argv[1:])
from mckibben import _jit
rows = []
for d in _jit.DISPATCHERS:
    sigs = list(d.overloads)
    if sigs:
        rows.append([f"{d.py_func.__module__}.{d.py_func.__qualname__}", len(sigs),
                     sum(any(isinstance(a, T.Literal) for a in s) for s in sigs),
                     sum(d.stats.cache_misses.values())])
print(json.dumps({"status": status, "kernels": rows}))
"""


def count(argv: list[str], cache: Path, src: str | None = None) -> dict:
    """Overloads per kernel after one cold run of ``mckibben <argv>`` (a fresh process, empty cache)."""
    env = dict(os.environ, MCKIBBEN_CACHE_DIR=str(cache), MCKIBBEN_BACKGROUND_WARM="0")
    if src:
        env["PYTHONPATH"] = src
    r = subprocess.run([sys.executable, "-c", RUN, *argv], env=env, capture_output=True, text=True, check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--all", action="store_true", help="list every kernel, not only those compiled more than once")
    ap.add_argument("--src", help="a source tree's src folder to put first on PYTHONPATH")
    args = ap.parse_args()
    for argv in COMMANDS:
        tmp = Path(tempfile.mkdtemp(prefix="bench-count-"))
        try:
            result = count(argv, tmp, args.src)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        rows = sorted(result["kernels"], key=lambda r: (-r[1], r[0]))
        print(f"\n`mckibben {' '.join(argv)}` (exit {result['status']}), cold, no background warm-up")
        print(f"kernels: {len(rows)}; overloads: {sum(r[1] for r in rows)}; with a literal argument: "
              f"{sum(r[2] for r in rows)}; compiled here: {sum(r[3] for r in rows)}\n")
        print("| kernel | overloads | with a literal argument | compiled |")
        print("| --- | --- | --- | --- |")
        for name, n, lit, comp in rows:
            if args.all or n > 1:
                print(f"| `{name}` | {n} | {lit} | {comp} |")


if __name__ == "__main__":
    main()
