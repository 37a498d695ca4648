"""Units at the edge: what a user types becomes SI."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mckibben.errors import InputError
from mckibben.units import G_N, parse_quantity, parse_values, split_column, to_si


@pytest.mark.parametrize(
    "text, dimension, expected",
    [
        ("0.8MPa", "pressure", 0.8e6),
        ("800kPa", "pressure", 0.8e6),
        ("80psi", "pressure", 80 * 6894.757293168361),
        ("5bar", "pressure", 5e5),
        ("97mm", "length", 0.097),
        ("9.7cm", "length", 0.097),
        ("0.6N", "force", 0.6),
        ("60gf", "force", 0.060 * G_N),
        ("60g", "force", 0.060 * G_N),
        ("20deg", "angle", math.radians(20)),
        ("0.5s", "time", 0.5),
        (" 1 kHz ", "frequency", 1000.0),
    ],
)
def test_parse_quantity_examples_from_the_issue(text, dimension, expected):
    assert parse_quantity(text, dimension) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize(
    "text, dimension, message",
    [
        ("0.8", "pressure", "--x: '0.8' has no unit; write it with one of Pa, kPa, MPa, bar, mbar, psi (e.g. 0.8MPa, 80psi, 5bar)"),
        ("0.8furlong", "pressure", "--x: unknown unit 'furlong'; use one of Pa, kPa, MPa, bar, mbar, psi"),
        ("97mm", "pressure", "--x: unit 'mm' is a length, but a pressure is wanted (use one of Pa, kPa, MPa, bar, mbar, psi)"),
        ("nanMPa", "pressure", "--x: 'nanMPa' is not a finite number"),
        ("-0.1MPa", "pressure", "--x: '-0.1MPa' is negative; a pressure here must be >= 0"),
        ("abc", "length", "--x: cannot read 'abc' as a length (e.g. 97mm, 9.7cm)"),
    ],
)
def test_bad_quantities_name_the_argument(text, dimension, message):
    with pytest.raises(InputError) as info:
        parse_quantity(text, dimension, "--x")
    assert str(info.value) == message


def test_negative_allowed_when_asked():
    assert parse_quantity("-2mm", "length", allow_negative=True) == pytest.approx(-0.002)


def test_ranges_and_lists():
    np.testing.assert_allclose(parse_values("0:0.8MPa:9", "pressure"), np.linspace(0, 0.8e6, 9))
    np.testing.assert_allclose(parse_values("0.2,0.4MPa", "pressure"), [0.2e6, 0.4e6])
    np.testing.assert_allclose(parse_values("80mm,9cm", "length"), [0.08, 0.09])
    with pytest.raises(InputError, match="START:STOP:COUNT"):
        parse_values("0:1MPa", "pressure", "--pressure")
    with pytest.raises(InputError, match="whole number"):
        parse_values("0:1MPa:x", "pressure", "--pressure")
    with pytest.raises(InputError, match="empty item"):
        parse_values("0.1MPa,,0.2MPa", "pressure", "--pressure")


def test_columns():
    assert split_column("pressure_MPa") == ("pressure", "MPa")
    assert split_column("load_g") == ("load", "g")
    assert split_column("trial") == ("trial", "")
    assert to_si(np.array([1.0, 2.0]), "mm", "length").tolist() == [0.001, 0.002]


@given(st.floats(min_value=0, max_value=1e3, allow_nan=False), st.sampled_from(["Pa", "kPa", "MPa", "bar", "psi"]))
def test_pressure_round_trip(value, unit):
    si = parse_quantity(f"{value!r}{unit}", "pressure")
    assert si == pytest.approx(to_si(value, unit, "pressure"), rel=1e-12)
