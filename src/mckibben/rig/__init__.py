"""The rig: the serial protocol, the recorder, the device emulator and live control.
See ``docs/protocol.md`` and ``docs/rig.md``."""
