"""The three-muscle endoscope of 000_909f662a44080c85.txt §V: geometry, constant-curvature
kinematics, the pressures that put the tip at a target, the workspace and tracking in simulation.

See docs/tool.md.
"""

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
]
