"""The static models share one calling convention and one result type (models/static.py)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.datasets import get_muscle
from mckibben.errors import InputError
from mckibben.models import LENGTH_MODELS, StaticResult, force, force_laws, length, predict_length

MUSCLE = get_muscle("mpam97")


@pytest.mark.parametrize("model", sorted(LENGTH_MODELS))
def test_length_then_force_gives_the_load_back(model):
    p = np.array([0.3e6, 0.5e6, 0.8e6])
    r = length(p, 0.6, MUSCLE, model=model)
    assert isinstance(r, StaticResult) and r.model == model and r.length.shape == (3,)
    back = force(p, r.length, MUSCLE, model=model)
    # closed forms invert exactly; the wall-corrected length is a 60-step bisection (2^-60 of cos θ)
    assert_allclose(back.load, 0.6, rtol=1e-9)


@pytest.mark.parametrize("model", sorted(force_laws()))  # every registered law with a published set
def test_force_rises_with_pressure_and_falls_with_contraction(model):
    # where the model is valid (no flag: within the characterized loads for the empirical model)
    r = force(np.linspace(0.2e6, 0.8e6, 13), 0.088, MUSCLE, model=model)
    ok = r.flags == 0
    assert ok.sum() >= 3 and np.all(np.diff(r.load[ok]) > 0)
    r = force(0.7e6, np.linspace(0.080, 0.095, 16), MUSCLE, model=model)
    ok = r.flags == 0
    assert ok.sum() >= 3 and np.all(np.diff(r.load[ok]) > 0)  # a longer (less contracted) muscle pulls harder


def test_text_quantities_and_the_published_model():
    a = length("0.8MPa", "0.6N", MUSCLE)
    b = predict_length(MUSCLE, 0.8e6, 0.6)
    assert float(a.length) == float(b.length)  # the same function, through the family's face
    assert "length_m" in a.to_pandas() and "StaticResult(model='mpam'" in repr(a)
    with pytest.raises(InputError, match="unknown length model 'tondu'"):
        length(0.8e6, 0.6, MUSCLE, model="tondu")
