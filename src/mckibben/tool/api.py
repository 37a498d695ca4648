"""The three-muscle endoscope from Python: build a tool, pose it, sample its workspace.

Each function takes quantities as SI numbers (text with a unit is refused, with the SI number to
pass: :func:`mckibben.units.si`) and returns a result. Steering the tip along a path with three
simulated muscles is an experiment: :func:`mckibben.experiments.track_tip` (``mckibben tool track``).

>>> import mckibben.tool as mt                                              # doctest: +SKIP
>>> tool = mt.make_tool("mpam117", preload=1.0)                             # doctest: +SKIP
>>> mt.inverse([0.0, 3e-3, 0.09], tool).pressures, mt.map_workspace(tool).plot()  # doctest: +SKIP
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_instance
from mckibben.models.law_statics import LawMuscle
from mckibben.models.mpam import MiniatureMuscle
from mckibben.results import Result, to_jsonable
from mckibben.tool.geometry import DEFAULT_MUSCLE, MAX_BENDING_STIFFNESS, StackLoad, Tool, ToolGeometry
from mckibben.tool.workspace import Workspace
from mckibben.units import SI_UNIT, parse_values, si
from mckibben.datasets import get_muscle
from mckibben.hardware import P_MAX_DEFAULT
from mckibben.limits import check_p_max
from mckibben.fit.muscle_file import check_direction
from mckibben.tool.muscles import file_geometry, file_load, file_muscle
from mckibben.tool.statics import ToolState, pressures_for_tip, tip_from_pressures
from mckibben.tool.kinematics import arc_from_lengths, tip_position
from mckibben.tool.statics import require_reachable_tip
from mckibben.tool.workspace import sample_workspace
from mckibben.tool.workspace import plot_workspace

__all__ = ["WorkspaceResult", "check_within_reach", "forward", "inverse", "make_tool", "map_workspace", "state_dict",
           "tool_dict"]


def _discs(discs):
    if discs is None:
        return None
    if isinstance(discs, str):
        if discs.strip().lower() in ("continuous", "none", "inf"):
            return None
        try:
            int(discs)
        except ValueError:
            raise InputError(f"discs: {discs!r} is not a whole number of discs (or 'continuous')") from None
    if isinstance(discs, bool) or not isinstance(discs, (int, np.integer, str)):
        raise InputError(f"discs: {discs!r} is not a whole number of discs (or 'continuous')")
    n = int(discs)
    if n < 2:
        raise InputError(f"discs: {discs!r} must be at least 2 (base and tip)")
    return n




def make_tool(muscle=None, *, muscle_file=None, direction="inflate", pitch_radius=None, discs=13, preload=None,
              bending_stiffness=None, axial_stiffness=None, p_max=None) -> Tool:
    """The three-muscle tool of §V of [mpam-characterization] with its stack's load model.

    With ``muscle_file``, the three muscles are a lab's own (a muscle file with a fitted force
    law, ``mckibben fit … --save``) in the paper's disc stack scaled to their outer diameter, with
    a load model that spans the lengths the law was fitted on (:mod:`mckibben.tool.muscles`;
    docs/tool.md, "A lab's own muscle"). Every default below is then the file's.

    Parameters
    ----------
    muscle : str or MiniatureMuscle, optional
        Parameter set of the three muscles (``mpam97``, ``mpam117``, ``mpam143``); default
        ``mpam117``. [-]
    muscle_file : str or pathlib.Path, optional
        A muscle file with a ``[force_model]`` table: its fitted law is the muscles' statics and
        its plant the tracking plant (not with ``muscle``). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        ``muscle_file``: the spring law's branch (its hysteresis); the other laws have one and
        refuse ``deflate``. [-]
    pitch_radius : float, optional
        Radius of the muscle holes' circle; default the middle of the disc's ring (4 mm on the
        paper's 12 mm disc). [m]
    discs : int or None, default 13
        Spacer discs including base and tip; None (or ``"continuous"``) for the limit of many. [-]
    preload : float, optional
        Tension of each muscle in the straight tool, F0; default 1 N, or a file's
        :func:`~mckibben.tool.muscles.file_load`. [N]
    bending_stiffness : float, optional
        Backbone bending stiffness Kb; default 2e-4 N·m², or a file's. [N·m²]
    axial_stiffness : float, optional
        Backbone axial stiffness Ka (force per unit strain); default 0 N, or a file's. [N]
    p_max : float, optional
        Highest pressure allowed in any muscle; default 0.8 MPa
        (:data:`mckibben.hardware.P_MAX_DEFAULT`), for a file at most the top of its fitted
        pressures (a larger ``p_max`` is refused). [Pa]

    Returns
    -------
    Tool
    """

    n_discs = _discs(discs)
    radius = si(pitch_radius, "length", "pitch_radius", allow_zero=False) if pitch_radius is not None else None
    pmax = None if p_max is None else check_p_max(si(p_max, "pressure", "p_max", allow_zero=False))
    for name, value, dim in (("preload", preload, "force"), ("bending_stiffness", bending_stiffness, "bending_stiffness"),
                             ("axial_stiffness", axial_stiffness, "force")):
        if value is not None:
            si(value, dim, name)

    check_direction(direction)
    if muscle_file is not None:
        if not isinstance(muscle_file, (str, os.PathLike)):
            raise ArgumentTypeError(f"muscle_file = {muscle_file!r}: not a file path ({type(muscle_file).__name__}); "
                                    "give a str or a pathlib.Path")
        if muscle is not None:
            raise InputError("muscle_file: give either `muscle` (a published set) or `muscle_file`, not both")
        fm = file_muscle(muscle_file, direction)
        top = float(fm.pressure_range[1])
        if pmax is None:
            pmax = min(float(P_MAX_DEFAULT), top)
        elif pmax > top:
            raise InputError(f"p_max: {pmax / 1e6:g} MPa is above the top of the pressures the force law of "
                             f"{muscle_file} was fitted on ({top / 1e6:g} MPa): the law is not known there")
        geo = file_geometry(fm, radius, n_discs)
        dflt = file_load(fm, float(geo.pitch_radius or 0.0), pmax)
        s_ref = dflt["reference_length"]
        m: MiniatureMuscle | LawMuscle = fm
    else:
        if not isinstance(muscle, (str, type(None), MiniatureMuscle)):
            raise ArgumentTypeError(f"muscle = {muscle!r}: not a muscle ({type(muscle).__name__}); give a published "
                                    "set's name (mpam97, mpam117, mpam143) or a MiniatureMuscle")
        m = get_muscle(DEFAULT_MUSCLE if muscle is None else muscle) if isinstance(muscle, (str, type(None))) else muscle
        pmax = float(P_MAX_DEFAULT) if pmax is None else pmax
        geo = ToolGeometry(pitch_radius=radius, n_discs=n_discs)
        dflt, s_ref = {"preload": 1.0, "bending_stiffness": 2e-4, "axial_stiffness": 0.0}, None
    preload = dflt["preload"] if preload is None else preload
    bending_stiffness = dflt["bending_stiffness"] if bending_stiffness is None else bending_stiffness
    axial_stiffness = dflt["axial_stiffness"] if axial_stiffness is None else axial_stiffness
    kb = si(bending_stiffness, "bending_stiffness", "bending_stiffness")
    if not 0 < kb <= MAX_BENDING_STIFFNESS:
        raise InputError(f"bending_stiffness (`bending_stiffness`) = {kb:g} N·m²: outside (0, {MAX_BENDING_STIFFNESS:g}] "
                         "N·m² (a steel rod of the tool's 12 mm diameter is about 2e2 N·m²)")
    load = StackLoad(preload=si(preload, "force", "preload"), bending_stiffness=kb,
                     axial_stiffness=si(axial_stiffness, "force", "axial_stiffness"), reference_length=s_ref)
    try:
        return Tool(m, geo, load, pmax)
    except InputError as exc:  # the Tool names its field; a caller of make_tool gave --discs
        msg = str(exc)
        raise InputError("--" + msg if msg.startswith("discs:") else msg) from None


def tool_dict(tool: Tool) -> dict:
    """The tool's parameters, JSON-ready (SI, unit-suffixed keys).

    Parameters
    ----------
    tool : Tool
        The tool. [-]
    """
    check_instance(tool, "tool", Tool, "a Tool (make_tool)")
    g, ld = tool.geometry, tool.load
    return {
        "muscle": tool.muscle.name,
        "disc_diameter_m": g.disc_diameter,
        "hole_diameter_m": g.hole_diameter,
        "channel_diameter_m": g.channel_diameter,
        "pitch_radius_m": g.pitch_radius,
        "n_discs": g.n_discs,
        "muscle_angles_rad": [0.0, 2 * np.pi / 3, 4 * np.pi / 3],
        "preload_N": ld.preload,
        "bending_stiffness_Nm2": ld.bending_stiffness,
        "axial_stiffness_N": ld.axial_stiffness,
        "reference_length_m": tool.reference_length,
        "p_max_Pa": tool.p_max,
        **(_file_dict(tool.muscle) if isinstance(tool.muscle, LawMuscle) else {}),
    }


def _file_dict(m: LawMuscle) -> dict:
    """What a tool of a muscle file adds to :func:`tool_dict`: the file, its law and where it holds."""
    return {"muscle_file": str(getattr(m.source, "path", "") or m.name), "force_law": m.law, "direction": m.direction,
            "fitted_pressure_range_Pa": list(m.pressure_range), "fitted_length_range_m": list(m.length_range),
            "strand_length_m": m.strand_length}


def state_dict(state) -> dict:
    """One pose (:class:`~mckibben.tool.statics.ToolState`), JSON-ready (SI, unit-suffixed keys).

    Parameters
    ----------
    state : ToolState
        A single pose. [-]
    """
    check_instance(state, "state", ToolState, "a ToolState (forward, inverse)")
    arc = state.arc
    return to_jsonable({
        "arc_length_m": float(arc.arc_length),
        "curvature_per_m": float(arc.curvature),
        "bend_angle_rad": float(arc.theta),
        "bend_plane_angle_rad": float(arc.phi),
        "theta_x_rad": float(arc.theta_x),
        "theta_y_rad": float(arc.theta_y),
        "tip_m": state.tip.tolist(),
        "tip_direction": state.rotation[:, 2].tolist(),
        "tip_rotation": state.rotation.tolist(),
        "lengths_m": state.lengths.tolist(),
        "tensions_N": state.tensions.tolist(),
        "pressures_Pa": state.pressures.tolist(),
        "flags": state.flag_lists(),
        "reachable": bool(state.reachable),
    })


def _three(value, dimension: str, name: str, **kw) -> np.ndarray:
    """Three SI numbers (muscles 1, 2, 3, or x, y, z): text is refused with the numbers to pass."""
    if isinstance(value, str):
        try:
            hint = f"; pass {[float(f'{v:.6g}') for v in parse_values(value, dimension, name, **kw)]} for {value!r}"
        except InputError:
            hint = ""
        raise ArgumentTypeError(f"{name} = {value!r}: the library takes three numbers in {SI_UNIT[dimension]} (SI), "
                                f"not text{hint} (mckibben.units.parse_values converts text)")
    if isinstance(value, (bytes, dict, set)) or value is None or np.ndim(value) != 1 or len(value) != 3:
        got = f"shape {np.shape(value)}" if isinstance(value, np.ndarray) else repr(value)
        raise InputError(f"{name}: need exactly 3 values (muscles 1, 2, 3, or x, y, z), got {' '.join(got.split())}")
    return np.array([si(x, dimension, name, **kw) for x in value])


def check_within_reach(point: np.ndarray, tool: Tool, name: str, what: str) -> None:
    """Refuse a target farther from the base than the tool's muscles are long (before any solve).

    Parameters
    ----------
    point : numpy.ndarray
        The target (a tip, or a path's size as a one-element array). [m]
    tool : Tool
        The tool. [-]
    name, what : str
        The argument refused and what it holds, for the message. [-]
    """
    reach = tool.muscle.strand_length
    dist = float(np.linalg.norm(point)) if np.all(np.isfinite(point)) else float("inf")
    if not dist <= reach:
        raise InputError(f"{name}: {what} {dist * 1e3:.4g} mm from the base is farther than the tool reaches "
                         f"(its muscles' strands are {reach * 1e3:g} mm)")


def forward(tool: Tool | None = None, *, lengths=None, pressures=None):
    """Forward kinematics: three muscle lengths, or three pressures (static equilibrium), to the pose.

    Parameters
    ----------
    tool : Tool, optional
        Default :func:`make_tool`'s. [-]
    lengths : sequence of 3 float, optional
        Muscle lengths (e.g. ``[0.117, 0.112, 0.115]``). [m]
    pressures : sequence of 3 float, optional
        Muscle pressures (e.g. ``[0.4e6, 0.0, 0.2e6]``). [Pa]

    Returns
    -------
    ToolState
        Arc, tip, rotation, lengths, tensions, pressures and flags (:func:`state_dict`).
    """

    check_instance(tool, "tool", Tool, "a Tool (make_tool)", optional=True)
    tool = make_tool() if tool is None else tool
    if (lengths is None) == (pressures is None):
        raise InputError("tool fk: give exactly one of `lengths` or `pressures`")
    if lengths is not None:
        ls = _three(lengths, "length", "lengths", allow_zero=False)
        lo, hi = tool.muscle.length_stops
        if np.any(ls < lo) or np.any(ls > hi):
            raise InputError(f"lengths: {[float(f'{v * 1e3:.6g}') for v in ls]} mm leave the muscles' range "
                             f"{lo * 1e3:.4g}–{hi * 1e3:.4g} mm (the braid's locking angle to its straight strands); "
                             f"lengths are in metres")
        arc = arc_from_lengths(ls, tool.geometry.pitch_radius, tool.geometry.n_gaps)
        return pressures_for_tip(tip_position(arc), tool)  # the pressures holding them, as `inverse` finds them
    ps = _three(pressures, "pressure", "pressures")
    if np.any(ps > tool.p_max):
        raise InputError(f"pressures: {pressures!r} is above p_max ({tool.p_max / 1e6:g} MPa, `p_max`)")
    state = tip_from_pressures(ps, tool)
    if not bool(state.converged):
        raise InputError(f"pressures: the static equilibrium did not converge for {pressures!r}")
    return state


def inverse(tip, tool: Tool | None = None):
    """A tip position → arc → muscle lengths → tensions → pressures; an unreachable tip is an error.

    Parameters
    ----------
    tip : sequence of 3 float
        Target tip X, Y, Z (e.g. ``[0.02, 0.0, 0.11]``). [m]
    tool : Tool, optional
        Default :func:`make_tool`'s. [-]

    Returns
    -------
    ToolState
    """

    check_instance(tool, "tool", Tool, "a Tool (make_tool)", optional=True)
    tool = make_tool() if tool is None else tool
    p = _three(tip, "length", "tip", allow_negative=True)
    check_within_reach(p, tool, "tip", "a tip")
    state = pressures_for_tip(p, tool)
    require_reachable_tip(state, tool)
    return state


@dataclass(frozen=True, repr=False)
class WorkspaceResult(Result):
    """The tips the pressure box [0, p_max]³ reaches (:func:`map_workspace`).

    Attributes
    ----------
    samples : Workspace
        Pressures and poses on the grid. [-]
    tool : Tool
        The tool. [-]
    arguments : dict
        Grid points per muscle. [-]
    """

    samples: Workspace
    tool: Tool
    arguments: dict = field(default_factory=dict)
    call = "mckibben.tool.map_workspace"
    _repr_keys = ("lateral_reach_m", "tip_angle_max_rad", "z_min_m", "z_max_m")

    @property
    def metrics(self) -> dict:
        """Extent: lateral reach [m], tip angles [rad], heights [m], arc lengths [m], counts."""
        return self.samples.extent()

    def to_dict(self) -> dict:
        """What ``mckibben tool workspace --json`` prints."""
        return to_jsonable({**self.metrics, "grid": self.arguments["grid"], "tool": tool_dict(self.tool)})

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        p = self.samples.pressures.reshape(-1, 3)
        tip = self.samples.state.tip.reshape(-1, 3)
        return pd.DataFrame({"pressure_1_Pa": p[:, 0], "pressure_2_Pa": p[:, 1], "pressure_3_Pa": p[:, 2],
                             "tip_x_m": tip[:, 0], "tip_y_m": tip[:, 1], "tip_z_m": tip[:, 2],
                             "bend_angle_rad": np.ravel(self.samples.state.arc.theta)})

    def plot(self, ax=None):
        """The reachable tip surface (3-D), top and side views; return the Figure.

        Parameters
        ----------
        ax : matplotlib.figure.Figure, optional
            A figure to draw into; default a new one. [-]
        """

        return plot_workspace(self.samples, self.tool, fig=ax)


def map_workspace(tool: Tool | None = None, grid: int = 15) -> WorkspaceResult:
    """Sample the pressure box [0, p_max]³ through the forward static equilibrium.

    Parameters
    ----------
    tool : Tool, optional
        Default :func:`make_tool`'s. [-]
    grid : int, default 15
        Pressure grid points per muscle, 2..101. [-]

    Returns
    -------
    WorkspaceResult
    """

    check_instance(tool, "tool", Tool, "a Tool (make_tool)", optional=True)
    tool = make_tool() if tool is None else tool
    if isinstance(grid, bool) or not isinstance(grid, (int, np.integer)) or not 2 <= grid <= 101:
        raise InputError(f"grid: {grid!r} must be a whole number of points per muscle in 2..101")
    return WorkspaceResult(sample_workspace(tool, grid), tool, {"grid": grid})
