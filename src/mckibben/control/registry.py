"""The controller registry: every pressure controller of the core, one entry each.

An entry (:class:`ControllerSpec`) holds everything the library knows about one controller: its
name, its firmware mode id (SET_MODE), its gains (:class:`GainSpec`: SET_GAIN id, unit,
fixed-point scale, range and **the** default), the Python law that mirrors the C law bit for
bit, its design function, its documented designs and the candidate grid its tuning searches.
The core (:mod:`mckibben.control.core`), the experiments, the rig, the sweeps, the plots and the
command line read this module; none keeps its own list of controllers or defaults. The supervisor's
own settings (ADC scaling, sensor checks) are :data:`SUPERVISOR_GAINS`.

The firmware holds the same facts in ``firmware/core/controller.h`` (the core's laws and the gain
table) and ``firmware/core/laws.h`` (the extension laws, one header each);
``tests/test_control_registry.py`` holds this module against them, and runs every registered law
through the same checks (C against Python step by step, the float reference, the plant).

Adding a controller (``docs/controller.md``, "Adding a controller"): a module with its law
(a module-level kernel, ``mckibben._kernels.kernel``: ``law(st, ip, so, io, p, pref, e) -> (u_q8, surface)``), its
coefficients (``derive``), its float reference and its design; a header
``firmware/core/law_<name>.h``; and one entry here (:data:`CONTROLLERS` and its line in
:func:`extension_law`), plus one line in ``firmware/core/laws.h``.

References
----------
[mpam-characterization], §IV (the sliding mode and the PID).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field


from mckibben._kernels import kernel, register
from mckibben import hardware as HW
from mckibben.control import stsmc
from mckibben.errors import unknown_name

#: The core's modes that run no law (``MCK_MODE_OFF``, ``MCK_MODE_OPEN_LOOP``).
MODE_OFF = 0
MODE_OPEN_LOOP = 3
#: Sizes of the core's own state and parameter layouts (:mod:`mckibben.control.core`): the
#: extension laws' slots follow them.
CORE_N_ISTATE = 18
CORE_IP_GAIN0 = 26


@dataclass(frozen=True)
class GainSpec:
    """One SET_GAIN entry: the value sent is ``round(physical · scale)`` in ``[lo, hi]``.

    Parameters
    ----------
    id : int
        SET_GAIN id (``MCK_GAIN_*`` in ``firmware/core/controller.h`` or the law's header). [-]
    name : str
        Gain name of the protocol and the design files (``smc_beta``). [-]
    param : str
        The :class:`~mckibben.control.core.CoreParams` field that carries it (``beta``). [-]
    unit : str
        Unit of the physical value. [-]
    scale : float
        Fixed-point scale of the value sent. [-]
    lo, hi : int
        Accepted range of the value sent. [-]
    default : float or int
        The default physical value, in ``unit``: the one place it is written. [unit]
    c_name : str
        The C enumerator (``MCK_GAIN_SMC_BETA``). [-]
    doc : str
        One line for the docs. [-]
    """

    id: int
    name: str
    param: str
    unit: str
    scale: float
    lo: int
    hi: int
    default: float | int
    c_name: str
    doc: str = ""

    @property
    def default_value(self) -> int:
        """The default in the SET_GAIN scale, ``round(default · scale)``. [-]"""
        return int(round(self.default * self.scale))


@dataclass(frozen=True)
class ControllerSpec:
    """One controller of the core.

    Parameters
    ----------
    name : str
        Name used everywhere (``--controller``, sweeps, the rig). [-]
    mode : int
        SET_MODE id (``MCK_MODE_<c_name>``). [-]
    c_name : str
        Its name in the C core's macros. [-]
    label : str
        Label of figures. [-]
    summary : str
        One line: what the law is. [-]
    gains : tuple of GainSpec
        The gains it owns (the supervisor's are :data:`SUPERVISOR_GAINS`). [-]
    law : str
        ``module:qualname`` of the Python law, the bit-exact mirror of the C law. [-]
    design : str
        ``module:qualname`` of ``design(model, base, **gains) -> CoreParams``: the controller
        with its documented design on an identified model. [-]
    candidates : str
        ``module:qualname`` of ``candidates(model, base, top, law, given) -> (gains, params)``:
        the candidates :func:`~mckibben.control.runs.tune_gains` simulates. [-]
    designs : mapping
        The documented designs, by name: design parameter -> value (SI or PWM counts). [-]
    grid : mapping
        The candidate grids of the tuning, by design name: parameter -> values. [-]
    laws : tuple of str
        Variants of the law selected by ``law=`` (the sliding mode's ``model`` and ``paper``);
        empty when there is one. [-]
    describe : str
        ``module:qualname`` of ``describe(params) -> dict``: the gains as reported in results. [-]
    state : int
        Integer state slots of an extension law (after the core's). [-]
    coefs : tuple of str
        Coefficients of an extension law, in the order of its parameter slots. [-]
    derive : str
        ``module:qualname`` of ``derive(gains, ts_us) -> {coef: array}`` of an extension law. [-]
    float_law : str
        ``module:qualname`` of the float64 reference of an extension law. [-]
    references : str
        Where the law comes from. [-]
    """

    name: str
    mode: int
    c_name: str
    label: str
    summary: str
    gains: tuple[GainSpec, ...]
    law: str
    design: str
    candidates: str
    designs: Mapping[str, Mapping[str, float]]
    grid: Mapping[str, Mapping[str, tuple]]
    laws: tuple[str, ...] = ()
    describe: str = ""
    state: int = 0
    coefs: tuple[str, ...] = ()
    derive: str = ""
    float_law: str = ""
    references: str = ""
    extension: bool = field(default=True)

    def resolve(self, what: str) -> Callable:
        """The function an entry names (``law``, ``design``, ``candidates``, ...).

        Parameters
        ----------
        what : str
            The field holding a ``module:qualname``. [-]
        """
        module, _, qualname = getattr(self, what).partition(":")
        obj = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
        return obj

    def default(self, design: str | None = None) -> Mapping[str, float]:
        """A documented design (default: the first). [-]"""
        return self.designs[design or next(iter(self.designs))]


# --- the core's gains ---------------------------------------------------------------------------

_G = GainSpec
#: The supervisor's and the ADC's settings (every mode; docs/firmware.md, "Gains").
SUPERVISOR_GAINS: tuple[GainSpec, ...] = (
    _G(10, "adc_zero", "adc_zero", "count", 1.0, 0, 1023, 0, "MCK_GAIN_ADC_ZERO", "ADC count at zero gauge pressure"),
    _G(11, "pa_per_count", "pa_per_count", "Pa/count", 1e3, 1, 2_047_999, HW.PA_PER_COUNT, "MCK_GAIN_PA_PER_COUNT",
       "pressure per ADC count"),
    _G(12, "margin", "margin", "Pa", 1.0, 0, 200_000, 20e3, "MCK_GAIN_MARGIN", "overpressure margin above p_max"),
    _G(13, "adc_min", "adc_min", "count", 1.0, 0, 1023, 0, "MCK_GAIN_ADC_MIN", "lowest valid reading"),
    _G(14, "adc_max", "adc_max", "count", 1.0, 0, 1023, 1022, "MCK_GAIN_ADC_MAX", "highest valid reading"),
    _G(15, "n_stuck", "n_stuck", "samples", 1.0, 0, 65_535, 250, "MCK_GAIN_N_STUCK",
       "unchanged readings under a predicted change that latch a vent (0: off)"),
    _G(16, "n_missing", "n_missing", "samples", 1.0, 0, 65_535, 10, "MCK_GAIN_N_MISSING",
       "missing samples that latch a vent (0: off)"),
    _G(18, "sup_g", "sup_g", "Pa/count", 1e3, 0, 100_000_000, 3000.0, "MCK_GAIN_SUP_G",
       "G_s of the supervisor's valve model (0: response rule off)"),
    _G(19, "sup_u0", "sup_u0", "PWM counts", 1e3, 0, 255_000, 112.0, "MCK_GAIN_SUP_U0", "u0_s, its lift-off"),
)

_SMC = "mckibben.control.runs"
SMC = ControllerSpec(
    name="smc", mode=1, c_name="SMC", label="SMC\n(ours)",
    summary="sliding mode, eq. (5)-(12) with the signs corrected; law 'model' (model term) or 'paper'",
    gains=(
        _G(0, "smc_beta", "beta", "PWM counts", 1e3, 0, 255_000, 120.0, "MCK_GAIN_SMC_BETA",
           "switching gain (the firmware's start-up value; the paper's 120)"),
        _G(1, "smc_eps", "eps", "Pa", 1.0, 1, 1_000_000, 20e3, "MCK_GAIN_SMC_EPS", "boundary layer of tanh(S/ε)"),
        _G(2, "smc_ki", "ki", "1/s", 1e3, 0, 1_000_000, 10.0, "MCK_GAIN_SMC_KI", "integral weight of S = e + Ki·I"),
        _G(3, "smc_tau", "tau", "s", 1e6, 0, 10_000_000, 0.09, "MCK_GAIN_SMC_TAU", "τ of the model term"),
        _G(4, "smc_g", "g", "Pa/count", 1e3, 0, 100_000_000, 3000.0, "MCK_GAIN_SMC_G",
           "G of the model term (0: no model term, the paper's law)"),
        _G(5, "smc_i_max", "i_max", "Pa s", 1e3, 0, 2_147_483_647, 1e4, "MCK_GAIN_SMC_IMAX", "clamp of the integral"),
        _G(17, "smc_u0", "u0", "PWM counts", 1e3, 0, 255_000, 0.0, "MCK_GAIN_SMC_U0", "valve lift-off of the model term"),
    ),
    law="mckibben.control.core:smc_law_q8",
    design=f"{_SMC}:smc_design",
    candidates=f"{_SMC}:smc_candidates",
    describe="mckibben.control.simulation:smc_gains_dict",
    laws=("model", "paper"),
    # Two designs on purpose: ours (law ``model``: with the model term carrying the holding
    # command a small β suffices; docs/control.md says how it was chosen) and the paper's law
    # (β·tanh(S/ε) alone, β = 150 the paper's faster setting; ε and Ki ours, chosen so that the
    # integral brings the β = 120 step to its target within Fig. 13's second).
    designs={"model": {"beta": 50.0, "eps": 100e3, "ki": 5.0, "i_max": 4e4},
             "paper": {"beta": 150.0, "eps": 50e3, "ki": 12.0, "i_max": 1e4}},
    grid={"model": {"beta": (10.0, 20.0, 50.0), "eps": (50e3, 100e3, 200e3, 400e3), "ki": (1.0, 2.5, 5.0),
                    "tau_factor": (1.0, 1 / 4, 1 / 16, 1 / 64, 1 / 256)},
          "paper": {"beta": (115.0, 120.0, 130.0, 150.0, 175.0, 200.0), "eps": (25e3, 50e3, 100e3, 200e3),
                    "ki": (4.0, 12.0, 24.0)}},
    references="[mpam-characterization] §IV eq. (5)-(12); docs/controller.md",
    extension=False,
)

PID = ControllerSpec(
    name="pid", mode=2, c_name="PID", label="PID",
    summary="PID with filtered derivative and conditional integration, lambda-tuned on the first-order model",
    gains=(
        _G(6, "pid_kp", "kp", "counts/Pa", 1e9, 0, 1_000_000_000, 1e-3, "MCK_GAIN_PID_KP", "proportional gain"),
        _G(7, "pid_ki", "ki_pid", "counts/(Pa s)", 1e9, 0, 2_147_483_647, 0.011, "MCK_GAIN_PID_KI", "integral gain"),
        _G(8, "pid_kd", "kd", "counts s/Pa", 1e12, 0, 2_147_483_647, 0.0, "MCK_GAIN_PID_KD", "derivative gain"),
        _G(9, "pid_tf", "tf", "s", 1e6, 0, 10_000_000, 0.005, "MCK_GAIN_PID_TF", "derivative filter time constant"),
    ),
    law="mckibben.control.core:_pid_law_q8",
    design=f"{_SMC}:pid_design",
    candidates=f"{_SMC}:pid_candidates",
    describe="mckibben.control.simulation:pid_gains_dict",
    # λ = τ/3 of the identified τ: three times faster than open loop, a usual aggressive choice
    designs={"pid": {"tau_over_lambda": 3.0}},
    grid={"pid": {"tau_factor": (1.0, 1 / 4, 1 / 16, 1 / 64), "lam_factor": (1 / 4, 1 / 2, 1.0, 2.0, 4.0)}},
    references="[mpam-characterization] §IV.A; docs/controller.md",
    extension=False,
)

STSMC = ControllerSpec(
    name="stsmc", mode=stsmc.MODE, c_name="STSMC", label="super-\ntwisting",
    summary="super-twisting (second-order) sliding mode on the model's static inverse",
    gains=(
        _G(20, "stsmc_k1", "st_k1", "PWM counts", 1e3, 0, 255_000, 10.0, "MCK_GAIN_STSMC_K1", "gain of the root term"),
        _G(21, "stsmc_k2", "st_k2", "counts/s", 1.0, 0, 1_000_000, 20.0, "MCK_GAIN_STSMC_K2",
           "gain of the integral term"),
        _G(22, "stsmc_phi", "st_phi", "Pa", 1.0, 1, 1_000_000, 50e3, "MCK_GAIN_STSMC_PHI", "error scale of the root"),
        _G(23, "stsmc_g", "st_g", "Pa/count", 1e3, 0, 100_000_000, 3000.0, "MCK_GAIN_STSMC_G",
           "G of the feed-forward (0: none)"),
        _G(24, "stsmc_u0", "st_u0", "PWM counts", 1e3, 0, 255_000, 0.0, "MCK_GAIN_STSMC_U0", "valve lift-off"),
    ),
    law="mckibben.control.stsmc:law", design="mckibben.control.stsmc:design",
    candidates="mckibben.control.stsmc:candidates", describe="mckibben.control.stsmc:describe",
    designs={"stsmc": stsmc.DESIGN}, grid={"stsmc": stsmc.GRID},
    state=stsmc.N_STATE, coefs=stsmc.COEFS, derive="mckibben.control.stsmc:derive",
    float_law="mckibben.control.stsmc:float_command",
    references="Levant 1993; Moreno & Osorio 2012; Seeber & Andritsch 2025 (mckibben.control.stsmc)",
)

#: Every controller of the core, by name, in mode order.
CONTROLLERS: dict[str, ControllerSpec] = {c.name: c for c in sorted((SMC, PID, STSMC), key=lambda c: c.mode)}

# --- derived tables -----------------------------------------------------------------------------

#: Every SET_GAIN entry in id order: the controllers' and the supervisor's.
GAINS: tuple[GainSpec, ...] = tuple(sorted(SUPERVISOR_GAINS + tuple(g for c in CONTROLLERS.values() for g in c.gains),
                                           key=lambda g: g.id))
N_GAINS = len(GAINS)
#: Valid SET_MODE ids.
MODES: tuple[int, ...] = tuple(sorted((MODE_OFF, MODE_OPEN_LOOP, *(c.mode for c in CONTROLLERS.values()))))
#: Controller names (``--controller``).
NAMES: tuple[str, ...] = tuple(CONTROLLERS)
#: The extension laws (beyond the core's sliding mode and PID), in mode order.
EXTENSIONS: tuple[ControllerSpec, ...] = tuple(c for c in CONTROLLERS.values() if c.extension)


def _layout() -> dict[str, tuple[int, int]]:
    """Each extension law's first istate and iparams slot (after the core's state and gains)."""
    out, so, io = {}, CORE_N_ISTATE, CORE_IP_GAIN0 + N_GAINS
    for c in EXTENSIONS:
        out[c.name] = (so, io)
        so += c.state
        io += len(c.coefs)
    return out


#: name -> (first istate slot, first iparams slot) of each extension law.
LAYOUT = _layout()
#: Lengths of the core's arrays with every law's slots.
N_ISTATE = CORE_N_ISTATE + sum(c.state for c in EXTENSIONS)
N_IPARAMS = CORE_IP_GAIN0 + N_GAINS + sum(len(c.coefs) for c in EXTENSIONS)


_STSMC_MODE, _STSMC_SLOTS = STSMC.mode, LAYOUT["stsmc"]


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def extension_law(mode, st, ip, p, pref, e):
    """The law of an extension mode: one line per registered extension law.

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
    if mode == _STSMC_MODE:
        return stsmc.law(st, ip, _STSMC_SLOTS[0], _STSMC_SLOTS[1], p, pref, e)
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


_DEFAULTS = {g.param: g.default for g in GAINS}


register(__name__)  # the kernels above compile once the package loads Numba (mckibben._kernels)
