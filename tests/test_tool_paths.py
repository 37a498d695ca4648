"""Tip path specs (circle, figure-eight) and the tool modules' doctests."""

import doctest
import importlib

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.errors import InputError
from mckibben.tool.paths import parse_path


def test_circle_spec_and_geometry():
    p = parse_path("circle:radius=5mm,period=2s,z=110mm,cx=1mm,cy=-2mm,cycles=3")
    assert (p.kind, p.size, p.period, p.z, p.cx, p.cy, p.cycles) == ("circle", 0.005, 2.0, 0.11, 0.001, -0.002, 3.0)
    t = np.linspace(0, 2, 101)
    xyz = p.position(t)
    assert_allclose(np.hypot(xyz[:, 0] - 0.001, xyz[:, 1] + 0.002), 0.005, rtol=1e-12)  # round-off
    assert_allclose(xyz[0], [0.006, -0.002, 0.11], atol=1e-15)  # starts at (cx + R, cy)
    assert p.duration == 6.0
    assert p.mean_speed == pytest.approx(2 * np.pi * 0.005 / 2)


def test_figure8_crosses_its_centre_twice_per_loop():
    p = parse_path("figure8:size=4mm,period=1s,z=100mm")
    xyz = p.position([0.0, 0.25, 0.5, 0.75])
    assert_allclose(xyz[:, :2], [[0, 0], [0.004, 0], [0, 0], [-0.004, 0]], atol=1e-15)
    # loop length: ∫₀^{2π} √(cos²t + cos²2t) dt · a = 6.09722…·a (scipy.integrate.quad); the
    # polyline of 20000 chords is short by O(1/N²) ≈ 1e-8 relative
    assert p.length == pytest.approx(6.097223 * 0.004, rel=1e-6)


@pytest.mark.parametrize(
    "spec, message",
    [
        ("circle:radius=5,period=2s", "no unit"),
        ("circle:radius=5mm,period=2mm", "is a length, but a time is wanted"),
        ("circle:period=2s", "circle needs radius"),
        ("square:radius=5mm,period=2s", "unknown path kind"),
        ("circle:radius=5mm,period=2s,speed=1mm", "unknown key 'speed'"),
        ("circle:radius=5mm,period=2s,period=1s", "given twice"),
        ("circle:radius=5mm period=2s", "cannot read"),
        ("circle:radius=5mm,,period=2s", "not key=value"),
        ("circle", "is not a path"),
        ("circle:radius=0mm,period=2s", "is zero"),
        ("figure8:radius=5mm,period=2s", "unknown key 'radius' for figure8"),
    ],
)
def test_bad_specs(spec, message):
    with pytest.raises(InputError, match=message):
        parse_path(spec)


@pytest.mark.parametrize("name", ["mckibben.tool.geometry", "mckibben.tool.kinematics", "mckibben.tool.paths"])
def test_doctests(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
