"""Plant parameters: a frozen dataclass in SI, packed into one float row per instance.

Every parameter may be a scalar or an array of N (one value per simulated instance);
:meth:`PlantParams.pack` broadcasts them to an ``(N, NP)`` float64 array whose columns are named
by the ``I_*`` indices below. ``docs/plant.md`` says how each default was chosen.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from mckibben import hardware as HW
from mckibben.errors import InputError, unknown_name
from mckibben.models.mpam import MiniatureMuscle, predict_length

P_ATM = 101325.0  #: atmospheric pressure [Pa]
R_AIR = 287.05  #: specific gas constant of air [J/(kg·K)]
T0 = 293.15  #: ISO 6358 reference temperature, also the supply temperature [K]
RHO0 = 1.185  #: ISO 6358 reference density of air (ANR, 20 °C, 1 atm) [kg/m³]
G = 9.80665  #: standard gravity [m/s²]

#: Force laws, by name (see :mod:`mckibben.plant.physics`).
FORCE_MODELS = {"calibrated": 0, "tondu-lopez": 0, "chou-hannaford": 1, "empirical": 2}
#: Loads, by name.
LOADS = {"hanging": 0, "blocked": 1, "spring": 2}

_FIELDS = [
    # supply and valves
    "supply_pressure", "supply_droop", "valve_conductance", "bleed_conductance", "critical_ratio",
    "valve_tau", "dead_band", "driver_gain",
    # chamber
    "dead_volume", "leak_conductance", "polytropic_n", "temperature",
    # muscle geometry (volume) and force law
    "nominal_length", "strand_length", "k1", "k2", "outer_diameter", "inner_diameter",
    "force_model", "r0", "alpha0", "k_tl", "p_threshold", "ch_turns",
    "emp_load_lo", "emp_load_hi", "emp_c3_lo", "emp_c2_lo", "emp_c1_lo", "emp_c0_lo",
    "emp_c3_hi", "emp_c2_hi", "emp_c1_hi", "emp_c0_hi",
    "passive_stiffness", "friction_force", "friction_per_pa", "friction_stiffness",
    # load
    "load_kind", "load_force", "moving_mass", "damping", "spring_stiffness", "spring_free_length",
    # sensors
    "adc_zero", "pa_per_count", "encoder_resolution", "pressure_noise", "seed",
]
#: Columns derived from the fields by :meth:`PlantParams.pack` (constants of the hot loop).
_DERIVED = ["tl_a", "tl_b", "sin0", "rho_atm", "inv_valve_tau", "l_straight"]
for _i, _name in enumerate(_FIELDS + _DERIVED):
    globals()[f"I_{_name.upper()}"] = _i
NP = len(_FIELDS) + len(_DERIVED)


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
    Tondu & Lopez (2000), eq. (4); 000_909f662a44080c85.txt, §III.A, eq. (2)–(3), Tables I–II.
    """
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
    r0 = np.sqrt(a1 / (np.pi * (p1 - p_th)))
    return {"r0": float(r0), "k_tl": float(k), "p_threshold": float(p_th), "alpha0": float(a0)}


@dataclass(frozen=True)
class PlantParams:
    """Parameters of the muscle test rig (one instance, or arrays of N).

    Defaults are the paper's rig with the 97 mm muscle (``docs/plant.md`` gives each choice).
    Pressures are gauge unless named otherwise. Use :meth:`for_muscle` for another muscle and
    :func:`dataclasses.replace` (or keyword arguments) to change any parameter.

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
        Polytropic exponent of the air in the chamber (1 isothermal … 1.4 adiabatic). [-]
    temperature : float
        Supply air temperature. [K]
    nominal_length, strand_length, k1, k2 : float
        The muscle: rest length, braid strand length, eq. (2) correction. [m], [m], [-], [m]
    outer_diameter, inner_diameter : float
        Muscle outer diameter and tube lumen diameter at rest. [m]
    force_model : float
        0 calibrated Tondu–Lopez (with threshold), 1 Chou–Hannaford, 2 empirical map. [-]
    r0, alpha0, k_tl, p_threshold : float
        Tondu–Lopez radius, rest braid angle, contraction correction, pressure threshold.
        [m], [rad], [-], [Pa]
    ch_turns : float
        Chou–Hannaford turns of one strand (its strand length is ``strand_length``). [-]
    emp_load_lo, emp_load_hi : float
        Empirical map: the two characterized loads. [N]
    emp_c3_lo … emp_c0_hi : float
        Empirical map: cubic coefficients (P in MPa) at the two loads. [-]
    passive_stiffness : float
        Axial stiffness of the tube stretched beyond its rest length. [N/m]
    friction_force, friction_per_pa : float
        Braid friction (Dahl model) limit: F_c = friction_force + friction_per_pa·P. [N], [N/Pa]
    friction_stiffness : float
        Dahl model rest stiffness σ. [N/m]
    load_kind : float
        0 hanging mass, 1 blocked (isometric), 2 spring. [-]
    load_force : float
        Hanging weight (hanging) or the spring's preload at the rest length. [N]
    moving_mass : float
        Pulley, belt and muscle end (the hanging mass is added to it). [kg]
    damping : float
        Viscous damping of the moving parts. [N·s/m]
    spring_stiffness, spring_free_length : float
        Spring load: stiffness and the muscle length at which it is relaxed. [N/m], [m]
    adc_zero, pa_per_count : float
        Pressure transducer and 10-bit ADC: count = P/pa_per_count + adc_zero. [-], [Pa]
    encoder_resolution : float
        Belt travel per encoder count (500 counts per pulley turn). [m]
    pressure_noise : float
        Standard deviation of the transducer noise (0: none). [Pa]
    seed : float
        Seed of the instance's noise generator. [-]
    """

    supply_pressure: object = 0.8e6
    supply_droop: object = 0.0
    valve_conductance: object = 2.0e-10
    bleed_conductance: object = 2.0e-10
    critical_ratio: object = 0.3
    valve_tau: object = 3e-3
    dead_band: object = 0.63
    driver_gain: object = 1.43
    dead_volume: object = 3.0e-7
    leak_conductance: object = 2.0e-11
    polytropic_n: object = 1.2
    temperature: object = T0
    nominal_length: object = 0.097
    strand_length: object = 0.112
    k1: object = 0.92
    k2: object = 0.77e-3
    outer_diameter: object = 1.2e-3
    inner_diameter: object = 0.5e-3
    force_model: object = 0.0
    r0: object = 0.0
    alpha0: object = float(np.deg2rad(20.0))
    k_tl: object = 1.0
    p_threshold: object = 0.0
    ch_turns: object = 0.0
    emp_load_lo: object = 0.6
    emp_load_hi: object = 2.1
    emp_c3_lo: object = -0.6
    emp_c2_lo: object = 0.9
    emp_c1_lo: object = -0.71
    emp_c0_lo: object = 1.05
    emp_c3_hi: object = -0.1
    emp_c2_hi: object = 0.1
    emp_c1_hi: object = -0.06
    emp_c0_hi: object = 0.94
    passive_stiffness: object = 200.0
    friction_force: object = 0.01
    friction_per_pa: object = 0.2e-6
    friction_stiffness: object = 2000.0
    load_kind: object = 0.0
    load_force: object = 0.6
    moving_mass: object = 0.005
    damping: object = 4.0
    spring_stiffness: object = 0.0
    spring_free_length: object = 0.097
    adc_zero: object = 0.0
    pa_per_count: object = HW.PA_PER_COUNT
    encoder_resolution: object = HW.ENCODER_RESOLUTION
    pressure_noise: object = 0.0
    seed: object = 0.0
    muscle_name: str = field(default="mpam97", compare=False)

    def __post_init__(self):
        if self.muscle_name and np.all(np.asarray(self.r0) == 0):
            from mckibben.datasets import get_muscle

            cal = calibrate_force_law(get_muscle(self.muscle_name))
            for key, value in cal.items():
                object.__setattr__(self, key, value)
        if np.all(np.asarray(self.ch_turns) == 0):
            # Chou–Hannaford turns from the rest geometry: D = b·sin θ0/(n·π) at l0 = b·cos θ0
            b = np.asarray(self.strand_length, dtype=float)
            c0 = np.clip(np.asarray(self.nominal_length, dtype=float) / b, 0.0, 1.0)
            d = np.asarray(self.outer_diameter, dtype=float) - 0.1e-3
            object.__setattr__(self, "ch_turns", b * np.sqrt(1 - c0**2) / (np.pi * d))

    @classmethod
    def for_muscle(cls, muscle: MiniatureMuscle, **kwargs) -> "PlantParams":
        """Plant with a published (or fitted) miniature muscle, its force law calibrated.

        Parameters
        ----------
        muscle : MiniatureMuscle
            The muscle (two characterized loads needed for the empirical force law).
        **kwargs
            Any other :class:`PlantParams` field. [SI]
        """
        bm = muscle.braid_map
        emp = {}
        if len(bm.loads) >= 2:
            (c_lo, c_hi) = bm.coefficients[0], bm.coefficients[-1]
            emp = dict(
                emp_load_lo=bm.loads[0], emp_load_hi=bm.loads[-1],
                emp_c3_lo=c_lo[0], emp_c2_lo=c_lo[1], emp_c1_lo=c_lo[2], emp_c0_lo=c_lo[3],
                emp_c3_hi=c_hi[0], emp_c2_hi=c_hi[1], emp_c1_hi=c_hi[2], emp_c0_hi=c_hi[3],
            )
        base = dict(
            nominal_length=muscle.nominal_length, strand_length=muscle.strand_length,
            k1=muscle.k1, k2=muscle.k2, outer_diameter=muscle.geometry.outer_diameter,
            inner_diameter=muscle.geometry.tube_inner_diameter, spring_free_length=muscle.nominal_length,
            muscle_name="", **emp, **calibrate_force_law(muscle),
        )
        base.update(kwargs)
        return cls(**base)

    def replace(self, **kwargs) -> "PlantParams":
        """A copy with some fields changed (named loads and force models accepted).

        Parameters
        ----------
        **kwargs
            Fields of :class:`PlantParams`; ``force_model`` and ``load_kind`` may be names. [SI]
        """
        if isinstance(kwargs.get("force_model"), str):
            name = kwargs["force_model"]
            if name not in FORCE_MODELS:
                raise unknown_name("force model", name, FORCE_MODELS)
            kwargs["force_model"] = float(FORCE_MODELS[name])
        if isinstance(kwargs.get("load_kind"), str):
            name = kwargs["load_kind"]
            if name not in LOADS:
                raise unknown_name("load", name, LOADS)
            kwargs["load_kind"] = float(LOADS[name])
        bad = [k for k in kwargs if k not in _FIELDS and k != "muscle_name"]
        if bad:
            raise unknown_name("plant parameter", bad[0], _FIELDS)
        return dataclasses.replace(self, **kwargs)

    def size(self) -> int:
        """N, the number of instances the array-valued fields describe (1 if all scalars)."""
        sizes = {np.size(getattr(self, f)) for f in _FIELDS} - {1}
        if len(sizes) > 1:
            raise InputError(f"plant parameters: arrays of different lengths {sorted(sizes)}")
        return sizes.pop() if sizes else 1

    def pack(self, n: int | None = None) -> np.ndarray:
        """The ``(N, NP)`` float64 parameter array, validated.

        Parameters
        ----------
        n : int, optional
            Number of instances (scalars are repeated); default :meth:`size`.
        """
        n = self.size() if n is None else int(n)
        if n != self.size() and self.size() != 1:
            raise InputError(f"plant parameters have {self.size()} instances, {n} were asked for")
        out = np.empty((n, NP))
        for j, name in enumerate(_FIELDS):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.ndim > 1:
                raise InputError(f"plant parameter {name}: scalar or 1-D array, got shape {value.shape}")
            out[:, j] = np.broadcast_to(value.ravel() if value.ndim else value, (n,))
        validate(out)
        derive(out)
        return out


def derive(p: np.ndarray) -> None:
    """Fill the derived columns of packed, validated parameters (in place).

    Parameters
    ----------
    p : numpy.ndarray
        Packed ``(N, NP)`` parameters.
    """
    a0 = p[:, I_ALPHA0]
    p[:, I_TL_A] = 3.0 / np.tan(a0) ** 2
    p[:, I_TL_B] = 1.0 / np.sin(a0) ** 2
    c0 = np.clip((p[:, I_NOMINAL_LENGTH] - p[:, I_K2]) / (p[:, I_K1] * p[:, I_STRAND_LENGTH]), 0.05, 0.9999)
    p[:, I_SIN0] = np.sqrt(1.0 - c0**2)
    p[:, I_RHO_ATM] = P_ATM / (R_AIR * p[:, I_TEMPERATURE])
    p[:, I_INV_VALVE_TAU] = 1.0 / p[:, I_VALVE_TAU]
    p[:, I_L_STRAIGHT] = p[:, I_K1] * p[:, I_STRAND_LENGTH] + p[:, I_K2]


def validate(p: np.ndarray) -> None:
    """Refuse physically wrong parameter rows with one line naming the parameter and instance.

    Parameters
    ----------
    p : numpy.ndarray
        Packed ``(N, NP)`` parameters.
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
    check(col["supply_pressure"] <= 1.0e6, "supply_pressure", "the compressor gives at most 1 MPa")
    check((col["supply_droop"] >= 0) & (col["supply_droop"] < 1), "supply_droop", "must be in [0, 1)")
    for name in ("valve_conductance", "bleed_conductance", "leak_conductance", "friction_force", "friction_per_pa",
                 "passive_stiffness", "damping", "spring_stiffness", "pressure_noise", "p_threshold"):
        check(col[name] >= 0, name, "must be >= 0")
    check((col["critical_ratio"] > 0) & (col["critical_ratio"] < 1), "critical_ratio", "must be in (0, 1)")
    check(col["valve_tau"] > 0, "valve_tau", "must be > 0")
    check((col["dead_band"] >= 0) & (col["dead_band"] < 1), "dead_band", "must be in [0, 1)")
    check(col["driver_gain"] > 0, "driver_gain", "must be > 0")
    check(col["dead_volume"] > 0, "dead_volume", "a volume must be > 0")
    check((col["polytropic_n"] >= 1) & (col["polytropic_n"] <= 1.4), "polytropic_n", "must be in [1, 1.4]")
    check(col["temperature"] > 0, "temperature", "must be > 0 K")
    for name in ("nominal_length", "strand_length", "outer_diameter", "inner_diameter", "k1", "moving_mass",
                 "pa_per_count", "encoder_resolution", "friction_stiffness", "r0"):
        check(col[name] > 0, name, "must be > 0")
    check(col["nominal_length"] < col["strand_length"] * col["k1"] + col["k2"], "nominal_length",
          "must be shorter than the straightened braid k1·Ls + k2")
    check(col["inner_diameter"] < col["outer_diameter"], "inner_diameter", "must be below the outer diameter")
    check((col["alpha0"] > 0) & (col["alpha0"] < np.pi / 2), "alpha0", "must be in (0, 90°)")
    check(np.isin(col["force_model"], [0, 1, 2]), "force_model", "must be 0, 1 or 2 (see FORCE_MODELS)")
    check(np.isin(col["load_kind"], [0, 1, 2]), "load_kind", "must be 0, 1 or 2 (see LOADS)")
    check(col["load_force"] >= 0, "load_force", "a hanging weight must be >= 0")
    check(col["emp_load_hi"] > col["emp_load_lo"], "emp_load_hi", "must exceed emp_load_lo")


def field_names() -> list[str]:
    """The packed parameter columns, in order."""
    return list(_FIELDS)
