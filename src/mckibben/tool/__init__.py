"""The three-muscle endoscope of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt) §V: geometry, constant-curvature
kinematics, the pressures that put the tip at a target, the workspace and tracking in simulation.

See docs/tool.md. From Python: :func:`make_tool`, :func:`forward`, :func:`inverse`,
:func:`map_workspace` and :func:`track` (a tip path, :class:`TipPath` or :func:`parse_path` of
its one-line text, followed by three simulated muscles, a
:class:`ToolTrackResult` with ``.metrics``, ``.to_pandas()``, ``.plot()``).
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
    "ToolTrackResult": "mckibben.tool.experiments",
    "WorkspaceResult": "mckibben.tool.experiments",
    "arc_from_lengths": "mckibben.tool.kinematics",
    "arc_from_tip": "mckibben.tool.kinematics",
    "forward": "mckibben.tool.experiments",
    "inverse": "mckibben.tool.experiments",
    "lengths_from_arc": "mckibben.tool.kinematics",
    "lengths_from_tip": "mckibben.tool.kinematics",
    "make_tool": "mckibben.tool.experiments",
    "map_workspace": "mckibben.tool.experiments",
    "parse_path": "mckibben.tool.paths",
    "state_dict": "mckibben.tool.experiments",
    "tip_from_lengths": "mckibben.tool.kinematics",
    "tip_position": "mckibben.tool.kinematics",
    "tip_rotation": "mckibben.tool.kinematics",
    "tool_dict": "mckibben.tool.experiments",
    "track": "mckibben.tool.experiments",
}

__all__ = [
    "MUSCLE_ANGLES", "Arc", "StackLoad", "TipPath", "Tool", "ToolGeometry", "arc_from_lengths", "arc_from_tip",
    "lengths_from_arc", "lengths_from_tip", "tip_from_lengths", "tip_position", "tip_rotation",
    "ToolTrackResult", "WorkspaceResult", "forward", "inverse", "make_tool", "map_workspace", "state_dict",
    "tool_dict", "track", "parse_path",
]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.tool.kinematics import Arc as Arc
    from mckibben.tool.geometry import MUSCLE_ANGLES as MUSCLE_ANGLES
    from mckibben.tool.geometry import StackLoad as StackLoad
    from mckibben.tool.paths import TipPath as TipPath
    from mckibben.tool.paths import parse_path as parse_path
    from mckibben.tool.geometry import Tool as Tool
    from mckibben.tool.geometry import ToolGeometry as ToolGeometry
    from mckibben.tool.experiments import ToolTrackResult as ToolTrackResult
    from mckibben.tool.experiments import WorkspaceResult as WorkspaceResult
    from mckibben.tool.kinematics import arc_from_lengths as arc_from_lengths
    from mckibben.tool.kinematics import arc_from_tip as arc_from_tip
    from mckibben.tool.experiments import forward as forward
    from mckibben.tool.experiments import inverse as inverse
    from mckibben.tool.kinematics import lengths_from_arc as lengths_from_arc
    from mckibben.tool.kinematics import lengths_from_tip as lengths_from_tip
    from mckibben.tool.experiments import make_tool as make_tool
    from mckibben.tool.experiments import map_workspace as map_workspace
    from mckibben.tool.experiments import state_dict as state_dict
    from mckibben.tool.kinematics import tip_from_lengths as tip_from_lengths
    from mckibben.tool.kinematics import tip_position as tip_position
    from mckibben.tool.kinematics import tip_rotation as tip_rotation
    from mckibben.tool.experiments import tool_dict as tool_dict
    from mckibben.tool.experiments import track as track


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
