"""Direction-aware laws (mckibben.fit.direction, mckibben.models.hysteresis.direction).

Synthetic campaigns generated from known parameters: a registered law (relative-strain, its fit to
the bundled commercial-size table) fed through a known play on the pressure, or plus a known
friction term; the joint fit must recover them within their 95 % intervals. The gap metric is
checked to count errors of either sign (a crossing loop has a signed mean of zero). No real data.
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
from mckibben.errors import InputError
from mckibben.fit.direction import (DirectionAwareFit, fit_direction_aware, gap_scores, heldout_gap, loop_gap,
                                    run_order)
from mckibben.fit.isometric import fit_isometric
from mckibben.models import laws
from mckibben.models.hysteresis.direction import branch_state, direction_aware_force, play_pressure

COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"
LAW = "relative-strain"  # fits the bundled table without a flag, in a fraction of a second
R_TRUE = 25e3  # [Pa] play threshold of the synthetic truth
AREA_TRUE = 4e-6  # [m²] friction area of the synthetic truth (A·P = 2.5 N at 620 kPa)
NOISE_N = 0.3  # [N] force noise of the synthetic truth


@pytest.fixture(scope="module")
def truth():
    """The law's parameters (its fit to the bundled table), its fit spec and the muscle."""
    muscle = read_muscle(COMMERCIAL / "muscle.toml")
    fit = fit_isometric(read_table(COMMERCIAL / "isometric.csv"), muscle, LAW)
    return muscle, fit.result.values


def _campaign(tmp_path, muscle, theta, structure, op, trials=(1, 2, 3, 4), seed=0, name="iso.csv"):
    """An isometric table generated from the direction-aware form with known parameters."""
    rng = np.random.default_rng(seed)
    l0 = muscle.nominal_length
    held = l0 * np.array([1.0, 0.95, 0.9, 0.85])
    up = np.linspace(20e3, 620e3, 21)
    seq = np.concatenate([up, up[::-1][1:]])
    dirn = np.array(["inflate"] * up.size + ["deflate"] * (up.size - 1))
    rows = []
    for t in trials:
        for ell in held:
            data = {"pressure": seq, "held_length": np.full(seq.size, ell), "force": np.zeros(seq.size),
                    "direction": dirn, "rest_length": np.full(seq.size, l0)}
            spec = laws.LAWS[LAW].fit_spec(muscle, 1.0, data)
            z, _ = play_pressure(seq, op[0])
            f = direction_aware_force(spec.force, structure, np.r_[theta, op], seq, data["held_length"], z,
                                      direction=dirn, rest_length=data["rest_length"])
            f = f + rng.normal(0, NOISE_N, f.size)
            rows.append(pd.DataFrame({"held_length_mm": ell * 1e3, "pressure_kPa": seq / 1e3, "force_N": f,
                                      "direction": dirn, "trial": t}))
    path = tmp_path / name
    pd.concat(rows).sample(frac=1.0, random_state=seed).to_csv(path, index=False)  # file order does not count
    return path


def _within(res, name, true):
    lo, hi = res.ci95[res.names.index(name)]
    return lo <= true <= hi


def test_play_recovers_law_and_threshold(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE])
    fit = fit_direction_aware(read_table(path), muscle, LAW, "play")
    res = fit.result
    assert isinstance(fit, DirectionAwareFit)
    assert _within(res, "play_threshold_Pa", R_TRUE), (res["play_threshold_Pa"], res.ci95[-1])
    for name, v in zip(res.names[:-1], theta):
        assert _within(res, name, v), (name, v, res[name], res.ci95[res.names.index(name)])
    # the residual is the noise (the truth is in the model class): within 20 % of its σ
    assert res.residual_rms == pytest.approx(NOISE_N, rel=0.2)


def test_friction_recovers_area(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "friction", [R_TRUE, AREA_TRUE])
    fit = fit_direction_aware(read_table(path), muscle, LAW, "friction")
    res = fit.result
    assert _within(res, "friction_area_m2", AREA_TRUE), (res["friction_area_m2"], res.ci95[-1])
    assert res.residual_rms == pytest.approx(NOISE_N, rel=0.2)


def test_plain_law_leaves_the_gap_and_direction_aware_form_predicts_it_held_out(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2, 3))
    h = heldout_gap(read_table(path), muscle, LAW, "play", test_trials=[3])
    m = h.metrics
    assert m["n_runs"] == 4 and m["n_pressures"] > 50
    # the plain law predicts (almost) no gap: its error is about the measured gap
    assert m["plain_gap_error_rms_N"] > 0.8 * m["measured_gap_rms_N"]
    # the direction-aware form, fitted on trials 1–2, predicts trial 3's gap to its noise
    # (the gap of two noisy branches has noise √2·σ)
    assert m["direction_aware_gap_error_rms_N"] < 2 * np.sqrt(2) * NOISE_N
    assert m["direction_aware_gap_error_ratio"] < 0.5
    fig = h.plot()
    assert fig.axes and len(fig.axes[0].lines) == 3


def test_gap_error_cannot_cancel():
    # a loop that crosses itself: deflate above inflate at low pressure, below at high pressure
    p = np.linspace(100e3, 500e3, 41)
    base = 1e-4 * p
    gap = 5.0 * np.sin(2 * np.pi * (p - 100e3) / 400e3)  # signed mean 0 over the grid
    pp = np.concatenate([p, p[::-1]])
    dn = np.array(["inflate"] * p.size + ["deflate"] * p.size)
    f = np.concatenate([base, (base + gap)[::-1]])
    g, measured = loop_gap(pp, f, dn, step=10e3)
    assert g.size == 41 and abs(np.mean(measured)) < 1e-9
    s = gap_scores(measured, np.zeros_like(measured))  # a static law: no gap
    assert s["gap_error_rms_N"] == pytest.approx(5.0 / np.sqrt(2), rel=0.02)  # RMS of a sine of amplitude 5 N
    assert s["gap_error_max_N"] == pytest.approx(5.0, rel=1e-3)
    # predicting the loop upside down is twice as wrong, not right on average
    assert gap_scores(measured, -measured)["gap_error_rms_N"] == pytest.approx(2 * s["gap_error_rms_N"])
    assert gap_scores(measured, measured)["gap_error_rms_N"] == 0.0


def test_loop_gap_needs_both_branches():
    g, gap = loop_gap([1e5, 2e5], [1.0, 2.0], ["inflate", "inflate"])
    assert g.size == 0 and gap.size == 0


def test_play_is_rate_independent_and_continues_from_its_state():
    p = np.array([0, 2e5, 5e5, 3e5, 4e5, 1e5])
    z, zf = play_pressure(p, 5e4, state=0.0)
    # resampling in time (each value repeated) changes nothing at the original samples
    z2, _ = play_pressure(np.repeat(p, 3), 5e4, state=0.0)
    np.testing.assert_allclose(z2[2::3], z)
    # two halves from the state the first leaves = the whole
    za, s = play_pressure(p[:3], 5e4, state=0.0)
    zb, _ = play_pressure(p[3:], 5e4, state=s)
    np.testing.assert_allclose(np.concatenate([za, zb]), z)
    # far along a branch the state is P ∓ r
    np.testing.assert_allclose(branch_state([3e5, 3e5], ["inflate", "deflate"], 5e4), [2.5e5, 3.5e5])


def test_predict_along_a_history_and_on_branches(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2))
    fit = fit_direction_aware(read_table(path), muscle, LAW, "play")
    ell = muscle.nominal_length * 0.9
    p = np.concatenate([np.linspace(0.1e6, 0.6e6, 11), np.linspace(0.6e6, 0.1e6, 11)[1:]])
    f, state = fit.predict(p, ell)
    assert state == pytest.approx(0.1e6 + fit.result["play_threshold_Pa"])
    # the deflate branch pulls more than the inflate branch at the same pressure (the loop runs the muscle's way)
    assert np.all(f[11:-1] > f[1:10][::-1] - 1e-9)
    # far from the reversal the history and the branch agree
    fb, _ = fit.predict_branch(p[:3], ell, "inflate")
    np.testing.assert_allclose(f[1:3], fb[1:3], rtol=1e-9)
    # continuing from the state: a second inflation starts on the deflate side
    f2, _ = fit.predict([0.1e6, 0.15e6], ell, state=state)
    assert f2[0] == pytest.approx(f[-1])
    # compensation: the pressure for a force on each branch is the forward form's inverse, and
    # inflating needs more pressure than deflating (by 2r on a play form)
    pw = np.array([0.4e6, 0.5e6])  # where the muscle pulls (not slack): the force rises with pressure
    target, _ = fit.predict_branch(pw, ell, "inflate")
    assert np.all(np.diff(fit.predict_branch(np.linspace(0.35e6, 0.55e6, 9), ell)[0]) > 0)
    p_up = fit.pressure(target, ell, "inflate")
    np.testing.assert_allclose(p_up, pw, rtol=1e-6)
    p_dn = fit.pressure(target, ell, "deflate")
    np.testing.assert_allclose(p_up - p_dn, 2 * fit.result["play_threshold_Pa"], rtol=1e-5)
    assert np.isnan(fit.pressure(1e6, ell))  # beyond the fitted range's pull
    with pytest.raises(InputError, match="direction"):
        fit.pressure(10.0, ell, "up")
    fig = fit.plot()
    assert fig.axes[0].get_xlabel() == "pressure [kPa]"
    df = fit.points()
    assert {"force_N", "force_model_N", "fitted"} <= set(df.columns)
    assert fit.to_dict()["direction_aware"]["structure"] == "play"


def test_run_order_is_the_protocol():
    d = pd.DataFrame({"held_length": [0.1] * 4 + [0.2] * 2, "pressure": [3e5, 1e5, 2e5, 5e5, 1e5, 2e5],
                      "direction": ["deflate", "inflate", "deflate", "inflate", "deflate", "inflate"],
                      "trial": [1] * 6, "force": np.zeros(6)})
    order, runs = run_order(d)
    assert [list(d["pressure"].iloc[order[s]]) for s in runs] == [[1e5, 5e5, 3e5, 2e5], [2e5, 1e5]]


def test_bad_input_is_named(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2))
    table = read_table(path)
    with pytest.raises(InputError, match="model"):
        fit_direction_aware(table, muscle, "surface")
    with pytest.raises(InputError, match="structure"):
        fit_direction_aware(table, muscle, LAW, "backlash")
    with pytest.raises(InputError, match="trials"):
        fit_direction_aware(table, muscle, LAW, trials=[7])
    with pytest.raises(InputError, match="test_trials"):
        heldout_gap(table, muscle, LAW, test_trials=[7])
    d = pd.read_csv(path)
    d[d.direction == "inflate"].to_csv(tmp_path / "up.csv", index=False)
    with pytest.raises(InputError, match="deflate"):
        fit_direction_aware(read_table(tmp_path / "up.csv"), muscle, LAW)
    d[d.trial == 1].to_csv(tmp_path / "one.csv", index=False)
    with pytest.raises(InputError, match="two trials"):
        heldout_gap(read_table(tmp_path / "one.csv"), muscle, LAW)
    with pytest.raises(InputError, match="play_threshold_Pa"):
        play_pressure([1e5], 0.0)


def _mckibben(*args, cwd):
    code = "import sys; from mckibben.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


def test_cli_fit_direction_aware(tmp_path, truth):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2))
    (tmp_path / "muscle.toml").write_text((COMMERCIAL / "muscle.toml").read_text())
    run = _mckibben("fit", str(path), "--model", LAW, "--direction-aware", "--json", "--plot", "loop.png",
                    cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert out["direction_aware"]["structure"] == "play"
    lo, hi = out["ci95"]["play_threshold_Pa"]
    assert lo <= R_TRUE <= hi
    assert (tmp_path / "loop.png").stat().st_size > 0


@pytest.mark.parametrize("args, words", [
    (["--model", "surface", "--direction-aware"], "not a registered force law"),
    (["--model", LAW, "--direction-aware", "--save", "out.txt"], "save"),  # saved since #33; a .toml only
    (["--model", LAW, "--direction-aware", "--rails", "sideways"], "rails"),
])
def test_cli_bad_input(tmp_path, truth, args, words):
    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2))
    (tmp_path / "muscle.toml").write_text((COMMERCIAL / "muscle.toml").read_text())
    run = _mckibben("fit", str(path), *args, cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in run.stderr
    assert not (tmp_path / "out.toml").exists() and not (tmp_path / "out.txt").exists()


def test_compare_scores_each_law_beside_its_direction_aware_form(tmp_path, truth):
    from mckibben.fit.direction import compare_direction_aware

    muscle, theta = truth
    path = _campaign(tmp_path, muscle, theta, "play", [R_TRUE], trials=(1, 2))
    rows = compare_direction_aware(read_table(path), muscle, models=[LAW, "surface"])
    row = {r["model"]: r for r in rows}
    assert row[LAW]["cv"] == "leave-one-trial-out" and len(row[LAW]["play_threshold_Pa"]) == 2
    assert row[LAW]["direction_aware_gap_error_rms_N"] < 0.5 * row[LAW]["plain_gap_error_rms_N"]
    assert row["surface"]["note"].startswith("not fitted")


def test_cli_direction_aware_refuses_an_isotonic_table(tmp_path):
    folder = BUNDLED_ISOMETRIC.parent / "campaign" / "mpam97"
    run = _mckibben("fit", str(folder / "isotonic.csv"), "--model", "chou-hannaford", "--direction-aware",
                    "--muscle-file", str(folder / "muscle.toml"), cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "--direction-aware" in lines[0] and "isotonic" in lines[0]
    run = _mckibben("compare", str(folder / "isotonic.csv"), "--direction-aware",
                    "--muscle-file", str(folder / "muscle.toml"), cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "--direction-aware" in lines[0] and "isometric" in lines[0]


def test_one_operator_across_the_muscles_of_a_family(tmp_path):
    """A family law's form on two muscles of one type: one play threshold for both, recovered."""
    from mckibben.fit.isometric import fit_points, isometric_points

    muscle = read_muscle(COMMERCIAL / "muscle.toml")
    d = pd.read_csv(COMMERCIAL / "isometric.csv")
    rest_long = float(d["held_length_mm"].max())
    fam = pd.concat([d.assign(muscle="long", rest_length_mm=rest_long),
                     d.assign(muscle="short", held_length_mm=d["held_length_mm"] * 0.8, rest_length_mm=rest_long * 0.8)])
    fam.to_csv(tmp_path / "fam0.csv", index=False)
    pts, _ = isometric_points(read_table(tmp_path / "fam0.csv"))
    theta = fit_points(pts, muscle, LAW).values  # the family law's truth: its fit to the two muscles
    rng = np.random.default_rng(1)
    up = np.linspace(20e3, 620e3, 21)
    seq = np.concatenate([up, up[::-1][1:]])
    dirn = np.array(["inflate"] * up.size + ["deflate"] * (up.size - 1))
    rows = []
    for name, rest in (("long", rest_long / 1e3), ("short", 0.8 * rest_long / 1e3)):
        for t in (1, 2, 3):
            for ell in rest * np.array([1.0, 0.95, 0.9, 0.85]):
                n = seq.size
                data = {"pressure": seq, "held_length": np.full(n, ell), "force": np.zeros(n), "direction": dirn,
                        "rest_length": np.full(n, rest)}
                spec = laws.LAWS[LAW].fit_spec(muscle, 1.0, data)
                z, _ = play_pressure(seq, R_TRUE)
                f = direction_aware_force(spec.force, "play", np.r_[theta, R_TRUE], seq, data["held_length"], z,
                                          direction=dirn, rest_length=data["rest_length"]) + rng.normal(0, NOISE_N, n)
                rows.append(pd.DataFrame({"held_length_mm": ell * 1e3, "pressure_kPa": seq / 1e3, "force_N": f,
                                          "direction": dirn, "trial": t, "muscle": name, "rest_length_mm": rest * 1e3}))
    pd.concat(rows).to_csv(tmp_path / "fam.csv", index=False)
    table = read_table(tmp_path / "fam.csv")
    fit = fit_direction_aware(table, muscle, LAW, "play")
    assert _within(fit.result, "play_threshold_Pa", R_TRUE)
    assert fit.result.residual_rms == pytest.approx(NOISE_N, rel=0.2)
    with pytest.raises(InputError, match="fitted on one muscle"):
        fit_direction_aware(table, muscle, "hunt-quinn", "play")
