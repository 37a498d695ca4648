"""Plants for the closed-loop runs: the calibrated rig as a batch, its parameters, and random plants.

:func:`plant_batch` (the calibrated plant with some fields changed, one value or one per
instance), :func:`to_plant_params` (what the simulator takes from a batch or a
:class:`~mckibben.plant.PlantParams`), and :func:`sample_plants` (the robustness study's uncertain
plants: ±30 % on :data:`UNCERTAIN_FACTORS`, random supply and load).
"""

from __future__ import annotations

import numpy as np

from mckibben.errors import InputError, unknown_name
from mckibben.plant import PlantParams


def plant_batch(**kwargs) -> dict:
    """Plant description for :func:`run_closed_loop`, checked; :func:`to_plant_params` builds it.

    Parameters
    ----------
    **kwargs
        ``load_N`` (hanging load) [N], ``supply_Pa`` (supply, gauge) [Pa], and multiplicative
        factors on the calibrated plant (1 = calibrated) [-]: ``valve_gain`` (sonic conductance
        of both valves), ``dead_band``, ``volume`` (the tube lumen at rest), ``dead_volume``,
        ``leak``. Scalars or arrays of N.

    Returns
    -------
    dict
        The keyword arguments, as float arrays.
    """
    allowed = ("load_N", "supply_Pa") + UNCERTAIN_FACTORS
    out = {}
    for key, value in kwargs.items():
        if key not in allowed:
            raise unknown_name("plant factor", key, allowed)
        a = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(a)):
            raise InputError(f"plant {key}: must be finite")
        if key == "load_N" and np.any(a < 0):
            raise InputError(f"plant load_N: {a.min():g} N, a hanging load cannot be negative")
        if key != "load_N" and np.any(a <= 0):
            raise InputError(f"plant {key}: {a.min():g}, must be positive")
        out[key] = a
    return out


def to_plant_params(plant=None, base=None):
    """:class:`~mckibben.plant.PlantParams` from a :func:`plant_batch` dict (or pass one through).

    The factors scale the calibrated default plant: ``valve_gain`` both valves' sonic
    conductance, ``dead_band`` the valves' dead band, ``volume`` the lumen (the tube's inner
    diameter by its square root, so the rest lumen volume scales by the factor), ``dead_volume``
    the tubing volume, ``leak`` the leak conductance.

    Parameters
    ----------
    plant : dict or PlantParams or None
        None: the calibrated default plant. [-]
    base : PlantParams, optional
        The plant the factors scale; default the calibrated one. [-]

    Returns
    -------
    PlantParams
    """

    if plant is None:
        return PlantParams() if base is None else base
    if isinstance(plant, PlantParams):
        return plant
    f = plant_batch(**plant)
    base = PlantParams() if base is None else base
    kw = {}
    if "valve_gain" in f:
        kw["valve_conductance"] = base.valve_conductance * f["valve_gain"]
        kw["bleed_conductance"] = base.bleed_conductance * f["valve_gain"]
    if "dead_band" in f:
        kw["dead_band"] = np.minimum(base.dead_band * f["dead_band"], 0.95)
    if "volume" in f:
        kw["inner_diameter"] = base.inner_diameter * np.sqrt(f["volume"])
    if "dead_volume" in f:
        kw["dead_volume"] = base.dead_volume * f["dead_volume"]
    if "leak" in f:
        kw["leak_conductance"] = base.leak_conductance * f["leak"]
    if "supply_Pa" in f:
        kw["supply_pressure"] = f["supply_Pa"]
    if "load_N" in f:
        kw["load_force"] = f["load_N"]
    kw = {k: (float(v) if np.ndim(v) == 0 else v) for k, v in kw.items()}
    return base.replace(**kw) if kw else base


#: Uncertainty of the robustness study: multiplicative ±30 % (uniform) on these plant factors.
UNCERTAIN_FACTORS = ("valve_gain", "dead_band", "volume", "dead_volume", "leak")


def sample_plants(n: int, seed: int = 0, spread: float = 0.3, supply=(0.6e6, 1.0e6), load=(0.0, 3.0)) -> dict:
    """Random plants around the calibrated one (uniform distributions).

    Parameters
    ----------
    n : int
        Number of plants. [-]
    seed : int, default 0
        Random seed. [-]
    spread : float, default 0.3
        Half-width of the multiplicative factors. [-]
    supply : tuple of float, default (0.6e6, 1.0e6)
        Supply pressure range. [Pa]
    load : tuple of float, default (0, 3)
        Hanging load range. [N]

    Returns
    -------
    dict of str to numpy.ndarray
        :func:`plant_batch` keyword arguments, arrays of n.
    """
    if int(n) < 1:
        raise InputError(f"n: {n!r} must be at least 1")
    rng = np.random.default_rng(seed)
    out = {k: rng.uniform(1 - spread, 1 + spread, n) for k in UNCERTAIN_FACTORS}
    out["supply_Pa"] = rng.uniform(*supply, n)
    out["load_N"] = rng.uniform(*load, n)
    return out
