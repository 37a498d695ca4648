"""The three-muscle endoscope of [mpam-characterization] §V: geometry, constant-curvature
kinematics, the pressures that put the tip at a target, the workspace, and the building blocks of
tracking (:mod:`~mckibben.tool.tracking`).

See docs/tool.md. From Python: :func:`make_tool`, :func:`forward`, :func:`inverse`,
:func:`map_workspace`, and tip paths (:class:`TipPath`, :func:`parse_path` of its one-line text).
Following a path with three simulated muscles is an experiment, in the layer above:
:func:`mckibben.experiments.track_tip`.
"""

from mckibben import _lazy
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "Arc": "mckibben.tool.kinematics",
    "MUSCLE_ANGLES": "mckibben.tool.geometry",
    "StackLoad": "mckibben.tool.geometry",
    "TipPath": "mckibben.tool.paths",
    "Tool": "mckibben.tool.geometry",
    "ToolGeometry": "mckibben.tool.geometry",
    "WorkspaceResult": "mckibben.tool.api",
    "arc_from_lengths": "mckibben.tool.kinematics",
    "arc_from_tip": "mckibben.tool.kinematics",
    "forward": "mckibben.tool.api",
    "inverse": "mckibben.tool.api",
    "lengths_from_arc": "mckibben.tool.kinematics",
    "lengths_from_tip": "mckibben.tool.kinematics",
    "make_tool": "mckibben.tool.api",
    "map_workspace": "mckibben.tool.api",
    "parse_path": "mckibben.tool.paths",
    "state_dict": "mckibben.tool.api",
    "tip_from_lengths": "mckibben.tool.kinematics",
    "tip_position": "mckibben.tool.kinematics",
    "tip_rotation": "mckibben.tool.kinematics",
    "tool_dict": "mckibben.tool.api",
}

__all__ = [
    "MUSCLE_ANGLES", "Arc", "StackLoad", "TipPath", "Tool", "ToolGeometry", "arc_from_lengths", "arc_from_tip",
    "lengths_from_arc", "lengths_from_tip", "tip_from_lengths", "tip_position", "tip_rotation",
    "WorkspaceResult", "forward", "inverse", "make_tool", "map_workspace", "state_dict",
    "tool_dict", "parse_path",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.tool.kinematics import Arc as Arc
    from mckibben.tool.geometry import MUSCLE_ANGLES as MUSCLE_ANGLES
    from mckibben.tool.geometry import StackLoad as StackLoad
    from mckibben.tool.paths import TipPath as TipPath
    from mckibben.tool.paths import parse_path as parse_path
    from mckibben.tool.geometry import Tool as Tool
    from mckibben.tool.geometry import ToolGeometry as ToolGeometry
    from mckibben.tool.api import WorkspaceResult as WorkspaceResult
    from mckibben.tool.kinematics import arc_from_lengths as arc_from_lengths
    from mckibben.tool.kinematics import arc_from_tip as arc_from_tip
    from mckibben.tool.api import forward as forward
    from mckibben.tool.api import inverse as inverse
    from mckibben.tool.kinematics import lengths_from_arc as lengths_from_arc
    from mckibben.tool.kinematics import lengths_from_tip as lengths_from_tip
    from mckibben.tool.api import make_tool as make_tool
    from mckibben.tool.api import map_workspace as map_workspace
    from mckibben.tool.api import state_dict as state_dict
    from mckibben.tool.kinematics import tip_from_lengths as tip_from_lengths
    from mckibben.tool.kinematics import tip_position as tip_position
    from mckibben.tool.kinematics import tip_rotation as tip_rotation
    from mckibben.tool.api import tool_dict as tool_dict


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
