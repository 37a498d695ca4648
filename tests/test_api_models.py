"""The static models share one calling convention and one result type (models/static.py)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.datasets import get_muscle
from mckibben.errors import InputError
from mckibben.models import StaticResult, force, force_laws, length, predict_length, pressure

MUSCLE = get_muscle("mpam97")


@pytest.mark.parametrize("model", sorted(force_laws()))  # every registered law with a published set
def test_length_then_force_gives_the_load_back(model):
    p = np.array([0.3e6, 0.5e6, 0.8e6])
    r = length(p, 0.6, MUSCLE, model=model)
    assert isinstance(r, StaticResult) and r.model == model and r.length.shape == (3,)
    assert np.all(r.flags == 0)  # inside every law's range at these pressures and this load
    back = force(p, r.length, MUSCLE, model=model)
    # Chandrupatla's root to its default tolerance (4 ulp of the length); the map's closed form exactly
    assert_allclose(back.load, 0.6, rtol=1e-9)


@pytest.mark.parametrize("model", sorted(force_laws()))
def test_pressure_inverts_length(model):
    p = np.array([0.4e6, 0.6e6, 0.8e6])
    ell = length(p, 0.6, MUSCLE, model=model).length
    r = pressure(ell, 0.6, MUSCLE, model=model, p_max=0.8e6)
    assert r.model == model and np.all(r.flags == 0)
    # the pressure root to the solver's tolerance (the map: its Newton-polished cubic roots)
    assert_allclose(r.pressure, p, rtol=1e-7)
    beyond = pressure(ell[-1], 0.6, MUSCLE, model=model, p_max=0.5e6)  # needs 0.8 MPa: unreachable under 0.5
    assert np.isnan(beyond.pressure) and beyond.flags != 0


def test_the_braid_laws_solved_for_the_length_stay_on_the_rising_branch():
    # the wall term's −1/sin θ makes the wall-corrected pull fall again before the straight braid;
    # the length is the first (stable) one where it passes the load, below the law's peak
    r = length(0.8e6, 0.6, MUSCLE, model="wall-corrected")
    near = force(0.8e6, float(r.length) * np.array([0.999, 1.001]), MUSCLE, model="wall-corrected").load
    assert near[0] < 0.6 < near[1]


def test_old_length_model_names_are_read_with_a_deprecation_warning():
    with pytest.warns(DeprecationWarning, match="'mpam' is deprecated"):
        r = length(0.8e6, 0.6, MUSCLE, model="mpam")
    assert r.model == "braid-map"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert float(length(0.8e6, 0.6, MUSCLE, model="braid-map").length) == float(r.length)


def test_length_and_pressure_refuse_a_law_without_a_published_set():
    for call in (lambda: length(0.8e6, 0.6, MUSCLE, model="virtual-work"),
                 lambda: pressure(0.08, 0.6, MUSCLE, model="virtual-work")):
        with pytest.raises(InputError, match="model: virtual-work has no published parameters"):
            call()
    with pytest.raises(InputError, match="p_max"):
        pressure(0.08, 0.6, MUSCLE, model="chou-hannaford", p_max=0.0)


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
    assert float(a.length) == float(b.length)  # the braid map's own inverse, through the family's face
    assert "length_m" in a.to_pandas() and "StaticResult(model='braid-map'" in repr(a)
    with pytest.raises(InputError, match="unknown model 'tondu'"):
        length(0.8e6, 0.6, MUSCLE, model="tondu")
