"""The stuck-sensor rule on the plant: healthy muscles are never vented, dead sensors are caught.

Supervisor 3 (``docs/controller.md``) predicts from the identified valve model whether the
reading must move under the applied command. Here the firmware core (bit-exact mirror) runs on
the batch plant simulator with random references, supplies, loads and valves; nothing is mocked.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mckibben.control import runs as E
from mckibben.control.controllers import pid_params, with_supervisor_model
from mckibben.control.core import FAULT_ADC_RANGE, FAULT_MISSING, FAULT_STUCK, CoreParams, core_spec
from mckibben.control.faults import FAULT_FIXED_READING, FAULT_STUCK_SENSOR, instrumented_spec

SENSOR_FAULTS = FAULT_STUCK | FAULT_ADC_RANGE | FAULT_MISSING
#: The stated detection time: n_stuck samples after the first command under which the model
#: predicts a change, plus the few periods the law takes to open a valve that far. [samples]
REACT = 30


@pytest.fixture(scope="module")
def model():
    return E.identify_plant()[1]


def _controllers(model):
    base = with_supervisor_model(CoreParams(), model)
    return [E.smc_core_params(model), E.smc_core_params(model, 120.0, law="paper"),
            E.smc_core_params(model, 255.0, law="paper"), pid_params(E.default_pid(model), base=base)]


@st.composite
def healthy_batch(draw):
    n = 8
    supply = draw(st.lists(st.floats(0.15e6, 1.0e6), min_size=n, max_size=n))
    load = draw(st.lists(st.floats(0.0, 3.0), min_size=n, max_size=n))
    valve = draw(st.lists(st.floats(0.8, 1.2), min_size=n, max_size=n))
    volume = draw(st.lists(st.floats(0.8, 1.2), min_size=n, max_size=n))
    # piecewise-constant references in [0, p_max], some above the supply, 4 levels of 0.3 s
    levels = draw(st.lists(st.lists(st.floats(0.0, 0.8e6), min_size=4, max_size=4), min_size=n, max_size=n))
    law = draw(st.lists(st.integers(0, 3), min_size=n, max_size=n))
    return supply, load, valve, volume, levels, law


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(case=healthy_batch())
def test_healthy_plants_are_never_vented(model, case):
    supply, load, valve, volume, levels, law = case
    ctrls = _controllers(model)
    steps = 300
    ref = np.repeat(np.asarray(levels), steps, axis=1)
    plant = E.plant_batch(supply_Pa=supply, load_N=load, valve_gain=valve, volume=volume)
    rec = E.run_closed_loop(core_spec([ctrls[k] for k in law]), ref, ref.shape[1] * 1e-3, plant)
    bad = np.bitwise_or.reduce(rec.faults.astype(np.int64), axis=1) & SENSOR_FAULTS
    assert not bad.any(), (bad, law, supply)


def test_a_step_above_the_supply_ends_at_the_supply_without_fault(model):
    # the case: the chamber cannot rise further, the valve stays wide open, the reading
    # stops moving; the supply's limit is not a sensor fault
    n = 1500
    ref = E.step_reference(n, 50, 0.0, 0.55e6)
    ctrls = _controllers(model)
    rec = E.run_closed_loop(core_spec(ctrls), ref, n * 1e-3, E.plant_batch(supply_Pa=0.3e6))
    assert not np.any(rec.faults)
    assert np.all(rec.pressure[:, -1] < 0.3e6 + 1e3)
    # our law, the paper's at beta 255 and the PID open the inlet wide: the chamber ends at the
    # supply's pressure (the paper's law at beta 120 commands at most 120 counts, barely past the
    # valves' lift-off: it stops below)
    assert np.all(np.abs(rec.pressure[[0, 2, 3], -1] - 0.3e6) < 10e3)


def _faulty_run(model, kind, value, levels, onset, supply=0.9e6):
    """Our law through a level sequence, a sensor fault from ``onset``; the true pressure too."""
    params = E.smc_core_params(model)
    steps = 400
    ref = np.repeat(np.asarray(levels, dtype=float), steps)
    spec = instrumented_spec([params], ref.size, kinds=[kind], onsets=[onset], values=[value])
    rec = E.run_closed_loop(spec, ref, ref.size * 1e-3, E.plant_batch(supply_Pa=supply))
    return params, rec, steps


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(high=st.floats(0.5e6, 0.8e6), hold=st.floats(0.1e6, 0.4e6), after=st.floats(0.0, 0.8e6),
       onset=st.integers(850, 1150))
def test_a_frozen_sensor_is_caught_within_the_stated_time(model, high, hold, after, onset):
    # the supply has shown `high`; the sensor freezes while the chamber holds `hold`; then the
    # reference moves by at least 100 kPa: the command that follows must move the reading
    if abs(after - hold) < 0.1e6:
        after = hold + 0.2e6 if hold + 0.2e6 <= 0.8e6 else hold - 0.2e6
    params, rec, steps = _faulty_run(model, FAULT_STUCK_SENSOR, 0, [0.0, high, hold, after], onset)
    stuck = np.flatnonzero(rec.faults[0] & FAULT_STUCK)
    assert stuck.size, (high, hold, after)
    assert stuck[0] >= onset  # never before the fault
    assert stuck[0] <= 3 * steps + params.n_stuck + REACT  # within n_stuck + REACT of the move
    assert np.all(rec.bleed[0, stuck[0]:] == 255)  # vented


@pytest.mark.parametrize("value, flag", [(0, FAULT_STUCK), (1023, FAULT_ADC_RANGE)])
def test_a_disconnected_or_railed_sensor_is_caught(model, value, flag):
    # the wire drops (0 counts) or shorts to the rail (1023) while the chamber holds 0.3 MPa after
    # the supply showed 0.6 MPa: the inlet opens wide for a reading that never rises
    onset = 600
    params, rec, _ = _faulty_run(model, FAULT_FIXED_READING, value, [0.6e6, 0.3e6, 0.3e6], onset)
    hit = np.flatnonzero(rec.faults[0] & flag)
    assert hit.size and onset <= hit[0] <= onset + params.n_stuck + REACT
    assert np.all(rec.bleed[0, hit[0]:] == 255)


def test_cli_step_above_the_supply_warns_that_the_target_is_unreachable(cli):
    r = cli("control", "step", "--supply", "0.3MPa", "--target", "0.55MPa", "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["faults"] == 0 and out["target_unreachable"] is True
    assert out["peak_pressure_Pa"] < 0.3e6 + 1e3
    assert "warning: the target 0.55 MPa is unreachable" in r.err and r.err.count("\n") == 1
    # a reachable target: no warning
    r = cli("control", "step", "--target", "0.3MPa", "--json")
    assert r.code == 0 and r.json()["target_unreachable"] is False and "warning" not in r.err


@pytest.mark.parametrize("fmt", [["--json"], []])
def test_cli_shows_faults_in_every_format(cli, fmt):
    # the paper's law at beta 255 on a 1 MPa supply ten times p_max overshoots past p_max + margin
    # (the supervisor's lead cut and headroom cap hold it below that at the default 0.8 MPa): the vent
    r = cli("control", "step", "--law", "paper", "--beta", "255", "--target", "0.1MPa", "--p-max", "0.1MPa",
            "--supply", "1MPa", *fmt)
    assert r.code == 0, r.err
    assert "warning: the supervisor reported faults: overpressure" in r.err
