"""The run-drift nuisance of a direction-aware fit (``drift=True``, mckibben.fit.direction).

A synthetic campaign generated from a registered law fed through a known play, its force relaxing
over each run by a known share (force × (1 + c·s), s the place along the run): the joint fit must
recover c within its interval, predict a held-out trial's gap better than the same form without
the drift, and keep the drift out of what it predicts for the muscle. No real data.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.fit.direction import DRIFT_NAME, fit_direction_aware, heldout_gap, run_order, run_position
from mckibben.fit.isometric import fit_isometric
from mckibben.models import laws
from mckibben.models.hysteresis.direction import direction_aware_force, play_pressure

COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"
LAW = "relative-strain"  # fits the bundled table without a flag, in a fraction of a second
R_TRUE = 10e3  # [Pa] play threshold of the synthetic truth
DRIFT_TRUE = -0.08  # [-] the force relaxes by 8 % of itself over a run (the real Festo fits: -5 to -20 %)
NOISE_N = 0.3  # [N] force noise of the synthetic truth


@pytest.fixture(scope="module")
def truth():
    muscle = read_muscle(COMMERCIAL / "muscle.toml")
    fit = fit_isometric(read_table(COMMERCIAL / "isometric.csv"), muscle, LAW)
    return muscle, fit.result.values


def _relaxing(tmp_path, muscle, theta, drift, trials=(1, 2, 3), seed=0):
    rng = np.random.default_rng(seed)
    l0 = muscle.nominal_length
    up = np.linspace(20e3, 620e3, 21)
    seq = np.concatenate([up, up[::-1][1:]])
    dirn = np.array(["inflate"] * up.size + ["deflate"] * (up.size - 1))
    s = np.linspace(0.0, 1.0, seq.size)
    rows = []
    for t in trials:
        for ell in l0 * np.array([1.0, 0.95, 0.9, 0.85]):
            data = {"pressure": seq, "held_length": np.full(seq.size, ell), "force": np.zeros(seq.size),
                    "direction": dirn, "rest_length": np.full(seq.size, l0)}
            spec = laws.LAWS[LAW].fit_spec(muscle, 1.0, data)
            z, _ = play_pressure(seq, R_TRUE)
            f = direction_aware_force(spec.force, "play", np.r_[theta, R_TRUE], seq, data["held_length"], z,
                                      direction=dirn, rest_length=data["rest_length"])
            f = f * (1 + drift * s) + rng.normal(0, NOISE_N, f.size)
            rows.append(pd.DataFrame({"held_length_mm": ell * 1e3, "pressure_kPa": seq / 1e3, "force_N": f,
                                      "direction": dirn, "trial": t}))
    path = tmp_path / f"relaxing{seed}.csv"
    pd.concat(rows).sample(frac=1.0, random_state=seed).to_csv(path, index=False)
    return path


def test_run_position_runs_along_each_run():
    d = pd.DataFrame({"held_length": [0.1] * 4 + [0.2] * 3, "pressure": [1e5, 3e5, 2e5, 1e5, 1e5, 2e5, 1e5],
                      "direction": ["inflate", "inflate", "deflate", "deflate", "inflate", "inflate", "deflate"],
                      "trial": [1] * 7})
    order, runs = run_order(d)
    s = run_position(len(d), runs)
    assert np.allclose(s, [0, 1 / 3, 2 / 3, 1, 0, 0.5, 1])
    assert np.allclose(run_position(1, [slice(0, 1)]), [0.0])  # a run of one point sits at its start


def test_drift_is_recovered_and_left_out_of_the_muscle(tmp_path, truth):
    muscle, theta = truth
    table = read_table(_relaxing(tmp_path, muscle, theta, DRIFT_TRUE, trials=(1, 2)))
    fit = fit_direction_aware(table, muscle, LAW, "play", drift=True)
    res = fit.result
    lo, hi = res.ci95[res.names.index(DRIFT_NAME)]
    assert lo <= DRIFT_TRUE <= hi and hi < 0, (res[DRIFT_NAME], lo, hi)
    assert fit.operator[DRIFT_NAME] == res[DRIFT_NAME]
    assert "run drift -" in fit.plot().axes[0].get_title()  # the modelled loops are drawn along the drifting run
    assert res.residual_rms == pytest.approx(NOISE_N, rel=0.25)
    # the muscle's prediction carries no drift: it is the law through the play alone
    p = np.linspace(50e3, 600e3, 12)
    ell = muscle.nominal_length * 0.95
    spec = laws.LAWS[LAW].fit_spec(muscle, 1.0, {"pressure": p, "held_length": np.full(p.size, ell),
                                                 "force": np.zeros(p.size), "direction": np.array(["inflate"] * p.size),
                                                 "rest_length": np.full(p.size, muscle.nominal_length)})
    z, _ = play_pressure(p, res["play_threshold_Pa"])
    law_values = res.values[:-1]
    expected = direction_aware_force(spec.force, "play", law_values, p, np.full(p.size, ell), z,
                                     direction=np.array(["inflate"] * p.size),
                                     rest_length=np.full(p.size, muscle.nominal_length))
    got, _ = fit.predict(p, ell)
    assert np.allclose(got, expected)
    far = direction_aware_force(spec.force, "play", law_values, p, np.full(p.size, ell), p + res["play_threshold_Pa"],
                                direction=np.array(["deflate"] * p.size),
                                rest_length=np.full(p.size, muscle.nominal_length))
    assert np.allclose(fit.predict_branch(p, ell, "deflate")[0], far)
    # without the nuisance the same data fit worse
    assert fit_direction_aware(table, muscle, LAW, "play").result.residual_rms > 2 * res.residual_rms


def test_heldout_gap_predicts_the_drift_from_the_other_trials(tmp_path, truth):
    muscle, theta = truth
    table = read_table(_relaxing(tmp_path, muscle, theta, DRIFT_TRUE))
    with_drift = heldout_gap(table, muscle, LAW, "play", test_trials=[3], drift=True)
    without = heldout_gap(table, muscle, LAW, "play", test_trials=[3])
    # the fold's drift comes from trials 1-2 alone: the held-out trial gives it no value
    assert with_drift.fits[0].result[DRIFT_NAME] == pytest.approx(
        fit_direction_aware(table, muscle, LAW, "play", trials=[1, 2], drift=True).result[DRIFT_NAME])
    m, m0 = with_drift.metrics, without.metrics
    assert m["direction_aware_gap_error_ratio"] < 0.5 * m0["direction_aware_gap_error_ratio"]
    assert m["direction_aware_gap_error_rms_N"] < 2 * np.sqrt(2) * NOISE_N  # the gap's noise, √2·σ per branch


def test_no_drift_in_the_data_fits_none(tmp_path, truth):
    muscle, theta = truth
    table = read_table(_relaxing(tmp_path, muscle, theta, 0.0, trials=(1, 2), seed=1))
    res = fit_direction_aware(table, muscle, LAW, "play", drift=True).result
    lo, hi = res.ci95[res.names.index(DRIFT_NAME)]
    assert lo <= 0.0 <= hi and hi - lo < 0.05, (lo, hi)


def _mckibben(*args, cwd):
    code = "import sys; from mckibben.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


def test_cli_fit_run_drift(tmp_path, truth):
    muscle, theta = truth
    path = _relaxing(tmp_path, muscle, theta, DRIFT_TRUE, trials=(1, 2))
    (tmp_path / "muscle.toml").write_text((COMMERCIAL / "muscle.toml").read_text())
    run = _mckibben("fit", str(path), "--model", LAW, "--direction-aware", "--run-drift", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    lo, hi = out["ci95"][DRIFT_NAME]
    assert lo <= DRIFT_TRUE <= hi
    assert out["direction_aware"][DRIFT_NAME] == out["parameters"][DRIFT_NAME]


@pytest.mark.parametrize("cmd, args", [("fit", ["--model", LAW, "--run-drift"]), ("compare", ["--run-drift"])])
def test_cli_run_drift_needs_direction_aware(tmp_path, truth, cmd, args):
    muscle, theta = truth
    path = _relaxing(tmp_path, muscle, theta, DRIFT_TRUE, trials=(1, 2))
    (tmp_path / "muscle.toml").write_text((COMMERCIAL / "muscle.toml").read_text())
    run = _mckibben(cmd, str(path), *args, cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --run-drift:") and "--direction-aware" in lines[0], lines


def test_compare_reports_the_drift_of_each_fold(tmp_path, truth):
    from mckibben.fit.direction import compare_direction_aware

    muscle, theta = truth
    table = read_table(_relaxing(tmp_path, muscle, theta, DRIFT_TRUE))
    row = compare_direction_aware(table, muscle, models=[LAW], drift=True)[0]
    # within 0.02 of the truth: each fold's 95 % interval is about ± 0.004 on this campaign
    assert len(row[DRIFT_NAME]) == 3 and all(abs(c - DRIFT_TRUE) < 0.02 for c in row[DRIFT_NAME]), row[DRIFT_NAME]
    assert DRIFT_NAME not in compare_direction_aware(table, muscle, models=[LAW])[0]
