"""Plant parameters: a frozen dataclass in SI, packed into one float row per instance.

Every numeric parameter may be a scalar or an array of N (one value per simulated instance);
:meth:`PlantParams.pack` broadcasts them to an ``(N, NP)`` float64 array whose columns are the
members of the :class:`Col` enum. ``docs/plant.md`` says how each default was chosen.
"""

from __future__ import annotations

import dataclasses
import enum
from dataclasses import dataclass, field

import numpy as np

from mckibben import hardware as HW
from mckibben.errors import ArgumentTypeError, InputError, check_instance, check_real, unknown_name
from mckibben.limits import PLAUSIBLE_MAX
from mckibben.units import P_ATM  # noqa: F401  (the plant's atmosphere: PP.P_ATM in the kernels)
from mckibben.models import laws as LW
from mckibben.models.muscle import FILE_BRAID_ANGLE as MUSCLE_BRAID_ANGLE
from mckibben.models.muscle import Muscle
from mckibben.models.mpam import MiniatureMuscle, predict_length
from mckibben.models.spring import CONTRACTION, ELONGATION
from mckibben.datasets import get_muscle
from mckibben.data.muscle_file import MuscleSpec, read_muscle

#: A plant parameter: one value for every instance, or one per instance (shape (N,)). [SI unit of the field]
Value = float | np.ndarray

R_AIR = 287.05  #: specific gas constant of air [J/(kg·K)]
T0 = 293.15  #: ISO 6358 reference temperature, also the supply temperature [K]
RHO0 = 1.185  #: ISO 6358 reference density of air (ANR, 20 °C, 1 atm) [kg/m³]
G = 9.80665  #: standard gravity [m/s²]

GAMMA = 1.4  #: ratio of specific heats of air [-]
#: Nusselt number of laminar, fully developed flow in a tube at constant wall temperature
#: (Incropera & DeWitt, Fundamentals of Heat and Mass Transfer, §8.4.1): h = Nu·k/d.
NUSSELT_TUBE = 3.66
K_AIR = 0.0257  #: thermal conductivity of air at 20 °C [W/(m·K)]
#: Temperatures of the air the plant accepts: from a cold store to a hot workshop, well inside the
#: range where air is an ideal gas with constant γ (what the chamber model assumes). [K]
TEMPERATURE_RANGE = (200.0, 400.0)
#: Lightest moving mass the plant accepts: a milligram. The mechanics' time constant falls as √m,
#: and far below this it is shorter than any integrator step a 1 ms control period allows. [kg]
MIN_MOVING_MASS = 1e-6

#: Force laws, by name: the registry's names and old aliases (:mod:`mckibben.models.laws`, the one
#: vocabulary), plus ``calibrated``: Tondu–Lopez with the plant's calibrated columns.
LAW_NAMES = {"calibrated": "tondu-lopez", **{n: n for n in LW.LAW_NAMES}, **LW.ALIASES}
#: Chamber thermodynamics, by name.
THERMAL = ("energy", "polytropic")

# --- the rig of a muscle file's own force law (PlantParams.from_muscle_file; docs/plant.md) ---------
#: Rest braid angle assumed when neither the file nor its fitted law gives one (the project's
#: construction angle, the default ``alpha0``): :data:`mckibben.models.muscle.FILE_BRAID_ANGLE`. [rad]
FILE_BRAID_ANGLE = MUSCLE_BRAID_ANGLE
#: Lumen over outer diameter when the file gives no tube: a 10 mm bore in a 12 mm sleeve, the
#: commercial 10 mm class. Only the chamber volume depends on it. [-]
FILE_LUMEN_FRACTION = 10.0 / 12.0
#: Tubing between the valves and a commercial muscle: 0.5 m of 4 mm bore (the 6 mm tube a 1/8"
#: valve port takes). [m], [m]
FILE_TUBE_BORE, FILE_TUBE_LENGTH = 4.0e-3, 0.5
#: Moving mass of a commercial rig: rod end, clevis and load-cell fixture. [kg]
FILE_MOVING_MASS = 0.1


class Load(enum.IntEnum):
    """Load kinds (the ``load_kind`` column)."""

    hanging = 0
    blocked = 1
    spring = 2


#: Loads, by name.
LOADS = {k.name: int(k) for k in Load}

_FIELDS = [
    # supply and valves
    "supply_pressure", "supply_droop", "valve_conductance", "bleed_conductance", "critical_ratio",
    "valve_tau", "dead_band", "driver_gain",
    # chamber
    "dead_volume", "leak_conductance", "polytropic_n", "temperature", "tube_diameter", "heat_transfer_coefficient",
    # muscle geometry (volume) and force law parameters
    "nominal_length", "strand_length", "k1", "k2", "outer_diameter", "inner_diameter", "wall_thickness",
    "r0", "alpha0", "k_tl", "p_threshold", "ch_turns",
    "passive_stiffness", "friction_force", "friction_per_pa", "friction_stiffness",
    # load
    "load_kind", "load_force", "moving_mass", "damping", "spring_stiffness", "spring_free_length",
    # sensors
    "adc_zero", "pa_per_count", "encoder_resolution", "pressure_noise", "seed",
]
#: Columns derived from the fields by :meth:`PlantParams.pack` (constants of the hot loop).
_DERIVED = ["inv_k1ls", "od_sin0", "wall_step", "d_min", "inv_valve_tau", "l_min", "l_max", "mobile", "inv_mass",
            "spring_rate", "k_gas", "inflow_at_supply", "h_area", "inv_1mb", "phi_laminar", "g_supply"]
#: The packed parameter columns: fields, then derived constants.
Col = enum.IntEnum("Col", [(name, i) for i, name in enumerate(_FIELDS + _DERIVED)])
NP = len(Col)


def calibrate_force_law(muscle: MiniatureMuscle, blocked_force: float | None = None, alpha0: float | None = None):
    """Tondu–Lopez force law with a pressure threshold, calibrated to three published numbers.

    F = π·r0²·(P − P_th)·[a(1 − k·ε)² − b] for P > P_th (0 below), a = 3/tan²α0, b = 1/sin²α0.
    The three unknowns (r0, k, P_th) follow in closed form from: the blocked force at 0.8 MPa
    (§III.A), and the contraction under 0.6 N at 0.8 MPa and at 0.4 MPa from eq. (2)+(3).
    The threshold models what the paper observes: at low pressure the braid angle barely changes
    (the silicone tube must first be stretched), Fig. 10.

    Parameters
    ----------
    muscle : MiniatureMuscle
        A published set with a blocked force at 0.8 MPa and a cubic at 0.6 N.
    blocked_force : float, optional
        Blocked force at 0.8 MPa; the muscle's published value by default. [N]
    alpha0 : float, optional
        Braid angle at rest; the construction's 20° by default. [rad]

    Returns
    -------
    dict
        ``r0`` [m], ``k_tl`` [-], ``p_threshold`` [Pa], ``alpha0`` [rad].

    References
    ----------
    Tondu & Lopez (2000), eq. (4); [mpam-characterization], §III.A, eq. (2)–(3), Tables I–II.
    """
    check_instance(muscle, "muscle", MiniatureMuscle, "a MiniatureMuscle (get_muscle)")
    if blocked_force is not None:
        blocked_force = check_real(blocked_force, "blocked_force", lo=0.0, lo_open=True, hi=PLAUSIBLE_MAX["force"],
                                   unit="N")
    if alpha0 is not None:
        alpha0 = check_real(alpha0, "alpha0", lo=0.0, hi=ALPHA0_MAX, lo_open=True, hi_open=True, unit="rad")
    f_b = blocked_force if blocked_force is not None else dict(muscle.blocked_force)[0.8e6]
    a0 = muscle.geometry.braid_angle if alpha0 is None else alpha0
    a = 3.0 / np.tan(a0) ** 2
    b = 1.0 / np.sin(a0) ** 2
    w, p1, p2 = 0.6, 0.8e6, 0.4e6
    eps1 = float(predict_length(muscle, p1, w).contraction)
    eps2 = float(predict_length(muscle, p2, w).contraction)
    a1 = f_b / (a - b)  # π r0² (P1 − P_th)
    k = (1.0 - np.sqrt((w / a1 + b) / a)) / eps1
    a2 = w / (a * (1.0 - k * eps2) ** 2 - b)  # π r0² (P2 − P_th)
    p_th = (a1 * p2 - a2 * p1) / (a1 - a2)
    with np.errstate(invalid="ignore"):
        r0 = np.sqrt(a1 / (np.pi * (p1 - p_th)))
    if not all(np.isfinite(v) and v > 0 for v in (r0, k)) or not np.isfinite(p_th):
        what = "blocked_force" if blocked_force is not None else "alpha0" if alpha0 is not None else "muscle"
        raise InputError(f"{what}: no Tondu-Lopez law meets these numbers (r0 = {float(r0):g} m, k = {float(k):g}, "
                         f"P_th = {float(p_th):g} Pa); check the blocked force and the rest braid angle")
    return {"r0": float(r0), "k_tl": float(k), "p_threshold": float(p_th), "alpha0": float(a0)}


#: Largest rest braid angle of the Tondu–Lopez law: at arccos(1/√3) ≈ 54.7° (the locking angle)
#: a braid pulls nothing, so a = 3/tan²α0 > b = 1/sin²α0 needs α0 below it. [rad]
ALPHA0_MAX = float(np.arccos(1.0 / np.sqrt(3.0)))


def _same(value, default) -> bool:
    """Whether a field still holds its default (NaN never does)."""
    try:
        return bool(np.all(np.asarray(value, dtype=float) == default))
    except (TypeError, ValueError):
        return False


def _show(value) -> str:
    return f"{value:g}" if isinstance(value, float) else repr(value)


@dataclass(frozen=True)
class PlantParams:
    """Parameters of the muscle test rig (one instance, or arrays of N).

    Defaults are the paper's rig with the 97 mm muscle (``docs/plant.md`` gives each choice).
    Pressures are gauge unless named otherwise. Use :meth:`for_muscle` for another muscle and
    :meth:`replace` (or keyword arguments) to change any parameter. Every numeric field is a
    :data:`Value`: a float for all instances or an array of N, one per instance (the attributes
    below give each one's unit).

    Attributes
    ----------
    supply_pressure : float
        Regulated supply (reservoir) pressure, gauge; ≤ 1 MPa (the compressor). [Pa]
    supply_droop : float
        Regulator droop: supply falls by this fraction at a fully open inlet. [-]
    valve_conductance, bleed_conductance : float
        ISO 6358 sonic conductance C of the inlet and bleed valves fully open. [m³/(s·Pa)]
    critical_ratio : float
        ISO 6358 critical pressure ratio b of the valves and the leak. [-]
    valve_tau : float
        First-order lag of the valve opening. [s]
    dead_band : float
        Fraction of full coil current below which a valve stays shut. [-]
    driver_gain : float
        LM358 driver: coil current per PWM duty, as a fraction of full current (saturates
        at 1, i.e. above 255/driver_gain counts). [-]
    dead_volume : float
        Tubing and fitting volume between the valves and the muscle. [m³]
    leak_conductance : float
        Sonic conductance of the leak to atmosphere (0: no leak). [m³/(s·Pa)]
    polytropic_n : float
        Polytropic exponent, used by ``thermal="polytropic"`` only (1 isothermal … 1.4 adiabatic). [-]
    temperature : float
        Supply air and wall (room) temperature. [K]
    tube_diameter : float
        Inner diameter of the tubing that makes the dead volume (its wall area exchanges heat). [m]
    heat_transfer_coefficient : float
        Film coefficient h between the chamber air and its walls; default Nu·k/d of laminar
        flow in the tube (Nu = 3.66). 0 is the adiabatic chamber. [W/(m²·K)]
    nominal_length, strand_length, k1, k2 : float
        The muscle: rest length, braid strand length, eq. (2) correction. [m], [m], [-], [m]
    outer_diameter, inner_diameter : float
        Muscle outer diameter and tube lumen diameter at rest. [m]
    wall_thickness : float
        Tube wall thickness of the wall-corrected law. [m]
    r0, alpha0, k_tl, p_threshold : float
        Tondu–Lopez radius, rest braid angle, contraction correction, pressure threshold.
        [m], [rad], [-], [Pa]
    ch_turns : float
        Chou–Hannaford turns of one strand (its strand length is ``strand_length``). [-]
    passive_stiffness : float
        Axial stiffness of the tube stretched beyond its rest length. [N/m]
    friction_force, friction_per_pa : float
        Braid friction (Dahl model) limit: F_c = friction_force + friction_per_pa·P (0: none). [N], [N/Pa]
    friction_stiffness : float
        Dahl model rest stiffness σ. [N/m]
    load_kind : float
        0 hanging mass, 1 blocked (isometric), 2 spring (:class:`Load`). [-]
    load_force : float
        Hanging weight (hanging) or the spring's preload at its free length. [N]
    moving_mass : float
        Pulley, belt and muscle end (the hanging mass is added to it). [kg]
    damping : float
        Viscous damping of the moving parts. [N·s/m]
    spring_stiffness, spring_free_length : float
        Spring load: stiffness and the muscle length at which it is relaxed. [N/m], [m]
    adc_zero, pa_per_count : float
        Pressure transducer and 10-bit ADC (:mod:`mckibben.hardware`). [-], [Pa]
    encoder_resolution : float
        Belt travel per encoder count. [m]
    pressure_noise : float
        Standard deviation of the transducer noise (0: none). [Pa]
    seed : float
        Seed of the instance's noise generator. [-]
    force_model : str or model
        The force law: a name of :data:`LAW_NAMES` (``"calibrated"``: Tondu–Lopez with the
        threshold from the fields above; ``"empirical"``: the muscle's braid-angle map) or a static
        model object (a published or fitted ``MiniatureMuscle``, ``TonduLopez``, ``BraidGeometry``,
        ``SpringModel``; see :func:`mckibben.models.laws.law_of`).
    thermal : str
        ``"energy"`` (energy balance with wall heat exchange) or ``"polytropic"``.
    muscle : MiniatureMuscle, optional
        The muscle whose braid-angle map ``force_model="empirical"`` uses (default: ``muscle_name``'s).
    """

    supply_pressure: Value = 0.8e6
    supply_droop: Value = 0.0
    valve_conductance: Value = 2.0e-10
    bleed_conductance: Value = 2.0e-10
    critical_ratio: Value = 0.3
    valve_tau: Value = 3e-3
    dead_band: Value = 0.63
    driver_gain: Value = 1.43
    dead_volume: Value = 2.3e-7
    leak_conductance: Value = 1.7e-11
    polytropic_n: Value = 1.2
    temperature: Value = T0
    tube_diameter: Value = 1.0e-3
    heat_transfer_coefficient: Value | None = None
    nominal_length: Value = 0.097
    strand_length: Value = 0.112
    k1: Value = 0.92
    k2: Value = 0.77e-3
    outer_diameter: Value = 1.2e-3
    inner_diameter: Value = 0.5e-3
    wall_thickness: Value = 0.2e-3
    r0: Value = 0.0
    alpha0: Value = float(np.deg2rad(20.0))
    k_tl: Value = 1.0
    p_threshold: Value = 0.0
    ch_turns: Value = 0.0
    passive_stiffness: Value = 200.0
    friction_force: Value = 0.01
    friction_per_pa: Value = 0.2e-6
    friction_stiffness: Value = 2000.0
    load_kind: Value = 0.0
    load_force: Value = 0.6
    moving_mass: Value = 0.005
    damping: Value = 4.0
    spring_stiffness: Value = 0.0
    spring_free_length: Value = 0.097
    adc_zero: Value = 0.0
    pa_per_count: Value = HW.PA_PER_COUNT
    encoder_resolution: Value = HW.ENCODER_RESOLUTION
    pressure_noise: Value = 0.0
    seed: Value = 0.0
    force_model: object = "calibrated"
    thermal: str = "energy"
    muscle: MiniatureMuscle | None = field(default=None, compare=False)
    muscle_name: str = field(default="mpam97", compare=False)

    def __post_init__(self):
        if self.muscle_name and np.all(np.asarray(self.r0) == 0):
            cal = calibrate_force_law(get_muscle(self.muscle_name), alpha0=self._own_alpha0())
            for key, value in cal.items():
                object.__setattr__(self, key, value)
        if np.all(np.asarray(self.ch_turns) == 0):
            # Chou–Hannaford turns from the rest geometry: D = b·sin θ0/(n·π) at l0 = b·cos θ0
            b = np.asarray(self.strand_length, dtype=float)
            c0 = np.clip(np.asarray(self.nominal_length, dtype=float) / b, 0.0, 1.0)
            d = np.asarray(self.outer_diameter, dtype=float) - 0.1e-3
            object.__setattr__(self, "ch_turns", b * np.sqrt(1 - c0**2) / (np.pi * d))
        if self.heat_transfer_coefficient is None:
            d = np.asarray(self.tube_diameter, dtype=float)
            with np.errstate(divide="ignore", invalid="ignore"):
                object.__setattr__(self, "heat_transfer_coefficient", NUSSELT_TUBE * K_AIR / d)
        if isinstance(self.force_model, str) and self.force_model not in LAW_NAMES:
            raise InputError(f"force_model: {unknown_name('force model', self.force_model, LAW_NAMES)}")
        if not isinstance(self.thermal, str) or self.thermal not in THERMAL:
            raise InputError(f"thermal: {unknown_name('thermal model', str(self.thermal), THERMAL)}")

    def _own_alpha0(self) -> float | None:
        """The user's ``alpha0`` for the calibration (r0 left at 0), checked; None for the default.

        r0, k_tl and p_threshold are calibrated together: a ``k_tl`` or ``p_threshold`` given
        without ``r0`` would be replaced by the calibration, so it is refused, never overwritten.
        """
        defaults = {f.name: f.default for f in dataclasses.fields(self) if f.name in ("alpha0", "k_tl", "p_threshold")}
        for name in ("k_tl", "p_threshold"):
            value = getattr(self, name)
            if not _same(value, defaults[name]):
                raise InputError(f"{name} = {_show(value)} given without r0: r0, k_tl and p_threshold are calibrated "
                                 "together when r0 is 0 (left out), which would replace it; give r0 as well for your "
                                 f"own Tondu-Lopez law, or leave {name} out")
        if _same(self.alpha0, defaults["alpha0"]):
            return None
        if np.ndim(self.alpha0) != 0:
            raise InputError("alpha0: one rest braid angle for the calibrated law (r0 left at 0), not an array; "
                             "give r0, k_tl and p_threshold per instance for your own laws")
        return check_real(self.alpha0, "alpha0", lo=0.0, hi=ALPHA0_MAX, lo_open=True, hi_open=True, unit="rad")

    @classmethod
    def for_muscle(cls, muscle: MiniatureMuscle, **kwargs) -> "PlantParams":
        """Plant with a published (or fitted) miniature muscle, its force law calibrated.

        Parameters
        ----------
        muscle : MiniatureMuscle
            The muscle (its braid-angle map drives ``force_model="empirical"``).
        **kwargs
            Any other :class:`PlantParams` field. [SI]
        """
        base = dict(
            nominal_length=muscle.nominal_length, strand_length=muscle.strand_length,
            k1=muscle.k1, k2=muscle.k2, outer_diameter=muscle.geometry.outer_diameter,
            inner_diameter=muscle.geometry.tube_inner_diameter, wall_thickness=muscle.geometry.wall_thickness,
            spring_free_length=muscle.nominal_length, muscle_name="", muscle=muscle, **calibrate_force_law(muscle),
        )
        base.update(kwargs)
        return cls(**base)

    @classmethod
    def from_muscle_file(cls, muscle, direction: str = "inflate", **kwargs) -> "PlantParams":
        """Plant with a muscle file's own fitted force law, on a rig sized for that muscle.

        The force law is the file's ``[force_model]`` (written by ``mckibben fit … --save``),
        run through the law registry (:meth:`mckibben.fit.muscle_file.MuscleForceLaw.static_model`,
        :func:`mckibben.models.laws.law_of`); the surface model has no physical law and is refused.
        The rig around it is sized from the file's geometry (``docs/plant.md``, "A muscle file's
        plant", gives each choice and its reason):

        - braid: an ideal braid (eq. 2 with k1 = 1, k2 = 0) of strand length ``strand_length_mm``,
          else L0/cos θ0 with the fitted θ0 (Chou–Hannaford, Tondu–Lopez), the file's
          ``braid_angle_deg`` or :data:`FILE_BRAID_ANGLE`, shortened to where the law's pull peaks
          when it peaks beyond the rest length (:attr:`mckibben.models.laws.Law.peak_length`, the
          wall-corrected braid; :class:`~mckibben.models.muscle.Muscle`): it sets the chamber
          volume's change with length and the end stops;
        - lumen: ``tube_inner_diameter_mm``, else the outer diameter less the fitted wall (wall-
          corrected fit, unless the wall sits at a bound of its fit: not identified), else
          :data:`FILE_LUMEN_FRACTION` of the outer diameter;
        - tubing: :data:`FILE_TUBE_LENGTH` of :data:`FILE_TUBE_BORE` bore;
        - valves and leak: the calibrated rig's sonic conductances scaled by the ratio of the
          chamber volumes at rest, so the fill keeps the calibrated rig's time constant
          (≈ 0.09 s) that the controllers' gains were chosen for;
        - passive stiffness and friction 0: the fitted law is the whole measured force, the tube's
          elasticity included, and one branch of it (the spring model's inflate or deflate);
        - moving mass :data:`FILE_MOVING_MASS`; damping critical for that mass and a hanging
          load's (``load_force``/g) on the law's steepest stiffness at the supply pressure;
        - supply: the top of the fitted pressure range (the law is not known above it), ≤ 1 MPa.

        Parameters
        ----------
        muscle : str, pathlib.Path, MuscleSpec or Muscle
            A muscle file with a ``[force_model]`` table, the spec read from one, or the
            :class:`~mckibben.models.muscle.Muscle` built from one (its branch is used). [-]
        direction : {"inflate", "deflate"}, default "inflate"
            The spring model's branch (its hysteresis); the other laws have one. [-]
        **kwargs
            Any other :class:`PlantParams` field, applied last (e.g. ``load_force``,
            ``valve_conductance`` of the lab's own valve). [SI]

        Returns
        -------
        PlantParams
            Checked: the integrator can run its law over the operating range.

        Raises
        ------
        InputError
            One line naming the file and what is wrong: no ``[force_model]``, a missing geometry
            key, a law the plant cannot run (the surface model; a law that pulls less when
            stretched inside the operating range).
        """

        if direction not in ("inflate", "deflate"):
            raise InputError(f"direction: {direction!r} must be inflate or deflate")
        if isinstance(muscle, Muscle):
            m = muscle
            direction = m.direction
        else:
            spec = muscle if isinstance(muscle, MuscleSpec) else read_muscle(muscle)
            m = Muscle.from_spec(spec, direction)
        spec = m.spec
        where = spec.path or spec.id
        obj = m.params
        l0 = float(m.nominal_length)
        od = spec.need("outer_diameter", "the plant's chamber volume")
        # the braid that moves the chamber and sets the end stops: the muscle's (models/muscle.py)
        b = m.strand_length
        # a fitted braid's wall, when the fit identified it: a wall at a bound of its fit (flagged) is
        # no measure of the tube (at the lower bound it is a rounding-size number, ~1e-19 m on a 26 mm
        # Festo muscle, and od − 2·wall is od itself: no lumen wall at all)
        wall = float(getattr(obj, "wall_thickness", 0.0))
        if any(f.startswith("wall_m_at_") for f in m.flags):
            wall = 0.0
        if spec.tube_inner_diameter is not None:
            inner = float(spec.tube_inner_diameter)
        elif wall > 0:
            inner = od - 2.0 * wall
        else:
            inner = FILE_LUMEN_FRACTION * od
        dead = 0.25 * np.pi * FILE_TUBE_BORE**2 * FILE_TUBE_LENGTH
        base = cls()
        v_ref = base.dead_volume + 0.25 * np.pi * base.inner_diameter**2 * base.nominal_length
        scale = (dead + 0.25 * np.pi * inner**2 * l0) / v_ref
        supply = min(m.pressure_range[1] if np.isfinite(m.pressure_range[1]) else base.supply_pressure, HW.P_MAX_LIMIT)
        fields = dict(
            nominal_length=l0, strand_length=float(b), k1=1.0, k2=0.0, outer_diameter=od, inner_diameter=inner,
            wall_thickness=0.5 * (od - inner), r0=float(getattr(obj, "initial_radius", 0.0)),
            alpha0=float(np.arccos(min(l0 / b, 1.0))) or base.alpha0, k_tl=1.0, p_threshold=0.0,
            dead_volume=dead, tube_diameter=FILE_TUBE_BORE, valve_conductance=base.valve_conductance * scale,
            bleed_conductance=base.bleed_conductance * scale, leak_conductance=base.leak_conductance * scale,
            passive_stiffness=0.0, friction_force=0.0, friction_per_pa=0.0, moving_mass=FILE_MOVING_MASS,
            supply_pressure=supply if supply > 0 else base.supply_pressure, spring_free_length=l0,
            load_force=0.0, force_model=obj, muscle_name="", muscle=None,
        )
        plant = cls(**fields)
        plant = plant.replace(**kwargs) if kwargs else plant
        hung = np.where(np.asarray(plant.load_kind) == Load.hanging, np.asarray(plant.load_force, float) / G, 0.0)
        mass = np.asarray(plant.moving_mass, float) + np.maximum(hung, 0.0)
        if "damping" not in kwargs and np.all(mass > 0):  # (a bad mass is named by the validation below)
            # critical for everything that moves: the fixture's mass and a hanging load's
            mass = float(mass) if mass.ndim == 0 else mass
            now = {k: getattr(plant, k) for k in ("strand_length", "supply_pressure") if np.ndim(getattr(plant, k)) == 0}
            plant = plant.replace(damping=_critical_damping(obj, {**fields, **now, "moving_mass": mass}, direction))
        try:
            plant.prepare()
        except InputError as exc:
            raise InputError(f"{where} (fitted {spec.force_model['model']} force law): {exc}") from None
        return plant

    def replace(self, **kwargs) -> "PlantParams":
        """A copy with some fields changed (named loads accepted).

        Parameters
        ----------
        **kwargs
            Fields of :class:`PlantParams`; ``load_kind`` may be a name. [SI]
        """
        if isinstance(kwargs.get("load_kind"), str):
            name = kwargs["load_kind"]
            if name not in LOADS:
                raise unknown_name("load", name, LOADS)
            kwargs["load_kind"] = float(LOADS[name])
        bad = [k for k in kwargs if k not in _FIELDS and k not in ("muscle_name", "force_model", "thermal", "muscle")]
        if bad:
            raise unknown_name("plant parameter", bad[0], _FIELDS)
        return dataclasses.replace(self, **kwargs)

    def size(self) -> int:
        """N, the number of instances the array-valued fields describe (1 if all scalars)."""
        empty = [f for f in _FIELDS if np.size(getattr(self, f)) == 0]
        if empty:
            raise InputError(f"plant parameter {empty[0]}: an empty array; give a number, or one value per instance")
        sizes = {np.size(getattr(self, f)) for f in _FIELDS} - {1}
        if len(sizes) > 1:
            raise InputError(f"plant parameters: arrays of different lengths {sorted(sizes)}")
        return sizes.pop() if sizes else 1

    def pack(self, n: int | None = None) -> np.ndarray:
        """The ``(N, NP)`` float64 parameter array (columns :class:`Col`), validated.

        Parameters
        ----------
        n : int, optional
            Number of instances (scalars are repeated); default :meth:`size`.
        """
        row = self.__dict__.get("_packed_row")
        if row is not None:  # every field a Python or NumPy scalar: immutable, packed once
            return np.repeat(row, 1 if n is None else int(n), axis=0)
        n = self.size() if n is None else int(n)
        if n != self.size() and self.size() != 1:
            raise InputError(f"plant parameters have {self.size()} instances, {n} were asked for")
        out = np.empty((n, NP))
        for j, name in enumerate(_FIELDS):
            raw = getattr(self, name)
            if (raw is None or isinstance(raw, (str, bytes, bool, np.bool_))
                    or (isinstance(raw, np.ndarray) and raw.dtype.kind not in "iuf")):
                hint = " (PlantParams takes SI numbers)" if isinstance(raw, str) else ""
                raise ArgumentTypeError(f"{name} = {raw!r}: not a number or an array of numbers "
                                        f"({type(raw).__name__}){hint}")
            try:
                value = np.asarray(raw, dtype=float)
            except (TypeError, ValueError):
                raise ArgumentTypeError(f"{name} = {raw!r}: not a number or an array of numbers "
                                        f"({type(raw).__name__})") from None
            if value.ndim > 1:
                raise InputError(f"plant parameter {name}: scalar or 1-D array, got shape {value.shape}")
            out[:, j] = np.broadcast_to(value.ravel() if value.ndim else value, (n,))
        validate(out, law_fields=isinstance(self.force_model, str))
        derive(out, self.thermal)
        if n >= 1 and all(isinstance(getattr(self, f), (int, float, np.integer, np.floating)) for f in _FIELDS):
            object.__setattr__(self, "_packed_row", out[:1].copy())
        return out

    def law(self, n: int | None = None) -> tuple[str, np.ndarray]:
        """The force law's registry name and its parameters θ, ``(NTH, N)``.

        Parameters
        ----------
        n : int, optional
            Number of instances; default :meth:`size`.
        """
        n = self.size() if n is None else int(n)
        fm = self.force_model
        if not isinstance(fm, str):
            try:
                name, th = LW.law_of(fm)
            except InputError as exc:
                raise InputError(f"force_model = {fm!r}: {exc}") from None
            return name, np.repeat(th[:, None], n, axis=1)
        name = LAW_NAMES[fm]
        law = LW.LAWS[name]
        if law.plant_theta is None:  # the law's θ is not in the plant's columns: it needs its parameter object
            what = law.params.__name__ if law.params is not None else "its parameter object"
            raise InputError(f"force_model={fm!r} needs its model object (e.g. force_model={what}(...))")
        col = {f: np.broadcast_to(np.asarray(getattr(self, f), dtype=float), (n,)) for f in _FIELDS}

        def muscle():
            if self.muscle is not None:
                return self.muscle
            if not self.muscle_name:
                raise InputError(f"force_model={fm!r} needs a muscle (PlantParams.for_muscle or muscle=...)")
            return get_muscle(self.muscle_name)

        return name, np.asarray(law.plant_theta(col, muscle), dtype=float)

    def prepare(self, n: int | None = None):
        """Everything the integrator needs, checked: ``(prm (N, NP), law index, θ (NTH, N), law name)``.

        Raises :class:`~mckibben.errors.InputError` for parameters the integrator cannot run,
        naming the parameter, or, for the force law, the pressures and lengths where it fails
        (:func:`check_force_law`).

        Parameters
        ----------
        n : int, optional
            Number of instances; default :meth:`size`.
        """
        prm = self.pack(n)
        name, th = self.law(prm.shape[0])
        th = np.ascontiguousarray(th, dtype=float)
        check_force_law(name, prm, th, self._law_label())
        return prm, LW.LAW_INDEX[name], th, name

    def _law_label(self) -> str:
        fm = self.force_model
        if not isinstance(fm, str):
            return f"{type(fm).__name__} {getattr(fm, 'name', '')}".strip()
        who = getattr(self.muscle, "name", None) or self.muscle_name
        return f"{fm} ({who})" if who else fm


def derive(p: np.ndarray, thermal: str = "energy") -> None:
    """Fill the derived columns of packed, validated parameters (in place).

    Parameters
    ----------
    p : numpy.ndarray
        Packed ``(N, NP)`` parameters.
    thermal : str, default "energy"
        The chamber model (:data:`THERMAL`).
    """
    c = Col
    k1ls = p[:, c.k1] * p[:, c.strand_length]
    p[:, c.inv_k1ls] = 1.0 / k1ls
    c0 = np.clip((p[:, c.nominal_length] - p[:, c.k2]) / k1ls, 0.05, 0.9999)
    p[:, c.od_sin0] = p[:, c.outer_diameter] / np.sqrt(1.0 - c0**2)
    p[:, c.wall_step] = p[:, c.outer_diameter] - p[:, c.inner_diameter]
    p[:, c.d_min] = 0.1 * p[:, c.inner_diameter]
    p[:, c.inv_valve_tau] = 1.0 / p[:, c.valve_tau]
    # end stops: the braid's locking angle (cos θ = 1/√3, where an ideal braid's force vanishes)
    # and the straight braid (cos θ = 1), through eq. (2)
    p[:, c.l_min] = k1ls / np.sqrt(3.0) + p[:, c.k2]
    p[:, c.l_max] = k1ls + p[:, c.k2]
    kind = p[:, c.load_kind]
    p[:, c.mobile] = np.where(kind == Load.blocked, 0.0, 1.0)
    hang = kind == Load.hanging
    p[:, c.inv_mass] = 1.0 / (p[:, c.moving_mass] + np.where(hang, p[:, c.load_force] / G, 0.0))
    p[:, c.spring_rate] = np.where(kind == Load.spring, p[:, c.spring_stiffness], 0.0)
    energy = thermal == "energy"
    p[:, c.k_gas] = GAMMA if energy else p[:, c.polytropic_n]
    p[:, c.inflow_at_supply] = 1.0 if energy else 0.0
    # wall area: the tubing (4·V/d of a tube) and the muscle's lumen at rest
    area = 4.0 * p[:, c.dead_volume] / p[:, c.tube_diameter] + np.pi * p[:, c.inner_diameter] * p[:, c.nominal_length]
    p[:, c.h_area] = p[:, c.heat_transfer_coefficient] * area if energy else 0.0
    # ISO 6358 constants of the flow function (critical ratio b) and √(T0/T_supply)
    b = p[:, c.critical_ratio]
    p[:, c.inv_1mb] = 1.0 / (1.0 - b)
    sl = (0.999 - b) / (1.0 - b)
    p[:, c.phi_laminar] = np.sqrt(1.0 - sl * sl) / (1.0 - 0.999)
    p[:, c.g_supply] = np.sqrt(T0 / p[:, c.temperature])


def validate(p: np.ndarray, law_fields: bool = True) -> None:
    """Refuse physically wrong parameter rows with one line naming the parameter and instance.

    Parameters
    ----------
    p : numpy.ndarray
        Packed ``(N, NP)`` parameters.
    law_fields : bool, default True
        Check the fields only the named force laws read (the Tondu–Lopez radius ``r0``); False
        when the law is a model object (:meth:`PlantParams.from_muscle_file`), which carries its own. [-]
    """
    if p.ndim != 2 or p.shape[1] < len(_FIELDS):
        raise InputError(f"packed plant parameters: shape {p.shape}, want (N, {NP})")
    col = {name: p[:, j] for j, name in enumerate(_FIELDS)}

    def check(cond, name, what):
        bad = np.flatnonzero(~np.asarray(cond))
        if bad.size:
            i = bad[0]
            raise InputError(f"plant parameter {name} = {col[name][i]:g} (instance {i}): {what}")

    for name in _FIELDS:
        check(np.isfinite(col[name]), name, "must be a finite number")
    check(col["supply_pressure"] > 0, "supply_pressure", "the supply must be above atmosphere (gauge > 0)")
    check(col["supply_pressure"] <= HW.P_MAX_LIMIT, "supply_pressure", "the compressor gives at most 1 MPa")
    check((col["supply_droop"] >= 0) & (col["supply_droop"] < 1), "supply_droop", "must be in [0, 1)")
    for name in ("valve_conductance", "bleed_conductance", "leak_conductance", "friction_force", "friction_per_pa",
                 "passive_stiffness", "damping", "spring_stiffness", "pressure_noise", "p_threshold",
                 "heat_transfer_coefficient", "wall_thickness"):
        check(col[name] >= 0, name, "must be >= 0")
    check((col["critical_ratio"] > 0) & (col["critical_ratio"] < 1), "critical_ratio", "must be in (0, 1)")
    check(col["valve_tau"] > 0, "valve_tau", "must be > 0")
    check((col["dead_band"] >= 0) & (col["dead_band"] < 1), "dead_band", "must be in [0, 1)")
    check(col["driver_gain"] > 0, "driver_gain", "must be > 0")
    check(col["dead_volume"] > 0, "dead_volume", "a volume must be > 0")
    check((col["polytropic_n"] >= 1) & (col["polytropic_n"] <= 1.4), "polytropic_n", "must be in [1, 1.4]")
    check((col["temperature"] >= TEMPERATURE_RANGE[0]) & (col["temperature"] <= TEMPERATURE_RANGE[1]), "temperature",
          f"the air's temperature must be in [{TEMPERATURE_RANGE[0]:g}, {TEMPERATURE_RANGE[1]:g}] K, where the "
          f"chamber's ideal-gas model holds (a value in °C or a unit slip?)")
    check(col["moving_mass"] >= MIN_MOVING_MASS, "moving_mass",
          f"must be at least {MIN_MOVING_MASS:g} kg (a milligram): a lighter mass makes the mechanics stiffer than "
          f"the integrator's step (a unit slip?)")
    for name in ("nominal_length", "strand_length", "outer_diameter", "inner_diameter", "k1", "moving_mass",
                 "pa_per_count", "encoder_resolution", "friction_stiffness", "tube_diameter"):
        check(col[name] > 0, name, "must be > 0")
    if law_fields:
        check(col["r0"] > 0, "r0", "must be > 0")
        check((col["alpha0"] > 0) & (col["alpha0"] < ALPHA0_MAX), "alpha0",
              f"a rest braid angle in (0, {ALPHA0_MAX:.4g}) rad, below the locking angle where a braid pulls nothing")
        check(col["k_tl"] > 0, "k_tl", "must be > 0")
        check(col["p_threshold"] < HW.P_MAX_LIMIT, "p_threshold",
              "must be below the compressor's 1 MPa, else the muscle never pulls")
    check(col["nominal_length"] < col["strand_length"] * col["k1"] + col["k2"], "nominal_length",
          "must be shorter than the straightened braid k1·Ls + k2")
    check(col["nominal_length"] > col["strand_length"] * col["k1"] / np.sqrt(3.0) + col["k2"], "nominal_length",
          "must be longer than the braid at its locking angle k1·Ls/√3 + k2")
    check(col["inner_diameter"] < col["outer_diameter"], "inner_diameter", "must be below the outer diameter")
    check((col["alpha0"] > 0) & (col["alpha0"] < np.pi / 2), "alpha0", "must be in (0, 90°)")
    check(np.isin(col["load_kind"], list(LOADS.values())), "load_kind", "must be 0, 1 or 2 (see LOADS)")
    check(col["load_force"] >= 0, "load_force", "a hanging weight must be >= 0")
    check(col["load_force"] <= PLAUSIBLE_MAX["force"], "load_force",
          f"more than {PLAUSIBLE_MAX['force']:g} N, past any muscle's pull (a unit slip?)")


def check_force_law(name: str, prm: np.ndarray, theta: np.ndarray, label: str = "", pressure_floor: float = 0.0) -> None:
    """Refuse a force law the integrator cannot run over the operating range, naming where.

    The operating range of an instance is its pressures 0..supply and its lengths between the
    end stops. Over a grid of it (17 pressures × 97 lengths), wherever the law pulls (its value
    is positive), its force must be finite and must not fall as the muscle lengthens: with a
    negative stiffness a hanging load has no stable rest (the published 97 and 117 mm maps below
    ~0.23 MPa: a heavier load would give a *shorter* muscle) and the dynamics run away.
    Instances with equal law, geometry and supply are checked once.

    Parameters
    ----------
    name : str
        Law name (:data:`mckibben.models.laws.LAWS`).
    prm : numpy.ndarray
        Packed ``(N, NP)`` parameters.
    theta : numpy.ndarray
        The law's ``(NTH, N)`` parameters.
    label : str
        How to name the law in the message.
    pressure_floor : float, default 0.0
        Lowest gauge pressure of the operating range: a run held above it (the MuJoCo endoscope,
        whose muscles never vent) may use a law that is only stable above it, such as the
        published braid-angle maps (stable above ~0.25 MPa). [Pa]
    """
    c = Col
    lim = prm[:, [c.l_min, c.l_max]]
    if np.all(theta == theta[:, :1]) and np.all(lim == lim[:1]):  # one law over one range (a sweep of the rest)
        first = np.unique(prm[:, c.supply_pressure], return_index=True)[1]  # as the rows below, without sorting them
        envelope = len(first) > 64
        first = first[:1] if envelope else first
    else:
        first = _first_of_each_row(np.concatenate([theta.T, prm[:, [c.supply_pressure]], lim], axis=1))
        envelope = len(first) > 64
        if envelope:  # many different instances (a sweep): the envelope of each law vector
            first = _first_of_each_row(np.concatenate([theta.T, lim], axis=1))
    np_, nl = 17, 97
    for i in np.sort(first)[:256]:
        supply = HW.P_MAX_LIMIT if envelope else float(prm[i, c.supply_pressure])
        passed = (name, pressure_floor, supply, theta[:, i].tobytes(), prm[i, [c.l_min, c.l_max]].tobytes())
        if passed in _LAWS_PASSED:  # the same law over the same range passed before (a sweep's next chunk)
            continue
        pg = np.linspace(min(pressure_floor, supply), supply, np_)[:, None]
        ln = np.linspace(prm[i, c.l_min], prm[i, c.l_max], nl)[None, :]
        f = LW.evaluate(name, pg, ln, theta[:, i])
        active = f > 0
        if not np.all(np.isfinite(f[active])) or np.any(np.isnan(f)):
            bad = ~np.isfinite(f)
            where = _range_text(pg[:, 0], ln[0], bad)
            raise InputError(f"force law {label or name} (instance {i}): no finite force at {where}")
        both = active[:, 1:] & active[:, :-1]
        falls = both & (np.diff(f, axis=1) < -1e-9 * np.maximum(np.abs(f[:, 1:]), 1e-12))
        if np.any(falls):
            where = _range_text(pg[:, 0], 0.5 * (ln[0, 1:] + ln[0, :-1]), falls)
            raise InputError(
                f"force law {label or name} (instance {i}): the muscle pulls less when stretched (negative "
                f"stiffness) at {where}, inside its operating range {min(pressure_floor, supply) / 1e6:g}..{supply / 1e6:g} MPa × "
                f"{prm[i, c.l_min] * 1e3:.1f}..{prm[i, c.l_max] * 1e3:.1f} mm: a load has no stable rest there; "
                "use another force law or a map that rises with length")
        if len(_LAWS_PASSED) > 1024:
            _LAWS_PASSED.clear()
        _LAWS_PASSED.add(passed)


#: Law vectors and ranges :func:`check_force_law` has passed in this process (it is deterministic).
_LAWS_PASSED: set = set()


def _first_of_each_row(key: np.ndarray) -> np.ndarray:
    """Index of the first occurrence of each distinct row of a 2-D float array.

    The rows of ``np.unique(key, axis=0, return_index=True)``, by a stable lexicographic sort of
    the columns (``np.unique`` with ``axis=0`` sorts the rows as opaque records, 35× slower on
    a sweep's chunk of 2,000).
    """
    order = np.lexsort(key.T[::-1])
    ranked = key[order]
    new = np.ones(len(order), dtype=bool)
    new[1:] = np.any(ranked[1:] != ranked[:-1], axis=1)
    return order[new]


def _range_text(p, length, mask) -> str:
    rows, cols = np.nonzero(mask)
    return (f"{p[rows.min()] / 1e6:.3g}..{p[rows.max()] / 1e6:.3g} MPa, "
            f"{length[cols.min()] * 1e3:.1f}..{length[cols.max()] * 1e3:.1f} mm")


def _critical_damping(model, fields: dict, direction: str) -> float:
    """Damping [N·s/m] critical for the moving mass on a law's steepest stiffness at the supply.

    The stiffness is the largest rise of the law's force per metre over the lengths between the
    ideal braid's end stops (k1 = 1, k2 = 0) at the supply pressure.
    """

    name, th = LW.law_of(model, direction=CONTRACTION if direction == "deflate" else ELONGATION)
    b = fields["strand_length"]
    ell = np.linspace(b / np.sqrt(3.0), b, 201)
    f = np.nan_to_num(LW.evaluate(name, fields["supply_pressure"], ell, th))
    k = float(np.max(np.diff(np.maximum(f, 0.0)) / np.diff(ell), initial=0.0))
    return 2.0 * np.sqrt(max(k, 0.0) * fields["moving_mass"])


def field_names() -> list[str]:
    """The packed parameter columns set from fields, in order."""
    return list(_FIELDS)
