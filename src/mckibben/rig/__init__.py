"""The rig: the serial protocol, the recorder, the device emulator and live control.
See ``docs/protocol.md`` and ``docs/rig.md``.

``Device(port).step(target)`` runs a pressure step on the device (or ``Emulator``'s pty) and
returns a :class:`RigStepResult`; ``Recorder`` and ``recover`` log telemetry to Parquet.
"""

from mckibben.rig.device import BAUD, Device, RigStepResult, open_port
from mckibben.rig.emulator import Emulator
from mckibben.rig.recorder import Recorder, read_recording, recover

__all__ = ["BAUD", "Device", "Emulator", "Recorder", "RigStepResult", "open_port", "read_recording", "recover"]
