"""Benchmark of the compile layer's own cost: the same kernels compiled through two source trees.

A cold command's time depends on how two processes (the command and its background warm-up) share
the machine, which another developer's load moves by seconds. This takes the race out: for each
source tree, in a fresh cache, one process compiles the plant's output stage (so the generated law
dispatch ``law_force`` is cached, as the command leaves it for its warm-up), then a second process
compiles the integrator ``advance`` (the warm-up's chain: ``rhs`` four times, ``rk4_step``,
``advance``). It prints that second process's user and system CPU time, its minor page faults and
its wall time, and the kernels it compiled and loaded. System time and page faults are what a
frame stack thrashing at a chunk's edge costs (``mckibben._jit._FRESH_STACK_SLOTS``); the work
itself is the same in every tree.

Run: ``python benchmarks/bench_compile_work.py [--repeat 3] TREE/src [TREE/src ...]`` (each tree's
``src`` folder, e.g. made with ``git archive <commit> src | tar -x -C TREE``; the trees alternate,
about 20 s per run).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

STAGE = """
import resource, sys, time
from mckibben import _kernels
jit = _kernels.jit()
from mckibben import plant
from numba import types as T
ph = plant.physics
f64 = T.Array(T.float64, 1, "C")
r0, w = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
if sys.argv[1] == "outputs":
    ph.outputs.compile((T.int64, f64, T.int64))
else:
    ph.advance.compile((T.int64, f64, T.int64, T.float64, T.int64))
r1, s = resource.getrusage(resource.RUSAGE_SELF), jit.compile_stats()
print(f"{r1.ru_utime - r0.ru_utime:.2f} {r1.ru_stime - r0.ru_stime:.2f} {r1.ru_minflt - r0.ru_minflt} "
      f"{time.perf_counter() - w:.2f} {s['compiled']} {s['cache_hits']}")
"""


def stage(src: str, cache: Path, name: str) -> list[str]:
    env = dict(os.environ, PYTHONPATH=src, MCKIBBEN_CACHE_DIR=str(cache), MCKIBBEN_BACKGROUND_WARM="0")
    r = subprocess.run([sys.executable, "-c", STAGE, name], env=env, capture_output=True, text=True, check=True)
    return r.stdout.split()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs="+", help="source folders (each put first on PYTHONPATH)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per tree, alternating")
    args = ap.parse_args()
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}; {os.cpu_count()} CPUs\n")
    print("| tree | advance: user CPU [s] | system CPU [s] | minor page faults | wall [s] | compiled | loaded |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for _ in range(args.repeat):
        for src in args.trees:
            tmp = Path(tempfile.mkdtemp(prefix="bench-compile-"))
            try:
                stage(src, tmp, "outputs")
                user, system, faults, wall, compiled, loaded = stage(src, tmp, "advance")
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
            print(f"| `{src}` | {user} | {system} | {int(faults):,} | {wall} | {compiled} | {loaded} |", flush=True)


if __name__ == "__main__":
    main()
