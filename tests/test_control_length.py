"""Length control pieces: static feed-forward, hysteresis branches, the outer-loop kernel."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.control import core
from mckibben.control.controllers import adc_from_pressure
from mckibben.control.length import (
    FS_CORR,
    fit_hysteresis_branches,
    inflating_direction,
    length_feedforward,
    length_loop_spec,
)
from mckibben.datasets import get_muscle
from mckibben.errors import InputError, UnreachableError
from mckibben.models.mpam import predict_length


def test_feedforward_inverts_the_static_model():
    m = get_muscle("mpam97")
    p = np.linspace(0.1e6, 0.8e6, 8)
    ell = predict_length(m, p, 0.6).length
    # the paper's worked example: 0.8 MPa under 0.6 N -> 78.1 mm; the inverse returns the pressure
    assert_allclose(length_feedforward(ell, muscle=m, load=0.6), p, rtol=1e-6)  # Newton-polished roots


def test_feedforward_unreachable_is_an_error():
    with pytest.raises(UnreachableError, match="unreachable"):
        length_feedforward(np.array([0.05]))


def test_branches_recover_known_hysteresis():
    # a synthetic sweep: inflating needs 40 kPa more than deflating for the same length
    ell = np.linspace(0.080, 0.095, 200)
    p_up = 0.8e6 - 50e6 * (ell - 0.080) + 1e9 * (ell - 0.08) ** 2
    sweep_l = np.r_[ell[::-1], ell]
    sweep_p = np.r_[p_up[::-1], p_up - 40e3]
    up = np.r_[np.ones(200, bool), np.zeros(200, bool)]
    b = fit_hysteresis_branches(sweep_p, sweep_l, up)
    assert_allclose(b.width(ell), 40e3, atol=1e-3)  # exact cubic data: fit to round-off
    assert b.rmse_inflate < 1e-3 and b.rmse_deflate < 1e-3
    # the feed-forward follows the direction of the target
    ref = np.r_[np.linspace(0.094, 0.082, 30), np.full(5, 0.082), np.linspace(0.082, 0.09, 30)]
    ff = length_feedforward(ref, branches=b)
    up_ref = inflating_direction(ref)
    assert up_ref[:36].all() and not up_ref[36:].any()  # 36th sample repeats 82 mm: still holding
    assert_allclose(ff[34] - b.pressure(0.082, False), 40e3, atol=1e-3)


def test_branch_fit_needs_both_branches():
    with pytest.raises(InputError, match="too few deflating"):
        fit_hysteresis_branches(np.arange(20.0), np.arange(20.0), np.ones(20, bool))


def test_outer_loop_adds_pressure_when_too_long_and_supervisor_stays_below():
    params = core.CoreParams(mode=core.MODE_SMC, n_stuck=0)
    kern, ist, ip, fst, fp = length_loop_spec(params, np.full(100, 0.085), kp=2e7, ki=0.0, rest_length=0.097)
    # encoder 0 counts: the muscle is at rest length 97 mm, 12 mm too long -> +240 kPa, clamped to 100 kPa
    kern(ist[0], ip[0], fst[0], fp[0], adc_from_pressure(0.3e6), 0, True, 0.3e6)
    assert_allclose(fst[0, FS_CORR], 0.1e6)
    assert ist[0, core.IS_REFERENCE] == 400_000
    # a feed-forward above p_max is clamped by the core's supervisor, whatever the outer loop adds
    kern(ist[0], ip[0], fst[0], fp[0], adc_from_pressure(0.3e6), 0, True, 0.79e6)
    assert ist[0, core.IS_REFERENCE] == 800_000
    inlet, bleed, faults = kern(ist[0], ip[0], fst[0], fp[0], adc_from_pressure(0.9e6), 0, True, 0.5e6)
    assert (inlet, bleed) == (0, 255) and faults & core.FAULT_OVERPRESSURE


def test_length_loop_spec_bad_gain():
    with pytest.raises(InputError, match="kp"):
        length_loop_spec(core.CoreParams(), np.ones(3), kp=-1.0, ki=0.0, rest_length=0.1)
