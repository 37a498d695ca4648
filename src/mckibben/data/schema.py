"""Table schemas: the experiment kinds a characterization lab records, and their columns.

A table is one experiment: a CSV or Parquet file whose numeric columns are named
``quantity_unit`` (``pressure_MPa``, ``load_g``, ``length_mm``) and whose text columns have bare
names (``direction``, ``muscle``). The units are those of :data:`mckibben.units.UNITS`; a load may
also be given as a hanging mass (``load_g``, ``load_kg``), taken times standard gravity.

Kinds (see ``docs/data.md`` for the full description of each):

=================  ==========================================  ===============================
kind               required                                    optional
=================  ==========================================  ===============================
blocked_force      pressure, force                             trial, muscle
isotonic           pressure, load, length                      trial, muscle
hysteresis         pressure, load, length, direction           trial, muscle
                   (inflate/deflate)
braid_angle        braid_angle, length                         pressure, load, trial, muscle
force_length       pressure, length, force, direction          trial, muscle
                   (elongation/contraction)
isometric          held_length, pressure, force                direction (inflate/deflate; absent:
                                                               inflate), trial, tare, muscle,
                                                               rest_length, pressure_zero,
                                                               n_samples (muscle + rest_length:
                                                               a family)
step_response      time, pressure, command                     trial, muscle
=================  ==========================================  ===============================
"""

from __future__ import annotations

from dataclasses import dataclass

#: Numeric quantities: name -> (dimension, whether negative values are refused, description).
QUANTITIES: dict[str, tuple[str, bool, str]] = {
    "pressure": ("pressure", True, "gauge pressure"),
    "load": ("force", True, "hanging load (a force, or a mass taken times g)"),
    "length": ("length", True, "muscle length"),
    "held_length": ("length", True, "length the muscle is clamped at (isometric test)"),
    "force": ("force", False, "measured pulling force (a load cell may read slightly below zero)"),
    "tare": ("force", False, "load-cell reading to subtract from the force (its zero), per row"),
    "rest_length": ("length", True, "the muscle's rest length (a family table: several muscles of one type)"),
    "pressure_zero": ("pressure", False, "the pressure transducer's reading at atmosphere (its zero), per row"),
    "braid_angle": ("angle", True, "braid angle from the muscle axis"),
    "time": ("time", False, "time"),
    "command": ("dimensionless", False, "valve command, as a fraction of full scale"),
    "n_samples": ("dimensionless", True, "count of readings behind a binned point (a table binned from a stepped protocol)"),
}

#: Quantities that describe a muscle, not a row: a family table repeats them on each of its rows. [-]
PER_MUSCLE = ("rest_length",)
#: A sensor's own calibration columns (not listed among the measured quantities). [-]
SENSOR_COLUMNS = ("pressure_zero",)

#: Columns without a unit: name -> description.
BARE_COLUMNS: dict[str, str] = {
    "trial": "repetition number (whole number)",
    "direction": "branch of a loop (inflate/deflate or elongation/contraction)",
    "muscle": "muscle id; must match the muscle file's id",
}

INFLATE_DEFLATE = ("inflate", "deflate")
ELONGATION_CONTRACTION = ("elongation", "contraction")


@dataclass(frozen=True)
class Schema:
    """The columns of one experiment kind.

    Attributes
    ----------
    kind : str
        The kind's name, e.g. ``"isotonic"``.
    required : tuple of str
        Quantities (or bare columns) every table of this kind has.
    optional : tuple of str
        Quantities (or bare columns) it may have.
    directions : tuple of str
        The allowed values of the ``direction`` column (empty if it has none).
    description : str
        One line saying what the experiment is.
    defaults : tuple of (str, object, str)
        Optional columns a table without them is read with: the column, its value, and what
        reading it so means (the reader's note). A ``trial`` column is 1 for every kind without one.
    """

    kind: str
    required: tuple[str, ...]
    optional: tuple[str, ...]
    directions: tuple[str, ...] = ()
    description: str = ""
    defaults: tuple[tuple[str, object, str], ...] = ()

    @property
    def allowed(self) -> tuple[str, ...]:
        """Every column name (quantity or bare) this kind accepts."""
        return self.required + self.optional


SCHEMAS: dict[str, Schema] = {
    s.kind: s
    for s in [
        Schema("blocked_force", ("pressure", "force"), ("trial", "muscle"),
               description="blocked (isometric) force vs pressure, muscle held at its rest length (Fig. 3)"),
        Schema("isotonic", ("pressure", "load", "length"), ("trial", "muscle"),
               description="length under hanging loads vs pressure (Fig. 5, Fig. 10 via eq. 2)"),
        Schema("hysteresis", ("pressure", "load", "length", "direction"), ("trial", "muscle"), INFLATE_DEFLATE,
               description="length vs pressure while inflating and deflating under a load (Fig. 6)"),
        Schema("braid_angle", ("braid_angle", "length"), ("pressure", "load", "trial", "muscle"),
               description="braid angle from photographs with the length at that moment (Fig. 9, 10)"),
        Schema("force_length", ("pressure", "length", "force", "direction"), ("trial", "muscle"),
               ELONGATION_CONTRACTION,
               description="force-length loops at constant pressure (Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], Fig. 5)"),
        Schema("isometric", ("held_length", "pressure", "force"),
               ("direction", "trial", "tare", "muscle", "rest_length", "pressure_zero", "n_samples"),
               INFLATE_DEFLATE,
               description="force at held lengths while the pressure is stepped up (inflate) and back"
                           " down (deflate); one run per held length and trial (commercial muscles); a published"
                           " force map of one value per point has no direction: its rows are read as one branch",
               defaults=(("direction", "inflate", "one branch: a published force map of one value per point; the "
                                                  "direction-aware forms need both branches"),)),
        Schema("step_response", ("time", "pressure", "command"), ("trial", "muscle"),
               description="pressure after a step of the valve command (§IV.A)"),
    ]
}

KINDS = tuple(SCHEMAS)


def column_name(name: str) -> str:
    """How a quantity or bare column is written in a file: ``pressure_<unit>``, ``command``, ``trial``.

    Parameters
    ----------
    name : str
        A key of :data:`QUANTITIES` or :data:`BARE_COLUMNS`. [-]
    """
    return name if name in BARE_COLUMNS or QUANTITIES[name][0] == "dimensionless" else f"{name}_<unit>"


def known_columns() -> tuple[str, ...]:
    """Every column a table may have, as written in a file (the list messages give), from the schema.

    Returns
    -------
    tuple of str
        ``pressure_<unit>``, ..., ``rest_length_<unit>``, ``pressure_zero_<unit>``, ``command``,
        ``trial``, ``direction``, ``muscle``: every quantity of :data:`QUANTITIES`, then every
        bare column of :data:`BARE_COLUMNS`.
    """
    return tuple(column_name(q) for q in [*QUANTITIES, *BARE_COLUMNS])


def schema_markdown() -> str:
    """The two tables of ``docs/data.md`` (kinds, and quantities), generated from the schema.

    ``tests/test_docs.py`` checks that ``docs/data.md`` holds exactly this text, so the
    documentation cannot drift from :data:`SCHEMAS` and :data:`QUANTITIES`.

    Returns
    -------
    str
        Markdown.
    """
    lines = ["| kind | required | optional | what |", "| --- | --- | --- | --- |"]
    for s in SCHEMAS.values():
        dirs = f" (direction: {'/'.join(s.directions)})" if s.directions else ""
        filled = {q: value for q, value, _ in s.defaults}
        req = ", ".join(s.required) + (dirs if "direction" in s.required else "")
        opt = ", ".join(f"{q} ({'/'.join(s.directions) + '; ' if q == 'direction' else ''}absent: {filled[q]})"
                        if q in filled else q for q in s.optional)
        lines.append(f"| `{s.kind}` | {req} | {opt} | {s.description} |")
    lines += ["", "Quantities and the dimension of their unit:", "",
              "| column | dimension | negative values | meaning |", "| --- | --- | --- | --- |"]
    for q, (dim, no_neg, text) in QUANTITIES.items():
        col = column_name(q)
        lines.append(f"| `{col}` | {dim} | {'refused' if no_neg else 'allowed'} | {text} |")
    for q, text in BARE_COLUMNS.items():
        lines.append(f"| `{q}` | — | — | {text} |")
    return "\n".join(lines) + "\n"
