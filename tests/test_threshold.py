"""The threshold pressure term (mckibben.models.threshold): fitted with a law, found back, flagged when the data do not tell it."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mckibben import read_muscle
from mckibben.errors import InputError
from mckibben.fit.isometric import IsometricFit, _NO_DATA, _spec, compare_isometric, fit_points, threshold_law
from mckibben.fit.muscle_file import muscle_file_text
from mckibben.data import read_table
from mckibben.models.threshold import THRESHOLD_NAME, THRESHOLD_SUFFIX, above_threshold, split_threshold

L0 = 0.25  # [m]
P_TH = 60e3  # the threshold the table is generated with [Pa]
#: chou-hannaford's theta0 [rad], d0 [m], offset [N]: a 10 mm muscle braided at 25 deg (d0·sin θ0 ≈ the outer diameter)
TRUTH = (np.deg2rad(25.0), 0.024, 0.0)
NOISE = 0.5  # the load cell's noise [N]


@pytest.fixture(scope="module")
def muscle(tmp_path_factory):
    path = tmp_path_factory.mktemp("m") / "m.toml"
    path.write_text(f'id = "m"\nnominal_length_mm = {L0 * 1e3:g}\nouter_diameter_mm = 10\n')
    return read_muscle(str(path))


def _points(muscle, p_th, seed=0):
    """An isometric map of chou-hannaford with a threshold: 4 held lengths × 3 trials, 20–600 kPa, noisy."""
    force = _spec("chou-hannaford", muscle, 1.0, *_NO_DATA).force
    rng = np.random.default_rng(seed)
    p = np.linspace(20e3, 600e3, 25)
    rows = []
    for ell in (0.25, 0.24, 0.23, 0.22):
        for trial in (1, 2, 3):
            f = force(np.array(TRUTH), above_threshold(p, p_th), np.full(p.size, ell)) + rng.normal(0, NOISE, p.size)
            rows.append(pd.DataFrame({"held_length": ell, "pressure": p, "force": f, "direction": "inflate",
                                      "trial": trial}))
    return pd.concat(rows, ignore_index=True)


def test_a_known_threshold_is_found_back_with_its_interval(muscle):
    res = fit_points(_points(muscle, P_TH), muscle, "chou-hannaford", threshold=True)
    k = res.names.index(THRESHOLD_NAME)
    lo, hi = res.ci95[k]
    # noise of 0.5 N on forces of hundreds of N, 300 points: the threshold within 5 kPa, its interval covering it
    assert res.values[k] == pytest.approx(P_TH, abs=5e3) and lo <= P_TH <= hi, (res.values[k], lo, hi, res.flags)
    assert not [f for f in res.flags if f.startswith(THRESHOLD_NAME)], res.flags
    plain = fit_points(_points(muscle, P_TH), muscle, "chou-hannaford")
    assert res.residual_rms < 0.5 * plain.residual_rms  # without the term the law misfits the slack points


def test_no_threshold_in_the_data_is_flagged_at_its_bound(muscle):
    res = fit_points(_points(muscle, 0.0), muscle, "chou-hannaford", threshold=True)
    assert f"{THRESHOLD_NAME}_at_lower_bound" in res.flags or f"{THRESHOLD_NAME}_unconstrained" in res.flags, res.flags


def test_a_threshold_the_law_absorbs_is_flagged_unconstrained(muscle):
    # one held length, no point below 150 kPa: there chou-hannaford is linear in P, and a shift of its
    # pressure is a shift of its load-cell zero (c·P_th ≈ 20 N, inside the zero's bound): the profile at
    # P_th = 0 fits as well
    d = _points(muscle, 30e3)
    d = d[(d["pressure"] > 150e3) & (d["held_length"] == 0.24)]
    res = fit_points(d, muscle, "chou-hannaford", threshold=True)
    assert any(f.startswith(THRESHOLD_NAME) for f in res.flags), (res.values, res.flags)


def test_the_suffix_names_the_term_and_laws_with_their_own_threshold_refuse_it(muscle):
    assert split_threshold("virtual-work" + THRESHOLD_SUFFIX) == ("virtual-work", True)
    assert split_threshold("virtual-work") == ("virtual-work", False)
    d = _points(muscle, P_TH)
    res = fit_points(d, muscle, "chou-hannaford" + THRESHOLD_SUFFIX)
    assert res.names[-1] == THRESHOLD_NAME
    assert not threshold_law("tondu-lopez", muscle) and threshold_law("virtual-work", muscle)
    with pytest.raises(InputError, match="tondu-lopez has a threshold pressure of its own"):
        fit_points(d, muscle, "tondu-lopez", threshold=True)
    with pytest.raises(InputError, match="threshold: the threshold pressure is a term of a registered force law"):
        fit_points(d, muscle, "surface", threshold=True)


def test_compare_scores_each_law_with_its_threshold_beside_it(tmp_path, muscle):
    d = _points(muscle, P_TH)
    path = tmp_path / "iso.csv"
    pd.DataFrame({"held_length_mm": d["held_length"] * 1e3, "pressure_kPa": d["pressure"] / 1e3,
                  "force_N": d["force"], "direction": d["direction"], "trial": d["trial"]}).to_csv(path, index=False)
    c = compare_isometric(read_table(str(path)), muscle, models=["chou-hannaford", "tondu-lopez"], threshold=True)
    names = [s["model"] for s in c.scores]
    assert names == ["chou-hannaford", "chou-hannaford" + THRESHOLD_SUFFIX, "tondu-lopez"]
    by = {s["model"]: s for s in c.scores}
    # the generating law with its term predicts held-out lengths better than without it
    assert by["chou-hannaford" + THRESHOLD_SUFFIX]["cv_rmse_N"] < by["chou-hannaford"]["cv_rmse_N"]


def test_a_muscle_file_refuses_a_threshold_fit_in_one_line(muscle):
    d = _points(muscle, P_TH)
    res = fit_points(d, muscle, "chou-hannaford", threshold=True)
    fit = IsometricFit("chou-hannaford" + THRESHOLD_SUFFIX, res, muscle, {"method": "none"}, d)
    with pytest.raises(InputError, match=f"save: .*{THRESHOLD_NAME}") as exc:
        muscle_file_text(muscle, fit)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("value", ["30000.0", "-5.0", '"abc"'])
def test_predict_refuses_a_muscle_file_with_a_threshold_in_one_line(tmp_path, muscle, value):
    # the term is not stored in muscle files: a hand-edited one (a threshold, negative or not a number) is
    # refused by the command naming the key, exit 2, no traceback
    d = _points(muscle, P_TH)
    res = fit_points(d, muscle, "chou-hannaford")
    text = muscle_file_text(muscle, IsometricFit("chou-hannaford", res, muscle, {"method": "none"}, d))
    path = tmp_path / "m.toml"
    path.write_text(text.replace("[force_model.parameters]\n", f"[force_model.parameters]\n{THRESHOLD_NAME} = {value}\n"))
    r = subprocess.run([sys.executable, "-m", "mckibben.cli", "predict", "force", "--muscle-file", str(path),
                        "--pressure", "0.3MPa", "--length", "240mm"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and THRESHOLD_NAME in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
