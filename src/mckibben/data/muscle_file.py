"""Muscle files (TOML): read (:func:`read_muscle`) and write (:func:`muscle_file_text_of`) a muscle's
geometry and fitted force law, and check a table against its muscle.

Every problem is an :class:`~mckibben.errors.InputError` with one line that names the file and the
key and what is wrong.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mckibben.atomic import as_path, check_input_file
from mckibben.data.tables import Table
from mckibben.errors import InputError, check_instance
from mckibben.limits import PLAUSIBLE_MIN_LENGTH
from mckibben.units import to_si, units_of



@dataclass(frozen=True)
class MuscleSpec:
    """A muscle as described by its TOML file (SI).

    Only ``id``, the nominal length and the outer diameter are required: a commercial muscle's
    braid angle and strand length are not published (``/work/shared/notes/lab-data.md``). A
    model that needs a missing quantity either fits it within physical bounds or asks for it
    with :meth:`need` (one line naming the key).

    Attributes
    ----------
    id : str
        The muscle's id, e.g. ``"mpam97"``.
    nominal_length : float
        Length at zero gauge pressure and no load, L0. [m]
    strand_length : float or None
        Length of one braid strand, Ls (None: not known). [m]
    outer_diameter : float or None
        Outer diameter at rest (required in a file). [m]
    tube_inner_diameter, tube_outer_diameter, strand_diameter : float or None
        Construction (None: not known). [m]
    braid_angle : float or None
        Braid angle at rest, from the axis (None: not known). [rad]
    notes : str
        Free text.
    synthetic : bool
        Whether the muscle (and its data) are generated, not measured.
    path : str
        The file it was read from.
    force_model : dict or None
        A fitted static force law (``[force_model]`` table written by ``mckibben fit --save``):
        ``model``, ``parameters`` (SI) and ``valid_range``.
    """

    id: str
    nominal_length: float
    strand_length: float | None = None
    outer_diameter: float | None = None
    tube_inner_diameter: float | None = None
    tube_outer_diameter: float | None = None
    strand_diameter: float | None = None
    braid_angle: float | None = None
    notes: str = ""
    synthetic: bool = False
    path: str = ""
    force_model: dict | None = None

    def need(self, quantity: str, model: str) -> float:
        """The value of an optional quantity a model needs, or one line naming the missing key.

        Parameters
        ----------
        quantity : str
            A field name, e.g. ``"strand_length"``. [-]
        model : str
            The model that needs it, for the message. [-]
        """
        value = getattr(self, quantity)
        if value is None:
            unit = "deg" if quantity == "braid_angle" else "mm"
            raise InputError(f"{self.path or self.id}: key {quantity}_<unit> missing; {model} needs it"
                             f" (e.g. {quantity}_{unit} = ...)")
        return float(value)



#: Muscle-file keys: field -> (dimension, required).
MUSCLE_KEYS: dict[str, tuple[str, bool]] = {
    "nominal_length": ("length", True),
    "strand_length": ("length", False),
    "outer_diameter": ("length", True),
    "tube_inner_diameter": ("length", False),
    "tube_outer_diameter": ("length", False),
    "strand_diameter": ("length", False),
    "braid_angle": ("angle", False),
}
#: The largest size a muscle file may give (no braided muscle made is near it: the longest are a few
#: metres, the widest a few centimetres); a larger value is a typo or a unit slip, refused. [m]
MUSCLE_MAX_SIZE = {"nominal_length": 20.0, "strand_length": 20.0, "outer_diameter": 0.5,
                   "tube_inner_diameter": 0.5, "tube_outer_diameter": 0.5, "strand_diameter": 0.5}


def read_muscle(path, needed_by: dict | None = None) -> MuscleSpec:
    """Read a muscle file (TOML): id, lengths and diameters as ``quantity_unit`` keys, notes.

    Parameters
    ----------
    path : str or pathlib.Path
        The TOML file, e.g. ``mpam97.toml`` with ``id = "mpam97"``, ``nominal_length_mm = 97``,
        ``outer_diameter_mm = 1.2`` and optionally ``strand_length_mm``, ``tube_inner_diameter_mm``,
        ``tube_outer_diameter_mm``, ``strand_diameter_mm``, ``braid_angle_deg``, ``notes``,
        ``synthetic`` and a ``[force_model]`` table (a fitted force law, written by
        ``mckibben fit --save``).
    needed_by : dict, optional
        Field -> what reads the file for it (``{"outer_diameter": "tondu-lopez"}``): a missing
        required key's message names it. Default: the file's own ``[force_model]``, if any. [-]

    Returns
    -------
    MuscleSpec
        The muscle in SI.
    """
    name = str(path)
    p = as_path(path, "path", "muscle file")
    check_input_file(p, None, "muscle file")
    try:
        doc = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: not a valid TOML file: {' '.join(str(exc).split())}") from None
    if not isinstance(doc.get("id"), str) or not doc["id"].strip():
        raise InputError(f"{name}: key id: missing; give the muscle an id, e.g. id = \"mpam97\"")
    values: dict = {"id": doc["id"].strip(), "path": name}
    seen = {"id"}
    for key, raw in doc.items():
        if key in ("id",):
            continue
        if key == "notes":
            values["notes"] = str(raw)
            seen.add(key)
            continue
        if key == "force_model":
            values["force_model"] = _force_model_entry(name, raw)
            seen.add(key)
            continue
        if key == "synthetic":
            if not isinstance(raw, bool):
                raise InputError(f"{name}: key synthetic: must be true or false")
            values["synthetic"] = raw
            seen.add(key)
            continue
        quantity, _, unit = key.rpartition("_")
        if quantity == "braid":  # braid_angle_deg splits as braid / angle_deg
            quantity, unit = "braid_angle", key[len("braid_angle_"):]
        if quantity not in MUSCLE_KEYS:
            known = ", ".join([f"{k}_<unit>" for k in MUSCLE_KEYS] + ["id", "notes", "synthetic", "force_model"])
            raise InputError(f"{name}: key {key!r} is unknown; known keys are {known}")
        dim = MUSCLE_KEYS[quantity][0]
        if unit not in units_of(dim):
            raise InputError(f"{name}: key {key}: unknown unit {unit!r} for {quantity}; use one of {', '.join(units_of(dim))}")
        if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw) or raw <= 0:
            raise InputError(f"{name}: key {key}: {raw!r} is not a positive number")
        if quantity in values:
            raise InputError(f"{name}: keys give {quantity} twice; keep one")
        values[quantity] = float(to_si(float(raw), unit, dim))
        if quantity in ("nominal_length", "strand_length") and values[quantity] < PLAUSIBLE_MIN_LENGTH:
            raise InputError(f"{name}: key {key}: {raw!r} is not a plausible length for a braided muscle (at least "
                             f"{PLAUSIBLE_MIN_LENGTH / to_si(1.0, unit, dim):g} {unit})")
        top = MUSCLE_MAX_SIZE.get(quantity)
        if top is not None and not values[quantity] <= top:
            raise InputError(f"{name}: key {key}: {raw!r} is not a plausible size for a braided muscle "
                             f"(at most {to_si(top, 'm', 'length') / to_si(1.0, unit, dim):g} {unit})")
    for quantity, (dim, required) in MUSCLE_KEYS.items():
        if required and quantity not in values:
            law = values["force_model"]["model"] if "force_model" in values else None  # the law that needs it
            needs = (f"; {needed_by[quantity]} needs it" if needed_by and quantity in needed_by
                     else f"; its force law {law} ([force_model]) needs it" if law else "")
            raise InputError(f"{name}: key {quantity}_<unit> missing{needs} (e.g. {quantity}_mm = ...)")
    spec = MuscleSpec(**values)
    if spec.strand_length is not None and spec.strand_length < spec.nominal_length:
        raise InputError(
            f"{name}: key strand_length: {spec.strand_length * 1e3:g} mm is shorter than the nominal length"
            f" {spec.nominal_length * 1e3:g} mm; a braid strand is at least as long as the muscle (eq. 1)"
        )
    if spec.braid_angle is not None and not spec.braid_angle < np.pi / 2:
        raise InputError(f"{name}: key braid_angle: must be below 90 deg")
    if None not in (spec.tube_inner_diameter, spec.tube_outer_diameter) and \
            spec.tube_inner_diameter >= spec.tube_outer_diameter:
        raise InputError(f"{name}: key tube_inner_diameter: must be smaller than tube_outer_diameter")
    return spec


#: Muscle-file keys written from a MuscleSpec: field -> (key, factor from SI).
_KEYS = (("nominal_length", "nominal_length_mm", 1e3), ("outer_diameter", "outer_diameter_mm", 1e3),
         ("strand_length", "strand_length_mm", 1e3), ("tube_inner_diameter", "tube_inner_diameter_mm", 1e3),
         ("tube_outer_diameter", "tube_outer_diameter_mm", 1e3), ("strand_diameter", "strand_diameter_mm", 1e3),
         ("braid_angle", "braid_angle_deg", 180.0 / math.pi))


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(float(v))


def muscle_file_text_of(spec: MuscleSpec, force_model: dict | None = None, note: str = "") -> str:
    """The TOML text of a muscle file: the spec's keys and, optionally, a ``[force_model]`` table.

    The writer of :func:`read_muscle`'s format (what one writes, the other reads back).

    Parameters
    ----------
    spec : MuscleSpec
        The muscle (its known geometry is written as is). [SI]
    force_model : dict, optional
        ``model``, ``parameters`` (name -> value, SI) and optionally ``source``, ``tare``,
        ``flags``, ``rmse_N``, ``r2``, ``valid_range`` (quantity -> (min, max), SI), ``stderr``,
        and any other scalar keys. [-]
    note : str
        Appended to the spec's notes. [-]
    """
    lines = [f"id = {_toml_value(spec.id)}"]
    for field_, key, factor in _KEYS:
        value = getattr(spec, field_)
        if value is not None:
            lines.append(f"{key} = {float(value) * factor:.12g}")
    notes = " ".join(x for x in (spec.notes, note) if x)
    lines.append(f"notes = {_toml_value(notes)}")
    lines.append(f"synthetic = {_toml_value(bool(spec.synthetic))}")
    if force_model is not None:
        fm = dict(force_model)
        lines += ["", "[force_model]", f"model = {_toml_value(fm.pop('model'))}"]
        params, stderr = fm.pop("parameters"), fm.pop("stderr", {})
        valid = fm.pop("valid_range", {})
        for k in ("source", "tare", "flags", "rmse_N", "r2"):
            if k in fm:
                v = fm.pop(k)
                lines.append(f"{k} = {v!r}" if k in ("rmse_N", "r2") else f"{k} = {_toml_value(v)}")
        for k, v in fm.items():
            lines.append(f"{k} = {_toml_value(v)}")
        for q, (lo, hi) in valid.items():
            unit = {"pressure": "Pa", "length": "m", "rest_length": "m"}.get(q, "")
            lines.append(f"valid_{q}_{unit} = [{float(lo)!r}, {float(hi)!r}]")
        lines += ["", "[force_model.parameters]"] + [f"{n} = {float(v)!r}" for n, v in params.items()]
        lines += ["", "[force_model.stderr]"] + [f"{n} = {float(v)!r}" for n, v in stderr.items()]
    return "\n".join(lines) + "\n"


def _force_model_entry(name: str, raw) -> dict:
    """Check a muscle file's ``[force_model]`` table: model name, numeric parameters, range."""
    if not isinstance(raw, dict) or not isinstance(raw.get("model"), str):
        raise InputError(f"{name}: key force_model: must be a table with model = \"<name>\" and [force_model.parameters]")
    params = raw.get("parameters")
    if not isinstance(params, dict) or not params:
        raise InputError(f"{name}: key force_model.parameters: missing; a fitted force law needs its parameters")
    for k, v in params.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"{name}: key force_model.parameters.{k}: {v!r} is not a finite number")
    out = {"model": raw["model"], "parameters": {k: float(v) for k, v in params.items()}}
    for k, v in raw.items():
        if k not in ("model", "parameters"):
            out[k] = v
    return out


def check_muscle(table: Table, muscle: MuscleSpec) -> None:
    """Check that a table belongs to a muscle file; raise naming the first mismatch.

    A ``muscle`` column must hold the muscle file's id, and no length may exceed the strand length
    (eq. 1: l = Ls·cos θ ≤ Ls): a longer one means the data and the muscle file do not match.

    Parameters
    ----------
    table : Table
        A validated table.
    muscle : MuscleSpec
        The muscle file's content.
    """
    check_instance(table, "table", Table, "a Table (read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (read_muscle)")
    d = table.data
    if "muscle" in d and "rest_length" not in d:  # a family table holds several muscles of the file's type
        wrong = np.flatnonzero(d["muscle"].to_numpy() != muscle.id)
        ids = list(dict.fromkeys(d["muscle"].astype(str)))
        if wrong.size and len(ids) > 1 and muscle.id in ids:
            raise InputError(f"{table.where(None, 'muscle')}: holds {len(ids)} muscles ({', '.join(ids[:8])}); pick "
                             f"the one of muscle file {muscle.path or muscle.id} with `select` muscle={muscle.id}")
        if wrong.size:
            r = int(d.index[wrong[0]])
            raise InputError(
                f"{table.where(r, 'muscle')}: {d['muscle'].iloc[wrong[0]]!r} does not match muscle file"
                f" {muscle.path or muscle.id} (id {muscle.id!r})"
            )
    for q in ("length", "held_length"):
        if q not in d or muscle.strand_length is None:
            continue
        over = np.flatnonzero(d[q].to_numpy() > muscle.strand_length)
        if over.size:
            r = int(d.index[over[0]])
            raise InputError(
                f"{table.where(r, q)}: {d[q].iloc[over[0]] * 1e3:g} mm is longer than the strand"
                f" length {muscle.strand_length * 1e3:g} mm of muscle file {muscle.path or muscle.id}"
                f" (id {muscle.id!r}); does the muscle file match the data?"
            )


def muscle_of_table(table: Table) -> MuscleSpec | None:
    """The muscle a table itself describes, when no muscle file is given: one rest length, or None.

    A lab's isometric table often gives each muscle's rest length (``rest_length_mm``) and nothing
    else of it; for one muscle (the table's rows, or those picked with ``select``) that is its
    nominal length L0, all a law like the spring model needs. A law that needs more (the outer
    diameter, the braid angle) asks for it by key (:meth:`MuscleSpec.need`).

    Parameters
    ----------
    table : Table
        A validated table. [-]

    Returns
    -------
    MuscleSpec or None
        ``id`` the table's muscle (or its file name and selection), ``nominal_length`` its rest
        length [m]; None when the table has no rest length or several.
    """
    check_instance(table, "table", Table, "a Table (read_table)")
    d = table.data
    if "rest_length" not in d or np.unique(d["rest_length"].to_numpy()).size != 1:
        return None
    ids = np.unique(d["muscle"].astype(str)) if "muscle" in d else []
    picked = ", ".join(f"{k}={v}" for k, v in table.selected.items())
    name = str(ids[0]) if len(ids) == 1 else Path(table.path).stem + (f" ({picked})" if picked else "")
    return MuscleSpec(id=name, nominal_length=float(d["rest_length"].iloc[0]),
                      notes=f"from the rest length of {table.path} (no muscle file)")


def find_muscle_file(data_path) -> Path | None:
    """The muscle file beside a data file: ``muscle.toml`` in the same folder, if there is one.

    Parameters
    ----------
    data_path : str or pathlib.Path
        A data file or a folder. [-]
    """
    p = as_path(data_path, "data_path")
    folder = p if p.is_dir() else p.parent
    candidate = folder / "muscle.toml"
    return candidate if candidate.is_file() else None
