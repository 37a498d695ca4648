"""A muscle: geometry, force law, valid ranges and end stops, read from and written to a muscle file.

:class:`Muscle` is what the plant (:meth:`mckibben.plant.PlantParams.from_muscle_file`), the tool
(:func:`mckibben.tool.muscles.file_muscle`) and the statics (:class:`~mckibben.models.law_statics.LawMuscle`,
which it extends) take. It is built once from a muscle file's ``[force_model]`` table: the law
(a name of the registry, :mod:`mckibben.models.laws`, old names read) turns the saved values into
its parameter object (:attr:`~mckibben.models.laws.Law.from_values`, the one conversion) and θ.

End stops. The braid that bounds the muscle's length is an ideal braid (eq. 2 with k1 = 1,
k2 = 0) of strand length ``b``: the law's own when its parameters carry one (a fitted
Chou–Hannaford braid), else the file's ``strand_length_mm``, else ``L0/cos θ0`` with the law's
fitted braid angle (Tondu–Lopez), the file's ``braid_angle_deg`` or :data:`FILE_BRAID_ANGLE`.
The stops are the locking angle ``b/√3`` (the shortest, full contraction) and the straight braid
``b`` (the longest; below the rest length the muscle is slack under no load). A law whose pull
peaks and then falls as the muscle stretches (:attr:`~mckibben.models.laws.Law.peak_length`: the
wall-corrected braid, whose wall term −1/sin θ goes to −∞ at the straight braid) shortens that
braid to its peak when the peak lies beyond the rest length: the muscle's plant and FMU stop the
muscle there instead of running a negative stiffness no load can rest on (a peak below the rest
length is inside the data, and the plant refuses the law there by name).

References
----------
[mpam-characterization], eq. (1)–(2) (the braid); Chou & Hannaford (1996) (the locking angle).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mckibben.atomic import atomic_file
from mckibben.data.muscle_file import MuscleSpec, muscle_file_text_of, read_muscle
from mckibben.errors import InputError
from mckibben.models import laws
from mckibben.models.flags import Flag, outside
from mckibben.models.hysteresis.direction import FRICTION_FORCE_NAME, FRICTION_NAME, PLAY_NAME
from mckibben.models.law_statics import LawMuscle
from mckibben.models.tube import TUBE_NAME

__all__ = ["FILE_BRAID_ANGLE", "MUSCLE_TERMS", "Muscle", "check_terms", "law_values"]

#: The terms any law of a muscle file may carry beside its own parameters (in ``[force_model.parameters]``,
#: optional; a file without them has none): the tube's stiffness past the rest length
#: (:mod:`mckibben.models.tube`), the braid's friction, its area and its constant part
#: (:func:`~mckibben.models.hysteresis.direction.branch_force`; a file without the constant has none),
#: and the threshold of a play on the pressure feeding the law (a ``"play"`` direction-aware fit; one
#: operator: not with a friction). [-]
MUSCLE_TERMS = (TUBE_NAME, FRICTION_NAME, FRICTION_FORCE_NAME, PLAY_NAME)


def law_values(parameters: dict) -> dict:
    """A saved law's own parameters: a muscle file's ``[force_model.parameters]`` without :data:`MUSCLE_TERMS`. [SI]

    Parameters
    ----------
    parameters : dict
        Name -> value, as saved. [SI]
    """
    return {n: v for n, v in parameters.items() if n not in MUSCLE_TERMS}


def check_terms(parameters: dict, where: str) -> None:
    """Check a saved law's :data:`MUSCLE_TERMS`: each ≥ 0, and one hysteresis operator (a play or a friction).

    Parameters
    ----------
    parameters : dict
        Name -> value, as saved. [SI]
    where : str
        The file, for the message. [-]

    Raises
    ------
    InputError
        One line naming the file and the key.
    """
    for term in MUSCLE_TERMS:
        if parameters.get(term, 0.0) < 0:
            raise InputError(f"{where}: key force_model.parameters.{term}: {parameters[term]!r} must be >= 0")
    if parameters.get(PLAY_NAME, 0.0) and (parameters.get(FRICTION_NAME, 0.0) or parameters.get(FRICTION_FORCE_NAME, 0.0)):
        raise InputError(f"{where}: key force_model.parameters.{PLAY_NAME}: a play beside a friction ({FRICTION_NAME}, "
                         f"{FRICTION_FORCE_NAME}); a muscle's law has one hysteresis operator, keep one")

#: Rest braid angle assumed when neither the file nor its fitted law gives one: the project's
#: construction angle. It only shapes the chamber volume's change with length and the end stops;
#: the fitted law itself does not use it. [rad]
FILE_BRAID_ANGLE = float(np.deg2rad(20.0))


@dataclass(frozen=True, eq=False)
class Muscle(LawMuscle):
    """A muscle with its force law: geometry + law + valid ranges + end stops.

    Attributes (beyond :class:`~mckibben.models.law_statics.LawMuscle`'s)
    ----------------------------------------------------------------------
    values : dict
        The law's parameters by name, as saved in the muscle file (with the terms of
        :data:`MUSCLE_TERMS` it carries). [SI]
    params : object
        The law's parameter object (:attr:`mckibben.models.laws.Law.from_values`). [-]
    flags : tuple of str
        The fit's flags, as saved. [-]
    """

    values: dict = field(default_factory=dict)
    params: object = None
    flags: tuple = ()

    @property
    def spec(self) -> MuscleSpec:
        """The muscle file's content (geometry, notes, ``[force_model]``). [-]"""
        return self.source

    @property
    def end_stops(self) -> tuple[float, float]:
        """Shortest (locking angle, ``b/√3``) and longest (straight braid, ``b``) length. [m]"""
        return self.length_stops

    @classmethod
    def from_spec(cls, spec: MuscleSpec, direction: str = "inflate", rest_length: float | None = None) -> "Muscle":
        """The muscle of a read muscle file with a ``[force_model]`` table.

        Parameters
        ----------
        spec : MuscleSpec
            From :func:`mckibben.data.muscle_file.read_muscle`. [-]
        direction : {"inflate", "deflate"}, default "inflate"
            The branch of a two-branch law (the spring model's hysteresis). [-]
        rest_length : float, optional
            The muscle's rest length, replacing the file's nominal length: a family law's file
            (fitted across muscles of one type) predicts any muscle of the type from it; its
            valid lengths are scaled to it, and a rest length outside the family's adds the flag
            ``rest_length_out_of_range`` to :attr:`flags`. [m]

        Raises
        ------
        InputError
            No ``[force_model]``, an unknown law, a law with no physical form (the data-driven
            surface), missing parameters, a rest length that is not positive.
        """
        where = spec.path or spec.id
        if direction not in ("inflate", "deflate"):
            raise InputError(f"direction: {direction!r} must be inflate or deflate")
        saved_rest = float(spec.nominal_length)
        if rest_length is not None:
            if not (np.isfinite(rest_length) and rest_length > 0):
                raise InputError(f"rest_length: {rest_length!r} must be a positive length [m]")
            spec = dataclasses.replace(spec, nominal_length=float(rest_length))
        fm = spec.force_model
        if fm is None:
            raise InputError(f"{where}: no [force_model] table; fit one (mckibben.fit.fit_table, then "
                             "save_muscle_file; or the fit command) and save it into the file")
        name = fm["model"]
        law = laws.LAWS.get(laws.ALIASES.get(name, name))
        if law is None or law.from_values is None:
            raise InputError(f"{where}: the data-driven {name} force law has no physical law the plant can run; "
                             f"fit one of {', '.join(laws.fit_laws())}")
        valid = {q: tuple(float(x) for x in fm[f"valid_{q}_{u}"]) for q, u in
                 (("pressure", "Pa"), ("length", "m"), ("rest_length", "m")) if f"valid_{q}_{u}" in fm}
        fit_flags = tuple(fm.get("flags", ()))
        if rest_length is not None and law.family:
            # a family law's valid lengths are relative to the rest length: scaled to this muscle's
            if "length" in valid:
                valid["length"] = tuple(x * float(rest_length) / saved_rest for x in valid["length"])
            lo, hi = valid.get("rest_length", (-np.inf, np.inf))
            if outside(rest_length, lo, hi, Flag.REST_LENGTH_OUT_OF_RANGE) and "rest_length_out_of_range" not in fit_flags:
                fit_flags += ("rest_length_out_of_range",)  # extrapolated beyond the family's rest lengths
        check_terms(fm["parameters"], where)
        try:
            params = law.from_values(law_values(fm["parameters"]), spec, direction, valid)
        except KeyError as exc:
            raise InputError(f"{where}: key force_model.parameters: missing {exc.args[0]} for model {law.name}") from None
        kind, theta = laws.law_of(params, law=law.name, direction="contraction" if direction == "deflate" else "elongation")
        l0 = float(spec.nominal_length)
        b = getattr(params, "strand_length", None)
        if b is None:
            b = spec.strand_length
        if b is None:
            th0 = getattr(params, "initial_angle", None)
            th0 = th0 if th0 is not None else spec.braid_angle
            b = l0 / math.cos(FILE_BRAID_ANGLE if th0 is None else float(th0))
        peak = law.peak_length(theta) if law.peak_length is not None else math.inf
        if l0 < peak < b:  # the law's pull falls beyond its peak (the wall-corrected braid): the braid ends there
            b = peak
        od = spec.need("outer_diameter", f"the muscle of its {law.name} force law (its chamber)")
        stops = (float(b) / math.sqrt(3.0), float(b))
        return cls(name=spec.id, nominal_length=l0, law=kind, theta=np.asarray(theta, dtype=float),
                   strand_length=float(b), pressure_range=valid.get("pressure", (0.0, np.inf)),
                   length_range=valid.get("length", stops), outer_diameter=float(od), direction=direction,
                   source=spec, citation=f"{law.name} force law fitted to {fm.get('source', 'data')} ({where})",
                   values=dict(fm["parameters"]), params=params, flags=fit_flags,
                   tube_stiffness=float(fm["parameters"].get(TUBE_NAME, 0.0)),
                   friction_area=float(fm["parameters"].get(FRICTION_NAME, 0.0)),
                   friction_force=float(fm["parameters"].get(FRICTION_FORCE_NAME, 0.0)),
                   play_threshold=float(fm["parameters"].get(PLAY_NAME, 0.0)))

    @classmethod
    def from_muscle_file(cls, path, direction: str = "inflate", rest_length: float | None = None) -> "Muscle":
        """Read a muscle file with a ``[force_model]`` table (see :meth:`from_spec`).

        Parameters
        ----------
        path : str or pathlib.Path
            The TOML file. [-]
        direction : {"inflate", "deflate"}, default "inflate"
            The branch of a two-branch law. [-]
        rest_length : float, optional
            The muscle's rest length (a family law's file). [m]
        """
        return cls.from_spec(read_muscle(path), direction, rest_length)

    def to_muscle_file_text(self) -> str:
        """The muscle file's TOML text: geometry (nominal length = this muscle's rest length) and the law."""
        fm = {k: v for k, v in self.spec.force_model.items() if k not in ("parameters",) and not k.startswith("valid_")}
        fm["model"] = self.law if self.law in laws.LAWS else fm["model"]
        fm["parameters"] = dict(self.values)
        fm["valid_range"] = {q: v for q, v in (("pressure", self.pressure_range), ("length", self.length_range))
                             if np.all(np.isfinite(v))}
        rest = self.spec.force_model.get("valid_rest_length_m")
        if rest is not None:
            fm["valid_range"]["rest_length"] = tuple(rest)
        spec = dataclasses.replace(self.spec, nominal_length=self.nominal_length, notes=self.spec.notes)
        return muscle_file_text_of(spec, fm)

    def save(self, path) -> Path:
        """Write the muscle file, atomically (nothing half-written).

        Parameters
        ----------
        path : str or pathlib.Path
            A ``.toml`` file. [-]
        """
        p = Path(path)
        if p.suffix.lower() != ".toml":
            raise InputError(f"path: {path} must end in .toml")
        text = self.to_muscle_file_text()
        with atomic_file(p, "path") as tmp:
            Path(tmp).write_text(text, encoding="utf-8")
        return p
