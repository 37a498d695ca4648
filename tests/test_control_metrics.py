"""Step metrics against analytic responses with known parameters."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from mckibben.control.metrics import step_metrics, step_metrics_batch, tracking_metrics, tracking_metrics_batch
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


# --- the batch scorer against python-control's step_info, row by row ---------------------------

FAMILIES = ("first_order", "second_order", "flat", "never", "nan", "noise", "no_settle", "ramp_back")


def _response(family, t, a, b, gain, seed):
    """One response on t with a step at t[2]: a family of shapes that covers the edge cases."""
    rng = np.random.default_rng(seed)
    tt = np.clip(t - t[2], 0.0, None)
    if family == "first_order":
        y = gain * (1 - np.exp(-tt / (a * 0.05)))
    elif family == "second_order":  # damping 0.05-0.95: overshoot, may not settle in the record
        zeta, wn = min(b / 2.1, 0.95), 20.0 / a
        wd = wn * math.sqrt(1 - zeta**2)
        y = gain * (1 - np.exp(-zeta * wn * tt) * (np.cos(wd * tt) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * tt)))
    elif family == "flat":
        y = np.full_like(t, gain * (b - 1.0))
    elif family == "never":  # stops short of 90 %
        y = 0.8 * gain * (1 - np.exp(-tt / (a * 0.02)))
    elif family == "nan":  # a run the simulator flagged
        y = gain * (1 - np.exp(-tt / 0.05))
        y[rng.integers(0, t.size)] = np.nan
    elif family == "noise":
        y = gain * (1 - np.exp(-tt / (a * 0.03))) + rng.normal(0.0, 0.05 * b, t.size)
    elif family == "no_settle":  # reaches the target, then oscillates around it outside ±2 %
        y = gain * (1 - np.exp(-tt / 0.01)) * (1 + 0.1 * b * np.sin(tt * 40.0 * a))
    else:  # overshoots and comes back below the start
        y = gain * np.sin(np.pi * tt / (t[-1] * a / 3.0))
    if rng.random() < 0.5:  # ADC-like quantization: ties between neighbours
        y = np.round(y * 20.0) / 20.0
    return y


def _step_info_metrics(t, y, r, c, t_step, threshold):
    """The per-run definition the batch must reproduce: control.step_info on the shifted record."""
    import control

    k0 = int(np.searchsorted(t, t_step))
    base = y[k0 - 1] if k0 > 0 else y[0]
    tt, yy = t[k0:] - t_step, y[k0:] - base
    step = r[-1] - base
    keys = ("time_constant_s", "rise_time_s", "settling_time_s", "overshoot_pct", "peak_time_s",
            "steady_state_error_", "rms_error_", "valve_effort_counts", "step_size_")
    out = dict.fromkeys(keys, math.nan)
    if not np.all(np.isfinite(y)) or step == 0:
        return out
    sgn = math.copysign(1.0, step)
    level = (1 - math.exp(-1)) * abs(step)
    for k in range(tt.size):  # first sample at/above 63.2 %, linear interpolation
        if sgn * yy[k] >= level:
            y1, y0 = sgn * yy[k], sgn * yy[k - 1] if k else math.nan
            out["time_constant_s"] = tt[k] if k == 0 or y1 == y0 else tt[k - 1] + (level - y0) * (tt[k] - tt[k - 1]) / (y1 - y0)
            break
    if np.any(sgn * yy >= 0.9 * abs(step)):
        info = control.step_info(yy, timepts=tt, final_output=step, SettlingTimeThreshold=threshold)
        out["rise_time_s"], out["settling_time_s"] = info["RiseTime"], info["SettlingTime"]
        out["overshoot_pct"], out["peak_time_s"] = info["Overshoot"], tt[int(np.argmax(sgn * yy))]
    n_ss = max(1, int(round(0.1 * yy.size)))
    out["steady_state_error_"] = r[-1] - np.mean(y[k0:][-n_ss:])
    out["rms_error_"] = np.sqrt(np.mean((r[k0:] - y[k0:]) ** 2))
    out["valve_effort_counts"] = np.abs(c[k0:]).sum()
    out["step_size_"] = step
    return out


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    rows=st.lists(st.tuples(st.sampled_from(FAMILIES), st.floats(0.05, 3.0), st.floats(0.05, 2.0),
                            st.sampled_from([1.0, -1.0, 0.55e6, -0.3e6, 2.5]), st.integers(0, 2**31)),
                  min_size=1, max_size=6),
    n=st.integers(6, 80),
    per_row_reference=st.booleans(),
    threshold=st.sampled_from([0.02, 0.05, 0.2]),
)
def test_batch_equals_step_info_row_by_row(rows, n, per_row_reference, threshold):
    t = np.arange(n) * 1e-3
    y = np.array([_response(f, t, a, b, g, s) for f, a, b, g, s in rows])
    targets = np.array([g for *_, g, _ in rows])
    r = np.where(np.arange(n) >= 2, targets[:, None], 0.0)
    c = np.random.default_rng(n).integers(-255, 256, y.shape)
    ref = r if per_row_reference else np.where(np.arange(n) >= 2, 1.0, 0.0)
    if not per_row_reference:
        r = np.broadcast_to(ref, y.shape)
    got = step_metrics_batch(t, y, ref, c, unit="", settling_threshold=threshold)  # t_step: the reference's step
    for i in range(len(rows)):
        want = _step_info_metrics(t, y[i], r[i], c[i], t[2], threshold)
        # the same floating-point operations in the same order: equal to the last bit
        assert {k: got[k][i] for k in want} == pytest.approx(want, rel=0, abs=0, nan_ok=True), rows[i]
        if np.all(np.isfinite(y[i])) and want["step_size_"] == want["step_size_"]:
            single = step_metrics(t, y[i], r[i], c[i], unit="", settling_threshold=threshold)
            assert single == pytest.approx({k: got[k][i] for k in single}, rel=0, abs=0, nan_ok=True)


def test_batch_flags_nan_and_zero_step_rows_and_keeps_the_others():
    t = np.arange(50) * 1e-3
    good = 1 - np.exp(-t / 0.01)
    y = np.stack([good, np.full(50, np.nan), np.zeros(50), good])
    m = step_metrics_batch(t, y, 1.0, np.ones((4, 50, 2)), unit="")
    for key, v in m.items():
        assert np.isnan(v[1]), key  # the simulator's non-finite run
        assert v[0] == v[3], key
    assert np.isnan(m["time_constant_s"][2]) and m["steady_state_error_"][2] == 1.0  # flat: never rises
    assert m["valve_effort_counts"][0] == 100.0  # (inlet, bleed) pairs, every sample (step at t[0])
    assert math.isnan(step_metrics_batch(t, np.ones((1, 50)), 1.0)["step_size_Pa"][0])  # zero step: NaN


def test_batch_refuses_rows_stepping_at_different_times():
    t = np.arange(10) * 1.0
    r = np.stack([np.where(t >= 2, 1.0, 0.0), np.where(t >= 3, 1.0, 0.0)])
    with pytest.raises(InputError, match="step at different times; give t_step"):
        step_metrics_batch(t, np.zeros((2, 10)), r)
    assert step_metrics_batch(t, np.tile(np.minimum(t / 5, 1), (2, 1)), r, t_step=2.0)["rise_time_s"].shape == (2,)


def test_tracking_batch_equals_tracking_metrics_row_by_row():
    t = np.arange(300) * 1e-3
    rng = np.random.default_rng(3)
    r = 0.4e6 + 0.1e6 * np.sin(2 * np.pi * 3 * t)
    y = r + rng.normal(0, 5e3, (5, 300))
    y[2, 7] = np.inf
    c = rng.integers(-255, 256, (5, 300))
    got = tracking_metrics_batch(t, y, r, c)
    for i in (0, 1, 3, 4):
        assert tracking_metrics(t, y[i], r, c[i]) == {k: got[k][i] for k in got}
    assert all(np.isnan(v[2]) for v in got.values())


def test_settling_at_the_last_sample_and_never():
    import control

    t = np.arange(20) * 1e-3
    last = np.r_[0.0, np.full(18, 1.1), 1.0]  # inside ±2 % only at the last sample
    never = np.r_[0.0, np.full(19, 1.1)]
    m = step_metrics_batch(t, np.stack([last, never]), 1.0, unit="")
    assert m["settling_time_s"][0] == control.step_info(last, timepts=t, final_output=1.0)["SettlingTime"] == t[-1]
    assert np.isnan(m["settling_time_s"][1]) and np.isnan(control.step_info(never, timepts=t, final_output=1.0)["SettlingTime"])
    assert m["overshoot_pct"][1] == pytest.approx(10.0)


def test_a_batch_larger_than_one_block_of_rows_equals_its_rows_scored_one_by_one():
    from mckibben.control.metrics import _ROWS

    rng = np.random.default_rng(5)
    n_rows = 2 * _ROWS + 77  # three blocks, the last one partial
    t = np.arange(120) * 1e-3
    target = rng.uniform(0.2e6, 0.6e6, n_rows)
    r = np.where(t >= 0.01, target[:, None], 0.0)
    y = target[:, None] * (1 - np.exp(-np.clip(t - 0.01, 0, None) / rng.uniform(0.003, 0.08, (n_rows, 1))))
    y *= 1 + rng.uniform(0, 0.2, (n_rows, 1)) * np.sin(t * rng.uniform(30, 300, (n_rows, 1)))
    y[::97, 50] = np.nan
    c = rng.integers(0, 256, (n_rows, 120, 2))
    got = step_metrics_batch(t, y, r, c)
    for i in range(n_rows):
        if i % 97 == 0:
            assert all(np.isnan(v[i]) for v in got.values())
            continue
        assert step_metrics(t, y[i], r[i], c[i]) == pytest.approx({k: got[k][i] for k in got}, rel=0, abs=0, nan_ok=True)
