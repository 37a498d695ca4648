"""Constant-curvature kinematics of the three-muscle tool: round trips, the straight limit, and
checks against independent constructions (integrated backbone, hole-to-hole chords)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from mckibben.errors import InputError, UnreachableError
from mckibben.tool.geometry import MUSCLE_ANGLES, ToolGeometry, default_pitch_radius, pitch_radius_limits
from mckibben.tool.kinematics import (
    Arc,
    arc_from_lengths,
    arc_from_tip,
    chord_factor,
    lengths_from_arc,
    lengths_from_tip,
    tip_from_lengths,
    tip_position,
    tip_rotation,
)

MM = 1e-3

# Muscle lengths across the workspace of the published muscles (≈ 100..126 mm; differences up
# to 20 mm, i.e. bends up to 4.3 rad, beyond the 3.1 rad the pressure box reaches), plus
# near-straight sets (differences down to 1e-15 m and exactly 0).
base = st.floats(95 * MM, 130 * MM)
delta = st.one_of(
    st.floats(-10 * MM, 10 * MM),
    st.floats(-1e-9, 1e-9),
    st.sampled_from([0.0, 1e-15, -1e-15, 1e-12]),
)
radius = st.floats(3.1 * MM, 4.9 * MM)
gaps = st.sampled_from([None, 4, 12, 40])  # one gap cannot take 20 mm differences (test_bad_input)


@settings(max_examples=400, deadline=None)
@given(base, delta, delta, delta, radius, gaps)
def test_forward_then_inverse_returns_the_lengths(l0, d1, d2, d3, r, n):
    lengths = np.array([l0 + d1, l0 + d2, l0 + d3])
    tip = tip_from_lengths(lengths, r, n)
    back = lengths_from_tip(tip, r, n)
    # the bar: 1e-9 m; float64 round-off on 0.1 m lengths is ~1e-16 m per operation
    assert_allclose(back, lengths, rtol=0, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(base, delta, delta, delta, radius, gaps)
def test_arc_round_trip_is_exact_to_round_off(l0, d1, d2, d3, r, n):
    lengths = np.array([l0 + d1, l0 + d2, l0 + d3])
    arc = arc_from_lengths(lengths, r, n)
    # lengths → arc → lengths involves no tip: only round-off (1e-15 m scale)
    assert_allclose(lengths_from_arc(arc, r, n), lengths, rtol=0, atol=1e-13)


def test_vectorized_over_leading_axes():
    rng = np.random.default_rng(1)
    lengths = 0.115 + rng.uniform(-0.01, 0.01, size=(4, 5, 3))
    tip = tip_from_lengths(lengths, 4 * MM, 12)
    assert tip.shape == (4, 5, 3)
    one = tip_from_lengths(lengths[2, 3], 4 * MM, 12)
    assert_allclose(tip[2, 3], one, rtol=0, atol=1e-15)  # same arithmetic, round-off only


@pytest.mark.parametrize("n", [None, 12])
def test_straight_limit_is_continuous_and_exact(n):
    r, L = 4 * MM, 0.117
    # exactly straight: no NaN, tip on the axis at the arc length, identity orientation
    arc = arc_from_lengths([L, L, L], r, n)
    assert float(arc.theta) == 0.0
    assert_allclose(tip_position(arc), [0, 0, L], rtol=0, atol=1e-18)  # exact arithmetic at θ = 0
    assert_allclose(tip_rotation(arc), np.eye(3), rtol=0, atol=1e-18)
    # lengthen muscle 1 by δ: continuous-limit Clarke coordinates give θx = −2δ/(3r), θy = 0
    # (bend away from muscle 1, φ = π) and the tip leaves the axis like s·θ/2, with no jump.
    for d in [1e-6, 1e-9, 1e-12, 1e-15]:
        l1 = L + d
        d = l1 - L  # the δ float64 represents (Sterbenz: exact)
        arc = arc_from_lengths([l1, L, L], r, n)
        expected_theta = 2 * d / (3 * r)
        # θ ≤ 1.7e-4 rad: the neglected terms are O(θ²) ≤ 3e-8 relative (chord factor, sinc),
        # so rtol 1e-7; atol 1e-14 rad is the round-off of Σ l_i·cos θi (a few ulp of 0.117 m,
        # 1e-17 m) times 2/(3r) = 167 1/m. The θ = 0 point and θ > 0 meet without a jump.
        assert_allclose(-float(arc.theta_x), expected_theta, rtol=1e-7, atol=1e-14)
        assert abs(float(arc.theta_y)) <= 1e-12 * expected_theta + 1e-14
        tip = tip_position(arc)
        s = float(arc.arc_length)
        assert_allclose(tip[0], -s * expected_theta / 2, rtol=1e-7, atol=1e-15)  # same, times s/2
        assert_allclose(tip[2], s, rtol=1e-8)  # z = s·sinc θ, 1 − θ²/6 ≥ 1 − 5e-9


def test_inverse_near_straight_tip_is_continuous():
    r, z = 4 * MM, 0.11
    prev = lengths_from_tip([0.0, 0.0, z], r, 12)
    assert_allclose(prev, [z, z, z], rtol=0, atol=1e-18)  # on the axis: all lengths equal z
    for eps in [1e-15, 1e-12, 1e-9, 1e-6]:
        lengths = lengths_from_tip([eps, 0.0, z], r)  # continuous: no chord factor term
        # lateral tip offset ε needs θ ≈ 2ε/z, so muscle 1 shortens by r·θ = 2rε/z, less the
        # arc's growth s − z ≈ (2/3)ε²/z; the next terms are O(ε³) (rtol 1e-7) and atol 1e-16 m
        # is ~7 ulp of 0.11 m (round-off of z − l)
        assert_allclose(z - lengths[0], 2 * r * eps / z - (2 / 3) * eps**2 / z, rtol=1e-7, atol=1e-16)


def test_series_branch_matches_closed_form_at_the_switch():
    # _asin_ratio switches to its series at u = 1e-3; lengths on both sides must agree smoothly
    r, n = 4 * MM, 1  # one gap makes u = |m|/2 largest for a given bend
    d_switch = 1e-3 * 2 * n * 3 * r / 2  # δ on muscle 1 that puts u at 1e-3
    a = arc_from_lengths([0.1 + d_switch * (1 - 1e-9), 0.1, 0.1], r, n)
    b = arc_from_lengths([0.1 + d_switch * (1 + 1e-9), 0.1, 0.1], r, n)
    assert_allclose(float(a.theta), float(b.theta), rtol=1e-8)  # the step in δ is 2e-9 relative


def _integrated_tip(arc, steps=4000):
    """Tip by integrating the backbone: constant curvature = equal small rotations, midpoint rule."""
    s = float(arc.arc_length)
    ds = s / steps
    rot_step = Rotation.from_rotvec(np.array([-float(arc.theta_y), float(arc.theta_x), 0.0]) / steps)
    half = Rotation.from_rotvec(np.array([-float(arc.theta_y), float(arc.theta_x), 0.0]) / (2 * steps))
    frame = Rotation.identity()
    p = np.zeros(3)
    for _ in range(steps):
        p += (frame * half).apply([0, 0, ds])
        frame = frame * rot_step
    return p, frame.as_matrix()


@pytest.mark.parametrize("theta, phi", [(0.3, 0.0), (1.2, 2.0), (2.5, -2.2), (3.5, 0.7)])
def test_tip_pose_matches_an_integrated_backbone(theta, phi):
    arc = Arc(np.float64(0.115), np.float64(theta * np.cos(phi)), np.float64(theta * np.sin(phi)))
    p, R = _integrated_tip(arc)
    # midpoint rule on a constant-curvature arc is exact for each chord direction up to the chord
    # length error (1 − sinc(θ/2N)) ~ θ²/(24 N²) ≈ 3e-8 relative: 1e-9 m is round-off + that
    assert_allclose(tip_position(arc), p, rtol=0, atol=5e-9)
    assert_allclose(tip_rotation(arc), R, rtol=0, atol=1e-9)  # products of 4000 rotations: round-off
    # the tip direction points along (sin θ cos φ, sin θ sin φ, cos θ)
    assert_allclose(tip_rotation(arc)[:, 2], [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], atol=1e-12)


@pytest.mark.parametrize("n_gaps", [1, 3, 12])
def test_disc_lengths_match_hole_to_hole_chords(n_gaps):
    """Muscle length with discs = sum of straight hole-to-hole distances, built independently."""
    r = 4 * MM
    arc = Arc(np.float64(0.12), np.float64(1.1), np.float64(-0.6))
    s, tx, ty = 0.12, 1.1, -0.6
    holes = r * np.column_stack([np.cos(MUSCLE_ANGLES), np.sin(MUSCLE_ANGLES), np.zeros(3)])
    pts = []
    for k in range(n_gaps + 1):
        sub = Arc(np.float64(s * k / n_gaps), np.float64(tx * k / n_gaps), np.float64(ty * k / n_gaps))
        pts.append(tip_position(sub) + holes @ tip_rotation(sub).T)  # disc frame → base frame
    pts = np.array(pts)  # (discs, muscle, xyz)
    chords = np.linalg.norm(np.diff(pts, axis=0), axis=2).sum(axis=0)
    assert_allclose(lengths_from_arc(arc, r, n_gaps), chords, rtol=0, atol=1e-14)  # round-off only


def test_one_muscle_shorter_bends_toward_it():
    for i, ang in enumerate(MUSCLE_ANGLES):
        lengths = np.full(3, 0.117)
        lengths[i] -= 5 * MM
        arc = arc_from_lengths(lengths, 4 * MM, 12)
        assert_allclose(np.cos(float(arc.phi) - ang), 1.0, atol=1e-12)  # φ points at muscle i
        tip = tip_position(arc)
        assert tip[:2] @ [np.cos(ang), np.sin(ang)] > 0


def test_chord_factor_limits():
    assert float(chord_factor(0.0, 12)) == 1.0
    assert float(chord_factor(2.0, None)) == 1.0
    assert_allclose(chord_factor(1e-4, 12), 1.0, atol=1e-12)  # 1 − x²/6 with x = 4e-6


def test_bad_input():
    with pytest.raises(InputError, match="3 muscle lengths"):
        arc_from_lengths([0.1, 0.1], 4 * MM)
    with pytest.raises(InputError, match="> 0"):
        arc_from_lengths([0.1, -0.1, 0.1], 4 * MM)
    with pytest.raises(InputError, match="too much"):
        arc_from_lengths([0.1, 0.2, 0.3], 4 * MM, 1)
    with pytest.raises(UnreachableError, match="negative z"):
        arc_from_tip([0.0, 0.0, -0.05])
    with pytest.raises(UnreachableError):
        arc_from_tip([0.0, 0.0, 0.0])
    with pytest.raises(InputError, match="3 coordinates"):
        arc_from_tip([0.0, 0.1])


def test_geometry_defaults_and_limits():
    g = ToolGeometry()
    assert g.pitch_radius == pytest.approx(4.0 * MM)  # (12 + 4)/4 mm: middle of the ring
    assert default_pitch_radius(12 * MM, 2.2 * MM, 4 * MM) == pytest.approx(4 * MM)
    lo, hi = pitch_radius_limits(12 * MM, 2.2 * MM, 4 * MM)
    assert (lo, hi) == (pytest.approx(3.1 * MM), pytest.approx(4.9 * MM))
    assert g.n_gaps == 12
    with pytest.raises(InputError, match="pitch radius"):
        ToolGeometry(pitch_radius=5.0 * MM)
    with pytest.raises(InputError, match="pitch radius"):
        ToolGeometry(pitch_radius=3.0 * MM)
    with pytest.raises(InputError, match="discs"):
        ToolGeometry(n_discs=1)
