"""Tip tracking: a path → pressure references (IK + static inverse) → three controlled muscles.

The reference half (this module's :func:`tip_reference`) needs only the tool: each sample of the
path goes through the inverse kinematics, the load model and each muscle's inverse static model,
giving three pressure references. The simulation half runs three plant instances, one per
muscle, each with its own pressure controller, on those references (:func:`simulate_tracking`),
and takes the pressures the plant achieves back through the tool's forward static equilibrium
to the achieved tip.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import UnreachableError
from mckibben.tool.geometry import Tool
from mckibben.tool.paths import TipPath
from mckibben.tool.statics import ToolState, explain_unreachable, pressures_for_tip, tip_from_pressures


def straight_height(tool: Tool, fraction: float = 0.5) -> float:
    """Height of the straight tool's tip with ``fraction·p_max`` in all three muscles.

    Parameters
    ----------
    tool : Tool
        The tool.
    fraction : float, default 0.5
        Fraction of p_max. [-]

    Returns
    -------
    float
        Tip height z (= arc length, the tool is straight). [m]
    """
    p = fraction * tool.p_max
    return float(tip_from_pressures(np.array([p, p, p]), tool).tip[2])


def resolve_path(path: TipPath, tool: Tool) -> TipPath:
    """The path with its plane height set (default :func:`straight_height` at p_max/2).

    Parameters
    ----------
    path : TipPath
        The parsed path.
    tool : Tool
        The tool it is for.
    """
    return path if path.z is not None else path.with_z(straight_height(tool))


@dataclass(frozen=True)
class TipReference:
    """Target tip positions along a path and the pressures that hold them (static inverse).

    Attributes
    ----------
    time : numpy.ndarray
        Sample times. [s]
    target : numpy.ndarray
        Target tip positions, shape (n, 3). [m]
    state : ToolState
        Lengths, tensions, pressures (shape (n, 3)) and flags at every sample.
    """

    time: np.ndarray
    target: np.ndarray
    state: ToolState

    @property
    def pressures(self) -> np.ndarray:
        """Pressure references of muscles 1, 2, 3, shape (n, 3). [Pa]"""
        return self.state.pressures


def tip_reference(tool: Tool, path: TipPath, ts: float = 1e-3) -> TipReference:
    """Pressure references for a tip path, sampled every ``ts``.

    Parameters
    ----------
    tool : Tool
        The tool.
    path : TipPath
        The path (its ``z`` resolved with :func:`resolve_path` if unset).
    ts : float, default 1e-3
        Sample period (the controllers' period). [s]

    Returns
    -------
    TipReference
        Times, targets and the static inverse at each sample.

    Raises
    ------
    UnreachableError
        When any point of the path is unreachable: names the first such time, the target and the
        limiting muscle(s).
    """
    path = resolve_path(path, tool)
    n = int(round(path.duration / ts))
    t = np.arange(n) * ts
    target = path.position(t)
    per_loop = path.period / ts
    if abs(per_loop - round(per_loop)) < 1e-9 * per_loop and round(per_loop) < n:
        # the path repeats every round(per_loop) samples: solve one loop and tile it (same numbers)
        m = int(round(per_loop))
        one = pressures_for_tip(target[:m], tool)
        state = _tile_state(one, -(-n // m), n)
    else:
        state = pressures_for_tip(target, tool)
    bad = np.flatnonzero(~state.reachable)
    if bad.size:
        i = int(bad[0])
        x, y, z = target[i] * 1e3
        raise UnreachableError(
            f"path: the tip target ({x:.2f}, {y:.2f}, {z:.2f}) mm at t = {t[i]:.3f} s is unreachable:"
            f" {explain_unreachable(state, tool, i)}"
        )
    return TipReference(t, target, state)


def _tile_state(state: ToolState, reps: int, n: int) -> ToolState:
    """Repeat a ToolState along its first axis ``reps`` times and keep ``n`` samples."""
    from mckibben.tool.kinematics import Arc

    def tile(a):
        a = np.asarray(a)
        return np.concatenate([a] * reps, axis=0)[:n]

    arc = Arc(tile(state.arc.arc_length), tile(state.arc.theta_x), tile(state.arc.theta_y))
    return ToolState(arc, tile(state.tip), tile(state.rotation), tile(state.lengths), tile(state.tensions),
                     tile(state.pressures), tile(state.flags), tile(state.converged))


def tip_errors(target, achieved) -> dict:
    """RMS and maximum distance between target and achieved tip positions.

    Parameters
    ----------
    target : array_like
        Target tips, shape (n, 3). [m]
    achieved : array_like
        Achieved tips, shape (n, 3). [m]

    Returns
    -------
    dict
        ``rms_error_m`` and ``max_error_m``.
    """
    d = np.linalg.norm(np.asarray(achieved, float) - np.asarray(target, float), axis=-1)
    return {"rms_error_m": float(np.sqrt(np.mean(d * d))), "max_error_m": float(d.max())}


def simulate_tracking(tool: Tool, runs):
    """Run three plant instances per run (one per muscle, each with its own pressure controller).

    Parameters
    ----------
    tool : Tool
        The tool.
    runs : list of (TipPath, TipReference)
        The paths and their references; all runs are simulated in one batch.
    """
    from mckibben.errors import InputError

    try:
        from mckibben.plant import simulate_closed_loop  # issue 5
    except ImportError:
        raise InputError(
            "tracking in simulation needs the plant simulator (mckibben.plant, issue 5), which is not in"
            " this checkout; use --reference-only for the pressure references"
        ) from None
    raise InputError(f"tool tracking is not yet connected to {simulate_closed_loop.__module__}; use --reference-only")
