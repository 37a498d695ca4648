"""The controller registry: every table of the controllers, built from their files.

The entries are the files of :mod:`mckibben.control.laws` (one per controller, each exporting a
:class:`ControllerSpec` of real function objects, discovered); their modes and gain ids are the
one table's (:mod:`mckibben.control.laws._table`). This module adds the supervisor's own
settings (:data:`SUPERVISOR_GAINS`) and derives what the core, the experiments, the rig, the
sweeps, the plots and the command line read: every gain in id order (:data:`ALL_GAINS`), the valid
modes, the extension laws' slots in the core's arrays (:data:`LAYOUT`) and the dispatch of the
core's step to them (:func:`extension_law`). None of them keeps its own list of controllers or
defaults.

The firmware holds the same facts in ``firmware/core/controller.h`` (the core's laws and the gain
table, checked against the table) and ``firmware/core/laws.h`` (the extension laws, generated
from the table); ``tests/test_controller_conformance.py`` runs every registered controller
through the same checks (C against Python step by step, design, experiments, cycles on the AVR).

References
----------
[mpam-characterization], §IV (the sliding mode and the PID).
"""

from __future__ import annotations

from mckibben._kernels import kernel, register
from mckibben import hardware as HW
from mckibben.control import laws
from mckibben.control.laws import CONTROLLERS, ControllerSpec, GainSpec
from mckibben.control.layout import CORE_N_ISTATE, IP_GAIN0
from mckibben.errors import unknown_name

__all__ = ["ALL_GAINS", "CONTROLLERS", "ControllerSpec", "EXTENSIONS", "GainSpec", "LAYOUT", "MODE_IDS", "MODE_OFF",
           "MODE_OPEN_LOOP", "NAMES", "N_GAINS", "N_IPARAMS", "N_ISTATE", "PID", "SMC", "SUPERVISOR_GAINS",
           "default_of", "extension_law", "get"]

#: The core's modes that run no law (``MCK_MODE_OFF``, ``MCK_MODE_OPEN_LOOP``), the table's.
MODE_OFF = laws.MODES["off"]
MODE_OPEN_LOOP = laws.MODES["open_loop"]


# --- the supervisor's gains ---------------------------------------------------------------------

_G = GainSpec
#: The supervisor's and the ADC's settings (every mode; docs/firmware.md, "Gains").
SUPERVISOR_GAINS: tuple[GainSpec, ...] = (
    _G("adc_zero", "adc_zero", "count", 1.0, 0, 1023, 0, "MCK_GAIN_ADC_ZERO", "ADC count at zero gauge pressure"),
    _G("pa_per_count", "pa_per_count", "Pa/count", 1e3, 1, 2_047_999, HW.PA_PER_COUNT, "MCK_GAIN_PA_PER_COUNT",
       "pressure per ADC count"),
    _G("margin", "margin", "Pa", 1.0, 0, 200_000, 20e3, "MCK_GAIN_MARGIN", "overpressure margin above p_max"),
    _G("adc_min", "adc_min", "count", 1.0, 0, 1023, 0, "MCK_GAIN_ADC_MIN", "lowest valid reading"),
    _G("adc_max", "adc_max", "count", 1.0, 0, 1023, 1022, "MCK_GAIN_ADC_MAX", "highest valid reading"),
    _G("n_stuck", "n_stuck", "samples", 1.0, 0, 65_535, 250, "MCK_GAIN_N_STUCK",
       "unchanged readings under a predicted change that latch a vent (0: off)"),
    _G("n_missing", "n_missing", "samples", 1.0, 0, 65_535, 10, "MCK_GAIN_N_MISSING",
       "missing samples that latch a vent (0: off)"),
    _G("sup_g", "sup_g", "Pa/count", 1e3, 0, 100_000_000, 3000.0, "MCK_GAIN_SUP_G",
       "G_s of the supervisor's valve model (0: response rule off)"),
    _G("sup_u0", "sup_u0", "PWM counts", 1e3, 0, 255_000, 112.0, "MCK_GAIN_SUP_U0", "u0_s, its lift-off"),
)

if tuple(g.name for g in SUPERVISOR_GAINS) != tuple(laws.TABLE["supervisor"][1]):
    raise ImportError("mckibben.control.registry: SUPERVISOR_GAINS differ from the table's supervisor row")

#: The core's own two laws (``controller.c``): every build has them, and the command line's and
#: the tool's defaults read their designs.
SMC, PID = CONTROLLERS["smc"], CONTROLLERS["pid"]

# --- derived tables -----------------------------------------------------------------------------

#: Every SET_GAIN entry in id order: the controllers' and the supervisor's (a controller's own are its
#: ``GAINS``, :attr:`ControllerSpec.gains`).
ALL_GAINS: tuple[GainSpec, ...] = tuple(sorted(SUPERVISOR_GAINS + tuple(g for c in CONTROLLERS.values() for g in c.gains),
                                           key=lambda g: g.id))
N_GAINS = len(ALL_GAINS)
#: Valid SET_MODE ids (the ids of the table's :data:`~mckibben.control.laws.MODES`, by name).
MODE_IDS: tuple[int, ...] = tuple(sorted((MODE_OFF, MODE_OPEN_LOOP, *(c.mode for c in CONTROLLERS.values()))))
#: Controller names (``--controller``).
NAMES: tuple[str, ...] = tuple(CONTROLLERS)
#: The extension laws (beyond the core's sliding mode and PID), in mode order.
EXTENSIONS: tuple[ControllerSpec, ...] = tuple(c for c in CONTROLLERS.values() if c.extension)


def _layout() -> dict[str, tuple[int, int]]:
    """Each extension law's first istate and iparams slot (after the core's state and gains)."""
    out, so, io = {}, CORE_N_ISTATE, IP_GAIN0 + N_GAINS
    for c in EXTENSIONS:
        out[c.name] = (so, io)
        so += c.state
        io += len(c.coefs)
    return out


#: name -> (first istate slot, first iparams slot) of each extension law.
LAYOUT = _layout()
#: Lengths of the core's arrays with every law's slots.
N_ISTATE = CORE_N_ISTATE + sum(c.state for c in EXTENSIONS)
N_IPARAMS = IP_GAIN0 + N_GAINS + sum(len(c.coefs) for c in EXTENSIONS)


#: Extension laws the core's step can dispatch to (:func:`extension_law`), as the plant keeps
#: slots for force laws: a law added to the table takes the next slot, nothing else changes.
EXTENSION_SLOTS = 4
if len(EXTENSIONS) > EXTENSION_SLOTS:
    raise ImportError(f"mckibben.control.registry: {len(EXTENSIONS)} extension laws, {EXTENSION_SLOTS} slots in "
                      "extension_law: add a slot")


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def _no_law(st, ip, so, io, p, pref, e):
    """An empty slot: no command, the error as surface."""
    return 0, e


def _slot(i: int):
    """(mode, law, first istate slot, first iparams slot) of extension slot i (-1 and no law if empty)."""
    if i < len(EXTENSIONS):
        c = EXTENSIONS[i]
        return (c.mode, c.law, *LAYOUT[c.name])
    return -1, _no_law, 0, 0


(_M0, _L0, _S0, _I0), (_M1, _L1, _S1, _I1), (_M2, _L2, _S2, _I2), (_M3, _L3, _S3, _I3) = (
    _slot(i) for i in range(EXTENSION_SLOTS))


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def extension_law(mode, st, ip, p, pref, e):
    """The law of an extension mode: the registered extension laws in their slots, in mode order.

    Parameters
    ----------
    mode : int
        The mode (> 3). [-]
    st, ip : numpy.ndarray of int64
        istate and iparams of one instance. [-]
    p, pref, e : int
        Measured pressure, clamped reference, error. [Pa]

    Returns
    -------
    tuple of int
        The command in PWM counts Q8 and the surface reported in telemetry. [-], [Pa]
    """
    if mode == _M0:
        return _L0(st, ip, _S0, _I0, p, pref, e)
    if mode == _M1:
        return _L1(st, ip, _S1, _I1, p, pref, e)
    if mode == _M2:
        return _L2(st, ip, _S2, _I2, p, pref, e)
    if mode == _M3:
        return _L3(st, ip, _S3, _I3, p, pref, e)
    return 0, e


def get(name: str) -> ControllerSpec:
    """The entry of a controller by name.

    Parameters
    ----------
    name : str
        A name of :data:`NAMES`. [-]

    Raises
    ------
    KeyError
        An unknown name, with the known ones and the closest match.
    """
    if name not in CONTROLLERS:
        raise unknown_name("controller", name, NAMES)
    return CONTROLLERS[name]


def default_of(param: str) -> float | int:
    """The default physical value of a gain by its :class:`CoreParams` field name. [unit]"""
    return _DEFAULTS[param]


_DEFAULTS = {g.param: g.default for g in ALL_GAINS}


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
