"""Benchmark the tool's batch computations: forward equilibrium (workspace), IK + static inverse.

Also for a tool of a fitted muscle file (the spring law fitted to the bundled SYNTHETIC
commercial campaign), whose statics solve the law by bracketed root finding.

Run: python benchmarks/bench_tool.py
"""

from __future__ import annotations

import timeit

import numpy as np

from mckibben.datasets import get_muscle
from mckibben.tool.geometry import Tool
from mckibben.tool.kinematics import lengths_from_tip, tip_from_lengths
from mckibben.tool.statics import pressures_for_tip, tip_from_pressures
from mckibben.tool.workspace import sample_workspace


def best(stmt, number=1, repeat=5):
    return min(timeit.repeat(stmt, number=number, repeat=repeat)) / number


def main():
    tool = Tool(get_muscle("mpam117"))
    rng = np.random.default_rng(0)
    lengths = 0.115 + rng.uniform(-0.01, 0.01, size=(100_000, 3))
    t = best(lambda: lengths_from_tip(tip_from_lengths(lengths, 4e-3, 12), 4e-3, 12))
    print(f"kinematics FK+IK, 100000 poses: {t * 1e3:.1f} ms ({t / 1e5 * 1e9:.0f} ns/pose)")
    for n in (15, 21):
        t = best(lambda: sample_workspace(tool, n))
        print(f"workspace {n}^3 = {n**3} equilibria: {t * 1e3:.1f} ms ({t / n**3 * 1e6:.1f} us/pose)")
    tips = tip_from_pressures(rng.uniform(0, 0.8e6, size=(1000, 3)), tool).tip
    t = best(lambda: pressures_for_tip(tips, tool), repeat=3)
    print(f"pressures_for_tip, 1000 tips: {t * 1e3:.1f} ms ({t / 1e3 * 1e6:.0f} us/tip; 3 cubic roots each)")
    file_tool()


def file_tool():
    """The same on a tool of a muscle file (spring law fitted to the bundled commercial campaign)."""
    import tempfile
    from pathlib import Path

    from mckibben.data import read_muscle, read_table
    from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
    from mckibben.fit.isometric import fit_isometric
    from mckibben.fit.muscle_file import save_muscle_file
    from mckibben.tool import make_tool

    folder = BUNDLED_ISOMETRIC / "commercial10"
    table, spec = read_table(folder / "isometric.csv"), read_muscle(folder / "muscle.toml")
    with tempfile.TemporaryDirectory() as tmp:
        path = save_muscle_file(Path(tmp) / "mine.toml", spec, fit_isometric(table, spec, "spring"))
        tool = make_tool(muscle_file=path)
    for n in (15, 21):
        t = best(lambda: sample_workspace(tool, n))
        print(f"muscle file: workspace {n}^3 = {n**3} equilibria: {t * 1e3:.1f} ms ({t / n**3 * 1e6:.1f} us/pose)")
    rng = np.random.default_rng(0)
    tips = tip_from_pressures(rng.uniform(0, tool.p_max, size=(1000, 3)), tool).tip
    t = best(lambda: pressures_for_tip(tips, tool), repeat=3)
    print(f"muscle file: pressures_for_tip, 1000 tips: {t * 1e3:.1f} ms ({t / 1e3 * 1e6:.0f} us/tip; "
          "3 bracketed roots each)")


if __name__ == "__main__":
    main()
