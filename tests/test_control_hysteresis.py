"""Hysteresis compensation for length control: its measured benefit on the plant simulator.

Numbers measured on the calibrated default plant (docs/hysteresis.md), sliding mode (our law,
SMC_TUNING), length target 90.0 ± 6.2 mm, period 4 s, errors after the first cycle:

- sweep 32 s (default, 8 × period): single cubic RMS 2.35 mm / max 3.87 mm, branches RMS
  0.38 mm / max 1.09 mm (ratios 0.16 / 0.28), loop width 41 kPa at the mean length;
- sweep 4 s (as fast as the tracking): loop width 88 kPa, branches RMS 2.31 mm against 2.50 mm
  (ratio 0.93), max 5.29 mm against 3.98 mm: the over-wide branches buy nothing."""

from __future__ import annotations

import numpy as np
import pytest

from mckibben.control.runs import identify_plant
from mckibben.control.hysteresis import hysteresis_benefit
from mckibben.errors import InputError


@pytest.fixture(scope="module")
def model():
    return identify_plant()[1]


@pytest.fixture(scope="module")
def result(model):
    return hysteresis_benefit(model, period=4.0)


def test_compensation_reduces_length_error(result):
    assert result.sweep_period == 32.0
    single_rms, branch_rms = result.rms_error
    single_max, branch_max = result.max_error
    # measured 2.33 mm: the single map's error is the half-width of the loop, millimetres
    assert 1.5e-3 < single_rms < 3.5e-3
    # measured ratios 0.16 (RMS) and 0.29 (max)
    assert branch_rms < 0.3 * single_rms
    assert branch_max < 0.5 * single_max
    assert result.rms_ratio == pytest.approx(branch_rms / single_rms)


def test_branch_fits_bracket_the_sweep(result):
    b = result.branches
    lo, hi = b.length_range
    ell = np.linspace(lo, hi, 50)
    # inflating needs more pressure than deflating for the same length, everywhere in the range
    width = b.width(ell)
    assert np.all(width > 15e3), width.min()
    # the single cubic lies between the branches
    mid = result.single(ell)
    assert np.all(b.pressure(ell, False) < mid) and np.all(mid < b.pressure(ell, True))
    # each branch fits its own half of the sweep to a few kPa, far better than the single cubic
    assert max(b.rmse_inflate, b.rmse_deflate) < 5e3 < result.rmse_single
    # the sweep's samples sit on their branch's side of the single cubic
    m, up = result.fit_mask, result.sweep_inflating
    p, l_sw = result.sweep_pressure[m], result.sweep_length[m]
    above = p > result.single(l_sw)
    assert above[up[m]].mean() > 0.95 and (~above[~up[m]]).mean() > 0.95
    # the target stays inside the fitted range
    assert lo <= result.length_ref.min() and result.length_ref.max() <= hi


def test_a_sweep_as_fast_as_the_tracking_buys_nothing(model, result):
    """Why the sweep is 8× slower by default: at 4 s viscous lag doubles the loop's width."""
    fast = hysteresis_benefit(model, period=4.0, sweep_period=4.0)
    assert fast.branches.width(fast.mean) > 1.5 * result.branches.width(result.mean)  # 88 vs 41 kPa
    assert fast.rms_ratio > 0.8  # measured 0.95
    assert fast.max_ratio > 1.0  # measured 1.34: worse at the reversals


@pytest.mark.parametrize("kwargs, match", [
    ({"period": 0.5}, "period"),
    ({"period": float("nan")}, "period"),
    ({"cycles": 1}, "cycles"),
    ({"sweep_period": 1e4}, "sweep_period"),
    ({"mean": 0.070}, "fitted range"),
])
def test_bad_arguments(model, kwargs, match):
    with pytest.raises(InputError, match=match):
        hysteresis_benefit(model, **kwargs)


def test_cli_json(cli, tmp_path):
    out = tmp_path / "hyst.svg"
    r = cli("control", "hysteresis", "--period", "4s", "--json", "--plot", str(out))
    assert r.code == 0, r.err
    d = r.json()
    assert {"period_s", "sweep_period_s", "cycles", "length_mean_m", "length_amplitude_m", "fit_length_range_m",
            "fit_rmse_Pa", "hysteresis_width_at_mean_Pa", "single_cubic", "branches", "rms_ratio",
            "max_ratio"} <= set(d)
    for method in ("single_cubic", "branches"):
        assert set(d[method]) == {"rms_error_m", "max_error_m"}
    assert d["period_s"] == 4.0 and d["sweep_period_s"] == 32.0
    assert d["branches"]["rms_error_m"] < 0.3 * d["single_cubic"]["rms_error_m"]
    assert out.read_text().lstrip().startswith("<?xml")


@pytest.mark.parametrize("args, message", [
    (("--period", "-1s"), "--period"),
    (("--period", "abc"), "--period"),
    (("--period", "0s"), "--period"),
    (("--period", "120s"), "--period"),
    (("--sweep-period", "5kg"), "--sweep-period"),
    (("--plot", "loop.xyz"), "--plot"),
])
def test_cli_bad_input_exits_2(cli, args, message):
    r = cli("control", "hysteresis", *args)
    assert r.code == 2
    assert message in r.err and r.err.count("\n") == 1


def test_prandtl_ishlinskii_compensation_beside_the_branches(result):
    """The PI variant (its own sweep with minor loops, the exact inverse as feed-forward).

    Measured at 4 s (sweep 32 s): RMS 0.97 mm, max 2.42 mm against the single cubic's
    2.35 / 3.87 mm (ratios 0.41 / 0.63); the branches, fitted on the major loop the sinusoid
    follows, do better (0.38 mm)."""
    s = result.summary()
    pi = s["prandtl_ishlinskii"]
    assert pi["rms_error_m"] == result.pi_rms_error
    assert result.pi_rms_error < 0.6 * result.rms_error[0]
    assert result.pi_max_error < 0.9 * result.max_error[0]
    # the identified operator: weights >= 0 summing to 1, invertible, standard errors reported
    w = result.pi.model.weights
    assert np.all(w >= 0) and w[0] > 0 and w.sum() == pytest.approx(1.0)
    assert len(pi["weights_stderr"]) == w.size
    # the feed-forward is the exact inverse: the operator maps it back onto the (clipped) target
    ell = np.clip(result.length_ref, *result.pi.length_range)
    back, _ = result.pi.length(result.pi.pressure(result.length_ref)[0])
    np.testing.assert_allclose(back, ell, atol=1e-9)
