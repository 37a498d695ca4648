"""Tip tracking: pressure references from a path, and (with the plant) the closed loop."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.datasets import get_muscle
from mckibben.errors import UnreachableError
from mckibben.tool.geometry import Tool
from mckibben.tool.paths import parse_path
from mckibben.tool.statics import pressures_for_tip, tip_from_pressures
from mckibben.tool.tracking import straight_height, tip_errors, tip_reference

TOOL = Tool(get_muscle("mpam117"))


def test_reference_pressures_hold_the_target_path():
    ref = tip_reference(TOOL, parse_path("figure8:size=15mm,period=0.2s,cycles=1.5"), ts=1e-3)
    assert ref.time.shape == (300,) and ref.pressures.shape == (300, 3)
    # the forward equilibrium at the reference pressures puts the tip on the target: the cubic
    # roots are polished to 1e-9 in cos θ (≈ 0.1 µm in length), the equilibrium to 1e-12 m
    achieved = tip_from_pressures(ref.pressures, TOOL).tip
    assert tip_errors(ref.target, achieved)["max_error_m"] < 1e-6
    assert_allclose(ref.target[:, 2], straight_height(TOOL), rtol=0, atol=0)  # default plane z


def test_tiled_loops_equal_the_direct_solution():
    path = parse_path("circle:radius=8mm,period=0.1s,cycles=3")
    ref = tip_reference(TOOL, path, ts=1e-3)
    direct = pressures_for_tip(ref.target, TOOL)
    # the circle repeats sample for sample; the targets of loop 2 and 3 differ from loop 1 only by
    # the round-off of cos/sin at larger arguments (1e-16 m), so the pressures agree to ~1e-6 Pa
    assert_allclose(ref.pressures, direct.pressures, rtol=0, atol=1e-3)


def test_symmetric_circle_pressures_are_phase_shifted_copies():
    # a circle about the axis: muscle 2 sees muscle 1's pressure one third of a loop later
    ref = tip_reference(TOOL, parse_path("circle:radius=10mm,period=0.3s,cycles=1"), ts=1e-3)
    assert_allclose(np.roll(ref.pressures[:, 0], 100), ref.pressures[:, 1], rtol=0, atol=1e-3)


def test_unreachable_path_names_time_and_muscle():
    with pytest.raises(UnreachableError, match=r"t = 0.000 s is unreachable: muscle 1 \(at 0°\)"):
        tip_reference(TOOL, parse_path("circle:radius=60mm,period=1s"))


def test_tip_errors():
    e = tip_errors([[0, 0, 0], [0, 0, 0]], [[3e-3, 4e-3, 0], [0, 0, 0]])
    assert e == {"rms_error_m": pytest.approx(5e-3 / np.sqrt(2)), "max_error_m": pytest.approx(5e-3)}
