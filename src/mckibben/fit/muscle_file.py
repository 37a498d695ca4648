"""A lab's own muscle through the whole flow: fitted force laws saved in, and read from, muscle files.

``mckibben fit ISO.csv --model spring --muscle my.toml --save mine.toml`` writes the muscle file
again with a ``[force_model]`` table: the model's name, its parameters in SI (with standard
errors), the range of data it was fitted on and its flags; with ``--direction-aware``, the law's
hysteresis operator too (:func:`muscle_file_text`). :func:`muscle_force_law` turns such a
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
# the branches of a fitted force law (inflate, deflate): the spring model has one per direction of travel (its
# hysteresis); every other model has one, the same for both
from mckibben.models.hysteresis.direction import (DIRECTIONS, FRICTION_FORCE_NAME, FRICTION_NAME, PLAY_NAME,
                                                  STRUCTURES, branch_force)
from mckibben.fit.direction import DRIFT_NAME, DirectionAwareFit
from mckibben.models.laws.spring import CONTRACTION, ELONGATION
from mckibben.models.muscle import MUSCLE_TERMS, check_terms, law_values
from mckibben.models.threshold import THRESHOLD_NAME
from mckibben.models.tube import TUBE_NAME, tube_force
from mckibben.atomic import atomic_file

def muscle_file_text(spec: MuscleSpec, fit, rest_length: float | None = None) -> str:
    """The TOML text of a muscle file holding a fitted force law.

    Parameters
    ----------
    spec : MuscleSpec
        The muscle file the fit used (its known geometry is kept as is).
    fit : IsometricFit or DirectionAwareFit
        From :func:`mckibben.fit.isometric.fit_isometric`, or a one-branch law's direction-aware
        form (:func:`mckibben.fit.direction.fit_direction_aware`): its operator is written with the
        law, ``"play"`` as ``play_threshold_Pa`` r, ``"friction"`` as ``friction_area_m2`` A_f (far
        along a branch the friction form is law ± A_f·P whatever r, the isotonic friction's form,
        :func:`~mckibben.models.hysteresis.direction.branch_force`), with the operator's 95 %
        interval (``ci95_<name>``) and ``direction_aware`` the structure; the run drift (a nuisance
        of the test) is left out.
    rest_length : float, optional
        A family law's file: the rest length of the muscle it describes (its nominal length),
        default the muscle file's; the valid lengths are the fitted ones relative to the rest
        length, scaled to it. Outside the rest lengths the family was fitted on, the file's
        ``flags`` say ``rest_length_out_of_range``. [m]
    """
    r = fit.result
    if THRESHOLD_NAME in r.names:  # a term scored by compare (issue 33's offset test), not a muscle's law yet
        raise InputError(f"save: the {fit.model} fit carries a threshold pressure ({THRESHOLD_NAME}), which a muscle "
                         "file does not store; save the plain law's fit")
    law = laws.LAWS.get(fit.model)
    left_out = {DRIFT_NAME}  # the test's, not the muscle's
    operator: dict = {}
    if isinstance(fit, DirectionAwareFit):
        if law is not None and law.branches > 1:
            raise InputError(f"save: the {fit.model} law has an inflate and a deflate branch of its own; a muscle file "
                             "holds one operator on a one-branch law: save the plain fit, or a direction-aware fit of "
                             f"one of {', '.join(n for n, lw in laws.fit_laws().items() if lw.branches == 1)}")
        if fit.structure == "friction":
            left_out.add(PLAY_NAME)  # at a branch state the friction form does not depend on r
        terms = [n for n in STRUCTURES[fit.structure][0] if n not in left_out]
        operator = {"direction_aware": fit.structure,
                    **{f"ci95_{n}": [float(x) for x in r.ci95[r.names.index(n)]] for n in terms}}
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
    if operator:  # a flag of a term the file leaves out (the friction form's r) says nothing of the file's law
        flags = [fl for fl in flags if not fl.startswith(tuple(left_out))]
        note = (f"Force law fitted by mckibben fit --model {fit.model} --direction-aware ({fit.structure}) to "
                f"{r.source}.")

    def kept(n: str) -> bool:  # each run's zero (tare "fitted") belongs to the table, not to the muscle
        return not n.startswith("zero_dev_") and n not in left_out

    fm = {"model": fit.model, "source": r.source, "tare": fit.tare.get("method", "none"), "flags": flags,
          "rmse_N": r.residual_rms, "r2": r.r2, **operator, "valid_range": valid,
          "parameters": {n: float(v) for n, v in zip(r.names, r.values) if kept(n)},
          "stderr": {n: float(s) for n, s in zip(r.names, r.stderr) if np.isfinite(s) and kept(n)}}
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
        Parameter name -> value, with the terms of :data:`~mckibben.models.muscle.MUSCLE_TERMS` the
        file carries (the tube's stiffness, the friction area and force, a play's threshold). [SI]
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

    @property
    def has_operator(self) -> bool:
        """Whether the file's law carries a hysteresis operator (``friction_area_m2``, ``friction_force_N`` or
        ``play_threshold_Pa`` above 0): a ``branch`` of its loop to give. [-]"""
        return any(self.parameters.get(n, 0.0) for n in (FRICTION_NAME, FRICTION_FORCE_NAME, PLAY_NAME))

    def force(self, pressure, length, direction="inflate", branch: str | None = None):
        """Force at pressures and lengths, flagged outside the fitted range.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        length : array_like
            Muscle length. [m]
        direction : str, default "inflate"
            ``"inflate"`` or ``"deflate"`` branch of a two-branch law (the spring model's). [-]
        branch : {"inflate", "deflate"}, optional
            A file with an operator (:attr:`has_operator`): the force far along that branch of its
            loop, law ∓ (F_0 + A_f·P) or the law at the play's output P ∓ r
            (:func:`mckibben.models.hysteresis.direction.branch_force`); None: the law alone. [-]

        Returns
        -------
        force : numpy.ndarray
            [N]
        flags : numpy.ndarray
            :class:`~mckibben.models.flags.Flag` masks.
        """
        p, ell = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(length, dtype=float))
        if branch is not None and branch not in DIRECTIONS:
            raise InputError(f"branch: {branch!r} must be inflate or deflate (or left out: the law alone)")
        if branch is not None and not self.has_operator:
            raise InputError(f"branch: the {self.model} force law of {self.spec.path or self.spec.id} has no fitted "
                             f"friction or play ({FRICTION_NAME} or {PLAY_NAME}: a direction-aware fit saved to it, or a bench "
                             "characterization); leave the branch out for the law alone")

        def law_force(values, pp, el, direction="inflate"):
            f = force_law(self.model, self.spec, values)(pp, el, direction)
            if self.parameters.get(TUBE_NAME):  # the tube's pull past the rest length (models/tube.py)
                f = f + tube_force(el, self.spec.nominal_length, self.parameters[TUBE_NAME])
            return f

        prm = self.parameters
        f = np.broadcast_to(branch_force(law_force, list(law_values(prm).values()), prm.get(FRICTION_NAME, 0.0), p, ell,
                                         branch, friction_force=prm.get(FRICTION_FORCE_NAME, 0.0),
                                         play_threshold=prm.get(PLAY_NAME, 0.0), direction=direction), p.shape)
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
        return law.from_values(law_values(self.parameters), self.spec, direction, self.valid_range)

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
    params = law_values(fm["parameters"])  # the tube's and the friction's terms are any law's (optional)
    if model not in laws.LAWS and len(params) != len(fm["parameters"]):
        extra = ", ".join(n for n in fm["parameters"] if n in MUSCLE_TERMS)
        raise InputError(f"{where}: key force_model.parameters: {extra} is a term of a registered force law; the "
                         f"data-driven {model} model has none")
    check_terms(fm["parameters"], where)
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
    return MuscleForceLaw(spec, model, dict(fm["parameters"]), vr, tuple(fm.get("flags", ())))




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
