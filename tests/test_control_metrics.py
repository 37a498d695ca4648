"""Step metrics against analytic responses with known parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.control.metrics import step_metrics, tracking_metrics
from mckibben.errors import InputError

TS = 1e-3


def first_order(t, k, tau, theta):
    return np.where(t >= theta, k * (1 - np.exp(-(t - theta) / tau)), 0.0)


def test_first_order_step_known_parameters():
    t = np.arange(0, 1.0, TS)
    y = first_order(t, 0.55e6, 0.06, 0.0)
    m = step_metrics(t, y, reference=0.55e6)
    # linear interpolation between 1 ms samples of a smooth exponential: error << 0.1 ms
    assert_allclose(m["time_constant_s"], 0.06, atol=1e-4)
    # step_info picks the first sample at/after 10 % and 90 %: one sample either side (atol=dt)
    assert_allclose(m["rise_time_s"], 0.06 * math.log(9), atol=TS)
    assert_allclose(m["settling_time_s"], 0.06 * math.log(50), atol=TS)
    assert m["overshoot_pct"] == 0.0
    # 1 - exp(-(0.9 s)/0.06 s) is within 1e-6 of 1: the steady-state error is below 1 Pa
    assert abs(m["steady_state_error_Pa"]) < 1.0


def test_second_order_overshoot_matches_formula():
    zeta, wn = 0.65, 300.0
    t = np.arange(0, 0.5, 1e-4)
    wd = wn * math.sqrt(1 - zeta**2)
    y = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    m = step_metrics(t, y, reference=1.0, unit="")
    expected = 100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    # the sampled peak misses the true one by at most (wd*dt)^2/8 relative: far below 0.05 %
    assert_allclose(m["overshoot_pct"], expected, atol=0.05)
    assert_allclose(m["peak_time_s"], math.pi / wd, atol=1e-4)  # atol = dt


def test_dead_time_step_later_and_downward():
    t = np.arange(0, 1.0, TS)
    r = np.where(t >= 0.1, 0.2e6, 0.5e6)
    y = 0.5e6 - first_order(t, 0.3e6, 0.05, 0.12)  # 20 ms dead time after the step at 0.1 s
    u = np.where(t >= 0.1, -40.0, 0.0)
    m = step_metrics(t, y, reference=r, commands=u)
    # the time constant counts from the step: dead time + tau; interpolation error << 0.1 ms
    assert_allclose(m["time_constant_s"], 0.02 + 0.05, atol=1e-4)
    assert_allclose(m["step_size_Pa"], -0.3e6)
    assert m["valve_effort_counts"] == 40.0 * np.count_nonzero(t >= 0.1)
    assert m["overshoot_pct"] == 0.0


def test_never_reaching_gives_nan_not_error():
    t = np.arange(0, 0.2, TS)
    m = step_metrics(t, 0.5 * (1 - np.exp(-t / 0.05)), reference=1.0, unit="")
    assert math.isnan(m["rise_time_s"]) and math.isnan(m["settling_time_s"])
    assert_allclose(m["steady_state_error_"], 0.5, atol=0.02)  # 0.5 e^{-3.6} residual rise


def test_tracking_metrics_sine():
    t = np.arange(0, 1.0, TS)
    r = np.sin(2 * np.pi * 5 * t)
    m = tracking_metrics(t, r - 0.1, r, commands=np.ones_like(t), unit="")
    assert_allclose(m["rms_error_"], 0.1)
    assert m["valve_effort_counts"] == len(t)


@pytest.mark.parametrize(
    "kwargs, msg",
    [
        ({"t": [0, 1, 1, 2], "y": [0, 1, 1, 1], "reference": 1.0}, "strictly increasing"),
        ({"t": [0, 1, 2, 3], "y": [0, 1, 1], "reference": 1.0}, "y has 3 samples"),
        ({"t": [0, 1, 2, 3], "y": [0, 1, np.nan, 1], "reference": 1.0}, "NaN"),
        ({"t": [0, 1, 2, 3], "y": [0, 1, 1, 1]}, "reference is required"),
        ({"t": [0, 1, 2, 3], "y": [0, 1, 1, 1], "reference": 0.0}, "step size is zero"),
    ],
)
def test_bad_input(kwargs, msg):
    with pytest.raises(InputError, match=msg):
        step_metrics(**kwargs)
