"""A lab's own muscle through the whole flow: fitted force laws saved in, and read from, muscle files.

``mckibben fit ISO.csv --model spring --muscle my.toml --save mine.toml`` writes the muscle file
again with a ``[force_model]`` table: the model's name, its parameters in SI (with standard
errors), the range of data it was fitted on and its flags. :func:`muscle_force_law` turns such a
file back into F(P, L) for ``mckibben predict force --muscle-file mine.toml``; evaluating outside
the fitted range is flagged.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mckibben.data.muscle_file import MuscleSpec, muscle_file_text_of
from mckibben.errors import InputError
from mckibben.fit.isometric import ALL_MODELS, force_law, model_name, parameter_names
from mckibben.models import laws
from mckibben.models.flags import Flag, outside
from mckibben.models.laws.spring import CONTRACTION, ELONGATION
from mckibben.atomic import atomic_file

def muscle_file_text(spec: MuscleSpec, fit, rest_length: float | None = None) -> str:
    """The TOML text of a muscle file holding a fitted force law.

    Parameters
    ----------
    spec : MuscleSpec
        The muscle file the fit used (its known geometry is kept as is).
    fit : IsometricFit
        From :func:`mckibben.fit.isometric.fit_isometric`.
    rest_length : float, optional
        A family law's file: the rest length of the muscle it describes (its nominal length),
        default the muscle file's; the valid lengths are the fitted ones relative to the rest
        length, scaled to it. Outside the rest lengths the family was fitted on, the file's
        ``flags`` say ``rest_length_out_of_range``. [m]
    """
    r = fit.result
    law = laws.LAWS.get(fit.model)
    valid = dict(r.valid_range)
    flags = list(r.flags)
    if rest_length is not None or (law is not None and law.family):
        if law is None or not law.family:
            raise InputError(f"rest_length: applies to a family law; {fit.model} describes the muscle it was fitted on")
        l0 = spec.nominal_length if rest_length is None else float(rest_length)
        if not (np.isfinite(l0) and l0 > 0):
            raise InputError(f"rest_length: {rest_length!r} must be a positive length")
        d = fit.data
        rest = d["rest_length"].to_numpy(dtype=float) if "rest_length" in d else np.full(len(d), spec.nominal_length)
        rel = d["held_length"].to_numpy(dtype=float) / rest
        valid["length"] = (float(rel.min()) * l0, float(rel.max()) * l0)
        spec = replace(spec, nominal_length=l0)
        if "rest_length" in valid and outside(l0, *valid["rest_length"], Flag.REST_LENGTH_OUT_OF_RANGE):
            flags.append("rest_length_out_of_range")  # the family law extrapolated to this muscle: said in the file
    note = f"Force law fitted by mckibben fit --model {fit.model} to {r.source}."
    fm = {"model": fit.model, "source": r.source, "tare": fit.tare.get("method", "none"), "flags": flags,
          "rmse_N": r.residual_rms, "r2": r.r2, "valid_range": valid,
          # each run's zero (tare "fitted") belongs to the table, not to the muscle: the law keeps the runs' mean
          "parameters": {n: float(v) for n, v in zip(r.names, r.values) if not n.startswith("zero_dev_")},
          "stderr": {n: float(s) for n, s in zip(r.names, r.stderr) if np.isfinite(s) and not n.startswith("zero_dev_")}}
    return muscle_file_text_of(spec, fm, note)


def save_muscle_file(path, spec: MuscleSpec, fit, rest_length: float | None = None) -> Path:
    """Write a muscle file with a fitted force law, atomically (nothing half-written).

    Parameters
    ----------
    path : str or pathlib.Path
        The TOML file to write. [-]
    spec : MuscleSpec
        The muscle file the fit used.
    fit : IsometricFit
        The fit.
    rest_length : float, optional
        A family law's file: the rest length of the muscle it describes. [m]

    Returns
    -------
    pathlib.Path
        The file written.
    """

    p = Path(path)
    if p.suffix.lower() != ".toml":
        raise InputError(f"save: {path} must end in .toml")
    text = muscle_file_text(spec, fit, rest_length)
    with atomic_file(p, "save") as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return p


@dataclass(frozen=True)
class MuscleForceLaw:
    """A muscle file's fitted force law, ready to evaluate.

    Attributes
    ----------
    spec : MuscleSpec
        The muscle.
    model : str
        The fitted model's name.
    parameters : dict
        Parameter name -> value. [SI]
    valid_range : dict
        ``pressure`` and ``length`` -> (min, max) of the data it was fitted on. [Pa, m]
    flags : tuple of str
        The fit's flags, as saved.
    """

    spec: MuscleSpec
    model: str
    parameters: dict
    valid_range: dict
    flags: tuple

    def force(self, pressure, length, direction="inflate"):
        """Force at pressures and lengths, flagged outside the fitted range.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        length : array_like
            Muscle length. [m]
        direction : str, default "inflate"
            ``"inflate"`` or ``"deflate"`` branch. [-]

        Returns
        -------
        force : numpy.ndarray
            [N]
        flags : numpy.ndarray
            :class:`~mckibben.models.flags.Flag` masks.
        """
        p, ell = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(length, dtype=float))
        f = np.broadcast_to(force_law(self.model, self.spec, list(self.parameters.values()))(p, ell, direction), p.shape)
        flags = np.zeros(p.shape, dtype=np.uint16)
        if "pressure" in self.valid_range:
            flags |= outside(p, *self.valid_range["pressure"], Flag.PRESSURE_OUT_OF_RANGE)
        if "length" in self.valid_range:
            flags |= outside(ell, *self.valid_range["length"], Flag.LENGTH_OUT_OF_RANGE)
        return np.asarray(f, dtype=float), flags


    def static_model(self, direction: str = "inflate"):
        """The fitted law as the static model object the plant's registry runs.

        :func:`mckibben.models.laws.law_of` turns the object into ``(name, θ)``, which is how a
        measured muscle drives the plant with its own force law. The load cell's zero
        (``offset_N``) is left out: it is the instrument's, not the muscle's.

        Parameters
        ----------
        direction : {"inflate", "deflate"}, default "inflate"
            The spring model's branch (its hysteresis); the other laws have one. [-]

        Returns
        -------
        The law's parameter object (:attr:`mckibben.models.laws.Law.from_values`, the one
        conversion of fitted values): BraidGeometry, TonduLopez, SpringModel or an added law's.

        Raises
        ------
        InputError
            For the data-driven ``surface``: it has no physical law to run.
        """
        law = laws.LAWS.get(self.model)
        if law is None or law.from_values is None:
            where = self.spec.path or self.spec.id
            raise InputError(f"{where}: the data-driven {self.model} force law has no physical law the plant can run;"
                             f" fit one of {', '.join(laws.fit_laws())}")
        return law.from_values(self.parameters, self.spec, direction, self.valid_range)

    def plant_law(self, direction: str = "inflate") -> tuple:
        """``(name, θ)`` of the plant's law registry (:func:`mckibben.models.laws.law_of`).

        Parameters
        ----------
        direction : {"inflate", "deflate"}, default "inflate"
            The spring model's branch. [-]
        """
        obj = self.static_model(direction)
        return laws.law_of(obj, law=self.model, direction=CONTRACTION if direction == "deflate" else ELONGATION)


def muscle_force_law(spec: MuscleSpec) -> MuscleForceLaw:
    """The fitted force law of a muscle file (its ``[force_model]`` table), checked.

    Parameters
    ----------
    spec : MuscleSpec
        A muscle file read by :func:`mckibben.data.muscle_file.read_muscle`.

    Raises
    ------
    InputError
        No ``[force_model]``, an unknown model, or parameters that are not the model's.
    """
    where = spec.path or spec.id
    fm = spec.force_model
    if fm is None:
        raise InputError(f"{where}: no [force_model] table; fit one (fit_table, then save_muscle_file; or the fit "
                         "command) and save it into the file")
    model = fm["model"]
    if model not in ALL_MODELS and model not in laws.ALIASES:
        raise InputError(f"{where}: key force_model.model: {model!r} is not one of {', '.join(ALL_MODELS)}")
    model = model_name(model)  # an old name (wall-chou-hannaford) is read as its registry name
    names = parameter_names(model, spec)
    params = fm["parameters"]
    optional = laws.LAWS[model].extra.get("optional_names", ()) if model in laws.LAWS else ()
    if tuple(params) != tuple(names) and (tuple(n for n in params if n not in optional)
                                          == tuple(n for n in names if n not in optional)):
        # a law's optional parameters: fitted (a family's end-fitting length), or absent from a law
        # saved before they were (Tondu–Lopez's threshold): the law reads what the file holds
        names = tuple(params)
    if tuple(params) != tuple(names):
        missing = [n for n in names if n not in params]
        extra = [n for n in params if n not in names]
        what = f"missing {', '.join(missing)}" if missing else f"unexpected {', '.join(extra)}" if extra else "out of order"
        raise InputError(f"{where}: key force_model.parameters: {what} for model {model} with this muscle's geometry"
                         f" (expected {', '.join(names)})")
    vr = {}
    for q, unit in (("pressure", "Pa"), ("length", "m")):
        v = fm.get(f"valid_{q}_{unit}")
        if v is not None:
            if not (isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v)):
                raise InputError(f"{where}: key force_model.valid_{q}_{unit}: must be [min, max]")
            vr[q] = (float(v[0]), float(v[1]))
    return MuscleForceLaw(spec, model, dict(params), vr, tuple(fm.get("flags", ())))


#: The branches of a fitted force law: the spring model has one per direction of travel (its
#: hysteresis); every other model has one, the same for both.
DIRECTIONS = ("inflate", "deflate")


def check_direction(direction: str, law: MuscleForceLaw | None = None) -> str:
    """The branch of a muscle file's law to run, checked (the ``direction`` argument of every muscle-file call).

    Parameters
    ----------
    direction : {"inflate", "deflate"}
        The branch: inflating (pressure rising) or deflating. [-]
    law : MuscleForceLaw, optional
        The file's law: only the spring model has a deflate branch of its own. [-]

    Returns
    -------
    str
        ``direction``.

    Raises
    ------
    InputError
        An unknown direction, or ``deflate`` for a law with one branch (asking for a branch the
        fit does not have would silently run the inflate one).
    """
    if direction not in DIRECTIONS:
        raise InputError(f"direction: {direction!r} must be inflate or deflate")
    if direction == "deflate" and law is not None and getattr(laws.LAWS.get(law.model), "branches", 1) < 2:
        raise InputError(f"`direction` deflate: the {law.model} force law of {law.spec.path or law.spec.id} has one "
                         "branch for both directions; only a spring fit has a deflate branch")
    return direction
