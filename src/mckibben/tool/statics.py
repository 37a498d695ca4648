"""Pressures for a tip target and the tip a set of pressures holds: kinematics + muscle statics.

Inverse (target → pressures), closed form except for each muscle's cubic:
tip → arc (unique, :func:`~mckibben.tool.kinematics.arc_from_tip`) → muscle lengths → the
tension each muscle must carry (:func:`muscle_tensions`, the shared load model) → each
muscle's pressure from its inverse static model at that length under that tension, within
``p_max``: the muscle object's ``pressure_for_length`` (the miniature's braid-angle map inverted,
:func:`mckibben.models.mpam.pressure_for_length`; a fitted law solved for the pressure,
:meth:`mckibben.models.law_statics.LawMuscle.pressure_for_length`).

Forward (pressures → tip): the lengths depend on the tensions and the tensions on the pose, so
the pose is the solution of three equations ``l_i(s, θx, θy) = L(P_i, F_i(s, θx, θy))``
(geometry = static model), solved for all samples at once by a damped Newton iteration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import InputError, UnreachableError
from mckibben.models.flags import Flag, flag_names, flag_where
from mckibben.models.laws import MPA
from mckibben.tool.geometry import MUSCLE_ANGLES, Tool
from mckibben.tool.kinematics import Arc, arc_from_lengths, arc_from_tip, lengths_from_arc, tip_position, tip_rotation

from mckibben.tool.kinematics import _COS, _SIN  # exact cos/sin of the muscle angles


def muscle_tensions(arc: Arc, tool: Tool) -> np.ndarray:
    """The tension each muscle carries in a pose: the shared load model (:class:`StackLoad`).

    Parameters
    ----------
    arc : Arc
        The pose's arc length and bend vector.
    tool : Tool
        Geometry (pitch radius r) and load model (F0, Kb, Ka, s_ref).

    Returns
    -------
    numpy.ndarray
        Tensions of muscles 1, 2, 3 on the last axis; negative means the muscle would have to
        push. [N]

    References
    ----------
    /work/shared/notes/continuum-kinematics.md "Forces": Kb·κ = r·Σ F_i·ĥ_i,
    Σ F_i = A, so F_i = A/3 + (2/3)(Kb/r)(κx cos θi + κy sin θi),
    A = 3·F0 + Ka·(s_ref − s)/s_ref.
    """
    load = tool.load
    r = tool.geometry.pitch_radius
    s = np.asarray(arc.arc_length, dtype=float)
    s_ref = tool.reference_length
    axial = 3.0 * load.preload + load.axial_stiffness * (s_ref - s) / s_ref
    kappa = arc.curvature_vector
    bend = (load.bending_stiffness / r) * (kappa[..., 0:1] * _COS + kappa[..., 1:2] * _SIN)
    return axial[..., None] / 3.0 + (2.0 / 3.0) * bend


@dataclass(frozen=True)
class ToolState:
    """A pose of the tool with what each muscle does there (arrays; muscles on the last axis).

    Attributes
    ----------
    arc : Arc
        Arc length [m] and bend vector [rad].
    tip : numpy.ndarray
        Tip position (x, y, z). [m]
    rotation : numpy.ndarray
        Tip orientation, ``(..., 3, 3)``. [-]
    lengths : numpy.ndarray
        Muscle lengths. [m]
    tensions : numpy.ndarray
        Muscle tensions from the load model. [N]
    pressures : numpy.ndarray
        Muscle pressures (NaN where unreachable). [Pa]
    flags : numpy.ndarray
        Per-muscle :class:`~mckibben.models.flags.Flag` masks (uint16).
    converged : numpy.ndarray
        Whether the static equilibrium converged (always True for the inverse). [-]
    """

    arc: Arc
    tip: np.ndarray
    rotation: np.ndarray
    lengths: np.ndarray
    tensions: np.ndarray
    pressures: np.ndarray
    flags: np.ndarray
    converged: np.ndarray

    @property
    def reachable(self) -> np.ndarray:
        """True where every muscle's pressure is within [0, p_max] and no muscle pushes. [-]"""
        return np.all(np.isfinite(self.pressures), axis=-1) & ~np.any(self.flags & Flag.SLACK, axis=-1)

    def flag_lists(self) -> list:
        """Per-muscle lists of flag names (nested like the leading shape, then the 3 muscles)."""
        flat = self.flags.reshape(-1, 3)
        out = [[flag_names(f) for f in row] for row in flat]
        return out[0] if self.flags.ndim == 1 else out


def pressures_for_tip(tip, tool: Tool) -> ToolState:
    """The three pressures that put the tip at a target (IK + load model + static inverse).

    Parameters
    ----------
    tip : array_like
        Target tip position(s) (x, y, z), last axis. [m]
    tool : Tool
        The tool (geometry, muscle, load model, p_max).

    Returns
    -------
    ToolState
        Arc, lengths, tensions, pressures (NaN where a muscle cannot reach its length under its
        tension within [0, p_max]) and flags per muscle: the static model's flags
        (``pressure_out_of_range``, ``load_out_of_range``, ``cos_theta_above_one``) plus
        ``unreachable`` and ``slack`` (the muscle would have to push).

    References
    ----------
    [mpam-characterization] eq. (2)–(3) inverted per muscle; kinematics as in
    :mod:`mckibben.tool.kinematics`.
    """
    arc = arc_from_tip(tip)
    geo = tool.geometry
    lengths = lengths_from_arc(arc, geo.pitch_radius, geo.n_gaps)
    tensions = muscle_tensions(arc, tool)
    result = tool.muscle.pressure_for_length(lengths, tensions, tool.p_max)
    slack = tensions < 0
    pressures = np.where(slack, np.nan, result.pressure)
    flags = (result.flags | flag_where(slack, Flag.SLACK) | flag_where(slack, Flag.UNREACHABLE)).astype(np.uint16)
    tip = tip_position(arc)
    return ToolState(arc, tip, tip_rotation(arc), lengths, tensions, pressures, flags, np.ones(tip.shape[:-1], bool))


def length_span(tool: Tool, tension, n: int = 801) -> tuple[float, float]:
    """Shortest and longest length a muscle reaches with pressures in [0, p_max] under a tension.

    Parameters
    ----------
    tool : Tool
        The tool (its muscle and p_max).
    tension : float
        The muscle's tension. [N]
    n : int, default 801
        Pressure samples over [0, p_max] (the cubic need not be monotonic). [-]

    Returns
    -------
    tuple of float
        (shortest, longest) length. [m]
    """
    lengths = tool.muscle.length_for_pressure(np.linspace(0.0, tool.p_max, n), tension).length
    return float(lengths.min()), float(lengths.max())


def explain_unreachable(state: ToolState, tool: Tool, index: int = 0) -> str | None:
    """Why a target is unreachable, naming the limiting muscle; ``None`` when it is reachable.

    Parameters
    ----------
    state : ToolState
        The result of :func:`pressures_for_tip`.
    tool : Tool
        The tool it was computed for.
    index : int, default 0
        Which target (flat index over the leading shape). [-]
    """
    lengths = state.lengths.reshape(-1, 3)[index]
    tensions = state.tensions.reshape(-1, 3)[index]
    pressures = state.pressures.reshape(-1, 3)[index]
    reasons = []
    for i in range(3):
        name = f"muscle {i + 1} (at {np.degrees(MUSCLE_ANGLES[i]):.0f}°)"
        if tensions[i] < 0:
            reasons.append(
                f"{name} would have to push ({tensions[i]:.3g} N): a McKibben muscle only pulls"
            )
        elif not np.isfinite(pressures[i]):
            lo, hi = length_span(tool, tensions[i])
            if lengths[i] > hi:
                why = f"longer than its relaxed {hi * 1e3:.2f} mm at 0 MPa: it can only shorten"
            elif lengths[i] < lo:
                why = f"shorter than its {lo * 1e3:.2f} mm at {tool.p_max / MPA:g} MPa: more pressure than p_max"
            else:
                why = f"outside what 0..{tool.p_max / MPA:g} MPa reaches"
            reasons.append(f"{name} would have to be {lengths[i] * 1e3:.2f} mm under {tensions[i]:.3g} N, {why}")
    if not reasons:
        return None
    return "; ".join(reasons)


def require_reachable_tip(state: ToolState, tool: Tool) -> None:
    """Raise :class:`~mckibben.errors.UnreachableError` naming the limiting muscle(s) of the first unreachable target.

    Parameters
    ----------
    state : ToolState
        The result of :func:`pressures_for_tip`.
    tool : Tool
        The tool it was computed for.
    """
    reach = np.ravel(state.reachable)
    bad = np.flatnonzero(~reach)
    if bad.size:
        i = int(bad[0])
        tip = state.tip.reshape(-1, 3)[i] * 1e3
        raise UnreachableError(
            f"tip ({tip[0]:.2f}, {tip[1]:.2f}, {tip[2]:.2f}) mm is unreachable: {explain_unreachable(state, tool, i)}"
        )


def tip_from_pressures(pressures, tool: Tool, *, tol: float = 1e-12, max_iter: int = 60) -> ToolState:
    """The pose three pressures hold: static equilibrium of geometry, load model and muscle model.

    Solves ``l_i(s, θx, θy) = L(P_i, F_i(s, θx, θy))`` for every sample at once (damped Newton,
    forward-difference Jacobian, started from the straight tool under the preload).

    Parameters
    ----------
    pressures : array_like
        Pressures of muscles 1, 2, 3 on the last axis. [Pa]
    tool : Tool
        The tool.
    tol : float, default 1e-12
        Convergence threshold on the largest length residual. [m]
    max_iter : int, default 60
        Newton iterations at most. [-]

    Returns
    -------
    ToolState
        The equilibrium pose; ``converged`` is False where the iteration did not converge;
        flags carry the static model's flags and ``slack`` where a muscle would push.

    References
    ----------
    [mpam-characterization] eq. (2)–(3) per muscle; load model :func:`muscle_tensions`.
    """
    p = np.asarray(pressures, dtype=float)
    if p.ndim == 0 or p.shape[-1] != 3:
        raise InputError(f"pressures: need 3 muscle pressures (last axis), got shape {p.shape}")
    if not np.all(np.isfinite(p)) or np.any(p < 0):
        raise InputError("pressures: every pressure must be a finite gauge pressure >= 0 Pa")
    if np.any(p > tool.p_max * (1 + 1e-12)):
        raise InputError(f"pressures: above p_max = {tool.p_max / MPA:g} MPa")
    shape = p.shape[:-1]
    p = p.reshape(-1, 3)
    geo = tool.geometry
    r, n = geo.pitch_radius, geo.n_gaps
    muscle = tool.muscle

    def unpack(x):
        return Arc(x[:, 0], x[:, 1], x[:, 2])

    def residual(x, rows=slice(None)):
        arc = unpack(x)
        f = muscle_tensions(arc, tool)
        return lengths_from_arc(arc, r, n) - muscle.length_for_pressure(p[rows], f).length

    start = muscle.length_for_pressure(p, tool.load.preload).length
    a0 = arc_from_lengths(start, r, n)
    x = np.column_stack([a0.arc_length, a0.theta_x, a0.theta_y])
    res = residual(x)
    converged = np.max(np.abs(res), axis=1) < tol
    step_cap = np.array([5e-3, 0.2, 0.2])  # largest Newton step per iteration in s [m], θx, θy [rad]
    for _ in range(max_iter):
        todo = ~converged
        if not todo.any():
            break
        xt, rt = x[todo], res[todo]
        jac = np.empty((xt.shape[0], 3, 3))
        h = np.array([1e-7, 1e-6, 1e-6])  # forward-difference steps: s [m], θx, θy [rad]
        for j in range(3):
            xp = xt.copy()
            xp[:, j] += h[j]
            jac[:, :, j] = (residual(xp, todo) - rt) / h[j]
        try:
            dx = np.linalg.solve(jac, -rt[..., None])[..., 0]
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(jac.reshape(-1, 3), -rt.reshape(-1), rcond=None)[0].reshape(-1, 3)
        scale = np.max(np.abs(dx) / step_cap, axis=1)
        dx /= np.maximum(scale, 1.0)[:, None]
        xn = xt + dx
        rn = residual(xn, todo)
        # halve steps that did not reduce the residual
        for _half in range(8):
            worse = np.max(np.abs(rn), axis=1) > np.max(np.abs(rt), axis=1)
            if not worse.any():
                break
            dx[worse] *= 0.5
            xn = xt + dx
            rn = residual(xn, todo)
        x[todo], res[todo] = xn, rn
        converged = np.max(np.abs(res), axis=1) < tol
    arc = unpack(x)
    tensions = muscle_tensions(arc, tool)
    pred = muscle.length_for_pressure(p, tensions)
    flags = (pred.flags | flag_where(tensions < 0, Flag.SLACK)).astype(np.uint16)
    lengths = lengths_from_arc(arc, r, n)
    arc = Arc(arc.arc_length.reshape(shape), arc.theta_x.reshape(shape), arc.theta_y.reshape(shape))
    return ToolState(
        arc,
        tip_position(arc),
        tip_rotation(arc),
        lengths.reshape(shape + (3,)),
        tensions.reshape(shape + (3,)),
        p.reshape(shape + (3,)),
        flags.reshape(shape + (3,)),
        converged.reshape(shape),
    )

