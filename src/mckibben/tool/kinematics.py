"""Constant-curvature kinematics of the three-muscle segment, without singularities.

Conventions (fixed here, once): muscle i sits at angle θi = 0°, 120°, 240° counter-clockwise
from the base x axis at pitch radius r; z is the tool axis. The arc is described by its arc
length s and the bend vector (θx, θy) = θ·(cos φ, sin φ) — the "Clarke coordinates" of
Grassmann & Burgner-Kahrs (2024) — where θ = κ·s is the total bend angle and φ the direction
the tip bends toward. Everything is written in (s, θx, θy): no branch, no division by θ, so the
straight configuration θ → 0 is an ordinary point (the sinc functions below are exact there).

Lengths (Webster & Jones, IJRR 2010, constant curvature), with ``n`` gaps between discs the
muscle runs straight from hole to hole, so each muscle's length is the arc length at its
offset times the chord factor ``c(θ) = sinc(θ/(2n))`` (1 in the continuous limit)::

    l_i = c(θ) · (s − r·(θx·cos θi + θy·sin θi))

Inverse, linear in the lengths::

    m = −(2/(3r))·Σ l_i·(cos θi, sin θi) = c(θ)·(θx, θy)
    θ = 2n·asin(|m|/(2n)),  (θx, θy) = m·θ/|m|,  s = mean(l)/c(θ)

Tip position: p = s·(θx·h1(θ), θy·h1(θ), h2(θ)) with h1 = (1 − cos θ)/θ² = ½·sinc²(θ/2),
h2 = sin θ/θ. Orientation: the rotation by θ about (−sin φ, cos φ, 0), i.e. the rotation
vector (−θy, θx, 0) — equal to Rz(φ)·Ry(θ)·Rz(−φ), torsion-free.

Position → arc (one segment sets position only; 3 DOF ↔ 3 lengths): the tip lies on a
circle through the base tangent to z, so α = θ/2 = atan2(ρ, z), s = |p|·α/sin α,
(θx, θy) = (2/|p|)·(α/sin α)·(x, y). Unique for every tip off the negative z half-axis.

References
----------
[webster2010] Webster, R. J. & Jones, B. A. (2010), Design and kinematic modeling of constant curvature
continuum robots: a review, IJRR 29(13), doi:10.1177/0278364910368147.
Grassmann, R. M. & Burgner-Kahrs, J. (2024), On the merits of joint space and orientation
representations in learning the forward kinematics in SE(3) / Clarke coordinates.
Jones, B. A. & Walker, I. D. (2006) on discrete spacer discs (chords between discs).
/work/shared/notes/continuum-kinematics.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, UnreachableError, check_array, check_int, check_real

# cos and sin of 0°, 120°, 240° written exactly, so that equal lengths give exactly θ = 0
# (np.cos(2π/3) is −0.4999999999999998, which would leave a 1e-15 rad bend).
_COS = np.array([1.0, -0.5, -0.5])
_SIN = np.array([0.0, 0.5 * np.sqrt(3.0), -0.5 * np.sqrt(3.0)])


@dataclass(frozen=True)
class Arc:
    """A constant-curvature arc in Clarke coordinates (arrays, broadcast together).

    Attributes
    ----------
    arc_length : numpy.ndarray
        Arc length of the disc-centre line, s. [m]
    theta_x, theta_y : numpy.ndarray
        Bend vector θ·(cos φ, sin φ). [rad]
    """

    arc_length: np.ndarray
    theta_x: np.ndarray
    theta_y: np.ndarray

    def __post_init__(self):
        for name in ("arc_length", "theta_x", "theta_y"):
            value = getattr(self, name)
            if not isinstance(value, (np.ndarray, np.generic)):  # built by hand (not computed): a checked number
                check_real(value, name, lo=0.0 if name == "arc_length" else None, unit="m" if name == "arc_length"
                           else "rad")

    @property
    def theta(self) -> np.ndarray:
        """Total bend angle θ = κ·s, ≥ 0. [rad]"""
        return np.hypot(self.theta_x, self.theta_y)

    @property
    def phi(self) -> np.ndarray:
        """Bending-plane angle φ, the direction the tip bends toward (0 when straight). [rad]"""
        return np.arctan2(self.theta_y, self.theta_x)

    @property
    def curvature(self) -> np.ndarray:
        """Curvature κ = θ/s. [1/m]"""
        return self.theta / self.arc_length

    @property
    def curvature_vector(self) -> np.ndarray:
        """(κx, κy) = (θx, θy)/s, last axis. [1/m]"""
        return np.stack([self.theta_x, self.theta_y], axis=-1) / np.asarray(self.arc_length)[..., None]


def _sinc(x):
    """sin x / x, exact at 0 (NumPy's normalized sinc rescaled)."""
    return np.sinc(np.asarray(x, dtype=float) / np.pi)


def _asin_ratio(u):
    """asin(u)/u for 0 ≤ u ≤ 1, exact at 0 (series below 1e-3, error < 1e-19)."""
    u = np.asarray(u, dtype=float)
    small = u < 1e-3
    safe = np.where(small, 0.5, u)
    series = 1.0 + u * u / 6.0 + 3.0 * u**4 / 40.0
    return np.where(small, series, np.arcsin(np.minimum(safe, 1.0)) / safe)


def chord_factor(theta, n_gaps):
    """Ratio of a muscle's chord path to its arc path with ``n_gaps`` gaps between discs.

    Parameters
    ----------
    theta : array_like
        Total bend angle. [rad]
    n_gaps : int or None
        Number of gaps between discs; ``None`` is the continuous limit (factor 1). [-]

    Returns
    -------
    numpy.ndarray
        ``sinc(θ/(2·n_gaps))``: every muscle crosses a gap of bend θ/n on a straight chord. [-]

    Examples
    --------
    >>> float(chord_factor(0.0, 12)), round(float(chord_factor(2.4, 12)), 5)
    (1.0, 0.99833)
    """
    theta = np.asarray(theta, dtype=float)
    if n_gaps is None:
        return np.ones_like(theta)
    return _sinc(theta / (2.0 * n_gaps))


def _as_lengths(lengths) -> np.ndarray:
    if lengths is None or isinstance(lengths, (str, bytes, bool, np.bool_, dict, set)):
        raise ArgumentTypeError(f"lengths = {lengths!r}: not an array of 3 muscle lengths ({type(lengths).__name__})")
    try:
        raw = np.asarray(lengths)
    except (TypeError, ValueError):
        raise ArgumentTypeError("lengths: not an array of numbers (ragged or mixed)") from None
    if raw.dtype == bool or raw.dtype.kind not in "iuf":
        raise ArgumentTypeError(f"lengths: an array of {raw.dtype} values; give lengths in m")
    if raw.size > MAX_POSES * 3:
        raise InputError(f"lengths: {raw.size // 3:,} poses, more than the {MAX_POSES:,} a call takes; call in chunks")
    lengths = raw.astype(float)
    if lengths.ndim == 0 or lengths.shape[-1] != 3:
        raise InputError(f"lengths: need 3 muscle lengths (last axis), got shape {lengths.shape}")
    if not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
        raise InputError("lengths: every muscle length must be a finite length > 0 m")
    return lengths


#: The most poses (rows of three lengths or coordinates) one kinematics call takes: about 1 s and
#: 1 GiB of working arrays at the limit. [-]
MAX_POSES = 10**6


def _check_arc(arc) -> None:
    if not isinstance(arc, Arc):
        raise ArgumentTypeError(f"arc = {arc!r}: not an Arc ({type(arc).__name__}); get one from arc_from_lengths "
                                "or arc_from_tip")


#: Largest pitch radius accepted by the kinematics: far past any continuum tool. [m]
MAX_PITCH_RADIUS = 1.0


def _check_pitch(pitch_radius) -> float:
    """The pitch radius: a finite number in (0, :data:`MAX_PITCH_RADIUS`]. [m]"""
    return check_real(pitch_radius, "pitch_radius", lo=0.0, hi=MAX_PITCH_RADIUS, lo_open=True, unit="m")


def _check_gaps(n_gaps):
    """``n_gaps``: None (continuous backbone) or a whole number >= 1. [-]"""
    return None if n_gaps is None else check_int(n_gaps, "n_gaps", lo=1)


def arc_from_lengths(lengths, pitch_radius, n_gaps=None) -> Arc:
    """Arc parameters from the three muscle lengths (forward kinematics, first half).

    Parameters
    ----------
    lengths : array_like
        Muscle lengths, last axis = muscles 1, 2, 3 (at 0°, 120°, 240°). [m]
    pitch_radius : float
        Radius of the circle through the muscles, r. [m]
    n_gaps : int or None, default None
        Gaps between discs; ``None`` is the continuous backbone. [-]

    Returns
    -------
    Arc
        Arc length s [m] and bend vector (θx, θy) [rad].

    Raises
    ------
    InputError
        Not three positive lengths, or lengths so different that no chord path fits them.

    References
    ----------
    Webster & Jones (2010) constant curvature; Clarke coordinates (Grassmann & Burgner-Kahrs
    2024): m = −(2/(3r))·Σ l_i·(cos θi, sin θi). Module docstring.

    Examples
    --------
    >>> a = arc_from_lengths([0.117, 0.117, 0.117], 4e-3)
    >>> float(a.arc_length), float(a.theta)
    (0.117, 0.0)
    """
    lengths = _as_lengths(lengths)
    pitch_radius, n_gaps = _check_pitch(pitch_radius), _check_gaps(n_gaps)
    k = -2.0 / (3.0 * pitch_radius)
    # Σ l_i·cos θi and Σ l_i·sin θi written as differences: exactly 0 for equal lengths, where a
    # BLAS dot product (FMA, reordered sums) leaves a rounding residue of order 1e-17 m
    l1, l2, l3 = lengths[..., 0], lengths[..., 1], lengths[..., 2]
    mx = k * (l1 - 0.5 * (l2 + l3))
    my = k * (_SIN[1] * (l2 - l3))
    m = np.hypot(mx, my)
    if n_gaps is None:
        ratio = np.ones_like(m)
    else:
        u = m / (2.0 * n_gaps)
        if np.any(u > 1.0):
            raise InputError(
                "lengths: the muscles differ too much for the disc stack"
                f" (a bend of more than π per gap with {n_gaps} gaps)"
            )
        ratio = _asin_ratio(u)
    theta = m * ratio
    s = lengths.mean(axis=-1) / chord_factor(theta, n_gaps)
    return Arc(s, mx * ratio, my * ratio)


def lengths_from_arc(arc: Arc, pitch_radius, n_gaps=None) -> np.ndarray:
    """Muscle lengths from the arc parameters (inverse kinematics, second half).

    Parameters
    ----------
    arc : Arc
        Arc length and bend vector.
    pitch_radius : float
        Radius of the circle through the muscles, r. [m]
    n_gaps : int or None, default None
        Gaps between discs; ``None`` is the continuous backbone. [-]

    Returns
    -------
    numpy.ndarray
        Lengths of muscles 1, 2, 3 on the last axis. [m]

    References
    ----------
    Webster & Jones (2010): l_i = s − r·θ·cos(θi − φ), times the chord factor for discs.
    """
    _check_arc(arc)
    pitch_radius, n_gaps = _check_pitch(pitch_radius), _check_gaps(n_gaps)
    s = np.asarray(arc.arc_length, dtype=float)[..., None]
    tx = np.asarray(arc.theta_x, dtype=float)[..., None]
    ty = np.asarray(arc.theta_y, dtype=float)[..., None]
    c = chord_factor(np.asarray(arc.theta), n_gaps)[..., None]
    return c * (s - pitch_radius * (tx * _COS + ty * _SIN))


def tip_position(arc: Arc) -> np.ndarray:
    """Tip position (centre of the tip disc) of a constant-curvature arc.

    Parameters
    ----------
    arc : Arc
        Arc length and bend vector.

    Returns
    -------
    numpy.ndarray
        (x, y, z) on the last axis, base frame (z along the straight tool). [m]

    References
    ----------
    Webster & Jones (2010), eq. for p with f1 = (1 − cos θ)/θ = θ·½·sinc²(θ/2), f2 = sinc θ.
    """
    _check_arc(arc)
    s = np.asarray(arc.arc_length, dtype=float)
    theta = np.asarray(arc.theta)
    h1 = 0.5 * _sinc(0.5 * theta) ** 2
    return np.stack([s * arc.theta_x * h1, s * arc.theta_y * h1, s * _sinc(theta)], axis=-1)


def tip_rotation(arc: Arc) -> np.ndarray:
    """Orientation of the tip disc: Rz(φ)·Ry(θ)·Rz(−φ), computed from the rotation vector.

    Parameters
    ----------
    arc : Arc
        Arc length and bend vector.

    Returns
    -------
    numpy.ndarray
        Rotation matrices, shape ``(..., 3, 3)``; the third column is the tip direction. [-]
    """
    _check_arc(arc)
    from scipy.spatial.transform import Rotation  # deferred on purpose: SciPy
    tx = np.asarray(arc.theta_x, dtype=float)
    ty = np.asarray(arc.theta_y, dtype=float)
    rotvec = np.stack([-ty, tx, np.zeros_like(tx)], axis=-1)
    flat = rotvec.reshape(-1, 3)
    return Rotation.from_rotvec(flat).as_matrix().reshape(rotvec.shape[:-1] + (3, 3))


def arc_from_tip(tip) -> Arc:
    """Arc parameters that put the tip at a position (the unique constant-curvature arc).

    Parameters
    ----------
    tip : array_like
        Tip position (x, y, z) on the last axis, base frame. [m]

    Returns
    -------
    Arc
        Arc length s [m] and bend vector (θx, θy) [rad].

    Raises
    ------
    UnreachableError
        A tip at the base or on the negative z half-axis: no arc tangent to z at the base ends
        there (it would need θ = 2π).

    References
    ----------
    Webster & Jones (2010): θ = 2·atan2(ρ, z), s = |p|·(θ/2)/sin(θ/2); written with
    α/sin α so that ρ → 0 has no division by zero. Module docstring.

    Examples
    --------
    >>> a = arc_from_tip([0.0, 0.0, 0.11])
    >>> float(a.arc_length), float(a.theta)
    (0.11, 0.0)
    """
    tip = check_array(tip, "tip", size=MAX_POSES * 3, unit="m")
    if tip.ndim == 0 or tip.shape[-1] != 3:
        raise InputError(f"tip: need 3 coordinates (x, y, z), got shape {tip.shape}")
    x, y, z = tip[..., 0], tip[..., 1], tip[..., 2]
    rho = np.hypot(x, y)
    dist = np.sqrt(rho * rho + z * z)
    alpha = np.arctan2(rho, z)
    bad = (dist <= 0) | (np.pi - alpha < 1e-9)
    if np.any(bad):
        raise UnreachableError(
            "tip: a tip at the base or straight behind it (on the negative z axis) needs a bend of 2π;"
            " no single constant-curvature arc reaches it"
        )
    q = 1.0 / _sinc(alpha)  # α / sin α
    return Arc(dist * q, 2.0 * q / dist * x, 2.0 * q / dist * y)


def lengths_from_tip(tip, pitch_radius, n_gaps=None) -> np.ndarray:
    """Muscle lengths that put the tip at a position (inverse kinematics).

    Parameters
    ----------
    tip : array_like
        Tip position (x, y, z) on the last axis. [m]
    pitch_radius : float
        Radius of the circle through the muscles, r. [m]
    n_gaps : int or None, default None
        Gaps between discs; ``None`` is the continuous backbone. [-]

    Returns
    -------
    numpy.ndarray
        Lengths of muscles 1, 2, 3. [m]
    """
    return lengths_from_arc(arc_from_tip(tip), pitch_radius, n_gaps)


def tip_from_lengths(lengths, pitch_radius, n_gaps=None) -> np.ndarray:
    """Tip position from the three muscle lengths (forward kinematics).

    Parameters
    ----------
    lengths : array_like
        Muscle lengths, last axis = muscles 1, 2, 3. [m]
    pitch_radius : float
        Radius of the circle through the muscles, r. [m]
    n_gaps : int or None, default None
        Gaps between discs; ``None`` is the continuous backbone. [-]

    Returns
    -------
    numpy.ndarray
        Tip position (x, y, z). [m]
    """
    return tip_position(arc_from_lengths(lengths, pitch_radius, n_gaps))
