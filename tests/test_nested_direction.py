"""Honest selection of the direction-aware form (issue 33, items 1 and 7): nested leave-one-trial-out.

Each held-out trial's up/down gap is predicted by the candidate (law × structure × run drift) chosen
on the other trials alone, by the gap error RMS of an inner leave-one-trial-out. Synthetic campaigns
generated with a known structure (the helpers of tests/test_direction_aware.py and
tests/test_direction_drift.py): the selection must find it on every fold. No real data.
"""

from __future__ import annotations

import json
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from mckibben.data import read_muscle, read_table  # noqa: E402
from mckibben.errors import ArgumentTypeError, InputError  # noqa: E402
from mckibben.fit.direction import heldout_gap  # noqa: E402
from mckibben.fit.isometric import fit_isometric  # noqa: E402
from mckibben.fit.nested import (NESTED_MIN_FOLDS, NestedGapComparison, compare_direction_aware_nested,  # noqa: E402
                                 compare_nested)

from conftest import names_argument  # noqa: E402
from test_direction_aware import AREA_TRUE, COMMERCIAL, LAW, NOISE_N, R_TRUE, _campaign  # noqa: E402
from test_direction_drift import DRIFT_TRUE, _relaxing  # noqa: E402


@pytest.fixture(scope="module")
def truth():
    """The law's parameters (its fit to the bundled table) and the muscle."""
    muscle = read_muscle(COMMERCIAL / "muscle.toml")
    fit = fit_isometric(read_table(COMMERCIAL / "isometric.csv"), muscle, LAW)
    return muscle, fit.result.values


@pytest.mark.parametrize("structure, op", [("play", [R_TRUE]), ("friction", [R_TRUE, AREA_TRUE])])
def test_nested_selection_finds_the_true_structure_on_every_fold(tmp_path, truth, structure, op):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, structure, op, trials=(1, 2, 3))
    res = compare_direction_aware_nested(read_table(path), muscle, models=[LAW], drifts=False)
    assert isinstance(res, NestedGapComparison)
    true = f"{LAW} ({structure})"
    assert res.candidates == [f"{LAW} (play)", f"{LAW} (friction)"]
    assert [f["chosen"] for f in res.folds] == [true] * 3  # each held-out trial, chosen on the other two alone
    assert res.selection == {true: 3} and res.non_nested["best"] == true
    for f in res.folds:
        assert f["inner_folds"] == [t for t in (1, 2, 3) if t != f["held_out"]]  # 2 inner folds of one trial each
        wrong = next(k for k in f["inner"] if k != true)
        assert f["inner"][true]["gap_error_rms_N"] < 0.5 * f["inner"][wrong]["gap_error_rms_N"]
        assert f["gap_error_ratio"] < 0.5  # the gap held out: well inside issue 33's bar
    m = res.metrics
    # the same choice on every fold: nested and non-nested are the same fits on the same trials, to the last bit
    assert m["optimism"] == 0.0 and m["nested_gap_error_ratio"] == m["non_nested_gap_error_ratio"]
    assert m["folds_at_most_half"] == 3 and m["folds_choosing_non_nested_best"] == 3
    # the gap error of a model in the truth's class is about the gap's noise (two branches: √2·σ)
    assert m["nested_gap_error_rms_N"] < 2 * np.sqrt(2) * NOISE_N


def test_nested_selection_finds_the_run_drift_on_every_fold(tmp_path, truth):
    muscle, theta = truth
    path = _relaxing(tmp_path, muscle, theta, DRIFT_TRUE)  # a play and a force relaxing by 8 % over each run
    res = compare_direction_aware_nested(read_table(path), muscle, models=LAW, structures="play")
    assert res.candidates == [f"{LAW} (play)", f"{LAW} (play, drift)"]
    assert res.selection == {f"{LAW} (play, drift)": 3}
    assert all(f["inner"][f"{LAW} (play, drift)"]["gap_error_rms_N"] < 0.5 * f["inner"][f"{LAW} (play)"]["gap_error_rms_N"]
               for f in res.folds)


def test_each_folds_score_is_the_chosen_candidates_fit_on_the_other_trials(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2, 3))
    table = read_table(path)
    res = compare_direction_aware_nested(table, muscle, models=[LAW], drifts=False)
    # the outer score is heldout_gap's own (the same fit of the same rows): one number however it was chosen
    h = heldout_gap(table, muscle, LAW, "play", test_trials=[2])
    fold = next(f for f in res.folds if f["held_out"] == 2)
    assert fold["gap_error_rms_N"] == pytest.approx(h.metrics["direction_aware_gap_error_rms_N"], rel=1e-9)
    assert fold["measured_gap_rms_N"] == pytest.approx(h.metrics["measured_gap_rms_N"], rel=1e-12)
    # the inner score is heldout_gap on the two training trials alone
    inner = heldout_gap(table, muscle, LAW, "play", test_trials=[1, 3])  # scored on all three: not the inner one
    assert fold["inner"][f"{LAW} (play)"]["gap_error_rms_N"] != pytest.approx(
        inner.metrics["direction_aware_gap_error_rms_N"], rel=1e-6)
    # a result like every other: one row per held-out trial, a figure with the bar and the choices, JSON
    df = res.to_pandas()
    assert list(df["held_out"]) == [1, 2, 3] and {"nested_gap_error_ratio", "non_nested_gap_error_ratio"} <= set(df)
    assert df.attrs["provenance"]["call"] == "mckibben.fit.nested.compare_direction_aware_nested"
    fig = res.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert any(np.allclose(ln.get_xdata(), 0.5) for ln in ax.lines)  # the bar's line at 0.5
    assert {t.get_text() for t in ax.get_yticklabels()} == {"trial 1", "trial 2", "trial 3"}
    assert sum(f"{LAW} (play)" in t.get_text() for t in ax.texts) == 3  # each fold's choice written on it
    assert json.loads(json.dumps(res.to_dict()))["selection"] == res.selection


def test_fits_on_the_same_points_are_made_once_and_equal_fitting_again(tmp_path, truth, monkeypatch):
    """Three trials: the outer folds fit on three pairs, the inner folds on single trials, each single
    trial in two outer folds; with the shared cache each training set is fitted once (6 fits, not 9)."""
    import mckibben.fit.direction as direction

    muscle, theta = truth
    table = read_table(_campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2, 3)))
    fresh = heldout_gap(table, muscle, LAW, "play").metrics
    made = []
    real = direction._fit_points
    monkeypatch.setattr(direction, "_fit_points", lambda d, *a, **k: made.append(tuple(sorted(set(d["trial"])))) or
                        real(d, *a, **k))
    res = compare_direction_aware_nested(table, muscle, models=[LAW], structures=("play",), drifts=False)
    assert sorted(made) == [(1,), (1, 2), (1, 3), (2,), (2, 3), (3,)]
    cache: dict = {}
    made.clear()
    first = heldout_gap(table, muscle, LAW, "play", cache=cache).metrics
    again = heldout_gap(table, muscle, LAW, "play", cache=cache).metrics
    assert len(made) == 3 and first == again == fresh  # the second call fits nothing; the numbers are fitting's own
    with pytest.raises(ArgumentTypeError, match=r"cache = \[\]: not a dict"):
        heldout_gap(table, muscle, LAW, "play", cache=[])
    assert res.folds[0]["non_nested_gap_error_rms_N"] == pytest.approx(
        heldout_gap(table, muscle, LAW, "play", test_trials=[1]).metrics["direction_aware_gap_error_rms_N"], rel=1e-12)


def test_bad_input_is_named(tmp_path, truth):
    muscle, theta = truth
    two = read_table(_campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2), name="two.csv"))
    with pytest.raises(InputError, match=f"needs {NESTED_MIN_FOLDS} trials or more, found 2"):
        compare_direction_aware_nested(two, muscle, models=[LAW])
    table = read_table(_campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2, 3)))
    for kw, name in (({"structures": "sideways"}, "structures"), ({"structures": ()}, "structures"),
                     ({"drifts": "yes"}, "drifts"), ({"models": [LAW, LAW]}, "models"), ({"tare": "fitted"}, "tare"),
                     ({"min_samples": 30}, "min_samples"), ({"min_samples": -1}, "min_samples")):
        with pytest.raises(InputError) as exc:
            compare_direction_aware_nested(table, muscle, **{"models": [LAW], **kw})
        assert names_argument(str(exc.value), name), (kw, str(exc.value))
    with pytest.raises(InputError, match="no direction-aware candidate could be scored"):
        compare_direction_aware_nested(table, muscle, models=["surface"])
    with pytest.raises(InputError, match="table"):
        compare_direction_aware_nested("iso.csv", muscle)


def _mckibben(*args, cwd):
    code = "import sys; from mckibben.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


def test_cli_direction_aware_nested_json_and_plot(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "friction", [R_TRUE, AREA_TRUE], trials=(1, 2, 3))
    (tmp_path / "muscle.toml").write_text((COMMERCIAL / "muscle.toml").read_text())
    run = _mckibben("compare", str(path), "--direction-aware", "--nested", "--laws", LAW, "--structure",
                    "play,friction", "--json", "--plot", "nested.png", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    for key in ("file", "kind", "muscle", "synthetic", "cv", "candidates", "min_samples", "non_nested_best",
                "measured_gap_rms_N", "nested_gap_error_rms_N", "nested_gap_error_ratio", "non_nested_gap_error_ratio",
                "optimism", "folds_at_most_half", "n_folds", "selection", "nested", "non_nested", "folds", "models"):
        assert key in out, key
    assert out["cv"] == "leave-one-trial-out" and out["n_folds"] == 3 and out["min_samples"] == 0
    assert out["selection"] == {f"{LAW} (friction)": 3}
    for f in out["folds"]:
        assert {"held_out", "inner_folds", "chosen", "inner", "gap_error_ratio", "non_nested_gap_error_ratio",
                "optimism"} <= set(f)
    assert (tmp_path / "nested.png").stat().st_size > 0
    run = _mckibben("compare", str(path), "--direction-aware", "--nested", "--laws", LAW, cwd=tmp_path)  # the table
    assert run.returncode == 0, run.stderr
    assert run.stdout.count(f"{LAW} (play)") >= 3 and "pooled gap error / measured gap RMS: nested" in run.stdout


@pytest.mark.parametrize("args, said", [
    (["--direction-aware", "--nested", "--cv", "leave-one-length-out"], "--cv"),
    (["--direction-aware", "--nested", "--structure", "play,sideways"], "--structure"),
    (["--direction-aware", "--nested", "--rest-lengths", "fitted"], "--rest-lengths"),
    (["--direction-aware", "--nested", "--tare", "fitted"], "--tare"),
    (["--direction-aware", "--nested", "--min-samples", "30"], "--min-samples"),  # no n_samples column
    (["--direction-aware", "--laws", LAW], "--laws"),  # the candidates of the nested selection only
    (["--nested", "--run-drift"], "--run-drift"),  # a nuisance of the direction-aware forms
    (["--direction-aware", "--nested", "--laws", "surface"], "no direction-aware candidate"),
])
def test_cli_bad_combinations_exit_2_in_one_line(tmp_path, truth, args, said):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2, 3))
    (tmp_path / "muscle.toml").write_text((COMMERCIAL / "muscle.toml").read_text())
    run = _mckibben("compare", str(path), *args, "--plot", "x.png", cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and said in lines[0] and "Traceback" not in run.stderr, run.stderr
    assert run.stdout == "" and not (tmp_path / "x.png").exists()


def _binned(folder, seed=337):
    """A family isometric table binned from a stepped protocol (two virtual-work muscles, 200 and 250 mm, four held
    lengths each, three trials): holds of 250 readings, steps of 10 whose force is 20 N off (still moving). A
    family table, so compare's candidates are the family laws (fast)."""
    from mckibben.models.laws.virtual_work import VirtualWork

    rng = np.random.default_rng(seed)
    rows = []
    for rest in (0.2, 0.25):
        law = VirtualWork(480.0, -2000.0, 400.0, 100.0, 0.02, 500.0, 0.01, rest)
        for eps in (0.0, 0.03, 0.06, 0.09):
            for trial in (1, 2, 3):
                p = np.linspace(0.0, 0.6e6, 13)
                step = np.arange(p.size) % 2 == 1  # every other point a step passing through
                f = law.force(p, rest * (1 - eps)) + rng.normal(0, 1.0, p.size) + np.where(step, 20.0, 0.0)
                rows += [dict(muscle=f"m{rest * 100:g}", rest_length_mm=rest * 1e3, held_length_mm=rest * (1 - eps) * 1e3,
                              pressure_kPa=a / 1e3, force_N=b, direction="inflate", trial=trial,
                              n_samples=10 if s else 250) for a, b, s in zip(p, f, step)]
    pd.DataFrame(rows).to_csv(folder / "binned.csv", index=False)
    (folder / "m.toml").write_text('id = "m"\nnominal_length_mm = 200\nouter_diameter_mm = 10\n')
    return folder / "binned.csv", folder / "m.toml"


def test_plain_nested_takes_the_settled_points_only(tmp_path):
    path, toml = _binned(tmp_path)
    table, muscle = read_table(path), read_muscle(toml)
    every = compare_nested(table, muscle, "leave-one-trial-out")  # the family laws
    settled = compare_nested(table, muscle, "leave-one-trial-out", min_samples=100)
    n_settled = int((pd.read_csv(path)["n_samples"] >= 100).sum())
    assert sum(f["n_points"] for f in settled.folds) == n_settled < sum(f["n_points"] for f in every.folds)
    # the steps' 20 N offsets are gone from fit and score alike: the held-out error falls to about the noise
    assert settled.nested["rmse_N"] < 2.0 < every.nested["rmse_N"]
    assert settled.selection == {"virtual-work": 3} and settled.to_dict()["min_samples"] == 100


def test_cli_plain_nested_min_samples(tmp_path):
    path, toml = _binned(tmp_path)
    run = _mckibben("compare", str(path), "--muscle-file", str(toml), "--nested", "--cv", "leave-one-trial-out",
                    "--min-samples", "100", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert out["min_samples"] == 100 and out["nested"]["rmse_N"] < 2.0
    assert sum(f["n_points"] for f in out["folds"]) == int((pd.read_csv(path)["n_samples"] >= 100).sum())
    run = _mckibben("compare", str(path), "--muscle-file", str(toml), "--nested", "--min-samples", "1000", cwd=tmp_path)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "--min-samples" in lines[0]
