"""The three-muscle endoscope of “Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (text: 000_909f662a44080c85.txt) §V: geometry, constant-curvature
kinematics, the pressures that put the tip at a target, the workspace and tracking in simulation.

See docs/tool.md. From Python: :func:`make_tool`, :func:`forward`, :func:`inverse`,
:func:`map_workspace` and :func:`track` (a tip path followed by three simulated muscles, a
:class:`ToolTrackResult` with ``.metrics``, ``.to_pandas()``, ``.plot()``).
"""

from mckibben.tool.experiments import (
    ToolTrackResult,
    WorkspaceResult,
    forward,
    inverse,
    make_tool,
    map_workspace,
    state_dict,
    tool_dict,
    track,
)
from mckibben.tool.geometry import MUSCLE_ANGLES, StackLoad, Tool, ToolGeometry
from mckibben.tool.kinematics import (
    Arc,
    arc_from_lengths,
    arc_from_tip,
    lengths_from_arc,
    lengths_from_tip,
    tip_from_lengths,
    tip_position,
    tip_rotation,
)

__all__ = [
    "MUSCLE_ANGLES", "Arc", "StackLoad", "Tool", "ToolGeometry", "arc_from_lengths", "arc_from_tip",
    "lengths_from_arc", "lengths_from_tip", "tip_from_lengths", "tip_position", "tip_rotation",
    "ToolTrackResult", "WorkspaceResult", "forward", "inverse", "make_tool", "map_workspace", "state_dict",
    "tool_dict", "track",
]
