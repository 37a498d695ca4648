"""The rig: the serial protocol, the recorder, the device emulator and live control.
See ``docs/protocol.md`` and ``docs/rig.md``.

``Device(port).step(target)`` runs a pressure step on the device (or ``Emulator``'s pty) and
returns a :class:`RigStepResult`; ``Recorder`` and ``recover`` log telemetry to Parquet.
"""

from mckibben import _lazy
from typing import TYPE_CHECKING

#: Where each public name lives. The submodules are imported on first use (PEP 562): importing the
#: package is cheap (``mckibben --version``/``--help`` import every command module), and a
#: submodule loads its heavy packages (Numba, SciPy, pandas...) only when a name of it is used.
_WHERE = {
    "BAUD": "mckibben.rig.device",
    "Bench": "mckibben.rig.bench",
    "CharacterizeResult": "mckibben.rig.characterize",
    "read_protocol": "mckibben.rig.characterize",
    "run_characterization": "mckibben.rig.characterize",
    "Device": "mckibben.rig.device",
    "Emulator": "mckibben.rig.emulator",
    "Recorder": "mckibben.rig.recorder",
    "RigStepResult": "mckibben.rig.device",
    "open_port": "mckibben.rig.device",
    "read_recording": "mckibben.rig.recorder",
    "recover": "mckibben.rig.recorder",
}

__all__ = ["BAUD", "Bench", "CharacterizeResult", "Device", "Emulator", "Recorder", "RigStepResult", "open_port",
           "read_protocol", "read_recording", "recover", "run_characterization"]

if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only (explicit re-exports)
    from mckibben.rig.device import BAUD as BAUD
    from mckibben.rig.bench import Bench as Bench
    from mckibben.rig.characterize import CharacterizeResult as CharacterizeResult
    from mckibben.rig.characterize import read_protocol as read_protocol
    from mckibben.rig.characterize import run_characterization as run_characterization
    from mckibben.rig.device import Device as Device
    from mckibben.rig.emulator import Emulator as Emulator
    from mckibben.rig.recorder import Recorder as Recorder
    from mckibben.rig.device import RigStepResult as RigStepResult
    from mckibben.rig.device import open_port as open_port
    from mckibben.rig.recorder import read_recording as read_recording
    from mckibben.rig.recorder import recover as recover


__getattr__, __dir__ = _lazy.package(__name__, _WHERE)
