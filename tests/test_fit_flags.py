"""Fit flags mean doubt about predictions (issue 33, item 2): data generated from known parameters."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.fit.core import AT_BOUND_REL, COND_FLAG, at_bounds, bounded_fit
from mckibben.models.flags import FIT_NOTES, split_fit_flags

RNG = np.random.default_rng(33)


def _fit(model, y, starts, names, lo, hi):
    return bounded_fit(model, y, starts, names, lo, hi, model="test", response="force_N", what="test fit",
                       valid_range={}, func=lambda v, **kw: model(v))


def test_unconstrained_parameter_is_flagged():
    # F = a·x + k·exp((x − 3)/0.1): an end-stop term that only acts beyond the measured x ≤ 1, so no
    # change of k of its own size (500 N, its start) moves a prediction by the noise (0.5 N); a and k are not
    # correlated (k's column is ~1e-9 of a's), k is simply not seen by the data
    x = np.linspace(0.0, 1.0, 60)

    def model(v):
        return v[0] * x + v[1] * np.exp((x - 3.0) / 0.1)

    y = model([100.0, 100.0]) + RNG.normal(0, 0.5, x.size)
    res = _fit(model, y, [[80.0, 500.0]], ("a_N", "k_N"), [-np.inf, -np.inf], [np.inf, np.inf])
    assert "k_N_unconstrained" in res.flags, res.flags
    assert res.se("k_N") > 1e4  # its interval is far wider than its value
    assert not any(f.startswith("a_N") for f in res.flags), res.flags
    assert "correlated_parameters" not in res.notes
    # the same law measured out to x = 3.2, where the term acts: k is seen, no flag
    x = np.linspace(0.0, 3.2, 60)
    y = model([100.0, 100.0]) + RNG.normal(0, 0.5, x.size)
    res = _fit(model, y, [[80.0, 500.0]], ("a_N", "k_N"), [-np.inf, -np.inf], [np.inf, np.inf])
    assert res.flags == (), res.flags
    assert res["k_N"] == pytest.approx(100.0, rel=0.05)  # 0.5 N of noise against a term of up to 740 N


def test_parameter_at_a_one_sided_bound_of_zero_is_flagged():
    # F = a·x + g·x² with g = −30 N generated, the law asks g ≥ 0: the fit presses g onto 0
    x = np.linspace(0.0, 1.0, 50)

    def model(v):
        return v[0] * x + v[1] * x * x

    y = model([100.0, -30.0]) + RNG.normal(0, 0.3, x.size)
    res = _fit(model, y, [[50.0, 5.0], [120.0, 1.0]], ("a_N", "g_N"), [-np.inf, 0.0], [np.inf, np.inf])
    assert res["g_N"] == pytest.approx(0.0, abs=1e-6)
    assert "g_N_at_lower_bound" in res.flags, res.flags
    assert np.isnan(res.se("g_N"))  # held at the bound for the covariance


def test_a_value_just_above_a_bound_of_zero_is_at_it():
    # |value| is no span for a one-sided bound: 1e-11 above 0 is at 0 when the parameter's magnitude is 5
    assert at_bounds([1e-11], [0.0], [np.inf], [5.0]).tolist() == [-1]
    assert at_bounds([5e-3 * 1.001], [0.0], [np.inf], [5.0]).tolist() == [0]  # just beyond AT_BOUND_REL·5
    assert AT_BOUND_REL * 5.0 < 5e-3 * 1.001
    assert at_bounds([0.9999999], [0.0], [1.0], [1.0]).tolist() == [1]


def test_correlated_but_predictive_fit_is_not_discarded():
    # F = a·P + b·P·L with L within 1e-6 of 1: a and b trade off (their separate intervals are
    # enormous), but a + b is pinned and every prediction within the data is right
    p = np.tile(np.linspace(0.1, 1.0, 20), 3)
    ell = np.repeat([1.0, 1.0 + 5e-7, 1.0 + 1e-6], 20)

    def model(v):
        return v[0] * p + v[1] * p * ell

    y = model([60.0, 40.0]) + RNG.normal(0, 0.2, p.size)
    res = _fit(model, y, [[50.0, 50.0], [10.0, 90.0]], ("a_N", "b_N"), [-np.inf, -np.inf], [np.inf, np.inf])
    assert res.condition_number > COND_FLAG
    assert res.flags == (), res.flags
    assert res.notes == ("correlated_parameters",)
    assert np.max(res.stderr) > 100.0  # each parameter alone: intervals far wider than its value
    assert res.residual_rms == pytest.approx(0.2, rel=0.3)  # predicts to the noise (0.2 N generated)
    assert res.to_dict()["notes"] == ["correlated_parameters"]


def test_notes_are_split_from_flags():
    flags, notes = split_fit_flags(["large_offset", "negative_area", "x_at_lower_bound"])
    assert flags == ("large_offset", "x_at_lower_bound") and notes == ("negative_area",)
    assert set(FIT_NOTES) == {"correlated_parameters", "negative_area", "<name>_from_prior"}


def test_heldout_far_above_insample_is_a_flag_of_compare():
    from mckibben.data import read_muscle, read_table
    from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
    from mckibben.fit.core import HELDOUT_RATIO, heldout_flags
    from mckibben.fit.isometric import compare_isometric

    assert heldout_flags(3.01, 1.0) == ("heldout_far_above_insample",) and heldout_flags(2.99, 1.0) == ()
    assert HELDOUT_RATIO == 3.0
    folder = BUNDLED_ISOMETRIC / "commercial10"
    c = compare_isometric(read_table(folder / "isometric.csv"), read_muscle(folder / "muscle.toml"),
                          models=["surface", "chou-hannaford"])
    for s in c.scores:  # the comparison's own figures decide the flag, and it is in the flags `best` reads
        far = s["cv_rmse_interpolated_N"] > HELDOUT_RATIO * s["rmse_interpolated_N"]
        assert ("heldout_far_above_insample" in s["flags"]) == far, s
        assert isinstance(s["notes"], list)
        # the held-out figure the flag reads is the one of the folds that interpolate
        inner = [x for x in s["folds"] if not x["extrapolated"]]
        assert 0 < len(inner) < len(s["folds"])  # four held lengths: the two extreme ones extrapolate
        n = sum(x["n_points"] for x in inner)
        # rtol: sums of squares regrouped, float64
        assert_allclose(s["cv_rmse_interpolated_N"] ** 2 * n, sum(x["rmse_N"] ** 2 * x["n_points"] for x in inner),
                        rtol=1e-9)
    assert c.best in {s["model"] for s in c.scores if not s["flags"]} or c.best_flagged


def test_heldout_ratio_reads_the_interpolating_folds():
    """An extrapolated fold's error (every law pays it) does not flag; the same error inside the range does."""
    from mckibben.fit.core import heldout_flags, interpolated_rms

    rng = np.random.default_rng(3)
    residuals = rng.normal(0.0, 1.0, 40)  # in-sample, unit noise
    heldout = residuals * 1.5  # held out: a fit that generalizes loses ~1.5x
    inside = np.ones(40, dtype=bool)
    inside[:10] = False  # the first fold (10 points) predicts beyond the fitted range
    heldout[:10] = 20.0  # and misses by 20x the noise there
    cv_all = float(np.sqrt(np.mean(heldout**2)))
    assert heldout_flags(cv_all, float(np.sqrt(np.mean(residuals**2))))  # the pooled ratio would flag it
    cv, fit = interpolated_rms(heldout, residuals, inside)
    assert_allclose(cv / fit, 1.5, rtol=1e-12)  # rtol: the same points, scaled by 1.5 exactly
    assert heldout_flags(cv, fit) == ()
    heldout[10:20] = 20.0  # the same miss inside the range: a fit that describes only what it saw
    assert heldout_flags(*interpolated_rms(heldout, residuals, inside)) == ("heldout_far_above_insample",)
    # every fold extrapolating: all points; nothing predicted: no figure, no flag
    assert_allclose(interpolated_rms(heldout, residuals, np.zeros(40, bool))[0], float(np.sqrt(np.mean(heldout**2))))
    nan = interpolated_rms(np.full(3, np.nan), np.ones(3), np.ones(3, bool))
    assert np.isnan(nan[0]) and heldout_flags(*nan) == ()
