"""The Prandtl–Ishlinskii operator: fit recovery, exact inverse, rate independence, properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mckibben.errors import InputError
from mckibben.fit.hysteresis import fit_prandtl_ishlinskii
from mckibben.models.hysteresis import (
    PrandtlIshlinskii,
    apply,
    descended_state,
    forward_state,
    inverse_operator,
    inverse_state,
    invert,
    loading_curve,
    play_matrix,
    thresholds_uniform,
)

#: A muscle-like operator: pressure [Pa] to contraction [m], loop about 40 kPa wide.
R = thresholds_uniform(6, 0.6e6)
W = np.array([20e-9, 8e-9, 6e-9, 4e-9, 3e-9, 2e-9])


def _muscle():
    return PrandtlIshlinskii(R, W, input_offset=0.0, output_offset=1e-3, input_unit="Pa", output_unit="m")


def _excitation(rng, n=4000):
    """A pressure sequence with reversals of every size inside 0–0.7 MPa (rate-independent data)."""
    turns = np.r_[0.0, 0.7e6, rng.uniform(0.05e6, 0.65e6, 30)]
    return np.concatenate([np.linspace(a, b, n // turns.size) for a, b in zip(turns[:-1], turns[1:])])


def test_play_follows_at_its_threshold_and_holds_inside_the_band():
    z, zf = play_matrix([0.0, 1.0], [0.0, 3.0, 2.5, 1.0, 2.0])
    # the identity play is the input; the play of threshold 1 lags by 1 and holds on small reversals
    np.testing.assert_allclose(z[:, 0], [0.0, 3.0, 2.5, 1.0, 2.0])
    np.testing.assert_allclose(z[:, 1], [0.0, 2.0, 2.0, 2.0, 2.0])
    np.testing.assert_allclose(zf, [2.0, 2.0])


def test_fit_recovers_known_weights_within_a_few_standard_errors():
    rng = np.random.default_rng(1)
    pi = _muscle()
    u = _excitation(rng)
    y_true, _ = apply(pi, u)
    sigma = 5e-6  # 5 µm noise on a ~15 mm output
    y = y_true + rng.normal(0.0, sigma, u.size)
    res = fit_prandtl_ishlinskii(u, y, R, input_unit="Pa", output_unit="m")
    z = (res.model.weights - W) / res.model.stderr
    assert np.all(np.abs(z) < 4), z
    assert abs(res.fit.values[0] - 1e-3) < 4 * res.fit.stderr[0]
    assert res.fit.residual_rms == pytest.approx(sigma, rel=0.1)
    assert res.fit.flags == ()
    # the standard errors are honest: the fitted weights scatter like them over repeated noise
    draws = []
    for k in range(20):
        yk = y_true + np.random.default_rng(100 + k).normal(0.0, sigma, u.size)
        draws.append(fit_prandtl_ishlinskii(u, yk, R).model.weights)
    spread = np.std(draws, axis=0, ddof=1)
    assert np.all(spread < 2.0 * res.model.stderr) and np.all(spread > 0.4 * res.model.stderr)


def test_fit_holds_a_zero_weight_at_its_bound_and_flags_it():
    rng = np.random.default_rng(2)
    w = W.copy()
    w[3] = 0.0
    pi = PrandtlIshlinskii(R, w)
    u = _excitation(rng)
    y = apply(pi, u)[0] - 2e-6 * np.abs(rng.normal(size=u.size))  # noise that would push w3 negative
    res = fit_prandtl_ishlinskii(u, y, R)
    assert np.all(res.model.weights >= 0)
    if res.model.weights[3] == 0.0:
        assert "w3_m_per_Pa_at_lower_bound" in res.fit.flags and np.isnan(res.model.stderr[3])


def test_modified_pi_follows_a_saturating_output_and_inverts_exactly():
    rng = np.random.default_rng(3)
    # plays in Pa (identity weight 1), then a monotone S-shaped map to contraction [m]
    w = np.r_[1.0, W[1:] / W[0]]
    yk = np.linspace(0.0, 0.02, 6)
    vk = np.array([0.0, 0.25e6, 0.35e6, 0.45e6, 0.6e6, 0.9e6])
    pi = PrandtlIshlinskii(R, w, output_map=(yk, vk))
    u = _excitation(rng)
    y, _ = apply(pi, u)
    inside = (y > yk[0]) & (y < yk[-1])
    res = fit_prandtl_ishlinskii(u, y, R, mask=inside, output_knots=6)
    # the fit's knots (even over the fitted outputs) are not the generating ones: close, not exact
    # (the fit normalizes the weights to sum 1; the map absorbs the scale)
    np.testing.assert_allclose(res.model.weights, w / w.sum(), rtol=0.02)
    assert res.fit.residual_rms < 2e-3 * 0.7e6
    back, _ = invert(res.model, y[inside])  # from virgin: the first samples differ, compare later ones
    y_fit, _ = apply(res.model, u)
    np.testing.assert_allclose(y_fit[inside], y[inside], atol=2.5e-3 * 0.02)
    # the exact inverse: the output of the fitted operator inverted gives its input back
    y_in = apply(pi, u)[0]
    mono = np.clip(y_in, yk[0] + 1e-4, yk[-1] - 1e-4)
    u_back, _ = invert(pi, mono)
    np.testing.assert_allclose(apply(pi, u_back)[0], mono, rtol=0, atol=1e-12)
    assert back.shape == y[inside].shape


@pytest.mark.parametrize("seed", range(5))
def test_inverse_of_forward_is_identity_on_random_inputs(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    r = np.r_[0.0, np.sort(rng.uniform(0.01, 1.0, n - 1))]
    w = rng.uniform(0.05, 1.0, n)
    pi = PrandtlIshlinskii(r, w, input_offset=rng.normal(), output_offset=rng.normal(), input_unit="-",
                           output_unit="-")
    monotone = np.cumsum(rng.uniform(0, 0.01, 500))
    wild = np.cumsum(rng.normal(0, 0.2, 2000))
    for u in (monotone, -monotone, wild):
        y, zf = apply(pi, u)
        back, zb = invert(pi, y)
        np.testing.assert_allclose(back, u, rtol=0, atol=1e-9)
        np.testing.assert_allclose(zb, zf, rtol=0, atol=1e-9)
    # from a state left by an earlier sequence, too
    _, z1 = apply(pi, wild[:1000])
    y2, _ = apply(pi, wild[1000:], z1)
    back2, _ = invert(pi, y2, z1)
    np.testing.assert_allclose(back2, wild[1000:], rtol=0, atol=1e-9)
    # and forward of inverse
    inv = inverse_operator(pi)
    u_of_y, _ = apply(inv, wild)
    np.testing.assert_allclose(apply(pi, u_of_y)[0], wild, rtol=0, atol=1e-9)
    # the inverse of the inverse is the operator; the state maps are each other's inverse
    again = inverse_operator(inv)
    np.testing.assert_allclose(again.thresholds, r, atol=1e-12)
    np.testing.assert_allclose(again.weights, w, rtol=1e-9)
    np.testing.assert_allclose(forward_state(pi, inverse_state(pi, z1)), z1, atol=1e-12)


def test_inverse_thresholds_are_the_loading_curve_at_the_thresholds():
    pi = _muscle()
    inv = inverse_operator(pi)
    np.testing.assert_allclose(inv.thresholds, loading_curve(pi, R) - pi.output_offset, rtol=1e-12)
    assert inv.weights[0] == pytest.approx(1 / W[0]) and np.all(inv.weights[1:] < 0)
    assert (inv.input_unit, inv.output_unit) == ("m", "Pa")


def test_loop_is_rate_independent():
    rng = np.random.default_rng(4)
    pi = _muscle()
    turns = np.r_[0.0, rng.uniform(0, 0.7e6, 12)]
    t_turn = np.cumsum(np.r_[0.0, rng.uniform(0.5, 2.0, turns.size - 1)])
    for dt in (1e-3, 7e-3, 0.05):  # the same turning points, sampled at three rates
        t = np.union1d(np.arange(0.0, t_turn[-1], dt), t_turn)
        u = np.interp(t, t_turn, turns)
        y, z = apply(pi, u)
        at = y[np.searchsorted(t, t_turn)]  # the output at the turning points
        if dt == 1e-3:
            ref, z_ref = at, z
        np.testing.assert_allclose(at, ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(z, z_ref, rtol=0, atol=1e-6)
    # a time warp (slow start, fast end) at 1 ms: the same loop
    t = np.union1d(np.arange(0.0, t_turn[-1], 1e-3), t_turn)
    warped = t_turn[-1] * (t / t_turn[-1]) ** 2
    u_w = np.interp(warped, t_turn, turns)
    y_w, _ = apply(pi, u_w)
    at_w = np.interp(t_turn[1:-1], warped, y_w)
    np.testing.assert_allclose(at_w, ref[1:-1], rtol=0, atol=2e-3 * np.ptp(y_w))
    # exact statement: inserting samples between two samples on a monotone stretch changes nothing
    u = np.array([0.0, 0.5e6, 0.2e6, 0.4e6])
    fine = np.concatenate([np.linspace(a, b, 50, endpoint=False) for a, b in zip(u[:-1], u[1:])] + [u[-1:]])
    y_c, z_c = apply(pi, u)
    y_f, z_f = apply(pi, fine)
    np.testing.assert_allclose(y_f[::50], y_c, rtol=0, atol=1e-15)
    np.testing.assert_allclose(z_f, z_c, rtol=0, atol=1e-9)


def test_descended_state_makes_the_first_rise_hold():
    pi = _muscle()
    z0 = descended_state(R, 0.1e6)
    y, _ = apply(pi, [0.1e6, 0.1e6 + 0.9 * R[1] * 2], z0)
    # only the identity play moves within the first 2·r_1 of the rise
    assert y[1] - y[0] == pytest.approx(W[0] * 0.9 * R[1] * 2, rel=1e-12)


@pytest.mark.parametrize("kwargs, name", [
    ({"thresholds": [0.0, -1.0], "weights": [1.0, 1.0]}, "thresholds"),
    ({"thresholds": [0.0, 1.0], "weights": [1.0]}, "weights"),
    ({"thresholds": [0.0, np.nan], "weights": [1.0, 1.0]}, "thresholds"),
])
def test_bad_parameters_name_the_argument(kwargs, name):
    with pytest.raises(InputError, match=name):
        PrandtlIshlinskii(**kwargs)


def test_not_invertible_is_refused():
    with pytest.raises(InputError, match="not invertible"):
        inverse_operator(PrandtlIshlinskii([0.0, 1.0], [1.0, -2.0]))


def test_fit_refuses_plays_that_never_move():
    u = np.linspace(0, 1.0, 200)
    with pytest.raises(InputError, match="never moves"):
        fit_prandtl_ishlinskii(np.r_[u, u[::-1]], np.r_[u, u[::-1]], [0.0, 0.3, 2.0])


# --- property tests -------------------------------------------------------------------------

_weights = st.lists(st.floats(0.0, 10.0), min_size=1, max_size=8)


@settings(max_examples=60, deadline=None)
@given(_weights, st.lists(st.floats(-5, 5), min_size=2, max_size=60), st.floats(0.01, 2.0))
def test_nonnegative_weights_give_an_output_monotone_in_a_monotone_input(w, steps, dr):
    r = np.arange(len(w)) * dr
    pi = PrandtlIshlinskii(r, np.asarray(w))
    u = np.cumsum(np.abs(steps))
    y, _ = apply(pi, u)
    assert np.all(np.diff(y) >= -1e-9 * (1 + np.abs(y[1:])))
    y_dn, _ = apply(pi, -u)
    assert np.all(np.diff(y_dn) <= 1e-9 * (1 + np.abs(y_dn[1:])))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 8), st.floats(0.01, 2.0), st.lists(st.floats(-5, 5), min_size=1, max_size=80))
def test_play_states_stay_within_their_band_of_the_input(n, dr, u):
    r = np.arange(n) * dr
    z, zf = play_matrix(r, u)
    x = np.asarray(u)[:, None]
    assert np.all(np.abs(x - z) <= r + 1e-12)
    # bounded by the input's range (from the virgin state at 0)
    lo, hi = min(0.0, min(u)), max(0.0, max(u))
    assert np.all(z >= lo - 1e-12) and np.all(z <= hi + 1e-12)


def test_length_feedforward_through_the_inverse_operator():
    from mckibben.control.length import fit_pi_hysteresis, length_feedforward

    rng = np.random.default_rng(5)
    w = np.r_[0.2, 0.5, 0.3, 0.0, 0.0, 0.0]
    yk = np.linspace(0.0, 0.015, 5)
    truth = PrandtlIshlinskii(R, w, output_map=(yk, np.array([0.3e6, 0.36e6, 0.42e6, 0.5e6, 0.6e6])))
    u = _excitation(rng, 6000)
    c, _ = apply(truth, u)
    length = 0.1 - c
    inside = (c > 0.001) & (c < 0.014)
    op = fit_pi_hysteresis(u, length, mask=inside, reference_length=0.1, n_plays=6, output_knots=5)
    assert op.rmse < 5e3  # Pa
    target = 0.1 - 0.0075 + 0.004 * np.sin(np.linspace(0, 6 * np.pi, 600))
    p = length_feedforward(target, pi=op, p_max=0.8e6)
    # the pressure reference drives the true operator to the target within the fit's error
    got = 0.1 - apply(truth, p)[0]
    assert np.sqrt(np.mean((got[100:] - target[100:]) ** 2)) < 2e-4
    # direction-aware without branch switching: the same length, falling then rising, needs two
    # pressures; the reference moves between them continuously (no step at the reversal)
    i_min = 100 + int(np.argmin(target[100:300]))
    assert np.max(np.abs(np.diff(p))) < 0.05e6
    assert p[i_min - 20] - p[i_min + 20] > 10e3 or abs(target[i_min - 20] - target[i_min + 20]) > 1e-4
    with pytest.raises(InputError, match="pi"):
        length_feedforward(target, pi=op, branches=object())  # type: ignore[arg-type]
