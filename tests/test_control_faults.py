"""The fault-injecting, surface-recording wrapper of the core kernel (driven step by step)."""

from __future__ import annotations

import numpy as np
import pytest

from mckibben.control import core
from mckibben.control.controllers import adc_from_pressure
from mckibben.control.faults import instrumented_spec
from mckibben.errors import InputError


def _drive(spec, adcs, p_ref):
    kern, ist, ip, fst, fp = spec
    out = []
    for a in adcs:
        out.append(kern(ist[0], ip[0], fst[0], fp[0], int(a), 0, True, p_ref))
    return np.array(out), fst[0]


def test_records_the_same_surface_as_the_bare_core():
    params = core.CoreParams(n_stuck=0)
    adcs = np.linspace(0, 500, 50).astype(int)
    out, s = _drive(instrumented_spec([params], 50), adcs, 0.55e6)
    bare = core.CoreController(params)
    surf, cmds = [], []
    for a in adcs:
        cmds.append(bare.step(int(a), True, 0.55e6))
        surf.append(bare.surface_pa)
    assert np.array_equal(out, np.array(cmds))  # no fault: the wrapper is transparent, bit for bit
    assert np.array_equal(s, np.array(surf, dtype=float))


def test_stuck_sensor_is_caught_by_the_core_supervisor():
    # the paper's law (no model term) with beta 200: the bleed opens at ~200 counts
    params = core.CoreParams(n_stuck=20, g=0.0, beta=200.0)
    # the true pressure falls from 0.59 MPa towards a 0.2 MPa reference with the bleed open, but
    # from step 5 on the controller sees the reading of step 5: no response to the bleed
    adcs = np.linspace(600, 200, 60).astype(int)
    out, _ = _drive(instrumented_spec([params], 60, kinds=[1], onsets=[5]), adcs, 0.2e6)
    stuck = np.flatnonzero(out[:, 2] & core.FAULT_STUCK)
    # the fault after n_stuck = 20 unchanged readings while the model predicts a fall
    assert stuck.size and 5 + 19 <= stuck[0] <= 5 + 21
    assert np.all(out[stuck[0]:, 1] == 255) and np.all(out[stuck[0]:, 0] == 0)
    # the same fall with a healthy sensor: no fault
    out, _ = _drive(instrumented_spec([params], 60), adcs, 0.2e6)
    assert not np.any(out[:, 2])


def test_missing_and_fixed_reading_vent():
    params = core.CoreParams(n_missing=10)
    adc = adc_from_pressure(0.3e6)
    out, _ = _drive(instrumented_spec([params], 40, kinds=[2], onsets=[10]), [adc] * 40, 0.5e6)
    assert out[19, 2] & core.FAULT_MISSING and out[19, 1] == 255 and not out[18, 2]
    out, _ = _drive(instrumented_spec([params], 40, kinds=[3], onsets=[3], values=[1023]), [adc] * 40, 0.5e6)
    assert out[3, 2] & core.FAULT_ADC_RANGE and np.all(out[3:, 1] == 255)


def test_bad_fault_kind():
    with pytest.raises(InputError, match="fault kinds"):
        instrumented_spec([core.CoreParams()], 10, kinds=[7])
