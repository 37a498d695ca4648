"""Identification: recover known FOPDT/SOPDT parameters from generated step responses."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.control.identify import fit_step_response, fopdt_response, sopdt_response
from mckibben.errors import InputError

TS = 1e-3


def test_fopdt_recovered_with_noise_and_stderr_covers_truth():
    rng = np.random.default_rng(1)
    t = np.arange(0, 1.0, TS)
    u = np.where(t >= 0.1, 180.0, 20.0)
    truth = dict(gain=3000.0, tau=0.09, dead_time=0.008)
    y = fopdt_response(t, truth["gain"], truth["tau"], truth["dead_time"], y0=60e3, t_step=0.1, input_step=160)
    y = y + rng.normal(0, 2e3, t.size)  # 2 kPa white noise, ~2 ADC counts of the 0-1 MPa sensor
    f = fit_step_response(t, y, u)
    assert f.input_step == 160.0 and f.t_step == pytest.approx(0.1)
    # white noise: the truth lies within 4 standard errors (p > 0.9999 for a correct covariance)
    for k, key in (("gain", "gain"), ("tau", "tau_s"), ("dead_time", "dead_time_s")):
        assert abs(f.params[key] - truth[k]) < 4 * f.se(key), key
    # and the standard errors are small: < 1 % of tau, < 1 ms of dead time at this noise level
    assert f.se("tau_s") < 0.01 * truth["tau"] and f.se("dead_time_s") < 1e-3
    assert_allclose(np.std(f.residuals), 2e3, rtol=0.1)  # residuals are the noise (rtol: 1000 samples)
    lo, hi = f.confidence_intervals(0.99)["tau_s"]
    assert lo < truth["tau"] < hi


def test_second_order_fit_and_aic_prefers_true_order():
    t = np.arange(0, 0.6, TS)
    y = sopdt_response(t, 2.0, 60.0, 0.5, 0.005, t_step=0.05, input_step=100.0)
    y = y + np.random.default_rng(2).normal(0, 1.0, t.size)
    f2 = fit_step_response(t, y, np.where(t >= 0.05, 100.0, 0.0), order=2)
    f1 = fit_step_response(t, y, np.where(t >= 0.05, 100.0, 0.0), order=1)
    # noise 1 on a 200 step: parameters within 2 % (several stderr, checked loosely)
    assert_allclose([f2.gain, f2.params["wn_rad_s"], f2.params["zeta"]], [2.0, 60.0, 0.5], rtol=0.02)
    assert f2.aic < f1.aic  # an underdamped response is not first order


def test_first_order_transfer_function_dcgain():
    t = np.arange(0, 1.0, TS)
    y = fopdt_response(t, 1500.0, 0.05, 0.0, t_step=0.0, input_step=100.0)
    f = fit_step_response(t, y, np.where(t > 0, 100.0, 0.0), t_step=0.0, input_step=100.0)
    assert_allclose(f.transfer_function().dcgain(), 1500.0, rtol=1e-4)  # noiseless: fit is exact


@pytest.mark.parametrize(
    "t, y, u, msg",
    [
        (np.arange(5.0), np.arange(5.0), None, "at least 10"),
        (np.arange(20.0), np.ones(20), np.ones(20), "never changes"),
        (np.arange(20.0), np.ones(20), np.r_[np.zeros(10), np.ones(10)], "does not respond"),
        (np.arange(20.0), np.r_[np.nan, np.ones(19)], None, "NaN"),
    ],
)
def test_bad_input(t, y, u, msg):
    with pytest.raises(InputError, match=msg):
        fit_step_response(t, y, u)
