"""Plant parameters: a frozen dataclass in SI, and its constructors for a published muscle or a muscle file.

Every numeric parameter may be a scalar or an array of N (one value per simulated instance);
:meth:`PlantParams.pack` broadcasts them to an ``(N, NP)`` float64 array whose columns are the
members of the :class:`~mckibben.plant.packing.Col` enum: the column layout, its derived
constants and the checks of a packed row are in :mod:`mckibben.plant.packing` (this module
imports its public names too, their old home). ``docs/plant.md`` says how each default was chosen.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from mckibben import hardware as HW
from mckibben.errors import ArgumentTypeError, InputError, check_instance, check_real, unknown_name
from mckibben.limits import PLAUSIBLE_MAX
from mckibben.models import laws as LW
# the rest braid angle of a muscle file's rig (PlantParams.from_muscle_file), defined with the Muscle; imported
# here, its old home
from mckibben.models.muscle import FILE_BRAID_ANGLE  # noqa: F401
from mckibben.models.muscle import Muscle
from mckibben.models.mpam import MiniatureMuscle, predict_length
from mckibben.models.spring import CONTRACTION, ELONGATION
from mckibben.datasets import get_muscle
from mckibben.data.muscle_file import MuscleSpec, read_muscle
from mckibben.plant.packing import _FIELDS, ALPHA0_MAX, G, K_AIR, LOADS, NP, NUSSELT_TUBE, T0, THERMAL, Load
from mckibben.plant.packing import FORCE_MODELS as LAW_NAMES  # the plant's force-model names (its old name here)
from mckibben.plant.packing import check_force_law, validate
from mckibben.plant.packing import derive_columns as derive  # its old name here
# the names' old home: imported so that ``mckibben.plant.params.<name>`` still works
from mckibben.plant.packing import GAMMA, MIN_MOVING_MASS, P_ATM, R_AIR, RHO0, TEMPERATURE_RANGE  # noqa: F401
from mckibben.plant.packing import Col, field_names  # noqa: F401

#: A plant parameter: one value for every instance, or one per instance (shape (N,)). [SI unit of the field]
Value = float | np.ndarray


# --- the rig of a muscle file's own force law (PlantParams.from_muscle_file; docs/plant.md) ---------
#: Lumen over outer diameter when the file gives no tube: a 10 mm bore in a 12 mm sleeve, the
#: commercial 10 mm class. Only the chamber volume depends on it. [-]
FILE_LUMEN_FRACTION = 10.0 / 12.0
#: Tubing between the valves and a commercial muscle: 0.5 m of 4 mm bore (the 6 mm tube a 1/8"
#: valve port takes). [m], [m]
FILE_TUBE_BORE, FILE_TUBE_LENGTH = 4.0e-3, 0.5
#: Moving mass of a commercial rig: rod end, clevis and load-cell fixture. [kg]
FILE_MOVING_MASS = 0.1




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
    play_threshold : float
        Threshold r of a play (backlash) operator on the gauge pressure that the force law sees
        instead of the pressure (a direction-aware law's ``"play"`` form,
        :mod:`mckibben.models.hysteresis.direction`; Kuhnen 2003); 0: no play, the law sees the
        pressure. [Pa]
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
    play_threshold: Value = 0.0
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
          ``braid_angle_deg`` or :data:`~mckibben.models.muscle.FILE_BRAID_ANGLE`, shortened to where the law's pull peaks
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
        - passive stiffness: the file's tube stiffness (``tube_stiffness_N_per_m``, a law fitted with
          the tube's stretch, :mod:`mckibben.models.tube`), else 0 (the fitted law is the whole
          measured force, the tube's elasticity included);
        - friction: ``friction_per_pa`` the file's friction area (``friction_area_m2``, A_f·P fitted
          on the up/down branches, :func:`mckibben.fit.direction.fit_isotonic_friction`) and
          ``friction_force`` its constant part (``friction_force_N``, F_0; 0 in a file without it), else none (the fitted law is one branch of the measured force:
          the spring model's inflate or deflate, or the branches' mean); a direction-aware fit's
          ``"friction"`` form saved (``fit_table(..., direction_aware="friction", save=...)``) is such
          an A_f;
        - play: ``play_threshold`` the file's play on the pressure (``play_threshold_Pa``, a
          direction-aware fit's ``"play"`` form saved, ``fit_table(..., direction_aware="play",
          save=...)``): the law sees the play's output instead of the pressure, and the file's law is
          the one the play feeds (one operator: a file has a play or a friction, never both); else 0;
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
            passive_stiffness=float(m.tube_stiffness), friction_force=float(m.friction_force),
            friction_per_pa=float(m.friction_area), play_threshold=float(m.play_threshold),
            moving_mass=FILE_MOVING_MASS,
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


