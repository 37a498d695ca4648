"""Pressures for a tip target and the pose pressures hold: physics of the three-muscle tool."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.datasets import get_muscle
from mckibben.errors import UnreachableError
from mckibben.models.flags import Flag
from mckibben.models.mpam import predict_length, pressure_for_length
from mckibben.tool.geometry import MUSCLE_ANGLES, StackLoad, Tool, ToolGeometry
from mckibben.tool.kinematics import _COS, _SIN
from mckibben.tool.statics import (
    muscle_tensions,
    pressures_for_tip,
    require_reachable_tip,
    tip_from_pressures,
)
from mckibben.tool.workspace import sample_workspace

TOOL = Tool(get_muscle("mpam117"))


@pytest.mark.parametrize("p", [0.0, 0.2e6, 0.5e6, 0.8e6])
def test_symmetric_pressure_shortens_without_bending(p):
    st = tip_from_pressures([p, p, p], TOOL)
    assert st.converged
    assert float(st.arc.theta) < 1e-12  # round-off of the Newton iteration on a straight pose
    assert_allclose(st.tip[:2], 0.0, atol=1e-12)  # on the axis (same round-off, times s)
    # Ka = 0: every muscle carries the preload, so the tool is as long as one muscle under F0
    expected = float(predict_length(TOOL.muscle, p, TOOL.load.preload).length)
    assert_allclose(float(st.arc.arc_length), expected, rtol=0, atol=1e-12)  # Newton tol 1e-12 m


def test_symmetric_pressure_shortens_monotonically():
    s = [float(tip_from_pressures([p, p, p], TOOL).arc.arc_length) for p in np.linspace(0, 0.8e6, 9)]
    assert np.all(np.diff(s) < 0)
    # mpam117 under 1 N: 124.8 mm relaxed, 104.6 mm at 0.8 MPa (Table I–II, eq. 2–3)
    assert s[0] * 1e3 == pytest.approx(124.78, abs=0.01)
    assert s[-1] * 1e3 == pytest.approx(104.61, abs=0.01)


@pytest.mark.parametrize("i", [0, 1, 2])
@pytest.mark.parametrize("p", [0.2e6, 0.8e6])
def test_one_muscle_bends_the_tip_toward_its_side(i, p):
    pressures = np.zeros(3)
    pressures[i] = p
    st = tip_from_pressures(pressures, TOOL)
    assert st.converged
    ang = MUSCLE_ANGLES[i]
    assert float(st.arc.theta) > 0.05  # a real bend, not round-off
    assert_allclose(np.cos(float(st.arc.phi) - ang), 1.0, atol=1e-9)  # bend plane at muscle i
    lateral = st.tip[:2]
    toward = lateral @ [np.cos(ang), np.sin(ang)]
    assert toward > 0 and abs(lateral @ [-np.sin(ang), np.cos(ang)]) < 1e-9 * toward + 1e-12
    # away from the other two: they are the longer ones and equally long
    others = [j for j in range(3) if j != i]
    assert st.lengths[i] < st.lengths[others[0]]
    assert_allclose(st.lengths[others[0]], st.lengths[others[1]], rtol=1e-12)
    # and more pressure bends further
    assert float(st.arc.theta) > float(tip_from_pressures(pressures / 2, TOOL).arc.theta)


def test_tensions_balance_the_backbone():
    st = tip_from_pressures([0.6e6, 0.1e6, 0.3e6], TOOL)
    f, r, ld = st.tensions, TOOL.geometry.pitch_radius, TOOL.load
    assert_allclose(f.sum(), 3 * ld.preload, rtol=1e-12)  # Ka = 0: constant compression
    kappa = np.array([float(st.arc.theta_x), float(st.arc.theta_y)]) / float(st.arc.arc_length)
    moment = r * np.array([f @ _COS, f @ _SIN])
    assert_allclose(moment, ld.bending_stiffness * kappa, rtol=1e-12)  # Kb·κ = r·Σ F_i ĥ_i


def test_axial_stiffness_adds_compression_when_shorter():
    tool = Tool(TOOL.muscle, load=StackLoad(preload=1.0, axial_stiffness=50.0))
    st = tip_from_pressures([0.8e6] * 3, tool)
    s = float(st.arc.arc_length)
    expected = 1.0 + 50.0 * (0.117 - s) / 0.117 / 3
    assert_allclose(st.tensions, expected, rtol=1e-12)
    # and the length is the muscle's at that tension (the fixed point the solver found)
    assert_allclose(s, float(predict_length(tool.muscle, 0.8e6, expected).length), atol=1e-12)


def test_pressures_for_tip_inverts_the_equilibrium():
    rng = np.random.default_rng(7)
    p = rng.uniform(0, 0.8e6, size=(50, 3))
    fwd = tip_from_pressures(p, TOOL)
    assert fwd.converged.all()
    back = pressures_for_tip(fwd.tip, TOOL)
    assert back.reachable.all()
    # pressures from the cubic's root (Newton-polished to 1e-9 in cos θ) at lengths reproduced to
    # the equilibrium's 1e-12 m: dP/dl ≈ 0.8 MPa/20 mm = 40 Pa/µm, so 1e-3 Pa is ample
    assert_allclose(back.pressures, p, rtol=0, atol=1e-3)
    assert_allclose(back.lengths, fwd.lengths, rtol=0, atol=1e-11)


def test_inverse_uses_each_muscles_own_tension():
    st = pressures_for_tip([0.02, 0.01, 0.11], TOOL)
    for i in range(3):
        single = pressure_for_length(TOOL.muscle, st.lengths[i], st.tensions[i], TOOL.p_max)
        assert float(single.pressure) == st.pressures[i]  # the same call, element by element


def test_unreachable_longer_than_relaxed_names_every_muscle():
    st = pressures_for_tip([0.0, 0.0, 0.130], TOOL)
    assert not st.reachable
    assert np.all(st.flags & Flag.UNREACHABLE)
    with pytest.raises(UnreachableError, match=r"muscle 1 \(at 0°\).*can only shorten.*muscle 3"):
        require_reachable_tip(st, TOOL)


def test_unreachable_needs_more_than_p_max_names_the_muscle():
    # from P = (0.8, 0.3, 0.3) MPa bend 3 % further: muscle 1 would need more than 0.8 MPa while
    # muscles 2 and 3 still have pressure to let go, so muscle 1 alone is limiting
    from mckibben.tool.kinematics import Arc, tip_position

    arc = tip_from_pressures([0.8e6, 0.3e6, 0.3e6], TOOL).arc
    beyond = tip_position(Arc(arc.arc_length, 1.03 * arc.theta_x, 1.03 * arc.theta_y))
    st = pressures_for_tip(beyond, TOOL)
    assert not st.reachable
    with pytest.raises(UnreachableError, match=r"muscle 1 \(at 0°\).*more pressure than p_max") as exc:
        require_reachable_tip(st, TOOL)
    assert "muscle 2" not in str(exc.value)


def test_slack_muscle_is_named():
    stiff = Tool(TOOL.muscle, load=StackLoad(preload=0.6, bending_stiffness=2e-3))
    st = pressures_for_tip([0.04, 0.0, 0.1], stiff)
    assert st.tensions[1] < 0 and st.tensions[2] < 0
    assert st.flags[1] & Flag.SLACK
    with pytest.raises(UnreachableError, match=r"muscle 2 \(at 120°\) would have to push"):
        require_reachable_tip(st, stiff)


def test_model_flags_are_carried():
    # mpam97's 0.6 N cubic gives cos θ = 1.05 > 1 at 0 MPa (Table II): the tool must say so
    tool = Tool(get_muscle("mpam97"), load=StackLoad(preload=0.6))
    st = tip_from_pressures([0.0, 0.0, 0.0], tool)
    assert all("cos_theta_above_one" in f for f in st.flag_lists())
    # a bend with the default load model pushes one tension below the characterized 0.6 N
    st = tip_from_pressures([0.8e6, 0.8e6, 0.0], TOOL)
    assert "load_out_of_range" in st.flag_lists()[2]


def test_muscle_tensions_straight_is_preload():
    from mckibben.tool.kinematics import Arc

    f = muscle_tensions(Arc(np.float64(0.117), np.float64(0.0), np.float64(0.0)), TOOL)
    assert_allclose(f, [1.0, 1.0, 1.0], rtol=0, atol=0)  # exact: no bend term


def test_workspace_is_symmetric_and_converges():
    ws = sample_workspace(TOOL, 7)
    ext = ws.extent()
    assert ext["converged"] == ext["samples"] == 343
    assert ext["tip_angle_min_rad"] < 1e-12  # the diagonal P1 = P2 = P3 is straight
    assert ext["lateral_reach_m"] > 0.05
    # three-fold symmetry: giving muscle i+1 the pressure of muscle i rotates the tip by +120°
    tip = ws.state.tip
    rot = np.array([[-0.5, -np.sqrt(3) / 2, 0], [np.sqrt(3) / 2, -0.5, 0], [0, 0, 1]])
    assert_allclose(tip[5, 1, 2], rot @ tip[1, 2, 5], atol=1e-10)  # equilibrium tol 1e-12 m × gain
    assert ext["straight_length_max_m"] == pytest.approx(0.12478, abs=1e-5)


def test_geometry_changes_the_bend():
    wide = Tool(TOOL.muscle, ToolGeometry(pitch_radius=4.8e-3))
    narrow = Tool(TOOL.muscle, ToolGeometry(pitch_radius=3.2e-3))
    a = float(tip_from_pressures([0.5e6, 0, 0], wide).arc.theta)
    b = float(tip_from_pressures([0.5e6, 0, 0], narrow).arc.theta)
    assert b > a  # a smaller pitch radius turns the same length difference into a larger bend
