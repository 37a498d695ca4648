"""Device engines: what answers at the other end of the serial link when there is no Mega.

Both engines look the same to a host: a pseudo-terminal to open as ``/dev/ttyACM0``, a reset
when a process opens it after nobody had it open, the bootloader's delay, a HELLO frame, then
the protocol of ``docs/protocol.md`` at 1 kHz.

- ``python`` (:class:`mckibben.rig.Emulator`): the controller core's Python mirror on
  :class:`mckibben.plant.PlantStepper` plants, in a thread of this process.
- ``avr`` (:class:`mckibben.rig.engines.avr.AvrDevice`): the firmware image ``make -C firmware``
  builds, run by simavr in the processor-in-the-loop harness (``firmware/pil``) against the C
  plant (``export/c/mk_plant.c``), in a child process.

:func:`start_device` starts either one; the object it returns has ``port``, ``resets``,
``host_present``, ``run(duration)``, ``stop()`` and is a context manager.
"""

from __future__ import annotations

from mckibben import hardware as HW
from mckibben.errors import InputError
from mckibben.plant import params as PP
from mckibben.rig.emulator import Emulator
from mckibben.rig.engines.avr import AvrDevice

#: The engines by name.
ENGINES = ("python", "avr")


def with_supply(plants, n_channels: int, supply: float | None):
    """The channels' plants (one each), with ``supply`` as every one's supply pressure when given.

    Parameters
    ----------
    plants : PlantParams or sequence of PlantParams or None
        As :class:`~mckibben.rig.Emulator` takes them; None: the calibrated rig. [-]
    n_channels : int
        Channels, 1..3. [-]
    supply : float, optional
        Supply pressure (gauge), above 0 and at most :data:`mckibben.hardware.P_MAX_LIMIT`. [Pa]
    """
    listed = list(plants) if isinstance(plants, (list, tuple)) else [plants] * n_channels
    listed = [PP.PlantParams() if p is None else p for p in listed]
    if supply is None:
        return listed
    s = float(supply)
    if not 0 < s <= HW.P_MAX_LIMIT:
        raise InputError(f"supply: {supply!r} must be above 0 and at most {HW.P_MAX_LIMIT / 1e6:g} MPa (gauge)")
    return [p.replace(supply_pressure=s) for p in listed]


def start_device(engine: str = "python", *, plant=None, n_channels: int = 3, boot_time: float = 0.3,
                 supply: float | None = None, unthrottled: bool = False, hold_adc: int | None = None,
                 load_cell: HW.LoadCell | None = None):
    """A device engine behind a pseudo-terminal, not yet running (``run()`` or ``start()`` it).

    Parameters
    ----------
    engine : {"python", "avr"}, default "python"
        The Python emulator or the firmware image in simavr. [-]
    plant : PlantParams or sequence of PlantParams, optional
        The rig of every channel, or one per channel; default the calibrated one. [-]
    n_channels : int, default 3
        Channels of the device, 1..3 (the avr engine builds the image with ``MCK_N_CHANNELS``). [-]
    boot_time : float, default 0.3
        Bootloader time after each reset (a Mega: 1-2 s). [s]
    supply : float, optional
        Supply pressure of every channel (gauge); default the plants' own (0.8 MPa). A supply above
        the safe maximum is how a bench proves the supervisor. [Pa]
    unthrottled : bool, default False
        avr engine only: run as fast as the host allows instead of following wall time. [-]
    hold_adc : int, optional
        Channel 0's ADC reads this count whatever the pressure (a stuck sensor), 0..1023. [count]
    load_cell : LoadCell, optional
        A load cell on channel 0's muscle (full scale, offset, noise), modelled alike by both
        engines (:class:`mckibben.hardware.LoadCell`); None: none fitted. [-]

    Raises
    ------
    InputError
        An unknown engine, a bad channel count or supply; for ``avr``, a missing tool (named with
        the Debian package that installs it).
    """
    if engine not in ENGINES:
        raise InputError(f"engine: {engine!r} must be one of {', '.join(ENGINES)}")
    if not 1 <= int(n_channels) <= 3:
        raise InputError(f"n_channels: {n_channels!r} must be 1, 2 or 3")
    plants = with_supply(plant, int(n_channels), supply)
    if hold_adc is not None and not 0 <= int(hold_adc) <= HW.ADC_MAX:
        raise InputError(f"hold_adc: {hold_adc!r} must be a count in 0..{HW.ADC_MAX}")
    if engine == "python":
        if unthrottled:
            raise InputError("unthrottled: the python engine follows wall time only")
        return Emulator(plant=plants, n_channels=n_channels, boot_time=boot_time, hold_adc=hold_adc,
                        load_cell=load_cell)
    return AvrDevice(plants, n_channels=int(n_channels), boot_time=boot_time, unthrottled=unthrottled,
                     hold_adc=hold_adc, load_cell=load_cell)
