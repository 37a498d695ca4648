"""How long a law's statics take: length under a load by the one solver (law_statics.rising_root).

Times, best of ``--repeat`` runs after one warm-up call:

- a muscle file's statics (:class:`mckibben.models.law_statics.LawMuscle`, the tool's muscles):
  ``length_for_pressure`` of the Tondu-Lopez law fitted to the bundled commercial table, N points;
- the braid laws' ``length_under_load`` (Chou-Hannaford, wall-corrected), N points;
- ``mckibben.models.length`` for every law with a published set on the catalogue's mpam143.

Both of the first two exist before the solver was shared, so the script runs against an older
source tree too (``PYTHONPATH=OLD/src``); the third is skipped where ``models.length`` does not
take the law.

Usage: ``PYTHONPATH=src python benchmarks/bench_law_statics.py --repeat 5``
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

import mckibben
from mckibben.data import read_muscle, read_table
from mckibben.datasets import get_muscle
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.muscle_file import save_muscle_file
from mckibben.models import force_laws, length
from mckibben.models.muscle import Muscle
from mckibben.models.physical import length_under_load, miniature_geometry


def best(call, repeat: int) -> float:
    call()  # warm-up: compiled kernels, SciPy imports
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        call()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--tmp", default="/tmp/bench_law_statics.toml")
    a = ap.parse_args()
    print(f"mckibben from {mckibben.__file__}")
    folder = BUNDLED_ISOMETRIC / "commercial10"
    spec = read_muscle(folder / "muscle.toml")
    fit = fit_isometric(read_table(folder / "isometric.csv"), spec, "tondu-lopez")
    m = Muscle.from_spec(read_muscle(save_muscle_file(a.tmp, spec, fit)))
    rng = np.random.default_rng(0)
    print("| what | N | best [ms] | per point [µs] |\n| --- | --- | --- | --- |")
    for n in (1, 100, 10_000, 100_000):
        p = rng.uniform(0.1e6, 0.6e6, n)
        w = rng.uniform(10.0, 200.0, n)
        t = best(lambda: m.length_for_pressure(p, w), a.repeat)
        print(f"| muscle file (tondu-lopez) length_for_pressure | {n} | {t * 1e3:.3f} | {t / n * 1e6:.3f} |")
    for model in ("chou-hannaford", "wall-corrected"):
        g = miniature_geometry(0.097, wall=model == "wall-corrected")
        for n in (1, 10_000):
            p = rng.uniform(0.1e6, 0.8e6, n)
            w = rng.uniform(0.05, 3.0, n)
            t = best(lambda: length_under_load(p, w, g, model), a.repeat)
            print(f"| length_under_load {model} | {n} | {t * 1e3:.3f} | {t / n * 1e6:.3f} |")
    cat = get_muscle("mpam143")
    for name in force_laws():
        p = rng.uniform(0.3e6, 0.8e6, 10_000)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t = best(lambda: length(p, 0.6, cat, model=name), a.repeat)
        except Exception as exc:  # an older tree: models.length does not take this law
            print(f"| models.length {name} | 10000 | not available ({type(exc).__name__}) | |")
            continue
        print(f"| models.length {name} | 10000 | {t * 1e3:.3f} | {t / 1e4 * 1e6:.3f} |")


if __name__ == "__main__":
    main()
