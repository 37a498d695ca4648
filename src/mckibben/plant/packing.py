"""The plant's packed parameter rows: the column layout, the derived constants, the checks.

A :class:`~mckibben.plant.params.PlantParams` is packed (:meth:`~mckibben.plant.params.PlantParams.pack`)
into one float64 row per instance whose columns are the members of :class:`Col`: first the fields
(:func:`field_names`), then the constants of the hot loop :func:`derive_columns` fills. :func:`validate`
refuses a physically wrong row and :func:`check_force_law` a force law the integrator cannot run,
each naming the parameter or the range. The air's constants the chamber and the packing use are
here too. The compiled kernels (:mod:`mckibben.plant.physics`), the C layout
(:mod:`mckibben.plant.c_layout`) and the FMU read this module, not the dataclass.
"""

from __future__ import annotations

import enum

import numpy as np

from mckibben import hardware as HW
from mckibben.errors import InputError
from mckibben.limits import PLAUSIBLE_MAX
from mckibben.units import P_ATM  # noqa: F401  (the plant's atmosphere: PK.P_ATM in the kernels)
from mckibben.models import laws as LW
from mckibben.models.mpam import braid_end_stops

#: The plant's force models, by the name ``PlantParams(force_model=...)`` takes -> the registry's law
#: name: the registry's names and old aliases (:mod:`mckibben.models.laws`, the one vocabulary), plus
#: ``calibrated``: Tondu–Lopez with the plant's calibrated columns.
FORCE_MODELS = {"calibrated": "tondu-lopez", **{n: n for n in LW.LAW_NAMES}, **LW.ALIASES}

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
#: Chamber thermodynamics, by name.
THERMAL = ("energy", "polytropic")


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
    "passive_stiffness", "friction_force", "friction_per_pa", "friction_stiffness", "play_threshold",
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


#: Largest rest braid angle of the Tondu–Lopez law: at arccos(1/√3) ≈ 54.7° (the locking angle)
#: a braid pulls nothing, so a = 3/tan²α0 > b = 1/sin²α0 needs α0 below it. [rad]
ALPHA0_MAX = float(np.arccos(1.0 / np.sqrt(3.0)))


def derive_columns(p: np.ndarray, thermal: str = "energy") -> None:
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
    p[:, c.l_min], p[:, c.l_max] = braid_end_stops(p[:, c.strand_length], p[:, c.k1], p[:, c.k2])
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
                 "heat_transfer_coefficient", "wall_thickness", "play_threshold"):
        check(col[name] >= 0, name, "must be >= 0")
    check(col["play_threshold"] < HW.P_MAX_LIMIT, "play_threshold",
          "a play on the pressure must be narrower than the compressor's 1 MPa (a unit slip?)")
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
    locking, straight = braid_end_stops(col["strand_length"], col["k1"], col["k2"])
    check(col["nominal_length"] < straight, "nominal_length", "must be shorter than the straightened braid k1·Ls + k2")
    check(col["nominal_length"] > locking, "nominal_length",
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

def field_names() -> list[str]:
    """The packed parameter columns set from fields, in order."""
    return list(_FIELDS)
