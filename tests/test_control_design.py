"""Controller design and wrappers: PID lambda tuning, the core wrappers, the supervised callable."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.control import core
from mckibben.control.controllers import (
    FirstOrderModel,
    PIDController,
    SlidingModeController,
    adc_from_pressure,
    design_pid,
    pid_params,
    smc_params,
    supervised,
)
from mckibben.errors import InputError

MODEL = FirstOrderModel(gain=2500.0, tau=0.09, dead_time=0.0)


def test_lambda_tuning_without_dead_time_gives_first_order_loop():
    d = design_pid(MODEL, 0.03)
    # PI with Ti = tau cancels the plant pole: the closed loop is exactly 1/(lambda s + 1)
    assert_allclose(d.kp, 0.09 / (2500 * 0.03))
    assert_allclose(d.ki, d.kp / 0.09)
    # step_response on a 4000-point grid over 1.2 s: 0.3 ms resolution, interpolated
    assert_allclose(d.predicted["time_constant_s"], 0.03, rtol=0.01)
    assert d.predicted["overshoot_pct"] < 0.1  # first order: no overshoot up to grid noise
    assert d.phase_margin_deg > 85  # a pure integrator loop has 90 degrees


def test_lambda_tuning_with_dead_time_is_stable_with_margin():
    d = design_pid(FirstOrderModel(2500.0, 0.09, 0.01), 0.01, derivative=True)
    # SIMC with lambda = theta aims at ~60 deg phase margin and gain margin ~3
    assert 45 < d.phase_margin_deg < 80 and d.gain_margin > 2.5
    assert d.kd > 0 and d.tf >= 1e-3


def _simulate_linear(ctl, model, p_ref, n=600, ts=1e-3, substeps=20):
    """The identified first-order model under a core controller (Euler, 20 substeps/period)."""
    p = 0.0
    ps, us = [], []
    for _ in range(n):
        u = ctl.step(p, p_ref)
        for _ in range(substeps):
            p += ts / substeps * (model.gain * u - p) / model.tau
        ps.append(p)
        us.append(u)
    return np.array(ps), np.array(us)


def test_wrapped_pid_tracks_its_design_model():
    d = design_pid(MODEL, 0.03)
    ps, us = _simulate_linear(PIDController(pid_params(d)), MODEL, 0.3e6)
    # 0.3 MPa needs 120 counts: below saturation; quantization of the ADC (978 Pa) and PWM
    # (1 count = 2.5 kPa) limits the steady error to a few counts' worth
    assert abs(ps[-1] - 0.3e6) < 5e3
    t63 = np.argmax(ps >= 0.632 * 0.3e6) * 1e-3
    assert 0.02 < t63 < 0.045  # lambda = 30 ms plus the initial saturation at 255 counts


def test_wrapped_smc_reaches_reference_on_its_model():
    ctl = SlidingModeController(smc_params(MODEL, beta=120, eps=20e3, ki=10))
    ps, _ = _simulate_linear(ctl, MODEL, 0.55e6)
    assert abs(ps[-1] - 0.55e6) < 5e3  # ADC and PWM quantization, as above
    assert ctl.faults == 0


def test_controller_clamps_reference_to_p_max():
    ctl = SlidingModeController(smc_params(MODEL, beta=120, eps=20e3, ki=10))
    ctl.step(0.0, 5e6)
    assert ctl.core.reference_pa == 800_000  # the supervisor's clamp (default p_max 0.8 MPa)


def test_supervised_callable_cannot_overpressurize():
    greedy = supervised(lambda t, adc, enc, p_ref: (255, 0))
    adc_ok = adc_from_pressure(0.5e6)
    assert greedy(0.0, adc_ok, 0, 0.7e6) == (255, 0)  # below the limit the callable decides
    over = adc_from_pressure(0.8e6 + 25e3)  # beyond p_max + 20 kPa margin
    assert greedy(0.001, over, 0, 0.7e6) == (0, 255)
    assert greedy.faults & core.FAULT_OVERPRESSURE
    # vents until the pressure is back below p_max, then the callable decides again, its inlet
    # within the headroom cap, (p_max - p) >> 8 counts: 255 from 65.3 kPa below p_max down
    assert greedy(0.002, adc_from_pressure(0.805e6), 0, 0.7e6) == (0, 255)
    inlet, bleed = greedy(0.003, adc_from_pressure(0.79e6), 0, 0.7e6)
    assert 0 < inlet <= 10e3 / 256 + 2 and bleed == 0
    assert greedy(0.004, adc_from_pressure(0.7e6), 0, 0.7e6) == (255, 0)


def test_supervised_callable_vents_on_sensor_fault_and_sees_clamped_reference():
    seen = []

    def f(t, adc, enc, p_ref):
        seen.append(p_ref)
        return 200, 0

    g = supervised(f)
    assert g(0.0, 1023, 0, 2e6) == (0, 255)  # 1023 is outside adc_max = 1022: open/shorted wire
    assert g.faults & core.FAULT_ADC_RANGE
    assert seen == [0.8e6]
    assert g(0.001, 500, 0, 0.5e6) == (0, 255)  # latched


def test_adc_quantization():
    assert adc_from_pressure(0.0) == 0 and adc_from_pressure(2e6) == 1023
    assert_allclose(adc_from_pressure(np.array([0.5e6])) * 1e6 / 1023, 0.5e6, atol=1e6 / 1023 / 2)


def test_bad_design_inputs():
    with pytest.raises(InputError, match="closed_loop_tau"):
        design_pid(MODEL, 0.0)
    with pytest.raises(InputError, match="gain > 0"):
        design_pid(FirstOrderModel(-1.0, 0.09), 0.03)
    with pytest.raises(InputError, match="beta"):
        SlidingModeController(smc_params(MODEL, beta=400, eps=20e3, ki=10))


def test_a_dead_time_zero_to_round_off_designs_like_none():
    # an identification can return θ = 1e-26 s; its Padé poles at 1e26/s overflowed the design
    a = design_pid(FirstOrderModel(6.3e4, 0.108, 1e-26), 0.036)
    b = design_pid(FirstOrderModel(6.3e4, 0.108, 0.0), 0.036)
    assert a.kp == b.kp and a.predicted == b.predicted
