"""The spring model F = K(P, Ls)·Ls of Wickramatunge & Leephakpreeda (2010) [wickramatunge2010]."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from mckibben.errors import InputError
from mckibben.models.flags import flag_names
from mckibben.models.spring import (
    SpringModel,
    spring_force,
    spring_length,
    spring_length_series,
    stiffness,
    unstretched_length,
)

# Known parameters used to generate test values (SI: Pa, m, N/m). Not a published set: the
# paper's coefficients are unreadable in our copy.
ELONG = (2e-3, 1e-2, 5e4, 2e3)  # c3 [N/(m·Pa)], c2 [N/(m²·Pa)], c1 [N/m²], c0 [N/m]
CONTR = (1.5e-3, 1e-2, 4e4, 1.5e3)
MODEL = SpringModel(
    nominal_length=0.30,
    h=(-2e-13, -1.5e-8, 0.30),
    coefficients={(d, r): c for d, c in (("elongation", ELONG), ("contraction", CONTR)) for r in ("low", "high")},
)


def test_unstretched_length_quadratic():
    assert_allclose(unstretched_length([0.0, 1e5], MODEL.h), [0.30, 0.30 - 1.5e-3 - 2e-3], rtol=1e-12)


def test_force_is_k_times_stretch():
    L, P = 0.29, 3e5
    ls = L - unstretched_length(P, MODEL.h)
    k = ELONG[0] * P + ELONG[1] * P * ls + ELONG[2] * ls + ELONG[3]  # eq. (2) by hand
    f, flags = spring_force(L, P, MODEL, "elongation")
    assert float(f) == pytest.approx(k * ls, rel=1e-12)
    assert flag_names(flags) == []


def test_slack_muscle_pulls_nothing_and_says_so():
    f, flags = spring_force(0.20, 3e5, MODEL)
    assert float(f) == 0.0 and flag_names(flags) == ["slack"]


def test_direction_gives_hysteresis():
    f_up, _ = spring_force(0.29, 3e5, MODEL, "elongation")
    f_down, _ = spring_force(0.29, 3e5, MODEL, "contraction")
    assert f_up > f_down  # stretching takes more force than the muscle gives back


@settings(max_examples=200, deadline=None)
@given(L=st.floats(0.28, 0.30), P=st.floats(0.0, 5e5), d=st.sampled_from(["elongation", "contraction"]))
def test_property_length_inverts_force(L, P, d):
    if L <= float(unstretched_length(P, MODEL.h)):
        return
    f, _ = spring_force(L, P, MODEL, d)
    back, flags = spring_length(f, P, MODEL, d)
    assert abs(float(back) - L) < 1e-9


def test_general_terms_solved_by_bisection_agree_with_the_closed_form():
    m2 = dataclasses.replace(
        MODEL,
        terms=((1, 0), (1, 1), (0, 1), (0, 0), (2, 0)),
        coefficients={k: tuple(v) + (0.0,) for k, v in MODEL.coefficients.items()},
    )
    f = np.array([5.0, 50.0, 120.0])
    a, _ = spring_length(f, 3e5, MODEL)
    b, _ = spring_length(f, 3e5, m2)
    assert_allclose(a, b, atol=1e-12)


def test_series_switches_direction_with_the_force():
    p = np.full(6, 3e5)
    f = np.array([0.0, 10.0, 20.0, 20.0, 10.0, 0.0])
    length, direction, _ = spring_length_series(p, f, MODEL)
    assert list(direction) == ["elongation"] * 4 + ["contraction"] * 2
    assert length[2] > length[1] > length[0]
    # on the way back, the softer contraction set gives a longer muscle at the same force
    up, _ = spring_length(10.0, 3e5, MODEL, "elongation")
    assert length[4] > float(up)


def test_bad_input():
    with pytest.raises(InputError, match="pressure has 2 samples, force 3"):
        spring_length_series([1, 2], [1, 2, 3], MODEL)
    with pytest.raises(InputError, match="coefficients for 4 terms"):
        SpringModel(0.3, MODEL.h, {("elongation", "low"): (1.0, 2.0)})
    with pytest.raises(InputError, match="bad coefficient key"):
        SpringModel(0.3, MODEL.h, {("up", "low"): ELONG})


def test_stiffness_terms():
    assert float(stiffness(2.0, 3.0, (1.0, 1.0, 1.0, 1.0))) == pytest.approx(2 + 6 + 3 + 1)
