"""The zero of each run fitted with the law (issue 33, item 4): ``tare="fitted"``, library and CLI.

A synthetic campaign from the ideal braid with a known load-cell zero per run (one held length ×
trial, swept up and down): the fit recovers every run's zero within its interval, the
law's geometry with it, and leaves the table's force as read.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.data.io import TARES, apply_tare
from mckibben.fit.isometric import compare_isometric, fit_isometric, zero_runs
from mckibben.fit.muscle_file import muscle_force_law
from mckibben.models.geometry import BraidGeometry
from mckibben.models.laws.chou_hannaford import chou_hannaford_force

L0, OD, THETA0, D0 = 0.300, 0.012, float(np.deg2rad(22.0)), 0.0294
LENGTHS = (1.0, 0.94, 0.88, 0.82)
TRIALS = (1, 2, 3)
NOISE = 0.4  # [N], the load cell's scatter about a run's zero


def _campaign(tmp_path, seed=33, missed=0.0):
    """The CSV and muscle file of a 4 × 3-run campaign (each swept up and down) with a zero per run.

    ``missed`` [N]: a force the law lacks, the same at every pressure of a held length and alternating
    in sign from one length to the next (what a wrong length dependence leaves behind).
    """
    rng = np.random.default_rng(seed)
    b = L0 / np.cos(THETA0)
    geom = BraidGeometry(b, b / (np.pi * D0), 0.0)
    p_up = np.linspace(0.0, 600e3, 13)
    rows = []
    for j, frac in enumerate(LENGTHS):
        for trial in TRIALS:
            zero = rng.normal(3.0, 4.0)  # a cell never zeroed: a few newtons either way, per run
            for direction, p in (("inflate", p_up), ("deflate", p_up[::-1])):
                f = (chou_hannaford_force(p, np.full(p.size, frac * L0), geom) + zero + missed * (-1) ** j
                     + rng.normal(0, NOISE, p.size))
                rows += [{"held_length_mm": frac * L0 * 1e3, "pressure_kPa": pk / 1e3, "force_N": fk,
                          "direction": direction, "trial": trial, "_zero": zero} for pk, fk in zip(p, f)]
    d = pd.DataFrame(rows)
    iso = tmp_path / "iso.csv"
    d.drop(columns="_zero").to_csv(iso, index=False)
    toml = tmp_path / "m.toml"
    toml.write_text(f'id = "c10"\nnominal_length_mm = {L0 * 1e3:g}\nouter_diameter_mm = {OD * 1e3:g}\n'
                    f"braid_angle_deg = 22\n")
    return iso, toml, d


def test_fitted_tare_recovers_each_runs_zero(tmp_path):
    iso, toml, d = _campaign(tmp_path)
    t, m = read_table(str(iso)), read_muscle(str(toml))
    fit = fit_isometric(t, m, "chou-hannaford", tare="fitted")
    runs = fit.tare["per_run_N"]
    assert len(runs) == len(LENGTHS) * len(TRIALS)  # held length × trial
    label, keys = zero_runs(fit.data)
    truth = np.array([d["_zero"].to_numpy()[label == i][0] for i in range(len(keys))])
    est = np.array([r["zero_N"] for r in runs])
    lo, hi = np.array([r["ci95_N"] for r in runs]).T
    # 26 points of 0.4 N noise per run: a zero's standard error about 0.4/√26 ≈ 0.08 N
    np.testing.assert_allclose(est, truth, atol=0.5)
    covered = np.mean((lo <= truth) & (truth <= hi))
    assert covered >= 0.83, covered  # 12 intervals at 95 %: 2 misses are 1 in 9, 3 misses 1 in 50
    assert np.all(hi - lo < 1.0)
    # the law's geometry comes out with them, and the table's force is the one read (pre-tension kept)
    assert fit.result["d0_m"] == pytest.approx(D0, rel=0.01)
    assert fit.result["offset_N"] == pytest.approx(truth.mean(), abs=0.2)  # the runs' mean zero
    np.testing.assert_allclose(np.sort(fit.data["force"].to_numpy()), np.sort(d["force_N"].to_numpy()))
    assert not fit.flags, fit.flags
    # the zeros are reported beside the run they belong to
    assert {"held_length_m", "trial", "zero_N", "ci95_N"} <= set(runs[0])


def test_zeros_that_carry_a_missed_force_are_flagged(tmp_path):
    # ±60 N that changes with the held length (about 8 % of the ~700 N peak): the run zeros take it up
    iso, toml, _ = _campaign(tmp_path, missed=60.0)
    fit = fit_isometric(read_table(str(iso)), read_muscle(str(toml)), "chou-hannaford", tare="fitted")
    assert "run_zeros_spread" in fit.flags  # (the same campaign without it carries no flag: the test above)


def test_one_zero_for_the_whole_table_misses_the_runs(tmp_path):
    # the same data with one shared zero: the residuals carry the runs' spread (4 N), the fitted zeros do not
    iso, toml, _ = _campaign(tmp_path)
    t, m = read_table(str(iso)), read_muscle(str(toml))
    shared = fit_isometric(t, m, "chou-hannaford", tare="none").result.residual_rms
    per_run = fit_isometric(t, m, "chou-hannaford", tare="fitted").result.residual_rms
    assert per_run < 1.5 * NOISE < 2.0 < shared


def test_compare_with_fitted_zeros_scores_held_out_runs_at_the_mean_zero(tmp_path):
    iso, toml, _ = _campaign(tmp_path)
    c = compare_isometric(read_table(str(iso)), read_muscle(str(toml)), "leave-one-length-out", tare="fitted",
                          models=["chou-hannaford"])
    s = c.scores[0]
    assert s["cv_rmse_N"] is not None and c.tare["method"] == "fitted"
    assert len(c.fits["chou-hannaford"].tare["per_run_N"]) == 12  # each model's fit carries its runs' zeros
    # an unseen run's zero is not known: it is predicted at the runs' mean, off by the zeros' spread (4 N)
    assert 1.0 < s["cv_rmse_N"] < 8.0


def test_fitted_is_a_tare_that_leaves_the_table_as_read(tmp_path):
    iso, _, _ = _campaign(tmp_path)
    t = read_table(str(iso))
    assert "fitted" in TARES
    same, report = apply_tare(t, "fitted")
    assert same is t and report == {"method": "fitted"}


def _cli(*args):
    """``mckibben ARGS`` in a fresh interpreter (the command's real exit status, stdout and stderr)."""
    code = "import sys; from mckibben.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300)


def test_cli_fit_tare_fitted_prints_each_runs_zero(tmp_path):
    iso, toml, _ = _campaign(tmp_path)
    r = _cli("fit", str(iso), "--model", "chou-hannaford", "--muscle-file", str(toml), "--tare", "fitted", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)["fits"][0]
    runs = out["tare"]["per_run_N"]
    assert len(runs) == 12 and all(lo <= z["zero_N"] <= hi for z in runs for lo, hi in [z["ci95_N"]])


def test_cli_fit_tare_fitted_text_names_the_zeros(tmp_path):
    iso, toml, _ = _campaign(tmp_path)
    r = _cli("fit", str(iso), "--model", "chou-hannaford", "--muscle-file", str(toml), "--tare", "fitted")
    assert r.returncode == 0, r.stderr
    assert "tare (fitted): 12 runs, zeros" in r.stdout


def test_cli_bad_tare_is_one_line_exit_2(tmp_path):
    iso, toml, _ = _campaign(tmp_path)
    r = _cli("fit", str(iso), "--model", "chou-hannaford", "--muscle-file", str(toml), "--tare", "fited")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "fitted" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    # a direction-aware fit has one zero: refused by name
    r = _cli("fit", str(iso), "--model", "chou-hannaford", "--muscle-file", str(toml), "--tare", "fitted",
             "--direction-aware")
    assert r.returncode == 2 and "Traceback" not in r.stderr and "fitted" in r.stderr, r.stderr


def test_a_law_fitted_with_run_zeros_saves_without_them(tmp_path):
    iso, toml, _ = _campaign(tmp_path)
    out = tmp_path / "fitted.toml"
    r = _cli("fit", str(iso), "--model", "chou-hannaford", "--muscle-file", str(toml), "--tare", "fitted",
             "--save", str(out), "--json")
    assert r.returncode == 0, r.stderr
    law = muscle_force_law(read_muscle(str(out)))  # read back: the law's own parameters only
    assert list(law.parameters) == ["d0_m", "offset_N"]
    assert law.parameters["d0_m"] == pytest.approx(D0, rel=0.01)
