"""A/B benchmark of the plant's integrator: two source trees, interleaved, on the same machine.

A change to the hot loop (``mckibben.plant.physics``) is measured against the tree before it, not
against a number recorded on another day: each round runs one process per tree, in turn, so a
machine shared with other work slows both alike. Each process times :func:`mckibben.plant.simulate`
(the default rig, the inlet open at 200 counts, the pressure recorded) for one rig over 1 s and
for 640 rigs (ten blocks) over 0.5 s, best of 7 after a warm-up, and, with a play on the pressure
(``play_threshold``, issue #33), the same runs again.

Run: ``python benchmarks/bench_plant_ab.py OLD_SRC NEW_SRC [--rounds 3]`` (each ``*_SRC`` a ``src``
folder holding ``mckibben``; e.g. a ``git worktree`` of the commit before). About 10 s a round.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

RUNS = ((1, 1.0), (640, 0.5))  # (rigs, simulated seconds)


def _measure() -> str:
    import numpy as np  # noqa: F401  (imported before timing, as mckibben does)

    from mckibben.plant import PlantParams, simulate

    out = []
    for label, fields in (("no play", {}), ("play 30 kPa", {"play_threshold": 30e3})):
        if not set(fields) <= set(PlantParams.__dataclass_fields__):  # a tree before the field
            continue
        plant = PlantParams(**fields)
        for n, seconds in RUNS:
            simulate(plant, 0.01, inlet=200, n=n)  # compile / load the cache
            best = min(_timed(simulate, plant, seconds, n) for _ in range(7))
            out.append(f"{label}, N={n}: {best / (n * seconds * 1e4) * 1e9:.1f}")
    return "; ".join(out) + " ns/instance-substep"


def _timed(simulate, plant, seconds, n) -> float:
    t0 = time.perf_counter()
    simulate(plant, seconds, inlet=200, n=n, record=("pressure",))
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("src", nargs="*", help="src folders to compare (each holds the mckibben package)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        print(_measure())
        return
    for r in range(a.rounds):
        for src in a.src:
            env = {**os.environ, "PYTHONPATH": os.path.abspath(src)}
            run = subprocess.run([sys.executable, __file__, "--child"], env=env, capture_output=True, text=True,
                                 check=True)
            print(f"round {r + 1} {src}: {run.stdout.strip()}", flush=True)


if __name__ == "__main__":
    main()
