"""A reading at a sensor's rail says "at most" (or "at least"), not "equal" (issue 33, item 4).

Data generated from known parameters and clipped at a floor, as a load cell that cannot read lower
clips them; the censored fit recovers the parameters within its intervals, the fit that reads the
floor as a value does not. The command runs as a user runs it (a separate process).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.fit.core import bounded_fit, censor_hinge
from mckibben.fit.isometric import compare_isometric, fit_isometric, isometric_points
from mckibben.models.laws.virtual_work import VirtualWork

RNG = np.random.default_rng(334)


def test_the_censored_fit_recovers_a_line_clipped_at_a_floor():
    # y = 2 + 10·x with 0.5 of noise, read by a sensor whose floor is 6: a third of the points read 6
    x = np.linspace(0.0, 1.0, 90)
    y = np.maximum(2.0 + 10.0 * x + RNG.normal(0, 0.5, x.size), 6.0)
    cens = np.where(y == 6.0, -1, 0)

    def fit(c):
        return bounded_fit(lambda v: v[0] + v[1] * x, y, [[1.0, 1.0]], ("a", "b"), [-np.inf, -np.inf], [np.inf, np.inf],
                           model="line", response="y", what="test", valid_range={}, func=lambda v, **kw: v[0] + v[1] * x,
                           censored=c)

    censored, read = fit(cens), fit(None)
    for name, true in (("a", 2.0), ("b", 10.0)):
        lo, hi = censored.ci95[censored.names.index(name)]
        assert lo < true < hi, (name, lo, hi)
    # read as values, the floor's rows bend the line flat: the slope's interval misses the truth
    lo, hi = read.ci95[read.names.index("b")]
    assert hi < 10.0, (lo, hi)
    # residuals: 0 where the line keeps below the floor, data − model elsewhere
    below = (censored["a"] + censored["b"] * x < 6.0) & (cens < 0)
    assert np.all(censored.residuals[below] == 0.0)


def test_the_hinge_keeps_only_the_error_a_bound_leaves():
    r = np.array([-2.0, 3.0, -2.0, 3.0, -2.0])
    np.testing.assert_array_equal(censor_hinge(r, np.array([-1, -1, 1, 1, 0])), [0.0, 3.0, -2.0, 0.0, -2.0])
    assert censor_hinge(r, None) is r


def _clipped_table(tmp_path, floor=4.0):
    """One 200 mm muscle, four lengths, three trials, 1 N noise, read by a load cell that cannot go below ``floor``."""
    rest = 0.2
    law = VirtualWork(480.0, -2000.0, 400.0, 100.0, 0.02, 500.0, 0.0, rest)
    rows = []
    for eps in (0.0, 0.03, 0.06, 0.09):
        for trial in (1, 2, 3):
            p = np.linspace(0.0, 0.6e6, 25)
            f = np.maximum(law.force(p, rest * (1 - eps)) + RNG.normal(0, 1.0, p.size), floor)
            rows += [dict(held_length_mm=rest * (1 - eps) * 1e3, pressure_kPa=a / 1e3, force_N=b, direction="inflate",
                          trial=trial) for a, b in zip(p, f)]
    pd.DataFrame(rows).to_csv(tmp_path / "iso.csv", index=False)
    (tmp_path / "m.toml").write_text('id = "m"\nnominal_length_mm = 200\nouter_diameter_mm = 10\n')
    return tmp_path / "iso.csv", tmp_path / "m.toml"


def test_a_muscle_read_through_a_floor_is_recovered_when_the_floor_is_censored(tmp_path):
    iso, toml = _clipped_table(tmp_path)
    table, muscle = read_table(iso), read_muscle(toml)
    d, report = isometric_points(table, rails="censor")
    assert report["rails"]["censored"] and (d["censored"] == -1).sum() == report["rails"]["rows_at_rail"] > 20
    fit = fit_isometric(table, muscle, "virtual-work", rails="censor").result
    ci = dict(zip(fit.names, fit.ci95))
    # the load cell's zero is 0 (the floor hides the slack rows' zeros; the censored fit does not invent one)
    for name, true in (("a0_N_per_MPa", 480.0), ("g0_N", 100.0), ("offset_N", 0.0)):
        assert ci[name][0] < true < ci[name][1], (name, ci[name])
    kept = fit_isometric(table, muscle, "virtual-work", rails="keep").result
    # read as forces, the floor's 4 N lift the zero: its interval excludes the truth
    lo, hi = dict(zip(kept.names, kept.ci95))["offset_N"]
    assert lo > 0.0, (lo, hi)
    # held out, a prediction below the floor where the cell read the floor is no error
    c = compare_isometric(table, muscle, rails="censor", models=["virtual-work"])
    assert c.scores[0]["flags"] == [] and c.scores[0]["cv_rmse_N"] < 2.0  # 1 N of noise


def test_the_command_censors_and_refuses_an_unknown_policy(tmp_path):
    iso, toml = _clipped_table(tmp_path)
    run = [sys.executable, "-m", "mckibben.cli", "fit", str(iso), "--model", "virtual-work", "--muscle-file", str(toml)]
    r = subprocess.run(run + ["--rails", "censor", "--json"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert "censored" in r.stderr  # the warning says what was done with the rail's rows
    assert out["tare"]["rails"]["censored"] is True
    bad = subprocess.run(run + ["--rails", "censr"], capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2 and "censor" in bad.stderr and "Traceback" not in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1, bad.stderr


@pytest.mark.parametrize("policy", ["keep", "exclude"])
def test_the_other_policies_add_no_censored_column(tmp_path, policy):
    iso, _ = _clipped_table(tmp_path)
    d, report = isometric_points(read_table(iso), rails=policy)
    assert "censored" not in d and report["rails"]["censored"] is False
