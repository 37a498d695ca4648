"""A sweep description (TOML): parameters with grids or distributions, a scenario, metrics, seed.

```toml
[sweep]
seed = 1            # all random draws follow from it
samples = 20        # random plants drawn per grid point
chunk_size = 500    # instances per batch call of the simulator

[scenario]
kind = "step"       # "step" (to `target`) or "sine" (mean ± amplitude at frequency)
target = "0.55MPa"
duration = "0.4s"

[plant]             # any PlantParams field, or `muscle` (a published set's name)
supply_pressure = { uniform = ["0.6MPa", "1.0MPa"] }
load_force = { uniform = ["0N", "3N"] }
dead_band = { normal = [0.63, 0.03] }

[controller]        # kind = "smc" or "pid", and any CoreParams gain (g = 0: the paper's law)
kind = "smc"
g = 0
beta = { grid = [120, 150, 180] }
eps = "50kPa"

[metrics]
keep = ["time_constant_s", "overshoot_pct", "steady_state_error_Pa", "valve_effort_counts"]
```

A value is a constant (a number, or a string with a unit), ``{grid = [...]}`` (every value, in
the cartesian product of all grids), ``{uniform = [lo, hi]}``, ``{normal = [mean, sd]}``,
``{lognormal = [median, sigma]}`` or ``{choice = [...]}`` (a draw per sample).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import dataclasses
import hashlib
import itertools
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mckibben.control import registry as R
from mckibben.errors import InputError, unknown_name
from mckibben.units import parse_quantity
from mckibben.datasets import get_muscle
from mckibben.limits import PLAUSIBLE_MAX
from mckibben.hardware import P_MAX_DEFAULT, P_MAX_LIMIT
from mckibben.atomic import as_path, check_input_file
from mckibben.control.core import CoreParams, core_spec
from mckibben.plant.params import PlantParams

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pandas as pd

#: Plant fields a sweep may set, with the dimension of a value given with a unit.
PLANT_FIELDS = {
    "supply_pressure": "pressure", "supply_droop": "dimensionless", "valve_conductance": None,
    "bleed_conductance": None, "critical_ratio": "dimensionless", "valve_tau": "time",
    "dead_band": "dimensionless", "driver_gain": "dimensionless", "dead_volume": None,
    "leak_conductance": None, "polytropic_n": "dimensionless", "friction_per_pa": None,
    "load_force": "force", "damping": None, "pressure_noise": "pressure", "muscle": "name",
}
#: Controller gains a sweep may set (CoreParams fields), with their dimension.
#: Dimension of a gain's value by its unit, as a sweep parses it (None: a plain number).
_DIMENSION_OF_UNIT = {"PWM counts": "dimensionless", "Pa": "pressure", "1/s": "frequency", "s": "time"}
#: Every registered controller's gains (:mod:`mckibben.control.registry`), the maximum pressure and
#: the overpressure margin.
CONTROLLER_FIELDS = {
    **{g.param: _DIMENSION_OF_UNIT.get(g.unit) for c in R.CONTROLLERS.values() for g in c.gains if g.id < 12},
    "p_max": "pressure", "margin": "pressure",
    **{g.param: _DIMENSION_OF_UNIT.get(g.unit) for c in R.CONTROLLERS.values() for g in c.gains if g.id > 12},
}
#: Controller kinds (:data:`mckibben.control.registry.NAMES`).
CONTROLLER_KINDS = R.NAMES
SCENARIOS = ("step", "sine")
METRICS = ("time_constant_s", "rise_time_s", "settling_time_s", "overshoot_pct", "steady_state_error_Pa",
           "valve_effort_counts", "rms_error_Pa", "max_pressure_Pa")
DISTRIBUTIONS = ("grid", "uniform", "normal", "lognormal", "choice")
#: The controller's fields (what :func:`_check_ranges` packs).
_CORE_FIELDS = frozenset(f.name for f in dataclasses.fields(CoreParams))
#: Largest spread (standard deviation of the logarithm) of a lognormal distribution. [-]
MAX_LOG_SPREAD = 3.0
#: Shortest step scenario: the step at 10 ms and 10 ms of response for its metrics. [s]
MIN_STEP_DURATION = 0.02
#: Fewest control periods per cycle of a sine scenario (its frequency's ceiling). [-]
SAMPLES_PER_CYCLE = 20


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: its design table and how to run it."""

    path: str
    sha256: str
    seed: int
    samples: int
    chunk_size: int
    scenario: dict
    controller_kind: str
    metrics: tuple[str, ...]
    grid_names: tuple[str, ...]
    design: pd.DataFrame = field(repr=False)  # one row per simulation: run_id, grid_id, parameters

    @property
    def n_runs(self) -> int:
        """Number of simulations."""
        return len(self.design)

    @property
    def n_chunks(self) -> int:
        """Number of chunks."""
        return math.ceil(self.n_runs / self.chunk_size)

    def chunk(self, k: int) -> pd.DataFrame:
        """Rows of chunk k.

        Parameters
        ----------
        k : int
            Chunk index. [-]
        """
        return self.design.iloc[k * self.chunk_size:(k + 1) * self.chunk_size]


def _value(raw, dim, where):
    if dim == "name":
        if not isinstance(raw, str):
            raise InputError(f"{where}: a muscle name is wanted, got {raw!r}")

        get_muscle(raw)  # raises with close matches
        return raw
    if isinstance(raw, bool):
        raise InputError(f"{where}: {raw!r} is not a number")
    if isinstance(raw, (int, float)):
        if not math.isfinite(raw):
            raise InputError(f"{where}: {raw!r} is not finite")
        return float(raw)
    if isinstance(raw, str):
        if dim is None:
            raise InputError(f"{where}: {raw!r} — give this parameter as a plain number in SI")
        return parse_quantity(raw, dim, where, allow_negative=True)
    raise InputError(f"{where}: {raw!r} is neither a number nor a quantity with a unit")


def _parse_param(name, raw, dim, where):
    """-> ("const", v) | ("grid", [v...]) | (dist, (a, b)) | ("choice", [v...])"""
    if isinstance(raw, dict):
        if len(raw) != 1:
            raise InputError(f"{where}: one of {', '.join(DISTRIBUTIONS)} per parameter, got {sorted(raw)}")
        (kind, args), = raw.items()
        if kind not in DISTRIBUTIONS:
            raise unknown_name(f"distribution in {where}", kind, DISTRIBUTIONS)
        if not isinstance(args, list):
            raise InputError(f"{where}: {kind} takes a list, got {args!r}")
        if kind in ("grid", "choice"):
            if not args:
                raise InputError(f"{where}: empty {kind}")
            return kind, [_value(a, dim, where) for a in args]
        if dim == "name":
            raise InputError(f"{where}: a muscle takes a grid or a choice, not {kind}")
        if len(args) != 2:
            raise InputError(f"{where}: {kind} takes two values [{'lo, hi' if kind == 'uniform' else 'centre, spread'}]")
        a, b = (_value(x, dim, where) for x in args)
        if kind == "uniform" and not b > a:
            raise InputError(f"{where}: uniform needs lo < hi, got [{a:g}, {b:g}]")
        if kind in ("normal", "lognormal") and not b > 0:
            raise InputError(f"{where}: {kind} needs a spread > 0, got {b:g}")
        if kind == "lognormal" and not a > 0:
            raise InputError(f"{where}: lognormal needs a median > 0, got {a:g}")
        if kind == "lognormal" and b > MAX_LOG_SPREAD:
            raise InputError(f"{where}: lognormal spread {b:g} is past {MAX_LOG_SPREAD:g} (the standard deviation of "
                             f"the logarithm: 3 draws values up to e^12 ≈ 1.6e5 times the median); give a smaller one")
        return kind, (a, b)
    return "const", _value(raw, dim, where)


def _check_design(path, params: dict, cols: dict) -> None:
    """Refuse a design whose drawn values leave the plausible range of their quantity
    (:data:`mckibben.limits.PLAUSIBLE_MAX`) or turn negative where the quantity cannot: a load of
    1e278 N would otherwise be simulated, and fail (or pass) in the middle of the run."""

    for name in params:
        section, field_ = name.split(".", 1)
        dim = (PLANT_FIELDS if section == "plant" else CONTROLLER_FIELDS).get(field_)
        if dim == "name":
            continue
        values = np.asarray(cols[name], dtype=float)
        if not values.size:
            continue
        limit = PLAUSIBLE_MAX.get(dim) if dim is not None else None
        worst = float(np.max(np.abs(values)))
        if not np.all(np.isfinite(values)) or (limit is not None and worst > limit):
            raise InputError(f"{path} [{section}] {field_}: draws values up to {worst:g} (SI), past the plausible "
                             f"{limit if limit is not None else 'finite'} of a {dim or 'value'}; narrow its distribution")


def _check_ranges(path, cols: dict, controller_kind: str) -> None:
    """Refuse, before any run, a swept value the plant or the controller would refuse in the middle.

    The plant's :func:`~mckibben.plant.packing.validate` and the controller's packing
    (:func:`~mckibben.control.core.core_spec`) check each field's range on its own; they are run
    here on two instances holding every swept field's smallest and largest drawn value, so a
    negative conductance or gain is named now, not by a worker after hours."""

    ends = {name: np.array([np.min(v), np.max(v)], dtype=float) for name, v in cols.items()
            if name.startswith(("plant.", "controller.")) and name != "plant.muscle"}
    plant = {name[6:]: v for name, v in ends.items() if name.startswith("plant.")}
    ctrl = {name[11:]: v for name, v in ends.items() if name.startswith("controller.") and name[11:] in _CORE_FIELDS}
    try:
        if plant:
            PlantParams(**plant).pack()
        ctrl["mode"] = np.full(2, float(R.get(controller_kind).mode))
        core_spec(ctrl)
    except InputError as exc:
        section = "plant" if str(exc).startswith("plant") else "controller"
        raise InputError(f"{path} [{section}]: {exc}") from None


def _check_scenario_pressures(path, scenario: dict, params: dict) -> None:
    """Refuse a scenario whose reference leaves [0, p_max]: the supervisor would clamp it and the
    metrics would be scored against a pressure never commanded."""

    kind_, args = params.get("controller.p_max", ("const", float(P_MAX_DEFAULT)))
    if kind_ == "const":
        cap, what = float(args), "the controller's p_max"
    elif kind_ in ("grid", "choice"):
        cap, what = float(min(args)), "the smallest controller p_max"
    else:
        cap, what = float(P_MAX_LIMIT), "the supervisor's ceiling"
    if scenario["kind"] == "step":
        checks = [("target", scenario["target"]), ("start", scenario["start"])]
    else:
        checks = [("mean + amplitude", scenario["mean"] + scenario["amplitude"])]
        if scenario["mean"] - scenario["amplitude"] < 0:
            raise InputError(f"{path} [scenario] mean - amplitude: {(scenario['mean'] - scenario['amplitude']) / 1e6:g}"
                             " MPa is below 0 gauge; the supervisor would clamp the reference")
    for key, value in checks:
        if value > cap:
            raise InputError(f"{path} [scenario] {key}: {value / 1e6:g} MPa is above {what} ({cap / 1e6:g} MPa); "
                             "the supervisor would clamp the reference")


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file and expand it into its design table.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    Sweep
        The sweep with one design row per simulation.
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    path = check_input_file(as_path(path, "path", "sweep file"), None, "sweep file")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the sweep file ({exc.strerror})") from None
    try:
        doc = tomllib.loads(data.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    sections = ("sweep", "scenario", "plant", "controller", "metrics")
    for key in doc:
        if key not in sections:
            raise unknown_name(f"section in {path}", key, sections)
    sw = doc.get("sweep", {})
    for key in sw:
        if key not in ("seed", "samples", "chunk_size", "name"):
            raise unknown_name(f"key in {path} [sweep]", key, ("seed", "samples", "chunk_size", "name"))

    def whole(key, default, lo):
        v = sw.get(key, default)
        if not isinstance(v, int) or isinstance(v, bool) or v < lo:
            raise InputError(f"{path} [sweep] {key}: a whole number >= {lo}, got {v!r}")
        return v

    seed, samples, chunk = whole("seed", 0, 0), whole("samples", 1, 1), whole("chunk_size", 500, 1)

    sc = dict(doc.get("scenario", {}))
    kind = sc.pop("kind", "step")
    if kind not in SCENARIOS:
        raise unknown_name(f"scenario in {path}", kind, SCENARIOS)
    allowed = {"step": ("target", "duration", "start"), "sine": ("mean", "amplitude", "frequency", "duration")}[kind]
    for key in sc:
        if key not in allowed:
            raise unknown_name(f"key in {path} [scenario] ({kind})", key, allowed)
    dims = {"target": "pressure", "start": "pressure", "mean": "pressure", "amplitude": "pressure",
            "frequency": "frequency", "duration": "time"}
    defaults = {"target": "0.55MPa", "start": "0MPa", "mean": "0.4MPa", "amplitude": "0.1MPa",
                "frequency": "2Hz", "duration": "0.4s"}
    scenario = {"kind": kind}
    for key in allowed:
        scenario[key] = parse_quantity(str(sc.get(key, defaults[key])), dims[key], f"{path} [scenario] {key}")
    if not 0 < scenario["duration"] <= 10:
        raise InputError(f"{path} [scenario] duration: must be in (0, 10] s")
    if abs(scenario["duration"] * 1000 - round(scenario["duration"] * 1000)) > 1e-6:
        raise InputError(f"{path} [scenario] duration: a whole number of 1 ms control periods")
    if kind == "step" and scenario["duration"] < MIN_STEP_DURATION:
        raise InputError(f"{path} [scenario] duration: {scenario['duration']:g} s is too short for the step metrics; the "
                         f"step comes at 10 ms and they need at least {MIN_STEP_DURATION:g} s")
    if kind == "sine":
        f_max = 1.0 / (SAMPLES_PER_CYCLE * 1e-3)
        if scenario["frequency"] > f_max:
            raise InputError(f"{path} [scenario] frequency: {scenario['frequency']:g} Hz is past {f_max:g} Hz: the 1 ms "
                             f"control period samples a cycle fewer than {SAMPLES_PER_CYCLE} times (the sine aliases)")
        if scenario["duration"] * scenario["frequency"] < 1.0:
            raise InputError(f"{path} [scenario] duration: {scenario['duration']:g} s is shorter than one cycle of "
                             f"{scenario['frequency']:g} Hz; the tracking metrics need a whole cycle")

    ctrl = dict(doc.get("controller", {}))
    ckind = ctrl.pop("kind", "smc")
    if ckind not in CONTROLLER_KINDS:
        raise unknown_name(f"controller kind in {path}", ckind, CONTROLLER_KINDS)

    params = {}
    for section, fields_, raw in (("plant", PLANT_FIELDS, doc.get("plant", {})), ("controller", CONTROLLER_FIELDS, ctrl)):
        for name, value in raw.items():
            if name not in fields_:
                raise unknown_name(f"{section} parameter in {path}", name, fields_)
            params[f"{section}.{name}"] = _parse_param(name, value, fields_[name], f"{path} [{section}] {name}")

    _check_scenario_pressures(path, scenario, params)

    mt = doc.get("metrics", {})
    keep = mt.get("keep", list(METRICS[:6]))
    if not isinstance(keep, list) or not keep:
        raise InputError(f"{path} [metrics] keep: a non-empty list of metric names")
    for m in keep:
        if m not in METRICS:
            raise unknown_name(f"metric in {path}", m, METRICS)

    if not doc:
        raise InputError(f"{path}: the sweep file is empty; it names the parameters to vary (a grid or a "
                         f"distribution) in [plant] or [controller] (`mckibben examples copy sweep.toml` has one)")
    if samples == 1 and all(kind_ == "const" for kind_, _ in params.values()):
        raise InputError(f"{path}: nothing varies (one sample, every parameter fixed); give a [plant] or "
                         f"[controller] parameter a grid or a distribution ({', '.join(DISTRIBUTIONS)}), or "
                         f"[sweep] samples > 1")
    grid_names = tuple(k for k, (kind_, _) in params.items() if kind_ == "grid")
    grids = [params[k][1] for k in grid_names]
    points = list(itertools.product(*grids)) if grids else [()]
    n = len(points) * samples
    if n > 5_000_000:
        raise InputError(f"{path}: {n} simulations is more than the 5,000,000 a sweep may hold")
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    cols: dict[str, object] = {"run_id": np.arange(n), "grid_id": np.repeat(np.arange(len(points)), samples)}
    for j, name in enumerate(grid_names):
        cols[name] = np.repeat([pt[j] for pt in points], samples)
    for name, (kind_, args) in params.items():
        if kind_ == "grid":
            continue
        if kind_ == "const":
            cols[name] = [args] * n if isinstance(args, str) else np.full(n, args)
        elif kind_ == "uniform":
            cols[name] = rng.uniform(args[0], args[1], n)
        elif kind_ == "normal":
            cols[name] = rng.normal(args[0], args[1], n)
        elif kind_ == "lognormal":
            cols[name] = args[0] * np.exp(rng.normal(0.0, args[1], n))
        else:  # choice
            cols[name] = [args[i] for i in rng.integers(0, len(args), n)]
    _check_design(path, params, cols)
    _check_ranges(path, cols, ckind)
    cols["noise_seed"] = rng.integers(0, 2**31 - 1, n)
    return Sweep(str(path), hashlib.sha256(data).hexdigest(), seed, samples, chunk, scenario, ckind, tuple(keep),
                 grid_names, pd.DataFrame(cols))
